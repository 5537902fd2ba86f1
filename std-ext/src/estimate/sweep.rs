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

use crate::estimate::uncertainty::{sandwich_covariance, WeightedRow};
use crate::estimate::unknowns::Parametrization;
use crate::fe::assembly::FeError;
use crate::io::measurement::{Measurements, Sample};
use crate::model::{BearingLaw, ModelError, RotorModel, Unbalance};
use crate::reduce::ReductionError;
use nalgebra::DMatrix;
use num_complex::{Complex, Complex64};
use rotorid_core::factor::FactorMut;
use rotorid_core::identify::{
    check_sizes, estimates_into, Config, GuardState, IdField, IdentifierError, Kernel, Scratch,
    SteadyPolicy, StepReport,
};
use rotorid_core::parametrization::{BearingEstimate, Formulation, Structure, UnbalanceEstimate};
use rotorid_core::regressor::Equations;
use rotorid_core::scaling::ColumnScaling;
use rotorid_core::Real;
use thiserror::Error;

/// Errors of the desktop identification.
#[derive(Debug, Error)]
pub enum IdentifyError {
    /// The model has no bearing.
    #[error("measurements: the model has no bearing")]
    NoBearing,
    /// The measurement has no sample.
    #[error("measurements: no samples")]
    NoSamples,
    /// The measurement's bearing count differs from the model's.
    #[error("measurements: {file} bearing(s) in the file, {model} in the model")]
    BearingCount {
        /// Bearings (channel groups) in the file.
        file: usize,
        /// Bearings in the model.
        model: usize,
    },
    /// Fewer independent real equations than unknowns: the data cannot
    /// determine the parameters (too few distinct speeds).
    #[error("measurements: {speeds} distinct speed(s) give {equations} real equations for {unknowns} unknowns: the data cannot determine the parameters (measure more speeds)")]
    NotDetermined {
        /// Distinct speeds.
        speeds: usize,
        /// Real equations they give (`4 N_b` per speed).
        equations: usize,
        /// Real unknowns of the structure.
        unknowns: usize,
    },
    /// Every response is below [`MIN_SIGNAL`] in magnitude: no signal.
    #[error("measurements: every response is below {MIN_SIGNAL:e} m (zero or numerical noise): no signal to identify from")]
    NoSignal,
    /// The model is invalid.
    #[error("model: {0}")]
    Model(#[from] ModelError),
    /// The FE model could not be built.
    #[error("model: {0}")]
    Fe(#[from] FeError),
    /// The reduction to the bearings failed.
    #[error("model: {0}")]
    Reduction(#[from] ReductionError),
    /// Reduced terms of the wrong size from a caller's terms function.
    #[error("model: reduced terms of size {a_rows}x{a_cols} and {b_rows}x{b_cols}, expected {nq}x{nq} and {nq}x{np}")]
    TermsSize {
        /// Rows of `A`.
        a_rows: usize,
        /// Columns of `A`.
        a_cols: usize,
        /// Rows of `B`.
        b_rows: usize,
        /// Columns of `B`.
        b_cols: usize,
        /// Expected `2 N_b`.
        nq: usize,
        /// Expected `N_p`.
        np: usize,
    },
    /// The column scaling does not fit the working precision.
    #[error("options: column scaling not representable in this precision")]
    Scaling,
    /// The configuration was refused by the core identifier.
    #[error("options: {0}")]
    Config(IdentifierError),
    /// The identifier refused sample `index` (0-based; shown from 1) at `rpm`.
    #[error("sample {} (counting from 1, {rpm} rpm): {source}", index + 1)]
    Step {
        /// Index of the sample in the file (0-based).
        index: usize,
        /// Its speed (rpm).
        rpm: f64,
        /// The core error.
        source: IdentifierError,
    },
    /// Estimates could not be extracted (singular factor).
    #[error("estimates: {0}")]
    Estimates(IdentifierError),
    /// Per-sample standard deviations that do not match the samples, or
    /// are not finite and positive.
    #[error(
        "measurements: the standard deviations must be finite and > 0, one per sample and channel"
    )]
    StdShape,
    /// No sample at or below the slow-roll speed.
    #[error("--slow-roll {rpm} rpm: no sample at or below that speed")]
    NoSlowRoll {
        /// The slow-roll speed (rpm).
        rpm: f64,
    },
    /// The output-error refinement failed.
    #[error(transparent)]
    OutputError(#[from] crate::estimate::output_error::OutputErrorError),
}

/// The smallest response magnitude (m) that counts as a signal: 1e-15 m,
/// a million times below the resolution of any vibration probe and still
/// a normal number in single precision. A sweep whose every response is
/// below it has nothing to identify from.
pub const MIN_SIGNAL: f64 = 1e-15;

/// Arithmetic of the identification.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Precision {
    /// Double precision (default).
    #[default]
    F64,
    /// Single precision, as in firmware.
    F32,
}

/// Identification options. [`Options::default`] is what `rotorid
/// identify` does without options (physical structure of order 1, the
/// output-error estimate, the probe noise model estimated from the data,
/// runout fitted when the low speeds show one); [`Options::new`] is the
/// paper's method (the QRD/RLS estimate alone, its path recorded).
#[derive(Debug, Clone, PartialEq)]
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
    /// Estimate the covariance of the QRD/RLS estimate
    /// ([`Identification::covariance`]): every row folded in is kept for
    /// it. Off, no row is kept and the covariance is `None` (a start that
    /// only needs the weights).
    pub covariance: bool,
    /// The estimate reported: the QRD/RLS alone (the library default, the
    /// paper's method) or refined by the output-error fit (the default of
    /// `rotorid identify`).
    pub estimator: Estimator,
    /// The probes' noise floor (m, every channel), e.g. from a data sheet;
    /// `None`: estimated from the data (SPEC section 7).
    pub noise_floor: Option<f64>,
    /// Exclude the samples the noise model cannot explain (glitches) from
    /// the output-error fit, and report them.
    pub outliers: bool,
    /// What is done about the probes' runout.
    pub runout: RunoutHandling,
    /// Called with the number of samples done as the sweep goes on.
    pub progress: Option<Progress>,
}

