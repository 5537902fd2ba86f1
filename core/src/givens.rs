//! Complex (and real) Givens rotations, computed without overflow or
//! underflow in the intermediate sums of squares.
//!
//! A Givens rotation acts on two rows. Given a pivot `a` (the diagonal entry
//! of the triangular factor) and an entry `b` of the incoming data row, it is
//! the unitary 2 x 2 matrix
//!
//! ```text
//!     G = [   c     s ]      with c real, c^2 + |s|^2 = 1,
//!         [ -s^*    c ]
//! ```
//!
//! such that `G [a; b] = [r; 0]`. For a real, non-negative pivot `a`
//! (the case of the QRD/RLS, whose factor keeps a real, non-negative
//! diagonal):
//!
//! ```text
//!     rho = sqrt(a^2 + |b|^2),   c = a / rho,   s = b^* / rho,   r = rho,
//! ```
//!
//! and indeed `-s^* a + c b = -(b a)/rho + (a b)/rho = 0` and
//! `c a + s b = (a^2 + |b|^2)/rho = rho`. For a general complex pivot
//! ([`rotation`]), `c = |a|/rho`, `s = (a/|a|) b^*/rho`, `r = (a/|a|) rho`.
//! When `a = 0`, `c = 0`, `s = b^*/|b|`, `r = |b|`; when `a = b = 0` the
//! rotation is the identity (`c = 1`, `s = 0`, `r = 0`).
//!
//! Applied to the rest of the two rows, `(x, y) -> (c x + s y, -s^* x + c y)`
//! ([`Rotation::apply`]); the same formulas serve real data (`F = T`, where
//! `s^* = s`).
//!
//! # Range safety ("hypot-style")
//!
//! `a^2 + |b|^2` is only formed directly when the largest magnitude
//! `m = max(|a|, |Re b|, |Im b|)` lies in `(2^-490, 2^490)` in `f64`
//! (`(2^-60, 2^60)` in `f32`), where no square overflows and the sum cannot
//! underflow to a wrong value. Outside that
//! range the pair is first divided by `m` (as LAPACK's `xLARTG` does), so a
//! finite pair always gives a finite rotation with `c^2 + |s|^2 = 1` to
//! round-off, and `r` is finite unless the true `rho` exceeds `T::MAX`.

use crate::Real;
use nalgebra::ComplexField;

/// A Givens rotation with real cosine `c` and field-valued sine `s`
/// (`G = [c, s; -s^*, c]`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rotation<F: ComplexField> {
    /// Cosine, real, in `[0, 1]` for the rotations built here.
    pub c: F::RealField,
    /// Sine, `|s| = sqrt(1 - c^2)`.
    pub s: F,
}

impl<F, T> Rotation<F>
where
    F: ComplexField<RealField = T> + Copy,
    T: Real,
{
    /// The identity rotation (`c = 1`, `s = 0`).
    #[inline]
    pub fn identity() -> Self {
        Self {
            c: T::one(),
            s: F::zero(),
        }
    }

    /// Applies the rotation to one column pair: returns
    /// `(c x + s y, -s^* x + c y)`.
    #[inline(always)]
    pub fn apply(&self, x: F, y: F) -> (F, F) {
        (
            x.scale(self.c) + self.s * y,
            y.scale(self.c) - self.s.conjugate() * x,
        )
    }
}

/// Range `(lo, hi)` of the largest magnitude `m` in which the squares can be
/// summed directly: `2^-60 .. 2^60` in `f32`, `2^-490 .. 2^490` in `f64`
/// (squares between `2^-120` and `2^120`, resp. `2^-980` and `2^980`: normal
/// numbers, far from overflow, and a square that underflows is below the
/// rounding error of the largest one). [`Real`] is implemented by `f32` and
/// `f64` only; the precision is told apart by its machine epsilon (a
/// constant, so the branch folds away).
#[inline(always)]
pub(crate) fn safe_range<T: Real>() -> (T, T) {
    if T::EPS.to_f64() > 1e-10 {
        (T::lit(pow2(-60)), T::lit(pow2(60)))
    } else {
        (T::lit(pow2(-490)), T::lit(pow2(490)))
    }
}

/// The squared range `(4 lo^2, hi^2)` of [`safe_range`] (`2^-118 .. 2^120`
/// in `f32`, `2^-978 .. 2^980` in `f64`, all exact powers of two) for the
/// computed sum of squares `rho2 = fl(a^2 + |b|^2)`.
///
/// `rho2 < hi^2` gives `m < hi`: every computed square is at most `rho2`
/// (rounding is monotone and the terms are non-negative), and `m >= hi`
/// would give a computed square `fl(m^2) >= hi^2`. `rho2 > 4 lo^2` gives
/// `m > lo`: with `m <= lo` the (at most three) computed squares are each at
/// most `lo^2`, and their rounded sum stays below `3 lo^2 (1 + eps)^2 <
/// 4 lo^2`.
#[inline(always)]
pub(crate) fn safe_range_sq<T: Real>() -> (T, T) {
    if T::EPS.to_f64() > 1e-10 {
        (T::lit(pow2(-118)), T::lit(pow2(120)))
    } else {
        (T::lit(pow2(-978)), T::lit(pow2(980)))
    }
}

