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

use crate::estimate::unknowns::Parametrization;

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
        let mut solve = Solve::new(nq, np);
        solve.run(omega, terms, entries, theta)?;
        let h_inv = DMatrix::from_column_slice(nq, nq, &solve.h_inv);
        let q = DVector::from_column_slice(&solve.q);
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

/// The prediction at one speed into reused buffers, without allocating:
/// the inner loop of the fit ([`Predictor::predict_with`] wraps it).
#[derive(Debug, Clone)]
pub(crate) struct Solve {
    nq: usize,
    np: usize,
    /// `H`, then its triangular factors (column-major `nq x nq`).
    lu: Vec<Complex64>,
    /// `H^-1` (column-major `nq x nq`).
    pub h_inv: Vec<Complex64>,
    /// The forcing `B a(theta)`.
    f: Vec<Complex64>,
    /// `a(theta)`.
    ak: Vec<Complex64>,
    /// The predicted `q_B`.
    pub q: Vec<Complex64>,
}

impl Solve {
    /// Buffers for `nq` channels and `np` planes.
    pub(crate) fn new(nq: usize, np: usize) -> Self {
        let zero = Complex64::new(0.0, 0.0);
        Solve {
            nq,
            np,
            lu: vec![zero; nq * nq],
            h_inv: vec![zero; nq * nq],
            f: vec![zero; nq],
            ak: vec![zero; np],
            q: vec![zero; nq],
        }
    }

    /// `H^-1` and `q = H^-1 B a(theta)` at `omega` (see
    /// [`Predictor::predict_with`]).
    pub(crate) fn run(
        &mut self,
        omega: f64,
        terms: &Terms,
        entries: &[Entry],
        theta: &[f64],
    ) -> Result<(), PredictError> {
        let (a, b) = terms;
        let (nq, np) = (self.nq, self.np);
        if a.nrows() != nq || a.ncols() != nq || b.nrows() != nq || b.ncols() != np {
            return Err(PredictError::Dimension);
        }
        // Z_B and a are linear in theta: H = A + sum_i theta_i dZ_i,
        // f = B sum_i theta_i da_i.
        self.lu.copy_from_slice(a.as_slice());
        self.ak.fill(Complex64::new(0.0, 0.0));
        for (en, &t) in entries.iter().zip(theta) {
            match *en {
                Entry::Bearing { row, col, dz } => self.lu[col * nq + row] += dz * t,
                Entry::Unbalance { plane, da } => self.ak[plane] += da * t,
            }
        }
        self.f.fill(Complex64::new(0.0, 0.0));
        for (bk, a_k) in b.as_slice().chunks_exact(nq).zip(&self.ak) {
            for (fi, bik) in self.f.iter_mut().zip(bk) {
                *fi += bik * a_k;
            }
        }
        if !invert(nq, &mut self.lu, &mut self.h_inv) {
            return Err(PredictError::Singular { omega });
        }
        self.q.fill(Complex64::new(0.0, 0.0));
        for (col, fj) in self.h_inv.chunks_exact(nq).zip(&self.f) {
            for (qi, hij) in self.q.iter_mut().zip(col) {
                *qi += hij * fj;
            }
        }
        Ok(())
    }
}

/// `inv = m^-1` for the `n x n` column-major `m`, which is overwritten by
/// its triangular factors: Gaussian elimination with partial pivoting (the
/// largest `|re| + |im|` of the column), then a forward and a back
/// substitution for each column of the identity. `false` when a pivot is
/// zero or the inverse is not finite.
///
/// The sizes of one to four bearings run a copy of the same steps on
/// fixed-size arrays (unrolled, without bounds checks); the tests check
/// that both give the same bits.
pub(crate) fn invert(n: usize, m: &mut [Complex64], inv: &mut [Complex64]) -> bool {
    match n {
        2 => invert_fixed::<2>(m, inv),
        4 => invert_fixed::<4>(m, inv),
        6 => invert_fixed::<6>(m, inv),
        8 => invert_fixed::<8>(m, inv),
        _ => invert_any(n, m, inv),
    }
}

fn l1(z: Complex64) -> f64 {
    z.re.abs() + z.im.abs()
}

fn invert_any(n: usize, m: &mut [Complex64], inv: &mut [Complex64]) -> bool {
    let zero = Complex64::new(0.0, 0.0);
    inv.fill(zero);
    for i in 0..n {
        inv[i * n + i] = Complex64::new(1.0, 0.0);
    }
    let mut d = vec![zero; n];
    for k in 0..n {
        let (mut p, mut best) = (k, l1(m[k * n + k]));
        for i in k + 1..n {
            let v = l1(m[k * n + i]);
            if v > best {
                (p, best) = (i, v);
            }
        }
        if !(best > 0.0 && best.is_finite()) {
            return false;
        }
        if p != k {
            for j in 0..n {
                m.swap(j * n + k, j * n + p);
                inv.swap(j * n + k, j * n + p);
            }
        }
        d[k] = m[k * n + k].inv();
        for i in k + 1..n {
            let l = m[k * n + i] * d[k];
            m[k * n + i] = l;
            for j in k + 1..n {
                let mkj = m[j * n + k];
                m[j * n + i] -= l * mkj;
            }
            for j in 0..n {
                let ikj = inv[j * n + k];
                inv[j * n + i] -= l * ikj;
            }
        }
    }
    // Back substitution U X = L^-1 P, column by column.
    for j in 0..n {
        let col = j * n;
        for k in (0..n).rev() {
            let mut s = inv[col + k];
            for c in k + 1..n {
                s -= m[c * n + k] * inv[col + c];
            }
            inv[col + k] = s * d[k];
        }
    }
    inv.iter().all(|z| z.re.is_finite() && z.im.is_finite())
}

