//! The bank of hypotheses (module docs of [`crate::diagnose`], step 2):
//! each family of model extensions fitted by the same Levenberg-Marquardt
//! from the nominal estimate, the best variant of each kept as a
//! candidate. One module per family:
//!
//! * `speed_law`: `speed_dependent_bearing`;
//! * `pedestal`: `foundation_flexibility` (and the two pedestals of the
//!   pairs);
//! * `nodes`: `shaft_bow` and `extra_unbalance_plane`, screened over nodes;
//! * `runout`: `probe_runout`;
//! * `modulus`: `shaft_stiffness_error`;
//! * `gain`: `probe_sensitivity`.

mod gain;
mod modulus;
mod nodes;
mod pedestal;
mod runout;
mod speed_law;

pub(crate) use nodes::rescreen;
pub(crate) use pedestal::two_pedestals;
pub use pedestal::PEDESTAL_RATIOS;

use nalgebra::{DMatrix, DVector};

use crate::diagnose::candidate::Candidate;
use crate::diagnose::context::Context;
use crate::diagnose::effect::Effect;
use crate::diagnose::extended::{ExtendedModel, Extension};
use crate::diagnose::fit::{self, FitData};
use crate::diagnose::input::DiagnoseError;
use crate::diagnose::stages::Stages;
use crate::diagnose::terms::SpeedTerms;

/// The fitted bank.
pub(crate) struct Bank {
    /// The best fit of each family that fitted, in the order tried:
    /// speed law, pedestal, bow, extra plane, runout, modulus, gain.
    pub hypotheses: Vec<Candidate>,
    /// The terms at the fitted shaft-modulus factor, when the modulus'
    /// last round was fitted on them.
    pub e_terms: Option<(f64, Vec<SpeedTerms>)>,
    /// The model's own terms with their derivatives in the modulus factor
    /// at `e = 1`, when the modulus hypothesis was tried.
    pub terms_de: Option<Vec<SpeedTerms>>,
}

/// Fits every family of the bank in turn, a lap of `clock` each (bow and
/// extra plane one lap).
pub(crate) fn run(ctx: &Context<'_>, clock: &mut Stages) -> Result<Bank, DiagnoseError> {
    let mut hypotheses: Vec<Candidate> = Vec::new();
    hypotheses.extend(speed_law::speed_dependent_bearing(ctx));
    clock.lap(Effect::SpeedDependentBearing.name());
    // foundation_flexibility: a pedestal under each bearing in turn.
    hypotheses.extend(pedestal::foundation_flexibility(ctx));
    clock.lap(Effect::FoundationFlexibility.name());
    // shaft_bow and extra_unbalance_plane: screened over nodes.
    for effect in [Effect::ShaftBow, Effect::ExtraUnbalancePlane] {
        hypotheses.extend(nodes::node_effect(ctx, effect)?);
    }
    clock.lap("shaft_bow, extra_unbalance_plane");
    hypotheses.extend(runout::probe_runout(ctx));
    clock.lap(Effect::ProbeRunout.name());
    // shaft_stiffness_error: rounds of terms rebuilt at the new factor.
    let modulus = modulus::shaft_stiffness_error(ctx)?;
    hypotheses.extend(modulus.candidate);
    clock.lap(Effect::ShaftStiffnessError.name());
    hypotheses.extend(gain::probe_sensitivity(ctx)?);
    clock.lap(Effect::ProbeSensitivity.name());
    Ok(Bank {
        hypotheses,
        e_terms: modulus.e_terms,
        terms_de: modulus.terms_de,
    })
}

/// Ranks the alternatives `exts` of one hypothesis (indices into `exts`)
/// by the drop in `S` that one Gauss-Newton step from the estimate
/// `theta0` of `base` predicts when the alternative is added (all of
/// `base`'s parameters free):
///
/// ```text
///     drop_k = g_k^T G_kk^-1 g_k,   g = J^T r,   G = J^T J
/// ```
///
/// over the nominal columns and the alternative's own, from one Jacobian
/// holding every alternative's columns.
pub(crate) fn screen(
    base: &ExtendedModel,
    data: &FitData<'_>,
    theta0: &[f64],
    exts: &[Extension],
) -> Result<Vec<usize>, DiagnoseError> {
    let all = ExtendedModel {
        ext: base.ext.iter().chain(exts).copied().collect(),
        ..base.clone()
    };
    let mut theta = theta0.to_vec();
    theta.resize(all.n_params(), 0.0);
    let en = fit::entries(&all, data);
    let (r, jac) = fit::evaluate(&all, data, &en, &theta, true)?;
    let Some(j) = jac else {
        return Ok(Vec::new());
    };
    let g = j.tr_mul(&r);
    let gram = fit::gram(&j);
    let p0 = base.n_params();
    let nq = base.n_channels();
    let mut scored: Vec<(f64, usize)> = Vec::new();
    for (k, e) in exts.iter().enumerate() {
        let o = all.offset(base.ext.len() + k);
        let idx: Vec<usize> = (0..p0).chain(o..o + e.n_params(nq)).collect();
        let gs = DVector::from_iterator(idx.len(), idx.iter().map(|&i| g[i]));
        let gss = DMatrix::from_fn(idx.len(), idx.len(), |a, b| gram[(idx[a], idx[b])]);
        let drop = gss.cholesky().map(|c| gs.dot(&c.solve(&gs))).unwrap_or(0.0);
        scored.push((drop, k));
    }
    scored.sort_by(|a, b| b.0.total_cmp(&a.0));
    Ok(scored.into_iter().map(|(_, k)| k).collect())
}
