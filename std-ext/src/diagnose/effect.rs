//! The effects a diagnosis names ([`Effect`]): nothing beyond the noise,
//! the seven hypotheses of the bank, or a misfit none of them removes; with
//! the names of the command-line contract.

use serde::Serialize;

/// What the data show beyond the nominal model (SPEC section 5 names).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Effect {
    /// Nothing beyond measurement noise.
    None,
    /// Bearing coefficients that vary with speed.
    SpeedDependentBearing,
    /// A pedestal that moves.
    FoundationFlexibility,
    /// A bent shaft.
    ShaftBow,
    /// A constant phasor added to a probe.
    ProbeRunout,
    /// Unbalance at a node not among the planes.
    ExtraUnbalancePlane,
    /// The shaft stiffer or softer than the model.
    ShaftStiffnessError,
    /// A probe channel whose scale factor is off.
    ProbeSensitivity,
    /// A misfit none of the above removes.
    Unexplained,
}

impl Effect {
    /// The hypotheses of the bank, in the order they are tried.
    pub const BANK: [Effect; 7] = [
        Effect::SpeedDependentBearing,
        Effect::FoundationFlexibility,
        Effect::ShaftBow,
        Effect::ProbeRunout,
        Effect::ExtraUnbalancePlane,
        Effect::ShaftStiffnessError,
        Effect::ProbeSensitivity,
    ];

    /// The name of the command-line contract.
    pub fn name(&self) -> &'static str {
        match self {
            Effect::None => "none",
            Effect::SpeedDependentBearing => "speed_dependent_bearing",
            Effect::FoundationFlexibility => "foundation_flexibility",
            Effect::ShaftBow => "shaft_bow",
            Effect::ProbeRunout => "probe_runout",
            Effect::ExtraUnbalancePlane => "extra_unbalance_plane",
            Effect::ShaftStiffnessError => "shaft_stiffness_error",
            Effect::ProbeSensitivity => "probe_sensitivity",
            Effect::Unexplained => "unexplained",
        }
    }

    /// Parses a name of [`Effect::name`].
    pub fn from_name(s: &str) -> Option<Effect> {
        [
            Effect::None,
            Effect::SpeedDependentBearing,
            Effect::FoundationFlexibility,
            Effect::ShaftBow,
            Effect::ProbeRunout,
            Effect::ExtraUnbalancePlane,
            Effect::ShaftStiffnessError,
            Effect::ProbeSensitivity,
            Effect::Unexplained,
        ]
        .into_iter()
        .find(|e| e.name() == s)
    }
}
