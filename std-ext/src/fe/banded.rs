//! Complex band matrices and their LU factorisation with partial pivoting.
//!
//! A beam model couples each node only to its neighbours: with the DOF
//! numbering `dof(node, dir) = 4 node + dir` of [`crate::fe::assembly`], every
//! non-zero of the dynamic stiffness `Z(Omega)` lies within 7 places of the
//! diagonal (`kl = ku = 7`). Solving `Z q = f` in band storage costs
//! `O(n kl (kl + ku))` instead of the `O(n^3)` of a dense LU.
//!
//! Storage follows LAPACK's `zgbtrf`/`zgbtrs`: column-major, leading
//! dimension `ldab = 2 kl + ku + 1`, entry `(i, j)` of the matrix at row
//! `kl + ku + i - j` of column `j`. The first `kl` rows of the storage are
//! kept free for the fill-in that row interchanges create in `U` (whose band
//! grows to `kl + ku` super-diagonals).

use nalgebra::DMatrix;
use num_complex::Complex64;
use thiserror::Error;

/// Errors of the band solver.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum BandedError {
    /// An index or a right-hand side does not fit the matrix.
    #[error("dimension mismatch: {0}")]
    Dimension(String),
    /// An entry outside the band was written.
    #[error("entry ({row}, {col}) lies outside the band (kl = {kl}, ku = {ku})")]
    OutsideBand {
        /// Row index.
        row: usize,
        /// Column index.
        col: usize,
        /// Sub-diagonals.
        kl: usize,
        /// Super-diagonals.
        ku: usize,
    },
    /// A zero pivot: the matrix is singular (to working precision).
    #[error("matrix is singular: zero pivot in column {0}")]
    Singular(usize),
    /// A NaN or infinity in the matrix or the right-hand side.
    #[error("non-finite value in the matrix or right-hand side")]
    NonFinite,
}

/// A square complex band matrix with `kl` sub- and `ku` super-diagonals.
#[derive(Debug, Clone, PartialEq)]
pub struct BandedMatrix {
    n: usize,
    kl: usize,
    ku: usize,
    /// Column-major band storage, `ldab = 2 kl + ku + 1` rows per column.
    ab: Vec<Complex64>,
}

impl BandedMatrix {
    /// The `n x n` zero matrix with `kl` sub- and `ku` super-diagonals.
    pub fn zeros(n: usize, kl: usize, ku: usize) -> Self {
        let ldab = 2 * kl + ku + 1;
        BandedMatrix {
            n,
            kl,
            ku,
            ab: vec![Complex64::new(0.0, 0.0); ldab * n],
        }
    }

    /// A matrix from LAPACK band storage (`ab.len() = (2 kl + ku + 1) n`,
    /// entry `(i, j)` at `ab[kl + ku + i - j + j (2 kl + ku + 1)]`, the first
    /// `kl` rows of each column zero).
    pub fn from_storage(
        n: usize,
        kl: usize,
        ku: usize,
        ab: Vec<Complex64>,
    ) -> Result<Self, BandedError> {
        if ab.len() != (2 * kl + ku + 1) * n {
            return Err(BandedError::Dimension(format!(
                "band storage of length {} for n = {n}, kl = {kl}, ku = {ku}",
                ab.len()
            )));
        }
        Ok(BandedMatrix { n, kl, ku, ab })
    }

    /// Storage index of entry `(i, j)` (which must lie in the band) in the
    /// layout of [`BandedMatrix::from_storage`].
    pub fn storage_index(kl: usize, ku: usize, i: usize, j: usize) -> usize {
        (kl + ku + i - j) + j * (2 * kl + ku + 1)
    }

    /// Order of the matrix.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Number of sub-diagonals.
    pub fn kl(&self) -> usize {
        self.kl
    }

    /// Number of super-diagonals.
    pub fn ku(&self) -> usize {
        self.ku
    }

    fn ldab(&self) -> usize {
        2 * self.kl + self.ku + 1
    }

