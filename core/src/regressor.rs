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
//! * [`Formulation::Paper`], order `P` (`P = 1` is Eqs. 43, 47, 48):
//!   `Z_B^(m)(Omega) = sum_{p=0..P} Omega^p Z_p^(m)` with complex 2x2 `Z_p`.
//!   Complex unknowns, `M = 4 (P+1) N_b + N_p`, `N = 2 N_b` complex rows.
//!   Column of `Z_p[r][c]` in row `(m, r)`: `-Omega^p q_(m,c)`.
//!   Unknown index (bearing `m`, row direction `r`, power `p`, column `c`):
//!   `j = 4 (P+1) m + 2 (P+1) r + 2 p + c`, i.e. per bearing
//!   `(Z0yy Z0yz Z1yy Z1yz Z0zy Z0zz Z1zy Z1zz)` for `P = 1` (Eq. 48);
//!   then the planes `j = 4 (P+1) N_b + k`.
//! * [`Formulation::Physical`], order `P`: real
//!   `K(Omega) = sum_{p<P} K_p Omega^p`, `C(Omega) = sum_{p<P} C_p Omega^p`,
//!   so `Z_B = K + j Omega C` is a polynomial of degree `P` in `Omega`
//!   (`P = 1`: constant K and C). Real unknowns: `8 P` per bearing and
//!   `(Re a_k, Im a_k)` per plane, `M = 8 P N_b + 2 N_p`. Each complex
//!   equation is split into its real and imaginary rows (`N = 4 N_b`, row
//!   `2 i` = Re, `2 i + 1` = Im of complex row `i`). Columns in row `(m, r)`:
//!   `K_p[r][c] -> -Omega^p q_(m,c)`, `C_p[r][c] -> -j Omega^(p+1) q_(m,c)`,
//!   `Re a_k -> B_ik`, `Im a_k -> j B_ik` (then split). Unknown index
//!   (bearing `m`, direction `r`, power `p`, kind `K = 0 / C = 1`, column
//!   `c`): `j = 8 P m + 4 P r + 4 p + 2 kind + c`, i.e. per bearing
//!   `(Kyy Kyz Cyy Cyz Kzy Kzz Czy Czz)` for `P = 1`; then
//!   `j = 8 P N_b + 2 k (+1)` for `Re a_k` (`Im a_k`).
//!
//! Stiffness proportional to `Omega^2` (the paper's Eq. 49) needs physical
//! order 3 or paper order 2.
//!
//! All columns are formed already scaled by [`ColumnScaling`] (`U S`, see
//! [`crate::scaling`]); [`ColumnScaling::identity`] gives the raw SI form.
//! The functions work on slices (row-major, caller buffers) so that firmware
//! uses fixed arrays and the desktop uses `Vec`s of runtime size.

use crate::scalar::Real;
use crate::scaling::ColumnScaling;
use num_complex::Complex;

/// Which unknowns describe the bearings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Formulation {
    /// Complex `Z_p` per bearing (the paper's Eqs. 43, 47, 48 for order 1).
    Paper,
    /// Real polynomial `K(Omega)`, `C(Omega)` per bearing, complex unbalance
    /// as two reals; each complex equation split into two real rows.
    Physical,
}

/// A model structure: formulation and polynomial order `P` of the bearing
/// dynamic stiffness in `Omega` (`Z_B` of degree `P`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Structure {
    /// The formulation.
    pub formulation: Formulation,
    /// The order `P >= 1`.
    pub order: usize,
}

/// Highest supported order (keeps `(Omega/Omega_r)^P` meaningful in f32).
pub const MAX_ORDER: usize = 8;

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

impl Structure {
    /// The paper's complex formulation of order `order`.
    pub const fn paper(order: usize) -> Self {
        Structure {
            formulation: Formulation::Paper,
            order,
        }
    }

    /// The physical (real K, C) formulation of order `order`.
    pub const fn physical(order: usize) -> Self {
        Structure {
            formulation: Formulation::Physical,
            order,
        }
    }

