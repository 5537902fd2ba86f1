//! Bearing stiffness, damping and unbalance identification, one measured
//! speed at a time (the method paper's section 3.3, with the corrections of
//! [`crate::regressor`]).
//!
//! Per measurement `(Omega, q_B)`:
//!
//! 1. the input is validated (non-finite speed or phasor: error, state
//!    untouched);
//! 2. the reduced shaft terms `A(Omega)`, `B(Omega)` come from the table
//!    ([`crate::table::BearingTable::terms`]) or from the caller;
//! 3. the scaled regression `d = (U S) w~` is formed
//!    ([`crate::regressor`], [`crate::scaling`]), optionally with each row
//!    normalised ([`crate::regressor::normalise_rows`]);
//! 4. the excitation guard picks this step's forgetting factor (below);
//! 5. the QRD/RLS factor is updated (complex field for the `paper`
//!    structure, real for `physical`): by the block-structured filter
//!    [`crate::blockqrd`] when the identifier holds a [`BlockFactor`] (each
//!    row touches one channel's bearing coefficients and the shared
//!    unbalance unknowns), else by the dense [`crate::qrdrls::update_rows`];
//!    both give the same numbers.
//!
//! Estimates (`K`, `C` per bearing, `m e` and phase per plane, and the
//! paper structure's consistency values `Im Z_0`, `Re Z_1`) come on demand
//! from a back-substitution.
//!
//! # Steady running (estimator wind-up)
//!
//! At constant speed successive 1X measurements repeat the same `2 N_b`
//! equations: they carry no information on the other `M - 2 N_b`
//! directions of `w`. With `lambda < 1` the factor `R` keeps shrinking by
//! `sqrt(lambda)` per step in those directions, until noise alone steers the
//! estimates there (wind-up). The guard [`SteadyPolicy`] therefore lets a
//! step forget only when it brings speeds the memory does not hold yet.
//!
//! What a step adds: the rows `U(Omega)` are smooth (rational) functions
//! of the speed, so the information a step brings beyond the factor's is
//! the part of `U(Omega)` outside the span of the rows already folded in.
//! A speed inside the range the recent steps covered, `Omega_min <= Omega
//! <= Omega_max`, gives rows that are, to the order of interpolation,
//! combinations of the rows of those steps: forgetting for it shrinks every
//! other direction by `lambda` and adds nothing new. A speed outside that
//! range extends the span. The rule (speed coverage), with `Omega_k` the
//! speeds of the last [`COVERAGE_STEPS`] excited steps (a ring in
//! [`GuardState`]; the first step is excited):
//!
//! ```text
//! held(n)  <=>  |Omega(n) - Omega_k| <= margin for some k
//!          or   lo < Omega(n) < hi with lo, hi neighbouring Omega_k and
//!               hi - lo <= max(margin, GAP Omega(n))     (GAP = 1 %).
//! ```
//!
//! A sweep in either direction, at any step size, reaches beyond the
//! recent speeds at every sample: no sample is held; after a jump (a
//! repeated run-up starting again from the bottom) the gap to the old
//! speeds is wide, so the new sweep is kept too. A constant speed, or a
//! dither between speeds (`9000 <-> 9011 rpm`), is held once its speeds
//! are among the recent ones: at most one step per distinct speed forgets
//! there, whatever the length of the stretch. When a sweep turns back (run-up then coast-down),
//! the samples that re-cover the last [`COVERAGE_STEPS`] excited speeds are
//! held, the rest forget again. Optionally, the factor's conditioning
//! indicator `min|R_ii| / max|R_ii|` must also be above `min_diag_ratio`.
//!
//! A held step is skipped by default (the estimates stay exactly where the
//! last excited step left them), or folded in with `lambda = 1`
//! ([`SteadyAction`]). Skipping also discards the noise averaging repeated
//! samples at one speed could give: the price of hours at one speed never
//! outweighing the sweep (folded in, 20000 samples at one speed pull the
//! estimates toward that speed's equation-error fit, see
//! [`SteadyAction::FreezeForgetting`]).
//!
//! Two drivers share this code: [`Identifier`] (const-generic, inline
//! arrays, firmware) and any caller with runtime-sized buffers through
//! [`Kernel`] (the desktop driver in `rotorid::identify`).

use crate::blockqrd::{BlockFactor, BlockShape};
use crate::factor::{DenseFactor, Factor, FactorMut, FilterState};
use crate::parametrization::{
    bearing_estimate, unbalance_estimate, BearingEstimate, Formulation, ParamError, Structure,
    UnbalanceEstimate, MAX_ORDER,
};
use crate::qrdrls::{self, FilterError};
use crate::regressor::{self, Equations, RegressorError};
use crate::scalar::Real;
use crate::scaling::ColumnScaling;
use crate::sqrtfree::SqrtFreeFactor;
use crate::table::{BearingTable, TableError, TableSetup};
use core::fmt;
use nalgebra::ComplexField;
use num_complex::Complex;

/// Errors of the identifier.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum IdentifierError {
    /// Non-finite speed, phasor or table term (state untouched).
    NonFinite,
    /// Sizes (`M`, `N`, buffers, bearing or plane index) do not match the
    /// structure, or the field type does not match the formulation.
    Dimension,
    /// The configuration's structure is not the one the identifier's type
    /// determines ([`Identifier::STRUCTURE`]).
    Structure {
        /// The structure of the type (from `F`, `NQ`, `NP`, `M`).
        expected: Structure,
        /// The structure asked for.
        found: Structure,
    },
    /// Polynomial order outside `1..=MAX_ORDER`.
    InvalidOrder,
    /// Negative speed.
    InvalidSpeed,
    /// Guard thresholds, or the prefilter's noise floor
    /// ([`crate::prefilter::NoiseFloor`]), out of range (negative or not
    /// finite).
    InvalidConfig,
    /// Forgetting factor outside `[MIN_LAMBDA, 1]` (see [`MIN_LAMBDA`]).
    InvalidLambda,
    /// Regularisation outside `[1 / L, L]`, `L = sqrt(T::MAX)` (see
    /// [`delta_range`]).
    InvalidDelta,
    /// A physical estimate (after back-substitution and unscaling) is not
    /// finite: the weights are too large for the working precision.
    EstimateOverflow,
    /// The table could not give the terms at this speed.
    Table(TableError),
    /// The filter refused the update or the back-substitution.
    Filter(FilterError),
}

impl fmt::Display for IdentifierError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            IdentifierError::NonFinite => f.write_str("non-finite speed, response or table term"),
            IdentifierError::Dimension => {
                f.write_str("sizes do not match the model structure (M, N, bearings, planes)")
            }
            IdentifierError::Structure { expected, found } => write!(
                f,
                "structure {:?} order {} asked for, but the identifier's type is {:?} order {}",
                found.formulation, found.order, expected.formulation, expected.order
            ),
            IdentifierError::InvalidOrder => f.write_str("polynomial order out of range"),
            IdentifierError::InvalidSpeed => f.write_str("speed must be >= 0"),
            IdentifierError::InvalidConfig => f.write_str(
                "steady-running guard thresholds and noise floors must be finite and >= 0",
            ),
            IdentifierError::InvalidLambda => f.write_str(
                "forgetting factor lambda must lie in [0.368, 1] (a memory of at least one update)",
            ),
            IdentifierError::InvalidDelta => f.write_str(
                "regularisation delta must lie in [1/sqrt(MAX), sqrt(MAX)] of the working precision \
                 (f32: 5.4e-20..1.8e19, f64: 7.5e-155..1.3e154)",
            ),
            IdentifierError::EstimateOverflow => f.write_str(
                "an estimate is not finite in the working precision (the data cannot determine it)",
            ),
            IdentifierError::Table(e) => write!(f, "table lookup failed: {e}"),
            IdentifierError::Filter(e) => write!(f, "filter: {e}"),
        }
    }
}

impl core::error::Error for IdentifierError {}

impl From<RegressorError> for IdentifierError {
    fn from(e: RegressorError) -> Self {
        match e {
            RegressorError::InvalidOrder => IdentifierError::InvalidOrder,
            RegressorError::Dimension => IdentifierError::Dimension,
            RegressorError::NonFinite => IdentifierError::NonFinite,
        }
    }
}

impl From<ParamError> for IdentifierError {
    fn from(e: ParamError) -> Self {
        match e {
            ParamError::InvalidOrder => IdentifierError::InvalidOrder,
            ParamError::Dimension => IdentifierError::Dimension,
        }
    }
}

impl From<FilterError> for IdentifierError {
    fn from(e: FilterError) -> Self {
        match e {
            FilterError::NonFinite => IdentifierError::NonFinite,
            other => IdentifierError::Filter(other),
        }
    }
}

