//! `probe_runout`: a constant phasor added to every channel (the bearing
//! channels and the probes at other nodes), the better of two starts: the
//! readings at the lowest speed, and the slow-roll estimate refined by the
//! output-error fit that solves for the runout.

use num_complex::Complex64;

use crate::diagnose::candidate::Candidate;
use crate::diagnose::context::Context;
use crate::diagnose::effect::Effect;
use crate::diagnose::extended::Extension;
use crate::diagnose::fit;
use crate::diagnose::nominal::{oe_start, oe_start_with_runout};
use crate::io::measurement::Sample;

/// The fit of a runout phasor on every channel (scaled by the RMS
/// reading), from the lowest speed's readings as runout and the nominal
/// parameters estimated again on the data less them, and from the
/// slow-roll runout refined with them; the better fit. `None` when the
/// equations leave no room or the fit fails.
pub(crate) fn probe_runout(ctx: &Context<'_>) -> Option<Candidate> {
    let (samples, setup) = (ctx.samples, ctx.setup);
    let nq = ctx.base.n_channels();
    // The lowest speed's sample: its reading is mostly runout (the
    // unbalance response vanishes like Omega^2).
    let i_low = (0..samples.len()).min_by(|&a, &b| samples[a].omega.total_cmp(&samples[b].omega));
    let node_low: Vec<Complex64> = i_low
        .and_then(|i| ctx.node_q.get(i))
        .cloned()
        .unwrap_or_default();
    let mut ext = vec![Extension::Runout];
    ext.extend((0..node_low.len()).map(|k| Extension::NodeRunout { output: nq + k }));
    let m = ctx.with_ext(ext);
    if !ctx.n_room(m.n_params()) {
        return None;
    }
    let scales = setup.scales;
    let node_r0: Vec<f64> = node_low
        .iter()
        .flat_map(|r| [r.re / scales.q, r.im / scales.q])
        .collect();
    // Start: the lowest speed's readings as runout, the nominal
    // parameters refitted to the data without it.
    let low = i_low.map(|i| samples[i].q.clone()).unwrap_or_default();
    let corrected: Vec<Sample> = samples
        .iter()
        .map(|s| Sample {
            omega: s.omega,
            q: s.q.iter().zip(&low).map(|(y, r)| y - r).collect(),
        })
        .collect();
    let r0: Vec<f64> = low
        .iter()
        .flat_map(|r| [r.re / scales.q, r.im / scales.q])
        .collect();
    let mut t = match oe_start(
        ctx.model,
        &corrected,
        ctx.terms,
        setup.structure,
        setup.scaling,
        setup.held_noise(),
    ) {
        Ok((_, th, _)) => th,
        Err(_) => ctx.theta0.clone(),
    };
    t.extend_from_slice(&r0);
    t.extend_from_slice(&node_r0);
    t.resize(m.n_params(), 0.0);
    let mut best = fit::fit(&m, ctx.data, &t, 50).ok();
    // Second start: the slow-roll runout (fitted over the lowest speeds,
    // `slow_roll_estimate`) refined with the nominal parameters by the
    // output-error fit that solves for it.
    let slow = crate::estimate::sweep::slow_roll_estimate(samples)
        .map(|e| e.runout)
        .unwrap_or_else(|| low.clone());
    if let Ok((_, mut t2, _, r2)) = oe_start_with_runout(
        ctx.model,
        samples,
        ctx.terms,
        setup.structure,
        setup.scaling,
        setup.held_noise(),
        Some(&slow),
    ) {
        if r2.len() == low.len() {
            t2.extend(r2.iter().flat_map(|r| [r.re / scales.q, r.im / scales.q]));
            t2.extend_from_slice(&node_r0);
            t2.resize(m.n_params(), 0.0);
            if let Ok(f2) = fit::fit(&m, ctx.data, &t2, 50) {
                if best.as_ref().is_none_or(|b| f2.s < b.s) {
                    best = Some(f2);
                }
            }
        }
    }
    let f = best?;
    Some(Candidate::new(
        vec![Effect::ProbeRunout],
        if node_low.is_empty() {
            "runout phasor on every channel".into()
        } else {
            "runout phasor on every channel, node probes included".into()
        },
        m,
        f,
        1.0,
        1,
    ))
}
