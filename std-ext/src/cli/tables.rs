//! `rotorid tables`: precompute the bearing-level model tables (the
//! reduction of the FE model to the bearing DOFs) on a speed grid and write
//! them for firmware.

use clap::Args;

use super::{CliError, RpmGridArgs};

/// Arguments of `rotorid tables`.
#[derive(Debug, Clone, PartialEq, Args)]
pub struct TablesArgs {
    /// Model: `paper` or a model file (rotorid or ROSS TOML).
    #[arg(long, value_name = "MODEL")]
    pub model: String,
    /// Output file.
    #[arg(long, value_name = "FILE")]
    pub out: std::path::PathBuf,
    /// Speed grid.
    #[command(flatten)]
    pub grid: RpmGridArgs,
    /// Store the table in single precision.
    #[arg(long = "f32")]
    pub f32: bool,
}

/// Runs `rotorid tables`.
pub fn run(args: &TablesArgs) -> Result<(), CliError> {
    let _ = args;
    Err(CliError::new("tables: not yet available in this build"))
}
