//! Bearing-level model tables: the finite-element rotor reduced, speed by
//! speed, to the bearing degrees of freedom (Eqs. 35-39, 44-46 of the method
//! paper, with the corrections of the project specification).
//!
//! # What a table holds
//!
//! With `q_B` the shaft's absolute displacements at the bearing nodes
//! (`NQ = 2 N_b` channels, ordered `b1_y, b1_z, b2_y, ...`, metres) and `a`
//! the complex unbalance of the `NP` planes (kg m), the shaft-and-disk model
//! (no bearings, no pedestals) gives at every speed `Omega` (rad/s)
//!
//! ```text
//! A(Omega) q_B = -Z_B(Omega) q_B + B(Omega) a          (N)
//! A = Z_R,BB - Y Z_R,iB              (N/m,  NQ x NQ)
//! B = Omega^2 (T_B - Y T_i)          (N/(kg m) = 1/s^2, NQ x NP)
//! Y = Z_R,Bi Z_R,ii^-1
//! ```
//!
//! where `Z_R = K - Omega^2 M + j Omega^2 G` is the shaft-and-disk dynamic
//! stiffness and `T` the unbalance distribution (`1` at a plane's `y` DOF,
//! `-j` at its `z` DOF). The identifier's desired response is `d = A q_B`
//! (Eq. 45) and `B` are the unbalance columns of its data matrix (Eq. 46).
//!
//! # Interpolation between grid speeds (pole-factored, linear in `X / Omega^2`)
//!
//! `Y` has poles at the speeds `Omega_k` where the shaft with its bearing
//! points held fixed resonates (`det Z_R,ii(Omega_k) = 0`). `A` has all of
//! them; `B` only those whose mode the unbalance excites (for an
//! axisymmetric shaft the backward-whirl crossings drop out of `B`: a
//! forward-rotating force does no work on a backward mode), and factoring
//! out a pole a matrix does not have would create an error `~h^2 / delta`
//! near it. So a table stores a pole list for `A` and one for `B` (at most
//! [`MAX_POLES`] each, those inside or near the grid) and interpolates linearly
//! in `Omega`, between the grid speeds `w0 < Omega < w1` around the measured
//! speed, the pole-free, slowly varying products
//!
//! ```text
//! p_X(Omega) X(Omega) / Omega^2   for X = A and X = B,
//! p_X(Omega) = prod_k (Omega_k^2 - Omega^2)   over the poles of X
//! ```
//!
//! then multiplies by `Omega^2 / p_X(Omega)` exactly. With
//! `t = (Omega - w0) / (w1 - w0)`:
//!
//! ```text
//! X(Omega) = c0 X(w0) + c1 X(w1)
//! c0 = (1 - t) (p_X(w0) / p_X(Omega)) (Omega / w0)^2
//! c1 = t (p_X(w1) / p_X(Omega)) (Omega / w1)^2
//! ```
//!
//! (see [`weights`]; the ratios `p(w) / p(Omega)` are formed factor by
//! factor, so nothing overflows). Why these choices:
//!
//! * Plain linear interpolation of a function with a simple pole has an
//!   `O(1)` relative error in the interval that contains the pole however
//!   fine the grid; `p_X X` is smooth, so the error is `O(h^2)` everywhere,
//!   across the poles too.
//! * `B = Omega^2 (T_B - Y T_i)` grows like `Omega^2`, and so does `A` for
//!   a shaft on two bearings (`A(0) = 0`: any bearing displacement is a
//!   rigid-body motion of the free shaft, `A ~ -Omega^2 M_red` at low
//!   speed). Linear interpolation of `Omega^2` has the relative error
//!   `(h / 2 Omega)^2`, which would force a fine grid at low speed; of
//!   `X / Omega^2`, which is nearly constant there, almost none. (With
//!   three or more bearings `A(0) != 0` and `A / Omega^2 ~ A(0) / Omega^2`
//!   at low speed: the error is then `~(h / Omega)^2`, the same order as
//!   interpolating `A` itself.)
//!
//! At a grid speed the stored matrices are returned exactly; a speed
//! outside the grid is [`TableError::OutOfRange`]; a speed between grid
//! speeds and within [`POLE_GUARD`] (relative) of a pole is
//! [`TableError::Pole`].
//!
//! # Binary blob (format version 2), little-endian, byte by byte
//!
//! `w` is the scalar width (4 for f32, 8 for f64), `NQ = 2 N_b`. Besides the
//! reduced model a blob carries the identification it was written for: the
//! model structure ([`Structure`]: formulation and order) and the column
//! scaling ([`ColumnScaling`]: three reference magnitudes, always stored as
//! f64 and rounded once to the reader's `T`), so that firmware sets up its
//! identifier from the blob alone ([`TableSetup`]).
//!
//! | offset | size | field |
//! |---|---|---|
//! | 0 | 8 | magic `b"ROTORTBL"` |
//! | 8 | 2 | format version, u16 = 2 |
//! | 10 | 1 | scalar type, u8: 4 = f32, 8 = f64 (its width in bytes) |
//! | 11 | 1 | reserved, u8 = 0 |
//! | 12 | 2 | number of shaft nodes of the model, u16 (>= 2) |
//! | 14 | 2 | N_b, number of bearings, u16 (1..=[`MAX_BEARINGS`]) |
//! | 16 | 2 | N_p, number of unbalance planes, u16 (0..=[`MAX_PLANES`]) |
//! | 18 | 1 | N_ka, number of poles of `A`, u8 (0..=[`MAX_POLES`]) |
//! | 19 | 1 | N_kb, number of poles of `B`, u8 (0..=[`MAX_POLES`]) |
//! | 20 | 4 | N_s, number of speeds, u32 (>= 1) |
//! | 24 | 1 | formulation, u8: 1 = paper (complex `Z_p`), 2 = physical (real `K_p`, `C_p`) |
//! | 25 | 1 | order `P`, u8 (1..=[`MAX_ORDER`]) |
//! | 26 | 6 | reserved, 0 |
//! | 32 | 8 | scaling: reference stiffness `s_K` (N/m), f64, finite, > 0 |
//! | 40 | 8 | scaling: reference speed `Omega_r` (rad/s), f64, finite, > 0 |
//! | 48 | 8 | scaling: reference unbalance `s_a` (kg m), f64, finite, > 0 |
//! | 56 | 2 N_p | plane nodes, u16 each, 1-based, distinct |
//! | 56 + 2 N_p | 2 N_b | bearing nodes, u16 each, 1-based, strictly increasing |
//! | P = 56 + 2 (N_p + N_b) | w N_ka | poles of `A` (rad/s), finite, > 0, strictly increasing |
//! | P + w N_ka | w N_kb | poles of `B` (rad/s), finite, > 0, strictly increasing |
//! | S = P + w (N_ka + N_kb) | w N_s | speeds (rad/s), finite, > 0, strictly increasing |
//! | D = S + w N_s | N_s R | per speed: `A` row-major (NQ x NQ), then `B` row-major (NQ x N_p), each entry `re` then `im`; `R = 2 w (NQ^2 + NQ N_p)` |
//! | D + N_s R | 4 | CRC-32 (IEEE, [`crate::crc32`]) of every byte before it, u32 |
//!
//! The scaling must also be finite and > 0 once rounded to the reader's
//! `T` ([`ColumnScaling::new`]). Version 1 (the same without bytes 24..56)
//! is refused with [`TableError::UnsupportedVersion`]; rebuild such a blob
//! with `rotorid tables`.
//!
//! The total length is exactly `D + N_s R + 4`; anything else is rejected.
//! Every matrix entry must be finite.
//!
//! Nothing here allocates, uses `unsafe` or panics on any input: values are
//! read with `from_le_bytes` on checked sub-slices and all size arithmetic is
//! checked.

