//! The 1X vectors of a recording: the core's order tracker
//! (`rotorid_core::ordertrack::OrderTracker`, the firmware's code) in
//! `f64`, chosen at run time among a few channel counts and buffer sizes.
//!
//! # Speed range and buffer
//!
//! A first pass finds the keyphasor events (`rotorid_core::keyphasor`,
//! the same level and hysteresis) and their periods `P_k` (samples). The
//! steady ones (within 10 % of both neighbours, the tracker's own period
//! test) give the speeds `Omega_k = 2 pi f_s / P_k` of the recording; the
//! speed range is `[0.95 min, 1.05 max]` of them unless given. The
//! tracker's buffer `CAP` must hold the slowest revolution allowed,
//! `2 pi f_s / Omega_min + 7` samples; the smallest of `2^8, 2^10, ..,
//! 2^22` above twice that is taken (so a missing pulse is seen as a period
//! jump), the largest that holds it when none is.
//!
//! # Channels
//!
//! `OrderTracker<T, NC, CAP>` is const-generic in the channel count: the
//! recording's `n` probes run in the smallest of `NC = 2, 4, 8, 16, 32` at
//! or above `n`, the unused channels fed zeros (their vectors are
//! dropped). The state, `CAP (NC + 1)` floats and a few hundred bytes, can
//! reach tens of megabytes, more than a thread's stack: the tracker is
//! built and run on a thread of its own whose stack is four times the
//! state and 16 MiB.
//!
//! # Sweep rate
//!
//! The mean sweep rate is the least-squares slope of the steady periods'
//! speeds (rpm) against their mid times (s): `rate = sum (t - tm)(n - nm) /
//! sum (t - tm)^2`, rpm/s, negative on a run-down.

use std::f64::consts::PI;

use num_complex::Complex64;
use rotorid_core::keyphasor::{Crossing, Keyphasor};
use rotorid_core::ordertrack::{Config, ConfigError, Counts, OrderTracker};
use thiserror::Error;

use super::channels::{measurement_order, ChannelName};
use super::noise::{self, NoiseFit};
use super::Recording;

/// Options of [`extract`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExtractOptions {
    /// Lowest speed accepted (rpm); `None`: from the keyphasor.
    pub speed_min_rpm: Option<f64>,
    /// Highest speed accepted (rpm); `None`: from the keyphasor.
    pub speed_max_rpm: Option<f64>,
    /// Revolutions per averaged vector (the core's default 8).
    pub revolutions: u32,
    /// Keyphasor hysteresis (the signal's unit); `None`: a tenth of the
    /// signal's span.
    pub hysteresis: Option<f64>,
    /// Pool the standard errors over the sweep ([`noise`]); `false`: each
    /// row's own scatter.
    pub pool: bool,
}

impl Default for ExtractOptions {
    fn default() -> Self {
        ExtractOptions {
            speed_min_rpm: None,
            speed_max_rpm: None,
            revolutions: 8,
            hysteresis: None,
            pool: true,
        }
    }
}

