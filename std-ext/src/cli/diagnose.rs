//! `rotorid diagnose`: which physical effect the nominal model lacks.

use clap::Args;

use super::{CliError, Io};

/// Arguments of `rotorid diagnose`.
#[derive(Debug, Clone, PartialEq, Args)]
pub struct DiagnoseArgs {
    /// Model: `paper` or a model file (rotorid or ROSS TOML).
    #[arg(long, value_name = "MODEL")]
    pub model: String,
    /// Measurement CSV (see the README, "Measurement file").
    #[arg(long, value_name = "FILE.csv")]
    pub measurements: std::path::PathBuf,
    /// Write the diagnosis as JSON.
    #[arg(long, value_name = "OUT.json")]
    pub json: Option<std::path::PathBuf>,
}

/// Runs `rotorid diagnose`.
pub fn run(args: &DiagnoseArgs, io: &mut Io<'_>) -> Result<(), CliError> {
    let _ = (args, io);
    Err(CliError::new("diagnose: not yet available in this build"))
}
