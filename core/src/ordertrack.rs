//! Synchronous order tracking: the 1X (and 2X) vectors of every probe
//! channel, revolution by revolution, from the keyphasor and the probes'
//! samples, averaged over groups of revolutions with their standard errors.
//!
//! Samples come one at a time ([`OrderTracker::push`]: the pulse channel's
//! value and the `NC` probes' values of one sampling instant, sample rate
//! `f_s` in Hz). The keyphasor events ([`crate::keyphasor`]) delimit the
//! revolutions; revolution `k` runs from event `u_k` to event `u_(k+1)`
//! (times in samples, [`EventTime`]).
//!
//! # Phasor convention
//!
//! Angle 0 of a revolution is its keyphasor event: the mark passing the
//! keyphasor probe. A probe signal `y = A cos(n theta + phi)`, `theta` the
//! shaft angle since the event (rad), has the nX phasor `Y_n = A exp(j phi)`
//! (the convention `y = Re{ Y exp(j Omega t) }` of the crate, with
//! `theta = Omega t`):
//!
//! ```text
//! Y_n = (1 / pi) * integral over theta in [0, 2 pi] of y(theta) exp(-j n theta) dtheta
//! ```
//!
//! over exactly one revolution in angle. A constant (DC) and the other
//! harmonics `m != n` integrate to zero over a whole revolution: they do not
//! leak into `Y_n`, whatever the number of samples per revolution.
//!
//! # Shaft angle between events
//!
//! On a run-up or a coast-down the speed changes within a revolution. The
//! angle is the quadratic in time (constant angular acceleration) through
//! the last three events, at `theta = -2 pi, 0, 2 pi`. With `tau` the time
//! since `u_k` in samples, `T = u_(k+1) - u_k` this revolution's period and
//! `P = u_k - u_(k-1)` the previous one (samples):
//!
//! ```text
//! theta(tau) = w tau + a tau^2 / 2                     (rad)
//! a = 4 pi (P - T) / (T P (T + P))                     (rad / sample^2)
//! w = 2 pi / T - a T / 2                               (rad / sample)
//! ```
//!
//! which gives `theta(-P) = -2 pi`, `theta(0) = 0`, `theta(T) = 2 pi`. A
//! linear speed ramp is a constant acceleration: the angle is then exact,
//! up to the timing of the events. In SI: speed `w f_s` at the event (rad/s),
//! acceleration `a f_s^2` (rad/s^2); the revolution's mean speed is
//! `Omega = 2 pi f_s / T` (rad/s), the speed reported.
//!
//! # One revolution buffered
//!
//! The angle of a sample is known only once the revolution's end event is
//! found. The tracker therefore keeps the revolution's samples, every
//! channel, in an inline buffer of `CAP` samples (`[[T; NC]; CAP]`, no heap)
//! and computes the revolution's vectors when its end event comes, in one
//! pass over the buffer: a burst of work once per revolution (about
//! `30 + 10 NC` flops per sample of the revolution, 2X included), nothing
//! but a copy and a few comparisons at the other samples. `CAP` must hold
//! the slowest revolution allowed and 7 samples more (checked by
//! [`OrderTracker::new`]); with `CAP` above twice the longest revolution
//! expected, a missing pulse is told as such ([`Rejection::PeriodJump`])
//! rather than dropped as [`Rejection::NoEvent`]. For `NC = 4` and
//! `CAP = 1024` the state is 16 864 bytes in `f32` (the buffer and 480
//! bytes, the rule's constant weights included; 33 536 in `f64`); on the
//! Cortex-M4F (`opt-level = "z"`, LTO) the code takes about 5 KiB beside
//! `sqrtf`, the per-sample path has no `f64` (software) arithmetic and
//! no function of a math library runs per revolution but `sqrt` and
//! `hypot` for the standard errors (the rotations come from the series
//! below), so the vectors are the same bits on every IEEE machine. Accumulating with a
//! provisional angle and correcting afterwards would spare the buffer but
//! not the accuracy: the correction of a speed change of 0.2 % per
//! revolution needs several orders of its expansion to reach 1e-6.
//!
//! # The integral over one revolution
//!
//! With the substitution `theta = theta(tau)`, the integral over one
//! revolution in angle is an integral over the revolution's time, where
//! the samples are uniform (`tau_i = i - u_k` for sample `i`):
//!
//! ```text
//! Y_n = (1 / pi) * integral over tau in [0, T] of g_n(tau) dtau,
//! g_n(tau) = y(tau) exp(-j n theta(tau)) theta'(tau),   theta'(tau) = w + a tau.
//! ```
//!
//! The events fall between samples, so the trapezoid rule (in angle or in
//! time) has two partial steps at the ends and is only second order there:
//! with 510 samples per revolution, a DC leaks into 1X at 3e-8 of its size,
//! a 5X at 2e-7 (and a probe's gap is some 100 times its 1X). The rule
//! here integrates, on each sample interval `[c, c + 1]` (a part of it at
//! the two ends), the degree-5 Lagrange polynomial through six
//! neighbouring samples; centred (samples
//! `c - 2 .. c + 3`) except on the last two intervals, which end at the
//! sample after the end event (`c - 3 .. c + 2`, `c - 4 .. c + 1`), so
//! that the revolution closes as soon as its end event is found. Summed over
//! the revolution, every sample whose interpolants are all centred gets the
//! weight exactly 1 (the centred weights `(11, -93, 802, 802, -93, 11) /
//! 1440` add up to 1): the rule is the plain sum of the samples with
//! weights computed once per revolution for the six samples at each end
//! ([`lagrange_integrals`]). Its error is of sixth order in the sample
//! step, at the ends only: with 510 samples per revolution, a DC 100 times
//! the 1X and 2X..5X of its size leave 1X within 3e-12 (f64,
//! `core/tests/ordertrack/accuracy.rs`). The event times themselves are
//! exact at constant speed for a pulse edge linear in time; on a ramp
//! `alpha` (rad/s^2) their linear interpolation is off by up to
//! `alpha / (8 f_s^2)` rad (6e-9 rad at 10 %/s, 50 Hz, 25.6 kHz), the
//! error then seen in the vectors.
//!
//! # No sine or cosine per sample
//!
//! `exp(-j theta_i)` is carried from sample to sample by the increment
//! `D_i = exp(-j (theta_(i+1) - theta_i))`. For the quadratic angle the
//! increment is linear in the sample number, `theta_(i+1) - theta_i = d_0 +
//! a i`, so
//!
//! ```text
//! p_0 = exp(-j theta(tau_0)),     E = exp(-j d_0)     (once a revolution, by the same series),
//! D_i = E exp(-j a i),            exp(-j e) = cos e - j sin e by their series in e = a i,
//! p_(i+1) = p_i D_i (3 - |p_i D_i|^2) / 2,
//! ```
//!
//! the series truncated once a revolution where the remainder falls below
//! the precision (at constant speed `a = 0` and `D_i = E`; on a ramp of
//! 10 %/s at 50 Hz, `|a i| < 3e-5` and two terms suffice). Where three
//! terms suffice (in `f32` always with the default period ratio of 0.1)
//! `exp(-j a i)` is not summed at each sample but carried by a recurrence
//! on `1 - cos(a i)` and `sin(a i)` themselves, small numbers that keep
//! their relative precision, so that its rounding puts only `sqrt(i) eps
//! |a i|` into the phase (`Chirp`). `D_i = E exp(-j a i)` is formed from
//! it afresh at every sample: no error of consequence accumulates in the
//! increment (with the recurrence `D_(i+1) = D_i exp(-j a)` on the unit
//! phasor itself the increment's rounding would add up in the angle as
//! `M^1.5 eps`). The factor `(3 - |z|^2) / 2`
//! (one Newton step towards `|z| = 1`) renormalises at every sample, so
//! that rounding does not accumulate in the magnitude; the phase error
//! grows as a random walk, `sqrt(M) eps` after `M` samples. The 2X factor is `p_i^2`. In the sums, each
//! channel's first sample of the revolution is taken off every sample (a
//! constant integrates to zero): the rounding is then that of the
//! vibration, not of a probe's gap, which in `f32` takes the 1X error from
//! 5e-5 to 1e-6 with a gap 100 times the 1X. The channels are summed over
//! blocks of 8 samples (the block's `q1`, `q2` once, then each channel
//! with its block sums), which leaves 6e-7.
//!
//! # Averaging, standard errors
//!
//! Groups of `N` accepted revolutions ([`Config::revolutions`]) are averaged
//! into one vector per channel, `Y = mean(Y_r)`, with the speed the mean of
//! the revolutions' mean speeds. The standard error of `Y` comes from the
//! revolution-to-revolution scatter:
//!
//! ```text
//! E|Y - Y_true|^2 = s^2 / N,    s^2 = sum_r |Y_r - Yhat_r|^2 / (N - d),
//! ```
//!
//! about the mean (`Yhat_r = Y`, `d = 1`, [`Scatter::Mean`]) or about a
//! straight line in the revolution number (`d = 2`, [`Scatter::Trend`], the
//! default: on a run-up the vectors change with the speed, and that change
//! is no scatter). The reported value is `sqrt(s^2 / N)` (the standard
//! deviation of the complex average, `E|dY|^2 = std^2`), formed by
//! Welford-type updates (no sum of squares to cancel).
//!
//! For white noise of standard deviation `sigma` on the samples, `M`
//! samples per revolution, the noise of one revolution's phasor is
//! `dY = (1 / pi) sum_i W_i theta'_i e_i exp(-j theta_i)` with
//! `theta'_i = 2 pi / M` and weights `W_i = 1` but at the ends, so
//!
//! ```text
//! E|dY|^2 = (1 / pi^2) (2 pi / M)^2 sigma^2 sum_i W_i^2 = 4 sigma^2 / M,
//! E|dY_avg|^2 = 4 sigma^2 / (M N)       (N revolutions),
//! ```
//!
//! `2 sigma^2 / (M N)` in each of the real and imaginary parts. It is the
//! variance of a sinusoid fitted by least squares at a known frequency:
//! `y_i = b cos theta_i + c sin theta_i + e_i` over `M` samples evenly
//! spread in angle gives `b, c` each of variance `2 sigma^2 / M`
//! (`sum cos^2 = sum sin^2 = M / 2`), and `Y = b - j c`.
//!
//! # Rejected revolutions
//!
//! A revolution is rejected, counted by cause ([`Counts`]) and never
//! averaged, for the first of ([`Rejection`]):
//!
//! 1. [`Rejection::NoReference`]: fewer than two periods before it in the
//!    chain of events (the first two revolutions of a pulse train, and
//!    after a restart);
//! 2. [`Rejection::PeriodJump`]: its period or the previous one (which its
//!    angle uses) differs from the period before by more than
//!    [`Config::period_ratio`]: `|T / P - 1|` or `|P / P' - 1|` too large
//!    (`P'` the period before `P`). A missing pulse rejects three
//!    revolutions, an extra pulse four;
//! 3. [`Rejection::Undersampled`]: fewer than [`Config::min_samples`]
//!    samples in the revolution (the sample rate is too low for the
//!    speed);
//! 4. [`Rejection::SpeedRange`]: its mean speed outside
//!    `[speed_min, speed_max]`;
//! 5. [`Rejection::NonFinite`]: a NaN or infinite probe sample among those
//!    its integral uses, a non-finite keyphasor sample during it (the
//!    revolution is dropped at once, the event chain restarts) or a vector
//!    that overflowed;
//! 6. [`Rejection::Clipped`]: a probe sample at or beyond the ADC limits
//!    ([`Config::adc_min`], [`Config::adc_max`]: a saturated converter
//!    reads its limit);
//! 7. [`Rejection::NoEvent`]: no event within `CAP` samples (the pulse
//!    train stopped, or the shaft is far below the speed range): the
//!    revolution is dropped and the chain restarts at the next event.
//!
//! A revolution is one measurement of every channel: a fault on any
//! channel rejects it on all. The samples next to an event take part in the
//! integrals of both revolutions, so a bad sample there rejects both.
//! Nothing panics on any input: every sample, finite or not, is taken.

