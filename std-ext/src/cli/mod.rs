//! The `rotorid` command line (the contract is in the README).
//!
//! ```text
//! rotorid simulate --model MODEL --out FILE.csv [--rpm-min 50] [--rpm-max 15000] [--rpm-step 50] [--noise 0.01] [--seed 1]
//!                  [--nodes N,N,...] [--plot DIR]
//! rotorid tables   --model MODEL --out FILE [--rpm-min 50] [--rpm-max 15000] [--rpm-step 50] [--f32]
//!                  [--adaptive TOL] [--formulation physical|paper] [--order 1]
//! rotorid identify --model MODEL --measurements FILE.csv [--formulation physical|paper] [--order 1]
//!                  [--lambda 0.999] [--delta 1e-7] [--f32] [--json OUT.json] [--plot DIR]
//!                  [--amplitude-unit m|mm|um|mil] [--amplitude 0-pk|pk-pk|rms] [--phase arg|lag]
//! rotorid diagnose --model MODEL --measurements FILE.csv [--json OUT.json]
//!                  [--amplitude-unit ...] [--amplitude ...] [--phase ...]
//! rotorid campbell --model MODEL [--rpm-max 15000] [--rpm-step 250] [--modes 8]
//!                  [--plot OUT.svg] [--json OUT.json] [--csv OUT.csv]
//! rotorid vectors  --signals FILE --out VECTORS.csv [--plot DIR] [--json OUT.json] [--config FILE.toml]
//!                  [--kp SOURCE] [--channels b1_y=0,...] [--sensitivity V/mm] [--full-scale V]
//!                  [--edge rising|falling] [--kp-level X] [--kp-hysteresis X]
//!                  [--speed-min RPM] [--speed-max RPM] [--revolutions 8] [--no-pool]
//! ```
//!
//! MODEL is `paper` (the built-in reference rotor), `paper-speed-dependent`
//! (Eq. 49) or a path to a model file (rotorid TOML or ROSS TOML, detected).
//! Exit status 0 on success; 2 with a one-line message on stderr for any
//! error, including command-line usage errors.
//!
//! Every command writes through the writers of an [`Io`], so the whole
//! command line runs in-process on any pair of writers
//! ([`run_with_io`]); the binary passes the process's stdout and stderr
//! ([`main_with_args`]).

use std::fmt;
use std::io::{IsTerminal, Write};

use clap::{Args, Parser, Subcommand};

use crate::io::model_file::{model_file_by_name_or_path, ModelFile};

pub mod campbell;
pub mod diagnose;
pub mod identify;
pub mod simulate;
pub mod tables;
pub mod vectors;

pub use campbell::CampbellArgs;
pub use diagnose::DiagnoseArgs;
pub use identify::{FormulationArg, IdentifyArgs};
pub use simulate::SimulateArgs;
pub use tables::TablesArgs;
pub use vectors::VectorsArgs;

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
    /// Turn recorded probe and keyphasor signals into a measurement CSV.
    Vectors(VectorsArgs),
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
pub fn load_model_arg(name_or_path: &str) -> Result<ModelFile, CliError> {
    model_file_by_name_or_path(name_or_path).map_err(|e| match e {
        crate::io::model_file::ModelFileError::UnknownModel(_)
        | crate::io::model_file::ModelFileError::NotFound(_) => CliError(e.to_string()),
        other => CliError(format!("model {name_or_path}: {other}")),
    })
}

/// Refuses a command line whose outputs (`(option, path)`, `None` when
/// not given) include one of its inputs: the model file (unless `model` is
/// a built-in name) or another input file. Called before anything runs.
pub fn refuse_overwriting_inputs(
    model: Option<&str>,
    inputs: &[(&str, &std::path::Path)],
    outputs: &[(&str, Option<&std::path::Path>)],
) -> Result<(), CliError> {
    let mut all: Vec<(&str, &std::path::Path)> = Vec::new();
    if let Some(m) = model {
        if crate::io::model_file::builtin_model(m).is_none() {
            all.push(("--model", std::path::Path::new(m)));
        }
    }
    all.extend_from_slice(inputs);
    let outs: Vec<(&str, &std::path::Path)> = outputs
        .iter()
        .filter_map(|(f, p)| p.map(|p| (*f, p)))
        .collect();
    crate::io::output::refuse_inputs_as_outputs(&all, &outs)?;
    Ok(())
}

