//! The output-error (maximum-likelihood) fit: the parameters whose
//! predicted bearing responses ([`Predictor`]) best match the measured
//! ones, weighted by the noise model.
//!
//! # Objective
//!
//! The measurement file's noise model gives each complex sample the
//! variance `s^2 |q|^2` (proportional noise). With weights
//! `w_(n,c) = max(|q^_(n,c)|, f_c)` from the prediction `q^` (a floor
//! `f_c = floor x RMS_n |q_meas,(n,c)|` guards vanishing responses) the fit
//! minimises
//!
//! ```text
//!     S(theta) = sum_(n,c) |q_meas,(n,c) - q_(n,c)(theta)|^2 / w_(n,c)^2 ,
//! ```
//!
//! the negative log-likelihood up to constants for known weights; the
//! weights are refreshed from the new prediction and the fit repeated
//! (iteratively reweighted least squares). `s` is not needed for the
//! estimate; it is estimated afterwards.
//!
//! # Start: prefiltered refined instrumental variables
//!
//! A Gauss-Newton or Levenberg-Marquardt iteration started from the
//! equation-error (QRD/RLS) estimate can stall in a local minimum when that
//! estimate is biased (errors in variables). Before the polish, a few
//! linear passes make the start consistent (Young's refined instrumental
//! variables): at `theta_prev`, the equation error filtered by the
//! prediction's own dynamics,
//!
//! ```text
//!     r(theta) = H(theta_prev)^-1 (H(theta) q_meas - B a(theta)) / w,
//! ```
//!
//! is linear in `theta` and equals the weighted output error at
//! `theta = theta_prev`. Its regressor `X` contains the noisy `q_meas`; the
//! instruments `Z` are the same columns built from the noise-free
//! prediction `q^` (the Jacobian of the output error), so
//! `Re(Z^H X) theta = -Re(Z^H y_0)` has no errors-in-variables bias.
//!
//! # Polish: Levenberg-Marquardt
//!
//! On the scaled parameters, with the normal equations accumulated block
//! by block of speeds (`P x P`, `P` = 22 for the paper rotor; a QR of the full
//! `4 N_s N_b x P` Jacobian would cost more for nothing here), Marquardt's
//! diagonal scaling and Nielsen's damping update. A well-kept
//! implementation, the `levenberg-marquardt` crate (a MINPACK port), builds
//! on nalgebra 0.34 while rotorid uses 0.35, and it factors the full
//! Jacobian at every step; the iteration here is short and checked against
//! the known optimum in the tests. It stops when the next step would move
//! the estimate by less than a thousandth of its standard deviation.
//!
//! # Probe noise: refinement without predictions
//!
//! Under the probe noise model (`E|e|^2 = f_c^2 + s^2 |q|^2`, SPEC
//! section 7) the weights depend on the variance parameters, which are
//! refitted from the residuals between polishes. The passes keep their weighted rows
//! `[X y]`: the leverages of the residuals are a product of them with
//! `L^-T` (`N = L L^T`), and the normal equations under the new weights
//! at the same `theta` a product of the rows rescaled by `w / w_new`, so a
//! refinement costs no prediction. Near the optimum (within 0.1 standard
//! deviations) the polish moves the rows to first order instead of
//! predicting again (`y - X delta`, `linear_step`); the leverages are
//! computed row by row only in the blocks whose mean leverage, from their
//! kept share of the normal equations, is above 1e-3; and a
//! refinement that settles with the previous leverages keeps them and the
//! weights at hand.
//!
//! # Uncertainty
//!
//! The real and imaginary parts of `(q_meas - q) / w` each have variance
//! `s^2 / 2`, so the Fisher information of `theta` is
//! `F = (2 / s^2) Re(J^H J)` with `J = (dq/dtheta) / w`, and the
//! covariance of the estimate `F^-1` ([`OutputErrorFit::covariance`], with
//! `s` estimated from the residuals: `s^2 = S / (N - P / 2)`, `N` complex
//! samples).

use nalgebra::{DMatrix, DMatrixView, DVector};
use num_complex::Complex64;
use thiserror::Error;

use crate::estimate::noise::{
    noise_from_channels_near, ChannelPoints, NoiseModel, NoiseSource, VariancePoint,
};
use crate::estimate::predictor::{Entry, PredictError, Predictor, Solve, Terms};
use crate::io::measurement::Sample;

/// Options of the output-error fit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OutputErrorOptions {
    /// Refined-instrumental-variable passes before the polish.
    pub iv_passes: usize,
    /// Reweightings (each followed by a Levenberg-Marquardt polish).
    pub reweightings: usize,
    /// Levenberg-Marquardt iterations per polish, at most.
    pub max_iterations: usize,
    /// Convergence: relative change of `S` and scaled step size.
    pub tolerance: f64,
    /// Weight floor relative to each channel's RMS measured response.
    pub floor: f64,
}

impl Default for OutputErrorOptions {
    fn default() -> Self {
        OutputErrorOptions {
            iv_passes: 2,
            reweightings: 2,
            max_iterations: 50,
            tolerance: 1e-10,
            floor: 1e-6,
        }
    }
}

/// A weighted misfit `S / N` below this (relative RMS misfit 1e-10) is a
/// fit to round-off: no pass or step can improve it.
const PERFECT: f64 = 1e-20;

/// The fit could not be done.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum OutputErrorError {
    /// Samples and terms differ in number, or a sample has the wrong
    /// number of channels.
    #[error("output-error fit: samples and model terms do not match")]
    Dimension,
    /// Fewer real equations than parameters.
    #[error("output-error fit: {equations} real equations for {params} parameters")]
    TooFewEquations {
        /// Real equations (2 per complex sample).
        equations: usize,
        /// Parameters.
        params: usize,
    },
    /// The start is not usable (prediction fails there).
    #[error("output-error fit: {0}")]
    Predict(#[from] PredictError),
    /// The normal equations are singular: the data do not determine the
    /// parameters.
    #[error(
        "output-error fit: the data do not determine the parameters (singular normal equations)"
    )]
    Singular,
}

/// The result of the output-error fit.
#[derive(Debug, Clone, PartialEq)]
pub struct OutputErrorFit {
    /// Real parameters (scaled, see [`Predictor`]).
    pub theta: Vec<f64>,
    /// The same as scaled weights `w~` of the parametrization.
    pub weights: Vec<Complex64>,
    /// Covariance of `theta` (`s^2 / 2 Re(J^H J)^-1`, `s` from the residuals).
    pub covariance: DMatrix<f64>,
    /// Relative RMS misfit `sqrt(S / N)`, `N` complex samples: the noise
    /// level when the model fits.
    pub residual: f64,
    /// `s` estimated from the residuals, `sqrt(S / (N - P/2))`.
    pub residual_noise: f64,
    /// Levenberg-Marquardt iterations in all.
    pub iterations: usize,
    /// Whether the last polish met the tolerance.
    pub converged: bool,
    /// The noise model at the end of the fit (refined when asked), when the
    /// fit was given one.
    pub noise: Option<NoiseModel>,
    /// The samples excluded as outliers, by sample and channel.
    pub outliers: Vec<Outlier>,
    /// More samples than [`MAX_OUTLIER_FRACTION`] lay beyond the outlier
    /// limit: the largest were excluded, the others kept.
    pub outliers_capped: bool,
    /// The fitted runout phasor per channel (m), when asked for.
    pub runout: Vec<Complex64>,
    /// Its standard deviation per channel, `sqrt(E|dr|^2)` (m).
    pub runout_std: Vec<f64>,
    /// The misfit against [`FitNoise::reference`]: `S_ref / dof / s_ref^2`,
    /// 1 when the model describes the data within that noise.
    pub chi2_per_dof: Option<f64>,
}

/// Accumulated normal equations of one pass at fixed weights.
#[derive(Clone)]
struct Pass {
    /// `Re(J^H J)`.
    normal: DMatrix<f64>,
    /// `Re(J^H r)`.
    gradient: DVector<f64>,
    /// `S`.
    cost: f64,
    /// `|q_meas - q|` of every sample at `n * nq + c` (m).
    error: Vec<f64>,
    /// `|q|`, the predicted reading, at `n * nq + c` (m).
    read: Vec<f64>,
    /// The weighted rows `[X y]` when the data keep them
    /// ([`Data::keep_rows`]), in order of samples.
    rows: Vec<Block>,
}

/// The weighted rows of a block of speeds: the dense columns `[X_m y]`,
/// `k x (nm + 1)`, column-major (real rows `2 i` and `2 i + 1` of the
/// block's sample `i`), and, when a runout is fitted, its columns in
/// sparse form ([`Rows`]): real row `r` has its one value `d_r` in the
/// column `nm + (r mod 2 nq)` (the real rows of a speed's sample of channel
/// `c` are `2 c` and `2 c + 1`, those of `Re r_c` and `Im r_c`).
#[derive(Clone)]
struct Block {
    k: usize,
    /// Dense columns of `X` (the model's; all of them where `d` is empty).
    nm: usize,
    x: Vec<f64>,
    /// The runout columns' value per real row (`k`), or empty.
    d: Vec<f64>,
    /// The block's own share of the normal equations, `X_b^T X_b`
    /// (`na x na`, column-major): with `N^-1` it gives the sum of the
    /// block's leverages, `tr(N^-1 X_b^T X_b)` ([`leverages`]).
    gram: Vec<f64>,
}

impl Block {
    /// Runout parameters (`2 nq`, or 0).
    fn nr(&self, na: usize) -> usize {
        if self.d.is_empty() {
            0
        } else {
            na - self.nm
        }
    }

    /// The rows `[X y]` with the runout's columns written out (`k x (na +
    /// 1)`).
    #[cfg(test)]
    fn dense(&self, na: usize) -> DMatrix<f64> {
        let (k, nm, nr) = (self.k, self.nm, self.nr(na));
        let x = DMatrixView::from_slice(&self.x, k, nm + 1);
        let mut out = DMatrix::zeros(k, na + 1);
        out.columns_mut(0, nm).copy_from(&x.columns(0, nm));
        out.column_mut(na).copy_from(&x.column(nm));
        for (r, dr) in self.d.iter().enumerate() {
            out[(r, nm + r % nr)] = *dr;
        }
        out
    }
}

/// The parameters' entries at every sample's speed.
fn speed_entries(pr: &Predictor, samples: &[Sample]) -> Vec<Vec<Entry>> {
    samples.iter().map(|s| pr.entries(s.omega)).collect()
}

/// How each complex sample `(n, c)` is weighted: `w_(n,c)` in the
/// relative units of the fit (`sigma_(n,c) / s`, see [`NoiseModel`]).
///
/// - proportional noise (SPEC section 4): `w = max(|q^|, floor_c)` with
///   `floor_c` a tiny fraction of the channel's RMS reading, which only
///   guards vanishing responses;
/// - probe noise with a floor (SPEC section 7): `w = sqrt(phi_c^2 + |q^|^2)`
///   with `phi_c = f_c / s` ([`NoiseModel::relative_floor`]);
/// - per-sample standard deviations (the file's `_std` columns): fixed;
/// - an excluded sample (an outlier): `w = inf`, so it adds nothing.
#[derive(Debug, Clone, PartialEq)]
pub struct Weighting {
    /// Per-channel guard floors of the proportional model (m).
    tiny: Vec<f64>,
    /// `phi_c` per channel (m); empty: proportional.
    phi: Vec<f64>,
    /// Fixed weights at `n * nq + c`, when given.
    fixed: Option<Vec<f64>>,
    /// Excluded samples at `n * nq + c`; empty: none.
    excluded: Vec<bool>,
}

