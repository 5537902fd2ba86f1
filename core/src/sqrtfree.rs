//! Square-root-free block-structured QRD/RLS: the filter of
//! [`crate::blockqrd`] with Gentleman's scaled rotations, which need no
//! square root, one division per rotation, and about two thirds of the
//! arithmetic per rotated pair.
//!
//! # Representation
//!
//! The triangular factor `R` of `Phi = R^H R` (same block-arrowhead layout
//! as [`crate::blockqrd`]) is held as
//!
//! ```text
//!     R = D^(1/2) U,    p = D^(1/2) q,
//! ```
//!
//! `D = diag(d_1 .. d_M)` real and non-negative (`d_i = R_ii^2`), `U` unit
//! upper triangular, `q` the scaled right-hand side. Forgetting,
//! `[R p] <- sqrt(lambda) [R p]`, is `d <- lambda d` (`M` entries, `U` and
//! `q` unchanged), and the weights solve `U w = q` (no division).
//!
//! # One rotation (Gentleman 1973)
//!
//! The working row is `y = sqrt(delta) x` with a real weight `delta`
//! (`delta = 1` for a new row). The Givens rotation of [`crate::givens`]
//! that zeroes `y_i` against row `i` of `R` (`rho^2 = d_i + delta |x_i|^2`,
//! `c = sqrt(d_i) / rho`, `s = sqrt(delta) x_i^* / rho`) becomes, for every
//! entry `k` right of the pivot and the right-hand side,
//!
//! ```text
//!     d_i'   = d_i + delta |x_i|^2,
//!     sbar   = delta x_i^* / d_i',            delta' = delta d_i / d_i',
//!     x_k'   = x_k - x_i u_ik,                u_ik'  = u_ik + sbar x_k',
//! ```
//!
//! which is exactly `R' = D'^(1/2) U'` and `y' = sqrt(delta') x'`:
//! `c r_k + s y_k = (d_i u_ik + delta x_i^* x_k) / rho = rho u_ik'` and
//! `-s^* r_k + c y_k = sqrt(delta d_i) (x_k - x_i u_ik) / rho
//! = sqrt(delta') x_k'`. After the row is folded in, `delta` is the product
//! of the `c^2`, the conversion factor `gamma_j`, and the right-hand side
//! entry of the working row is the a-priori error `alpha_j`: the
//! a-posteriori error is `xi_j = gamma_j alpha_j`, as the Givens filters
//! return it.
//!
//! # Cost and agreement
//!
//! Per rotated pair: `x_k - x_i u_ik` and `u_ik + sbar x_k'`, two
//! multiply-adds (real data; eight real multiplications in complex data)
//! against the four multiplications and two additions of a Givens rotation
//! with real cosine; per rotation one division and no square root;
//! forgetting touches `M` entries instead of the whole factor. The numbers
//! are not the Givens filters' to the last bit: they agree to round-off
//! (tests: `R = D^(1/2) U`, `p`, `xi_j`, `gamma_j` and the weights within
//! `1e-12` relative of the dense filter in `f64` after hundreds of updates
//! with forgetting, and within `f32` round-off in `f32`).
//!
//! # Input range
//!
//! The squares `d_i` and `delta |x_i|^2` are formed directly, and entries
//! of `U` are ratios `R_ik / R_ii`: a factor whose diagonal spans many
//! decades (a long-unexcited direction under forgetting) makes them, and
//! the working row `x = y / sqrt(delta)`, large, where the Givens filters'
//! entries stay bounded by the data's column norms. No bound on the
//! entries keeps every update finite, so none is imposed: entries must be
//! finite, and an update whose result would not be finite at the precision
//! is undone and reported. Each update keeps a copy of the state, folds its
//! rows, and checks that every stored entry (and, for compact rows, every
//! returned `xi_j`, `gamma_j`) is finite; otherwise it puts the copy back
//! and returns `NonFinite` if an input was not finite, `OutOfRange` if the
//! arithmetic left the range. A non-finite input cannot pass unseen: every
//! entry of a row is the pivot entry of some rotation, where it makes `d_i`
//! non-finite, and a non-finite right-hand side reaches `q` or `xi_j`. The
//! Givens filters of [`crate::blockqrd`] and [`crate::qrdrls`] remain the
//! range-safe reference and the desktop driver's filter; this one is the
//! fast update for scaled regressions (the identification's unknowns are
//! scaled to order one, [`crate::scaling`]) and the filter of the
//! generated firmware identifier (`type Id` of `rotorid tables`).
//!
//! Rows of `M` entries are checked before anything is written, as in
//! [`crate::blockqrd`] (lengths, forgetting factor, finiteness, one block
//! per row); compact rows are checked for lengths, block indices and
//! forgetting factor first, for finiteness by the check after the fold
//! (a rejected update changes nothing either way).
//!
//! # Rows
//!
//! [`SqrtFreeFactor::update_rows`] takes rows of `M` entries as the other
//! filters (each non-zero in one block and the shared columns, checked);
//! [`SqrtFreeFactor::update_grouped_rows`] rows of `M` entries in the block
//! layout's groups (the identification's rows: each row's block and shared
//! entries are read where they lie, nothing else is looked at). With the
//! feature `compact-rows`, `update_block_rows` takes the structure instead:
//! the block of each row, its `W` block entries and its `S` shared entries,
//! so that nothing scans or stores the structural zeros (what the benches
//! and the `sqrtfree_update` fuzz target drive; the identifier does not use
//! it).
//!
//! # Example
//!
//! ```
//! use rotorid_core::sqrtfree::SqrtFreeQrdRls;
//!
//! // 2 blocks of 2 unknowns and 1 shared unknown: M = 5, real field.
//! let mut f = SqrtFreeQrdRls::<f64, 2, 2, 1>::new(1.0, 1e-12)?;
//! let w = [1.0, -2.0, 0.5, 3.0, 4.0];
//! // Rows grouped by block: two rows in block 0, then two in block 1,
//! // each with the shared column.
//! let u = [
//!     1.0, 0.5, 0.0, 0.0, 1.0, //
//!     0.0, 2.0, 0.0, 0.0, -1.0, //
//!     0.0, 0.0, 1.0, 1.0, 0.5, //
//!     0.0, 0.0, -1.0, 2.0, 2.0,
//! ];
//! let d: Vec<f64> = u.chunks(5).map(|r| r.iter().zip(&w).map(|(a, b)| a * b).sum()).collect();
//! let (mut xi, mut gamma) = ([0.0; 4], [0.0; 4]);
//! f.update_grouped_rows(&u, &d, &mut xi, &mut gamma)?;
//! f.update_rows(&[0.0, 0.0, 0.0, 0.0, 3.0], &[12.0], &mut xi[..1], &mut gamma[..1])?;
//! let mut est = [0.0; 5];
//! f.weights(&mut est)?;
//! assert!(est.iter().zip(&w).all(|(a, b)| (a - b).abs() < 1e-9));
//! # Ok::<(), rotorid_core::qrdrls::FilterError>(())
//! ```

