//! `foundation_flexibility`: a pedestal (mass, two springs, two dampers)
//! under each bearing in turn, its fit started from the least point of a
//! misfit profile over its natural frequencies in y and z (every pair of
//! a grid across the speed range, [`PEDESTAL_RATIOS`], and two about the
//! speed where the nominal model misfits the bearing most; the unbalance
//! solved for by linear least squares at each point), each bearing's fit
//! restarted with its y and z frequencies apart, then the best one's
//! variant with different masses in y and z, kept on BIC; and the
//! pedestals under two bearings the pairs try.

use nalgebra::DVector;

use crate::diagnose::candidate::Candidate;
use crate::diagnose::choice::Judge;
use crate::diagnose::context::Context;
use crate::diagnose::effect::Effect;
use crate::diagnose::extended::{ExtendedModel, Extension, PedestalParams};
use crate::diagnose::fit::{self, Fit, FitData};
use crate::diagnose::parallel;
use crate::diagnose::stats::bic;
use crate::diagnose::terms::SpeedTerms;
use crate::estimate::predictor::Entry;

/// Natural frequencies of the pedestal search's profile (in y and in z)
/// and of the pairs' starts, as fractions of the top measured speed
/// (besides two at the largest nominal misfit).
/// The lowest, 0.15, reaches half the first critical speed of a rotor
/// measured to four times it (ROSS's stepped hollow shaft to 12000 rpm).
pub const PEDESTAL_RATIOS: [f64; 8] = [0.15, 0.3, 0.45, 0.6, 0.75, 0.9, 1.1, 1.4];

