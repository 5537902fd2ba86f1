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
//! the known optimum in the tests.
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
}

/// Accumulated normal equations of one pass at fixed weights.
struct Pass {
    /// `Re(J^H J)`.
    normal: DMatrix<f64>,
    /// `Re(J^H r)`.
    gradient: DVector<f64>,
    /// `S`.
    cost: f64,
}

/// The parameters' entries at every sample's speed.
fn speed_entries(pr: &Predictor, samples: &[Sample]) -> Vec<Vec<Entry>> {
    samples.iter().map(|s| pr.entries(s.omega)).collect()
}

/// What every pass reads: the model, the samples, their terms and the
/// parameters' entries at their speeds, and the weight floors.
struct Data<'a> {
    pr: &'a Predictor,
    samples: &'a [Sample],
    terms: &'a [Terms],
    entries: Vec<Vec<Entry>>,
    floors: Vec<f64>,
}

impl<'a> Data<'a> {
    fn new(pr: &'a Predictor, samples: &'a [Sample], terms: &'a [Terms], floor: f64) -> Self {
        Data {
            pr,
            samples,
            terms,
            entries: speed_entries(pr, samples),
            floors: floors(samples, floor),
        }
    }

    /// [`pass`] with weights from this pass's own prediction.
    fn reweighted(&self, theta: &[f64], jacobian: bool) -> Result<(Pass, Vec<f64>), PredictError> {
        self.pass(WeightsFrom::Prediction(&self.floors), theta, jacobian)
    }

