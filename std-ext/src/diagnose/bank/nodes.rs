//! `shaft_bow` and `extra_unbalance_plane`: an effect at one node (a bow
//! offset at an interior node; unbalance at a node that is not a plane),
//! the nodes ranked by the drop in misfit one Gauss-Newton step predicts
//! ([`screen`]), the best two fitted; and the same search again on top of
//! another effect's fit for the pairs (`rescreen`).

use crate::diagnose::bank::{screen, screen_groups};
use crate::diagnose::candidate::Candidate;
use crate::diagnose::context::Context;
use crate::diagnose::effect::Effect;
use crate::diagnose::extended::{ExtendedModel, Extension};
use crate::diagnose::fit::{self, Fit, FitData};
use crate::diagnose::input::DiagnoseError;
use crate::diagnose::stats::{bic, chi2_quantile_upper};
use crate::fe::assembly::{Dir, FeModel};
use crate::model::{BowPoint, RotorModel, ShaftBow};

/// The best fit of `effect` (`ShaftBow` or `ExtraUnbalancePlane`) at one
/// node: the two nodes `screen` ranks first, each fitted from the nominal
/// estimate with the effect at zero. A bow has two shapes where the
/// bearings are not just the shaft's two ends: offset from the line
/// through the shaft's ends, and from the bearing line (zero at every
/// bearing, [`crate::fe::assembly::FeModel::line_bow_shape`]); the two
/// best nodes of each are fitted and the better fit (same parameter count)
/// kept. For an extra unbalance, then the variant of one shared equally
/// by a run of nodes ([`spread_variant`]), kept when it fits better than
/// the plane by more than the chi-square tie (2 degrees of freedom at
/// 1 %, the plane's own noise variance: as many parameters, but chosen
/// among many runs). Then the effect at two nodes ([`two_nodes`]: a bow
/// of two knots, two extra planes), kept when its BIC is lower. `None`
/// when none fits.
pub(crate) fn node_effect(
    ctx: &Context<'_>,
    effect: Effect,
) -> Result<Option<Candidate>, DiagnoseError> {
    let model = ctx.model;
    let n_nodes = model.n_nodes();
    let families: Vec<Vec<Extension>> = match effect {
        Effect::ShaftBow => {
            let mut f = vec![(1..n_nodes.saturating_sub(1))
                .map(|node| Extension::Bow { node, line: false })
                .collect::<Vec<_>>()];
            if ctx.terms.first().is_some_and(|t| t.g_line.is_some()) {
                let bearings = model.bearing_nodes();
                f.push(
                    (0..n_nodes)
                        .filter(|n| !bearings.contains(n))
                        .map(|node| Extension::Bow { node, line: true })
                        .collect(),
                );
            }
            f
        }
        _ => vec![(0..n_nodes)
            .filter(|n| !model.planes.contains(n))
            .map(|node| Extension::Plane { node })
            .collect()],
    };
    let mut best: Option<(Fit, ExtendedModel, Extension)> = None;
    // The best one-knot fit of each family, where the second knot of a
    // bow is screened from.
    let mut family_best: Vec<Option<(Fit, Extension)>> = vec![None; families.len()];
    for (exts, fb) in families.iter().zip(family_best.iter_mut()) {
        let ranked = screen(ctx.base, ctx.data, &ctx.theta0, exts)?;
        for &i in ranked.iter().take(2) {
            let m = ctx.with_ext(vec![exts[i]]);
            if !ctx.n_room(m.n_params()) {
                continue;
            }
            let t = ctx.start_with(&m, &[]);
            if let Ok(f) = fit::fit(&m, ctx.data, &t, 50) {
                if fb.as_ref().is_none_or(|b| f.s < b.0.s) {
                    *fb = Some((f.clone(), exts[i]));
                }
                if best.as_ref().is_none_or(|b| f.s < b.0.s) {
                    best = Some((f, m, exts[i]));
                }
            }
        }
    }
    let Some((f, m, ext)) = best else {
        return Ok(None);
    };
    let mut alternatives: usize = families.iter().map(Vec::len).sum();
    let mut chosen = (f, m, node_label(ext));
    if effect == Effect::ExtraUnbalancePlane {
        // The variant of an unbalance spread along a section: kept when
        // it fits better than the plane by more than a tie.
        if let Some((run, weighed)) = spread_variant(ctx, &chosen.0) {
            alternatives += weighed;
            let tie = chi2_quantile_upper(2.0, 0.01) * chosen.0.sigma2();
            if run.0.s < chosen.0.s - tie {
                chosen = run;
            }
        }
    }
    let (pair, tried) = two_nodes(ctx, &families, &family_best)?;
    alternatives += tried;
    if let Some(p) = pair {
        let n = ctx.setup.n_real;
        if bic(&p.0, n) < bic(&chosen.0, n) {
            chosen = p;
        }
    }
    let (f, m, label) = chosen;
    let coupling = match m.ext.as_slice() {
        [a, b] => knot_coupling(model, *a, *b),
        _ => None,
    };
    let mut c = Candidate::new(vec![effect], label, m, f, 1.0, alternatives);
    c.bow_coupling = coupling;
    Ok(Some(c))
}