/// The best fit of a pedestal under one bearing: the starts of each
/// bearing's misfit profile ([`profile`]) fitted in full, every bearing's
/// first start before any second one, the bearing of least profile first,
/// until one fits to the noise; unless one does,
/// each bearing's fit restarted with its y and z frequencies apart
/// ([`frequencies_apart`]). `None` when none fits.
///
/// The profile replaced a screening of 60 starts a bearing (natural
/// frequencies alike in y and z, three masses, from both nominal starts)
/// by five iterations each: it finds the basin of a pedestal whose
/// resonance couples with a rotor mode where the screening ranked other
/// basins first, and costs about a tenth as much.
pub(crate) fn foundation_flexibility(ctx: &Context<'_>) -> Option<Candidate> {
    let (base, data, theta0) = (ctx.base, ctx.data, &ctx.theta0);
    let mut best: Option<(Fit, ExtendedModel, usize)> = None;
    let mut alt = 0;
    // Where the nominal model misfits a bearing's channels most: a
    // pedestal's resonance shows there.
    let r_nominal = fit::evaluate(base, data, &fit::entries(base, data), theta0, false)
        .map(|(r, _)| r)
        .ok();
    let n_out = data.inv_w.first().map_or(0, Vec::len);
    // Each bearing's model and natural frequencies of the starts.
    let mut singles: Vec<(usize, ExtendedModel, Vec<f64>)> = Vec::new();
    for bearing in 0..ctx.model.bearings.len() {
        let m = ctx.with_ext(vec![Extension::Pedestal {
            bearing,
            split: false,
        }]);
        if !ctx.n_room(m.n_params()) {
            continue;
        }
        alt += 1;
        let peak_ratio = r_nominal
            .as_ref()
            .and_then(|r| peak_ratio(ctx, r, n_out, bearing));
        let mut ratios = PEDESTAL_RATIOS.to_vec();
        if let Some(p) = peak_ratio {
            ratios.extend([0.97 * p, 1.03 * p]);
        }
        singles.push((bearing, m, ratios));
    }
    let mut per_bearing: Vec<Option<Fit>> = vec![None; ctx.model.bearings.len()];
    // The starts of each bearing's misfit profile over the y and z
    // frequencies (`profile`), fitted in full until one fits to the noise.
    let profiled = parallel::map(&singles, ctx.threads(), |(_, m, ratios)| {
        profile(ctx, m, ratios)
    });
    // Every bearing's first start, by its profile's `S`, then their second.
    let mut order: Vec<(usize, f64, usize, Vec<f64>)> = singles
        .iter()
        .zip(profiled)
        .flat_map(|((bearing, ..), p)| {
            p.into_iter()
                .enumerate()
                .map(move |(k, (s, t))| (k, s, *bearing, t))
        })
        .collect();
    order.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
    for (_, _, bearing, t) in order {
        if best.as_ref().is_some_and(|b| ctx.at_noise(&b.0)) {
            break;
        }
        let Some((_, m, _)) = singles.iter().find(|s| s.0 == bearing) else {
            continue;
        };
        // A second start that reaches the first one's minimum ends there.
        let known: Vec<&Fit> = per_bearing[bearing].iter().collect();
        if let Ok(f) = fit::fit_known(m, data, &t, 60, &known) {
            if per_bearing[bearing].as_ref().is_none_or(|b| f.s < b.s) {
                per_bearing[bearing] = Some(f.clone());
            }
            if best.as_ref().is_none_or(|b| f.s < b.0.s) {
                best = Some((f, m.clone(), bearing));
            }
        }
    }
    // Each bearing's best fit with its y and z frequencies moved apart
    // (`frequencies_apart`), unless the best fits to the noise: a
    // pedestal's local minimum under its own bearing can misfit more than
    // one under another bearing.
    if best.as_ref().is_some_and(|b| !ctx.at_noise(&b.0)) {
        let thin = ctx.thinned();
        let terms: Vec<SpeedTerms> = thin.keep.iter().map(|&k| ctx.terms[k].clone()).collect();
        let screen = ctx
            .data
            .rows(&thin.keep, &thin.samples, &thin.node_q, &terms);
        for (bearing, m, _) in &singles {
            let Some(f) = &per_bearing[*bearing] else {
                continue;
            };
            if let Some(g) = frequencies_apart(ctx, screen.as_ref().unwrap_or(ctx.data), m, f) {
                if best.as_ref().is_none_or(|b| g.s < b.0.s) {
                    best = Some((g, m.clone(), *bearing));
                }
            }
        }
    }
    let (mut f, mut m, bearing) = best?;
    // The variant with its masses in y and z apart (a sixth parameter),
    // from the one-mass fit; kept when its BIC is lower.
    let split = ctx.with_ext(vec![Extension::Pedestal {
        bearing,
        split: true,
    }]);
    let mut is_split = false;
    if ctx.n_room(split.n_params()) {
        let mut theta = f.theta.clone();
        theta.push(0.0);
        if let Ok(fs) = fit::fit(&split, data, &theta, 60) {
            let n = ctx.setup.n_real;
            if bic(&fs, n) < bic(&f, n) {
                (f, m, is_split) = (fs, split, true);
            }
        }
    }
    Some(Candidate::new(
        vec![Effect::FoundationFlexibility],
        format!(
            "pedestal under bearing {} (node {}){}",
            bearing + 1,
            ctx.model.bearings[bearing].node + 1,
            if is_split {
                ", masses in y and z apart"
            } else {
                ""
            }
        ),
        m,
        f,
        1.0,
        alt,
    ))
}