/// Smallest positive normal number of the precision (`2^-126` in `f32`,
/// `2^-1022` in `f64`).
#[inline(always)]
pub(crate) fn min_normal<T: Real>() -> T {
    if T::EPS.to_f64() > 1e-10 {
        T::lit(pow2(-126))
    } else {
        T::lit(pow2(-1022))
    }
}

/// `2^k` for `-1022 <= k <= 1023`, exactly.
const fn pow2(k: i32) -> f64 {
    f64::from_bits(((1023 + k) as u64) << 52)
}

/// Rotation against a real, non-negative pivot `a` (see the module
/// documentation): returns the rotation and `r = sqrt(a^2 + |b|^2) >= 0`.
///
/// This is the form the QRD/RLS uses (its triangular factor has a real,
/// non-negative diagonal). A negative `a` is treated as `|a|` for the
/// cosine, i.e. the caller must pass `a >= 0` for `G [a; b] = [r; 0]` to
/// hold exactly.
#[inline(always)]
pub fn rotation_real_pivot<F, T>(a: T, b: F) -> (Rotation<F>, T)
where
    F: ComplexField<RealField = T> + Copy,
    T: Real,
{
    let a = a.abs();
    if let Some(r) = rotation_direct(a, b) {
        return r;
    }
    // Plain comparisons (not the NaN-aware `max`): the inputs are finite.
    let (br, bi) = (b.real().abs(), b.imaginary().abs());
    let bm = if br > bi { br } else { bi };
    let m = if a > bm { a } else { bm };
    if m == T::zero() {
        return (Rotation::identity(), T::zero());
    }
    let (lo, hi) = safe_range::<T>();
    if m > lo && m < hi {
        let rho = (a * a + b.modulus_squared()).sqrt();
        let inv = T::one() / rho;
        (
            Rotation {
                c: a * inv,
                s: b.conjugate().scale(inv),
            },
            rho,
        )
    } else {
        // Scale by m (a division, not a reciprocal: 1/m overflows for
        // subnormal m).
        let a_s = a / m;
        let b_s = b.unscale(m);
        let rho_s = (a_s * a_s + b_s.modulus_squared()).sqrt();
        (
            Rotation {
                c: a_s / rho_s,
                s: b_s.conjugate().unscale(rho_s),
            },
            rho_s * m,
        )
    }
}

/// The common case of [`rotation_real_pivot`] for `a >= 0`: the sum of
/// squares formed directly and tested against the squared range
/// (`4 lo^2 < rho2 < hi^2`), which implies `lo < m < hi` for
/// `m = max(|a|, |Re b|, |Im b|)` (see [`safe_range_sq`]): the same
/// expression, so the same bits, as the direct branch of
/// [`rotation_real_pivot`], for two comparisons instead of the magnitudes;
/// `None` outside the range.
#[inline(always)]
fn rotation_direct<F, T>(a: T, b: F) -> Option<(Rotation<F>, T)>
where
    F: ComplexField<RealField = T> + Copy,
    T: Real,
{
    let rho2 = a * a + b.modulus_squared();
    let (lo2, hi2) = safe_range_sq::<T>();
    if rho2 > lo2 && rho2 < hi2 {
        let rho = rho2.sqrt();
        let inv = T::one() / rho;
        Some((
            Rotation {
                c: a * inv,
                s: b.conjugate().scale(inv),
            },
            rho,
        ))
    } else {
        None
    }
}

/// [`rotation_real_pivot`] for a pivot known to be `a >= +0`, the diagonal
/// of a QRD/RLS factor (`sqrt(delta) > 0` at the start, then
/// `rho = sqrt(a^2 + |b|^2) >= +0` and scalings by `sqrt(lambda) > 0`):
/// `|a| = a` bit for bit, so the same rotation and `rho`, without taking
/// the magnitude on the common path.
#[inline(always)]
pub(crate) fn rotation_nonneg_pivot<F, T>(a: T, b: F) -> (Rotation<F>, T)
where
    F: ComplexField<RealField = T> + Copy,
    T: Real,
{
    rotation_direct(a, b).unwrap_or_else(|| rotation_real_pivot(a, b))
}

