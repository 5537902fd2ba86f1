//! Desktop identification driver: bearing stiffness, damping and unbalance
//! from a measurement sweep, with runtime sizes.
//!
//! The per-speed terms `A(Omega)`, `B(Omega)` come from the FE model,
//! reduced exactly at each measured speed by [`crate::reduce::Reducer`]
//! (banded, no interpolation; a pedestal, if the model has one, is part of
//! what is identified as "the bearing", see [`crate::reduce`]),
//! and the identification itself runs the very same core kernels as the
//! firmware ([`rotorid_core::identify::Kernel`]: regressor, scaling,
//! excitation guard, Givens QRD/RLS slice kernel) on `Vec` buffers, in `f64`
//! or `f32`. The result keeps the estimates after every speed (for plots
//! like the paper's Figs. 4 and 5) and the final ones (for reports and the
//! SPEC's JSON).

use crate::io::measurement::{Measurements, Sample};
use crate::model::{BearingCoefficients, BearingLaw, RotorModel, Unbalance};
use nalgebra::DMatrix;
use num_complex::{Complex, Complex64};
use rotorid_core::identify::{
    check_sizes, estimates_into, Config, GuardState, IdField, IdentifyError as CoreError, Kernel,
    SteadyPolicy,
};
use rotorid_core::regressor::{BearingEstimate, Formulation, Structure, UnbalanceEstimate};
use rotorid_core::scaling::ColumnScaling;
use rotorid_core::Real;
use serde_json::{json, Value};
use thiserror::Error;

/// Errors of the desktop identification.
#[derive(Debug, Error)]
pub enum IdentifyError {
    /// The measurement does not fit the model (channel count, no samples).
    #[error("measurements: {0}")]
    Measurements(String),
    /// The FE model or the reduction failed.
    #[error("model: {0}")]
    Model(String),
    /// Options out of range.
    #[error("options: {0}")]
    Options(String),
    /// The identifier refused sample `index` (0-based) at `rpm`.
    #[error("sample {index} ({rpm} rpm): {source}")]
    Step {
        /// Index of the sample in the file (0-based).
        index: usize,
        /// Its speed (rpm).
        rpm: f64,
        /// The core error.
        source: CoreError,
    },
    /// Estimates could not be extracted (singular factor).
    #[error("estimates: {0}")]
    Estimates(CoreError),
}

/// Arithmetic of the identification.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Precision {
    /// Double precision (default).
    #[default]
    F64,
    /// Single precision, as in firmware.
    F32,
}

/// Identification options.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Options {
    /// Model structure (formulation, order).
    pub structure: Structure,
    /// Forgetting factor in `(0, 1]`.
    pub lambda: f64,
    /// Start-up regularisation `R(0) = sqrt(delta) I` (on scaled unknowns
    /// unless `scaling` is the identity).
    pub delta: f64,
    /// Arithmetic.
    pub precision: Precision,
    /// Column scaling; `None` = [`auto_scaling`] from the model and the
    /// highest measured speed.
    pub scaling: Option<ColumnScaling<f64>>,
    /// Row normalisation (see `rotorid_core::regressor::normalise_rows`).
    pub normalise_rows: bool,
    /// Poor-excitation guard (speeds in rad/s).
    pub steady: SteadyPolicy<f64>,
    /// Keep the estimates after every speed.
    pub record_history: bool,
}

impl Options {
    /// The SPEC defaults: `lambda = 0.999`, `delta = 1e-7`, f64, automatic
    /// scaling, no row normalisation, the default steady-running guard,
    /// history recorded.
    pub fn new(structure: Structure) -> Self {
        Options {
            structure,
            lambda: 0.999,
            delta: 1e-7,
            precision: Precision::F64,
            scaling: None,
            normalise_rows: false,
            steady: SteadyPolicy::default_guard(),
            record_history: true,
        }
    }
}

/// Bearing and unbalance estimates at one point of the sweep (SI units).
#[derive(Debug, Clone, PartialEq)]
pub struct EstimateSet {
    /// Speed at which the bearing coefficients are evaluated (rad/s).
    pub omega: f64,
    /// One per bearing, in bearing order.
    pub bearings: Vec<BearingEstimate<f64>>,
    /// One per plane, in plane order.
    pub unbalance: Vec<UnbalanceEstimate<f64>>,
}