/// What a step judged not excited does.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SteadyAction {
    /// Do not fold the rows in at all (the default): the estimates stay
    /// exactly where the last excited step left them; the data of the
    /// stretch are discarded.
    #[default]
    Skip,
    /// Fold the rows in with `lambda = 1`: nothing is forgotten and the new
    /// rows average the noise in the directions they excite. Over very long
    /// stretches the repeated equations of that one speed outweigh the
    /// sweep, so with noisy data the estimates drift toward that speed's
    /// (errors-in-variables biased) least-squares fit: measured with 1%
    /// noise, lambda 0.99 and 20000 samples at 9000 rpm after a 300-speed
    /// sweep, unbalance errors grew 2x (physical) to 7x (paper structure);
    /// without a guard by 100x to 3000x.
    FreezeForgetting,
}

/// Number of most recent excited speeds a step is compared with (see the
/// module documentation).
pub const COVERAGE_STEPS: usize = 4;

/// Relative width of a gap between recent excited speeds below which a
/// speed inside it counts as covered (1 % of the speed).
pub const GAP: f64 = 0.01;

/// Poor-excitation guard (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SteadyPolicy<T> {
    /// Speed-coverage criterion on: a step forgets only if its speed is new
    /// for the last [`COVERAGE_STEPS`] excited speeds (see the module
    /// documentation). `false`: every step forgets (unless
    /// `min_diag_ratio` holds it).
    pub coverage: bool,
    /// Margin (rad/s, `>= 0`): a speed within it of a recent excited speed
    /// is not new; `0` (the default) holds only repeated speeds. A
    /// margin above the measurement jitter of the speed keeps jitter from
    /// counting as new speeds.
    pub margin: T,
    /// Minimum `min|R_ii| / max|R_ii|` of the factor (before the step) for
    /// it to forget. `0` disables this criterion.
    pub min_diag_ratio: T,
    /// What to do with a step that is not excited.
    pub action: SteadyAction,
}

impl<T: Real> SteadyPolicy<T> {
    /// No guard: every step uses the configured `lambda` (the paper).
    pub fn off() -> Self {
        SteadyPolicy {
            coverage: false,
            margin: T::zero(),
            min_diag_ratio: T::zero(),
            action: SteadyAction::FreezeForgetting,
        }
    }

    /// The default guard: a step is excited only if its speed lies outside
    /// the range of the last [`COVERAGE_STEPS`] excited speeds (no margin);
    /// no conditioning criterion; unexcited steps are skipped.
    pub fn default_guard() -> Self {
        SteadyPolicy {
            coverage: true,
            margin: T::zero(),
            min_diag_ratio: T::zero(),
            action: SteadyAction::Skip,
        }
    }
}

/// Configuration of an identifier.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Config<T> {
    /// Model structure (formulation and order).
    pub structure: Structure,
    /// Forgetting factor `lambda` in `(0, 1]`.
    pub lambda: T,
    /// Regularisation: `R(0) = sqrt(delta) I` on the **scaled** unknowns.
    pub delta: T,
    /// Column scaling `S` ([`ColumnScaling::identity`] for raw SI).
    pub scaling: ColumnScaling<T>,
    /// Divide each row of `[U d]` by the norm of its `U` part before the
    /// update (changes the least-squares weighting, see
    /// [`regressor::normalise_rows`]).
    pub normalise_rows: bool,
    /// Poor-excitation guard.
    pub steady: SteadyPolicy<T>,
}

impl<T: Real> Config<T> {
    /// The defaults for `structure` and `scaling`: `lambda = 0.999`,
    /// `delta = 1e-7` (the SPEC's), no row normalisation, the default
    /// steady-running guard ([`SteadyPolicy::default_guard`]). Change them
    /// with the `with_*` methods:
    ///
    /// ```
    /// use rotorid_core::identify::{Config, SteadyPolicy};
    /// use rotorid_core::parametrization::Structure;
    /// use rotorid_core::scaling::ColumnScaling;
    ///
    /// let c = Config::<f32>::new(Structure::physical(1), ColumnScaling::identity())
    ///     .with_lambda(0.99)
    ///     .with_steady(SteadyPolicy::off());
    /// assert_eq!((c.lambda, c.delta, c.normalise_rows), (0.99, 1e-7, false));
    /// assert!(c.validate().is_ok());
    /// ```
    pub fn new(structure: Structure, scaling: ColumnScaling<T>) -> Self {
        Config {
            structure,
            lambda: T::lit(0.999),
            delta: T::lit(1e-7),
            scaling,
            normalise_rows: false,
            steady: SteadyPolicy::default_guard(),
        }
    }

    /// With forgetting factor `lambda` (in `(0, 1]`, checked by [`Self::validate`]).
    pub fn with_lambda(mut self, lambda: T) -> Self {
        self.lambda = lambda;
        self
    }

    /// With regularisation `delta` (`R(0) = sqrt(delta) I`, finite and > 0).
    pub fn with_delta(mut self, delta: T) -> Self {
        self.delta = delta;
        self
    }

    /// With another column scaling.
    pub fn with_scaling(mut self, scaling: ColumnScaling<T>) -> Self {
        self.scaling = scaling;
        self
    }

    /// With row normalisation on or off (see [`Config::normalise_rows`]).
    pub fn with_normalise_rows(mut self, normalise_rows: bool) -> Self {
        self.normalise_rows = normalise_rows;
        self
    }

    /// With another steady-running guard.
    pub fn with_steady(mut self, steady: SteadyPolicy<T>) -> Self {
        self.steady = steady;
        self
    }

    /// Checks `lambda` (in `[MIN_LAMBDA, 1]`), `delta` (in [`delta_range`]),
    /// the order and the guard thresholds.
    pub fn validate(&self) -> Result<(), IdentifierError> {
        self.structure.validate()?;
        if !(self.lambda >= T::lit(MIN_LAMBDA) && self.lambda <= T::one()) {
            return Err(IdentifierError::InvalidLambda);
        }
        let (lo, hi) = delta_range::<T>();
        if !(self.delta >= lo && self.delta <= hi) {
            return Err(IdentifierError::InvalidDelta);
        }
        let ok = |x: T| x.is_finite() && x >= T::zero();
        if !(ok(self.steady.margin) && ok(self.steady.min_diag_ratio)) {
            return Err(IdentifierError::InvalidConfig);
        }
        Ok(())
    }
}

/// Smallest forgetting factor the identifier accepts: `exp(-1)`. The
/// memory of the filter, the number of updates over which the weight of an
/// old update falls by `e` (`-1 / ln lambda`), is then at least one update;
/// below it each update all but replaces the previous ones and the filter
/// is meaningless.
pub const MIN_LAMBDA: f64 = 0.367_879_441_171_442_33;

/// The range `[1 / L, L]` of the regularisation `delta`, `L = sqrt(T::MAX)`
/// ([`qrdrls::input_limit`]): `R(0) = sqrt(delta) I` and its inverse stay
/// far from overflow and underflow (f32: `5.4e-20..1.8e19`, f64:
/// `7.5e-155..1.3e154`).
pub fn delta_range<T: Real>() -> (T, T) {
    let l = qrdrls::input_limit::<T>();
    (T::one() / l, l)
}

/// The field of the filter for a formulation: `Complex<T>` for
/// [`Formulation::Paper`], `T` for [`Formulation::Physical`]. Dispatches
/// the regressor.
pub trait IdField<T: Real>: ComplexField<RealField = T> + Copy {
    /// The formulation this field serves.
    const FORMULATION: Formulation;

    /// Forms `d` and `U S` (see [`regressor::form_paper`],
    /// [`regressor::form_physical`]).
    fn form(
        order: usize,
        scaling: &ColumnScaling<T>,
        eq: &Equations<'_, T>,
        d: &mut [Self],
        u: &mut [Self],
    ) -> Result<(), RegressorError>;
}

impl<T: Real> IdField<T> for Complex<T> {
    const FORMULATION: Formulation = Formulation::Paper;

    fn form(
        order: usize,
        scaling: &ColumnScaling<T>,
        eq: &Equations<'_, T>,
        d: &mut [Self],
        u: &mut [Self],
    ) -> Result<(), RegressorError> {
        regressor::form_paper(order, scaling, eq, d, u)
    }
}

macro_rules! real_field {
    ($t:ty) => {
        impl IdField<$t> for $t {
            const FORMULATION: Formulation = Formulation::Physical;

            fn form(
                order: usize,
                scaling: &ColumnScaling<$t>,
                eq: &Equations<'_, $t>,
                d: &mut [Self],
                u: &mut [Self],
            ) -> Result<(), RegressorError> {
                regressor::form_physical(order, scaling, eq, d, u)
            }
        }
    };
}
real_field!(f32);
real_field!(f64);

/// What one step did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepReport<T> {
    /// Speed of the step (rad/s).
    pub omega: T,
    /// Whether the guard judged the step excited (forgetting applied).
    pub excited: bool,
    /// The forgetting factor used (`lambda`, or `1` when not excited; `0`
    /// when the step was skipped, see [`SteadyAction::Skip`]).
    pub lambda_used: T,
    /// RMS of the a-posteriori errors over RMS of `d` (after scaling and
    /// optional row normalisation): how well the current model fits this
    /// step's equations (`0` for a skipped step).
    pub relative_residual: T,
}

