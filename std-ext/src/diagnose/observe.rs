//! Observability: how large an effect must be for these sensors and speeds
//! to see it, and which effects the data cannot tell apart.
//!
//! # Smallest detectable size
//!
//! At the reference estimate ([`reference()`]: the nominal parameters of the
//! chosen model), with `J = [J_n, J_e]` the weighted Jacobian of
//! the nominal and the effect's parameters (effect at zero) and `sigma^2`
//! the noise variance of one real reading, an effect `phi` (scaled) raises
//! the expected likelihood-ratio statistic of its hypothesis by the
//! non-centrality
//!
//! ```text
//!     lambda = phi^T S phi / sigma^2,   S = J_e^T J_e - J_e^T J_n (J_n^T J_n)^-1 J_n^T J_e
//! ```
//!
//! (the information left once the nominal parameters are refitted: an
//! effect the nominal model can mimic has a small `S`). The effect is
//! detected, in the worst phase, when `lambda` reaches the hypothesis'
//! threshold `t`: `|phi|_min = sqrt(t sigma^2 / mu_min(S))`. This is
//! computed for the effects that vanish at zero parameters (bow and extra
//! plane at every node, runout on every channel, a gain on every probe
//! channel) and for the shaft modulus factor (one parameter, its threshold
//! the chi-square quantile of one degree of freedom, as for a gain; `dA/de`
//! from the terms at `e = 0.95` and `1.05`).
//!
//! The speed law and the pedestal are linearised the same way
//! ([`speed_law_min_detectable`], [`pedestal_min_detectable`]), one
//! parameter at a time:
//!
//! - **speed law**: each coefficient of a bearing law one order higher
//!   (`K_P Omega^P`, `C_P Omega^P`, zero at the nominal estimate), its
//!   threshold that of the whole hypothesis (`8 N_b` parameters); the size
//!   is the change it makes to its coefficient at the top speed, relative
//!   to the direct coefficient of the same row;
//! - **pedestal**: a pedestal under each bearing with its natural
//!   frequency on a grid ([`PEDESTAL_GRID`] x the top speed) and damping
//!   ratio [`PEDESTAL_ZETA`], its size the compliance `1 / k_p` (a rigid
//!   support is compliance 0, where the effect vanishes linearly),
//!   reported as `k_B / k_p`; threshold of 5 parameters.
//!
//! Both are checked against a refit: the effect of the computed size put
//! into noise-free data leaves the refitted nominal model `S = t sigma^2`
//! within 5 % (module tests).
//!
//! # Effects the data cannot tell apart
//!
//! Two significant hypotheses whose misfits differ by less than the
//! chi-square quantile of 2 degrees of freedom at 1 % (`tied`) explain
//! the data equally well: the data do not tell them apart, and the report
//! says which measurement would.

use serde::Serialize;

use crate::diagnose::extended::{ExtendedModel, Extension, GAIN_STEP};
use crate::diagnose::fit::{self, FitData};
use crate::diagnose::result::output_name;
use crate::diagnose::{chi2_quantile_upper, Candidate, Diagnosis, Effect};
use crate::fe::assembly::{Dir, FeModel};
use crate::model::{BowPoint, RotorModel, ShaftBow};
use crate::units::rad_s_to_rpm;
use nalgebra::{DMatrix, DVector};

/// What the data can show of one effect.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Observability {
    /// The effect.
    pub effect: Effect,
    /// Smallest detectable size at the best location (unit in `unit`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub min_size: Option<f64>,
    /// Where `min_size` holds (node or channel).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub best_at: Option<String>,
    /// Smallest detectable size at the worst location.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub min_size_worst: Option<f64>,
    /// Where `min_size_worst` holds.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub worst_at: Option<String>,
    /// Unit of the sizes.
    pub unit: &'static str,
    /// Effects that explain the data equally well.
    pub indistinguishable_from: Vec<Effect>,
    /// One line for the report.
    pub note: String,
}

/// Smallest detectable size (physical units) of `make(k)` for each `k` in
/// `locations`, at `theta0` of `base` with threshold `t` (see the module
/// documentation). `scale` turns a scaled amplitude into physical units.
pub fn min_detectable(
    base: &ExtendedModel,
    data: &FitData<'_>,
    theta0: &[f64],
    sigma2: f64,
    t: f64,
    exts: &[Extension],
    scale: f64,
) -> Option<Vec<f64>> {
    let all = ExtendedModel {
        ext: exts.to_vec(),
        ..base.clone()
    };
    let mut theta = theta0.to_vec();
    theta.resize(all.n_params(), 0.0);
    let en = fit::entries(&all, data);
    let (_, jac) = fit::evaluate(&all, data, &en, &theta, true).ok()?;
    let j = jac?;
    let g = crate::diagnose::fit::gram(&j);
    let p0 = base.n_params();
    let gnn = g.view((0, 0), (p0, p0)).into_owned();
    let ch = gnn.cholesky()?;
    let nq = base.n_channels();
    let mut out = Vec::new();
    for (k, e) in exts.iter().enumerate() {
        let o = all.offset(k);
        let groups: Vec<usize> = match e {
            Extension::Runout => (0..nq).map(|c| o + 2 * c).collect(),
            _ => vec![o],
        };
        let w = match e {
            Extension::Runout => 2,
            _ => e.n_params(nq),
        };
        for o2 in groups {
            let s = schur_block(&g, &ch, o2, w);
            let mu = s.symmetric_eigenvalues().min();
            let size = if mu > 0.0 {
                scale * (t * sigma2 / mu).sqrt()
            } else {
                f64::INFINITY
            };
            out.push(size);
        }
    }
    Some(out)
}

