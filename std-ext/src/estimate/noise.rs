//! The measurement's relative noise level, estimated without the rotor
//! model, so that a model's misfit can be told from noise.
//!
//! # Method
//!
//! The noise model is the measurement file's: each complex sample carries
//! `s |q| eps`, `eps` standard complex Gaussian (`E|eps|^2 = 1`). The true
//! 1X response is smooth in the speed, the noise is independent from
//! sample to sample. Per channel, with the samples sorted by speed, a
//! quadratic in `Omega` is fitted by least squares to each window of
//! [`WINDOW`] consecutive samples; the residual of the window's centre
//! sample has variance `s^2 |q|^2 (1 - h)` with `h` the centre's leverage
//! (hat-matrix diagonal) when the window holds only noise around a
//! quadratic. So `x = |e|^2 / ((1 - h) |q|^2)` is `s^2` times an `Exp(1)`
//! variable, whose median is `ln 2`, and
//!
//! ```text
//!     s^2 = median_(samples, channels) x / ln 2 .
//! ```
//!
//! The median ignores the minority of windows where the response is not
//! locally quadratic (across a resonance on a coarse grid): the estimate
//! is model-free and robust, not exact; its relative standard error is
//! about `1.25 / sqrt(n)` for `n` windows (`~1e-2` for 3000 speeds x 4
//! channels), plus the curvature bias of a coarse grid (the speeds must be
//! dense enough that the response is locally quadratic over [`WINDOW`]
//! samples over most of the range).

use crate::io::measurement::Sample;

/// Samples per local fit.
pub const WINDOW: usize = 7;

/// The relative noise level `s` (see the module documentation), or `None`
/// with fewer than [`WINDOW`] samples of distinct speed or no signal.
pub fn relative_noise_level(samples: &[Sample]) -> Option<f64> {
    let nq = samples.first()?.q.len();
    let mut ratios = Vec::with_capacity(samples.len() * nq);
    for_each_window(samples, |idx, coef_of, h| {
        for c in 0..nq {
            let qc = samples[idx[WINDOW / 2]].q[c];
            let mag2 = qc.norm_sqr();
            if mag2.is_nan() || mag2 <= 0.0 || h >= 1.0 {
                continue;
            }
            let fit: num_complex::Complex64 = idx
                .iter()
                .zip(coef_of)
                .map(|(&i, &l)| samples[i].q[c] * l)
                .sum();
            let e = qc - fit;
            ratios.push(e.norm_sqr() / ((1.0 - h) * mag2));
        }
    });
    if ratios.is_empty() {
        return None;
    }
    let mid = ratios.len() / 2;
    let (_, median, _) = ratios.select_nth_unstable_by(mid, f64::total_cmp);
    let s2 = *median / core::f64::consts::LN_2;
    s2.is_finite().then_some(s2.sqrt())
}

/// Calls `f(idx, l, h)` for every window of [`WINDOW`] consecutive
/// samples in speed order (`idx` the samples' indices, the centre at
/// `WINDOW / 2`) whose speeds span a positive range, with the smoother
/// weights `l` of a quadratic in `Omega` at the centre and its leverage `h`
/// ([`centre_smoother`]).
fn for_each_window(samples: &[Sample], mut f: impl FnMut(&[usize], &[f64], f64)) {
    let mut order: Vec<usize> = (0..samples.len()).collect();
    order.sort_by(|&i, &j| samples[i].omega.total_cmp(&samples[j].omega));
    let half = WINDOW / 2;
    for centre in half..order.len().saturating_sub(half) {
        let idx = &order[centre - half..=centre + half];
        let w0 = samples[order[centre]].omega;
        let span = samples[idx[WINDOW - 1]].omega - samples[idx[0]].omega;
        if span.is_nan() || span <= 0.0 {
            continue;
        }
        // Quadratic design in x = (Omega - Omega_centre) / span.
        let x: Vec<f64> = idx
            .iter()
            .map(|&i| (samples[i].omega - w0) / span)
            .collect();
        if let Some((coef_of, h)) = centre_smoother(&x, half) {
            f(idx, &coef_of, h);
        }
    }
}

/// The weights `l` with `fit(centre) = sum_i l_i y_i` of a least-squares
/// quadratic through the points `x`, and the centre's leverage `h = l_centre`.
fn centre_smoother(x: &[f64], centre: usize) -> Option<(Vec<f64>, f64)> {
    // Normal matrix of the basis (1, x, x^2).
    let mut n = nalgebra::Matrix3::<f64>::zeros();
    for &xi in x {
        let v = nalgebra::Vector3::new(1.0, xi, xi * xi);
        n += v * v.transpose();
    }
    let inv = n.try_inverse()?;
    let x0 = x[centre];
    let v0 = nalgebra::Vector3::new(1.0, x0, x0 * x0);
    let row = v0.transpose() * inv;
    let l: Vec<f64> = x
        .iter()
        .map(|&xi| (row * nalgebra::Vector3::new(1.0, xi, xi * xi))[0])
        .collect();
    let h = l[centre];
    Some((l, h))
}

