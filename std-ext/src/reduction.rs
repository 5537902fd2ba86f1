//! Reduction of the shaft-and-disk model to the bearing DOFs (placeholder
//! until the finite-element model lands).

use nalgebra::DMatrix;
use num_complex::Complex64;

/// `A` and `B` at one speed.
#[derive(Debug, Clone, PartialEq)]
pub struct ReducedTerms {
    /// Speed Omega (rad/s).
    pub omega: f64,
    /// `A = Z_R,BB - Y Z_R,iB` (N/m), `2 N_b x 2 N_b`.
    pub a: DMatrix<Complex64>,
    /// `B = Omega^2 (T_B - Y T_i)` (1/s^2), `2 N_b x N_p`.
    pub b: DMatrix<Complex64>,
}