    /// Whether `(i, j)` lies in the band.
    pub fn in_band(&self, i: usize, j: usize) -> bool {
        i < self.n && j < self.n && i + self.ku >= j && j + self.kl >= i
    }

    #[inline]
    fn idx(&self, i: usize, j: usize) -> usize {
        // row kl + ku + i - j of column j
        (self.kl + self.ku + i - j) + j * self.ldab()
    }

    /// Entry `(i, j)`; zero outside the band and outside the matrix.
    pub fn get(&self, i: usize, j: usize) -> Complex64 {
        if self.in_band(i, j) {
            self.ab[self.idx(i, j)]
        } else {
            Complex64::new(0.0, 0.0)
        }
    }

    /// Sets entry `(i, j)`, which must lie in the band.
    pub fn set(&mut self, i: usize, j: usize, v: Complex64) -> Result<(), BandedError> {
        if !self.in_band(i, j) {
            return Err(self.outside(i, j));
        }
        let k = self.idx(i, j);
        self.ab[k] = v;
        Ok(())
    }

    /// Adds `v` to entry `(i, j)`, which must lie in the band.
    pub fn add(&mut self, i: usize, j: usize, v: Complex64) -> Result<(), BandedError> {
        if !self.in_band(i, j) {
            return Err(self.outside(i, j));
        }
        let k = self.idx(i, j);
        self.ab[k] += v;
        Ok(())
    }

    fn outside(&self, i: usize, j: usize) -> BandedError {
        BandedError::OutsideBand {
            row: i,
            col: j,
            kl: self.kl,
            ku: self.ku,
        }
    }

    /// The dense matrix.
    pub fn to_dense(&self) -> DMatrix<Complex64> {
        let mut d = DMatrix::zeros(self.n, self.n);
        for j in 0..self.n {
            let i0 = j.saturating_sub(self.ku);
            let i1 = (j + self.kl).min(self.n.saturating_sub(1));
            for i in i0..=i1 {
                d[(i, j)] = self.ab[self.idx(i, j)];
            }
        }
        d
    }

    /// The band part of a dense matrix (entries outside the band are
    /// ignored).
    pub fn from_dense(d: &DMatrix<Complex64>, kl: usize, ku: usize) -> Result<Self, BandedError> {
        if d.nrows() != d.ncols() {
            return Err(BandedError::Dimension(format!(
                "matrix is {} x {}, not square",
                d.nrows(),
                d.ncols()
            )));
        }
        let n = d.nrows();
        let mut b = BandedMatrix::zeros(n, kl, ku);
        for j in 0..n {
            let i0 = j.saturating_sub(ku);
            let i1 = (j + kl).min(n.saturating_sub(1));
            for i in i0..=i1 {
                let k = b.idx(i, j);
                b.ab[k] = d[(i, j)];
            }
        }
        Ok(b)
    }

    /// Matrix-vector product `y = A x`.
    pub fn mul_vec(&self, x: &[Complex64]) -> Result<Vec<Complex64>, BandedError> {
        if x.len() != self.n {
            return Err(BandedError::Dimension(format!(
                "vector of length {} for a matrix of order {}",
                x.len(),
                self.n
            )));
        }
        let mut y = vec![Complex64::new(0.0, 0.0); self.n];
        for (j, xj) in x.iter().enumerate() {
            let i0 = j.saturating_sub(self.ku);
            let i1 = (j + self.kl).min(self.n - 1);
            for (i, yi) in y.iter_mut().enumerate().take(i1 + 1).skip(i0) {
                *yi += self.ab[self.idx(i, j)] * xj;
            }
        }
        Ok(y)
    }

