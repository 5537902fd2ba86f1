//! Streaming 1X order tracking: the vectors of [`crate::ordertrack`]
//! without a revolution buffer, for the firmware path.
//!
//! [`crate::ordertrack::OrderTracker`] keeps a whole revolution of samples
//! and integrates it once its end event is found, because the angle of a
//! sample is known only then. This tracker integrates each sample as it
//! comes, with the angle *predicted* from the three events before the
//! revolution, and checks the prediction at the end event: a revolution
//! whose end event misses the predicted angle by more than a tolerance is
//! rejected. It keeps 32 samples per channel instead of a revolution (for
//! `NC = 4` in `f32` the whole state is 1 KiB), and its work is spread
//! over the samples (a block of 16 at a time, and a few thousand
//! operations once a revolution). It gives 1X only (the identification's input); 2X and the
//! exact-angle rule are [`crate::ordertrack::OrderTracker`]'s.
//!
//! # The predicted angle
//!
//! Revolution `k` runs from event `u_k` to `u_(k+1)`; the two periods before
//! it are `P' = u_(k-1) - u_(k-2)` and `P = u_k - u_(k-1)` (samples). The
//! quadratic through the events at `theta = -4 pi, -2 pi, 0`, with `tau`
//! the time since `u_k` (samples):
//!
//! ```text
//! theta^(tau) = w tau + a tau^2 / 2                     (rad)
//! a = 4 pi (P' - P) / (P P' (P + P'))                   (rad / sample^2)
//! w = 2 pi / P + a P / 2                                (rad / sample)
//! ```
//!
//! (`theta^(-P) = -2 pi`, `theta^(-P - P') = -4 pi`). At constant angular
//! acceleration (a linear speed ramp, a constant speed) it is the angle of
//! [`crate::ordertrack`] itself, the quadratic through `u_(k-1), u_k,
//! u_(k+1)`, so the two trackers give the same vectors (up to rounding and
//! the events' timing). Where the acceleration changes, the angle is off by
//! `delta(tau) = c tau (tau + P)` (zero at the two events both quadratics
//! share), known at the end event from the prediction's miss
//!
//! ```text
//! e = 2 pi - theta^(T) = c T (T + P),      T = u_(k+1) - u_k,
//! ```
//!
//! and the vector is then off by less than `|e|` relative (first order in
//! `delta`: `dY = (1 / pi) integral of y exp(-j theta) (d delta - j delta
//! dtheta)`, and `|delta| <= |e|` over the revolution; measured, 0.67 `|e|`
//! at most). A revolution with `|e|` above
//! [`StreamTracker::angle_tolerance`] (default [`DEFAULT_ANGLE_TOLERANCE`],
//! 1e-3 rad: the vectors within 1e-3 relative, 0.06 degrees) is rejected
//! as [`Rejection::PeriodJump`]. For scale: on a coast-down whose
//! deceleration follows `Omega^2` at 20 % per second, 50 Hz, `|e|` is
//! about 2e-4 rad; on a linear ramp of 10 % per second it is the events'
//! timing error, 2e-8 rad.
//!
//! # The integral, sample by sample
//!
//! The rule is [`crate::ordertrack`]'s: `Y = (1 / pi) sum_i W_i y_i
//! exp(-j theta_i) theta'_i` with `W_i = 1` but at the six samples at each
//! end. Samples go into a ring of 32; each block of 16 is added to the
//! sums when it is complete, every sample with the weight it has if the
//! revolution goes on (`W = 1`, or a head weight for the two samples after
//! the start event). The factor `q_i = p_i theta^'_i W_i`, `p_i = exp(-j
//! theta^_i)`, is carried from sample to sample: `p_(i+1) = p_i D_i` with
//! the increment `D_i = theta^_(i+1) - theta^_i = d_0 + a i` as `D_i = E
//! exp(-j a i)`, `E = exp(-j d_0)`. At the first sample of a block `exp(-j
//! a i)` comes from its series, within the block `D_(i+1) = D_i R`, `R =
//! exp(-j a)`: the increment's rounding grows over 16 steps at most, and
//! `p` takes one Newton step towards `|p| = 1` per block (its phase error
//! a random walk, `sqrt(M) eps` after `M` samples). No sine or cosine per
//! sample. When the end event is found, at the sample after it, the block
//! so far is added and the six samples `c_b - 4 .. c_b + 1` (in the ring)
//! get their tail weights: `(W_tail - 1) y exp(-j theta^) theta^'` is
//! added, the phasor from its series about `2 pi`. The next revolution
//! opens with the four samples of its head that have come (`c_a - 2 ..=
//! c_a + 1`), from the ring. Each channel's sample at `c_a - 2` is taken off
//! every sample (a constant integrates to zero; the sums then carry the
//! vibration, not a probe's gap, in their rounding).
//!
//! The ADC range test costs three operations a channel-sample: a
//! multiply-subtract maps the range to `(-2, 2)`, whose high word's bit
//! 30 (the top bit of the exponent), ORed over the block, tells whether
//! every sample is surely inside; a block with a sample near or beyond a
//! limit is tested exactly.
//!
//! [`StreamTracker::push`] is [`StreamTracker::push_sample`], the work of
//! every sample, followed when needed by [`StreamTracker::finish_sample`],
//! the work of about one sample a revolution (an event, a non-finite
//! keyphasor sample, a revolution run too long): a caller may compile the
//! two differently (the firmware: the first for speed, the second for
//! size). [`StreamTracker::push_block`] takes [`BLOCK`] instants at a time
//! (a DMA transfer's half) with the same result: a quiet stretch shares
//! one keyphasor scan ([`Keyphasor::quiet_run`]) and one deadline test,
//! and the block's sums are taken from the caller's buffer, of which the
//! ring keeps only the last six instants (and, at an instant that is
//! not quiet, the block so far, for [`StreamTracker::finish_sample`]).
//!
//! # Rejections, averages
//!
//! As in [`crate::ordertrack`] (the same [`Config`], [`Rejection`],
//! [`Counts`], averages with their standard errors), with these
//! differences: a revolution is dropped as [`Rejection::NoEvent`] when it
//! has run twice the configuration's slowest revolution and 7 samples
//! (there is no buffer to fill; a missing pulse is then a
//! [`Rejection::PeriodJump`], as with a buffer that long);
//! a sum that overflows on samples beyond the ADC limits counts as
//! non-finite; a missed prediction counts as a period jump. The revolution
//! after a rejected one is integrated as usual: the prediction needs only
//! the events.