use crate::keyphasor::{Crossing, EventTime, InvalidLevel, Keyphasor};
use crate::scalar::Real;
use core::fmt;
use num_complex::Complex;

/// `n` in the working precision, converted directly (in `f32` a hardware
/// conversion on the Cortex-M4F, no `f64` arithmetic in software).
#[inline(always)]
pub(crate) fn int<T: Real>(n: i32) -> T {
    T::from_i32(n).unwrap_or_else(T::zero)
}

/// A count in the working precision (see [`int`]).
#[inline(always)]
pub(crate) fn count<T: Real>(n: usize) -> T {
    T::from_usize(n).unwrap_or_else(T::zero)
}

/// The smallest [`Config::min_samples`] allowed: the integration rule
/// needs six samples at each end of a revolution and one between.
pub const MIN_SAMPLES_FLOOR: usize = 16;

/// The most revolutions in a group ([`Config::revolutions`]).
pub const MAX_REVOLUTIONS: u32 = 1 << 16;

/// The largest buffer capacity `CAP` (2^24: sample counts within a
/// revolution stay exact in `f32`).
pub const MAX_CAPACITY: usize = 1 << 24;

/// Samples kept before the start event of a revolution (its first
/// interpolant reaches two samples back) plus the start event's own two.
const HISTORY: usize = 4;

/// The largest ADC limit in magnitude, `sqrt(T::MAX) / 2^24`
/// (about 1.1e12 in `f32`, 8e146 in `f64`): a revolution's phasors, their
/// squares and the statistics of [`MAX_REVOLUTIONS`] of them stay finite.
/// The default ADC range is `[-adc_limit, adc_limit]`.
pub fn adc_limit<T: Real>() -> T {
    T::max_value().map_or(T::zero(), |m| m.sqrt()) * T::lit(1.0 / 16_777_216.0)
}

/// How the standard error of an average is formed from the scatter of its
/// revolutions (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scatter {
    /// About the mean: `N - 1` degrees of freedom (steady speed).
    Mean,
    /// About a straight line in the revolution number: `N - 2` degrees of
    /// freedom; a vector changing steadily (a run-up) is no scatter.
    Trend,
}

impl Scatter {
    /// Degrees of freedom the scatter spends (1 or 2).
    fn spent(self) -> u32 {
        match self {
            Scatter::Mean => 1,
            Scatter::Trend => 2,
        }
    }
}

/// Configuration of an [`OrderTracker`]. Build it with [`Config::new`] and
/// the `with_*` methods; [`OrderTracker::new`] validates it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Config<T> {
    /// Sample rate `f_s` (Hz), finite and `> 0`.
    pub sample_rate: T,
    /// Keyphasor level `L` (the pulse channel's unit).
    pub level: T,
    /// Keyphasor hysteresis `h >= 0`: re-armed below `L - h`.
    pub hysteresis: T,
    /// Lowest speed accepted (rad/s), `> 0`.
    pub speed_min: T,
    /// Highest speed accepted (rad/s), `> speed_min`.
    pub speed_max: T,
    /// The largest relative change of the period from one revolution to
    /// the next, `|T / P - 1|`, in `(0, 0.5]`.
    pub period_ratio: T,
    /// Lower ADC limit (probe unit): a sample `<= adc_min` is clipped.
    pub adc_min: T,
    /// Upper ADC limit (probe unit): a sample `>= adc_max` is clipped.
    pub adc_max: T,
    /// The fewest samples per revolution, at least [`MIN_SAMPLES_FLOOR`].
    pub min_samples: usize,
    /// Revolutions per average `N`, at least 2 ([`Scatter::Mean`]) or 3
    /// ([`Scatter::Trend`]), at most [`MAX_REVOLUTIONS`].
    pub revolutions: u32,
    /// The scatter the standard errors come from.
    pub scatter: Scatter,
}

impl<T: Real> Config<T> {
    /// The defaults for sample rate `sample_rate` (Hz), keyphasor level
    /// `level` and speeds `speed_min ..= speed_max` (rad/s): no hysteresis,
    /// period ratio 0.1, ADC range `[-adc_limit, adc_limit]` ([`adc_limit`]),
    /// 32 samples per revolution at least, averages of 8 revolutions, the
    /// scatter about the trend.
    ///
    /// ```
    /// use rotorid_core::ordertrack::{Config, OrderTracker, Scatter};
    ///
    /// // 25.6 kHz, a 0..5 V keyphasor, 600..6000 rpm.
    /// let rpm = |n: f32| n * core::f32::consts::PI / 30.0;
    /// let c = Config::new(25_600.0, 2.5, rpm(600.0), rpm(6000.0))
    ///     .with_hysteresis(0.5)
    ///     .with_adc_range(-2e-3, 2e-3)
    ///     .with_revolutions(16)
    ///     .with_scatter(Scatter::Mean);
    /// // 4 probes, room for 2600 samples: one revolution at 600 rpm and 6.
    /// let t = OrderTracker::<f32, 4, 2600>::new(c).unwrap();
    /// assert_eq!(t.config().min_samples, 32);
    /// ```
    pub fn new(sample_rate: T, level: T, speed_min: T, speed_max: T) -> Self {
        let lim = adc_limit::<T>();
        Config {
            sample_rate,
            level,
            hysteresis: T::zero(),
            speed_min,
            speed_max,
            period_ratio: T::lit(0.1),
            adc_min: -lim,
            adc_max: lim,
            min_samples: 32,
            revolutions: 8,
            scatter: Scatter::Trend,
        }
    }

