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
//! * `modulus`: `shaft_stiffness_error`.

mod modulus;
mod nodes;
mod pedestal;
mod runout;
mod speed_law;

pub(crate) use nodes::rescreen;
pub(crate) use pedestal::two_pedestals;
pub use pedestal::PEDESTAL_RATIOS;

use crate::diagnose::candidate::Candidate;
use crate::diagnose::context::Context;
use crate::diagnose::effect::Effect;
use crate::diagnose::input::DiagnoseError;
use crate::diagnose::stages::Stages;
use crate::diagnose::terms::SpeedTerms;

/// The fitted bank.
pub(crate) struct Bank {
    /// The best fit of each family that fitted, in the order tried:
    /// speed law, pedestal, bow, extra plane, runout, modulus.
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
    Ok(Bank {
        hypotheses,
        e_terms: modulus.e_terms,
        terms_de: modulus.terms_de,
    })
}
