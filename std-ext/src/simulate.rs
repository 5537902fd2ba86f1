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
//!    any extra unbalance planes; the probe signal is the shaft's absolute
//!    displacement at each bearing node, channels `b1_y, b1_z, b2_y, ...`;
//! 3. probe runout phasors are added, constant across speed ([`add_runout`]);
//! 4. noise: every complex sample `q` of every channel gets `s |q| eps`,
//!    `eps` standard complex Gaussian (`E|eps|^2 = 1`: real and imaginary
//!    parts independent `N(0, 1/2)`), drawn from a ChaCha8 generator seeded
//!    with `seed`, in the order sample by sample, channel by channel, real
//!    part then imaginary part ([`add_noise`]). Same seed, same data.

use num_complex::Complex64;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use thiserror::Error;

use crate::assembly::FeModel;
use crate::measurement::{Measurements, Sample};
use crate::model::{BearingLaw, BowPoint, ModelError, Pedestal, RotorModel, ShaftBow, Unbalance};
use crate::response::{unbalance_response, Forcing};
use crate::units::rpm_to_rad_s;

/// Error of the simulator.
#[derive(Debug, Error)]
pub enum SimulateError {
    /// The model (after effects) is invalid.
    #[error("{0}")]
    Model(#[from] ModelError),
    /// Bad speed grid.
    #[error("speed grid: {0}")]
    Grid(String),
    /// An effect cannot be applied to this model.
    #[error("{0}")]
    Effect(String),
    /// Bad noise level.
    #[error("noise level must be finite and >= 0, got {0}")]
    Noise(f64),
    /// The finite-element solve failed.
    #[error("finite-element response: {0}")]
    Solver(String),
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
                p.mass, p.k[0], p.k[1], p.c[0], p.c[1]
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
                "effect: runout on b{}_{}: {} m at {} deg",
                r.channel.bearing + 1,
                match r.channel.direction {
                    Direction::Y => "y",
                    Direction::Z => "z",
                },
                r.amplitude,
                r.phase.to_degrees()
            ));
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

/// The uniform grid `rpm_min, rpm_min + step, ...` up to and including
/// `rpm_max` when it falls on the grid (within 1e-9 of a step). Counted
/// with integers, `rpm_i = rpm_min + i step`, never by accumulation.
pub fn uniform_rpm_grid(rpm_min: f64, rpm_max: f64, step: f64) -> Result<Vec<f64>, SimulateError> {
    if !(rpm_min.is_finite() && rpm_min >= 0.0) {
        return Err(SimulateError::Grid(format!(
            "--rpm-min must be finite and >= 0, got {rpm_min}"
        )));
    }
    if !(rpm_max.is_finite() && rpm_max >= rpm_min) {
        return Err(SimulateError::Grid(format!(
            "--rpm-max must be finite and >= --rpm-min ({rpm_min}), got {rpm_max}"
        )));
    }
    if !(step.is_finite() && step > 0.0) {
        return Err(SimulateError::Grid(format!(
            "--rpm-step must be finite and > 0, got {step}"
        )));
    }
    let span = (rpm_max - rpm_min) / step;
    const MAX_POINTS: f64 = 10_000_000.0;
    if span >= MAX_POINTS {
        return Err(SimulateError::Grid(format!(
            "{} speeds is too many (at most {MAX_POINTS})",
            span.floor() + 1.0
        )));
    }
    let n = (span + 1e-9).floor() as usize + 1;
    Ok((0..n).map(|i| rpm_min + i as f64 * step).collect())
}