    /// With keyphasor hysteresis `h` (`>= 0`).
    pub fn with_hysteresis(mut self, hysteresis: T) -> Self {
        self.hysteresis = hysteresis;
        self
    }

    /// With the largest relative period change `|T / P - 1|` (in `(0, 0.5]`).
    pub fn with_period_ratio(mut self, ratio: T) -> Self {
        self.period_ratio = ratio;
        self
    }

    /// With ADC limits: samples `<= lo` or `>= hi` are clipped.
    pub fn with_adc_range(mut self, lo: T, hi: T) -> Self {
        self.adc_min = lo;
        self.adc_max = hi;
        self
    }

    /// With the fewest samples per revolution (at least [`MIN_SAMPLES_FLOOR`]).
    pub fn with_min_samples(mut self, min_samples: usize) -> Self {
        self.min_samples = min_samples;
        self
    }

    /// With `N` revolutions per average.
    pub fn with_revolutions(mut self, revolutions: u32) -> Self {
        self.revolutions = revolutions;
        self
    }

    /// With the scatter the standard errors come from.
    pub fn with_scatter(mut self, scatter: Scatter) -> Self {
        self.scatter = scatter;
        self
    }

    /// The longest revolution allowed, `2 pi f_s / speed_min` samples
    /// (f64; infinite or NaN for a bad configuration).
    pub(crate) fn longest(&self) -> f64 {
        core::f64::consts::TAU * self.sample_rate.to_f64() / self.speed_min.to_f64()
    }

    /// The timing checks of a revolution of `t` samples whose two previous
    /// periods are `[P', P]` and whose mean speed is `speed` (rad/s), in the
    /// order of the module documentation: [`Rejection::NoReference`]
    /// without both periods, [`Rejection::PeriodJump`] when `|t / P - 1|`
    /// or `|P / P' - 1|` exceeds the period ratio or `angle_ok` is false,
    /// then [`Rejection::Undersampled`], [`Rejection::SpeedRange`].
    pub(crate) fn timing(
        &self,
        t: T,
        periods: [Option<T>; 2],
        speed: T,
        angle_ok: bool,
    ) -> Result<(), Rejection> {
        // NaN is no steady period.
        let steady = |x: T, y: T| (x / y - T::one()).abs() <= self.period_ratio;
        match periods {
            [Some(pp), Some(p)] => {
                if !steady(t, p) || !steady(p, pp) || !angle_ok {
                    Err(Rejection::PeriodJump)
                } else if t < count(self.min_samples) {
                    Err(Rejection::Undersampled)
                } else if !(speed >= self.speed_min && speed <= self.speed_max) {
                    Err(Rejection::SpeedRange)
                } else {
                    Ok(())
                }
            }
            _ => Err(Rejection::NoReference),
        }
    }

    /// Checks every field, and that a buffer of `capacity` samples holds
    /// the slowest revolution allowed (`2 pi f_s / speed_min` samples) and
    /// 6 more (see [`ConfigError`]).
    pub fn validate(&self, capacity: usize) -> Result<(), ConfigError> {
        let pos = |x: T| x.is_finite() && x > T::zero();
        if !pos(self.sample_rate) {
            return Err(ConfigError::SampleRate);
        }
        if Keyphasor::new(self.level, self.hysteresis).is_err() {
            return Err(ConfigError::Keyphasor);
        }
        if !(pos(self.speed_min) && self.speed_max.is_finite() && self.speed_max > self.speed_min) {
            return Err(ConfigError::SpeedRange);
        }
        if !(pos(self.period_ratio) && self.period_ratio <= T::lit(0.5)) {
            return Err(ConfigError::PeriodRatio);
        }
        let lim = adc_limit::<T>();
        if !(self.adc_min >= -lim && self.adc_max <= lim && self.adc_min < self.adc_max) {
            return Err(ConfigError::AdcRange);
        }
        if self.min_samples < MIN_SAMPLES_FLOOR || self.min_samples > MAX_CAPACITY {
            return Err(ConfigError::MinSamples);
        }
        if self.revolutions < self.scatter.spent() + 1 || self.revolutions > MAX_REVOLUTIONS {
            return Err(ConfigError::Revolutions);
        }
        let longest = self.longest();
        // `as` saturates (and maps NaN to 0): no overflow.
        let needed = if longest.is_finite() && longest < MAX_CAPACITY as f64 {
            (longest as usize).saturating_add(7)
        } else {
            usize::MAX
        };
        if capacity < needed || capacity > MAX_CAPACITY {
            return Err(ConfigError::Capacity { needed });
        }
        Ok(())
    }
}

/// A configuration an [`OrderTracker`] refuses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ConfigError {
    /// The sample rate is not finite and `> 0`.
    SampleRate,
    /// The keyphasor level or hysteresis is not finite, the hysteresis is
    /// negative, or `level - hysteresis` is not finite.
    Keyphasor,
    /// Not `0 < speed_min < speed_max`, both finite.
    SpeedRange,
    /// The period ratio is not in `(0, 0.5]`.
    PeriodRatio,
    /// Not `-adc_limit <= adc_min < adc_max <= adc_limit` ([`adc_limit`]).
    AdcRange,
    /// `min_samples` below [`MIN_SAMPLES_FLOOR`] (or above [`MAX_CAPACITY`]).
    MinSamples,
    /// `revolutions` below 2 (3 with [`Scatter::Trend`]) or above
    /// [`MAX_REVOLUTIONS`].
    Revolutions,
    /// The buffer capacity `CAP` is below `needed` (the slowest revolution
    /// allowed, `2 pi f_s / speed_min` samples, and 7 more; `usize::MAX`
    /// when that is beyond [`MAX_CAPACITY`]) or above [`MAX_CAPACITY`].
    Capacity {
        /// The capacity the configuration needs.
        needed: usize,
    },
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ConfigError::SampleRate => f.write_str("sample rate must be finite and > 0"),
            ConfigError::Keyphasor => f.write_str(
                "keyphasor level and hysteresis must be finite, the hysteresis >= 0",
            ),
            ConfigError::SpeedRange => {
                f.write_str("speed range must satisfy 0 < speed_min < speed_max, finite")
            }
            ConfigError::PeriodRatio => f.write_str("period ratio must lie in (0, 0.5]"),
            ConfigError::AdcRange => f.write_str(
                "ADC limits must satisfy -adc_limit <= adc_min < adc_max <= adc_limit",
            ),
            ConfigError::MinSamples => write!(
                f,
                "minimum samples per revolution must be at least {MIN_SAMPLES_FLOOR}"
            ),
            ConfigError::Revolutions => write!(
                f,
                "revolutions per average must be at least 2 (3 about the trend) and at most {MAX_REVOLUTIONS}"
            ),
            ConfigError::Capacity { needed } => write!(
                f,
                "buffer capacity too small for the slowest revolution allowed: {needed} samples needed (at most {MAX_CAPACITY})"
            ),
        }
    }
}

impl core::error::Error for ConfigError {}

impl From<InvalidLevel> for ConfigError {
    fn from(_: InvalidLevel) -> Self {
        ConfigError::Keyphasor
    }
}

/// Why a revolution was rejected (see the module documentation for the
/// order in which they are tested).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Rejection {
    /// Fewer than two periods before it in the chain of events: no angle
    /// reference yet (start of the pulse train, or after a restart).
    NoReference,
    /// Its period or the previous one differs from the period before it by
    /// more than the period ratio: a missing or an extra keyphasor pulse.
    PeriodJump,
    /// Fewer samples than [`Config::min_samples`]: the sample rate is too
    /// low for the speed.
    Undersampled,
    /// Mean speed outside `[speed_min, speed_max]`.
    SpeedRange,
    /// A NaN or infinite sample (probe or keyphasor), or an overflow.
    NonFinite,
    /// A probe sample at or beyond the ADC limits.
    Clipped,
    /// No keyphasor event within the buffer's `CAP` samples: the pulse
    /// train stopped.
    NoEvent,
}

