//! A run-up or coast-down in the time domain: the full FE model integrated
//! through a constant-rate speed ramp ([`crate::fe::transient`]), sampled
//! as probe and keyphasor signals (SPEC section 8's layout), and the 1X
//! vectors extracted from them by the core's order tracker
//! ([`rotorid_core::ordertrack`]). A check of the steady-state simulator
//! that does not come from it: the vectors agree with [`super::simulate`]
//! within the noise when the sweep is slow.
//!
//! # Signals
//!
//! Sampled at `f_s` (Hz), `t_k = k / f_s`, with `r` Newmark steps per
//! sample (`h = 1 / (r f_s)`):
//!
//! - bearing channels `bK_y, bK_z`: the shaft's displacement at the bearing
//!   node, relative to the pedestal for `probes = "relative"` (m), as the
//!   steady-state simulator's;
//! - node probes `nN_y, nN_z`: the shaft's absolute displacement (m);
//! - the keyphasor `kp`: a pulse of height 1 once a revolution whose
//!   rising edge is linear in the rotor angle `theta` across
//!   `theta = 2 pi k +- KP_EDGE` ([`keyphasor_pulse`]), so that the
//!   crossing of the midway level 0.5 is at `theta = 2 pi k`: the mark at
//!   the rotor's angle 0 under a keyphasor probe on +y (SPEC section 8).
//!
//! # Noise
//!
//! Chosen so that the 1X of one revolution carries SPEC section 7's noise,
//! `E|e|^2 = f^2 + s^2 |Y|^2`. With `M = 2 pi f_s / Omega` samples per
//! revolution, the one-revolution 1X of white noise of variance `sigma^2`
//! is `E|dY|^2 = 4 sigma^2 / M`, and of a multiplicative `y (1 + sigma_r
//! n)` on `y = A cos(theta + phi)` it is `2 A^2 sigma_r^2 / M`. Hence at
//! every sample
//!
//! ```text
//! y_k <- y_k (1 + sigma_r n_k) + sigma_f m_k,
//! sigma_f^2 = f^2 M / 4,     sigma_r^2 = s^2 M / 2,
//! ```
//!
//! `n_k, m_k ~ N(0, 1)` from ChaCha8 seeded with `seed`, stream
//! [`TRANSIENT_NOISE_STREAM`] (sample by sample, channel by channel,
//! relative then floor). An average of `N` revolutions then has
//! `E|e|^2 = (f^2 + s^2 |Y|^2) / N`.

use std::fmt::Write as _;

use num_complex::Complex64;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use rotorid_core::ordertrack::{Config, Counts, OrderTracker};
use thiserror::Error;

use crate::fe::assembly::{Dir, FeError, FeModel};
use crate::fe::response::Forcing;
use crate::fe::transient::{Integrator, Ramp};
use crate::io::measurement::{Measurements, Sample};
use crate::model::{ModelError, ProbeReference, RotorModel};
use crate::units::rpm_to_rad_s;

/// Stream of the ChaCha8 generator that draws the signals' noise.
pub const TRANSIENT_NOISE_STREAM: u64 = 6;

/// Half width of the keyphasor pulse's rising edge in rotor angle (rad):
/// the edge spans `4 pi / 32` rad, two samples at 32 samples a revolution.
pub const KP_EDGE: f64 = std::f64::consts::PI / 16.0;

/// Plateau of the keyphasor pulse (rad of rotor angle).
pub const KP_PLATEAU: f64 = std::f64::consts::PI / 4.0;

/// Channels per order tracker (the core's tracker is const-generic).
const NC: usize = 4;

/// Buffer of one tracker (samples of one revolution): the slowest
/// revolution the extraction takes is `CAP - 8` samples.
pub const TRACKER_CAPACITY: usize = 8192;