/// [`invert_any`] for `n = N`, step for step (the same operations in the
/// same order) on arrays `[column][row]`. Index loops: with constant
/// bounds they unroll; the iterator forms cost 3 % more instructions.
#[allow(clippy::needless_range_loop)]
fn invert_fixed<const N: usize>(m_io: &mut [Complex64], inv_io: &mut [Complex64]) -> bool {
    let zero = Complex64::new(0.0, 0.0);
    let mut m = [[zero; N]; N];
    let mut inv = [[zero; N]; N];
    for (j, col) in m.iter_mut().enumerate() {
        col.copy_from_slice(&m_io[j * N..(j + 1) * N]);
        inv[j][j] = Complex64::new(1.0, 0.0);
    }
    let mut d = [zero; N];
    for k in 0..N {
        let (mut p, mut best) = (k, l1(m[k][k]));
        for i in k + 1..N {
            let v = l1(m[k][i]);
            if v > best {
                (p, best) = (i, v);
            }
        }
        if !(best > 0.0 && best.is_finite()) {
            return false;
        }
        if p != k {
            for j in 0..N {
                m[j].swap(k, p);
                inv[j].swap(k, p);
            }
        }
        d[k] = m[k][k].inv();
        for i in k + 1..N {
            let l = m[k][i] * d[k];
            m[k][i] = l;
            for j in k + 1..N {
                let mkj = m[j][k];
                m[j][i] -= l * mkj;
            }
            for col in inv.iter_mut() {
                let ikj = col[k];
                col[i] -= l * ikj;
            }
        }
    }
    for col in inv.iter_mut() {
        for k in (0..N).rev() {
            let mut s = col[k];
            for c in k + 1..N {
                s -= m[c][k] * col[c];
            }
            col[k] = s * d[k];
        }
    }
    for (j, col) in m.iter().enumerate() {
        m_io[j * N..(j + 1) * N].copy_from_slice(col);
        inv_io[j * N..(j + 1) * N].copy_from_slice(&inv[j]);
    }
    inv.iter()
        .flatten()
        .all(|z| z.re.is_finite() && z.im.is_finite())
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
    fn inverse_equals_nalgebras_and_needs_pivoting() {
        // Dense complex matrices of several sizes, one with a zero leading
        // diagonal (elimination without row exchanges fails on it), one
        // with rows of very different scale, and singular ones.
        for n in 1..=9 {
            for case in 0..3 {
                if n == 1 && case == 1 {
                    continue;
                }
                // Pseudo-random entries in [-1, 1) (a linear congruential
                // sequence).
                let mut state = 0x2545_f491_4f6c_dd1d_u64 ^ (n * 3 + case) as u64;
                let mut rand = || {
                    state = state
                        .wrapping_mul(6_364_136_223_846_793_005)
                        .wrapping_add(1_442_695_040_888_963_407);
                    (state >> 11) as f64 / (1u64 << 52) as f64 - 1.0
                };
                let m = DMatrix::from_fn(n, n, |i, j| {
                    let z = Complex64::new(rand(), rand());
                    match case {
                        1 if i == j => Complex64::new(0.0, 0.0),
                        2 => z * 10f64.powi(2 * i as i32),
                        _ => z,
                    }
                });
                let reference = m.clone().try_inverse().unwrap();
                let mut lu = m.as_slice().to_vec();
                let mut inv = vec![Complex64::new(0.0, 0.0); n * n];
                assert!(invert(n, &mut lu, &mut inv), "{n} {case}");
                let inv = DMatrix::from_column_slice(n, n, &inv);
                let id = DMatrix::<Complex64>::identity(n, n);
                // Round-off of a backward-stable inverse: the residual and
                // the difference from nalgebra's inverse within
                // eps * n * |m| |m^-1| (the condition number).
                let big = |x: &DMatrix<Complex64>| x.iter().map(|z| z.norm()).fold(0.0, f64::max);
                let kappa = big(&m) * big(&reference);
                let res = big(&(&m * &inv - &id));
                assert!(
                    res < 1e-15 * (n * n) as f64 * kappa,
                    "{n} {case}: {res} {kappa}"
                );
                let diff = big(&(&inv - &reference)) / big(&reference);
                assert!(
                    diff < 1e-15 * (n * n) as f64 * kappa,
                    "{n} {case}: {diff} {kappa}"
                );
            }
            // The fixed-size copies take the same steps: the same bits.
            let m = DMatrix::from_fn(n, n, |i, j| {
                Complex64::new((1 + i * j) as f64 * 0.37, (i as f64 - j as f64) * 1.9)
            });
            let (mut lu1, mut lu2) = (m.as_slice().to_vec(), m.as_slice().to_vec());
            let mut inv1 = vec![Complex64::new(0.0, 0.0); n * n];
            let mut inv2 = inv1.clone();
            assert!(invert(n, &mut lu1, &mut inv1), "{n}");
            assert!(invert_any(n, &mut lu2, &mut inv2), "{n}");
            assert_eq!((lu1, inv1), (lu2, inv2), "{n}");
            // Singular: a zero column; not finite: a NaN entry.
            let mut s = DMatrix::from_fn(n, n, |i, j| Complex64::new((i + j) as f64, 1.0));
            if n > 1 {
                s.set_column(1, &DVector::zeros(n));
                let mut lu = s.as_slice().to_vec();
                let mut inv = lu.clone();
                assert!(!invert(n, &mut lu, &mut inv), "{n}");
            }
            s[(0, 0)] = Complex64::new(f64::NAN, 0.0);
            let mut lu = s.as_slice().to_vec();
            let mut inv = lu.clone();
            assert!(!invert(n, &mut lu, &mut inv), "{n} NaN");
        }
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
