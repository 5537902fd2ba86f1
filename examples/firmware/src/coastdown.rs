//! A synthetic coast-down: the keyphasor and probe samples of a rotor
//! decelerating at a constant rate, sampled at a fixed rate like an ADC,
//! generated from a table of 1X phasors (speed in rad/s, one phasor per
//! probe in m). Shared word for word by the firmware and its host check
//! (`examples/firmware_host.rs`), so that both run the same `f32`
//! arithmetic: no `sin`/`cos` of a math library (the rotations come from a
//! series, once a revolution), no fused multiply-add, integer noise.
//!
//! # Angle
//!
//! Speed `w(t) = w_0 - alpha t` (rad/s, `alpha > 0` the deceleration in
//! rad/s^2), sample `i` at `t = i / f_s`, shaft angle from the keyphasor
//! mark `theta_i = w_0 i / f_s - alpha i^2 / (2 f_s^2)` (rad). The step from
//! sample `i` to `i + 1` is `d_i = (w_0 - alpha (i + 1/2) / f_s) / f_s`, so
//! the angle's unit phasor and its step are rotated, no sine per sample:
//!
//! ```text
//! P_(i+1) = P_i S_i,      S_(i+1) = S_i C,
//! P_0 = 1,   S_0 = exp(j d_0),   C = exp(-j alpha / f_s^2),
//! ```
//!
//! `P_i = exp(j theta_i)`. Rounding makes `|P|` drift by about
//! `f32::EPSILON` per sample; once a revolution it is put back on the unit
//! circle by one Newton step, `z (3 - |z|^2) / 2`, and `S_i` is formed
//! afresh, `exp(j d_i)` by its series (so that the step's rounding does not
//! add up over the run and the rotation keeps the nominal speed).
//!
//! # Signals
//!
//! Probe `c` reads, in m,
//!
//! ```text
//! y_c = Re{ Y_c P } + Re{ r_2 Y_c P^2 } + g_c + sigma_c e,
//! sigma_c^2 = f^2 + s^2 |Y_c|^2      (floor f in m, relative part s),
//! ```
//!
//! `Y_c` the table's phasor linearly interpolated at the revolution's mean
//! speed (set once a revolution, at its start: the vibration of a
//! revolution is one sinusoid), `r_2` the 2X as a ratio of the 1X, `g_c`
//! the probe's gap (DC), `e` unit-variance noise. The noise law is the
//! probe noise model `E|e|^2 = f^2 + s^2 |q|^2` on every sample, whose 1X
//! vector over `M` samples per revolution and `N` revolutions has
//! `E|dY|^2 = 4 sigma_c^2 / (M N)`.
//!
//! `e` is the sum of the four bytes of a 32-bit xorshift draw
//! (Marsaglia's 13, 17, 5), centred and scaled to unit variance: an
//! Irwin-Hall approximation of the normal law, exact integer arithmetic.
//!
//! # Keyphasor
//!
//! The mark passes the keyphasor probe at `theta = 0 (mod 2 pi)`, where
//! `Im P` rises through 0 with `Re P > 0`. The pulse channel (0..1) is
//!
//! ```text
//! k = clamp(1/2 + Im P / (2 h), 0, 1)   where Re P > 0,   else 0,
//! ```
//!
//! an edge `2 h` wide in `sin theta` (`h = 0.3`: 0.6 rad) rising through
//! 1/2 exactly at the mark, high until `theta = pi / 2`. A revolution starts
//! at the first sample with `Im P >= 0` after one with `Im P < 0`, `Re P > 0`.

use rotorid_core::{Complex, Real};

/// A 32-bit xorshift generator (Marsaglia 2003, shifts 13, 17, 5): period
/// `2^32 - 1`, nonzero state.
#[derive(Debug, Clone, Copy)]
pub struct Xorshift32(u32);

impl Xorshift32 {
    /// A generator from `seed` (0 is replaced by a fixed nonzero state).
    pub fn new(seed: u32) -> Self {
        Xorshift32(if seed == 0 { 0x9E37_79B9 } else { seed })
    }

    /// The next 32-bit draw.
    pub fn next_u32(&mut self) -> u32 {
        let mut x = self.0;
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        self.0 = x;
        x
    }