/// One step of the sweep.
#[derive(Debug, Clone, PartialEq)]
pub struct HistoryPoint {
    /// Speed (rad/s).
    pub omega: f64,
    /// Whether forgetting was applied (see the steady-running guard).
    pub excited: bool,
    /// Relative a-posteriori residual of the step.
    pub relative_residual: f64,
    /// Estimates after the step.
    pub estimate: EstimateSet,
}

/// The result of an identification run.
#[derive(Debug, Clone, PartialEq)]
pub struct Identification {
    /// Options used (with the scaling actually applied).
    pub options: Options,
    /// Column scaling actually applied.
    pub scaling: ColumnScaling<f64>,
    /// Bearing nodes (0-based).
    pub bearing_nodes: Vec<usize>,
    /// Plane nodes (0-based).
    pub plane_nodes: Vec<usize>,
    /// Estimates after each sample (empty unless recorded).
    pub history: Vec<HistoryPoint>,
    /// Estimates at the end of the sweep, bearings evaluated at the last speed.
    pub last: EstimateSet,
    /// Steps folded in.
    pub steps: u64,
    /// Steps with forgetting frozen by the guard.
    pub frozen: u64,
    /// Final scaled weights `w~` (for the physical structure the real
    /// weights in `re`), see `rotorid_core::regressor` for the layout.
    pub scaled_weights: Vec<Complex64>,
    /// Estimated covariance of the scaled weights: White's
    /// heteroscedasticity-consistent sandwich from the final residuals of
    /// every row, with the forgetting weights (`None` with too few rows, or
    /// when more than 100000 rows still carry weight: the rows are kept in
    /// memory until the end).
    /// It describes the scatter due to noise, not the errors-in-variables
    /// bias of noisy `q_B` in `U`.
    pub covariance: Option<DMatrix<Complex64>>,
}

/// A sparse linear functional of the scaled weights: `(index, coefficient)`.
type Functional = Vec<(usize, f64)>;

/// Standard deviations of the final estimates (same units as the values).
#[derive(Debug, Clone, PartialEq)]
pub struct StdSet {
    /// Per bearing: std of `k` (N/m) and `c` (N s/m), `yy..zz`.
    pub bearings: Vec<([f64; 4], [f64; 4])>,
    /// Per plane: std of `m e` (kg m) and of the phase (deg).
    pub unbalance: Vec<(f64, f64)>,
}

/// Reference magnitudes for the column scaling from the known part of the
/// model (the shaft), never from the unknown bearings:
///
/// * stiffness `s_K = 48 E I / L^3`, the midspan stiffness of the shaft as a
///   simply supported beam (length-weighted mean `E I`, total length `L`);
/// * `omega_ref` = the given highest speed (rad/s);
/// * unbalance `s_a = m_rotor * G / omega_ref` with the ISO 1940 balance
///   grade `G = 6.3 mm/s` and `m_rotor` = shaft + disk mass.
///
/// For the paper rotor: `s_K` = 2.1e7 N/m, `s_a` = 3.4e-4 kg m at 15000 rpm.
pub fn auto_scaling(model: &RotorModel, omega_ref: f64) -> ColumnScaling<f64> {
    let mut len = 0.0;
    let mut ei_l = 0.0;
    let mut mass = 0.0;
    for e in &model.shaft {
        let (d_o, d_i) = (e.outer_diameter, e.inner_diameter);
        let i = core::f64::consts::PI * (d_o.powi(4) - d_i.powi(4)) / 64.0;
        let area = core::f64::consts::PI * (d_o * d_o - d_i * d_i) / 4.0;
        len += e.length;
        ei_l += e.material.e * i * e.length;
        mass += e.material.rho * area * e.length;
    }
    mass += model.disks.iter().map(|d| d.mass).sum::<f64>();
    let omega_ref = if omega_ref.is_finite() && omega_ref > 0.0 {
        omega_ref
    } else {
        1.0
    };
    let stiffness = if len > 0.0 {
        48.0 * (ei_l / len) / len.powi(3)
    } else {
        1.0
    };
    let unbalance = mass * 6.3e-3 / omega_ref;
    ColumnScaling::new(stiffness, omega_ref, unbalance)
        .unwrap_or_else(|_| ColumnScaling::identity())
}

/// The reduced terms at one speed: `A` (`2N_b x 2N_b`), `B` (`2N_b x N_p`).
pub type TermsAt = (DMatrix<Complex64>, DMatrix<Complex64>);

