//! Column scaling of the identification unknowns.
//!
//! The unknowns of the identification span many decades in SI units:
//! bearing stiffness ~1e7..1e8 N/m, damping ~1e2..1e3 N s/m, unbalance
//! ~1e-4..1e-2 kg m, and the coefficients of `Omega^p` in a polynomial
//! bearing model shrink as `Omega_ref^-p`. The filter therefore works on
//! scaled unknowns
//!
//! ```text
//!     w~ = S^-1 w,   S = diag(s_1, ..., s_M),   (U S) w~ = d,
//! ```
//!
//! with `S` fixed at configuration time from three reference magnitudes:
//!
//! * `stiffness` `s_K` (N/m): a typical bearing stiffness;
//! * `omega_ref` `Omega_r` (rad/s): a typical speed, normally the top of
//!   the speed range;
//! * `unbalance` `s_a` (kg m): a typical unbalance.
//!
//! | unknown | scale `s_j` | scaled column of `U S` |
//! |---|---|---|
//! | `Z_p` (paper, complex) | `s_K / Omega_r^p` | `-(Omega/Omega_r)^p s_K q` |
//! | `K_p` (physical) | `s_K / Omega_r^p` | `-(Omega/Omega_r)^p s_K q` |
//! | `C_p` (physical) | `s_K / Omega_r^(p+1)` | `-j (Omega/Omega_r)^(p+1) s_K q` |
//! | `a_k` (both) | `s_a` | `s_a B_k` |
//!
//! Why these scales equilibrate the columns: when every scaled unknown is of
//! order one, each column of `U S` has the magnitude of that unknown's
//! contribution to `d = A q_B = -Z_B q_B + B a`, and the bearing and the
//! unbalance contributions balance each other (both are of the size of `d`).
//! Column equilibration is near-optimal for the condition number (van der
//! Sluis), it makes the start-up prior `delta |w~|^2` negligible (no slow
//! start-up as with raw SI unknowns, see the crate README), and it keeps the
//! diagonal of the triangular factor meaningful as a conditioning indicator.
//! The powers are evaluated as `(Omega / Omega_r)^p`, never `Omega^p`, so
//! nothing overflows in `f32` for any order.
//!
//! The same formulas are used in `f32` and `f64` (the references are given
//! in `f64` and rounded once). [`ColumnScaling::identity`] gives raw SI
//! unknowns (the paper's own formulation).

use crate::scalar::Real;

/// Reference magnitudes that fix the column scaling `S` (see the module
/// documentation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ColumnScaling<T> {
    /// Reference bearing stiffness `s_K` (N/m).
    pub stiffness: T,
    /// Reference speed `Omega_r` (rad/s).
    pub omega_ref: T,
    /// Reference unbalance `s_a` (kg m).
    pub unbalance: T,
}

/// A reference magnitude that is not finite and positive.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct InvalidScaling;

impl<T: Real> ColumnScaling<T> {
    /// Raw SI unknowns: every scale is 1 (`S = I`).
    pub fn identity() -> Self {
        ColumnScaling {
            stiffness: T::one(),
            omega_ref: T::one(),
            unbalance: T::one(),
        }
    }

    /// From reference magnitudes in SI units (N/m, rad/s, kg m), rounded
    /// once to `T`. Each must be finite and positive.
    pub fn new(stiffness: f64, omega_ref: f64, unbalance: f64) -> Result<Self, InvalidScaling> {
        let ok = |x: f64| x.is_finite() && x > 0.0;
        if !(ok(stiffness) && ok(omega_ref) && ok(unbalance)) {
            return Err(InvalidScaling);
        }
        let s = ColumnScaling {
            stiffness: T::lit(stiffness),
            omega_ref: T::lit(omega_ref),
            unbalance: T::lit(unbalance),
        };
        // Rounding to f32 could underflow to 0 or overflow to inf.
        let okt = |x: T| x.is_finite() && x > T::zero();
        if okt(s.stiffness) && okt(s.omega_ref) && okt(s.unbalance) {
            Ok(s)
        } else {
            Err(InvalidScaling)
        }
    }

    /// `s_K / Omega_r^p`: the scale of a stiffness-like unknown multiplying
    /// `Omega^p` (N/m / (rad/s)^p). Damping `C_p` uses `p + 1`.
    pub fn power_scale(&self, p: usize) -> T {
        let mut s = self.stiffness;
        for _ in 0..p {
            s /= self.omega_ref;
        }
        s
    }

    /// `(Omega / Omega_r)^p`, the dimensionless speed power of a scaled column.
    pub fn speed_power(&self, omega: T, p: usize) -> T {
        let x = omega / self.omega_ref;
        let mut v = T::one();
        for _ in 0..p {
            v *= x;
        }
        v
    }
}