use crate::blockqrd::{block_of_fixed, BlockFactor, BlockShape, BLOCKS_KEPT};
use crate::factor::QrdRls;
use crate::givens::min_normal;
use crate::qrdrls::{self, FilterError};
use crate::Real;
use nalgebra::ComplexField;

/// The square-root-free factor `R = D^(1/2) U`, `p = D^(1/2) q` of the
/// block-arrowhead layout `(NB, W, S)` (see the module documentation).
///
/// Stored: the squared diagonals `d` of each block and of the shared part,
/// the strictly upper entries of `U` (the `W x W` blocks and the `S x S`
/// shared part keep their diagonal slots at zero, the unit diagonal is
/// implied), the coupling blocks `D_b^(-1/2) C_b`, and `q`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SqrtFreeFactor<F: ComplexField, const NB: usize, const W: usize, const S: usize> {
    db: [[F::RealField; W]; NB],
    ub: [[[F; W]; W]; NB],
    coupling: [[[F; S]; W]; NB],
    ds: [F::RealField; S],
    us: [[F; S]; S],
    qb: [[F; W]; NB],
    qs: [F; S],
}

impl<F, T, const NB: usize, const W: usize, const S: usize> SqrtFreeFactor<F, NB, W, S>
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

    /// The initial factor `R = sqrt(delta) I`, `p = 0`: `d_i = delta`,
    /// `U = I`, `q = 0`.
    pub fn new(delta: T) -> Self {
        const { assert!(NB > 0 && W > 0, "SqrtFreeFactor: NB and W must be > 0") };
        SqrtFreeFactor {
            db: [[delta; W]; NB],
            ub: [[[F::zero(); W]; W]; NB],
            coupling: [[[F::zero(); S]; W]; NB],
            ds: [delta; S],
            us: [[F::zero(); S]; S],
            qb: [[F::zero(); W]; NB],
            qs: [F::zero(); S],
        }
    }

    /// `d <- lambda d`: forgetting, `[R p] <- sqrt(lambda) [R p]`.
    fn forget(&mut self, lambda: T) {
        self.db
            .as_flattened_mut()
            .iter_mut()
            .chain(self.ds.iter_mut())
            .for_each(|d| *d *= lambda);
    }

    /// Folds the row with block entries `xb` in block `b < NB`, shared
    /// entries `xs` and right-hand side `e`, with the pivots written out
    /// (as [`crate::blockqrd`]'s fixed-size kernel: every index and loop
    /// bound a constant, the working row in registers). Returns
    /// `(xi, gamma)`.
    ///
    /// Not inlined into `update_block_rows`: in its row loop the
    /// loop's own values take the registers of the working row, which
    /// then spills (4.59k against 3.90k instructions per update on the
    /// `f32` flight-solver problem, `(4, 4, 6)` with 8 rows).
    ///
    /// Rows are folded one at a time. Folding two rows pivot by pivot
    /// (row 1's rotation and then row 2's on each row of the factor,
    /// loaded and stored once for both; the same arithmetic) measured
    /// worse on x86-64: 4.24k instructions per update with every pivot
    /// paired, 4.11k with the shared pivots only, against 3.90k; the two
    /// working rows do not fit the vector registers and spill.
    #[inline(never)]
    fn fold_row(&mut self, b: usize, row_b: &[F; W], row_s: &[F; S], e: F) -> (F, T) {
        // A local copy, so that the working row stays in registers.
        let mut r = Working::new(row_b, row_s, e);
        self.fold_block(b, &mut r);
        self.fold_shared(&mut r);
        r.result()
    }

    /// The block pivots of [`Self::fold_row`]: folds the working row `r`
    /// into block `b < NB`.
    // index proven: `b < NB` is checked by every caller.
    #[allow(clippy::indexing_slicing)]
    #[inline(always)]
    fn fold_block(&mut self, b: usize, r: &mut Working<F, T, W, S>) {
        let (db, ub, coup, qb) = (
            &mut self.db[b],
            &mut self.ub[b],
            &mut self.coupling[b],
            &mut self.qb[b],
        );
        macro_rules! block_steps {
            ($($i:literal)*) => {
                $(block_step($i, db, ub, coup, qb, r);)*
            };
        }
        block_steps!(0 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15);
        for i in UNROLL..W {
            block_step(i, db, ub, coup, qb, r);
        }
    }

    /// The shared pivots of [`Self::fold_row`]: folds the working row `r`
    /// into the shared part.
    #[inline(always)]
    fn fold_shared(&mut self, r: &mut Working<F, T, W, S>) {
        let (ds, us, qs) = (&mut self.ds, &mut self.us, &mut self.qs);
        macro_rules! shared_steps {
            ($($i:literal)*) => {
                $(shared_step($i, ds, us, qs, r);)*
            };
        }
        shared_steps!(0 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15);
        for i in UNROLL..S {
            shared_step(i, ds, us, qs, r);
        }
    }

    /// All zero (`d = 0`: no information; see [`Self::init`]).
    pub fn zeroed() -> Self {
        Self::new(T::zero())
    }

    /// Resets to `R = sqrt(delta) I`, `p = 0`.
    ///
    /// Errors (state untouched): `InvalidDelta` (`delta` not in
    /// `(0, sqrt(T::MAX)]`).
    pub fn init(&mut self, delta: T) -> Result<(), FilterError> {
        qrdrls::validate_delta(delta)?;
        // The state of `new(delta)`, written in place (no temporary of the
        // whole factor on the stack).
        self.db.as_flattened_mut().fill(delta);
        self.ub
            .as_flattened_mut()
            .as_flattened_mut()
            .fill(F::zero());
        self.coupling
            .as_flattened_mut()
            .as_flattened_mut()
            .fill(F::zero());
        self.ds.fill(delta);
        self.us.as_flattened_mut().fill(F::zero());
        self.qb.as_flattened_mut().fill(F::zero());
        self.qs.fill(F::zero());
        Ok(())
    }

    /// One update with `N = d.len()` rows of `M = NB W + S` entries in `u`
    /// (row-major), each non-zero in one block and the shared columns, as
    /// [`crate::blockqrd::BlockFactor::update_rows`], with forgetting
    /// factor `lambda` for this step; writes the a-posteriori errors `xi`
    /// and conversion factors `gamma`.
    ///
    /// Errors (state untouched): `Dimension` (lengths, or a row with
    /// non-zeros in two blocks), `InvalidLambda`, `NonFinite` (an entry),
    /// `OutOfRange` (an update whose result would not be finite at the
    /// precision, see the module documentation).
    pub fn update_rows(
        &mut self,
        u: &[F],
        d: &[F],
        lambda: T,
        xi: &mut [F],
        gamma: &mut [T],
    ) -> Result<(), FilterError> {
        let m = Self::SHAPE.unknowns();
        let mut blocks = [u16::MAX; BLOCKS_KEPT];
        let max = T::max_value().unwrap_or_else(T::one);
        BlockFactor::<F, NB, W, S>::validate(u, d, lambda, xi, gamma, &mut blocks, max)?;
        let saved = self.begin(lambda);
        let rows = u.chunks_exact(m).zip(d).zip(xi).zip(gamma);
        for (j, (((row, &dj), xj), gj)) in rows.enumerate() {
            let b = match blocks.get(j) {
                Some(&b) if b != u16::MAX => usize::from(b),
                _ => block_of_fixed::<F, T, NB, W>(row).unwrap_or(0),
            };
            // The working row built in place and folded here (inlined:
            // 4.62k against 4.75k instructions per update with
            // `fold_row`, `f32` flight-solver problem).
            let mut r = Working {
                xb: [F::zero(); W],
                xs: [F::zero(); S],
                e: dj,
                delta: T::one(),
            };
            if let (Some(a), Some(c)) = (row.get(b * W..(b + 1) * W), row.get(NB * W..m)) {
                r.xb.copy_from_slice(a);
                r.xs.copy_from_slice(c);
            }
            self.fold_block(b.min(NB - 1), &mut r);
            self.fold_shared(&mut r);
            (*xj, *gj) = r.result();
        }
        self.commit_or_restore(&saved, true)
    }

    /// One update with `N = d.len()` rows given by their structure: row `j`
    /// lies in block `blocks[j] < NB`, with block entries
    /// `a[j W .. (j + 1) W]` and shared entries `c[j S .. (j + 1) S]`
    /// (the row of `M` entries is zero elsewhere), forgetting factor
    /// `lambda` for this step. Nothing scans the zeros.
    ///
    /// Errors (state untouched): `Dimension` (lengths, or a block index
    /// `>= NB`), `InvalidLambda`, `NonFinite` (an entry), `OutOfRange` (an
    /// update whose result would not be finite at the precision). Entries
    /// are checked for finiteness after the fold, by the same check as its
    /// result (module documentation).
    ///
    /// Feature `compact-rows`: for callers that hold their rows in this
    /// form (the benches and the `sqrtfree_update` fuzz target); the
    /// identifier hands its rows to [`Self::update_grouped_rows`].
    #[cfg(feature = "compact-rows")]
    #[allow(clippy::too_many_arguments)]
    pub fn update_block_rows(
        &mut self,
        blocks: &[usize],
        a: &[F],
        c: &[F],
        d: &[F],
        lambda: T,
        xi: &mut [F],
        gamma: &mut [T],
    ) -> Result<(), FilterError> {
        let n = d.len();
        if blocks.len() != n
            || n.checked_mul(W) != Some(a.len())
            || n.checked_mul(S) != Some(c.len())
            || xi.len() != n
            || gamma.len() != n
            || blocks.iter().any(|&b| b >= NB)
        {
            return Err(FilterError::Dimension);
        }
        qrdrls::validate_lambda(lambda)?;
        let saved = self.begin(lambda);
        // Rows of `c` by chunks (`chunks_exact(0)` would panic: with `S = 0`
        // every row's shared part is the empty array).
        let mut cs = c.chunks_exact(S.max(1));
        let rows = blocks
            .iter()
            .zip(d)
            .zip(a.chunks_exact(W))
            .zip(xi.iter_mut().zip(gamma.iter_mut()));
        for (((&b, &dj), aj), (xj, gj)) in rows {
            let cj = if S == 0 { Some(&[][..]) } else { cs.next() };
            let (Ok(aj), Some(Ok(cj))) = (<&[F; W]>::try_from(aj), cj.map(<&[F; S]>::try_from))
            else {
                continue;
            };
            (*xj, *gj) = self.fold_row(b.min(NB - 1), aj, cj, dj);
        }
        self.commit_unchecked(&saved, xi, gamma, || {
            a.iter().chain(c).chain(d).all(|x| x.is_finite())
        })
    }

    /// One update with `N = d.len()` rows of `M` entries whose structure
    /// the caller guarantees: the rows come in `NB` consecutive groups of
    /// `N / NB`, the rows of group `b` lie in block `b` (the
    /// identification's rows: one group per channel, [`crate::regressor`]),
    /// and only each row's block entries `u[j M + b W .. j M + (b + 1) W]`
    /// and shared entries `u[j M + NB W .. (j + 1) M]` are read; the rest of
    /// the row is taken as zero without a look. The rows' compact form
    /// (`update_block_rows`) without copying them out: the cost of
    /// compact rows where the caller has rows of `M` entries.
    ///
    /// Errors (state untouched): `Dimension` (lengths, or `N` not a
    /// multiple of `NB`), `InvalidLambda`, `NonFinite` (an entry read),
    /// `OutOfRange` (as `update_block_rows`, whose finiteness check
    /// this is).
    pub fn update_grouped_rows(
        &mut self,
        u: &[F],
        d: &[F],
        lambda: T,
        xi: &mut [F],
        gamma: &mut [T],
    ) -> Result<(), FilterError> {
        let m = Self::SHAPE.unknowns();
        let n = d.len();
        if n % NB != 0 || n.checked_mul(m) != Some(u.len()) || xi.len() != n || gamma.len() != n {
            return Err(FilterError::Dimension);
        }
        qrdrls::validate_lambda(lambda)?;
        let saved = self.begin(lambda);
        let per_block = (n / NB).max(1);
        let groups = u
            .chunks_exact(per_block * m)
            .zip(d.chunks_exact(per_block))
            .zip(
                xi.chunks_exact_mut(per_block)
                    .zip(gamma.chunks_exact_mut(per_block)),
            );
        for (b, ((ug, dg), (xg, gg))) in groups.enumerate() {
            let b = b.min(NB - 1);
            let rows = ug
                .chunks_exact(m)
                .zip(dg)
                .zip(xg.iter_mut().zip(gg.iter_mut()));
            for ((row, &dj), (xj, gj)) in rows {
                let (Some(Ok(aj)), Some(Ok(cj))) = (
                    row.get(b * W..(b + 1) * W).map(<&[F; W]>::try_from),
                    row.get(NB * W..m).map(<&[F; S]>::try_from),
                ) else {
                    continue;
                };
                (*xj, *gj) = self.fold_row(b, aj, cj, dj);
            }
        }
        self.commit_unchecked(&saved, xi, gamma, || {
            u.iter().chain(d).all(|x| x.is_finite())
        })
    }

    /// Starts an update: a copy of the state (for [`Self::commit_or_restore`]),
    /// then forgetting by `lambda`.
    #[inline(always)]
    fn begin(&mut self, lambda: T) -> Self {
        let saved = *self;
        if lambda != T::one() {
            self.forget(lambda);
        }
        saved
    }

    /// Ends an update whose entries were not checked before the fold
    /// (compact and grouped rows): [`Self::commit_or_restore`] with the
    /// outputs `xi`, `gamma` in the check; a rejected update is `NonFinite`
    /// if `inputs_finite()` says an entry read was not finite, else
    /// `OutOfRange`.
    #[inline(always)]
    fn commit_unchecked(
        &mut self,
        saved: &Self,
        xi: &[F],
        gamma: &[T],
        inputs_finite: impl FnOnce() -> bool,
    ) -> Result<(), FilterError> {
        let out = all_finite(xi) & all_finite_real(gamma);
        self.commit_or_restore(saved, out).map_err(|e| {
            if inputs_finite() {
                e
            } else {
                FilterError::NonFinite
            }
        })
    }

    /// Ends an update: keeps it if `ok` (the caller's outputs are finite)
    /// and every stored entry is finite, else puts `saved` (the state
    /// before the update) back and reports `OutOfRange`. Squares and
    /// ratios of finite data can leave the type's range here (entries of
    /// `U` are `R_ik / R_ii`, the working row is the Givens row over
    /// `sqrt(delta)`), where the Givens filters' entries stay bounded by
    /// the data's column norms; the check makes such
    /// an update an error that changes nothing (found by the
    /// `sqrtfree_update` fuzz target: rows of `1e-20` in `f32`, whose
    /// squares are subnormal, after forgetting had flushed `d` to zero).
    fn commit_or_restore(&mut self, saved: &Self, ok: bool) -> Result<(), FilterError> {
        if ok & self.is_finite() {
            Ok(())
        } else {
            *self = *saved;
            Err(FilterError::OutOfRange)
        }
    }

    /// Whether every stored entry (`D`, `U`, `D^(-1/2) C`, `q`) is finite:
    /// true after every accepted update (the check that ends one).
    #[inline(always)]
    pub fn is_finite(&self) -> bool {
        all_finite_real(self.db.as_flattened())
            & all_finite_real(&self.ds)
            & all_finite(self.ub.as_flattened().as_flattened())
            & all_finite(self.coupling.as_flattened().as_flattened())
            & all_finite(self.us.as_flattened())
            & all_finite(self.qb.as_flattened())
            & all_finite(&self.qs)
    }

    /// Back-substitution `U w = q` (`w` has `M` entries, block-then-shared
    /// order): `w_s` from the shared part, then each block,
    /// `w_b = q_b - U_b^strict w_b - (D_b^(-1/2) C_b) w_s`.
    ///
    /// Errors: `Dimension` (length of `w`); `Singular` if some `d_i` is
    /// below the smallest normal number (a direction without information)
    /// or a weight is not finite.
    // index proven: `i < S` (`W`) in arrays of `S` (`W`) entries.
    #[allow(clippy::indexing_slicing)]
    pub fn solve_weights(&self, w: &mut [F]) -> Result<(), FilterError> {
        if w.len() != Self::SHAPE.unknowns() {
            return Err(FilterError::Dimension);
        }
        let tiny = min_normal::<T>();
        let regular = |d: &T| d.is_finite() && *d >= tiny;
        if !self.db.as_flattened().iter().chain(&self.ds).all(regular) {
            return Err(FilterError::Singular);
        }
        let (wb_all, ws) = w.split_at_mut(NB * W);
        for i in (0..S).rev() {
            let mut acc = self.qs[i];
            for (u, wk) in self.us[i].iter().zip(ws.iter()).skip(i + 1) {
                acc -= *u * *wk;
            }
            ws[i] = acc;
        }
        for (b, wb) in wb_all.chunks_exact_mut(W).enumerate() {
            for i in (0..W).rev() {
                let mut acc = self.qb[b][i];
                for (u, wk) in self.ub[b][i].iter().zip(wb.iter()).skip(i + 1) {
                    acc -= *u * *wk;
                }
                for (c, wk) in self.coupling[b][i].iter().zip(ws.iter()) {
                    acc -= *c * *wk;
                }
                wb[i] = acc;
            }
        }
        if w.iter().all(|x| x.is_finite()) {
            Ok(())
        } else {
            Err(FilterError::Singular)
        }
    }

    /// The same factor in the Givens filters' form, `R = D^(1/2) U`,
    /// `p = D^(1/2) q`, written into `out` (for the readers of a
    /// [`BlockFactor`]: covariance, conditioning, the dense form).
    ///
    /// Errors: `OutOfRange` if an entry of the Givens form is not finite
    /// at the precision (`out` is written all the same). The stored
    /// factor is always finite, but a product `d_i^(1/2) q_i` can exceed
    /// `T::MAX` where `q_i` alone does not (in `f32`, `d_i = 6.3e4` and
    /// `q_i = -1.4e36`, found by the `sqrtfree_update` fuzz target).
    // index proven: `b < NB`, `i, k < W` or `< S`.
    #[allow(clippy::indexing_slicing)]
    pub fn to_block(&self, out: &mut BlockFactor<F, NB, W, S>) -> Result<(), FilterError> {
        for b in 0..NB {
            for i in 0..W {
                let r = self.db[b][i].sqrt();
                for k in 0..W {
                    out.diag[b][i][k] = if k == i {
                        F::from_real(r)
                    } else if k > i {
                        self.ub[b][i][k].scale(r)
                    } else {
                        F::zero()
                    };
                }
                for k in 0..S {
                    out.coupling[b][i][k] = self.coupling[b][i][k].scale(r);
                }
                out.pb[b][i] = self.qb[b][i].scale(r);
            }
        }
        for i in 0..S {
            let r = self.ds[i].sqrt();
            for k in 0..S {
                out.shared[i][k] = if k == i {
                    F::from_real(r)
                } else if k > i {
                    self.us[i][k].scale(r)
                } else {
                    F::zero()
                };
            }
            out.ps[i] = self.qs[i].scale(r);
        }
        let v = out.view();
        let finite = all_finite(v.diag)
            & all_finite(v.coupling)
            & all_finite(v.shared)
            & all_finite(v.pb)
            & all_finite(v.ps);
        if finite {
            Ok(())
        } else {
            Err(FilterError::OutOfRange)
        }
    }

    /// Conditioning indicator `min_i |R_ii| / max_i |R_ii|`
    /// `= sqrt(min d / max d)`, as [`crate::blockqrd::BlockRef::diag_ratio`].
    pub fn diag_ratio(&self) -> T {
        let all = || self.db.as_flattened().iter().chain(&self.ds).copied();
        let lo = all().fold(T::max_value().unwrap_or_else(T::one), |a, d| a.min(d));
        let hi = all().fold(T::zero(), |a, d| a.max(d));
        if hi > T::zero() && hi.is_finite() {
            (lo / hi).sqrt()
        } else {
            T::zero()
        }
    }
}