/// General rotation against a complex pivot `a`: returns the rotation and
/// `r = (a/|a|) sqrt(|a|^2 + |b|^2)` such that `G [a; b] = [r; 0]`.
///
/// `|a|` is taken with the same range-safe scaling as
/// [`rotation_real_pivot`]. For `a = 0`: `c = 0`, `s = b^*/|b|`, `r = |b|`.
pub fn rotation<F, T>(a: F, b: F) -> (Rotation<F>, F)
where
    F: ComplexField<RealField = T> + Copy,
    T: Real,
{
    let am = a.real().abs().max(a.imaginary().abs());
    let bm = b.real().abs().max(b.imaginary().abs());
    let m = am.max(bm);
    if m == T::zero() {
        return (Rotation::identity(), F::zero());
    }
    let a_s = a.unscale(m);
    let b_s = b.unscale(m);
    let abs_a_s = a_s.modulus_squared().sqrt();
    let rho_s = (a_s.modulus_squared() + b_s.modulus_squared()).sqrt();
    if abs_a_s == T::zero() {
        return (
            Rotation {
                c: T::zero(),
                s: b_s.conjugate().unscale(rho_s),
            },
            F::from_real(rho_s * m),
        );
    }
    let phase = a_s.unscale(abs_a_s);
    (
        Rotation {
            c: abs_a_s / rho_s,
            s: (phase * b_s.conjugate()).unscale(rho_s),
        },
        phase.scale(rho_s * m),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use num_complex::Complex;

    fn check_real_pivot_c64(a: f64, b: Complex<f64>, tol: f64) {
        let (g, r) = rotation_real_pivot(a, b);
        let (top, bottom) = g.apply(Complex::new(a, 0.0), b);
        let scale = a.abs().max(b.norm());
        assert!((top.re - r).abs() <= tol * scale, "{a} {b}: {top} vs {r}");
        assert!(top.im.abs() <= tol * scale);
        assert!(bottom.norm() <= tol * scale, "{a} {b}: bottom {bottom}");
        assert!((g.c * g.c + g.s.norm_sqr() - 1.0).abs() <= 4.0 * f64::EPSILON);
        assert!(r.is_finite() && g.c.is_finite() && g.s.is_finite());
    }

    #[test]
    fn real_pivot_zeroes_entry_across_the_range() {
        for &(a, b) in &[
            (1.0, Complex::new(2.0, -3.0)),
            (0.0, Complex::new(2.0, -3.0)),
            (5.0, Complex::new(0.0, 0.0)),
            (1e300, Complex::new(1e300, -1e300)),
            (1e-300, Complex::new(3e-310, 1e-310)),
            (0.0, Complex::new(4e-320, 0.0)),
            (1e200, Complex::new(1e-200, 0.0)),
            (1e-200, Complex::new(1e200, 1.0)),
        ] {
            check_real_pivot_c64(a, b, 4.0 * f64::EPSILON);
        }
    }

    #[test]
    fn real_pivot_without_scaling_would_overflow_in_f32() {
        // a^2 overflows f32 (1e40), the scaled path must still be exact.
        let (g, r) = rotation_real_pivot(3e20f32, Complex::new(4e20f32, 0.0));
        assert!((r - 5e20).abs() <= 5e20 * 1e-6);
        assert!((g.c - 0.6).abs() < 1e-6 && (g.s.re - 0.8).abs() < 1e-6);
        // And underflow: squares of 1e-25 are 0 in f32.
        let (g, r) = rotation_real_pivot(3e-25f32, Complex::new(0.0, 4e-25f32));
        assert!((r - 5e-25).abs() <= 5e-25 * 1e-6);
        assert!((g.c - 0.6).abs() < 1e-6 && (g.s.im + 0.8).abs() < 1e-6);
    }

    #[test]
    fn zero_pair_is_identity() {
        let (g, r) = rotation_real_pivot(0.0f64, Complex::new(0.0, 0.0));
        assert_eq!(g, Rotation::identity());
        assert_eq!(r, 0.0);
        let (g, r) = rotation(Complex::new(0.0f32, 0.0), Complex::new(0.0, 0.0));
        assert_eq!(g, Rotation::identity());
        assert_eq!(r, Complex::new(0.0, 0.0));
    }

    #[test]
    fn real_field_rotation() {
        let (g, r) = rotation_real_pivot(3.0f64, -4.0f64);
        assert!((r - 5.0).abs() < 1e-15);
        let (top, bottom) = g.apply(3.0, -4.0);
        assert!((top - 5.0).abs() < 1e-15 && bottom.abs() < 1e-15);
    }

    #[test]
    fn complex_pivot_rotation() {
        for &(a, b) in &[
            (Complex::new(1.0f64, 2.0), Complex::new(-0.5, 3.0)),
            (Complex::new(0.0, 0.0), Complex::new(-0.5, 3.0)),
            (Complex::new(-1e300, 1e300), Complex::new(1e300, 0.0)),
            (Complex::new(1e-310, 0.0), Complex::new(0.0, -2e-310)),
        ] {
            let (g, r) = rotation(a, b);
            let (top, bottom) = g.apply(a, b);
            let scale = a.norm().max(b.norm());
            assert!((top - r).norm() <= 8.0 * f64::EPSILON * scale);
            assert!(bottom.norm() <= 8.0 * f64::EPSILON * scale);
            assert!((g.c * g.c + g.s.norm_sqr() - 1.0).abs() <= 8.0 * f64::EPSILON);
            let rho = (a.norm().powi(2) + b.norm().powi(2)).sqrt();
            if rho.is_finite() && rho > 1e-300 {
                assert!((r.norm() - rho).abs() <= 8.0 * f64::EPSILON * rho);
            }
        }
    }
}
