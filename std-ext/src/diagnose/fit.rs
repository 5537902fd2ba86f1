//! Weighted least squares of measured against predicted probe readings,
//! for any [`ExtendedModel`]: one objective for every hypothesis.
//!
//! # Objective
//!
//! With the weights `w_(n,c) = max(|y_meas,(n,c)|, f_c)` fixed by the data
//! (proportional noise, SPEC section 4; the floor `f_c = 1e-3 x RMS_n
//! |y_meas,(n,c)|` guards vanishing readings) and the same for every
//! model,
//!
//! ```text
//!     S(theta) = sum_(n,c) |y_meas,(n,c) - y_(n,c)(theta)|^2 / w_(n,c)^2 ,
//!     residual = sqrt(S / N)         (N complex readings),
//! ```
//!
//! the relative RMS misfit: the noise level `s` when the model fits
//! (each real and imaginary part then has variance `s^2 / 2`). Because
//! the weights do not depend on the model, the `S` of two models are
//! comparable (likelihood ratio).
//!
//! # Iteration
//!
//! Levenberg-Marquardt on the scaled parameters: normal equations
//! `(J^T J + mu D) dx = J^T r` (`D` the diagonal of `J^T J`), Cholesky,
//! `mu` divided by 3 after a step that lowers `S`, multiplied by 4
//! otherwise; stop when `S` falls by less than `1e-9` relative (a change of
//! `1e-9 N` in chi-square, far below any decision threshold) or the
//! scaled step is below `1e-7`.
//!
//! A fit may also stop *stalled*: when the data carry a noise level `s`
//! ([`FitData::with_noise_level`]), `S` is still above [`STALL_MISFIT`]
//! times its noise floor `S_0 = (2N - P) s^2 / 2` (an RMS misfit over three
//! times the noise), and the last [`STALL_WINDOW`] iterations lowered `S`
//! by less than [`STALL_DROP`] of it in all. Such a model misfits the data
//! whatever its exact minimum: its parameters wander off along a valley
//! (a pedestal fitted to a runout, a stiffness a thousand times the
//! bearing's) while `S` creeps down by a few hundredths of a percent per
//! step, to the iteration limit. The decisions taken on it (significant
//! against the nominal model, misfit above the noise) are the same at its
//! minimum: at most a further `~2 STALL_DROP` of `S` (about ten more
//! windows at the same rate) stands against a factor [`STALL_MISFIT`] /
//! [`crate::diagnose::MISFIT_CHI2`] = 5 to the misfit threshold. A model
//! this far from the noise is never the answer alone (the choice goes on
//! to the pairs, which start from its fit, or to `unexplained`); a fit
//! that converges to the noise is never stopped this way. On the three-bearing
//! rotor's cases, these settings (before: 100 and `1e-2`) cut the
//! iterations of a diagnosis by up to three quarters (2068 to 620 on a
//! pedestal case).
//!
//! A stop at the rate instead (where `S`, at the last window's rate, would
//! still be above [`STALL_MISFIT`] times the floor at the iteration limit)
//! is not safe: on a three-bearing case of a distributed unbalance it cut
//! the fit of a pair of extra planes at 4.4 times the noise, which without
//! it creeps on, then falls to the noise.
//!
//! At the other end, with the noise level known, a fit also stops
//! *converged* when the last [`STALL_WINDOW`] iterations lowered `S` by
//! less than [`FLAT_DROP`] `sigma_0^2` (`sigma_0^2 = s^2 / 2`, the noise
//! variance of one real reading): a change of `1e-3` in chi-square, where
//! every decision threshold is above 10. This ends the fits that wander
//! along a direction the data do not determine (a pedestal's mass on data
//! without one) instead of running to the iteration limit. A fit that
//! converges linearly at a rate of 0.99 per iteration stops within about
//! 0.2 standard deviations of its minimum; a faster one far closer.
//!
//! # Known minima
//!
//! A search that restarts a hypothesis from several points (the pedestal's
//! profile starts and its restarts with the frequencies apart, the speed
//! law's two starts) often sees a restart return to a minimum it has
//! already found, after as many iterations as the first fit took.
//! [`fit_known`] ends such a restart as soon as it is in that minimum's
//! basin: where `S` and its quadratic model about the known end,
//! `S_k + d^T J_k^T J_k d` (`d = theta - theta_k`), both lie within
//! [`KNOWN_BASIN`] noise variances of `S_k`, the fit goes on to `theta_k`
//! to within that, and the known fit is returned. A known fit counts when a
//! stopping test ended it (converged, or stalled far above the noise), not
//! the iteration limit. The restart can no longer end a fraction of a
//! noise variance below the known fit at the same minimum; every decision
//! threshold is above ten. On the three-bearing rotor's speed-law case it
//! cut the pedestal search's full fits from 293 iterations to 202.
//!
//! # Behind a fit at the noise
//!
//! The bank fits its families in three groups: the short ones (the
//! runout, the probe gains), then the node effects, then the long ones
//! (the speed law, the pedestal, the shaft's stiffness). Once a group has
//! a fit that explains the data to the noise
//! ([`crate::diagnose::NOISE_CHI2`]), a later hypothesis can change the
//! diagnosis only by ending within a tie of that fit (9.2 noise
//! variances) or below it by BIC: within about [`NOISE_CHI2`] times its
//! own noise floor. On such data ([`FitData::explained`]) a fit that has
//! run a [`STALL_WINDOW`] stops stalled when `S` is still above
//! [`STALL_MISFIT`] times its floor, however fast it falls, or when, at
//! the last window's rate of fall for the iterations it has left, it would
//! still be above [`NOISE_CHI2`] times the floor at its iteration limit
//! (`behind`); the shaft modulus' rounds end at such a fit. From the
//! nominal estimate with its effect at zero, a hypothesis that explains
//! the data makes its largest fall in its first steps and is below both
//! bounds within the window (test
//! `a_fit_behind_one_at_the_noise_stops_at_its_first_window`). What is
//! given up: a hypothesis that would creep and then fall to the noise, on
//! data another family already explains to the noise; its `S` in the
//! report is then an upper bound, as for every stalled fit. The pedestal
//! search is not stopped this way: its fits cross the rotor's resonances
//! and can creep from twenty times the noise floor before they fall to it
//! (a paper-rotor probe-gain case), and a search whose fits end above the
//! noise goes on to more starts.
//!
//! # Covariance
//!
//! `cov(theta) = sigma^2 (J^T J)^-1`, `sigma^2 = S / (2N - P)` (the
//! variance of one real part, `s^2 / 2`).