/// Where a [`NoiseModel`] came from (SPEC section 7, `"source"`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum NoiseSource {
    /// Floor and relative part estimated from the data.
    Estimated,
    /// The floor given (`--noise-floor`, a probe data sheet); the relative
    /// part estimated.
    Given,
    /// Per-sample standard deviations from the measurement file (the
    /// `_std` columns), up to one common factor.
    File,
}

impl NoiseSource {
    /// The JSON name.
    pub fn name(self) -> &'static str {
        match self {
            NoiseSource::Estimated => "estimated",
            NoiseSource::Given => "given",
            NoiseSource::File => "file",
        }
    }
}

/// The noise model of real probes (SPEC section 7): each complex sample
/// `q` of channel `c` carries noise `e` with
///
/// ```text
///     E|e|^2 = f_c^2 + s^2 |q|^2 ,
/// ```
///
/// a floor `f_c` (m) per channel (probe electronics, electrical runout
/// scatter, quantisation) plus the relative part `s`. `f_c = 0` for every
/// channel is the proportional model of SPEC section 4.
#[derive(Debug, Clone, PartialEq)]
pub struct NoiseModel {
    /// `f_c` per channel (m).
    pub floor_m: Vec<f64>,
    /// `s`.
    pub relative: f64,
    /// Where it came from.
    pub source: NoiseSource,
}

/// The smallest relative part used to express a floor in relative units
/// (`f_c / s`): data with a floor and no measurable relative part are
/// weighted as if `s` were this, which leaves the weights constant per
/// channel (`w ~ f_c / s`).
pub const MIN_RELATIVE: f64 = 1e-9;

impl NoiseModel {
    /// Proportional noise `s` on `nq` channels (no floor).
    pub fn proportional(nq: usize, s: f64, source: NoiseSource) -> Self {
        NoiseModel {
            floor_m: vec![0.0; nq],
            relative: s,
            source,
        }
    }

    /// Whether any channel has a floor.
    pub fn has_floor(&self) -> bool {
        self.floor_m.iter().any(|f| *f > 0.0)
    }

    /// The variance `E|e|^2` of a sample of channel `c` whose true
    /// response has magnitude squared `q2` (m^2).
    pub fn variance(&self, c: usize, q2: f64) -> f64 {
        let f = self.floor_m.get(c).copied().unwrap_or(0.0);
        f * f + self.relative * self.relative * q2
    }

    /// The floors in relative units, `phi_c = f_c / s` (m), with `s` at
    /// least [`MIN_RELATIVE`]: the weight of a sample in the relative
    /// units of the fits is `sqrt(phi_c^2 + |q|^2) = sigma / s`.
    pub fn relative_floor(&self) -> Vec<f64> {
        let s = self.relative.max(MIN_RELATIVE);
        self.floor_m.iter().map(|f| f / s).collect()
    }
}

/// One observation of the noise variance: a squared residual `x` (of
/// channel `channel`) whose expectation under the noise model is linear in
/// the variance parameters,
///
/// ```text
///     E[x] = a f_c^2 + b s^2 ,
/// ```
///
/// (`x` exponentially distributed for a complex Gaussian residual): for a
/// model residual `a = 1`, `b = |q|^2`; for a local smoother's residual the
/// sums of its squared weights (see [`local_points`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VariancePoint {
    /// Channel index.
    pub channel: usize,
    /// The squared residual.
    pub x: f64,
    /// Coefficient of `f_c^2`.
    pub a: f64,
    /// Coefficient of `s^2`.
    pub b: f64,
}

impl VariancePoint {
    /// A residual `e` of a sample whose true response has magnitude
    /// squared `q2` (m^2): `x = |e|^2 corr`, `a = 1`, `b = q2` (`corr` the
    /// leverage correction of the fit).
    pub fn residual(channel: usize, e2: f64, q2: f64, corr: f64) -> Self {
        VariancePoint {
            channel,
            x: e2 * corr,
            a: 1.0,
            b: q2,
        }
    }

    /// A known variance `v` (m^2) of a sample of magnitude squared `q2`.
    pub fn known(channel: usize, v: f64, q2: f64) -> Self {
        Self::residual(channel, v, q2, 1.0)
    }
}

/// Residuals of a local quadratic beyond which a window is treated as
/// curvature, not noise, by [`fit_variance`]: the ratio `x / E[x]` is
/// capped here (an `Exp(1)` variable exceeds 4 with probability 1.8 %).
pub const CAP: f64 = 4.0;

/// Wald statistic `f_c^2 / se(f_c^2)` above which a channel's floor counts
/// as present in the data; below it the channel's floor is taken as 0 (the
/// proportional model, which gives exactly the weights of SPEC section 4).
pub const FLOOR_SIGNIFICANCE: f64 = 4.0;