/// The model with the model-changing effects applied: shaft modulus scale,
/// speed-dependent bearing stiffness, pedestals, extra bow points. The
/// forcing effects (extra unbalance, runout) are applied by [`simulate`].
pub fn apply_effects(model: &RotorModel, effects: &Effects) -> Result<RotorModel, SimulateError> {
    let mut m = model.clone();
    if !(effects.e_scale.is_finite() && effects.e_scale > 0.0) {
        return Err(SimulateError::Effect(format!(
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
            return Err(SimulateError::Effect(format!(
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
                BearingLaw::Table { .. } => {
                    return Err(SimulateError::Effect(format!(
                        "bearing {} has a coefficient table: speed scaling applies to constant or polynomial bearings only",
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
            return Err(SimulateError::Effect(format!(
                "extra unbalance: node {} is not on the shaft (nodes 1..={})",
                u.node + 1,
                m.n_nodes()
            )));
        }
    }
    Ok(m)
}

/// Adds each runout phasor to its channel at every sample.
pub fn add_runout(m: &mut Measurements, runout: &[Runout]) -> Result<(), SimulateError> {
    for r in runout {
        if r.channel.bearing >= m.n_bearings {
            return Err(SimulateError::Effect(format!(
                "runout on bearing {}: the model has {} bearings",
                r.channel.bearing + 1,
                m.n_bearings
            )));
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
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let h = std::f64::consts::FRAC_1_SQRT_2;
    for sample in &mut m.samples {
        for q in &mut sample.q {
            let n1: f64 = StandardNormal.sample(&mut rng);
            let n2: f64 = StandardNormal.sample(&mut rng);
            *q += Complex64::new(n1 * h, n2 * h) * (s * q.norm());
        }
    }
    Ok(())
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
        return Err(SimulateError::Grid("no speeds".into()));
    }
    if let Some(r) = opts
        .speeds_rpm
        .iter()
        .find(|r| !(r.is_finite() && **r >= 0.0))
    {
        return Err(SimulateError::Grid(format!(
            "speeds must be finite and >= 0 rpm, got {r}"
        )));
    }
    let m = apply_effects(model, &opts.effects)?;
    let mut unbalance = m.unbalance.clone();
    unbalance.extend_from_slice(&opts.effects.extra_unbalance);
    let omegas: Vec<f64> = opts.speeds_rpm.iter().map(|&r| rpm_to_rad_s(r)).collect();
    let responses = solve(&m, &unbalance, m.bow.as_ref(), &omegas)?;
    let n_b = m.bearings.len();
    if responses.len() != omegas.len() || responses.iter().any(|q| q.len() != 2 * n_b) {
        return Err(SimulateError::Solver(
            "response has the wrong number of speeds or channels".into(),
        ));
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
    };
    add_runout(&mut out, &opts.effects.runout)?;
    add_noise(&mut out, opts.noise, opts.seed)?;
    Ok(out)
}

/// Simulates `model` with `opts`: the FE unbalance/bow response at the
/// bearing nodes (`response::unbalance_response`), then runout and noise.
pub fn simulate(model: &RotorModel, opts: &SimOptions) -> Result<Measurements, SimulateError> {
    simulate_with(model, opts, &fe_bearing_response)
}

/// The finite-element response at the bearing probes: the shaft's absolute
/// displacement at each bearing node (`Response::bearings`), one banded LU
/// per speed.
fn fe_bearing_response(
    model: &RotorModel,
    unbalance: &[Unbalance],
    bow: Option<&ShaftBow>,
    omegas: &[f64],
) -> Result<Vec<Vec<Complex64>>, SimulateError> {
    let fe = FeModel::new(model).map_err(|e| SimulateError::Solver(e.to_string()))?;
    let forcing = Forcing {
        unbalance: unbalance.to_vec(),
        bow: bow.cloned(),
    };
    let responses = unbalance_response(&fe, &forcing, omegas)
        .map_err(|e| SimulateError::Solver(e.to_string()))?;
    Ok(responses.into_iter().map(|r| r.bearings).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_includes_max_on_grid_only() {
        let g = uniform_rpm_grid(50.0, 15000.0, 50.0).unwrap();
        assert_eq!(g.len(), 300);
        assert_eq!(*g.last().unwrap(), 15000.0);
        let g = uniform_rpm_grid(0.0, 1.0, 0.1).unwrap();
        assert_eq!(g.len(), 11);
        assert!((g[10] - 1.0).abs() < 1e-12);
        let g = uniform_rpm_grid(0.0, 1.05, 0.1).unwrap();
        assert_eq!(g.len(), 11);
        assert_eq!(uniform_rpm_grid(100.0, 100.0, 50.0).unwrap(), vec![100.0]);
        assert!(uniform_rpm_grid(100.0, 50.0, 50.0).is_err());
        assert!(uniform_rpm_grid(0.0, 50.0, 0.0).is_err());
        assert!(uniform_rpm_grid(-1.0, 50.0, 1.0).is_err());
        assert!(uniform_rpm_grid(0.0, f64::NAN, 1.0).is_err());
        assert!(uniform_rpm_grid(0.0, 1e12, 1e-3).is_err());
    }

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
                mass: 20.0,
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
