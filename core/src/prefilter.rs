//! Prefiltered recursive identification: the QRD/RLS with real unknowns
//! (the `physical` structure) on equations weighted as the output error
//! is, so that a recursive pass comes close to the maximum-likelihood
//! estimate without the batch solve.
//!
//! Why it stays in the core: it is the firmware's answer to measurement
//! noise. The desktop's output-error fit (`rotorid::estimate`) needs an
//! allocator and the whole sweep at once; one prefiltered pass after a
//! plain one comes within 3 % of it with inline storage. Nothing else in
//! this repository calls it: it is for a firmware that keeps a sweep (or
//! the previous sweep's estimate) for a second pass, and
//! `tests/identify/prefilter.rs` checks it against the Cramér-Rao bound
//! (the tables in `docs/validation.md`). On data with a probe noise floor
//! the floor must be given ([`NoiseFloor`]): weighted as if the noise were
//! proportional to the response, the samples below the floor get enormous
//! weights (on the realistic case there, the median parameter lands some
//! 150 CRB off; with the floor, every parameter within 1.1 CRB).
//!
//! # Why the plain equations are badly weighted
//!
//! At speed `Omega` the bearing equation `(A + Z_B(w)) q = B a(w)` gives
//! the equation error of the regression ([`crate::regressor`])
//!
//! ```text
//! e(w) = U(q) w - d(q) = +-[ (A + Z_B(w)) q - B a(w) ] = +-H(w) (q - q(w)),
//! H(w) = A(Omega) + Z_B(Omega; w),     q(w) = H(w)^-1 B(Omega) a(w),
//! ```
//!
//! for any measured `q`. The noise of a proximity probe has a floor and a
//! part proportional to the response: channel `i` of a speed reads
//! `q_i = q_true,i + sigma_i eps`, `eps` standard complex Gaussian, with
//!
//! ```text
//! sigma_i^2 = E|q_i - q_true,i|^2 = f_i^2 + s^2 |q_true,i|^2
//!           = s^2 (phi_i^2 + |q_true,i|^2),      phi_i = f_i / s,
//! ```
//!
//! `f_i` the floor of channel `i` (m), `s` the relative part and `phi_i`
//! the floor in relative units (m, [`NoiseFloor`]); `phi = 0` is noise
//! proportional to the response. The output error `q_i - q_i(w)` divided
//! by `sqrt(phi_i^2 + |q_i(w)|^2)` is therefore white with variance `s^2`
//! at the true `w`, while the equation error multiplies it by `H`, whose
//! size swings by orders of magnitude over the sweep (it is near-singular
//! at the rotor's resonances and large where the shaft with its bearing
//! points held resonates). Least squares on `e` weighs the speeds by
//! `|H| |q|`: far from the noise's own weighting.
//!
//! # The prefilter
//!
//! With a previous estimate `w_prev` (of an earlier pass over the sweep,
//! or of an earlier sweep), each speed's complex equations are multiplied
//! by
//!
//! ```text
//! P(Omega) = diag(1 / r_i) H(w_prev)^-1,
//! r_i = max( sqrt(phi_i^2 + |q_hat_i|^2), f max_k |q_hat_k| )   (m),
//! q_hat = H(w_prev)^-1 B a(w_prev),   f = FLOOR (1e-6),
//! ```
//!
//! with `phi` the identifier's [`NoiseFloor`] (zero unless set), so that
//! `P e(w) = diag(1/r) H(w_prev)^-1 H(w) (q - q(w))`, which is the output
//! error divided by `sigma / s` (white, variance `s^2`) when `w = w_prev`:
//! the sum of squares the filter minimises is, to first order around
//! `w_prev`, the output-error (maximum-likelihood) criterion of the noise
//! model, the weighting of the desktop's fit under a probe noise model.
//! The guard `f` only bounds the weight of a node of the response; with
//! `phi = 0`, `r_i = max(|q_hat_i|, f max_k |q_hat_k|)` is the weighting
//! of noise proportional to the response. Each complex equation `i` of the
//! physical structure is a pair of real rows (real and imaginary parts,
//! [`crate::regressor::form_physical`]); `P` mixes the complex rows
//! `g_i = u_(2i) + j u_(2i+1)` and `d_i = d_(2i) + j d_(2i+1)` and splits
//! them again. The unknowns stay real and enter linearly: the update is
//! the same Givens QRD/RLS ([`crate::qrdrls::update_rows`]) with the same
//! forgetting factor, regularisation and steady-running guard as
//! [`crate::identify`]. Passes repeat with `w_prev` set to the last
//! estimate ([`PrefilteredIdentifier::next_pass`]): a fixed point of the
//! iteration is a Steiglitz-McBride-type estimate. The noisy `q` still
//! enters `U` (errors in variables), which the prefilter does not remove.
//!
//! Cost per speed over the plain step: one complex `2 N_b x 2 N_b`
//! Gauss-Jordan inversion and the `2 N_b x 2 N_b` mixing of the `M + 1`
//! columns. No heap: every buffer is an inline array of the const sizes.

