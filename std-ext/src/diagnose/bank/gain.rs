//! `probe_sensitivity`: one probe channel whose scale factor is off, the
//! reading `(1 + g)` times the signal ([`Extension::Gain`]); the channels
//! ranked by the drop in misfit one Gauss-Newton step predicts ([`screen`]),
//! the best two fitted.
//!
//! A common gain on every channel is the unbalance's scale and cannot be
//! seen; a gain on one channel changes that channel's ratio to the others
//! at every speed, which no bearing or unbalance change reproduces across
//! a resonance.

use crate::diagnose::bank::screen;
use crate::diagnose::candidate::Candidate;
use crate::diagnose::context::Context;
use crate::diagnose::effect::Effect;
use crate::diagnose::extended::{ExtendedModel, Extension, GAIN_STEP};
use crate::diagnose::fit::{self, Fit};
use crate::diagnose::input::DiagnoseError;
use crate::diagnose::observe::tied;
use crate::diagnose::result::output_name;

/// The best fit of a gain on one output channel (bearing channels and
/// probes at other nodes): the channel `screen` ranks first, the other
/// direction of the same probe pair and the channel ranked second, each
/// fitted from the nominal estimate with the gain at 1. `None` when none
/// fits.
///
/// Where the shaft is stiff against a bearing, the bearing's displacement
/// scales like its compliance, so a common gain on both channels of a
/// bearing is a scale of its coefficients: only the ratio of the pair's
/// gains is seen, and `g` on `y` fits as well as `1 / g` on `z`. When the
/// pair's two fits differ by less than the chi-square quantile of 2
/// degrees of freedom at 1 % (times `sigma^2`), the label says so.
pub(crate) fn probe_sensitivity(ctx: &Context<'_>) -> Result<Option<Candidate>, DiagnoseError> {
    let Some(st) = ctx.terms.first() else {
        return Ok(None);
    };
    let n_out = ctx.base.n_outputs(st);
    let exts: Vec<Extension> = (0..n_out)
        .map(|channel| Extension::Gain { channel })
        .collect();
    let ranked = screen(ctx.base, ctx.data, &ctx.theta0, &exts)?;
    let mut tried: Vec<usize> = Vec::new();
    if let Some(&first) = ranked.first() {
        // The pair of a channel: `b_k y` and `b_k z` (and likewise for the
        // node probes, which follow the even number of bearing channels).
        tried.push(first);
        if (first ^ 1) < n_out {
            tried.push(first ^ 1);
        }
    }
    tried.extend(ranked.get(1).filter(|c| !tried.contains(c)));
    let mut fits: Vec<(Fit, ExtendedModel, usize)> = Vec::new();
    for &channel in &tried {
        let m = ctx.with_ext(vec![Extension::Gain { channel }]);
        if !ctx.n_room(m.n_params()) {
            continue;
        }
        let t = ctx.start_with(&m, &[]);
        if let Ok(f) = fit::fit(&m, ctx.data, &t, 50) {
            fits.push((f, m, channel));
        }
    }
    fits.sort_by(|a, b| a.0.s.total_cmp(&b.0.s));
    let mut fits = fits.into_iter();
    let Some((f, m, channel)) = fits.next() else {
        return Ok(None);
    };
    let name = |c: usize| output_name(c, m.n_channels(), ctx.probe_nodes);
    let gain = |f: &Fit| 1.0 + GAIN_STEP * f.theta[f.theta.len() - 1];
    let mut label = format!("gain on probe {}", name(channel));
    if let Some((f2, _, c2)) = fits.find(|x| x.2 == channel ^ 1) {
        if tied(f2.s, f.s, f.sigma2()) {
            label.push_str(&format!(
                " (or x {:.4} on {}: the data do not tell the pair apart)",
                gain(&f2),
                name(c2)
            ));
        }
    }
    Ok(Some(Candidate::new(
        vec![Effect::ProbeSensitivity],
        label,
        m,
        f,
        1.0,
        n_out,
    )))
}
