//! Keyphasor events: the once-per-revolution pulse found sample by sample.
//!
//! A keyphasor probe faces a notch (or a key) on the shaft and gives one
//! pulse per revolution. The event is the rising crossing of a level `L`
//! (in the pulse signal's unit) by the samples `k_n` of the pulse channel,
//! with hysteresis `h >= 0`:
//!
//! ```text
//! armed    once a sample  k_n < L - h,
//! event    at the first sample k_n >= L while armed (then disarmed),
//! time     u = (n - 1) + f,   f = (L - k_(n-1)) / (k_n - k_(n-1))  in (0, 1]
//! ```
//!
//! `u` is the event time in samples (seconds: `u / f_s`, `f_s` the sample
//! rate in Hz): the threshold crossing by linear interpolation between the
//! last sample below the level and the first at or above it. The hysteresis
//! keeps noise on a slow edge from giving a second event: after an event the
//! signal must fall below `L - h` before the next one counts. A detector
//! that starts on a high signal is not armed, so a pulse already under way
//! at the first sample gives no event.
//!
//! # Time without losing precision
//!
//! An event time is held as a sample index (`u64`) and a fraction in
//! `(0, 1]` of the working precision ([`EventTime`]), never as one float:
//! in `f32` a time in seconds would lose a sample's resolution after
//! 2^24 samples (11 minutes at 25.6 kHz). Intervals between events are
//! formed as the integer difference of the indices plus the difference of
//! the fractions ([`EventTime::since`]), exact in both precisions for
//! intervals below 2^24 samples, whatever the length of the recording.
//!
//! A non-finite sample disarms the detector (it must see `k < L - h` again)
//! and is reported ([`Crossing::Invalid`]); nothing panics on any input.

use crate::scalar::Real;

/// The time of a keyphasor event: `sample + frac` samples from the first
/// sample of the stream (index 0), `frac` in `(0, 1]`; in seconds
/// `(sample + frac) / f_s`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EventTime<T> {
    /// The last sample before the crossing (the crossing lies between it
    /// and the next sample, or on the next sample when `frac == 1`).
    pub sample: u64,
    /// The fraction of a sample interval after `sample`, in `(0, 1]`.
    pub frac: T,
}

impl<T: Real> EventTime<T> {
    /// The time in seconds at the sample rate `sample_rate` (Hz), formed in
    /// `f64`: `(sample + frac) / sample_rate`.
    pub fn seconds(&self, sample_rate: f64) -> f64 {
        (self.sample as f64 + self.frac.to_f64()) / sample_rate
    }

    /// The time from `earlier` to `self` in samples:
    /// `(sample - earlier.sample) + (frac - earlier.frac)`, the index
    /// difference exact (integer) and converted once, so that the interval
    /// keeps the working precision whatever the indices. Negative when
    /// `earlier` is later.
    pub fn since(&self, earlier: &EventTime<T>) -> T {
        let whole = if self.sample >= earlier.sample {
            samples::<T>(self.sample - earlier.sample)
        } else {
            -samples::<T>(earlier.sample - self.sample)
        };
        whole + (self.frac - earlier.frac)
    }
}

/// A sample count in the working precision: a 32-bit conversion (in `f32`
/// a hardware one on the Cortex-M4F) below 2^32, a 64-bit one above (one
/// rounding either way; both conversions are total).
#[inline(always)]
fn samples<T: Real>(n: u64) -> T {
    let wide = || T::from_u64(n).unwrap_or_else(T::zero);
    match u32::try_from(n) {
        Ok(m) => T::from_u32(m).unwrap_or_else(wide),
        Err(_) => wide(),
    }
}

/// What one sample of the pulse channel gave.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Crossing<T> {
    /// No event at this sample.
    None,
    /// A keyphasor event between the previous sample and this one (or on
    /// this one).
    Event(EventTime<T>),
    /// The sample is NaN or infinite: the detector is disarmed.
    Invalid,
}