use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;

use crate::diagnose::context::NOISE_CHI2;
use crate::diagnose::extended::{Eval, ExtendedModel};
use crate::diagnose::terms::SpeedTerms;
use crate::estimate::output_error::stalled;
use crate::estimate::predictor::{Entry, PredictError};
use crate::io::measurement::Sample;

/// Weight floor relative to a channel's RMS reading.
pub const FLOOR: f64 = 1e-3;

/// The stall rule's settings, shared with the output-error starts
/// ([`crate::estimate::output_error::FitNoise::stall`]): `S` over its noise
/// floor above which a fit may stop stalled (module documentation, an RMS
/// misfit `sqrt(10)` times the noise); the iterations over which it fell
/// by less than the relative [`STALL_DROP`].
pub use crate::estimate::output_error::{STALL_DROP, STALL_MISFIT, STALL_WINDOW};

/// Fall of `S` over [`STALL_WINDOW`] iterations, in units of the noise
/// variance of one real reading, below which a fit has converged.
pub const FLAT_DROP: f64 = 1e-3;

/// Data of the fits: readings, terms and the fixed weights.
#[derive(Debug, Clone)]
pub struct FitData<'a> {
    /// The measured samples.
    pub samples: &'a [Sample],
    /// Readings of the probes at other nodes per sample (empty: none),
    /// appended to each sample's bearing channels.
    pub node_q: &'a [Vec<Complex64>],
    /// The terms at each sample's speed.
    pub terms: &'a [SpeedTerms],
    /// The readings of every sample: bearing channels, then node probes
    /// (m), joined once.
    pub readings: Vec<Vec<Complex64>>,
    /// `1 / w_(n,c)`.
    pub inv_w: Vec<Vec<f64>>,
    /// The relative noise level `s` of the readings, when known: lets a
    /// fit far above it stop stalled, and one at it stop where `S` no
    /// longer moves in chi-square (module documentation).
    pub noise_level: Option<f64>,
    /// The probes' noise floor per reading channel in relative units,
    /// `phi_c = f_c / s` (m; empty: proportional noise), see
    /// [`FitData::with_floors`].
    pub phi: Vec<f64>,
    /// Whether another hypothesis already explains these data to the
    /// noise: a fit that could not come near it then stops after its
    /// first stall window (module documentation, "Behind a fit at the
    /// noise").
    pub explained: bool,
}

impl<'a> FitData<'a> {
    /// The data with the weights of the module documentation.
    pub fn new(samples: &'a [Sample], terms: &'a [SpeedTerms]) -> Self {
        Self::with_probes(samples, &[], terms)
    }

    /// [`FitData::new`] with the readings of probes at other nodes
    /// (`node_q[n]`: `y, z` per probe node at sample `n`; empty: none),
    /// weighted the same way.
    pub fn with_probes(
        samples: &'a [Sample],
        node_q: &'a [Vec<Complex64>],
        terms: &'a [SpeedTerms],
    ) -> Self {
        let readings: Vec<Vec<Complex64>> = samples
            .iter()
            .enumerate()
            .map(|(k, s)| {
                let mut y = s.q.clone();
                if let Some(x) = node_q.get(k) {
                    y.extend_from_slice(x);
                }
                y
            })
            .collect();
        let nq = readings.first().map_or(0, Vec::len);
        let n = samples.len().max(1) as f64;
        let floor: Vec<f64> = (0..nq)
            .map(|c| {
                let ms = readings
                    .iter()
                    .map(|y| y.get(c).map_or(0.0, |z| z.norm_sqr()))
                    .sum::<f64>()
                    / n;
                FLOOR * ms.sqrt()
            })
            .collect();
        let inv_w = readings
            .iter()
            .map(|y| {
                y.iter()
                    .zip(&floor)
                    .map(|(q, f)| {
                        let w = q.norm().max(*f);
                        if w > 0.0 && w.is_finite() {
                            1.0 / w
                        } else {
                            0.0
                        }
                    })
                    .collect()
            })
            .collect();
        FitData {
            samples,
            node_q,
            terms,
            readings,
            inv_w,
            noise_level: None,
            phi: Vec::new(),
            explained: false,
        }
    }

    /// The same data weighted for a probe noise floor (SPEC section 7):
    /// `w_(n,c) = sqrt(|y_meas,(n,c)|^2 + phi_c^2)`, `phi_c = f_c / s` the
    /// floor in the relative units of `S` (so `S / N` stays `s^2` when the
    /// model fits). Channels past `phi`'s end (probes at other nodes) take
    /// the mean of `phi`. Empty or all-zero `phi`: unchanged.
    pub fn with_floors(mut self, phi: &[f64]) -> Self {
        if phi.iter().all(|p| *p <= 0.0) {
            return self;
        }
        let mean = phi.iter().sum::<f64>() / phi.len() as f64;
        for (y, iw) in self.readings.iter().zip(&mut self.inv_w) {
            for (c, (q, o)) in y.iter().zip(iw.iter_mut()).enumerate() {
                let p = phi.get(c).copied().unwrap_or(mean);
                let w = q.norm().hypot(p);
                *o = if w > 0.0 && w.is_finite() {
                    1.0 / w
                } else {
                    0.0
                };
            }
        }
        self.phi = phi.to_vec();
        self
    }