/// The variance parameters fitted by [`fit_variance`].
#[derive(Debug, Clone, PartialEq)]
pub struct VarianceFit {
    /// `f_c^2` per channel (m^2).
    pub floor2: Vec<f64>,
    /// `s^2`.
    pub relative2: f64,
    /// `f_c^2 / se(f_c^2)` per channel (0 where the floor was held).
    pub floor_z: Vec<f64>,
}

/// Maximum-likelihood variance parameters `f_c^2`, `s^2` of the points
/// (robust: each point's ratio to its expectation is capped at [`CAP`]).
///
/// # Method
///
/// With `v_i = a_i f_(c_i)^2 + b_i s^2` and `x_i ~ v_i Exp(1)`, the score
/// equations of the likelihood are those of a gamma regression with the
/// identity link, solved by iteratively reweighted least squares: regress
/// `y_i` on `a_i` (in the column of its channel) and `b_i` with weights
/// `1 / v_i^2`, `v_i` from the previous iterate. The pseudo-observation is
/// `y_i = v_i min(x_i / v_i, CAP) / (1 - e^-CAP)`, whose expectation under
/// the model is `v_i` (`E min(E, c) = 1 - e^-c` for `E ~ Exp(1)`): points
/// far above their expectation (a local fit across a resonance, a glitch)
/// have bounded influence. A parameter the iteration drives below zero is
/// held at zero. The standard errors are those of the gamma regression
/// (dispersion 1), `(X^T W X)^-1`.
///
/// These scoring steps converge linearly (by a factor of 0.1-0.4 per step
/// on sweeps). From a start near the root (a refinement's previous
/// estimate) or once a scoring step is under [`NEWTON_BELOW`] (relative),
/// with every free parameter inside its bound, the iteration takes
/// Newton's steps on the same score equations instead, which converge
/// quadratically: with `m = min(x, CAP v) / (1 - e^-CAP)`, the score of
/// each parameter is `sum_i u_i (m_i - v_i) / v_i^2` (`u_i` its
/// coefficient `a_i` or `b_i`) and its derivative `-sum_i u_i u_i^T (2 m_i
/// / v_i - 1 - dm_i/dv_i) / v_i^2`. It stops when a scoring step is under
/// 1e-8 or a Newton step under [`NEWTON_DONE`] (relative), which leaves an
/// error of about `2 NEWTON_DONE^2`.
///
/// `held[c] = Some(f2)` holds channel `c`'s floor at `f2` (a given
/// floor, or 0); `None` fits it. `None` when there are no points or the
/// system is singular.
pub fn fit_variance(points: &[VariancePoint], held: &[Option<f64>]) -> Option<VarianceFit> {
    fit_variance_from(points, held, None)
}

/// [`fit_variance`] started from `start` (`f_c^2` per channel, `s^2`), e.g.
/// the previous fit's, instead of the medians.
pub fn fit_variance_from(
    points: &[VariancePoint],
    held: &[Option<f64>],
    start: Option<(&[f64], f64)>,
) -> Option<VarianceFit> {
    fit_variance_channels(&ChannelPoints::of(points, held.len())?, held, start, true)
}

/// Variance points channel by channel, `[a, b, x]` each, in their order
/// ([`VariancePoint`] without the channel).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ChannelPoints(pub Vec<Vec<[f64; 3]>>);

impl ChannelPoints {
    /// `points` on `nq` channels; `None` when a point's channel is not
    /// below `nq`.
    pub fn of(points: &[VariancePoint], nq: usize) -> Option<Self> {
        let mut by_channel = vec![Vec::with_capacity(points.len() / nq.max(1) + 1); nq];
        for p in points {
            by_channel.get_mut(p.channel)?.push([p.a, p.b, p.x]);
        }
        Some(ChannelPoints(by_channel))
    }

    fn len(&self) -> usize {
        self.0.iter().map(Vec::len).sum()
    }
}