/// Excitation-guard state: the speeds of the last excited steps.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct GuardState<T> {
    /// Speeds (rad/s) of the last [`COVERAGE_STEPS`] excited steps, a ring:
    /// the first `min(excited, COVERAGE_STEPS)` entries are valid, the next
    /// one written is `excited % COVERAGE_STEPS`.
    pub recent: [T; COVERAGE_STEPS],
    /// Number of excited steps so far.
    pub excited: u64,
    /// Number of steps folded in.
    pub steps: u64,
    /// Number of those steps with forgetting frozen.
    pub frozen: u64,
}

impl<T: Real> GuardState<T> {
    /// The valid part of [`Self::recent`].
    pub fn recent_speeds(&self) -> &[T] {
        let n = usize::try_from(self.excited).map_or(COVERAGE_STEPS, |n| n.min(COVERAGE_STEPS));
        self.recent.get(..n).unwrap_or(&self.recent)
    }

    /// Whether `omega` is a new speed for the recent excited speeds
    /// `Omega_k`: not within `margin` of any of them, and not inside a gap
    /// between two of them (neighbours in speed) narrower than
    /// `max(margin, GAP * omega)` (always before the first excited step).
    pub fn extends_coverage(&self, omega: T, margin: T) -> bool {
        let recent = self.recent_speeds();
        if recent.iter().any(|&w| (omega - w).abs() <= margin) {
            return false;
        }
        let below = recent
            .iter()
            .filter(|&&w| w < omega)
            .copied()
            .reduce(T::max);
        let above = recent
            .iter()
            .filter(|&&w| w > omega)
            .copied()
            .reduce(T::min);
        match (below, above) {
            (Some(lo), Some(hi)) => hi - lo > margin.max(T::lit(GAP) * omega.abs()),
            _ => true,
        }
    }

    /// Records an excited step at `omega`.
    pub(crate) fn record_excited(&mut self, omega: T) {
        // `excited % COVERAGE_STEPS` fits in usize whatever usize's width.
        let slot = (self.excited % COVERAGE_STEPS as u64) as usize;
        if let Some(r) = self.recent.get_mut(slot) {
            *r = omega;
        }
        self.excited = self.excited.saturating_add(1);
    }
}

/// The identification step on caller buffers (runtime or fixed sizes):
/// `factor` holds the filter state (dense, or block-structured with the
/// layout [`BlockShape::of`] the structure); `d`, `u`, `xi`, `gamma`
/// are scratch of lengths `N`, `N x M`, `N`, `N`. Used by [`Identifier`] and
/// by the desktop driver, so both run exactly the same arithmetic.
#[derive(Debug)]
pub struct Kernel<'a, T, F, V = FactorMut<'a, F>> {
    /// Configuration.
    pub config: &'a Config<T>,
    /// Number of bearing channels `2 N_b`.
    pub nq: usize,
    /// Number of unbalance planes.
    pub np: usize,
    /// Filter state (factor `R` and rotated right-hand side `p`): a
    /// [`FactorMut`] (dense, on caller slices) or an identifier's inline
    /// storage ([`crate::factor::Factor`]) borrowed as `&mut R`.
    pub factor: V,
    /// The field `F` of the filter (`Complex<T>` or `T`).
    pub field: core::marker::PhantomData<F>,
    /// Guard state.
    pub guard: &'a mut GuardState<T>,
}

/// Scratch buffers of one step: `d`, `U S`, a-posteriori errors `xi`
/// (length `N`, `N x M`, `N`) and conversion factors `gamma` (`N`).
#[derive(Debug)]
pub struct Scratch<'a, T, F> {
    /// Desired response `d`.
    pub d: &'a mut [F],
    /// Scaled data matrix `U S`, row-major.
    pub u: &'a mut [F],
    /// A-posteriori errors.
    pub xi: &'a mut [F],
    /// Conversion factors.
    pub gamma: &'a mut [T],
}

/// Checks that field, `M` and `N` match the structure for `nq` channels and
/// `np` planes.
pub fn check_sizes<T: Real, F: IdField<T>>(
    structure: &Structure,
    nq: usize,
    np: usize,
    m: usize,
    n: usize,
) -> Result<(), IdentifierError> {
    structure.validate()?;
    if F::FORMULATION != structure.formulation
        || nq == 0
        || nq % 2 != 0
        || m != structure.n_unknowns(nq / 2, np)
        || n != structure.n_rows(nq / 2)
    {
        return Err(IdentifierError::Dimension);
    }
    Ok(())
}

impl<T: Real, F: IdField<T>, V: FilterState<F>> Kernel<'_, T, F, V> {
    /// A block-structured factor must have the layout of the structure.
    fn check_layout(&self) -> Result<(), IdentifierError> {
        match self.factor.shape() {
            Some(s) if s != BlockShape::of(self.config.structure, self.nq / 2, self.np) => {
                Err(IdentifierError::Dimension)
            }
            _ => Ok(()),
        }
    }

    /// Initialises the filter state: `R = sqrt(delta) I`, `w~ = 0`, guard reset.
    pub fn init(&mut self) -> Result<(), IdentifierError> {
        self.config.validate()?;
        check_sizes::<T, F>(
            &self.config.structure,
            self.nq,
            self.np,
            self.factor.unknowns(),
            self.config.structure.n_rows(self.nq / 2),
        )?;
        self.check_layout()?;
        self.factor.init(self.config.delta)?;
        *self.guard = GuardState::default();
        Ok(())
    }

    /// One measurement `eq` (speed, terms `A`, `B`, phasors `q`; see
    /// [`Equations`]) with scratch buffers `scratch`. On any error the
    /// state is untouched.
    pub fn step(
        &mut self,
        eq: &Equations<'_, T>,
        scratch: Scratch<'_, T, F>,
    ) -> Result<StepReport<T>, IdentifierError> {
        let cfg = self.config;
        let Scratch { d, u, xi, gamma } = scratch;
        let omega = eq.omega;
        if !omega.is_finite() || eq.q.iter().any(|z| !(z.re.is_finite() && z.im.is_finite())) {
            return Err(IdentifierError::NonFinite);
        }
        if eq.nq != self.nq || eq.np != self.np {
            return Err(IdentifierError::Dimension);
        }
        if omega < T::zero() {
            return Err(IdentifierError::InvalidSpeed);
        }
        let order = cfg.structure.order;
        let m = self.factor.unknowns();
        let n = d.len();
        check_sizes::<T, F>(&cfg.structure, self.nq, self.np, m, n)?;
        self.check_layout()?;
        F::form(order, &cfg.scaling, eq, d, u)?;
        if cfg.normalise_rows {
            regressor::normalise_rows(u, d, n, m)?;
        }
        // Excitation guard.
        let mut excited =
            !cfg.steady.coverage || self.guard.extends_coverage(omega, cfg.steady.margin);
        if excited && cfg.steady.min_diag_ratio > T::zero() {
            let ratio = self.factor.diag_ratio()?;
            if ratio < cfg.steady.min_diag_ratio {
                excited = false;
            }
        }
        let lambda_used = if excited { cfg.lambda } else { T::one() };
        if !excited && cfg.steady.action == SteadyAction::Skip {
            // Not folded in: the state is left exactly as it was.
            self.guard.frozen += 1;
            self.guard.steps += 1;
            return Ok(StepReport {
                omega,
                excited,
                lambda_used: T::zero(),
                relative_residual: T::zero(),
            });
        }
        // The rows come in one group per channel, each in its channel's
        // block (checked layout): a block filter may read only those
        // entries.
        self.factor
            .update_grouped_rows(u, d, lambda_used, xi, gamma)?;
        // Only now (the filter accepted the step) does the guard move.
        if excited {
            self.guard.record_excited(omega);
        } else {
            self.guard.frozen += 1;
        }
        self.guard.steps += 1;
        let mut en = T::zero();
        let mut dn = T::zero();
        for (x, y) in xi.iter().zip(d.iter()) {
            en += x.modulus_squared();
            dn += y.modulus_squared();
        }
        let relative_residual = if dn > T::zero() {
            (en / dn).sqrt()
        } else {
            T::zero()
        };
        Ok(StepReport {
            omega,
            excited,
            lambda_used,
            relative_residual,
        })
    }

    /// Current scaled weights `w~` into `w` (length `M`).
    pub fn weights(&self, w: &mut [F]) -> Result<(), IdentifierError> {
        self.factor.solve_weights(w)?;
        Ok(())
    }
}

