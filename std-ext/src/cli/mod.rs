//! The `rotorid` command line (SPEC section 5).
//!
//! ```text
//! rotorid simulate --model MODEL --out FILE.csv [--rpm-min 50] [--rpm-max 15000] [--rpm-step 50] [--noise 0.01] [--seed 1]
//! rotorid tables   --model MODEL --out FILE [--rpm-min 50] [--rpm-max 15000] [--rpm-step 50] [--f32]
//!                  [--adaptive TOL] [--formulation physical|paper] [--order 1]
//! rotorid identify --model MODEL --measurements FILE.csv [--formulation physical|paper] [--order 1]
//!                  [--lambda 0.999] [--delta 1e-7] [--f32] [--json OUT.json] [--plot DIR]
//! rotorid diagnose --model MODEL --measurements FILE.csv [--json OUT.json]
//! rotorid campbell --model MODEL [--rpm-max 15000] [--plot OUT.svg]
//! ```
//!
//! MODEL is `paper` (the built-in reference rotor), `paper-speed-dependent`
//! (Eq. 49) or a path to a model file (rotorid TOML or ROSS TOML, detected).
//! Exit status 0 on success; 2 with a one-line message on stderr for any
//! error, including command-line usage errors.

use std::fmt;

use clap::{Args, Parser, Subcommand};

use crate::io::model_file::{model_file_by_name_or_path, ModelFile};

pub mod campbell;
pub mod diagnose;
pub mod identify;
pub mod simulate;
pub mod tables;

pub use campbell::CampbellArgs;
pub use diagnose::DiagnoseArgs;
pub use identify::{Formulation, IdentifyArgs};
pub use simulate::SimulateArgs;
pub use tables::TablesArgs;

/// Exit status for every error (bad input, usage, failed computation).
pub const EXIT_ERROR: i32 = 2;

/// Bearing stiffness, damping and unbalance identification from 1X
/// bearing vibration.
#[derive(Debug, Parser)]
#[command(name = "rotorid", version, about, long_about = None)]
pub struct Cli {
    /// The command.
    #[command(subcommand)]
    pub command: Command,
}

/// The commands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Simulate a measurement CSV (1X response at the bearings) from a model.
    Simulate(SimulateArgs),
    /// Precompute the bearing-level model tables for firmware.
    Tables(TablesArgs),
    /// Identify bearing coefficients and unbalance from a measurement CSV.
    Identify(IdentifyArgs),
    /// Find which physical effect the nominal model lacks.
    Diagnose(DiagnoseArgs),
    /// Campbell diagram: natural frequencies, whirl, log dec, critical speeds.
    Campbell(CampbellArgs),
}

/// The uniform speed grid of `simulate` and `tables`: from `--rpm-min` in
/// steps of `--rpm-step` up to and including `--rpm-max` when it falls on
/// the grid.
#[derive(Debug, Clone, Copy, PartialEq, Args)]
pub struct RpmGridArgs {
    /// Lowest speed (rpm).
    #[arg(
        long,
        default_value_t = 50.0,
        value_name = "RPM",
        allow_negative_numbers = true
    )]
    pub rpm_min: f64,
    /// Highest speed (rpm), included when on the grid.
    #[arg(
        long,
        default_value_t = 15000.0,
        value_name = "RPM",
        allow_negative_numbers = true
    )]
    pub rpm_max: f64,
    /// Step (rpm).
    #[arg(
        long,
        default_value_t = 50.0,
        value_name = "RPM",
        allow_negative_numbers = true
    )]
    pub rpm_step: f64,
}

impl RpmGridArgs {
    /// The speeds (rpm), validated.
    pub fn speeds_rpm(&self) -> Result<Vec<f64>, CliError> {
        Ok(crate::tables::grid::uniform_rpm(
            self.rpm_min,
            self.rpm_max,
            self.rpm_step,
        )?)
    }

    /// The speeds (rad/s), validated.
    pub fn speeds_rad_s(&self) -> Result<Vec<f64>, CliError> {
        Ok(self
            .speeds_rpm()?
            .into_iter()
            .map(crate::units::rpm_to_rad_s)
            .collect())
    }
}

/// A command's failure: one line for stderr.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CliError(pub String);

impl CliError {
    /// An error with this message.
    pub fn new(msg: impl Into<String>) -> Self {
        CliError(msg.into())
    }

    /// The message on one line (line breaks joined with "; ").
    pub fn one_line(&self) -> String {
        self.0
            .lines()
            .map(str::trim)
            .filter(|l| !l.is_empty())
            .collect::<Vec<_>>()
            .join("; ")
    }
}

impl fmt::Display for CliError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.one_line())
    }
}

impl<E: std::error::Error> From<E> for CliError {
    fn from(e: E) -> Self {
        CliError(e.to_string())
    }
}

/// Loads MODEL: a built-in name or a model file (own format or ROSS), with
/// the file's `[simulate]` effects. The error names the model argument.
pub fn load_model(name_or_path: &str) -> Result<ModelFile, CliError> {
    model_file_by_name_or_path(name_or_path).map_err(|e| match e {
        crate::io::model_file::ModelFileError::UnknownModel(_) => CliError(e.to_string()),
        other => CliError(format!("model {name_or_path}: {other}")),
    })
}

/// Runs a parsed command line.
pub fn run(cli: &Cli) -> Result<(), CliError> {
    match &cli.command {
        Command::Simulate(a) => simulate::run(a),
        Command::Tables(a) => tables::run(a),
        Command::Identify(a) => identify::run(a),
        Command::Diagnose(a) => diagnose::run(a),
        Command::Campbell(a) => campbell::run(a),
    }
}

/// Parses `args` (the first is the program name), runs the command and
/// returns the exit status: 0 on success (and for `--help`/`--version`),
/// 2 with a one-line message on stderr on any error.
pub fn main_with_args<I, T>(args: I) -> i32
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    let cli = match Cli::try_parse_from(args) {
        Ok(c) => c,
        Err(e) => {
            use clap::error::ErrorKind;
            match e.kind() {
                ErrorKind::DisplayHelp | ErrorKind::DisplayVersion => {
                    let _ = e.print();
                    return 0;
                }
                ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand => {
                    eprintln!(
                        "error: a command is required (simulate, tables, identify, diagnose, campbell); see `rotorid --help`"
                    );
                    return EXIT_ERROR;
                }
                _ => {
                    // clap's message up to its usage block, on one line.
                    let rendered = e.render().to_string();
                    let msg = rendered
                        .lines()
                        .take_while(|l| !l.starts_with("Usage:"))
                        .map(str::trim)
                        .filter(|l| !l.is_empty() && !l.starts_with("For more information"))
                        .collect::<Vec<_>>()
                        .join(" ");
                    let msg = if msg.is_empty() {
                        "error: invalid command line".to_string()
                    } else {
                        msg
                    };
                    eprintln!("{msg} (see `rotorid --help`)");
                    return EXIT_ERROR;
                }
            }
        }
    };
    match run(&cli) {
        Ok(()) => 0,
        Err(e) => {
            let msg = e.one_line();
            if msg.starts_with("error") {
                eprintln!("{msg}");
            } else {
                eprintln!("error: {msg}");
            }
            EXIT_ERROR
        }
    }
}

/// [`main_with_args`] on the process's arguments.
pub fn main_from_env() -> i32 {
    main_with_args(std::env::args_os())
}
