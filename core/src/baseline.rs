//! Reference algorithms for tests and benchmarks (feature `baseline`; they
//! allocate and are not part of the firmware path).
//!
//! Both solve the same problem as [`crate::qrdrls`] (same cost function,
//! same `d = U w` convention, same initial state and forgetting per step),
//! share its validation ([`crate::qrdrls::validate_lambda`],
//! [`crate::qrdrls::validate_delta`], [`crate::qrdrls::check_finite`]: an
//! error leaves the state untouched) and are generic over `f32`/`f64` and
//! real/complex in the same way.
//!
//! * [`ConventionalRls`]: the covariance-form RLS of the paper's Eqs. 10-13
//!   (matrix inversion lemma), one row at a time.
//! * [`StackQrRls`]: the paper's own implementation of Eq. 20: stack
//!   `[sqrt(lambda) R, sqrt(lambda) p; U, d]` and call a general dense QR
//!   (nalgebra's Householder `QR` on a `DMatrix`) every step.

use crate::qrdrls::{check_finite, validate_delta, validate_lambda, FilterError};
use crate::Real;
use nalgebra::{ComplexField, DMatrix, DVector};
use std::vec;
use std::vec::Vec;

/// The construction checks shared by both baselines (the same as the
/// filter's: `M > 0`, [`validate_delta`], [`check_finite`] on `w0`), and the
/// prior weights `w0`, zero when not given.
fn prior_weights<F, T>(m: usize, delta: T, w0: Option<&[F]>) -> Result<Vec<F>, FilterError>
where
    F: ComplexField<RealField = T> + Copy,
    T: Real,
{
    if m == 0 {
        return Err(FilterError::Dimension);
    }
    validate_delta(delta)?;
    match w0 {
        Some(w0) if w0.len() == m => {
            check_finite(w0, &[])?;
            Ok(w0.to_vec())
        }
        Some(_) => Err(FilterError::Dimension),
        None => Ok(vec![F::zero(); m]),
    }
}

/// Conventional (covariance-form) RLS, Eqs. 10-13 of the paper, in the
/// `d = U w` convention of this crate.
///
/// # Derivation of the update in our convention
///
/// The paper's scalar filter is `y = w^H u_p`, `Phi = sum u_p u_p^H`,
/// `z = sum u_p d_p^*`. A row `u` of `U` (acting as `u w`) is the paper's
/// `u_p = u^H` with `d_p = d^*`: then `w^H u_p = (u w)^*`, so the paper's
/// a-priori error (Eq. 12) is `zeta = d_p - w^H u_p = alpha^*` with our
/// `alpha = d - u w(n-1)`. With the corrected sign of Eq. 13,
/// `w(n) = w(n-1) + k zeta^* = w(n-1) + k alpha`, and Eqs. 10-11 become
///
/// ```text
/// pi    = P(n-1) u^H
/// k     = pi / (lambda + u pi)                         (Eq. 11)
/// alpha = d - u w(n-1)                                 (Eq. 12)
/// w(n)  = w(n-1) + k alpha                             (Eq. 13, sign corrected)
/// P(n)  = lambda^-1 (P(n-1) - k (u P(n-1)))            (Eq. 10, literally)
/// ```
///
/// with `P(0) = delta^-1 I`, `w(0) = w0`. Eq. 10 is evaluated as printed
/// (the row `u P(n-1)` is computed, Hermitian symmetry of `P` is neither
/// assumed nor enforced): that is the textbook algorithm whose loss of
/// symmetry and positive definiteness in finite precision motivates the
/// QRD/RLS.
///
/// The `N` rows of a step are processed one at a time; `lambda` is applied
/// to the first row of the step only (rows 2..N use `lambda = 1`), which is
/// exactly the forgetting of the QRD/RLS (`Phi(n) = lambda Phi(n-1) + U^H U`).
/// Per row it reports the a-posteriori error `xi = d - u w(n) = gamma alpha`
/// and the conversion factor `gamma = lambda_row / (lambda_row + u pi)`.
#[derive(Clone, Debug, PartialEq)]
pub struct ConventionalRls<F: ComplexField> {
    m: usize,
    p: Vec<F>,
    w: Vec<F>,
    pi: Vec<F>,
    up: Vec<F>,
}