/// The information left in the `w` parameters from `o` of the Gram
/// matrix `g = J^T J` once its first `p0` (the nominal ones, `ch` the
/// Cholesky factor of their block) are refitted: the Schur complement
/// `G_ee - G_ne^T G_nn^-1 G_ne`.
fn schur_block(
    g: &DMatrix<f64>,
    ch: &nalgebra::Cholesky<f64, nalgebra::Dyn>,
    o: usize,
    w: usize,
) -> DMatrix<f64> {
    let p0 = ch.l_dirty().nrows();
    let gne = g.view((0, o), (p0, w)).into_owned();
    let gee = g.view((o, o), (w, w)).into_owned();
    gee - gne.transpose() * ch.solve(&gne)
}

fn where_min(
    v: &[f64],
    names: &[String],
) -> (Option<f64>, Option<String>, Option<f64>, Option<String>) {
    let mut best: Option<(f64, usize)> = None;
    let mut worst: Option<(f64, usize)> = None;
    for (i, &x) in v.iter().enumerate() {
        if best.is_none_or(|b| x < b.0) {
            best = Some((x, i));
        }
        if worst.is_none_or(|w| x > w.0) {
            worst = Some((x, i));
        }
    }
    (
        best.map(|b| b.0),
        best.and_then(|b| names.get(b.1).cloned()),
        worst.map(|w| w.0),
        worst.and_then(|w| names.get(w.1).cloned()),
    )
}

/// The statistic a `k`-parameter effect must reach: the chi-square quantile
/// at the choice's false-alarm rate split over the alternatives tried.
fn detection_threshold(d: &Diagnosis, k: f64) -> f64 {
    let alternatives: usize = d
        .hypotheses
        .iter()
        .filter(|c| c.effects.len() == 1)
        .map(|c| c.alternatives)
        .sum::<usize>()
        .max(1);
    chi2_quantile_upper(k, d.false_alarm / alternatives as f64)
}

/// What would tell `a` from `b`.
pub fn suggestion(a: Effect, b: Effect) -> &'static str {
    use Effect::*;
    let (x, y) = if a <= b { (a, b) } else { (b, a) };
    match (x, y) {
        (ShaftBow, ExtraUnbalancePlane) => {
            "a slow-roll reading (well below the first critical speed) or a probe near mid-span: a bow shows at low speed, an unbalance grows with speed squared"
        }
        (ShaftBow, ProbeRunout) | (ProbeRunout, ExtraUnbalancePlane) => {
            "a slow-roll reading on every probe: runout is the same at every speed"
        }
        (SpeedDependentBearing, FoundationFlexibility) => {
            "a seismic (absolute) sensor on the bearing housing: a moving pedestal shows there"
        }
        (SpeedDependentBearing, ShaftStiffnessError) | (FoundationFlexibility, ShaftStiffnessError) => {
            "a probe at mid-span, or a speed range through the shaft's bending critical"
        }
        (_, ProbeSensitivity) => {
            "a static calibration of the probes (gap voltage against a micrometer on the target), or a second probe beside the suspect one"
        }
        _ => "more speeds near the critical speeds, or a probe at another node",
    }
}

/// The observability of every hypothesis of `d` (see the module docs).
///
/// `data_de`: the same data with the nominal terms carrying `dA/de` at
/// `e = 1`, for the shaft modulus (without it the modulus gets a note only).
pub fn analyse(
    d: &Diagnosis,
    data: &FitData<'_>,
    data_de: Option<&FitData<'_>>,
) -> Vec<Observability> {
    let nominal = reference(d);
    let base = &nominal.model;
    let theta0 = &nominal.fit.theta;
    let n_nodes = data.terms.first().map_or(0, |t| t.b_node.ncols());
    let t2 = detection_threshold(d, 2.0);
    let n_out = data.terms.first().map_or(0, |st| base.n_outputs(st));
    let mut out = Vec::new();
    for effect in Effect::BANK {
        let (exts, names, scale, unit) = extensions(
            effect,
            base,
            n_nodes,
            data_de.is_some(),
            (n_out, &d.probe_nodes),
        );
        let special = match effect {
            Effect::SpeedDependentBearing => speed_law_sizes(d, data),
            Effect::FoundationFlexibility => pedestal_sizes(d, data),
            _ => None,
        };
        let (names, unit) = match &special {
            Some((_, n, u)) => (n.clone(), *u),
            None => (names, unit),
        };
        let sizes = match (effect, data_de) {
            _ if special.is_some() => special.map(|(v, ..)| v),
            _ if exts.is_empty() => None,
            (Effect::ShaftStiffnessError, Some(dd)) => {
                let t1 = detection_threshold(d, 1.0);
                min_detectable(base, dd, theta0, d.sigma2, t1, &exts, scale)
            }
            (Effect::ProbeSensitivity, _) => {
                let t1 = detection_threshold(d, 1.0);
                min_detectable(base, data, theta0, d.sigma2, t1, &exts, scale)
            }
            _ => min_detectable(base, data, theta0, d.sigma2, t2, &exts, scale),
        };
        let (min_size, best_at, min_size_worst, worst_at) = match &sizes {
            Some(v) => where_min(v, &names),
            None => (None, None, None, None),
        };
        let mut o = Observability {
            effect,
            min_size,
            best_at,
            min_size_worst,
            worst_at,
            unit,
            indistinguishable_from: indistinguishable(d, effect),
            note: String::new(),
        };
        o.note = note(&o, d.omega_report);
        out.push(o);
    }
    out
}