/// An error of [`extract`].
#[derive(Debug, Error)]
pub enum ExtractError {
    /// The keyphasor gives no events to work with.
    #[error("keyphasor: {0}")]
    Keyphasor(String),
    /// The probe channels do not make a measurement file.
    #[error("{0}")]
    Channels(String),
    /// A speed option out of range.
    #[error("{0}")]
    Speed(String),
    /// The tracker's configuration was refused.
    #[error("order tracker: {0}")]
    Config(#[from] ConfigError),
    /// The tracker's thread could not be started or failed.
    #[error("order tracker thread: {0}")]
    Thread(String),
}

/// One averaged row: a group of revolutions.
#[derive(Debug, Clone, PartialEq)]
pub struct VectorRow {
    /// Mean speed (rad/s).
    pub omega: f64,
    /// Revolutions averaged.
    pub revolutions: u32,
    /// Time of the group's first and last event (s).
    pub time: (f64, f64),
    /// 1X vectors (m), measurement order.
    pub x1: Vec<Complex64>,
    /// The standard errors from the group's own scatter (m).
    pub std_raw: Vec<f64>,
    /// The standard errors written (m): pooled ([`noise`]) or raw.
    pub std: Vec<f64>,
}

/// The vectors of a recording.
#[derive(Debug, Clone, PartialEq)]
pub struct Vectors {
    /// The measurement channels, in the measurement file's order.
    pub channels: Vec<ChannelName>,
    /// The rows, in time order.
    pub rows: Vec<VectorRow>,
    /// Revolutions accepted and rejected by cause.
    pub counts: Counts,
    /// Mean sweep rate (rpm/s), `None` with fewer than two steady periods.
    pub sweep_rate_rpm_per_s: Option<f64>,
    /// The speed range used (rad/s).
    pub speed_range: (f64, f64),
    /// Keyphasor level and hysteresis used (after a falling edge's sign
    /// turn).
    pub level: (f64, f64),
    /// Keyphasor events found.
    pub events: usize,
    /// Sample rate (Hz).
    pub sample_rate: f64,
    /// Samples.
    pub samples: usize,
    /// The tracker's channel count and buffer (`NC`, `CAP`).
    pub tracker: (usize, usize),
    /// The pooled noise per channel (`None` where not pooled).
    pub noise: Vec<Option<NoiseFit>>,
}

/// Buffer sizes `CAP` to choose from.
pub const CAPACITIES: [usize; 8] = [
    1 << 8,
    1 << 10,
    1 << 12,
    1 << 14,
    1 << 16,
    1 << 18,
    1 << 20,
    1 << 22,
];

/// Channel counts `NC` to choose from.
pub const CHANNEL_COUNTS: [usize; 5] = [2, 4, 8, 16, 32];

/// The speeds and times of the keyphasor's steady periods.
struct FirstPass {
    events: usize,
    /// (mid time s, speed rad/s) of steady periods.
    steady: Vec<(f64, f64)>,
}

fn first_pass(kp: &[f64], level: f64, hysteresis: f64, fs: f64) -> Result<FirstPass, ExtractError> {
    let mut k = Keyphasor::new(level, hysteresis).map_err(|_| {
        ExtractError::Keyphasor(format!(
            "level {level} or hysteresis {hysteresis} out of range"
        ))
    })?;
    let mut events = Vec::new();
    for &x in kp {
        match k.push(x) {
            Crossing::Event(e) => events.push(e.sample as f64 + e.frac),
            Crossing::Invalid => events.push(f64::NAN),
            Crossing::None => {}
        }
    }
    let periods: Vec<(f64, f64)> = events
        .windows(2)
        .filter_map(|w| match w {
            [a, b] => Some(((a + b) / 2.0, b - a)),
            _ => None,
        })
        .collect();
    let steady = |x: f64, y: f64| (x / y - 1.0).abs() <= 0.1;
    let steady: Vec<(f64, f64)> = periods
        .windows(3)
        .filter_map(|w| match w {
            [(_, p0), (t, p), (_, p2)] if steady(*p, *p0) && steady(*p2, *p) => {
                Some((t / fs, 2.0 * PI * fs / p))
            }
            _ => None,
        })
        .collect();
    Ok(FirstPass {
        events: events.iter().filter(|e| e.is_finite()).count(),
        steady,
    })
}

/// Least-squares slope of `y` against `x`.
fn slope(pts: &[(f64, f64)]) -> Option<f64> {
    if pts.len() < 2 {
        return None;
    }
    let n = pts.len() as f64;
    let xm = pts.iter().map(|p| p.0).sum::<f64>() / n;
    let ym = pts.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = pts.iter().map(|p| (p.0 - xm).powi(2)).sum();
    let sxy: f64 = pts.iter().map(|p| (p.0 - xm) * (p.1 - ym)).sum();
    (sxx > 0.0).then(|| sxy / sxx)
}

/// What one run of the tracker gives back.
struct Tracked {
    rows: Vec<VectorRow>,
    counts: Counts,
}

/// Runs `OrderTracker<f64, NC, CAP>` over the recording (probe columns in
/// `order`), on the calling thread.
fn track<const NC: usize, const CAP: usize>(
    rec: &Recording,
    order: &[usize],
    config: Config<f64>,
    progress: Option<&(dyn Fn(u64) + Sync)>,
) -> Result<Tracked, ExtractError> {
    let mut t = OrderTracker::<f64, NC, CAP>::new(config)?;
    let nc = rec.channels.len();
    let n_out = order.len();
    let fs = rec.sample_rate;
    let mut rows = Vec::new();
    let mut take = |a: rotorid_core::ordertrack::Average<f64, NC>| {
        let x1: Vec<Complex64> = a.x1.iter().take(n_out).copied().collect();
        let std: Vec<f64> = a.x1_std.iter().take(n_out).copied().collect();
        rows.push(VectorRow {
            omega: a.speed,
            revolutions: a.revolutions,
            time: (a.start.seconds(fs), a.end.seconds(fs)),
            x1,
            std_raw: std.clone(),
            std,
        });
    };
    let mut y = [0.0f64; NC];
    for (i, (k, row)) in rec
        .kp
        .iter()
        .zip(rec.probes.chunks_exact(nc.max(1)))
        .enumerate()
    {
        for (slot, &col) in y.iter_mut().zip(order) {
            *slot = row.get(col).copied().unwrap_or(f64::NAN);
        }
        if let Some(out) = t.push(*k, &y) {
            if let Some(a) = out.average {
                take(a);
            }
        }
        if i & 0xffff == 0 {
            if let Some(p) = progress {
                p(i as u64);
            }
        }
    }
    if let Some(a) = t.flush() {
        take(a);
    }
    Ok(Tracked {
        rows,
        counts: *t.counts(),
    })
}

/// [`track`] on a thread whose stack holds the tracker's state.
fn track_on_thread<const NC: usize, const CAP: usize>(
    rec: &Recording,
    order: &[usize],
    config: Config<f64>,
    progress: Option<&(dyn Fn(u64) + Sync)>,
) -> Result<Tracked, ExtractError> {
    let state = std::mem::size_of::<OrderTracker<f64, NC, CAP>>();
    let stack = state.saturating_mul(4).saturating_add(16 << 20);
    std::thread::scope(|s| {
        let h = std::thread::Builder::new()
            .name("ordertrack".into())
            .stack_size(stack)
            .spawn_scoped(s, || track::<NC, CAP>(rec, order, config, progress))
            .map_err(|e| ExtractError::Thread(e.to_string()))?;
        h.join()
            .map_err(|_| ExtractError::Thread("the tracker's thread panicked".into()))?
    })
}

/// Dispatches [`track_on_thread`] over `NC` in [`CHANNEL_COUNTS`] and `CAP`
/// in [`CAPACITIES`].
macro_rules! dispatch {
    ($nc:expr, $cap:expr, $args:tt) => {
        dispatch!(@nc $nc, $cap, $args, [2, 4, 8, 16, 32])
    };
    (@nc $nc:expr, $cap:expr, $args:tt, [$($n:literal),*]) => {
        match $nc {
            $($n => dispatch!(@cap $n, $cap, $args, [8, 10, 12, 14, 16, 18, 20, 22]),)*
            other => Err(ExtractError::Channels(format!("{other} channels: at most 32"))),
        }
    };
    (@cap $n:literal, $cap:expr, $args:tt, [$($e:literal),*]) => {
        match $cap {
            $(c if c == 1usize << $e => track_on_thread::<$n, { 1usize << $e }> $args,)*
            other => Err(ExtractError::Thread(format!("no tracker of capacity {other}"))),
        }
    };
}

/// The 1X vectors of `rec` (see the module documentation); `progress`
/// is called now and then with the samples done.
pub fn extract(
    rec: &Recording,
    opts: &ExtractOptions,
    progress: Option<&(dyn Fn(u64) + Sync)>,
) -> Result<Vectors, ExtractError> {
    let fs = rec.sample_rate;
    let order = measurement_order(&rec.channels).map_err(ExtractError::Channels)?;
    let channels: Vec<ChannelName> = order
        .iter()
        .filter_map(|&i| rec.channels.get(i).copied())
        .collect();
    let nc = CHANNEL_COUNTS
        .iter()
        .copied()
        .find(|&n| n >= order.len())
        .ok_or_else(|| {
            ExtractError::Channels(format!("{} probe channels: at most 32", order.len()))
        })?;
    // Level: given, or midway between the finite extremes.
    let (lo, hi) = rec
        .kp
        .iter()
        .filter(|x| x.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
            (a.min(x), b.max(x))
        });
    if hi.partial_cmp(&lo) != Some(std::cmp::Ordering::Greater) {
        return Err(ExtractError::Keyphasor(
            "the signal is constant: no pulses".into(),
        ));
    }
    let level = rec.kp_level.unwrap_or(0.5 * (lo + hi));
    let hysteresis = opts.hysteresis.unwrap_or(0.1 * (hi - lo));
    let first = first_pass(&rec.kp, level, hysteresis, fs)?;
    if first.events < 4 {
        return Err(ExtractError::Keyphasor(format!(
            "{} events at level {level}: fewer than 4, no revolution to average",
            first.events
        )));
    }
    let rpm = crate::units::rad_s_to_rpm;
    let to_rad = crate::units::rpm_to_rad_s;
    let found = first
        .steady
        .iter()
        .map(|p| p.1)
        .fold((f64::INFINITY, 0.0f64), |(a, b), w| (a.min(w), b.max(w)));
    let check = |v: Option<f64>, what: &str| -> Result<Option<f64>, ExtractError> {
        match v {
            Some(x) if !(x.is_finite() && x > 0.0) => Err(ExtractError::Speed(format!(
                "--{what} must be finite and > 0 rpm, got {x}"
            ))),
            other => Ok(other.map(to_rad)),
        }
    };
    let given_min = check(opts.speed_min_rpm, "speed-min")?;
    let given_max = check(opts.speed_max_rpm, "speed-max")?;
    if (given_min.is_none() || given_max.is_none()) && first.steady.is_empty() {
        return Err(ExtractError::Keyphasor(format!(
            "{} events but no three steady periods in a row: no speed range (give --speed-min and --speed-max)",
            first.events
        )));
    }
    let w_min = given_min.unwrap_or(0.95 * found.0);
    let w_max = given_max.unwrap_or(1.05 * found.1);
    if w_max.partial_cmp(&w_min) != Some(std::cmp::Ordering::Greater) {
        return Err(ExtractError::Speed(format!(
            "speed range {} .. {} rpm is empty",
            rpm(w_min),
            rpm(w_max)
        )));
    }
    let needed = (2.0 * PI * fs / w_min).ceil() + 7.0;
    let cap = CAPACITIES
        .iter()
        .copied()
        .find(|&c| c as f64 >= 2.0 * needed)
        .or_else(|| CAPACITIES.iter().copied().rev().find(|&c| c as f64 >= needed))
        .ok_or_else(|| {
            ExtractError::Speed(format!(
                "the slowest revolution, {} rpm at {fs} Hz, is {needed} samples: more than {} (raise --speed-min)",
                rpm(w_min),
                CAPACITIES[CAPACITIES.len() - 1]
            ))
        })?;
    let state = cap.saturating_mul(nc + 1).saturating_mul(8);
    if state > 1 << 30 {
        return Err(ExtractError::Speed(format!(
            "the tracker's state for {} rpm at {fs} Hz and {nc} channels would be {} MiB (raise --speed-min)",
            rpm(w_min),
            state >> 20
        )));
    }
    let config = Config::new(fs, level, w_min, w_max)
        .with_hysteresis(hysteresis)
        .with_revolutions(opts.revolutions);
    config.validate(cap)?;
    let tracked = dispatch!(nc, cap, (rec, &order, config, progress))?;
    let mut rows = tracked.rows;
    let noise = if opts.pool {
        pool(&mut rows, fs, channels.len())
    } else {
        vec![None; channels.len()]
    };
    // A zero standard error (noise-free signals) would make a file that
    // claims exact vectors: the floor is the rounding of the largest one.
    for c in 0..channels.len() {
        let top = rows
            .iter()
            .filter_map(|r| r.x1.get(c))
            .map(|z| z.norm())
            .fold(0.0, f64::max);
        let floor = (f64::EPSILON * top).max(1e-300);
        for r in &mut rows {
            if let Some(s) = r.std.get_mut(c) {
                *s = s.max(floor);
            }
        }
    }
    let rate_pts: Vec<(f64, f64)> = first.steady.iter().map(|&(t, w)| (t, rpm(w))).collect();
    Ok(Vectors {
        channels,
        rows,
        counts: tracked.counts,
        sweep_rate_rpm_per_s: slope(&rate_pts),
        speed_range: (w_min, w_max),
        level: (level, hysteresis),
        events: first.events,
        sample_rate: fs,
        samples: rec.len(),
        tracker: (nc, cap),
        noise,
    })
}