    /// The matrix with the rows and columns `dofs` removed (any order,
    /// duplicates ignored). Removing rows and columns together never widens
    /// the band, so the result keeps `kl`, `ku`.
    pub fn remove(&self, dofs: &[usize]) -> Result<BandedMatrix, BandedError> {
        let mut drop = vec![false; self.n];
        for &d in dofs {
            if d >= self.n {
                return Err(BandedError::Dimension(format!(
                    "index {d} out of range for order {}",
                    self.n
                )));
            }
            drop[d] = true;
        }
        // New index of every kept old index.
        let mut new_index = vec![usize::MAX; self.n];
        let mut kept = 0;
        for (i, d) in drop.iter().enumerate() {
            if !d {
                new_index[i] = kept;
                kept += 1;
            }
        }
        let mut out = BandedMatrix::zeros(kept, self.kl, self.ku);
        for j in 0..self.n {
            let jn = new_index[j];
            if jn == usize::MAX {
                continue;
            }
            let i0 = j.saturating_sub(self.ku);
            let i1 = (j + self.kl).min(self.n - 1);
            for (i, &in_) in new_index.iter().enumerate().take(i1 + 1).skip(i0) {
                if in_ != usize::MAX {
                    // |in_ - jn| <= |i - j|, so (in_, jn) is in the new band.
                    let k = out.idx(in_, jn);
                    out.ab[k] = self.ab[self.idx(i, j)];
                }
            }
        }
        Ok(out)
    }

    /// The dense block with the given rows and columns.
    pub fn submatrix(
        &self,
        rows: &[usize],
        cols: &[usize],
    ) -> Result<DMatrix<Complex64>, BandedError> {
        if let Some(&bad) = rows.iter().chain(cols).find(|&&i| i >= self.n) {
            return Err(BandedError::Dimension(format!(
                "index {bad} out of range for order {}",
                self.n
            )));
        }
        Ok(DMatrix::from_fn(rows.len(), cols.len(), |r, c| {
            self.get(rows[r], cols[c])
        }))
    }

    /// LU factorisation with partial pivoting (a copy; `self` is kept).
    pub fn lu(&self) -> Result<BandedLu, BandedError> {
        self.clone().into_lu()
    }

    /// LU factorisation with partial pivoting, in place (LAPACK `zgbtf2`):
    /// `P A = L U`, `L` unit lower with `kl` sub-diagonals (stored as
    /// multipliers), `U` upper with `kl + ku` super-diagonals.
    pub fn into_lu(mut self) -> Result<BandedLu, BandedError> {
        if self
            .ab
            .iter()
            .any(|z| !(z.re.is_finite() && z.im.is_finite()))
        {
            return Err(BandedError::NonFinite);
        }
        let n = self.n;
        let (kl, ku) = (self.kl, self.ku);
        let kv = kl + ku;
        let ldab = self.ldab();
        let mut ipiv = vec![0usize; n];
        // Last column touched by the interchanges and updates so far.
        let mut ju = 0usize;
        let ab = &mut self.ab;
        for j in 0..n {
            let km = kl.min(n - 1 - j);
            // Pivot search in column j, rows j..=j+km (storage rows kv..=kv+km),
            // by the squared magnitude |a|^2 = re^2 + im^2: the same order as
            // |a|, so the same pivots up to rounding ties, without the `hypot`
            // of `norm()`, which took most of the factorisation time. Squares
            // that overflow (|a| > 1e154) compare as infinite (the first is
            // taken, a valid pivot); if all squares underflow to 0 the search
            // is repeated with |a|. (LAPACK's |re| + |im| changes the pivots
            // enough to move the reduced terms beyond round-off at the lowest
            // speeds, see `tests/tables/reduction.rs`.)
            let col = j * ldab;
            let mut jp = 0usize;
            let mut best = -1.0f64;
            for p in 0..=km {
                let a = ab[col + kv + p].norm_sqr();
                if a > best {
                    best = a;
                    jp = p;
                }
            }
            if best == 0.0 {
                for p in 0..=km {
                    let a = ab[col + kv + p].norm();
                    if a > best {
                        best = a;
                        jp = p;
                    }
                }
            }
            ipiv[j] = j + jp;
            if best == 0.0 {
                return Err(BandedError::Singular(j));
            }
            ju = ju.max((j + ku + jp).min(n - 1));
            if jp != 0 {
                // Swap rows j and j + jp over columns j..=ju.
                for c in j..=ju {
                    let a = kv + j - c + c * ldab;
                    let b = kv + j + jp - c + c * ldab;
                    ab.swap(a, b);
                }
            }
            if km > 0 {
                let inv = Complex64::new(1.0, 0.0) / ab[col + kv];
                for p in 1..=km {
                    ab[col + kv + p] *= inv;
                }
                // Rank-one update of the trailing block, columns j+1..=ju.
                for c in (j + 1)..=ju {
                    let u = ab[kv + j - c + c * ldab];
                    if u.re == 0.0 && u.im == 0.0 {
                        continue;
                    }
                    for p in 1..=km {
                        let l = ab[col + kv + p];
                        ab[kv + j + p - c + c * ldab] -= l * u;
                    }
                }
            }
        }
        Ok(BandedLu { a: self, ipiv })
    }