    /// Checks the order.
    pub const fn validate(&self) -> Result<(), RegressorError> {
        if self.order >= 1 && self.order <= MAX_ORDER {
            Ok(())
        } else {
            Err(RegressorError::InvalidOrder)
        }
    }

    /// Whether the unknowns and rows are complex (`Paper`) or real.
    pub const fn is_complex(&self) -> bool {
        matches!(self.formulation, Formulation::Paper)
    }

    /// Unknowns per bearing: `4 (P+1)` (paper) or `8 P` (physical).
    pub const fn per_bearing(&self) -> usize {
        match self.formulation {
            Formulation::Paper => 4 * (self.order + 1),
            Formulation::Physical => 8 * self.order,
        }
    }

    /// Unknowns per plane: 1 complex (paper) or 2 real (physical).
    pub const fn per_plane(&self) -> usize {
        match self.formulation {
            Formulation::Paper => 1,
            Formulation::Physical => 2,
        }
    }

    /// Number of unknowns `M` for `nb` bearings and `np` planes.
    pub const fn n_unknowns(&self, nb: usize, np: usize) -> usize {
        self.per_bearing() * nb + self.per_plane() * np
    }

    /// Number of rows `N` per update for `nb` bearings: `2 N_b` complex
    /// (paper) or `4 N_b` real (physical).
    pub const fn n_rows(&self, nb: usize) -> usize {
        match self.formulation {
            Formulation::Paper => 2 * nb,
            Formulation::Physical => 4 * nb,
        }
    }

    /// Index of the paper unknown `Z_p[r][c]` of bearing `m`.
    pub const fn paper_index(&self, m: usize, r: usize, p: usize, c: usize) -> usize {
        let p1 = self.order + 1;
        4 * p1 * m + 2 * p1 * r + 2 * p + c
    }

    /// Index of the physical unknown `K_p[r][c]` (`kind = 0`) or `C_p[r][c]`
    /// (`kind = 1`) of bearing `m`.
    pub const fn physical_index(
        &self,
        m: usize,
        r: usize,
        p: usize,
        kind: usize,
        c: usize,
    ) -> usize {
        8 * self.order * m + 4 * self.order * r + 4 * p + 2 * kind + c
    }

    /// Index of the (first) unknown of plane `k` for `nb` bearings.
    pub const fn plane_index(&self, nb: usize, k: usize) -> usize {
        self.per_bearing() * nb + self.per_plane() * k
    }

    /// The column scale `s_j` of unknown `j` (the physical unknown is
    /// `w_j = s_j w~_j`), see [`crate::scaling`]. `None` if `j >= M`.
    pub fn column_scale<T: Real>(
        &self,
        scaling: &ColumnScaling<T>,
        nb: usize,
        np: usize,
        j: usize,
    ) -> Option<T> {
        let nbear = self.per_bearing() * nb;
        if j >= self.n_unknowns(nb, np) {
            return None;
        }
        if j >= nbear {
            return Some(scaling.unbalance);
        }
        let within = j % self.per_bearing();
        Some(match self.formulation {
            Formulation::Paper => {
                let p = (within % (2 * (self.order + 1))) / 2;
                scaling.power_scale(p)
            }
            Formulation::Physical => {
                let rem = within % (4 * self.order);
                let p = rem / 4;
                let kind = (rem % 4) / 2;
                scaling.power_scale(p + kind)
            }
        })
    }
}

/// Checks the lengths common to both formulations.
fn check_terms<T>(
    nq: usize,
    np: usize,
    a: &[Complex<T>],
    b: &[Complex<T>],
    q: &[Complex<T>],
) -> Result<usize, RegressorError> {
    if nq == 0 || nq % 2 != 0 || a.len() != nq * nq || b.len() != nq * np || q.len() != nq {
        return Err(RegressorError::Dimension);
    }
    Ok(nq / 2)
}

fn all_finite<T: Real>(omega: T, a: &[Complex<T>], b: &[Complex<T>], q: &[Complex<T>]) -> bool {
    let f = |z: &Complex<T>| z.re.is_finite() && z.im.is_finite();
    omega.is_finite() && a.iter().all(f) && b.iter().all(f) && q.iter().all(f)
}