impl fmt::Display for Rejection {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Rejection::NoReference => "no reference period yet",
            Rejection::PeriodJump => "period jump (missing or extra keyphasor pulse)",
            Rejection::Undersampled => "too few samples per revolution",
            Rejection::SpeedRange => "speed outside the range",
            Rejection::NonFinite => "non-finite sample",
            Rejection::Clipped => "clipped probe sample",
            Rejection::NoEvent => "no keyphasor event (pulse train stopped)",
        })
    }
}

/// Revolutions closed so far, by outcome (a revolution still waiting for
/// its end event, at the end of a recording, is not counted).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Counts {
    /// Accepted (averaged).
    pub accepted: u64,
    /// [`Rejection::NoReference`].
    pub no_reference: u64,
    /// [`Rejection::PeriodJump`].
    pub period_jump: u64,
    /// [`Rejection::Undersampled`].
    pub undersampled: u64,
    /// [`Rejection::SpeedRange`].
    pub speed_range: u64,
    /// [`Rejection::NonFinite`].
    pub non_finite: u64,
    /// [`Rejection::Clipped`].
    pub clipped: u64,
    /// [`Rejection::NoEvent`].
    pub no_event: u64,
}

impl Counts {
    /// The count of one cause.
    pub fn of(&self, cause: Rejection) -> u64 {
        match cause {
            Rejection::NoReference => self.no_reference,
            Rejection::PeriodJump => self.period_jump,
            Rejection::Undersampled => self.undersampled,
            Rejection::SpeedRange => self.speed_range,
            Rejection::NonFinite => self.non_finite,
            Rejection::Clipped => self.clipped,
            Rejection::NoEvent => self.no_event,
        }
    }

    /// Rejected revolutions, every cause.
    pub fn rejected(&self) -> u64 {
        [
            self.no_reference,
            self.period_jump,
            self.undersampled,
            self.speed_range,
            self.non_finite,
            self.clipped,
            self.no_event,
        ]
        .iter()
        .fold(0u64, |s, &c| s.saturating_add(c))
    }

    /// Every revolution closed, accepted or rejected.
    pub fn total(&self) -> u64 {
        self.accepted.saturating_add(self.rejected())
    }

    pub(crate) fn add(&mut self, outcome: Result<(), Rejection>) {
        let c = match outcome {
            Ok(()) => &mut self.accepted,
            Err(Rejection::NoReference) => &mut self.no_reference,
            Err(Rejection::PeriodJump) => &mut self.period_jump,
            Err(Rejection::Undersampled) => &mut self.undersampled,
            Err(Rejection::SpeedRange) => &mut self.speed_range,
            Err(Rejection::NonFinite) => &mut self.non_finite,
            Err(Rejection::Clipped) => &mut self.clipped,
            Err(Rejection::NoEvent) => &mut self.no_event,
        };
        *c = c.saturating_add(1);
    }
}

/// The order vectors of one revolution, per channel (probe unit, e.g. m).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Orders<T, const NC: usize> {
    /// 1X: `y = A cos(theta + phi)` gives `A exp(j phi)`.
    pub x1: [Complex<T>; NC],
    /// 2X: `y = A cos(2 theta + phi)` gives `A exp(j phi)`.
    pub x2: [Complex<T>; NC],
}

/// One revolution closed: its timing and its vectors or why it was
/// rejected.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Revolution<T, const NC: usize> {
    /// The keyphasor event that opened it (angle 0).
    pub start: EventTime<T>,
    /// Its period `T` in samples (for a revolution dropped without its end
    /// event, [`Rejection::NoEvent`] or a non-finite keyphasor sample: the
    /// samples it had run).
    pub samples: T,
    /// Mean speed `2 pi f_s / T` (rad/s); 0 when dropped without its end
    /// event.
    pub speed: T,
    /// Angular acceleration `a f_s^2` of the angle model (rad/s^2); 0 when
    /// there is no previous period.
    pub acceleration: T,
    /// The vectors, or the cause of the rejection.
    pub result: Result<Orders<T, NC>, Rejection>,
}

/// The average of a group of accepted revolutions, per channel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Average<T, const NC: usize> {
    /// Revolutions averaged.
    pub revolutions: u32,
    /// The start event of the group's first revolution.
    pub start: EventTime<T>,
    /// The end event of its last revolution.
    pub end: EventTime<T>,
    /// Mean of the revolutions' mean speeds (rad/s).
    pub speed: T,
    /// Mean 1X vector (probe unit).
    pub x1: [Complex<T>; NC],
    /// Standard error of the mean 1X vector: `E|dY|^2 = x1_std^2`.
    pub x1_std: [T; NC],
    /// Mean 2X vector.
    pub x2: [Complex<T>; NC],
    /// Standard error of the mean 2X vector.
    pub x2_std: [T; NC],
}

/// What [`OrderTracker::push`] gives when a revolution closes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Output<T, const NC: usize> {
    /// The revolution that closed.
    pub revolution: Revolution<T, NC>,
    /// The average its acceptance completed, if it did.
    pub average: Option<Average<T, NC>>,
}

/// Running mean, scatter and trend of one complex series (Welford).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Moments<T> {
    mean: Complex<T>,
    /// `sum (r - rbar)(Y - Ybar)`.
    cross: Complex<T>,
    /// `sum |Y - Ybar|^2`.
    m2: T,
}

impl<T: Real> Moments<T> {
    fn zero() -> Self {
        let z = Complex::new(T::zero(), T::zero());
        Moments {
            mean: z,
            cross: z,
            m2: T::zero(),
        }
    }

    /// Adds `y` with revolution offset `dr = r - rbar_old`, count `n` after it.
    fn add(&mut self, y: Complex<T>, dr: T, n: T) {
        let d = y - self.mean;
        self.mean += d.unscale(n);
        let d2 = y - self.mean;
        self.cross += d2.scale(dr);
        self.m2 += d.re * d2.re + d.im * d2.im;
    }

    /// `sqrt(s^2 / n)` with `s^2 = rss / (n - spent)`; `rss` about the mean
    /// or about the line (`m2r = sum (r - rbar)^2 > 0`).
    fn std_error(&self, scatter: Scatter, m2r: T, n: u32) -> T {
        let rss = match scatter {
            Scatter::Mean => self.m2,
            Scatter::Trend => {
                let c = T::magnitude(self.cross.re, self.cross.im) / m2r.sqrt();
                self.m2 - c * c
            }
        };
        let rss = if rss > T::zero() { rss } else { T::zero() };
        let dof = T::from_u32(n.saturating_sub(scatter.spent())).unwrap_or_else(T::zero);
        (rss / (dof * T::from_u32(n).unwrap_or_else(T::zero))).sqrt()
    }
}

/// The running average of the current group.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Averager<T, const NC: usize> {
    pub(crate) n: u32,
    start: Option<EventTime<T>>,
    end: Option<EventTime<T>>,
    /// Revolution number (closed revolutions, any outcome) at the group's start.
    seq0: u64,
    rmean: T,
    m2r: T,
    speed: T,
    x1: [Moments<T>; NC],
    x2: [Moments<T>; NC],
}

impl<T: Real, const NC: usize> Averager<T, NC> {
    pub(crate) fn new() -> Self {
        Averager {
            n: 0,
            start: None,
            end: None,
            seq0: 0,
            rmean: T::zero(),
            m2r: T::zero(),
            speed: T::zero(),
            x1: [Moments::zero(); NC],
            x2: [Moments::zero(); NC],
        }
    }

    pub(crate) fn add(
        &mut self,
        seq: u64,
        (start, end): (EventTime<T>, EventTime<T>),
        speed: T,
        o: &Orders<T, NC>,
    ) {
        if self.n == 0 {
            *self = Self::new();
            self.start = Some(start);
            self.seq0 = seq;
        }
        self.end = Some(end);
        self.n = self.n.saturating_add(1);
        let n = T::from_u32(self.n).unwrap_or_else(T::zero);
        let r = T::from_u64(seq.wrapping_sub(self.seq0)).unwrap_or_else(T::zero);
        let dr = r - self.rmean;
        self.rmean += dr / n;
        self.m2r += dr * (r - self.rmean);
        self.speed += (speed - self.speed) / n;
        for (m, y) in self.x1.iter_mut().zip(o.x1.iter()) {
            m.add(*y, dr, n);
        }
        for (m, y) in self.x2.iter_mut().zip(o.x2.iter()) {
            m.add(*y, dr, n);
        }
    }

