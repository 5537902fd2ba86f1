//! The simulator behind `rotorid simulate`: the 1X unbalance (and bow)
//! response at the bearing probes over a speed sweep, with optional
//! physical effects the nominal model lacks and measurement noise.
//!
//! Pipeline, per speed Omega of the grid:
//!
//! 1. the model is modified by the [`Effects`] (shaft modulus scale,
//!    speed-dependent bearings, pedestals, extra bow points) once, before
//!    the sweep ([`apply_effects`]);
//! 2. `Z(Omega) q = Omega^2 f_unbalance + f_bow` is solved by the FE model
//!    (`response::unbalance_response`), with the model's true unbalance plus
//!    any extra unbalance planes; the probe signal is the shaft's
//!    displacement at each bearing node relative to the bearing housing
//!    (the pedestal, where there is one; [`ProbeReference`]), or absolute
//!    for `probes = "absolute"`, channels `b1_y, b1_z, b2_y, ...`;
//! 3. probe runout phasors are added, constant across speed ([`add_runout`]),
//!    and probes whose sensitivity is off scale their channel
//!    ([`apply_probe_gain`]);
//! 4. noise: every complex sample `q` of every channel gets `s |q| eps`,
//!    `eps` standard complex Gaussian (`E|eps|^2 = 1`: real and imaginary
//!    parts independent `N(0, 1/2)`), drawn from a ChaCha8 generator seeded
//!    with `seed`, in the order sample by sample, channel by channel, real
//!    part then imaginary part ([`add_noise`]). Same seed, same data.

pub mod transient;

use num_complex::Complex64;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use thiserror::Error;

use crate::fe::assembly::{Dir, FeError, FeModel};
use crate::fe::response::{unbalance_response, Forcing};
use crate::io::measurement::{Measurements, Sample};
use crate::model::extension::{apply_effects, Effects, ExtensionError, ProbeGain, Runout};
use crate::model::{ModelError, ProbeReference, RotorModel, ShaftBow, Unbalance};
use crate::units::rpm_to_rad_s;

