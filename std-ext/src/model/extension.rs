//! Physical effects that a nominal rotor model may lack: the hypotheses of
//! the diagnosis and the effects the simulator can put into data.
//!
//! | effect | what changes |
//! |---|---|
//! | [`SpeedScaling`] | bearing stiffness `K (Omega / Omega_ref)^p`, `p = 1, 2` |
//! | [`Effects::pedestal`] | a mass on spring and damper under each bearing |
//! | [`Effects::bow`] | a bent shaft, forcing `K_s q_bow` |
//! | [`Runout`] | a constant phasor (m) added to a probe's signal |
//! | [`ProbeGain`] | a probe's reading times a real factor (its sensitivity off) |
//! | [`Effects::extra_unbalance`] | unbalance (kg m) at nodes that are not planes |
//! | [`Effects::e_scale`] | the shaft's E and G times a factor |
//!
//! [`apply_effects`] turns the model-changing ones into a modified
//! [`RotorModel`]; the forcing and probe effects are applied by the
//! simulator (`crate::simulate`).

use num_complex::Complex64;
use thiserror::Error;

use crate::model::{BearingLaw, BowPoint, ModelError, Pedestal, RotorModel, ShaftBow, Unbalance};
use crate::units::rpm_to_rad_s;

/// An effect that cannot be applied to a model.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ExtensionError {
    /// The modified model is invalid.
    #[error("{0}")]
    Model(#[from] ModelError),
    /// The effect's parameters are out of range or do not fit the model.
    #[error("{0}")]
    Invalid(String),
}

/// How bearing stiffness scales with speed (the damping is unchanged).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SpeedLaw {
    /// `K(Omega) = K (Omega / Omega_ref)^2`, the paper's Eq. 49 form.
    Quadratic,
    /// `K(Omega) = K Omega / Omega_ref`.
    Linear,
}

/// Speed-dependent bearing stiffness: every bearing's stiffness is
/// multiplied by `(rpm / rpm_ref)^2` (quadratic) or `rpm / rpm_ref`
/// (linear), so it equals the model's value at `rpm_ref`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpeedScaling {
    /// Speed at which the stiffness equals the model's (rpm).
    pub rpm_ref: f64,
    /// Scaling law.
    pub law: SpeedLaw,
}

/// Transverse direction of a probe.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Direction {
    /// y.
    Y,
    /// z.
    Z,
}

/// One probe channel: bearing (0-based) and direction.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Channel {
    /// Bearing index (0-based; `b1` is 0).
    pub bearing: usize,
    /// Direction.
    pub direction: Direction,
}

impl Channel {
    /// Parses `b<k>_y` / `b<k>_z` (k 1-based, at most `n_bearings`).
    pub fn parse(s: &str, n_bearings: usize) -> Result<Channel, String> {
        let bad = || format!("bad channel `{s}` (expected b1_y, b1_z, ..., b{n_bearings}_z)");
        let rest = s.strip_prefix('b').ok_or_else(bad)?;
        let (num, dir) = rest.split_once('_').ok_or_else(bad)?;
        let k: usize = num.parse().map_err(|_| bad())?;
        let direction = match dir {
            "y" => Direction::Y,
            "z" => Direction::Z,
            _ => return Err(bad()),
        };
        if k == 0 || k > n_bearings {
            return Err(bad());
        }
        Ok(Channel {
            bearing: k - 1,
            direction,
        })
    }

    /// Index in the phasor vector `b1_y, b1_z, b2_y, ...`.
    pub fn index(&self) -> usize {
        2 * self.bearing
            + match self.direction {
                Direction::Y => 0,
                Direction::Z => 1,
            }
    }

    /// The channel of index `ch` in `b1_y, b1_z, b2_y, ...` (the inverse
    /// of [`Channel::index`]).
    pub fn of_index(ch: usize) -> Channel {
        Channel {
            bearing: ch / 2,
            direction: if ch % 2 == 0 {
                Direction::Y
            } else {
                Direction::Z
            },
        }
    }
}

/// The channel's name as in the measurement file's header: `b<k>_y` or
/// `b<k>_z` (k 1-based), what [`Channel::parse`] reads.
impl std::fmt::Display for Channel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let dir = match self.direction {
            Direction::Y => "y",
            Direction::Z => "z",
        };
        write!(f, "b{}_{dir}", self.bearing + 1)
    }
}

/// Probe runout: a constant phasor added to one channel at every speed
/// (electrical/mechanical runout of the probe track).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Runout {
    /// The channel it is added to.
    pub channel: Channel,
    /// Amplitude (m).
    pub amplitude: f64,
    /// Phase (rad).
    pub phase: f64,
}

impl Runout {
    /// The phasor `amplitude exp(j phase)` (m).
    pub fn phasor(&self) -> Complex64 {
        Complex64::from_polar(self.amplitude, self.phase)
    }
}