use core::fmt;
use core::marker::PhantomData;

use num_complex::Complex;

use crate::crc32::crc32;
use crate::parametrization::{Formulation, Structure, MAX_ORDER};
use crate::scaling::ColumnScaling;
use crate::Real;

/// Magic bytes at offset 0 of a table blob.
pub const MAGIC: [u8; 8] = *b"ROTORTBL";
/// The blob format version this reader understands (and the writer writes).
pub const FORMAT_VERSION: u16 = 2;
/// Length of the fixed header (bytes), before the node lists.
pub const HEADER_LEN: usize = 56;
/// Formulation code of [`Formulation::Paper`] at byte 24.
pub const FORMULATION_PAPER: u8 = 1;
/// Formulation code of [`Formulation::Physical`] at byte 24.
pub const FORMULATION_PHYSICAL: u8 = 2;

/// The blob code of a formulation (byte 24).
pub const fn formulation_code(f: Formulation) -> u8 {
    match f {
        Formulation::Paper => FORMULATION_PAPER,
        Formulation::Physical => FORMULATION_PHYSICAL,
    }
}

/// The formulation of a blob code, `None` for an unknown code.
pub const fn formulation_from_code(code: u8) -> Option<Formulation> {
    match code {
        FORMULATION_PAPER => Some(Formulation::Paper),
        FORMULATION_PHYSICAL => Some(Formulation::Physical),
        _ => None,
    }
}
/// Largest number of poles a table may carry.
pub const MAX_POLES: usize = 16;
/// Relative half-width of the band around each pole where a lookup returns
/// [`TableError::Pole`]: `|Omega - Omega_k| <= POLE_GUARD Omega_k`. Inside
/// it `A ~ 1 / (Omega - Omega_k)` is so large that a pole position known to
/// `~1e-12` relative (the round-off of the reduction) already changes it
/// by more than `1e-6`; for the paper rotor the band is +-0.007 rpm.
pub const POLE_GUARD: f64 = 1e-6;
/// Largest number of bearings a blob may declare.
pub const MAX_BEARINGS: usize = 64;
/// Largest number of unbalance planes a blob may declare.
pub const MAX_PLANES: usize = 256;

/// Why a table was rejected or a lookup failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TableError {
    /// The blob is shorter than its fixed header.
    Truncated {
        /// Bytes needed.
        needed: usize,
        /// Bytes present.
        found: usize,
    },
    /// The first 8 bytes are not [`MAGIC`].
    BadMagic,
    /// A format version this reader does not read (version 1 blobs carry
    /// no structure and scaling: rebuild them with `rotorid tables`).
    UnsupportedVersion {
        /// Version found in the blob.
        found: u16,
        /// The version this reader reads ([`FORMAT_VERSION`]).
        expected: u16,
    },
    /// The blob's scalar type (byte 10) is not the reader's `T`
    /// (or is neither 4 nor 8).
    ScalarType {
        /// Code of the reader's type (4 or 8).
        expected: u8,
        /// Code found in the blob.
        found: u8,
    },
    /// A reserved byte is not zero.
    Reserved,
    /// The model structure (formulation code, order) is unknown or out of
    /// range.
    BadStructure,
    /// A reference magnitude of the column scaling is not finite and > 0
    /// (in f64, or once rounded to the reader's scalar type).
    BadScaling,
    /// A count is zero where it must not be, above its limit, or the sizes
    /// overflow.
    BadSize,
    /// The blob length is not what its header implies.
    Length {
        /// Length implied by the header.
        expected: usize,
        /// Actual length.
        found: usize,
    },
    /// The stored CRC-32 does not match the contents.
    Crc {
        /// CRC stored in the blob.
        stored: u32,
        /// CRC computed over the blob.
        computed: u32,
    },
    /// A node number is 0, beyond the model's nodes, repeated, or bearing
    /// nodes are not strictly increasing.
    BadNode,
    /// A stored value, or a speed asked for, is NaN or infinite.
    NonFinite,
    /// Speeds not strictly increasing, or not > 0.
    SpeedsNotIncreasing,
    /// Poles not finite, > 0 and strictly increasing, or too many.
    BadPole,
    /// The table's `2 N_b`, `N_p` or number of speeds does not match the
    /// const-generic sizes asked for.
    Dimension,
    /// The speed asked for is outside the grid.
    OutOfRange,
    /// The speed asked for sits on a pole: `A` and `B` are infinite there.
    Pole,
    /// Internal inconsistency of an owned table (e.g. `n_poles` above
    /// [`MAX_POLES`] or speeds not increasing in a hand-built [`Table`]).
    Corrupt,
}

