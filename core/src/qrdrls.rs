//! Vector QRD/RLS filter (the method paper's section 2.3, Eq. 20), updated
//! row by row with Givens rotations ([`crate::givens`]).
//!
//! # Problem
//!
//! At step `n` the filter receives `N` equations `d(n) = U(n) w` (Eq. 19:
//! `U(n)` is `N x M`, `d(n)` has `N` entries, `w` the `M` unknowns) and
//! minimises the exponentially weighted, regularised cost
//!
//! ```text
//! J(w) = lambda^n delta ||w - w0||^2 + sum_{k=1..n} lambda^(n-k) ||d(k) - U(k) w||^2
//! ```
//!
//! with forgetting factor `0 < lambda <= 1`, regularisation `delta > 0` and
//! prior weights `w0` (zero unless given). The normal equations are
//! `Phi(n) w = z(n)` with
//!
//! ```text
//! Phi(n) = lambda Phi(n-1) + U(n)^H U(n),   Phi(0) = delta I,
//! z(n)   = lambda z(n-1)   + U(n)^H d(n),   z(0)   = delta w0.
//! ```
//!
//! (The paper writes a scalar filter as `y = w^H u`; with its input vector
//! `u_paper = u^H` for a row `u` of `U`, and `d_paper = d^*`, the two forms
//! are the same problem. Here rows act on `w` without conjugation.)
//!
//! # Convention for the factor
//!
//! The state is an **upper-triangular** `R(n)` (`M x M`, real non-negative
//! diagonal) and a vector `p(n)` with
//!
//! ```text
//! Phi(n) = R(n)^H R(n),   z(n) = R(n)^H p(n),   so   R(n) w(n) = p(n).
//! ```
//!
//! The paper's Eq. 15 writes `Phi = R R^H` with a lower-triangular `R`; its
//! Eq. 17/20 then carries `R^H` (upper triangular) in the top block. Our `R`
//! **is** the paper's `R^H`, our `p` is the paper's `p = R^H w`, and our
//! update is Eq. 20 with that block renamed:
//!
//! ```text
//!       [ sqrt(lambda) R(n-1)   sqrt(lambda) p(n-1)   0 ]     [ R(n)   p(n)   * ]
//!   Q   [                                               ]  =  [                 ]
//!       [ u_j                   d_j                   1 ]     [ 0      e_j    g_j ]
//! ```
//!
//! Initial state (Eq. 18): `R(0) = sqrt(delta) I`, `p(0) = R(0) w0 = sqrt(delta) w0`.
//!
//! # Update
//!
//! `R` and `p` are scaled by `sqrt(lambda)` once per step (skipped when
//! `lambda = 1`); then the `N` rows are folded in **one at a time**: for row
//! `u_j` (with right-hand side `d_j`), `M` Givens rotations zero `u_j`
//! against the diagonal of `R` (rotation `i` acts on row `i` of `[R p]` and
//! the working copy of `[u_j d_j]`), which is `O(M^2)` per row and
//! `O(N M^2)` per step, in place, without allocation and without a general
//! QR. The rotation of the augmented column `[0; 1]` is never stored: its
//! bottom entry is the product `g_j = c_1 c_2 ... c_M` of the cosines.
//!
//! Implementation detail: up to 4 rows are folded together column by
//! column (rotation `i` of a row only touches row `i` of `[R p]` and the
//! row's own working copy, so every entry meets the same rotations in the
//! same order as row after row, and the result is bit-identical; a unit
//! test checks it). Their working copies live in a stack buffer of 128
//! entries of `F` (1 KiB for `Complex<f32>`, 2 KiB for `Complex<f64>`);
//! blocks of 4 rows are used for `M <= 33`, of 2 for `M <= 65`, and beyond
//! that rows are folded one at a time with the strictly lower triangle of
//! `r` as the working row.
//!
//! # What an update returns
//!
//! Rows are folded sequentially, so row `j` sees the state `R^(j-1), p^(j-1)`
//! that already contains the rows before it (and the step's `lambda`
//! scaling); `w^(j) = (R^(j))^-1 p^(j)` is the least-squares solution after
//! row `j`, and `P^(j) = (Phi^(j))^-1`. Per row:
//!
//! * a-priori error `alpha_j = d_j - u_j w^(j-1)`,
//! * **conversion factor** `gamma_j = 1 - u_j P^(j) u_j^H
//!   = 1 / (1 + u_j (Phi^(j-1))^-1 u_j^H)`, in `(0, 1]` (returned, `T`;
//!   it underflows to `0` only if `u_j (Phi^(j-1))^-1 u_j^H` exceeds the
//!   inverse of the smallest normal number, e.g. a first row of size 1e25
//!   against `delta = 1` in `f32`),
//! * **a-posteriori error** `xi_j = d_j - u_j w^(j) = gamma_j alpha_j`
//!   (returned, `F`),
//! * the rotations deliver the angle-normalised error
//!   `e_j = sqrt(gamma_j) alpha_j` in the `p` column and `g_j = sqrt(gamma_j)`
//!   in the augmented column (Eq. 17/20); `xi_j = g_j e_j` is formed from
//!   them without any division. `alpha_j = xi_j / gamma_j` and
//!   `e_j = xi_j / sqrt(gamma_j)` can be recovered by the caller when
//!   `gamma_j > 0`.
//!
//! For the last row of a step, `xi_{N-1} = d_{N-1} - u_{N-1} w(n)`. Weights
//! are only computed on demand, by back-substitution of `R w = p`.
//!
//! # Input safety
//!
//! * Any non-finite entry in `U` or `d` -> [`FilterError::NonFinite`]; an
//!   entry beyond [`input_limit`] (`sqrt(T::MAX)`) ->
//!   [`FilterError::OutOfRange`]; a `lambda` outside `(0, 1]` ->
//!   [`FilterError::InvalidLambda`]; wrong lengths ->
//!   [`FilterError::Dimension`]. All checks run **before** the state is
//!   touched, so an error leaves it bit for bit unchanged.
//! * The rotations are range-safe ([`crate::givens`]): finite data never
//!   produce an infinity or NaN in `R`, `p` unless a true column norm of the
//!   stacked data exceeds the type's maximum, which the input limit rules
//!   out (see [`input_limit`]). Found by the `qrdrls_update` fuzz target:
//!   rows of entries near `f32::MAX` used to overflow the factor.
//! * A row of all zeros meets identity rotations (`c = 1`, `s = 0`): `R` and
//!   `p` are untouched (apart from the step's `lambda` scaling),
//!   `gamma_j = 1` and `xi_j = d_j`. A zero entry of a row is likewise
//!   skipped (its rotation is the identity), which makes sparse rows cheap.
//! * For `M > 65` the strictly lower triangle of the `r` buffer is used as
//!   workspace for the working row during an update; it is zero again on
//!   return in every case.