/// A keyphasor level or hysteresis that is not finite, a negative
/// hysteresis, or `L - h` not finite.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct InvalidLevel;

/// The event detector of the module documentation: rising crossings of a
/// level with hysteresis, timed by linear interpolation.
///
/// ```
/// use rotorid_core::keyphasor::{Crossing, Keyphasor};
///
/// let mut kp = Keyphasor::<f64>::new(0.5, 0.2).unwrap();
/// let mut events = [None; 8];
/// for (i, k) in [0.0, 0.0, 0.25, 1.0, 1.0, 0.0, 0.0, 0.75].into_iter().enumerate() {
///     if let Crossing::Event(e) = kp.push(k) {
///         events[i] = Some(e);
///     }
/// }
/// // 0.25 -> 1.0 crosses 0.5 a third of the way: sample 2 + 1/3.
/// let e = events[3].unwrap();
/// assert_eq!(e.sample, 2);
/// assert!((e.frac - 1.0 / 3.0).abs() < 1e-15);
/// // 0.0 -> 0.75 crosses two thirds of the way: 6 + 2/3 samples.
/// let e = events[7].unwrap();
/// assert!((e.seconds(1.0) - (6.0 + 2.0 / 3.0)).abs() < 1e-15);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Keyphasor<T> {
    level: T,
    rearm: T,
    armed: bool,
    /// The samples that change nothing but `prev`, `lo <= k < hi`: armed,
    /// `[-M, L)` (`M` the largest finite `f32`: no event, stays armed);
    /// disarmed, `[L - h, inf)` (stays disarmed). Every other sample
    /// (infinite, NaN, or one that arms or fires) takes the full test.
    quiet: [T; 2],
    prev: T,
    /// Index the next sample gets.
    next: u64,
}

impl<T: Real> Keyphasor<T> {
    /// A detector for rising crossings of `level` with `hysteresis >= 0`
    /// (both in the pulse signal's unit). Error unless both are finite, the
    /// hysteresis is `>= 0` and `level - hysteresis` is finite.
    pub fn new(level: T, hysteresis: T) -> Result<Self, InvalidLevel> {
        let rearm = level - hysteresis;
        let valid = level.is_finite()
            && hysteresis.is_finite()
            && hysteresis >= T::zero()
            && rearm.is_finite();
        if !valid {
            return Err(InvalidLevel);
        }
        Ok(Keyphasor {
            level,
            rearm,
            armed: false,
            quiet: Self::quiet_range(false, level, rearm),
            prev: T::zero(),
            next: 0,
        })
    }

    /// [`Keyphasor::quiet`] for the armed state `armed`.
    fn quiet_range(armed: bool, level: T, rearm: T) -> [T; 2] {
        if armed {
            [-T::lit(f64::from(f32::MAX)), level]
        } else {
            [rearm, T::lit(f64::INFINITY)]
        }
    }

    /// The level `L`.
    pub fn level(&self) -> T {
        self.level
    }

    /// The re-arming level `L - h`.
    pub fn rearm_level(&self) -> T {
        self.rearm
    }

    /// The index the next sample gets (the number of samples seen).
    pub fn samples(&self) -> u64 {
        self.next
    }

    /// Back to the state of [`Keyphasor::new`] (disarmed, sample count 0).
    pub fn reset(&mut self) {
        self.armed = false;
        self.quiet = Self::quiet_range(false, self.level, self.rearm);
        self.prev = T::zero();
        self.next = 0;
    }

    /// One sample `k` of the pulse channel.
    #[inline]
    pub fn push(&mut self, k: T) -> Crossing<T> {
        let n = self.next;
        self.next = self.next.wrapping_add(1);
        // Two comparisons for the samples that change nothing (NaN fails
        // both).
        if k >= self.quiet[0] && k < self.quiet[1] {
            self.prev = k;
            return Crossing::None;
        }
        let out = self.change(k, n);
        self.quiet = Self::quiet_range(self.armed, self.level, self.rearm);
        out
    }