impl Weighting {
    /// The proportional weighting of `samples` with guard floors `floor`
    /// times each channel's RMS reading (the weighting of SPEC section 4's
    /// noise).
    pub fn proportional(samples: &[Sample], floor: f64) -> Self {
        Weighting {
            tiny: floors(samples, floor),
            phi: Vec::new(),
            fixed: None,
            excluded: Vec::new(),
        }
    }

    /// The weighting of `noise` on `samples` (guard floors as
    /// [`Weighting::proportional`]).
    pub fn of_noise(samples: &[Sample], floor: f64, noise: &NoiseModel) -> Self {
        let mut w = Self::proportional(samples, floor);
        w.set_noise(noise);
        w
    }

    /// Fixed weights `std_(n,c)` (m) at `n * nq + c`: the noise model of
    /// per-sample standard deviations.
    pub fn fixed(samples: &[Sample], floor: f64, std: Vec<f64>) -> Self {
        let mut w = Self::proportional(samples, floor);
        w.fixed = Some(std);
        w
    }

    fn set_noise(&mut self, noise: &NoiseModel) {
        self.phi = if noise.has_floor() {
            noise.relative_floor()
        } else {
            Vec::new()
        };
    }

    /// The weight of sample `idx = n * nq + c` (channel `c`) whose
    /// predicted reading is `q`.
    fn weight(&self, idx: usize, c: usize, q: Complex64) -> f64 {
        if self.excluded.get(idx).copied().unwrap_or(false) {
            return f64::INFINITY;
        }
        if let Some(f) = &self.fixed {
            return f.get(idx).copied().unwrap_or(f64::INFINITY);
        }
        match self.phi.get(c) {
            // `sqrt(phi^2 + |q|^2)`: readings and floors are far from
            // overflow and underflow, no `hypot` needed.
            Some(&p) if p > 0.0 => (p * p + q.norm_sqr()).sqrt(),
            _ => q
                .norm()
                .max(self.tiny.get(c).copied().unwrap_or(f64::MIN_POSITIVE)),
        }
    }

    /// Whether sample `idx` is excluded.
    fn is_excluded(&self, idx: usize) -> bool {
        self.excluded.get(idx).copied().unwrap_or(false)
    }

    /// Complex samples that count.
    fn count(&self, n: usize) -> usize {
        n - self.excluded.iter().filter(|x| **x).count()
    }
}

/// What every pass reads: the model, the samples, their terms and the
/// parameters' entries at their speeds, the weighting and whether a
/// runout phasor per channel is fitted (its parameters follow the model's,
/// `Re`, `Im` per channel, in units of `runout_scale`).
struct Data<'a> {
    pr: &'a Predictor,
    samples: &'a [Sample],
    terms: &'a [Terms],
    entries: Vec<Vec<Entry>>,
    weighting: Weighting,
    runout_scale: Vec<f64>,
    /// Passes with the Jacobian keep their weighted rows (for the
    /// leverages and a reweighting without predictions).
    keep_rows: bool,
    /// The instrumental-variable passes solve for the runout too (else
    /// they hold it).
    iv_runout: bool,
    /// The runout's columns kept sparse ([`Rows`]; the dense form is the
    /// reference in the tests).
    sparse_runout: bool,
}

impl<'a> Data<'a> {
    #[cfg(test)]
    fn new(pr: &'a Predictor, samples: &'a [Sample], terms: &'a [Terms], floor: f64) -> Self {
        Self::weighted(pr, samples, terms, Weighting::proportional(samples, floor))
    }

    fn weighted(
        pr: &'a Predictor,
        samples: &'a [Sample],
        terms: &'a [Terms],
        weighting: Weighting,
    ) -> Self {
        Data {
            pr,
            samples,
            terms,
            entries: speed_entries(pr, samples),
            weighting,
            runout_scale: Vec::new(),
            keep_rows: false,
            iv_runout: true,
            sparse_runout: true,
        }
    }

    /// Parameters in all: the model's and the runout's.
    fn n_all(&self) -> usize {
        self.pr.n_params() + 2 * self.runout_scale.len()
    }

    /// The runout phasors (m) in `theta` (all parameters).
    fn runout(&self, theta: &[f64]) -> Vec<Complex64> {
        let np = self.pr.n_params();
        self.runout_scale
            .iter()
            .enumerate()
            .map(|(c, sc)| {
                let re = theta.get(np + 2 * c).copied().unwrap_or(0.0);
                let im = theta.get(np + 2 * c + 1).copied().unwrap_or(0.0);
                Complex64::new(re, im) * *sc
            })
            .collect()
    }

    /// [`pass`] with weights from this pass's own prediction.
    fn reweighted(&self, theta: &[f64], jacobian: bool) -> Result<(Pass, Vec<f64>), PredictError> {
        self.pass(WeightsFrom::Prediction, theta, jacobian)
    }

    fn pass(
        &self,
        weights: WeightsFrom<'_>,
        theta: &[f64],
        jacobian: bool,
    ) -> Result<(Pass, Vec<f64>), PredictError> {
        pass(self, weights, theta, jacobian)
    }

    /// The rows of a pass over `unknowns` parameters (the model's, then
    /// the runout's if any), with instruments or not.
    fn rows(&self, unknowns: usize, instruments: bool) -> Rows {
        let pr = self.pr;
        let (np, nq, npl) = (
            pr.n_params(),
            2 * pr.param.n_bearings(),
            pr.param.n_planes(),
        );
        let nr = unknowns.saturating_sub(np);
        if self.sparse_runout && nr > 0 {
            Rows::new(nq, npl, np, nr, instruments)
        } else {
            Rows::new(nq, npl, unknowns, 0, instruments)
        }
    }

    /// Complex samples that count (not excluded).
    fn n_counted(&self) -> usize {
        let nq = self.samples.first().map_or(0, |s| s.q.len());
        self.weighting.count(self.samples.len() * nq)
    }
}

/// Per-channel weight floors.
fn floors(samples: &[Sample], floor: f64) -> Vec<f64> {
    let nq = samples.first().map_or(0, |s| s.q.len());
    (0..nq)
        .map(|c| {
            let ms = samples.iter().map(|s| s.q[c].norm_sqr()).sum::<f64>() / samples.len() as f64;
            (floor * ms.sqrt()).max(f64::MIN_POSITIVE)
        })
        .collect()
}

/// Where the weights of a pass come from.
enum WeightsFrom<'a> {
    /// Fixed (within a Levenberg-Marquardt polish): `w_(n,c)` at
    /// `n * nq + c`.
    Given(&'a [f64]),
    /// This pass's own prediction, by the data's [`Weighting`] (a
    /// reweighting).
    Prediction,
}

/// Speeds per block of [`Rows`]: one matrix product per block.
const BLOCK: usize = 64;

/// The real rows of the weighted Jacobian `X` (and of the instruments `Z`
/// of an instrumental-variable pass) for a block of speeds, and the
/// accumulated product `Z^T [X y]` (`Z = X` without instruments).
///
/// At a speed with `D = diag(1/w)`, `L = D H^-1` and `Y = [L, L B]`
/// (`nq x (nq + N_p)`), the weighted column of parameter `i` is
/// `Y e_(idx_i) g_i` with `g_i` the scalar of its sparse column of `G`:
/// `-dz q_col` in row `idx_i = row` for a bearing parameter, `da` in
/// `B`'s column `idx_i = nq + plane` for an unbalance parameter (the
/// module documentation of [`crate::estimate::predictor`]). Each complex
/// entry gives two real rows, its real and its imaginary part, so that
/// `Re(Z^H X) = Z^T X` over the real rows; the rows of [`BLOCK`] speeds
/// are multiplied at once (a dense matrix product, vectorised; the
/// columns padded with zeros to a multiple of [`PAD`] so that its kernels
/// run on whole tiles).
///
/// A runout's columns `R` (`nr = 2 nq`, after the model's `nm`) have one
/// entry per sample: `d = scale_c / w` in the real row of `Re r_c`'s
/// column and in the imaginary row of `Im r_c`'s. With `nr > 0` they are
/// kept in that form and their products taken row by row, `O(k na)` per
/// block instead of widening the dense product by `nr` columns:
///
/// ```text
///     Z^T [X y] = [ Z_m^T X_m   Z_m^T R   Z_m^T y ]
///                 [ R^T X_m     R^T R     R^T y   ]
/// ```
///
/// with `R^T R` diagonal and `Z_m^T R = (R^T Z_m)^T` ([`assemble`]).
struct Rows {
    nq: usize,
    npl: usize,
    /// Dense columns of `X` (the model's, or all of them).
    np: usize,
    /// Sparse runout columns (0 or `2 nq`).
    nr: usize,
    /// Columns of `Z` and of `[X y]` with the padding.
    lw: usize,
    rw: usize,
    /// Real rows per block.
    cap: usize,
    /// Real rows filled.
    filled: usize,
    /// `[X y]`, column-major `cap x rw`.
    x: Vec<f64>,
    /// `Z`, column-major `cap x lw`; empty when `Z` is `X`.
    z: Vec<f64>,
    /// `Y` at the current speed, column-major.
    y: Vec<Complex64>,
    /// `Z^T [X y]`, `lw x rw` (the first `np x (np + 1)` wanted).
    out: DMatrix<f64>,
    /// The blocks of `[X y]` kept, if asked for.
    store: Option<Vec<Block>>,
    /// The runout columns' value per real row of the block (`cap`).
    d: Vec<f64>,
    /// `R^T [X_m y]` (`nr x (np + 1)`), `R^T Z_m` (`nr x np`, with
    /// instruments) and the diagonal of `R^T R` over every speed.
    rx: DMatrix<f64>,
    rz: DMatrix<f64>,
    rd: Vec<f64>,
}

/// Multiple to which [`Rows`] pads its columns (the tile of the widest
/// kernel of `matrixmultiply`, 8 x 8 with AVX-512).
const PAD: usize = 8;

impl Rows {
    fn new(nq: usize, npl: usize, np: usize, nr: usize, instruments: bool) -> Self {
        let cap = 2 * nq * BLOCK;
        let (lw, rw) = (np.div_ceil(PAD) * PAD, (np + 1).div_ceil(PAD) * PAD);
        Rows {
            nq,
            npl,
            np,
            lw,
            rw,
            cap,
            filled: 0,
            x: vec![0.0; cap * rw],
            z: if instruments {
                vec![0.0; cap * lw]
            } else {
                Vec::new()
            },
            y: vec![Complex64::new(0.0, 0.0); nq * (nq + npl)],
            out: DMatrix::zeros(lw, rw),
            store: None,
            nr,
            d: vec![0.0; if nr > 0 { cap } else { 0 }],
            rx: DMatrix::zeros(nr, np + 1),
            rz: DMatrix::zeros(if instruments { nr } else { 0 }, np),
            rd: vec![0.0; nr],
        }
    }

    /// `Y = [D H^-1, D H^-1 B]` from `H^-1` and `B` (column-major) and
    /// the weights `w`.
    fn set_speed(&mut self, h_inv: &[Complex64], b: &[Complex64], w: &[f64]) {
        let nq = self.nq;
        let (l, lb) = self.y.split_at_mut(nq * nq);
        for (lc, hc) in l.chunks_exact_mut(nq).zip(h_inv.chunks_exact(nq)) {
            for ((o, h), wc) in lc.iter_mut().zip(hc).zip(w) {
                *o = h / wc;
            }
        }
        for (lbk, bk) in lb.chunks_exact_mut(nq).zip(b.chunks_exact(nq)) {
            lbk.fill(Complex64::new(0.0, 0.0));
            for (lj, bjk) in l.chunks_exact(nq).zip(bk) {
                for (o, ljc) in lbk.iter_mut().zip(lj) {
                    *o += ljc * bjk;
                }
            }
        }
    }