/// [`fit_variance_from`] on points by channel; `newton` false takes only
/// scoring steps (the reference of the tests).
fn fit_variance_channels(
    points: &ChannelPoints,
    held: &[Option<f64>],
    start: Option<(&[f64], f64)>,
    newton_steps: bool,
) -> Option<VarianceFit> {
    let nq = held.len();
    let n = points.len();
    if n == 0 || points.0.len() != nq {
        return None;
    }
    let norm = (1.0 - (-CAP).exp()).recip();
    let scale_x = points
        .0
        .iter()
        .flatten()
        .map(|[a, _, x]| x / a.max(f64::MIN_POSITIVE))
        .sum::<f64>()
        / n as f64;
    if !(scale_x.is_finite() && scale_x > 0.0) {
        return None;
    }
    // Start: the given one (a refinement) where it is usable, else `s^2`
    // from the upper half of the responses and `f_c^2` from the lower
    // quarter of each channel (a sort of the points, skipped when the
    // given start covers every free parameter).
    let given = start.filter(|(f0, s0)| f0.len() == nq && s0.is_finite() && *s0 > 0.0);
    let usable = |c: usize| given.is_some_and(|(f0, _)| f0[c].is_finite() && f0[c] > 0.0);
    let near = given.is_some() && (0..nq).all(|c| held[c].is_some() || usable(c));
    let (mut s2, mut f2) = if near {
        (0.0, held.iter().map(|h| h.unwrap_or(0.0)).collect())
    } else {
        start_from_points(points, held, scale_x)
    };
    if let Some((f0, s0)) = given {
        s2 = s0;
        for (c, f) in f2.iter_mut().enumerate() {
            if held[c].is_none() && usable(c) {
                *f = f0[c];
            }
        }
    }
    let free: Vec<bool> = held.iter().map(Option::is_none).collect();
    let tiny = 1e-12 * scale_x;
    let mut floor_z = vec![0.0; nq];
    let mut sums = vec![ArrowSums::default(); nq];
    // Unknowns: the free floors, then s^2.
    let idx: Vec<usize> = (0..nq).filter(|&c| free[c]).collect();
    // Newton's steps from the start when it is the previous estimate.
    let mut newton = near && newton_steps;
    for _ in 0..200 {
        // The normal equations are an arrow: each point touches its own
        // channel's floor and `s^2`. Their sums per channel, of the scoring
        // step and of Newton's, and those of `s^2` (a held floor's part
        // `known` in `v`).
        let mut ss = ArrowSums::default();
        for (c, pts) in points.0.iter().enumerate() {
            let (own, of_s) = channel_sums(pts, f2[c], s2, free[c], norm, tiny);
            sums[c] = own;
            ss.merge(&of_s);
        }
        // The scoring (IRLS) step: regress `y` with weights `1 / v^2`.
        let k = idx.len() + 1;
        let scoring = ArrowSums::solve(&idx, &sums, &ss, |s| (s.faa, s.fab, s.fay))?;
        let inv_diag = scoring.1;
        let mut sol = scoring.0;
        // Newton's step on the same score equations, once the scoring
        // steps are small and every free parameter is inside its bound:
        // converges quadratically to the same root (the scoring steps
        // only linearly, the more slowly the more the data's spread
        // departs from the model's).
        let mut quadratic = false;
        if newton {
            let step = ArrowSums::solve(&idx, &sums, &ss, |s| (s.haa, s.hab, s.g));
            if let Some((d, _)) = step {
                quadratic = true;
                for (j, &c) in idx.iter().enumerate() {
                    sol[j] = f2[c] + d[j];
                }
                sol[k - 1] = s2 + d[k - 1];
            }
        }
        let mut change: f64 = 0.0;
        let mut inside = true;
        for (j, &c) in idx.iter().enumerate() {
            let new = sol[j];
            floor_z[c] = new / inv_diag[j].sqrt();
            // Projected onto f_c^2 >= 0 (the iteration may bring it back).
            inside &= new > 0.0;
            let new = new.max(0.0);
            change = change.max((new - f2[c]).abs() / scale_x);
            f2[c] = new;
        }
        let new = sol[k - 1].max(0.0);
        inside &= new > 0.0;
        change = change.max((new - s2).abs() / s2.max(f64::MIN_POSITIVE));
        s2 = new;
        if !f2.iter().chain([&s2]).all(|v| v.is_finite()) {
            return None;
        }
        // A Newton step of relative size `d` leaves an error of order
        // `d^2` (about `2 d^2` on sweeps): 2e-8 at most.
        if change < 1e-8 || (quadratic && change < NEWTON_DONE) {
            break;
        }
        newton = newton_steps && inside && change < NEWTON_BELOW;
    }
    Some(VarianceFit {
        floor2: f2,
        relative2: s2,
        floor_z,
    })
}

/// Relative change of the variance parameters per step below which
/// [`fit_variance_from`] takes Newton's steps instead of scoring steps.
pub const NEWTON_BELOW: f64 = 0.05;

/// Relative size of a Newton step after which [`fit_variance_from`] stops.
pub const NEWTON_DONE: f64 = 1e-4;

/// Sums of one unknown's points in [`fit_variance_from`]: of the scoring
/// step (weights `w = 1 / v^2`: `sum w a^2`, `sum w a b`, `sum w a y`) and
/// of Newton's (`sum w_n a^2`, `sum w_n a b` with the second derivative
/// `w_n = (2 m / v - 1 - dm/dv) / v^2` of the log-likelihood's score
/// `sum a (m - v) / v^2`, `m = min(x, CAP v) / (1 - e^-CAP)`, and the score
/// itself `sum a (m - v) / v^2`).
#[derive(Debug, Clone, Copy, Default)]
struct ArrowSums {
    faa: f64,
    fab: f64,
    fay: f64,
    haa: f64,
    hab: f64,
    g: f64,
}

impl ArrowSums {
    /// Adds a point of coefficients `a`, `b` (`b` 0 for the row of `s^2`
    /// itself, whose coefficient is passed as `a`).
    #[inline(always)]
    fn add(&mut self, a: f64, b: f64, w: f64, wn: f64, y: f64, g: f64) {
        let (wa, wna) = (w * a, wn * a);
        self.faa += wa * a;
        self.fab += wa * b;
        self.fay += wa * y;
        self.haa += wna * a;
        self.hab += wna * b;
        self.g += g * a;
    }