use crate::keyphasor::{Crossing, EventTime, Keyphasor};
use crate::ordertrack::{
    count, series_terms, Averager, Config, ConfigError, Counts, Orders, Rejection, Rule, Scatter,
    MAX_CAPACITY,
};
use crate::scalar::Real;
use core::marker::PhantomData;
use num_complex::Complex;

/// The default [`StreamTracker::angle_tolerance`] (rad).
pub const DEFAULT_ANGLE_TOLERANCE: f64 = 1e-3;

/// Samples per block of the sums, and of [`StreamTracker::push_block`].
pub const BLOCK: usize = 16;

/// Samples kept: the block being filled and the one before it (a
/// revolution's tail needs the last six), in a ring of 32.
const RING: usize = 2 * BLOCK;
const MASK: usize = RING - 1;

/// The rows before an event that a revolution's end reads (`c_b - 4 ..=
/// c_b + 1`, the event found at `c_b + 1`): [`StreamTracker::push_block`]
/// keeps a block's last six in the ring.
const TAIL: usize = 6;

/// One revolution closed: its timing and its 1X vectors or why it was
/// rejected.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StreamRevolution<T, const NC: usize> {
    /// The keyphasor event that opened it (angle 0).
    pub start: EventTime<T>,
    /// Its period `T` in samples (for a revolution dropped without its end
    /// event: the samples it had run).
    pub samples: T,
    /// Mean speed `2 pi f_s / T` (rad/s); 0 when dropped without its end
    /// event.
    pub speed: T,
    /// Angular acceleration `a f_s^2` of the predicted angle (rad/s^2); 0
    /// without a prediction.
    pub acceleration: T,
    /// The prediction's miss at the end event, `e = 2 pi - theta^(T)`
    /// (rad); 0 without a prediction.
    pub angle_error: T,
    /// The 1X vectors, or the cause of the rejection.
    pub result: Result<[Complex<T>; NC], Rejection>,
}

/// The average of a group of accepted revolutions, per channel (as
/// [`crate::ordertrack::Average`], 1X only).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StreamAverage<T, const NC: usize> {
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
}

/// What [`StreamTracker::push`] gives when a revolution closes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StreamOutput<T, const NC: usize> {
    /// The revolution that closed.
    pub revolution: StreamRevolution<T, NC>,
    /// The average its acceptance completed, if it did.
    pub average: Option<StreamAverage<T, NC>>,
}

/// What [`StreamTracker::push_sample`] brought, for
/// [`StreamTracker::finish_sample`]: a few flags (the event's time is kept
/// in the tracker), so that it travels in a register.
#[derive(Debug, Clone, Copy, PartialEq)]
#[must_use]
pub struct SampleOutcome<T> {
    /// [`OVERRUN`], [`INVALID`], [`EVENT`].
    flags: u8,
    scalar: PhantomData<T>,
}

/// The open revolution has run longer than any allowed.
const OVERRUN: u8 = 1;
/// The keyphasor channel's sample is not finite.
const INVALID: u8 = 2;
/// A keyphasor event (its time in [`StreamTracker::event`]).
const EVENT: u8 = 4;

impl<T> SampleOutcome<T> {
    /// Nothing to finish: no event, a finite keyphasor sample, no
    /// revolution run too long.
    pub fn is_quiet(&self) -> bool {
        self.flags == 0
    }
}