impl fmt::Display for TableError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TableError::Truncated { needed, found } => {
                write!(
                    f,
                    "table blob truncated: {found} bytes, header needs {needed}"
                )
            }
            TableError::BadMagic => write!(f, "not a rotorid table (bad magic)"),
            TableError::UnsupportedVersion { found, expected } => {
                if *found < *expected {
                    write!(
                        f,
                        "table blob format version {found} is no longer read; rebuild it with `rotorid tables`"
                    )
                } else {
                    write!(
                        f,
                        "table blob format version {found} is not known to this reader (it reads version {expected})"
                    )
                }
            }
            TableError::ScalarType { expected, found } => write!(
                f,
                "table scalar type code {found}, reader expects {expected} (4 = f32, 8 = f64)"
            ),
            TableError::Reserved => write!(f, "reserved header byte is not zero"),
            TableError::BadStructure => write!(
                f,
                "table model structure invalid (formulation code 1 = paper, 2 = physical; order 1..={MAX_ORDER})"
            ),
            TableError::BadScaling => {
                write!(f, "table column scaling not finite and > 0 in the reader's type")
            }
            TableError::BadSize => write!(f, "table sizes out of range"),
            TableError::Length { expected, found } => {
                write!(f, "table blob has {found} bytes, header implies {expected}")
            }
            TableError::Crc { stored, computed } => write!(
                f,
                "table CRC mismatch: stored {stored:#010x}, computed {computed:#010x}"
            ),
            TableError::BadNode => write!(f, "implausible node numbers in table"),
            TableError::NonFinite => write!(f, "non-finite value"),
            TableError::SpeedsNotIncreasing => {
                write!(f, "table speeds not > 0 and strictly increasing")
            }
            TableError::BadPole => write!(f, "table poles not > 0 and strictly increasing"),
            TableError::Dimension => write!(f, "table dimensions do not match"),
            TableError::OutOfRange => write!(f, "speed outside the table's grid"),
            TableError::Pole => write!(f, "speed on a pole of the reduced model"),
            TableError::Corrupt => write!(f, "inconsistent table"),
        }
    }
}

impl core::error::Error for TableError {}

/// A scalar type a table can be stored in: `f32` (code 4) or `f64` (code 8).
pub trait TableScalar: Real {
    /// Type code in the blob header (its width in bytes).
    const TYPE_CODE: u8;
    /// Width in bytes.
    const WIDTH: usize;
    /// Reads one little-endian value; `None` unless `bytes.len() == WIDTH`.
    fn from_le(bytes: &[u8]) -> Option<Self>;
}

impl TableScalar for f32 {
    const TYPE_CODE: u8 = 4;
    const WIDTH: usize = 4;
    fn from_le(bytes: &[u8]) -> Option<Self> {
        <[u8; 4]>::try_from(bytes).ok().map(f32::from_le_bytes)
    }
}

impl TableScalar for f64 {
    const TYPE_CODE: u8 = 8;
    const WIDTH: usize = 8;
    fn from_le(bytes: &[u8]) -> Option<Self> {
        <[u8; 8]>::try_from(bytes).ok().map(f64::from_le_bytes)
    }
}

/// The reduced model at one speed: `A` (N/m, NQ x NQ) and `B` (1/s^2,
/// NQ x NP), such that `A q_B = -Z_B q_B + B a` (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Terms<T, const NQ: usize, const NP: usize> {
    /// `A = Z_R,BB - Y Z_R,iB`, row-major `a[row][col]`.
    pub a: [[Complex<T>; NQ]; NQ],
    /// `B = Omega^2 (T_B - Y T_i)`, row-major `b[row][plane]`.
    pub b: [[Complex<T>; NP]; NQ],
}

impl<T: Real, const NQ: usize, const NP: usize> Terms<T, NQ, NP> {
    /// All entries zero.
    pub fn zero() -> Self {
        let z = Complex::new(T::zero(), T::zero());
        Terms {
            a: [[z; NQ]; NQ],
            b: [[z; NP]; NQ],
        }
    }
}

/// Anything that gives the reduced terms at a measured speed.
pub trait BearingTable<T, const NQ: usize, const NP: usize> {
    /// `A` and `B` at `omega` (rad/s): exact at grid speeds, interpolated
    /// (pole-factored linear, see the module docs) between them.
    ///
    /// Errors: [`TableError::NonFinite`] for a non-finite speed (or a result
    /// that overflows),
    /// [`TableError::OutOfRange`] outside the grid, [`TableError::Dimension`]
    /// if `NQ`/`NP` are not the table's, [`TableError::Pole`] on a pole.
    fn terms(&self, omega: T) -> Result<Terms<T, NQ, NP>, TableError>;
    /// First and last grid speed (rad/s).
    fn speed_range(&self) -> (T, T);
}

/// What a table says about the identification it was written for: the
/// model structure and the column scaling (`rotorid tables --formulation
/// .. --order ..` writes both). [`crate::identify::Identifier::from_table`]
/// sets an identifier up from it.
pub trait TableSetup<T> {
    /// The model structure (formulation and order).
    fn structure(&self) -> Structure;
    /// The column scaling (reference stiffness, speed, unbalance).
    fn scaling(&self) -> ColumnScaling<T>;
}

/// Where a speed falls on a grid.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Position {
    /// On grid speed `i`.
    Exact(usize),
    /// Strictly between grid speeds `i` and `i + 1`.
    Between(usize),
}

