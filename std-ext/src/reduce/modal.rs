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
//! # Whirl split
//!
//! For an axisymmetric interior the quarter turn about the shaft axis,
//! `J: (y, z, phi_y, phi_z) -> (-z, y, -phi_z, phi_y)` per node, commutes
//! with `K_ii` and `H_ii` (every 2 x 2 block of a pair of node pairs has the
//! form `[[a, b], [-b, a]]`, checked to `1e-13` of the largest entry, not
//! assumed). `J^2 = -I`; in the unitary basis of its eigenvectors
//! `(e_p0 -+ j e_p1) / sqrt(2)` (forward and backward whirl) both matrices
//! are block diagonal, so the Cholesky, the triangular solves and the
//! eigendecomposition run on two halves of size `n_i / 2`: a quarter of the
//! work. Anything that breaks the symmetry (a point mass with `mx != my` on
//! the shaft) keeps the whole problem.
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

use nalgebra::{Cholesky, DMatrix, SymmetricEigen};
use num_complex::Complex64;

use super::{dense_k_h, ProbeTerms, ReducedTerms, Reducer, ReductionError, Statics};

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
    /// (`2 n_left (2 N_b + N_p)` rows).
    residues: DMatrix<f64>,
    /// Rows of the left factor: the `2 N_b` rows of `V_L`, then one row
    /// `e_i^T` per probe DOF ([`Reducer::modal_probes`]).
    n_left: usize,
    /// Per probe DOF: `Ok(interior index)` or `Err(bearing channel)`.
    probes: Vec<Result<usize, usize>>,
    /// Per probe DOF, its row of `X_0` (zero for a bearing DOF)
    /// (`n_probe x 2 N_b`).
    x0_rows: DMatrix<Complex64>,
    /// Whether the interior was split into its whirl halves.
    split: bool,
}

/// Relative size below which the coupling of the two whirl subspaces is
/// round-off (an axisymmetric interior, [`whirl_pairs`]).
const ISOTROPY_TOL: f64 = 1e-13;

/// For an axisymmetric interior, the pairs `(y, z)` and `(phi_y, phi_z)` of
/// each node as interior positions `(p0, p0 + 1)`, if `K_ii` and `H_ii`
/// commute with the quarter turn about the shaft axis
/// `J: (y, z, phi_y, phi_z) -> (-z, y, -phi_z, phi_y)`; `None` otherwise.
///
/// `J^2 = -I`; its eigenspaces (`J b = +-j b`) are spanned by
/// `b_p = (e_p0 -+ j e_p1) / sqrt(2)`, one vector per pair. A matrix that
/// commutes with `J` maps each eigenspace into itself, so in the unitary
/// basis `[B_+, B_-]` the interior splits into two independent halves
/// (forward and backward whirl), each `n_i / 2` square: the Cholesky, the
/// triangular solves and the eigendecomposition cost a quarter of the
/// whole. Commuting with `J` means every 2 x 2 block `X[p, q]` of a pair of
/// pairs has the form `[[a, b], [-b, a]]`; that is checked to
/// [`ISOTROPY_TOL`] of the largest entry (a point mass with `mx != my`, or
/// anything else that breaks the symmetry, keeps the full problem).
fn whirl_pairs(
    interior: &[usize],
    k: &DMatrix<f64>,
    h: &DMatrix<Complex64>,
) -> Option<Vec<(usize, usize)>> {
    let n = interior.len();
    if n % 2 != 0 {
        return None;
    }
    let mut pairs = Vec::with_capacity(n / 2);
    for (p0, w) in interior.chunks_exact(2).enumerate() {
        let (g0, g1) = (*w.first()?, *w.get(1)?);
        // (y, z) or (phi_y, phi_z) of one node: global 4 node + {0, 1} or {2, 3}.
        if g0 % 2 != 0 || g1 != g0 + 1 {
            return None;
        }
        pairs.push((2 * p0, 2 * p0 + 1));
    }
    let kmax = k.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
    let hmax = h.iter().fold(0.0_f64, |m, x| m.max(x.norm()));
    for &(p0, p1) in &pairs {
        for &(q0, q1) in &pairs {
            let kd = (k[(p0, q0)] - k[(p1, q1)]).abs() + (k[(p0, q1)] + k[(p1, q0)]).abs();
            let hd = (h[(p0, q0)] - h[(p1, q1)]).norm() + (h[(p0, q1)] + h[(p1, q0)]).norm();
            if kd > ISOTROPY_TOL * kmax || hd > ISOTROPY_TOL * hmax {
                return None;
            }
        }
    }
    Some(pairs)
}

