//! The one scalar bound of the crate: [`Real`], implemented by `f32` and `f64`.
//!
//! Complex data are `num_complex::Complex<T>` (the same type nalgebra calls
//! `Complex`). Use [`Real::lit`] for literals so that no code path depends on
//! the precision.

use core::fmt::Debug;

/// A real floating-point scalar: `f32` or `f64`.
///
/// Built on [`nalgebra::RealField`] (which brings `sqrt`, `hypot`, `abs`,
/// `is_finite`, ... through `ComplexField`), plus a few conversions.
pub trait Real: nalgebra::RealField + Copy + Debug + Default + PartialOrd + 'static {
    /// Machine epsilon of the type.
    const EPS: Self;
    /// Converts an `f64` literal or value (rounding to the nearest `f32` for `f32`).
    fn lit(x: f64) -> Self;
    /// Widens to `f64` (exact for both types).
    fn to_f64(self) -> f64;
    /// The 32-bit word of the representation that holds the sign: bit 31
    /// is set for negative values, `-0` and NaNs with the sign bit (the
    /// whole `f32`, the upper half of an `f64`). OR-ing these words tells
    /// whether any of a set of values is negative with one integer
    /// operation per value.
    fn sign_word(self) -> u32;
    /// `|re + j im| = sqrt(re^2 + im^2)` without overflow or underflow in
    /// the squares: `hypot` for `f64`; for `f32` in `f32` arithmetic, `b
    /// sqrt(1 + (s / b)^2)` with `b` the larger and `s` the smaller
    /// magnitude (within 2 ulp; `libm`'s `hypotf` works in `f64`, which a
    /// Cortex-M4F does in software). Infinite when either part is, NaN
    /// when either is NaN and neither infinite.
    fn magnitude(re: Self, im: Self) -> Self;
}

impl Real for f32 {
    const EPS: Self = f32::EPSILON;
    #[inline]
    fn lit(x: f64) -> Self {
        x as f32
    }
    #[inline]
    fn to_f64(self) -> f64 {
        self as f64
    }
    #[inline]
    fn sign_word(self) -> u32 {
        self.to_bits()
    }
    #[inline]
    fn magnitude(re: Self, im: Self) -> Self {
        let (a, b) = (re.abs(), im.abs());
        if a.is_infinite() || b.is_infinite() {
            return f32::INFINITY;
        }
        if a.is_nan() || b.is_nan() {
            return f32::NAN;
        }
        let (big, small) = if a >= b { (a, b) } else { (b, a) };
        if big == 0.0 {
            return 0.0;
        }
        let r = small / big;
        big * nalgebra::ComplexField::sqrt(1.0 + r * r)
    }
}

impl Real for f64 {
    const EPS: Self = f64::EPSILON;
    #[inline]
    fn lit(x: f64) -> Self {
        x
    }
    #[inline]
    fn to_f64(self) -> f64 {
        self
    }
    #[inline]
    fn sign_word(self) -> u32 {
        (self.to_bits() >> 32) as u32
    }
    #[inline]
    fn magnitude(re: Self, im: Self) -> Self {
        nalgebra::ComplexField::hypot(re, im)
    }
}

#[cfg(test)]
mod tests {
    use super::Real;
    use crate::testrng::SplitMix64;

    /// Distance in units in the last place between two finite `f32` of the
    /// same sign.
    fn ulps(a: f32, b: f32) -> u32 {
        a.to_bits().abs_diff(b.to_bits())
    }

    /// `f32` magnitude against `f64` `hypot` rounded once to `f32`: within
    /// 2 ulp from 1e-40 (subnormal) to 1e38 (near overflow) and at every
    /// ratio of the parts; zero, infinities and NaN as documented; `f64`
    /// is `hypot` itself.
    #[test]
    fn the_f32_magnitude_is_within_two_ulp() {
        let mut rng = SplitMix64::new(5);
        let mut worst = 0;
        for _ in 0..200_000 {
            let e = -40.0 + 78.0 * rng.uniform();
            let ratio = 10f64.powf(-12.0 * rng.uniform());
            let big = 10f64.powf(e) * rng.sym().signum();
            let (re, im) = (big as f32, (big * ratio * rng.sym()) as f32);
            let (re, im) = if rng.next_u64() % 2 == 0 {
                (re, im)
            } else {
                (im, re)
            };
            let want = (re as f64).hypot(im as f64) as f32;
            let got = f32::magnitude(re, im);
            worst = worst.max(ulps(got, want));
        }
        assert!(worst <= 2, "{worst} ulp");
        assert_eq!(f32::magnitude(0.0, -0.0), 0.0);
        assert_eq!(f32::magnitude(3.0, 4.0), 5.0);
        assert_eq!(f32::magnitude(f32::MAX, f32::MAX), f32::INFINITY);
        assert_eq!(f32::magnitude(f32::NAN, f32::NEG_INFINITY), f32::INFINITY);
        assert!(f32::magnitude(f32::NAN, 1.0).is_nan());
        assert!(f32::magnitude(0.0, f32::NAN).is_nan());
        assert_eq!(f64::magnitude(3e300, 4e300), 3e300f64.hypot(4e300));
    }
}
