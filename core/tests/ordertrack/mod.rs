//! Synchronous order tracking (`rotorid_core::ordertrack`) against signals
//! generated analytically: the exact shaft angle
//! `theta(t) = theta0 + w0 t + alpha t^2 / 2`, keyphasor pulses at
//! `theta = 2 pi k`, probes `sum_n A_n cos(n theta + phi_n)`.

mod accuracy;
mod faults;
mod noise;
mod stream;

use crate::common::SplitMix64;
use num_complex::Complex;
use rotorid_core::ordertrack::{Average, OrderTracker, Revolution};
use rotorid_core::Real;
use std::f64::consts::{PI, TAU};

/// Keyphasor level and hysteresis of the generated pulse.
pub const LEVEL: f64 = 0.5;
pub const HYSTERESIS: f64 = 0.2;

/// `rpm` in rad/s.
pub fn rpm(n: f64) -> f64 {
    n * PI / 30.0
}

/// The angle in `[-pi, pi)`.
pub fn wrap(theta: f64) -> f64 {
    (theta + PI).rem_euclid(TAU) - PI
}

/// The keyphasor signal at shaft angle `theta`: 0, then a rising edge
/// linear in the angle over 0.2 rad that crosses `LEVEL` at the mark
/// (`theta = 0 mod 2 pi`), 1 up to a quarter turn, 0 again.
pub fn pulse(theta: f64) -> f64 {
    let u = wrap(theta);
    if u >= PI / 2.0 {
        0.0
    } else {
        (0.5 + u / 0.2).clamp(0.0, 1.0)
    }
}

/// A generated recording.
#[derive(Clone, Debug)]
pub struct Signal<const NC: usize> {
    /// Sample rate (Hz).
    pub fs: f64,
    /// Angle at t = 0 (rad), speed at t = 0 (rad/s), acceleration (rad/s^2).
    pub theta0: f64,
    pub w0: f64,
    pub alpha: f64,
    /// Per channel, `(A_n, phi_n)` for `n = 0..=5` (`n = 0`: the DC value `A_0`).
    pub harmonics: [[(f64, f64); 6]; NC],
}

impl<const NC: usize> Signal<NC> {
    /// At constant speed `w0`, with random harmonics: DC 100 times the 1X,
    /// 2X..5X between 0.3 and 1 times it.
    pub fn steady(fs: f64, w0: f64, seed: u64) -> Self {
        let mut rng = SplitMix64::new(seed);
        let harmonics = core::array::from_fn(|_| {
            let a1 = 1e-5 * (1.0 + rng.uniform());
            core::array::from_fn(|n| match n {
                0 => (100.0 * a1 * rng.sym(), 0.0),
                1 => (a1, PI * rng.sym()),
                _ => (a1 * (0.3 + 0.7 * rng.uniform()), PI * rng.sym()),
            })
        });
        Signal {
            fs,
            theta0: 1.0,
            w0,
            alpha: 0.0,
            harmonics,
        }
    }

    pub fn theta(&self, i: usize) -> f64 {
        let t = i as f64 / self.fs;
        self.theta0 + self.w0 * t + 0.5 * self.alpha * t * t
    }

    /// The probes at angle `theta`.
    pub fn probes(&self, theta: f64) -> [f64; NC] {
        core::array::from_fn(|c| {
            self.harmonics[c]
                .iter()
                .enumerate()
                .map(|(n, &(a, phi))| {
                    if n == 0 {
                        a
                    } else {
                        a * (n as f64 * theta + phi).cos()
                    }
                })
                .sum()
        })
    }

    /// The nX phasor of channel `c`: `A_n exp(j phi_n)`.
    pub fn truth(&self, c: usize, n: usize) -> Complex<f64> {
        let (a, phi) = self.harmonics[c][n];
        Complex::from_polar(a, phi)
    }

    /// Keyphasor and probes of sample `i`.
    pub fn sample(&self, i: usize) -> (f64, [f64; NC]) {
        let th = self.theta(i);
        (pulse(th), self.probes(th))
    }

    /// The time (s) at which the angle reaches `theta` (first root).
    pub fn time_of(&self, theta: f64) -> f64 {
        let d = theta - self.theta0;
        if self.alpha == 0.0 {
            d / self.w0
        } else {
            2.0 * d / (self.w0 + (self.w0 * self.w0 + 2.0 * self.alpha * d).sqrt())
        }
    }
}

/// What a run gave.
pub struct Run<T, const NC: usize> {
    pub revolutions: Vec<Revolution<T, NC>>,
    pub averages: Vec<Average<T, NC>>,
}

/// Feeds `n` samples to `tracker`, rounded to `T`.
pub fn run<T: Real, const NC: usize, const CAP: usize>(
    tracker: &mut OrderTracker<T, NC, CAP>,
    n: usize,
    mut sample: impl FnMut(usize) -> (f64, [f64; NC]),
) -> Run<T, NC> {
    let mut out = Run {
        revolutions: Vec::new(),
        averages: Vec::new(),
    };
    for i in 0..n {
        let (kp, y) = sample(i);
        if let Some(o) = tracker.push(T::lit(kp), &y.map(T::lit)) {
            out.revolutions.push(o.revolution);
            out.averages.extend(o.average);
        }
    }
    out
}

pub fn c64<T: Real>(z: Complex<T>) -> Complex<f64> {
    Complex::new(z.re.to_f64(), z.im.to_f64())
}

/// Relative error and phase error (degrees) of `x` against `truth`.
pub fn errors(x: Complex<f64>, truth: Complex<f64>) -> (f64, f64) {
    (
        (x - truth).norm() / truth.norm(),
        (x / truth).arg().to_degrees().abs(),
    )
}

/// A standard normal draw (Box-Muller).
pub fn gauss(rng: &mut SplitMix64) -> f64 {
    let u1 = 1.0 - rng.uniform();
    let u2 = rng.uniform();
    (-2.0 * u1.ln()).sqrt() * (TAU * u2).cos()
}