    /// The same data with the relative noise level `s` of its readings
    /// (a model-free estimate, [`crate::estimate::noise`]): fits far above
    /// it may stop stalled. Ignored unless finite and positive.
    pub fn with_noise_level(mut self, s: Option<f64>) -> Self {
        self.noise_level = s.filter(|x| x.is_finite() && *x > 0.0);
        self
    }

    /// The same data, marked as explained to the noise by another
    /// hypothesis ([`FitData::explained`]).
    pub fn with_explained(mut self, explained: bool) -> Self {
        self.explained = explained;
        self
    }

    /// These data at the samples `keep` only (indices, in order), each
    /// row with its weights as they are: the data of a screening on fewer
    /// speeds. `samples`, `node_q` and `terms` are those samples', their
    /// node probes' readings (empty: none) and their terms, in the order
    /// of `keep`. `None` when an index is out of range or the lengths
    /// differ.
    pub fn rows<'b>(
        &self,
        keep: &[usize],
        samples: &'b [Sample],
        node_q: &'b [Vec<Complex64>],
        terms: &'b [SpeedTerms],
    ) -> Option<FitData<'b>> {
        let n = self.readings.len();
        if keep.iter().any(|&k| k >= n)
            || samples.len() != keep.len()
            || terms.len() != keep.len()
            || !(node_q.is_empty() || node_q.len() == keep.len())
        {
            return None;
        }
        Some(FitData {
            samples,
            node_q,
            terms,
            readings: keep.iter().map(|&k| self.readings[k].clone()).collect(),
            inv_w: keep.iter().map(|&k| self.inv_w[k].clone()).collect(),
            noise_level: self.noise_level,
            phi: self.phi.clone(),
            explained: self.explained,
        })
    }

    /// Number of real equations `2 N`.
    pub fn n_equations(&self) -> usize {
        2 * self.inv_w.iter().map(Vec::len).sum::<usize>()
    }
}

/// A fitted model.
#[derive(Debug, Clone, PartialEq)]
pub struct Fit {
    /// The scaled parameters.
    pub theta: Vec<f64>,
    /// `S` at `theta`.
    pub s: f64,
    /// Real equations `2 N`.
    pub n: usize,
    /// `sigma^2 (J^T J)^-1`, when `J^T J` is invertible.
    pub covariance: Option<DMatrix<f64>>,
    /// Iterations done.
    pub iterations: usize,
    /// Whether the stopping test was met.
    pub converged: bool,
    /// Whether it stopped stalled far above the noise (module
    /// documentation): `S` is then an upper bound of its minimum.
    pub stalled: bool,
}

impl Fit {
    /// Number of parameters.
    pub fn n_params(&self) -> usize {
        self.theta.len()
    }

    /// Relative RMS misfit `sqrt(S / N)`.
    pub fn residual(&self) -> f64 {
        (2.0 * self.s / self.n as f64).sqrt()
    }

    /// `sigma^2 = S / (2N - P)`.
    pub fn sigma2(&self) -> f64 {
        self.s / (self.n.saturating_sub(self.n_params()).max(1)) as f64
    }

    /// Standard deviation of parameter `i`.
    pub fn std(&self, i: usize) -> Option<f64> {
        self.covariance.as_ref().map(|c| c[(i, i)].max(0.0).sqrt())
    }
}

/// Weighted residuals and, if asked, the Jacobian of the predictions.
pub fn evaluate(
    model: &ExtendedModel,
    data: &FitData<'_>,
    entries: &[Vec<Entry>],
    theta: &[f64],
    jacobian: bool,
) -> Result<(DVector<f64>, Option<DMatrix<f64>>), PredictError> {
    if !jacobian {
        return residuals(model, data, entries, theta).map(|(r, _)| (r, None));
    }
    let (r, evals) = residuals(model, data, entries, theta)?;
    let j = jacobian_from(model, data, entries, theta, evals)?;
    Ok((r, Some(j)))
}

/// The weighted residuals at `theta` and the Jacobian's columns `cols`
/// only (in that order): the same numbers, bit for bit, as those columns
/// of [`evaluate`]'s Jacobian, at a fraction of its cost when `cols` are
/// few (a profile solving for the unbalance at many points).
pub fn evaluate_columns(
    model: &ExtendedModel,
    data: &FitData<'_>,
    entries: &[Vec<Entry>],
    theta: &[f64],
    cols: &[usize],
) -> Result<(DVector<f64>, DMatrix<f64>), PredictError> {
    let p = model.n_params();
    if cols.iter().any(|&c| c >= p) {
        return Err(PredictError::Dimension);
    }
    let (r, evals) = residuals(model, data, entries, theta)?;
    let mut want = vec![false; p];
    for &c in cols {
        want[c] = true;
    }
    let j = jacobian_columns(model, data, entries, theta, evals, cols, Some(&want))?;
    Ok((r, j))
}

/// The number of readings per sample, checked against every sample's
/// readings, terms and weights.
fn outputs(model: &ExtendedModel, data: &FitData<'_>) -> Result<usize, PredictError> {
    let nq = data.terms.first().map_or(0, |st| model.n_outputs(st));
    let ok = data.readings.len() == data.terms.len()
        && data.inv_w.len() == data.terms.len()
        && data
            .readings
            .iter()
            .zip(data.terms)
            .zip(&data.inv_w)
            .all(|((m, st), w)| m.len() == nq && model.n_outputs(st) == nq && w.len() == nq);
    if ok {
        Ok(nq)
    } else {
        Err(PredictError::Dimension)
    }
}

