//! Bearings and pedestals as 2 x 2 dynamic stiffnesses.
//!
//! A bearing at a shaft node acts on the shaft translations `q_s = (y, z)`
//! with the force `f = -(K q + C q')` where `q` is the shaft displacement
//! relative to its support (the ground, or a pedestal). At speed `Omega`
//! the coefficients are [`BearingLaw::at`]`(Omega)`:
//!
//! ```text
//! K = [kyy kyz; kzy kzz],   C = [cyy cyz; czy czz],
//! Z_B(s) = K + s C          (harmonic at Omega: s = j Omega, Eq. 43)
//! ```
//!
//! A pedestal is a mass (`m_y`, `m_z` in y and z, kg) with its own stiffness
//! and damping to ground,
//! `Z_P(s) = diag(k_y + s c_y + s^2 m_y, k_z + s c_z + s^2 m_z)`; the bearing acts
//! between the shaft node and the pedestal. With no external force on the
//! pedestal, its equation `Z_B (q_p - q_s) + Z_P q_p = 0` gives
//!
//! ```text
//! q_p   = (Z_B + Z_P)^-1 Z_B q_s                   (pedestal response)
//! Z_eff = Z_B - Z_B (Z_B + Z_P)^-1 Z_B             (what the shaft sees)
//! ```
//!
//! an exact condensation at each frequency that keeps the shaft's banded
//! structure. For eigenvalues (Campbell diagram) the pedestal DOFs are kept
//! explicitly instead (see [`crate::fe::assembly`]).

use crate::model::{BearingCoefficients, BearingLaw, Pedestal};
use nalgebra::{Matrix2, Vector2};
use num_complex::Complex64;
use thiserror::Error;

/// Errors of the bearing/pedestal condensation.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum BearingError {
    /// `Z_B + Z_P` is singular at this frequency (undamped resonance of the
    /// pedestal on the bearing with the shaft held).
    #[error("bearing + pedestal dynamic stiffness is singular at s = {0}")]
    Singular(Complex64),
}

/// Stiffness matrix `K = [kyy kyz; kzy kzz]` (N/m).
pub fn stiffness(c: &BearingCoefficients) -> Matrix2<f64> {
    Matrix2::new(c.k[0], c.k[1], c.k[2], c.k[3])
}

/// Damping matrix `C = [cyy cyz; czy czz]` (N s/m).
pub fn damping(c: &BearingCoefficients) -> Matrix2<f64> {
    Matrix2::new(c.c[0], c.c[1], c.c[2], c.c[3])
}

/// Bearing dynamic stiffness `Z_B(s) = K + s C` with the coefficients of
/// `law` at rotor speed `omega` (rad/s).
pub fn law_dynamic_stiffness(law: &BearingLaw, omega: f64, s: Complex64) -> Matrix2<Complex64> {
    let c = law.at(omega);
    stiffness(&c).map(|v| Complex64::new(v, 0.0)) + damping(&c).map(|v| s * v)
}

/// Pedestal dynamic stiffness `Z_P(s) = diag(k_y + s c_y + s^2 m_y,
/// k_z + s c_z + s^2 m_z)` (N/m).
pub fn pedestal_dynamic_stiffness(p: &Pedestal, s: Complex64) -> Matrix2<Complex64> {
    let d = |j: usize| Complex64::new(p.k[j], 0.0) + s * p.c[j] + s * s * p.mass[j];
    Matrix2::from_diagonal(&Vector2::new(d(0), d(1)))
}

/// Exact condensation of a pedestal: returns `(Z_eff, T)` with
/// `Z_eff = Z_B - Z_B (Z_B + Z_P)^-1 Z_B` and `T = (Z_B + Z_P)^-1 Z_B`, so
/// that `q_p = T q_s`.
pub fn condense_pedestal(
    zb: &Matrix2<Complex64>,
    zp: &Matrix2<Complex64>,
    s: Complex64,
) -> Result<(Matrix2<Complex64>, Matrix2<Complex64>), BearingError> {
    let sum = zb + zp;
    let scale = sum.iter().map(|z| z.norm()).fold(0.0, f64::max);
    let det = sum[(0, 0)] * sum[(1, 1)] - sum[(0, 1)] * sum[(1, 0)];
    let ok = det.re.is_finite() && det.im.is_finite() && det.norm() > 1e-13 * scale * scale;
    if !ok {
        return Err(BearingError::Singular(s));
    }
    let inv = Matrix2::new(sum[(1, 1)], -sum[(0, 1)], -sum[(1, 0)], sum[(0, 0)]) / det;
    let t = inv * zb;
    Ok((zb - zb * t, t))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn condensation_is_series_connection() {
        let law = BearingLaw::Constant(BearingCoefficients {
            k: [5e7, 0.5e7, 1e7, 7e7],
            c: [500.0, 50.0, 100.0, 700.0],
        });
        let p = Pedestal {
            mass: [50.0, 70.0],
            k: [2e7, 3e7],
            c: [1e3, 2e3],
        };
        let s = Complex64::new(0.0, 600.0);
        let zb = law_dynamic_stiffness(&law, 600.0, s);
        let zp = pedestal_dynamic_stiffness(&p, s);
        let (zeff, t) = condense_pedestal(&zb, &zp, s).unwrap();
        // Series form: Z_eff = Z_B (Z_B + Z_P)^-1 Z_P.
        let alt = zb * (zb + zp).try_inverse().unwrap() * zp;
        assert!((zeff - alt).norm() < 1e-9 * zeff.norm());
        // Force balance on the pedestal for an arbitrary shaft motion.
        let qs = Vector2::new(Complex64::new(1.0, 0.2), Complex64::new(-0.3, 0.7));
        let qp = t * qs;
        let r = zb * (qp - qs) + zp * qp;
        assert!(r.norm() < 1e-9 * (zb * qs).norm());
        // Force on the shaft equals Z_eff q_s.
        assert!((zb * (qs - qp) - zeff * qs).norm() < 1e-9 * (zeff * qs).norm());
        // A very stiff pedestal gives back the bearing.
        let stiff = Pedestal {
            mass: [1.0, 1.0],
            k: [1e18, 1e18],
            c: [0.0, 0.0],
        };
        let (z2, _) = condense_pedestal(&zb, &pedestal_dynamic_stiffness(&stiff, s), s).unwrap();
        assert!((z2 - zb).norm() < 1e-8 * zb.norm());
    }

    #[test]
    fn singular_is_an_error() {
        let zb = Matrix2::from_diagonal(&Vector2::new(
            Complex64::new(1.0, 0.0),
            Complex64::new(1.0, 0.0),
        ));
        let zp = -zb;
        assert!(condense_pedestal(&zb, &zp, Complex64::new(0.0, 1.0)).is_err());
    }
}