use crate::identify::{
    check_sizes, Config, Estimates, GuardState, IdField, IdentifierError, SteadyAction, StepReport,
};
use crate::parametrization::{
    bearing_estimate, unbalance_estimate, BearingEstimate, Formulation, UnbalanceEstimate,
};
use crate::qrdrls::{self, FilterError};
use crate::regressor::{self, Equations};
use crate::scalar::Real;
use crate::table::BearingTable;
use num_complex::Complex;

/// Relative floor of the weights: a channel's predicted response counts as
/// at least `FLOOR` times the largest one at that speed (a node of the
/// response must not get an unbounded weight), whatever the [`NoiseFloor`].
pub const FLOOR: f64 = 1e-6;

fn abs<T: Real>(z: Complex<T>) -> T {
    z.re.hypot(z.im)
}

/// The probe noise floor per channel in the relative units of the
/// prefilter: `phi_i = f_i / s` (m), with `f_i` the floor of channel `i`
/// (m: the standard deviation of its complex 1X reading where the response
/// vanishes) and `s` the relative part of the noise, so that a reading
/// `q_i` has `E|e_i|^2 = f_i^2 + s^2 |q_i|^2 = s^2 (phi_i^2 + |q_i|^2)`
/// (see the module documentation). Zero, the default: noise proportional
/// to the response. Every `phi_i` is finite and `>= 0`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoiseFloor<T, const NQ: usize> {
    phi: [T; NQ],
}

impl<T: Real, const NQ: usize> NoiseFloor<T, NQ> {
    /// No floor: noise proportional to the response.
    pub fn zero() -> Self {
        NoiseFloor {
            phi: [T::zero(); NQ],
        }
    }

    /// The floor `phi_i = f_i / s` (m) per channel. Error
    /// ([`IdentifierError::InvalidConfig`]) unless every `phi_i` is finite
    /// and `>= 0`.
    pub fn new(phi: [T; NQ]) -> Result<Self, IdentifierError> {
        if phi.iter().all(|x| x.is_finite() && *x >= T::zero()) {
            Ok(NoiseFloor { phi })
        } else {
            Err(IdentifierError::InvalidConfig)
        }
    }

    /// The floor of probes whose noise is `E|e_i|^2 = f_i^2 + s^2 |q_i|^2`:
    /// `floor_m` the `f_i` (m), `relative` the `s` (e.g. 0.005 for 0.5 %);
    /// `phi_i = f_i / s`. Error ([`IdentifierError::InvalidConfig`]) unless
    /// every `f_i` is finite and `>= 0`, `s` finite and `> 0`, and every
    /// `f_i / s` finite.
    pub fn of_probe(floor_m: [T; NQ], relative: T) -> Result<Self, IdentifierError> {
        if !(relative.is_finite() && relative > T::zero()) {
            return Err(IdentifierError::InvalidConfig);
        }
        Self::new(floor_m.map(|f| f / relative))
    }

    /// `phi_i` (m) per channel.
    pub fn relative_floor(&self) -> &[T; NQ] {
        &self.phi
    }
}