/// Locates `omega` on a grid of `n` speeds given by `speed(i)` (assumed
/// strictly increasing; if they are not, the answer is some in-range index,
/// never a panic). Binary search, `O(log n)`.
pub fn locate<T: Real>(
    n: usize,
    speed: impl Fn(usize) -> Option<T>,
    omega: T,
) -> Result<Position, TableError> {
    if !omega.is_finite() {
        return Err(TableError::NonFinite);
    }
    if n == 0 {
        return Err(TableError::OutOfRange);
    }
    let last = n - 1;
    let first_speed = speed(0).ok_or(TableError::Corrupt)?;
    let last_speed = speed(last).ok_or(TableError::Corrupt)?;
    if omega < first_speed || omega > last_speed {
        return Err(TableError::OutOfRange);
    }
    let (mut lo, mut hi) = (0usize, last);
    while hi - lo > 1 {
        let mid = lo + (hi - lo) / 2;
        if speed(mid).ok_or(TableError::Corrupt)? <= omega {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    if speed(lo).ok_or(TableError::Corrupt)? == omega {
        Ok(Position::Exact(lo))
    } else if speed(hi).ok_or(TableError::Corrupt)? == omega {
        Ok(Position::Exact(hi))
    } else if lo == hi {
        Err(TableError::OutOfRange)
    } else {
        Ok(Position::Between(lo))
    }
}

/// Interpolation weights between grid speeds `w0 < omega < w1`:
/// `X(omega) = c0 X(w0) + c1 X(w1)` for `X = A` and `X = B`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Weights<T> {
    /// Weight of `X(w0)`: `(1 - t) (p(w0) / p(omega)) (omega / w0)^2`.
    pub c0: T,
    /// Weight of `X(w1)`: `t (p(w1) / p(omega)) (omega / w1)^2`.
    pub c1: T,
}

/// The interpolation weights of the module docs (pole-factored, linear in
/// `X / Omega^2`), with `p(Omega) = prod_k (Omega_k^2 - Omega^2)` over
/// `poles` (rad/s). `t = (omega - w0) / (w1 - w0)`; each ratio
/// `p(w) / p(omega)` is formed factor by factor as
/// `(Omega_k - w)(Omega_k + w) / ((Omega_k - omega)(Omega_k + omega))`.
///
/// Errors: [`TableError::NonFinite`] if an input is not finite,
/// [`TableError::Corrupt`] unless `0 < w0 < w1`, [`TableError::Pole`] if
/// `omega` is within [`POLE_GUARD`] (relative) of a pole or a weight is not
/// finite.
pub fn weights<T: Real>(omega: T, w0: T, w1: T, poles: &[T]) -> Result<Weights<T>, TableError> {
    if !(omega.is_finite() && w0.is_finite() && w1.is_finite()) {
        return Err(TableError::NonFinite);
    }
    let zero = T::zero();
    if !(w0 > zero && w1 > w0) {
        return Err(TableError::Corrupt);
    }
    let t = (omega - w0) / (w1 - w0);
    let mut r0 = T::one();
    let mut r1 = T::one();
    let guard = T::lit(POLE_GUARD);
    for &p in poles {
        if (omega - p).abs() <= guard * p {
            return Err(TableError::Pole);
        }
        let den = (p - omega) * (p + omega);
        r0 *= (p - w0) * (p + w0) / den;
        r1 *= (p - w1) * (p + w1) / den;
    }
    let s0 = omega / w0;
    let s1 = omega / w1;
    let w = Weights {
        c0: (T::one() - t) * r0 * s0 * s0,
        c1: t * r1 * s1 * s1,
    };
    if w.c0.is_finite() && w.c1.is_finite() {
        Ok(w)
    } else {
        Err(TableError::Pole)
    }
}

/// Shared lookup: fills a [`Terms`] from entry accessors.
fn lookup<T: Real, const NQ: usize, const NP: usize>(
    n_s: usize,
    speed: impl Fn(usize) -> Option<T>,
    poles_a: &[T],
    poles_b: &[T],
    a_at: impl Fn(usize, usize, usize) -> Option<Complex<T>>,
    b_at: impl Fn(usize, usize, usize) -> Option<Complex<T>>,
    omega: T,
) -> Result<Terms<T, NQ, NP>, TableError> {
    let mut out = Terms::<T, NQ, NP>::zero();
    match locate(n_s, &speed, omega)? {
        Position::Exact(i) => {
            for (r, row) in out.a.iter_mut().enumerate() {
                for (c, x) in row.iter_mut().enumerate() {
                    *x = a_at(i, r, c).ok_or(TableError::Corrupt)?;
                }
            }
            for (r, row) in out.b.iter_mut().enumerate() {
                for (c, x) in row.iter_mut().enumerate() {
                    *x = b_at(i, r, c).ok_or(TableError::Corrupt)?;
                }
            }
        }
        Position::Between(i) => {
            let j = i + 1;
            let w0 = speed(i).ok_or(TableError::Corrupt)?;
            let w1 = speed(j).ok_or(TableError::Corrupt)?;
            let w = weights(omega, w0, w1, poles_a)?;
            let wb = weights(omega, w0, w1, poles_b)?;
            for (r, row) in out.a.iter_mut().enumerate() {
                for (c, x) in row.iter_mut().enumerate() {
                    let x0 = a_at(i, r, c).ok_or(TableError::Corrupt)?;
                    let x1 = a_at(j, r, c).ok_or(TableError::Corrupt)?;
                    *x = x0 * w.c0 + x1 * w.c1;
                }
            }
            let w = wb;
            for (r, row) in out.b.iter_mut().enumerate() {
                for (c, x) in row.iter_mut().enumerate() {
                    let x0 = b_at(i, r, c).ok_or(TableError::Corrupt)?;
                    let x1 = b_at(j, r, c).ok_or(TableError::Corrupt)?;
                    *x = x0 * w.c0 + x1 * w.c1;
                }
            }
            let finite = out
                .a
                .iter()
                .flatten()
                .chain(out.b.iter().flatten())
                .all(|z| z.re.is_finite() && z.im.is_finite());
            if !finite {
                // Overflow of huge stored values times the weights.
                return Err(TableError::NonFinite);
            }
        }
    }
    Ok(out)
}

fn read_u16(bytes: &[u8], off: usize) -> Option<u16> {
    let s = bytes.get(off..off.checked_add(2)?)?;
    <[u8; 2]>::try_from(s).ok().map(u16::from_le_bytes)
}

fn read_u32(bytes: &[u8], off: usize) -> Option<u32> {
    let s = bytes.get(off..off.checked_add(4)?)?;
    <[u8; 4]>::try_from(s).ok().map(u32::from_le_bytes)
}

fn read_t<T: TableScalar>(bytes: &[u8], off: usize) -> Option<T> {
    T::from_le(bytes.get(off..off.checked_add(T::WIDTH)?)?)
}

/// Checks that `n` values given by `get` are finite, > 0 and strictly
/// increasing.
fn increasing_positive<T: Real>(n: usize, get: impl Fn(usize) -> Option<T>) -> Option<bool> {
    let mut prev = T::zero();
    for i in 0..n {
        let v = get(i)?;
        if !(v.is_finite() && v > prev) {
            return Some(false);
        }
        prev = v;
    }
    Some(true)
}

/// A validated, borrowed view of a table blob (format in the module docs).
/// Nothing is copied; lookups read the bytes.
#[derive(Debug, Clone, Copy)]
pub struct TableView<'a, T> {
    bytes: &'a [u8],
    structure: Structure,
    scaling: ColumnScaling<T>,
    stored_scaling: ColumnScaling<f64>,
    n_nodes: u16,
    n_b: usize,
    n_p: usize,
    n_ka: usize,
    n_kb: usize,
    n_s: usize,
    off_planes: usize,
    off_bearings: usize,
    off_poles_a: usize,
    off_poles_b: usize,
    off_speeds: usize,
    off_data: usize,
    per_speed: usize,
    _t: PhantomData<T>,
}

