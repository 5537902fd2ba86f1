//! The identification runs of the firmware, shared word for word with its
//! host check (`examples/firmware_host.rs`), with the identifier `FwId` of
//! the enclosing module (the generated table's `type Id`, square-root-free
//! block filter, f32, or another filter of the same structure):
//!
//! 1. vectors: the identifier folds in the measured sweep (`SWEEP`, 1X
//!    phasors per speed) directly;
//! 2. samples: a coast-down's keyphasor and probe samples, generated from
//!    the same sweep's phasors ([`crate::coastdown`], 6 656 Hz, 12 100 to
//!    2 900 rpm), go through the order tracker
//!    (`rotorid_core::streamtrack::StreamTracker`, 4 probes, each sample
//!    integrated as it comes, no revolution buffered), whose averages of 8
//!    revolutions feed the identifier.
//!
//! Each value is printed as a fixed-point decimal (integer arithmetic on
//! the `f32`, truncated) followed by its `f32` bit pattern in hex, so equal
//! lines mean bit-identical estimates. (Core's float formatting would add
//! about 10 KiB of flash.)

use super::FwId as Id;
use crate::coastdown::{Coastdown, Setup};
use crate::sweep::SWEEP;
use crate::table::{SCALING, STRUCTURE, TABLE};
use core::fmt::{self, Write};
use rotorid_core::identify::{Config, Estimates, IdentifierError};
use rotorid_core::ordertrack::{Config as TrackerConfig, ConfigError};
use rotorid_core::parametrization::COEFFICIENTS;
use rotorid_core::streamtrack::{SampleOutcome, StreamAverage};

/// Hooks around each identifier update, tracker push and generated sample
/// (stack painting, instruction-count markers on the target; nothing on the
/// host).
pub trait Probe {
    /// Right before `Id::update`.
    fn before_update(&mut self) {}
    /// Right after `Id::update`.
    fn after_update(&mut self) {}
    /// Right before `StreamTracker::push`.
    fn before_push(&mut self) {}
    /// Right after `StreamTracker::push`.
    fn after_push(&mut self) {}
    /// Right before `Coastdown::next_sample`.
    fn before_sample(&mut self) {}
    /// Right after `Coastdown::next_sample`.
    fn after_sample(&mut self) {}
}

/// Probe channels (b1_y, b1_z, b2_y, b2_z).
pub use crate::tracking::NC;

/// The order tracker of the sample run (f32, 4 probes; 16 samples of
/// history, no revolution buffer).
pub use crate::tracking::Tracker;

/// Sampling instants per block of the tracker.
pub use crate::tracking::BLOCK_LEN;

/// `n` rpm in rad/s.
fn rpm(n: f32) -> f32 {
    n * (core::f32::consts::PI / 30.0)
}

/// Sample rate of the probes and the keyphasor (Hz), the usual rate of a
/// vibration data acquisition: 128 samples per revolution at 12 000 rpm,
/// 512 at 3 000 rpm. (The streaming tracker keeps no revolution, so the
/// rate costs no RAM; each revolution's fixed work is shared by more
/// samples.)
pub const SAMPLE_RATE: f32 = 25_600.0;

/// The tracker's configuration: 3 000..12 000 rpm, a 0..1 keyphasor with
/// level 0.5 and hysteresis 0.2, the probes' ADC range 0..50 mm, averages
/// of 8 revolutions, scatter about the trend.
pub fn tracker_config() -> TrackerConfig<f32> {
    TrackerConfig::new(SAMPLE_RATE, 0.5, rpm(3000.0), rpm(12_000.0))
        .with_hysteresis(0.2)
        .with_adc_range(0.0, 50.0e-3)
        .with_revolutions(8)
}

/// A tracker with [`tracker_config`] (the firmware keeps it in a static).
pub fn tracker() -> Result<Tracker, ConfigError> {
    Tracker::new(tracker_config())
}

/// The coast-down: 12 100 to 2 900 rpm at `crate::DECELERATION`
/// (150 rad/s^2: 6.4 s, 801 revolutions, 164 432 samples), a 2X of 5 % of
/// the 1X, probe gaps of 25..26 mm, probe noise 5 um + 2 % of the 1X per
/// sample.
pub fn coastdown_setup() -> Setup<NC> {
    Setup {
        sample_rate: SAMPLE_RATE,
        speed_start: rpm(12_100.0),
        speed_end: rpm(2900.0),
        deceleration: crate::DECELERATION,
        x2_ratio: rotorid_core::Complex::new(0.027, 0.042),
        gap: [25.0e-3, 25.5e-3, 26.0e-3, 25.5e-3],
        noise_floor: 5e-6,
        noise_relative: 0.02,
        seed: 1,
    }
}