/// Error of the simulator.
#[derive(Debug, Error)]
pub enum SimulateError {
    /// The model (after effects) is invalid.
    #[error("{0}")]
    Model(#[from] ModelError),
    /// No speeds to simulate.
    #[error("speed grid: no speeds")]
    NoSpeeds,
    /// A speed is negative or not finite.
    #[error("speed grid: speeds must be finite and >= 0 rpm, got {0}")]
    Speed(f64),
    /// A runout names a bearing the model does not have.
    #[error("runout on bearing {bearing}: the model has {n_bearings} bearings")]
    RunoutBearing {
        /// The bearing (1-based).
        bearing: usize,
        /// Bearings of the model.
        n_bearings: usize,
    },
    /// A probe gain names a bearing the model does not have, or its
    /// factor is not finite and > 0.
    #[error("probe gain on bearing {bearing}: {why}")]
    ProbeGain {
        /// The bearing (1-based).
        bearing: usize,
        /// What is wrong.
        why: String,
    },
    /// A model-changing effect cannot be applied.
    #[error("{0}")]
    Extension(#[from] ExtensionError),
    /// Bad noise level.
    #[error("noise level must be finite and >= 0, got {0}")]
    Noise(f64),
    /// Bad noise floor.
    #[error("noise floor must be finite and >= 0 m, got {0}")]
    NoiseFloor(f64),
    /// More glitches than samples.
    #[error("{k} glitches asked for, the sweep has {total} samples")]
    Glitches {
        /// Glitches asked for.
        k: usize,
        /// Samples (speeds x channels).
        total: usize,
    },
    /// The finite-element solve failed.
    #[error("finite-element response: {0}")]
    Solver(#[from] FeError),
    /// A response solver returned the wrong number of speeds or channels.
    #[error("finite-element response: the response has the wrong number of speeds or channels")]
    ResponseShape,
    /// Nothing excites the rotor: no unbalance (every `m e` is 0), no bow
    /// and no runout, so every response would be exactly zero.
    #[error("nothing to simulate: the model has no unbalance, bow or runout, so every response would be zero; give it an unbalance")]
    NoExcitation,
    /// A node probe names a node the shaft does not have.
    #[error("node probe at node {node}: the shaft has nodes 1..={n_nodes}")]
    ProbeNode {
        /// The node (1-based).
        node: usize,
        /// Nodes of the shaft.
        n_nodes: usize,
    },
}

/// Whether `unbalance`, `bow` and `runout` excite anything: an unbalance
/// with `m e > 0` (kg m), a bow point with amplitude > 0 (m) or a runout
/// with amplitude > 0 (m).
pub fn has_excitation(unbalance: &[Unbalance], bow: Option<&ShaftBow>, runout: &[Runout]) -> bool {
    unbalance.iter().any(|u| u.me != 0.0)
        || bow.is_some_and(|b| b.points.iter().any(|p| p.amplitude != 0.0))
        || runout.iter().any(|r| r.amplitude != 0.0)
}

/// What to simulate.
#[derive(Debug, Clone, PartialEq)]
pub struct SimOptions {
    /// Speeds (rpm), in sweep order.
    pub speeds_rpm: Vec<f64>,
    /// Relative noise level s (0 = noise-free).
    pub noise: f64,
    /// Seed of the noise generator.
    pub seed: u64,
    /// Effects.
    pub effects: Effects,
}

impl Default for SimOptions {
    /// `rotorid simulate`'s defaults: 50..15000 rpm in steps of 50 rpm,
    /// noise-free, seed 1, no effects.
    fn default() -> Self {
        SimOptions {
            speeds_rpm: (1..=300).map(|k| 50.0 * k as f64).collect(),
            noise: 0.0,
            seed: 1,
            effects: Effects::default(),
        }
    }
}

/// Adds each runout phasor to its channel at every sample.
pub fn add_runout(m: &mut Measurements, runout: &[Runout]) -> Result<(), SimulateError> {
    for r in runout {
        if r.channel.bearing >= m.n_bearings {
            return Err(SimulateError::RunoutBearing {
                bearing: r.channel.bearing + 1,
                n_bearings: m.n_bearings,
            });
        }
        let z = r.phasor();
        for s in &mut m.samples {
            if let Some(q) = s.q.get_mut(r.channel.index()) {
                *q += z;
            }
        }
    }
    Ok(())
}

/// Multiplies each gain's channel by its factor at every sample (after
/// the runout: a probe's sensitivity scales all it reads).
pub fn apply_probe_gain(m: &mut Measurements, gains: &[ProbeGain]) -> Result<(), SimulateError> {
    for g in gains {
        let bearing = g.channel.bearing + 1;
        if g.channel.bearing >= m.n_bearings {
            return Err(SimulateError::ProbeGain {
                bearing,
                why: format!("the model has {} bearings", m.n_bearings),
            });
        }
        if !(g.factor.is_finite() && g.factor > 0.0) {
            return Err(SimulateError::ProbeGain {
                bearing,
                why: format!("the factor must be finite and > 0, got {}", g.factor),
            });
        }
    }
    for g in gains {
        for s in &mut m.samples {
            if let Some(q) = s.q.get_mut(g.channel.index()) {
                *q *= g.factor;
            }
        }
    }
    Ok(())
}

/// Adds relative complex Gaussian noise: `q += s |q| eps`,
/// `eps = (n1 + j n2) / sqrt(2)`, `n1, n2 ~ N(0, 1)` from ChaCha8 seeded with
/// `seed` (sample by sample, channel by channel, real then imaginary).
pub fn add_noise(m: &mut Measurements, s: f64, seed: u64) -> Result<(), SimulateError> {
    if !(s.is_finite() && s >= 0.0) {
        return Err(SimulateError::Noise(s));
    }
    if s == 0.0 {
        return Ok(());
    }
    add_gaussian(
        m.samples.iter_mut().flat_map(|x| x.q.iter_mut()),
        seed,
        0,
        |q| s * q.norm(),
    );
    Ok(())
}

/// Adds `scale(q) eps` to every phasor `q` of `phasors` in order, `eps =
/// (n1 + j n2) / sqrt(2)`, `n1, n2 ~ N(0, 1)` (real part drawn first) from
/// stream `stream` of ChaCha8 seeded with `seed`.
fn add_gaussian<'a>(
    phasors: impl Iterator<Item = &'a mut Complex64>,
    seed: u64,
    stream: u64,
    scale: impl Fn(Complex64) -> f64,
) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    if stream != 0 {
        rng.set_stream(stream);
    }
    let h = std::f64::consts::FRAC_1_SQRT_2;
    for q in phasors {
        let n1: f64 = StandardNormal.sample(&mut rng);
        let n2: f64 = StandardNormal.sample(&mut rng);
        *q += Complex64::new(n1 * h, n2 * h) * scale(*q);
    }
}

/// Stream of the ChaCha8 generator (seeded with the same seed) that draws
/// the noise floor, apart from the relative noise's stream 0, so that a
/// floor leaves the relative part of the noise unchanged.
pub const FLOOR_NOISE_STREAM: u64 = 2;

/// Stream that chooses the glitched samples ([`add_glitches`]).
pub const GLITCH_STREAM: u64 = 3;

/// Stream that draws the phases of [`random_runout`].
pub const RUNOUT_STREAM: u64 = 4;

/// What a glitch does to a sample: the phasor is multiplied by this (a
/// revolution group averaged across a spike or a dropout of the probe
/// signal, a transient of the monitoring system).
pub const GLITCH_FACTOR: f64 = 8.0;

/// Adds the probe's noise floor: `q += F eps`, `eps = (n1 + j n2) /
/// sqrt(2)`, `n1, n2 ~ N(0, 1)` from stream [`FLOOR_NOISE_STREAM`] of
/// ChaCha8 seeded with `seed` (sample by sample, channel by channel, real
/// then imaginary): with [`add_noise`] the noise of SPEC section 7,
/// `E|e|^2 = F^2 + s^2 |q|^2`. `F` in metres.
pub fn add_floor_noise(m: &mut Measurements, floor: f64, seed: u64) -> Result<(), SimulateError> {
    if !(floor.is_finite() && floor >= 0.0) {
        return Err(SimulateError::NoiseFloor(floor));
    }
    if floor == 0.0 {
        return Ok(());
    }
    add_gaussian(
        m.samples.iter_mut().flat_map(|x| x.q.iter_mut()),
        seed,
        FLOOR_NOISE_STREAM,
        |_| floor,
    );
    Ok(())
}

/// Stream of the node probes' noise floor.
pub const NODE_FLOOR_STREAM: u64 = 5;

/// [`add_floor_noise`] for the node probes' phasors (`y, z` per node per
/// sample), from stream [`NODE_FLOOR_STREAM`].
pub fn add_floor_noise_nodes(
    node_q: &mut [Vec<Complex64>],
    floor: f64,
    seed: u64,
) -> Result<(), SimulateError> {
    if !(floor.is_finite() && floor >= 0.0) {
        return Err(SimulateError::NoiseFloor(floor));
    }
    if floor == 0.0 {
        return Ok(());
    }
    add_gaussian(node_q.iter_mut().flatten(), seed, NODE_FLOOR_STREAM, |_| {
        floor
    });
    Ok(())
}

/// Spoils `k` samples, each a (speed, channel) drawn without repetition
/// from stream [`GLITCH_STREAM`] of ChaCha8 seeded with `seed`: the phasor
/// is multiplied by [`GLITCH_FACTOR`]. Returns the spoilt (sample,
/// channel) pairs in the order drawn. More glitches than samples is an
/// error.
pub fn add_glitches(
    m: &mut Measurements,
    k: usize,
    seed: u64,
) -> Result<Vec<(usize, usize)>, SimulateError> {
    let nq = m.samples.first().map_or(0, |s| s.q.len());
    let total = m.samples.len() * nq;
    if k > total {
        return Err(SimulateError::Glitches { k, total });
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(GLITCH_STREAM);
    let picked = rand::seq::index::sample(&mut rng, total, k);
    let mut out = Vec::with_capacity(k);
    for i in picked.iter() {
        let (n, c) = (i / nq, i % nq);
        m.samples[n].q[c] *= GLITCH_FACTOR;
        out.push((n, c));
    }
    Ok(out)
}

/// A runout of magnitude `amplitude` (m) on every bearing channel of a
/// rotor with `n_bearings` bearings, each with a phase drawn uniformly
/// from stream [`RUNOUT_STREAM`] of ChaCha8 seeded with `seed`.
pub fn random_runout(n_bearings: usize, amplitude: f64, seed: u64) -> Vec<Runout> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(RUNOUT_STREAM);
    let uniform = rand_distr::Uniform::new(0.0, std::f64::consts::TAU)
        .unwrap_or_else(|_| unreachable!("0 < tau"));
    (0..2 * n_bearings)
        .map(|i| Runout {
            channel: crate::model::extension::Channel {
                bearing: i / 2,
                direction: if i % 2 == 0 {
                    crate::model::extension::Direction::Y
                } else {
                    crate::model::extension::Direction::Z
                },
            },
            amplitude,
            phase: uniform.sample(&mut rng),
        })
        .collect()
}

/// `model` with its unbalance scaled so that the total `sum_k m_k e_k`
/// matches balance grade `G` (mm/s) at `omega` (rad/s), the phases and
/// the planes' shares unchanged ([`RotorModel::balance_grade_unbalance`]).
/// `None` when the model has no unbalance.
pub fn at_balance_grade(model: &RotorModel, grade_mm_s: f64, omega: f64) -> Option<RotorModel> {
    let total: f64 = model.unbalance.iter().map(|u| u.me).sum();
    if total.is_nan() || total <= 0.0 {
        return None;
    }
    let g = model.balance_grade_unbalance(grade_mm_s, omega) / total;
    let mut m = model.clone();
    for u in &mut m.unbalance {
        u.me *= g;
    }
    Some(m)
}

/// The bearing-probe response of `model` under `forcing` at the speeds
/// `omegas` (rad/s): one vector `b1_y, b1_z, b2_y, ...` per speed. This is
/// the finite-element part, given as a function so that the rest of the
/// pipeline does not depend on how it is solved.
pub type BearingResponseFn<'a> = dyn Fn(
        &RotorModel,
        &[Unbalance],
        Option<&ShaftBow>,
        &[f64],
    ) -> Result<Vec<Vec<Complex64>>, SimulateError>
    + 'a;

