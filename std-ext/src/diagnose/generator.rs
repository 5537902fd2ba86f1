//! Hidden-effect cases: a seeded generator that draws a machine around a
//! model, hides one effect (or none) in it, simulates a noisy sweep and
//! keeps the answer apart from the data.
//!
//! What is drawn (uniform distributions, all from one ChaCha8 stream):
//!
//! | part | draw |
//! |---|---|
//! | bearings | every K and C entry of each bearing times `U(0.7, 1.3)` (constant coefficients) |
//! | unbalance | at the model's planes, `m e = U(0.5, 1.5) m e_ref`, phase `U(0, 360)` deg; `m e_ref` the model's mean, or ISO 1940 grade G 2.5 (`e = 2.5 mm/s / Omega_max`) split over the planes when the model has none |
//! | noise | relative level `U(0.001, 0.01)` unless given |
//! | `speed_dependent_bearing` | `K(Omega) = K (1 + kappa (Omega/Omega_max)^2)`, `|kappa| = U(0.2, 0.6)`, random sign |
//! | `foundation_flexibility` | a pedestal under one random bearing: mass `U(0.5, 2) m_rotor / N_b`, natural frequencies `w_y = U(0.4, 1.1) Omega_max`, `w_z = U(1, 1.3) w_y`, damping ratios `U(0.02, 0.08)`; relative probes |
//! | `shaft_bow` | an offset `U(10, 50)` um at a random interior node that is not a bearing node, random phase |
//! | `probe_runout` | on one or two random channels, `U(3, 15)` um, random phase |
//! | `extra_unbalance_plane` | at a random node that is not a plane, `U(0.3, 1) m e_ref`, random phase |
//! | `shaft_stiffness_error` | E and G times `1 +- U(0.03, 0.10)` |
//! | `probe_sensitivity` | one random bearing channel reads `1 +- U(0.05, 0.20)` times its signal |

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::diagnose::terms::StiffnessForm;
use crate::diagnose::{rotor_mass, Effect};
use crate::io::measurement::Measurements;
use crate::model::extension::{Channel, Effects, ProbeGain, Runout};
use crate::model::{
    BearingCoefficients, BearingLaw, BowPoint, Pedestal, RotorModel, TableInterpolation, Unbalance,
};
use crate::simulate::{simulate, SimOptions, SimulateError};
use crate::units::rpm_to_rad_s;

/// What was hidden (the answer key).
#[derive(Debug, Clone, PartialEq)]
pub struct Hidden {
    /// The effect.
    pub effect: Effect,
    /// One line, for logs.
    pub description: String,
    /// Node (0-based) of a bow or extra plane.
    pub node: Option<usize>,
    /// Bearing (0-based) of a pedestal.
    pub bearing: Option<usize>,
    /// The main size: bow amplitude (m), extra plane `m e` (kg m), runout
    /// amplitude of the first channel (m), modulus factor, pedestal natural
    /// frequency `w_y` (rad/s), `kappa`, a probe's gain factor.
    pub size: f64,
    /// Phase (rad) of a phasor-valued effect.
    pub phase: f64,
    /// Channel index of a probe gain.
    pub channel: Option<usize>,
    /// Runout phasors by channel index.
    pub runout: Vec<(usize, num_complex::Complex64)>,
    /// The pedestal.
    pub pedestal: Option<Pedestal>,
    /// The form of a stiffness error.
    pub stiffness: Option<StiffnessForm>,
    /// The knots of a bow (one, or two for [`Form::TwoKnotBow`]).
    pub bow: Vec<BowPoint>,
}

/// A generated case.
#[derive(Debug, Clone)]
pub struct Case {
    /// The machine as simulated (scattered bearings, drawn unbalance,
    /// pedestal or speed law included).
    pub truth: RotorModel,
    /// The effects applied by the simulator (bow, runout, extra
    /// unbalance, modulus).
    pub effects: Effects,
    /// The answer.
    pub hidden: Hidden,
    /// Relative noise level.
    pub noise: f64,
    /// The simulated measurement.
    pub meas: Measurements,
}