/// The runs of nodes of the spread variant fitted per round (the best
/// ones of the linearised screen, [`super::plane_spread::best_runs`]).
const SPREAD_FITTED: usize = 1;

/// Rounds of the spread variant's screen: the first about the plane's
/// fit, the next about the best run's.
const SPREAD_ROUNDS: usize = 2;

/// The best fit of an extra unbalance shared equally by a run of two or
/// more consecutive nodes ([`Extension::Spread`]): the [`SPREAD_FITTED`]
/// runs that fit best linearised about the plane's fit `plane` (its
/// nominal parameters), each fitted from there; then, for
/// [`SPREAD_ROUNDS`] rounds in all, those linearised about the best run's
/// fit (the plane's fit absorbs a spread unbalance in its bearings, which
/// can rank another run first). With the number of runs weighed (the
/// alternatives of the search); `None` when none fits.
fn spread_variant(ctx: &Context<'_>, plane: &Fit) -> Option<(LabelledFit, usize)> {
    let nom = ctx.base.n_params();
    let mut best: Option<LabelledFit> = None;
    let mut tried: Vec<Extension> = Vec::new();
    let mut about = plane.theta.get(..nom)?.to_vec();
    let mut weighed = 0;
    for _ in 0..SPREAD_ROUNDS {
        let (runs, n_runs) =
            super::plane_spread::best_runs(ctx, &about, SPREAD_FITTED + tried.len())?;
        weighed = n_runs;
        let fresh: Vec<super::plane_spread::RunStart> = runs
            .into_iter()
            .filter(|r| !tried.contains(&r.0))
            .take(SPREAD_FITTED)
            .collect();
        for (ext, p) in fresh {
            tried.push(ext);
            let m = ctx.with_ext(vec![ext]);
            if !ctx.n_room(m.n_params()) {
                continue;
            }
            let mut t = about.clone();
            t.extend_from_slice(&p);
            if let Ok(f) = fit::fit(&m, ctx.data, &t, 50) {
                if best.as_ref().is_none_or(|b| f.s < b.0.s) {
                    best = Some((f, m, node_label(ext)));
                }
            }
        }
        match &best {
            Some(b) => about = b.0.theta.get(..nom)?.to_vec(),
            None => break,
        }
    }
    best.map(|b| (b, weighed))
}

/// `[s_b(a), s_a(b)]` of [`Candidate::bow_coupling`] for the one-knot bow
/// shapes `a` and `b` (of one family): the `y` offset of each unit shape
/// ([`FeModel::bow_shape`], [`FeModel::line_bow_shape`]) at the other's
/// knot. `None` for other extensions.
fn knot_coupling(model: &RotorModel, a: Extension, b: Extension) -> Option<[f64; 2]> {
    let fe = FeModel::new(model).ok()?;
    let bearings = model.bearing_nodes();
    let shape = |e: Extension| match e {
        Extension::Bow { node, line: false } => fe
            .bow_shape(&ShaftBow {
                points: vec![BowPoint {
                    node,
                    amplitude: 1.0,
                    phase: 0.0,
                }],
            })
            .ok(),
        Extension::Bow { node, line: true } => fe.line_bow_shape(node, &bearings).ok(),
        _ => None,
    };
    let (Extension::Bow { node: na, .. }, Extension::Bow { node: nb, .. }) = (a, b) else {
        return None;
    };
    let (sa, sb) = (shape(a)?, shape(b)?);
    Some([sb[fe.dof(na, Dir::Y)].re, sa[fe.dof(nb, Dir::Y)].re])
}

/// A fit with its model and label.
type LabelledFit = (Fit, ExtendedModel, String);

/// The two nodes of a bow of two knots or of two extra planes at least
/// this many nodes apart: the responses to adjacent nodes are nearly
/// collinear, and a fit on them trades large sizes of opposite sign.
const MIN_KNOT_GAP: usize = 2;

/// Rounds of [`two_nodes`]'s exchange of one node.
const KNOT_ROUNDS: usize = 2;