    /// Takes the leading samples of `ks` that change nothing (each in the
    /// quiet range, as [`Keyphasor::push`] tests it) and returns how many:
    /// the same state as that many calls of [`Keyphasor::push`], each of
    /// which would have returned [`Crossing::None`]. The first sample it
    /// stops at (if any) is left for [`Keyphasor::push`].
    #[inline]
    pub fn quiet_run(&mut self, ks: &[T]) -> usize {
        let [lo, hi] = self.quiet;
        let n = ks
            .iter()
            .position(|k| !(*k >= lo && *k < hi))
            .unwrap_or(ks.len());
        if let Some(last) = n.checked_sub(1).and_then(|i| ks.get(i)) {
            self.prev = *last;
            // `n` is at most a slice's length: no truncation.
            self.next = self.next.wrapping_add(n as u64);
        }
        n
    }

    /// [`Keyphasor::push`] of a sample `k` (index `n`) outside the quiet
    /// range.
    fn change(&mut self, k: T, n: u64) -> Crossing<T> {
        if !k.is_finite() {
            self.armed = false;
            return Crossing::Invalid;
        }
        let mut out = Crossing::None;
        if self.armed && k >= self.level {
            // Armed means a sample below `L - h <= L` came and none at or
            // above `L` since, so `prev < L <= k` and `n >= 1`.
            let f = (self.level - self.prev) / (k - self.prev);
            // In (0, 1] mathematically; a difference that overflowed gives
            // 0 or NaN: the event is then put on this sample.
            let frac = if f > T::zero() && f <= T::one() {
                f
            } else {
                T::one()
            };
            out = Crossing::Event(EventTime {
                sample: n.wrapping_sub(1),
                frac,
            });
            self.armed = false;
        }
        if k < self.rearm {
            self.armed = true;
        }
        self.prev = k;
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn events(kp: &mut Keyphasor<f64>, xs: &[f64]) -> std::vec::Vec<(usize, EventTime<f64>)> {
        xs.iter()
            .enumerate()
            .filter_map(|(i, &x)| match kp.push(x) {
                Crossing::Event(e) => Some((i, e)),
                _ => None,
            })
            .collect()
    }

    #[test]
    fn hysteresis_keeps_noise_on_an_edge_from_counting_twice() {
        let mut kp = Keyphasor::new(0.5, 0.2).unwrap();
        // Rises through 0.5, dips to 0.4 (above 0.3: not re-armed), rises
        // again, falls below 0.3, rises again.
        let ev = events(&mut kp, &[0.0, 0.6, 0.4, 0.7, 0.2, 0.9]);
        assert_eq!(ev.len(), 2);
        assert_eq!((ev[0].0, ev[0].1.sample), (1, 0));
        assert!((ev[0].1.frac - 5.0 / 6.0).abs() < 1e-15);
        assert_eq!((ev[1].0, ev[1].1.sample), (5, 4));
        assert!((ev[1].1.frac - 3.0 / 7.0).abs() < 1e-15);
        // Without hysteresis the dip counts.
        let mut kp = Keyphasor::new(0.5, 0.0).unwrap();
        assert_eq!(events(&mut kp, &[0.0, 0.6, 0.4, 0.7, 0.2, 0.9]).len(), 3);
    }

    #[test]
    fn a_pulse_under_way_at_the_start_and_a_crossing_on_a_sample() {
        let mut kp = Keyphasor::new(0.5, 0.1).unwrap();
        // Starts high: no event until the signal has been low.
        let ev = events(&mut kp, &[1.0, 1.0, 0.0, 0.5]);
        assert_eq!(ev.len(), 1);
        assert_eq!((ev[0].1.sample, ev[0].1.frac), (2, 1.0));
        assert_eq!(kp.samples(), 4);
    }

    #[test]
    fn non_finite_samples_disarm_and_huge_ones_do_not_panic() {
        let mut kp = Keyphasor::new(0.5, 0.1).unwrap();
        assert_eq!(kp.push(0.0), Crossing::None);
        assert_eq!(kp.push(f64::NAN), Crossing::Invalid);
        // Disarmed: the rise right after the NaN is no event.
        assert_eq!(kp.push(1.0), Crossing::None);
        assert_eq!(kp.push(-f64::MAX), Crossing::None);
        // (L - k0) / (k1 - k0) with k1 - k0 = inf: the event on the sample.
        match kp.push(f64::MAX) {
            Crossing::Event(e) => assert_eq!((e.sample, e.frac), (3, 1.0)),
            c => panic!("{c:?}"),
        }
        assert_eq!(kp.push(f64::INFINITY), Crossing::Invalid);
        assert_eq!(Keyphasor::new(f64::NAN, 0.1), Err(InvalidLevel));
        assert_eq!(Keyphasor::new(0.5, -0.1), Err(InvalidLevel));
        assert_eq!(Keyphasor::new(-f64::MAX, f64::MAX), Err(InvalidLevel));
    }

    #[test]
    fn intervals_keep_their_precision_far_into_a_recording() {
        let a = EventTime {
            sample: 1 << 40,
            frac: 0.25f32,
        };
        let b = EventTime {
            sample: (1 << 40) + 511,
            frac: 0.75f32,
        };
        assert_eq!(b.since(&a), 511.5);
        assert_eq!(a.since(&b), -511.5);
        assert!((b.seconds(25600.0) - ((1u64 << 40) as f64 + 511.75) / 25600.0).abs() < 1e-9);
    }

    /// The quiet range's two comparisons give what the full test gives:
    /// against the rule of the module documentation written out per
    /// sample, on a pulse train with noise, non-finite samples, samples
    /// right on both levels and beyond the largest `f32`.
    #[test]
    fn the_quiet_range_changes_nothing() {
        fn reference(state: &mut (bool, f64), level: f64, rearm: f64, k: f64) -> Crossing<f64> {
            let (armed, prev) = *state;
            if !k.is_finite() {
                state.0 = false;
                return Crossing::Invalid;
            }
            let mut out = Crossing::None;
            let mut armed_now = armed;
            if armed && k >= level {
                out = Crossing::Event(EventTime {
                    sample: 0,
                    frac: (level - prev) / (k - prev),
                });
                armed_now = false;
            }
            if k < rearm {
                armed_now = true;
            }
            *state = (armed_now, k);
            out
        }
        let (level, hysteresis) = (0.5, 0.2);
        let mut kp = Keyphasor::<f64>::new(level, hysteresis).unwrap();
        let mut state = (false, 0.0);
        let special = [
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            0.5,
            0.3,
            f64::from(f32::MAX) * 4.0,
            -f64::from(f32::MAX) * 4.0,
            1.0,
        ];
        let mut seed = 12345u64;
        let (mut events, mut invalid) = (0, 0);
        for i in 0..20_000u64 {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let u = (seed >> 11) as f64 / (1u64 << 53) as f64;
            let pulse = if (i / 37) % 2 == 0 { 0.0 } else { 1.0 };
            let k = if u < 0.01 {
                special[(seed >> 3) as usize % special.len()]
            } else {
                pulse + 0.05 * (u - 0.5)
            };
            let got = kp.push(k);
            let want = reference(&mut state, level, level - hysteresis, k);
            match (got, want) {
                (Crossing::Event(g), Crossing::Event(w)) => {
                    events += 1;
                    assert_eq!(g.sample, i - 1);
                    let frac = if w.frac > 0.0 && w.frac <= 1.0 {
                        w.frac
                    } else {
                        1.0
                    };
                    assert_eq!(g.frac, frac);
                }
                (Crossing::Invalid, Crossing::Invalid) => invalid += 1,
                (Crossing::None, Crossing::None) => {}
                (g, w) => panic!("sample {i} ({k}): {g:?} against {w:?}"),
            }
        }
        assert!(
            events > 200 && invalid > 20,
            "{events} events, {invalid} invalid"
        );
    }
}