/// Replaces each row's standard errors by the pooled ones ([`noise`]),
/// channel by channel; returns the fits.
fn pool(rows: &mut [VectorRow], fs: f64, n_channels: usize) -> Vec<Option<NoiseFit>> {
    // g_k = 4 / (M_k N_k), M_k = 2 pi f_s / Omega_k.
    let g: Vec<f64> = rows
        .iter()
        .map(|r| 4.0 * r.omega / (2.0 * PI * fs * f64::from(r.revolutions.max(1))))
        .collect();
    let mut fits = Vec::with_capacity(n_channels);
    for c in 0..n_channels {
        let y2: Vec<f64> = rows
            .iter()
            .map(|r| r.x1.get(c).map_or(f64::NAN, |z| z.norm_sqr()))
            .collect();
        let u: Vec<f64> = rows
            .iter()
            .zip(&g)
            .map(|(r, g)| r.std_raw.get(c).map_or(f64::NAN, |s| s * s / g))
            .collect();
        let t: Vec<f64> = rows
            .iter()
            .map(|r| noise::beyond_threshold(2.0 * (f64::from(r.revolutions) - 2.0)))
            .collect();
        let f = noise::fit(&y2, &u, &t);
        if let Some(f) = &f {
            for (((r, g), y2), t) in rows.iter_mut().zip(&g).zip(&y2).zip(&t) {
                let model = f.variance(*g, *y2);
                let own = r.std_raw.get(c).map_or(f64::NAN, |s| s * s);
                if let Some(s) = r.std.get_mut(c) {
                    // Beyond the model at the 0.1 % level: the row's own.
                    *s = if own > t * model {
                        own.sqrt()
                    } else {
                        model.sqrt()
                    };
                }
            }
        }
        fits.push(f);
    }
    fits
}