/// Weighted residuals at `theta` and the evaluation at every speed, from
/// which [`jacobian_from`] forms the Jacobian at the same `theta`
/// without evaluating the model again.
fn residuals(
    model: &ExtendedModel,
    data: &FitData<'_>,
    entries: &[Vec<Entry>],
    theta: &[f64],
) -> Result<(DVector<f64>, Vec<Eval>), PredictError> {
    let nq = outputs(model, data)?;
    let mut r = DVector::zeros(data.n_equations());
    let mut evals = Vec::with_capacity(data.terms.len());
    for (k, (meas, st)) in data.readings.iter().zip(data.terms).enumerate() {
        let ev = model.evaluate(st, &entries[k], theta)?;
        let y = ev.readings();
        for c in 0..nq {
            let row = 2 * (k * nq + c);
            let d = (meas[c] - y[c]) * data.inv_w[k][c];
            r[row] = d.re;
            r[row + 1] = d.im;
        }
        evals.push(ev);
    }
    Ok((r, evals))
}

/// The weighted Jacobian (real rows: `Re`, `Im` of each reading) at the
/// `theta` of `evals` ([`residuals`]).
fn jacobian_from(
    model: &ExtendedModel,
    data: &FitData<'_>,
    entries: &[Vec<Entry>],
    theta: &[f64],
    evals: Vec<Eval>,
) -> Result<DMatrix<f64>, PredictError> {
    let all: Vec<usize> = (0..model.n_params()).collect();
    jacobian_columns(model, data, entries, theta, evals, &all, None)
}

/// [`jacobian_from`]'s columns `cols` (in that order), formed from the
/// model's columns `want` ([`ExtendedModel::predict_columns`]; `None`:
/// all).
fn jacobian_columns(
    model: &ExtendedModel,
    data: &FitData<'_>,
    entries: &[Vec<Entry>],
    theta: &[f64],
    evals: Vec<Eval>,
    cols: &[usize],
    want: Option<&[bool]>,
) -> Result<DMatrix<f64>, PredictError> {
    let nq = outputs(model, data)?;
    if evals.len() != data.terms.len() {
        return Err(PredictError::Dimension);
    }
    let p = model.n_params();
    let mut j = DMatrix::zeros(data.n_equations(), cols.len());
    let mut jz = DMatrix::<Complex64>::zeros(nq, p);
    for (k, (ev, st)) in evals.into_iter().zip(data.terms).enumerate() {
        model.predict_columns(ev, st, &entries[k], theta, Some(&mut jz), want)?;
        // Column by column: this speed's `2 nq` rows of a column are
        // contiguous in the column-major `j`.
        let iw = &data.inv_w[k];
        let row0 = 2 * k * nq;
        for (ic, &i) in cols.iter().enumerate() {
            let (zc, mut jc) = (jz.column(i), j.column_mut(ic));
            for c in 0..nq {
                let v = zc[c] * iw[c];
                jc[row0 + 2 * c] = v.re;
                jc[row0 + 2 * c + 1] = v.im;
            }
        }
    }
    Ok(j)
}

/// `J^T J` (`J`: `m x p`), its upper triangle by matrix products of
/// column blocks, `G[0..b1, b0..b1] = J[:, 0..b1]^T J[:, b0..b1]`, and
/// mirrored, so that the result is exactly symmetric. nalgebra hands
/// products of this size to `matrixmultiply`'s blocked kernel (several
/// times faster than column dot products); `J^T` is a strided view of
/// `J`'s own storage, not a copy. Every element is the kernel's sum over
/// the same `k` blocks as in the one product `J^T J`, so it is that
/// product's element bit for bit (test `gram_is_the_product_bit_for_bit`)
/// at about `(1 + b/p)/2` of its work (`b` the block width).
pub fn gram(j: &DMatrix<f64>) -> DMatrix<f64> {
    let (m, p) = j.shape();
    let mut g = if m <= GRAM_SMALL || p <= GRAM_SMALL {
        // nalgebra's own loops, not the kernel, below its threshold.
        j.transpose() * j
    } else {
        let jt = nalgebra::DMatrixView::from_slice_with_strides(j.as_slice(), p, m, m, 1);
        let mut g = DMatrix::zeros(p, p);
        // Blocks wider than nalgebra's small-size threshold (5), so that
        // every product goes to the same kernel as the whole one would; a
        // narrow last block joins the one before it.
        let mut b0 = 0;
        while b0 < p {
            let mut b1 = (b0 + GRAM_BLOCK).min(p);
            if p - b1 < GRAM_BLOCK {
                b1 = p;
            }
            g.view_mut((0, b0), (b1, b1 - b0)).gemm(
                1.0,
                &jt.rows(0, b1),
                &j.columns(b0, b1 - b0),
                0.0,
            );
            b0 = b1;
        }
        g
    };
    // The lower triangle from the upper.
    for a in 0..p {
        for b in a + 1..p {
            g[(b, a)] = g[(a, b)];
        }
    }
    g
}

/// Column-block width of [`gram`].
const GRAM_BLOCK: usize = 12;

/// nalgebra's small-size threshold of a product (`SMALL_DIM` of its
/// `gemm`): at or below it in any dimension a product is not handed to
/// the kernel.
const GRAM_SMALL: usize = 5;

/// The nominal parameters' entries at every speed of `data`.
pub fn entries(model: &ExtendedModel, data: &FitData<'_>) -> Vec<Vec<Entry>> {
    data.terms
        .iter()
        .map(|t| model.pr.entries(t.omega))
        .collect()
}