/// The effect at two nodes: the bow of two knots, or two extra planes
/// (two unbalances, or one spread along a section). For each family of
/// one-node extensions, pairs of its nodes ([`MIN_KNOT_GAP`] apart or more) added
/// together: two planes are two unbalances; for the bow, the sum of the
/// two one-knot splines spans the natural spline through both knots
/// exactly, so the pair is the bow offset at two nodes.
///
/// Per family, three pairs are fitted: the pair [`screen_groups`] ranks
/// first from the nominal estimate, and the family's best one-node fit
/// `a` (`family_best`) with each of the two second nodes [`screen`] ranks
/// first on top of that fit (started from it). The best of them then has
/// each node in turn exchanged for the one `screen` ranks first with the
/// other node's fit held ([`KNOT_ROUNDS`] rounds, while the fit improves).
/// The best fit with its model and label, and the number of pairs there
/// are (the alternatives of the test).
fn two_nodes(
    ctx: &Context<'_>,
    families: &[Vec<Extension>],
    family_best: &[Option<(Fit, Extension)>],
) -> Result<(Option<LabelledFit>, usize), DiagnoseError> {
    let mut best: Option<(Fit, [Extension; 2])> = None;
    let mut tried = 0;
    let nom = ctx.base.n_params();
    let apart = |a: Extension, b: Extension| node_of(a).abs_diff(node_of(b)) >= MIN_KNOT_GAP;
    for (exts, fb) in families.iter().zip(family_best) {
        let pairs: Vec<Vec<usize>> = (0..exts.len())
            .flat_map(|a| (a + 1..exts.len()).map(move |b| vec![a, b]))
            .filter(|p| apart(exts[p[0]], exts[p[1]]))
            .collect();
        tried += pairs.len();
        // (one knot, its parameters' start, the other knot; the start of
        // the nominal parameters).
        let mut starts: Vec<(Extension, [f64; 2], Extension, Vec<f64>)> = Vec::new();
        let ranked = screen_groups(ctx.base, ctx.data, &ctx.theta0, exts, &pairs)?;
        if let Some(&i) = ranked.first() {
            let (a, b) = (exts[pairs[i][0]], exts[pairs[i][1]]);
            starts.push((a, [0.0; 2], b, ctx.theta0.clone()));
        }
        if let Some((fa, a)) = fb {
            for b in second_knots(ctx, exts, *a, &fa.theta, 2)? {
                starts.push((
                    *a,
                    [fa.theta[nom], fa.theta[nom + 1]],
                    b,
                    fa.theta[..nom].to_vec(),
                ));
            }
        }
        let mut family: Option<(Fit, [Extension; 2])> = None;
        for (a, pa, b, theta_nom) in starts {
            if let Some(f) = fit_pair(ctx, a, pa, b, &theta_nom) {
                if family.as_ref().is_none_or(|x| f.0.s < x.0.s) {
                    family = Some(f);
                }
            }
        }
        // Exchange one knot at a time, the other's fit held.
        for _ in 0..KNOT_ROUNDS {
            let before = family.as_ref().map(|x| x.0.s);
            for keep in 0..2 {
                let Some((f, pair)) = family.clone() else {
                    break;
                };
                let held = pair[keep];
                let o = nom + 2 * keep;
                let mut t_held = f.theta[..nom].to_vec();
                t_held.extend_from_slice(&f.theta[o..o + 2]);
                let Some(b) = second_knots(ctx, exts, held, &t_held, 1)?
                    .into_iter()
                    .find(|b| *b != pair[1 - keep])
                else {
                    continue;
                };
                let held_start = [f.theta[o], f.theta[o + 1]];
                if let Some(g) = fit_pair(ctx, held, held_start, b, &f.theta[..nom]) {
                    if g.0.s < f.s {
                        family = Some(g);
                    }
                }
            }
            if family.as_ref().map(|x| x.0.s) == before {
                break;
            }
        }
        if let Some(f) = family {
            if best.as_ref().is_none_or(|b| f.0.s < b.0.s) {
                best = Some(f);
            }
        }
    }
    Ok((
        best.map(|(f, pair)| {
            (
                f,
                ctx.with_ext(pair.to_vec()),
                two_knot_label(pair[0], pair[1]),
            )
        }),
        tried,
    ))
}

/// The `n` second knots of `exts` (at least [`MIN_KNOT_GAP`] from `a`)
/// that [`screen`] ranks first on top of the one-knot bow `a` at the
/// estimate `theta` (nominal parameters, then `a`'s two).
fn second_knots(
    ctx: &Context<'_>,
    exts: &[Extension],
    a: Extension,
    theta: &[f64],
    n: usize,
) -> Result<Vec<Extension>, DiagnoseError> {
    let others: Vec<Extension> = exts
        .iter()
        .copied()
        .filter(|&e| node_of(e).abs_diff(node_of(a)) >= MIN_KNOT_GAP)
        .collect();
    let on_a = ctx.with_ext(vec![a]);
    let ranked = screen(&on_a, ctx.data, theta, &others)?;
    Ok(ranked.into_iter().take(n).map(|i| others[i]).collect())
}