    /// Unit-variance noise: the four bytes of a draw summed (mean 510,
    /// variance `4 (256^2 - 1) / 12 = 21845`), centred and scaled.
    pub fn noise(&mut self) -> f32 {
        /// `1 / sqrt(21845)`.
        const SCALE: f32 = 0.006_765_901;
        let x = self.next_u32();
        let s = (x & 0xff) + ((x >> 8) & 0xff) + ((x >> 16) & 0xff) + (x >> 24);
        (s as i32 - 510) as f32 * SCALE
    }
}

/// `exp(j x)` by the series of the cosine and the sine in `x^2` (Horner,
/// six terms beyond the first: below `f32` rounding for `|x| <= 0.5`),
/// plain `f32` arithmetic, the same bits on every IEEE machine.
fn cis(x: f32) -> Complex<f32> {
    let z = x * x;
    let (mut c, mut s) = (1.0f32, 1.0f32);
    for m in (1..=6u32).rev() {
        c = 1.0 - z * c / ((2 * m - 1) * (2 * m)) as f32;
        s = 1.0 - z * s / ((2 * m) * (2 * m + 1)) as f32;
    }
    Complex::new(c, x * s)
}

/// The square root (correctly rounded in IEEE arithmetic, so the same on
/// the host, `sqrtss`, and the target, `vsqrt.f32` or `libm`).
fn sqrt<T: Real>(x: T) -> T {
    x.sqrt()
}

/// `z (3 - |z|^2) / 2`: `z` put back on the unit circle (one Newton step).
fn unit(z: Complex<f32>) -> Complex<f32> {
    z.scale(1.5 - 0.5 * (z.re * z.re + z.im * z.im))
}

/// What the coast-down is: the rates, the speeds and the signal's content.
#[derive(Debug, Clone, Copy)]
pub struct Setup<const NC: usize> {
    /// Sample rate `f_s` (Hz).
    pub sample_rate: f32,
    /// Speed at the first sample `w_0` (rad/s).
    pub speed_start: f32,
    /// The coast-down ends (no more samples) below this speed (rad/s).
    pub speed_end: f32,
    /// Deceleration `alpha` (rad/s^2, `> 0`).
    pub deceleration: f32,
    /// 2X as a ratio of the 1X, `r_2` (0 for none).
    pub x2_ratio: Complex<f32>,
    /// Probe gaps `g_c` (m; 0 for none).
    pub gap: [f32; NC],
    /// Noise floor `f` (m, per sample).
    pub noise_floor: f32,
    /// Relative noise `s` (of `|Y_c|`, per sample).
    pub noise_relative: f32,
    /// Noise seed.
    pub seed: u32,
}

/// The sample generator of the module documentation over a phasor table
/// `(speed in rad/s, [Y_c in m; NC])`, speeds increasing.
#[derive(Debug, Clone)]
pub struct Coastdown<'a, const NC: usize> {
    table: &'a [(f32, [Complex<f32>; NC])],
    setup: Setup<NC>,
    /// `alpha / f_s` (rad/s per sample).
    decel_per_sample: f32,
    /// `P_i`, `S_i`, `C`.
    p: Complex<f32>,
    step: Complex<f32>,
    chirp: Complex<f32>,
    /// The sample to come, `i`.
    i: u32,
    /// The table interval of the last lookup.
    cursor: usize,
    /// This revolution's 1X and 2X phasors and noise levels.
    y1: [Complex<f32>; NC],
    y2: [Complex<f32>; NC],
    sigma: [f32; NC],
    /// Revolutions started (the one under way included).
    revolutions: u32,
    rng: Xorshift32,
}

impl<'a, const NC: usize> Coastdown<'a, NC> {
    /// The generator at sample 0 (angle 0, the mark passing).
    pub fn new(table: &'a [(f32, [Complex<f32>; NC])], setup: Setup<NC>) -> Self {
        let (fs, alpha) = (setup.sample_rate, setup.deceleration);
        let zero = Complex::new(0.0, 0.0);
        let mut g = Coastdown {
            table,
            setup,
            decel_per_sample: alpha / fs,
            p: Complex::new(1.0, 0.0),
            step: Complex::new(1.0, 0.0),
            chirp: cis(-alpha / (fs * fs)),
            i: 0,
            cursor: 0,
            y1: [zero; NC],
            y2: [zero; NC],
            sigma: [0.0; NC],
            revolutions: 0,
            rng: Xorshift32::new(setup.seed),
        };
        g.revolution();
        g
    }