/// Error of the time-domain simulation or the extraction.
#[derive(Debug, Error)]
pub enum TransientError {
    /// The model is invalid.
    #[error("{0}")]
    Model(#[from] ModelError),
    /// The integration failed.
    #[error("time integration: {0}")]
    Fe(#[from] FeError),
    /// An option out of range (named).
    #[error("{0}")]
    Invalid(String),
    /// The order tracker refused its configuration.
    #[error("order tracker: {0}")]
    Tracker(String),
}

/// The speed profile, sampling and noise of a time-domain sweep.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepOptions {
    /// Speed at the start (rpm).
    pub rpm_start: f64,
    /// Speed at the end (rpm); equal to `rpm_start` for a constant speed.
    pub rpm_end: f64,
    /// Rate of the ramp (rpm/s, `> 0`; its sign comes from start and end).
    /// Ignored at constant speed.
    pub rate_rpm_per_s: f64,
    /// Duration at constant speed (s); ignored for a ramp.
    pub duration_s: f64,
    /// Sample rate (Hz).
    pub sample_rate: f64,
    /// Newmark steps per sample (`>= 1`).
    pub substeps: usize,
    /// Relative noise `s` of one revolution's 1X.
    pub noise: f64,
    /// Noise floor `f` of one revolution's 1X (m).
    pub noise_floor: f64,
    /// Seed of the noise.
    pub seed: u64,
    /// Probes at these shaft nodes (0-based) too.
    pub node_probes: Vec<usize>,
}

impl SweepOptions {
    /// A coast-down or run-up from `rpm_start` to `rpm_end` at
    /// `rate_rpm_per_s`, sampled at `sample_rate` Hz, one Newmark step per
    /// sample, noise-free, seed 1.
    pub fn ramp(rpm_start: f64, rpm_end: f64, rate_rpm_per_s: f64, sample_rate: f64) -> Self {
        SweepOptions {
            rpm_start,
            rpm_end,
            rate_rpm_per_s,
            duration_s: 0.0,
            sample_rate,
            substeps: 1,
            noise: 0.0,
            noise_floor: 0.0,
            seed: 1,
            node_probes: Vec::new(),
        }
    }

    /// `duration_s` at `rpm` (see [`SweepOptions::ramp`]).
    pub fn constant(rpm: f64, duration_s: f64, sample_rate: f64) -> Self {
        SweepOptions {
            duration_s,
            ..SweepOptions::ramp(rpm, rpm, 0.0, sample_rate)
        }
    }

    /// The ramp (rad/s, rad/s^2) and its duration (s).
    fn profile(&self) -> Result<(Ramp, f64), TransientError> {
        let fin = |x: f64| x.is_finite();
        if !(fin(self.rpm_start) && self.rpm_start > 0.0 && fin(self.rpm_end) && self.rpm_end > 0.0)
        {
            return Err(TransientError::Invalid(format!(
                "sweep speeds must be finite and > 0 rpm, got {} and {}",
                self.rpm_start, self.rpm_end
            )));
        }
        if !(fin(self.sample_rate) && self.sample_rate > 0.0) {
            return Err(TransientError::Invalid(format!(
                "sample rate must be finite and > 0 Hz, got {}",
                self.sample_rate
            )));
        }
        if self.substeps == 0 {
            return Err(TransientError::Invalid(
                "substeps must be at least 1".into(),
            ));
        }
        if !(fin(self.noise)
            && self.noise >= 0.0
            && fin(self.noise_floor)
            && self.noise_floor >= 0.0)
        {
            return Err(TransientError::Invalid(format!(
                "noise must be finite and >= 0, got {} relative, {} m floor",
                self.noise, self.noise_floor
            )));
        }
        let w0 = rpm_to_rad_s(self.rpm_start);
        if self.rpm_start == self.rpm_end {
            if !(fin(self.duration_s) && self.duration_s > 0.0) {
                return Err(TransientError::Invalid(format!(
                    "duration at constant speed must be finite and > 0 s, got {}",
                    self.duration_s
                )));
            }
            return Ok((
                Ramp {
                    omega0: w0,
                    alpha: 0.0,
                    theta0: 0.0,
                },
                self.duration_s,
            ));
        }
        if !(fin(self.rate_rpm_per_s) && self.rate_rpm_per_s > 0.0) {
            return Err(TransientError::Invalid(format!(
                "sweep rate must be finite and > 0 rpm/s, got {}",
                self.rate_rpm_per_s
            )));
        }
        let dur = (self.rpm_end - self.rpm_start).abs() / self.rate_rpm_per_s;
        let alpha = rpm_to_rad_s(self.rate_rpm_per_s) * (self.rpm_end - self.rpm_start).signum();
        Ok((
            Ramp {
                omega0: w0,
                alpha,
                theta0: 0.0,
            },
            dur,
        ))
    }