/// The basis of one part of the interior: the whole (identity), or one
/// whirl subspace `b_p = (e_p0 - s j e_p1) / sqrt(2)`, `s = +-1`.
#[derive(Debug, Clone, Copy)]
enum Part<'p> {
    Whole(usize),
    Whirl(&'p [(usize, usize)], f64),
}

impl Part<'_> {
    fn dim(&self) -> usize {
        match self {
            Part::Whole(n) => *n,
            Part::Whirl(pairs, _) => pairs.len(),
        }
    }

    /// `B^H X B` (`dim x dim`) of a square interior matrix.
    fn project<T: Copy + Into<Complex64>>(&self, x: &DMatrix<T>) -> DMatrix<Complex64> {
        let at = |r: usize, c: usize| -> Complex64 { x[(r, c)].into() };
        match *self {
            Part::Whole(n) => DMatrix::from_fn(n, n, &at),
            Part::Whirl(pairs, s) => {
                let js = Complex64::new(0.0, s);
                DMatrix::from_fn(pairs.len(), pairs.len(), |p, q| {
                    let ((p0, p1), (q0, q1)) = (pairs[p], pairs[q]);
                    (at(p0, q0) + at(p1, q1) - js * at(p0, q1) + js * at(p1, q0)) * 0.5
                })
            }
        }
    }

    /// `B^H R` (`dim x ncols`).
    fn left(&self, r: &DMatrix<Complex64>) -> DMatrix<Complex64> {
        match *self {
            Part::Whole(_) => r.clone(),
            Part::Whirl(pairs, s) => {
                let js = Complex64::new(0.0, s);
                let h = std::f64::consts::FRAC_1_SQRT_2;
                DMatrix::from_fn(pairs.len(), r.ncols(), |p, c| {
                    let (p0, p1) = pairs[p];
                    (r[(p0, c)] + js * r[(p1, c)]) * h
                })
            }
        }
    }

    /// `V B` (`nrows x dim`).
    fn right(&self, v: &DMatrix<Complex64>) -> DMatrix<Complex64> {
        match *self {
            Part::Whole(_) => v.clone(),
            Part::Whirl(pairs, s) => {
                let js = Complex64::new(0.0, s);
                let h = std::f64::consts::FRAC_1_SQRT_2;
                DMatrix::from_fn(v.nrows(), pairs.len(), |r, p| {
                    let (p0, p1) = pairs[p];
                    (v[(r, p0)] - js * v[(r, p1)]) * h
                })
            }
        }
    }
}

/// `L^-1 X` for a lower-triangular `L` with a band profile: row `i` of
/// `L` has its nonzeros in columns `first[i]..=i` (`first` from
/// [`band_profile`]), so forward substitution costs `O(n b)` per column of
/// `X` instead of `O(n^2)`. The Cholesky factor of a banded matrix keeps
/// its band exactly (no fill outside the envelope; the entries there are
/// computed as exact zeros). `None` if a diagonal entry is zero.
fn solve_lower_banded(
    l: &DMatrix<Complex64>,
    first: &[usize],
    x: &DMatrix<Complex64>,
) -> Option<DMatrix<Complex64>> {
    let mut y = x.clone();
    for mut col in y.column_iter_mut() {
        for (i, &fi) in first.iter().enumerate() {
            let mut acc = col[i];
            for j in fi..i {
                acc -= l[(i, j)] * col[j];
            }
            let d = l[(i, i)];
            if d.re == 0.0 && d.im == 0.0 {
                return None;
            }
            col[i] = acc / d;
        }
    }
    Some(y)
}

/// Per row of the lower-triangular `l`, the first column holding a nonzero
/// (the row's own index if none before the diagonal).
fn band_profile(l: &DMatrix<Complex64>) -> Vec<usize> {
    (0..l.nrows())
        .map(|i| {
            (0..i)
                .find(|&j| {
                    let z = l[(i, j)];
                    z.re != 0.0 || z.im != 0.0
                })
                .unwrap_or(i)
        })
        .collect()
}

/// One part's eigenvalues and the factors `P` (`n_left x dim`) and `Q`
/// (`dim x ncols`) of its residues `R_k = P[:, k] Q[k, :]`.
type PartModes = (Vec<f64>, DMatrix<Complex64>, DMatrix<Complex64>);