/// Why a run stopped.
#[derive(Debug)]
pub enum RunError {
    /// The identifier refused its configuration or gave no estimates.
    Identifier(IdentifierError),
    /// The order tracker refused its configuration.
    Tracker(ConfigError),
}

impl fmt::Display for RunError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RunError::Identifier(e) => write!(f, "identifier: {e}"),
            RunError::Tracker(e) => write!(f, "order tracker: {e}"),
        }
    }
}

impl From<IdentifierError> for RunError {
    fn from(e: IdentifierError) -> Self {
        RunError::Identifier(e)
    }
}

impl From<ConfigError> for RunError {
    fn from(e: ConfigError) -> Self {
        RunError::Tracker(e)
    }
}

/// `x` as a fixed-point decimal with `decimals` digits (truncated toward
/// zero; magnitudes beyond `i64` saturate) and its bit pattern, e.g.
/// `12.34 [0x414570a4]`.
pub struct Fixed(pub f32, pub u32);

impl fmt::Display for Fixed {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let scale = 10i64.pow(self.1);
        let n = (self.0 * scale as f32) as i64;
        let sign = if n < 0 { "-" } else { "" };
        let (int, frac) = (
            n.unsigned_abs() / scale as u64,
            n.unsigned_abs() % scale as u64,
        );
        if self.1 == 0 {
            write!(f, "{sign}{int}")?;
        } else {
            write!(f, "{sign}{int}.{frac:0w$}", w = self.1 as usize)?;
        }
        write!(f, " [{:#010x}]", self.0.to_bits())
    }
}

/// One identifier update (table lookup, regression, block QRD/RLS), in a
/// frame of its own so that the stack it takes can be measured.
#[inline(never)]
pub fn update(
    id: &mut Id,
    omega: f32,
    q: &[rotorid_core::Complex<f32>; 4],
) -> Result<rotorid_core::identify::StepReport<f32>, IdentifierError> {
    id.update(&TABLE, omega, q)
}

/// A fresh identifier of the generated table's structure and scaling (the
/// firmware keeps it in a static; each run resets it).
pub fn identifier() -> Result<Id, IdentifierError> {
    Id::new(Config::new(STRUCTURE, SCALING))
}

/// Both runs (module documentation): the sweep's vectors, then the
/// coast-down's samples through `tracker` (a fresh one, [`tracker`]) into
/// the identifier `id` (reset at the start of each run, [`identifier`]);
/// writes the estimates to `out` (lines starting with `est `). Returns the
/// updates folded in by each.
pub fn run<W: Write, P: Probe>(
    out: &mut W,
    probe: &mut P,
    tracker: &mut Tracker,
    id: &mut Id,
) -> Result<(usize, usize), RunError> {
    let vectors = run_vectors(out, probe, id)?;
    let samples = run_samples(out, probe, tracker, id)?;
    Ok((vectors, samples))
}

/// The sweep's vectors into the identifier (`est` lines).
#[inline(never)]
fn run_vectors<W: Write, P: Probe>(
    out: &mut W,
    probe: &mut P,
    id: &mut Id,
) -> Result<usize, RunError> {
    id.reset()?;
    let (mut used, mut last) = (0usize, 0.0f32);
    for (omega, q) in SWEEP.iter() {
        probe.before_update();
        let step = update(id, *omega, q);
        probe.after_update();
        if step.is_ok() {
            used += 1;
            last = *omega;
        }
    }
    // A failed write to the host cannot be reported anywhere else.
    let _ = writeln!(
        out,
        "est updates {} of {} at {} rad/s",
        used,
        SWEEP.len(),
        Fixed(last, 3)
    );
    print_estimates(out, "est", id, last)?;
    Ok(used)
}

/// One sample through the tracker, and the average it completed; in a
/// frame of its own, so that the revolution's integral (inlined in the
/// push) takes no stack under the identifier's updates.
#[inline(never)]
fn track<P: Probe>(
    probe: &mut P,
    tracker: &mut Tracker,
    kp: f32,
    y: &[f32; NC],
) -> Option<StreamAverage<f32, NC>> {
    probe.before_push();
    let outcome = crate::tracking::push(tracker, kp, y);
    let a = if outcome.is_quiet() {
        None
    } else {
        finish(tracker, outcome)
    };
    probe.after_push();
    a
}

/// A block of samples (from index `from` on) through the tracker, up to
/// the average a revolution's end completed, if one did: that average and
/// the index to go on from ([`BLOCK_LEN`] when the block is through). In a
/// frame of its own, as [`track`].
#[inline(never)]
fn track_block<P: Probe>(
    probe: &mut P,
    tracker: &mut Tracker,
    kp: &[f32; BLOCK_LEN],
    y: &[[f32; NC]; BLOCK_LEN],
    mut from: usize,
) -> (Option<StreamAverage<f32, NC>>, usize) {
    probe.before_push();
    let mut average = None;
    while from < BLOCK_LEN && average.is_none() {
        let (outcome, next) = crate::tracking::push_block(tracker, kp, y, from);
        if !outcome.is_quiet() {
            average = finish(tracker, outcome);
        }
        from = next;
    }
    probe.after_push();
    (average, from)
}