/// The extensions of `effect` whose smallest detectable size is computed
/// by [`min_detectable`] (empty for the speed law and the pedestal, which
/// have their own, and for the modulus without `dA/de`), the name of each
/// location, the scale from a scaled amplitude to physical units, and
/// their unit.
fn extensions(
    effect: Effect,
    base: &ExtendedModel,
    n_nodes: usize,
    has_de: bool,
    (n_out, probe_nodes): (usize, &[usize]),
) -> (Vec<Extension>, Vec<String>, f64, &'static str) {
    let planes = &base.pr.param.plane_nodes;
    match effect {
        Effect::ShaftBow => {
            let nodes: Vec<usize> = (1..n_nodes.saturating_sub(1)).collect();
            (
                nodes
                    .iter()
                    .map(|&node| Extension::Bow { node, line: false })
                    .collect(),
                nodes.iter().map(|n| format!("node {}", n + 1)).collect(),
                base.scales.q,
                "m",
            )
        }
        Effect::ExtraUnbalancePlane => {
            let nodes: Vec<usize> = (0..n_nodes).filter(|n| !planes.contains(n)).collect();
            (
                nodes
                    .iter()
                    .map(|&node| Extension::Plane { node })
                    .collect(),
                nodes.iter().map(|n| format!("node {}", n + 1)).collect(),
                base.pr.param.scaling.unbalance,
                "kg m",
            )
        }
        Effect::ProbeRunout => {
            let nq = base.n_channels();
            let mut exts = vec![Extension::Runout];
            exts.extend((nq..n_out).map(|output| Extension::NodeRunout { output }));
            (
                exts,
                (0..n_out)
                    .map(|c| output_name(c, nq, probe_nodes))
                    .collect(),
                base.scales.q,
                "m",
            )
        }
        Effect::ProbeSensitivity => (
            (0..n_out)
                .map(|channel| Extension::Gain { channel })
                .collect(),
            (0..n_out)
                .map(|c| output_name(c, base.n_channels(), probe_nodes))
                .collect(),
            GAIN_STEP,
            "(relative change of a probe's sensitivity)",
        ),
        Effect::ShaftStiffnessError if has_de => (
            vec![Extension::EScale],
            vec!["the shaft".to_string()],
            crate::diagnose::extended::E_STEP,
            "(relative change of E and G)",
        ),
        _ => (Vec::new(), Vec::new(), 1.0, ""),
    }
}

/// Two misfits `a`, `b` the data do not tell apart: within the chi-square
/// quantile of 2 degrees of freedom at 1 % times the noise variance
/// `sigma2`. The one rule for effects (here), a stiffness error's forms
/// ([`Diagnosis::stiffness_alike`]) and a probe gain's pair of channels.
pub(crate) fn tied(a: f64, b: f64, sigma2: f64) -> bool {
    (a - b).abs() < chi2_quantile_upper(2.0, 0.01) * sigma2
}

/// The other significant single effects whose misfit lies within the
/// chi-square quantile of 2 degrees of freedom at 1 % (times `sigma^2`) of
/// `effect`'s ([`tied`]), when `effect` is significant.
fn indistinguishable(d: &Diagnosis, effect: Effect) -> Vec<Effect> {
    // Equally good significant alternatives.
    let me = d
        .hypotheses
        .iter()
        .filter(|c| c.effects == [effect])
        .map(|c| c.fit.s)
        .next();
    match me {
        Some(s)
            if d.hypotheses
                .iter()
                .any(|c| c.effects == [effect] && c.significant) =>
        {
            d.hypotheses
                .iter()
                .filter(|c| c.effects.len() == 1 && c.effects[0] != effect && c.significant)
                .filter(|c| tied(c.fit.s, s, d.sigma2))
                .map(|c| c.effects[0])
                .collect()
        }
        _ => Vec::new(),
    }
}