/// The starts of the misfit profile of the pedestal model `m` over its
/// natural frequencies in y and z, each of `ratios` of the top speed
/// (every pair), its mass the rotor's per bearing, damping ratio
/// [`PROFILE_ZETA`], the bearings at the model's own coefficients
/// (`theta_model`): at each point the unbalance, on which the readings
/// depend linearly, is solved for by least squares,
/// `du = (J_u^T J_u)^-1 J_u^T r`. Returns `(S, scaled parameters)` of the
/// least point and of the least one [`PROFILE_APART`] from it
/// ([`PROFILE_STARTS`] in all), least first; empty when no point could
/// be evaluated.
///
/// A point costs one evaluation with the unbalance's columns of the
/// Jacobian ([`fit::evaluate_columns`]), against about a dozen full ones
/// for a screening fit of five iterations. Its y and z frequencies apart
/// and its bearings held reach the basin of a pedestal that couples with a
/// rotor mode: on the paper rotor's grid (pedestals at 56, 100 and 108 Hz,
/// the first critical speed at 97 Hz) the full fit from the profile's
/// least point reaches the noise where those from the screened starts
/// stalled at 2.4 to 5 times it. The bearings at the model's values are a
/// start only: with the truth's 20 % from them, the grid's cases are
/// still found.
fn profile(ctx: &Context<'_>, m: &ExtendedModel, ratios: &[f64]) -> Vec<(f64, Vec<f64>)> {
    let scales = ctx.setup.scales;
    let data = ctx.data;
    let en = fit::entries(m, data);
    let Some(first) = en.first() else {
        return Vec::new();
    };
    let unbalance: Vec<usize> = first
        .iter()
        .enumerate()
        .filter(|(_, e)| matches!(e, Entry::Unbalance { .. }))
        .map(|(i, _)| i)
        .collect();
    // (S, ln of the y and z ratios, parameters) of every point.
    let mut points: Vec<(f64, [f64; 2], Vec<f64>)> = Vec::new();
    for &ry in ratios {
        for &rz in ratios {
            let ped = PedestalParams {
                mass: scales.mass,
                split: 0.0,
                omega: [ry * scales.omega, rz * scales.omega],
                zeta: [PROFILE_ZETA; 2],
            };
            let mut t = ctx.theta_model.clone();
            for &i in &unbalance {
                t[i] = 0.0;
            }
            t.extend_from_slice(&ped.to_scaled(&scales));
            let Ok((r, ju)) = fit::evaluate_columns(m, data, &en, &t, &unbalance) else {
                continue;
            };
            let Some(ch) = fit::gram(&ju).cholesky() else {
                continue;
            };
            let du = ch.solve(&ju.tr_mul(&r));
            let s = (r - &ju * &du).norm_squared();
            for (k, &i) in unbalance.iter().enumerate() {
                t[i] += du[k];
            }
            if s.is_finite() {
                points.push((s, [ry.ln(), rz.ln()], t));
            }
        }
    }
    points.sort_by(|a, b| a.0.total_cmp(&b.0));
    // The least point, then the least one apart from it.
    let mut out: Vec<(f64, [f64; 2], Vec<f64>)> = Vec::new();
    for p in points {
        let apart = out.iter().all(|q| {
            (p.1[0] - q.1[0]).abs() > PROFILE_APART.ln()
                || (p.1[1] - q.1[1]).abs() > PROFILE_APART.ln()
        });
        if apart {
            out.push(p);
            if out.len() == PROFILE_STARTS {
                break;
            }
        }
    }
    out.into_iter().map(|(s, _, t)| (s, t)).collect()
}

/// The damping ratio of the profile's pedestal: three times the largest a
/// pedestal usually has, so that a resonance a grid step off still
/// overlaps the true one (with `0.05`, one 10 % off in z misfits more than
/// none: the profile's least point then had the z frequency above the
/// range, and the fit from it stalled).
const PROFILE_ZETA: f64 = 0.15;

/// The starts each bearing's profile gives: its least point and the least
/// one [`PROFILE_APART`] from it in y or z.
const PROFILE_STARTS: usize = 2;

/// How far (a ratio) the profile's second start lies from its first in the
/// y or the z frequency: more than one step of its grid.
const PROFILE_APART: f64 = 1.3;

/// The factors [`frequencies_apart`] moves one of a pedestal's natural
/// frequencies by.
const APART: [f64; 4] = [0.8, 0.9, 1.12, 1.25];

/// A pedestal's natural frequency above this many times the top speed has
/// run off: [`frequencies_apart`] restarts it from the other axis'.
const RUN_OFF: f64 = 2.0;