    /// The weighted columns of every parameter at this speed, with `q`
    /// multiplying the bearing terms, into `Z` (`instruments`) or `X`.
    fn columns(&mut self, instruments: bool, entries: &[Entry], q: &[Complex64]) {
        let (nq, cap, row0) = (self.nq, self.cap, self.filled);
        let buf = if instruments {
            &mut self.z
        } else {
            &mut self.x
        };
        for (i, en) in entries.iter().enumerate() {
            let (k, g) = match *en {
                Entry::Bearing { row, col, dz } => (row, -(dz * q[col])),
                Entry::Unbalance { plane, da } => (nq + plane, da),
            };
            let yk = &self.y[k * nq..(k + 1) * nq];
            let out = &mut buf[i * cap + row0..i * cap + row0 + 2 * nq];
            for (o, yr) in out.chunks_exact_mut(2).zip(yk) {
                let v = yr * g;
                o[0] = v.re;
                o[1] = v.im;
            }
        }
    }

    /// The weighted columns of the runout parameters (from column `np0`,
    /// `Re`, `Im` per channel, scaled by `scale`): `d(reading_c) / d Re r_c
    /// = scale_c`, `/ d Im r_c = j scale_c`, each over `w_c`.
    fn runout_columns(&mut self, np0: usize, scale: &[f64], w: &[f64]) {
        let (cap, row0, nq) = (self.cap, self.filled, self.nq);
        if self.nr > 0 {
            for (c, sc) in scale.iter().enumerate() {
                self.d[row0 + 2 * c] = sc / w[c];
                self.d[row0 + 2 * c + 1] = sc / w[c];
            }
            return;
        }
        let with_z = !self.z.is_empty();
        for (c, sc) in scale.iter().enumerate() {
            for part in 0..2 {
                let i = np0 + 2 * c + part;
                let out = &mut self.x[i * cap + row0..i * cap + row0 + 2 * nq];
                out.fill(0.0);
                out[2 * c + part] = sc / w[c];
                // Their instruments are the same columns: the readings are
                // linear in the runout.
                if with_z {
                    let z = &mut self.z[i * cap + row0..i * cap + row0 + 2 * nq];
                    z.fill(0.0);
                    z[2 * c + part] = sc / w[c];
                }
            }
        }
    }

    /// The extra column `y` of `[X y]` at this speed.
    fn extra(&mut self, v: &[Complex64]) {
        let at = self.np * self.cap + self.filled;
        for (o, z) in self.x[at..at + 2 * self.nq].chunks_exact_mut(2).zip(v) {
            o[0] = z.re;
            o[1] = z.im;
        }
    }

    /// Next speed (multiplies a full block out).
    fn advance(&mut self) {
        self.filled += 2 * self.nq;
        if self.filled == self.cap {
            self.flush();
        }
    }

    fn flush(&mut self) {
        let (k, cap, np, nr) = (self.filled, self.cap, self.np, self.nr);
        if k == 0 {
            return;
        }
        // The runout's share, row by row.
        let mut bx = DMatrix::<f64>::zeros(nr, np + 1);
        let mut bd = vec![0.0; nr];
        let d = &self.d[..if nr > 0 { k } else { 0 }];
        if nr > 0 {
            add_runout_products(&self.x, cap, k, np + 1, d, &mut bx);
            if !self.z.is_empty() {
                add_runout_products(&self.z, cap, k, np, d, &mut self.rz);
            }
            add_runout_diag(d, &mut bd);
            self.rx += &bx;
            for (o, v) in self.rd.iter_mut().zip(&bd) {
                *o += v;
            }
        }
        // Without instruments the first lw columns of [X y] (X, then y or
        // padding) stand for Z; the rows of out past np are not read.
        let left = if self.z.is_empty() { &self.x } else { &self.z };
        let zt = DMatrixView::from_slice_with_strides(left, self.lw, k, cap, 1);
        let xy = DMatrixView::from_slice_with_strides(&self.x, k, self.rw, 1, cap);
        match self.store.as_mut() {
            None => self.out.gemm(1.0, &zt, &xy, 1.0),
            Some(store) => {
                // The block's product on its own (kept with its rows),
                // then added.
                let mut part = DMatrix::<f64>::zeros(self.lw, self.rw);
                part.gemm(1.0, &zt, &xy, 0.0);
                self.out += &part;
                let mut x = Vec::with_capacity(k * (np + 1));
                for j in 0..=np {
                    x.extend_from_slice(&self.x[j * cap..j * cap + k]);
                }
                let full = assemble(part.view((0, 0), (np, np + 1)), &bx, None, &bd);
                let na = np + nr;
                let gram = full.as_slice()[..na * na].to_vec();
                store.push(Block {
                    k,
                    nm: np,
                    x,
                    d: d.to_vec(),
                    gram,
                });
            }
        }
        self.filled = 0;
    }

    /// `Z^T [X y]` over every speed (`na x (na + 1)`, in the order of the
    /// unknowns), and the blocks kept.
    fn finish(mut self) -> (DMatrix<f64>, Vec<Block>) {
        self.flush();
        debug_assert_eq!(self.y.len(), self.nq * (self.nq + self.npl));
        let rz = (!self.z.is_empty()).then_some(&self.rz);
        let dense = self.out.view((0, 0), (self.np, self.np + 1));
        (
            assemble(dense, &self.rx, rz, &self.rd),
            self.store.unwrap_or_default(),
        )
    }
}

/// `out += R^T C` for the runout columns `R` of a block of `k` real rows
/// (the value `d_r` of each row, [`Block`]; `out` is `nr x ncols`, `nr =
/// 2 nq`, the real rows of one speed) and the `ncols` columns of `c`
/// (column `j` at `c[j * stride..]`): `out[r mod nr, j] += d_r c[r, j]`,
/// a sum over speeds of `nr`-long elementwise products.
fn add_runout_products(
    c: &[f64],
    stride: usize,
    k: usize,
    ncols: usize,
    d: &[f64],
    out: &mut DMatrix<f64>,
) {
    let nr = out.nrows();
    if nr == 0 {
        return;
    }
    for (j, o) in out
        .as_mut_slice()
        .chunks_exact_mut(nr)
        .take(ncols)
        .enumerate()
    {
        let col = &c[j * stride..j * stride + k];
        match nr {
            4 => add_products::<4>(col, d, o),
            8 => add_products::<8>(col, d, o),
            12 => add_products::<12>(col, d, o),
            16 => add_products::<16>(col, d, o),
            _ => {
                for (xs, ds) in col.chunks_exact(nr).zip(d.chunks_exact(nr)) {
                    for ((a, x), dr) in o.iter_mut().zip(xs).zip(ds) {
                        *a += x * dr;
                    }
                }
            }
        }
    }
}

/// `o += sum_n x_n .* d_n` over the `N`-long pieces of `x` and `d` (the
/// real rows of one speed): fixed-size, so that it vectorises.
fn add_products<const N: usize>(x: &[f64], d: &[f64], o: &mut [f64]) {
    let mut acc = [0.0; N];
    for (xs, ds) in x.chunks_exact(N).zip(d.chunks_exact(N)) {
        if let (Ok(xs), Ok(ds)) = (<&[f64; N]>::try_from(xs), <&[f64; N]>::try_from(ds)) {
            for ((a, x), dr) in acc.iter_mut().zip(xs).zip(ds) {
                *a += x * dr;
            }
        }
    }
    for (o, a) in o.iter_mut().zip(acc) {
        *o += a;
    }
}

/// `diag += diag(R^T R)` for the runout columns of a block ([`Block`]):
/// `diag[r mod nr] += d_r^2`.
fn add_runout_diag(d: &[f64], diag: &mut [f64]) {
    let nr = diag.len();
    if nr == 0 {
        return;
    }
    for ds in d.chunks_exact(nr) {
        for (a, dr) in diag.iter_mut().zip(ds) {
            *a += dr * dr;
        }
    }
}

/// `Z^T [X y]` in the order of the unknowns (`na x (na + 1)`, `na = nm +
/// nr`) from its parts ([`Rows`]): `dense = Z_m^T [X_m y]` (`nm x (nm +
/// 1)`), `rx = R^T [X_m y]` (`nr x (nm + 1)`), `rz = R^T Z_m` (`nr x nm`;
/// `None` where the instruments are the regressors) and `rd` the diagonal
/// of `R^T R`.
fn assemble(
    dense: DMatrixView<'_, f64>,
    rx: &DMatrix<f64>,
    rz: Option<&DMatrix<f64>>,
    rd: &[f64],
) -> DMatrix<f64> {
    let (nm, nr) = (dense.nrows(), rd.len());
    let na = nm + nr;
    let mut out = DMatrix::zeros(na, na + 1);
    out.view_mut((0, 0), (nm, nm))
        .copy_from(&dense.columns(0, nm));
    out.view_mut((0, na), (nm, 1))
        .copy_from(&dense.columns(nm, 1));
    if nr > 0 {
        let cross = rz.unwrap_or(rx).columns(0, nm);
        out.view_mut((0, nm), (nm, nr)).tr_copy_from(&cross);
        out.view_mut((nm, 0), (nr, nm))
            .copy_from(&rx.columns(0, nm));
        out.view_mut((nm, na), (nr, 1))
            .copy_from(&rx.columns(nm, 1));
        for (r, v) in rd.iter().enumerate() {
            out[(nm + r, nm + r)] = *v;
        }
    }
    out
}

/// `S`, and with `jacobian` the normal equations, at `theta`; returns the
/// weights used (`w_(n,c)` at `n * nq + c`).
///
/// With `dq/dtheta = H^-1 G` (`G` one entry `-dz q_col` in row `row` for a
/// bearing parameter, the column `B e_k da` for an unbalance parameter) and
/// `D = diag(1/w)`, the weighted Jacobian is `D H^-1 G`, one scaled column
/// of `[D H^-1, D H^-1 B]` per parameter ([`Rows`]); with the weighted
/// residual `r = D (q_meas - q)` appended, one product of the real rows
/// gives `Re(J^H D^2 J)` and the gradient `-Re(J^H D^2 (q_meas - q))`
/// (checked against the Jacobian of the predictor in the tests).
fn pass(
    data: &Data<'_>,
    weights: WeightsFrom<'_>,
    theta: &[f64],
    jacobian: bool,
) -> Result<(Pass, Vec<f64>), PredictError> {
    let pr = data.pr;
    let np = pr.n_params();
    let na = data.n_all();
    let (nq, npl) = (2 * pr.param.n_bearings(), pr.param.n_planes());
    if theta.len() != na || data.entries.iter().any(|en| en.len() != np) {
        return Err(PredictError::Dimension);
    }
    let runout = data.runout(theta);
    let mut solve = Solve::new(nq, npl);
    let mut rows = jacobian.then(|| {
        let mut r = data.rows(na, false);
        if data.keep_rows {
            r.store = Some(Vec::new());
        }
        r
    });
    let mut r = vec![Complex64::new(0.0, 0.0); nq];
    let mut read = vec![Complex64::new(0.0, 0.0); nq];
    let mut cost = 0.0;
    let mut used = Vec::with_capacity(data.samples.len() * nq);
    let mut error = Vec::with_capacity(data.samples.len() * nq);
    let mut read_abs = Vec::with_capacity(data.samples.len() * nq);
    let it = data.samples.iter().zip(data.terms).zip(&data.entries);
    for (n, ((s, t), en)) in it.enumerate() {
        solve.run(s.omega, t, en, &theta[..np])?;
        // What the probes read: the shaft's motion plus the runout.
        for (c, o) in read.iter_mut().enumerate() {
            *o = solve.q[c] + runout.get(c).copied().unwrap_or_default();
        }
        let w0 = used.len();
        match weights {
            WeightsFrom::Given(w) => used.extend_from_slice(&w[n * nq..(n + 1) * nq]),
            WeightsFrom::Prediction => used.extend(
                read.iter()
                    .enumerate()
                    .map(|(c, q)| data.weighting.weight(n * nq + c, c, *q)),
            ),
        }
        let wn = &used[w0..];
        for (c, rc) in r.iter_mut().enumerate() {
            let d2 = 1.0 / (wn[c] * wn[c]);
            let ec = s.q[c] - read[c];
            cost += ec.norm_sqr() * d2;
            *rc = ec / wn[c];
            error.push(ec.norm());
            read_abs.push(read[c].norm());
        }
        if let Some(rows) = rows.as_mut() {
            rows.set_speed(&solve.h_inv, t.1.as_slice(), wn);
            rows.columns(false, en, &solve.q);
            rows.runout_columns(np, &data.runout_scale, wn);
            rows.extra(&r);
            rows.advance();
        }
    }
    let mut kept = Vec::new();
    let (normal, gradient) = match rows {
        Some(rows) => {
            let (out, blocks) = rows.finish();
            kept = blocks;
            let mut normal = out.columns(0, na).into_owned();
            for i in 0..na {
                for k in 0..i {
                    normal[(i, k)] = normal[(k, i)];
                }
            }
            (normal, -out.column(na))
        }
        None => (DMatrix::zeros(na, na), DVector::zeros(na)),
    };
    Ok((
        Pass {
            normal,
            gradient,
            cost,
            error,
            read: read_abs,
            rows: kept,
        },
        used,
    ))
}