/// Levenberg-Marquardt from `theta0`, at most `max_iter` iterations.
pub fn fit(
    model: &ExtendedModel,
    data: &FitData<'_>,
    theta0: &[f64],
    max_iter: usize,
) -> Result<Fit, PredictError> {
    fit_with(model, data, theta0, max_iter, true)
}

/// [`fit`]; without `covariance` the Jacobian is not evaluated again at
/// the last point and [`Fit::covariance`] is `None` (a screening fit that
/// only ranks starts).
pub fn fit_with(
    model: &ExtendedModel,
    data: &FitData<'_>,
    theta0: &[f64],
    max_iter: usize,
    covariance: bool,
) -> Result<Fit, PredictError> {
    fit_inner(model, data, theta0, max_iter, covariance, &[])
}

/// [`fit`] that ends once it reaches the basin of a minimum already found
/// (module documentation, "Known minima"): `known` are fits of the same
/// model on the same data; where the iterate comes within
/// [`KNOWN_BASIN`] noise variances of one that a stopping test ended
/// (converged or stalled), that fit is returned, with this one's
/// iterations.
pub fn fit_known(
    model: &ExtendedModel,
    data: &FitData<'_>,
    theta0: &[f64],
    max_iter: usize,
    known: &[&Fit],
) -> Result<Fit, PredictError> {
    fit_inner(model, data, theta0, max_iter, true, known)
}

/// A minimum already found, as [`fit_known`] tests an iterate against it:
/// the fit and its Gauss-Newton matrix `J^T J = sigma^2 cov^-1`
/// (recovered from the covariance, a `P x P` inverse per known fit and
/// call: the fit keeps no `J^T J` of its own).
struct Known<'f> {
    fit: &'f Fit,
    gram: DMatrix<f64>,
}

impl<'f> Known<'f> {
    /// The known end `fit` of a model of `p` parameters on `n` real
    /// equations; `None` unless a stopping test ended it (converged, or
    /// stalled far above the noise: a fit that reaches its neighbourhood
    /// stalls there too), not the iteration limit, and it has its
    /// covariance.
    fn new(fit: &'f Fit, p: usize, n: usize) -> Option<Self> {
        if !(fit.converged || fit.stalled) || fit.theta.len() != p || fit.n != n {
            return None;
        }
        let sigma2 = fit.s / (n.saturating_sub(p).max(1)) as f64;
        let gram = fit.covariance.as_ref()?.clone().cholesky()?.inverse() * sigma2;
        Some(Known { fit, gram })
    }

    /// Whether `theta` with misfit `s` lies in this minimum's basin: both
    /// `S - S_k` and its quadratic model `d^T J^T J d` (`d = theta -
    /// theta_k`) within `tol` of zero.
    fn holds(&self, theta: &[f64], s: f64, tol: f64) -> bool {
        let d = DVector::from_iterator(
            theta.len(),
            theta.iter().zip(&self.fit.theta).map(|(a, b)| a - b),
        );
        let q = d.dot(&(&self.gram * &d));
        (s - self.fit.s).abs() <= tol && q <= tol
    }
}

/// The reach of a known minimum's basin ([`fit_known`]), in noise
/// variances of one real reading (`s^2 / 2`).
pub const KNOWN_BASIN: f64 = 1.0;

/// Whether a fit whose `S` after each accepted iteration is `history`,
/// on data another hypothesis explains to the noise
/// ([`FitData::explained`]), stops behind it (module documentation,
/// "Behind a fit at the noise"), once it has run a [`STALL_WINDOW`]:
/// when `S` is still above `stall` ([`STALL_MISFIT`] times its noise
/// floor), however fast it falls; or when, falling at the last window's
/// rate for the `left` iterations it has left, it would still be above
/// `noise` ([`NOISE_CHI2`] times the floor) at its iteration limit.
fn behind(history: &[f64], stall: f64, noise: f64, left: usize) -> bool {
    let (Some(&s), Some(k)) = (history.last(), history.len().checked_sub(STALL_WINDOW + 1)) else {
        return false;
    };
    let rate = (s / history[k]).min(1.0);
    let windows = left as f64 / STALL_WINDOW as f64;
    s > stall || s * rate.powf(windows) > noise
}