/// Identification over `model`'s shaft and planes: builds the FE model,
/// reduces it at every measured speed and runs [`identify_with`].
/// `progress` is called with the number of samples done.
pub fn identify(
    model: &RotorModel,
    meas: &Measurements,
    options: &Options,
    progress: Option<&dyn Fn(usize)>,
) -> Result<Identification, IdentifyError> {
    let fe = crate::fe::assembly::FeModel::new(model)
        .map_err(|e| IdentifyError::Model(e.to_string()))?;
    let reducer =
        crate::reduce::Reducer::new(&fe, model).map_err(|e| IdentifyError::Model(e.to_string()))?;
    let mut terms = |omega: f64| -> Result<TermsAt, IdentifyError> {
        let t = reducer
            .reduce(omega)
            .map_err(|e| IdentifyError::Model(e.to_string()))?;
        Ok((t.a, t.b))
    };
    let scaling = match options.scaling {
        Some(s) => s,
        None => auto_scaling(model, max_speed(&meas.samples)),
    };
    let mut opts = *options;
    opts.scaling = Some(scaling);
    identify_with(
        &model.bearing_nodes(),
        &model.planes,
        meas,
        &opts,
        &mut terms,
        progress,
    )
}

/// The reduced terms `A`, `B` of `model` (its planes) at `omega` (rad/s),
/// as the identification uses them ([`crate::reduce::reduce`]). For many
/// speeds build a [`crate::reduce::Reducer`] once instead.
pub fn reduce_terms(
    fe: &crate::fe::assembly::FeModel,
    model: &RotorModel,
    omega: f64,
) -> Result<TermsAt, IdentifyError> {
    let t =
        crate::reduce::reduce(fe, model, omega).map_err(|e| IdentifyError::Model(e.to_string()))?;
    Ok((t.a, t.b))
}

/// Highest speed of a sweep (rad/s), 0 if empty.
pub fn max_speed(samples: &[Sample]) -> f64 {
    samples.iter().map(|s| s.omega).fold(0.0, f64::max)
}

/// Identification with the terms given by `terms(omega)` (e.g. the FE
/// reduction, or a table). `bearing_nodes`, `plane_nodes` (0-based) fix
/// `N_b` and `N_p`; `options.scaling = None` means raw SI here (no model to
/// derive references from).
pub fn identify_with(
    bearing_nodes: &[usize],
    plane_nodes: &[usize],
    meas: &Measurements,
    options: &Options,
    terms: &mut dyn FnMut(f64) -> Result<TermsAt, IdentifyError>,
    progress: Option<&dyn Fn(usize)>,
) -> Result<Identification, IdentifyError> {
    let nb = bearing_nodes.len();
    let np = plane_nodes.len();
    if nb == 0 {
        return Err(IdentifyError::Measurements(
            "the model has no bearing".into(),
        ));
    }
    if meas.samples.is_empty() {
        return Err(IdentifyError::Measurements("no samples".into()));
    }
    if meas.n_bearings != nb || meas.samples.iter().any(|s| s.q.len() != 2 * nb) {
        return Err(IdentifyError::Measurements(format!(
            "{} bearing(s) in the file, {} in the model",
            meas.n_bearings, nb
        )));
    }
    let scaling = options.scaling.unwrap_or_else(ColumnScaling::identity);
    let structure = options.structure;
    let mut out = match (structure.formulation, options.precision) {
        (Formulation::Paper, Precision::F64) => {
            run::<f64, Complex<f64>>(nb, np, meas, options, scaling, terms, progress)?
        }
        (Formulation::Paper, Precision::F32) => {
            run::<f32, Complex<f32>>(nb, np, meas, options, scaling, terms, progress)?
        }
        (Formulation::Physical, Precision::F64) => {
            run::<f64, f64>(nb, np, meas, options, scaling, terms, progress)?
        }
        (Formulation::Physical, Precision::F32) => {
            run::<f32, f32>(nb, np, meas, options, scaling, terms, progress)?
        }
    };
    out.bearing_nodes = bearing_nodes.to_vec();
    out.plane_nodes = plane_nodes.to_vec();
    Ok(out)
}

fn lit<T: Real>(z: Complex64) -> Complex<T> {
    Complex::new(T::lit(z.re), T::lit(z.im))
}

fn widen_bearing<T: Real>(b: &BearingEstimate<T>) -> BearingEstimate<f64> {
    let w = |a: [T; 4]| a.map(|x| x.to_f64());
    BearingEstimate {
        k: w(b.k),
        c: w(b.c),
        im_z0: b.im_z0.map(w),
        re_z1: b.re_z1.map(w),
    }
}