/// Byte offsets of a blob's sections, from its counts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Layout {
    /// Offset of the plane nodes.
    pub planes: usize,
    /// Offset of the bearing nodes.
    pub bearings: usize,
    /// Offset of the poles of `A`.
    pub poles_a: usize,
    /// Offset of the poles of `B`.
    pub poles_b: usize,
    /// Offset of the speeds.
    pub speeds: usize,
    /// Offset of the per-speed data.
    pub data: usize,
    /// Bytes per speed: `2 w (NQ^2 + NQ N_p)`.
    pub per_speed: usize,
    /// Offset of the CRC.
    pub crc: usize,
    /// Total length.
    pub total: usize,
}

impl Layout {
    /// Offsets for scalar width `w`, `n_b` bearings, `n_p` planes, `n_ka`
    /// and `n_kb` poles and `n_s` speeds; `None` on arithmetic overflow.
    pub fn new(
        w: usize,
        n_b: usize,
        n_p: usize,
        n_ka: usize,
        n_kb: usize,
        n_s: usize,
    ) -> Option<Layout> {
        let nq = n_b.checked_mul(2)?;
        let planes = HEADER_LEN;
        let bearings = planes.checked_add(n_p.checked_mul(2)?)?;
        let poles_a = bearings.checked_add(n_b.checked_mul(2)?)?;
        let poles_b = poles_a.checked_add(n_ka.checked_mul(w)?)?;
        let speeds = poles_b.checked_add(n_kb.checked_mul(w)?)?;
        let data = speeds.checked_add(n_s.checked_mul(w)?)?;
        let entries = nq.checked_mul(nq)?.checked_add(nq.checked_mul(n_p)?)?;
        let per_speed = entries.checked_mul(2)?.checked_mul(w)?;
        let crc = data.checked_add(n_s.checked_mul(per_speed)?)?;
        let total = crc.checked_add(4)?;
        Some(Layout {
            planes,
            bearings,
            poles_a,
            poles_b,
            speeds,
            data,
            per_speed,
            crc,
            total,
        })
    }
}

impl<'a, T: TableScalar> TableView<'a, T> {
    /// Validates every field of a blob and returns a view of it: magic,
    /// version, scalar type equal to `T`, reserved byte, counts within their
    /// limits, exact length, CRC, node numbers (1..=nodes, bearings strictly
    /// increasing, planes distinct), poles and speeds finite, > 0 and
    /// strictly increasing, every matrix entry finite, and the header's
    /// structure (formulation code, order) and scaling (finite, > 0 in f64
    /// and in `T`). A blob of another format version is
    /// [`TableError::UnsupportedVersion`] whatever its length.
    ///
    /// ```
    /// use rotorid_core::table::{BearingTable, TableError, TableView, Terms};
    /// use rotorid_core::Structure;
    ///
    /// // A tiny f64 blob: 2 shaft nodes, 1 bearing at node 1 (2 channels),
    /// // no planes, no poles, 2 speeds; written for `physical` 1.
    /// let mut b = Vec::new();
    /// b.extend_from_slice(b"ROTORTBL");
    /// b.extend_from_slice(&2u16.to_le_bytes()); // format version
    /// b.extend_from_slice(&[8, 0]); // f64, reserved
    /// for v in [2u16, 1, 0] {
    ///     b.extend_from_slice(&v.to_le_bytes()); // nodes, N_b, N_p
    /// }
    /// b.extend_from_slice(&[0, 0]); // poles of A, of B
    /// b.extend_from_slice(&2u32.to_le_bytes()); // N_s
    /// b.extend_from_slice(&[2, 1, 0, 0, 0, 0, 0, 0]); // physical, order 1, reserved
    /// for x in [2.1e7f64, 200.0, 3.4e-4] {
    ///     b.extend_from_slice(&x.to_le_bytes()); // scaling: N/m, rad/s, kg m
    /// }
    /// b.extend_from_slice(&1u16.to_le_bytes()); // bearing node
    /// for w in [100.0f64, 200.0] {
    ///     b.extend_from_slice(&w.to_le_bytes()); // speeds (rad/s)
    /// }
    /// for w in [100.0f64, 200.0] {
    ///     // A = -w^2 m I of a rigid mass m = 2 kg, row-major, re then im
    ///     for (r, c) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
    ///         let a = if r == c { -2.0 * w * w } else { 0.0 };
    ///         b.extend_from_slice(&a.to_le_bytes());
    ///         b.extend_from_slice(&0f64.to_le_bytes());
    ///     }
    /// }
    /// let crc = rotorid_core::crc32::crc32(&b);
    /// b.extend_from_slice(&crc.to_le_bytes());
    ///
    /// let view = TableView::<f64>::parse(&b)?;
    /// assert_eq!((view.n_bearings(), view.n_planes(), view.n_speeds()), (1, 0, 2));
    /// assert_eq!(view.structure(), Structure::physical(1));
    /// assert_eq!(view.scaling().omega_ref, 200.0);
    /// // Between grid speeds: pole-factored linear in A / w^2, exact here.
    /// let t: Terms<f64, 2, 0> = view.terms(150.0)?;
    /// assert!((t.a[0][0].re + 2.0 * 150.0 * 150.0).abs() < 1e-9);
    /// // Damage is a typed error, never a panic.
    /// b[60] ^= 1;
    /// assert!(matches!(TableView::<f64>::parse(&b), Err(TableError::Crc { .. })));
    /// b[8] = 1;
    /// assert_eq!(
    ///     TableView::<f64>::parse(&b).unwrap_err().to_string(),
    ///     "table blob format version 1 is no longer read; rebuild it with `rotorid tables`"
    /// );
    /// # Ok::<(), TableError>(())
    /// ```
    pub fn parse(bytes: &'a [u8]) -> Result<Self, TableError> {
        let hdr = TableError::Truncated {
            needed: HEADER_LEN,
            found: bytes.len(),
        };
        // Magic and version first (as far as present), so that a blob of
        // another version is named as such whatever its length.
        let n_magic = bytes.len().min(MAGIC.len());
        if bytes.get(..n_magic) != MAGIC.get(..n_magic) {
            return Err(TableError::BadMagic);
        }
        if let Some(version) = read_u16(bytes, 8) {
            if version != FORMAT_VERSION {
                return Err(TableError::UnsupportedVersion {
                    found: version,
                    expected: FORMAT_VERSION,
                });
            }
        }
        if bytes.len() < HEADER_LEN {
            return Err(hdr);
        }
        let scalar = *bytes.get(10).ok_or(hdr)?;
        if scalar != T::TYPE_CODE {
            return Err(TableError::ScalarType {
                expected: T::TYPE_CODE,
                found: scalar,
            });
        }
        if *bytes.get(11).ok_or(hdr)? != 0 || bytes.get(26..32).ok_or(hdr)?.iter().any(|&b| b != 0)
        {
            return Err(TableError::Reserved);
        }
        let formulation =
            formulation_from_code(*bytes.get(24).ok_or(hdr)?).ok_or(TableError::BadStructure)?;
        let structure = Structure {
            formulation,
            order: *bytes.get(25).ok_or(hdr)? as usize,
        };
        structure.validate().map_err(|_| TableError::BadStructure)?;
        let reference = |off: usize| read_t::<f64>(bytes, off).ok_or(hdr);
        let stored_scaling = ColumnScaling::<f64> {
            stiffness: reference(32)?,
            omega_ref: reference(40)?,
            unbalance: reference(48)?,
        };
        let scaling = ColumnScaling::<T>::new(
            stored_scaling.stiffness,
            stored_scaling.omega_ref,
            stored_scaling.unbalance,
        )
        .map_err(|_| TableError::BadScaling)?;
        let n_nodes = read_u16(bytes, 12).ok_or(hdr)?;
        let n_b = read_u16(bytes, 14).ok_or(hdr)? as usize;
        let n_p = read_u16(bytes, 16).ok_or(hdr)? as usize;
        let n_ka = *bytes.get(18).ok_or(hdr)? as usize;
        let n_kb = *bytes.get(19).ok_or(hdr)? as usize;
        let n_s =
            usize::try_from(read_u32(bytes, 20).ok_or(hdr)?).map_err(|_| TableError::BadSize)?;
        if n_nodes < 2
            || n_b == 0
            || n_b > MAX_BEARINGS
            || n_b > n_nodes as usize
            || n_p > MAX_PLANES
            || n_ka > MAX_POLES
            || n_kb > MAX_POLES
            || n_s == 0
        {
            return Err(TableError::BadSize);
        }
        let lay = Layout::new(T::WIDTH, n_b, n_p, n_ka, n_kb, n_s).ok_or(TableError::BadSize)?;
        if bytes.len() != lay.total {
            return Err(TableError::Length {
                expected: lay.total,
                found: bytes.len(),
            });
        }
        let stored = read_u32(bytes, lay.crc).ok_or(TableError::Corrupt)?;
        let computed = crc32(bytes.get(..lay.crc).ok_or(TableError::Corrupt)?);
        if stored != computed {
            return Err(TableError::Crc { stored, computed });
        }
        let view = TableView {
            bytes,
            structure,
            scaling,
            stored_scaling,
            n_nodes,
            n_b,
            n_p,
            n_ka,
            n_kb,
            n_s,
            off_planes: lay.planes,
            off_bearings: lay.bearings,
            off_poles_a: lay.poles_a,
            off_poles_b: lay.poles_b,
            off_speeds: lay.speeds,
            off_data: lay.data,
            per_speed: lay.per_speed,
            _t: PhantomData,
        };
        view.validate_values()?;
        Ok(view)
    }