/// The open revolution's predicted angle and running sums.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Open<T, const NC: usize> {
    start: EventTime<T>,
    /// `w`, `a` of the prediction (`None`: fewer than two periods before).
    angle: Option<(T, T)>,
    /// `exp(-j theta^)` of the next sample, and `theta^'` there.
    p: Complex<T>,
    dtheta: T,
    /// `E = exp(-j d_0)`, `R = exp(-j a)`, and the terms of the series of
    /// `exp(-j a i)` over the revolution.
    e: Complex<T>,
    r: Complex<T>,
    terms: usize,
    /// `a` (rad / sample^2) and the steps taken, `i`.
    a: T,
    step: T,
    /// The head weights of the two samples after the event's, and how
    /// many of them are still to come.
    head: [T; 2],
    head_left: usize,
    /// Each channel's reference sample.
    reference: [T; NC],
    sums: [Complex<T>; NC],
    /// Bit 31: a sample at or beyond an ADC limit.
    outside: u32,
}

/// The streaming 1X tracker of the module documentation, for `NC` probe
/// channels.
///
/// ```
/// use rotorid_core::ordertrack::Config;
/// use rotorid_core::streamtrack::StreamTracker;
/// use rotorid_core::Complex;
///
/// // 2 probes, 2560 Hz, a shaft at 25 Hz (102.4 samples per revolution).
/// let (fs, f) = (2560.0, 25.0);
/// let w = 2.0 * core::f64::consts::PI * f;
/// let config = Config::new(fs, 0.5, 100.0, 200.0).with_revolutions(4);
/// let mut t = StreamTracker::<f64, 2>::new(config).unwrap();
/// let mut avg = None;
/// for i in 0..2000 {
///     let theta = w * i as f64 / fs + 1.0;
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
/// assert!((a.x1[0] - Complex::from_polar(2e-6, 0.5)).norm() < 1e-14);
/// assert!(a.x1[1].norm() < 1e-14);
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct StreamTracker<T, const NC: usize> {
    config: Config<T>,
    kp: Keyphasor<T>,
    tolerance: T,
    /// Twice the longest revolution allowed and 7 (samples): a revolution
    /// without its end event by then is dropped ([`Rejection::NoEvent`]).
    max_samples: usize,
    /// `pos` at the open revolution's start and `max_samples` (wrapping):
    /// the sample that finds it run too long.
    deadline: usize,
    /// The last 32 samples, sample `i` at `ring[i & MASK]`; `pos` samples
    /// pushed (wrapping), the block's `n` the last.
    ring: [[T; NC]; RING],
    pos: usize,
    /// The first sample (`pos` then) of the block [`StreamTracker::push_block`]
    /// last copied into the ring whole.
    copied: Option<usize>,
    /// Samples of the current block already folded (or before the open
    /// revolution's start).
    done: usize,
    open: Option<Open<T, NC>>,
    /// The keyphasor event of the last sample that had one (for
    /// [`StreamTracker::finish_sample`]).
    event: EventTime<T>,
    /// The two last periods (samples): `[P', P]`.
    periods: [Option<T>; 2],
    seq: u64,
    counts: Counts,
    avg: Averager<T, NC>,
    rule: Rule<T>,
    series: Series<T>,
    /// The ADC range's scale `s = 2 / h` and scaled middle `m = mid s`
    /// ([`StreamTracker::fold`]).
    scale: T,
    mid_scaled: T,
}

impl<T: Real, const NC: usize> StreamTracker<T, NC> {
    /// A tracker with `config` ([`Config::validate`]; there is no buffer,
    /// so the slowest revolution need only stay below 2^24 samples).
    pub fn new(config: Config<T>) -> Result<Self, ConfigError> {
        config.validate(MAX_CAPACITY)?;
        let longest = config.longest();
        // `as` saturates; `validate` bounds `longest` below 2^24. Twice the
        // slowest revolution: a missing pulse is told as a period jump.
        let max_samples = (2.0 * longest) as usize + 7;
        let half = (config.adc_max - config.adc_min) / T::lit(2.0);
        let scale = T::lit(2.0) / (half * (T::one() - T::lit(8.0) * T::EPS));
        Ok(StreamTracker {
            kp: Keyphasor::new(config.level, config.hysteresis)?,
            config,
            tolerance: T::lit(DEFAULT_ANGLE_TOLERANCE),
            max_samples,
            deadline: max_samples,
            ring: [[T::zero(); NC]; RING],
            pos: 0,
            copied: None,
            done: 0,
            open: None,
            event: EventTime {
                sample: 0,
                frac: T::zero(),
            },
            periods: [None; 2],
            seq: 0,
            counts: Counts::default(),
            avg: Averager::new(),
            rule: Rule::new(),
            series: Series::new(),
            scale,
            mid_scaled: (config.adc_min + config.adc_max) / T::lit(2.0) * scale,
        })
    }

    /// The largest miss `|e|` of the predicted angle at a revolution's end
    /// event (rad) that still accepts the revolution.
    pub fn angle_tolerance(&self) -> T {
        self.tolerance
    }