    /// Solves `A x = b` in place (`rhs` = b on entry, x on exit).
    pub fn solve(&self, rhs: &mut [Complex64]) -> Result<(), BandedError> {
        self.lu()?.solve(rhs)
    }

    /// Solves `A X = B` for several right-hand sides (the columns of `rhs`)
    /// with one factorisation.
    pub fn solve_many(&self, rhs: &mut DMatrix<Complex64>) -> Result<(), BandedError> {
        self.lu()?.solve_many(rhs)
    }
}

/// The LU factors of a [`BandedMatrix`], for repeated solves.
#[derive(Debug, Clone)]
pub struct BandedLu {
    a: BandedMatrix,
    ipiv: Vec<usize>,
}

impl BandedLu {
    /// Order of the factored matrix.
    pub fn n(&self) -> usize {
        self.a.n
    }

    /// Determinant of the factored matrix: `det P^T prod U_ii`.
    pub fn determinant(&self) -> Complex64 {
        let kv = self.a.kl + self.a.ku;
        let ldab = self.a.ldab();
        let mut d = Complex64::new(1.0, 0.0);
        for j in 0..self.a.n {
            d *= self.a.ab[kv + j * ldab];
            if self.ipiv[j] != j {
                d = -d;
            }
        }
        d
    }

    /// Solves `A x = b` in place (LAPACK `zgbtrs`, no transpose).
    pub fn solve(&self, b: &mut [Complex64]) -> Result<(), BandedError> {
        let n = self.a.n;
        if b.len() != n {
            return Err(BandedError::Dimension(format!(
                "right-hand side of length {} for a matrix of order {n}",
                b.len()
            )));
        }
        if b.iter().any(|z| !(z.re.is_finite() && z.im.is_finite())) {
            return Err(BandedError::NonFinite);
        }
        let kl = self.a.kl;
        let kv = kl + self.a.ku;
        let ldab = self.a.ldab();
        let ab = &self.a.ab;
        // Forward substitution with L and the row interchanges.
        for j in 0..n.saturating_sub(1) {
            let lm = kl.min(n - 1 - j);
            let l = self.ipiv[j];
            if l != j {
                b.swap(l, j);
            }
            let bj = b[j];
            if bj.re == 0.0 && bj.im == 0.0 {
                continue;
            }
            let col = j * ldab;
            for p in 1..=lm {
                b[j + p] -= ab[col + kv + p] * bj;
            }
        }
        // Back substitution with U (kv super-diagonals).
        for j in (0..n).rev() {
            let col = j * ldab;
            b[j] /= ab[col + kv];
            let t = b[j];
            let i0 = j.saturating_sub(kv);
            for i in i0..j {
                b[i] -= ab[col + kv + i - j] * t;
            }
        }
        Ok(())
    }