/// The report's line for `o`, from its other fields: the smallest
/// detectable sizes in words, or why there are none, and what would tell
/// the effect from those it cannot be told apart from; `omega_report` is
/// the speed the bearings are reported at (rad/s).
fn note(o: &Observability, omega_report: f64) -> String {
    let (effect, unit) = (o.effect, o.unit);
    let mut note = match (o.min_size, &o.best_at, o.min_size_worst, &o.worst_at) {
        (Some(a), Some(_), Some(_), Some(_))
            if a.is_finite() && effect == Effect::ShaftStiffnessError =>
        {
            format!(
                "{}: detectable from a {:.1e} relative change of the shaft's modulus (through the shift of the critical speeds and mode shapes in the range)",
                effect.name(),
                a
            )
        }
        (Some(a), Some(wa), Some(b), Some(wb))
            if a.is_finite() && effect == Effect::SpeedDependentBearing =>
        {
            format!(
                "{}: a bearing law one order higher in speed is detectable once it changes a coefficient at {:.0} rpm by {a:.1e} of its value ({wa}); {} ({wb})",
                effect.name(),
                rad_s_to_rpm(omega_report),
                if b.is_finite() { format!("{b:.1e} is needed") } else { "not at all".into() }
            )
        }
        (Some(a), Some(wa), Some(b), Some(wb))
            if a.is_finite() && effect == Effect::FoundationFlexibility =>
        {
            format!(
                "{}: a pedestal (damping ratio {PEDESTAL_ZETA}) is detectable up to a stiffness of {:.1e} times the bearing's ({wa}); {} ({wb})",
                effect.name(),
                1.0 / a,
                if b.is_finite() { format!("up to {:.1e} times", 1.0 / b) } else { "not at all".into() }
            )
        }
        (Some(a), Some(wa), Some(b), Some(wb)) if a.is_finite() => {
            if b.is_finite() {
                format!(
                    "{}: detectable from {a:.2e} {unit} ({wa}) to {b:.2e} {unit} ({wb})",
                    effect.name()
                )
            } else {
                format!(
                    "{}: detectable from {a:.2e} {unit} ({wa}); not at all at {wb} (the nominal model absorbs it)",
                    effect.name()
                )
            }
        }
        _ => match effect {
            Effect::SpeedDependentBearing => {
                "speed_dependent_bearing: refitted as a polynomial law one and two orders higher".to_string()
            }
            Effect::FoundationFlexibility => {
                "foundation_flexibility: seen when the pedestal's resonance lies in or near the speed range; far above it, a pedestal only softens the bearing"
                    .to_string()
            }
            Effect::ShaftStiffnessError => {
                "shaft_stiffness_error: seen through the shift of the critical speeds in the range".to_string()
            }
            _ => format!("{}: not observable with these data", effect.name()),
        },
    };
    for other in &o.indistinguishable_from {
        note.push_str(&format!(
            "; explains the data as well as {}: {}",
            other.name(),
            suggestion(effect, *other)
        ));
    }
    note
}

/// The nominal model at the best estimate of the machine: the nominal
/// parameters of the chosen hypothesis when it keeps the nominal bearing
/// law (its bearings and unbalance are those the data support), else the
/// nominal fit's. On data the nominal model misfits, its own fit wanders
/// to bearings no machine has, and the information there says nothing.
pub fn reference(d: &Diagnosis) -> Candidate {
    let mut c = d.nominal.clone();
    if let Some(h) = d.chosen.and_then(|i| d.hypotheses.get(i)) {
        let p = c.model.pr.n_params();
        if h.model.pr.param == c.model.pr.param && h.fit.theta.len() >= p {
            c.fit.theta = h.fit.theta[..p].to_vec();
        }
    }
    c
}

/// The smallest detectable size of `ext` alone at the reference estimate
/// of `d` ([`reference()`]; physical units: m for bow and runout, kg m for a
/// plane, the relative gain error for a probe gain).
pub fn min_detectable_single(d: &Diagnosis, data: &FitData<'_>, ext: Extension) -> Option<f64> {
    let nominal = reference(d);
    let base = &nominal.model;
    let (scale, k) = match ext {
        Extension::Plane { .. } => (base.pr.param.scaling.unbalance, 2.0),
        Extension::Bow { .. } | Extension::Runout | Extension::NodeRunout { .. } => {
            (base.scales.q, 2.0)
        }
        Extension::Gain { .. } => (GAIN_STEP, 1.0),
        _ => return None,
    };
    let t = detection_threshold(d, k);
    let v = min_detectable(base, data, &nominal.fit.theta, d.sigma2, t, &[ext], scale)?;
    v.into_iter().reduce(f64::min)
}