    /// Sets [`StreamTracker::angle_tolerance`]; a value that is not finite
    /// and positive is refused (`false`, nothing changed).
    pub fn set_angle_tolerance(&mut self, tolerance: T) -> bool {
        let ok = tolerance.is_finite() && tolerance > T::zero();
        if ok {
            self.tolerance = tolerance;
        }
        ok
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

    /// Back to the state of [`StreamTracker::new`] (counts and the group
    /// being averaged included; the angle tolerance kept).
    pub fn reset(&mut self) {
        self.kp.reset();
        self.ring = [[T::zero(); NC]; RING];
        self.pos = 0;
        self.copied = None;
        self.deadline = self.max_samples;
        self.done = 0;
        self.open = None;
        self.event = EventTime {
            sample: 0,
            frac: T::zero(),
        };
        self.periods = [None; 2];
        self.seq = 0;
        self.counts = Counts::default();
        self.avg = Averager::new();
    }

    /// The average of the revolutions accepted since the last average, if
    /// there are more than the scatter spends; for the end of a recording.
    /// The group is emptied either way.
    pub fn flush(&mut self) -> Option<StreamAverage<T, NC>> {
        self.finish()
    }

    /// One sampling instant: `kp` the keyphasor channel, `y` the probes.
    /// Returns the revolution that closed at this sample, if any (with the
    /// average it completed). Any input is taken, finite or not.
    ///
    /// The same as [`StreamTracker::push_sample`] followed, when it reports
    /// something ([`SampleOutcome::is_quiet`] false), by
    /// [`StreamTracker::finish_sample`].
    pub fn push(&mut self, kp: T, y: &[T; NC]) -> Option<StreamOutput<T, NC>> {
        let outcome = self.push_sample(kp, y);
        if outcome.is_quiet() {
            None
        } else {
            self.finish_sample(outcome)
        }
    }

    /// The per-sample half of [`StreamTracker::push`]: the sample into the
    /// history and the sums; what it brought (a keyphasor event, a
    /// non-finite keyphasor sample, a revolution run too long) is returned
    /// for [`StreamTracker::finish_sample`], the half that runs about once a
    /// revolution. Split so that a caller can keep the rare half off its
    /// per-sample path (the firmware optimises the two for speed and for
    /// size); every outcome that is not quiet must be finished before the
    /// next sample.
    // index proven: ring indices masked.
    #[allow(clippy::indexing_slicing)]
    pub fn push_sample(&mut self, kp: T, y: &[T; NC]) -> SampleOutcome<T> {
        // The keyphasor first: its sample is not kept across the block's
        // fold.
        let mut flags = match self.kp.push(kp) {
            Crossing::None => 0,
            Crossing::Invalid => INVALID,
            Crossing::Event(e) => {
                self.event = e;
                EVENT
            }
        };
        let pos = self.pos;
        // The open revolution's `max_samples + 1`-th sample (with none
        // open, `finish_sample` has nothing to drop).
        if pos == self.deadline {
            flags |= OVERRUN;
        }
        self.ring[pos & MASK] = *y;
        self.copied = None;
        self.pos = pos.wrapping_add(1);
        if self.pos & (BLOCK - 1) == 0 {
            // A whole block: its samples from `done` on.
            self.fold_block(pos & !(BLOCK - 1) & MASK, None);
        }
        SampleOutcome {
            flags,
            scalar: PhantomData,
        }
    }

    /// A block of [`BLOCK`] sampling instants (`kp` the keyphasor, `y` the
    /// probes, as a DMA transfer gives them) from index `from` on: the same
    /// as [`StreamTracker::push_sample`] on each instant in turn, up to and
    /// including the first whose outcome is not quiet. Returns that
    /// outcome and the index after its instant (the caller finishes the
    /// outcome with [`StreamTracker::finish_sample`] and calls again from
    /// there with the same block), or a quiet outcome and [`BLOCK`] when
    /// the block is through.
    ///
    /// The work of a quiet stretch is shared by its instants: the block
    /// goes into the history in one copy, the keyphasor's quiet test runs
    /// over the stretch ([`Keyphasor::quiet_run`]) and the deadline is
    /// tested once; the sums take the block when it is complete, as in
    /// [`StreamTracker::push_sample`]. When the samples pushed so far are
    /// not a whole number of blocks (single instants pushed before), or
    /// `from` does not continue the last call's block, each instant goes
    /// through [`StreamTracker::push_sample`]: the same result, at its
    /// cost.
    // index proven: `from < BLOCK` checked, ring slots of a block masked
    // and block-aligned.
    #[allow(clippy::indexing_slicing)]
    pub fn push_block(
        &mut self,
        kp: &[T; BLOCK],
        y: &[[T; NC]; BLOCK],
        from: usize,
    ) -> (SampleOutcome<T>, usize) {
        let quiet = SampleOutcome {
            flags: 0,
            scalar: PhantomData,
        };
        if from >= BLOCK {
            return (quiet, BLOCK);
        }
        let base = self.pos.wrapping_sub(from);
        let fast = base & (BLOCK - 1) == 0 && (from == 0 || self.copied == Some(base));
        if !fast {
            for j in from..BLOCK {
                let outcome = self.push_sample(kp[j], &y[j]);
                if !outcome.is_quiet() {
                    return (outcome, j + 1);
                }
            }
            return (quiet, BLOCK);
        }
        let slot = base & MASK;
        self.copied = Some(base);
        // The instant that finds the open revolution run too long, if it
        // is in this block at or after `from`.
        let deadline = self.deadline.wrapping_sub(base);
        let mut j = from;
        loop {
            let stop = if deadline >= j && deadline < BLOCK {
                deadline
            } else {
                BLOCK
            };
            j += self.kp.quiet_run(&kp[j..stop]);
            if j >= BLOCK {
                self.pos = base.wrapping_add(BLOCK);
                self.end_block(slot, y);
                return (quiet, BLOCK);
            }
            // Instant `j`: a keyphasor sample outside the quiet range, or
            // the deadline's.
            let mut flags = match self.kp.push(kp[j]) {
                Crossing::None => 0,
                Crossing::Invalid => INVALID,
                Crossing::Event(e) => {
                    self.event = e;
                    EVENT
                }
            };
            if j == deadline {
                flags |= OVERRUN;
            }
            j += 1;
            self.pos = base.wrapping_add(j);
            if j == BLOCK {
                self.end_block(slot, y);
            } else if flags != 0 {
                // What `finish_sample` reads: the block's rows so far.
                self.ring[slot..slot + j].copy_from_slice(&y[..j]);
            }
            if flags != 0 || j == BLOCK {
                return (
                    SampleOutcome {
                        flags,
                        scalar: PhantomData,
                    },
                    j,
                );
            }
        }
    }

    /// The end of a block [`StreamTracker::push_block`] took: its rows not
    /// yet folded into the sums, from the caller's block, and its last
    /// [`TAIL`] rows into the ring (what a revolution ending or starting in
    /// the next block's first instants reads).
    fn end_block(&mut self, slot: usize, y: &[[T; NC]; BLOCK]) {
        self.fold_block(slot, Some(y));
        let keep = slot + BLOCK - TAIL..slot + BLOCK;
        if let Some(ring) = self.ring.get_mut(keep) {
            for (r, row) in ring.iter_mut().zip(&y[BLOCK - TAIL..]) {
                *r = *row;
            }
        }
    }

    /// The rest of [`StreamTracker::push`] for what
    /// [`StreamTracker::push_sample`] reported: a revolution run too long
    /// dropped ([`Rejection::NoEvent`]; the samples folded into it since
    /// are dropped with it), a revolution with a non-finite keyphasor sample
    /// dropped, a revolution closed and the next opened at an event.
    pub fn finish_sample(&mut self, outcome: SampleOutcome<T>) -> Option<StreamOutput<T, NC>> {
        let mut out = None;
        if outcome.flags & OVERRUN != 0 {
            if let Some(o) = &self.open {
                let start = o.start;
                out = Some(self.drop_open(start, Rejection::NoEvent));
            }
        }
        if outcome.flags & INVALID != 0 {
            if let Some(o) = &self.open {
                let start = o.start;
                out = Some(self.drop_open(start, Rejection::NonFinite));
            }
            self.periods = [None; 2];
        } else if outcome.flags & EVENT != 0 {
            let e = self.event;
            // The block so far (empty when it has just been folded).
            let p = self.pos;
            self.fold(p & !(BLOCK - 1) & MASK, p & (BLOCK - 1));
            if self.open.is_some() {
                out = self.close(e);
            }
            self.start(e);
        }
        out
    }

    /// [`StreamTracker::fold`] of the rest of a whole block, from the ring
    /// (its slot `slot`) or from the caller's block `rows`; `done = 0`.
    #[inline(always)]
    fn fold_block(&mut self, slot: usize, rows: Option<&[[T; NC]; BLOCK]>) {
        let from = self.done;
        self.done = 0;
        let limits = (self.config.adc_min, self.config.adc_max);
        let range = (self.scale, self.mid_scaled);
        let rows = match rows {
            Some(rows) => rows,
            None => match self
                .ring
                .get(slot..slot + BLOCK)
                .map(<&[[T; NC]; BLOCK]>::try_from)
            {
                Some(Ok(rows)) => rows,
                _ => return,
            },
        };
        fold_whole(&mut self.open, from, rows, range, &self.series, limits);
    }

    /// Adds the samples `done .. to` of the block at ring slot `slot` (0 or
    /// 16) to the open revolution's sums, their factors `q_i` carried on from
    /// sample to sample; `done = to` (modulo the block).
    ///
    /// The ADC range test of a sample: `u = y s - m`, with `s = 2 / h`, `m =
    /// mid s`, `mid` the middle of the range and `h = (hi - lo) / 2 (1 - 8
    /// eps)`, is within `(-2, 2)` exactly when the high word `w` of `u`
    /// (sign, exponent, leading mantissa bits) has bit 30 clear (2.0 is
    /// `0x4000_0000` in the high word of both precisions, and every `|u| >=
    /// 2`, infinity and NaN has that bit of the exponent set): bit 30 of
    /// the words ORed over the block. Clear, it proves `|y - mid| < h` (the
    /// margin of `8 eps` covers the rounding of `u`), so no sample is at or
    /// beyond a limit (a multiply-subtract, a move and an OR per sample);
    /// set (a sample near or beyond
    /// a limit, or not finite), the block is tested exactly, `(lo - y)(y -
    /// hi) <= 0`.
    fn fold(&mut self, slot: usize, to: usize) {
        self.fold_rows_of::<false>(slot, to);
    }

    /// [`StreamTracker::fold`], with the loop of a whole block (a fixed
    /// trip count) when `WHOLE` and the rows are one; the loop of any
    /// length otherwise (the only one where the call is never for a whole
    /// block: one copy of each loop in the per-sample half, one in the
    /// rest).
    #[inline(always)]
    fn fold_rows_of<const WHOLE: bool>(&mut self, slot: usize, to: usize) {
        let from = self.done;
        self.done = to & (BLOCK - 1);
        if from >= to {
            return;
        }
        let rows = self.ring.get(slot + from..slot + to).unwrap_or(&[]);
        let limits = (self.config.adc_min, self.config.adc_max);
        let range = (self.scale, self.mid_scaled);
        fold_open::<T, NC, WHOLE>(&mut self.open, rows, range, &self.series, limits);
    }

    /// The last `M` samples, oldest first.
    // index proven: ring indices masked.
    #[allow(clippy::indexing_slicing)]
    fn last<const M: usize>(&self) -> [[T; NC]; M] {
        let first = self.pos.wrapping_sub(M);
        core::array::from_fn(|j| self.ring[first.wrapping_add(j) & MASK])
    }

    /// Opens a revolution at event `e` (the last four samples are `e.sample
    /// - 2 ..= e.sample + 1`).
    fn start(&mut self, e: EventTime<T>) {
        let zero = Complex::new(T::zero(), T::zero());
        let c = &self.config;
        let two = T::lit(2.0);
        let tau = T::two_pi();
        let angle = match self.periods {
            [Some(pp), Some(p)] => {
                let a = two * tau * (pp - p) / (p * pp * (p + pp));
                Some((tau / p + a * p / two, a))
            }
            _ => None,
        };
        let mut o = Open {
            start: e,
            angle,
            p: zero,
            dtheta: T::zero(),
            e: zero,
            r: Complex::new(T::one(), T::zero()),
            terms: 0,
            a: T::zero(),
            step: T::zero(),
            head: [T::zero(); 2],
            head_left: 0,
            reference: [T::zero(); NC],
            sums: [zero; NC],
            outside: 0,
        };
        if let (Some((w, a)), Some(p)) = (angle, self.periods[1]) {
            let head = self.rule.head(e.frac);
            let theta = |t: T| w * t + a * t * t / two;
            // The head's first four samples, c - 2 .. c + 1: tau = j - 2 - frac.
            let rows = self.last::<4>();
            o.reference = rows[0];
            // |theta| <= 4 |w| at these samples and the next (a < w / 16).
            let terms = series_terms(T::lit(4.0) * w.abs());
            let (lo, hi) = (c.adc_min, c.adc_max);
            for (j, (row, wj)) in rows.iter().zip(head.iter()).enumerate() {
                let t = count::<T>(j) - two - e.frac;
                let th = theta(t);
                let f = self.series.exp_neg_j(th, terms).scale((w + a * t) * *wj);
                for ((s, y), y0) in o.sums.iter_mut().zip(row.iter()).zip(o.reference.iter()) {
                    o.outside |= ((lo - *y) * (*y - hi)).sign_word();
                    *s += f.scale(*y - *y0);
                }
            }
            // The next sample, c + 2.
            let t0 = two - e.frac;
            let th0 = theta(t0);
            o.p = self.series.exp_neg_j(th0, terms);
            o.dtheta = w + a * t0;
            let d0 = w + a * (t0 + T::lit(0.5));
            o.e = self.series.exp_neg_j(d0, terms);
            o.r = self.series.exp_neg_j(a, series_terms(a.abs()));
            o.a = a;
            let span = p * (T::one() + c.period_ratio) + T::lit(8.0);
            o.terms = series_terms(a.abs() * span);
            o.head = [head[4], head[5]];
            o.head_left = 2;
        }
        self.open = Some(o);
        self.deadline = self.pos.wrapping_add(self.max_samples);
    }

    /// A revolution dropped without its end event.
    fn drop_open(&mut self, start: EventTime<T>, cause: Rejection) -> StreamOutput<T, NC> {
        self.open = None;
        self.seq = self.seq.wrapping_add(1);
        self.periods = [None; 2];
        self.counts.add(Err(cause));
        let now = EventTime {
            sample: self.kp.samples().wrapping_sub(1),
            frac: T::zero(),
        };
        StreamOutput {
            revolution: StreamRevolution {
                start,
                samples: now.since(&start),
                speed: T::zero(),
                acceleration: T::zero(),
                angle_error: T::zero(),
                result: Err(cause),
            },
            average: None,
        }
    }

    /// Closes the open revolution at its end event `end` (the block's
    /// samples folded in; the last six samples are `c_b - 4 ..= c_b + 1`).
    fn close(&mut self, end: EventTime<T>) -> Option<StreamOutput<T, NC>> {
        let o = self.open.as_ref()?;
        let (start, angle) = (o.start, o.angle);
        let t = end.since(&start);
        let [p_prev, p] = self.periods;
        let c = self.config;
        let two = T::lit(2.0);
        let tau = T::two_pi();
        let speed = tau * c.sample_rate / t;
        let (w, a) = angle.unwrap_or((T::zero(), T::zero()));
        let miss = tau - (w * t + a * t * t / two);
        // NaN is no hit.
        let hit = miss.abs() <= self.tolerance;
        let timing = match angle {
            Some(_) => c.timing(t, [p_prev, p], speed, hit),
            None => Err(Rejection::NoReference),
        };
        let result = timing.and_then(|()| self.finish_sums(o, end.frac, t, w, a, miss));
        self.open = None;
        self.seq = self.seq.wrapping_add(1);
        self.periods = [p, Some(t)];
        self.counts.add(result.map(|_| ()));
        let mut average = None;
        if let Ok(x1) = &result {
            let zero = Complex::new(T::zero(), T::zero());
            let orders = Orders {
                x1: *x1,
                x2: [zero; NC],
            };
            self.avg.add(self.seq, (start, end), speed, &orders);
            if self.avg.n >= self.config.revolutions {
                average = self.finish();
            }
        }
        let (acceleration, angle_error) = match angle {
            Some(_) => (a * c.sample_rate * c.sample_rate, miss),
            None => (T::zero(), T::zero()),
        };
        Some(StreamOutput {
            revolution: StreamRevolution {
                start,
                samples: t,
                speed,
                acceleration,
                angle_error,
                result,
            },
            average,
        })
    }

    /// The tail weights on the last six samples (`c_b - 4 .. c_b + 1`, all
    /// summed with weight 1), then the vectors: `tau_j = T - frac_b - 4 +
    /// j` and `theta^(tau_j) - 2 pi = (tau_j - T) (w + a (tau_j + T) / 2) -
    /// e`, small (its series converges fast and keeps the precision).
    fn finish_sums(
        &self,
        o: &Open<T, NC>,
        frac_b: T,
        t: T,
        w: T,
        a: T,
        miss: T,
    ) -> Result<[Complex<T>; NC], Rejection> {
        let two = T::lit(2.0);
        let tail = self.rule.tail(frac_b);
        let mut sums = o.sums;
        let rows = self.last::<6>();
        // |theta - 2 pi| <= 6 |w| at these samples (and the miss, checked).
        let terms = series_terms(T::lit(6.0) * w.abs());
        for (j, (row, wj)) in rows.iter().zip(tail.iter()).enumerate() {
            let d = count::<T>(j) - frac_b - T::lit(4.0);
            let tj = t + d;
            let th = d * (w + a * (tj + t) / two) - miss;
            let f = self
                .series
                .exp_neg_j(th, terms)
                .scale((w + a * tj) * (*wj - T::one()));
            for ((s, y), y0) in sums.iter_mut().zip(row.iter()).zip(o.reference.iter()) {
                *s += f.scale(*y - *y0);
            }
        }
        let inv_pi = T::one() / T::pi();
        let x1 = sums.map(|z| z.scale(inv_pi));
        let finite = x1.iter().all(|z| z.re.is_finite() && z.im.is_finite());
        if !finite {
            Err(Rejection::NonFinite)
        } else if o.outside >> 31 != 0 {
            Err(Rejection::Clipped)
        } else {
            Ok(x1)
        }
    }

    /// The group's average (1X), emptied.
    fn finish(&mut self) -> Option<StreamAverage<T, NC>> {
        let scatter: Scatter = self.config.scatter;
        self.avg.finish(scatter).map(|a| StreamAverage {
            revolutions: a.revolutions,
            start: a.start,
            end: a.end,
            speed: a.speed,
            x1: a.x1,
            x1_std: a.x1_std,
        })
    }
}

/// The series of [`crate::ordertrack`]'s `exp(-j e)` (`cos e = 1 - e^2 /
/// (1 2) (1 - e^2 / (3 4) (1 - ...))`, `sin e = e (1 - e^2 / (2 3) (1 -
/// ...))`) with the reciprocals `1 / ((2m - 1) 2m)`, `1 / (2m (2m + 1))`
/// formed once ([`StreamTracker::new`]): no division or integer conversion
/// per term.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Series<T> {
    cos: [T; SERIES_TERMS],
    sin: [T; SERIES_TERMS],
}

