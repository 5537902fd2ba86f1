//! Block-structured QRD/RLS: the filter of [`crate::qrdrls`] for regressions
//! whose rows each touch one block of unknowns plus a set of shared ones.
//!
//! # Structure
//!
//! The `M = NB W + S` unknowns are ordered as `NB` blocks of `W` columns
//! followed by `S` shared columns:
//!
//! ```text
//!     w = ( w_0 | w_1 | ... | w_(NB-1) | w_s ),   w_b in F^W,  w_s in F^S.
//! ```
//!
//! Row `u_j` of an update has non-zeros only in one block `b(j)` and in the
//! shared columns, `u_j = (0 .. 0, a_j, 0 .. 0, c_j)`. In the identification
//! ([`crate::identify`]) a block is one bearing and direction, i.e. one
//! channel `(m, r)`: its `W = per_bearing / 2` coefficients of `Z_B^(m)[r][.]`
//! (N/m, N s/m, ... scaled), and the shared unknowns are the `S` unbalance
//! unknowns (kg m, scaled). Extension parameters that enter every channel
//! (runout, an extra unbalance plane) are more shared columns: any layout
//! `(NB, W, S)` with rows of that form is accepted.
//!
//! # The triangular factor is block-arrowhead
//!
//! With the shared columns last, the upper-triangular factor `R` of
//! `Phi = R^H R` (the convention of [`crate::qrdrls`]) keeps the form
//!
//! ```text
//!         [ D_0               C_0     ]
//!         [       D_1         C_1     ]
//!     R = [             ...   ...     ] ,  D_b  W x W upper triangular,
//!         [                   C_(NB-1)]    C_b  W x S,
//!         [                   R_s     ]    R_s  S x S upper triangular,
//! ```
//!
//! for every step: `R(0) = sqrt(delta) I` has it, and the Givens rotations
//! that fold row `u_j` in (Eq. 20 of the method paper) only ever combine
//! `u_j` with rows of `R` where `u_j` is non-zero. Rotation `i` of block
//! `b(j)` mixes row `i` of `[D_b C_b p_b]` with the working row, whose
//! non-zeros stay inside block `b(j)` and the shared columns; once the block
//! part is zeroed only the shared part is left, folded into `[R_s p_s]`.
//! Blocks `b != b(j)` meet identity rotations (their working entries are
//! exactly zero), which the dense filter also skips. Only `D_b`, `C_b`,
//! `R_s` and `p` are stored:
//!
//! ```text
//!     NB W^2 + NB W S + S^2 + M   entries of F   (dense: M^2 + M).
//! ```
//!
//! # Cost
//!
//! A row costs `W` rotations over `W - i + S` entries plus `S` rotations
//! over `S - i` entries, `O(W^2 + W S + S^2)` operations instead of the dense
//! filter's `O(M (M - b W))`: the cost per update grows linearly with `NB`
//! (`N = NB` or `2 NB` rows of constant cost) where the dense one grows with
//! `NB^3`.
//!
//! The kernel, [`BlockFactor::update_rows`], has `NB`, `W`, `S` known at
//! compile time (the update of [`BlockQrdRls`] and of the Givens block
//! identifiers); its pivots are written out one by one so that every index
//! and loop bound is a constant: the working row lives in registers and
//! each rotation runs over the fixed range right of its pivot, unrolled and
//! vectorised by the compiler. `docs/benchmarks.md` compares it with the
//! dense filter and the baselines.
//!
//! # Same numbers as the dense filter
//!
//! Every stored entry meets the same rotations, computed from the same
//! values by the dense filter's [`crate::givens::rotation_real_pivot`] (in
//! its form for a pivot known to be non-negative, which gives the same
//! bits), in the same order as in
//! [`crate::qrdrls::update_rows`]; the entries the dense filter adds besides
//! are products with exact zeros. The factor, `p`, `xi_j` and `gamma_j`
//! equal the dense filter's (tests check equality to the last bit on the
//! stored entries and round-off agreement with a batch least-squares
//! solve), and so do the weights of the back-substitution, which adds the
//! same non-zero products in the same order.
//!
//! # Input safety
//!
//! As [`crate::qrdrls`]: non-finite entries ([`FilterError::NonFinite`]),
//! entries beyond [`qrdrls::input_limit`] ([`FilterError::OutOfRange`]), a
//! `lambda` outside `(0, 1]`, wrong lengths, and a row with non-zeros in two
//! blocks ([`FilterError::Dimension`]) are all rejected **before** anything
//! is written: the state is then bit for bit unchanged. No heap, no
//! `unsafe`, no panics (every index is checked by a slice access or guarded
//! by the lengths validated up front).
//!
//! # Example
//!
//! ```
//! use rotorid_core::blockqrd::BlockQrdRls;
//!
//! // 2 blocks of 2 unknowns and 1 shared unknown: M = 5, real field.
//! let mut f = BlockQrdRls::<f64, 2, 2, 1>::new(1.0, 1e-12)?;
//! let w = [1.0, -2.0, 0.5, 3.0, 4.0];
//! // Rows: block 0 then block 1, each with the shared column.
//! let u = [
//!     1.0, 0.5, 0.0, 0.0, 1.0, //
//!     0.0, 2.0, 0.0, 0.0, -1.0, //
//!     0.0, 0.0, 1.0, 1.0, 0.5, //
//!     0.0, 0.0, -1.0, 2.0, 2.0, //
//!     0.0, 0.0, 0.0, 0.0, 3.0,
//! ];
//! let d: Vec<f64> = u.chunks(5).map(|r| r.iter().zip(&w).map(|(a, b)| a * b).sum()).collect();
//! let (mut xi, mut gamma) = ([0.0; 5], [0.0; 5]);
//! f.update_rows(&u, &d, &mut xi, &mut gamma)?;
//! let mut est = [0.0; 5];
//! f.weights(&mut est)?;
//! assert!(est.iter().zip(&w).all(|(a, b)| (a - b).abs() < 1e-9));
//! # Ok::<(), rotorid_core::qrdrls::FilterError>(())
//! ```

