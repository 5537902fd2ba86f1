//! The regression `d(n) = U(n) w` of the identification (the method paper's
//! Eqs. 43-48, with their signs corrected), for every model structure.
//!
//! # Derivation
//!
//! At speed `Omega` the shaft-and-disk model reduced to the `2 N_b` bearing
//! channels (`b1_y, b1_z, b2_y, ...`) gives, for the true parameters
//! (the table contract of [`crate::table`], Eq. 38 of the paper):
//!
//! ```text
//!     A(Omega) q_B = -Z_B(Omega) q_B + B(Omega) a,
//!     A = Z_R,BB - Y Z_R,iB,   B = Omega^2 (T_B - Y T_i),   Y = Z_R,Bi Z_R,ii^-1,
//! ```
//!
//! with `q_B` the measured 1X phasors (m), `Z_B = blockdiag(Z_B^(m))` the
//! bearing dynamic stiffness (one 2x2 block per bearing, N/m) and
//! `a = (a_1 .. a_Np)` the unbalances `a_k = m_k e_k exp(j alpha_k)` (kg m).
//! The left side is known, so `d := A q_B` and every unknown column of `U`
//! carries a **minus sign** for the bearing terms (the paper's Eqs. 44/46
//! print it on `-Omega^2 Y T` but drop it from the bearing columns; used
//! literally they identify `-K` and `-C`). The row of channel `(m, r)`
//! (bearing `m`, direction `r` = y or z) reads
//!
//! ```text
//!     d_(m,r) = - sum_c Z_B^(m)[r][c](Omega) q_(m,c) + sum_k B_(m,r),k a_k .
//! ```
//!
//! # Model structures
//!
//! What the unknowns are, their order, scales and how each enters `Z_B`
//! is [`crate::parametrization`]. The column of unknown `j` in row
//! `(m, r)` is `-g_j(Omega) s_j q_(m,c)` for a bearing term of entry
//! `[r][c]` of bearing `m` (zero for other bearings and directions) and
//! `B_(m,r),k s_a da/dw_j` for plane `k`. The physical structure's complex
//! equation is split into its real and imaginary rows (`N = 4 N_b`, row
//! `2 i` = Re, `2 i + 1` = Im of complex row `i`).
//!
//! Stiffness proportional to `Omega^2` (the paper's Eq. 49) needs physical
//! order 3 or paper order 2.
//!
//! All columns are formed already scaled by [`ColumnScaling`] (`U S`, see
//! [`crate::scaling`]); [`ColumnScaling::identity`] gives the raw SI form.
//! The functions work on slices (row-major, caller buffers) so that firmware
//! uses fixed arrays and the desktop uses `Vec`s of runtime size.

use crate::parametrization::{ParamError, Structure, UnbalancePart, Unknown};
use crate::scalar::Real;
use crate::scaling::ColumnScaling;
use num_complex::Complex;

/// Errors of the regressor formation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RegressorError {
    /// Order outside `1..=MAX_ORDER`.
    InvalidOrder,
    /// A buffer length does not match the structure and sizes.
    Dimension,
    /// A non-finite value in the speed, the terms or the measurement.
    NonFinite,
}

impl From<ParamError> for RegressorError {
    fn from(e: ParamError) -> Self {
        match e {
            ParamError::InvalidOrder => RegressorError::InvalidOrder,
            ParamError::Dimension => RegressorError::Dimension,
        }
    }
}

/// One measurement with its reduced terms: the input of the regression.
#[derive(Debug, Clone, Copy)]
pub struct Equations<'a, T> {
    /// Speed `Omega` (rad/s).
    pub omega: T,
    /// `A(Omega)`, row-major `nq x nq` (N/m).
    pub a: &'a [Complex<T>],
    /// `B(Omega)`, row-major `nq x np` (1/s^2).
    pub b: &'a [Complex<T>],
    /// Measured phasors `q_B` (m), `nq = 2 N_b`.
    pub q: &'a [Complex<T>],
    /// Number of bearing channels `nq = 2 N_b`.
    pub nq: usize,
    /// Number of planes `N_p`.
    pub np: usize,
}