/// The pedestal fit `f` of `m` restarted with its natural frequency in y,
/// then in z, times each of [`APART`] (the other kept), from both
/// nominal starts of the search (the nominal estimate and the model's
/// values): the restarts screened by three iterations side by side on
/// `screen` (every [`SCREEN_EVERY`](crate::diagnose::context::SCREEN_EVERY)-th speed of the context's data: the
/// ranking needs the shape of the misfit, not its last digit), the two
/// best fitted in full on every speed from where their screening ended,
/// the better returned.
/// A pedestal's y and z frequencies differ on a machine (its stiffness is
/// seldom the same both ways); the starts of the search have them equal,
/// and its fits can stop where one frequency sits on a resonance that
/// belongs to the other. `None` when no restart could be fitted.
fn frequencies_apart(
    ctx: &Context<'_>,
    screen: &FitData<'_>,
    m: &ExtendedModel,
    f: &Fit,
) -> Option<Fit> {
    let o = ctx.base.n_params();
    let jobs: Vec<(usize, usize, f64)> = (0..2)
        .flat_map(|list| (0..2).flat_map(move |axis| APART.iter().map(move |&k| (list, axis, k))))
        .collect();
    let screened = parallel::map(&jobs, ctx.threads(), |&(list, axis, k)| {
        let mut t = if list == 0 {
            ctx.theta0.clone()
        } else {
            ctx.theta_model.clone()
        };
        t.extend_from_slice(&f.theta[o..]);
        // The scaled parameters `o + 1`, `o + 2` are `ln(w / w_0)`, `w_0`
        // the top speed. A frequency that ran off above the range (that
        // axis gone rigid) restarts from the other's.
        let (i, other) = (o + 1 + axis, o + 2 - axis);
        if t[i] > RUN_OFF.ln() {
            t[i] = t[other];
        }
        t[i] += k.ln();
        fit::fit_with(m, screen, &t, 3, false).ok()
    });
    let mut screened: Vec<Fit> = screened.into_iter().flatten().collect();
    screened.sort_by(|a, b| a.s.total_cmp(&b.s));
    // A restart that returns to `f`'s minimum, or to the first restart's,
    // ends there.
    let mut out: Option<Fit> = None;
    for s in screened.iter().take(2) {
        let known: Vec<&Fit> = std::iter::once(f).chain(out.as_ref()).collect();
        let Ok(g) = fit::fit_known(m, ctx.data, &s.theta, 60, &known) else {
            continue;
        };
        if out.as_ref().is_none_or(|o| g.s < o.s) {
            out = Some(g);
        }
    }
    out
}

/// The speed where the nominal weighted residuals `r` of `bearing`'s four
/// real channels (`n_out` complex outputs per sample) are largest, as a
/// fraction of the top speed.
fn peak_ratio(ctx: &Context<'_>, r: &DVector<f64>, n_out: usize, bearing: usize) -> Option<f64> {
    let samples = ctx.samples;
    let k = (0..samples.len()).max_by(|&a, &b| {
        let e = |k: usize| -> f64 {
            (4 * bearing..4 * bearing + 4)
                .map(|i| r[2 * k * n_out + i].powi(2))
                .sum()
        };
        e(a).total_cmp(&e(b))
    })?;
    Some(samples[k].omega / ctx.setup.scales.omega)
}