/// A progress callback: called with the number of samples done.
#[derive(Clone)]
pub struct Progress(pub std::sync::Arc<dyn Fn(usize) + Send + Sync>);

impl Progress {
    /// The callback `f`.
    pub fn new(f: impl Fn(usize) + Send + Sync + 'static) -> Self {
        Progress(std::sync::Arc::new(f))
    }
}

impl std::fmt::Debug for Progress {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Progress(..)")
    }
}

/// Two callbacks are equal when they are the same one.
impl PartialEq for Progress {
    fn eq(&self, other: &Self) -> bool {
        std::sync::Arc::ptr_eq(&self.0, &other.0)
    }
}

impl Default for Options {
    /// `rotorid identify`'s defaults: [`Options::new`] on the physical
    /// structure of order 1 with the output-error estimate and no history.
    fn default() -> Self {
        Options {
            estimator: Estimator::OutputError,
            record_history: false,
            ..Options::new(Structure::physical(1))
        }
    }
}

/// What the identification does about probe runout: a constant phasor on
/// each channel (mechanical and electrical runout of the probe track) that
/// the rotor model does not predict.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum RunoutHandling {
    /// Nothing: the data are taken as free of runout.
    None,
    /// Slow-roll vector subtraction, the practice of the trade: the mean
    /// vector of the samples at or below this speed (rad/s) is subtracted
    /// from every sample of its channel.
    SlowRoll(f64),
    /// A runout phasor per channel as unknowns of the output-error fit
    /// (started from the slow-roll estimate of [`slow_roll_estimate`]).
    Fit,
    /// [`RunoutHandling::Fit`] when the low-speed samples show a runout
    /// significantly different from zero ([`slow_roll_estimate`]),
    /// otherwise [`RunoutHandling::None`] (the default).
    #[default]
    Auto,
}

/// Which estimate is reported.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Estimator {
    /// The equation-error QRD/RLS estimate alone (the paper's method).
    #[default]
    Rls,
    /// The QRD/RLS estimate refined by the output-error (maximum-likelihood)
    /// fit of [`crate::estimate::output_error`].
    OutputError,
}