    fn pass(
        &self,
        weights: WeightsFrom<'_>,
        theta: &[f64],
        jacobian: bool,
    ) -> Result<(Pass, Vec<f64>), PredictError> {
        pass(
            self.pr,
            self.samples,
            self.terms,
            &self.entries,
            weights,
            theta,
            jacobian,
        )
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
    /// This pass's own prediction, with these floors (a reweighting).
    Prediction(&'a [f64]),
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
struct Rows {
    nq: usize,
    npl: usize,
    np: usize,
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
}

/// Multiple to which [`Rows`] pads its columns (the tile of the widest
/// kernel of `matrixmultiply`, 8 x 8 with AVX-512).
const PAD: usize = 8;

impl Rows {
    fn new(nq: usize, npl: usize, np: usize, instruments: bool) -> Self {
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
        let (k, cap) = (self.filled, self.cap);
        if k == 0 {
            return;
        }
        // Without instruments the first lw columns of [X y] (X, then y or
        // padding) stand for Z; the rows of out past np are not read.
        let left = if self.z.is_empty() { &self.x } else { &self.z };
        let zt = DMatrixView::from_slice_with_strides(left, self.lw, k, cap, 1);
        let xy = DMatrixView::from_slice_with_strides(&self.x, k, self.rw, 1, cap);
        self.out.gemm(1.0, &zt, &xy, 1.0);
        self.filled = 0;
    }

    /// `Z^T [X y]` over every speed (`np x (np + 1)`).
    fn finish(mut self) -> DMatrix<f64> {
        self.flush();
        debug_assert_eq!(self.y.len(), self.nq * (self.nq + self.npl));
        self.out.view((0, 0), (self.np, self.np + 1)).into_owned()
    }
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
    pr: &Predictor,
    samples: &[Sample],
    terms: &[Terms],
    entries: &[Vec<Entry>],
    weights: WeightsFrom<'_>,
    theta: &[f64],
    jacobian: bool,
) -> Result<(Pass, Vec<f64>), PredictError> {
    let np = pr.n_params();
    let (nq, npl) = (2 * pr.param.n_bearings(), pr.param.n_planes());
    if theta.len() != np || entries.iter().any(|en| en.len() != np) {
        return Err(PredictError::Dimension);
    }
    let mut solve = Solve::new(nq, npl);
    let mut rows = jacobian.then(|| Rows::new(nq, npl, np, false));
    let mut r = vec![Complex64::new(0.0, 0.0); nq];
    let mut cost = 0.0;
    let mut used = Vec::with_capacity(samples.len() * nq);
    for (n, ((s, t), en)) in samples.iter().zip(terms).zip(entries).enumerate() {
        solve.run(s.omega, t, en, theta)?;
        let w0 = used.len();
        match weights {
            WeightsFrom::Given(w) => used.extend_from_slice(&w[n * nq..(n + 1) * nq]),
            WeightsFrom::Prediction(floors) => {
                used.extend(solve.q.iter().zip(floors).map(|(q, f)| q.norm().max(*f)))
            }
        }
        let wn = &used[w0..];
        for (c, rc) in r.iter_mut().enumerate() {
            let d2 = 1.0 / (wn[c] * wn[c]);
            let ec = s.q[c] - solve.q[c];
            cost += ec.norm_sqr() * d2;
            *rc = ec / wn[c];
        }
        if let Some(rows) = rows.as_mut() {
            rows.set_speed(&solve.h_inv, t.1.as_slice(), wn);
            rows.columns(false, en, &solve.q);
            rows.extra(&r);
            rows.advance();
        }
    }
    let (normal, gradient) = match rows {
        Some(rows) => {
            let out = rows.finish();
            let mut normal = out.columns(0, np).into_owned();
            for i in 0..np {
                for k in 0..i {
                    normal[(i, k)] = normal[(k, i)];
                }
            }
            (normal, -out.column(np))
        }
        None => (DMatrix::zeros(np, np), DVector::zeros(np)),
    };
    Ok((
        Pass {
            normal,
            gradient,
            cost,
        },
        used,
    ))
}

/// The equations of one refined-instrumental-variable pass at `theta`
/// (see the module documentation), `Re(Z^H X) theta' = Re(Z^H y_0)` with
/// the weighted instruments `Z` and regressors `X` of [`Rows`] and
/// `y_0 = D H^-1 A q_meas` (`np x (np + 1)`: `[Re(Z^H X), Re(Z^H y_0)]`),
/// and `S` at `theta` with the weights of this prediction (the same
/// number as [`Data::reweighted`]'s: the pass that checks one step's
/// result sets up the next step).
fn iv_system(data: &Data<'_>, theta: &[f64]) -> Result<(f64, DMatrix<f64>), PredictError> {
    let (pr, floors) = (data.pr, &data.floors);
    let np = pr.n_params();
    let (nq, npl) = (2 * pr.param.n_bearings(), pr.param.n_planes());
    if theta.len() != np {
        return Err(PredictError::Dimension);
    }
    let mut cost = 0.0;
    let mut solve = Solve::new(nq, npl);
    let mut rows = Rows::new(nq, npl, np, true);
    let zero = Complex64::new(0.0, 0.0);
    let (mut w, mut aq, mut y0) = (vec![0.0; nq], vec![zero; nq], vec![zero; nq]);
    for ((s, t), entries) in data.samples.iter().zip(data.terms).zip(&data.entries) {
        let (a, b) = t;
        solve.run(s.omega, t, entries, theta)?;
        for ((wc, q), f) in w.iter_mut().zip(&solve.q).zip(floors) {
            *wc = q.norm().max(*f);
        }
        for (c, wc) in w.iter().enumerate() {
            let d2 = 1.0 / (wc * wc);
            cost += (s.q[c] - solve.q[c]).norm_sqr() * d2;
        }
        rows.set_speed(&solve.h_inv, b.as_slice(), &w);
        // Instruments from the prediction, regressors from the measurement.
        rows.columns(true, entries, &solve.q);
        rows.columns(false, entries, &s.q);
        // y_0 = D H^-1 A q_meas.
        aq.fill(zero);
        for (ac, qc) in a.as_slice().chunks_exact(nq).zip(&s.q) {
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
        for (yc, wc) in y0.iter_mut().zip(&w) {
            *yc /= wc;
        }
        rows.extra(&y0);
        rows.advance();
    }
    Ok((cost, rows.finish()))
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

/// Levenberg-Marquardt at fixed weights; returns the new `theta`, the
/// iterations and whether the tolerance was met.
fn levenberg_marquardt(
    data: &Data<'_>,
    w: &[f64],
    start: (Vec<f64>, Pass),
    opts: &OutputErrorOptions,
) -> Result<(Vec<f64>, usize, bool), OutputErrorError> {
    let np = data.pr.n_params();
    let (mut theta, mut cur) = start;
    let n = data.samples.len() * data.samples.first().map_or(0, |s| s.q.len());
    if cur.cost <= PERFECT * n as f64 {
        return Ok((theta, 0, true));
    }
    let max_diag = (0..np).map(|i| cur.normal[(i, i)]).fold(0.0, f64::max);
    if max_diag.is_nan() || max_diag <= 0.0 {
        return Err(OutputErrorError::Singular);
    }
    let mut mu = 1e-6 * max_diag;
    let mut nu = 2.0;
    for it in 1..=opts.max_iterations {
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
        let delta = chol.solve(&(-&cur.gradient));
        let trial: Vec<f64> = theta.iter().zip(delta.iter()).map(|(t, d)| t + d).collect();
        // The trial's cost decides; its normal equations are formed only
        // when the iteration goes on from it.
        let next = match data.pass(WeightsFrom::Given(w), &trial, false) {
            Ok((p, _)) => p.cost,
            Err(_) => {
                mu *= nu;
                nu *= 2.0;
                continue;
            }
        };
        // Predicted reduction of S/2: -G.delta - delta.N.delta/2.
        let nd = &cur.normal * &delta;
        let predicted = -cur.gradient.dot(&delta) - 0.5 * delta.dot(&nd);
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
                return Ok((theta, it, true));
            }
            cur = data.pass(WeightsFrom::Given(w), &theta, true)?.0;
            mu *= (1.0 - (2.0 * rho - 1.0).powi(3)).max(1.0 / 3.0);
            nu = 2.0;
        } else {
            mu *= nu;
            nu *= 2.0;
            if step < opts.tolerance {
                return Ok((theta, it, true));
            }
        }
    }
    Ok((theta, opts.max_iterations, false))
}

/// The output-error fit of `samples` (with their reduced `terms`, one per
/// sample) from the start `start` (scaled weights, e.g. the QRD/RLS
/// estimate).
pub fn fit_output_error(
    pr: &Predictor,
    samples: &[Sample],
    terms: &[Terms],
    start: &[Complex64],
    opts: &OutputErrorOptions,
) -> Result<OutputErrorFit, OutputErrorError> {
    let nq = 2 * pr.param.n_bearings();
    if samples.len() != terms.len() || samples.iter().any(|s| s.q.len() != nq) {
        return Err(OutputErrorError::Dimension);
    }
    let n = samples.len() * nq;
    let np = pr.n_params();
    if 2 * n <= np {
        return Err(OutputErrorError::TooFewEquations {
            equations: 2 * n,
            params: np,
        });
    }
    let data = Data::new(pr, samples, terms, opts.floor);
    let mut theta = pr.theta(start);
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
        if cost <= PERFECT * n as f64 {
            break;
        }
        let Some(sys) = system.take() else { break };
        let t = match solve_iv(sys) {
            Ok(t) => t,
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
    for _ in 0..opts.reweightings.max(1) {
        let (cur, w) = match fresh.take() {
            Some(f) => f,
            None => data.reweighted(&theta, true)?,
        };
        let (t, it, ok) = levenberg_marquardt(&data, &w, (theta, cur), opts)?;
        theta = t;
        iterations += it;
        converged = ok;
    }
    let (fin, _) = data.reweighted(&theta, true)?;
    let dof = n as f64 - np as f64 / 2.0;
    let residual_noise = (fin.cost / dof).sqrt();
    let inv = fin
        .normal
        .clone()
        .cholesky()
        .map(|c| c.inverse())
        .ok_or(OutputErrorError::Singular)?;
    let covariance = inv * (residual_noise * residual_noise / 2.0);
    Ok(OutputErrorFit {
        weights: pr.weights(&theta),
        theta,
        covariance,
        residual: (fin.cost / n as f64).sqrt(),
        residual_noise,
        iterations,
        converged,
    })
}

/// The Fisher information of `theta` per unit noise, `2 Re(J^H J)` with
/// `J = (dq/dtheta) / |q|` at `theta` (floored as in the fit): divide by
/// `s^2` for the information of data with relative noise `s`. Its inverse
/// times `s^2` is the Cramér-Rao bound on the covariance of any unbiased
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
    let (p, _) = Data::new(pr, samples, terms, floor).reweighted(theta, true)?;
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
    let theta = pr.theta(w);
    let (p, _) = Data::new(pr, samples, terms, floor).reweighted(&theta, false)?;
    let n = (samples.len() * samples[0].q.len()) as f64;
    let dof = (n - pr.n_params() as f64 / 2.0).max(1.0);
    Ok(((p.cost / n).sqrt(), (p.cost / dof).sqrt()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimate::parametrization::Parametrization;
    use rotorid_core::parametrization::Structure;
    use rotorid_core::scaling::ColumnScaling;

    #[test]
    fn normal_equations_equal_those_of_the_jacobian() {
        for st in [Structure::physical(2), Structure::paper(1)] {
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
            // More speeds than a block of rows holds, the last block part-filled.
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
                        omega * omega * (0.3 + 0.1 * (i + k) as f64),
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
            let floors = floors(&samples, 1e-6);
            let entries = speed_entries(&pr, &samples);
            let (fast, w) = pass(
                &pr,
                &samples,
                &terms,
                &entries,
                WeightsFrom::Prediction(&floors),
                &theta,
                true,
            )
            .unwrap();
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
}