    /// Adds the sums of `other`.
    fn merge(&mut self, other: &ArrowSums) {
        self.faa += other.faa;
        self.fab += other.fab;
        self.fay += other.fay;
        self.haa += other.haa;
        self.hab += other.hab;
        self.g += other.g;
    }

    /// Solves the arrow system whose diagonal, border and right-hand side
    /// `pick` reads from the free channels' sums (`idx`) and those of
    /// `s^2` (`ss`: diagonal and right-hand side; its border is the
    /// channels'), with Jacobi scaling before the Cholesky factorisation.
    /// The solution and the diagonal of the inverse; `None` when the
    /// matrix is not positive definite.
    fn solve(
        idx: &[usize],
        sums: &[ArrowSums],
        ss: &ArrowSums,
        pick: impl Fn(&ArrowSums) -> (f64, f64, f64),
    ) -> Option<(Vec<f64>, Vec<f64>)> {
        let k = idx.len() + 1;
        let mut a = nalgebra::DMatrix::<f64>::zeros(k, k);
        let mut b = nalgebra::DVector::<f64>::zeros(k);
        for (j, &c) in idx.iter().enumerate() {
            let (aa, ab, ay) = pick(&sums[c]);
            a[(j, j)] = aa;
            a[(j, k - 1)] = ab;
            a[(k - 1, j)] = ab;
            b[j] = ay;
        }
        let (bb, _, by) = pick(ss);
        a[(k - 1, k - 1)] = bb;
        b[k - 1] = by;
        let d: Vec<f64> = (0..k)
            .map(|i| a[(i, i)].max(f64::MIN_POSITIVE).sqrt())
            .collect();
        let scaled = nalgebra::DMatrix::from_fn(k, k, |i, j| a[(i, j)] / (d[i] * d[j]));
        let chol = scaled.cholesky()?;
        let rhs = nalgebra::DVector::from_fn(k, |i, _| b[i] / d[i]);
        let sol = chol.solve(&rhs);
        let inv = chol.inverse();
        Some((
            (0..k).map(|i| sol[i] / d[i]).collect(),
            (0..k).map(|i| inv[(i, i)] / (d[i] * d[i])).collect(),
        ))
    }
}

/// One channel's sums of [`fit_variance_from`] at `f_c^2 = fc`, `s^2 = s2`:
/// those of its floor (zero when held) and its share of those of `s^2`.
///
/// Per point, with `v = a f_c^2 + b s^2` (at least `tiny a`), `r = x / v`,
/// `m / v = min(r, CAP) norm` and `dm/dv = CAP norm` where capped: the
/// scoring weight `w = 1 / v^2`, its pseudo-observation `y = m`, Newton's
/// weight `w_n = (2 m / v - 1 - dm/dv) w` and the score `(m - v) / v^2`.
fn channel_sums(
    pts: &[[f64; 3]],
    fc: f64,
    s2: f64,
    free: bool,
    norm: f64,
    tiny: f64,
) -> (ArrowSums, ArrowSums) {
    let (mut own, mut of_s) = (ArrowSums::default(), ArrowSums::default());
    let capped = CAP * norm;
    for &[a, b, x] in pts {
        let v0 = fc * a + s2 * b;
        let lo = tiny
            * if a > f64::MIN_POSITIVE {
                a
            } else {
                f64::MIN_POSITIVE
            };
        let v = if v0 > lo { v0 } else { lo };
        let iv = v.recip();
        let r = x * iv * norm;
        let (mv, dm) = if r < capped {
            (r, 0.0)
        } else {
            (capped, capped)
        };
        let w = iv * iv;
        let y = v * mv;
        let wn = (2.0 * mv - 1.0 - dm) * w;
        let g = (mv - 1.0) * iv;
        let known = if free {
            own.add(a, b, w, wn, y, g);
            0.0
        } else {
            fc * a
        };
        of_s.add(b, 0.0, w, wn, y - known, g);
    }
    (own, of_s)
}

