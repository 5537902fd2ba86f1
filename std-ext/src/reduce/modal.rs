//! The reduction in pole-residue (modal) form: `A(Omega)` and `B(Omega)` at
//! any number of speeds from one Hermitian eigendecomposition, without a
//! factorisation per speed.
//!
//! # Derivation
//!
//! With `K_ii = L L^T` (Cholesky; `K_ii` is real symmetric positive
//! definite when two or more bearings pin the shaft) and the Hermitian
//! `C = L^-1 H_ii L^-T = U diag(mu) U^H` (`H = M - j G`, the matrix whose
//! positive eigenvalues give the poles, [`Reducer::poles`]):
//!
//! ```text
//! Z_ii(Omega) = K_ii - Omega^2 H_ii = L U (I - Omega^2 diag(mu)) U^H L^T
//! Z_ii^-1     = L^-T U diag(d(Omega)) U^H L^-1,   d_k = 1 / (1 - Omega^2 mu_k)
//! ```
//!
//! so the only speed-dependent product of the split formulation (module
//! docs of [`crate::reduce`]) is a sum over the `n_i` modes with real
//! weights:
//!
//! ```text
//! V_L Z_ii^-1 [V, T_i] = sum_k d_k(Omega) R_k,
//! R_k = (V_L L^-T u_k) (u_k^H L^-1 [V, T_i])      (2 N_b x (2 N_b + N_p))
//! ```
//!
//! The residues `R_k` are computed once; per speed the cost is one real
//! matrix-vector product of size `2 (2 N_b) (2 N_b + N_p) x n_i`
//! (`56 x 104` for the paper rotor, about 6k multiply-adds, against a banded
//! LU and seven banded solves of the `104 x 104` `Z_ii`). The sum is exact
//! algebra (every mode is kept, none truncated); it agrees with the banded
//! reduction to round-off of the eigendecomposition (about `1e-12`
//! relative, `tests/tables/modal.rs`).
//!
//! # Poles
//!
//! `d_k` has its pole at `Omega_k = mu_k^-1/2` exactly, so the pole of the
//! modal `A`, `B` is the eigenvalue's, which carries the eigensolver's
//! round-off (up to `1.6e-12` relative in `mu` on the paper rotor). Close
//! to a pole both forms lose accuracy as `eps_mu / (2 |Omega / Omega_k - 1|)`:
//! the banded LU of the nearly singular `Z_ii` as much as the modal sum.
//! Their difference at a relative distance `s` from a pole stays below
//! `1e-10 + 2e-12 / s` on the paper rotor (`tests/tables/modal.rs`), `1e-10`
//! away from the poles; the secant refinement of [`Reducer::refine_pole`]
//! moves the eigenvalue's pole by the same `1e-12`, and a Rayleigh quotient
//! on the original pencil does no better: forming `K - Omega^2 H` (or
//! `x^T K x`) in floating point perturbs the pole of a smooth mode by
//! `eps |K| / (u^T K u)` relative, the same order, so none of the three forms
//! is the more exact one there.

use nalgebra::{Cholesky, DMatrix, DVector, SymmetricEigen};
use num_complex::Complex64;

use super::{assemble_vy, dense_k_h, ReducedTerms, Reducer, ReductionError, Statics};

/// Iteration limit of the Hermitian eigensolver (nalgebra's implicit QR):
/// far above what a well-posed `C` needs (a few per eigenvalue).
const EIGEN_MAX_ITER: usize = 10_000;

/// The modal form of a [`Reducer`]: eigenvalues `mu_k` and residues
/// `R_k`, prepared once ([`Reducer::modal`]); [`ModalReducer::reduce`] per
/// speed.
#[derive(Debug, Clone)]
pub struct ModalReducer {
    statics: Statics,
    /// `mu_k` (s^2/rad^2), eigenvalues of `C = L^-1 H_ii L^-T`.
    mu: Vec<f64>,
    /// Residues, one column per mode: the entries of `R_k` in column-major
    /// order, real and imaginary parts interleaved
    /// (`2 (2 N_b) (2 N_b + N_p)` rows).
    residues: DMatrix<f64>,
}