/// The smallest detectable multiple of the bow through the knots `points`
/// (offsets in m and phases in rad, the shape relative to the shaft's ends,
/// [`FeModel::bow_shape`] of `model`) at the reference estimate of `d`: the
/// factor `c` such that `c` times the bow, in its worst common phase, is
/// just detected by the hypothesis of its own knots (threshold of `2 n`
/// parameters for `n` knots).
///
/// The bow of `n` knots is the sum of the one-knot shapes `p_k s_k(x)`
/// ([`Extension::Bow`]); its offsets at the knots are `o = C p`,
/// `C_jk = s_k(x_j)`, so its parameters are `p = C^-1 o` (scaled by
/// `1 / q`). With `S` the Schur complement of the knots' joint block (see
/// the module documentation), a common phase `alpha` turns `phi` into
/// `R(alpha) phi` and the non-centrality
/// `lambda(alpha) = a cos^2 + 2 b sin cos + g sin^2`
/// (`a = phi^T S phi`, `b = phi^T S J phi`, `g = (J phi)^T S J phi`, `J`
/// the quarter turn of every knot's `(re, im)`) is least at
/// `(a + g) / 2 - sqrt(((a - g) / 2)^2 + b^2)`; the multiple is
/// `c = sqrt(t sigma^2 / lambda_min)`. For one knot this is
/// `min_detectable_single / amplitude`. The one-knot size at a pair's
/// larger knot says little of the pair: on the paper rotor two knots of
/// one sign three nodes apart are seen at 0.27 of their offsets where the
/// larger knot alone needs 0.63 of its own (`tests/diagnose/cases.rs`).
pub fn min_detectable_bow(
    d: &Diagnosis,
    data: &FitData<'_>,
    model: &RotorModel,
    points: &[BowPoint],
) -> Option<f64> {
    let n = points.len();
    if n == 0 {
        return None;
    }
    let fe = FeModel::new(model).ok()?;
    let shapes: Vec<Vec<num_complex::Complex64>> = points
        .iter()
        .map(|p| {
            fe.bow_shape(&ShaftBow {
                points: vec![BowPoint {
                    node: p.node,
                    amplitude: 1.0,
                    phase: 0.0,
                }],
            })
            .ok()
        })
        .collect::<Option<_>>()?;
    let c = DMatrix::from_fn(n, n, |j, k| {
        shapes[k]
            .get(fe.dof(points[j].node, Dir::Y))
            .map_or(f64::NAN, |z| z.re)
    });
    let lu = c.lu();
    let re = DVector::from_iterator(n, points.iter().map(|p| p.amplitude * p.phase.cos()));
    let im = DVector::from_iterator(n, points.iter().map(|p| p.amplitude * p.phase.sin()));
    let (pr, pi) = (lu.solve(&re)?, lu.solve(&im)?);
    let nominal = reference(d);
    let base = &nominal.model;
    let scale = base.scales.q;
    let exts: Vec<Extension> = points
        .iter()
        .map(|p| Extension::Bow {
            node: p.node,
            line: false,
        })
        .collect();
    let all = ExtendedModel {
        ext: exts,
        ..base.clone()
    };
    let mut theta = nominal.fit.theta.clone();
    theta.resize(all.n_params(), 0.0);
    let en = fit::entries(&all, data);
    let (_, jac) = fit::evaluate(&all, data, &en, &theta, true).ok()?;
    let gram = fit::gram(&jac?);
    let p0 = base.n_params();
    let w = 2 * n;
    let ch = gram.view((0, 0), (p0, p0)).into_owned().cholesky()?;
    let s = schur_block(&gram, &ch, p0, w);
    let phi = DVector::from_fn(w, |i, _| {
        let v = if i % 2 == 0 { pr[i / 2] } else { pi[i / 2] };
        v / scale
    });
    // The quarter turn of every knot's phasor: (x, y) -> (-y, x).
    let jphi = DVector::from_fn(w, |i, _| if i % 2 == 0 { -phi[i + 1] } else { phi[i - 1] });
    let a = phi.dot(&(&s * &phi));
    let b = phi.dot(&(&s * &jphi));
    let g = jphi.dot(&(&s * &jphi));
    let lambda = (0.5 * (a + g) - (0.25 * (a - g) * (a - g) + b * b).sqrt()) / d.sigma2;
    let t = detection_threshold(d, w as f64);
    (lambda > 0.0 && lambda.is_finite()).then(|| (t / lambda).sqrt())
}

/// The speed law's sizes for [`analyse`]: per new coefficient, its change
/// at the report speed relative to the nominal coefficient of its row
/// (`k_yy` for `k_yy`, `k_yz`; `k_zz` for `k_zy`, `k_zz`; the same for
/// damping).
fn speed_law_sizes(
    d: &Diagnosis,
    data: &FitData<'_>,
) -> Option<(Vec<f64>, Vec<String>, &'static str)> {
    let nominal = reference(d);
    let base = &nominal.model;
    let n_extra = 8 * base.pr.param.n_bearings();
    let t = detection_threshold(d, n_extra as f64);
    let v = speed_law_min_detectable(base, data, &nominal.fit.theta, d.sigma2, t, d.omega_report)?;
    let (bearings, _) = crate::diagnose::estimates(&nominal, d.omega_report);
    let dir = |i: usize| if i == 0 { "y" } else { "z" };
    let mut sizes = Vec::new();
    let mut names = Vec::new();
    for l in v {
        let Some(b) = bearings.get(l.bearing) else {
            continue;
        };
        let co = if l.stiffness { &b.k } else { &b.c };
        let reference = if l.entry < 2 { co.yy } else { co.zz }.abs();
        sizes.push(if reference > 0.0 {
            l.change / reference
        } else {
            f64::INFINITY
        });
        names.push(format!(
            "{} of bearing {}",
            format_args!(
                "{}_{}{}",
                if l.stiffness { "k" } else { "c" },
                dir(l.entry / 2),
                dir(l.entry % 2)
            ),
            l.bearing + 1
        ));
    }
    Some((
        sizes,
        names,
        "(relative change of a bearing coefficient at the top speed)",
    ))
}