/// The data's start of [`fit_variance_from`]: `s^2` from the upper half of
/// the responses (the median of `x / b` over `ln 2`, the median of an
/// `Exp(1)` variable), `f_c^2` from the lower quarter of each channel
/// (the median of `x / a` over `ln 2`), held floors as given.
fn start_from_points(
    points: &ChannelPoints,
    held: &[Option<f64>],
    scale_x: f64,
) -> (f64, Vec<f64>) {
    // (q2, channel, point)
    let mut by_q: Vec<(f64, usize, [f64; 3])> = points
        .0
        .iter()
        .enumerate()
        .flat_map(|(c, pts)| pts.iter().map(move |p| (c, *p)))
        .filter(|(_, [a, ..])| *a > 0.0)
        .map(|(c, p)| (p[1] / p[0], c, p))
        .collect();
    by_q.sort_by(|a, b| a.0.total_cmp(&b.0));
    let upper: Vec<f64> = by_q[by_q.len() / 2..]
        .iter()
        .filter(|(_, _, [_, b, _])| *b > 0.0)
        .map(|(_, _, [_, b, x])| x / b)
        .collect();
    let s2 = median(upper).unwrap_or(0.0) / core::f64::consts::LN_2;
    let f2 = (0..held.len())
        .map(|c| {
            if let Some(h) = held[c] {
                return h;
            }
            let ch: Vec<&[f64; 3]> = by_q
                .iter()
                .filter(|(_, pc, _)| *pc == c)
                .map(|(_, _, p)| p)
                .collect();
            let low: Vec<f64> = ch[..ch.len().div_ceil(4)]
                .iter()
                .map(|[a, _, x]| x / a)
                .collect();
            let m = median(low).unwrap_or(scale_x) / core::f64::consts::LN_2;
            m.max(1e-6 * scale_x)
        })
        .collect();
    (s2, f2)
}

fn median(mut v: Vec<f64>) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    let mid = v.len() / 2;
    let (_, m, _) = v.select_nth_unstable_by(mid, f64::total_cmp);
    Some(*m)
}

/// The noise model of `points` on `nq` channels: with `given_floor`, the
/// floor (m, every channel) is held and `s` fitted (source
/// [`NoiseSource::Given`]); otherwise every channel's floor is fitted and
/// kept where it is significant ([`FLOOR_SIGNIFICANCE`]), the others set to
/// 0 and the rest refitted (source [`NoiseSource::Estimated`]). `None` when
/// [`fit_variance`] fails.
pub fn noise_from_points(
    points: &[VariancePoint],
    nq: usize,
    given_floor: Option<f64>,
) -> Option<NoiseModel> {
    noise_from_points_near(points, nq, given_floor, None)
}

/// [`noise_from_points`] with the regressions started at `near` (the
/// previous estimate, when refining).
pub fn noise_from_points_near(
    points: &[VariancePoint],
    nq: usize,
    given_floor: Option<f64>,
    near: Option<&NoiseModel>,
) -> Option<NoiseModel> {
    noise_from_channels_near(&ChannelPoints::of(points, nq)?, given_floor, near)
}

/// [`noise_from_points_near`] on points by channel.
pub fn noise_from_channels_near(
    points: &ChannelPoints,
    given_floor: Option<f64>,
    near: Option<&NoiseModel>,
) -> Option<NoiseModel> {
    let nq = points.0.len();
    let start: Option<(Vec<f64>, f64)> = near.map(|m| {
        (
            m.floor_m.iter().map(|f| f * f).collect(),
            m.relative * m.relative,
        )
    });
    let start = start.as_ref().map(|(f, s)| (f.as_slice(), *s));
    let fit_variance =
        |p: &ChannelPoints, h: &[Option<f64>]| fit_variance_channels(p, h, start, true);
    if let Some(f) = given_floor {
        let fit = fit_variance(points, &vec![Some(f * f); nq])?;
        return Some(NoiseModel {
            floor_m: vec![f; nq],
            relative: fit.relative2.sqrt(),
            source: NoiseSource::Given,
        });
    }
    let first = fit_variance(points, &vec![None; nq])?;
    let held: Vec<Option<f64>> = first
        .floor_z
        .iter()
        .map(|z| (*z < FLOOR_SIGNIFICANCE).then_some(0.0))
        .collect();
    let fit = if held.iter().any(Option::is_some) {
        fit_variance(points, &held)?
    } else {
        first
    };
    Some(NoiseModel {
        floor_m: fit.floor2.iter().map(|f| f.sqrt()).collect(),
        relative: fit.relative2.sqrt(),
        source: NoiseSource::Estimated,
    })
}