    /// The group's average if it has more revolutions than the scatter
    /// spends; the group is emptied either way.
    pub(crate) fn finish(&mut self, scatter: Scatter) -> Option<Average<T, NC>> {
        let n = self.n;
        self.n = 0;
        let (start, end) = (self.start.take()?, self.end.take()?);
        if n <= scatter.spent() {
            return None;
        }
        let m2r = self.m2r;
        let avg = Average {
            revolutions: n,
            start,
            end,
            speed: self.speed,
            x1: self.x1.map(|m| m.mean),
            x1_std: self.x1.map(|m| m.std_error(scatter, m2r, n)),
            x2: self.x2.map(|m| m.mean),
            x2_std: self.x2.map(|m| m.std_error(scatter, m2r, n)),
        };
        let ok = |z: &Complex<T>| z.re.is_finite() && z.im.is_finite();
        let finite = avg.x1.iter().chain(avg.x2.iter()).all(ok)
            && avg
                .x1_std
                .iter()
                .chain(avg.x2_std.iter())
                .all(|s| s.is_finite())
            && avg.speed.is_finite();
        finite.then_some(avg)
    }
}

/// The synchronous 1X/2X extractor of the module documentation, for `NC`
/// probe channels and revolutions of up to `CAP - 7` samples (one
/// revolution buffered, `NC CAP` values inline).
///
/// ```
/// use rotorid_core::ordertrack::{Config, OrderTracker};
/// use rotorid_core::Complex;
///
/// // 2 probes, 2560 Hz, a shaft at 25 Hz (102.4 samples per revolution).
/// let (fs, f) = (2560.0, 25.0);
/// let w = 2.0 * core::f64::consts::PI * f;
/// let config = Config::new(fs, 0.5, 100.0, 200.0).with_revolutions(4);
/// let mut t = OrderTracker::<f64, 2, 256>::new(config).unwrap();
/// let mut avg = None;
/// for i in 0..2000 {
///     let theta = w * i as f64 / fs + 1.0;
///     // A pulse rising linearly through 0.5 as the mark passes (theta = 0 mod 2 pi).
///     let u = (theta + core::f64::consts::PI).rem_euclid(2.0 * core::f64::consts::PI)
///         - core::f64::consts::PI;
///     let kp = (0.5 + u / 0.3).clamp(0.0, 1.0) * f64::from(u < 1.0);
///     let y = [2e-6 * (theta + 0.5).cos() + 1e-6, 1e-6 * (2.0 * theta).sin()];
///     if let Some(out) = t.push(kp, &y) {
///         avg = avg.or(out.average);
///     }
/// }
/// let a = avg.unwrap();
/// assert_eq!(a.revolutions, 4);
/// assert!((a.speed - w).abs() < 1e-9 * w);
/// assert!((a.x1[0] - Complex::from_polar(2e-6, 0.5)).norm() < 1e-14);
/// // sin(2 theta) = cos(2 theta - pi/2).
/// assert!((a.x2[1] - Complex::new(0.0, -1e-6)).norm() < 1e-14);
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct OrderTracker<T, const NC: usize, const CAP: usize> {
    config: Config<T>,
    kp: Keyphasor<T>,
    /// The samples from the open revolution's start (two before its start
    /// event), or the last few when none is open.
    buf: [[T; NC]; CAP],
    len: usize,
    /// Index of `buf[0]` in the stream.
    base: u64,
    /// The open revolution's start event.
    start: Option<EventTime<T>>,
    /// The two last periods (samples): `[P', P]`.
    periods: [Option<T>; 2],
    /// Revolutions closed.
    seq: u64,
    counts: Counts,
    avg: Averager<T, NC>,
    /// The integration rule's constant weights ([`Rule`]).
    rule: Rule<T>,
}

impl<T: Real, const NC: usize, const CAP: usize> OrderTracker<T, NC, CAP> {
    /// A tracker with `config` ([`Config::validate`] with capacity `CAP`).
    pub fn new(config: Config<T>) -> Result<Self, ConfigError> {
        config.validate(CAP)?;
        Ok(OrderTracker {
            kp: Keyphasor::new(config.level, config.hysteresis)?,
            config,
            buf: [[T::zero(); NC]; CAP],
            len: 0,
            base: 0,
            start: None,
            periods: [None; 2],
            seq: 0,
            counts: Counts::default(),
            avg: Averager::new(),
            rule: Rule::new(),
        })
    }

    /// The configuration.
    pub fn config(&self) -> &Config<T> {
        &self.config
    }

    /// Revolutions closed so far, by outcome.
    pub fn counts(&self) -> &Counts {
        &self.counts
    }

    /// Samples taken so far.
    pub fn samples(&self) -> u64 {
        self.kp.samples()
    }

    /// Back to the state of [`OrderTracker::new`] (counts and the group
    /// being averaged included).
    pub fn reset(&mut self) {
        self.kp.reset();
        self.len = 0;
        self.base = 0;
        self.start = None;
        self.periods = [None; 2];
        self.seq = 0;
        self.counts = Counts::default();
        self.avg = Averager::new();
    }

    /// The average of the revolutions accepted since the last average, if
    /// there are more than the scatter spends (2, or 3 about the trend);
    /// for the end of a recording. The group is emptied either way.
    pub fn flush(&mut self) -> Option<Average<T, NC>> {
        self.avg.finish(self.config.scatter)
    }

    /// One sampling instant: `kp` the keyphasor channel, `y` the probes.
    /// Returns the revolution that closed at this sample, if any (with the
    /// average it completed). Any input is taken, finite or not.
    pub fn push(&mut self, kp: T, y: &[T; NC]) -> Option<Output<T, NC>> {
        let mut out = None;
        if self.len >= CAP {
            // A full buffer: the open revolution has run longer than any
            // allowed (CAP exceeds the slowest by 7 samples).
            if let Some(start) = self.start.take() {
                out = Some(self.drop_open(start, Rejection::NoEvent));
            }
        }
        if self.start.is_none() && self.len >= HISTORY {
            self.keep_from(self.len - (HISTORY - 1));
        }
        if let Some(slot) = self.buf.get_mut(self.len) {
            *slot = *y;
            self.len += 1;
        }
        match self.kp.push(kp) {
            Crossing::None => {}
            Crossing::Invalid => {
                if let Some(start) = self.start.take() {
                    out = Some(self.drop_open(start, Rejection::NonFinite));
                }
                self.periods = [None; 2];
            }
            Crossing::Event(e) => {
                if let Some(start) = self.start {
                    out = Some(self.close(start, e));
                }
                self.open(e);
            }
        }
        out
    }

    /// Drops the buffer's first `from` samples.
    fn keep_from(&mut self, from: usize) {
        if from > 0 && from <= self.len {
            self.buf.copy_within(from..self.len, 0);
            self.len -= from;
            self.base = self.base.wrapping_add(from as u64);
        }
    }

    /// Opens a revolution at event `e`: the buffer keeps the samples from
    /// two before the event's sample (fewer when the stream is that young).
    fn open(&mut self, e: EventTime<T>) {
        self.start = Some(e);
        let first = e.sample.saturating_sub(2);
        if first > self.base {
            let from = first - self.base;
            self.keep_from(usize::try_from(from).unwrap_or(usize::MAX));
        }
    }

    /// A revolution dropped without its end event.
    fn drop_open(&mut self, start: EventTime<T>, cause: Rejection) -> Output<T, NC> {
        self.seq = self.seq.wrapping_add(1);
        self.periods = [None; 2];
        self.counts.add(Err(cause));
        let now = EventTime {
            sample: self.kp.samples().wrapping_sub(1),
            frac: T::zero(),
        };
        Output {
            revolution: Revolution {
                start,
                samples: now.since(&start),
                speed: T::zero(),
                acceleration: T::zero(),
                result: Err(cause),
            },
            average: None,
        }
    }