/// The equations of one refined-instrumental-variable pass at `theta`
/// (see the module documentation), `Re(Z^H X) theta' = Re(Z^H y_0)` with
/// the weighted instruments `Z` and regressors `X` of [`Rows`] and
/// `y_0 = D H^-1 A q_meas` (`na x (na + 1)`: `[Re(Z^H X), Re(Z^H y_0)]`),
/// and `S` at `theta` with the weights of this prediction (the same
/// number as [`Data::reweighted`]'s: the pass that checks one step's
/// result sets up the next step).
///
/// With a runout `r` per channel the shaft's motion is `q_meas - r`, and
/// the equation error, filtered as above, is linearised in `r` about the
/// previous runout `r_0` (`H(theta_prev)^-1 H(theta) ~ 1` on it):
///
/// ```text
///     r(theta, r) = D H^-1 (H(theta) (q_meas - r_0) - B a(theta)) - D (r - r_0),
/// ```
///
/// linear in both, equal to the weighted output error at
/// `(theta_prev, r_0)`; the runout's columns are `D` times its scale, the
/// same in `Z` and `X` (the readings are linear in it), and `y_0` gains
/// `D r_0`. A fixed point is a stationary point of the output error.
fn iv_system(data: &Data<'_>, theta: &[f64]) -> Result<(f64, DMatrix<f64>), PredictError> {
    let pr = data.pr;
    let np = pr.n_params();
    let na = data.n_all();
    let (nq, npl) = (2 * pr.param.n_bearings(), pr.param.n_planes());
    if theta.len() != na {
        return Err(PredictError::Dimension);
    }
    // The shaft's motion is the reading less the runout.
    let runout = data.runout(theta);
    let (unknowns, scale) = if data.iv_runout {
        (na, data.runout_scale.as_slice())
    } else {
        (np, &[][..])
    };
    let mut cost = 0.0;
    let mut solve = Solve::new(nq, npl);
    let mut rows = data.rows(unknowns, true);
    let zero = Complex64::new(0.0, 0.0);
    let (mut w, mut aq, mut y0) = (vec![0.0; nq], vec![zero; nq], vec![zero; nq]);
    let mut shaft = vec![zero; nq];
    let it = data.samples.iter().zip(data.terms).zip(&data.entries);
    for (n, ((s, t), entries)) in it.enumerate() {
        let (a, b) = t;
        solve.run(s.omega, t, entries, &theta[..np])?;
        for (c, o) in shaft.iter_mut().enumerate() {
            *o = s.q[c] - runout.get(c).copied().unwrap_or_default();
        }
        for (c, wc) in w.iter_mut().enumerate() {
            let read = solve.q[c] + runout.get(c).copied().unwrap_or_default();
            *wc = data.weighting.weight(n * nq + c, c, read);
        }
        for (c, wc) in w.iter().enumerate() {
            let d2 = 1.0 / (wc * wc);
            cost += (shaft[c] - solve.q[c]).norm_sqr() * d2;
        }
        rows.set_speed(&solve.h_inv, b.as_slice(), &w);
        // Instruments from the prediction, regressors from the measurement.
        rows.columns(true, entries, &solve.q);
        rows.columns(false, entries, &shaft);
        // y_0 = D H^-1 A q_meas.
        aq.fill(zero);
        for (ac, qc) in a.as_slice().chunks_exact(nq).zip(&shaft) {
            for (o, aic) in aq.iter_mut().zip(ac) {
                *o += aic * qc;
            }
        }
        y0.fill(zero);
        for (hc, ac) in solve.h_inv.chunks_exact(nq).zip(&aq) {
            for (o, hic) in y0.iter_mut().zip(hc) {
                *o += hic * ac;
            }
        }
        for (c, (yc, wc)) in y0.iter_mut().zip(&w).enumerate() {
            let r0 = match data.iv_runout {
                true => runout.get(c).copied().unwrap_or_default(),
                false => zero,
            };
            *yc = (*yc + r0) / wc;
        }
        rows.runout_columns(np, scale, &w);
        rows.extra(&y0);
        rows.advance();
    }
    Ok((cost, rows.finish().0))
}

/// The solution of [`iv_system`]'s equations.
fn solve_iv(out: DMatrix<f64>) -> Result<Vec<f64>, OutputErrorError> {
    let np = out.nrows();
    let sol = out
        .columns(0, np)
        .into_owned()
        .lu()
        .solve(&out.column(np))
        .ok_or(OutputErrorError::Singular)?;
    if sol.iter().all(|x| x.is_finite()) {
        Ok(sol.as_slice().to_vec())
    } else {
        Err(OutputErrorError::Singular)
    }
}

/// A step shorter than this many standard deviations of the estimate ends
/// the polish: nothing a further step changes is visible in the result.
const STEP_STDS: f64 = 1e-3;

/// Within this many standard deviations of the quadratic model's optimum
/// the polish takes the undamped Gauss-Newton step (quadratic convergence
/// where the model is exact to far below the noise); farther, the damped
/// one, which keeps a model that cannot fit from running off.
const NEAR_STDS: f64 = 0.1;

/// What a Levenberg-Marquardt polish returns: the new `theta`, the
/// iterations, whether the tolerance was met, and the pass at `theta`
/// (its normal equations) when the polish formed it.
type Polished = (Vec<f64>, usize, bool, Option<Pass>);

/// The Gauss-Newton step `N delta = -G` of `pass` and its squared length
/// in standard deviations, `delta^T N delta` over the variance of a real
/// part, `S / (2 n)` (`n` complex samples that count). The step is `None`
/// where `N` is not positive definite; the length is `None` where the step
/// is, or where it comes out negative (`N` numerically indefinite: a step
/// of negative length says nothing).
fn gauss_newton_step(pass: &Pass, n: usize) -> (Option<DVector<f64>>, Option<f64>) {
    let variance = pass.cost / (2 * n) as f64;
    let step = pass
        .normal
        .clone()
        .cholesky()
        .map(|ch| ch.solve(&(-&pass.gradient)))
        .filter(|d| d.iter().all(|x| x.is_finite()));
    let dist2 = step
        .as_ref()
        .map(|d| -pass.gradient.dot(d) / variance.max(f64::MIN_POSITIVE))
        .filter(|d2| *d2 >= 0.0);
    (step, dist2)
}

/// Levenberg-Marquardt at fixed weights.
///
/// It ends when `S` or the scaled step change by less than the tolerance,
/// or when the next step (undamped) would move the estimate by less than
/// [`STEP_STDS`] standard deviations: then without trying it. With
/// `stall_cost` (`STALL_MISFIT N s^2`, [`FitNoise::stall`]) it also ends,
/// not converged, once `S` is above it and fell by less than
/// [`STALL_DROP`] over the last [`STALL_WINDOW`] iterations.
fn levenberg_marquardt(
    data: &Data<'_>,
    w: &[f64],
    start: (Vec<f64>, Pass),
    opts: &OutputErrorOptions,
    stall_cost: Option<f64>,
) -> Result<Polished, OutputErrorError> {
    let np = data.n_all();
    let (mut theta, mut cur) = start;
    let mut history: Vec<f64> = vec![cur.cost];
    let n = data.n_counted();
    if cur.cost <= PERFECT * n as f64 {
        return Ok((theta, 0, true, Some(cur)));
    }
    let max_diag = (0..np).map(|i| cur.normal[(i, i)]).fold(0.0, f64::max);
    if max_diag.is_nan() || max_diag <= 0.0 {
        return Err(OutputErrorError::Singular);
    }
    // Marquardt's scaling, `mu diag(N)`, with `mu` starting at `1e-6`
    // times the largest diagonal element: a strong damping at first, which
    // keeps a model that cannot fit the data from running off to a
    // degenerate optimum.
    let mut mu = 1e-6 * max_diag;
    let mut nu = 2.0;
    // Undamped steps are tried near the optimum until one fails.
    let mut undamped = true;
    for it in 1..=opts.max_iterations {
        // The Gauss-Newton step `N delta = -G` and its length in standard
        // deviations: `delta^T N delta` over the variance of a real part,
        // `S / (2 n)`.
        let (gauss_newton, dist2) = gauss_newton_step(&cur, n);
        if dist2.is_some_and(|d2| d2 < STEP_STDS * STEP_STDS) {
            return Ok((theta, it - 1, true, Some(cur)));
        }
        let near = undamped && dist2.is_some_and(|d2| d2 < NEAR_STDS * NEAR_STDS);
        if near && !cur.rows.is_empty() {
            // With the rows kept, the undamped step near the optimum is
            // taken to first order on them (no prediction): it is the
            // optimum of the quadratic model, and the model is exact there
            // to far below the noise.
            if let Some(d) = gauss_newton.as_ref() {
                let trial = theta.iter().zip(d.iter()).map(|(t, x)| t + x).collect();
                let moved = linear_step(data, cur, w, d);
                return Ok((trial, it, true, Some(moved)));
            }
        }
        let delta = match gauss_newton.filter(|_| near) {
            Some(d) => d,
            None => {
                // (N + mu D) delta = -G with D = diag(N) (floored).
                let mut lhs = cur.normal.clone();
                for i in 0..np {
                    lhs[(i, i)] += mu * cur.normal[(i, i)].max(1e-12 * max_diag);
                }
                let Some(chol) = lhs.cholesky() else {
                    mu *= nu;
                    nu *= 2.0;
                    continue;
                };
                chol.solve(&(-&cur.gradient))
            }
        };
        // Predicted reduction of S/2: -G.delta - delta.N.delta/2.
        let nd = &cur.normal * &delta;
        let predicted = -cur.gradient.dot(&delta) - 0.5 * delta.dot(&nd);
        let trial: Vec<f64> = theta.iter().zip(delta.iter()).map(|(t, d)| t + d).collect();
        // The trial's cost decides; its normal equations are formed only
        // when the iteration goes on from it: with the trial (one
        // prediction per speed for both) where the undamped step is taken,
        // which near the optimum is accepted, else after the trial.
        let (next, formed) = match data.pass(WeightsFrom::Given(w), &trial, near) {
            Ok((p, _)) => (p.cost, near.then_some(p)),
            Err(_) => {
                mu *= nu;
                nu *= 2.0;
                continue;
            }
        };
        let actual = 0.5 * (cur.cost - next);
        let rho = if predicted > 0.0 {
            actual / predicted
        } else {
            -1.0
        };
        let step = delta.amax() / (1.0 + theta.iter().fold(0.0f64, |a, t| a.max(t.abs())));
        if rho > 0.0 {
            let rel = (cur.cost - next) / cur.cost.max(f64::MIN_POSITIVE);
            theta = trial;
            if rel < opts.tolerance || step < opts.tolerance {
                return Ok((theta, it, true, None));
            }
            cur = match formed {
                Some(p) => p,
                None => data.pass(WeightsFrom::Given(w), &theta, true)?.0,
            };
            history.push(cur.cost);
            if stall_cost.is_some_and(|f| stalled(&history, f)) {
                return Ok((theta, it, false, Some(cur)));
            }
            mu *= (1.0 - (2.0 * rho - 1.0).powi(3)).max(1.0 / 3.0);
            nu = 2.0;
        } else {
            if near {
                // The quadratic model failed where it was trusted: damped
                // steps from here on.
                undamped = false;
            } else {
                mu *= nu;
                nu *= 2.0;
            }
            if step < opts.tolerance {
                return Ok((theta, it, true, Some(cur)));
            }
        }
    }
    Ok((theta, opts.max_iterations, false, Some(cur)))
}