/// The once-a-revolution half of [`track`], out of its line (its frame
/// and saved registers only when there is something to finish).
#[inline(never)]
fn finish(tracker: &mut Tracker, outcome: SampleOutcome<f32>) -> Option<StreamAverage<f32, NC>> {
    tracker.finish_sample(outcome).and_then(|o| o.average)
}

/// The coast-down's samples through the tracker, its averages into the
/// identifier (`est samples` lines: revolutions by outcome, updates,
/// estimates).
#[inline(never)]
fn run_samples<W: Write, P: Probe>(
    out: &mut W,
    probe: &mut P,
    tracker: &mut Tracker,
    id: &mut Id,
) -> Result<usize, RunError> {
    id.reset()?;
    let mut gen = Coastdown::new(&SWEEP, coastdown_setup());
    let (mut samples, mut averages, mut used, mut last) = (0u32, 0usize, 0usize, 0.0f32);
    let mut feed = |a: StreamAverage<f32, NC>, probe: &mut P| {
        averages += 1;
        probe.before_update();
        let step = update(id, a.speed, &a.x1);
        probe.after_update();
        if step.is_ok() {
            used += 1;
            last = a.speed;
        }
    };
    // Blocks of samples, as a DMA transfer gives them; the last, partial
    // block instant by instant.
    let mut kp = [0.0f32; BLOCK_LEN];
    let mut y = [[0.0f32; NC]; BLOCK_LEN];
    loop {
        let mut n = 0;
        while n < BLOCK_LEN {
            probe.before_sample();
            let next = gen.next_sample();
            probe.after_sample();
            let Some((k, v)) = next else { break };
            (kp[n], y[n]) = (k, v);
            n += 1;
        }
        samples += n as u32;
        if n == BLOCK_LEN {
            let mut from = 0;
            while from < BLOCK_LEN {
                let (average, next) = track_block(probe, tracker, &kp, &y, from);
                if let Some(a) = average {
                    feed(a, probe);
                }
                from = next;
            }
            continue;
        }
        for (k, v) in kp.iter().zip(y.iter()).take(n) {
            if let Some(a) = track(probe, tracker, *k, v) {
                feed(a, probe);
            }
        }
        if let Some(a) = tracker.flush() {
            feed(a, probe);
        }
        break;
    }
    let c = tracker.counts();
    let _ = writeln!(
        out,
        "est samples {} revolutions {}: accepted {}, rejected no_reference {} period_jump {} \
         undersampled {} speed_range {} non_finite {} clipped {} no_event {}",
        samples,
        c.total(),
        c.accepted,
        c.no_reference,
        c.period_jump,
        c.undersampled,
        c.speed_range,
        c.non_finite,
        c.clipped,
        c.no_event
    );
    let _ = writeln!(
        out,
        "est samples updates {} of {} averages, last at {} rad/s",
        used,
        averages,
        Fixed(last, 3)
    );
    print_estimates(out, "est samples", id, last)?;
    Ok(used)
}

/// The estimates of `id` at `omega` as lines starting with `tag`: each
/// bearing's `k`, `c`, each plane's unbalance phasor (and, as comments, its
/// magnitude and phase). In a frame of its own (not on the stack under the
/// updates).
#[inline(never)]
fn print_estimates<W: Write>(out: &mut W, tag: &str, id: &Id, omega: f32) -> Result<(), RunError> {
    let est: Estimates<f32, { crate::table::NQ }, { crate::table::NP }> = id.estimates(omega)?;
    for (m, b) in est.bearings.iter().enumerate() {
        for (j, name) in COEFFICIENTS.iter().enumerate() {
            let _ = writeln!(
                out,
                "{tag} bearing {} k{} {} N/m c{} {} N s/m",
                m + 1,
                name,
                Fixed(b.k[j], 0),
                name,
                Fixed(b.c[j], 2)
            );
        }
    }
    // The unbalance phasor itself is compared; its magnitude and phase
    // (`hypot`, `atan2`) are printed as comments: the target's `libm` and
    // the host's C library may round those differently by an ulp.
    for (k, u) in est.unbalance.iter().enumerate() {
        let _ = writeln!(
            out,
            "{tag} plane {} a {} {} g mm",
            k + 1,
            Fixed(u.a.re * 1e6, 3),
            Fixed(u.a.im * 1e6, 3)
        );
        let _ = writeln!(
            out,
            "# plane {} me {} g mm phase {} deg",
            k + 1,
            Fixed(u.me * 1e6, 3),
            Fixed(u.phase_deg(), 3)
        );
    }
    Ok(())
}
