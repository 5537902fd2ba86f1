//! `rotorid identify`: bearing coefficients and unbalance from a
//! measurement CSV.

use clap::{Args, ValueEnum};

use super::CliError;

/// Model structure of the identification.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Formulation {
    /// Real K and C per bearing and complex unbalance (physics enforced).
    Physical,
    /// The paper's complex Z0, Z1 per bearing (Eqs. 43, 47, 48).
    Paper,
}

/// Arguments of `rotorid identify`.
#[derive(Debug, Clone, PartialEq, Args)]
pub struct IdentifyArgs {
    /// Model: `paper` or a model file (rotorid or ROSS TOML).
    #[arg(long, value_name = "MODEL")]
    pub model: String,
    /// Measurement CSV (SPEC section 4).
    #[arg(long, value_name = "FILE.csv")]
    pub measurements: std::path::PathBuf,
    /// Model structure.
    #[arg(long, value_enum, default_value_t = Formulation::Physical)]
    pub formulation: Formulation,
    /// Polynomial order P of the bearing dynamic stiffness in Omega
    /// (1 = Z0 + Omega Z1).
    #[arg(long, default_value_t = 1, value_name = "P")]
    pub order: usize,
    /// Forgetting factor lambda in (0, 1].
    #[arg(long, default_value_t = 0.999, allow_negative_numbers = true)]
    pub lambda: f64,
    /// Regularisation delta > 0 (R(0) = sqrt(delta) I).
    #[arg(long, default_value_t = 1e-7, allow_negative_numbers = true)]
    pub delta: f64,
    /// Run the identification in single precision.
    #[arg(long = "f32")]
    pub f32: bool,
    /// Write the estimates as JSON (SPEC section 5).
    #[arg(long, value_name = "OUT.json")]
    pub json: Option<std::path::PathBuf>,
    /// Write plots (SVG) into this folder.
    #[arg(long, value_name = "DIR")]
    pub plot: Option<std::path::PathBuf>,
}

/// Runs `rotorid identify`.
pub fn run(args: &IdentifyArgs) -> Result<(), CliError> {
    let _ = args;
    Err(CliError::new("identify: not yet available in this build"))
}