/// Natural frequencies of the pedestals of the observability analysis, as
/// fractions of the top measured speed.
pub const PEDESTAL_GRID: [f64; 10] = [0.25, 0.35, 0.5, 0.7, 0.85, 1.0, 1.2, 1.5, 2.0, 3.0];

/// The pedestal's sizes for [`analyse`]: `k_B / k_p` (the bearing's direct
/// stiffness, mean of `k_yy` and `k_zz` at the report speed, over the
/// pedestal's) at its smallest detectable compliance, per bearing and
/// natural frequency on [`PEDESTAL_GRID`].
fn pedestal_sizes(
    d: &Diagnosis,
    data: &FitData<'_>,
) -> Option<(Vec<f64>, Vec<String>, &'static str)> {
    let nominal = reference(d);
    let base = &nominal.model;
    let t = detection_threshold(d, 5.0);
    let (bearings, _) = crate::diagnose::estimates(&nominal, d.omega_report);
    let k_ref: Vec<f64> = bearings
        .iter()
        .map(|b| 0.5 * (b.k.yy.abs() + b.k.zz.abs()))
        .collect();
    let top = data.terms.iter().map(|t| t.omega).fold(0.0, f64::max);
    let omegas: Vec<f64> = PEDESTAL_GRID.iter().map(|r| r * top).collect();
    let v = pedestal_min_detectable(base, data, &nominal.fit.theta, d.sigma2, t, &omegas, &k_ref)?;
    let sizes = v.iter().map(|p| p.compliance * k_ref[p.bearing]).collect();
    let names = v
        .iter()
        .map(|p| {
            format!(
                "bearing {}, resonance at {:.0} rpm",
                p.bearing + 1,
                rad_s_to_rpm(p.omega)
            )
        })
        .collect();
    Some((sizes, names, "(bearing stiffness over pedestal stiffness)"))
}

/// The smallest detectable size of one speed-law coefficient (see
/// [`speed_law_min_detectable`]).
#[derive(Debug, Clone, PartialEq)]
pub struct LawSize {
    /// Parameter index in the predictor one order higher.
    pub param: usize,
    /// Its smallest detectable (scaled) value.
    pub scaled: f64,
    /// The change it makes at the evaluation speed to its bearing
    /// coefficient (N/m or N s/m).
    pub change: f64,
    /// Bearing (0-based).
    pub bearing: usize,
    /// Entry `2 row + col` (`yy, yz, zy, zz`).
    pub entry: usize,
    /// Stiffness (`true`) or damping.
    pub stiffness: bool,
}

/// `d_k = (S)_kk` for every column `k` of `je`: the information on each
/// extra parameter alone left once the nominal parameters (columns of
/// `jn`) are refitted, `S = J_e^T J_e - J_e^T J_n (J_n^T J_n)^-1 J_n^T J_e`.
fn schur_diagonal(jn: &DMatrix<f64>, je: &DMatrix<f64>) -> Option<Vec<f64>> {
    let ch = fit::gram(jn).cholesky()?;
    let cross = jn.tr_mul(je);
    let x = ch.solve(&cross);
    Some(
        (0..je.ncols())
            .map(|k| je.column(k).norm_squared() - cross.column(k).dot(&x.column(k)))
            .collect(),
    )
}

/// A speed-dependent bearing, linearised: the predictor of physical order
/// `P + 1` at the nominal estimate (its new coefficients `K_P`, `C_P` of
/// every entry at zero). For each new coefficient alone, with `s_kk` its
/// information left after the nominal parameters are refitted
/// (a Schur complement of `J^T J`), the smallest value that reaches the threshold
/// `t` is `x_k = sqrt(t sigma^2 / s_kk)` (scaled), and it changes its
/// bearing coefficient at `omega` (rad/s) by `x_k g_k(omega)`, `g_k` the
/// coefficient's functional (`K_P Omega^P` or `C_P Omega^P` in SI units).
/// `None` when the nominal order is already the highest or the Fisher
/// information is singular.
pub fn speed_law_min_detectable(
    base: &ExtendedModel,
    data: &FitData<'_>,
    theta0: &[f64],
    sigma2: f64,
    t: f64,
    omega: f64,
) -> Option<Vec<LawSize>> {
    use crate::estimate::predictor::Predictor;
    use crate::estimate::Parametrization;
    use rotorid_core::parametrization::{BearingTerm, Structure, Unknown, MAX_ORDER};
    let param = &base.pr.param;
    let order = param.structure.order;
    if !base.ext.is_empty()
        || order + 1 > MAX_ORDER
        || param.structure != Structure::physical(order)
    {
        return None;
    }
    let prn = Predictor::new(Parametrization {
        structure: Structure::physical(order + 1),
        ..param.clone()
    });
    let higher = ExtendedModel {
        pr: prn.clone(),
        ..base.clone()
    };
    let theta_h = crate::diagnose::map_theta(&base.pr, theta0, &prn);
    let (_, jn) = fit::evaluate(base, data, &fit::entries(base, data), theta0, true).ok()?;
    let (_, jh) =
        fit::evaluate(&higher, data, &fit::entries(&higher, data), &theta_h, true).ok()?;
    let jh = jh?;
    let extra: Vec<usize> = (0..prn.param.n_unknowns())
        .filter(|&j| {
            let u = prn.param.unknown(j);
            (0..param.n_unknowns()).all(|i| param.unknown(i) != u)
        })
        .collect();
    let je = DMatrix::from_fn(jh.nrows(), extra.len(), |r, c| jh[(r, extra[c])]);
    let s = schur_diagonal(&jn?, &je)?;
    let mut out = Vec::new();
    for (k, &j) in extra.iter().enumerate() {
        let Some(Unknown::Bearing {
            bearing,
            row,
            col,
            term,
        }) = prn.param.unknown(j)
        else {
            continue;
        };
        let entry = 2 * row + col;
        let stiffness = matches!(term, BearingTerm::K { .. });
        let functional = if stiffness {
            prn.param.stiffness_functional(bearing, entry, omega)
        } else {
            prn.param.damping_functional(bearing, entry, omega)
        };
        let g = functional
            .iter()
            .find(|(i, _)| *i == j)
            .map_or(0.0, |(_, g)| *g);
        let scaled = if s[k] > 0.0 {
            (t * sigma2 / s[k]).sqrt()
        } else {
            f64::INFINITY
        };
        out.push(LawSize {
            param: j,
            scaled,
            change: scaled * g.abs(),
            bearing,
            entry,
            stiffness,
        });
    }
    Some(out)
}

