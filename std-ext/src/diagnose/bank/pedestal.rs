//! `foundation_flexibility`: a pedestal (mass, two springs, two dampers)
//! under each bearing in turn, its fits started from a grid of natural
//! frequencies across the speed range ([`PEDESTAL_RATIOS`], and two about
//! the speed where the nominal model misfits the bearing most).

use nalgebra::DVector;

use crate::diagnose::candidate::Candidate;
use crate::diagnose::context::Context;
use crate::diagnose::effect::Effect;
use crate::diagnose::extended::{ExtendedModel, Extension, PedestalParams};
use crate::diagnose::fit::{self, Fit};

/// Natural frequencies of the starts of the pedestal search, as fractions
/// of the top measured speed (besides two at the largest nominal misfit).
pub const PEDESTAL_RATIOS: [f64; 7] = [0.3, 0.45, 0.6, 0.75, 0.9, 1.1, 1.4];

/// The best fit of a pedestal under one bearing: under each bearing the
/// two best of the screened starts (`single_starts`), then the full fits
/// of all of them, best screened start first, until one fits to the
/// noise. `None` when none fits.
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
    let mut queue: Vec<(Fit, usize)> = Vec::new();
    for bearing in 0..ctx.model.bearings.len() {
        let m = ctx.with_ext(vec![Extension::Pedestal { bearing }]);
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
        let starts = single_starts(ctx, &m, &ratios);
        queue.extend(starts.into_iter().take(2).map(|f| (f, bearing)));
    }
    // The full fits, best screened start first (the thinned `S` of all
    // bearings are comparable), until one fits to the noise: another
    // start could then only move `S` by noise.
    queue.sort_by(|a, b| a.0.s.total_cmp(&b.0.s));
    for (start, bearing) in queue {
        if best.as_ref().is_some_and(|b| ctx.at_noise(&b.0)) {
            break;
        }
        let m = ctx.with_ext(vec![Extension::Pedestal { bearing }]);
        if let Ok(f) = fit::fit(&m, data, &start.theta, 60) {
            if best.as_ref().is_none_or(|b| f.s < b.0.s) {
                best = Some((f, m, bearing));
            }
        }
    }
    let (f, m, bearing) = best?;
    Some(Candidate::new(
        vec![Effect::FoundationFlexibility],
        format!(
            "pedestal under bearing {} (node {})",
            bearing + 1,
            ctx.model.bearings[bearing].node + 1
        ),
        m,
        f,
        1.0,
        alt,
    ))
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

/// The screened starts of the single pedestal `m`, best first: natural
/// frequencies `ratios` of the top speed (y and z alike), masses 0.5 and
/// 1.5 of the rotor's mass per bearing, damping ratio 0.05.
fn single_starts(ctx: &Context<'_>, m: &ExtendedModel, ratios: &[f64]) -> Vec<Fit> {
    let scales = ctx.setup.scales;
    // Screen a grid of natural frequencies and masses by three
    // iterations each (fewer rank the starts wrongly: the basin of
    // a resonance is narrow), then fit from the two best starts.
    // The bearings start from the nominal fit and from the model's
    // own values (a large pedestal distorts the nominal fit).
    // (Ranking on every second speed only halves this and loses
    // pedestals whose y and z frequencies lie apart.)
    let mut starts: Vec<Fit> = Vec::new();
    for nominal_start in [&ctx.theta0, &ctx.theta_model] {
        for &ratio in ratios {
            for mass in [0.5, 1.5] {
                let ped = PedestalParams {
                    mass: mass * scales.mass,
                    omega: [ratio * scales.omega; 2],
                    zeta: [0.05; 2],
                };
                let mut t = nominal_start.clone();
                t.extend_from_slice(&ped.to_scaled(&scales));
                if let Ok(f) = fit::fit_with(m, ctx.data, &t, 3, false) {
                    starts.push(f);
                }
            }
        }
    }
    starts.sort_by(|a, b| a.s.total_cmp(&b.s));
    starts
}