impl Options {
    /// The SPEC defaults: `lambda = 0.999`, `delta = 1e-7`, f64, automatic
    /// scaling, no row normalisation, the default steady-running guard,
    /// history recorded, the QRD/RLS estimate alone.
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
            covariance: true,
            estimator: Estimator::Rls,
            noise_floor: None,
            outliers: true,
            runout: RunoutHandling::Auto,
            progress: None,
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
    /// What the unknowns are (structure, scaling, bearing and plane nodes).
    pub param: Parametrization,
    /// Estimates after each sample (empty unless recorded).
    pub history: Vec<HistoryPoint>,
    /// Estimates at the end of the sweep, bearings evaluated at the last speed.
    pub last: EstimateSet,
    /// Steps folded in.
    pub steps: u64,
    /// Steps with forgetting frozen by the guard.
    pub frozen: u64,
    /// Final scaled weights `w~` (for the physical structure the real
    /// weights in `re`), see [`Parametrization`] for their meaning.
    pub scaled_weights: Vec<Complex64>,
    /// Estimated covariance of the scaled weights
    /// ([`sandwich_covariance`]; `None` with too few rows, or when more than
    /// 100000 rows still carry weight: the rows are kept in memory until
    /// the end). It describes the scatter due to noise, not the
    /// errors-in-variables bias of noisy `q_B` in `U`. After the
    /// output-error refinement, the covariance of that fit.
    pub covariance: Option<DMatrix<Complex64>>,
    /// The output-error refinement, when it ran.
    pub refinement: Option<crate::estimate::refine::Refinement>,
    /// How well the reported estimate explains the data (noise level,
    /// misfit, warnings), when checked ([`identify`] always checks).
    pub check: Option<crate::estimate::refine::FitCheck>,
}

/// Reference magnitudes for the column scaling from the model's shaft (see
/// [`crate::tables::auto_scaling`], where it lives so that the tables can
/// carry it).
pub use crate::tables::auto_scaling;

/// The reduced terms at one speed: `A` (`2N_b x 2N_b`), `B` (`2N_b x N_p`).
pub type TermsAt = (DMatrix<Complex64>, DMatrix<Complex64>);

/// Identification over `model`'s shaft and planes: builds the FE model,
/// reduces it at every measured speed and runs [`identify_with`], then
/// (by default) the output-error fit ([`Options`]).
///
/// ```no_run
/// let model = rotorid::RotorModel::paper();
/// let meas = rotorid::io::measurement::read_csv("sweep.csv")?;
/// let id = rotorid::identify(&model, &meas, &rotorid::IdentifyOptions::default())?;
/// println!("{}", rotorid::report::identify::report_table(&id, Some(&model)));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn identify(
    model: &RotorModel,
    meas: &Measurements,
    options: &Options,
) -> Result<Identification, IdentifyError> {
    identify_with_std(model, meas, None, options)
}

