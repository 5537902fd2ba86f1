//! The prediction model of the output-error fit: the bearing responses the
//! model predicts for given parameters, and their derivatives.
//!
//! # Model
//!
//! At speed `Omega`, with the reduced terms `A(Omega)`, `B(Omega)` of the
//! tables (the same the equation-error filter uses) and the bearing dynamic
//! stiffness `Z_B(Omega; theta)` and unbalance `a(theta)` of the
//! [`Parametrization`],
//!
//! ```text
//!     H(Omega; theta) q_B = B(Omega) a(theta),   H = A(Omega) + Z_B(Omega; theta),
//! ```
//!
//! a `2 N_b x 2 N_b` complex solve per speed (m).
//!
//! # Parameters
//!
//! The fit works on real parameters `theta`: the scaled weights `w~` of the
//! parametrization, each real unknown as one parameter, each complex unknown
//! (paper structure) as two, its real and its imaginary part
//! ([`Predictor::params`]).
//!
//! # Jacobian (derivative of the solve)
//!
//! Differentiating `H q = B a`: `H dq = B da - dZ_B q`. A bearing parameter
//! of entry `[r][c]` of bearing `m` with Z-factor `g` (scaled,
//! [`BearingTerm::scaled_z_factor`]; times `j` for an imaginary part)
//! changes only `Z_B[2m+r][2m+c]`, so
//!
//! ```text
//!     dq/dtheta_i = -H^-1 e_(2m+r) g q_(2m+c),
//! ```
//!
//! one column of `H^-1`; an unbalance parameter of plane `k` with factor
//! `s_a da/dw` gives `dq/dtheta_i = H^-1 B e_k s_a da/dw`. One inverse of
//! `H` per speed serves every column. Checked against central finite
//! differences in the tests.

use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;
use rotorid_core::parametrization::{BearingTerm, UnbalancePart, Unknown};
use thiserror::Error;

use crate::estimate::parametrization::Parametrization;

/// The prediction failed at a speed.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum PredictError {
    /// `A + Z_B` is singular (or not finite) at this speed: the parameters
    /// put an undamped resonance exactly on it.
    #[error("A + Z_B is singular at {omega} rad/s")]
    Singular {
        /// Speed (rad/s).
        omega: f64,
    },
    /// Terms or weights of the wrong size.
    #[error("terms or parameters do not match the parametrization")]
    Dimension,
}

/// One real parameter of the fit: unknown `j` of the parametrization and,
/// for a complex unknown, which part.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FitParam {
    /// Index of the unknown in the parametrization.
    pub unknown: usize,
    /// The imaginary part of a complex unknown (`false`: the real part, or
    /// the real unknown itself).
    pub imaginary: bool,
}

/// The reduced terms at one speed: `A` (`2 N_b x 2 N_b`, N/m) and `B`
/// (`2 N_b x N_p`, 1/s^2).
pub type Terms = (DMatrix<Complex64>, DMatrix<Complex64>);

/// The prediction model for one parametrization (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct Predictor {
    /// The unknowns.
    pub param: Parametrization,
    /// The real fit parameters, in order.
    pub params: Vec<FitParam>,
}

/// The prediction at one speed.
#[derive(Debug, Clone, PartialEq)]
pub struct Prediction {
    /// Predicted bearing responses `q_B` (m), `b1_y, b1_z, b2_y, ...`.
    pub q: DVector<Complex64>,
    /// `dq / dtheta` (`2 N_b x P`), when asked for.
    pub jacobian: Option<DMatrix<Complex64>>,
    /// `H^-1` (for prefilters built on the prediction).
    pub h_inv: DMatrix<Complex64>,
}

impl Predictor {
    /// The predictor of `param`: one parameter per real unknown, two per
    /// complex unknown.
    pub fn new(param: Parametrization) -> Self {
        let complex = param.structure.is_complex();
        let mut params = Vec::new();
        for unknown in 0..param.n_unknowns() {
            params.push(FitParam {
                unknown,
                imaginary: false,
            });
            if complex {
                params.push(FitParam {
                    unknown,
                    imaginary: true,
                });
            }
        }
        Predictor { param, params }
    }

    /// Number of real parameters `P`.
    pub fn n_params(&self) -> usize {
        self.params.len()
    }

