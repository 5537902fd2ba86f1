//! Measured (or simulated) 1X responses at the bearings, and the
//! measurement CSV format (see the README, "Measurement file").

use num_complex::Complex64;

/// The 1X response phasors at all bearing channels at one speed.
#[derive(Debug, Clone, PartialEq)]
pub struct Sample {
    /// Rotor speed Omega (rad/s).
    pub omega: f64,
    /// Phasors (m), `2 N_b` entries in the order `b1_y, b1_z, b2_y, b2_z, ...`.
    pub q: Vec<Complex64>,
}

/// A sweep of samples, in file order (run-ups and run-downs are both valid).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Measurements {
    /// Comment lines of the file, without the leading `#`.
    pub comments: Vec<String>,
    /// Number of bearings N_b.
    pub n_bearings: usize,
    /// One sample per row.
    pub samples: Vec<Sample>,
}