impl<T: Real> Equations<'_, T> {
    /// Checks lengths and finiteness; returns `N_b`.
    fn check(&self) -> Result<usize, RegressorError> {
        let (nq, np) = (self.nq, self.np);
        if nq == 0
            || nq % 2 != 0
            || self.a.len() != nq * nq
            || self.b.len() != nq * np
            || self.q.len() != nq
        {
            return Err(RegressorError::Dimension);
        }
        let f = |z: &Complex<T>| z.re.is_finite() && z.im.is_finite();
        if !(self.omega.is_finite()
            && self.a.iter().all(f)
            && self.b.iter().all(f)
            && self.q.iter().all(f))
        {
            return Err(RegressorError::NonFinite);
        }
        Ok(nq / 2)
    }

    /// `d_i = (A q)_i`.
    fn d(&self, i: usize) -> Complex<T> {
        let mut s = Complex::new(T::zero(), T::zero());
        for (aij, qj) in self.a.iter().skip(i * self.nq).take(self.nq).zip(self.q) {
            s += *aij * *qj;
        }
        s
    }

    /// Calls `put(j, g)` for every non-zero column `j` of complex row `i`
    /// (channel `(m, r) = (i / 2, i % 2)`) with its complex coefficient
    /// `g` of the scaled unknown (see the module documentation).
    fn columns(
        &self,
        structure: &Structure,
        scaling: &ColumnScaling<T>,
        nb: usize,
        i: usize,
        mut put: impl FnMut(usize, Complex<T>) -> Result<(), RegressorError>,
    ) -> Result<(), RegressorError> {
        let (m, r) = (i / 2, i % 2);
        for t in 0..structure.terms_per_entry() {
            let term = structure.entry_term(t);
            let g = term.scaled_z_factor(scaling, self.omega);
            for c in 0..2 {
                let j = structure
                    .bearing_index(m, r, c, term)
                    .ok_or(RegressorError::Dimension)?;
                let qc = *self.q.get(2 * m + c).ok_or(RegressorError::Dimension)?;
                put(j, -(qc * g))?;
            }
        }
        for k in 0..self.np {
            let bik = *self
                .b
                .get(i * self.np + k)
                .ok_or(RegressorError::Dimension)?
                * scaling.unbalance;
            for part in [UnbalancePart::Phasor, UnbalancePart::Re, UnbalancePart::Im] {
                if let Some(j) = structure.index(nb, Unknown::Unbalance { plane: k, part }) {
                    put(j, bik * part.factor())?;
                }
            }
        }
        Ok(())
    }
}

/// Forms the complex regression of the `paper` structure of order `P`,
/// scaled: `d = A q` (length `N = nq`) and `U S` (row-major `N x M`).
/// Errors: order, buffer lengths, non-finite input (outputs untouched then).
pub fn form_paper<T: Real>(
    order: usize,
    scaling: &ColumnScaling<T>,
    eq: &Equations<'_, T>,
    d: &mut [Complex<T>],
    u: &mut [Complex<T>],
) -> Result<(), RegressorError> {
    let s = Structure::paper(order);
    s.validate()?;
    let nb = eq.check()?;
    let m_cols = s.n_unknowns(nb, eq.np);
    if d.len() != eq.nq || u.len() != eq.nq * m_cols {
        return Err(RegressorError::Dimension);
    }
    u.fill(Complex::new(T::zero(), T::zero()));
    // `m_cols > 0`: `eq.check` gives at least one bearing.
    for (i, (di, row)) in d.iter_mut().zip(u.chunks_exact_mut(m_cols)).enumerate() {
        *di = eq.d(i);
        eq.columns(&s, scaling, nb, i, |j, g| {
            *row.get_mut(j).ok_or(RegressorError::Dimension)? = g;
            Ok(())
        })?;
    }
    Ok(())
}