/// The local-quadratic residuals of the module documentation as variance
/// points, at each window's centre sample, every channel (windows across a
/// repeated speed skipped).
///
/// With the smoother weights `l_i` of the window (`fit(centre) = sum l_i
/// y_i`) and `d_i = delta_(i,centre) - l_i`, the centre's residual
/// `e = sum_i d_i y_i` has `E|e|^2 = sum_i d_i^2 v_i`:
///
/// - in the response (`y = q`, `v_i = f^2 + s^2 |q_i|^2`):
///   `a = sum d_i^2 = 1 - h`, `b = sum d_i^2 |q_i|^2`;
/// - in the inverse response (`y = 1 / q`, `v_i ~ (f^2 + s^2 |q_i|^2) /
///   |q_i|^4` to first order): `a = sum d_i^2 / |q_i|^4`,
///   `b = sum d_i^2 / |q_i|^2`.
///
/// Near a resonance the inverse response of a mode is a quadratic in
/// `Omega` (`(k - m Omega^2 + j c Omega) / F`), while the response itself
/// changes faster than any local quadratic on a practical speed grid: a
/// window is read in the inverse response where its centre response is
/// well above the floor (`|q| > INVERSE_ABOVE_FLOOR f_c`, `floor[c]`),
/// where the inverse is accurate, and in the response elsewhere (`floor`
/// empty: the response everywhere). `|q_i|` are the measured magnitudes.
pub fn local_points(samples: &[Sample], floor: &[f64]) -> Vec<VariancePoint> {
    let Some(nq) = samples.first().map(|s| s.q.len()) else {
        return Vec::new();
    };
    let half = WINDOW / 2;
    let mut out = Vec::with_capacity(samples.len() * nq);
    for_each_window(samples, |idx, coef_of, h| {
        if h >= 1.0 {
            return;
        }
        let d: Vec<f64> = coef_of
            .iter()
            .enumerate()
            .map(|(i, l)| if i == half { 1.0 - l } else { -l })
            .collect();
        for c in 0..nq {
            let fit: num_complex::Complex64 = idx
                .iter()
                .zip(coef_of)
                .map(|(&i, &l)| samples[i].q[c] * l)
                .sum();
            let f = floor.get(c).copied().unwrap_or(0.0);
            let inverse = f > 0.0 && fit.norm() > INVERSE_ABOVE_FLOOR * f;
            let q2: Vec<f64> = idx.iter().map(|&i| samples[i].q[c].norm_sqr()).collect();
            let p = if inverse && q2.iter().all(|v| *v > 0.0) {
                let e: num_complex::Complex64 = idx
                    .iter()
                    .zip(&d)
                    .map(|(&i, &di)| samples[i].q[c].inv() * di)
                    .sum();
                VariancePoint {
                    channel: c,
                    x: e.norm_sqr(),
                    a: d.iter().zip(&q2).map(|(di, v)| di * di / (v * v)).sum(),
                    b: d.iter().zip(&q2).map(|(di, v)| di * di / v).sum(),
                }
            } else {
                let e = samples[idx[half]].q[c] - fit;
                VariancePoint {
                    channel: c,
                    x: e.norm_sqr(),
                    a: 1.0 - h,
                    b: d.iter().zip(&q2).map(|(di, v)| di * di * v).sum(),
                }
            };
            if p.x.is_finite() && p.a.is_finite() && p.b.is_finite() {
                out.push(p);
            }
        }
    });
    out
}

/// A window is read in the inverse response where its centre response
/// exceeds the floor by this factor ([`local_points`]).
pub const INVERSE_ABOVE_FLOOR: f64 = 10.0;