    /// `theta` from the scaled weights `w~` (complex; real unknowns in `re`).
    pub fn theta(&self, w: &[Complex64]) -> Vec<f64> {
        self.params
            .iter()
            .map(|p| {
                let z = w.get(p.unknown).copied().unwrap_or_default();
                if p.imaginary {
                    z.im
                } else {
                    z.re
                }
            })
            .collect()
    }

    /// The scaled weights `w~` of `theta`.
    pub fn weights(&self, theta: &[f64]) -> Vec<Complex64> {
        let mut w = vec![Complex64::new(0.0, 0.0); self.param.n_unknowns()];
        for (p, &t) in self.params.iter().zip(theta) {
            if p.imaginary {
                w[p.unknown].im = t;
            } else {
                w[p.unknown].re = t;
            }
        }
        w
    }

    /// The complex factor by which parameter `i` enters: for a bearing
    /// parameter `(row index of Z_B, column index, factor)` with
    /// `dZ_B[row][col] = factor`, for an unbalance parameter
    /// `(plane, factor)` with `da_plane = factor` (kg m per unit).
    /// How every parameter enters at `omega`, in parameter order.
    pub fn entries(&self, omega: f64) -> Vec<Entry> {
        (0..self.n_params())
            .filter_map(|i| self.entry(i, omega))
            .collect()
    }

    fn entry(&self, i: usize, omega: f64) -> Option<Entry> {
        let p = self.params.get(i)?;
        let iota = if p.imaginary {
            Complex64::new(0.0, 1.0)
        } else {
            Complex64::new(1.0, 0.0)
        };
        Some(match self.param.unknown(p.unknown)? {
            Unknown::Bearing {
                bearing,
                row,
                col,
                term,
            } => Entry::Bearing {
                row: 2 * bearing + row,
                col: 2 * bearing + col,
                dz: bearing_factor(&term, &self.param, omega) * iota,
            },
            Unknown::Unbalance { plane, part } => Entry::Unbalance {
                plane,
                da: unbalance_factor(part, &self.param) * iota,
            },
        })
    }

    /// `q_B(Omega; theta)` and, with `jacobian`, `dq/dtheta`.
    pub fn predict(
        &self,
        omega: f64,
        terms: &Terms,
        theta: &[f64],
        jacobian: bool,
    ) -> Result<Prediction, PredictError> {
        self.predict_with(omega, terms, &self.entries(omega), theta, jacobian)
    }

    /// [`Predictor::predict`] with the parameters' [`Entry`]s at `omega`
    /// given (they depend on the speed only: a fit computes them once).
    pub fn predict_with(
        &self,
        omega: f64,
        terms: &Terms,
        entries: &[Entry],
        theta: &[f64],
        jacobian: bool,
    ) -> Result<Prediction, PredictError> {
        let (a, b) = terms;
        let nq = 2 * self.param.n_bearings();
        let np = self.param.n_planes();
        if a.nrows() != nq || a.ncols() != nq || b.nrows() != nq || b.ncols() != np {
            return Err(PredictError::Dimension);
        }
        if theta.len() != self.n_params() || entries.len() != self.n_params() {
            return Err(PredictError::Dimension);
        }
        // Z_B and a are linear in theta: H = A + sum_i theta_i dZ_i,
        // f = B sum_i theta_i da_i.
        let mut h = a.clone();
        let mut ak = vec![Complex64::new(0.0, 0.0); np];
        for (en, &t) in entries.iter().zip(theta) {
            match *en {
                Entry::Bearing { row, col, dz } => h[(row, col)] += dz * t,
                Entry::Unbalance { plane, da } => ak[plane] += da * t,
            }
        }
        let mut f = DVector::<Complex64>::zeros(nq);
        for (k, a_k) in ak.iter().enumerate() {
            for i in 0..nq {
                f[i] += b[(i, k)] * a_k;
            }
        }
        let h_inv = h
            .try_inverse()
            .filter(|m| m.iter().all(|z| z.re.is_finite() && z.im.is_finite()))
            .ok_or(PredictError::Singular { omega })?;
        let q = &h_inv * f;
        let jacobian = jacobian.then(|| self.jacobian_with(omega, &h_inv, b, &q));
        Ok(Prediction { q, jacobian, h_inv })
    }
}