/// `d = A q` (complex, length `nq`), `A` row-major `nq x nq`.
fn a_times_q<T: Real>(nq: usize, a: &[Complex<T>], q: &[Complex<T>], i: usize) -> Complex<T> {
    let mut s = Complex::new(T::zero(), T::zero());
    for (aij, qj) in a[i * nq..(i + 1) * nq].iter().zip(q) {
        s += *aij * *qj;
    }
    s
}

/// Forms the complex regression of the `paper` structure of order `P`,
/// scaled: `d = A q` (length `N = nq`) and `U S` (row-major `N x M`).
///
/// `a`: `A(Omega)` row-major `nq x nq`; `b`: `B(Omega)` row-major
/// `nq x np`; `q`: measured phasors (m), `nq = 2 N_b`. Errors: order,
/// buffer lengths, non-finite input (outputs untouched then).
#[allow(clippy::too_many_arguments)]
pub fn form_paper<T: Real>(
    order: usize,
    scaling: &ColumnScaling<T>,
    omega: T,
    a: &[Complex<T>],
    b: &[Complex<T>],
    q: &[Complex<T>],
    nq: usize,
    np: usize,
    d: &mut [Complex<T>],
    u: &mut [Complex<T>],
) -> Result<(), RegressorError> {
    let s = Structure::paper(order);
    s.validate()?;
    let nb = check_terms(nq, np, a, b, q)?;
    let m_cols = s.n_unknowns(nb, np);
    if d.len() != nq || u.len() != nq * m_cols {
        return Err(RegressorError::Dimension);
    }
    if !all_finite(omega, a, b, q) {
        return Err(RegressorError::NonFinite);
    }
    let zero = Complex::new(T::zero(), T::zero());
    u.fill(zero);
    for i in 0..nq {
        d[i] = a_times_q(nq, a, q, i);
        let (m, r) = (i / 2, i % 2);
        let row = &mut u[i * m_cols..(i + 1) * m_cols];
        for p in 0..=order {
            let f = -(scaling.speed_power(omega, p) * scaling.stiffness);
            for c in 0..2 {
                row[s.paper_index(m, r, p, c)] = q[2 * m + c] * f;
            }
        }
        for k in 0..np {
            row[s.plane_index(nb, k)] = b[i * np + k] * scaling.unbalance;
        }
    }
    Ok(())
}

/// Forms the real regression of the `physical` structure of order `P`,
/// scaled: `d` (length `N = 2 nq`: Re and Im of `A q`, interleaved) and
/// `U S` (row-major `N x M`). Arguments as in [`form_paper`].
#[allow(clippy::too_many_arguments)]
pub fn form_physical<T: Real>(
    order: usize,
    scaling: &ColumnScaling<T>,
    omega: T,
    a: &[Complex<T>],
    b: &[Complex<T>],
    q: &[Complex<T>],
    nq: usize,
    np: usize,
    d: &mut [T],
    u: &mut [T],
) -> Result<(), RegressorError> {
    let s = Structure::physical(order);
    s.validate()?;
    let nb = check_terms(nq, np, a, b, q)?;
    let m_cols = s.n_unknowns(nb, np);
    let n_rows = 2 * nq;
    if d.len() != n_rows || u.len() != n_rows * m_cols {
        return Err(RegressorError::Dimension);
    }
    if !all_finite(omega, a, b, q) {
        return Err(RegressorError::NonFinite);
    }
    u.fill(T::zero());
    for i in 0..nq {
        let di = a_times_q(nq, a, q, i);
        d[2 * i] = di.re;
        d[2 * i + 1] = di.im;
        let (m, r) = (i / 2, i % 2);
        // Complex coefficient g of a real unknown: Re row gets Re g, Im row Im g.
        let mut put = |j: usize, g: Complex<T>| {
            u[2 * i * m_cols + j] = g.re;
            u[(2 * i + 1) * m_cols + j] = g.im;
        };
        for p in 0..order {
            let fk = -(scaling.speed_power(omega, p) * scaling.stiffness);
            let fc = -(scaling.speed_power(omega, p + 1) * scaling.stiffness);
            for c in 0..2 {
                let qc = q[2 * m + c];
                // K_p: -Omega^p q ; C_p: -j Omega^(p+1) q.
                put(s.physical_index(m, r, p, 0, c), qc * fk);
                put(
                    s.physical_index(m, r, p, 1, c),
                    Complex::new(T::zero(), T::one()) * qc * fc,
                );
            }
        }
        for k in 0..np {
            let g = b[i * np + k] * scaling.unbalance;
            let j = s.plane_index(nb, k);
            // Re a -> g ; Im a -> j g.
            put(j, g);
            put(j + 1, Complex::new(-g.im, g.re));
        }
    }
    Ok(())
}