/// The noise model of `samples` estimated without the rotor model: the
/// points of [`local_points`] through [`noise_from_points`]. Where no
/// channel shows a significant floor the model is the proportional one with
/// `s` from [`relative_noise_level`] (exactly the estimate of SPEC section
/// 4's data). `None` as for [`relative_noise_level`].
pub fn estimate_noise(samples: &[Sample], given_floor: Option<f64>) -> Option<NoiseModel> {
    let nq = samples.first()?.q.len();
    let points = local_points(samples, &[]);
    if points.is_empty() {
        return None;
    }
    let first = noise_from_points(&points, nq, given_floor);
    match first {
        // A floor: the windows far above it again, in the inverse response.
        Some(n) if n.has_floor() => {
            let points = local_points(samples, &n.floor_m);
            Some(noise_from_points(&points, nq, given_floor).unwrap_or(n))
        }
        Some(n) if n.source == NoiseSource::Given => Some(NoiseModel {
            relative: relative_noise_level(samples)?,
            ..n
        }),
        _ => Some(NoiseModel::proportional(
            nq,
            relative_noise_level(samples)?,
            NoiseSource::Estimated,
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use num_complex::Complex64;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, StandardNormal};

    #[test]
    fn recovers_the_noise_of_a_smooth_response() {
        for s in [1e-3, 1e-2] {
            let mut rng = ChaCha8Rng::seed_from_u64(7);
            let samples: Vec<Sample> = (1..=3000)
                .map(|i| {
                    let w = i as f64 * 0.5;
                    // A resonance-like response (smooth at this density).
                    let q0 = Complex64::new(w * w, 0.0) / Complex64::new(1e6 - w * w, 2e3 * w);
                    let q: Vec<Complex64> = (0..4)
                        .map(|c| {
                            let qt = q0 * (1.0 + 0.3 * c as f64);
                            let n1: f64 = StandardNormal.sample(&mut rng);
                            let n2: f64 = StandardNormal.sample(&mut rng);
                            qt + Complex64::new(n1, n2) * (s * qt.norm() / 2f64.sqrt())
                        })
                        .collect();
                    Sample { omega: w, q }
                })
                .collect();
            let est = relative_noise_level(&samples).unwrap();
            assert!((est / s - 1.0).abs() < 0.05, "{s}: {est}");
        }
        assert!(relative_noise_level(&[]).is_none());
    }

    /// A resonance-like sweep on 4 channels with noise `f eps1 + s |q| eps2`.
    fn composite(f: f64, s: f64, seed: u64, n: usize) -> Vec<Sample> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        (1..=n)
            .map(|i| {
                let w = i as f64 * 1500.0 / n as f64;
                // From 0.25 nm at the low end to 0.5 mm at resonance.
                let q0 = Complex64::new(w * w, 0.0) / Complex64::new(1e6 - w * w, 2e3 * w) * 1e-3;
                let q: Vec<Complex64> = (0..4)
                    .map(|c| {
                        let qt = q0 * (1.0 + 0.3 * c as f64);
                        let mut g = || {
                            let n1: f64 = StandardNormal.sample(&mut rng);
                            let n2: f64 = StandardNormal.sample(&mut rng);
                            Complex64::new(n1, n2) / 2f64.sqrt()
                        };
                        let (e1, e2) = (g(), g());
                        qt + e1 * (s * qt.norm()) + e2 * f
                    })
                    .collect();
                Sample { omega: w, q }
            })
            .collect()
    }

    #[test]
    fn separates_the_floor_from_the_relative_part() {
        for (f, s) in [(5e-7, 5e-3), (1e-7, 5e-3), (2e-6, 1e-2)] {
            let samples = composite(f, s, 3, 3000);
            let m = estimate_noise(&samples, None).unwrap();
            assert_eq!(m.source, NoiseSource::Estimated);
            for fc in &m.floor_m {
                assert!((fc / f - 1.0).abs() < 0.1, "{f} {s}: floor {fc}");
            }
            assert!(
                (m.relative / s - 1.0).abs() < 0.1,
                "{f} {s}: {}",
                m.relative
            );
            // Given: the floor held, s fitted.
            let g = estimate_noise(&samples, Some(f)).unwrap();
            assert_eq!(g.source, NoiseSource::Given);
            assert_eq!(g.floor_m, vec![f; 4]);
            assert!((g.relative / s - 1.0).abs() < 0.1, "{}", g.relative);
        }
    }

    /// The score `sum u (m - v) / v^2` of the points at `f2`, `s2` (per
    /// free floor, then `s^2`), each relative to the sum of its terms'
    /// magnitudes: written out from the likelihood, not from the sums of
    /// the iteration.
    fn relative_score(points: &ChannelPoints, f2: &[f64], s2: f64) -> Vec<f64> {
        let norm = 1.0 / (1.0 - (-CAP).exp());
        let mut out = Vec::new();
        let mut gs = (0.0, 0.0);
        for (c, pts) in points.0.iter().enumerate() {
            let mut g = (0.0, 0.0);
            for &[a, b, x] in pts {
                let v = a * f2[c] + b * s2;
                let t = ((x.min(CAP * v) * norm) - v) / (v * v);
                g = (g.0 + a * t, g.1 + (a * t).abs());
                gs = (gs.0 + b * t, gs.1 + (b * t).abs());
            }
            out.push(g.0 / g.1);
        }
        out.push(gs.0 / gs.1);
        out
    }

    #[test]
    fn newton_steps_reach_the_scoring_root() {
        for (f, s, seed) in [(5e-7, 5e-3, 11), (2e-6, 1e-2, 12), (1e-7, 5e-3, 13)] {
            let samples = composite(f, s, seed, 3000);
            let floor = vec![f; 4];
            let points = ChannelPoints::of(&local_points(&samples, &floor), 4).unwrap();
            let free = vec![None; 4];
            let scoring = fit_variance_channels(&points, &free, None, false).unwrap();
            // From the previous estimate (here the root moved by 5 %):
            // Newton's steps, and the scoring steps alone.
            let f0: Vec<f64> = scoring.floor2.iter().map(|v| v * 1.05).collect();
            let start = Some((f0.as_slice(), scoring.relative2 * 0.95));
            let newton = fit_variance_channels(&points, &free, start, true).unwrap();
            let slow = fit_variance_channels(&points, &free, start, false).unwrap();
            for fit in [&newton, &slow] {
                for (a, b) in fit.floor2.iter().zip(&scoring.floor2) {
                    assert!((a / b - 1.0).abs() < 1e-7, "{f} {s}: {a} {b}");
                }
                assert!((fit.relative2 / scoring.relative2 - 1.0).abs() < 1e-7);
                // (Read at the iterate before the last step.)
                for (a, b) in fit.floor_z.iter().zip(&scoring.floor_z) {
                    assert!((a / b - 1.0).abs() < 1e-4, "{a} {b}");
                }
            }
            // The root: every score equation zero to rounding.
            for g in relative_score(&points, &newton.floor2, newton.relative2) {
                assert!(g.abs() < 1e-6, "{f} {s}: score {g}");
            }
        }
    }

    #[test]
    fn proportional_data_show_no_floor() {
        let samples = composite(0.0, 5e-3, 4, 3000);
        let m = estimate_noise(&samples, None).unwrap();
        assert!(!m.has_floor(), "{m:?}");
        assert_eq!(m.relative, relative_noise_level(&samples).unwrap());
    }
}
