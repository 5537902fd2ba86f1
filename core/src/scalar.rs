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
}