//!
//! # Example
//!
//! ```
//! use rotorid_core::qrdrls::{self, VectorQrdRls};
//! use rotorid_core::Complex;
//!
//! // Owning, fixed-size: 2 complex unknowns, 2 rows per step.
//! let w = [Complex::new(1.0, -2.0), Complex::new(0.5, 3.0)];
//! let mut f = VectorQrdRls::<Complex<f64>, 2, 2>::new(0.99, 1e-9)?;
//! let u = [
//!     [Complex::new(1.0, 0.0), Complex::new(0.0, 1.0)],
//!     [Complex::new(2.0, 1.0), Complex::new(-1.0, 0.5)],
//! ];
//! let d = [u[0][0] * w[0] + u[0][1] * w[1], u[1][0] * w[0] + u[1][1] * w[1]];
//! let info = f.update(&u, &d)?;
//! assert!(info.gamma.iter().all(|g| *g > 0.0 && *g <= 1.0));
//! let est = f.weights()?;
//! assert!((est[0] - w[0]).norm() < 1e-6 && (est[1] - w[1]).norm() < 1e-6);
//!
//! // The same with runtime sizes on caller buffers (real field here).
//! let m = 2;
//! let (mut r, mut p) = (vec![0.0f64; m * m], vec![0.0f64; m]);
//! qrdrls::init(&mut r, &mut p, 1e-9, None)?;
//! let (mut xi, mut gamma) = ([0.0; 2], [0.0; 2]);
//! qrdrls::update_rows(&mut r, &mut p, &[1.0, 2.0, 3.0, -1.0], &[5.0, 1.0], 1.0, &mut xi, &mut gamma)?;
//! let mut w = [0.0; 2];
//! qrdrls::solve_weights(&r, &p, &mut w)?;
//! assert!((w[0] - 1.0).abs() < 1e-6 && (w[1] - 2.0).abs() < 1e-6);
//! # Ok::<(), qrdrls::FilterError>(())
//! ```

use crate::givens::{min_normal, rotation_real_pivot, Rotation};
use crate::Real;
use core::fmt;
use nalgebra::ComplexField;

/// Errors of the QRD/RLS filter and its baselines.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FilterError {
    /// An entry of `U`, `d` or the initial weights is NaN or infinite.
    NonFinite,
    /// The forgetting factor is not in `(0, 1]` (or is NaN).
    InvalidLambda,
    /// The regularisation `delta` is not in `(0, sqrt(T::MAX)]`.
    InvalidDelta,
    /// Back-substitution met a zero diagonal entry of `R` (or overflowed).
    Singular,
    /// A buffer length does not match the dimensions (or `M = 0`).
    Dimension,
    /// An entry of `U`, `d` or the initial weights is finite but larger in
    /// magnitude (real or imaginary part) than [`input_limit`]
    /// (`sqrt(T::MAX)`), beyond which the factor could overflow.
    OutOfRange,
}

impl fmt::Display for FilterError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            FilterError::NonFinite => "non-finite value in the filter input",
            FilterError::InvalidLambda => "forgetting factor lambda must lie in (0, 1]",
            FilterError::InvalidDelta => {
                "regularisation delta must be > 0 and at most sqrt of the largest float"
            }
            FilterError::Singular => "triangular factor is singular",
            FilterError::Dimension => "buffer length does not match the filter dimensions",
            FilterError::OutOfRange => "filter input too large (beyond sqrt of the largest float)",
        })
    }
}

impl core::error::Error for FilterError {}

/// Checks `0 < lambda <= 1` (NaN rejected).
#[inline]
pub fn validate_lambda<T: Real>(lambda: T) -> Result<(), FilterError> {
    if lambda > T::zero() && lambda <= T::one() {
        Ok(())
    } else {
        Err(FilterError::InvalidLambda)
    }
}