/// Eigenvalues and residue factors of one part (module docs, in the
/// part's basis `B`): `B^H K B = L L^H`, `L^-1 B^H H B L^-H = U mu U^H`,
/// `P = W B L^-H U`, `Q = U^H L^-1 B^H [V, T_i]`, with the left rows
/// `W = [V_L; E^T]` (`E^T`: the probe rows, none for `A` and `B` alone).
fn part_modes(
    part: Part<'_>,
    k: &DMatrix<f64>,
    h: &DMatrix<Complex64>,
    st: &Statics,
    left: &DMatrix<Complex64>,
) -> Result<PartModes, ReductionError> {
    let kp = part.project(k);
    let kp = (&kp + kp.adjoint()) * Complex64::from(0.5);
    let hp = part.project(h);
    let hp = (&hp + hp.adjoint()) * Complex64::from(0.5);
    let chol = Cholesky::new(kp).ok_or_else(|| {
        ReductionError::Invalid(
            "the bearings do not hold the shaft (K_ii not positive definite)".into(),
        )
    })?;
    let l = chol.l();
    let first = band_profile(&l);
    let solve = |x: &DMatrix<Complex64>| {
        solve_lower_banded(&l, &first, x)
            .ok_or_else(|| ReductionError::Invalid("Cholesky factor of K_ii is singular".into()))
    };
    // C = L^-1 H L^-H by two triangular solves (H Hermitian).
    let y = solve(&hp)?;
    let ct = solve(&y.adjoint())?;
    let c = (&ct + ct.adjoint()) * Complex64::from(0.5);
    let eig = SymmetricEigen::try_new(c, f64::EPSILON, EIGEN_MAX_ITER).ok_or_else(|| {
        ReductionError::Invalid("the eigensolver for the modal reduction did not converge".into())
    })?;
    let u = &eig.eigenvectors;
    let p = solve(&part.right(left).adjoint())?.adjoint() * u;
    let q = u.adjoint() * solve(&part.left(&st.rhs))?;
    Ok((eig.eigenvalues.iter().copied().collect(), p, q))
}

impl Reducer<'_> {
    /// The modal form of this reduction (module docs of
    /// [`crate::reduce::modal`]): one Cholesky of `K_ii`, one Hermitian
    /// eigendecomposition of `C` and the residues, `O(n_i^3)` once; for an
    /// axisymmetric interior (every FE model of shaft, disks and isotropic
    /// point masses) the forward and backward whirl halves separately, a
    /// quarter of that (module docs). Fails if `K_ii` is not positive
    /// definite or the eigensolver does not converge.
    pub fn modal(&self) -> Result<ModalReducer, ReductionError> {
        self.modal_with(true, &[])
    }

    /// [`Reducer::modal`] that also gives the [`ProbeTerms`] of the shaft
    /// DOFs `probe_dofs` ([`ModalReducer::reduce_probes`]), the modal form
    /// of [`Reducer::reduce_adjoint_probes`]: the probe rows `R = E^T
    /// Z_ii^-1` of the interior probes are more rows of the left factor,
    /// `R [V, T_i] = sum_k d_k (E^T L^-T u_k) (u_k^H L^-1 [V, T_i])`, so
    /// their residues come from the same eigendecomposition.
    pub fn modal_probes(&self, probe_dofs: &[usize]) -> Result<ModalReducer, ReductionError> {
        self.modal_with(true, probe_dofs)
    }

    /// [`Reducer::modal`] without the whirl split even where it applies
    /// (one eigenproblem of the whole interior): the same numbers, for
    /// checking the split.
    pub fn modal_unsplit(&self) -> Result<ModalReducer, ReductionError> {
        self.modal_with(false, &[])
    }

    fn modal_with(
        &self,
        split: bool,
        probe_dofs: &[usize],
    ) -> Result<ModalReducer, ReductionError> {
        let (kd, hd) = dense_k_h(self.fe);
        let ii = &self.interior;
        let n = ii.len();
        let n_shaft = self.fe.n_shaft_dof();
        let nq = self.statics.v_l.nrows();
        let npr = probe_dofs.len();
        // Left rows: V_L, then e_i^T of each interior probe (a zero row for
        // a probe at a bearing DOF, which reads q_B itself).
        let mut left = DMatrix::<Complex64>::zeros(nq + npr, n);
        left.view_mut((0, 0), (nq, n)).copy_from(&self.statics.v_l);
        let mut probes = Vec::with_capacity(npr);
        let mut x0_rows = DMatrix::<Complex64>::zeros(npr, nq);
        for (k, &d) in probe_dofs.iter().enumerate() {
            if d >= n_shaft {
                return Err(ReductionError::Invalid(format!(
                    "probe DOF {d} beyond the shaft's {n_shaft} DOFs"
                )));
            }
            match ii.binary_search(&d) {
                Ok(i) => {
                    left[(nq + k, i)] = Complex64::new(1.0, 0.0);
                    x0_rows.row_mut(k).copy_from(&self.x0.row(i));
                    probes.push(Ok(i));
                }
                Err(_) => {
                    let ch = self.bearing.iter().position(|b| *b == d).ok_or_else(|| {
                        ReductionError::Invalid(format!("probe DOF {d} is not a shaft DOF"))
                    })?;
                    probes.push(Err(ch));
                }
            }
        }
        let n_left = nq + npr;
        let k =
            DMatrix::<f64>::from_fn(n, n, |r, c| 0.5 * (kd[(ii[r], ii[c])] + kd[(ii[c], ii[r])]));
        let h = DMatrix::<Complex64>::from_fn(n, n, |r, c| hd[(ii[r], ii[c])]);
        let pairs = if split { whirl_pairs(ii, &k, &h) } else { None };
        let parts: Vec<Part<'_>> = match &pairs {
            Some(p) => vec![Part::Whirl(p, 1.0), Part::Whirl(p, -1.0)],
            None => vec![Part::Whole(n)],
        };
        let ncol = self.statics.rhs.ncols();
        let mut mu = Vec::with_capacity(n);
        let mut residues = DMatrix::<f64>::zeros(2 * n_left * ncol, n);
        let mut kk = 0;
        for part in parts {
            let (m, p, q) = part_modes(part, &k, &h, &self.statics, &left)?;
            debug_assert_eq!(m.len(), part.dim());
            for (j, mj) in m.into_iter().enumerate() {
                let mut col = residues.column_mut(kk);
                for c in 0..ncol {
                    for r in 0..n_left {
                        let v = p[(r, j)] * q[(j, c)];
                        let at = 2 * (c * n_left + r);
                        col[at] = v.re;
                        col[at + 1] = v.im;
                    }
                }
                mu.push(mj);
                kk += 1;
            }
        }
        Ok(ModalReducer {
            statics: self.statics.clone(),
            mu,
            residues,
            n_left,
            probes,
            x0_rows,
            split: pairs.is_some(),
        })
    }
}

