//! Typed results of an identification in physical units, as a program
//! calling the library gets them and as `rotorid identify --json` writes
//! them (`serde::Serialize`; the keys are those of the command-line
//! contract: `bearings[].node/k/c`, `unbalance[].node/me/phase_deg`, and
//! the standard deviations beside their values under `std`).
//!
//! Nodes are 1-based here, as in files and reports; values are SI (N/m,
//! N s/m, kg m) and degrees for phases.

use serde::Serialize;

use crate::estimate::{Identification, Precision};
use crate::units::rad_s_to_rpm;
use rotorid_core::parametrization::{Formulation, UnbalanceEstimate};

/// A 2x2 bearing coefficient matrix by entry.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Coefficients {
    /// `yy` entry.
    pub yy: f64,
    /// `yz` entry.
    pub yz: f64,
    /// `zy` entry.
    pub zy: f64,
    /// `zz` entry.
    pub zz: f64,
}

impl From<[f64; 4]> for Coefficients {
    fn from(v: [f64; 4]) -> Self {
        Coefficients {
            yy: v[0],
            yz: v[1],
            zy: v[2],
            zz: v[3],
        }
    }
}

/// The paper structure's consistency values (physically zero).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Consistency {
    /// `Im Z_0` (N/m).
    pub im_z0: Coefficients,
    /// `Re Z_1` (N s/m).
    pub re_z1: Coefficients,
}

/// Standard deviations of a bearing's coefficients.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BearingStd {
    /// Of the stiffness (N/m).
    pub k: Coefficients,
    /// Of the damping (N s/m).
    pub c: Coefficients,
}

/// One identified bearing.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BearingResult {
    /// Node (1-based).
    pub node: usize,
    /// Stiffness at the evaluation speed (N/m).
    pub k: Coefficients,
    /// Damping at the evaluation speed (N s/m).
    pub c: Coefficients,
    /// Consistency values (paper structure only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub check: Option<Consistency>,
    /// Standard deviations, when known.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub std: Option<BearingStd>,
}

/// Standard deviations of a plane's unbalance.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct UnbalanceStd {
    /// Of `m e` (kg m).
    pub me: f64,
    /// Of the phase (deg).
    pub phase_deg: f64,
}

/// One identified unbalance plane.
///
/// Its JSON carries the standard deviations twice, as `me_std` and
/// `phase_deg_std` beside the values and under `std` with the values' keys
/// (both forms are the command line's contract); they are stored once.
#[derive(Debug, Clone, PartialEq)]
pub struct UnbalanceResult {
    /// Node (1-based).
    pub node: usize,
    /// `m e` (kg m).
    pub me: f64,
    /// Phase `alpha` (deg).
    pub phase_deg: f64,
    /// Standard deviations of `m e` and the phase, when known.
    pub std: Option<UnbalanceStd>,
}

impl UnbalanceResult {
    /// The plane at `node` (1-based) with the estimate `u` and, when known,
    /// the standard deviations `(m e, phase)` in kg m and degrees.
    pub fn new(node: usize, u: &UnbalanceEstimate<f64>, std: Option<(f64, f64)>) -> Self {
        UnbalanceResult {
            node,
            me: u.me,
            phase_deg: u.phase_deg(),
            std: std.map(|(me, phase_deg)| UnbalanceStd { me, phase_deg }),
        }
    }
}

impl Serialize for UnbalanceResult {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeStruct;
        let mut st = s.serialize_struct("UnbalanceResult", 6)?;
        st.serialize_field("node", &self.node)?;
        st.serialize_field("me", &self.me)?;
        st.serialize_field("phase_deg", &self.phase_deg)?;
        match &self.std {
            Some(sd) => {
                st.serialize_field("me_std", &sd.me)?;
                st.serialize_field("phase_deg_std", &sd.phase_deg)?;
                st.serialize_field("std", sd)?;
            }
            None => {
                st.skip_field("me_std")?;
                st.skip_field("phase_deg_std")?;
                st.skip_field("std")?;
            }
        }
        st.end()
    }
}

/// The reported estimate of an identification in physical units: the
/// bearings at the last speed and the unbalance, with their standard
/// deviations, and the checks of the fit (noise, outliers, runout); what
/// `rotorid identify --json` writes ([`Identification::result`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Estimate {
    /// `"oe"` (refined by the output-error fit) or `"rls"` (QRD/RLS alone).
    pub estimator: &'static str,
    /// The relative noise level `s` estimated from the data without the
    /// model, when the speeds allow it.
    pub noise_level: Option<f64>,
    /// The reported estimate's residual noise over `noise_level`, squared
    /// (1 when the model fits the data).
    pub chi2_per_dof: Option<f64>,
    /// The relative RMS misfit of the measured responses against the
    /// reported estimate's prediction.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub residual: Option<f64>,
    /// One line each: what must be known before trusting the result.
    pub warnings: Vec<String>,
    /// `"paper"` or `"physical"`.
    pub structure: &'static str,
    /// Polynomial order of `Z_B` in `Omega`.
    pub order: usize,
    /// `"f64"` or `"f32"`.
    pub precision: &'static str,
    /// Forgetting factor.
    pub lambda: f64,
    /// Start-up regularisation.
    pub delta: f64,
    /// Speed at which the bearing coefficients are evaluated (rpm).
    pub last_speed_rpm: f64,
    /// Steps folded in.
    pub steps: u64,
    /// Steps held by the steady-running guard.
    pub frozen_steps: u64,
    /// Bearings in bearing order.
    pub bearings: Vec<BearingResult>,
    /// Planes in plane order.
    pub unbalance: Vec<UnbalanceResult>,
    /// The noise model used (SPEC section 7).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub noise: Option<NoiseResult>,
    /// The samples excluded as outliers (SPEC section 7).
    pub outliers: Vec<OutlierResult>,
    /// The fitted runout per channel, when fitted.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub runout: Vec<RunoutResult>,
}