impl<T: Real, const NQ: usize> Default for NoiseFloor<T, NQ> {
    fn default() -> Self {
        Self::zero()
    }
}

/// The prefilter of one speed: `P = diag(1/r) H(w_prev)^-1` with
/// `r_i = max(sqrt(phi_i^2 + |q_hat_i|^2), FLOOR max_k |q_hat_k|)` (m)
/// (`NQ x NQ`, complex; see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Prefilter<T, const NQ: usize> {
    /// `P`, row-major.
    pub p: [[Complex<T>; NQ]; NQ],
    /// The predicted response `q_hat = H(w_prev)^-1 B a(w_prev)` (m).
    pub q_hat: [Complex<T>; NQ],
}

impl<T: Real, const NQ: usize> Prefilter<T, NQ> {
    /// The prefilter at `omega` (rad/s) for the terms `a`, `b`, the
    /// previous scaled weights `w_prev` of the physical `structure` with
    /// `config`'s scaling, and the noise floor `floor` (`phi`, m; use
    /// [`NoiseFloor::zero`] for noise proportional to the response).
    /// Errors: sizes ([`IdentifierError::Dimension`]),
    /// non-finite input ([`IdentifierError::NonFinite`]), `H(w_prev)`
    /// singular or a zero predicted response
    /// ([`IdentifierError::Filter`] with [`FilterError::Singular`]).
    // index proven: rows and columns below `NQ` (`2 m + 1 < 2 N_b = NQ`,
    // loop bounds `0..NQ`), planes below `NP`: the arrays' const sizes.
    #[allow(clippy::indexing_slicing)]
    pub fn new<const NP: usize>(
        config: &Config<T>,
        omega: T,
        a: &[[Complex<T>; NQ]; NQ],
        b: &[[Complex<T>; NP]; NQ],
        w_prev: &[T],
        floor: &NoiseFloor<T, NQ>,
    ) -> Result<Self, IdentifierError> {
        let st = &config.structure;
        if st.formulation != Formulation::Physical || NQ == 0 || NQ % 2 != 0 {
            return Err(IdentifierError::Dimension);
        }
        let finite = |z: &Complex<T>| z.re.is_finite() && z.im.is_finite();
        if !omega.is_finite()
            || !a.iter().flatten().all(finite)
            || !b.iter().flatten().all(finite)
            || !w_prev.iter().all(|x| x.is_finite())
        {
            return Err(IdentifierError::NonFinite);
        }
        let nb = NQ / 2;
        // H = A + Z_B(w_prev), Z_B = K + j Omega C per bearing block.
        let mut h = *a;
        for m in 0..nb {
            let be: BearingEstimate<T> =
                bearing_estimate(st, &config.scaling, w_prev, nb, NP, m, omega)?;
            for e in 0..4 {
                let (r, c) = (2 * m + e / 2, 2 * m + e % 2);
                h[r][c] += Complex::new(be.k[e], omega * be.c[e]);
            }
        }
        // rhs = B a(w_prev).
        let mut rhs = [Complex::new(T::zero(), T::zero()); NQ];
        for k in 0..NP {
            let u: UnbalanceEstimate<T> =
                unbalance_estimate(st, &config.scaling, w_prev, nb, NP, k)?;
            for (ri, bi) in rhs.iter_mut().zip(b.iter()) {
                *ri += bi[k] * u.a;
            }
        }
        // Gauss-Jordan with partial pivoting on [H | I | rhs].
        let zero = Complex::new(T::zero(), T::zero());
        let mut inv = [[zero; NQ]; NQ];
        for (i, row) in inv.iter_mut().enumerate() {
            row[i] = Complex::new(T::one(), T::zero());
        }
        let singular = IdentifierError::Filter(FilterError::Singular);
        for col in 0..NQ {
            let mut piv = col;
            let mut best = abs(h[col][col]);
            for (r, hr) in h.iter().enumerate().skip(col + 1) {
                let v = abs(hr[col]);
                if v > best {
                    best = v;
                    piv = r;
                }
            }
            if !(best > T::zero() && best.is_finite()) {
                return Err(singular);
            }
            h.swap(col, piv);
            inv.swap(col, piv);
            rhs.swap(col, piv);
            let d = Complex::new(T::one(), T::zero()) / h[col][col];
            for c in 0..NQ {
                h[col][c] *= d;
                inv[col][c] *= d;
            }
            rhs[col] *= d;
            for r in 0..NQ {
                if r == col {
                    continue;
                }
                let f = h[r][col];
                if f == zero {
                    continue;
                }
                for c in 0..NQ {
                    let (hc, ic) = (h[col][c], inv[col][c]);
                    h[r][c] -= f * hc;
                    inv[r][c] -= f * ic;
                }
                let rc = rhs[col];
                rhs[r] -= f * rc;
            }
        }
        let q_hat = rhs;
        let big = q_hat.iter().fold(T::zero(), |m, z| m.max(abs(*z)));
        if !(big > T::zero() && big.is_finite()) {
            return Err(singular);
        }
        let guard = big * T::lit(FLOOR);
        let mut p = inv;
        for ((row, q), phi) in p.iter_mut().zip(q_hat.iter()).zip(floor.phi.iter()) {
            // r = sqrt(phi^2 + |q_hat|^2): exactly |q_hat| without a floor.
            let r = if *phi > T::zero() {
                phi.hypot(abs(*q))
            } else {
                abs(*q)
            };
            let s = T::one() / r.max(guard);
            for x in row.iter_mut() {
                *x = x.scale(s);
            }
        }
        if !p.iter().flatten().all(finite) {
            return Err(singular);
        }
        Ok(Prefilter { p, q_hat })
    }