/// Forms the real regression of the `physical` structure of order `P`,
/// scaled: `d` (length `N = 2 nq`: Re and Im of `A q`, interleaved) and
/// `U S` (row-major `N x M`). Arguments as in [`form_paper`].
pub fn form_physical<T: Real>(
    order: usize,
    scaling: &ColumnScaling<T>,
    eq: &Equations<'_, T>,
    d: &mut [T],
    u: &mut [T],
) -> Result<(), RegressorError> {
    let s = Structure::physical(order);
    s.validate()?;
    let nb = eq.check()?;
    let m_cols = s.n_unknowns(nb, eq.np);
    let n_rows = 2 * eq.nq;
    if d.len() != n_rows || u.len() != n_rows * m_cols {
        return Err(RegressorError::Dimension);
    }
    u.fill(T::zero());
    // `m_cols > 0`: `eq.check` gives at least one bearing.
    for (i, (dd, rows)) in d
        .chunks_exact_mut(2)
        .zip(u.chunks_exact_mut(2 * m_cols))
        .enumerate()
    {
        let di = eq.d(i);
        if let [re, im] = dd {
            (*re, *im) = (di.re, di.im);
        }
        // Complex coefficient g of a real unknown: Re row gets Re g, Im row Im g.
        let (re_row, im_row) = rows.split_at_mut(m_cols);
        eq.columns(&s, scaling, nb, i, |j, g| {
            match (re_row.get_mut(j), im_row.get_mut(j)) {
                (Some(r), Some(m)) => (*r, *m) = (g.re, g.im),
                _ => return Err(RegressorError::Dimension),
            }
            Ok(())
        })?;
    }
    Ok(())
}

/// Divides each row of `[U d]` (row-major `n x m`, `d` of length `n`) by
/// the 2-norm of the row of `U` (rows of zeros are left alone).
///
/// Effect on the least squares: row `i` gets weight `1 / |U_i|^2`, so that
/// speeds with a large response (near the critical speeds) no longer
/// dominate the fit. With noise proportional to the response (the SPEC's
/// noise model), this makes the equation errors roughly equally sized,
/// which is the appropriate weighting; on noise-free data the solution is
/// unchanged. Returns `Err(Dimension)` on mismatched lengths.
pub fn normalise_rows<T: Real, F: nalgebra::ComplexField<RealField = T> + Copy>(
    u: &mut [F],
    d: &mut [F],
    n: usize,
    m: usize,
) -> Result<(), RegressorError> {
    if u.len() != n * m || d.len() != n {
        return Err(RegressorError::Dimension);
    }
    if m == 0 {
        return Ok(()); // rows of zero length: nothing to scale
    }
    for (row, di) in u.chunks_exact_mut(m).zip(d.iter_mut()) {
        // Scaled 2-norm (no overflow/underflow): max |u_ij| first.
        let mut big = T::zero();
        for x in row.iter() {
            let v = x.modulus();
            if v > big {
                big = v;
            }
        }
        if big <= T::zero() || !big.is_finite() {
            continue;
        }
        let mut ss = T::zero();
        for x in row.iter() {
            let v = x.modulus() / big;
            ss += v * v;
        }
        let norm = big * ss.sqrt();
        let inv = T::one() / norm;
        for x in row.iter_mut() {
            *x = x.scale(inv);
        }
        *di = di.scale(inv);
    }
    Ok(())
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)]
mod tests {
    use super::*;
    use crate::parametrization::{bearing_estimate, unbalance_estimate, BearingTerm};
    use nalgebra::DMatrix;
    use std::vec;
    use std::vec::Vec;

    type C64 = Complex<f64>;