fn widen_unbalance<T: Real>(u: &UnbalanceEstimate<T>) -> UnbalanceEstimate<f64> {
    UnbalanceEstimate::from_phasor(Complex64::new(u.a.re.to_f64(), u.a.im.to_f64()))
}

/// Runtime-size state of one identification: the filter buffers and the
/// scratch of the core [`Kernel`].
struct State<T, F> {
    config: Config<T>,
    nq: usize,
    np: usize,
    r: Vec<F>,
    p: Vec<F>,
    guard: GuardState<T>,
    d: Vec<F>,
    u: Vec<F>,
    xi: Vec<F>,
    gamma: Vec<T>,
    w: Vec<F>,
    /// Every row folded in (as the filter saw it: scaled, normalised) with
    /// the cumulative log forgetting at the time it was folded in, for the
    /// covariance estimate.
    rows: Vec<(Vec<Complex64>, Complex64, f64)>,
    /// `sum ln lambda_used` so far.
    log_w: f64,
    /// Too many rows kept: no covariance for this run.
    rows_overflow: bool,
}

/// Rows kept for the covariance estimate (memory bound of the desktop
/// driver: 100000 rows of 22 complex values = 35 MB).
const MAX_COV_ROWS: usize = 100_000;

impl<T: Real, F: IdField<T> + Widen> State<T, F> {
    fn new(config: Config<T>, nb: usize, np: usize) -> Result<Self, CoreError> {
        let m = config.structure.n_unknowns(nb, np);
        let n = config.structure.n_rows(nb);
        check_sizes::<T, F>(&config.structure, 2 * nb, np, m, n)?;
        let mut s = State {
            config,
            nq: 2 * nb,
            np,
            r: vec![F::zero(); m * m],
            p: vec![F::zero(); m],
            guard: GuardState::default(),
            d: vec![F::zero(); n],
            u: vec![F::zero(); n * m],
            xi: vec![F::zero(); n],
            gamma: vec![T::zero(); n],
            w: vec![F::zero(); m],
            rows: Vec::new(),
            log_w: 0.0,
            rows_overflow: false,
        };
        s.kernel().init()?;
        Ok(s)
    }