/// Most terms of [`Series::exp_neg_j`] (as in [`crate::ordertrack`]).
const SERIES_TERMS: usize = 12;

impl<T: Real> Series<T> {
    fn new() -> Self {
        Series {
            cos: core::array::from_fn(|i| T::one() / count::<T>((2 * i + 1) * (2 * i + 2))),
            sin: core::array::from_fn(|i| T::one() / count::<T>((2 * i + 2) * (2 * i + 3))),
        }
    }

    /// `exp(-j e)` to `terms` terms (at most [`SERIES_TERMS`]).
    fn exp_neg_j(&self, e: T, terms: usize) -> Complex<T> {
        let z = e * e;
        let (mut c, mut s) = (T::one(), T::one());
        let mut m = terms.min(SERIES_TERMS);
        while m > 0 {
            m -= 1;
            let (rc, rs) = match (self.cos.get(m), self.sin.get(m)) {
                (Some(rc), Some(rs)) => (*rc, *rs),
                _ => break,
            };
            c = T::one() - z * c * rc;
            s = T::one() - z * s * rs;
        }
        Complex::new(c, -e * s)
    }
}

/// [`StreamTracker::fold`] of the rows `from..` of a whole block `rows`
/// into the open revolution: out of the per-sample path's line (its
/// registers are saved only once a block), one copy for the ring's blocks
/// and the caller's.
#[inline(never)]
fn fold_whole<T: Real, const NC: usize>(
    open: &mut Option<Open<T, NC>>,
    from: usize,
    rows: &[[T; NC]; BLOCK],
    range: (T, T),
    series: &Series<T>,
    limits: (T, T),
) {
    fold_open::<T, NC, true>(open, rows.get(from..).unwrap_or(&[]), range, series, limits);
}