/// Checks `0 < delta <= input_limit()` (`sqrt(T::MAX)`; NaN rejected), so
/// that `R(0) = sqrt(delta) I` and `p(0) = sqrt(delta) w0` stay far from
/// overflow (see [`input_limit`]).
#[inline]
pub fn validate_delta<T: Real>(delta: T) -> Result<(), FilterError> {
    if delta > T::zero() && delta <= input_limit::<T>() {
        Ok(())
    } else {
        Err(FilterError::InvalidDelta)
    }
}

/// The largest magnitude the filter accepts for the real or imaginary part
/// of an input entry: `L = sqrt(T::MAX)` (1.8e19 in `f32`, 1.3e154 in `f64`).
///
/// Why this bound keeps the state finite: every entry of `[R p]` and of the
/// working row is bounded by the Euclidean norm of its column of the stacked
/// data `[sqrt(delta) I, sqrt(delta) w0; U(1), d(1); ...]` (the rotations are
/// unitary and forgetting only shrinks). With all entries below `L` in
/// magnitude and `delta <= L` ([`validate_delta`]), the prior block
/// contributes at most `L^(3/2)` and, after `n` steps of `N` rows, that norm
/// is at most `sqrt(2 n N) L + L^(3/2)`, which stays below `T::MAX = L^2`
/// for any `n N < T::MAX / 8`, i.e. forever in practice.
#[inline]
pub fn input_limit<T: Real>() -> T {
    T::max_value().unwrap_or_else(T::one).sqrt()
}

/// `Err(NonFinite)` if any entry of `u` or `d` is NaN or infinite, then
/// `Err(OutOfRange)` if the real or imaginary part of any entry exceeds
/// [`input_limit`] in magnitude.
#[inline]
pub fn check_finite<F>(u: &[F], d: &[F]) -> Result<(), FilterError>
where
    F: ComplexField,
    F::RealField: Real,
{
    let limit = input_limit::<F::RealField>();
    // One branch-free pass for the common case: `|x| <= limit` is false
    // for NaN and the infinities as well as for out-of-range entries.
    let within = |ok: bool, x: &F| {
        ok & (x.clone().real().abs() <= limit) & (x.clone().imaginary().abs() <= limit)
    };
    if u.iter().fold(true, within) & d.iter().fold(true, within) {
        return Ok(());
    }
    if !u.iter().chain(d.iter()).all(|x| x.is_finite()) {
        Err(FilterError::NonFinite)
    } else {
        Err(FilterError::OutOfRange)
    }
}

/// Number of unknowns `M` implied by the buffers, after checking
/// `p.len() = M > 0` and `r.len() = M * M`.
#[inline]
fn dim_of<F>(r_len: usize, p: &[F]) -> Result<usize, FilterError> {
    let m = p.len();
    if m == 0 || m.checked_mul(m) != Some(r_len) {
        return Err(FilterError::Dimension);
    }
    Ok(m)
}

/// Initialises the state: `R = sqrt(delta) I`, `p = R w0` (`p = 0` without
/// `w0`). `r` is `M x M` row-major (`M * M` entries), `p` has `M` entries.
///
/// Errors (state untouched): `InvalidDelta`, `Dimension`, `NonFinite` or
/// `OutOfRange` (in `w0`, see [`check_finite`]).
pub fn init<F, T>(r: &mut [F], p: &mut [F], delta: T, w0: Option<&[F]>) -> Result<(), FilterError>
where
    F: ComplexField<RealField = T> + Copy,
    T: Real,
{
    let m = dim_of(r.len(), p)?;
    validate_delta(delta)?;
    if let Some(w0) = w0 {
        if w0.len() != m {
            return Err(FilterError::Dimension);
        }
        check_finite(w0, &[])?;
    }
    let sd = delta.sqrt();
    for (i, row) in r.chunks_exact_mut(m).enumerate() {
        for (k, x) in row.iter_mut().enumerate() {
            *x = if i == k { F::from_real(sd) } else { F::zero() };
        }
    }
    match w0 {
        Some(w0) => {
            for (pi, wi) in p.iter_mut().zip(w0) {
                *pi = wi.scale(sd);
            }
        }
        None => p.iter_mut().for_each(|x| *x = F::zero()),
    }
    Ok(())
}

/// Folds the `N` rows of `u` (`N x M` row-major) with right-hand sides `d`
/// (`N`) into `R`, `p`, after scaling them by `sqrt(lambda)` (see the module
/// documentation). Writes the a-posteriori errors `xi_j` to `errors_out`
/// and the conversion factors `gamma_j` to `gamma_out` (both length `N`).
///
/// `r` must hold an upper-triangular factor with a real, non-negative
/// diagonal, as produced by [`init`] and kept by this function; only the
/// real part of a diagonal entry is read.
///
/// Errors (all checked before anything is written): `Dimension`,
/// `InvalidLambda`, `NonFinite`.
#[allow(clippy::too_many_arguments)]
pub fn update_rows<F, T>(
    r: &mut [F],
    p: &mut [F],
    u: &[F],
    d: &[F],
    lambda: T,
    errors_out: &mut [F],
    gamma_out: &mut [T],
) -> Result<(), FilterError>
where
    F: ComplexField<RealField = T> + Copy,
    T: Real,
{
    update_rows_impl(r, p, u, d, lambda, errors_out, gamma_out, true)
}