    fn kernel(&mut self) -> Kernel<'_, T, F> {
        Kernel {
            config: &self.config,
            nq: self.nq,
            np: self.np,
            r: &mut self.r,
            p: &mut self.p,
            guard: &mut self.guard,
        }
    }

    fn step(
        &mut self,
        omega: T,
        a: &[Complex<T>],
        b: &[Complex<T>],
        q: &[Complex<T>],
    ) -> Result<rotorid_core::identify::StepReport<T>, CoreError> {
        let (mut d, mut u, mut xi, mut gamma) = (
            std::mem::take(&mut self.d),
            std::mem::take(&mut self.u),
            std::mem::take(&mut self.xi),
            std::mem::take(&mut self.gamma),
        );
        let res = self
            .kernel()
            .step(omega, a, b, q, &mut d, &mut u, &mut xi, &mut gamma);
        (self.d, self.u, self.xi, self.gamma) = (d, u, xi, gamma);
        if let Ok(rep) = &res {
            let lam = rep.lambda_used.to_f64();
            if lam > 0.0 {
                self.log_w += lam.ln();
                let m = self.p.len();
                if !self.rows_overflow {
                    for (row, dj) in self.u.chunks_exact(m).zip(&self.d) {
                        let row = row.iter().map(|x| x.widen()).collect();
                        self.rows.push((row, dj.widen(), self.log_w));
                    }
                    if self.rows.len() > MAX_COV_ROWS {
                        // Rows forgotten below 1e-8 of weight no longer
                        // matter; if that is not enough (lambda = 1 on a
                        // very long run), give the covariance up.
                        let log_w = self.log_w;
                        let cut = self
                            .rows
                            .partition_point(|(_, _, lw)| log_w - lw < (1e-8f64).ln());
                        self.rows.drain(..cut);
                        if self.rows.len() > MAX_COV_ROWS {
                            self.rows = Vec::new();
                            self.rows_overflow = true;
                        }
                    }
                }
            }
        }
        res
    }

    /// Heteroscedasticity-consistent covariance of the scaled weights
    /// (White's sandwich with the HC3 leverage correction): with the row
    /// weights `v_j` (product of the forgetting factors applied after row
    /// `j`), `Phi = R^H R`, the final residuals `e_j = d_j - u_j w~` and the
    /// leverages `h_j = v_j u_j Phi^-1 u_j^H`,
    /// `Cov = Phi^-1 (sum_j v_j^2 |e_j / (1 - h_j)|^2 u_j^H u_j) Phi^-1`.
    /// The leverage correction matters here: the few speeds near the
    /// critical speeds carry most of the information (large `|q_B|`), so
    /// their residuals are strongly shrunk by the fit.
    /// `None` with fewer rows than unknowns or a singular factor.
    fn covariance(&self) -> Option<DMatrix<Complex64>> {
        let m = self.p.len();
        if self.rows_overflow || self.rows.len() <= m {
            return None;
        }
        let r = DMatrix::from_fn(m, m, |i, j| {
            if j >= i {
                self.r[i * m + j].widen()
            } else {
                Complex64::new(0.0, 0.0)
            }
        });
        let rinv = r.solve_upper_triangular(&DMatrix::identity(m, m))?;
        let phi_inv = &rinv * rinv.adjoint();
        let w: Vec<Complex64> = self.w.iter().map(|x| x.widen()).collect();
        let mut meat = DMatrix::<Complex64>::zeros(m, m);
        for (u, d, lw) in &self.rows {
            let v = (self.log_w - lw).exp();
            let e = d - u.iter().zip(&w).map(|(a, b)| a * b).sum::<Complex64>();
            // Leverage h = v u Phi^-1 u^H in [0, 1): the fit pulls row j's
            // residual toward zero by (1 - h); undo it (HC3).
            let mut h = Complex64::new(0.0, 0.0);
            for i in 0..m {
                if u[i] == Complex64::new(0.0, 0.0) {
                    continue;
                }
                for (k, uk) in u.iter().enumerate() {
                    h += u[i] * phi_inv[(i, k)] * uk.conj();
                }
            }
            let one_minus_h = (1.0 - v * h.re).max(1e-3);
            let s2 = v * v * e.norm_sqr() / (one_minus_h * one_minus_h);
            if s2 == 0.0 {
                continue;
            }
            for i in 0..m {
                let ui = u[i].conj() * s2;
                for (k, uk) in u.iter().enumerate() {
                    meat[(i, k)] += ui * uk;
                }
            }
        }
        let c = &phi_inv * meat * &phi_inv;
        c.iter()
            .all(|z| z.re.is_finite() && z.im.is_finite())
            .then_some(c)
    }

    fn estimates(&mut self, omega: T) -> Result<EstimateSet, CoreError> {
        let mut w = std::mem::take(&mut self.w);
        let res = self.kernel().weights(&mut w);
        self.w = w;
        res?;
        let nb = self.nq / 2;
        let zero_b = BearingEstimate {
            k: [T::zero(); 4],
            c: [T::zero(); 4],
            im_z0: None,
            re_z1: None,
        };
        let mut bearings = vec![zero_b; nb];
        let mut unbalance =
            vec![UnbalanceEstimate::from_phasor(Complex::new(T::zero(), T::zero())); self.np];
        estimates_into(
            &self.config,
            &self.w,
            self.nq,
            self.np,
            omega,
            &mut bearings,
            &mut unbalance,
        )?;
        Ok(EstimateSet {
            omega: omega.to_f64(),
            bearings: bearings.iter().map(widen_bearing).collect(),
            unbalance: unbalance.iter().map(widen_unbalance).collect(),
        })
    }
}

/// Widening of a filter field value to `Complex64`.
trait Widen {
    fn widen(self) -> Complex64;
}
impl<T: Real> Widen for Complex<T> {
    fn widen(self) -> Complex64 {
        Complex64::new(self.re.to_f64(), self.im.to_f64())
    }
}
impl Widen for f32 {
    fn widen(self) -> Complex64 {
        Complex64::new(self as f64, 0.0)
    }
}
impl Widen for f64 {
    fn widen(self) -> Complex64 {
        Complex64::new(self, 0.0)
    }
}