impl Predictor {
    /// `dq/dtheta` at a speed from `H^-1`, `B` and the response `q` that
    /// multiplies the bearing columns (`2 N_b x P`). With `q` the
    /// prediction this is the Jacobian of [`Predictor::predict`]; with the
    /// measured response it is the (negated) regressor of the prefiltered
    /// equation error `H^-1 (H(theta) q_meas - B a(theta))`, which is
    /// linear in `theta`.
    pub fn jacobian_with(
        &self,
        omega: f64,
        h_inv: &DMatrix<Complex64>,
        b: &DMatrix<Complex64>,
        q: &DVector<Complex64>,
    ) -> DMatrix<Complex64> {
        let nq = h_inv.nrows();
        let y = h_inv * b; // H^-1 B, nq x np
        let mut jac = DMatrix::<Complex64>::zeros(nq, self.n_params());
        for i in 0..self.n_params() {
            match self.entry(i, omega) {
                Some(Entry::Bearing { row, col, dz }) => {
                    let s = dz * q[col];
                    for r in 0..nq {
                        jac[(r, i)] = -(h_inv[(r, row)] * s);
                    }
                }
                Some(Entry::Unbalance { plane, da }) => {
                    for r in 0..nq {
                        jac[(r, i)] = y[(r, plane)] * da;
                    }
                }
                None => {}
            }
        }
        jac
    }
}

/// How one fit parameter enters at a speed (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Entry {
    /// `dZ_B[row][col] / dtheta = dz` (N/m per unit).
    Bearing {
        /// Row of `Z_B` (channel index).
        row: usize,
        /// Column of `Z_B` (channel index).
        col: usize,
        /// The derivative.
        dz: Complex64,
    },
    /// `da_plane / dtheta = da` (kg m per unit).
    Unbalance {
        /// The plane.
        plane: usize,
        /// The derivative.
        da: Complex64,
    },
}

fn bearing_factor(term: &BearingTerm, param: &Parametrization, omega: f64) -> Complex64 {
    term.scaled_z_factor(&param.scaling, omega)
}

fn unbalance_factor(part: UnbalancePart, param: &Parametrization) -> Complex64 {
    part.factor::<f64>() * param.scaling.unbalance
}

#[cfg(test)]
mod tests {
    use super::*;
    use rotorid_core::parametrization::Structure;
    use rotorid_core::scaling::ColumnScaling;

    fn terms(omega: f64) -> Terms {
        // A smooth synthetic "shaft" with 2 bearings and 2 planes.
        let a = DMatrix::from_fn(4, 4, |i, j| {
            Complex64::new(
                3e7 * ((i + 2 * j) as f64 * 0.37).sin()
                    - 5.0 * omega * omega * (i == j) as u8 as f64,
                1e3 * omega * ((i * j) as f64 * 0.11).cos(),
            )
        });
        let b = DMatrix::from_fn(4, 2, |i, k| {
            Complex64::new(
                omega * omega * (0.5 + 0.1 * i as f64),
                -0.2 * omega * omega * k as f64,
            )
        });
        (a, b)
    }

    #[test]
    fn jacobian_matches_central_differences() {
        for st in [
            Structure::physical(1),
            Structure::physical(3),
            Structure::paper(2),
        ] {
            let param = Parametrization {
                structure: st,
                scaling: ColumnScaling::new(3e7, 1500.0, 1e-3).unwrap(),
                bearing_nodes: vec![0, 10],
                plane_nodes: vec![3, 6],
            };
            let pr = Predictor::new(param);
            let theta: Vec<f64> = (0..pr.n_params())
                .map(|i| 0.8 + 0.3 * ((i * 37 % 11) as f64 / 11.0 - 0.5))
                .collect();
            let omega = 1100.0;
            let t = terms(omega);
            let p = pr.predict(omega, &t, &theta, true).unwrap();
            let jac = p.jacobian.unwrap();
            for i in 0..pr.n_params() {
                let h = 1e-6;
                let mut tp = theta.clone();
                let mut tm = theta.clone();
                tp[i] += h;
                tm[i] -= h;
                let qp = pr.predict(omega, &t, &tp, false).unwrap().q;
                let qm = pr.predict(omega, &t, &tm, false).unwrap().q;
                let fd = (qp - qm) / Complex64::new(2.0 * h, 0.0);
                let scale = p.q.norm();
                for r in 0..4 {
                    assert!(
                        (fd[r] - jac[(r, i)]).norm() <= 1e-7 * scale,
                        "{st:?} param {i} row {r}: {} vs {}",
                        fd[r],
                        jac[(r, i)]
                    );
                }
            }
            // theta -> weights -> theta is the identity.
            assert_eq!(pr.theta(&pr.weights(&theta)), theta);
        }
    }
}