    /// Applies `P` to the real rows of the physical structure in place:
    /// `d` (length `2 NQ`), `u` (row-major `2 NQ x m`), complex equation
    /// `i` in rows `2i` (real part) and `2i + 1` (imaginary part).
    // index proven: `2 i + 1 < 2 NQ`, `j < m` after the length check.
    #[allow(clippy::indexing_slicing)]
    pub fn apply(&self, d: &mut [T], u: &mut [T], m: usize) -> Result<(), IdentifierError> {
        if d.len() != 2 * NQ || u.len() != 2 * NQ * m {
            return Err(IdentifierError::Dimension);
        }
        let zero = Complex::new(T::zero(), T::zero());
        let mut g = [zero; NQ];
        for j in 0..=m {
            // Column j of U, or d for j = m, as NQ complex values.
            for (i, gi) in g.iter_mut().enumerate() {
                *gi = if j < m {
                    Complex::new(u[2 * i * m + j], u[(2 * i + 1) * m + j])
                } else {
                    Complex::new(d[2 * i], d[2 * i + 1])
                };
            }
            for (i, pr) in self.p.iter().enumerate() {
                let mut acc = zero;
                for (pil, gl) in pr.iter().zip(g.iter()) {
                    acc += *pil * *gl;
                }
                if j < m {
                    u[2 * i * m + j] = acc.re;
                    u[(2 * i + 1) * m + j] = acc.im;
                } else {
                    d[2 * i] = acc.re;
                    d[2 * i + 1] = acc.im;
                }
            }
        }
        Ok(())
    }
}