/// The output-error fit of `samples` (with their reduced `terms`, one per
/// sample) from the start `start` (scaled weights, e.g. the QRD/RLS
/// estimate), under proportional noise (SPEC section 4): the fit of
/// [`fit_output_error_with`] with [`FitNoise::default`].
pub fn fit_output_error(
    pr: &Predictor,
    samples: &[Sample],
    terms: &[Terms],
    start: &[Complex64],
    opts: &OutputErrorOptions,
) -> Result<OutputErrorFit, OutputErrorError> {
    fit_output_error_with(pr, samples, terms, start, opts, &FitNoise::default())
}

/// The noise treatment of [`fit_output_error_with`]. The default is the
/// proportional model of SPEC section 4, nothing excluded, no runout.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct FitNoise {
    /// The noise model the fit weights with (`None`: proportional).
    pub model: Option<NoiseModel>,
    /// Refine `model`'s variance parameters by maximum likelihood from the
    /// fit's residuals between the reweightings ([`crate::estimate::noise::noise_from_points`]: a
    /// given floor stays, an estimated one is refitted).
    pub refine: bool,
    /// Per-sample standard deviations (m) at `n * nq + c` (the measurement
    /// file's `_std` columns): fixed weights, instead of `model`'s.
    pub sample_std: Option<Vec<f64>>,
    /// Find the samples the noise model cannot explain, exclude them and
    /// refit ([`Outlier`]).
    pub outliers: bool,
    /// Fit a constant runout phasor per channel, from these values (m).
    pub runout: Option<Vec<Complex64>>,
    /// The noise model the misfit is judged against (e.g. the model-free
    /// estimate): [`OutputErrorFit::chi2_per_dof`].
    pub reference: Option<NoiseModel>,
    /// With `model` held (not refined), let a polish stop *stalled*: when
    /// its `S` is above [`STALL_MISFIT`] times the noise floor `N s^2`
    /// that `model` predicts (an RMS misfit over three times its relative
    /// noise `s`) and the last [`STALL_WINDOW`] iterations lowered it by
    /// less than [`STALL_DROP`] of it in all. A start for a fit that goes on
    /// from it (a diagnosis's hypotheses) needs no more: a model this far
    /// from the data creeps along a valley to the iteration limit.
    pub stall: bool,
}

/// `S` over the held noise model's floor above which a polish may stop
/// stalled ([`FitNoise::stall`]): an RMS misfit `sqrt(10)` times the noise.
pub const STALL_MISFIT: f64 = 10.0;

/// Iterations over which a stalled polish lowered `S` by less than
/// [`STALL_DROP`] ([`FitNoise::stall`]).
pub const STALL_WINDOW: usize = 5;

/// Relative fall of `S` over [`STALL_WINDOW`] iterations below which a
/// polish far above its noise floor stops ([`FitNoise::stall`]).
pub const STALL_DROP: f64 = 2e-3;

/// Whether a fit whose `S` after each accepted iteration is `history`
/// has stalled above `bound` ([`STALL_MISFIT`] times its noise floor):
/// the last `S` is above it and fell by less than [`STALL_DROP`] of
/// itself over the last [`STALL_WINDOW`] iterations.
pub fn stalled(history: &[f64], bound: f64) -> bool {
    match (history.last(), history.len().checked_sub(STALL_WINDOW + 1)) {
        (Some(&s), Some(k)) => s > bound && history[k] - s < STALL_DROP * s,
        _ => false,
    }
}

/// A sample the noise model cannot explain, excluded from the fit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Outlier {
    /// Index of the sample.
    pub sample: usize,
    /// Its channel.
    pub channel: usize,
    /// Its residual in standard deviations of the noise model.
    pub sigmas: f64,
}

/// False alarms of the outlier test per data set: a sample is an outlier
/// when `|e|^2 / sigma^2 > ln(N / OUTLIER_FALSE_ALARM)`, `N` complex
/// samples (for complex Gaussian noise `|e|^2 / sigma^2` is `Exp(1)`, so
/// the chance that any of `N` is flagged is about this).
pub const OUTLIER_FALSE_ALARM: f64 = 0.01;

/// At most this fraction of the samples is excluded as outliers; beyond
/// it the noise model does not describe the data, and excluding more would
/// hide a misfit.
pub const MAX_OUTLIER_FRACTION: f64 = 0.05;

/// Relative change of the noise floors in relative units (`f_c / s`)
/// below which the refined noise model has settled.
const NOISE_SETTLED: f64 = 0.02;

/// Reweightings at most while the refined noise model settles.
const NOISE_ROUNDS: usize = 8;

/// Rounds of outlier exclusion and refit at most.
const OUTLIER_ROUNDS: usize = 5;

/// Mean leverage per sample of a block below which the block's samples
/// take that mean instead of their own: `1 / (1 - h)` is then within
/// about this of its exact value for each of them, and exact on average.
const LEVERAGE_EXACT: f64 = 1e-3;

/// The leverage of every sample in the fit of `pass` (its rows kept): the
/// mean of its real and imaginary rows' `h_r = x_r N^-1 x_r^T`
/// (`N = X^T X = L L^T`); empty if `N` is singular (no correction).
///
/// A block's row leverages add up to `tr(N^-1 X_b^T X_b)`, from its kept
/// share of the normal equations (`na^2` operations). Where their mean is
/// below [`LEVERAGE_EXACT`] (the speeds far from the critical speeds, most
/// of a sweep) every sample takes it; elsewhere each row's is computed,
/// one matrix product per block, `h_r = |x_r L^-T|^2`.
fn leverages(data: &Data<'_>, pass: &Pass) -> Vec<f64> {
    leverages_screened(data, pass, LEVERAGE_EXACT)
}

/// [`leverages`] with blocks whose mean leverage is below `exact_below`
/// given that mean.
fn leverages_screened(data: &Data<'_>, pass: &Pass, exact_below: f64) -> Vec<f64> {
    let na = data.n_all();
    let Some(ch) = pass.normal.clone().cholesky() else {
        return Vec::new();
    };
    let n_inv = ch.inverse();
    let Some(lt) = ch
        .l()
        .solve_lower_triangular(&DMatrix::identity(na, na))
        .map(|m| m.transpose())
    else {
        return Vec::new();
    };
    let mut h = Vec::with_capacity(pass.error.len());
    let mut hr = Vec::new();
    for b in &pass.rows {
        let k = b.k;
        // Rows per block are even: two per sample.
        let samples = k / 2;
        let total: f64 = if b.gram.len() == na * na {
            n_inv
                .as_slice()
                .iter()
                .zip(&b.gram)
                .map(|(a, g)| a * g)
                .sum()
        } else {
            f64::INFINITY
        };
        // The mean of a sample's two rows' leverages averages to the
        // block's sum over its rows.
        if samples > 0 && total.is_finite() && total < exact_below * k as f64 {
            let mean = total.max(0.0) / k as f64;
            h.extend(std::iter::repeat_n(mean, samples));
            continue;
        }
        let x = DMatrixView::from_slice(&b.x, k, b.nm + 1);
        let mut v = x.columns(0, b.nm) * lt.rows(0, b.nm);
        // The runout's columns: row r gains d_r times the row of L^-T of
        // its runout parameter.
        let nr = b.nr(na);
        if nr > 0 {
            // Column by column: the nr rows of a speed take the nr
            // entries of L^-T's column in the runout's rows.
            let cols = v.as_mut_slice().chunks_exact_mut(k);
            for (col, l) in cols.zip(lt.as_slice().chunks_exact(na)) {
                let l = &l[b.nm..b.nm + nr];
                for (vs, ds) in col.chunks_exact_mut(nr).zip(b.d.chunks_exact(nr)) {
                    for ((o, dr), lr) in vs.iter_mut().zip(ds).zip(l) {
                        *o += dr * lr;
                    }
                }
            }
        }
        hr.clear();
        hr.resize(k, 0.0);
        for col in v.as_slice().chunks_exact(k) {
            for (o, x) in hr.iter_mut().zip(col) {
                *o += x * x;
            }
        }
        h.extend(hr.chunks_exact(2).map(|p| 0.5 * (p[0] + p[1])));
    }
    h
}

/// Variance points of a pass's residuals, excluded samples left out.
/// Each residual is corrected for the fit's leverage `h` (per sample,
/// [`leverages`]): `x = |e|^2 / (1 - h)`. The few speeds near the critical
/// speeds carry most of the information and most of the leverage, and they
/// are the ones that determine the relative part of the noise: without the
/// correction their shrunken residuals would make it far too small.
fn residual_points(data: &Data<'_>, pass: &Pass, h: &[f64]) -> ChannelPoints {
    let nq = data.samples.first().map_or(0, |s| s.q.len());
    let mut out = vec![Vec::with_capacity(pass.error.len() / nq.max(1) + 1); nq];
    for (i, (e, r)) in pass.error.iter().zip(&pass.read).enumerate() {
        if data.weighting.is_excluded(i) {
            continue;
        }
        let hi = h.get(i).copied().unwrap_or(0.0);
        let p = VariancePoint::residual(i % nq, e * e, r * r, 1.0 / (1.0 - hi).max(1e-3));
        out[i % nq].push([p.a, p.b, p.x]);
    }
    ChannelPoints(out)
}

/// The pass `pass` (at some `theta`, with weights `w`) under the weights
/// `w_new` at the same `theta`: the weighted rows and residual of sample
/// `i` are linear in `1 / w_i`, so each of its kept rows scales by
/// `w_i / w_new_i` and the normal equations are one product of the kept
/// rows, no prediction.
fn reweigh(pass: Pass, w: &[f64], w_new: &[f64], na: usize) -> Pass {
    let ratio: Vec<f64> = w
        .iter()
        .zip(w_new)
        .map(|(a, b)| {
            if a.is_finite() && b.is_finite() {
                a / b
            } else {
                0.0
            }
        })
        .collect();
    let mut out = DMatrix::<f64>::zeros(na, na + 1);
    // Each block's products (every block has the same columns).
    let (mut part, mut bx, mut bd) = (
        DMatrix::<f64>::zeros(0, 0),
        DMatrix::<f64>::zeros(0, 0),
        Vec::new(),
    );
    let mut rows = pass.rows;
    let mut g0 = 0;
    for b in &mut rows {
        let (k, nm, nr) = (b.k, b.nm, b.nr(na));
        // Rows 2 i and 2 i + 1 belong to sample i.
        let ratio_b = ratio.get(g0 / 2..).unwrap_or_default();
        for col in b.x.chunks_exact_mut(k) {
            for (pair, r) in col.chunks_exact_mut(2).zip(ratio_b) {
                pair[0] *= r;
                pair[1] *= r;
            }
        }
        for (pair, r) in b.d.chunks_exact_mut(2).zip(ratio_b) {
            pair[0] *= r;
            pair[1] *= r;
        }
        // [X_m y]^T [X_m y] with the transpose as a strided view (one
        // matrix-multiply kernel call), the runout's share row by row.
        let xt = DMatrixView::from_slice_with_strides(&b.x, nm + 1, k, k, 1);
        let xv = DMatrixView::from_slice(&b.x, k, nm + 1);
        if part.nrows() != nm + 1 {
            part = DMatrix::zeros(nm + 1, nm + 1);
            bx = DMatrix::zeros(nr, nm + 1);
            bd = vec![0.0; nr];
        }
        part.gemm(1.0, &xt, &xv, 0.0);
        bx.fill(0.0);
        bd.fill(0.0);
        add_runout_products(&b.x, k, k, nm + 1, &b.d, &mut bx);
        add_runout_diag(&b.d, &mut bd);
        let full = assemble(part.view((0, 0), (nm, nm + 1)), &bx, None, &bd);
        out += &full;
        b.gram.clear();
        b.gram.extend_from_slice(&full.as_slice()[..na * na]);
        g0 += k;
    }
    let cost = weighted_cost(&pass.error, w_new);
    Pass {
        normal: out.columns(0, na).into_owned(),
        gradient: -out.column(na),
        cost,
        error: pass.error,
        read: pass.read,
        rows,
    }
}