    fn validate_values(&self) -> Result<(), TableError> {
        let c = TableError::Corrupt;
        // Nodes.
        let mut prev = 0u16;
        for i in 0..self.n_b {
            let n = self.bearing_node(i).ok_or(c)?;
            if n == 0 || n > self.n_nodes || n <= prev {
                return Err(TableError::BadNode);
            }
            prev = n;
        }
        for i in 0..self.n_p {
            let n = self.plane_node(i).ok_or(c)?;
            if n == 0 || n > self.n_nodes {
                return Err(TableError::BadNode);
            }
            for j in 0..i {
                if self.plane_node(j).ok_or(c)? == n {
                    return Err(TableError::BadNode);
                }
            }
        }
        if !increasing_positive(self.n_ka, |i| self.pole_a(i)).ok_or(c)?
            || !increasing_positive(self.n_kb, |i| self.pole_b(i)).ok_or(c)?
        {
            return Err(TableError::BadPole);
        }
        if !increasing_positive(self.n_s, |i| self.speed(i)).ok_or(c)? {
            // Distinguish a NaN/infinite speed from a mis-ordered one.
            for i in 0..self.n_s {
                if !self.speed(i).ok_or(c)?.is_finite() {
                    return Err(TableError::NonFinite);
                }
            }
            return Err(TableError::SpeedsNotIncreasing);
        }
        let start = self.off_data;
        let end = self
            .per_speed
            .checked_mul(self.n_s)
            .and_then(|l| l.checked_add(start))
            .ok_or(c)?;
        let data = self.bytes.get(start..end).ok_or(c)?;
        for chunk in data.chunks_exact(T::WIDTH) {
            if !T::from_le(chunk).ok_or(c)?.is_finite() {
                return Err(TableError::NonFinite);
            }
        }
        Ok(())
    }

