//! The one deterministic generator of core's tests and benchmarks:
//! SplitMix64 (Steele, Lea, Flood 2014), small, fast, with a fixed stream
//! (no dependency on a crate's stream stability). Compiled into the unit
//! tests (`#[cfg(test)]`) and included by path into `core/tests` and
//! `core/benches`, so there is one copy.
#![allow(dead_code)]

use num_complex::Complex;

/// SplitMix64: one `u64` of state.
#[derive(Clone, Debug)]
pub struct SplitMix64(u64);

impl SplitMix64 {
    /// A generator with this seed.
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }
    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
    /// Uniform in [-1, 1).
    pub fn sym(&mut self) -> f64 {
        2.0 * self.uniform() - 1.0
    }
    /// Complex with both parts uniform in [-1, 1).
    pub fn c(&mut self) -> Complex<f64> {
        Complex::new(self.sym(), self.sym())
    }
}