/// Capacity (entries of `F`) of the stack buffer holding the working rows
/// of a block: 128 entries, i.e. 1 KiB for `Complex<f32>`, 2 KiB for
/// `Complex<f64>`.
const BLOCK_WORK: usize = 128;

/// [`update_rows`], with the row blocking switchable (`blocked = false`
/// folds strictly one row after the other; both give bit-identical results,
/// which a unit test checks).
#[allow(clippy::too_many_arguments)]
fn update_rows_impl<F, T>(
    r: &mut [F],
    p: &mut [F],
    u: &[F],
    d: &[F],
    lambda: T,
    errors_out: &mut [F],
    gamma_out: &mut [T],
    blocked: bool,
) -> Result<(), FilterError>
where
    F: ComplexField<RealField = T> + Copy,
    T: Real,
{
    let m = dim_of(r.len(), p)?;
    let n = d.len();
    if n.checked_mul(m) != Some(u.len()) || errors_out.len() != n || gamma_out.len() != n {
        return Err(FilterError::Dimension);
    }
    validate_lambda(lambda)?;
    check_finite(u, d)?;

    // Forgetting: [R p] <- sqrt(lambda) [R p] (upper triangle only).
    if lambda != T::one() {
        let sl = lambda.sqrt();
        for (i, row) in r.chunks_exact_mut(m).enumerate() {
            // A plain slice loop (`skip(i)` costs 3 % more instructions).
            for x in row.get_mut(i..).unwrap_or_default() {
                *x = x.scale(sl);
            }
        }
        for x in p.iter_mut() {
            *x = x.scale(sl);
        }
    }

    // Rows 0..M-1 of R, and the last row whose first M-1 (strictly lower)
    // entries serve as the working copy of u_j(1..M) for one-row folding.
    let (top, last) = r.split_at_mut((m - 1) * m);
    let (tri_work, last_diag) = last.split_at_mut(m - 1);
    let last_diag = last_diag.first_mut().ok_or(FilterError::Dimension)?;

    // Block size: as many rows (up to 4) as the stack buffer holds.
    let block = if !blocked {
        1
    } else if 4 * (m - 1) <= BLOCK_WORK {
        4
    } else if 2 * (m - 1) <= BLOCK_WORK {
        2
    } else {
        1
    };
    if block == 1 {
        for (((row, &dj), xi), gam) in u
            .chunks_exact(m)
            .zip(d)
            .zip(errors_out.iter_mut())
            .zip(gamma_out.iter_mut())
        {
            fold_block::<F, T, 1>(
                top,
                last_diag,
                p,
                m,
                row,
                core::slice::from_ref(&dj),
                tri_work,
                core::slice::from_mut(xi),
                core::slice::from_mut(gam),
            );
        }
    } else {
        let mut work = [F::zero(); BLOCK_WORK];
        for (((rows, dj), xi), gam) in u
            .chunks(block * m)
            .zip(d.chunks(block))
            .zip(errors_out.chunks_mut(block))
            .zip(gamma_out.chunks_mut(block))
        {
            match dj.len() {
                4 => fold_block::<F, T, 4>(top, last_diag, p, m, rows, dj, &mut work, xi, gam),
                3 => fold_block::<F, T, 3>(top, last_diag, p, m, rows, dj, &mut work, xi, gam),
                2 => fold_block::<F, T, 2>(top, last_diag, p, m, rows, dj, &mut work, xi, gam),
                _ => fold_block::<F, T, 1>(top, last_diag, p, m, rows, dj, &mut work, xi, gam),
            }
        }
    }
    tri_work.iter_mut().for_each(|x| *x = F::zero());
    Ok(())
}