/// Where a command writes: its stdout and stderr, and whether it may draw
/// a progress bar (on the process's stderr, only when that is a terminal).
pub struct Io<'a> {
    /// The command's output (tables, summaries).
    pub out: &'a mut dyn Write,
    /// Messages (`wrote FILE`) and the one-line error.
    pub err: &'a mut dyn Write,
    /// Draw progress bars on the process's stderr.
    pub progress: bool,
}

/// Runs a parsed command line.
pub fn run(cli: &Cli, io: &mut Io<'_>) -> Result<(), CliError> {
    match &cli.command {
        Command::Simulate(a) => simulate::run(a, io),
        Command::Tables(a) => tables::run(a, io),
        Command::Identify(a) => identify::run(a, io),
        Command::Diagnose(a) => diagnose::run(a, io),
        Command::Campbell(a) => campbell::run(a, io),
        Command::Vectors(a) => vectors::run(a, io),
    }
}

/// Parses `args` (the first is the program name), runs the command with
/// `stdout` and `stderr` as its output and returns the exit status: 0 on
/// success (and for `--help`/`--version`), 2 with a one-line message on
/// `stderr` on any error. No progress bar.
pub fn run_with_io<I, T>(args: I, stdout: &mut impl Write, stderr: &mut impl Write) -> i32
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    run_args(
        args,
        &mut Io {
            out: stdout,
            err: stderr,
            progress: false,
        },
    )
}

/// [`run_with_io`] on `io`.
fn run_args<I, T>(args: I, io: &mut Io<'_>) -> i32
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    // A failed write of the error line itself has nowhere else to go: the
    // status says it.
    let cli = match Cli::try_parse_from(args) {
        Ok(c) => c,
        Err(e) => {
            use clap::error::ErrorKind;
            match e.kind() {
                ErrorKind::DisplayHelp | ErrorKind::DisplayVersion => {
                    return match write!(io.out, "{}", e.render()).and_then(|()| io.out.flush()) {
                        Ok(()) => 0,
                        Err(_) => EXIT_ERROR,
                    };
                }
                ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand => {
                    let _ = writeln!(
                        io.err,
                        "error: a command is required (simulate, tables, identify, diagnose, campbell, vectors); see `rotorid --help`"
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
                    let _ = writeln!(io.err, "{msg} (see `rotorid --help`)");
                    return EXIT_ERROR;
                }
            }
        }
    };
    match run(&cli, io).and_then(|()| io.out.flush().map_err(CliError::from)) {
        Ok(()) => 0,
        Err(e) => {
            let msg = e.one_line();
            let _ = if msg.starts_with("error") {
                writeln!(io.err, "{msg}")
            } else {
                writeln!(io.err, "error: {msg}")
            };
            EXIT_ERROR
        }
    }
}

/// [`run_with_io`] on the process's stdout and stderr, with a progress bar
/// for long runs when stderr is a terminal.
pub fn main_with_args<I, T>(args: I) -> i32
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    run_args(
        args,
        &mut Io {
            out: &mut std::io::stdout(),
            err: &mut std::io::stderr(),
            progress: std::io::stderr().is_terminal(),
        },
    )
}

/// [`main_with_args`] on the process's arguments.
pub fn main_from_env() -> i32 {
    main_with_args(std::env::args_os())
}