/// [`identify`] with per-sample standard deviations `std[n][c]` (m) of
/// every sample and bearing channel (the measurement file's `_std`
/// columns), which are then the noise model (SPEC section 7).
pub fn identify_with_std(
    model: &RotorModel,
    meas: &Measurements,
    std: Option<&[Vec<f64>]>,
    options: &Options,
) -> Result<Identification, IdentifyError> {
    let fe = crate::fe::assembly::FeModel::new(model)?;
    let banded = crate::reduce::Reducer::new(&fe, model)?;
    let reducer = banded.many();
    let mut kept: Vec<TermsAt> = Vec::with_capacity(meas.samples.len());
    let mut terms = |omega: f64| -> Result<TermsAt, IdentifyError> {
        let t = reducer.reduce(omega)?;
        kept.push((t.a.clone(), t.b.clone()));
        Ok((t.a, t.b))
    };
    let scaling = match options.scaling {
        Some(s) => s,
        None => auto_scaling(model, max_speed(&meas.samples)),
    };
    let mut opts = options.clone();
    opts.scaling = Some(scaling);
    let sample_std = match std {
        Some(s) => Some(flatten_std(s, meas)?),
        None => None,
    };
    // Runout: the samples the filter sees, and the start of a fitted one.
    let (filtered, fitted) = match options.runout {
        RunoutHandling::None => (None, None),
        RunoutHandling::SlowRoll(omega) => {
            let mut m = meas.clone();
            subtract_slow_roll(&mut m, omega)?;
            (Some(m), None)
        }
        RunoutHandling::Fit | RunoutHandling::Auto => match slow_roll_estimate(&meas.samples) {
            Some(est) if options.runout == RunoutHandling::Fit || est.significant() => {
                let mut m = meas.clone();
                for s in &mut m.samples {
                    for (q, r) in s.q.iter_mut().zip(&est.runout) {
                        *q -= r;
                    }
                }
                (Some(m), Some(est.runout))
            }
            None if options.runout == RunoutHandling::Fit => {
                let nq = meas.samples.first().map_or(0, |s| s.q.len());
                (None, Some(vec![Complex64::new(0.0, 0.0); nq]))
            }
            _ => (None, None),
        },
    };
    let seen = filtered.as_ref().unwrap_or(meas);
    let mut id = identify_with(
        &model.bearing_nodes(),
        &model.planes,
        seen,
        &opts,
        &mut terms,
        options.progress.as_ref().map(|p| &*p.0 as &dyn Fn(usize)),
    )?;
    let setup = crate::estimate::refine::NoiseSetup {
        floor: options.noise_floor,
        sample_std,
        outliers: options.outliers,
        runout: fitted.clone(),
    };
    // The output-error fit sees the data as measured when it fits the
    // runout, else what the filter saw.
    let oe_samples = if fitted.is_some() {
        &meas.samples
    } else {
        &seen.samples
    };
    match options.estimator {
        Estimator::OutputError => {
            crate::estimate::refine::refine(&mut id, oe_samples, &kept, &setup)?
        }
        Estimator::Rls => crate::estimate::refine::check(&mut id, &seen.samples, &kept, &setup)?,
    }
    Ok(id)
}

/// The per-sample standard deviations as the fit reads them (`n * nq + c`).
fn flatten_std(std: &[Vec<f64>], meas: &Measurements) -> Result<Vec<f64>, IdentifyError> {
    let nq = 2 * meas.n_bearings;
    if std.len() != meas.samples.len() || std.iter().any(|s| s.len() < nq) {
        return Err(IdentifyError::StdShape);
    }
    let flat: Vec<f64> = std.iter().flat_map(|s| s[..nq].iter().copied()).collect();
    if flat.iter().any(|x| !(x.is_finite() && *x > 0.0)) {
        return Err(IdentifyError::StdShape);
    }
    Ok(flat)
}

/// Subtracts the slow-roll vector of every channel, the mean of the
/// samples at or below `omega` (rad/s), from every sample.
pub fn subtract_slow_roll(meas: &mut Measurements, omega: f64) -> Result<(), IdentifyError> {
    let slow: Vec<&Sample> = meas.samples.iter().filter(|s| s.omega <= omega).collect();
    if slow.is_empty() {
        return Err(IdentifyError::NoSlowRoll {
            rpm: crate::units::rad_s_to_rpm(omega),
        });
    }
    let nq = meas.samples.first().map_or(0, |s| s.q.len());
    let mean: Vec<Complex64> = (0..nq)
        .map(|c| slow.iter().map(|s| s.q[c]).sum::<Complex64>() / slow.len() as f64)
        .collect();
    for s in &mut meas.samples {
        for (q, r) in s.q.iter_mut().zip(&mean) {
            *q -= r;
        }
    }
    Ok(())
}

/// The runout seen at the low speeds of a sweep: per channel, the constant
/// of `q(Omega) = r + b Omega^2 + d Omega^4` fitted by least squares to the
/// [`SLOW_ROLL_SAMPLES`] lowest-speed samples below a quarter of the
/// highest speed (where the unbalance response is the first terms of its
/// series in `Omega^2`), with the standard error of `r` from the fit's own
/// residuals.
#[derive(Debug, Clone, PartialEq)]
pub struct SlowRollEstimate {
    /// `r` per channel (m).
    pub runout: Vec<Complex64>,
    /// Its standard error `sqrt(E|dr|^2)` per channel (m).
    pub std: Vec<f64>,
}