/// Folds the `B` rows `rows` (`B x M` row-major, right-hand sides `d`) into
/// `[R p]`, column by column: at column `i`, the rotations of rows
/// `0..B` are computed one after the other against the diagonal `R_ii`
/// (each seeing `R_ii` after the previous one), then all of them are
/// applied, in row order, to the rest of row `i` of `[R p]` and to the
/// working rows. Every entry meets exactly the same rotations in the same
/// order as when the rows are folded one after the other (a rotation of
/// column `i` only touches row `i` of `R` and its own working row), so the
/// result is bit-identical; row `i` of `R` is just loaded once per column
/// instead of once per row.
///
/// `top` = rows `0..M-1` of `R`, `last_diag` = `R[M-1][M-1]`, `work` holds
/// at least `B (M - 1)` entries (working row `j` at `work[j (M-1)..]`,
/// entries `1..M` of the row).
#[allow(clippy::too_many_arguments)]
// index proven: the caller passes `B` rows of `m` entries, `B` right-hand
// sides and outputs, `work` of at least `B (m - 1)` entries (`BLOCK_WORK`
// checked when choosing `B`), `top` of `(m - 1) m` and `p` of `m` entries;
// every index is below those bounds (`i < m`, `j < B`, `k < m - 1`).
#[allow(clippy::indexing_slicing)]
#[inline(always)]
fn fold_block<F, T, const B: usize>(
    top: &mut [F],
    last_diag: &mut F,
    p: &mut [F],
    m: usize,
    rows: &[F],
    d: &[F],
    work: &mut [F],
    xi: &mut [F],
    gam: &mut [T],
) where
    F: ComplexField<RealField = T> + Copy,
    T: Real,
{
    let mut e = [F::zero(); B]; // rotated right-hand sides: end as sqrt(gamma) alpha
    let mut g = [T::one(); B]; // rotated augmented column: ends as sqrt(gamma)
    let mut first = [F::zero(); B];
    for (j, row) in rows.chunks_exact(m).take(B).enumerate() {
        e[j] = d[j];
        first[j] = row[0];
        work[j * (m - 1)..(j + 1) * (m - 1)].copy_from_slice(&row[1..]);
    }
    let work = &mut work[..B * (m - 1)];
    // Real fields (F = T): apply each row's rotation along the whole row
    // (contiguous, vectorisable); complex fields: keep each R_ik in a
    // register through the B rotations. Same operations in the same order
    // per entry either way.
    let real_field = core::mem::size_of::<F>() == core::mem::size_of::<T>();

    for i in 0..m {
        let (diag, rest): (&mut F, &mut [F]) = if i + 1 < m {
            let r_row = &mut top[i * m + i..(i + 1) * m];
            match r_row.split_first_mut() {
                Some(x) => x,
                None => return,
            }
        } else {
            (&mut *last_diag, &mut [])
        };
        let mut rots = [Rotation::<F>::identity(); B];
        let mut active = [false; B];
        for j in 0..B {
            let b = if i == 0 {
                first[j]
            } else {
                work[j * (m - 1) + i - 1]
            };
            if b.real() == T::zero() && b.imaginary() == T::zero() {
                continue; // identity rotation
            }
            let (rot, rho) = rotation_real_pivot(diag.real(), b);
            *diag = F::from_real(rho);
            rots[j] = rot;
            active[j] = true;
            g[j] *= rot.c;
        }
        if !active.iter().any(|a| *a) {
            continue;
        }
        let skip = m - 1 - rest.len(); // working-row index of column i + 1
        if rest.is_empty() {
            // Last column (or M = 1): only p is left.
        } else if real_field || !active.iter().all(|a| *a) {
            // Row after row over the trailing entries.
            for ((rot, act), wj) in rots.iter().zip(&active).zip(work.chunks_exact_mut(m - 1)) {
                if *act {
                    for (x, y) in rest.iter_mut().zip(&mut wj[skip..]) {
                        let (nx, ny) = rot.apply(*x, *y);
                        *x = nx;
                        *y = ny;
                    }
                }
            }
        } else {
            // Entry after entry, the B rotations on one R_ik kept in a register.
            for (k, x) in (skip..).zip(rest.iter_mut()) {
                let mut xv = *x;
                for (rot, wj) in rots.iter().zip(work.chunks_exact_mut(m - 1)) {
                    let (nx, ny) = rot.apply(xv, wj[k]);
                    xv = nx;
                    wj[k] = ny;
                }
                *x = xv;
            }
        }
        let mut xv = p[i];
        for ((rot, ej), act) in rots.iter().zip(e.iter_mut()).zip(&active) {
            if *act {
                let (nx, ne) = rot.apply(xv, *ej);
                xv = nx;
                *ej = ne;
            }
        }
        p[i] = xv;
    }
    for j in 0..B {
        xi[j] = e[j].scale(g[j]);
        gam[j] = g[j] * g[j];
    }
}

/// Back-substitution `R w = p` for the weights (`w_out` has `M` entries).
///
/// Errors: `Dimension`; `Singular` if a diagonal entry of `R` is zero,
/// subnormal (below the smallest normal number of `T`: its relative
/// precision is lost) or not finite, or a weight overflows (then `w_out` holds no
/// meaningful values).
pub fn solve_weights<F, T>(r: &[F], p: &[F], w_out: &mut [F]) -> Result<(), FilterError>
where
    F: ComplexField<RealField = T> + Copy,
    T: Real,
{
    let m = dim_of(r.len(), p)?;
    if w_out.len() != m {
        return Err(FilterError::Dimension);
    }
    for (i, (row, &pi)) in r.chunks_exact(m).zip(p).enumerate().rev() {
        // `i < m`: the diagonal entry ends `left`, `w_i` ends `w_left`.
        let (left, right) = row.split_at(i + 1);
        let (w_left, w_right) = w_out.split_at_mut(i + 1);
        let mut acc = pi;
        for (rik, wk) in right.iter().zip(w_right.iter()) {
            acc -= *rik * *wk;
        }
        let (Some(&rii), Some(w_i)) = (left.last(), w_left.last_mut()) else {
            return Err(FilterError::Dimension);
        };
        let mag = rii.real().abs().max(rii.imaginary().abs());
        if !rii.is_finite() || mag < min_normal::<T>() {
            return Err(FilterError::Singular);
        }
        let wi = acc / rii;
        if !wi.is_finite() {
            return Err(FilterError::Singular);
        }
        *w_i = wi;
    }
    Ok(())
}

/// Conditioning indicator `min_i |R_ii| / max_i |R_ii|` of an `M x M`
/// row-major factor (`r.len()` must be a non-zero square). It is `1` right
/// after [`init`], falls toward `0` as some direction of `w` loses
/// excitation (`cond(R) >= 1 / ratio`), and is `0` if the factor is zero.
pub fn r_diag_ratio<F, T>(r: &[F]) -> Result<T, FilterError>
where
    F: ComplexField<RealField = T> + Copy,
    T: Real,
{
    let m = r.len().isqrt();
    if m == 0 || m * m != r.len() {
        return Err(FilterError::Dimension);
    }
    Ok(diag_ratio(r.iter().step_by(m + 1).copied()))
}