use crate::factor::QrdRls;
use crate::givens::{min_normal, rotation_nonneg_pivot, Rotation};
use crate::parametrization::Structure;
use crate::qrdrls::{self, FilterError};
use crate::Real;
use nalgebra::ComplexField;

/// The block layout `(NB, W, S)` at run time: `blocks` blocks of `width`
/// columns, then `shared` columns (`M = blocks width + shared`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct BlockShape {
    /// Number of blocks `NB` (> 0).
    pub blocks: usize,
    /// Columns per block `W` (> 0).
    pub width: usize,
    /// Shared columns `S` (may be 0).
    pub shared: usize,
}

impl BlockShape {
    /// The layout of the identification regression of `structure` for `nb`
    /// bearings and `np` planes: one block per channel (`NB = 2 nb`) of
    /// `W = per_bearing / 2` columns (the channel's row of `Z_B^(m)`), and
    /// `S = per_plane np` shared unbalance columns; see
    /// [`crate::parametrization::Structure::bearing_index`].
    pub const fn of(structure: Structure, nb: usize, np: usize) -> Self {
        BlockShape {
            blocks: 2 * nb,
            width: structure.per_bearing() / 2,
            shared: structure.per_plane() * np,
        }
    }

    /// Number of unknowns `M = NB W + S`.
    pub const fn unknowns(&self) -> usize {
        self.blocks * self.width + self.shared
    }

    /// Entries of the diagonal blocks `D_b` (`NB W^2`).
    pub const fn diag_len(&self) -> usize {
        self.blocks * self.width * self.width
    }

    /// Entries of the coupling blocks `C_b` (`NB W S`).
    pub const fn coupling_len(&self) -> usize {
        self.blocks * self.width * self.shared
    }

    /// Entries of the shared factor `R_s` (`S^2`).
    pub const fn shared_len(&self) -> usize {
        self.shared * self.shared
    }

    /// Entries of the stored factor (`NB W^2 + NB W S + S^2`), without `p`.
    pub const fn factor_len(&self) -> usize {
        self.diag_len() + self.coupling_len() + self.shared_len()
    }

    /// `blocks > 0` and `width > 0`.
    pub const fn is_valid(&self) -> bool {
        self.blocks > 0 && self.width > 0
    }
}

/// Read-only view of a block-structured state: `diag` (`NB` row-major
/// `W x W` blocks `D_b`), `coupling` (`NB` row-major `W x S` blocks `C_b`),
/// `shared` (row-major `S x S`, `R_s`), `pb` (`NB W`, the block part of
/// `p`) and `ps` (`S`).
#[derive(Debug, Clone, Copy)]
pub struct BlockRef<'a, F> {
    /// Layout.
    pub shape: BlockShape,
    /// Diagonal blocks `D_b`.
    pub diag: &'a [F],
    /// Coupling blocks `C_b`.
    pub coupling: &'a [F],
    /// Shared factor `R_s`.
    pub shared: &'a [F],
    /// Block part of `p`.
    pub pb: &'a [F],
    /// Shared part of `p`.
    pub ps: &'a [F],
}

#[inline(always)]
pub(crate) fn is_zero<F: ComplexField<RealField = T> + Copy, T: Real>(x: F) -> bool {
    x.real() == T::zero() && x.imaginary() == T::zero()
}

/// Applies `rot` to the row pair `(r, y)` entry by entry:
/// `(r_k, y_k) <- (c r_k + s y_k, -s^* r_k + c y_k)` for every
/// `from <= k < K` (`from = 0`, a constant after inlining, gives the
/// fixed-length loop over the whole rows).
#[inline(always)]
fn rotate_from<F, T, const K: usize>(rot: &Rotation<F>, r: &mut [F; K], y: &mut [F; K], from: usize)
where
    F: ComplexField<RealField = T> + Copy,
    T: Real,
{
    for (rk, yk) in r.iter_mut().zip(y.iter_mut()).skip(from) {
        let (nr, ny) = rot.apply(*rk, *yk);
        *rk = nr;
        *yk = ny;
    }
}

/// The block of `row` (at least `NB W` entries): the block with non-zeros,
/// `0` if there is none, `None` if two blocks have non-zeros. Without
/// branches on the data: the number of blocks with non-zeros and the last
/// of them are counted over all blocks.
#[inline]
pub(crate) fn block_of_fixed<F, T, const NB: usize, const W: usize>(row: &[F]) -> Option<usize>
where
    F: ComplexField<RealField = T> + Copy,
    T: Real,
{
    let (mut count, mut found) = (0usize, 0usize);
    for (b, cols) in row.chunks_exact(W).take(NB).enumerate() {
        let nz = cols.iter().fold(false, |nz, x| nz | !is_zero(*x));
        count += usize::from(nz);
        found = if nz { b } else { found };
    }
    (count <= 1).then_some(found)
}