/// A probe whose scale factor is off (the sensitivity set for another
/// target material, a cable or a driver fault): the channel reads
/// `factor` times the displacement it sees, runout included.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProbeGain {
    /// The channel.
    pub channel: Channel,
    /// The factor on its reading (1 = right; 1.1: reads 10 % high).
    pub factor: f64,
}

/// Physical effects put into simulated data, beyond the model file's own
/// description (see the README, "Simulator").
#[derive(Debug, Clone, PartialEq)]
pub struct Effects {
    /// Factor on the shaft's elastic moduli E and G (Poisson's ratio kept)
    /// of every element; 1 = none.
    pub e_scale: f64,
    /// Speed-dependent bearing stiffness, if any.
    pub bearing_speed_law: Option<SpeedScaling>,
    /// A pedestal added under every bearing that has none.
    pub pedestal: Option<Pedestal>,
    /// Bow points added to the model's bow.
    pub bow: Vec<BowPoint>,
    /// Probe runout phasors.
    pub runout: Vec<Runout>,
    /// Probe scale factors that are off.
    pub probe_gain: Vec<ProbeGain>,
    /// Unbalance added to the model's true unbalance (typically at a node
    /// that is not one of the model's planes).
    pub extra_unbalance: Vec<Unbalance>,
}

impl Default for Effects {
    fn default() -> Self {
        Effects {
            e_scale: 1.0,
            bearing_speed_law: None,
            pedestal: None,
            bow: Vec::new(),
            runout: Vec::new(),
            probe_gain: Vec::new(),
            extra_unbalance: Vec::new(),
        }
    }
}

impl Effects {
    /// Overlays `other` on `self`: scalar settings of `other` win when set,
    /// lists are concatenated.
    pub fn merged_with(mut self, other: &Effects) -> Effects {
        if other.e_scale != 1.0 {
            self.e_scale = other.e_scale;
        }
        if other.bearing_speed_law.is_some() {
            self.bearing_speed_law = other.bearing_speed_law;
        }
        if other.pedestal.is_some() {
            self.pedestal = other.pedestal;
        }
        self.bow.extend_from_slice(&other.bow);
        self.runout.extend_from_slice(&other.runout);
        self.probe_gain.extend_from_slice(&other.probe_gain);
        self.extra_unbalance
            .extend_from_slice(&other.extra_unbalance);
        self
    }

    /// One line per active effect, for the CSV comments.
    pub fn describe(&self) -> Vec<String> {
        let mut out = Vec::new();
        if self.e_scale != 1.0 {
            out.push(format!("effect: shaft E and G scaled by {}", self.e_scale));
        }
        if let Some(s) = &self.bearing_speed_law {
            out.push(format!(
                "effect: bearing stiffness x (rpm/{})^{}",
                s.rpm_ref,
                match s.law {
                    SpeedLaw::Quadratic => 2,
                    SpeedLaw::Linear => 1,
                }
            ));
        }
        if let Some(p) = &self.pedestal {
            out.push(format!(
                "effect: pedestal m={} kg k=[{}, {}] N/m c=[{}, {}] N s/m under every bearing",
                if p.mass[0] == p.mass[1] {
                    format!("{}", p.mass[0])
                } else {
                    format!("[{}, {}]", p.mass[0], p.mass[1])
                },
                p.k[0],
                p.k[1],
                p.c[0],
                p.c[1]
            ));
        }
        for b in &self.bow {
            out.push(format!(
                "effect: bow at node {}: {} m at {} deg",
                b.node + 1,
                b.amplitude,
                b.phase.to_degrees()
            ));
        }
        for r in &self.runout {
            out.push(format!(
                "effect: runout on {}: {} m at {} deg",
                r.channel,
                r.amplitude,
                r.phase.to_degrees()
            ));
        }
        for g in &self.probe_gain {
            out.push(format!("effect: probe {} reads x {}", g.channel, g.factor));
        }
        for u in &self.extra_unbalance {
            out.push(format!(
                "effect: extra unbalance at node {}: {} kg m at {} deg",
                u.node + 1,
                u.me,
                u.phase.to_degrees()
            ));
        }
        out
    }
}