fn diag_ratio<F, T>(diag: impl Iterator<Item = F>) -> T
where
    F: ComplexField<RealField = T> + Copy,
    T: Real,
{
    let mut lo = T::max_value().unwrap_or_else(T::one);
    let mut hi = T::zero();
    for x in diag {
        let a = x.modulus();
        lo = lo.min(a);
        hi = hi.max(a);
    }
    if hi > T::zero() && hi.is_finite() {
        lo / hi
    } else {
        T::zero()
    }
}

/// Result of one [`VectorQrdRls`] step: per row `j`, the a-posteriori error
/// `xi_j = d_j - u_j w^(j)` and the conversion factor
/// `gamma_j = 1 - u_j P^(j) u_j^H` (see the module documentation;
/// `xi_j = gamma_j alpha_j` with the a-priori error `alpha_j`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UpdateInfo<F: ComplexField, const N: usize> {
    /// A-posteriori errors, one per row.
    pub xi: [F; N],
    /// Conversion factors in `(0, 1]`, one per row.
    pub gamma: [F::RealField; N],
}

/// Owning, fixed-size vector QRD/RLS for firmware: `M` unknowns, `N` rows
/// per step, field `F` = `Complex<T>` (the paper's formulation) or `T`
/// (real formulation). All storage is inline (`M^2 + 2M` values of `F`).
///
/// `Clone` and `PartialEq` compare the whole state (factor, right-hand
/// side, prior weights, `lambda`, `delta`).
///
/// Set up, fold in one block of `N` rows, read the weights:
///
/// ```
/// use rotorid_core::qrdrls::VectorQrdRls;
///
/// // Two real unknowns, two equations per step (lambda 1, delta 1e-12).
/// let mut filter = VectorQrdRls::<f64, 2, 2>::new(1.0, 1e-12).unwrap();
/// let u = [[1.0, 0.5], [0.0, 3.0]];
/// let d = [1.5, -3.0]; // u w for w = [2, -1]
/// let info = filter.update(&u, &d).unwrap();
/// let w = filter.weights().unwrap();
/// assert!((w[0] - 2.0).abs() < 1e-9 && (w[1] + 1.0).abs() < 1e-9);
/// assert!(info.xi.iter().all(|e| e.abs() < 1e-9)); // a-posteriori errors
/// ```
///
/// `M = 0` does not compile:
///
/// ```compile_fail
/// let f = rotorid_core::qrdrls::VectorQrdRls::<f64, 0, 1>::new(1.0, 1.0);
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct VectorQrdRls<F: ComplexField, const M: usize, const N: usize> {
    r: [[F; M]; M],
    p: [F; M],
    w0: [F; M],
    lambda: F::RealField,
    delta: F::RealField,
}