/// `S = sum |e|^2 / w^2` over the samples of finite weight (`|e|` and `w`
/// at `n * nq + c`).
fn weighted_cost(error: &[f64], w: &[f64]) -> f64 {
    error
        .iter()
        .zip(w)
        .map(|(e, wi)| {
            if wi.is_finite() {
                (e / wi).powi(2)
            } else {
                0.0
            }
        })
        .sum()
}

/// The pass `pass` (at `theta`, weights `w`, its rows kept) moved by the
/// step `delta` to first order: the weighted residual rows become
/// `y - X delta` (the rows `X` held: the Jacobian at `theta`), and with
/// them the gradient `-X^T (y - X delta) = G + N delta`, the cost, and each
/// sample's error `e = w (y_re + j y_im)` and reading `q_meas - e`. The
/// normal equations stay those of `theta`.
fn linear_step(data: &Data<'_>, mut pass: Pass, w: &[f64], delta: &DVector<f64>) -> Pass {
    let na = data.n_all();
    let nq = data.samples.first().map_or(1, |s| s.q.len()).max(1);
    let mut g0 = 0;
    for b in &mut pass.rows {
        let (k, nm, nr) = (b.k, b.nm, b.nr(na));
        let (xs, y) = b.x.split_at_mut(nm * k);
        for (col, d) in xs.chunks_exact(k).zip(delta.iter()) {
            for (yr, xr) in y.iter_mut().zip(col) {
                *yr -= xr * d;
            }
        }
        // The runout's columns: d_r in row r.
        if nr > 0 {
            for (r, dr) in b.d.iter().enumerate() {
                y[r] -= dr * delta[nm + r % nr];
            }
        }
        // Real rows 2 i and 2 i + 1 belong to sample i.
        for (p, pair) in y.chunks_exact(2).enumerate() {
            let i = g0 / 2 + p;
            let wi = w.get(i).copied().unwrap_or(f64::INFINITY);
            if !wi.is_finite() {
                continue;
            }
            let e = Complex64::new(pair[0], pair[1]) * wi;
            pass.error[i] = e.norm_sqr().sqrt();
            pass.read[i] = (data.samples[i / nq].q[i % nq] - e).norm_sqr().sqrt();
        }
        g0 += k;
    }
    pass.cost = weighted_cost(&pass.error, w);
    pass.gradient += &pass.normal * delta;
    pass
}

/// Standardised residuals `|e| / (w s_0)` from a pass's `|e|` and
/// weights `w` (excluded samples 0), `s_0` a robust scale
/// (`median(|e|^2 / w^2) / ln 2`) over the samples that count.
fn standardised(data: &Data<'_>, error: &[f64], w: &[f64]) -> Vec<f64> {
    let mut z: Vec<f64> = error
        .iter()
        .zip(w)
        .map(|(e, wk)| if wk.is_finite() { e / wk } else { 0.0 })
        .collect();
    let mut sq: Vec<f64> = z
        .iter()
        .enumerate()
        .filter(|(i, _)| !data.weighting.is_excluded(*i))
        .map(|(_, x)| x * x)
        .collect();
    if sq.is_empty() {
        return z;
    }
    let mid = sq.len() / 2;
    let (_, med, _) = sq.select_nth_unstable_by(mid, f64::total_cmp);
    let s0 = (*med / core::f64::consts::LN_2).sqrt();
    if s0 > 0.0 && s0.is_finite() {
        for x in &mut z {
            *x /= s0;
        }
    }
    z
}

/// The output-error fit of `samples` (with their reduced `terms`, one per
/// sample) from the start `start` (scaled weights, e.g. the QRD/RLS
/// estimate), with the noise treatment `noise` (see the module
/// documentation and [`FitNoise`]).
///
/// With a runout fitted, the instrumental-variable passes solve for it
/// with the model; where that start leads to singular normal equations
/// (a model that cannot fit the data, whose runout and model parameters
/// then trade off), the fit is repeated with the runout held at its start
/// during those passes.
pub fn fit_output_error_with(
    pr: &Predictor,
    samples: &[Sample],
    terms: &[Terms],
    start: &[Complex64],
    opts: &OutputErrorOptions,
    noise: &FitNoise,
) -> Result<OutputErrorFit, OutputErrorError> {
    match fit_from(pr, samples, terms, start, opts, noise, true) {
        Err(OutputErrorError::Singular) if noise.runout.is_some() && opts.iv_passes > 0 => {
            fit_from(pr, samples, terms, start, opts, noise, false)
        }
        r => r,
    }
}

