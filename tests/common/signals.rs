//! Synthetic recordings for the `vectors` tests: the time signals of a
//! rotor's 1X response on a speed ramp, as probes and a keyphasor give them.
//!
//! The speed ramps linearly, `Omega(t) = Omega_0 + alpha t`, so the shaft
//! angle is `theta(t) = theta_0 + Omega_0 t + alpha t^2 / 2`. Each probe
//! channel `c` reads
//!
//! ```text
//! y_c(t) = Re{ Y_c(Omega(t)) e^(j theta) } + DC_c + Re{ X2_c e^(2 j theta) } + e_c(t),
//! e_c = f n_1 + s (y_c - DC_c) n_2,      n_1, n_2 independent N(0, 1),
//! ```
//!
//! `Y_c` the model's 1X response (`rotorid::fe`, interpolated linearly in
//! speed from a dense grid), `DC_c` a probe gap, `X2_c` a 2X part, `f` the
//! sample noise floor (m) and `s` a part relative to the vibration. The
//! keyphasor is 0..5 V with a rising edge of `0.1` rad of shaft angle
//! centred on `theta = 0 mod 2 pi` (so the level midway, 2.5 V, is crossed
//! at angle 0) and a falling edge at 1 rad.

use num_complex::Complex64;
use rand::Rng;
use rand_distr::{Distribution, StandardNormal};
use rotorid::model::RotorModel;
use rotorid::units::rpm_to_rad_s;
use std::f64::consts::PI;
use std::fmt::Write as _;

/// What to record.
#[derive(Debug, Clone, Copy)]
pub struct Sweep {
    /// Speed at t = 0 and at the end (rpm).
    pub rpm: (f64, f64),
    /// Duration (s).
    pub seconds: f64,
    /// Sample rate (Hz).
    pub fs: f64,
    /// Noise floor per sample (m).
    pub floor: f64,
    /// Relative noise per sample.
    pub relative: f64,
    /// Seed.
    pub seed: u64,
}

/// A recording with its truth.
pub struct Synthetic {
    /// Sample rate (Hz).
    pub fs: f64,
    /// Keyphasor (V).
    pub kp: Vec<f64>,
    /// Probe channels (m), one vector per channel `b1_y, b1_z, ...`.
    pub y: Vec<Vec<f64>>,
    /// Channel names.
    pub names: Vec<String>,
    /// Dense grid of the response: speeds (rad/s) and phasors per speed.
    grid: Vec<f64>,
    resp: Vec<Vec<Complex64>>,
    omega0: f64,
    alpha: f64,
    theta0: f64,
}

impl Synthetic {
    /// The model's 1X phasors at `omega` (rad/s), linear in speed between
    /// the grid's points.
    pub fn response(&self, omega: f64) -> Vec<Complex64> {
        let n = self.grid.len();
        let k = self.grid.partition_point(|w| *w <= omega).clamp(1, n - 1);
        let (w0, w1) = (self.grid[k - 1], self.grid[k]);
        let u = ((omega - w0) / (w1 - w0)).clamp(0.0, 1.0);
        self.resp[k - 1]
            .iter()
            .zip(&self.resp[k - 1 + 1])
            .map(|(a, b)| a * (1.0 - u) + b * u)
            .collect()
    }

    /// Shaft angle at time `t` (rad).
    pub fn theta(&self, t: f64) -> f64 {
        self.theta0 + self.omega0 * t + 0.5 * self.alpha * t * t
    }

    /// Speed at time `t` (rad/s).
    pub fn omega(&self, t: f64) -> f64 {
        self.omega0 + self.alpha * t
    }

    /// Sweep rate (rpm/s).
    pub fn rate_rpm_per_s(&self) -> f64 {
        rotorid::units::rad_s_to_rpm(self.alpha)
    }