    /// The signed rate (rpm/s): negative on a coast-down, 0 at constant speed.
    pub fn signed_rate(&self) -> f64 {
        if self.rpm_start == self.rpm_end {
            0.0
        } else {
            self.rate_rpm_per_s * (self.rpm_end - self.rpm_start).signum()
        }
    }
}

/// Sampled signals of a sweep, SPEC section 8's columns.
#[derive(Debug, Clone, PartialEq)]
pub struct Signals {
    /// Probe channel names (`b1_y, b1_z, ..., nN_y, nN_z`).
    pub channels: Vec<String>,
    /// Bearings of the model.
    pub n_bearings: usize,
    /// Node probes (0-based).
    pub node_probes: Vec<usize>,
    /// Sample rate (Hz).
    pub sample_rate: f64,
    /// Signed sweep rate (rpm/s).
    pub rate_rpm_per_s: f64,
    /// Keyphasor samples.
    pub kp: Vec<f64>,
    /// Probe samples, one row of `channels.len()` values per sample (m).
    pub y: Vec<Vec<f64>>,
}

impl Signals {
    /// Time of sample `k` (s).
    pub fn time(&self, k: usize) -> f64 {
        k as f64 / self.sample_rate
    }

    /// SPEC section 8's CSV: comment lines, `time_s,kp,b1_y,...`, one row
    /// per sample (shortest round-trip numbers).
    pub fn to_csv(&self, comments: &[String]) -> String {
        let mut s = String::new();
        for c in comments {
            let _ = writeln!(s, "# {c}");
        }
        let _ = writeln!(s, "# sweep: rate_rpm_per_s={}", self.rate_rpm_per_s);
        let _ = writeln!(s, "time_s,kp,{}", self.channels.join(","));
        for (k, (kp, row)) in self.kp.iter().zip(&self.y).enumerate() {
            let _ = write!(s, "{:e},{kp:e}", self.time(k));
            for v in row {
                let _ = write!(s, ",{v:e}");
            }
            s.push('\n');
        }
        s
    }
}

/// The keyphasor signal at rotor angle `theta` (rad): with `psi = (theta +
/// KP_EDGE) mod 2 pi`, `psi / (2 KP_EDGE)` on the rising edge, 1 on the
/// plateau `KP_PLATEAU`, a falling edge as long as the rising one, 0 for
/// the rest of the revolution. The level 0.5 is crossed upward at `theta =
/// 2 pi k`.
pub fn keyphasor_pulse(theta: f64) -> f64 {
    let psi = (theta + KP_EDGE).rem_euclid(std::f64::consts::TAU);
    let e = 2.0 * KP_EDGE;
    if psi < e {
        psi / e
    } else if psi < e + KP_PLATEAU {
        1.0
    } else if psi < 2.0 * e + KP_PLATEAU {
        1.0 - (psi - e - KP_PLATEAU) / e
    } else {
        0.0
    }
}

/// The probe channels' DOFs: per channel, the shaft DOF and the pedestal
/// DOF it is read relative to (if any).
fn channel_dofs(fe: &FeModel, nodes: &[usize]) -> (Vec<String>, Vec<(usize, Option<usize>)>) {
    let model = fe.model();
    let mut names = Vec::new();
    let mut dofs = Vec::new();
    for (bi, b) in model.bearings.iter().enumerate() {
        for (dir, tag) in [(Dir::Y, "y"), (Dir::Z, "z")] {
            names.push(format!("b{}_{tag}", bi + 1));
            let rel = match model.probes {
                ProbeReference::Relative => fe.pedestal_dof(bi, dir),
                ProbeReference::Absolute => None,
            };
            dofs.push((fe.dof(b.node, dir), rel));
        }
    }
    for &n in nodes {
        for (dir, tag) in [(Dir::Y, "y"), (Dir::Z, "z")] {
            names.push(format!("n{}_{tag}", n + 1));
            dofs.push((fe.dof(n, dir), None));
        }
    }
    (names, dofs)
}

/// Integrates `model` (its unbalance and bow) through the sweep of `opts`
/// and samples the signals (see the module documentation).
pub fn signals(model: &RotorModel, opts: &SweepOptions) -> Result<Signals, TransientError> {
    let (ramp, duration) = opts.profile()?;
    let n_nodes = model.n_nodes();
    if let Some(&n) = opts.node_probes.iter().find(|&&n| n >= n_nodes) {
        return Err(TransientError::Invalid(format!(
            "node probe at node {}: the shaft has nodes 1..={n_nodes}",
            n + 1
        )));
    }
    let fe = FeModel::new(model)?;
    let forcing = Forcing::from_model(model);
    let h = 1.0 / (opts.sample_rate * opts.substeps as f64);
    let mut it = Integrator::new(&fe, &forcing, ramp, h)?;
    let (channels, dofs) = channel_dofs(&fe, &opts.node_probes);
    let n_samples = (duration * opts.sample_rate).floor() as usize + 1;
    let mut rng = ChaCha8Rng::seed_from_u64(opts.seed);
    rng.set_stream(TRANSIENT_NOISE_STREAM);
    let noisy = opts.noise > 0.0 || opts.noise_floor > 0.0;
    let mut kp = Vec::with_capacity(n_samples);
    let mut y = Vec::with_capacity(n_samples);
    for k in 0..n_samples {
        if k > 0 {
            for _ in 0..opts.substeps {
                it.step()?;
            }
        }
        let t = k as f64 / opts.sample_rate;
        kp.push(keyphasor_pulse(ramp.theta(t)));
        let per_rev = std::f64::consts::TAU * opts.sample_rate / ramp.omega(t).max(1e-9);
        let sig_f = opts.noise_floor * (per_rev / 4.0).sqrt();
        let sig_r = opts.noise * (per_rev / 2.0).sqrt();
        let row: Vec<f64> = dofs
            .iter()
            .map(|&(d, rel)| {
                let mut v = it.displacement(d) - rel.map_or(0.0, |p| it.displacement(p));
                if noisy {
                    let n: f64 = StandardNormal.sample(&mut rng);
                    let m: f64 = StandardNormal.sample(&mut rng);
                    v = v * (1.0 + sig_r * n) + sig_f * m;
                }
                v
            })
            .collect();
        y.push(row);
    }
    Ok(Signals {
        channels,
        n_bearings: model.bearings.len(),
        node_probes: opts.node_probes.clone(),
        sample_rate: opts.sample_rate,
        rate_rpm_per_s: opts.signed_rate(),
        kp,
        y,
    })
}

/// 1X vectors extracted from [`Signals`].
#[derive(Debug, Clone, PartialEq)]
pub struct Extracted {
    /// One sample per average of `revolutions` revolutions, in time order:
    /// the mean speed and the bearing channels' mean 1X (node probes in
    /// `node_q`), comment `# sweep: rate_rpm_per_s=...`.
    pub measurements: Measurements,
    /// Standard error of each vector (m), per sample per channel (bearing
    /// channels, then node probes): `E|dY|^2 = std^2`.
    pub std: Vec<Vec<f64>>,
    /// The tracker's revolution counts (of its first channel group).
    pub counts: Counts,
}

/// Runs the core's order tracker ([`OrderTracker`], `f64`, groups of four
/// channels with the same keyphasor) over `sig`: averages of
/// `revolutions` revolutions (scatter about the trend), speeds between
/// `0.9` of the slowest and `1.1` of the fastest revolution the buffer of
/// [`TRACKER_CAPACITY`] samples holds. The tracker's state is large
/// (`CAP (NC + 1)` floats), so it runs on a thread of its own with a large
/// stack.
pub fn vectors(sig: &Signals, revolutions: u32) -> Result<Extracted, TransientError> {
    let sig = sig.clone();
    std::thread::Builder::new()
        .stack_size(64 << 20)
        .spawn(move || vectors_on_this_thread(&sig, revolutions))
        .map_err(|e| TransientError::Tracker(format!("cannot start its thread: {e}")))?
        .join()
        .map_err(|_| TransientError::Tracker("its thread panicked".into()))?
}

/// One average of one channel group: speed (rad/s), 1X vectors, their
/// standard errors.
type GroupAverage = (f64, [Complex64; NC], [f64; NC]);

fn vectors_on_this_thread(sig: &Signals, revolutions: u32) -> Result<Extracted, TransientError> {
    let fs = sig.sample_rate;
    let nc = sig.channels.len();
    let slowest = std::f64::consts::TAU * fs / (TRACKER_CAPACITY - 8) as f64;
    let config = Config::new(fs, 0.5, slowest, 1e6 * slowest)
        .with_revolutions(revolutions)
        .with_min_samples(32);
    let groups = nc.div_ceil(NC);
    let mut trackers = Vec::with_capacity(groups);
    for _ in 0..groups {
        trackers.push(Box::new(
            OrderTracker::<f64, NC, TRACKER_CAPACITY>::new(config)
                .map_err(|e| TransientError::Tracker(format!("{e:?}")))?,
        ));
    }
    // Per group: (speed, vectors, std) of each average.
    let mut out: Vec<Vec<GroupAverage>> = vec![Vec::new(); groups];
    for (kp, row) in sig.kp.iter().zip(&sig.y) {
        for (g, tr) in trackers.iter_mut().enumerate() {
            let mut y = [0.0; NC];
            for (c, v) in y.iter_mut().enumerate() {
                *v = row.get(g * NC + c).copied().unwrap_or(0.0);
            }
            if let Some(o) = tr.push(*kp, &y) {
                if let Some(a) = o.average {
                    out[g].push((a.speed, a.x1, a.x1_std));
                }
            }
        }
    }
    let counts = *trackers[0].counts();
    let n_avg = out[0].len();
    if out.iter().any(|o| o.len() != n_avg) {
        return Err(TransientError::Tracker(
            "channel groups gave different numbers of averages".into(),
        ));
    }
    let nb = 2 * sig.n_bearings;
    let mut samples = Vec::with_capacity(n_avg);
    let mut node_q = Vec::new();
    let mut std = Vec::with_capacity(n_avg);
    for (i, first) in out[0].iter().enumerate() {
        let mut q = Vec::with_capacity(nc);
        let mut s = Vec::with_capacity(nc);
        for c in 0..nc {
            let (_, x, e) = &out[c / NC][i];
            q.push(x[c % NC]);
            s.push(e[c % NC]);
        }
        node_q.push(q.split_off(nb));
        samples.push(Sample { omega: first.0, q });
        std.push(s);
    }
    if sig.node_probes.is_empty() {
        node_q.clear();
    }
    Ok(Extracted {
        measurements: Measurements {
            comments: vec![
                format!(
                    "source: order tracking of {} samples at {} Hz, {revolutions} revolutions per vector",
                    sig.kp.len(),
                    fs
                ),
                format!("sweep: rate_rpm_per_s={}", sig.rate_rpm_per_s),
            ],
            n_bearings: sig.n_bearings,
            samples,
            node_probes: sig.node_probes.clone(),
            node_q,
        },
        std,
        counts,
    })
}