/// The prefiltered firmware identifier of the physical structure: `NQ =
/// 2 N_b` channels, `NP` planes, `M` real unknowns, `N = 2 NQ` real rows,
/// inline storage. It holds the factor of the current pass, the scaled
/// weights `w_prev` of the previous estimate and the probe noise floor
/// `phi = f / s` ([`NoiseFloor`], zero unless set with
/// [`Self::with_noise_floor`]) that build each speed's [`Prefilter`].
///
/// ```
/// use rotorid_core::identify::Config;
/// use rotorid_core::prefilter::{NoiseFloor, PrefilteredIdentifier};
/// # use rotorid_core::identify::IdentifierError;
/// # mod table { include!("../../tests/data/paper_table_f32.rs"); }
/// # use table::{Id, SCALING, STRUCTURE, TABLE};
/// # fn main() -> Result<(), IdentifierError> {
/// # let q = [rotorid_core::Complex::new(1e-6f32, 2e-7); 4];
/// # let sweep = [(630.0f32, q), (700.0, q), (780.0, q)];
/// let config = Config::new(STRUCTURE, SCALING).with_lambda(1.0);
/// // Pass 0: the plain identifier (here the table's `Id`).
/// let mut plain = Id::new(config)?;
/// for (omega, q) in &sweep {
///     plain.update(&TABLE, *omega, q)?;
/// }
/// // Pass 1, 2, ...: prefiltered with the previous pass's estimate.
/// // Probes with a 0.5 um floor and 0.5 % relative noise: phi = 100 um.
/// let floor = NoiseFloor::of_probe([0.5e-6; 4], 0.005)?;
/// let mut id = PrefilteredIdentifier::<f32, 4, 3, 22, 8>::new(config, plain.scaled_weights()?)?
///     .with_noise_floor(floor);
/// for _pass in 0..2 {
///     for (omega, q) in &sweep {
///         id.update(&TABLE, *omega, q)?;
///     }
///     id.next_pass()?;
/// }
/// let est = id.previous_estimates(700.0)?;
/// # let _ = est.bearings[0].k[0];
/// # Ok(())
/// # }
/// ```
#[derive(Debug, Clone)]
pub struct PrefilteredIdentifier<
    T,
    const NQ: usize,
    const NP: usize,
    const M: usize,
    const N: usize,
> {
    config: Config<T>,
    r: [[T; M]; M],
    p: [T; M],
    prev: [T; M],
    floor: NoiseFloor<T, NQ>,
    guard: GuardState<T>,
}