/// The form an effect takes on a machine, beyond the bank's own
/// hypothesis form ([`Form::Bank`]):
///
/// | form | effect | draw |
/// |---|---|---|
/// | `EOnly` | `shaft_stiffness_error` | E alone times `1 +- U(0.03, 0.10)`, G kept (a material off) |
/// | `Diameter` | `shaft_stiffness_error` | the outer diameter of a third of the elements (a contiguous section) times `1 +- U(0.02, 0.05)`: stiffness and mass |
/// | `FilmTable` | `speed_dependent_bearing` | a table over 6 speeds, linear between: direct stiffness `K (0.75 + 0.5 r^1.5)`, cross-coupled `+-0.3 K r` (signs of a fluid film: `k_yz > 0`, `k_zy < 0`), damping `C (1.4 - 0.6 r)`, `r = Omega / Omega_max` |
/// | `PedestalMasses` | `foundation_flexibility` | the pedestal's z mass `U(1.2, 1.6)` times its y mass |
/// | `TwoKnotBow` | `shaft_bow` | offsets at two interior nodes 2 to 4 apart (not bearings), `U(10, 50)` um and `U(0.6, 1)` of it, phases within 0.3 rad |
/// | `DistributedUnbalance` | `extra_unbalance_plane` | the extra unbalance spread equally over three consecutive nodes (none a plane), phases within 0.2 rad; its size and phase the shares' resultant |
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Form {
    /// The bank's own form of the effect (the table of the module docs).
    Bank,
    /// E alone.
    EOnly,
    /// A section's diameter.
    Diameter,
    /// Bearing coefficients from a fluid-film-like table.
    FilmTable,
    /// A pedestal with different masses in y and z.
    PedestalMasses,
    /// A bow of two knots.
    TwoKnotBow,
    /// An extra unbalance spread over three nodes, one to five times a
    /// plane's in all.
    DistributedUnbalance,
}

impl Form {
    /// The forms beyond the bank's, with their effect.
    pub const MACHINE: [(Effect, Form); 6] = [
        (Effect::ShaftStiffnessError, Form::EOnly),
        (Effect::ShaftStiffnessError, Form::Diameter),
        (Effect::SpeedDependentBearing, Form::FilmTable),
        (Effect::FoundationFlexibility, Form::PedestalMasses),
        (Effect::ShaftBow, Form::TwoKnotBow),
        (Effect::ExtraUnbalancePlane, Form::DistributedUnbalance),
    ];
}

/// Generates a case around `model` with `effect` hidden (`Effect::None`:
/// nothing; `Unexplained` is not drawn), at the speeds `speeds_rpm`, with
/// the noise `noise` or a drawn one.
pub fn generate(
    model: &RotorModel,
    effect: Effect,
    seed: u64,
    speeds_rpm: &[f64],
    noise: Option<f64>,
) -> Result<Case, SimulateError> {
    generate_form(model, effect, Form::Bank, seed, speeds_rpm, noise)
}

/// `model` with an unbalance at each of its planes when it has none (a
/// ROSS rotor file carries none): `1e-4` and `0.6e-4` kg m in turn, at
/// 0.4 and 2.1 rad, to be scaled to a balance grade
/// ([`crate::simulate::at_balance_grade`]), as the confusion matrices of
/// the tests do.
pub fn with_plane_unbalance(mut model: RotorModel) -> RotorModel {
    if model.unbalance.is_empty() {
        model.unbalance = model
            .planes
            .iter()
            .enumerate()
            .map(|(k, &node)| Unbalance {
                node,
                me: if k % 2 == 0 { 1e-4 } else { 0.6e-4 },
                phase: if k % 2 == 0 { 0.4 } else { 2.1 },
            })
            .collect();
    }
    model
}