    /// The model structure the table was written for (header bytes 24, 25).
    pub fn structure(&self) -> Structure {
        self.structure
    }
    /// The column scaling the table was written for (header bytes 32..56),
    /// rounded once to `T`.
    pub fn scaling(&self) -> ColumnScaling<T> {
        self.scaling
    }
    /// The column scaling as stored in the blob (f64, before rounding to `T`).
    pub fn stored_scaling(&self) -> ColumnScaling<f64> {
        self.stored_scaling
    }
    /// Number of bearings N_b.
    pub fn n_bearings(&self) -> usize {
        self.n_b
    }
    /// Number of channels `2 N_b`.
    pub fn n_channels(&self) -> usize {
        2 * self.n_b
    }
    /// Number of unbalance planes N_p.
    pub fn n_planes(&self) -> usize {
        self.n_p
    }
    /// Number of grid speeds.
    pub fn n_speeds(&self) -> usize {
        self.n_s
    }
    /// Number of poles of `A`.
    pub fn n_poles_a(&self) -> usize {
        self.n_ka
    }
    /// Number of poles of `B`.
    pub fn n_poles_b(&self) -> usize {
        self.n_kb
    }
    /// Number of shaft nodes of the model the table came from.
    pub fn n_nodes(&self) -> u16 {
        self.n_nodes
    }
    /// Bearing `i`'s node (1-based).
    pub fn bearing_node(&self, i: usize) -> Option<u16> {
        if i >= self.n_b {
            return None;
        }
        read_u16(
            self.bytes,
            self.off_bearings.checked_add(i.checked_mul(2)?)?,
        )
    }
    /// Plane `i`'s node (1-based).
    pub fn plane_node(&self, i: usize) -> Option<u16> {
        if i >= self.n_p {
            return None;
        }
        read_u16(self.bytes, self.off_planes.checked_add(i.checked_mul(2)?)?)
    }
    /// Pole `i` of `A` (rad/s).
    pub fn pole_a(&self, i: usize) -> Option<T> {
        if i >= self.n_ka {
            return None;
        }
        read_t(
            self.bytes,
            self.off_poles_a.checked_add(i.checked_mul(T::WIDTH)?)?,
        )
    }
    /// Pole `i` of `B` (rad/s).
    pub fn pole_b(&self, i: usize) -> Option<T> {
        if i >= self.n_kb {
            return None;
        }
        read_t(
            self.bytes,
            self.off_poles_b.checked_add(i.checked_mul(T::WIDTH)?)?,
        )
    }
    /// Grid speed `i` (rad/s).
    pub fn speed(&self, i: usize) -> Option<T> {
        if i >= self.n_s {
            return None;
        }
        read_t(
            self.bytes,
            self.off_speeds.checked_add(i.checked_mul(T::WIDTH)?)?,
        )
    }
    fn entry(&self, s: usize, idx: usize) -> Option<Complex<T>> {
        let off = self
            .off_data
            .checked_add(s.checked_mul(self.per_speed)?)?
            .checked_add(idx.checked_mul(2 * T::WIDTH)?)?;
        let re = read_t(self.bytes, off)?;
        let im = read_t(self.bytes, off.checked_add(T::WIDTH)?)?;
        Some(Complex::new(re, im))
    }
    /// Stored `A[r][c]` at grid speed `s`.
    pub fn a_entry(&self, s: usize, r: usize, c: usize) -> Option<Complex<T>> {
        let nq = 2 * self.n_b;
        if s >= self.n_s || r >= nq || c >= nq {
            return None;
        }
        self.entry(s, r * nq + c)
    }
    /// Stored `B[r][c]` at grid speed `s`.
    pub fn b_entry(&self, s: usize, r: usize, c: usize) -> Option<Complex<T>> {
        let nq = 2 * self.n_b;
        if s >= self.n_s || r >= nq || c >= self.n_p {
            return None;
        }
        self.entry(s, nq * nq + r * self.n_p + c)
    }
    /// The poles of `A`, copied into a fixed array (first
    /// [`Self::n_poles_a`] used, the rest zero).
    pub fn poles_a(&self) -> [T; MAX_POLES] {
        let mut p = [T::zero(); MAX_POLES];
        for (i, x) in p.iter_mut().enumerate().take(self.n_ka) {
            *x = self.pole_a(i).unwrap_or_else(T::zero);
        }
        p
    }
    /// The poles of `B`, copied into a fixed array (first
    /// [`Self::n_poles_b`] used, the rest zero).
    pub fn poles_b(&self) -> [T; MAX_POLES] {
        let mut p = [T::zero(); MAX_POLES];
        for (i, x) in p.iter_mut().enumerate().take(self.n_kb) {
            *x = self.pole_b(i).unwrap_or_else(T::zero);
        }
        p
    }
}

impl<T: TableScalar, const NQ: usize, const NP: usize> BearingTable<T, NQ, NP>
    for TableView<'_, T>
{
    fn terms(&self, omega: T) -> Result<Terms<T, NQ, NP>, TableError> {
        if NQ != 2 * self.n_b || NP != self.n_p {
            return Err(TableError::Dimension);
        }
        let pa = self.poles_a();
        let pb = self.poles_b();
        lookup(
            self.n_s,
            |i| self.speed(i),
            pa.get(..self.n_ka).ok_or(TableError::Corrupt)?,
            pb.get(..self.n_kb).ok_or(TableError::Corrupt)?,
            |s, r, c| self.a_entry(s, r, c),
            |s, r, c| self.b_entry(s, r, c),
            omega,
        )
    }

    fn speed_range(&self) -> (T, T) {
        let first = self.speed(0).unwrap_or_else(T::zero);
        let last = self
            .speed(self.n_s.saturating_sub(1))
            .unwrap_or_else(T::zero);
        (first, last)
    }
}

impl<T: TableScalar> TableSetup<T> for TableView<'_, T> {
    fn structure(&self) -> Structure {
        self.structure
    }
    fn scaling(&self) -> ColumnScaling<T> {
        self.scaling
    }
}

/// An owned table with compile-time sizes: `NQ = 2 N_b` channels, `NP`
/// planes, `NS` speeds. This is what a generated Rust source file defines
/// (as a `static`, for `include!` in firmware); [`Table::from_view`] copies a
/// blob into one. Mind the size (`NS (NQ^2 + NQ NP)` complex values): build
/// large ones as `static`s, not on a small stack.
#[derive(Debug, Clone, PartialEq)]
pub struct Table<T, const NQ: usize, const NP: usize, const NS: usize> {
    /// The model structure the table was written for.
    pub structure: Structure,
    /// The column scaling the table was written for.
    pub scaling: ColumnScaling<T>,
    /// Poles of `A` (rad/s); the first `n_poles_a` are used, the rest are zero.
    pub poles_a: [T; MAX_POLES],
    /// Number of poles of `A` in use.
    pub n_poles_a: usize,
    /// Poles of `B` (rad/s); the first `n_poles_b` are used, the rest are zero.
    pub poles_b: [T; MAX_POLES],
    /// Number of poles of `B` in use.
    pub n_poles_b: usize,
    /// Grid speeds (rad/s), > 0, strictly increasing.
    pub speeds: [T; NS],
    /// `A` per speed, `a[s][row][col]` (N/m).
    pub a: [[[Complex<T>; NQ]; NQ]; NS],
    /// `B` per speed, `b[s][row][plane]` (1/s^2).
    pub b: [[[Complex<T>; NP]; NQ]; NS],
}

impl<T: Real, const NQ: usize, const NP: usize, const NS: usize> Table<T, NQ, NP, NS> {
    /// `NQ` even and > 0, `NS >= 1`: checked at compile time wherever the
    /// sizes matter.
    const SIZES: () = {
        assert!(
            NQ > 0 && NQ % 2 == 0,
            "Table: NQ = 2 N_b must be even and > 0"
        );
        assert!(NS > 0, "Table: NS must be > 0");
    };