impl<F, T> BlockRef<'_, F>
where
    F: ComplexField<RealField = T> + Copy,
    T: Real,
{
    fn check_lengths(&self) -> Result<(), FilterError> {
        let s = &self.shape;
        if !s.is_valid()
            || self.diag.len() != s.diag_len()
            || self.coupling.len() != s.coupling_len()
            || self.shared.len() != s.shared_len()
            || self.pb.len() != s.blocks * s.width
            || self.ps.len() != s.shared
        {
            return Err(FilterError::Dimension);
        }
        Ok(())
    }

    /// Back-substitution `R w = p` (`w_out` has `M` entries, block-then-
    /// shared order): first `R_s w_s = p_s`, then per block
    /// `D_b w_b = p_b - C_b w_s`.
    ///
    /// Errors: `Dimension`; `Singular` as [`qrdrls::solve_weights`].
    // index proven: lengths checked (`check_lengths`, `w_out`), `i < S`
    // (`W`) in rows of `S` (`W`) entries, `b < blocks`.
    #[allow(clippy::indexing_slicing)]
    pub fn solve_weights(&self, w_out: &mut [F]) -> Result<(), FilterError> {
        self.check_lengths()?;
        let (w, s) = (self.shape.width, self.shape.shared);
        if w_out.len() != self.shape.unknowns() {
            return Err(FilterError::Dimension);
        }
        let (wb_all, ws) = w_out.split_at_mut(self.shape.blocks * w);
        let check = |rii: F, acc: F| -> Result<F, FilterError> {
            let mag = rii.real().abs().max(rii.imaginary().abs());
            if !rii.is_finite() || mag < min_normal::<T>() {
                return Err(FilterError::Singular);
            }
            let wi = acc / rii;
            if !wi.is_finite() {
                return Err(FilterError::Singular);
            }
            Ok(wi)
        };
        for i in (0..s).rev() {
            let row = &self.shared[i * s..(i + 1) * s];
            let mut acc = self.ps[i];
            for (rik, wk) in row[i + 1..].iter().zip(&ws[i + 1..]) {
                acc -= *rik * *wk;
            }
            ws[i] = check(row[i], acc)?;
        }
        for (b, wb) in wb_all.chunks_exact_mut(w).enumerate() {
            let diag = &self.diag[b * w * w..(b + 1) * w * w];
            let coup = &self.coupling[b * w * s..(b + 1) * w * s];
            for i in (0..w).rev() {
                let drow = &diag[i * w..(i + 1) * w];
                let mut acc = self.pb[b * w + i];
                for (rik, wk) in drow[i + 1..].iter().zip(&wb[i + 1..]) {
                    acc -= *rik * *wk;
                }
                for (rik, wk) in coup[i * s..(i + 1) * s].iter().zip(ws.iter()) {
                    acc -= *rik * *wk;
                }
                wb[i] = check(drow[i], acc)?;
            }
        }
        Ok(())
    }

    /// Conditioning indicator `min_i |R_ii| / max_i |R_ii|` (as
    /// [`qrdrls::r_diag_ratio`]).
    pub fn diag_ratio(&self) -> T {
        let (w, s) = (self.shape.width, self.shape.shared);
        let mut lo = T::max_value().unwrap_or_else(T::one);
        let mut hi = T::zero();
        let blocks = (0..self.diag.len() / (w * w).max(1))
            .flat_map(|b| (0..w).map(move |i| (b * w * w + i * w + i, true)));
        let shared = (0..s).map(|i| (i * s + i, false));
        for (idx, in_diag) in blocks.chain(shared) {
            let x = if in_diag {
                self.diag.get(idx)
            } else {
                self.shared.get(idx)
            };
            let a = x.map_or(T::zero(), |x| x.modulus());
            lo = lo.min(a);
            hi = hi.max(a);
        }
        if hi > T::zero() && hi.is_finite() {
            lo / hi
        } else {
            T::zero()
        }
    }

    /// The factor and `p` written out densely (`r_out`: `M x M` row-major,
    /// `p_out`: `M`), as the dense filter holds them.
    // index proven: lengths checked (`check_lengths`, `r_out`, `p_out`);
    // `b < blocks`, `i, k < W` or `< S`, so every index is below `M^2`.
    #[allow(clippy::indexing_slicing)]
    pub fn to_dense(&self, r_out: &mut [F], p_out: &mut [F]) -> Result<(), FilterError> {
        self.check_lengths()?;
        let (w, s) = (self.shape.width, self.shape.shared);
        let m = self.shape.unknowns();
        if r_out.len() != m * m || p_out.len() != m {
            return Err(FilterError::Dimension);
        }
        let nbw = self.shape.blocks * w;
        r_out.iter_mut().for_each(|x| *x = F::zero());
        for b in 0..self.shape.blocks {
            for i in 0..w {
                let row = b * w + i;
                for k in 0..w {
                    r_out[row * m + b * w + k] = self.diag[b * w * w + i * w + k];
                }
                for k in 0..s {
                    r_out[row * m + nbw + k] = self.coupling[b * w * s + i * s + k];
                }
            }
        }
        for i in 0..s {
            for k in 0..s {
                r_out[(nbw + i) * m + nbw + k] = self.shared[i * s + k];
            }
        }
        p_out[..nbw].copy_from_slice(self.pb);
        p_out[nbw..].copy_from_slice(self.ps);
        Ok(())
    }
}