/// [`generate`] with the effect in the form `form` ([`Form`]; a form of
/// another effect is the bank's form).
// Long (~250 lines): a short `match` arm per effect, the draws in the order the seeds fix.
pub fn generate_form(
    model: &RotorModel,
    effect: Effect,
    form: Form,
    seed: u64,
    speeds_rpm: &[f64],
    noise: Option<f64>,
) -> Result<Case, SimulateError> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let omega_max = speeds_rpm.iter().copied().fold(0.0, f64::max).max(1.0);
    let omega_max = rpm_to_rad_s(omega_max);
    let mut truth = model.clone();
    truth.bow = None;
    let deg = |r: &mut ChaCha8Rng| r.random_range(0.0..std::f64::consts::TAU);
    for b in &mut truth.bearings {
        let co = b.law.at(0.5 * omega_max);
        let k = co.k.map(|v| v * rng.random_range(0.7..1.3));
        let c = co.c.map(|v| v * rng.random_range(0.7..1.3));
        b.law = BearingLaw::Constant(BearingCoefficients { k, c });
    }
    let np = model.planes.len().max(1);
    let me_ref = if model.unbalance.is_empty() {
        rotor_mass(model) * 2.5e-3 / omega_max / np as f64
    } else {
        model.unbalance.iter().map(|u| u.me).sum::<f64>() / model.unbalance.len() as f64
    };
    truth.unbalance = model
        .planes
        .iter()
        .map(|&node| Unbalance {
            node,
            me: me_ref * rng.random_range(0.5..1.5),
            phase: deg(&mut rng),
        })
        .collect();
    let noise = match noise {
        Some(s) => s,
        None => rng.random_range(0.001..0.01),
    };
    let mut effects = Effects::default();
    let mut hidden = Hidden {
        effect,
        description: "none".into(),
        node: None,
        bearing: None,
        size: 0.0,
        phase: 0.0,
        channel: None,
        runout: Vec::new(),
        pedestal: None,
        stiffness: None,
        bow: Vec::new(),
    };
    let n_nodes = model.n_nodes();
    let bearing_nodes = model.bearing_nodes();
    match effect {
        Effect::None | Effect::Unexplained => {}
        Effect::SpeedDependentBearing if form == Form::FilmTable => {
            let speeds: Vec<f64> = (0..6).map(|i| omega_max * i as f64 / 5.0).collect();
            for b in &mut truth.bearings {
                let co = b.law.at(0.0);
                let (kd, cd) = (0.5 * (co.k[0] + co.k[3]), 0.5 * (co.c[0] + co.c[3]));
                let coefficients = speeds
                    .iter()
                    .map(|&w| {
                        let r = w / omega_max;
                        let direct = 0.75 + 0.5 * r.powf(1.5);
                        let cross = 0.3 * kd * r;
                        let damp = 1.4 - 0.6 * r;
                        BearingCoefficients {
                            k: [co.k[0] * direct, cross, -cross, co.k[3] * direct],
                            c: [co.c[0] * damp, 0.1 * cd * r, 0.1 * cd * r, co.c[3] * damp],
                        }
                    })
                    .collect();
                b.law = BearingLaw::Table {
                    speeds: speeds.clone(),
                    coefficients,
                    interpolation: TableInterpolation::LinearHold,
                };
            }
            hidden.size = 0.5;
            hidden.description =
                "bearings from a fluid-film-like table: K x (0.75 + 0.5 r^1.5), cross-coupling 0.3 K r, C x (1.4 - 0.6 r)".into();
        }
        Effect::SpeedDependentBearing => {
            let kappa = rng.random_range(0.2..0.6) * if rng.random_bool(0.5) { 1.0 } else { -1.0 };
            for b in &mut truth.bearings {
                let co = b.law.at(0.0);
                b.law = BearingLaw::Polynomial {
                    k: vec![
                        co.k,
                        [0.0; 4],
                        co.k.map(|v| v * kappa / (omega_max * omega_max)),
                    ],
                    c: vec![co.c],
                };
            }
            hidden.size = kappa;
            hidden.description =
                format!("bearing stiffness x (1 + {kappa:.3} (Omega/Omega_max)^2)");
        }
        Effect::FoundationFlexibility => {
            let b = rng.random_range(0..truth.bearings.len());
            let mass = rng.random_range(0.5..2.0) * rotor_mass(model) / truth.bearings.len() as f64;
            let wy = rng.random_range(0.4..1.1) * omega_max;
            let wz = wy * rng.random_range(1.0..1.3);
            let zy = rng.random_range(0.02..0.08);
            let zz = rng.random_range(0.02..0.08);
            let mz = if form == Form::PedestalMasses {
                mass * rng.random_range(1.2..1.6)
            } else {
                mass
            };
            let p = Pedestal {
                mass: [mass, mz],
                k: [mass * wy * wy, mz * wz * wz],
                c: [2.0 * zy * mass * wy, 2.0 * zz * mz * wz],
            };
            truth.bearings[b].pedestal = Some(p);
            hidden.bearing = Some(b);
            hidden.size = wy;
            hidden.pedestal = Some(p);
            hidden.description = format!(
                "pedestal under bearing {}: {mass:.1} kg, {:.1}/{:.1} Hz, zeta {zy:.3}/{zz:.3}",
                b + 1,
                wy / std::f64::consts::TAU,
                wz / std::f64::consts::TAU
            );
        }
        Effect::ShaftBow => {
            let nodes: Vec<usize> = (1..n_nodes - 1)
                .filter(|n| !bearing_nodes.contains(n))
                .collect();
            let node = nodes[rng.random_range(0..nodes.len())];
            let amplitude = rng.random_range(10e-6..50e-6);
            let phase = deg(&mut rng);
            effects.bow.push(BowPoint {
                node,
                amplitude,
                phase,
            });
            if form == Form::TwoKnotBow {
                // A second knot 2-4 nodes away on the side with room, not a
                // bearing or a shaft end.
                let gap = rng.random_range(2..=4);
                let second = if node + gap < n_nodes - 1 && !bearing_nodes.contains(&(node + gap)) {
                    node + gap
                } else {
                    node.saturating_sub(gap).max(1)
                };
                if second != node && !bearing_nodes.contains(&second) {
                    effects.bow.push(BowPoint {
                        node: second,
                        amplitude: amplitude * rng.random_range(0.6..1.0),
                        phase: phase + rng.random_range(-0.3..0.3),
                    });
                    effects.bow.sort_by_key(|p| p.node);
                }
            }
            hidden.node = Some(node);
            hidden.size = amplitude;
            hidden.phase = phase;
            hidden.bow.clone_from(&effects.bow);
            hidden.description = format!(
                "bow {:.1} um at node {}, {:.0} deg",
                amplitude * 1e6,
                node + 1,
                phase.to_degrees()
            );
        }
        Effect::ProbeRunout => {
            let nq = 2 * truth.bearings.len();
            let first = rng.random_range(0..nq);
            let mut channels = vec![first];
            if rng.random_bool(0.5) {
                let second = (first + rng.random_range(1..nq)) % nq;
                channels.push(second);
            }
            for &ch in &channels {
                let amplitude = rng.random_range(3e-6..15e-6);
                let phase = deg(&mut rng);
                effects.runout.push(Runout {
                    channel: Channel::of_index(ch),
                    amplitude,
                    phase,
                });
                hidden
                    .runout
                    .push((ch, num_complex::Complex64::from_polar(amplitude, phase)));
            }
            hidden.size = hidden.runout[0].1.norm();
            hidden.phase = hidden.runout[0].1.arg();
            hidden.description = format!(
                "runout {}",
                hidden
                    .runout
                    .iter()
                    .map(|(c, z)| format!(
                        "ch{} {:.1} um {:.0} deg",
                        c,
                        z.norm() * 1e6,
                        z.arg().to_degrees()
                    ))
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
        Effect::ExtraUnbalancePlane => {
            let nodes: Vec<usize> = (0..n_nodes).filter(|n| !model.planes.contains(n)).collect();
            let node = nodes[rng.random_range(0..nodes.len())];
            // Spread along a section, a part of another balance quality (a
            // shrunk-on sleeve, deposits): one to five times a plane's.
            let me = if form == Form::DistributedUnbalance {
                me_ref * rng.random_range(1.0..5.0)
            } else {
                me_ref * rng.random_range(0.3..1.0)
            };
            let phase = deg(&mut rng);
            let spread: Vec<usize> = if form == Form::DistributedUnbalance {
                // Three consecutive nodes, none a plane, `node` in the middle
                // where there is room.
                let run: Vec<usize> = (node.saturating_sub(1)..=(node + 1).min(n_nodes - 1))
                    .filter(|n| !model.planes.contains(n))
                    .collect();
                if run.len() == 3 {
                    run
                } else {
                    vec![node]
                }
            } else {
                vec![node]
            };
            let share = me / spread.len() as f64;
            // The resultant: the phasor sum of the shares.
            let mut resultant = num_complex::Complex64::new(0.0, 0.0);
            for &n in &spread {
                let ph = if spread.len() > 1 {
                    phase + rng.random_range(-0.2..0.2)
                } else {
                    phase
                };
                effects.extra_unbalance.push(Unbalance {
                    node: n,
                    me: share,
                    phase: ph,
                });
                resultant += num_complex::Complex64::from_polar(share, ph);
            }
            hidden.node = Some(node);
            // The size of an unbalance spread over nodes is its resultant
            // (what a balancing would remove), up to 2 % below the sum of
            // the shares' sizes with their phases apart.
            hidden.size = resultant.norm();
            hidden.phase = resultant.arg();
            hidden.description = format!(
                "extra unbalance {:.3e} kg m at node {}, {:.0} deg",
                hidden.size,
                node + 1,
                hidden.phase.to_degrees().rem_euclid(360.0)
            );
        }
        Effect::ShaftStiffnessError if form == Form::EOnly => {
            let d = rng.random_range(0.03..0.10) * if rng.random_bool(0.5) { 1.0 } else { -1.0 };
            for el in &mut truth.shaft {
                el.material.e *= 1.0 + d;
            }
            hidden.size = 1.0 + d;
            hidden.stiffness = Some(StiffnessForm::EAlone);
            hidden.description = format!("shaft E alone x {:.4}", 1.0 + d);
        }
        Effect::ShaftStiffnessError if form == Form::Diameter => {
            let d = rng.random_range(0.02..0.05) * if rng.random_bool(0.5) { 1.0 } else { -1.0 };
            let n_el = truth.shaft.len();
            let len = (n_el / 3).max(1);
            let first = rng.random_range(0..=n_el - len);
            for el in &mut truth.shaft[first..first + len] {
                el.outer_diameter *= 1.0 + d;
            }
            hidden.size = 1.0 + d;
            hidden.stiffness = Some(StiffnessForm::Section {
                first,
                last: first + len - 1,
            });
            hidden.description = format!(
                "outer diameter of elements {}..{} x {:.4}",
                first + 1,
                first + len,
                1.0 + d
            );
        }
        Effect::ShaftStiffnessError => {
            let d = rng.random_range(0.03..0.10) * if rng.random_bool(0.5) { 1.0 } else { -1.0 };
            effects.e_scale = 1.0 + d;
            hidden.size = 1.0 + d;
            hidden.stiffness = Some(StiffnessForm::EAndG);
            hidden.description = format!("shaft E and G x {:.4}", 1.0 + d);
        }
        Effect::ProbeSensitivity => {
            let ch = rng.random_range(0..2 * truth.bearings.len());
            let d = rng.random_range(0.05..0.20) * if rng.random_bool(0.5) { 1.0 } else { -1.0 };
            let channel = Channel::of_index(ch);
            effects.probe_gain.push(ProbeGain {
                channel,
                factor: 1.0 + d,
            });
            hidden.channel = Some(ch);
            hidden.size = 1.0 + d;
            hidden.description = format!("probe {channel} reads x {:.4}", 1.0 + d);
        }
    }
    let sim_seed: u64 = rng.random();
    let meas = simulate(
        &truth,
        &SimOptions {
            speeds_rpm: speeds_rpm.to_vec(),
            noise,
            seed: sim_seed,
            effects: effects.clone(),
        },
    )?;
    Ok(Case {
        truth,
        effects,
        hidden,
        noise,
        meas,
    })
}

/// Draws the effect too: `none` or one of the bank, uniformly.
pub fn draw(
    model: &RotorModel,
    seed: u64,
    speeds_rpm: &[f64],
    noise: Option<f64>,
) -> Result<Case, SimulateError> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5eed_d1a6);
    let k = rng.random_range(0..=Effect::BANK.len());
    let effect = if k == 0 {
        Effect::None
    } else {
        Effect::BANK[k - 1]
    };
    generate(model, effect, seed, speeds_rpm, noise)
}