/// [`fit_output_error_with`], the runout solved for (`iv_runout`) or held
/// in the instrumental-variable passes.
// Long (~300 lines): one pass through the fit's stages sharing its state (the pass at `theta` and its weights, `at` and `reweighted`); pieces would each take and return all of it.
fn fit_from(
    pr: &Predictor,
    samples: &[Sample],
    terms: &[Terms],
    start: &[Complex64],
    opts: &OutputErrorOptions,
    noise: &FitNoise,
    iv_runout: bool,
) -> Result<OutputErrorFit, OutputErrorError> {
    let nq = 2 * pr.param.n_bearings();
    if samples.len() != terms.len() || samples.iter().any(|s| s.q.len() != nq) {
        return Err(OutputErrorError::Dimension);
    }
    let n_all = samples.len() * nq;
    let np = pr.n_params();
    let weighting = match (&noise.sample_std, &noise.model) {
        (Some(std), _) => {
            if std.len() != n_all || std.iter().any(|x| !(x.is_finite() && *x > 0.0)) {
                return Err(OutputErrorError::Dimension);
            }
            Weighting::fixed(samples, opts.floor, std.clone())
        }
        (None, Some(m)) => Weighting::of_noise(samples, opts.floor, m),
        (None, None) => Weighting::proportional(samples, opts.floor),
    };
    let mut data = Data::weighted(pr, samples, terms, weighting);
    data.iv_runout = iv_runout;
    let mut theta = pr.theta(start);
    if let Some(r0) = &noise.runout {
        if r0.len() != nq {
            return Err(OutputErrorError::Dimension);
        }
        // Scale: the start's size, at least a thousandth of the channel's
        // RMS reading, so that the runout parameters are of order one.
        data.runout_scale = r0
            .iter()
            .zip(&floors(samples, 1e-3))
            .map(|(r, f)| r.norm().max(*f))
            .collect();
        for (r, sc) in r0.iter().zip(&data.runout_scale) {
            theta.push(r.re / sc);
            theta.push(r.im / sc);
        }
    }
    let na = data.n_all();
    if 2 * n_all <= na {
        return Err(OutputErrorError::TooFewEquations {
            equations: 2 * n_all,
            params: na,
        });
    }
    let mut model = noise.model.clone();
    // The variance parameters are refined where the data show a floor (or
    // one is given, or a runout is fitted, which the model-free estimate
    // cannot tell from a floor): with proportional noise the weights do not
    // depend on `s`, and the fit is the proportional model's.
    let refine = noise.refine
        && noise.sample_std.is_none()
        && model.as_ref().is_some_and(|m| {
            m.has_floor() || m.source == NoiseSource::Given || noise.runout.is_some()
        });
    // Refinements read the leverages from, and reweigh, the kept rows.
    data.keep_rows = refine;
    // The held model's noise floor of `S`: `N s^2` (each weighted complex
    // residual has variance `s^2` under it).
    let stall_cost = model
        .as_ref()
        .filter(|_| noise.stall && !refine && noise.sample_std.is_none())
        .map(|m| STALL_MISFIT * data.n_counted() as f64 * m.relative * m.relative);
    // A pass keeps its result only if it explains the data better: on data
    // the start already fits to round-off, the instrumental-variable
    // equations (whose conditioning is that of the normal equations) must
    // not move it along poorly determined directions.
    //
    // The pass that checks a step's result also sets up what follows it:
    // the next instrumental-variable equations, or after the last one the
    // normal equations that start the polish (the same numbers as separate
    // passes, one prediction per speed fewer).
    let (mut cost, mut system) = if opts.iv_passes > 0 {
        let (c, sys) = iv_system(&data, &theta)?;
        (c, Some(sys))
    } else {
        (data.reweighted(&theta, false)?.0.cost, None)
    };
    let mut fresh = None;
    for k in 0..opts.iv_passes {
        if cost <= PERFECT * n_all as f64 {
            break;
        }
        let Some(sys) = system.take() else { break };
        let t = match solve_iv(sys) {
            // Held runout parameters stay as they are.
            Ok(mut t) => {
                t.extend_from_slice(&theta[t.len()..]);
                t
            }
            Err(OutputErrorError::Predict(_)) | Err(OutputErrorError::Singular) => break,
            Err(e) => return Err(e),
        };
        if k + 1 < opts.iv_passes {
            match iv_system(&data, &t) {
                Ok((c, sys)) if c < cost => {
                    theta = t;
                    cost = c;
                    system = Some(sys);
                }
                _ => break,
            }
        } else {
            match data.reweighted(&t, true) {
                Ok((p, w)) if p.cost < cost => {
                    theta = t;
                    cost = p.cost;
                    fresh = Some((p, w));
                }
                _ => break,
            }
        }
    }
    let mut iterations = 0;
    let mut converged = false;
    let mut outliers: Vec<Outlier> = Vec::new();
    let max_out = (MAX_OUTLIER_FRACTION * n_all as f64).floor() as usize;
    let mut too_many = false;
    let mut settled = false;
    // The pass at `theta` and its weights, when at hand (the
    // instrumental-variable stage's or the last polish's), and whether its
    // weights are the prediction's at `theta` (a reweighting).
    let mut at: Option<(Pass, Vec<f64>)> = fresh;
    let mut reweighted = at.is_some();
    // The leverages of the last refinement (per sample).
    let mut lev: Option<Vec<f64>> = None;
    for round in 0..OUTLIER_ROUNDS {
        // Reweightings; with the noise model refined, until its floors in
        // relative units settle (the weights depend on them). The first
        // refinement follows the first polish: read at the
        // instrumental-variable estimate instead, the noise of a model that
        // misfits (a diagnosis's nominal model) comes out larger, and the
        // diagnosis names fewer effects (25 of 33 realistic cases against
        // 28).
        let mut k = 0;
        loop {
            let mut changed = 0.0f64;
            if refine && (k > 0 || round > 0) {
                if let Some(m) = model.as_mut() {
                    let cur = match at.take() {
                        Some(a) => a,
                        None => data.reweighted(&theta, true)?,
                    };
                    let cur = with_rows(&mut data, &theta, cur)?;
                    // The previous refinement's leverages first (those of
                    // the weights before it): where the model refitted with
                    // them has settled, fresh ones (one product of the rows)
                    // would not move it by more than the tolerance either.
                    let settled_on_old = lev.as_ref().and_then(|h| {
                        let cand = refitted(&data, &cur.0, h, m);
                        (floor_change(m, &cand) <= NOISE_SETTLED).then_some(cand)
                    });
                    let next = match settled_on_old {
                        Some(n) => n,
                        None => {
                            let h = leverages(&data, &cur.0);
                            let n = refitted(&data, &cur.0, &h, m);
                            lev = Some(h);
                            n
                        }
                    };
                    changed = floor_change(m, &next);
                    *m = next;
                    at = Some(if changed <= NOISE_SETTLED {
                        // Settled: the weights at hand are within the
                        // tolerance of the new model's, and the estimate
                        // under them is final.
                        data.weighting.set_noise(m);
                        cur
                    } else {
                        apply_noise(&mut data, cur, m)
                    });
                    reweighted = true;
                }
            }
            let (cur, w) = match at.take() {
                Some(a) if reweighted => a,
                _ => data.reweighted(&theta, true)?,
            };
            let start_theta = theta.clone();
            let (t, it, ok, p) = levenberg_marquardt(&data, &w, (theta, cur), opts, stall_cost)?;
            theta = t;
            // Unmoved, the polish's pass is the prediction's at `theta`.
            reweighted = p.is_some() && theta == start_theta;
            at = p.map(|p| (p, w));
            iterations += it;
            converged = ok;
            k += 1;
            let settle = refine && changed > NOISE_SETTLED && k < NOISE_ROUNDS;
            // The last refinement moved the weights by less than the
            // tolerance: the model the last polish used is the final one.
            settled = refine && k > 1 && changed <= NOISE_SETTLED;
            if k >= opts.reweightings.max(1) && !settle {
                break;
            }
        }
        if !noise.outliers || too_many {
            break;
        }
        // The pass that looks for outliers is the final one if it finds
        // none.
        let (p, w) = match at.take() {
            Some(a) if reweighted => a,
            _ => data.reweighted(&theta, true)?,
        };
        let z = standardised(&data, &p.error, &w);
        at = Some((p, w));
        reweighted = true;
        let limit = (data.n_counted().max(1) as f64 / OUTLIER_FALSE_ALARM)
            .ln()
            .sqrt();
        let mut new: Vec<(usize, f64)> = z
            .iter()
            .enumerate()
            .filter(|(i, x)| **x > limit && !data.weighting.is_excluded(*i))
            .map(|(i, x)| (i, *x))
            .collect();
        if new.is_empty() {
            break;
        }
        if outliers.len() + new.len() > max_out {
            // Keep the largest up to the limit; the rest stays in (and the
            // caller warns that the noise model does not describe the data).
            new.sort_by(|a, b| b.1.total_cmp(&a.1));
            new.truncate(max_out.saturating_sub(outliers.len()));
            too_many = true;
            if new.is_empty() {
                break;
            }
        }
        if data.weighting.excluded.is_empty() {
            data.weighting.excluded = vec![false; n_all];
        }
        for (i, x) in new {
            data.weighting.excluded[i] = true;
            outliers.push(Outlier {
                sample: i / nq,
                channel: i % nq,
                sigmas: x,
            });
        }
        at = None;
        lev = None;
    }
    if refine && !settled {
        if let Some(m) = model.as_mut() {
            let cur = match at.take() {
                Some(a) => a,
                None => data.reweighted(&theta, true)?,
            };
            let cur = with_rows(&mut data, &theta, cur)?;
            let h = leverages(&data, &cur.0);
            *m = refitted(&data, &cur.0, &h, m);
            at = Some(apply_noise(&mut data, cur, m));
            reweighted = true;
        }
    }
    outliers.sort_by_key(|o| (o.sample, o.channel));
    let n = data.n_counted();
    let fin = match at {
        Some((p, _)) if reweighted => p,
        _ => data.reweighted(&theta, true)?.0,
    };
    let dof = n as f64 - na as f64 / 2.0;
    let residual_noise = (fin.cost / dof).sqrt();
    let inv = fin
        .normal
        .clone()
        .cholesky()
        .map(|c| c.inverse())
        .ok_or(OutputErrorError::Singular)?;
    let full = inv * (residual_noise * residual_noise / 2.0);
    let runout = data.runout(&theta);
    let runout_std = data
        .runout_scale
        .iter()
        .enumerate()
        .map(|(c, sc)| {
            (full[(np + 2 * c, np + 2 * c)] + full[(np + 2 * c + 1, np + 2 * c + 1)])
                .max(0.0)
                .sqrt()
                * sc
        })
        .collect();
    // With a floor, the model-free relative part rests on the few windows
    // where the response exceeds the floor, near a resonance, where a local
    // smoother also reads curvature: it is an upper bound. The reference is
    // the fit's relative part when below it (a fit within the noise), the
    // model-free one otherwise (a fit whose relative residual exceeds even
    // that bound misfits).
    let reference = noise.reference.as_ref().map(|r| match &model {
        Some(m) if r.has_floor() => NoiseModel {
            relative: m.relative.min(r.relative),
            ..r.clone()
        },
        _ => r.clone(),
    });
    let chi2_per_dof = match &reference {
        Some(r) if r.relative > 0.0 => {
            // The final pass's residuals weighted by the reference.
            let mut wr = Weighting::of_noise(samples, opts.floor, r);
            wr.excluded = data.weighting.excluded.clone();
            let cost: f64 = (0..n_all)
                .map(|i| {
                    let w = wr.weight(i, i % nq, Complex64::new(fin.read[i], 0.0));
                    if w.is_finite() {
                        (fin.error[i] / w).powi(2)
                    } else {
                        0.0
                    }
                })
                .sum();
            Some(cost / dof / (r.relative * r.relative))
        }
        _ => None,
    };
    theta.truncate(np);
    Ok(OutputErrorFit {
        weights: pr.weights(&theta),
        theta,
        covariance: full.view((0, 0), (np, np)).into_owned(),
        residual: (fin.cost / n as f64).sqrt(),
        residual_noise,
        iterations,
        converged,
        noise: model,
        outliers,
        outliers_capped: too_many,
        runout,
        runout_std,
        chi2_per_dof,
    })
}

/// `at` (the pass at `theta` and its weights) with its rows: one pass
/// keeps them where they were not kept.
fn with_rows(
    data: &mut Data<'_>,
    theta: &[f64],
    at: (Pass, Vec<f64>),
) -> Result<(Pass, Vec<f64>), PredictError> {
    if !at.0.rows.is_empty() {
        return Ok(at);
    }
    let keep = data.keep_rows;
    data.keep_rows = true;
    let p = data.pass(WeightsFrom::Given(&at.1), theta, true);
    data.keep_rows = keep;
    Ok((p?.0, at.1))
}

/// `model` refitted by maximum likelihood to the residuals of `pass` with
/// the leverages `h` ([`residual_points`],
/// [`crate::estimate::noise::noise_from_points`]; a given floor is held).
fn refitted(data: &Data<'_>, pass: &Pass, h: &[f64], model: &NoiseModel) -> NoiseModel {
    let points = residual_points(data, pass, h);
    if points.0.len() != model.floor_m.len() {
        return model.clone();
    }
    let given =
        (model.source == NoiseSource::Given).then(|| model.floor_m.first().copied().unwrap_or(0.0));
    match noise_from_channels_near(&points, given, Some(model)) {
        Some(m) => NoiseModel {
            source: model.source,
            ..m
        },
        None => model.clone(),
    }
}

/// The largest relative change of the floors in relative units
/// (`f_c / s`) from `before` to `after`.
fn floor_change(before: &NoiseModel, after: &NoiseModel) -> f64 {
    before
        .relative_floor()
        .iter()
        .zip(after.relative_floor())
        .map(|(a, b)| (a - b).abs() / a.max(b).max(f64::MIN_POSITIVE))
        .fold(0.0, f64::max)
}

/// The data's weighting set to `model`, and the pass of `at` (rows kept)
/// under the new weights at the same `theta` ([`reweigh`]).
fn apply_noise(data: &mut Data<'_>, at: (Pass, Vec<f64>), model: &NoiseModel) -> (Pass, Vec<f64>) {
    let (pass, w) = at;
    let nq = model.floor_m.len();
    data.weighting.set_noise(model);
    let w_new: Vec<f64> = pass
        .read
        .iter()
        .enumerate()
        .map(|(i, r)| data.weighting.weight(i, i % nq, Complex64::new(*r, 0.0)))
        .collect();
    let next = reweigh(pass, &w, &w_new, data.n_all());
    (next, w_new)
}

/// estimate.
pub fn fisher_information(
    pr: &Predictor,
    samples: &[Sample],
    terms: &[Terms],
    theta: &[f64],
    floor: f64,
) -> Result<DMatrix<f64>, OutputErrorError> {
    if samples.len() != terms.len() {
        return Err(OutputErrorError::Dimension);
    }
    fisher_information_weighted(
        pr,
        samples,
        terms,
        theta,
        &Weighting::proportional(samples, floor),
    )
}

/// [`fisher_information`] with the weights of `weighting` (e.g. of a noise
/// model with a floor, [`Weighting::of_noise`]): `2 Re(J^H J)` with
/// `J = (dq/dtheta) / w`; divide by `s^2` for the information of the data.
pub fn fisher_information_weighted(
    pr: &Predictor,
    samples: &[Sample],
    terms: &[Terms],
    theta: &[f64],
    weighting: &Weighting,
) -> Result<DMatrix<f64>, OutputErrorError> {
    if samples.len() != terms.len() {
        return Err(OutputErrorError::Dimension);
    }
    let (p, _) = Data::weighted(pr, samples, terms, weighting.clone()).reweighted(theta, true)?;
    Ok(p.normal * 2.0)
}

/// The Fisher information (per unit relative noise, as
/// [`fisher_information_weighted`]) of the model's parameters `theta` and
/// a runout phasor per channel at `runout` (m), the runout's parameters
/// last (`Re`, `Im` per channel, in metres): the bound of an estimate that
/// fits the runout.
pub fn fisher_information_with_runout(
    pr: &Predictor,
    samples: &[Sample],
    terms: &[Terms],
    theta: &[f64],
    runout: &[Complex64],
    weighting: &Weighting,
) -> Result<DMatrix<f64>, OutputErrorError> {
    if samples.len() != terms.len() {
        return Err(OutputErrorError::Dimension);
    }
    let mut data = Data::weighted(pr, samples, terms, weighting.clone());
    data.runout_scale = vec![1.0; runout.len()];
    let mut all = theta.to_vec();
    for r in runout {
        all.push(r.re);
        all.push(r.im);
    }
    let (p, _) = data.reweighted(&all, true)?;
    Ok(p.normal * 2.0)
}

/// The relative RMS misfit `sqrt(S / N)` and `s_fit = sqrt(S / (N - P/2))`
/// of the scaled weights `w` (any estimate, e.g. the QRD/RLS one), with the
/// weights of the fit.
pub fn misfit(
    pr: &Predictor,
    samples: &[Sample],
    terms: &[Terms],
    w: &[Complex64],
    floor: f64,
) -> Result<(f64, f64), OutputErrorError> {
    if samples.len() != terms.len() || samples.is_empty() {
        return Err(OutputErrorError::Dimension);
    }
    misfit_weighted(
        pr,
        samples,
        terms,
        w,
        &Weighting::proportional(samples, floor),
    )
}