fn fit_inner(
    model: &ExtendedModel,
    data: &FitData<'_>,
    theta0: &[f64],
    max_iter: usize,
    covariance: bool,
    known: &[&Fit],
) -> Result<Fit, PredictError> {
    let en = entries(model, data);
    let p = model.n_params();
    let n = data.n_equations();
    if theta0.len() != p {
        return Err(PredictError::Dimension);
    }
    let mut theta = theta0.to_vec();
    let (mut r, mut jac) = evaluate(model, data, &en, &theta, true)?;
    let mut s = r.norm_squared();
    let mut mu = 1e-3;
    let mut converged = false;
    let mut is_stalled = false;
    let stall_s = data
        .noise_level
        .map(|sn| STALL_MISFIT * 0.5 * n.saturating_sub(p) as f64 * sn * sn);
    let flat = data.noise_level.map(|sn| FLAT_DROP * 0.5 * sn * sn);
    let basin = data.noise_level.map(|sn| KNOWN_BASIN * 0.5 * sn * sn);
    let known: Vec<Known<'_>> = match basin {
        Some(_) => known.iter().filter_map(|k| Known::new(k, p, n)).collect(),
        None => Vec::new(),
    };
    let mut history: Vec<f64> = vec![s];
    let mut iterations = 0;
    while iterations < max_iter {
        iterations += 1;
        let Some(j) = jac.as_ref() else { break };
        let jtj = gram(j);
        let g = j.tr_mul(&r);
        let mut accepted: Option<(DVector<f64>, Vec<Eval>)> = None;
        for _ in 0..12 {
            let mut a = jtj.clone();
            for i in 0..p {
                a[(i, i)] += mu * jtj[(i, i)].max(1e-30);
            }
            let Some(ch) = a.cholesky() else {
                mu *= 4.0;
                continue;
            };
            let step = ch.solve(&g);
            let trial: Vec<f64> = theta.iter().zip(step.iter()).map(|(t, d)| t + d).collect();
            match residuals(model, data, &en, &trial) {
                Ok((rt, evals)) => {
                    let st = rt.norm_squared();
                    if st.is_finite() && st <= s {
                        let small_step =
                            step.norm() <= 1e-7 * (1.0 + DVector::from_column_slice(&theta).norm());
                        let small_drop = s - st <= 1e-9 * s;
                        theta = trial;
                        s = st;
                        mu = (mu / 3.0).max(1e-12);
                        accepted = Some((rt, evals));
                        if small_step || small_drop {
                            converged = true;
                        }
                        break;
                    }
                    mu *= 4.0;
                }
                Err(_) => mu *= 4.0,
            }
        }
        let Some((r_new, evals)) = accepted else {
            // No step lowers S: a minimum to the precision of the model
            // (residual and Jacobian are those of `theta` still).
            converged = true;
            break;
        };
        history.push(s);
        if !converged && history.len() > STALL_WINDOW {
            let before = history[history.len() - 1 - STALL_WINDOW];
            if stall_s.is_some_and(|f| {
                stalled(&history, f)
                    || (data.explained
                        && behind(
                            &history,
                            f,
                            f * NOISE_CHI2 / STALL_MISFIT,
                            max_iter - iterations,
                        ))
            }) {
                is_stalled = true;
            } else if flat.is_some_and(|f| before - s < f) {
                converged = true;
            }
        }
        if let Some(tol) = basin.filter(|_| !is_stalled && !converged) {
            if let Some(k) = known.iter().find(|k| k.holds(&theta, s, tol)) {
                return Ok(Fit {
                    iterations,
                    ..k.fit.clone()
                });
            }
        }
        let last = converged || is_stalled || iterations == max_iter;
        // The accepted trial's residuals and evaluations are those of the
        // new `theta`: the Jacobian comes from them.
        r = r_new;
        jac = if !last || covariance {
            Some(jacobian_from(model, data, &en, &theta, evals)?)
        } else {
            None
        };
        if converged || is_stalled {
            break;
        }
    }
    let covariance = jac.as_ref().filter(|_| covariance).and_then(|j| {
        let jtj = gram(j);
        let sigma2 = s / (n.saturating_sub(p).max(1)) as f64;
        jtj.cholesky().map(|c| c.inverse() * sigma2)
    });
    Ok(Fit {
        theta,
        s,
        n,
        covariance,
        iterations,
        converged,
        stalled: is_stalled,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnose::extended::{Extension, Scales};
    use crate::diagnose::terms::build;
    use crate::estimate::predictor::Predictor;
    use crate::estimate::Parametrization;
    use crate::model::RotorModel;
    use crate::tables::auto_scaling;
    use rotorid_core::parametrization::Structure;

    /// The extended model of `m` (bearings of physical order 1) with `ext`.
    fn paper_model(m: &RotorModel, ext: Vec<Extension>) -> ExtendedModel {
        let param = Parametrization {
            structure: Structure::physical(1),
            scaling: auto_scaling(m, 1500.0),
            bearing_nodes: m.bearing_nodes(),
            plane_nodes: m.planes.clone(),
        };
        ExtendedModel {
            pr: Predictor::new(param),
            ext,
            scales: Scales {
                q: 1e-5,
                mass: 50.0,
                omega: 1000.0,
            },
            relative_probes: true,
        }
    }

    /// The paper rotor's model with an extra plane at node 16, 60 speeds
    /// to 1500 rad/s: its terms, the model, the true parameters (the
    /// plane's two at `plane` when given) and readings with relative noise
    /// `noise` (a fixed sequence).
    fn plane_case(
        noise: f64,
        plane: Option<[f64; 2]>,
    ) -> (Vec<SpeedTerms>, ExtendedModel, Vec<f64>, Vec<Sample>) {
        let m = RotorModel::paper();
        let omegas: Vec<f64> = (1..=60).map(|i| 25.0 * i as f64).collect();
        let terms = build(&m, &omegas, 1.0, false).unwrap();
        let x = paper_model(&m, vec![Extension::Plane { node: 16 }]);
        let p = x.n_params();
        let mut truth: Vec<f64> = (0..p)
            .map(|i| 1.0 + 0.5 * ((i * 7 % 5) as f64 - 2.0) / 2.0)
            .collect();
        if let Some(u) = plane {
            truth[p - 2..].copy_from_slice(&u);
        }
        let mut u = 0.37_f64;
        let mut draw = || {
            u = (u * 997.0 + 0.123).fract();
            u - 0.5
        };
        let samples = readings(&x, &terms, &truth, || {
            Complex64::new(1.0 + noise * draw(), noise * draw())
        });
        (terms, x, truth, samples)
    }

    /// The readings `x` predicts with `theta` at each speed of `terms`,
    /// each times `factor()` (a relative error).
    fn readings(
        x: &ExtendedModel,
        terms: &[SpeedTerms],
        theta: &[f64],
        mut factor: impl FnMut() -> Complex64,
    ) -> Vec<Sample> {
        terms
            .iter()
            .map(|st| Sample {
                omega: st.omega,
                q: x.predict(st, &x.pr.entries(st.omega), theta, None)
                    .unwrap()
                    .iter()
                    .map(|y| y * factor())
                    .collect(),
            })
            .collect()
    }

    /// On noise-free data made by the model itself, the fit from a start
    /// 20 % off returns the parameters and a zero residual; the covariance
    /// equals a dense inverse of the Gauss-Newton matrix; a few columns of
    /// the Jacobian formed alone equal those of the whole one.
    #[test]
    fn recovers_noise_free_parameters() {
        let m = RotorModel::paper();
        let omegas: Vec<f64> = (1..=60).map(|i| 25.0 * i as f64).collect();
        let terms = build(&m, &omegas, 1.0, false).unwrap();
        let x = paper_model(&m, vec![Extension::Runout, Extension::Plane { node: 16 }]);
        let p = x.n_params();
        let truth: Vec<f64> = (0..p)
            .map(|i| 1.0 + 0.5 * ((i * 7 % 5) as f64 - 2.0) / 2.0)
            .collect();
        let samples = readings(&x, &terms, &truth, || Complex64::new(1.0, 0.0));
        let data = FitData::new(&samples, &terms);
        let start: Vec<f64> = truth.iter().map(|t| t * 0.8).collect();
        // A few columns alone: those of the whole Jacobian, bit for bit.
        let en = entries(&x, &data);
        let (r, j) = evaluate(&x, &data, &en, &start, true).unwrap();
        let cols = [p - 1, 0, 5];
        let (rc, jc) = evaluate_columns(&x, &data, &en, &start, &cols).unwrap();
        assert_eq!(r, rc);
        assert_eq!(jc, j.unwrap().select_columns(cols.iter()));
        assert!(evaluate_columns(&x, &data, &en, &start, &[p]).is_err());
        let f = fit(&x, &data, &start, 100).unwrap();
        assert!(f.residual() < 1e-9, "residual {}", f.residual());
        for (a, b) in f.theta.iter().zip(&truth) {
            assert!((a - b).abs() < 1e-6 * (1.0 + b.abs()), "{a} vs {b}");
        }
    }

    /// A restart that reaches a known minimum returns it: on data with
    /// 0.5 % noise, the fit from a second start, told of the first start's
    /// minimum, returns that minimum after fewer iterations than it takes
    /// alone, and alone it ends within [`KNOWN_BASIN`] noise variances of
    /// it; told of a point ten standard deviations from the minimum, it
    /// ends as it does alone, bit for bit.
    #[test]
    fn a_restart_ends_at_the_minimum_it_reaches() {
        let noise = 0.005;
        let (terms, x, truth, samples) = plane_case(noise, None);
        let data = FitData::new(&samples, &terms).with_noise_level(Some(noise));
        let start = |k: f64| -> Vec<f64> {
            truth
                .iter()
                .enumerate()
                .map(|(i, t)| t * (1.0 + k * if i % 2 == 0 { 1.0 } else { -0.5 }))
                .collect()
        };
        let a = fit(&x, &data, &start(0.2), 100).unwrap();
        assert!(a.converged && !a.stalled);
        let b = fit(&x, &data, &start(-0.3), 100).unwrap();
        let variance = 0.5 * noise * noise;
        assert!(
            (b.s - a.s).abs() <= KNOWN_BASIN * variance,
            "the two starts end {} noise variances apart",
            (b.s - a.s).abs() / variance
        );
        let told = fit_known(&x, &data, &start(-0.3), 100, &[&a]).unwrap();
        assert_eq!((&told.theta, told.s), (&a.theta, a.s));
        assert!(
            told.iterations < b.iterations,
            "{} iterations told, {} alone",
            told.iterations,
            b.iterations
        );
        // A point ten standard deviations off the minimum: not reached.
        let mut off = a.clone();
        let sd = a.std(0).unwrap();
        off.theta[0] += 10.0 * sd;
        let told = fit_known(&x, &data, &start(-0.3), 100, &[&off]).unwrap();
        assert_eq!(told, b);
    }

    /// The two tests of [`behind`] on histories of `S` (in floors: the
    /// stall bound 10, the noise bound 1.2): above the stall bound after
    /// a window, whatever the fall; below it, a fall that at its rate
    /// would not reach the noise bound within the iterations left.
    #[test]
    fn behind_stops_where_the_noise_is_out_of_reach() {
        let (stall, noise) = (10.0, 1.2);
        // Not a whole window yet.
        assert!(!behind(&[40.0, 30.0, 20.0, 15.0, 12.0], stall, noise, 45));
        // Above the stall bound, falling fast.
        assert!(behind(
            &[80.0, 40.0, 30.0, 20.0, 15.0, 11.0],
            stall,
            noise,
            45
        ));
        // Below it, falling by 1 % a window: 5 x 0.99^9 = 4.6 at the limit.
        let creep = [5.05, 5.04, 5.03, 5.02, 5.01, 5.0];
        assert!(behind(&creep, stall, noise, 45));
        // Halving a window: 5 x 0.5^9 = 0.01 at the limit.
        let fall = [10.0, 9.0, 8.0, 7.0, 6.0, 5.0];
        assert!(!behind(&fall, stall, noise, 45));
        // At the limit, the same fall leaves it at 5.
        assert!(behind(&fall, stall, noise, 0));
        // Below the noise bound, not moving.
        assert!(!behind(&[1.1; 6], stall, noise, 45));
    }

    /// On data another hypothesis explains to the noise, a fit far above
    /// the noise stops stalled after its first window, where alone it
    /// runs on; the fit of the model that made the data ends as it does
    /// alone, bit for bit.
    #[test]
    fn a_fit_behind_one_at_the_noise_stops_at_its_first_window() {
        // The extra plane's unbalance large against the noise.
        let noise = 0.001;
        let (terms, x, truth, samples) = plane_case(noise, Some([300.0, -200.0]));
        let p = x.n_params();
        let m = RotorModel::paper();
        let data = FitData::new(&samples, &terms).with_noise_level(Some(noise));
        let explained = data.clone().with_explained(true);
        // The nominal model, without the plane: far above the noise.
        let nominal = paper_model(&m, vec![]);
        let start: Vec<f64> = truth[..p - 2].iter().map(|t| t * 1.1).collect();
        let alone = fit(&nominal, &data, &start, 100).unwrap();
        let floor = 0.5 * (alone.n - nominal.n_params()) as f64 * noise * noise;
        assert!(
            alone.s > STALL_MISFIT * floor && alone.iterations > STALL_WINDOW,
            "alone: S {} floors after {} iterations",
            alone.s / floor,
            alone.iterations
        );
        let behind = fit(&nominal, &explained, &start, 100).unwrap();
        assert!(behind.stalled && behind.iterations == STALL_WINDOW);
        assert!(behind.s > STALL_MISFIT * floor && behind.s >= alone.s);
        // The model of the data, from the nominal estimate with its plane
        // at zero (as the bank starts it): below the bound within the
        // window.
        let mut t0 = alone.theta.clone();
        t0.extend([0.0, 0.0]);
        let a = fit(&x, &data, &t0, 100).unwrap();
        let b = fit(&x, &explained, &t0, 100).unwrap();
        assert!(a.converged && a.s < 2.0 * floor);
        assert_eq!(a, b);
    }

    /// The rows of some samples keep their weights as the whole data
    /// give them (without a floor, a channel's weight floor is its RMS
    /// over every sample, which the kept samples alone would not give),
    /// and a fit's residuals on them are the whole data's at those rows.
    #[test]
    fn rows_keep_the_weights_of_the_whole_data() {
        let m = RotorModel::paper();
        let omegas: Vec<f64> = (1..=30).map(|i| 50.0 * i as f64).collect();
        let terms = build(&m, &omegas, 1.0, false).unwrap();
        let x = paper_model(&m, vec![]);
        let theta: Vec<f64> = (0..x.n_params()).map(|i| 1.0 + 0.01 * i as f64).collect();
        let samples: Vec<Sample> = terms
            .iter()
            .enumerate()
            .map(|(k, st)| Sample {
                omega: st.omega,
                // Readings spread over three decades, so that the weight
                // floor matters.
                q: x.predict(st, &x.pr.entries(st.omega), &theta, None)
                    .unwrap()
                    .iter()
                    .map(|q| q * (10f64).powi(k as i32 % 4 - 3))
                    .collect(),
            })
            .collect();
        let data = FitData::new(&samples, &terms).with_noise_level(Some(0.01));
        let keep: Vec<usize> = (0..samples.len()).step_by(3).collect();
        let (ks, kt): (Vec<Sample>, Vec<SpeedTerms>) = keep
            .iter()
            .map(|&k| (samples[k].clone(), terms[k].clone()))
            .unzip();
        let thin = data.rows(&keep, &ks, &[], &kt).unwrap();
        assert_eq!(thin.noise_level, data.noise_level);
        let fresh = FitData::new(&ks, &kt);
        assert_ne!(fresh.inv_w, thin.inv_w);
        let (r, _) = evaluate(&x, &data, &entries(&x, &data), &theta, false).unwrap();
        let (rt, _) = evaluate(&x, &thin, &entries(&x, &thin), &theta, false).unwrap();
        let per = 2 * x.n_outputs(&terms[0]);
        for (i, &k) in keep.iter().enumerate() {
            assert_eq!(rt.rows(i * per, per), r.rows(k * per, per));
        }
        // Lengths that do not match, an index past the end.
        assert!(data.rows(&keep, &ks[1..], &[], &kt).is_none());
        assert!(data
            .rows(&[samples.len()], &ks[..1], &[], &kt[..1])
            .is_none());
    }

    /// `J^T J` equals the column dot products, exactly symmetric, for
    /// column counts on both sides of the product's small-size threshold.
    #[test]
    fn gram_matches_product() {
        for p in [1, 2, 3, 4, 5, 9, 17, 41] {
            let j = DMatrix::from_fn(37, p, |r, c| {
                ((r * 31 + c * 17) % 23) as f64 - 11.0 + 0.1 * c as f64
            });
            let g = gram(&j);
            let d = DMatrix::from_fn(p, p, |a, b| j.column(a).dot(&j.column(b)));
            assert!((&g - &d).norm() <= 1e-13 * d.norm(), "p {p}");
            assert_eq!(g, g.transpose());
        }
    }

    /// The blocked upper triangle is the whole product `J^T J` bit for
    /// bit (the fits' results do not depend on how it is formed), for
    /// row counts across the kernel's `k` blocks and column counts on
    /// both sides of every block edge.
    #[test]
    fn gram_is_the_product_bit_for_bit() {
        let mut x = 0.61_f64;
        let mut rnd = move || {
            x = (x * 997.0 + 0.377).fract();
            x - 0.5
        };
        for m in [7, 37, 255, 256, 257, 700, 2401] {
            for p in [1, 5, 6, 7, 11, 12, 13, 23, 24, 25, 30, 41, 78] {
                let j = DMatrix::from_fn(m, p, |_, c| rnd() * (1.0 + c as f64));
                let mut whole = j.transpose() * &j;
                for a in 0..p {
                    for b in a + 1..p {
                        whole[(b, a)] = whole[(a, b)];
                    }
                }
                let g = gram(&j);
                assert!(
                    g.iter()
                        .zip(whole.iter())
                        .all(|(x, y)| x.to_bits() == y.to_bits()),
                    "m {m} p {p}"
                );
            }
        }
    }
}