/// Pedestals under two bearings, when `c` is a single pedestal: its
/// bearing with each other one, both started on the grid of the single
/// search (`pair_starts`), the two best fitted in full; each pair, and
/// each of its pedestals refitted alone from the pair's values, replaces
/// `pair_best` when its BIC is lower.
pub(crate) fn two_pedestals(
    ctx: &Context<'_>,
    c: &Candidate,
    judge: &Judge,
    pair_best: &mut Option<Candidate>,
) {
    let [Extension::Pedestal { bearing, .. }] = c.model.ext[..] else {
        return;
    };
    let model = ctx.model;
    for other in (0..model.bearings.len()).filter(|&o| o != bearing) {
        let m2 = ExtendedModel {
            ext: vec![
                Extension::Pedestal {
                    bearing,
                    split: false,
                },
                Extension::Pedestal {
                    bearing: other,
                    split: false,
                },
            ],
            ..c.model.clone()
        };
        if !ctx.n_room(m2.n_params()) {
            continue;
        }
        let starts = pair_starts(ctx, &m2);
        for st in starts.iter().take(2) {
            let Ok(f) = fit::fit(&m2, ctx.data, &st.theta, 60) else {
                continue;
            };
            singles_of_pair(ctx, &m2, &f, [bearing, other], judge, pair_best);
            let pair = Candidate::new(
                vec![Effect::FoundationFlexibility; 2],
                format!(
                    "pedestals under bearings {} and {} (nodes {} and {})",
                    bearing + 1,
                    other + 1,
                    model.bearings[bearing].node + 1,
                    model.bearings[other].node + 1
                ),
                m2.clone(),
                f,
                1.0,
                1,
            );
            if pair_best
                .as_ref()
                .is_none_or(|b| judge.bic(&pair) < judge.bic(b))
            {
                *pair_best = Some(pair);
            }
        }
    }
}

/// The screened starts of the two pedestals `m2`, best first: every pair
/// of [`PEDESTAL_RATIOS`] of the top speed, the rotor's mass per bearing,
/// damping ratio 0.05; the bearings from the nominal fit and from the
/// model's own values.
fn pair_starts(ctx: &Context<'_>, m2: &ExtendedModel) -> Vec<Fit> {
    let scales = ctx.setup.scales;
    let mut jobs: Vec<(&Vec<f64>, f64, f64)> = Vec::new();
    for nominal_start in [&ctx.theta0, &ctx.theta_model] {
        for &r1 in &PEDESTAL_RATIOS {
            for &r2 in &PEDESTAL_RATIOS {
                jobs.push((nominal_start, r1, r2));
            }
        }
    }
    let fits = parallel::map(&jobs, ctx.threads(), |&(nominal_start, r1, r2)| {
        let mut t = nominal_start.clone();
        for r in [r1, r2] {
            let ped = PedestalParams {
                mass: scales.mass,
                split: 0.0,
                omega: [r * scales.omega; 2],
                zeta: [0.05; 2],
            };
            t.extend_from_slice(&ped.to_scaled(&scales));
        }
        fit::fit_with(m2, ctx.data, &t, 3, false).ok()
    });
    let mut starts: Vec<Fit> = fits.into_iter().flatten().collect();
    starts.sort_by(|a, b| a.s.total_cmp(&b.s));
    starts
}

/// Each pedestal of the pair fit `f` of `m2` (under `bearings`) alone,
/// from the pair's values, replacing `pair_best` when its BIC is lower.
fn singles_of_pair(
    ctx: &Context<'_>,
    m2: &ExtendedModel,
    f: &Fit,
    bearings: [usize; 2],
    judge: &Judge,
    pair_best: &mut Option<Candidate>,
) {
    // Each pedestal of the pair alone, from the pair's
    // values: the joint search often finds a single
    // pedestal the single search missed, beside a second
    // one gone rigid (no trace in the data); by BIC the
    // single one then wins.
    let p0 = m2.pr.n_params();
    for (k, b) in bearings.into_iter().enumerate() {
        let m1 = ctx.with_ext(vec![Extension::Pedestal {
            bearing: b,
            split: false,
        }]);
        let mut t = f.theta[..p0].to_vec();
        t.extend_from_slice(&f.theta[m2.offset(k)..m2.offset(k) + 5]);
        let Ok(f1) = fit::fit(&m1, ctx.data, &t, 60) else {
            continue;
        };
        let single = Candidate::new(
            vec![Effect::FoundationFlexibility],
            format!(
                "pedestal under bearing {} (node {}), from the search for two",
                b + 1,
                ctx.model.bearings[b].node + 1
            ),
            m1,
            f1,
            1.0,
            1,
        );
        if pair_best
            .as_ref()
            .is_none_or(|c| judge.bic(&single) < judge.bic(c))
        {
            *pair_best = Some(single);
        }
    }
}