/// Samples of the slow-roll fit.
pub const SLOW_ROLL_SAMPLES: usize = 12;

/// `|r| / std(r)` above which a channel's runout counts as present.
pub const RUNOUT_SIGNIFICANCE: f64 = 5.0;

impl SlowRollEstimate {
    /// Whether any channel's runout is significant
    /// ([`RUNOUT_SIGNIFICANCE`]).
    pub fn significant(&self) -> bool {
        self.runout
            .iter()
            .zip(&self.std)
            .any(|(r, s)| r.norm() > RUNOUT_SIGNIFICANCE * s)
    }
}

/// The [`SlowRollEstimate`] of a sweep; `None` with fewer than
/// [`SLOW_ROLL_SAMPLES`] distinct speeds below a quarter of the highest.
pub fn slow_roll_estimate(samples: &[Sample]) -> Option<SlowRollEstimate> {
    let top = max_speed(samples);
    let mut low: Vec<&Sample> = samples.iter().filter(|s| s.omega <= 0.25 * top).collect();
    low.sort_by(|a, b| a.omega.total_cmp(&b.omega));
    low.dedup_by(|a, b| a.omega == b.omega);
    if low.len() < SLOW_ROLL_SAMPLES {
        return None;
    }
    low.truncate(SLOW_ROLL_SAMPLES);
    let w_ref = low.last()?.omega;
    if w_ref.is_nan() || w_ref <= 0.0 {
        return None;
    }
    let x = DMatrix::from_fn(low.len(), 3, |i, j| {
        let u = (low[i].omega / w_ref).powi(2);
        u.powi(j as i32)
    });
    let xtx_inv = (x.transpose() * &x).try_inverse()?;
    let hat = &xtx_inv * x.transpose();
    let nq = low[0].q.len();
    let dof = (low.len() - 3) as f64;
    let mut runout = Vec::with_capacity(nq);
    let mut std = Vec::with_capacity(nq);
    for c in 0..nq {
        let y: Vec<Complex64> = low.iter().map(|s| s.q[c]).collect();
        let coef: Vec<Complex64> = (0..3)
            .map(|j| (0..y.len()).map(|i| y[i] * hat[(j, i)]).sum())
            .collect();
        let rss: f64 = (0..y.len())
            .map(|i| {
                let fit: Complex64 = (0..3).map(|j| coef[j] * x[(i, j)]).sum();
                (y[i] - fit).norm_sqr()
            })
            .sum();
        runout.push(coef[0]);
        std.push((rss / dof * xtx_inv[(0, 0)]).sqrt());
    }
    Some(SlowRollEstimate { runout, std })
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
    if nb == 0 {
        return Err(IdentifyError::NoBearing);
    }
    if meas.samples.is_empty() {
        return Err(IdentifyError::NoSamples);
    }
    if meas.n_bearings != nb || meas.samples.iter().any(|s| s.q.len() != 2 * nb) {
        return Err(IdentifyError::BearingCount {
            file: meas.n_bearings,
            model: nb,
        });
    }
    if !meas
        .samples
        .iter()
        .flat_map(|s| &s.q)
        .any(|z| z.norm() >= MIN_SIGNAL)
    {
        return Err(IdentifyError::NoSignal);
    }
    // Each distinct speed gives 2 N_b complex (4 N_b real) equations; the
    // same speed repeated gives the same equations again.
    let mut speeds: Vec<u64> = meas.samples.iter().map(|s| s.omega.to_bits()).collect();
    speeds.sort_unstable();
    speeds.dedup();
    let real_unknowns = options.structure.n_unknowns(nb, plane_nodes.len())
        * if options.structure.is_complex() { 2 } else { 1 };
    let equations = 4 * nb * speeds.len();
    if equations < real_unknowns {
        return Err(IdentifyError::NotDetermined {
            speeds: speeds.len(),
            equations,
            unknowns: real_unknowns,
        });
    }
    let scaling = options.scaling.unwrap_or_else(ColumnScaling::identity);
    let structure = options.structure;
    let param = Parametrization {
        structure,
        scaling,
        bearing_nodes: bearing_nodes.to_vec(),
        plane_nodes: plane_nodes.to_vec(),
    };
    let out = match (structure.formulation, options.precision) {
        (Formulation::Paper, Precision::F64) => {
            run::<f64, Complex<f64>>(param, meas, options, terms, progress)?
        }
        (Formulation::Paper, Precision::F32) => {
            run::<f32, Complex<f32>>(param, meas, options, terms, progress)?
        }
        (Formulation::Physical, Precision::F64) => {
            run::<f64, f64>(param, meas, options, terms, progress)?
        }
        (Formulation::Physical, Precision::F32) => {
            run::<f32, f32>(param, meas, options, terms, progress)?
        }
    };
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
    rows: Vec<WeightedRow>,
    /// `sum ln lambda_used` so far.
    log_w: f64,
    /// Rows are kept for the covariance: asked for
    /// ([`Options::covariance`]) and not yet too many.
    keep_rows: bool,
}