/// The whole pipeline with a given response solver (see [`simulate`]).
pub fn simulate_with(
    model: &RotorModel,
    opts: &SimOptions,
    solve: &BearingResponseFn<'_>,
) -> Result<Measurements, SimulateError> {
    if !(opts.noise.is_finite() && opts.noise >= 0.0) {
        return Err(SimulateError::Noise(opts.noise));
    }
    if opts.speeds_rpm.is_empty() {
        return Err(SimulateError::NoSpeeds);
    }
    if let Some(r) = opts
        .speeds_rpm
        .iter()
        .find(|r| !(r.is_finite() && **r >= 0.0))
    {
        return Err(SimulateError::Speed(*r));
    }
    let m = apply_effects(model, &opts.effects)?;
    let mut unbalance = m.unbalance.clone();
    unbalance.extend_from_slice(&opts.effects.extra_unbalance);
    if !has_excitation(&unbalance, m.bow.as_ref(), &opts.effects.runout) {
        return Err(SimulateError::NoExcitation);
    }
    let omegas: Vec<f64> = opts.speeds_rpm.iter().map(|&r| rpm_to_rad_s(r)).collect();
    let responses = solve(&m, &unbalance, m.bow.as_ref(), &omegas)?;
    let n_b = m.bearings.len();
    if responses.len() != omegas.len() || responses.iter().any(|q| q.len() != 2 * n_b) {
        return Err(SimulateError::ResponseShape);
    }
    let mut comments = vec![
        format!("source: rotorid simulate, model {}", model.name),
        format!(
            "noise: {} (relative, complex Gaussian), seed {}",
            opts.noise, opts.seed
        ),
    ];
    comments.extend(opts.effects.describe());
    let mut out = Measurements {
        comments,
        n_bearings: n_b,
        samples: omegas
            .iter()
            .zip(responses)
            .map(|(&omega, q)| Sample { omega, q })
            .collect(),
        ..Measurements::default()
    };
    add_runout(&mut out, &opts.effects.runout)?;
    apply_probe_gain(&mut out, &opts.effects.probe_gain)?;
    add_noise(&mut out, opts.noise, opts.seed)?;
    Ok(out)
}