    /// Speed at the sample to come, `w_0 - alpha i / f_s` (rad/s).
    pub fn speed(&self) -> f32 {
        self.setup.speed_start - self.decel_per_sample * self.i as f32
    }

    /// Revolutions started so far.
    #[allow(dead_code)] // used by the host test (tests/identify/coastdown.rs)
    pub fn revolutions(&self) -> u32 {
        self.revolutions
    }

    /// This revolution's 1X phasors (m).
    #[allow(dead_code)] // used by the host test (tests/identify/coastdown.rs)
    pub fn x1(&self) -> &[Complex<f32>; NC] {
        &self.y1
    }

    /// This revolution's per-sample noise levels `sigma_c` (m).
    #[allow(dead_code)] // used by the host test (tests/identify/coastdown.rs)
    pub fn sigma(&self) -> &[f32; NC] {
        &self.sigma
    }

    /// The table's phasors at `speed`, linear between neighbouring
    /// speeds, the end values beyond them.
    fn lookup(&mut self, speed: f32) -> [Complex<f32>; NC] {
        let zero = [Complex::new(0.0, 0.0); NC];
        let n = self.table.len();
        if n == 0 {
            return zero;
        }
        // Move the cursor to the interval [s_j, s_(j+1)) holding the speed.
        let mut j = self.cursor.min(n - 1);
        while j > 0 && self.table.get(j).is_some_and(|r| r.0 > speed) {
            j -= 1;
        }
        while j + 1 < n && self.table.get(j + 1).is_some_and(|r| r.0 <= speed) {
            j += 1;
        }
        self.cursor = j;
        let (Some(a), Some(b)) = (self.table.get(j), self.table.get((j + 1).min(n - 1))) else {
            return zero;
        };
        let t = if b.0 > a.0 {
            ((speed - a.0) / (b.0 - a.0)).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let mut y = zero;
        for ((yc, ya), yb) in y.iter_mut().zip(a.1.iter()).zip(b.1.iter()) {
            *yc = *ya + (*yb - *ya).scale(t);
        }
        y
    }

    /// Starts a revolution: phasors at its mean speed `w - alpha pi / w`
    /// (half a period's deceleration after its start), noise levels,
    /// phasor renormalisation.
    fn revolution(&mut self) {
        self.revolutions = self.revolutions.wrapping_add(1);
        let w = self.speed();
        let mean = w - self.setup.deceleration * core::f32::consts::PI / w;
        self.y1 = self.lookup(mean);
        let (f, s) = (self.setup.noise_floor, self.setup.noise_relative);
        for ((y2, s2), y1) in self
            .y2
            .iter_mut()
            .zip(self.sigma.iter_mut())
            .zip(self.y1.iter())
        {
            *y2 = self.setup.x2_ratio * *y1;
            *s2 = sqrt(f * f + s * s * y1.norm_sqr());
        }
        self.p = unit(self.p);
        self.step = cis((w - 0.5 * self.decel_per_sample) / self.setup.sample_rate);
    }

    /// The next sampling instant: the keyphasor channel and the probes, or
    /// `None` once the speed is below the end speed.
    pub fn next_sample(&mut self) -> Option<(f32, [f32; NC])> {
        if self.speed() < self.setup.speed_end {
            return None;
        }
        let p = self.p;
        let kp = if p.re > 0.0 {
            (0.5 + p.im * (1.0 / 0.6)).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let p2 = p * p;
        let mut y = self.setup.gap;
        for (((yc, y1), y2), sc) in y
            .iter_mut()
            .zip(self.y1.iter())
            .zip(self.y2.iter())
            .zip(self.sigma.iter())
        {
            let v = (y1.re * p.re - y1.im * p.im) + (y2.re * p2.re - y2.im * p2.im);
            *yc += v + *sc * self.rng.noise();
        }
        // Advance the angle; a new revolution at the mark.
        let next = p * self.step;
        self.step *= self.chirp;
        self.p = next;
        self.i = self.i.wrapping_add(1);
        if p.im < 0.0 && next.im >= 0.0 && next.re > 0.0 {
            self.revolution();
        }
        Some((kp, y))
    }
}