impl Reducer<'_> {
    /// The modal form of this reduction (module docs of
    /// [`crate::reduce::modal`]): one Cholesky of `K_ii`, one Hermitian
    /// eigendecomposition of `C` and the residues, `O(n_i^3)` once.
    /// Fails if `K_ii` is not positive definite or the eigensolver does not
    /// converge.
    pub fn modal(&self) -> Result<ModalReducer, ReductionError> {
        let (kd, hd) = dense_k_h(self.fe);
        let ii = &self.interior;
        let n = ii.len();
        let k =
            DMatrix::<f64>::from_fn(n, n, |r, c| 0.5 * (kd[(ii[r], ii[c])] + kd[(ii[c], ii[r])]));
        let h = DMatrix::<Complex64>::from_fn(n, n, |r, c| hd[(ii[r], ii[c])]);
        let h = (&h + h.adjoint()) * Complex64::from(0.5);
        let chol = Cholesky::new(k).ok_or_else(|| {
            ReductionError::Invalid(
                "the bearings do not hold the shaft (K_ii not positive definite)".into(),
            )
        })?;
        let l = chol.l().map(Complex64::from);
        let singular = || ReductionError::Invalid("Cholesky factor of K_ii is singular".into());
        // C = L^-1 H L^-T by two triangular solves (L real).
        let y = l.solve_lower_triangular(&h).ok_or_else(singular)?;
        let ct = l
            .solve_lower_triangular(&y.adjoint())
            .ok_or_else(singular)?;
        let c = (&ct + ct.adjoint()) * Complex64::from(0.5);
        let eig = SymmetricEigen::try_new(c, f64::EPSILON, EIGEN_MAX_ITER).ok_or_else(|| {
            ReductionError::Invalid(
                "the eigensolver for the modal reduction did not converge".into(),
            )
        })?;
        let u = &eig.eigenvectors;
        let mu: Vec<f64> = eig.eigenvalues.iter().copied().collect();
        // P = (L^-1 V_L^T)^T U  (2 N_b x n),  Q = U^H L^-1 [V, T_i]  (n x (2 N_b + N_p)).
        let p = l
            .solve_lower_triangular(&self.statics.v_l.transpose())
            .ok_or_else(singular)?
            .transpose()
            * u;
        let q = u.adjoint()
            * l.solve_lower_triangular(&self.statics.rhs)
                .ok_or_else(singular)?;
        let (nq, ncol) = (p.nrows(), q.ncols());
        let mut residues = DMatrix::<f64>::zeros(2 * nq * ncol, n);
        for (kk, mut col) in residues.column_iter_mut().enumerate() {
            for c in 0..ncol {
                for r in 0..nq {
                    let v = p[(r, kk)] * q[(kk, c)];
                    let at = 2 * (c * nq + r);
                    col[at] = v.re;
                    col[at + 1] = v.im;
                }
            }
        }
        Ok(ModalReducer {
            statics: self.statics.clone(),
            mu,
            residues,
        })
    }
}

impl ModalReducer {
    /// The eigenvalues `mu_k` of `C` (s^2/rad^2), in the eigensolver's order.
    pub fn mu(&self) -> &[f64] {
        &self.mu
    }

    /// `A(omega)` and `B(omega)` by the modal sum (module docs). An error if
    /// `omega` is not finite or lies on a pole (`1 - omega^2 mu_k = 0`).
    pub fn reduce(&self, omega: f64) -> Result<ReducedTerms, ReductionError> {
        if !omega.is_finite() {
            return Err(ReductionError::Invalid(format!(
                "speed must be finite, got {omega}"
            )));
        }
        let w2 = omega * omega;
        let mut d = DVector::<f64>::zeros(self.mu.len());
        for (dk, &mu) in d.iter_mut().zip(&self.mu) {
            let den = 1.0 - w2 * mu;
            if den == 0.0 {
                return Err(ReductionError::Invalid(format!(
                    "Z_ii singular at {omega} rad/s (speed on a pinned-shaft resonance)"
                )));
            }
            *dk = 1.0 / den;
        }
        let nq = self.statics.v_l.nrows();
        let ncol = self.statics.rhs.ncols();
        let mut flat = DVector::<f64>::zeros(2 * nq * ncol);
        flat.gemv(1.0, &self.residues, &d, 0.0);
        let vy = DMatrix::from_fn(nq, ncol, |r, c| {
            let at = 2 * (c * nq + r);
            Complex64::new(flat[at], flat[at + 1])
        });
        let terms = assemble_vy(&self.statics, &vy, omega);
        if terms
            .a
            .iter()
            .chain(terms.b.iter())
            .all(|z| z.re.is_finite() && z.im.is_finite())
        {
            Ok(terms)
        } else {
            Err(ReductionError::Invalid(format!(
                "Z_ii numerically singular at {omega} rad/s (speed on a pinned-shaft resonance)"
            )))
        }
    }
}

/// The reduction used for many speeds: the modal form when its set-up
/// succeeds, else the banded one (same numbers to round-off; see the
/// module docs). [`Reducer::many`] chooses.
#[derive(Debug, Clone)]
pub enum ManySpeeds<'r, 'a> {
    /// Pole-residue sum, one matrix-vector product per speed.
    Modal(Box<ModalReducer>),
    /// One banded LU per speed.
    Banded(&'r Reducer<'a>),
}

impl<'a> Reducer<'a> {
    /// [`Reducer::modal`] if it can be set up (it needs `K_ii` positive
    /// definite and a converged eigensolver), else this banded reducer.
    pub fn many(&self) -> ManySpeeds<'_, 'a> {
        match self.modal() {
            Ok(m) => ManySpeeds::Modal(Box::new(m)),
            Err(_) => ManySpeeds::Banded(self),
        }
    }
}

impl ManySpeeds<'_, '_> {
    /// `A(omega)`, `B(omega)` ([`ModalReducer::reduce`] or
    /// [`Reducer::reduce`]).
    pub fn reduce(&self, omega: f64) -> Result<ReducedTerms, ReductionError> {
        match self {
            ManySpeeds::Modal(m) => m.reduce(omega),
            ManySpeeds::Banded(b) => b.reduce(omega),
        }
    }
}