fn run<T: Real, F: IdField<T> + Widen>(
    nb: usize,
    np: usize,
    meas: &Measurements,
    options: &Options,
    scaling: ColumnScaling<f64>,
    terms: &mut dyn FnMut(f64) -> Result<TermsAt, IdentifyError>,
    progress: Option<&dyn Fn(usize)>,
) -> Result<Identification, IdentifyError> {
    let opt_err = |what: &str| IdentifyError::Options(what.to_string());
    let scaling_t =
        ColumnScaling::<T>::new(scaling.stiffness, scaling.omega_ref, scaling.unbalance)
            .map_err(|_| opt_err("column scaling not representable in this precision"))?;
    let config = Config {
        structure: options.structure,
        lambda: T::lit(options.lambda),
        delta: T::lit(options.delta),
        scaling: scaling_t,
        normalise_rows: options.normalise_rows,
        steady: SteadyPolicy {
            min_speed_step: T::lit(options.steady.min_speed_step),
            min_diag_ratio: T::lit(options.steady.min_diag_ratio),
            action: options.steady.action,
        },
    };
    config.validate().map_err(|e| opt_err(&e.to_string()))?;
    let mut st = State::<T, F>::new(config, nb, np).map_err(|e| opt_err(&e.to_string()))?;
    let nq = 2 * nb;
    let mut history = Vec::new();
    let mut a_t = vec![Complex::new(T::zero(), T::zero()); nq * nq];
    let mut b_t = vec![Complex::new(T::zero(), T::zero()); nq * np];
    let mut q_t = vec![Complex::new(T::zero(), T::zero()); nq];
    let mut last_omega = 0.0;
    for (index, s) in meas.samples.iter().enumerate() {
        let rpm = crate::units::rad_s_to_rpm(s.omega);
        let (a, b) = terms(s.omega)?;
        if a.nrows() != nq || a.ncols() != nq || b.nrows() != nq || b.ncols() != np {
            return Err(IdentifyError::Model(format!(
                "reduced terms of size {}x{} and {}x{}, expected {nq}x{nq} and {nq}x{np}",
                a.nrows(),
                a.ncols(),
                b.nrows(),
                b.ncols()
            )));
        }
        // Row-major copies in the working precision.
        for i in 0..nq {
            for j in 0..nq {
                a_t[i * nq + j] = lit(a[(i, j)]);
            }
            for k in 0..np {
                b_t[i * np + k] = lit(b[(i, k)]);
            }
        }
        for (x, z) in q_t.iter_mut().zip(&s.q) {
            *x = lit(*z);
        }
        let rep = st
            .step(T::lit(s.omega), &a_t, &b_t, &q_t)
            .map_err(|source| IdentifyError::Step { index, rpm, source })?;
        last_omega = s.omega;
        if options.record_history {
            let estimate = st
                .estimates(T::lit(s.omega))
                .map_err(IdentifyError::Estimates)?;
            history.push(HistoryPoint {
                omega: s.omega,
                excited: rep.excited,
                relative_residual: rep.relative_residual.to_f64(),
                estimate,
            });
        }
        if let Some(p) = progress {
            p(index + 1);
        }
    }
    let last = st
        .estimates(T::lit(last_omega))
        .map_err(IdentifyError::Estimates)?;
    let scaled_weights = st.w.iter().map(|x| F::widen(*x)).collect();
    let covariance = st.covariance();
    let mut opts = *options;
    opts.scaling = Some(scaling);
    Ok(Identification {
        options: opts,
        scaling,
        bearing_nodes: Vec::new(),
        plane_nodes: Vec::new(),
        history,
        last,
        steps: st.guard.steps,
        frozen: st.guard.frozen,
        scaled_weights,
        covariance,
    })
}

fn coef_json(v: &[f64; 4]) -> Value {
    json!({"yy": v[0], "yz": v[1], "zy": v[2], "zz": v[3]})
}