/// Rows kept for the covariance estimate (memory bound of the desktop
/// driver: 100000 rows of 22 complex values = 35 MB).
const MAX_COV_ROWS: usize = 100_000;

impl<T: Real, F: IdField<T> + Widen> State<T, F> {
    fn new(config: Config<T>, nb: usize, np: usize) -> Result<Self, IdentifierError> {
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
            keep_rows: true,
        };
        s.kernel().init()?;
        Ok(s)
    }

    fn kernel(&mut self) -> Kernel<'_, T, F> {
        Kernel {
            config: &self.config,
            nq: self.nq,
            np: self.np,
            factor: FactorMut::Dense {
                r: &mut self.r,
                p: &mut self.p,
            },
            guard: &mut self.guard,
            field: std::marker::PhantomData,
        }
    }

    fn step(&mut self, eq: &Equations<'_, T>) -> Result<StepReport<T>, IdentifierError> {
        let (mut d, mut u, mut xi, mut gamma) = (
            std::mem::take(&mut self.d),
            std::mem::take(&mut self.u),
            std::mem::take(&mut self.xi),
            std::mem::take(&mut self.gamma),
        );
        let res = self.kernel().step(
            eq,
            Scratch {
                d: &mut d,
                u: &mut u,
                xi: &mut xi,
                gamma: &mut gamma,
            },
        );
        (self.d, self.u, self.xi, self.gamma) = (d, u, xi, gamma);
        if let Ok(rep) = &res {
            let lam = rep.lambda_used.to_f64();
            if lam > 0.0 {
                self.log_w += lam.ln();
                let m = self.p.len();
                if self.keep_rows {
                    for (row, dj) in self.u.chunks_exact(m).zip(&self.d) {
                        let row = row.iter().map(|x| x.widen()).collect();
                        self.rows.push(WeightedRow {
                            u: row,
                            d: dj.widen(),
                            log_weight: self.log_w,
                        });
                    }
                    if self.rows.len() > MAX_COV_ROWS {
                        // Rows forgotten below 1e-8 of weight no longer
                        // matter; if that is not enough (lambda = 1 on a
                        // very long run), give the covariance up.
                        let log_w = self.log_w;
                        let cut = self
                            .rows
                            .partition_point(|r| log_w - r.log_weight < (1e-8f64).ln());
                        self.rows.drain(..cut);
                        if self.rows.len() > MAX_COV_ROWS {
                            self.rows = Vec::new();
                            self.keep_rows = false;
                        }
                    }
                }
            }
        }
        res
    }

    /// The covariance of the scaled weights from the rows kept
    /// ([`sandwich_covariance`]); `None` when the rows were given up.
    fn covariance(&self) -> Option<DMatrix<Complex64>> {
        if !self.keep_rows {
            return None;
        }
        let r: Vec<Complex64> = self.r.iter().map(|x| x.widen()).collect();
        let w: Vec<Complex64> = self.w.iter().map(|x| x.widen()).collect();
        sandwich_covariance(&r, &w, &self.rows, self.log_w)
    }

    fn estimates(&mut self, omega: T) -> Result<EstimateSet, IdentifierError> {
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
    param: Parametrization,
    meas: &Measurements,
    options: &Options,
    terms: &mut dyn FnMut(f64) -> Result<TermsAt, IdentifyError>,
    progress: Option<&dyn Fn(usize)>,
) -> Result<Identification, IdentifyError> {
    let (nb, np) = (param.n_bearings(), param.n_planes());
    let scaling = param.scaling;
    let scaling_t =
        ColumnScaling::<T>::new(scaling.stiffness, scaling.omega_ref, scaling.unbalance)
            .map_err(|_| IdentifyError::Scaling)?;
    let config = Config {
        structure: options.structure,
        lambda: T::lit(options.lambda),
        delta: T::lit(options.delta),
        scaling: scaling_t,
        normalise_rows: options.normalise_rows,
        steady: SteadyPolicy {
            coverage: options.steady.coverage,
            margin: T::lit(options.steady.margin),
            min_diag_ratio: T::lit(options.steady.min_diag_ratio),
            action: options.steady.action,
        },
    };
    config.validate().map_err(IdentifyError::Config)?;
    let mut st = State::<T, F>::new(config, nb, np).map_err(IdentifyError::Config)?;
    st.keep_rows = options.covariance;
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
            return Err(IdentifyError::TermsSize {
                a_rows: a.nrows(),
                a_cols: a.ncols(),
                b_rows: b.nrows(),
                b_cols: b.ncols(),
                nq,
                np,
            });
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
        let eq = Equations {
            omega: T::lit(s.omega),
            a: &a_t,
            b: &b_t,
            q: &q_t,
            nq,
            np,
        };
        let rep = st
            .step(&eq)
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
    let mut opts = options.clone();
    opts.scaling = Some(scaling);
    Ok(Identification {
        options: opts,
        param,
        refinement: None,
        check: None,
        history,
        last,
        steps: st.guard.steps,
        frozen: st.guard.frozen,
        scaled_weights,
        covariance,
    })
}