/// The smallest detectable pedestal (see [`pedestal_min_detectable`]).
#[derive(Debug, Clone, PartialEq)]
pub struct PedestalSize {
    /// Bearing (0-based).
    pub bearing: usize,
    /// The pedestal's natural frequency (rad/s), y and z alike.
    pub omega: f64,
    /// Its smallest detectable compliance `1 / k_p` (m/N).
    pub compliance: f64,
}

/// Damping ratio of the pedestals of [`pedestal_min_detectable`].
pub const PEDESTAL_ZETA: f64 = 0.05;

/// A pedestal under `bearing`, linearised about a rigid support: with
/// natural frequency `w_p` (y and z alike, damping ratio
/// [`PEDESTAL_ZETA`]) and compliance `eps = 1 / k_p` (mass
/// `1 / (eps w_p^2)`), the weighted residual moves by `eps g` to first
/// order, `g` the difference quotient of the prediction at a compliance of
/// `1e-9 / |K_B|`. The part the refitted nominal model cannot absorb,
/// `|(I - P_n) g|^2` (`P_n` the projection on the nominal Jacobian's
/// columns), gives the smallest detectable compliance
/// `eps = sqrt(t sigma^2 / |(I - P_n) g|^2)`. `k_ref[b]`: the bearing's
/// direct stiffness (N/m), which sets the difference step.
#[allow(clippy::too_many_arguments)]
pub fn pedestal_min_detectable(
    base: &ExtendedModel,
    data: &FitData<'_>,
    theta0: &[f64],
    sigma2: f64,
    t: f64,
    omegas: &[f64],
    k_ref: &[f64],
) -> Option<Vec<PedestalSize>> {
    use crate::diagnose::extended::PedestalParams;
    if !base.ext.is_empty() {
        return None;
    }
    let (r0, jn) = fit::evaluate(base, data, &fit::entries(base, data), theta0, true).ok()?;
    let jn = jn?;
    let ch = fit::gram(&jn).cholesky()?;
    let mut out = Vec::new();
    for (bearing, &kb) in k_ref.iter().enumerate() {
        if !(kb.is_finite() && kb > 0.0) {
            continue;
        }
        let m = ExtendedModel {
            ext: vec![Extension::Pedestal {
                bearing,
                split: false,
            }],
            ..base.clone()
        };
        let en = fit::entries(&m, data);
        let eps_step = 1e-9 / kb;
        for &w in omegas {
            let ped = PedestalParams {
                mass: 1.0 / (eps_step * w * w),
                split: 0.0,
                omega: [w; 2],
                zeta: [PEDESTAL_ZETA; 2],
            };
            let mut theta = theta0.to_vec();
            theta.extend_from_slice(&ped.to_scaled(&base.scales));
            let Ok((r1, _)) = fit::evaluate(&m, data, &en, &theta, false) else {
                continue;
            };
            // r = y_meas - y: the effect moves y by -(r1 - r0).
            let g = (&r0 - &r1) / eps_step;
            let jg = jn.tr_mul(&g);
            let left = g.norm_squared() - jg.dot(&ch.solve(&jg));
            let compliance = if left > 0.0 {
                (t * sigma2 / left).sqrt()
            } else {
                f64::INFINITY
            };
            out.push(PedestalSize {
                bearing,
                omega: w,
                compliance,
            });
        }
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnose::extended::{PedestalParams, Scales};
    use crate::diagnose::terms::{build, SpeedTerms};
    use crate::estimate::predictor::Predictor;
    use crate::estimate::Parametrization;
    use crate::io::measurement::Sample;
    use crate::model::RotorModel;
    use crate::tables::auto_scaling;
    use rotorid_core::parametrization::Structure;

    /// Variance of one real reading at 0.1 % noise, and the threshold.
    const SIGMA2: f64 = 0.5e-6;
    const T: f64 = 20.0;

    /// The paper rotor's own bearings and unit (scaled) unbalances, order
    /// 1, at 120 speeds up to 1500 rad/s.
    fn setup() -> (Vec<SpeedTerms>, ExtendedModel, Vec<f64>) {
        let m = RotorModel::paper();
        let omegas: Vec<f64> = (1..=120).map(|i| 12.5 * i as f64).collect();
        let terms = build(&m, &omegas, 1.0, false).unwrap();
        let param = Parametrization {
            structure: Structure::physical(1),
            scaling: auto_scaling(&m, 1500.0),
            bearing_nodes: m.bearing_nodes(),
            plane_nodes: m.planes.clone(),
        };
        let pr = Predictor::new(param);
        let theta = crate::diagnose::theta_from_model(&pr, &m, &vec![1.0; pr.n_params()], 750.0);
        let base = ExtendedModel {
            pr,
            ext: Vec::new(),
            scales: Scales {
                q: 1e-5,
                mass: crate::diagnose::rotor_mass(&m) / 2.0,
                omega: 1500.0,
            },
            relative_probes: true,
        };
        (terms, base, theta)
    }

    /// Noise-free readings of `model` at `theta`.
    fn readings(model: &ExtendedModel, terms: &[SpeedTerms], theta: &[f64]) -> Vec<Sample> {
        terms
            .iter()
            .map(|st| Sample {
                omega: st.omega,
                q: model
                    .predict(st, &model.pr.entries(st.omega), theta, None)
                    .unwrap()
                    .iter()
                    .copied()
                    .collect(),
            })
            .collect()
    }

    /// `S / sigma^2` of the nominal model refitted to `samples`.
    fn refit(base: &ExtendedModel, terms: &[SpeedTerms], samples: &[Sample], theta: &[f64]) -> f64 {
        let data = FitData::new(samples, terms);
        let f = fit::fit(base, &data, theta, 200).unwrap();
        assert!(f.converged);
        f.s / SIGMA2
    }

    /// A speed-law coefficient of the computed smallest detectable size,
    /// put into the data, leaves the refitted nominal model a misfit of
    /// `t sigma^2` (the linearisation is exact to first order): checked for
    /// the most and the least visible coefficient and one between.
    #[test]
    fn speed_law_size_matches_a_refit() {
        let (terms, base, theta) = setup();
        let clean = readings(&base, &terms, &theta);
        let data = FitData::new(&clean, &terms);
        let v = speed_law_min_detectable(&base, &data, &theta, SIGMA2, T, 1500.0).unwrap();
        assert_eq!(v.len(), 16);
        let mut order: Vec<usize> = (0..v.len()).collect();
        order.sort_by(|&a, &b| v[a].scaled.total_cmp(&v[b].scaled));
        let prn = Predictor::new(Parametrization {
            structure: Structure::physical(2),
            ..base.pr.param.clone()
        });
        let higher = ExtendedModel {
            pr: prn.clone(),
            ..base.clone()
        };
        for &k in [order[0], order[8], order[15]].iter() {
            let mut th = crate::diagnose::map_theta(&base.pr, &theta, &prn);
            th[v[k].param] = v[k].scaled;
            let lambda = refit(&base, &terms, &readings(&higher, &terms, &th), &theta);
            assert!(
                (lambda - T).abs() < 0.05 * T,
                "coefficient {k}: S / sigma^2 {lambda} against {T}"
            );
            assert!(v[k].change > 0.0 && v[k].change.is_finite());
        }
    }

    /// A pedestal of the computed smallest detectable compliance, put into
    /// the data, leaves the refitted nominal model a misfit of
    /// `t sigma^2`, under either bearing, its resonance inside and above
    /// the speed range.
    #[test]
    fn pedestal_size_matches_a_refit() {
        let (terms, base, theta) = setup();
        let clean = readings(&base, &terms, &theta);
        let data = FitData::new(&clean, &terms);
        let k_ref = [1e8, 1e8];
        let omegas = [600.0, 1400.0, 3000.0];
        let v = pedestal_min_detectable(&base, &data, &theta, SIGMA2, T, &omegas, &k_ref).unwrap();
        assert_eq!(v.len(), 6);
        for p in &v {
            let m = ExtendedModel {
                ext: vec![Extension::Pedestal {
                    bearing: p.bearing,
                    split: false,
                }],
                ..base.clone()
            };
            let ped = PedestalParams {
                mass: 1.0 / (p.compliance * p.omega * p.omega),
                split: 0.0,
                omega: [p.omega; 2],
                zeta: [PEDESTAL_ZETA; 2],
            };
            let mut th = theta.clone();
            th.extend_from_slice(&ped.to_scaled(&base.scales));
            let lambda = refit(&base, &terms, &readings(&m, &terms, &th), &theta);
            assert!(
                (lambda - T).abs() < 0.05 * T,
                "{p:?}: S / sigma^2 {lambda} against {T}"
            );
        }
    }
}