    /// Closes the revolution `[start, end]` (the buffer ends at the sample
    /// after `end.sample`).
    fn close(&mut self, start: EventTime<T>, end: EventTime<T>) -> Output<T, NC> {
        self.seq = self.seq.wrapping_add(1);
        let t = end.since(&start);
        let [p_prev, p] = self.periods;
        self.periods = [p, Some(t)];
        let c = &self.config;
        let tau = T::two_pi();
        let speed = tau * c.sample_rate / t;
        // The quadratic angle (module documentation), rad / sample^2, rad / sample.
        let (a, w) = match p {
            Some(p) => {
                let a = T::lit(2.0) * tau * (p - t) / (t * p * (t + p));
                (a, tau / t - a * t / T::lit(2.0))
            }
            None => (T::zero(), tau / t),
        };
        let acceleration = a * c.sample_rate * c.sample_rate;
        let timing = c.timing(t, [p_prev, p], speed, true);
        let result = timing.and_then(|()| self.integrate(&start, &end, w, a));
        self.counts.add(result.map(|_| ()));
        let mut average = None;
        if let Ok(o) = &result {
            self.avg.add(self.seq, (start, end), speed, o);
            if self.avg.n >= self.config.revolutions {
                average = self.avg.finish(self.config.scatter);
            }
        }
        Output {
            revolution: Revolution {
                start,
                samples: t,
                speed,
                acceleration,
                result,
            },
            average,
        }
    }

    /// The 1X and 2X vectors of the revolution `[start, end]`, angle
    /// `theta(tau) = w tau + a tau^2 / 2` (module documentation).
    fn integrate(
        &self,
        start: &EventTime<T>,
        end: &EventTime<T>,
        w: T,
        a: T,
    ) -> Result<Orders<T, NC>, Rejection> {
        let two = T::lit(2.0);
        // Buffer offset of sample c_a - 2, and the count through c_b + 1.
        let first = start.sample.checked_sub(2).ok_or(Rejection::NoReference)?;
        let s0 = first.checked_sub(self.base).ok_or(Rejection::NoReference)?;
        let s0 = usize::try_from(s0).map_err(|_| Rejection::NoReference)?;
        let span = end
            .sample
            .checked_sub(start.sample)
            .ok_or(Rejection::PeriodJump)?;
        let len = usize::try_from(span)
            .ok()
            .and_then(|s| s.checked_add(4))
            .ok_or(Rejection::Undersampled)?;
        if len < 2 * 6 + 1 {
            return Err(Rejection::Undersampled);
        }
        let rows = s0
            .checked_add(len)
            .and_then(|e| self.buf.get(s0..e))
            .ok_or(Rejection::NoReference)?;
        let (head, tail) = self.rule.end_weights(start.frac, end.frac);

        // tau of the first sample, c_a - 2: -(2 + frac_a).
        let tau0 = -(two + start.frac);
        let theta0 = w * tau0 + a * tau0 * tau0 / two;
        let mut p = exp_neg_j(theta0, series_terms(theta0.abs()));
        let d0 = w + a * (tau0 + T::lit(0.5));
        let e = exp_neg_j(d0, series_terms(d0.abs()));
        let chirp = series_terms(a.abs() * count(len));
        let mut rotation = Chirp::new(a);

        let (lo, hi) = (self.config.adc_min, self.config.adc_max);
        // Bit 31: a sample at or beyond an ADC limit (or infinite).
        let mut outside = 0u32;
        let zero = Complex::new(T::zero(), T::zero());
        let mut x1 = [zero; NC];
        let mut x2 = [zero; NC];
        // The first sample of each channel is taken off every sample: a
        // constant integrates to zero, and the sums then carry the
        // vibration, not a probe's gap (100 times larger), in their
        // rounding.
        let reference = rows.first().copied().unwrap_or([T::zero(); NC]);
        // The six samples at each end with their weights, every sample
        // between with weight 1 (`len >= 13`, tested above).
        let last = len - 6;
        // The sample number as a float, counted (exact below 2^24).
        let mut fi = T::zero();
        // Blocks of samples: first the block's phasors, shared by the
        // channels, then each channel over the block with its block sums in
        // registers (no loop over the channels per sample, whose sums would
        // live in memory where the channel loop is not unrolled).
        let mut q = [[zero; 2]; BLOCK];
        for (b, block) in rows.chunks(BLOCK).enumerate() {
            let base = b * BLOCK;
            for (k, qk) in q.iter_mut().take(block.len()).enumerate() {
                let g = base + k;
                let weight = if g < 6 {
                    head.get(g)
                } else if g >= last {
                    tail.get(g - last)
                } else {
                    None
                };
                let weight = weight.copied().unwrap_or_else(T::one);
                let q1 = p.scale((w + a * (tau0 + fi)) * weight);
                *qk = [q1, q1 * p];
                let d = match chirp {
                    0 => e,
                    1..=3 => e * rotation.next(),
                    n => e * exp_neg_j(a * fi, n),
                };
                fi += T::one();
                let z = p * d;
                p = z.scale(T::lit(1.5) - z.norm_sqr() * T::lit(0.5));
            }
            for (c, (s1, s2)) in x1.iter_mut().zip(x2.iter_mut()).enumerate() {
                let y0 = reference.get(c).copied().unwrap_or_else(T::zero);
                let (mut b1, mut b2) = (zero, zero);
                for (row, [q1, q2]) in block.iter().zip(q.iter()) {
                    let y = row.get(c).copied().unwrap_or_else(T::zero);
                    // (lo - y)(y - hi) > 0 inside the ADC range, <= 0 (sign
                    // bit set, -0 included) at or beyond a limit or at an
                    // infinity: exact, since a difference of floats has the
                    // sign of the exact one and is 0 only for equal values.
                    // A NaN ends in the sums and is found below.
                    outside |= ((lo - y) * (y - hi)).sign_word();
                    let v = y - y0;
                    b1 += q1.scale(v);
                    b2 += q2.scale(v);
                }
                *s1 += b1;
                *s2 += b2;
            }
        }
        let inv_pi = T::one() / T::pi();
        let x1 = x1.map(|z| z.scale(inv_pi));
        let x2 = x2.map(|z| z.scale(inv_pi));
        let ok = |z: &Complex<T>| z.re.is_finite() && z.im.is_finite();
        if outside >> 31 == 0 && x1.iter().chain(x2.iter()).all(ok) {
            return Ok(Orders { x1, x2 });
        }
        // The rare path: which fault, in the order of the module
        // documentation (a non-finite sample, then a clipped one, then an
        // overflow).
        let flat = rows.iter().flat_map(|r| r.iter());
        if flat.clone().any(|y| !y.is_finite()) {
            Err(Rejection::NonFinite)
        } else if flat.clone().any(|y| !(*y > lo && *y < hi)) {
            Err(Rejection::Clipped)
        } else {
            Err(Rejection::NonFinite)
        }
    }
}

/// `w_j = integral over x in [lo, hi] of l_j(x) dx`, `l_j` the Lagrange
/// basis polynomials on the six nodes `x_k = o + k`, `k = 0..6` (degree 5):
/// the weights of the samples `o .. o + 5` (relative to the interval's left
/// sample) in the integral of their interpolant over `[lo, hi]`, a part of
/// the interval `[0, 1]`.
///
/// `l_j(x) = prod_(k != j) (x - x_k) / (x_j - x_k)`; its coefficients come
/// from the product of the linear factors, and the integral from the
/// antiderivative `sum_m c_m (hi^(m+1) - lo^(m+1)) / (m + 1)`.
// index proven: `m <= deg <= 5` and `m - 1 >= 0` in the product loop, `m < 6`
// in the integral; the arrays have 6 entries.
#[allow(clippy::indexing_slicing)]
pub fn lagrange_integrals<T: Real>(o: i32, lo: T, hi: T) -> [T; 6] {
    let mut out = [T::zero(); 6];
    for (j, wj) in out.iter_mut().enumerate() {
        let mut c = [T::zero(); 6];
        c[0] = T::one();
        let mut deg = 0;
        let mut den = T::one();
        for k in 0..6usize {
            if k == j {
                continue;
            }
            let xk: T = int(o.saturating_add(k as i32));
            // c(x) <- c(x) (x - x_k)
            for m in (1..=deg + 1).rev() {
                c[m] = c[m - 1] - xk * c[m];
            }
            c[0] = -xk * c[0];
            deg += 1;
            den *= int::<T>(j as i32 - k as i32);
        }
        let (mut ph, mut pl) = (hi, lo);
        let mut s = T::zero();
        for (m, cm) in c.iter().enumerate() {
            s += *cm * (ph - pl) / count::<T>(m + 1);
            ph *= hi;
            pl *= lo;
        }
        *wj = s / den;
    }
    out
}