/// Inline storage of a block-structured factor with `NB` blocks of `W`
/// columns and `S` shared columns (`M = NB W + S`): `D_b`, `C_b`, `R_s`
/// and `p`, `NB W^2 + NB W S + S^2 + NB W + S` entries of `F` (no heap).
/// The paper case (`NB = 4` channels, `W = 4`, `S = 6` real unbalance
/// unknowns, `physical` order 1, `f32`) holds 872 bytes against 2024 for
/// the dense `M = 22` factor.
#[derive(Clone, Debug, PartialEq)]
pub struct BlockFactor<F, const NB: usize, const W: usize, const S: usize> {
    pub(crate) diag: [[[F; W]; W]; NB],
    pub(crate) coupling: [[[F; S]; W]; NB],
    pub(crate) shared: [[F; S]; S],
    pub(crate) pb: [[F; W]; NB],
    pub(crate) ps: [F; S],
}

impl<F, T, const NB: usize, const W: usize, const S: usize> BlockFactor<F, NB, W, S>
where
    F: ComplexField<RealField = T> + Copy,
    T: Real,
{
    /// The layout `(NB, W, S)`.
    pub const SHAPE: BlockShape = BlockShape {
        blocks: NB,
        width: W,
        shared: S,
    };

    /// All zero (see [`Self::init`]).
    pub fn zeroed() -> Self {
        const { assert!(NB > 0 && W > 0, "BlockFactor: NB and W must be > 0") };
        BlockFactor {
            diag: [[[F::zero(); W]; W]; NB],
            coupling: [[[F::zero(); S]; W]; NB],
            shared: [[F::zero(); S]; S],
            pb: [[F::zero(); W]; NB],
            ps: [F::zero(); S],
        }
    }

    /// Initialises the state: `R = sqrt(delta) I`, `p = 0`.
    ///
    /// Errors (state untouched): `InvalidDelta`.
    pub fn init(&mut self, delta: T) -> Result<(), FilterError> {
        qrdrls::validate_delta(delta)?;
        let sd = F::from_real(delta.sqrt());
        *self = Self::zeroed();
        for blk in self.diag.iter_mut() {
            for (i, row) in blk.iter_mut().enumerate() {
                if let Some(x) = row.get_mut(i) {
                    *x = sd;
                }
            }
        }
        for (i, row) in self.shared.iter_mut().enumerate() {
            if let Some(x) = row.get_mut(i) {
                *x = sd;
            }
        }
        Ok(())
    }

    /// Back-substitution `R w = p` into `w` (`M` entries; see
    /// [`BlockRef::solve_weights`]).
    pub fn solve_weights(&self, w: &mut [F]) -> Result<(), FilterError> {
        self.view().solve_weights(w)
    }

    /// `min|R_ii| / max|R_ii|` (see [`BlockRef::diag_ratio`]).
    pub fn diag_ratio(&self) -> T {
        self.view().diag_ratio()
    }

    /// Read-only view.
    pub fn view(&self) -> BlockRef<'_, F> {
        BlockRef {
            shape: Self::SHAPE,
            diag: self.diag.as_flattened().as_flattened(),
            coupling: self.coupling.as_flattened().as_flattened(),
            shared: self.shared.as_flattened(),
            pb: self.pb.as_flattened(),
            ps: &self.ps,
        }
    }
}