impl ModalReducer {
    /// Whether the eigenproblem was split into the forward and backward
    /// whirl halves (an axisymmetric interior, see [`Reducer::modal`]).
    pub fn whirl_split(&self) -> bool {
        self.split
    }

    /// The eigenvalues `mu_k` of `C` (s^2/rad^2), in the eigensolver's order.
    pub fn mu(&self) -> &[f64] {
        &self.mu
    }

    /// `A(omega)` and `B(omega)` by the modal sum (module docs). An error if
    /// `omega` is not finite or lies on a pole (`1 - omega^2 mu_k = 0`).
    pub fn reduce(&self, omega: f64) -> Result<ReducedTerms, ReductionError> {
        let ncol = self.statics.rhs.ncols();
        let flat = self.sum(omega, ncol)?;
        self.assemble(&flat, omega, ncol)
    }

    /// [`ModalReducer::reduce`] and the [`ProbeTerms`] of the probe DOFs
    /// given to [`Reducer::modal_probes`] (the same numbers as
    /// [`Reducer::reduce_adjoint_probes`] to the round-off of the modal
    /// form): `P = X_0 rows + Omega^2 R V`, `L = R T_i`.
    pub fn reduce_probes(&self, omega: f64) -> Result<(ReducedTerms, ProbeTerms), ReductionError> {
        self.reduce_probes_loads(omega, self.n_loads())
    }

    /// The number of load columns `N_p` (the columns of `B` and of the
    /// probes' `L`).
    pub fn n_loads(&self) -> usize {
        self.statics.rhs.ncols() - self.statics.v_l.nrows()
    }

