//! `rotorid campbell`: damped natural frequencies against speed, whirl
//! direction, log decrement and critical speeds; optional SVG diagram.

use clap::Args;

use super::CliError;

/// Arguments of `rotorid campbell`.
#[derive(Debug, Clone, PartialEq, Args)]
pub struct CampbellArgs {
    /// Model: `paper` or a model file (rotorid or ROSS TOML).
    #[arg(long, value_name = "MODEL")]
    pub model: String,
    /// Highest speed (rpm); the diagram runs from 0.
    #[arg(
        long,
        default_value_t = 15000.0,
        value_name = "RPM",
        allow_negative_numbers = true
    )]
    pub rpm_max: f64,
    /// Speed step of the diagram (rpm).
    #[arg(
        long,
        default_value_t = 250.0,
        value_name = "RPM",
        allow_negative_numbers = true
    )]
    pub rpm_step: f64,
    /// Number of modes (lowest natural frequencies) per speed.
    #[arg(long, default_value_t = 8)]
    pub modes: usize,
    /// Write the diagram as SVG.
    #[arg(long, value_name = "OUT.svg")]
    pub plot: Option<std::path::PathBuf>,
}

/// Runs `rotorid campbell`.
pub fn run(args: &CampbellArgs) -> Result<(), CliError> {
    let _ = args;
    Err(CliError::new(
        "campbell: the Campbell analysis is not in this build yet",
    ))
}