impl<F, T, const M: usize, const N: usize> VectorQrdRls<F, M, N>
where
    F: ComplexField<RealField = T> + Copy,
    T: Real,
{
    /// A fresh filter with zero prior weights: `R = sqrt(delta) I`, `p = 0`.
    ///
    /// Errors: `InvalidLambda` (`lambda` not in `(0, 1]`), `InvalidDelta`
    /// (`delta` not finite and positive). `M = 0` is a compile error.
    pub fn new(lambda: T, delta: T) -> Result<Self, FilterError> {
        Self::with_weights(lambda, delta, &[F::zero(); M])
    }

    /// A fresh filter with prior weights `w0`: `R = sqrt(delta) I`,
    /// `p = sqrt(delta) w0` (so that `weights()` returns `w0`).
    ///
    /// Errors: as [`VectorQrdRls::new`], and `NonFinite` for `w0`.
    pub fn with_weights(lambda: T, delta: T, w0: &[F; M]) -> Result<Self, FilterError> {
        const { assert!(M > 0, "VectorQrdRls: M (unknowns) must be > 0") };
        validate_lambda(lambda)?;
        let mut s = Self {
            r: [[F::zero(); M]; M],
            p: [F::zero(); M],
            w0: *w0,
            lambda,
            delta,
        };
        init(s.r.as_flattened_mut(), &mut s.p, delta, Some(w0))?;
        Ok(s)
    }

    /// Back to the state right after construction (same `delta`, `w0`; the
    /// current `lambda` is kept).
    pub fn reset(&mut self) {
        let sd = self.delta.sqrt();
        for (i, row) in self.r.iter_mut().enumerate() {
            for (k, x) in row.iter_mut().enumerate() {
                *x = if i == k { F::from_real(sd) } else { F::zero() };
            }
        }
        for (pi, wi) in self.p.iter_mut().zip(&self.w0) {
            *pi = wi.scale(sd);
        }
    }

    /// Restarts with new prior weights `w0` (and the construction `delta`).
    pub fn reset_with_weights(&mut self, w0: &[F; M]) -> Result<(), FilterError> {
        check_finite(w0, &[])?;
        self.w0 = *w0;
        self.reset();
        Ok(())
    }

    /// One step with the filter's own `lambda`: folds the `N` rows of `u`
    /// with right-hand sides `d`. See [`VectorQrdRls::update_with_lambda`].
    pub fn update(&mut self, u: &[[F; M]; N], d: &[F; N]) -> Result<UpdateInfo<F, N>, FilterError> {
        self.update_with_lambda(u, d, self.lambda)
    }

    /// One step with forgetting factor `lambda` for this step only
    /// (`lambda = 1`: no forgetting, e.g. to freeze adaptation when the
    /// excitation is poor). Returns the a-posteriori errors and conversion
    /// factors per row.
    ///
    /// Errors (state unchanged): `InvalidLambda`, `NonFinite`.
    pub fn update_with_lambda(
        &mut self,
        u: &[[F; M]; N],
        d: &[F; N],
        lambda: T,
    ) -> Result<UpdateInfo<F, N>, FilterError> {
        let mut info = UpdateInfo {
            xi: [F::zero(); N],
            gamma: [T::zero(); N],
        };
        update_rows(
            self.r.as_flattened_mut(),
            &mut self.p,
            u.as_flattened(),
            d,
            lambda,
            &mut info.xi,
            &mut info.gamma,
        )?;
        Ok(info)
    }

    /// Current weights by back-substitution of `R w = p` (`O(M^2)`).
    ///
    /// Errors: `Singular` if a diagonal entry of `R` has decayed below the
    /// smallest normal number (only after extremely long runs without
    /// excitation in some direction with `lambda < 1`, e.g. 2045 steps of
    /// zero rows with `lambda = 0.5` in `f64`).
    pub fn weights(&self) -> Result<[F; M], FilterError> {
        let mut w = [F::zero(); M];
        solve_weights(self.r.as_flattened(), &self.p, &mut w)?;
        Ok(w)
    }

    /// The default forgetting factor.
    pub fn lambda(&self) -> T {
        self.lambda
    }

    /// Changes the default forgetting factor (`InvalidLambda` if not in `(0, 1]`).
    pub fn set_lambda(&mut self, lambda: T) -> Result<(), FilterError> {
        validate_lambda(lambda)?;
        self.lambda = lambda;
        Ok(())
    }

    /// The regularisation `delta` of `R(0) = sqrt(delta) I`.
    pub fn delta(&self) -> T {
        self.delta
    }

    /// `min_i |R_ii| / max_i |R_ii|` (see [`r_diag_ratio`]).
    pub fn r_diag_ratio(&self) -> T {
        diag_ratio(
            self.r
                .iter()
                .enumerate()
                .filter_map(|(i, row)| row.get(i).copied()),
        )
    }

    /// The factor `R` (upper triangular, real non-negative diagonal).
    pub fn r(&self) -> &[[F; M]; M] {
        &self.r
    }

    /// The rotated right-hand side `p` (`R w = p`).
    pub fn p(&self) -> &[F; M] {
        &self.p
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use num_complex::Complex;

    type C = Complex<f64>;

    #[test]
    fn exact_data_recovers_weights() {
        // Two complex unknowns, rows chosen so that after two steps the
        // regularisation is negligible.
        let w = [C::new(1.0, -2.0), C::new(0.5, 3.0)];
        let mut f = VectorQrdRls::<C, 2, 2>::new(1.0, 1e-12).unwrap();
        let us = [
            [
                [C::new(1.0, 0.0), C::new(0.0, 1.0)],
                [C::new(2.0, 1.0), C::new(-1.0, 0.5)],
            ],
            [
                [C::new(0.3, -0.7), C::new(1.5, 0.0)],
                [C::new(0.0, 0.0), C::new(0.0, 0.0)],
            ],
        ];
        for u in &us {
            let d = [
                u[0][0] * w[0] + u[0][1] * w[1],
                u[1][0] * w[0] + u[1][1] * w[1],
            ];
            let info = f.update(u, &d).unwrap();
            assert!(info.gamma.iter().all(|g| *g > 0.0 && *g <= 1.0));
        }
        let est = f.weights().unwrap();
        for k in 0..2 {
            assert!((est[k] - w[k]).norm() < 1e-9, "{est:?}");
        }
        // The strictly lower triangle is workspace, zero again after the step.
        assert_eq!(f.r()[1][0], C::new(0.0, 0.0));
    }

    #[test]
    fn zero_row_is_a_no_op_and_returns_d() {
        let mut f = VectorQrdRls::<f64, 3, 1>::with_weights(1.0, 2.0, &[1.0, 2.0, 3.0]).unwrap();
        let before = f.clone();
        let info = f.update(&[[0.0; 3]], &[5.0]).unwrap();
        assert_eq!(f, before);
        assert_eq!(info.xi, [5.0]);
        assert_eq!(info.gamma, [1.0]);
        assert_eq!(f.weights().unwrap(), [1.0, 2.0, 3.0]);
    }

    #[test]
    fn validation() {
        assert_eq!(
            VectorQrdRls::<f32, 2, 1>::new(0.0, 1.0).unwrap_err(),
            FilterError::InvalidLambda
        );
        assert_eq!(
            VectorQrdRls::<f32, 2, 1>::new(1.5, 1.0).unwrap_err(),
            FilterError::InvalidLambda
        );
        assert_eq!(
            VectorQrdRls::<f32, 2, 1>::new(f32::NAN, 1.0).unwrap_err(),
            FilterError::InvalidLambda
        );
        assert_eq!(
            VectorQrdRls::<f32, 2, 1>::new(1.0, 0.0).unwrap_err(),
            FilterError::InvalidDelta
        );
        assert_eq!(
            VectorQrdRls::<f32, 2, 1>::new(1.0, f32::INFINITY).unwrap_err(),
            FilterError::InvalidDelta
        );
        assert_eq!(
            VectorQrdRls::<f32, 2, 1>::with_weights(1.0, 1.0, &[f32::NAN, 0.0]).unwrap_err(),
            FilterError::NonFinite
        );
        let mut f = VectorQrdRls::<f32, 2, 1>::new(0.9, 1.0).unwrap();
        assert_eq!(
            f.update_with_lambda(&[[1.0, 1.0]], &[1.0], 0.0)
                .unwrap_err(),
            FilterError::InvalidLambda
        );
        assert_eq!(f.set_lambda(-1.0).unwrap_err(), FilterError::InvalidLambda);
        assert_eq!(f.lambda(), 0.9);
        let mut r = [0.0f64; 5];
        let mut p = [0.0f64; 2];
        assert_eq!(
            init(&mut r, &mut p, 1.0, None).unwrap_err(),
            FilterError::Dimension
        );
        let mut r = [0.0f64; 4];
        init(&mut r, &mut p, 4.0, None).unwrap();
        assert_eq!(r, [2.0, 0.0, 0.0, 2.0]);
        let (mut e, mut g) = ([0.0; 1], [0.0; 1]);
        assert_eq!(
            update_rows(
                &mut r,
                &mut p,
                &[1.0, 2.0, 3.0],
                &[1.0],
                1.0,
                &mut e,
                &mut g
            )
            .unwrap_err(),
            FilterError::Dimension
        );
        assert_eq!(r_diag_ratio(&r).unwrap(), 1.0);
    }
}

#[cfg(test)]
mod blocking_tests {
    use super::*;
    use crate::testrng::SplitMix64;
    use num_complex::Complex;

    fn run<F, T>(
        m: usize,
        n: usize,
        steps: usize,
        zeros: bool,
        blocked: bool,
        mk: &dyn Fn(f64, f64) -> F,
    ) -> ([F; 4096], [F; 64], [F; 64], [T; 64])
    where
        F: ComplexField<RealField = T> + Copy,
        T: Real,
    {
        let mut rng = SplitMix64::new(0x1234_5678_9abc_def0);
        let mut r = [F::zero(); 4096];
        let mut p = [F::zero(); 64];
        init(&mut r[..m * m], &mut p[..m], T::lit(0.1), None).unwrap();
        let (mut xi, mut ga) = ([F::zero(); 64], [T::zero(); 64]);
        let mut u = [F::zero(); 4096];
        let mut d = [F::zero(); 64];
        for _ in 0..steps {
            for x in u[..n * m].iter_mut() {
                let (a, b) = (rng.sym(), rng.sym());
                *x = if zeros && a.abs() < 0.3 {
                    F::zero()
                } else {
                    mk(a, b)
                };
            }
            for x in d[..n].iter_mut() {
                *x = mk(rng.sym(), rng.sym());
            }
            update_rows_impl(
                &mut r[..m * m],
                &mut p[..m],
                &u[..n * m],
                &d[..n],
                T::lit(0.97),
                &mut xi[..n],
                &mut ga[..n],
                blocked,
            )
            .unwrap();
        }
        (r, p, xi, ga)
    }

    #[test]
    fn blocked_folding_is_bit_identical_to_row_by_row() {
        let c64 = |a: f64, b: f64| Complex::new(a, b);
        let c32 = |a: f64, b: f64| Complex::new(a as f32, b as f32);
        let r32 = |a: f64, _b: f64| a as f32;
        // (M, N): block 4 with remainders, block 2 (M = 40), block 1 (M = 64).
        for &(m, n) in &[(1, 3), (2, 5), (19, 4), (22, 8), (7, 7), (40, 8), (64, 3)] {
            for zeros in [false, true] {
                let a = run::<Complex<f64>, f64>(m, n, 5, zeros, true, &c64);
                let b = run::<Complex<f64>, f64>(m, n, 5, zeros, false, &c64);
                assert!(
                    a.0.iter()
                        .zip(&b.0)
                        .all(|(x, y)| x.re.to_bits() == y.re.to_bits()
                            && x.im.to_bits() == y.im.to_bits()),
                    "M={m} N={n}"
                );
                assert!(a.1 == b.1 && a.2 == b.2 && a.3 == b.3, "M={m} N={n}");
                let a = run::<Complex<f32>, f32>(m, n, 5, zeros, true, &c32);
                let b = run::<Complex<f32>, f32>(m, n, 5, zeros, false, &c32);
                assert!(
                    a.0.iter()
                        .zip(&b.0)
                        .all(|(x, y)| x.re.to_bits() == y.re.to_bits()
                            && x.im.to_bits() == y.im.to_bits()),
                    "M={m} N={n}"
                );
                assert!(a.1 == b.1 && a.2 == b.2 && a.3 == b.3, "M={m} N={n}");
                let a = run::<f32, f32>(m, n, 5, zeros, true, &r32);
                let b = run::<f32, f32>(m, n, 5, zeros, false, &r32);
                assert!(
                    a.0.iter()
                        .zip(&b.0)
                        .all(|(x, y)| x.to_bits() == y.to_bits()),
                    "M={m} N={n}"
                );
                assert!(a.1 == b.1 && a.2 == b.2 && a.3 == b.3, "M={m} N={n}");
            }
        }
    }
}