/// Simulates `model` with `opts`: the FE unbalance/bow response at the
/// bearing nodes (`response::unbalance_response`), then runout and noise.
///
/// Fails with [`SimulateError::NoExcitation`] when nothing excites the
/// rotor (no unbalance, bow or runout in the model or the effects): an
/// all-zero sweep carries no information.
pub fn simulate(model: &RotorModel, opts: &SimOptions) -> Result<Measurements, SimulateError> {
    simulate_with(model, opts, &fe_bearing_response)
}

/// Stream of the ChaCha8 generator (seeded with the same seed) that draws
/// the node probes' noise, apart from the bearing channels' stream 0, so
/// that adding node probes leaves the bearing channels unchanged.
pub const NODE_NOISE_STREAM: u64 = 1;

/// [`simulate`], with probes at the shaft nodes `nodes` (0-based) too.
///
/// Returns the bearing-probe measurements (exactly those of [`simulate`]
/// with the same options) and, per speed in the same order, the phasors
/// (m) at the node probes, `2 nodes.len()` values `n_y, n_z` per node in
/// the order of `nodes`. A node probe reads the shaft's absolute
/// displacement (the casing is the ground); no runout is added to it. With
/// `opts.noise = s > 0` each node phasor `q` gets `s |q| eps` as the bearing
/// channels do, drawn from stream [`NODE_NOISE_STREAM`] of ChaCha8 seeded
/// with `opts.seed`, sample by sample, node by node, y then z, real part
/// then imaginary part.
pub fn simulate_at_nodes(
    model: &RotorModel,
    opts: &SimOptions,
    nodes: &[usize],
) -> Result<(Measurements, Vec<Vec<Complex64>>), SimulateError> {
    let n_nodes = model.n_nodes();
    if let Some(&n) = nodes.iter().find(|&&n| n >= n_nodes) {
        return Err(SimulateError::ProbeNode {
            node: n + 1,
            n_nodes,
        });
    }
    // One FE solve for both: the solver keeps the node phasors aside.
    let at_nodes = std::cell::RefCell::new(Vec::new());
    let solve = |m: &RotorModel,
                 unbalance: &[Unbalance],
                 bow: Option<&ShaftBow>,
                 omegas: &[f64]|
     -> Result<Vec<Vec<Complex64>>, SimulateError> {
        let (bearings, q_nodes) = fe_response(m, unbalance, bow, omegas, nodes)?;
        *at_nodes.borrow_mut() = q_nodes;
        Ok(bearings)
    };
    let measured = simulate_with(model, opts, &solve)?;
    let mut q_nodes = at_nodes.into_inner();
    if q_nodes.len() != measured.samples.len() {
        return Err(SimulateError::ResponseShape);
    }
    if opts.noise > 0.0 {
        add_gaussian(
            q_nodes.iter_mut().flatten(),
            opts.seed,
            NODE_NOISE_STREAM,
            |q| opts.noise * q.norm(),
        );
    }
    Ok((measured, q_nodes))
}