impl Identification {
    /// Standard deviations of the final estimates from [`Self::covariance`]
    /// by linearisation: each reported quantity is a linear functional
    /// `g . w~` of the scaled weights (`K`, `C` at the last speed), and
    /// `m e`, phase are linearised about the estimate. For the complex paper
    /// structure the errors are taken circular (`var Re = var Im = E|.|^2 / 2`).
    pub fn std(&self) -> Option<StdSet> {
        let cov = self.covariance.as_ref()?;
        let st = self.options.structure;
        let nb = self.last.bearings.len();
        let np = self.last.unbalance.len();
        let omega = self.last.omega;
        let scale = |j: usize| st.column_scale(&self.scaling, nb, np, j).unwrap_or(0.0);
        // E|g . dw|^2 for a sparse real-coefficient functional.
        let quad = |g: &[(usize, f64)]| -> f64 {
            let mut v = Complex64::new(0.0, 0.0);
            for &(i, gi) in g {
                for &(j, gj) in g {
                    v += cov[(i, j)] * gi * gj;
                }
            }
            v.re.max(0.0)
        };
        let complex = st.formulation == Formulation::Paper;
        let half = if complex { 0.5 } else { 1.0 };
        let mut bearings = Vec::with_capacity(nb);
        for m in 0..nb {
            let mut ks = [0.0; 4];
            let mut cs = [0.0; 4];
            for e in 0..4 {
                let (r, c) = (e / 2, e % 2);
                let (gk, gc): (Functional, Functional) = match st.formulation {
                    Formulation::Paper if st.order == 1 => {
                        let j0 = st.paper_index(m, r, 0, c);
                        let j1 = st.paper_index(m, r, 1, c);
                        (vec![(j0, scale(j0))], vec![(j1, scale(j1))])
                    }
                    Formulation::Paper => {
                        let g: Vec<(usize, f64)> = (0..=st.order)
                            .map(|p| {
                                let j = st.paper_index(m, r, p, c);
                                (j, scale(j) * omega.powi(p as i32))
                            })
                            .collect();
                        let gc = g
                            .iter()
                            .map(|&(j, x)| (j, if omega > 0.0 { x / omega } else { 0.0 }))
                            .collect();
                        (g, gc)
                    }
                    Formulation::Physical => {
                        let gk = (0..st.order)
                            .map(|p| {
                                let j = st.physical_index(m, r, p, 0, c);
                                (j, scale(j) * omega.powi(p as i32))
                            })
                            .collect();
                        let gc = (0..st.order)
                            .map(|p| {
                                let j = st.physical_index(m, r, p, 1, c);
                                (j, scale(j) * omega.powi(p as i32))
                            })
                            .collect();
                        (gk, gc)
                    }
                };
                ks[e] = (half * quad(&gk)).sqrt();
                cs[e] = (half * quad(&gc)).sqrt();
            }
            bearings.push((ks, cs));
        }
        let mut unbalance = Vec::with_capacity(np);
        for (k, u) in self.last.unbalance.iter().enumerate() {
            let j = st.plane_index(nb, k);
            let sa = self.scaling.unbalance;
            let (var_me, var_ph) = if complex {
                let v = 0.5 * cov[(j, j)].re.max(0.0) * sa * sa;
                (v, v / (u.me * u.me).max(f64::MIN_POSITIVE))
            } else {
                // d me = (x dx + y dy) / |a|, d phase = (x dy - y dx) / |a|^2.
                let (x, y) = (u.a.re, u.a.im);
                let r2 = (x * x + y * y).max(f64::MIN_POSITIVE);
                let r = r2.sqrt();
                let me = quad(&[(j, sa * x / r), (j + 1, sa * y / r)]);
                let ph = quad(&[(j, -sa * y / r2), (j + 1, sa * x / r2)]);
                (me, ph)
            };
            unbalance.push((var_me.sqrt(), var_ph.sqrt().to_degrees()));
        }
        Some(StdSet {
            bearings,
            unbalance,
        })
    }

    /// Physical (unscaled, SI) weight `j`: `s_j w~_j`.
    fn weight(&self, j: usize) -> Complex64 {
        let nb = self.last.bearings.len();
        let np = self.last.unbalance.len();
        let s = self
            .options
            .structure
            .column_scale(&self.scaling, nb, np, j)
            .unwrap_or(0.0);
        self.scaled_weights.get(j).copied().unwrap_or_default() * s
    }

    /// The identified bearing laws, exactly as the structure models them:
    ///
    /// * paper order 1: constant `K = Re Z_0`, `C = Im Z_1`;
    /// * paper order `P >= 2`: `K(Omega) = sum_p Re(Z_p) Omega^p`,
    ///   `C(Omega) = sum_{p>=1} Im(Z_p) Omega^(p-1)` (i.e. `Im Z_0`, physically
    ///   zero, is dropped);
    /// * physical order `P`: the polynomials `sum_p K_p Omega^p`,
    ///   `sum_p C_p Omega^p` (constant for `P = 1`).
    pub fn bearing_laws(&self) -> Vec<BearingLaw> {
        let st = self.options.structure;
        let nb = self.last.bearings.len();
        let order = st.order;
        (0..nb)
            .map(|m| match st.formulation {
                Formulation::Paper => {
                    let z = |p: usize| -> [Complex64; 4] {
                        core::array::from_fn(|e| self.weight(st.paper_index(m, e / 2, p, e % 2)))
                    };
                    if order == 1 {
                        BearingLaw::Constant(BearingCoefficients {
                            k: z(0).map(|x| x.re),
                            c: z(1).map(|x| x.im),
                        })
                    } else {
                        BearingLaw::Polynomial {
                            k: (0..=order).map(|p| z(p).map(|x| x.re)).collect(),
                            c: (1..=order).map(|p| z(p).map(|x| x.im)).collect(),
                        }
                    }
                }
                Formulation::Physical => {
                    let coef = |p: usize, kind: usize| -> [f64; 4] {
                        core::array::from_fn(|e| {
                            self.weight(st.physical_index(m, e / 2, p, kind, e % 2)).re
                        })
                    };
                    if order == 1 {
                        BearingLaw::Constant(BearingCoefficients {
                            k: coef(0, 0),
                            c: coef(0, 1),
                        })
                    } else {
                        BearingLaw::Polynomial {
                            k: (0..order).map(|p| coef(p, 0)).collect(),
                            c: (0..order).map(|p| coef(p, 1)).collect(),
                        }
                    }
                }
            })
            .collect()
    }