impl<F, T, const NB: usize, const W: usize, const S: usize> BlockFactor<F, NB, W, S>
where
    F: ComplexField<RealField = T> + Copy,
    T: Real,
{
    /// Folds the `N` rows of `u` (`N x M` row-major, in the block-then-
    /// shared column order; each row non-zero in at most one block) with
    /// right-hand sides `d` into the state after scaling it by
    /// `sqrt(lambda)`; writes the a-posteriori errors `xi_j` and the
    /// conversion factors `gamma_j` (as [`qrdrls::update_rows`], with the
    /// same numbers to the last bit, checked by the tests). The loops over
    /// `W` and `S` are fixed in length and the working row is held in
    /// registers. This is the update of [`BlockQrdRls`] and of the Givens
    /// block identifiers.
    ///
    /// Errors (state untouched): `Dimension` (lengths, or a row with
    /// non-zeros in two blocks), `InvalidLambda`, `NonFinite`, `OutOfRange`.
    pub fn update_rows(
        &mut self,
        u: &[F],
        d: &[F],
        lambda: T,
        xi: &mut [F],
        gamma: &mut [T],
    ) -> Result<(), FilterError> {
        let shape = Self::SHAPE;
        let m = shape.unknowns();
        // The blocks of the first `BLOCKS_KEPT` rows, found once by the
        // validation and reused by the update (`u16::MAX`: not kept).
        let mut blocks = [u16::MAX; BLOCKS_KEPT];
        Self::validate(u, d, lambda, xi, gamma, &mut blocks, qrdrls::input_limit())?;
        if lambda != T::one() {
            self.forget(lambda.sqrt());
        }
        let rows = u.chunks_exact(m).zip(d).zip(xi).zip(gamma);
        for (j, (((row, &dj), xj), gj)) in rows.enumerate() {
            let b = match blocks.get(j) {
                Some(&b) if b != u16::MAX => usize::from(b),
                _ => block_of_fixed::<F, T, NB, W>(row).unwrap_or(0),
            };
            let (x, g) = self.fold_row(b, row, dj);
            *xj = x;
            *gj = g;
        }
        Ok(())
    }

    /// The checks of an update (in this order: lengths, `lambda`,
    /// non-finite or out-of-range entries, then rows with non-zeros in two
    /// blocks) in one pass over each row, which finds
    /// the row's block at the same time (into `blocks`, for the first
    /// `BLOCKS_KEPT` rows). All of it before anything is written.
    #[inline(always)]
    pub(crate) fn validate(
        u: &[F],
        d: &[F],
        lambda: T,
        xi: &[F],
        gamma: &[T],
        blocks: &mut [u16; BLOCKS_KEPT],
        limit: T,
    ) -> Result<(), FilterError> {
        let m = Self::SHAPE.unknowns();
        let n = d.len();
        if n.checked_mul(m) != Some(u.len()) || xi.len() != n || gamma.len() != n {
            return Err(FilterError::Dimension);
        }
        qrdrls::validate_lambda(lambda)?;
        // `|x| <= limit` is false for NaN and the infinities as well as for
        // out-of-range entries (as in `qrdrls::check_finite`).
        let within = |x: &F| (x.real().abs() <= limit) & (x.imaginary().abs() <= limit);
        let mut ok = d.iter().fold(true, |ok, x| ok & within(x));
        let mut two = false;
        for (j, row) in u.chunks_exact(m).enumerate() {
            let (mut count, mut found) = (0usize, 0usize);
            for (b, cols) in row.chunks_exact(W).take(NB).enumerate() {
                let (nz, okb) = cols.iter().fold((false, true), |(nz, okb), x| {
                    (nz | !is_zero(*x), okb & within(x))
                });
                ok &= okb;
                count += usize::from(nz);
                found = if nz { b } else { found };
            }
            ok &= row.iter().skip(NB * W).fold(true, |ok, x| ok & within(x));
            two |= count > 1;
            if let Some(slot) = blocks.get_mut(j) {
                *slot = u16::try_from(found).unwrap_or(u16::MAX);
            }
        }
        if !ok {
            // Which error: the general check tells them apart (entries
            // within its limit but beyond a tighter `limit` are out of range).
            qrdrls::check_finite(u, d)?;
            return Err(FilterError::OutOfRange);
        }
        if two {
            return Err(FilterError::Dimension);
        }
        Ok(())
    }

    /// `[R p] <- s [R p]` on every stored entry: the strictly lower parts
    /// of `D_b` and `R_s` are exact zeros, which stay `+0` (`s > 0`), so
    /// scaling whole arrays gives the same state as scaling the upper
    /// entries only, in flat loops.
    fn forget(&mut self, s: T) {
        let flat = |x: &mut [F]| x.iter_mut().for_each(|x| *x = x.scale(s));
        flat(self.diag.as_flattened_mut().as_flattened_mut());
        flat(self.coupling.as_flattened_mut().as_flattened_mut());
        flat(self.shared.as_flattened_mut());
        flat(self.pb.as_flattened_mut());
        flat(&mut self.ps);
    }

    /// Folds row `row` (`M` entries, non-zero in block `b` and the shared
    /// columns only) with right-hand side `d`; returns `(xi, gamma)`.
    ///
    /// The arithmetic of [`qrdrls::update_rows`] on every stored entry,
    /// one-sided (each rotation touches the entries right of its pivot
    /// only, as the dense filter), with the loops over the pivots written
    /// out for the first [`UNROLL`] pivots of the block and of the shared
    /// part ([`block_step`], [`shared_step`] with a literal pivot): every
    /// index is then a constant, the rotations run over fixed-length
    /// ranges the compiler unrolls and vectorises, and the working row
    /// `(ub, us)` stays in registers. Pivots beyond [`UNROLL`] (layouts
    /// with `W` or `S` above it) take the same steps in a plain loop.
    // index proven: `b < NB` (from `block_of_fixed`, checked by the caller for
    // every row) and `row.len() = M = NB W + S` (checked by the caller).
    #[allow(clippy::indexing_slicing)]
    #[inline]
    fn fold_row(&mut self, b: usize, row: &[F], d: F) -> (F, T) {
        let mut ub = [F::zero(); W];
        let mut us = [F::zero(); S];
        ub.copy_from_slice(&row[b * W..(b + 1) * W]);
        us.copy_from_slice(&row[NB * W..NB * W + S]);
        let mut e = d; // ends as sqrt(gamma) alpha
        let mut g = T::one(); // ends as sqrt(gamma)
        let diag = &mut self.diag[b];
        let coup = &mut self.coupling[b];
        let pb = &mut self.pb[b];
        // Block part: rotations against D_b, applied to [D_b C_b p_b].
        macro_rules! block_steps {
            ($($i:literal)*) => {
                $(block_step($i, diag, coup, pb, &mut ub, &mut us, &mut e, &mut g);)*
            };
        }
        block_steps!(0 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15);
        for i in UNROLL..W {
            block_step(i, diag, coup, pb, &mut ub, &mut us, &mut e, &mut g);
        }
        // Shared part: rotations against R_s, applied to [R_s p_s].
        let (shared, ps) = (&mut self.shared, &mut self.ps);
        macro_rules! shared_steps {
            ($($i:literal)*) => {
                $(shared_step($i, shared, ps, &mut us, &mut e, &mut g);)*
            };
        }
        shared_steps!(0 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15);
        for i in UNROLL..S {
            shared_step(i, shared, ps, &mut us, &mut e, &mut g);
        }
        (e.scale(g), g * g)
    }
}

/// Number of rows per update whose blocks [`BlockFactor::update_rows`]
/// keeps from the validation (further rows find theirs again).
pub(crate) const BLOCKS_KEPT: usize = 64;