/// The model with the model-changing effects applied: shaft modulus scale,
/// speed-dependent bearing stiffness, pedestals, extra bow points. The
/// forcing effects (extra unbalance, runout) are applied by the simulator
/// (`rotorid::simulate::simulate`).
pub fn apply_effects(model: &RotorModel, effects: &Effects) -> Result<RotorModel, ExtensionError> {
    let mut m = model.clone();
    if !(effects.e_scale.is_finite() && effects.e_scale > 0.0) {
        return Err(ExtensionError::Invalid(format!(
            "shaft modulus scale must be finite and > 0, got {}",
            effects.e_scale
        )));
    }
    if effects.e_scale != 1.0 {
        for e in &mut m.shaft {
            e.material.e *= effects.e_scale;
            e.material.g *= effects.e_scale;
        }
    }
    if let Some(s) = &effects.bearing_speed_law {
        if !(s.rpm_ref.is_finite() && s.rpm_ref > 0.0) {
            return Err(ExtensionError::Invalid(format!(
                "reference speed must be finite and > 0 rpm, got {}",
                s.rpm_ref
            )));
        }
        let omega_ref = rpm_to_rad_s(s.rpm_ref);
        // K(Omega) s(Omega) with s = (Omega/Omega_ref)^p: shift the
        // polynomial by p powers and divide by Omega_ref^p.
        let p = match s.law {
            SpeedLaw::Quadratic => 2,
            SpeedLaw::Linear => 1,
        };
        let scale = omega_ref.powi(p);
        for (i, b) in m.bearings.iter_mut().enumerate() {
            let (k, c) = match &b.law {
                BearingLaw::Constant(co) => (vec![co.k], vec![co.c]),
                BearingLaw::Polynomial { k, c } => (k.clone(), c.clone()),
                BearingLaw::Table { .. } | BearingLaw::DynamicStiffness { .. } => {
                    return Err(ExtensionError::Invalid(format!(
                        "bearing {} has a coefficient table or a complex dynamic stiffness: speed scaling applies to constant or polynomial bearings only",
                        i + 1
                    )))
                }
            };
            let mut k2 = vec![[0.0; 4]; p as usize];
            k2.extend(k.iter().map(|row| row.map(|v| v / scale)));
            b.law = BearingLaw::Polynomial { k: k2, c };
        }
    }
    if let Some(p) = &effects.pedestal {
        for b in &mut m.bearings {
            if b.pedestal.is_none() {
                b.pedestal = Some(*p);
            }
        }
    }
    if !effects.bow.is_empty() {
        let mut bow = m.bow.take().unwrap_or_default();
        bow.points.extend_from_slice(&effects.bow);
        bow.points.sort_by_key(|p| p.node);
        m.bow = Some(ShaftBow { points: bow.points });
    }
    m.validate()?;
    for u in &effects.extra_unbalance {
        if u.node >= m.n_nodes() {
            return Err(ExtensionError::Invalid(format!(
                "extra unbalance: node {} is not on the shaft (nodes 1..={})",
                u.node + 1,
                m.n_nodes()
            )));
        }
    }
    Ok(m)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn channel_parse() {
        assert_eq!(Channel::parse("b2_z", 2).unwrap().index(), 3);
        assert_eq!(Channel::parse("b1_y", 2).unwrap().index(), 0);
        assert!(Channel::parse("b3_y", 2).is_err());
        assert!(Channel::parse("b0_y", 2).is_err());
        assert!(Channel::parse("b1_x", 2).is_err());
        assert!(Channel::parse("1_y", 2).is_err());
    }

    #[test]
    fn speed_scaling_equals_model_at_reference() {
        let m = RotorModel::paper();
        let eff = Effects {
            bearing_speed_law: Some(SpeedScaling {
                rpm_ref: 15000.0,
                law: SpeedLaw::Quadratic,
            }),
            ..Effects::default()
        };
        let s = apply_effects(&m, &eff).unwrap();
        let w = rpm_to_rad_s(15000.0);
        let a = s.bearings[0].law.at(w);
        let b = m.bearings[0].law.at(w);
        for j in 0..4 {
            assert!((a.k[j] - b.k[j]).abs() <= 1e-9 * b.k[j].abs());
            assert_eq!(a.c[j], b.c[j]);
        }
        let half = s.bearings[1].law.at(w / 2.0);
        assert!((half.k[0] - 0.25 * 5e7).abs() < 1e-3);
        // Equals the paper's Eq. 49 model.
        let p = RotorModel::paper_speed_dependent();
        let q = p.bearings[1].law.at(0.3 * w);
        let r = s.bearings[1].law.at(0.3 * w);
        for j in 0..4 {
            assert!((q.k[j] - r.k[j]).abs() <= 1e-9 * q.k[j].abs());
        }
        let lin = Effects {
            bearing_speed_law: Some(SpeedScaling {
                rpm_ref: 15000.0,
                law: SpeedLaw::Linear,
            }),
            ..Effects::default()
        };
        let s = apply_effects(&m, &lin).unwrap();
        assert!((s.bearings[0].law.at(w / 2.0).k[3] - 3.5e7).abs() < 1e-3);
    }

    #[test]
    fn e_scale_and_pedestal_change_the_model() {
        let m = RotorModel::paper();
        let eff = Effects {
            e_scale: 1.05,
            pedestal: Some(Pedestal {
                mass: [20.0, 20.0],
                k: [1e8, 2e8],
                c: [1e3, 1e3],
            }),
            ..Effects::default()
        };
        let s = apply_effects(&m, &eff).unwrap();
        assert!((s.shaft[3].material.e - 210e9).abs() < 1.0);
        assert!((s.shaft[3].material.nu() - 0.3).abs() < 1e-12);
        assert!(s.bearings.iter().all(|b| b.pedestal.is_some()));
        assert!(apply_effects(
            &m,
            &Effects {
                e_scale: -1.0,
                ..Effects::default()
            }
        )
        .is_err());
    }
}