/// A measurement file's error as one line: `file not found: X` for a
/// missing file, the error itself for other I/O errors (it names the file),
/// `X: error` for the file's contents.
pub fn measurement_error(
    path: &std::path::Path,
    e: crate::io::measurement::MeasurementError,
) -> CliError {
    use crate::io::measurement::MeasurementError;
    match e {
        MeasurementError::Io { source, .. } if source.kind() == std::io::ErrorKind::NotFound => {
            CliError::new(format!("file not found: {}", path.display()))
        }
        e @ MeasurementError::Io { .. } => CliError::new(e.to_string()),
        e => CliError::new(format!("{}: {e}", path.display())),
    }
}

/// The instrument conventions of the measurement file (SPEC section 7),
/// `identify`'s and `diagnose`'s `--amplitude-unit`, `--amplitude`,
/// `--phase`: each overrides the same key of the file's `# conventions:`
/// line; without either a value is rotorid's own (m, 0-pk, arg).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Args)]
pub struct ConventionArgs {
    /// Unit of the file's amplitudes, re/im values and `_std` columns: m,
    /// mm, um or mil (25.4e-6 m). Overrides the file's `# conventions:` line.
    #[arg(long, value_name = "UNIT")]
    pub amplitude_unit: Option<crate::io::measurement::AmplitudeUnit>,
    /// What the file's amplitudes measure: 0-pk, pk-pk (read as half) or
    /// rms (read as sqrt 2 times). Overrides the file's line.
    #[arg(long, value_name = "KIND")]
    pub amplitude: Option<crate::io::measurement::AmplitudeKind>,
    /// What the file's phases are: arg (arg Y, rotorid's) or lag (the lag
    /// from the keyphasor to the next positive peak, API 670 and ROSS;
    /// read as arg Y = -lag). Overrides the file's line.
    #[arg(long, value_name = "arg|lag")]
    pub phase: Option<crate::io::measurement::PhaseConvention>,
}

impl ConventionArgs {
    /// The keys given on the command line.
    pub fn declared(&self) -> crate::io::measurement::DeclaredConventions {
        crate::io::measurement::DeclaredConventions {
            amplitude_unit: self.amplitude_unit,
            amplitude: self.amplitude,
            phase: self.phase,
        }
    }
}

/// [`crate::io::measurement::read_for_model_with`] with the command line's
/// conventions over the file's, and the error as one line
/// ([`measurement_error`]).
pub fn read_measurements(
    path: &std::path::Path,
    file: &crate::io::model_file::ModelFile,
    conventions: &ConventionArgs,
) -> Result<crate::io::measurement::ModelMeasurements, CliError> {
    crate::io::measurement::read_for_model_with(path, file, &conventions.declared())
        .map_err(|e| measurement_error(path, e))
}

/// The warnings of a file's `# sweep: rate_rpm_per_s=...` line
/// ([`crate::campbell::sweep_rate_warnings`] over the file's speed range):
/// none without the line; one line if the check itself cannot be made.
pub fn sweep_warnings(
    model: &crate::model::RotorModel,
    meas: &crate::io::measurement::Measurements,
    rate_rpm_per_s: Option<f64>,
) -> Vec<String> {
    let Some(rate) = rate_rpm_per_s else {
        return Vec::new();
    };
    let rpm = |s: &crate::io::measurement::Sample| crate::units::rad_s_to_rpm(s.omega);
    let lo = meas.samples.iter().map(rpm).fold(f64::INFINITY, f64::min);
    let hi = meas.samples.iter().map(rpm).fold(0.0, f64::max);
    if meas.samples.is_empty() {
        return Vec::new();
    }
    match crate::campbell::sweep_rate_warnings(model, lo, hi, rate) {
        Ok(v) => v.iter().map(|f| f.message(rate)).collect(),
        Err(e) => vec![format!(
            "the sweep rate {rate} rpm/s was not checked against the critical speeds: {e}"
        )],
    }
}

/// `--noise-floor M`: finite and >= 0 metres.
pub fn noise_floor_option(v: Option<f64>) -> Result<Option<f64>, CliError> {
    match v {
        Some(f) if !(f.is_finite() && f >= 0.0) => Err(CliError::new(format!(
            "--noise-floor must be finite and >= 0 (metres), got {f}"
        ))),
        other => Ok(other),
    }
}