/// [`misfit`] with the weights of `weighting`.
pub fn misfit_weighted(
    pr: &Predictor,
    samples: &[Sample],
    terms: &[Terms],
    w: &[Complex64],
    weighting: &Weighting,
) -> Result<(f64, f64), OutputErrorError> {
    if samples.len() != terms.len() || samples.is_empty() {
        return Err(OutputErrorError::Dimension);
    }
    let theta = pr.theta(w);
    let data = Data::weighted(pr, samples, terms, weighting.clone());
    let (p, _) = data.reweighted(&theta, false)?;
    let n = data.n_counted() as f64;
    let dof = (n - pr.n_params() as f64 / 2.0).max(1.0);
    Ok(((p.cost / n).sqrt(), (p.cost / dof).sqrt()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimate::unknowns::Parametrization;
    use rotorid_core::parametrization::Structure;
    use rotorid_core::scaling::ColumnScaling;

    /// A synthetic problem: `2 BLOCK + 7` speeds (more than a block of
    /// rows holds, the last block part-filled), readings 1-2 % off the
    /// prediction at `theta`.
    fn problem(st: Structure) -> (Predictor, Vec<f64>, Vec<Sample>, Vec<Terms>) {
        let pr = Predictor::new(Parametrization {
            structure: st,
            scaling: ColumnScaling::new(3e7, 1500.0, 1e-3).unwrap(),
            bearing_nodes: vec![0, 10],
            plane_nodes: vec![3, 6, 8],
        });
        let theta: Vec<f64> = (0..pr.n_params())
            .map(|i| 0.7 + 0.05 * (i % 7) as f64)
            .collect();
        let mut samples = Vec::new();
        let mut terms = Vec::new();
        for n in 1..=(2 * BLOCK + 7) {
            let omega = 10.0 * n as f64;

            let a = DMatrix::from_fn(4, 4, |i, j| {
                Complex64::new(
                    2e7 * ((i * 3 + j) as f64 * 0.41).cos()
                        - 3.0 * omega * omega * (i == j) as u8 as f64,
                    50.0 * omega * ((i + j) as f64).sin(),
                )
            });
            let b = DMatrix::from_fn(4, 3, |i, k| {
                Complex64::new(
                    omega * omega * (0.3 + 0.1 * ((3 * i + 5 * k) as f64 * 0.7).cos()),
                    0.05 * omega * omega,
                )
            });
            let t = (a, b);
            let q = pr.predict(omega, &t, &theta, false).unwrap().q;
            let qm: Vec<Complex64> = q
                .iter()
                .enumerate()
                .map(|(c, z)| z * Complex64::new(1.0 + 0.01 * c as f64, -0.02))
                .collect();
            samples.push(Sample { omega, q: qm });
            terms.push(t);
        }
        (pr, theta, samples, terms)
    }

    #[test]
    fn normal_equations_equal_those_of_the_jacobian() {
        for st in [Structure::physical(2), Structure::paper(1)] {
            let (pr, theta, samples, terms) = problem(st);
            let data = Data::new(&pr, &samples, &terms, 1e-6);
            let (fast, w) = pass(&data, WeightsFrom::Prediction, &theta, true).unwrap();
            // Reference: explicit Jacobian rows -J / w.
            let np = pr.n_params();
            let mut normal = DMatrix::<f64>::zeros(np, np);
            let mut gradient = DVector::<f64>::zeros(np);
            for ((s, t), wn) in samples.iter().zip(&terms).zip(w.chunks_exact(4)) {
                let p = pr.predict(s.omega, t, &theta, true).unwrap();
                let jac = p.jacobian.unwrap();
                for c in 0..4 {
                    let r = (s.q[c] - p.q[c]) / wn[c];
                    for i in 0..np {
                        let ri = (-jac[(c, i)] / wn[c]).conj();
                        gradient[i] += (ri * r).re;
                        for k in 0..np {
                            normal[(i, k)] += (ri * (-jac[(c, k)] / wn[c])).re;
                        }
                    }
                }
            }
            let scale = normal.amax();
            assert!((&fast.normal - &normal).amax() <= 1e-12 * scale, "{st:?}");
            assert!(
                (&fast.gradient - &gradient).amax() <= 1e-12 * gradient.amax().max(1e-300),
                "{st:?}"
            );
        }
    }

    /// With a runout fitted, its sparse columns give the normal equations
    /// of the explicit Jacobian (`d reading_c / d Re r_c = scale_c`, `/ d
    /// Im r_c = j scale_c`), and the same passes and instrumental-variable
    /// equations as the dense columns.
    #[test]
    fn runout_columns_sparse_equal_the_jacobian_and_the_dense_form() {
        let (pr, theta, samples, terms) = problem(Structure::physical(2));
        let mut data = Data::new(&pr, &samples, &terms, 1e-6);
        let theta = with_runout(&mut data, &theta);
        let (np, na) = (pr.n_params(), data.n_all());
        let runout = data.runout(&theta);
        let (fast, w) = pass(&data, WeightsFrom::Prediction, &theta, true).unwrap();
        let mut normal = DMatrix::<f64>::zeros(na, na);
        let mut gradient = DVector::<f64>::zeros(na);
        for ((s, t), wn) in samples.iter().zip(&terms).zip(w.chunks_exact(4)) {
            let p = pr.predict(s.omega, t, &theta[..np], true).unwrap();
            let jac = p.jacobian.unwrap();
            for c in 0..4 {
                let mut row = vec![Complex64::new(0.0, 0.0); na];
                for (i, o) in row.iter_mut().take(np).enumerate() {
                    *o = jac[(c, i)];
                }
                row[np + 2 * c] = Complex64::new(data.runout_scale[c], 0.0);
                row[np + 2 * c + 1] = Complex64::new(0.0, data.runout_scale[c]);
                let r = (s.q[c] - p.q[c] - runout[c]) / wn[c];
                for i in 0..na {
                    let ri = (-row[i] / wn[c]).conj();
                    gradient[i] += (ri * r).re;
                    for k in 0..na {
                        normal[(i, k)] += (ri * (-row[k] / wn[c])).re;
                    }
                }
            }
        }
        let scale = normal.amax();
        assert!((&fast.normal - &normal).amax() <= 1e-12 * scale);
        assert!((&fast.gradient - &gradient).amax() <= 1e-12 * gradient.amax());
        // The dense form of the same columns.
        let mut dense = Data::new(&pr, &samples, &terms, 1e-6);
        dense.runout_scale = data.runout_scale.clone();
        dense.sparse_runout = false;
        let (slow, _) = pass(&dense, WeightsFrom::Prediction, &theta, true).unwrap();
        assert!((&fast.normal - &slow.normal).amax() <= 1e-13 * scale);
        assert!((&fast.gradient - &slow.gradient).amax() <= 1e-13 * gradient.amax());
        assert_eq!(fast.cost, slow.cost);
        let (c_fast, iv_fast) = iv_system(&data, &theta).unwrap();
        let (c_slow, iv_slow) = iv_system(&dense, &theta).unwrap();
        assert_eq!(c_fast, c_slow);
        assert_eq!(iv_fast.shape(), (na, na + 1));
        // Column by column: the runout's columns are far smaller than the
        // model's.
        for j in 0..=na {
            let (a, b) = (iv_fast.column(j), iv_slow.column(j));
            assert!((a - b).amax() <= 1e-13 * b.amax(), "{j}");
        }
    }

    /// The kept rows reweighed to other weights give the pass under those
    /// weights, and their leverages are the diagonal of the hat matrix
    /// `X (X^T X)^-1 X^T` formed densely.
    #[test]
    fn kept_rows_reweigh_and_give_the_leverages() {
        kept_rows_check(false);
        kept_rows_check(true);
    }

    /// A runout of a few per cent of the readings on the four channels of
    /// [`problem`]: its scale and the parameters with it.
    fn with_runout(data: &mut Data<'_>, theta: &[f64]) -> Vec<f64> {
        data.runout_scale = vec![1e-8, 2e-8, 1.5e-8, 1e-8];
        let mut t = theta.to_vec();
        t.extend([0.4, -0.3, 0.1, 0.2, -0.5, 0.6, 0.3, 0.0]);
        t
    }

    fn kept_rows_check(runout: bool) {
        let (pr, theta, samples, terms) = problem(Structure::physical(1));
        let nq = 4;
        let n_all = samples.len() * nq;
        let mut data = Data::new(&pr, &samples, &terms, 1e-6);
        data.keep_rows = true;
        let theta = if runout {
            with_runout(&mut data, &theta)
        } else {
            theta
        };
        let (p, w) = data.reweighted(&theta, true).unwrap();
        // Other weights: a floor in relative units on every channel.
        let noise = NoiseModel {
            floor_m: vec![3e-7; nq],
            relative: 0.01,
            source: NoiseSource::Given,
        };
        data.weighting.set_noise(&noise);
        let w_new: Vec<f64> = (0..n_all)
            .map(|i| {
                data.weighting
                    .weight(i, i % nq, Complex64::new(p.read[i], 0.0))
            })
            .collect();
        let (direct, w_direct) = data.reweighted(&theta, true).unwrap();
        for (a, b) in w_new.iter().zip(&w_direct) {
            assert!((a - b).abs() <= 1e-14 * b, "{a} {b}");
        }
        let rows = p.rows.clone();
        let na = data.n_all();
        let re = reweigh(p, &w, &w_new, na);
        let scale = direct.normal.amax();
        assert!((&re.normal - &direct.normal).amax() <= 1e-12 * scale);
        assert!((&re.gradient - &direct.gradient).amax() <= 1e-12 * direct.gradient.amax());
        assert!((re.cost - direct.cost).abs() <= 1e-12 * direct.cost);
        // Leverages against the dense hat matrix of the original rows.
        let mut x = DMatrix::<f64>::zeros(2 * n_all, na);
        let mut r0 = 0;
        for b in &rows {
            let v = b.dense(na);
            x.view_mut((r0, 0), (b.k, na)).copy_from(&v.columns(0, na));
            r0 += b.k;
        }
        assert_eq!(r0, 2 * n_all);
        // Hat diagonal from a thin QR (orthogonal, unlike an inverse of
        // the normal equations): row norms of Q.
        let q = x.qr().q();
        let (p2, _) = data.pass(WeightsFrom::Given(&w), &theta, true).unwrap();
        let points = residual_points(&data, &p2, &leverages_screened(&data, &p2, 0.0));
        let nq = points.0.len();
        assert_eq!(points.0.iter().map(Vec::len).sum::<usize>(), n_all);
        let mut total = 0.0;
        let mut exact = Vec::new();
        for i in 0..n_all {
            let [a, b, x] = points.0[i % nq][i / nq];
            let h = 0.5 * (q.row(2 * i).norm_squared() + q.row(2 * i + 1).norm_squared());
            let expect = p2.error[i].powi(2) / (1.0 - h).max(1e-3);
            assert!((x - expect).abs() <= 1e-9 * expect.max(1e-300), "{i}");
            assert_eq!(a, 1.0);
            assert_eq!(b, p2.read[i].powi(2));
            total += 2.0 * h;
            exact.push(h);
        }
        // The leverages add up to the number of parameters.
        assert!((total - na as f64).abs() < 1e-8 * na as f64, "{total}");
        // Every block screened: each sample takes its block's mean, and the
        // block's sum is that of the exact leverages (from its kept share
        // of the normal equations).
        let mean = leverages_screened(&data, &p2, f64::INFINITY);
        assert_eq!(p2.rows.len(), 3);
        let mut i0 = 0;
        for b in &p2.rows {
            let ns = b.k / 2;
            let block = &mean[i0..i0 + ns];
            assert!(block.iter().all(|h| *h == block[0]));
            let sum: f64 = exact[i0..i0 + ns].iter().sum();
            assert!((block[0] * ns as f64 - sum).abs() <= 1e-9 * sum, "{sum}");
            i0 += ns;
        }
        assert_eq!(i0, n_all);
    }
}