impl<T: Real + IdField<T>, const NQ: usize, const NP: usize, const M: usize, const N: usize>
    PrefilteredIdentifier<T, NQ, NP, M, N>
{
    /// A fresh pass with the previous scaled weights `w_prev` (e.g. of a
    /// plain pass of an identifier with any filter, such as
    /// [`crate::identify::PhysicalIdentifier`]). `config` must be of the
    /// physical structure with `M` unknowns and `N` rows for `NQ`, `NP`.
    pub fn new(config: Config<T>, w_prev: [T; M]) -> Result<Self, IdentifierError> {
        config.validate()?;
        check_sizes::<T, T>(&config.structure, NQ, NP, M, N)?;
        if N != 2 * NQ {
            return Err(IdentifierError::Dimension);
        }
        if !w_prev.iter().all(|x| x.is_finite()) {
            return Err(IdentifierError::NonFinite);
        }
        let mut s = PrefilteredIdentifier {
            config,
            r: [[T::zero(); M]; M],
            p: [T::zero(); M],
            prev: w_prev,
            floor: NoiseFloor::zero(),
            guard: GuardState::default(),
        };
        qrdrls::init(s.r.as_flattened_mut(), &mut s.p, config.delta, None)?;
        Ok(s)
    }

    /// The identifier weighting with the probe noise floor `floor`
    /// (`phi_i = f_i / s`, m) from the next update on.
    pub fn with_noise_floor(mut self, floor: NoiseFloor<T, NQ>) -> Self {
        self.floor = floor;
        self
    }

    /// Sets the probe noise floor (`phi_i = f_i / s`, m) the prefilter
    /// weights with from the next update on (e.g. between passes, once the
    /// floor is known).
    pub fn set_noise_floor(&mut self, floor: NoiseFloor<T, NQ>) {
        self.floor = floor;
    }

    /// The probe noise floor the prefilter weights with.
    pub fn noise_floor(&self) -> &NoiseFloor<T, NQ> {
        &self.floor
    }

    /// The configuration.
    pub fn config(&self) -> &Config<T> {
        &self.config
    }

    /// The guard state of the current pass.
    pub fn guard(&self) -> &GuardState<T> {
        &self.guard
    }

    /// The previous scaled weights the prefilter is built from.
    pub fn previous_weights(&self) -> &[T; M] {
        &self.prev
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

    /// One measurement with given terms `A(omega)`, `B(omega)`: rows formed
    /// as in [`crate::identify`], prefiltered, folded in. Errors leave the
    /// state untouched.
    pub fn update_with_terms(
        &mut self,
        omega: T,
        a: &[[Complex<T>; NQ]; NQ],
        b: &[[Complex<T>; NP]; NQ],
        q: &[Complex<T>; NQ],
    ) -> Result<StepReport<T>, IdentifierError> {
        if !omega.is_finite() || q.iter().any(|z| !(z.re.is_finite() && z.im.is_finite())) {
            return Err(IdentifierError::NonFinite);
        }
        if omega < T::zero() {
            return Err(IdentifierError::InvalidSpeed);
        }
        let cfg = self.config;
        let eq = Equations {
            omega,
            a: a.as_flattened(),
            b: b.as_flattened(),
            q,
            nq: NQ,
            np: NP,
        };
        let mut d = [T::zero(); N];
        let mut u = [[T::zero(); M]; N];
        regressor::form_physical(
            cfg.structure.order,
            &cfg.scaling,
            &eq,
            &mut d,
            u.as_flattened_mut(),
        )?;
        let pf = Prefilter::<T, NQ>::new::<NP>(&cfg, omega, a, b, &self.prev, &self.floor)?;
        pf.apply(&mut d, u.as_flattened_mut(), M)?;
        let excited = !cfg.steady.coverage || self.guard.extends_coverage(omega, cfg.steady.margin);
        if !excited && cfg.steady.action == SteadyAction::Skip {
            self.guard.frozen += 1;
            self.guard.steps += 1;
            return Ok(StepReport {
                omega,
                excited,
                lambda_used: T::zero(),
                relative_residual: T::zero(),
            });
        }
        let lambda_used = if excited { cfg.lambda } else { T::one() };
        let mut xi = [T::zero(); N];
        let mut gamma = [T::zero(); N];
        qrdrls::update_rows(
            self.r.as_flattened_mut(),
            &mut self.p,
            u.as_flattened(),
            &d,
            lambda_used,
            &mut xi,
            &mut gamma,
        )?;
        if excited {
            self.guard.record_excited(omega);
        } else {
            self.guard.frozen += 1;
        }
        self.guard.steps += 1;
        let en = xi.iter().fold(T::zero(), |s, x| s + *x * *x);
        let dn = d.iter().fold(T::zero(), |s, x| s + *x * *x);
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

    /// The scaled weights `w~` of the current pass (back-substitution).
    pub fn scaled_weights(&self) -> Result<[T; M], IdentifierError> {
        let mut w = [T::zero(); M];
        qrdrls::solve_weights(self.r.as_flattened(), &self.p, &mut w)?;
        Ok(w)
    }

    /// Ends the pass: its estimate becomes `w_prev`, the factor and the
    /// guard start afresh. On error (singular factor) nothing changes.
    pub fn next_pass(&mut self) -> Result<(), IdentifierError> {
        let w = self.scaled_weights()?;
        qrdrls::init(
            self.r.as_flattened_mut(),
            &mut self.p,
            self.config.delta,
            None,
        )?;
        self.prev = w;
        self.guard = GuardState::default();
        Ok(())
    }

    /// Physical estimates of the current pass, bearings at `omega` (rad/s).
    pub fn estimates(&self, omega: T) -> Result<Estimates<T, NQ, NP>, IdentifierError> {
        let w = self.scaled_weights()?;
        self.estimates_of(&w, omega)
    }

    /// Physical estimates of `w_prev` (after [`Self::next_pass`], the
    /// last pass's), bearings at `omega` (rad/s).
    pub fn previous_estimates(&self, omega: T) -> Result<Estimates<T, NQ, NP>, IdentifierError> {
        self.estimates_of(&self.prev, omega)
    }

    fn estimates_of(&self, w: &[T; M], omega: T) -> Result<Estimates<T, NQ, NP>, IdentifierError> {
        Estimates::from_weights(&self.config, w, omega)
    }
}