/// Identified parameters of one bearing at one speed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BearingEstimate<T> {
    /// Stiffness `[kyy, kyz, kzy, kzz]` (N/m).
    pub k: [T; 4],
    /// Damping `[cyy, cyz, czy, czz]` (N s/m).
    pub c: [T; 4],
    /// For the paper structure: `Im(Z_0)` (N/m), physically zero (the
    /// dynamic stiffness at rest is real); `None` for the physical one.
    pub im_z0: Option<[T; 4]>,
    /// For the paper structure: `Re(Z_1)` (N s/m), physically zero when the
    /// stiffness does not vary linearly with speed (exactly the consistency
    /// check of order 1); `None` for the physical one.
    pub re_z1: Option<[T; 4]>,
}

/// Identified unbalance of one plane.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UnbalanceEstimate<T> {
    /// `a = m e exp(j alpha)` (kg m).
    pub a: Complex<T>,
    /// `m e = |a|` (kg m).
    pub me: T,
    /// `alpha = arg a` (rad), in `(-pi, pi]`.
    pub phase: T,
}

impl<T: Real> UnbalanceEstimate<T> {
    /// From the complex unbalance.
    pub fn from_phasor(a: Complex<T>) -> Self {
        UnbalanceEstimate {
            a,
            me: a.re.hypot(a.im),
            phase: a.im.atan2(a.re),
        }
    }

    /// The phase in degrees.
    pub fn phase_deg(&self) -> T {
        self.phase * T::lit(180.0) / T::pi()
    }
}

/// Physical bearing parameters of bearing `m` from the **scaled** complex
/// weights `w~` of the paper structure, evaluated at `omega`.
///
/// `Z_B(Omega) = sum_p Omega^p Z_p`. Order 1: `K = Re Z_0`, `C = Im Z_1`
/// (speed-independent, the physically consistent part). Order >= 2:
/// `K(Omega) = Re Z_B(Omega)`, `C(Omega) = Im Z_B(Omega) / Omega`, with
/// `C(0) = Im Z_1` (the limit when `Im Z_0 = 0`).
pub fn paper_bearing<T: Real>(
    order: usize,
    scaling: &ColumnScaling<T>,
    w: &[Complex<T>],
    nb: usize,
    np: usize,
    m: usize,
    omega: T,
) -> Result<BearingEstimate<T>, RegressorError> {
    let s = Structure::paper(order);
    s.validate()?;
    if m >= nb || w.len() != s.n_unknowns(nb, np) {
        return Err(RegressorError::Dimension);
    }
    let z = |p: usize, e: usize| w[s.paper_index(m, e / 2, p, e % 2)] * scaling.power_scale(p);
    let mut out = BearingEstimate {
        k: [T::zero(); 4],
        c: [T::zero(); 4],
        im_z0: Some([T::zero(); 4]),
        re_z1: Some([T::zero(); 4]),
    };
    let mut im_z0 = [T::zero(); 4];
    let mut re_z1 = [T::zero(); 4];
    for e in 0..4 {
        im_z0[e] = z(0, e).im;
        re_z1[e] = z(1, e).re;
        if order == 1 {
            out.k[e] = z(0, e).re;
            out.c[e] = z(1, e).im;
        } else {
            let mut zb = Complex::new(T::zero(), T::zero());
            let mut pw = T::one();
            for p in 0..=order {
                zb += z(p, e) * pw;
                pw *= omega;
            }
            out.k[e] = zb.re;
            out.c[e] = if omega.abs() > T::zero() {
                zb.im / omega
            } else {
                z(1, e).im
            };
        }
    }
    out.im_z0 = Some(im_z0);
    out.re_z1 = Some(re_z1);
    Ok(out)
}