/// Physical estimates from scaled weights `w~`: bearings into `bearings`
/// (length `N_b`), evaluated at `omega` (matters for order > 1), planes into
/// `unbalance` (length `N_p`).
pub fn estimates_into<T: Real, F: IdField<T>>(
    config: &Config<T>,
    w: &[F],
    nq: usize,
    np: usize,
    omega: T,
    bearings: &mut [BearingEstimate<T>],
    unbalance: &mut [UnbalanceEstimate<T>],
) -> Result<(), IdentifierError> {
    let nb = nq / 2;
    if bearings.len() != nb || unbalance.len() != np {
        return Err(IdentifierError::Dimension);
    }
    let st = &config.structure;
    let finite = |v: &[T; 4]| v.iter().all(|x| x.is_finite());
    for (m, be) in bearings.iter_mut().enumerate() {
        *be = bearing_estimate(st, &config.scaling, w, nb, np, m, omega)?;
        if !(finite(&be.k)
            && finite(&be.c)
            && be.im_z0.as_ref().is_none_or(finite)
            && be.re_z1.as_ref().is_none_or(finite))
        {
            return Err(IdentifierError::EstimateOverflow);
        }
    }
    for (k, ue) in unbalance.iter_mut().enumerate() {
        *ue = unbalance_estimate(st, &config.scaling, w, nb, np, k)?;
        if !(ue.a.re.is_finite() && ue.a.im.is_finite() && ue.me.is_finite()) {
            return Err(IdentifierError::EstimateOverflow);
        }
    }
    Ok(())
}

/// Physical estimates of a const-generic identifier.
#[derive(Debug, Clone, PartialEq)]
pub struct Estimates<T, const NQ: usize, const NP: usize> {
    /// Speed at which the bearing coefficients are evaluated (rad/s).
    pub omega: T,
    /// One entry per bearing (`NQ / 2` of them).
    pub bearings: heapless::Vec<BearingEstimate<T>, NQ>,
    /// One entry per plane.
    pub unbalance: [UnbalanceEstimate<T>; NP],
}

impl<T: Real, const NQ: usize, const NP: usize> Estimates<T, NQ, NP> {
    /// The physical estimates of the scaled weights `w` ([`estimates_into`]),
    /// bearings evaluated at `omega`.
    pub fn from_weights<F: IdField<T>>(
        config: &Config<T>,
        w: &[F],
        omega: T,
    ) -> Result<Self, IdentifierError> {
        let zero_b = BearingEstimate {
            k: [T::zero(); 4],
            c: [T::zero(); 4],
            im_z0: None,
            re_z1: None,
        };
        let mut bearings: heapless::Vec<BearingEstimate<T>, NQ> = heapless::Vec::new();
        for _ in 0..NQ / 2 {
            bearings
                .push(zero_b)
                .map_err(|_| IdentifierError::Dimension)?;
        }
        let zero_u = UnbalanceEstimate::from_phasor(Complex::new(T::zero(), T::zero()));
        let mut unbalance = [zero_u; NP];
        estimates_into(config, w, NQ, NP, omega, &mut bearings, &mut unbalance)?;
        Ok(Estimates {
            omega,
            bearings,
            unbalance,
        })
    }
}

/// The firmware identifier: `NQ = 2 N_b` channels, `NP` planes, `M`
/// unknowns, `N` rows per update, all fixed at compile time, inline storage.
/// `F = Complex<T>` for the paper structure, `F = T` for the physical one;
/// `R` is the filter (see [Filter state](#filter-state); the aliases
/// [`PhysicalIdentifier`], [`PaperIdentifier`] give the recommended one).
///
/// The type determines the structure: the formulation comes from `F`, and
/// `M = per_bearing NQ/2 + per_plane NP` fixes the order
/// ([`Self::STRUCTURE`], [`Self::ORDER`]). A type whose `NQ` is odd or
/// zero, whose `N` is not `NQ` (paper) or `2 NQ` (physical), or whose `M`
/// fits no order in `1..=MAX_ORDER` does not compile. `rotorid tables`
/// writes the right type as `type Id` into the generated Rust source.
///
/// # Firmware in four lines
///
/// With a table generated by `rotorid tables --out paper_table_f32.rs --f32`
/// (it defines `TABLE`, `STRUCTURE`, `SCALING` and `type Id`):
///
/// ```
/// # use rotorid_core::identify::{Config, IdentifierError};
/// # use rotorid_core::Complex;
/// # mod generated { include!("../../tests/data/paper_table_f32.rs"); }
/// # use generated::{Id, SCALING, STRUCTURE, TABLE};
/// # fn main() -> Result<(), IdentifierError> {
/// # let (omega, q) = (700.0f32, [Complex::new(1e-6f32, 2e-7); 4]);
/// let mut id = Id::new(Config::new(STRUCTURE, SCALING))?; // or Id::from_table(&TABLE)
/// id.update(&TABLE, omega, &q)?;
/// let est = id.estimates(omega)?;
/// # let _ = (est.bearings[0].k, est.unbalance[2].me);
/// # assert_eq!(Id::STRUCTURE, STRUCTURE);
/// # assert_eq!(Id::from_table(&TABLE)?.config(), id.config());
/// # Ok(())
/// # }
/// ```
///
/// Written out (`include!` the generated file into a module of its own):
///
/// ```
/// use rotorid_core::identify::{Config, IdentifierError};
/// use rotorid_core::Complex;
///
/// mod table {
///     // TABLE, STRUCTURE, SCALING, type Id
///     include!("../../tests/data/paper_table_f32.rs");
/// }
/// use table::{Id, SCALING, STRUCTURE, TABLE};
///
/// fn main() -> Result<(), IdentifierError> {
///     let mut id = Id::new(Config::new(STRUCTURE, SCALING))?;
///     let (omega, q) = (700.0f32, [Complex::new(1e-6f32, 2e-7); 4]); // rad/s, m
///     id.update(&TABLE, omega, &q)?;
///     let est = id.estimates(omega)?;
///     let (k_yy, me) = (est.bearings[0].k[0], est.unbalance[0].me);
///     # let _ = (k_yy, me);
///     assert_eq!(Id::ORDER, 1); // the table was written for `physical` 1
///     Ok(())
/// }
/// ```
///
/// A wrong `M` (22 is `physical` 1 for 2 bearings and 3 planes) is a
/// compile error, not a run-time one:
///
/// ```compile_fail
/// use rotorid_core::identify::{Config, PhysicalDenseIdentifier};
/// use rotorid_core::parametrization::Structure;
/// use rotorid_core::scaling::ColumnScaling;
///
/// let config = Config::<f32>::new(Structure::physical(1), ColumnScaling::identity());
/// let id = PhysicalDenseIdentifier::<f32, 4, 3, 21, 8>::new(config);
/// ```
///
/// # Filter state
///
/// `R` is the filter's storage ([`Factor`]), named by the aliases:
///
/// | filter | physical (`F = T`) | paper (`F = Complex<T>`) | `R` |
/// |---|---|---|---|
/// | square-root-free block: the fastest, the generated `type Id` | [`PhysicalIdentifier`] | [`PaperIdentifier`] | [`SqrtFreeFactor`] |
/// | Givens block: range-safe, the desktop's bits | [`PhysicalGivensIdentifier`] | [`PaperGivensIdentifier`] | [`BlockFactor`] |
/// | dense Givens: any rows, the desktop's filter | [`PhysicalDenseIdentifier`] | [`PaperDenseIdentifier`] | [`DenseFactor`] |
///
/// The block filters store `NB = NQ` blocks of `W` channel coefficients
/// and `S` shared unbalance unknowns ([`BlockShape::of`]; `W`, `S` are
/// among the generated constants) and update in time linear in `N_b`; the
/// dense one stores `M^2 + M` entries. All three give the same estimates
/// to round-off, the two Givens filters to the bit. The square-root-free
/// filter refuses a step whose arithmetic would leave the range of `T`
/// ([`IdentifierError::Filter`] with `OutOfRange`, state untouched) where the
/// Givens filters' bounded entries go on; with the unknowns scaled to order
/// one ([`crate::scaling`]) that takes data far outside any machine's. A
/// block layout that is not the structure's is [`IdentifierError::Dimension`].
#[derive(Debug, Clone, PartialEq)]
pub struct Identifier<T, F, const NQ: usize, const NP: usize, const M: usize, const N: usize, R> {
    config: Config<T>,
    factor: R,
    guard: GuardState<T>,
    _field: core::marker::PhantomData<F>,
}

/// The recommended identifier with real K, C unknowns (`physical`
/// structure): the square-root-free block filter ([`crate::sqrtfree`]),
/// the fastest; `W = 4 P` coefficients per channel, `S = 2 N_p` shared
/// unbalance unknowns ([`BlockShape::of`]). The generated `type Id` of
/// `rotorid tables`. May refuse a step whose arithmetic would leave the
/// range (state untouched); see [`Identifier`].
pub type PhysicalIdentifier<
    T,
    const NQ: usize,
    const NP: usize,
    const M: usize,
    const N: usize,
    const W: usize,
    const S: usize,
> = Identifier<T, T, NQ, NP, M, N, SqrtFreeFactor<T, NQ, W, S>>;

/// The recommended identifier with the paper's complex unknowns: the
/// square-root-free block filter, `W = 2 (P + 1)`, `S = N_p` (as
/// [`PhysicalIdentifier`]).
pub type PaperIdentifier<
    T,
    const NQ: usize,
    const NP: usize,
    const M: usize,
    const N: usize,
    const W: usize,
    const S: usize,
> = Identifier<T, Complex<T>, NQ, NP, M, N, SqrtFreeFactor<Complex<T>, NQ, W, S>>;