/// The antiderivatives `F_j(x) = integral over [0, x] of l_j`, `l_j` the
/// Lagrange basis polynomials of [`lagrange_integrals`] on the nodes
/// `-2 .. 3` and `-4 .. 1` (the rule's first and last intervals), times
/// 1440: `1440 F_j(x) = sum_(m = 1..6) N_jm x^m`, integers (the
/// denominators of `l_j`, `j! (5 - j)!`, and `m` divide 1440). Derived with
/// exact rationals; `antiderivative_tables_are_the_lagrange_integrals`
/// checks them against [`lagrange_integrals`].
const ANTIDERIVATIVE_CENTRED: [[i16; 6]; 6] = [
    [0, 36, -20, -15, 12, -2],
    [0, -360, 320, -15, -48, 10],
    [1440, -240, -600, 150, 72, -20],
    [0, 720, 320, -210, -48, 20],
    [0, -180, -20, 105, 12, -10],
    [0, 24, 0, -15, 0, 2],
];

/// As [`ANTIDERIVATIVE_CENTRED`], on the nodes `-4 .. 1`.
const ANTIDERIVATIVE_LAST: [[i16; 6]; 6] = [
    [0, 36, 20, -15, -12, -2],
    [0, -240, -120, 105, 72, 10],
    [0, 720, 280, -330, -168, -20],
    [0, -1440, -80, 510, 192, 20],
    [1440, 780, -300, -375, -108, -10],
    [0, 144, 200, 105, 24, 2],
];

/// `F_j(x)` of one of the tables above (Horner, about 40 operations; no
/// division but the one by 1440).
// index proven: `j < 6`, `m < 6` on arrays of 6.
#[allow(clippy::indexing_slicing)]
fn antiderivative<T: Real>(table: &[[i16; 6]; 6], x: T) -> [T; 6] {
    let scale = T::one() / int::<T>(1440);
    let mut out = [T::zero(); 6];
    // Plain index loops: the same operations as a fold over the rows, but
    // no iterator adapters left to a size-optimised build.
    for j in 0..6 {
        let mut f = T::zero();
        let mut m = 6;
        while m > 0 {
            m -= 1;
            f = (f + int::<T>(i32::from(table[j][m]))) * x;
        }
        out[j] = f * scale;
    }
    out
}

/// The weights of the rule that do not depend on where the events fall
/// between samples, computed once ([`OrderTracker::new`]): the six head and
/// the six tail weights for events right on a sample (`frac = 0`), to which
/// [`Rule::end_weights`] adds the parts that depend on the events' fractions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Rule<T> {
    head0: [T; 6],
    tail0: [T; 6],
}

impl<T: Real> Rule<T> {
    // index proven: `m + j < 6` and `t + m - 1 < 6` are tested before use.
    #[allow(clippy::indexing_slicing)]
    pub(crate) fn new() -> Self {
        // Centred interval (nodes -2 .. 3) and last whole interval (-3 .. 2).
        let v = lagrange_integrals::<T>(-2, T::zero(), T::one());
        let u3 = lagrange_integrals::<T>(-3, T::zero(), T::one());
        // Head: `[c_a, c_a + 1]` whole (the start event's part is taken off
        // in `end_weights`) and the centred intervals c_a + m (m >= 1):
        // nodes c_a + m - 2 + j.
        let mut head0 = v;
        for m in 1..6 {
            for (j, vj) in v.iter().enumerate() {
                if m + j < 6 {
                    head0[m + j] += *vj;
                }
            }
        }
        // Tail sample t is c_b - 4 + t; interval c_b - 1 - m (m >= 1) is
        // centred with nodes c_b - 3 - m + j: t = j + 1 - m.
        let mut tail0 = [T::zero(); 6];
        for (t, wt) in tail0.iter_mut().enumerate() {
            *wt = u3[t];
            for m in 1..7 {
                if t + m >= 1 && t + m - 1 < 6 {
                    *wt += v[t + m - 1];
                }
            }
        }
        Rule { head0, tail0 }
    }

    /// The weights of the six samples at each end of a revolution whose
    /// start event lies `frac_a` after sample `c_a` and end event `frac_b`
    /// after sample `c_b` (fractions in `(0, 1]`): `head` for samples
    /// `c_a - 2 .. c_a + 3`, `tail` for `c_b - 4 .. c_b + 1`; every sample
    /// between weighs 1 (module documentation). The intervals: `[c_a, c_a +
    /// 1]` from `frac_a` (nodes `c_a - 2 ..`), full ones centred, `[c_b - 1,
    /// c_b]` on nodes `c_b - 4 .. c_b + 1`, `[c_b, c_b + 1]` to `frac_b` on
    /// the same. Needs at least 15 whole intervals between the events.
    /// `head = head0 - F(frac_a)` on the nodes `-2 .. 3`, `tail = tail0 +
    /// F(frac_b)` on `-4 .. 1` ([`antiderivative`]).
    fn end_weights(&self, frac_a: T, frac_b: T) -> ([T; 6], [T; 6]) {
        (self.head(frac_a), self.tail(frac_b))
    }

    /// The head weights of [`Rule::end_weights`]: samples `c_a - 2 .. c_a +
    /// 3` of a start event `frac_a` after sample `c_a`.
    pub(crate) fn head(&self, frac_a: T) -> [T; 6] {
        let fa = antiderivative(&ANTIDERIVATIVE_CENTRED, frac_a);
        let mut head = self.head0;
        for (h, f) in head.iter_mut().zip(fa.iter()) {
            *h -= *f;
        }
        head
    }

    /// The tail weights of [`Rule::end_weights`]: samples `c_b - 4 .. c_b +
    /// 1` of an end event `frac_b` after sample `c_b`.
    pub(crate) fn tail(&self, frac_b: T) -> [T; 6] {
        let fb = antiderivative(&ANTIDERIVATIVE_LAST, frac_b);
        let mut tail = self.tail0;
        for (t, f) in tail.iter_mut().zip(fb.iter()) {
            *t += *f;
        }
        tail
    }
}

/// Samples per block of the integral's loop ([`OrderTracker::integrate`]).
const BLOCK: usize = 8;

/// Most terms of the series of [`exp_neg_j`].
const SERIES_TERMS: usize = 12;

/// The terms (in `e^2`, beyond the first) of the series of [`exp_neg_j`]
/// that bring its remainder below the precision for `|e| <= e_max` (at most
/// [`SERIES_TERMS`]; 0 when `e_max` is 0 or not finite).
pub(crate) fn series_terms<T: Real>(e_max: T) -> usize {
    if !(e_max.is_finite() && e_max > T::zero()) {
        return 0;
    }
    let z = e_max * e_max;
    let mut term = T::one();
    for m in 1..=SERIES_TERMS {
        term *= z / count::<T>((2 * m - 1) * (2 * m));
        if term < T::EPS / int(8) {
            return m;
        }
    }
    SERIES_TERMS
}

/// `exp(-j e) = cos e - j sin e` by the series of the cosine and the sine
/// in `e^2` to `terms` terms (Horner: `cos e = 1 - e^2 / (1 2) (1 - e^2 /
/// (3 4) (1 - ...))`, `sin e = e (1 - e^2 / (2 3) (1 - ...))`).
pub(crate) fn exp_neg_j<T: Real>(e: T, terms: usize) -> Complex<T> {
    let z = e * e;
    let (mut c, mut s) = (T::one(), T::one());
    for m in (1..=terms.min(SERIES_TERMS)).rev() {
        c = T::one() - z * c / count::<T>((2 * m - 1) * (2 * m));
        s = T::one() - z * s / count::<T>(2 * m * (2 * m + 1));
    }
    Complex::new(c, -e * s)
}

/// `exp(-j a i)` for `i = 0, 1, ...`, the chirp of a revolution whose
/// `|a| len` is small (at most three terms of [`exp_neg_j`]: in `f32`
/// always with the default period ratio of 0.1), carried from sample to
/// sample as `(1 - c_i) - j s_i` with `c_i = 1 - cos(a i)` and `s_i =
/// sin(a i)` themselves, not their complement: multiplying by `exp(-j a) =
/// (1 - c_r) - j s_r`,
///
/// ```text
/// c_(i+1) = c_i + (c_r (1 - c_i) + s_i s_r),
/// s_(i+1) = s_i + (s_r (1 - c_i) - s_i c_r),
/// ```
///
/// where small `c_i`, `s_i` keep their relative precision: a rounding of
/// `eps` relative per step puts `sqrt(i) eps |a i|` into the phase, against
/// `sqrt(i) eps` for the rotation of a unit phasor (whose error would add up
/// in the angle as `M^1.5 eps`). `c_r = a^2 / 2 (1 - a^2 / 12 (1 - a^2 /
/// 30))`, `s_r = a (1 - a^2 / 6 (1 - a^2 / 20 (1 - a^2 / 42)))`: the series
/// to the precision for the `|a| < 0.05 / 16` of this use. About 11
/// operations a sample, with the product by `E`, against some 30 for the
/// series of `a i` at each sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Chirp<T> {
    c: T,
    s: T,
    cr: T,
    sr: T,
}