/// Number of pivots [`BlockFactor::update_rows`] writes out one by one
/// (the `0 .. 15` of its step lists).
const UNROLL: usize = 16;

/// Pivot `i` of the block part (nothing for `i >= W`): the rotation of row
/// `i` of `[D_b C_b p_b]` with the working row `(ub, us, e)` that zeroes
/// `ub[i]`, computed by `rotation_nonneg_pivot` from `(D_b[i][i], ub[i])`
/// and applied to the entries right of the pivot,
/// `(r_k, y_k) <- (c r_k + s y_k, -s^* r_k + c y_k)`; the pivot pair
/// becomes `(rho, 0)`, and `g <- c g`. A zero `ub[i]` is the identity
/// rotation, skipped (as in the dense filter). Inlined with a literal `i`,
/// every index and loop bound is a constant.
// index proven: `i < W` is checked first, and every array indexed by `i`
// or `k` has `W` entries.
#[allow(clippy::too_many_arguments, clippy::indexing_slicing)]
#[inline(always)]
fn block_step<F, T, const W: usize, const S: usize>(
    i: usize,
    diag: &mut [[F; W]; W],
    coup: &mut [[F; S]; W],
    pb: &mut [F; W],
    ub: &mut [F; W],
    us: &mut [F; S],
    e: &mut F,
    g: &mut T,
) where
    F: ComplexField<RealField = T> + Copy,
    T: Real,
{
    if i >= W || is_zero(ub[i]) {
        return;
    }
    let drow = &mut diag[i];
    let (rot, rho) = rotation_nonneg_pivot(drow[i].real(), ub[i]);
    for k in i + 1..W {
        let (nr, ny) = rot.apply(drow[k], ub[k]);
        drow[k] = nr;
        ub[k] = ny;
    }
    drow[i] = F::from_real(rho);
    ub[i] = F::zero();
    *g *= rot.c;
    rotate_from(&rot, &mut coup[i], us, 0);
    let (np, ne) = rot.apply(pb[i], *e);
    pb[i] = np;
    *e = ne;
}

/// Pivot `i` of the shared part (nothing for `i >= S`): as [`block_step`]
/// with row `i` of `[R_s p_s]` and the working row `(us, e)`.
// index proven: `i < S` is checked first, and every array indexed by `i`
// or `k` has `S` entries.
#[allow(clippy::indexing_slicing)]
#[inline(always)]
fn shared_step<F, T, const S: usize>(
    i: usize,
    shared: &mut [[F; S]; S],
    ps: &mut [F; S],
    us: &mut [F; S],
    e: &mut F,
    g: &mut T,
) where
    F: ComplexField<RealField = T> + Copy,
    T: Real,
{
    if i >= S || is_zero(us[i]) {
        return;
    }
    let srow = &mut shared[i];
    let (rot, rho) = rotation_nonneg_pivot(srow[i].real(), us[i]);
    for k in i + 1..S {
        let (nr, ny) = rot.apply(srow[k], us[k]);
        srow[k] = nr;
        us[k] = ny;
    }
    srow[i] = F::from_real(rho);
    us[i] = F::zero();
    *g *= rot.c;
    let (np, ne) = rot.apply(ps[i], *e);
    ps[i] = np;
    *e = ne;
}