/// Physical bearing parameters of bearing `m` from the **scaled** real
/// weights `w~` of the physical structure: `K(Omega) = sum_p K_p Omega^p`,
/// `C(Omega) = sum_p C_p Omega^p`.
pub fn physical_bearing<T: Real>(
    order: usize,
    scaling: &ColumnScaling<T>,
    w: &[T],
    nb: usize,
    np: usize,
    m: usize,
    omega: T,
) -> Result<BearingEstimate<T>, RegressorError> {
    let s = Structure::physical(order);
    s.validate()?;
    if m >= nb || w.len() != s.n_unknowns(nb, np) {
        return Err(RegressorError::Dimension);
    }
    let mut out = BearingEstimate {
        k: [T::zero(); 4],
        c: [T::zero(); 4],
        im_z0: None,
        re_z1: None,
    };
    for e in 0..4 {
        let (r, c) = (e / 2, e % 2);
        let mut pw = T::one();
        for p in 0..order {
            out.k[e] += w[s.physical_index(m, r, p, 0, c)] * scaling.power_scale(p) * pw;
            out.c[e] += w[s.physical_index(m, r, p, 1, c)] * scaling.power_scale(p + 1) * pw;
            pw *= omega;
        }
    }
    Ok(out)
}

/// Unbalance of plane `k` from the scaled paper weights.
pub fn paper_unbalance<T: Real>(
    order: usize,
    scaling: &ColumnScaling<T>,
    w: &[Complex<T>],
    nb: usize,
    np: usize,
    k: usize,
) -> Result<UnbalanceEstimate<T>, RegressorError> {
    let s = Structure::paper(order);
    s.validate()?;
    if k >= np || w.len() != s.n_unknowns(nb, np) {
        return Err(RegressorError::Dimension);
    }
    Ok(UnbalanceEstimate::from_phasor(
        w[s.plane_index(nb, k)] * scaling.unbalance,
    ))
}