    /// Solves for every column of `rhs` in place.
    pub fn solve_many(&self, rhs: &mut DMatrix<Complex64>) -> Result<(), BandedError> {
        if rhs.nrows() != self.a.n {
            return Err(BandedError::Dimension(format!(
                "right-hand sides with {} rows for a matrix of order {}",
                rhs.nrows(),
                self.a.n
            )));
        }
        for mut col in rhs.column_iter_mut() {
            let s = col.as_mut_slice();
            self.solve(s)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn c(re: f64, im: f64) -> Complex64 {
        Complex64::new(re, im)
    }

    /// A deterministic pseudo-random band matrix (weak diagonal, so that
    /// pivoting is exercised).
    fn sample(n: usize, kl: usize, ku: usize) -> BandedMatrix {
        let mut a = BandedMatrix::zeros(n, kl, ku);
        let mut rng = ChaCha8Rng::seed_from_u64(12345);
        let mut rnd = || rng.random_range(-0.5..0.5);
        for j in 0..n {
            for i in j.saturating_sub(ku)..=(j + kl).min(n - 1) {
                let scale = if i == j { 0.01 } else { 1.0 };
                a.set(i, j, c(scale * rnd(), scale * rnd())).unwrap();
            }
        }
        a
    }

    #[test]
    fn solve_matches_dense_lu() {
        for &(n, kl, ku) in &[(1, 0, 0), (5, 1, 2), (30, 7, 7), (40, 3, 5), (12, 11, 11)] {
            let a = sample(n, kl, ku);
            let x: Vec<Complex64> = (0..n)
                .map(|i| c(i as f64 + 1.0, -(i as f64) * 0.5))
                .collect();
            let mut b = a.mul_vec(&x).unwrap();
            a.solve(&mut b).unwrap();
            let err: f64 = b
                .iter()
                .zip(&x)
                .map(|(u, v)| (u - v).norm())
                .fold(0.0, f64::max);
            let xn = x.iter().map(|v| v.norm()).fold(0.0, f64::max);
            assert!(err < 1e-10 * xn, "n={n} kl={kl} ku={ku} err={err}");
            // Dense product agrees with the band product.
            let d = a.to_dense();
            let xd = nalgebra::DVector::from_vec(x.clone());
            let yd = &d * &xd;
            let yb = a.mul_vec(&x).unwrap();
            for i in 0..n {
                assert!((yd[i] - yb[i]).norm() < 1e-12 * (1.0 + yd[i].norm()));
            }
            // Determinant agrees with the dense one.
            let det_b = a.lu().unwrap().determinant();
            let det_d = d.clone().lu().determinant();
            assert!(
                (det_b - det_d).norm() <= 1e-10 * det_d.norm().max(1e-300),
                "{det_b} {det_d}"
            );
        }
    }

    #[test]
    fn solve_many_and_remove() {
        let a = sample(20, 7, 7);
        let mut rhs = DMatrix::from_fn(20, 3, |i, j| c(i as f64 - j as f64, (i * j) as f64));
        let orig = rhs.clone();
        a.solve_many(&mut rhs).unwrap();
        let back = a.to_dense() * &rhs;
        assert!((back - orig).norm() < 1e-9);

        let r = a.remove(&[0, 5, 19]).unwrap();
        assert_eq!(r.n(), 17);
        let d = a.to_dense();
        let keep: Vec<usize> = (0..20).filter(|i| ![0, 5, 19].contains(i)).collect();
        let sub = a.submatrix(&keep, &keep).unwrap();
        assert_eq!(r.to_dense(), sub);
        assert_eq!(sub[(0, 1)], d[(1, 2)]);
    }

    #[test]
    fn errors_are_typed() {
        let mut a = BandedMatrix::zeros(4, 1, 1);
        assert!(matches!(
            a.set(0, 3, c(1.0, 0.0)),
            Err(BandedError::OutsideBand { .. })
        ));
        assert_eq!(a.get(0, 3), c(0.0, 0.0));
        let mut b = vec![c(1.0, 0.0); 4];
        assert!(matches!(a.solve(&mut b), Err(BandedError::Singular(0))));
        let mut short = vec![c(1.0, 0.0); 3];
        for i in 0..4 {
            a.set(i, i, c(1.0, 0.0)).unwrap();
        }
        assert!(matches!(
            a.solve(&mut short),
            Err(BandedError::Dimension(_))
        ));
        a.set(1, 1, c(f64::NAN, 0.0)).unwrap();
        assert!(matches!(a.solve(&mut b), Err(BandedError::NonFinite)));
    }
}