/// Owning, fixed-size Givens block QRD/RLS: `NB` blocks of `W` unknowns,
/// `S` shared unknowns, forgetting factor `lambda`, regularisation `delta`
/// ([`QrdRls::new`]); the counterpart of [`qrdrls::VectorQrdRls`] for the
/// block layout.
pub type BlockQrdRls<F, const NB: usize, const W: usize, const S: usize> =
    QrdRls<F, BlockFactor<F, NB, W, S>>;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::qrdrls::{init, update_rows};
    use crate::testrng::SplitMix64;
    use nalgebra::{DMatrix, DVector};
    use num_complex::Complex;
    use std::vec;
    use std::vec::Vec;

    /// Random block-structured rows: `n` rows over `shape`, row `j` in
    /// block `j % NB`, some entries exactly zero.
    fn rows<F: ComplexField<RealField = T> + Copy, T: Real>(
        rng: &mut SplitMix64,
        shape: &BlockShape,
        n: usize,
        mk: &dyn Fn(f64, f64) -> F,
    ) -> (Vec<F>, Vec<F>) {
        let m = shape.unknowns();
        let mut u = vec![F::zero(); n * m];
        let mut d = vec![F::zero(); n];
        for j in 0..n {
            let b = j % shape.blocks;
            for k in 0..m {
                let in_block = k >= b * shape.width && k < (b + 1) * shape.width;
                let shared = k >= shape.blocks * shape.width;
                let (a, c) = (rng.sym(), rng.sym());
                if (in_block || shared) && a.abs() > 0.1 {
                    u[j * m + k] = mk(a, c);
                }
            }
            d[j] = mk(rng.sym(), rng.sym());
        }
        (u, d)
    }

    /// Runs the block filter and the dense one on the same rows; returns
    /// (block factor as dense, block p, dense r, dense p, block w, dense w,
    /// xi/gamma of both).
    #[allow(clippy::type_complexity)]
    fn compare<F, T, const NB: usize, const W: usize, const S: usize>(
        n: usize,
        steps: usize,
        lambda: f64,
        mk: &dyn Fn(f64, f64) -> F,
    ) -> (Vec<F>, Vec<F>, Vec<F>, Vec<F>)
    where
        F: ComplexField<RealField = T> + Copy + PartialEq + core::fmt::Debug,
        T: Real,
    {
        let shape = BlockFactor::<F, NB, W, S>::SHAPE;
        let m = shape.unknowns();
        let mut rng = SplitMix64::new(0x5eed_0000 + (m * 31 + n) as u64);
        let mut blk = BlockQrdRls::<F, NB, W, S>::new(T::lit(lambda), T::lit(0.1)).unwrap();
        let (mut r, mut p) = (vec![F::zero(); m * m], vec![F::zero(); m]);
        init(&mut r, &mut p, T::lit(0.1), None).unwrap();
        let (mut xb, mut gb) = (vec![F::zero(); n], vec![T::zero(); n]);
        let (mut xd, mut gd) = (vec![F::zero(); n], vec![T::zero(); n]);
        let mut all_u = Vec::new();
        let mut all_d = Vec::new();
        for _ in 0..steps {
            let (u, d) = rows(&mut rng, &shape, n, mk);
            blk.update_rows(&u, &d, &mut xb, &mut gb).unwrap();
            update_rows(&mut r, &mut p, &u, &d, T::lit(lambda), &mut xd, &mut gd).unwrap();
            assert_eq!(xb, xd, "xi");
            assert_eq!(gb, gd, "gamma");
            all_u.extend_from_slice(&u);
            all_d.extend_from_slice(&d);
        }
        let (mut rb, mut pb) = (vec![F::zero(); m * m], vec![F::zero(); m]);
        blk.factor().view().to_dense(&mut rb, &mut pb).unwrap();
        // Stored entries equal to the last bit (-0 == 0).
        assert_eq!(rb, r, "factor");
        assert_eq!(pb, p, "p");
        let mut wb = vec![F::zero(); m];
        let mut wd = vec![F::zero(); m];
        blk.weights(&mut wb).unwrap();
        qrdrls::solve_weights(&r, &p, &mut wd).unwrap();
        assert_eq!(wb, wd, "weights");
        assert_eq!(
            blk.factor().view().diag_ratio(),
            qrdrls::r_diag_ratio(&r).unwrap()
        );
        (wb, all_u, all_d, vec![])
    }

    fn c64(a: f64, b: f64) -> Complex<f64> {
        Complex::new(a, b)
    }
    fn c32(a: f64, b: f64) -> Complex<f32> {
        Complex::new(a as f32, b as f32)
    }
    fn r64(a: f64, _: f64) -> f64 {
        a
    }
    fn r32(a: f64, _: f64) -> f32 {
        a as f32
    }

    #[test]
    fn equals_the_dense_filter_bit_for_bit() {
        // Paper structure order 1 and 2, physical order 1 (N_b = 2, N_p = 3),
        // N_b = 4, N_p = 5, no shared unknowns, one block.
        compare::<Complex<f64>, f64, 4, 4, 3>(4, 30, 0.97, &c64);
        compare::<Complex<f32>, f32, 4, 4, 3>(4, 30, 0.97, &c32);
        compare::<Complex<f64>, f64, 4, 6, 3>(4, 30, 1.0, &c64);
        compare::<f64, f64, 4, 4, 6>(8, 30, 0.99, &r64);
        compare::<f32, f32, 4, 4, 6>(8, 30, 0.99, &r32);
        compare::<f64, f64, 8, 4, 10>(16, 20, 0.99, &r64);
        compare::<Complex<f64>, f64, 8, 4, 5>(8, 20, 0.99, &c64);
        compare::<f64, f64, 3, 2, 0>(6, 10, 0.9, &r64);
        compare::<Complex<f32>, f32, 1, 5, 2>(3, 10, 0.9, &c32);
        // Blocks and shared part wider than the pivots written out one by
        // one (`UNROLL`): the remaining pivots take the loop.
        compare::<f64, f64, 2, 18, 17>(4, 10, 0.99, &r64);
        compare::<Complex<f32>, f32, 2, 17, 18>(2, 10, 0.99, &c32);
    }

    #[test]
    fn many_updates_equal_the_dense_filter() {
        // The identification layouts over a long run (every update, every
        // `xi_j`, `gamma_j` and the final factor compared exactly): N_b 4,
        // N_p 5 physical order 1 in f64, N_b 2, N_p 3 in f32 and the paper
        // structure in complex f64.
        compare::<f64, f64, 8, 4, 10>(16, 300, 0.99, &r64);
        compare::<f32, f32, 4, 4, 6>(8, 300, 0.99, &r32);
        compare::<Complex<f64>, f64, 4, 4, 3>(4, 300, 0.97, &c64);
    }

    /// Batch least squares of the stacked, weighted rows with the prior:
    /// `min delta lambda^n |w|^2 + sum lambda^(n-k) |d_k - U_k w|^2`.
    fn batch_c64(
        u: &[Complex<f64>],
        d: &[Complex<f64>],
        m: usize,
        n: usize,
        lambda: f64,
        delta: f64,
    ) -> DVector<Complex<f64>> {
        let rows = d.len();
        let steps = rows / n;
        let mut a = DMatrix::<Complex<f64>>::zeros(rows + m, m);
        let mut b = DVector::<Complex<f64>>::zeros(rows + m);
        for j in 0..rows {
            let age = (steps - 1 - j / n) as i32;
            let s = lambda.powi(age).sqrt();
            for k in 0..m {
                a[(j, k)] = u[j * m + k] * s;
            }
            b[j] = d[j] * s;
        }
        let prior = (delta * lambda.powi(steps as i32)).sqrt();
        for k in 0..m {
            a[(rows + k, k)] = Complex::new(prior, 0.0);
        }
        a.svd(true, true).solve(&b, 1e-300).unwrap()
    }

    #[test]
    fn agrees_with_batch_least_squares() {
        let (w, u, d, _) = compare::<Complex<f64>, f64, 4, 4, 3>(4, 12, 0.97, &c64);
        let x = batch_c64(&u, &d, 19, 4, 0.97, 0.1);
        let scale = x.iter().map(|z| z.norm()).fold(0.0, f64::max);
        for (a, b) in w.iter().zip(x.iter()) {
            assert!((a - b).norm() <= 1e-10 * scale, "{a} {b}");
        }
        // Real f32 against an f64 batch solve of the same (f32) data.
        let (w, u, d, _) = compare::<f32, f32, 4, 4, 6>(8, 12, 0.99, &r32);
        let uc: Vec<Complex<f64>> = u.iter().map(|x| Complex::new(*x as f64, 0.0)).collect();
        let dc: Vec<Complex<f64>> = d.iter().map(|x| Complex::new(*x as f64, 0.0)).collect();
        let x = batch_c64(&uc, &dc, 22, 8, 0.99, 0.1);
        let scale = x.iter().map(|z| z.norm()).fold(0.0, f64::max);
        for (a, b) in w.iter().zip(x.iter()) {
            assert!((*a as f64 - b.re).abs() <= 2e-4 * scale, "{a} {b}");
        }
    }

    #[test]
    fn bad_input_leaves_the_state_unchanged() {
        let mut f = BlockQrdRls::<Complex<f64>, 2, 2, 1>::new(0.9, 1.0).unwrap();
        let shape = BlockFactor::<Complex<f64>, 2, 2, 1>::SHAPE;
        let mut rng = SplitMix64::new(7);
        let (u, d) = rows(&mut rng, &shape, 2, &c64);
        let (mut xi, mut g) = ([c64(0.0, 0.0); 2], [0.0; 2]);
        f.update_rows(&u, &d, &mut xi, &mut g).unwrap();
        let before = f.clone();
        let mut bad = u.clone();
        bad[0].re = f64::NAN;
        assert_eq!(
            f.update_rows(&bad, &d, &mut xi, &mut g),
            Err(FilterError::NonFinite)
        );
        let mut bad = u.clone();
        bad[4].im = f64::INFINITY;
        assert_eq!(
            f.update_rows(&bad, &d, &mut xi, &mut g),
            Err(FilterError::NonFinite)
        );
        let mut bad_d = d.clone();
        bad_d[1] = c64(1e200, 0.0);
        assert_eq!(
            f.update_rows(&u, &bad_d, &mut xi, &mut g),
            Err(FilterError::OutOfRange)
        );
        // A row touching blocks 0 and 1.
        let mut two = u.clone();
        two[0] = c64(1.0, 0.0);
        two[2] = c64(1.0, 0.0);
        assert_eq!(
            f.update_rows(&two, &d, &mut xi, &mut g),
            Err(FilterError::Dimension)
        );
        assert_eq!(
            f.update_rows(&u[..9], &d, &mut xi, &mut g),
            Err(FilterError::Dimension)
        );
        let mut fac = f.factor().clone();
        assert_eq!(
            fac.update_rows(&u, &d, 1.5, &mut xi, &mut g),
            Err(FilterError::InvalidLambda)
        );
        assert_eq!(&fac, f.factor());
        assert_eq!(f, before);
        assert_eq!(
            BlockQrdRls::<f32, 2, 2, 1>::new(0.0, 1.0).unwrap_err(),
            FilterError::InvalidLambda
        );
        assert_eq!(
            BlockQrdRls::<f32, 2, 2, 1>::new(1.0, f32::NAN).unwrap_err(),
            FilterError::InvalidDelta
        );
        // A zero row: identity rotations, gamma 1, xi = d.
        let z = [c64(0.0, 0.0); 5];
        let (mut xi1, mut g1) = ([c64(0.0, 0.0); 1], [0.0; 1]);
        let f0 = BlockQrdRls::<Complex<f64>, 2, 2, 1>::new(1.0, 1.0).unwrap();
        let mut f1 = f0.clone();
        f1.update_rows(&z, &[c64(2.0, 1.0)], &mut xi1, &mut g1)
            .unwrap();
        assert_eq!((xi1[0], g1[0]), (c64(2.0, 1.0), 1.0));
        assert_eq!(f1, f0);
    }

    #[test]
    fn shape_of_the_identification_structures() {
        let s = BlockShape::of(Structure::physical(1), 2, 3);
        assert_eq!((s.blocks, s.width, s.shared, s.unknowns()), (4, 4, 6, 22));
        let s = BlockShape::of(Structure::paper(1), 2, 3);
        assert_eq!((s.blocks, s.width, s.shared, s.unknowns()), (4, 4, 3, 19));
        let s = BlockShape::of(Structure::paper(2), 4, 5);
        assert_eq!((s.blocks, s.width, s.shared, s.unknowns()), (8, 6, 5, 53));
        for st in [Structure::paper(1), Structure::physical(2)] {
            let s = BlockShape::of(st, 3, 2);
            assert_eq!(s.unknowns(), st.n_unknowns(3, 2));
        }
        assert_eq!(core::mem::size_of::<BlockFactor<f32, 4, 4, 6>>(), 872);
    }
}