impl Identification {
    /// The text of a ROSS rotor file (format 3.x): `model` with its
    /// bearing laws replaced by the identified ones
    /// ([`Identification::identified_model`]; unbalance is not part of a
    /// ROSS rotor file). Constant laws (physical structure, order 1) are
    /// written as constants; laws that change with speed (physical order
    /// P > 1, `K(Omega) = sum_p K_p Omega^p`; the paper structure,
    /// `Z_B = sum_p Omega^p Z_p`) as PCHIP tables of
    /// [`crate::io::ross::ROSS_TABLE_POINTS`] speeds spread evenly over the
    /// speed range of `meas`, which is where the law was fitted.
    pub fn ross_toml(
        &self,
        model: &RotorModel,
        meas: &Measurements,
    ) -> Result<String, crate::io::ross::RossError> {
        let omega_min = meas
            .samples
            .iter()
            .map(|s| s.omega)
            .fold(f64::INFINITY, f64::min);
        let identified = self.identified_model(model);
        let tabulated = crate::io::ross::tabulate_for_ross(
            &identified,
            omega_min,
            max_speed(&meas.samples),
            crate::io::ross::ROSS_TABLE_POINTS,
        )?;
        crate::io::ross::to_ross_toml(&tabulated)
    }

    /// The identified bearing laws, exactly the `Z_B(Omega)` the structure
    /// fitted ([`Parametrization::bearing_laws`]).
    pub fn bearing_laws(&self) -> Vec<BearingLaw> {
        self.param.bearing_laws(&self.scaled_weights)
    }

    /// `model` with its bearing laws replaced by the identified ones and its
    /// unbalance by the identified one (at the plane nodes): the identified
    /// rotor, e.g. for its Campbell diagram.
    pub fn identified_model(&self, model: &RotorModel) -> RotorModel {
        let mut out = model.clone();
        for (b, law) in out.bearings.iter_mut().zip(self.bearing_laws()) {
            b.law = law;
        }
        out.unbalance = self
            .param
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
}