/// The fit of the bow with knots `a` and `b` from the nominal parameters
/// `theta_nom`, `a`'s at `pa` and `b`'s at zero; the knots in node order.
fn fit_pair(
    ctx: &Context<'_>,
    a: Extension,
    pa: [f64; 2],
    b: Extension,
    theta_nom: &[f64],
) -> Option<(Fit, [Extension; 2])> {
    let (pair, t_ext) = if node_of(a) < node_of(b) {
        ([a, b], [pa[0], pa[1], 0.0, 0.0])
    } else {
        ([b, a], [0.0, 0.0, pa[0], pa[1]])
    };
    let m = ctx.with_ext(pair.to_vec());
    if !ctx.n_room(m.n_params()) {
        return None;
    }
    let mut t = theta_nom.get(..ctx.base.n_params())?.to_vec();
    t.extend_from_slice(&t_ext);
    fit::fit(&m, ctx.data, &t, 50).ok().map(|f| (f, pair))
}

/// The node of a node extension (0 for others).
fn node_of(e: Extension) -> usize {
    match e {
        Extension::Bow { node, .. } | Extension::Plane { node } => node,
        _ => 0,
    }
}

/// The label of a node effect.
fn node_label(ext: Extension) -> String {
    match ext {
        Extension::Bow { node, line: false } => {
            format!("bow with its offset at node {}", node + 1)
        }
        Extension::Bow { node, line: true } => {
            format!("bow from the bearing line, offset at node {}", node + 1)
        }
        Extension::Plane { node } => format!("extra unbalance plane at node {}", node + 1),
        Extension::Spread { first, last } => format!(
            "extra unbalance shared by nodes {} to {}",
            first + 1,
            last + 1
        ),
        other => format!("{other:?}"),
    }
}

/// The label of a bow of two knots or of two extra planes.
fn two_knot_label(a: Extension, b: Extension) -> String {
    match (a, b) {
        (Extension::Bow { node: na, line }, Extension::Bow { node: nb, .. }) => format!(
            "bow {}with offsets at nodes {} and {}",
            if line { "from the bearing line " } else { "" },
            na + 1,
            nb + 1
        ),
        (Extension::Plane { node: na }, Extension::Plane { node: nb }) => {
            format!("extra unbalance planes at nodes {} and {}", na + 1, nb + 1)
        }
        _ => format!("{a:?}, {b:?}"),
    }
}

/// `b` (a node-searched effect) with its node searched again on top of
/// `a`'s fit: the two best nodes, each as a candidate whose effect
/// parameters start at zero (planes, for an unbalance shared by a run of
/// nodes).
pub(crate) fn rescreen(
    model: &RotorModel,
    data: &FitData<'_>,
    a: &Candidate,
    b: &Candidate,
) -> Result<Vec<Candidate>, DiagnoseError> {
    let n_nodes = model.n_nodes();
    let exts: Vec<Extension> = match b.model.ext.as_slice() {
        [Extension::Plane { .. }] | [Extension::Spread { .. }] => (0..n_nodes)
            .filter(|n| !model.planes.contains(n))
            .map(|node| Extension::Plane { node })
            .collect(),
        [Extension::Bow { line: false, .. }] => (1..n_nodes.saturating_sub(1))
            .map(|node| Extension::Bow { node, line: false })
            .collect(),
        [Extension::Bow { line: true, .. }] => {
            let bearings = model.bearing_nodes();
            (0..n_nodes)
                .filter(|n| !bearings.contains(n))
                .map(|node| Extension::Bow { node, line: true })
                .collect()
        }
        _ => return Ok(Vec::new()),
    };
    let ranked: Vec<Extension> = match screen(&a.model, data, &a.fit.theta, &exts) {
        Ok(r) => r.into_iter().map(|i| exts[i]).collect(),
        Err(_) => return Ok(Vec::new()),
    };
    let nom = b.model.pr.n_params();
    Ok(ranked
        .into_iter()
        .take(2)
        .filter(|e| b.model.ext != [*e])
        .map(|e| {
            let mut c = b.clone();
            c.model.ext = vec![e];
            c.fit.theta.truncate(nom);
            c.fit.theta.extend([0.0, 0.0]);
            c.label = node_label(e);
            c
        })
        .collect())
}