/// Number of pivots written out one by one in [`SqrtFreeFactor`]'s kernel.
const UNROLL: usize = 16;

/// Whether every entry of `xs` is finite: `|x| <= T::MAX` (false for NaN
/// and the infinities), folded without branches so that it vectorises.
#[inline(always)]
fn all_finite_real<T: Real>(xs: &[T]) -> bool {
    let max = T::max_value().unwrap_or_else(T::one);
    xs.iter().fold(true, |ok, x| ok & (x.abs() <= max))
}

/// [`all_finite_real`] for field entries (real and imaginary parts).
#[inline(always)]
fn all_finite<F, T>(xs: &[F]) -> bool
where
    F: ComplexField<RealField = T> + Copy,
    T: Real,
{
    let max = T::max_value().unwrap_or_else(T::one);
    xs.iter().fold(true, |ok, x| {
        ok & (x.real().abs() <= max) & (x.imaginary().abs() <= max)
    })
}

/// The working row `sqrt(delta) (xb, xs, e)` of one fold: block entries,
/// shared entries, right-hand side and weight.
#[derive(Clone, Copy)]
struct Working<F, T, const W: usize, const S: usize> {
    xb: [F; W],
    xs: [F; S],
    e: F,
    delta: T,
}

impl<F, T, const W: usize, const S: usize> Working<F, T, W, S>
where
    F: ComplexField<RealField = T> + Copy,
    T: Real,
{
    /// A new row `(xb, xs, e)` of weight `delta = 1`.
    #[inline(always)]
    fn new(xb: &[F; W], xs: &[F; S], e: F) -> Self {
        Working {
            xb: *xb,
            xs: *xs,
            e,
            delta: T::one(),
        }
    }

    /// After the fold: `(xi, gamma) = (delta alpha, delta)`, `alpha` the
    /// right-hand side entry left in the row.
    #[inline(always)]
    fn result(&self) -> (F, T) {
        (self.e.scale(self.delta), self.delta)
    }
}