    /// `model` with its bearing laws replaced by the identified ones and its
    /// unbalance by the identified one (same nodes as `plane_nodes`): the
    /// identified rotor, e.g. for its Campbell diagram.
    pub fn identified_model(&self, model: &RotorModel) -> RotorModel {
        let mut out = model.clone();
        for (b, law) in out.bearings.iter_mut().zip(self.bearing_laws()) {
            b.law = law;
        }
        out.unbalance = self
            .plane_nodes
            .iter()
            .zip(&self.last.unbalance)
            .map(|(&node, u)| Unbalance {
                node,
                me: u.me,
                phase: u.phase,
            })
            .collect();
        out.name = format!("{} (identified)", model.name);
        out
    }

    /// The SPEC section 5 JSON: `bearings` (node 1-based, `k` and `c` as
    /// `yy..zz` in SI, evaluated at the last speed), `unbalance` (node
    /// 1-based, `me` in kg m, `phase_deg`), plus `structure`, `order`,
    /// `last_speed_rpm`, for the paper structure the consistency values
    /// `check: {im_z0, re_z1}` per bearing, and the standard deviations of
    /// [`Self::std`] when known: `std: {k, c}` per bearing, `me_std`,
    /// `phase_deg_std` (also as `std: {me, phase_deg}`) per plane.
    pub fn to_json(&self) -> Value {
        let structure = match self.options.structure.formulation {
            Formulation::Paper => "paper",
            Formulation::Physical => "physical",
        };
        let std = self.std();
        let bearings: Vec<Value> = self
            .last
            .bearings
            .iter()
            .enumerate()
            .map(|(m, b)| {
                let mut v = json!({
                    "node": self.bearing_nodes.get(m).map(|n| n + 1).unwrap_or(m + 1),
                    "k": coef_json(&b.k),
                    "c": coef_json(&b.c),
                });
                if let (Some(i0), Some(r1)) = (b.im_z0, b.re_z1) {
                    v["check"] = json!({"im_z0": coef_json(&i0), "re_z1": coef_json(&r1)});
                }
                if let Some((ks, cs)) = std.as_ref().and_then(|s| s.bearings.get(m)) {
                    v["std"] = json!({"k": coef_json(ks), "c": coef_json(cs)});
                }
                v
            })
            .collect();
        let unbalance: Vec<Value> = self
            .last
            .unbalance
            .iter()
            .enumerate()
            .map(|(k, u)| {
                let mut v = json!({
                    "node": self.plane_nodes.get(k).map(|n| n + 1).unwrap_or(k + 1),
                    "me": u.me,
                    "phase_deg": u.phase_deg(),
                });
                if let Some(&(me_std, ph_std)) = std.as_ref().and_then(|s| s.unbalance.get(k)) {
                    v["me_std"] = json!(me_std);
                    v["phase_deg_std"] = json!(ph_std);
                    v["std"] = json!({"me": me_std, "phase_deg": ph_std});
                }
                v
            })
            .collect();
        json!({
            "structure": structure,
            "order": self.options.structure.order,
            "precision": match self.options.precision { Precision::F64 => "f64", Precision::F32 => "f32" },
            "lambda": self.options.lambda,
            "delta": self.options.delta,
            "last_speed_rpm": crate::units::rad_s_to_rpm(self.last.omega),
            "steps": self.steps,
            "frozen_steps": self.frozen,
            "bearings": bearings,
            "unbalance": unbalance,
        })
    }
}