impl<F, T> ConventionalRls<F>
where
    F: ComplexField<RealField = T> + Copy,
    T: Real,
{
    /// `P(0) = delta^-1 I`, `w(0) = w0` (zero if `None`).
    pub fn new(m: usize, delta: T, w0: Option<&[F]>) -> Result<Self, FilterError> {
        let w = prior_weights(m, delta, w0)?;
        let mut p = vec![F::zero(); m * m];
        let inv = T::one() / delta;
        if !inv.is_finite() {
            return Err(FilterError::InvalidDelta);
        }
        for i in 0..m {
            p[i * m + i] = F::from_real(inv);
        }
        Ok(Self {
            m,
            p,
            w,
            pi: vec![F::zero(); m],
            up: vec![F::zero(); m],
        })
    }

    /// Number of unknowns.
    pub fn dim(&self) -> usize {
        self.m
    }

    /// Current weights `w(n)` (kept up to date at every row).
    pub fn weights(&self) -> &[F] {
        &self.w
    }

    /// The inverse correlation matrix `P(n)` (`M x M` row-major).
    pub fn p_matrix(&self) -> &[F] {
        &self.p
    }

    /// One step: `N = d.len()` rows of `u` (`N x M` row-major). Writes the
    /// a-posteriori errors and conversion factors per row.
    pub fn update(
        &mut self,
        u: &[F],
        d: &[F],
        lambda: T,
        errors_out: &mut [F],
        gamma_out: &mut [T],
    ) -> Result<(), FilterError> {
        let m = self.m;
        let n = d.len();
        if n.checked_mul(m) != Some(u.len()) || errors_out.len() != n || gamma_out.len() != n {
            return Err(FilterError::Dimension);
        }
        validate_lambda(lambda)?;
        check_finite(u, d)?;
        for (j, (row, &dj)) in u.chunks_exact(m).zip(d).enumerate() {
            let lam = if j == 0 { lambda } else { T::one() };
            // pi = P u^H, up = u P, s = u pi.
            for (pi_i, p_row) in self.pi.iter_mut().zip(self.p.chunks_exact(m)) {
                let mut acc = F::zero();
                for (pik, uk) in p_row.iter().zip(row) {
                    acc += *pik * uk.conjugate();
                }
                *pi_i = acc;
            }
            self.up.iter_mut().for_each(|x| *x = F::zero());
            for (ui, p_row) in row.iter().zip(self.p.chunks_exact(m)) {
                for (upk, pik) in self.up.iter_mut().zip(p_row) {
                    *upk += *ui * *pik;
                }
            }
            let mut s = F::zero();
            for (ui, pii) in row.iter().zip(&self.pi) {
                s += *ui * *pii;
            }
            let denom = F::from_real(lam) + s;
            // k = pi / denom (stored in pi).
            for x in self.pi.iter_mut() {
                *x /= denom;
            }
            let mut alpha = dj;
            for (ui, wi) in row.iter().zip(&self.w) {
                alpha -= *ui * *wi;
            }
            for (wi, ki) in self.w.iter_mut().zip(&self.pi) {
                *wi += *ki * alpha;
            }
            let inv_lam = T::one() / lam;
            for (p_row, ki) in self.p.chunks_exact_mut(m).zip(&self.pi) {
                for (pik, upk) in p_row.iter_mut().zip(&self.up) {
                    *pik = (*pik - *ki * *upk).scale(inv_lam);
                }
            }
            let gamma = lam / denom.real();
            errors_out[j] = alpha.scale(gamma);
            gamma_out[j] = gamma;
        }
        Ok(())
    }
}

/// The paper's implementation of Eq. 20: at every step, stack
///
/// ```text
/// A = [ sqrt(lambda) R   sqrt(lambda) p ]   ((M + N) x (M + 1))
///     [ U                d              ]
/// ```
///
/// and compute a general dense QR of `A` (nalgebra's Householder `QR`, the
/// counterpart of MATLAB's `qr`); the new `R`, `p` are the top `M` rows of
/// the triangular factor. `O((M + N) M^2)` flops plus allocation per step.
/// Its `R` may have a complex or negative diagonal (Householder
/// convention): it differs from [`crate::qrdrls`]'s `R` by a unitary
/// diagonal factor, and `R^H R` and the weights are the same.
#[derive(Clone, Debug, PartialEq)]
pub struct StackQrRls<F: ComplexField> {
    r: DMatrix<F>,
    p: DVector<F>,
}

impl<F, T> StackQrRls<F>
where
    F: ComplexField<RealField = T> + Copy,
    T: Real,
{
    /// `R(0) = sqrt(delta) I`, `p(0) = sqrt(delta) w0`.
    pub fn new(m: usize, delta: T, w0: Option<&[F]>) -> Result<Self, FilterError> {
        let w = prior_weights(m, delta, w0)?;
        let sd = delta.sqrt();
        let p = DVector::from_iterator(m, w.iter().map(|x| x.scale(sd)));
        let r = DMatrix::from_diagonal_element(m, m, F::from_real(sd));
        Ok(Self { r, p })
    }

    /// Number of unknowns.
    pub fn dim(&self) -> usize {
        self.p.len()
    }

    /// The factor `R`.
    pub fn r(&self) -> &DMatrix<F> {
        &self.r
    }

    /// The rotated right-hand side `p`.
    pub fn p(&self) -> &DVector<F> {
        &self.p
    }

    /// One step with the `N = d.len()` rows of `u` (`N x M` row-major).
    pub fn update(&mut self, u: &[F], d: &[F], lambda: T) -> Result<(), FilterError> {
        let m = self.p.len();
        let n = d.len();
        if n.checked_mul(m) != Some(u.len()) {
            return Err(FilterError::Dimension);
        }
        validate_lambda(lambda)?;
        check_finite(u, d)?;
        let sl = lambda.sqrt();
        let mut a = DMatrix::<F>::zeros(m + n, m + 1);
        for i in 0..m {
            for k in i..m {
                a[(i, k)] = self.r[(i, k)].scale(sl);
            }
            a[(i, m)] = self.p[i].scale(sl);
        }
        for (j, (row, dj)) in u.chunks_exact(m).zip(d).enumerate() {
            for (k, x) in row.iter().enumerate() {
                a[(m + j, k)] = *x;
            }
            a[(m + j, m)] = *dj;
        }
        let rr = a.qr().r();
        self.r = rr.view((0, 0), (m, m)).into_owned();
        self.p = rr.view((0, m), (m, 1)).column(0).into_owned();
        Ok(())
    }

    /// Weights by back-substitution of `R w = p`.
    pub fn weights(&self) -> Result<Vec<F>, FilterError> {
        let w = self
            .r
            .solve_upper_triangular(&self.p)
            .ok_or(FilterError::Singular)?;
        if w.iter().all(|x| x.is_finite()) {
            Ok(w.iter().copied().collect())
        } else {
            Err(FilterError::Singular)
        }
    }
}