/// One rotated pair of a scaled rotation with pivot entry `xi` and
/// `sbar` (module documentation): `x <- x' = x - xi u`,
/// `u <- u + sbar x'`.
#[inline(always)]
fn rotate<F: ComplexField + Copy>(u: &mut F, x: &mut F, xi: F, sbar: F) {
    let t = *x - xi * *u;
    *u += sbar * t;
    *x = t;
}

/// Pivot `i` of the block part (nothing for `i >= W`): the scaled
/// rotation of row `i` of `[D_b^(1/2) (U_b, D_b^(-1/2) C_b, q_b)]` with
/// the working row `r` (module documentation). A zero `d_i'` (no
/// information in row `i` and a working row of weight zero) is skipped.
// index proven: `i < W` is checked first.
#[allow(clippy::indexing_slicing)]
#[inline(always)]
fn block_step<F, T, const W: usize, const S: usize>(
    i: usize,
    db: &mut [T; W],
    ub: &mut [[F; W]; W],
    coup: &mut [[F; S]; W],
    qb: &mut [F; W],
    r: &mut Working<F, T, W, S>,
) where
    F: ComplexField<RealField = T> + Copy,
    T: Real,
{
    if i >= W {
        return;
    }
    let xi = r.xb[i];
    if let Some(sbar) = pivot(&mut db[i], xi, &mut r.delta) {
        block_rotation(i, &mut ub[i], &mut coup[i], &mut qb[i], r, xi, sbar);
    }
}