/// Unbalance of plane `k` from the scaled physical weights.
pub fn physical_unbalance<T: Real>(
    order: usize,
    scaling: &ColumnScaling<T>,
    w: &[T],
    nb: usize,
    np: usize,
    k: usize,
) -> Result<UnbalanceEstimate<T>, RegressorError> {
    let s = Structure::physical(order);
    s.validate()?;
    if k >= np || w.len() != s.n_unknowns(nb, np) {
        return Err(RegressorError::Dimension);
    }
    let j = s.plane_index(nb, k);
    Ok(UnbalanceEstimate::from_phasor(
        Complex::new(w[j], w[j + 1]) * scaling.unbalance,
    ))
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
    for i in 0..n {
        let row = &mut u[i * m..(i + 1) * m];
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
        d[i] = d[i].scale(inv);
    }
    Ok(())
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)]
mod tests {
    use super::*;
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
                                let j = st.paper_index(m, e / 2, p, e % 2);
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
                    form_paper(
                        order, &sc, pb.omega, &pb.a, &pb.b, &pb.q, pb.nq, pb.np, &mut d, &mut u,
                    )
                    .unwrap();
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
                    // Estimates recover Z_B(Omega) = K + j Omega C.
                    for m in 0..nb {
                        let be = paper_bearing(order, &sc, &w, nb, np, m, omega).unwrap();
                        for e in 0..4 {
                            let z = zb[(2 * m + e / 2, 2 * m + e % 2)];
                            if order == 1 {
                                let z0 = zp[m * 2][e];
                                let z1 = zp[m * 2 + 1][e];
                                assert!((be.k[e] - z0.re).abs() <= 1e-12 * z0.norm());
                                assert!((be.c[e] - z1.im).abs() <= 1e-12 * z1.norm());
                                assert!((be.im_z0.unwrap()[e] - z0.im).abs() <= 1e-12 * z0.norm());
                                assert!((be.re_z1.unwrap()[e] - z1.re).abs() <= 1e-12 * z1.norm());
                            } else {
                                assert!((be.k[e] - z.re).abs() <= 1e-12 * z.norm());
                                assert!((be.c[e] * omega - z.im).abs() <= 1e-12 * z.norm());
                            }
                        }
                    }
                    for k in 0..np {
                        let ue = paper_unbalance(order, &sc, &w, nb, np, k).unwrap();
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
                                let jk = st.physical_index(m, e / 2, p, 0, e % 2);
                                let jc = st.physical_index(m, e / 2, p, 1, e % 2);
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
                    form_physical(
                        order, &sc, pb.omega, &pb.a, &pb.b, &pb.q, pb.nq, pb.np, &mut d, &mut u,
                    )
                    .unwrap();
                    let dn: f64 = d.iter().map(|x| x * x).sum::<f64>().sqrt();
                    for i in 0..n {
                        let uw: f64 = (0..mm).map(|j| u[i * mm + j] * w[j]).sum();
                        assert!(
                            (d[i] - uw).abs() <= 1e-12 * dn,
                            "order {order} nb {nb} row {i}"
                        );
                    }
                    for m in 0..nb {
                        let be = physical_bearing(order, &sc, &w, nb, np, m, omega).unwrap();
                        for e in 0..4 {
                            assert!((be.k[e] - kt[m][e]).abs() <= 1e-12 * 1e7 * order as f64);
                            assert!((be.c[e] - ct[m][e]).abs() <= 1e-12 * 1e4 * order as f64);
                        }
                        assert!(be.im_z0.is_none());
                    }
                    for k in 0..np {
                        let ue = physical_unbalance(order, &sc, &w, nb, np, k).unwrap();
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
        form_paper(
            order, &sc, omega, &pb.a, &pb.b, &pb.q, nq, np, &mut d, &mut u,
        )
        .unwrap();
        // Flip the bearing columns' sign: residual must be of the order of d.
        let mut w = vec![C64::new(0.0, 0.0); mm];
        for m in 0..nb {
            for e in 0..4 {
                w[st.paper_index(m, e / 2, 0, e % 2)] = zb[(2 * m + e / 2, 2 * m + e % 2)];
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
        form_physical(
            order, &sc64, omega, &pb.a, &pb.b, &pb.q, nq, np, &mut d64, &mut u64,
        )
        .unwrap();
        form_physical(
            order,
            &sc32,
            omega as f32,
            &c32(&pb.a),
            &c32(&pb.b),
            &c32(&pb.q),
            nq,
            np,
            &mut d32,
            &mut u32,
        )
        .unwrap();
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
            form_paper(0, &sc, 1.0, &a, &b, &q, 2, 1, &mut d, &mut u),
            Err(RegressorError::InvalidOrder)
        );
        assert_eq!(
            form_paper(1, &sc, 1.0, &a, &b, &q, 2, 1, &mut d[..1], &mut u),
            Err(RegressorError::Dimension)
        );
        assert_eq!(
            form_paper(1, &sc, 1.0, &a, &b[..1], &q, 2, 1, &mut d, &mut u),
            Err(RegressorError::Dimension)
        );
        q[1].im = f64::NAN;
        assert_eq!(
            form_paper(1, &sc, 1.0, &a, &b, &q, 2, 1, &mut d, &mut u),
            Err(RegressorError::NonFinite)
        );
        assert!(d.iter().chain(&u).all(|x| *x == z));
        let mut dr = vec![0.0; 4];
        let mut ur = vec![0.0; 4 * Structure::physical(1).n_unknowns(1, 1)];
        assert_eq!(
            form_physical(1, &sc, f64::INFINITY, &a, &b, &q, 2, 1, &mut dr, &mut ur),
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
