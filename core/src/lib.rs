#![doc = include_str!("../README.md")]
#![no_std]
#![forbid(unsafe_code)]
#![warn(missing_docs)]
// Panic discipline: no unwrap, expect or panic outside the tests (errors
// are returned; compile-time `assert!` in const contexts is allowed), and
// no indexing or slicing that could panic, except where a scoped `allow`
// states why the index is in range.
#![cfg_attr(
    not(test),
    deny(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::panic,
        clippy::indexing_slicing
    )
)]

#[cfg(any(test, feature = "baseline"))]
extern crate std;

// Reference algorithms for tests and benchmarks only (dense textbook
// indexing over `Vec`s of checked sizes), never on the firmware path.
#[cfg(feature = "baseline")]
#[allow(clippy::indexing_slicing)]
pub mod baseline;
pub mod blockqrd;
pub mod crc32;
pub mod factor;
pub mod givens;
pub mod identify;
pub mod keyphasor;
pub mod ordertrack;
pub mod parametrization;
pub mod prefilter;
pub mod qrdrls;
pub mod regressor;
pub mod scalar;
pub mod scaling;
pub mod sqrtfree;
pub mod streamtrack;
pub mod table;

/// The tests' generator (also included by path into `tests/` and `benches/`).
#[cfg(test)]
pub(crate) mod testrng;

pub use num_complex::Complex;
pub use parametrization::{Formulation, Structure};
pub use scalar::Real;