/// The entries of block pivot `i < W` right of the pivot: [`rotate`] on
/// `(urow_k, x_k)` for `k > i`, on the coupling row against `xs`, and on
/// `(q_i, e)`.
// index proven: `k < W` (`S`) in arrays of `W` (`S`) entries.
#[allow(clippy::indexing_slicing)]
#[inline(always)]
fn block_rotation<F, T, const W: usize, const S: usize>(
    i: usize,
    urow: &mut [F; W],
    crow: &mut [F; S],
    q: &mut F,
    r: &mut Working<F, T, W, S>,
    xi: F,
    sbar: F,
) where
    F: ComplexField<RealField = T> + Copy,
    T: Real,
{
    let (xb, xs) = (&mut r.xb, &mut r.xs);
    for k in i + 1..W {
        rotate(&mut urow[k], &mut xb[k], xi, sbar);
    }
    for k in 0..S {
        rotate(&mut crow[k], &mut xs[k], xi, sbar);
    }
    rotate(q, &mut r.e, xi, sbar);
}

/// Pivot `i` of the shared part (nothing for `i >= S`): as [`block_step`]
/// with row `i` of `[D_s^(1/2) (U_s, q_s)]` and the working row
/// `sqrt(delta) (xs, e)`.
// index proven: `i < S` is checked first.
#[allow(clippy::indexing_slicing)]
#[inline(always)]
fn shared_step<F, T, const W: usize, const S: usize>(
    i: usize,
    ds: &mut [T; S],
    us: &mut [[F; S]; S],
    qs: &mut [F; S],
    r: &mut Working<F, T, W, S>,
) where
    F: ComplexField<RealField = T> + Copy,
    T: Real,
{
    if i >= S {
        return;
    }
    let xi = r.xs[i];
    if let Some(sbar) = pivot(&mut ds[i], xi, &mut r.delta) {
        shared_rotation(i, &mut us[i], &mut qs[i], r, xi, sbar);
    }
}

/// The entries of shared pivot `i < S` right of the pivot: [`rotate`] on
/// `(urow_k, xs_k)` for `k > i` and on `(q_i, e)`.
// index proven: `k < S` in arrays of `S` entries.
#[allow(clippy::indexing_slicing)]
#[inline(always)]
fn shared_rotation<F, T, const W: usize, const S: usize>(
    i: usize,
    urow: &mut [F; S],
    q: &mut F,
    r: &mut Working<F, T, W, S>,
    xi: F,
    sbar: F,
) where
    F: ComplexField<RealField = T> + Copy,
    T: Real,
{
    let xs = &mut r.xs;
    for k in i + 1..S {
        rotate(&mut urow[k], &mut xs[k], xi, sbar);
    }
    rotate(q, &mut r.e, xi, sbar);
}

/// The scalar part of one scaled rotation against the pivot `d` with
/// working entry `x` of weight `delta`: `d <- d' = d + delta |x|^2`,
/// `delta <- delta d / d'`; returns `sbar = delta x^* / d'`, or `None`
/// (nothing changed) when `d' = 0`.
#[inline(always)]
fn pivot<F, T>(d: &mut T, x: F, delta: &mut T) -> Option<F>
where
    F: ComplexField<RealField = T> + Copy,
    T: Real,
{
    let dn = *d + *delta * x.modulus_squared();
    if dn <= T::zero() {
        return None;
    }
    // `t = delta / d'`: `sbar = t x^*`, `delta' = t d`.
    let t = *delta / dn;
    let sbar = x.conjugate().scale(t);
    *delta = t * *d;
    *d = dn;
    Some(sbar)
}

/// Owning, fixed-size square-root-free block QRD/RLS: `NB` blocks of `W`
/// unknowns, `S` shared unknowns, forgetting factor `lambda`,
/// regularisation `delta` (`R(0) = sqrt(delta) I`, [`QrdRls::new`]); the
/// counterpart of [`crate::blockqrd::BlockQrdRls`] with Gentleman's
/// rotations (module documentation).
pub type SqrtFreeQrdRls<F, const NB: usize, const W: usize, const S: usize> =
    QrdRls<F, SqrtFreeFactor<F, NB, W, S>>;