/// Physical-structure identifier with the Givens block filter
/// ([`crate::blockqrd`]): range-safe, and the desktop driver's estimates to
/// the bit; the layout of [`PhysicalIdentifier`].
pub type PhysicalGivensIdentifier<
    T,
    const NQ: usize,
    const NP: usize,
    const M: usize,
    const N: usize,
    const W: usize,
    const S: usize,
> = Identifier<T, T, NQ, NP, M, N, BlockFactor<T, NQ, W, S>>;

/// Paper-structure identifier with the Givens block filter (as
/// [`PhysicalGivensIdentifier`]).
pub type PaperGivensIdentifier<
    T,
    const NQ: usize,
    const NP: usize,
    const M: usize,
    const N: usize,
    const W: usize,
    const S: usize,
> = Identifier<T, Complex<T>, NQ, NP, M, N, BlockFactor<Complex<T>, NQ, W, S>>;

/// Physical-structure identifier with the dense Givens filter
/// ([`crate::qrdrls`]): any row structure, `M^2 + M` entries, the slowest;
/// the desktop driver's filter.
pub type PhysicalDenseIdentifier<
    T,
    const NQ: usize,
    const NP: usize,
    const M: usize,
    const N: usize,
> = Identifier<T, T, NQ, NP, M, N, DenseFactor<T, M>>;

/// Paper-structure identifier with the dense Givens filter (as
/// [`PhysicalDenseIdentifier`]).
pub type PaperDenseIdentifier<T, const NQ: usize, const NP: usize, const M: usize, const N: usize> =
    Identifier<T, Complex<T>, NQ, NP, M, N, DenseFactor<Complex<T>, M>>;

/// The compile-time side of a table: defines, in the module where it is
/// invoked, the items the Rust source of `rotorid tables` defines besides
/// the data (`NQ`, `NP`, `STRUCTURE`, `M`, `N`, `W`, `S` and `type Id`, the
/// recommended identifier [`PhysicalIdentifier`] or [`PaperIdentifier`]),
/// from what a table blob carries in its header: the scalar type, the
/// structure, the number of bearings and of planes.
///
/// A firmware that reads a blob at run time ([`crate::table::TableView`])
/// thus spells no generic parameter:
///
/// ```
/// use rotorid_core::identify::IdentifierError;
/// use rotorid_core::table::TableView;
/// use rotorid_core::Complex;
///
/// mod table {
///     // A blob of `rotorid tables --f32` (`physical` 1) for 2 bearings and 3 planes.
///     rotorid_core::identifier_types!(f32, physical(1), bearings: 2, planes: 3);
/// }
/// use table::{Id, NQ};
///
/// fn run(blob: &[u8], omega: f32, q: &[Complex<f32>; NQ]) -> Result<(), IdentifierError> {
///     let view = TableView::<f32>::parse(blob).map_err(IdentifierError::Table)?;
///     let mut id = Id::from_table(&view)?; // refused unless the blob is `physical` 1
///     id.update(&view, omega, q)?;
///     let est = id.estimates(omega)?;
///     # let _ = est;
///     Ok(())
/// }
/// # let _ = run;
/// # mod generated { include!("../../tests/data/paper_table_f32.rs"); }
/// # assert_eq!(
/// #     (table::NQ, table::NP, table::M, table::N, table::W, table::S, table::STRUCTURE),
/// #     (generated::NQ, generated::NP, generated::M, generated::N, generated::W, generated::S, generated::STRUCTURE)
/// # );
/// # let _: fn(&generated::Id) -> &table::Id = |id| id;
/// ```
///
/// The formulation is `physical(P)` or `paper(P)` with the order `P`. With
/// `<T>` in place of the scalar type, `Id<T>` is generic over it (for code
/// that reads f32 and f64 blobs alike):
///
/// ```
/// mod physical {
///     rotorid_core::identifier_types!(<T>, physical(2), bearings: 4, planes: 5);
/// }
/// assert_eq!((physical::M, physical::W, physical::S), (74, 8, 10));
/// let _ = physical::Id::<f64>::with_scaling;
/// ```
#[macro_export]
macro_rules! identifier_types {
    (@id physical, $t:ty) => {
        $crate::identify::PhysicalIdentifier<$t, NQ, NP, M, N, W, S>
    };
    (@id paper, $t:ty) => {
        $crate::identify::PaperIdentifier<$t, NQ, NP, M, N, W, S>
    };
    (@sizes $form:ident($order:expr), $nb:expr, $np:expr) => {
        /// Channels `NQ = 2 N_b`.
        pub const NQ: usize = 2 * ($nb);
        /// Unbalance planes.
        pub const NP: usize = $np;
        /// The model structure the table was written for.
        pub const STRUCTURE: $crate::parametrization::Structure =
            $crate::parametrization::Structure::$form($order);
        /// Unknowns `M` of the structure.
        pub const M: usize = STRUCTURE.n_unknowns(NQ / 2, NP);
        /// Rows `N` per update of the structure.
        pub const N: usize = STRUCTURE.n_rows(NQ / 2);
        /// Block layout of the filter: `W` coefficients per channel.
        pub const W: usize = $crate::blockqrd::BlockShape::of(STRUCTURE, NQ / 2, NP).width;
        /// Shared (unbalance) unknowns of the block layout.
        pub const S: usize = $crate::blockqrd::BlockShape::of(STRUCTURE, NQ / 2, NP).shared;
    };
    (<$t:ident>, $form:ident($order:expr), bearings: $nb:expr, planes: $np:expr $(,)?) => {
        $crate::identifier_types!(@sizes $form($order), $nb, $np);
        /// The identifier for this table (square-root-free block filter), generic over the scalar.
        pub type Id<$t> = $crate::identifier_types!(@id $form, $t);
    };
    ($t:ty, $form:ident($order:expr), bearings: $nb:expr, planes: $np:expr $(,)?) => {
        $crate::identifier_types!(@sizes $form($order), $nb, $np);
        /// The identifier for this table (square-root-free block filter): `Id::from_table(&view)`.
        pub type Id = $crate::identifier_types!(@id $form, $t);
    };
}

/// The structure of formulation `formulation` with `m` unknowns and `n`
/// rows for `nq` channels and `np` planes; a compile-time error (in a const
/// context) if there is none. Used by [`Identifier::STRUCTURE`].
const fn structure_of(
    formulation: Formulation,
    nq: usize,
    np: usize,
    m: usize,
    n: usize,
) -> Structure {
    assert!(
        nq > 0 && nq % 2 == 0,
        "Identifier: NQ = 2 N_b must be even and > 0"
    );
    let nb = nq / 2;
    let mut order = 1;
    let mut found = 0;
    while order <= MAX_ORDER {
        if (Structure { formulation, order }).n_unknowns(nb, np) == m {
            found = order;
        }
        order += 1;
    }
    assert!(
        found != 0,
        "Identifier: M must be per_bearing * NQ/2 + per_plane * NP for an order in 1..=MAX_ORDER \
         (paper: 4 (P+1) N_b + N_p; physical: 8 P N_b + 2 N_p)"
    );
    let s = Structure {
        formulation,
        order: found,
    };
    assert!(
        n == s.n_rows(nb),
        "Identifier: N must be NQ (paper, complex rows) or 2 NQ (physical, real rows)"
    );
    s
}