/// The rows into the open revolution's sums ([`fold_rows`]; the loop of a
/// whole block, a fixed trip count, when `WHOLE` and the rows are one), its
/// phasor renormalised, and the exact range test of the rows when the
/// quick one finds a sample near or beyond a limit
/// ([`StreamTracker::fold`]).
#[inline(always)]
fn fold_open<T: Real, const NC: usize, const WHOLE: bool>(
    open: &mut Option<Open<T, NC>>,
    rows: &[[T; NC]],
    range: (T, T),
    series: &Series<T>,
    (lo, hi): (T, T),
) {
    let Some(o) = open else { return };
    if o.angle.is_none() || rows.is_empty() {
        return;
    }
    let whole = <&[[T; NC]; BLOCK]>::try_from(rows).ok().filter(|_| WHOLE);
    let word = if let Some(rows) = whole {
        fold_rows(o, rows, range, series)
    } else {
        fold_rows(o, rows, range, series)
    };
    o.renormalise();
    if word & 0x4000_0000 != 0 {
        for y in rows.iter().flat_map(|r| r.iter()) {
            o.outside |= ((lo - *y) * (*y - hi)).sign_word();
        }
    }
}

/// `sums[c] += sum_k q_k (rows[k][c] - reference[c])` for every channel,
/// `q_k = p_k theta^'_k W_k` the open revolution's factors; returns the OR
/// of the range words, the high words `w` of `y s - m` ([`StreamTracker::fold`]; `(s,
/// m)` the range's scale and scaled middle).
///
/// The phasor: `p_(i+1) = p_i D_i` with the increment `D_i = E exp(-j a
/// i)` formed afresh at the first sample of the call from its series (no
/// error carried from call to call), then `D_(i+1) = D_i R`, `R = exp(-j
/// a)`, for the call's few (at most 16) samples: the increment's rounding
/// grows only within a call. The two samples after the start event carry
/// their head weights `W`; every other sample weighs 1.
#[inline(always)]
fn fold_rows<T: Real, const NC: usize>(
    o: &mut Open<T, NC>,
    rows: &[[T; NC]],
    (s, m): (T, T),
    series: &Series<T>,
) -> u32 {
    let mut word = 0u32;
    let mut sums = o.sums;
    let reference = o.reference;
    let mut d = if o.terms == 0 {
        o.e
    } else {
        o.e * series.exp_neg_j(o.a * o.step, o.terms)
    };
    let (mut p, mut dtheta) = (o.p, o.dtheta);
    let mut head = o.head_left;
    for row in rows {
        let mut qs = dtheta;
        if head > 0 {
            qs *= o.head.get(2 - head).copied().unwrap_or_else(T::one);
            head -= 1;
        }
        let q = p.scale(qs);
        p *= d;
        d *= o.r;
        dtheta += o.a;
        word |= add_row(&mut sums, q, row, &reference, (s, m));
    }
    o.head_left = head;
    o.sums = sums;
    o.p = p;
    o.dtheta = dtheta;
    o.step += count::<T>(rows.len());
    word
}

/// `sums[c] += q (row[c] - reference[c])` for every channel; the OR of the
/// row's range words ([`fold_rows`]).
#[inline(always)]
fn add_row<T: Real, const NC: usize>(
    sums: &mut [Complex<T>; NC],
    q: Complex<T>,
    row: &[T; NC],
    reference: &[T; NC],
    (s, m): (T, T),
) -> u32 {
    let mut word = 0u32;
    for ((acc, y), y0) in sums.iter_mut().zip(row.iter()).zip(reference.iter()) {
        word |= (*y * s - m).sign_word();
        let v = *y - *y0;
        acc.re += q.re * v;
        acc.im += q.im * v;
    }
    word
}

impl<T: Real, const NC: usize> Open<T, NC> {
    /// One Newton step of `|p|` towards 1: `p (3 - |p|^2) / 2`.
    fn renormalise(&mut self) {
        let p = self.p;
        self.p = p.scale(T::lit(1.5) - p.norm_sqr() * T::lit(0.5));
    }
}