#[cfg(feature = "compact-rows")]
impl<F, T, const NB: usize, const W: usize, const S: usize> QrdRls<F, SqrtFreeFactor<F, NB, W, S>>
where
    F: ComplexField<RealField = T> + Copy,
    T: Real,
{
    /// One update with `N = d.len()` rows given by their structure
    /// (block index, block entries, shared entries):
    /// [`SqrtFreeFactor::update_block_rows`] with the filter's `lambda`.
    ///
    /// Errors (state untouched): as [`SqrtFreeFactor::update_block_rows`].
    pub fn update_block_rows(
        &mut self,
        blocks: &[usize],
        a: &[F],
        c: &[F],
        d: &[F],
        xi: &mut [F],
        gamma: &mut [T],
    ) -> Result<(), FilterError> {
        let lambda = self.lambda();
        self.factor_mut()
            .update_block_rows(blocks, a, c, d, lambda, xi, gamma)
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    use super::*;
    use crate::blockqrd::BlockQrdRls;
    use crate::qrdrls::VectorQrdRls;
    use crate::testrng::SplitMix64;
    use num_complex::Complex;
    use std::vec;
    use std::vec::Vec;

    /// Rows of the block layout `(NB, W, S)`: row `j` in block
    /// `j % NB`, entries uniform in `[-1, 1)`, right-hand side `u w + noise`.
    #[allow(clippy::type_complexity)]
    fn rows<F, T, const NB: usize, const W: usize, const S: usize, const M: usize>(
        rng: &mut SplitMix64,
        n: usize,
        w: &[F; M],
        sample: fn(&mut SplitMix64) -> F,
    ) -> (Vec<usize>, Vec<F>, Vec<F>, Vec<F>, Vec<F>)
    where
        F: ComplexField<RealField = T> + Copy,
        T: Real,
    {
        let (mut blocks, mut a, mut c, mut u, mut d) = (vec![], vec![], vec![], vec![], vec![]);
        for j in 0..n {
            let b = (j + (rng.next_u64() % NB as u64) as usize) % NB;
            let mut row = [F::zero(); M];
            for k in 0..W {
                row[b * W + k] = sample(rng);
            }
            for k in 0..S {
                row[NB * W + k] = sample(rng);
            }
            let mut dj = sample(rng).scale(T::lit(1e-3));
            for k in 0..M {
                dj += row[k] * w[k];
            }
            blocks.push(b);
            a.extend_from_slice(&row[b * W..(b + 1) * W]);
            c.extend_from_slice(&row[NB * W..]);
            u.extend_from_slice(&row);
            d.push(dj);
        }
        (blocks, a, c, u, d)
    }

    fn c64(rng: &mut SplitMix64) -> Complex<f64> {
        Complex::new(rng.sym(), rng.sym())
    }
    fn r64(rng: &mut SplitMix64) -> f64 {
        rng.sym()
    }
    fn r32(rng: &mut SplitMix64) -> f32 {
        rng.sym() as f32
    }
    fn c32(rng: &mut SplitMix64) -> Complex<f32> {
        Complex::new(rng.sym() as f32, rng.sym() as f32)
    }

    /// Largest relative difference `|a - b| / max(max |b|, tiny)` over
    /// two arrays.
    fn rel<F: ComplexField<RealField = T> + Copy, T: Real>(a: &[F], b: &[F]) -> f64 {
        let scale = b
            .iter()
            .map(|x| x.modulus().to_f64())
            .fold(1e-300, f64::max);
        a.iter()
            .zip(b)
            .map(|(x, y)| (*x - *y).modulus().to_f64() / scale)
            .fold(0.0, f64::max)
    }

    /// `steps` updates of `N` rows, compact and full-row forms, against
    /// the dense Givens filter and the block Givens filter: factor (as
    /// `R = D^(1/2) U`), `p`, `xi`, `gamma` and the weights.
    #[allow(clippy::type_complexity)]
    fn compare<
        F,
        T,
        const NB: usize,
        const W: usize,
        const S: usize,
        const M: usize,
        const N: usize,
    >(
        lambda: T,
        steps: usize,
        sample: fn(&mut SplitMix64) -> F,
        tol: f64,
    ) where
        F: ComplexField<RealField = T> + Copy,
        T: Real,
    {
        let mut rng = SplitMix64::new(0xC0FFEE);
        let w: [F; M] = core::array::from_fn(|_| sample(&mut rng));
        let delta = T::lit(1e-3);
        let mut sf = SqrtFreeQrdRls::<F, NB, W, S>::new(lambda, delta).unwrap();
        #[cfg(feature = "compact-rows")]
        let mut sf_compact = sf.clone();
        let mut dense = VectorQrdRls::<F, M, N>::new(lambda, delta).unwrap();
        let mut blk = BlockQrdRls::<F, NB, W, S>::new(lambda, delta).unwrap();
        let (mut worst_x, mut worst_g) = (0.0f64, 0.0f64);
        for _ in 0..steps {
            let (blocks, a, c, u, d) = rows::<F, T, NB, W, S, M>(&mut rng, N, &w, sample);
            let (mut xi, mut gamma) = ([F::zero(); N], [T::zero(); N]);
            let (mut xi3, mut gamma3) = ([F::zero(); N], [T::zero(); N]);
            sf.update_rows(&u, &d, &mut xi, &mut gamma).unwrap();
            blk.update_rows(&u, &d, &mut xi3, &mut gamma3).unwrap();
            // The compact row form is the same arithmetic.
            #[cfg(feature = "compact-rows")]
            {
                let (mut xi2, mut gamma2) = ([F::zero(); N], [T::zero(); N]);
                sf_compact
                    .update_block_rows(&blocks, &a, &c, &d, &mut xi2, &mut gamma2)
                    .unwrap();
                assert_eq!(xi, xi2);
                assert_eq!(gamma, gamma2);
            }
            #[cfg(not(feature = "compact-rows"))]
            let _ = (blocks, a, c);
            let uu: [[F; M]; N] = core::array::from_fn(|j| core::array::from_fn(|k| u[j * M + k]));
            let dd: [F; N] = core::array::from_fn(|j| d[j]);
            let out = dense.update(&uu, &dd).unwrap();
            // `xi_j = d_j - u_j^T w_j` is a difference of terms of the size
            // of `d_j`: its round-off is relative to `d`.
            let dscale = d
                .iter()
                .map(|x| x.modulus().to_f64())
                .fold(1e-300, f64::max);
            let ex = xi
                .iter()
                .zip(&out.xi)
                .map(|(a, b)| (*a - *b).modulus().to_f64() / dscale)
                .fold(0.0, f64::max);
            worst_x = worst_x.max(ex);
            let g: Vec<F> = gamma.iter().map(|g| F::from_real(*g)).collect();
            let gd: Vec<F> = out.gamma.iter().map(|g| F::from_real(*g)).collect();
            worst_g = worst_g.max(rel(&g, &gd));
            // The Givens block filter's gamma is the dense one's.
            assert_eq!(gamma3, out.gamma);
        }
        #[cfg(feature = "compact-rows")]
        assert_eq!(sf, sf_compact);
        assert!(worst_x < tol, "xi: {worst_x:e}");
        assert!(worst_g < tol, "gamma: {worst_g:e}");
        // The factor in Givens form against the block Givens filter's.
        let mut as_block = BlockFactor::<F, NB, W, S>::zeroed();
        sf.factor().to_block(&mut as_block).unwrap();
        let (mut r1, mut p1) = (vec![F::zero(); M * M], vec![F::zero(); M]);
        let (mut r2, mut p2) = (vec![F::zero(); M * M], vec![F::zero(); M]);
        as_block.view().to_dense(&mut r1, &mut p1).unwrap();
        blk.factor().view().to_dense(&mut r2, &mut p2).unwrap();
        let er = rel(&r1, &r2);
        let ep = rel(&p1, &p2);
        assert!(er < tol, "R: {er:e}");
        assert!(ep < tol, "p: {ep:e}");
        // Weights against the Givens filter's back-substitution.
        let (mut w1, mut w2) = ([F::zero(); M], [F::zero(); M]);
        sf.weights(&mut w1).unwrap();
        blk.weights(&mut w2).unwrap();
        let ew = rel(&w1, &w2);
        assert!(ew < tol, "w: {ew:e}");
        // And the estimate is the truth to the noise.
        assert!(rel(&w1, &w) < 1e-1, "w vs truth");
        // Conditioning indicator.
        let (q1, q2) = (sf.factor().diag_ratio(), blk.factor().view().diag_ratio());
        assert!(
            (q1 - q2).abs().to_f64() <= tol * q2.to_f64(),
            "ratio {q1:?} {q2:?}"
        );
    }

    #[test]
    fn agrees_with_the_givens_filters_f64() {
        // The identification layouts: physical N_b 2 N_p 3 order 1, and
        // N_b 4 N_p 5 order 1; the paper's complex layout; forgetting and
        // none.
        compare::<f64, f64, 4, 4, 6, 22, 8>(0.999, 300, r64, 1e-12);
        compare::<f64, f64, 4, 4, 6, 22, 8>(1.0, 300, r64, 1e-12);
        compare::<f64, f64, 8, 4, 10, 42, 16>(0.99, 300, r64, 1e-12);
        compare::<Complex<f64>, f64, 4, 4, 3, 19, 4>(0.999, 300, c64, 1e-12);
        // Wide layouts: pivots beyond the written-out ones.
        compare::<f64, f64, 2, 18, 17, 53, 4>(0.995, 100, r64, 1e-12);
    }

    #[test]
    fn agrees_with_the_givens_filters_f32() {
        compare::<f32, f32, 4, 4, 6, 22, 8>(0.999, 300, r32, 2e-4);
        compare::<Complex<f32>, f32, 4, 4, 3, 19, 4>(0.999, 300, c32, 2e-4);
    }

    #[test]
    fn an_update_that_would_overflow_is_rejected_and_changes_nothing() {
        // Found by the `sqrtfree_update` fuzz target: forgetting flushes
        // `d = 2.4e-38 * 7.1e-15` to zero in f32, then a row of `8.4e-21`
        // has a subnormal square and `delta / d'` overflows.
        let mut f = SqrtFreeQrdRls::<f32, 1, 1, 0>::new(7.077_681_5e-15, 2.350_988_6e-38).unwrap();
        let before = f.clone();
        let (mut xi, mut gamma) = ([0.0f32; 2], [0.0f32; 2]);
        let x = 8.370_678e-21f32;
        assert_eq!(
            f.update_grouped_rows(&[x, x], &[x, x], &mut xi, &mut gamma),
            Err(FilterError::OutOfRange)
        );
        assert_eq!(f, before);
        // The same rows at order one are fine.
        assert!(f
            .update_grouped_rows(&[1.0, 1.0], &[1.0, 1.0], &mut xi, &mut gamma)
            .is_ok());
    }

    #[test]
    #[allow(clippy::type_complexity)]
    fn bad_input_leaves_the_state_unchanged() {
        let mut f = SqrtFreeQrdRls::<f64, 2, 2, 1>::new(0.99, 1e-3).unwrap();
        let u = [1.0, 0.5, 0.0, 0.0, 1.0];
        let (mut xi, mut gamma) = ([0.0; 1], [0.0; 1]);
        f.update_rows(&u, &[1.0], &mut xi, &mut gamma).unwrap();
        let before = f.clone();
        // Finite, but its square is not: the update would leave the range.
        let big = 1e200;
        let cases: [(&[f64], &[f64], FilterError); 5] = [
            (
                &[f64::NAN, 0.5, 0.0, 0.0, 1.0],
                &[1.0],
                FilterError::NonFinite,
            ),
            (
                &[1.0, 0.5, 0.0, 0.0, 1.0],
                &[f64::INFINITY],
                FilterError::NonFinite,
            ),
            (&[big, 0.5, 0.0, 0.0, 1.0], &[1.0], FilterError::OutOfRange),
            (&[1.0, 0.5, 1.0, 0.0, 1.0], &[1.0], FilterError::Dimension),
            (&[1.0, 0.5, 0.0, 0.0], &[1.0], FilterError::Dimension),
        ];
        for (u, d, err) in cases {
            assert_eq!(f.update_rows(u, d, &mut xi, &mut gamma), Err(err));
            assert_eq!(f, before);
        }
        #[cfg(feature = "compact-rows")]
        let compact: [(&[usize], &[f64], &[f64], &[f64], FilterError); 6] = [
            (&[2], &[1.0, 0.5], &[1.0], &[1.0], FilterError::Dimension),
            (&[0], &[1.0], &[1.0], &[1.0], FilterError::Dimension),
            (
                &[0],
                &[1.0, f64::NAN],
                &[1.0],
                &[1.0],
                FilterError::NonFinite,
            ),
            (&[1], &[1.0, 0.5], &[-big], &[1.0], FilterError::OutOfRange),
            (
                &[1],
                &[1.0, 0.5],
                &[f64::INFINITY],
                &[1.0],
                FilterError::NonFinite,
            ),
            (
                &[1],
                &[1.0, 0.5],
                &[1.0],
                &[f64::NAN],
                FilterError::NonFinite,
            ),
        ];
        #[cfg(feature = "compact-rows")]
        for (b, a, c, d, err) in compact {
            assert_eq!(
                f.update_block_rows(b, a, c, d, &mut xi, &mut gamma),
                Err(err)
            );
            assert_eq!(f, before);
        }
        assert_eq!(
            SqrtFreeQrdRls::<f64, 2, 2, 1>::new(1.5, 1e-3),
            Err(FilterError::InvalidLambda)
        );
    }

    #[test]
    fn large_finite_entries_are_accepted_when_the_result_is_finite() {
        // No input bound: `1e100` squares to `1e200`, within `f64`.
        let mut f = SqrtFreeQrdRls::<f64, 2, 2, 1>::new(1.0, 1e-3).unwrap();
        let (mut xi, mut gamma) = ([0.0; 2], [0.0; 2]);
        // Row 0 in block 0, row 1 in block 1, each with a shared entry.
        let u = [1e100, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 2.0, 1e100, 1.0];
        let rows = f.update_grouped_rows(&u, &[1e100, 1e100], &mut xi, &mut gamma);
        assert_eq!(rows, Ok(()));
        assert!(xi.iter().chain(&gamma).all(|x| x.is_finite()));
    }

    /// Grouped rows (one group per block, as the identification's) fold
    /// exactly as the same rows given as rows of `M` entries, and the
    /// entries outside each row's block are not read.
    fn grouped_is_rows<F, T, const NB: usize, const W: usize, const S: usize, const M: usize>(
        n: usize,
        sample: fn(&mut SplitMix64) -> F,
    ) where
        F: ComplexField<RealField = T> + Copy + core::fmt::Debug,
        T: Real,
    {
        let mut rng = SplitMix64::new(7);
        let w: [F; M] = core::array::from_fn(|_| sample(&mut rng));
        let mut by_rows = SqrtFreeQrdRls::<F, NB, W, S>::new(T::lit(0.99), T::lit(1e-2)).unwrap();
        let mut grouped = by_rows.clone();
        let (mut xi1, mut g1) = (vec![F::zero(); n], vec![T::zero(); n]);
        let (mut xi2, mut g2) = (vec![F::zero(); n], vec![T::zero(); n]);
        for _ in 0..50 {
            let (_, _, _, mut u, d) = rows::<F, T, NB, W, S, M>(&mut rng, n, &w, sample);
            // Row j in block j / (n / NB), zero elsewhere.
            for j in 0..n {
                let b = j / (n / NB);
                for k in 0..NB * W {
                    if k / W != b {
                        u[j * M + k] = F::zero();
                    } else if u[j * M + k] == F::zero() {
                        u[j * M + k] = sample(&mut rng);
                    }
                }
            }
            by_rows.update_rows(&u, &d, &mut xi1, &mut g1).unwrap();
            // What grouped rows do not read may be anything.
            for j in 0..n {
                let b = j / (n / NB);
                u[j * M + ((b + 1) % NB) * W] = F::from_real(T::zero() / T::zero());
            }
            grouped
                .update_grouped_rows(&u, &d, &mut xi2, &mut g2)
                .unwrap();
            assert_eq!(by_rows.factor(), grouped.factor());
            assert_eq!(xi1, xi2);
            assert_eq!(g1, g2);
        }
        // Rows that are not a multiple of NB.
        let (mut xi, mut g) = (vec![F::zero(); n + 1], vec![T::zero(); n + 1]);
        let u = vec![F::zero(); (n + 1) * M];
        let d = vec![F::zero(); n + 1];
        assert_eq!(
            grouped.update_grouped_rows(&u, &d, &mut xi, &mut g),
            Err(FilterError::Dimension)
        );
    }

    #[test]
    fn grouped_rows_fold_as_rows_of_m_entries() {
        // The identification's layouts: physical 1 (real, two rows per
        // channel) and paper 1 (complex, one row per channel), N_b 2, N_p 3.
        grouped_is_rows::<f64, f64, 4, 4, 6, 22>(8, r64);
        grouped_is_rows::<f32, f32, 4, 4, 6, 22>(8, r32);
        grouped_is_rows::<Complex<f64>, f64, 4, 4, 3, 19>(4, c64);
        grouped_is_rows::<Complex<f32>, f32, 4, 4, 3, 19>(4, c32);
    }

    #[test]
    fn a_finite_factor_whose_givens_form_overflows_reports_it() {
        // The fuzz case: q = d / a grows to -1.4e36 while d_i = 6.3e4, so
        // the stored factor is finite but p = d^(1/2) q exceeds f32::MAX.
        let mut f = SqrtFreeQrdRls::<f32, 1, 1, 0>::new(2.910383e-11, 2.7015305e-20).unwrap();
        let (mut xi, mut gamma) = ([0.0f32; 2], [0.0f32; 2]);
        f.update_rows(
            &[8.3706784e-21; 2],
            &[8.3706784e-21; 2],
            &mut xi,
            &mut gamma,
        )
        .unwrap();
        f.update_grouped_rows(
            &[158.00032, 195.26274],
            &[-2.3961028e38, -2.595487e38],
            &mut xi,
            &mut gamma,
        )
        .unwrap();
        assert!(f.factor().is_finite());
        let mut block = BlockFactor::<f32, 1, 1, 0>::zeroed();
        assert_eq!(
            f.factor().to_block(&mut block),
            Err(FilterError::OutOfRange)
        );
        // The weights come from `U w = q`, not from the Givens form.
        let mut w = [0.0f32; 1];
        f.weights(&mut w).unwrap();
        assert!(w[0].is_finite());
    }

    #[test]
    fn a_non_finite_right_hand_side_no_rotation_touches_is_rejected() {
        // Forgetting flushes every `d_i` to zero in f32 and the row is zero:
        // every pivot is skipped, so only `xi` sees the NaN.
        let mut f = SqrtFreeQrdRls::<f32, 1, 2, 1>::new(1e-30, 1e-30).unwrap();
        let (mut xi, mut gamma) = ([0.0f32; 1], [0.0f32; 1]);
        let zero = [0.0f32; 3];
        f.update_grouped_rows(&zero, &[0.0], &mut xi, &mut gamma)
            .unwrap();
        let before = f.clone();
        assert_eq!(
            f.update_grouped_rows(&zero, &[f32::NAN], &mut xi, &mut gamma),
            Err(FilterError::NonFinite)
        );
        assert_eq!(f, before);
    }

    #[test]
    fn no_information_is_singular() {
        assert_eq!(
            SqrtFreeQrdRls::<f64, 2, 2, 1>::new(1.0, 0.0),
            Err(FilterError::InvalidDelta)
        );
        // No information: the factor of zeros is singular.
        let f = SqrtFreeFactor::<f64, 2, 2, 1>::new(0.0);
        let mut w = [0.0; 5];
        assert_eq!(f.solve_weights(&mut w), Err(FilterError::Singular));
        // A zero row is the identity: gamma 1, xi = d.
        let mut f = SqrtFreeQrdRls::<f64, 2, 2, 1>::new(1.0, 1.0).unwrap();
        let (mut xi, mut gamma) = ([0.0; 1], [0.0; 1]);
        f.update_rows(&[0.0; 5], &[2.5], &mut xi, &mut gamma)
            .unwrap();
        assert_eq!((xi[0], gamma[0]), (2.5, 1.0));
    }
}