/// The noise model as written (SPEC section 7).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NoiseResult {
    /// The floor `f_c` per channel (m).
    pub floor_m: Vec<f64>,
    /// The relative part `s`.
    pub relative: f64,
    /// `"estimated"`, `"given"` or `"file"`.
    pub source: &'static str,
}

impl From<&crate::estimate::noise::NoiseModel> for NoiseResult {
    fn from(m: &crate::estimate::noise::NoiseModel) -> Self {
        NoiseResult {
            floor_m: m.floor_m.clone(),
            relative: m.relative,
            source: m.source.name(),
        }
    }
}

/// A sample excluded as an outlier (SPEC section 7).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct OutlierResult {
    /// Its speed (rpm).
    pub speed_rpm: f64,
    /// Its channel (`b1_y`, ...).
    pub channel: String,
    /// Its residual in standard deviations of the noise model.
    pub sigmas: f64,
}

/// A fitted runout phasor.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RunoutResult {
    /// The channel (`b1_y`, ...).
    pub channel: String,
    /// `|r|` (m).
    pub amplitude_m: f64,
    /// `arg r` (deg).
    pub phase_deg: f64,
    /// Standard deviation of the phasor, `sqrt(E|dr|^2)` (m).
    pub std_m: f64,
}

impl Identification {
    /// The typed result (see the module documentation), with the standard
    /// deviations of [`Identification::std`] when known.
    pub fn result(&self) -> Estimate {
        let std = self.std();
        let p = &self.param;
        let bearings = self
            .last
            .bearings
            .iter()
            .enumerate()
            .map(|(m, b)| BearingResult {
                node: p.bearing_nodes.get(m).map_or(m + 1, |n| n + 1),
                k: b.k.into(),
                c: b.c.into(),
                check: match (b.im_z0, b.re_z1) {
                    (Some(i0), Some(r1)) => Some(Consistency {
                        im_z0: i0.into(),
                        re_z1: r1.into(),
                    }),
                    _ => None,
                },
                std: std
                    .as_ref()
                    .and_then(|s| s.bearings.get(m))
                    .map(|(k, c)| BearingStd {
                        k: (*k).into(),
                        c: (*c).into(),
                    }),
            })
            .collect();
        let unbalance = self
            .last
            .unbalance
            .iter()
            .enumerate()
            .map(|(k, u)| {
                UnbalanceResult::new(
                    p.plane_nodes.get(k).map_or(k + 1, |n| n + 1),
                    u,
                    std.as_ref().and_then(|s| s.unbalance.get(k)).copied(),
                )
            })
            .collect();
        let check = self.check.as_ref();
        let names = crate::io::measurement::default_channel_names(p.n_bearings());
        Estimate {
            estimator: if self.refinement.is_some() {
                "oe"
            } else {
                "rls"
            },
            noise_level: check.and_then(|c| c.noise_level),
            chi2_per_dof: check.and_then(|c| c.chi2_per_dof),
            residual: check.map(|c| c.residual),
            warnings: check.map(|c| c.warnings.clone()).unwrap_or_default(),
            structure: match p.structure.formulation {
                Formulation::Paper => "paper",
                Formulation::Physical => "physical",
            },
            order: p.structure.order,
            precision: match self.options.precision {
                Precision::F64 => "f64",
                Precision::F32 => "f32",
            },
            lambda: self.options.lambda,
            delta: self.options.delta,
            last_speed_rpm: rad_s_to_rpm(self.last.omega),
            steps: self.steps,
            frozen_steps: self.frozen,
            bearings,
            unbalance,
            noise: check.and_then(|c| c.noise.as_ref()).map(NoiseResult::from),
            outliers: check
                .map(|c| {
                    c.outliers
                        .iter()
                        .map(|o| OutlierResult {
                            speed_rpm: rad_s_to_rpm(o.omega),
                            channel: names.get(o.channel).cloned().unwrap_or_default(),
                            sigmas: o.sigmas,
                        })
                        .collect()
                })
                .unwrap_or_default(),
            runout: self
                .refinement
                .as_ref()
                .map(|r| {
                    r.runout
                        .iter()
                        .zip(&names)
                        .map(|((z, sd), n)| RunoutResult {
                            channel: n.clone(),
                            amplitude_m: z.norm(),
                            phase_deg: z.arg().to_degrees(),
                            std_m: *sd,
                        })
                        .collect()
                })
                .unwrap_or_default(),
        }
    }
}