    /// The true vector of a group of revolutions from `t0` to `t1` (s):
    /// the angle average of the response over them,
    /// `(1 / (theta_1 - theta_0)) integral Y(Omega) dtheta` (Simpson, 256
    /// intervals), what averaging the revolutions' Fourier integrals gives.
    pub fn truth(&self, t0: f64, t1: f64) -> Vec<Complex64> {
        let n = 256;
        let h = (t1 - t0) / n as f64;
        let mut acc = vec![Complex64::new(0.0, 0.0); self.names.len()];
        let mut wsum = 0.0;
        for i in 0..=n {
            let t = t0 + h * i as f64;
            let simpson = if i == 0 || i == n {
                1.0
            } else if i % 2 == 1 {
                4.0
            } else {
                2.0
            };
            let w = simpson * self.omega(t);
            wsum += w;
            for (a, y) in acc.iter_mut().zip(self.response(self.omega(t))) {
                *a += y * w;
            }
        }
        acc.into_iter().map(|a| a / wsum).collect()
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.kp.len()
    }

    /// The SPEC's signals CSV text (time with 9 decimals).
    pub fn csv(&self) -> String {
        let mut s = String::with_capacity(self.len() * 20 * (2 + self.y.len()));
        s.push_str("# synthetic run-down\ntime_s,kp");
        for n in &self.names {
            s.push(',');
            s.push_str(n);
        }
        s.push('\n');
        for i in 0..self.len() {
            let _ = write!(s, "{:.9},{}", i as f64 / self.fs, self.kp[i]);
            for c in &self.y {
                let _ = write!(s, ",{:e}", c[i]);
            }
            s.push('\n');
        }
        s
    }
}

/// Keyphasor voltage at shaft angle `theta`.
pub fn keyphasor(theta: f64) -> f64 {
    let phi = (theta + PI).rem_euclid(2.0 * PI) - PI;
    let eps = 0.1;
    let rise = (phi / eps + 0.5).clamp(0.0, 1.0);
    let fall = ((1.0 - phi) / eps + 0.5).clamp(0.0, 1.0);
    5.0 * rise.min(fall)
}

/// Records `model` (its unbalance) on `sweep`.
pub fn record(model: &RotorModel, sweep: &Sweep) -> Synthetic {
    let (w0, w1) = (rpm_to_rad_s(sweep.rpm.0), rpm_to_rad_s(sweep.rpm.1));
    let (lo, hi) = (w0.min(w1) * 0.97, w0.max(w1) * 1.03);
    let grid: Vec<f64> = (0..=600)
        .map(|i| lo + (hi - lo) * i as f64 / 600.0)
        .collect();
    let m = super::simulate(model, &grid);
    let resp: Vec<Vec<Complex64>> = m.samples.into_iter().map(|s| s.q).collect();
    let nch = resp[0].len();
    let names: Vec<String> = (0..nch)
        .map(|c| format!("b{}_{}", c / 2 + 1, if c % 2 == 0 { "y" } else { "z" }))
        .collect();
    let mut rng = super::rng(sweep.seed);
    let theta0 = rng.random_range(0.5..5.5);
    let mut s = Synthetic {
        fs: sweep.fs,
        kp: Vec::new(),
        y: vec![Vec::new(); nch],
        names,
        grid,
        resp,
        omega0: w0,
        alpha: (w1 - w0) / sweep.seconds,
        theta0,
    };
    let n = (sweep.seconds * sweep.fs) as usize;
    let dc: Vec<f64> = (0..nch).map(|c| 0.5e-3 + 0.1e-3 * c as f64).collect();
    let x2: Vec<Complex64> = (0..nch)
        .map(|c| Complex64::from_polar(0.3e-6, 0.7 * c as f64))
        .collect();
    s.kp.reserve(n);
    for c in &mut s.y {
        c.reserve(n);
    }
    for i in 0..n {
        let t = i as f64 / sweep.fs;
        let th = s.theta(t);
        let e1 = Complex64::from_polar(1.0, th);
        let e2 = e1 * e1;
        let q = s.response(s.omega(t));
        s.kp.push(keyphasor(th));
        for c in 0..nch {
            let vib = (q[c] * e1).re + (x2[c] * e2).re;
            let n1: f64 = StandardNormal.sample(&mut rng);
            let n2: f64 = StandardNormal.sample(&mut rng);
            let y = vib + dc[c] + sweep.floor * n1 + sweep.relative * vib * n2;
            s.y[c].push(y);
        }
    }
    s
}