/// The finite-element response at the bearing probes: the shaft's
/// displacement at each bearing node (`Response::bearings`), less the
/// pedestal's (`Response::pedestals`) for relative probes, one banded LU
/// per speed.
fn fe_bearing_response(
    model: &RotorModel,
    unbalance: &[Unbalance],
    bow: Option<&ShaftBow>,
    omegas: &[f64],
) -> Result<Vec<Vec<Complex64>>, SimulateError> {
    Ok(fe_response(model, unbalance, bow, omegas, &[])?.0)
}

/// [`fe_bearing_response`], and the shaft's absolute `y, z` displacement
/// (m) at the nodes `nodes` (0-based), `2 nodes.len()` values per speed.
#[allow(clippy::type_complexity)]
fn fe_response(
    model: &RotorModel,
    unbalance: &[Unbalance],
    bow: Option<&ShaftBow>,
    omegas: &[f64],
    nodes: &[usize],
) -> Result<(Vec<Vec<Complex64>>, Vec<Vec<Complex64>>), SimulateError> {
    let fe = FeModel::new(model)?;
    let forcing = Forcing {
        unbalance: unbalance.to_vec(),
        bow: bow.cloned(),
    };
    let responses = unbalance_response(&fe, &forcing, omegas)?;
    let mut at_nodes = Vec::with_capacity(responses.len());
    let mut at_bearings = Vec::with_capacity(responses.len());
    for r in responses {
        let mut q = Vec::with_capacity(2 * nodes.len());
        for &n in nodes {
            for dir in [Dir::Y, Dir::Z] {
                q.push(
                    r.q.get(fe.dof(n, dir))
                        .copied()
                        .ok_or(SimulateError::ResponseShape)?,
                );
            }
        }
        at_nodes.push(q);
        at_bearings.push(match model.probes {
            // The probe on a pedestal reads the shaft relative to it.
            ProbeReference::Relative => r
                .bearings
                .iter()
                .zip(&r.pedestals)
                .map(|(s, p)| s - p)
                .collect(),
            ProbeReference::Absolute => r.bearings,
        });
    }
    Ok((at_bearings, at_nodes))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::extension::Channel;

    fn flat(n_b: usize, speeds: usize, v: Complex64) -> Measurements {
        Measurements {
            comments: vec![],
            n_bearings: n_b,
            samples: (0..speeds)
                .map(|i| Sample {
                    omega: i as f64,
                    q: vec![v; 2 * n_b],
                })
                .collect(),
            ..Measurements::default()
        }
    }

    #[test]
    fn noise_statistics_and_reproducibility() {
        let q0 = Complex64::new(3e-6, -4e-6);
        let s = 0.01;
        let mut a = flat(2, 50_000, q0);
        add_noise(&mut a, s, 7).unwrap();
        let mut b = flat(2, 50_000, q0);
        add_noise(&mut b, s, 7).unwrap();
        assert_eq!(a, b);
        let mut c = flat(2, 50_000, q0);
        add_noise(&mut c, s, 8).unwrap();
        assert_ne!(a, c);
        let n = (a.samples.len() * 4) as f64;
        let (mut p, mut re2, mut im2, mut mean) = (0.0, 0.0, 0.0, Complex64::new(0.0, 0.0));
        for smp in &a.samples {
            for q in &smp.q {
                let e = (q - q0) / (s * q0.norm());
                p += e.norm_sqr();
                re2 += e.re * e.re;
                im2 += e.im * e.im;
                mean += e;
            }
        }
        // 200000 draws: standard error of the mean power is sqrt(1/n) ~ 0.0022.
        assert!((p / n - 1.0).abs() < 0.01, "E|eps|^2 = {}", p / n);
        assert!((re2 / n - 0.5).abs() < 0.01);
        assert!((im2 / n - 0.5).abs() < 0.01);
        assert!((mean / n).norm() < 0.01);
        // Noise-free stays exact.
        let mut d = flat(1, 3, q0);
        add_noise(&mut d, 0.0, 1).unwrap();
        assert_eq!(d, flat(1, 3, q0));
        assert!(add_noise(&mut d, f64::NAN, 1).is_err());
    }

    #[test]
    fn runout_is_constant() {
        let mut m = flat(2, 5, Complex64::new(0.0, 0.0));
        let r = Runout {
            channel: Channel::parse("b2_y", 2).unwrap(),
            amplitude: 2e-6,
            phase: 0.5,
        };
        add_runout(&mut m, &[r]).unwrap();
        for s in &m.samples {
            assert_eq!(s.q[2], Complex64::from_polar(2e-6, 0.5));
            assert_eq!(s.q[0], Complex64::new(0.0, 0.0));
        }
    }
}