impl<T: Real> Chirp<T> {
    pub(crate) fn new(a: T) -> Self {
        let z = a * a;
        let one = T::one();
        Chirp {
            c: T::zero(),
            s: T::zero(),
            cr: z * T::lit(0.5) * (one - z * T::lit(1.0 / 12.0) * (one - z * T::lit(1.0 / 30.0))),
            sr: a
                * (one
                    - z * T::lit(1.0 / 6.0)
                        * (one - z * T::lit(1.0 / 20.0) * (one - z * T::lit(1.0 / 42.0)))),
        }
    }

    /// `exp(-j a i)` of this step, then on to `i + 1`.
    #[inline(always)]
    pub(crate) fn next(&mut self) -> Complex<T> {
        let one_c = T::one() - self.c;
        let u = Complex::new(one_c, -self.s);
        let (c, s) = (self.c, self.s);
        self.c = c + (self.cr * one_c + s * self.sr);
        self.s = s + (self.sr * one_c - s * self.cr);
        u
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centred_weights_are_the_known_ones() {
        let v = lagrange_integrals::<f64>(-2, 0.0, 1.0);
        let want = [11.0, -93.0, 802.0, 802.0, -93.0, 11.0].map(|x| x / 1440.0);
        for (a, b) in v.iter().zip(want.iter()) {
            assert!((a - b).abs() < 1e-15, "{v:?}");
        }
        assert!((v.iter().sum::<f64>() - 1.0).abs() < 1e-15);
    }

    /// The rule over `[c_a + frac_a, c_b + frac_b]` with dense weights,
    /// interval by interval, against the head / plain / tail split.
    #[test]
    fn end_weights_match_the_rule_interval_by_interval() {
        for &(fa, fb, cells) in &[(0.3, 0.7, 15usize), (1.0, 0.01, 20), (0.999, 1.0, 40)] {
            // Samples c_a - 2 .. c_b + 1 at offsets 0 .. cells + 4.
            let n = cells + 4;
            let mut dense = std::vec![0.0f64; n];
            for k in 0..=cells {
                // Interval c_a + k: offset of its left sample is k + 2.
                let (o, lo, hi) = if k == 0 {
                    (-2, fa, 1.0)
                } else if k == cells {
                    (-4, 0.0, fb)
                } else if k == cells - 1 {
                    (-3, 0.0, 1.0)
                } else {
                    (-2, 0.0, 1.0)
                };
                let w = lagrange_integrals::<f64>(o, lo, hi);
                for (j, wj) in w.iter().enumerate() {
                    dense[(k as i64 + 2 + o as i64 + j as i64) as usize] += wj;
                }
            }
            let (head, tail) = Rule::new().end_weights(fa, fb);
            for (i, d) in dense.iter().enumerate() {
                let split = if i < 6 {
                    head[i]
                } else if i >= n - 6 {
                    tail[i - (n - 6)]
                } else {
                    1.0
                };
                assert!(
                    (d - split).abs() < 1e-14,
                    "{fa} {fb} {cells}: {i}: {d} {split}"
                );
            }
            // Exact for polynomials up to degree 5: x^5 over the span.
            let (ua, ub) = (fa, cells as f64 + fb);
            let exact = (ub.powi(6) - ua.powi(6)) / 6.0;
            let rule: f64 = dense
                .iter()
                .enumerate()
                .map(|(i, w)| w * (i as f64 - 2.0).powi(5))
                .sum();
            assert!((rule - exact).abs() < 1e-9 * exact.abs(), "{rule} {exact}");
        }
    }

    /// The state is the buffer, `NC CAP` samples, and under 512 bytes
    /// (f32) or 800 bytes (f64) beside it for `NC = 4`; run with
    /// `--nocapture` for the numbers.
    #[test]
    fn the_state_is_the_buffer_and_a_few_hundred_bytes() {
        let f32_size = core::mem::size_of::<OrderTracker<f32, 4, 1024>>();
        let f64_size = core::mem::size_of::<OrderTracker<f64, 4, 1024>>();
        std::println!(
            "ordertrack state, NC 4, CAP 1024: f32 {f32_size} bytes (buffer 16384), \
             f64 {f64_size} bytes (buffer 32768)"
        );
        assert!(f32_size - 4 * 1024 * 4 < 512);
        assert!(f64_size - 4 * 1024 * 8 < 800);
    }

    #[test]
    fn the_series_is_exp_to_the_precision() {
        for &e in &[0.0f64, 1e-9, 3e-5, 0.01, 0.2, 0.5, 1.0, 1.2, 1.5] {
            let terms = series_terms(e);
            let terms32 = series_terms(e as f32);
            for x in [e, -e, 0.5 * e] {
                let z = exp_neg_j(x, terms);
                let want = Complex::new(x.cos(), -x.sin());
                assert!((z - want).norm() < 2.0 * f64::EPSILON, "{x}: {z} {want}");
                let z = exp_neg_j(x as f32, terms32);
                assert!((z.re as f64 - x.cos()).abs() < 2.0 * f32::EPSILON as f64);
                assert!((z.im as f64 + x.sin()).abs() < 2.0 * f32::EPSILON as f64);
            }
        }
        assert_eq!(series_terms(0.0f64), 0);
        assert_eq!(series_terms(3e-5f64), 2);
        assert_eq!(series_terms(f64::NAN), 0);
        // The chirp |a| len, about 0.63 / T with the default period ratio
        // (0.1) for T samples per revolution: three terms in f32 down to 16
        // samples (|a| len < 0.05); in f64 up to |a| len = 1e-3 (a 10 %/s
        // ramp at 50 Hz and 25.6 kHz: 2.5e-5), beyond it the general series.
        assert!(series_terms(0.05f32) <= 3 && series_terms(1e-3f64) <= 3);
        assert!(series_terms(0.05f64) > 3);
    }

    /// The chirp's recurrence against `exp(-j a i)` over 2000 steps, for the
    /// ramps of the tests and of the firmware and the largest `|a|` it is
    /// used for (`|a| len` up to 0.05 with 16 samples).
    #[test]
    fn the_chirp_recurrence_is_exp_to_the_precision() {
        for &a in &[4.8e-8f64, -4.8e-8, 1.4e-6, -1.35e-5, 3e-3 / 16.0] {
            let (mut r64, mut r32) = (Chirp::new(a), Chirp::new(a as f32));
            let mut worst = [0.0f64; 2];
            for i in 0..2000 {
                let x = a * i as f64;
                let want = Complex::new(x.cos(), -x.sin());
                let z = r64.next();
                worst[0] = worst[0].max((z - want).norm() / f64::EPSILON);
                let z = r32.next();
                let z = Complex::new(z.re as f64, z.im as f64);
                // Against the f32 value's own rounding of a32 i.
                let x = (a as f32) as f64 * i as f64;
                let want = Complex::new(x.cos(), -x.sin());
                worst[1] = worst[1].max((z - want).norm() / f32::EPSILON as f64);
            }
            std::println!(
                "chirp a {a:e}: worst error {:.2} eps (f64), {:.2} eps (f32)",
                worst[0],
                worst[1]
            );
            assert!(worst[0] < 4.0 && worst[1] < 4.0, "{a}: {worst:?}");
        }
    }

    /// The integer antiderivative tables against [`lagrange_integrals`]
    /// over `[0, x]`.
    #[test]
    fn antiderivative_tables_are_the_lagrange_integrals() {
        for &x in &[0.0f64, 0.01, 0.3, 0.5, 0.77, 1.0] {
            for (o, table) in [(-2, &ANTIDERIVATIVE_CENTRED), (-4, &ANTIDERIVATIVE_LAST)] {
                let f = antiderivative(table, x);
                let g = lagrange_integrals(o, 0.0, x);
                for (a, b) in f.iter().zip(g.iter()) {
                    assert!((a - b).abs() < 1e-15, "{o} {x}: {f:?} {g:?}");
                }
            }
        }
    }
}