/// A case of the pedestal grid (`tests/diagnose/pedestal_grid.rs`,
/// `examples/pedestal_case.rs`): `(nominal, truth)`. The nominal model is
/// `model` with constant bearings, its laws at half the top speed
/// `rpm_max`; the truth has, under `bearing`, a pedestal of the rotor's
/// mass per bearing resonating at `f_hz` in y and 1.15 times it in z
/// (stiffness `m w^2`), damping ratios 0.03 and 0.05, and its bearing `i`
/// stiffer than the nominal one by `1 + scatter sin(0.7 (i + 1))`, its
/// damping lower by as much. `None` when `bearing` is not one of the
/// model's.
pub fn pedestal_grid_case(
    model: &RotorModel,
    rpm_max: f64,
    bearing: usize,
    f_hz: f64,
    scatter: f64,
) -> Option<(RotorModel, RotorModel)> {
    let mut nominal = model.clone();
    let omega_max = rpm_to_rad_s(rpm_max);
    for b in &mut nominal.bearings {
        let co = b.law.at(0.5 * omega_max);
        b.law = BearingLaw::Constant(BearingCoefficients { k: co.k, c: co.c });
    }
    let mass = rotor_mass(&nominal) / nominal.bearings.len() as f64;
    let wy = std::f64::consts::TAU * f_hz;
    let wz = 1.15 * wy;
    let (zy, zz) = (0.03, 0.05);
    let mut truth = nominal.clone();
    for (i, b) in truth.bearings.iter_mut().enumerate() {
        let co = b.law.at(0.0);
        let f = 1.0 + scatter * ((i as f64 + 1.0) * 0.7).sin();
        b.law = BearingLaw::Constant(BearingCoefficients {
            k: co.k.map(|v| v * f),
            c: co.c.map(|v| v / f),
        });
    }
    truth.bearings.get_mut(bearing)?.pedestal = Some(Pedestal {
        mass: [mass, mass],
        k: [mass * wy * wy, mass * wz * wz],
        c: [2.0 * zy * mass * wy, 2.0 * zz * mass * wz],
    });
    Some((nominal, truth))
}