    /// Checks what [`TableView::parse`] checks of the values: structure and
    /// scaling valid, poles and speeds finite, > 0, strictly increasing,
    /// every entry finite. (`NQ` even and non-zero and `NS >= 1` are
    /// compile-time checks.)
    pub fn validate(&self) -> Result<(), TableError> {
        const { Self::SIZES };
        self.structure
            .validate()
            .map_err(|_| TableError::BadStructure)?;
        let sc = &self.scaling;
        if !(sc.stiffness.is_finite()
            && sc.stiffness > T::zero()
            && sc.omega_ref.is_finite()
            && sc.omega_ref > T::zero()
            && sc.unbalance.is_finite()
            && sc.unbalance > T::zero())
        {
            return Err(TableError::BadScaling);
        }
        for (poles, n) in [
            (&self.poles_a, self.n_poles_a),
            (&self.poles_b, self.n_poles_b),
        ] {
            let poles = poles.get(..n).ok_or(TableError::BadPole)?;
            if !increasing_positive(poles.len(), |i| poles.get(i).copied()).unwrap_or(false) {
                return Err(TableError::BadPole);
            }
        }
        if self.speeds.iter().any(|s| !s.is_finite()) {
            return Err(TableError::NonFinite);
        }
        if !increasing_positive(NS, |i| self.speeds.get(i).copied()).unwrap_or(false) {
            return Err(TableError::SpeedsNotIncreasing);
        }
        let finite = self
            .a
            .iter()
            .flatten()
            .flatten()
            .chain(self.b.iter().flatten().flatten())
            .all(|z| z.re.is_finite() && z.im.is_finite());
        if finite {
            Ok(())
        } else {
            Err(TableError::NonFinite)
        }
    }

    /// Copies a validated blob view into an owned table; [`TableError::Dimension`]
    /// unless the blob has exactly `NQ / 2` bearings, `NP` planes and `NS` speeds.
    pub fn from_view(view: &TableView<'_, T>) -> Result<Self, TableError>
    where
        T: TableScalar,
    {
        const { Self::SIZES };
        if NQ != view.n_channels() || NP != view.n_planes() || NS != view.n_speeds() {
            return Err(TableError::Dimension);
        }
        let z = Complex::new(T::zero(), T::zero());
        let mut t = Table {
            structure: view.structure(),
            scaling: view.scaling(),
            poles_a: view.poles_a(),
            n_poles_a: view.n_poles_a(),
            poles_b: view.poles_b(),
            n_poles_b: view.n_poles_b(),
            speeds: [T::zero(); NS],
            a: [[[z; NQ]; NQ]; NS],
            b: [[[z; NP]; NQ]; NS],
        };
        for (s, v) in t.speeds.iter_mut().enumerate() {
            *v = view.speed(s).ok_or(TableError::Corrupt)?;
        }
        for (s, m) in t.a.iter_mut().enumerate() {
            for (r, row) in m.iter_mut().enumerate() {
                for (c, x) in row.iter_mut().enumerate() {
                    *x = view.a_entry(s, r, c).ok_or(TableError::Corrupt)?;
                }
            }
        }
        for (s, m) in t.b.iter_mut().enumerate() {
            for (r, row) in m.iter_mut().enumerate() {
                for (c, x) in row.iter_mut().enumerate() {
                    *x = view.b_entry(s, r, c).ok_or(TableError::Corrupt)?;
                }
            }
        }
        Ok(t)
    }
}

impl<T: Copy, const NQ: usize, const NP: usize, const NS: usize> TableSetup<T>
    for Table<T, NQ, NP, NS>
{
    fn structure(&self) -> Structure {
        self.structure
    }
    fn scaling(&self) -> ColumnScaling<T> {
        self.scaling
    }
}

impl<T: Real, const NQ: usize, const NP: usize, const NS: usize> BearingTable<T, NQ, NP>
    for Table<T, NQ, NP, NS>
{
    fn terms(&self, omega: T) -> Result<Terms<T, NQ, NP>, TableError> {
        const { Self::SIZES };
        lookup(
            NS,
            |i| self.speeds.get(i).copied(),
            self.poles_a
                .get(..self.n_poles_a)
                .ok_or(TableError::Corrupt)?,
            self.poles_b
                .get(..self.n_poles_b)
                .ok_or(TableError::Corrupt)?,
            |s, r, c| self.a.get(s)?.get(r)?.get(c).copied(),
            |s, r, c| self.b.get(s)?.get(r)?.get(c).copied(),
            omega,
        )
    }

    fn speed_range(&self) -> (T, T) {
        let first = self.speeds.first().copied().unwrap_or_else(T::zero);
        let last = self.speeds.last().copied().unwrap_or_else(T::zero);
        (first, last)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn locate_finds_intervals_and_exact_points() {
        let s = [1.0f64, 2.0, 4.0, 8.0];
        let f = |i: usize| s.get(i).copied();
        assert_eq!(locate(4, f, 1.0), Ok(Position::Exact(0)));
        assert_eq!(locate(4, f, 8.0), Ok(Position::Exact(3)));
        assert_eq!(locate(4, f, 4.0), Ok(Position::Exact(2)));
        assert_eq!(locate(4, f, 3.0), Ok(Position::Between(1)));
        assert_eq!(locate(4, f, 7.9), Ok(Position::Between(2)));
        assert_eq!(locate(4, f, 0.5), Err(TableError::OutOfRange));
        assert_eq!(locate(4, f, 8.5), Err(TableError::OutOfRange));
        assert_eq!(locate(4, f, f64::NAN), Err(TableError::NonFinite));
        assert_eq!(locate(1, f, 1.0), Ok(Position::Exact(0)));
        assert_eq!(locate(1, f, 1.5), Err(TableError::OutOfRange));
    }

    /// The scheme reproduces `Omega^2 c / (Omega_k^2 - Omega^2)` (the shape
    /// of a pole in `A` or `B`) exactly, even across the pole, and
    /// `Omega^2` (`A` of a shaft on two bearings at low speed) exactly.
    #[test]
    fn pole_factored_weights_are_exact_for_a_simple_pole() {
        let pk = 10.0f64;
        let f = |w: f64| 3.0 * w * w / (pk * pk - w * w);
        let (w0, w1) = (9.0, 11.5);
        for &om in &[9.3, 9.99, 10.001, 11.2] {
            let w = weights(om, w0, w1, &[pk]).unwrap();
            let a = w.c0 * f(w0) + w.c1 * f(w1);
            assert!((a - f(om)).abs() < 1e-12 * f(om).abs(), "{om}");
        }
        let w = weights(2.5f64, 2.0, 3.0, &[]).unwrap();
        assert!((w.c0 * 4.0 + w.c1 * 9.0 - 6.25).abs() < 1e-14);
        assert_eq!(weights(10.0, w0, w1, &[pk]), Err(TableError::Pole));
        assert_eq!(weights(10.0 + 9e-6, w0, w1, &[pk]), Err(TableError::Pole));
        assert!(weights(10.0 + 2e-5, w0, w1, &[pk]).is_ok());
    }
}