    /// xorshift64* in [-1, 1).
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> f64 {
            self.0 ^= self.0 >> 12;
            self.0 ^= self.0 << 25;
            self.0 ^= self.0 >> 27;
            let x = self.0.wrapping_mul(0x2545_f491_4f6c_dd1d);
            (x >> 11) as f64 / (1u64 << 52) as f64 - 1.0
        }
        fn c(&mut self) -> C64 {
            C64::new(self.next(), self.next())
        }
    }

    /// A random problem: A, B, and a true Z_B, a; q solves (A + Z_B) q = B a.
    struct Problem {
        nq: usize,
        np: usize,
        omega: f64,
        a: Vec<C64>,
        b: Vec<C64>,
        q: Vec<C64>,
    }

    impl Problem {
        fn eq(&self) -> Equations<'_, f64> {
            Equations {
                omega: self.omega,
                a: &self.a,
                b: &self.b,
                q: &self.q,
                nq: self.nq,
                np: self.np,
            }
        }
    }

    fn solve_q(
        rng: &mut Rng,
        nq: usize,
        np: usize,
        zb: &DMatrix<C64>,
        ua: &[C64],
        omega: f64,
    ) -> Problem {
        let a = DMatrix::from_fn(nq, nq, |_, _| rng.c() * 1e8);
        let b = DMatrix::from_fn(nq, np, |_, _| rng.c() * omega * omega);
        let rhs = &b * nalgebra::DVector::from_column_slice(ua);
        let q = (&a + zb).lu().solve(&rhs).unwrap();
        Problem {
            nq,
            np,
            omega,
            a: a.transpose().as_slice().to_vec(),
            b: b.transpose().as_slice().to_vec(),
            q: q.as_slice().to_vec(),
        }
    }

    fn scalings() -> [ColumnScaling<f64>; 2] {
        [
            ColumnScaling::identity(),
            ColumnScaling::new(3e7, 1500.0, 2e-3).unwrap(),
        ]
    }

    #[test]
    fn paper_structure_true_parameters_satisfy_d_eq_u_w() {
        let mut rng = Rng(0x1234_5678_9abc_def1);
        for order in 1..=3 {
            for (nb, np) in [(1, 1), (2, 3), (3, 2)] {
                let nq = 2 * nb;
                let omega = 700.0 + 500.0 * rng.next();
                // Z_p per bearing, scaled so that Omega^p Z_p ~ 1e7.
                let mut zp = vec![[C64::new(0.0, 0.0); 4]; (order + 1) * nb];
                for (idx, z) in zp.iter_mut().enumerate() {
                    let p = idx % (order + 1);
                    for e in z.iter_mut() {
                        *e = rng.c() * 1e7 / omega.powi(p as i32);
                    }
                }
                let mut zb = DMatrix::zeros(nq, nq);
                for m in 0..nb {
                    for e in 0..4 {
                        let mut s = C64::new(0.0, 0.0);
                        for p in 0..=order {
                            s += zp[m * (order + 1) + p][e] * omega.powi(p as i32);
                        }
                        zb[(2 * m + e / 2, 2 * m + e % 2)] = s;
                    }
                }
                let ua: Vec<C64> = (0..np).map(|_| rng.c() * 1e-3).collect();
                let pb = solve_q(&mut rng, nq, np, &zb, &ua, omega);
                let st = Structure::paper(order);
                let mm = st.n_unknowns(nb, np);
                assert_eq!(mm, 4 * (order + 1) * nb + np);
                for sc in scalings() {
                    // True scaled weights w~ = S^-1 w.
                    let mut w = vec![C64::new(0.0, 0.0); mm];
                    for m in 0..nb {
                        for p in 0..=order {
                            for e in 0..4 {
                                let j = st
                                    .bearing_index(m, e / 2, e % 2, BearingTerm::Z { power: p })
                                    .unwrap();
                                w[j] = zp[m * (order + 1) + p][e]
                                    / st.column_scale(&sc, nb, np, j).unwrap();
                            }
                        }
                    }
                    for k in 0..np {
                        w[st.plane_index(nb, k)] = ua[k] / sc.unbalance;
                    }
                    let mut d = vec![C64::new(0.0, 0.0); nq];
                    let mut u = vec![C64::new(0.0, 0.0); nq * mm];
                    form_paper(order, &sc, &pb.eq(), &mut d, &mut u).unwrap();
                    let dn: f64 = d.iter().map(|x| x.norm_sqr()).sum::<f64>().sqrt();
                    for i in 0..nq {
                        let mut uw = C64::new(0.0, 0.0);
                        for j in 0..mm {
                            uw += u[i * mm + j] * w[j];
                        }
                        assert!(
                            (d[i] - uw).norm() <= 1e-12 * dn,
                            "order {order} nb {nb} row {i}"
                        );
                    }
                    // Estimates recover Z_B(Omega) = K + j Omega C + j Im Z_0.
                    for m in 0..nb {
                        let be = bearing_estimate(&st, &sc, &w, nb, np, m, omega).unwrap();
                        for e in 0..4 {
                            let z = zb[(2 * m + e / 2, 2 * m + e % 2)];
                            let z0 = zp[m * (order + 1)][e];
                            // Eq. 43 read at the speed, every order.
                            assert!((be.k[e] - z.re).abs() <= 1e-12 * z.norm());
                            assert!((be.c[e] * omega - (z.im - z0.im)).abs() <= 1e-12 * z.norm());
                            let z1 = zp[m * (order + 1) + 1][e];
                            assert!((be.im_z0.unwrap()[e] - z0.im).abs() <= 1e-12 * z0.norm());
                            assert!((be.re_z1.unwrap()[e] - z1.re).abs() <= 1e-12 * z1.norm());
                        }
                    }
                    for k in 0..np {
                        let ue = unbalance_estimate(&st, &sc, &w, nb, np, k).unwrap();
                        assert!((ue.a - ua[k]).norm() <= 1e-14 * ua[k].norm());
                        assert!((ue.me - ua[k].norm()).abs() <= 1e-14);
                        assert!((ue.phase - ua[k].arg()).abs() <= 1e-12);
                    }
                }
            }
        }
    }

    #[test]
    fn physical_structure_true_parameters_satisfy_d_eq_u_w() {
        let mut rng = Rng(0x0bad_cafe_f00d_1234);
        for order in 1..=3 {
            for (nb, np) in [(1, 1), (2, 3), (3, 2)] {
                let nq = 2 * nb;
                let omega = 700.0 + 500.0 * rng.next();
                // K_p, C_p real per bearing.
                let mut kp = vec![[0.0; 4]; order * nb];
                let mut cp = vec![[0.0; 4]; order * nb];
                for idx in 0..order * nb {
                    let p = (idx % order) as i32;
                    for e in 0..4 {
                        kp[idx][e] = rng.next() * 1e7 / omega.powi(p);
                        cp[idx][e] = rng.next() * 1e4 / omega.powi(p);
                    }
                }
                let mut zb = DMatrix::zeros(nq, nq);
                let mut kt = vec![[0.0; 4]; nb];
                let mut ct = vec![[0.0; 4]; nb];
                for m in 0..nb {
                    for e in 0..4 {
                        for p in 0..order {
                            kt[m][e] += kp[m * order + p][e] * omega.powi(p as i32);
                            ct[m][e] += cp[m * order + p][e] * omega.powi(p as i32);
                        }
                        zb[(2 * m + e / 2, 2 * m + e % 2)] = C64::new(kt[m][e], omega * ct[m][e]);
                    }
                }
                let ua: Vec<C64> = (0..np).map(|_| rng.c() * 1e-3).collect();
                let pb = solve_q(&mut rng, nq, np, &zb, &ua, omega);
                let st = Structure::physical(order);
                let mm = st.n_unknowns(nb, np);
                assert_eq!(mm, 8 * order * nb + 2 * np);
                for sc in scalings() {
                    let mut w = vec![0.0; mm];
                    for m in 0..nb {
                        for p in 0..order {
                            for e in 0..4 {
                                let jk = st
                                    .bearing_index(m, e / 2, e % 2, BearingTerm::K { power: p })
                                    .unwrap();
                                let jc = st
                                    .bearing_index(m, e / 2, e % 2, BearingTerm::C { power: p })
                                    .unwrap();
                                w[jk] = kp[m * order + p][e]
                                    / st.column_scale(&sc, nb, np, jk).unwrap();
                                w[jc] = cp[m * order + p][e]
                                    / st.column_scale(&sc, nb, np, jc).unwrap();
                            }
                        }
                    }
                    for k in 0..np {
                        let j = st.plane_index(nb, k);
                        w[j] = ua[k].re / sc.unbalance;
                        w[j + 1] = ua[k].im / sc.unbalance;
                    }
                    let n = 2 * nq;
                    let mut d = vec![0.0; n];
                    let mut u = vec![0.0; n * mm];
                    form_physical(order, &sc, &pb.eq(), &mut d, &mut u).unwrap();
                    let dn: f64 = d.iter().map(|x| x * x).sum::<f64>().sqrt();
                    for i in 0..n {
                        let uw: f64 = (0..mm).map(|j| u[i * mm + j] * w[j]).sum();
                        assert!(
                            (d[i] - uw).abs() <= 1e-12 * dn,
                            "order {order} nb {nb} row {i}"
                        );
                    }
                    for m in 0..nb {
                        let be = bearing_estimate(&st, &sc, &w, nb, np, m, omega).unwrap();
                        for e in 0..4 {
                            assert!((be.k[e] - kt[m][e]).abs() <= 1e-12 * 1e7 * order as f64);
                            assert!((be.c[e] - ct[m][e]).abs() <= 1e-12 * 1e4 * order as f64);
                        }
                        assert!(be.im_z0.is_none());
                    }
                    for k in 0..np {
                        let ue = unbalance_estimate(&st, &sc, &w, nb, np, k).unwrap();
                        assert!((ue.a - ua[k]).norm() <= 1e-14 * ua[k].norm());
                    }
                }
            }
        }
    }

    #[test]
    fn literal_paper_signs_would_identify_minus_z() {
        // With the bearing columns of Eq. 46 taken literally (+q instead of
        // -q), the true parameters do not satisfy the regression.
        let mut rng = Rng(77);
        let (nb, np, order) = (2, 3, 1);
        let nq = 2 * nb;
        let omega = 900.0;
        let zb = DMatrix::from_fn(nq, nq, |i, j| {
            if i / 2 == j / 2 {
                C64::new(5e7, omega * 500.0) * (1.0 + 0.1 * rng.next())
            } else {
                C64::new(0.0, 0.0)
            }
        });
        let ua: Vec<C64> = (0..np).map(|_| rng.c() * 1e-3).collect();
        let pb = solve_q(&mut rng, nq, np, &zb, &ua, omega);
        let st = Structure::paper(order);
        let mm = st.n_unknowns(nb, np);
        let sc = ColumnScaling::identity();
        let mut d = vec![C64::new(0.0, 0.0); nq];
        let mut u = vec![C64::new(0.0, 0.0); nq * mm];
        form_paper(order, &sc, &pb.eq(), &mut d, &mut u).unwrap();
        // Flip the bearing columns' sign: residual must be of the order of d.
        let mut w = vec![C64::new(0.0, 0.0); mm];
        for m in 0..nb {
            for e in 0..4 {
                w[st.bearing_index(m, e / 2, e % 2, BearingTerm::Z { power: 0 })
                    .unwrap()] = zb[(2 * m + e / 2, 2 * m + e % 2)];
            }
        }
        for k in 0..np {
            w[st.plane_index(nb, k)] = ua[k];
        }
        let mut worst: f64 = 0.0;
        let mut worst_flipped: f64 = 0.0;
        for i in 0..nq {
            let mut uw = C64::new(0.0, 0.0);
            let mut uw_f = C64::new(0.0, 0.0);
            for j in 0..mm {
                uw += u[i * mm + j] * w[j];
                let sign = if j < st.per_bearing() * nb { -1.0 } else { 1.0 };
                uw_f += u[i * mm + j] * w[j] * sign;
            }
            worst = worst.max((d[i] - uw).norm() / d[i].norm());
            worst_flipped = worst_flipped.max((d[i] - uw_f).norm() / d[i].norm());
        }
        assert!(worst < 1e-12, "{worst}");
        assert!(worst_flipped > 1e-2, "{worst_flipped}");
    }

    #[test]
    fn f32_formation_matches_f64() {
        let mut rng = Rng(99);
        let (nb, np, order) = (2, 3, 2);
        let nq = 2 * nb;
        let omega = 1200.0;
        let zb = DMatrix::from_fn(nq, nq, |i, j| {
            if i / 2 == j / 2 {
                rng.c() * 5e7
            } else {
                C64::new(0.0, 0.0)
            }
        });
        let ua: Vec<C64> = (0..np).map(|_| rng.c() * 1e-3).collect();
        let pb = solve_q(&mut rng, nq, np, &zb, &ua, omega);
        let sc64 = ColumnScaling::<f64>::new(5e7, 1571.0, 5e-3).unwrap();
        let sc32 = ColumnScaling::<f32>::new(5e7, 1571.0, 5e-3).unwrap();
        let c32 = |v: &[C64]| {
            v.iter()
                .map(|z| Complex::new(z.re as f32, z.im as f32))
                .collect::<Vec<_>>()
        };
        let st = Structure::physical(order);
        let mm = st.n_unknowns(nb, np);
        let n = st.n_rows(nb);
        let (mut d64, mut u64) = (vec![0.0f64; n], vec![0.0f64; n * mm]);
        let (mut d32, mut u32) = (vec![0.0f32; n], vec![0.0f32; n * mm]);
        form_physical(order, &sc64, &pb.eq(), &mut d64, &mut u64).unwrap();
        let (a32, b32, q32) = (c32(&pb.a), c32(&pb.b), c32(&pb.q));
        let eq32 = Equations {
            omega: omega as f32,
            a: &a32,
            b: &b32,
            q: &q32,
            nq,
            np,
        };
        form_physical(order, &sc32, &eq32, &mut d32, &mut u32).unwrap();
        let umax = u64.iter().fold(0.0f64, |a, x| a.max(x.abs()));
        for (x, y) in u64.iter().zip(&u32) {
            assert!((x - *y as f64).abs() <= 1e-6 * umax);
        }
    }

    #[test]
    fn bad_input_is_rejected_and_outputs_untouched() {
        let sc = ColumnScaling::<f64>::identity();
        let z = C64::new(0.0, 0.0);
        let a = vec![C64::new(1.0, 0.0); 4];
        let b = vec![C64::new(1.0, 0.0); 2];
        let mut q = vec![C64::new(1.0, 0.0); 2];
        let mm = Structure::paper(1).n_unknowns(1, 1);
        let mut d = vec![z; 2];
        let mut u = vec![z; 2 * mm];
        assert_eq!(
            form_paper(
                0,
                &sc,
                &Equations {
                    omega: 1.0,
                    a: &a,
                    b: &b,
                    q: &q,
                    nq: 2,
                    np: 1
                },
                &mut d,
                &mut u
            ),
            Err(RegressorError::InvalidOrder)
        );
        assert_eq!(
            form_paper(
                1,
                &sc,
                &Equations {
                    omega: 1.0,
                    a: &a,
                    b: &b,
                    q: &q,
                    nq: 2,
                    np: 1
                },
                &mut d[..1],
                &mut u
            ),
            Err(RegressorError::Dimension)
        );
        assert_eq!(
            form_paper(
                1,
                &sc,
                &Equations {
                    omega: 1.0,
                    a: &a,
                    b: &b[..1],
                    q: &q,
                    nq: 2,
                    np: 1
                },
                &mut d,
                &mut u
            ),
            Err(RegressorError::Dimension)
        );
        q[1].im = f64::NAN;
        assert_eq!(
            form_paper(
                1,
                &sc,
                &Equations {
                    omega: 1.0,
                    a: &a,
                    b: &b,
                    q: &q,
                    nq: 2,
                    np: 1
                },
                &mut d,
                &mut u
            ),
            Err(RegressorError::NonFinite)
        );
        assert!(d.iter().chain(&u).all(|x| *x == z));
        let mut dr = vec![0.0; 4];
        let mut ur = vec![0.0; 4 * Structure::physical(1).n_unknowns(1, 1)];
        assert_eq!(
            form_physical(
                1,
                &sc,
                &Equations {
                    omega: f64::INFINITY,
                    a: &a,
                    b: &b,
                    q: &q,
                    nq: 2,
                    np: 1
                },
                &mut dr,
                &mut ur
            ),
            Err(RegressorError::NonFinite)
        );
        assert!(ColumnScaling::<f32>::new(1e60, 1.0, 1.0).is_err());
        assert!(ColumnScaling::<f64>::new(-1.0, 1.0, 1.0).is_err());
    }

    #[test]
    fn row_normalisation_keeps_exact_solutions() {
        let mut u: Vec<f64> = vec![3.0, 4.0, 0.0, 0.0, 1e-30, 0.0];
        let mut d: Vec<f64> = vec![10.0, 0.0, 2e-30];
        normalise_rows(&mut u, &mut d, 3, 2).unwrap();
        assert!((u[0] - 0.6).abs() < 1e-15 && (d[0] - 2.0).abs() < 1e-15);
        assert_eq!((u[2], u[3], d[1]), (0.0, 0.0, 0.0));
        assert!((u[4] - 1.0).abs() < 1e-15 && (d[2] - 2.0).abs() < 1e-15);
    }
}