impl<
        T: Real,
        F: IdField<T>,
        const NQ: usize,
        const NP: usize,
        const M: usize,
        const N: usize,
        R: Factor<F>,
    > Identifier<T, F, NQ, NP, M, N, R>
{
    /// The model structure the type determines: the formulation of `F`
    /// ([`IdField::FORMULATION`]) and the order that gives `M` unknowns for
    /// `NQ / 2` bearings and `NP` planes. Evaluating it (every constructor
    /// does) fails to compile unless `NQ` is even and > 0, `M` fits an order
    /// in `1..=MAX_ORDER` and `N` is the structure's number of rows.
    pub const STRUCTURE: Structure = structure_of(F::FORMULATION, NQ, NP, M, N);

    /// The polynomial order `P` of the bearing model (from `M`).
    pub const ORDER: usize = Self::STRUCTURE.order;

    /// A fresh identifier. The sizes are checked at compile time (see
    /// [`Self::STRUCTURE`]); at run time `config.structure` must be
    /// [`Self::STRUCTURE`] (else [`IdentifierError::Structure`]) and `lambda`,
    /// `delta` and the guard in range ([`IdentifierError::InvalidLambda`],
    /// [`IdentifierError::InvalidDelta`], [`IdentifierError::InvalidConfig`]).
    pub fn new(config: Config<T>) -> Result<Self, IdentifierError> {
        let structure = const { Self::STRUCTURE };
        if config.structure != structure {
            return Err(IdentifierError::Structure {
                expected: structure,
                found: config.structure,
            });
        }
        config.validate()?;
        let mut s = Identifier {
            config,
            factor: R::zeroed(),
            guard: GuardState::default(),
            _field: core::marker::PhantomData,
        };
        s.kernel().init()?;
        Ok(s)
    }

    /// A fresh identifier with the default configuration
    /// ([`Config::new`]) for the structure of the type and `scaling`.
    pub fn with_scaling(scaling: ColumnScaling<T>) -> Result<Self, IdentifierError> {
        Self::new(Config::new(const { Self::STRUCTURE }, scaling))
    }

    /// A fresh identifier with the default configuration for the structure
    /// and scaling the table was written for ([`TableSetup`]: a generated
    /// `TABLE` or a parsed [`crate::table::TableView`]);
    /// [`IdentifierError::Structure`] if the table was written for another
    /// structure than the type's.
    pub fn from_table(table: &impl TableSetup<T>) -> Result<Self, IdentifierError> {
        Self::new(Config::new(table.structure(), table.scaling()))
    }

    fn kernel(&mut self) -> Kernel<'_, T, F, &mut R> {
        Kernel {
            config: &self.config,
            nq: NQ,
            np: NP,
            factor: &mut self.factor,
            guard: &mut self.guard,
            field: core::marker::PhantomData,
        }
    }

    /// The configuration.
    pub fn config(&self) -> &Config<T> {
        &self.config
    }

    /// The guard state (steps folded in, steps frozen).
    pub fn guard(&self) -> &GuardState<T> {
        &self.guard
    }

    /// Back to the initial state.
    pub fn reset(&mut self) -> Result<(), IdentifierError> {
        self.kernel().init()
    }

    /// One measurement with the terms looked up in `table` at `omega`.
    /// Errors leave the state untouched.
    pub fn update<TB: BearingTable<T, NQ, NP>>(
        &mut self,
        table: &TB,
        omega: T,
        q: &[Complex<T>; NQ],
    ) -> Result<StepReport<T>, IdentifierError> {
        if !omega.is_finite() || q.iter().any(|z| !(z.re.is_finite() && z.im.is_finite())) {
            return Err(IdentifierError::NonFinite);
        }
        let terms = table.terms(omega).map_err(IdentifierError::Table)?;
        self.update_with_terms(omega, &terms.a, &terms.b, q)
    }

    /// One measurement with given terms `A(omega)`, `B(omega)`.
    pub fn update_with_terms(
        &mut self,
        omega: T,
        a: &[[Complex<T>; NQ]; NQ],
        b: &[[Complex<T>; NP]; NQ],
        q: &[Complex<T>; NQ],
    ) -> Result<StepReport<T>, IdentifierError> {
        let mut d = [F::zero(); N];
        let mut u = [[F::zero(); M]; N];
        let mut xi = [F::zero(); N];
        let mut gamma = [T::zero(); N];
        let eq = Equations {
            omega,
            a: a.as_flattened(),
            b: b.as_flattened(),
            q,
            nq: NQ,
            np: NP,
        };
        self.kernel().step(
            &eq,
            Scratch {
                d: &mut d,
                u: u.as_flattened_mut(),
                xi: &mut xi,
                gamma: &mut gamma,
            },
        )
    }

    /// The scaled weights `w~` (back-substitution).
    pub fn scaled_weights(&self) -> Result<[F; M], IdentifierError> {
        let mut w = [F::zero(); M];
        self.factor.solve_weights(&mut w)?;
        Ok(w)
    }

    /// The filter state: its storage (the triangular factor `R` and the
    /// rotated right-hand side `p`, scaled unknowns); for the dense
    /// storage [`DenseFactor::parts`] gives the arrays.
    pub fn state(&self) -> &R {
        &self.factor
    }

    /// `min|R_ii| / max|R_ii|` of the factor.
    pub fn diag_ratio(&self) -> T {
        self.factor.diag_ratio().unwrap_or_else(|_| T::zero())
    }

    /// Physical estimates, bearing coefficients evaluated at `omega` (rad/s;
    /// irrelevant for order 1).
    pub fn estimates(&self, omega: T) -> Result<Estimates<T, NQ, NP>, IdentifierError> {
        Estimates::from_weights(&self.config, &self.scaled_weights()?, omega)
    }
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)]
mod tests {
    use super::*;
    use crate::table::Terms;
    use nalgebra::DMatrix;
    use std::vec::Vec;

    type C64 = Complex<f64>;
    const NQ: usize = 4;
    const NP: usize = 3;

    /// A synthetic "shaft": A(W) = A0 - W^2 A2 + j W A1, B(W) = W^2 B0.
    struct Synthetic {
        a0: DMatrix<C64>,
        a1: DMatrix<C64>,
        a2: DMatrix<C64>,
        b0: DMatrix<C64>,
        k: [[f64; 4]; 2],
        c: [[f64; 4]; 2],
        ua: [C64; NP],
    }