    /// [`ModalReducer::reduce_probes`] for the first `n_loads` load
    /// columns only (at most [`ModalReducer::n_loads`]): `B` and the
    /// probes' `L` have those columns. The residues' entries of a load
    /// column are contiguous after those of the columns before it, so the
    /// modal sum runs over a prefix of each residue and costs
    /// `(2 N_b + n_loads) / (2 N_b + N_p)` of the whole; the entries are
    /// the whole sum's, bit for bit (the same products, summed in the same
    /// order).
    pub fn reduce_probes_loads(
        &self,
        omega: f64,
        n_loads: usize,
    ) -> Result<(ReducedTerms, ProbeTerms), ReductionError> {
        let nq = self.statics.v_l.nrows();
        let ncol = nq + n_loads.min(self.n_loads());
        let n_loads = ncol - nq;
        let flat = self.sum(omega, ncol)?;
        let terms = self.assemble(&flat, omega, ncol)?;
        let np = self.probes.len();
        let w2 = omega * omega;
        let at = |r: usize, c: usize| {
            let i = 2 * (c * self.n_left + r);
            Complex64::new(flat[i], flat[i + 1])
        };
        let mut p = DMatrix::<Complex64>::zeros(np, nq);
        let mut l = DMatrix::<Complex64>::zeros(np, n_loads);
        for (k, pl) in self.probes.iter().enumerate() {
            match *pl {
                Ok(_) => {
                    for c in 0..nq {
                        p[(k, c)] = self.x0_rows[(k, c)] + at(nq + k, c) * w2;
                    }
                    for c in 0..n_loads {
                        l[(k, c)] = at(nq + k, nq + c);
                    }
                }
                Err(ch) => p[(k, ch)] = Complex64::new(1.0, 0.0),
            }
        }
        if p.iter()
            .chain(l.iter())
            .all(|z| z.re.is_finite() && z.im.is_finite())
        {
            Ok((terms, ProbeTerms { p, l }))
        } else {
            Err(ReductionError::Invalid(format!(
                "Z_ii numerically singular at {omega} rad/s (speed on a pinned-shaft resonance)"
            )))
        }
    }

    /// `sum_k d_k(omega) R_k` of every left row and the first `ncol`
    /// columns of `[V, T_i]` (layout of [`ModalReducer::residues`]: a
    /// prefix of each residue).
    fn sum(&self, omega: f64, ncol: usize) -> Result<Vec<f64>, ReductionError> {
        if !omega.is_finite() {
            return Err(ReductionError::Invalid(format!(
                "speed must be finite, got {omega}"
            )));
        }
        let w2 = omega * omega;
        let stride = 2 * self.n_left * self.statics.rhs.ncols();
        let rows = 2 * self.n_left * ncol.min(self.statics.rhs.ncols());
        // flat = sum_k d_k R_k over the modes, four at a time (one pass
        // over `flat` per four residue columns; the columns are contiguous).
        let mut d = Vec::with_capacity(self.mu.len());
        for &mu in &self.mu {
            let den = 1.0 - w2 * mu;
            if den == 0.0 {
                return Err(ReductionError::Invalid(format!(
                    "Z_ii singular at {omega} rad/s (speed on a pinned-shaft resonance)"
                )));
            }
            d.push(1.0 / den);
        }
        let mut flat = vec![0.0; rows];
        let cols = self.residues.as_slice().chunks_exact(stride);
        let mut quads = d.chunks_exact(4);
        let mut cols4 = self.residues.as_slice().chunks_exact(4 * stride);
        for (dq, block) in (&mut quads).zip(&mut cols4) {
            let c0 = &block[..rows];
            let c1 = &block[stride..stride + rows];
            let c2 = &block[2 * stride..2 * stride + rows];
            let c3 = &block[3 * stride..3 * stride + rows];
            if let [d0, d1, d2, d3] = *dq {
                for ((((y, a), b), c), e) in flat.iter_mut().zip(c0).zip(c1).zip(c2).zip(c3) {
                    *y += a * d0 + b * d1 + c * d2 + e * d3;
                }
            }
        }
        let done = d.len() - quads.remainder().len();
        for (col, &dk) in cols.skip(done).zip(quads.remainder()) {
            for (y, r) in flat.iter_mut().zip(&col[..rows]) {
                *y += r * dk;
            }
        }
        Ok(flat)
    }

    /// `A`, `B` (its first `ncol - 2 N_b` load columns) from the modal sum
    /// of [`ModalReducer::sum`] over `ncol` columns.
    fn assemble(
        &self,
        flat: &[f64],
        omega: f64,
        ncol: usize,
    ) -> Result<ReducedTerms, ReductionError> {
        let w2 = omega * omega;
        let nq = self.statics.v_l.nrows();
        // assemble_vy without temporaries: A = S_K - w2 M_red - w2^2 VY_A,
        // B = (T_red + w2 VY_B) w2.
        let vy = |r: usize, c: usize| {
            let at = 2 * (c * self.n_left + r);
            Complex64::new(flat[at], flat[at + 1])
        };
        let (w2c, w4c) = (Complex64::from(w2), Complex64::from(w2 * w2));
        let st = &self.statics;
        let a = DMatrix::from_fn(nq, nq, |r, c| {
            st.s_k[(r, c)] - st.m_red[(r, c)] * w2c - vy(r, c) * w4c
        });
        let b = DMatrix::from_fn(nq, ncol - nq, |r, c| {
            (st.t_red[(r, c)] + vy(r, nq + c) * w2c) * w2c
        });
        let terms = ReducedTerms { omega, a, b };
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
