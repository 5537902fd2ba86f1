//! Field elements decoded from raw fuzz bytes, shared by the filter
//! targets (`qrdrls_update`, `sqrtfree_update`).

use num_complex::Complex;

/// A field element decoded from raw bytes (4 per real for f32, 8 for f64).
pub trait Field: nalgebra::ComplexField<RealField = Self::Real> + Copy + PartialEq {
    type Real: rotorid_core::Real;
    fn take(data: &mut &[u8]) -> Option<Self>;
    fn take_real(data: &mut &[u8]) -> Option<Self::Real>;
    fn finite(&self) -> bool;
}

fn take_f32(data: &mut &[u8]) -> Option<f32> {
    let (head, rest) = data.split_first_chunk::<4>()?;
    *data = rest;
    Some(f32::from_le_bytes(*head))
}

fn take_f64(data: &mut &[u8]) -> Option<f64> {
    let (head, rest) = data.split_first_chunk::<8>()?;
    *data = rest;
    Some(f64::from_le_bytes(*head))
}

impl Field for f32 {
    type Real = f32;
    fn take(data: &mut &[u8]) -> Option<Self> {
        take_f32(data)
    }
    fn take_real(data: &mut &[u8]) -> Option<f32> {
        take_f32(data)
    }
    fn finite(&self) -> bool {
        self.is_finite()
    }
}

impl Field for f64 {
    type Real = f64;
    fn take(data: &mut &[u8]) -> Option<Self> {
        take_f64(data)
    }
    fn take_real(data: &mut &[u8]) -> Option<f64> {
        take_f64(data)
    }
    fn finite(&self) -> bool {
        self.is_finite()
    }
}

impl Field for Complex<f32> {
    type Real = f32;
    fn take(data: &mut &[u8]) -> Option<Self> {
        Some(Complex::new(take_f32(data)?, take_f32(data)?))
    }
    fn take_real(data: &mut &[u8]) -> Option<f32> {
        take_f32(data)
    }
    fn finite(&self) -> bool {
        self.re.is_finite() && self.im.is_finite()
    }
}

impl Field for Complex<f64> {
    type Real = f64;
    fn take(data: &mut &[u8]) -> Option<Self> {
        Some(Complex::new(take_f64(data)?, take_f64(data)?))
    }
    fn take_real(data: &mut &[u8]) -> Option<f64> {
        take_f64(data)
    }
    fn finite(&self) -> bool {
        self.re.is_finite() && self.im.is_finite()
    }
}