    fn lcg(s: &mut u64) -> f64 {
        *s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((*s >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }

    impl Synthetic {
        fn new() -> Self {
            let mut s = 42u64;
            let mut m = |scale: f64, r: usize, c: usize| {
                DMatrix::from_fn(r, c, |_, _| C64::new(lcg(&mut s), lcg(&mut s)) * scale)
            };
            Synthetic {
                a0: m(3e7, NQ, NQ),
                a1: m(1e2, NQ, NQ),
                a2: m(10.0, NQ, NQ),
                b0: m(1.0, NQ, NP),
                k: [[5e7, 0.5e7, 1e7, 7e7], [5e7, 1e7, 0.5e7, 7e7]],
                c: [[500.0, 50.0, 100.0, 700.0], [500.0, 100.0, 50.0, 700.0]],
                ua: [
                    C64::from_polar(0.0042, 0.0),
                    C64::from_polar(0.0030, 0.314),
                    C64::from_polar(0.0073, 0.401),
                ],
            }
        }
        fn terms(&self, w: f64) -> (DMatrix<C64>, DMatrix<C64>) {
            let a = &self.a0 - &self.a2 * C64::new(w * w, 0.0) + &self.a1 * C64::new(0.0, w);
            (a, &self.b0 * C64::new(w * w, 0.0))
        }
        fn q(&self, w: f64) -> Vec<C64> {
            let (a, b) = self.terms(w);
            let mut zb = DMatrix::zeros(NQ, NQ);
            for m in 0..2 {
                for e in 0..4 {
                    zb[(2 * m + e / 2, 2 * m + e % 2)] = C64::new(self.k[m][e], w * self.c[m][e]);
                }
            }
            let rhs = b * nalgebra::DVector::from_column_slice(&self.ua);
            (a + zb).lu().solve(&rhs).unwrap().as_slice().to_vec()
        }
        fn terms_arrays<T: Real>(&self, w: f64) -> Terms<T, NQ, NP> {
            let (a, b) = self.terms(w);
            let mut t = Terms::<T, NQ, NP>::zero();
            let cv = |z: C64| Complex::new(T::lit(z.re), T::lit(z.im));
            for i in 0..NQ {
                for j in 0..NQ {
                    t.a[i][j] = cv(a[(i, j)]);
                }
                for k in 0..NP {
                    t.b[i][k] = cv(b[(i, k)]);
                }
            }
            t
        }
    }

    fn config<T: Real>(structure: Structure, lambda: f64, delta: f64) -> Config<T> {
        Config {
            structure,
            lambda: T::lit(lambda),
            delta: T::lit(delta),
            scaling: ColumnScaling::new(5e7, 1600.0, 1e-3).unwrap(),
            normalise_rows: false,
            steady: SteadyPolicy::off(),
        }
    }

    fn run<T: Real, F: IdField<T>, const M: usize, const N: usize, R: Factor<F>>(
        sys: &Synthetic,
        id: &mut Identifier<T, F, NQ, NP, M, N, R>,
    ) {
        for i in 1..=60 {
            let w = 25.0 * i as f64;
            let q = sys.q(w);
            let t = sys.terms_arrays::<T>(w);
            let qa: [Complex<T>; NQ] =
                core::array::from_fn(|j| Complex::new(T::lit(q[j].re), T::lit(q[j].im)));
            id.update_with_terms(T::lit(w), &t.a, &t.b, &qa).unwrap();
        }
    }

    fn max_rel_err<T: Real, const M: usize>(
        sys: &Synthetic,
        e: &Estimates<T, NQ, NP>,
    ) -> (f64, f64, f64) {
        let (mut ek, mut ec, mut ea) = (0.0f64, 0.0f64, 0.0f64);
        for m in 0..2 {
            for j in 0..4 {
                ek = ek.max((e.bearings[m].k[j].to_f64() - sys.k[m][j]).abs() / sys.k[m][j]);
                ec = ec.max((e.bearings[m].c[j].to_f64() - sys.c[m][j]).abs() / sys.c[m][j]);
            }
        }
        for k in 0..NP {
            let a = e.unbalance[k].a;
            ea = ea.max(
                (C64::new(a.re.to_f64(), a.im.to_f64()) - sys.ua[k]).norm() / sys.ua[k].norm(),
            );
        }
        (ek, ec, ea)
    }

    // These checks use a tiny delta: the start-up prior delta lambda^n |w~|^2
    // biases the damping (1.6% of |Z_B| at the top speed) by ~1e-6 with
    // delta = 1e-7 and only 60 speeds; the FE tests in `tests/` use the
    // paper's delta on the full sweep.
    #[test]
    fn paper_structure_recovers_synthetic_parameters() {
        let sys = Synthetic::new();
        let mut id = PaperDenseIdentifier::<f64, NQ, NP, 19, 4>::new(config(
            Structure::paper(1),
            0.999,
            1e-14,
        ))
        .unwrap();
        run(&sys, &mut id);
        let e = id.estimates(1500.0).unwrap();
        let (ek, ec, ea) = max_rel_err::<f64, 19>(&sys, &e);
        assert!(ek < 1e-9 && ec < 1e-9 && ea < 1e-9, "{ek} {ec} {ea}");
        let im0 = e.bearings[0].im_z0.unwrap();
        assert!(im0.iter().all(|x| x.abs() < 1e-9 * 5e7), "{im0:?}");
    }

    #[test]
    fn physical_structure_f32_and_f64() {
        let sys = Synthetic::new();
        let mut id = PhysicalDenseIdentifier::<f64, NQ, NP, 22, 8>::new(config(
            Structure::physical(1),
            0.999,
            1e-14,
        ))
        .unwrap();
        run(&sys, &mut id);
        let (ek, ec, ea) = max_rel_err::<f64, 22>(&sys, &id.estimates(0.0).unwrap());
        assert!(ek < 1e-9 && ec < 1e-9 && ea < 1e-9, "{ek} {ec} {ea}");
        let mut id = PhysicalDenseIdentifier::<f32, NQ, NP, 22, 8>::new(config(
            Structure::physical(1),
            0.999,
            1e-14,
        ))
        .unwrap();
        run(&sys, &mut id);
        let (ek, ec, ea) = max_rel_err::<f32, 22>(&sys, &id.estimates(0.0).unwrap());
        assert!(ek < 1e-3 && ec < 1e-2 && ea < 1e-3, "{ek} {ec} {ea}");
    }

    /// The recommended aliases (square-root-free block filter) and the
    /// Givens block ones recover the parameters as the dense filter does;
    /// the Givens block filter with the dense one's bits.
    #[test]
    fn every_filter_recovers_the_synthetic_parameters() {
        let sys = Synthetic::new();
        let phys = config::<f64>(Structure::physical(1), 0.999, 1e-14);
        let paper = config::<f64>(Structure::paper(1), 0.999, 1e-14);
        let mut sf = PhysicalIdentifier::<f64, NQ, NP, 22, 8, 4, 6>::new(phys).unwrap();
        let mut gv = PhysicalGivensIdentifier::<f64, NQ, NP, 22, 8, 4, 6>::new(phys).unwrap();
        let mut dense = PhysicalDenseIdentifier::<f64, NQ, NP, 22, 8>::new(phys).unwrap();
        run(&sys, &mut sf);
        run(&sys, &mut gv);
        run(&sys, &mut dense);
        let (ek, ec, ea) = max_rel_err::<f64, 22>(&sys, &sf.estimates(0.0).unwrap());
        assert!(ek < 1e-9 && ec < 1e-9 && ea < 1e-9, "{ek} {ec} {ea}");
        assert_eq!(gv.estimates(0.0), dense.estimates(0.0));
        let mut sf = PaperIdentifier::<f64, NQ, NP, 19, 4, 4, 3>::new(paper).unwrap();
        let mut gv = PaperGivensIdentifier::<f64, NQ, NP, 19, 4, 4, 3>::new(paper).unwrap();
        let mut dense = PaperDenseIdentifier::<f64, NQ, NP, 19, 4>::new(paper).unwrap();
        run(&sys, &mut sf);
        run(&sys, &mut gv);
        run(&sys, &mut dense);
        let (ek, ec, ea) = max_rel_err::<f64, 19>(&sys, &sf.estimates(1500.0).unwrap());
        assert!(ek < 1e-9 && ec < 1e-9 && ea < 1e-9, "{ek} {ec} {ea}");
        assert_eq!(gv.estimates(1500.0), dense.estimates(1500.0));
    }

    #[test]
    fn sizes_determine_the_structure_and_the_config_must_agree() {
        // Wrong `M`, `N` or `NQ` do not compile (see the `compile_fail`
        // doctest of `Identifier`); the type names its structure.
        assert_eq!(
            PaperDenseIdentifier::<f64, NQ, NP, 19, 4>::STRUCTURE,
            Structure::paper(1)
        );
        assert_eq!(PaperDenseIdentifier::<f64, NQ, NP, 27, 4>::ORDER, 2);
        assert_eq!(
            PhysicalDenseIdentifier::<f32, NQ, NP, 54, 8>::STRUCTURE,
            Structure::physical(3)
        );
        assert_eq!(PhysicalDenseIdentifier::<f32, 2, 0, 64, 4>::ORDER, 8);
        assert_eq!(PaperDenseIdentifier::<f32, 2, 0, 8, 2>::ORDER, 1);
        let c = config::<f64>(Structure::paper(1), 0.99, 1e-3);
        assert_eq!(
            PaperDenseIdentifier::<f64, NQ, NP, 27, 4>::new(c).err(),
            Some(IdentifierError::Structure {
                expected: Structure::paper(2),
                found: Structure::paper(1)
            })
        );
        assert!(matches!(
            PhysicalDenseIdentifier::<f64, NQ, NP, 22, 8>::new(c),
            Err(IdentifierError::Structure { .. })
        ));
        let mut bad = c;
        bad.lambda = 1.5;
        assert_eq!(
            PaperDenseIdentifier::<f64, NQ, NP, 19, 4>::new(bad).err(),
            Some(IdentifierError::InvalidLambda)
        );
        assert!(PaperDenseIdentifier::<f64, NQ, NP, 27, 4>::new(config(
            Structure::paper(2),
            0.99,
            1e-3
        ))
        .is_ok());
        assert!(PhysicalDenseIdentifier::<f32, NQ, NP, 54, 8>::new(config(
            Structure::physical(3),
            0.99,
            1e-3
        ))
        .is_ok());
        // The defaults of `Config::new` and `with_scaling`.
        let sc = ColumnScaling::<f32>::new(5e7, 1600.0, 1e-3).unwrap();
        let id = PhysicalDenseIdentifier::<f32, NQ, NP, 22, 8>::with_scaling(sc).unwrap();
        assert_eq!(
            *id.config(),
            Config {
                structure: Structure::physical(1),
                lambda: 0.999,
                delta: 1e-7,
                scaling: sc,
                normalise_rows: false,
                steady: SteadyPolicy::default_guard(),
            }
        );
        let c = Config::new(Structure::paper(1), sc)
            .with_lambda(0.9)
            .with_delta(1e-3)
            .with_normalise_rows(true)
            .with_steady(SteadyPolicy::off())
            .with_scaling(ColumnScaling::identity());
        assert_eq!(
            (c.lambda, c.delta, c.normalise_rows, c.steady, c.scaling),
            (
                0.9,
                1e-3,
                true,
                SteadyPolicy::off(),
                ColumnScaling::identity()
            )
        );
        assert_eq!(
            Config::new(Structure::paper(1), sc)
                .with_lambda(0.0)
                .validate(),
            Err(IdentifierError::InvalidLambda)
        );
        // A memory under one update, and delta out of [1/L, L].
        for lambda in [1.5e-32, 1e-300f64 as f32, 0.36] {
            assert_eq!(
                Config::new(Structure::paper(1), sc)
                    .with_lambda(lambda)
                    .validate(),
                Err(IdentifierError::InvalidLambda)
            );
        }
        assert!(Config::new(Structure::paper(1), sc)
            .with_lambda(0.37)
            .validate()
            .is_ok());
        for delta in [1e-30f32, 0.0, f32::NAN, 1e20, f32::INFINITY] {
            assert_eq!(
                Config::new(Structure::paper(1), sc)
                    .with_delta(delta)
                    .validate(),
                Err(IdentifierError::InvalidDelta)
            );
        }
        for delta in [1e-19f32, 1e19] {
            assert!(Config::new(Structure::paper(1), sc)
                .with_delta(delta)
                .validate()
                .is_ok());
        }
        let sc64 = ColumnScaling::<f64>::new(5e7, 1600.0, 1e-3).unwrap();
        for delta in [1e-300, 1e300] {
            assert_eq!(
                Config::new(Structure::paper(1), sc64)
                    .with_delta(delta)
                    .validate(),
                Err(IdentifierError::InvalidDelta)
            );
        }
    }

    /// Weights finite in the filter but beyond the working precision once
    /// unscaled (f32, physical, huge responses, tiny delta) give an error,
    /// never `Ok` with an infinite estimate; the state is not changed by
    /// reading the estimates.
    #[test]
    fn unscaled_overflow_is_an_error_not_an_infinite_estimate() {
        let sys = Synthetic::new();
        // A large stiffness scale: weights near f32::MAX / 1e9 unscale to inf.
        let sc = ColumnScaling::<f32>::new(1e30, 1.0, 1.0).unwrap();
        let cfg = Config::new(Structure::physical(1), sc)
            .with_lambda(0.99)
            .with_delta(1e-19)
            .with_steady(SteadyPolicy::off());
        let mut id = PhysicalDenseIdentifier::<f32, NQ, NP, 22, 8>::new(cfg).unwrap();
        let t = sys.terms_arrays::<f32>(700.0);
        for q in [5.5e11f32, 5.5e3, 1e-3] {
            // Accepted or refused, never a non-finite state.
            let q = [Complex::new(q, -q); NQ];
            let _ = id.update_with_terms(700.0, &t.a, &t.b, &q);
        }
        let before = (id.factor.clone(), id.guard);
        match id.estimates(700.0) {
            Ok(e) => {
                for b in &e.bearings {
                    assert!(b.k.iter().chain(&b.c).all(|x| x.is_finite()), "{e:?}");
                }
                for u in &e.unbalance {
                    assert!(u.a.re.is_finite() && u.a.im.is_finite() && u.me.is_finite());
                }
            }
            Err(err) => assert!(
                matches!(
                    err,
                    IdentifierError::EstimateOverflow | IdentifierError::Filter(_)
                ),
                "{err:?}"
            ),
        }
        assert_eq!((id.factor.clone(), id.guard), before);
        // Finite weights whose unscaled value overflows f32.
        let w = [1e38f32; 22];
        let zero_b = BearingEstimate {
            k: [0.0f32; 4],
            c: [0.0; 4],
            im_z0: None,
            re_z1: None,
        };
        let mut bearings = [zero_b; NQ / 2];
        let mut unbalance = [UnbalanceEstimate::from_phasor(Complex::new(0.0f32, 0.0)); NP];
        assert_eq!(
            estimates_into::<f32, f32>(
                id.config(),
                &w,
                NQ,
                NP,
                700.0,
                &mut bearings,
                &mut unbalance
            ),
            Err(IdentifierError::EstimateOverflow)
        );
    }

    #[test]
    fn non_finite_input_leaves_state_untouched() {
        let sys = Synthetic::new();
        let mut id = PaperDenseIdentifier::<f64, NQ, NP, 19, 4>::new(config(
            Structure::paper(1),
            0.99,
            1e-3,
        ))
        .unwrap();
        run(&sys, &mut id);
        let before = (id.factor.clone(), id.guard);
        let t = sys.terms_arrays::<f64>(700.0);
        let mut q = [C64::new(1e-6, 0.0); NQ];
        q[2].im = f64::NAN;
        assert_eq!(
            id.update_with_terms(700.0, &t.a, &t.b, &q),
            Err(IdentifierError::NonFinite)
        );
        q[2].im = 0.0;
        assert_eq!(
            id.update_with_terms(f64::INFINITY, &t.a, &t.b, &q),
            Err(IdentifierError::NonFinite)
        );
        assert_eq!(
            id.update_with_terms(-1.0, &t.a, &t.b, &q),
            Err(IdentifierError::InvalidSpeed)
        );
        let mut tb = t;
        tb.a[1][1].re = f64::NAN;
        assert_eq!(
            id.update_with_terms(700.0, &tb.a, &tb.b, &q),
            Err(IdentifierError::NonFinite)
        );
        assert_eq!((id.factor.clone(), id.guard), before);
    }

    #[test]
    fn guard_freezes_forgetting_at_constant_speed() {
        let sys = Synthetic::new();
        let mut c = config::<f64>(Structure::paper(1), 0.9, 1e-7);
        c.steady = SteadyPolicy {
            action: SteadyAction::FreezeForgetting,
            margin: 0.1, // above the 0.02 rad/s jitter
            ..SteadyPolicy::default_guard()
        };
        let mut id = PaperDenseIdentifier::<f64, NQ, NP, 19, 4>::new(c).unwrap();
        run(&sys, &mut id);
        assert_eq!(id.guard().frozen, 0);
        let t = sys.terms_arrays::<f64>(1000.0);
        let q = sys.q(1000.0);
        let qa: [C64; NQ] = core::array::from_fn(|j| q[j]);
        for i in 0..100 {
            let rep = id
                .update_with_terms(1000.0 + 0.01 * (i % 3) as f64, &t.a, &t.b, &qa)
                .unwrap();
            assert_eq!(rep.excited, i == 0, "step {i}");
            assert_eq!(rep.lambda_used, if i == 0 { 0.9 } else { 1.0 });
        }
        assert_eq!(id.guard().frozen, 99);
        // Beyond the last excited speeds: excited.
        let rep = id.update_with_terms(1500.5, &t.a, &t.b, &qa).unwrap();
        assert!(rep.excited);
    }

    #[test]
    fn coverage_guard_keeps_sweeps_and_holds_dither() {
        let margin = 0.0;
        let mut g = GuardState::<f64>::default();
        let step = |g: &mut GuardState<f64>, w: f64| {
            let e = g.extends_coverage(w, margin);
            if e {
                g.record_excited(w);
            }
            e
        };
        // Sweeps up, at 1 and 0.1 rad/s steps, then down: every speed new.
        assert!((0..1000).all(|i| step(&mut g, i as f64)));
        assert!((0..1000).all(|i| step(&mut g, 1000.0 + 0.1 * i as f64)));
        // Turning back: the last 4 excited speeds (1099.6..1099.9) are
        // re-covered, then the coast-down is new again.
        let down: Vec<bool> = (1..=10)
            .map(|i| step(&mut g, 1100.0 - 0.1 * i as f64))
            .collect();
        assert_eq!(
            down,
            [false, false, false, false, true, true, true, true, true, true]
        );
        // A jump down: the gap to the old speeds is wide, a new sweep up
        // from there is kept.
        let before = g.excited;
        assert!((0..50).all(|i| step(&mut g, 500.0 + i as f64)));
        assert_eq!(g.excited - before, 50);
        // Dither between two speeds: at most the two speeds forget.
        let before = g.excited;
        for i in 0..10_000 {
            step(&mut g, if i % 2 == 0 { 942.0 } else { 943.2 });
        }
        assert!(g.excited - before <= 2, "{}", g.excited - before);
        // A margin: speeds must leave the range by more than it.
        let mut g = GuardState::<f32>::default();
        g.record_excited(100.0);
        assert!(!g.extends_coverage(100.5, 1.0));
        assert!(g.extends_coverage(101.5, 1.0));
        g.record_excited(110.0);
        // A gap of 10 is wider than max(1, 1 % of 105); a margin of 20
        // covers 105 from 100.
        assert!(g.extends_coverage(105.0, 1.0));
        assert!(!g.extends_coverage(105.0, 20.0));
        assert!(g.extends_coverage(98.5, 1.0));
        assert_eq!(g.recent_speeds(), &[100.0, 110.0]);
    }

    #[test]
    fn skip_leaves_the_state_exactly() {
        let sys = Synthetic::new();
        let mut c = config::<f64>(Structure::physical(1), 0.9, 1e-7);
        c.steady = SteadyPolicy::default_guard();
        assert_eq!(c.steady.action, SteadyAction::Skip);
        let mut id = PhysicalDenseIdentifier::<f64, NQ, NP, 22, 8>::new(c).unwrap();
        run(&sys, &mut id);
        let t = sys.terms_arrays::<f64>(1000.0);
        let q = sys.q(1000.0);
        let mut qa: [C64; NQ] = core::array::from_fn(|j| q[j]);
        id.update_with_terms(1000.0, &t.a, &t.b, &qa).unwrap();
        let before = id.factor.clone();
        for i in 0..50 {
            qa[0] *= 1.0 + 1e-3 * i as f64; // noisy data must not matter
            let rep = id.update_with_terms(1000.0, &t.a, &t.b, &qa).unwrap();
            assert!(!rep.excited);
        }
        assert_eq!(id.factor, before);
        assert_eq!(id.guard().frozen, 50);
    }

    #[test]
    fn diag_ratio_criterion_freezes_a_poorly_conditioned_factor() {
        let sys = Synthetic::new();
        let mut c = config::<f64>(Structure::paper(1), 0.9, 1e-7);
        // A fresh factor has ratio 1; after one step (4 rows, 19 unknowns)
        // most of R is still sqrt(delta) while the excited rows are large.
        c.steady = SteadyPolicy {
            coverage: false,
            margin: 0.0,
            min_diag_ratio: 1e-6,
            action: SteadyAction::FreezeForgetting,
        };
        let mut id = PaperDenseIdentifier::<f64, NQ, NP, 19, 4>::new(c).unwrap();
        let t = sys.terms_arrays::<f64>(1000.0);
        let q = sys.q(1000.0);
        let qa: [C64; NQ] = core::array::from_fn(|j| q[j]);
        assert!(
            id.update_with_terms(1000.0, &t.a, &t.b, &qa)
                .unwrap()
                .excited
        );
        assert!(id.diag_ratio() < 1e-6);
        let rep = id.update_with_terms(1100.0, &t.a, &t.b, &qa).unwrap();
        assert!(!rep.excited);
        assert_eq!(rep.lambda_used, 1.0);
    }
}
