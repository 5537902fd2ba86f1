//! `rotorid campbell`: the Campbell analysis of [`crate::campbell()`]
//! (damped natural frequencies against speed, modes tracked by mode shape,
//! whirl direction, log decrement and the critical speeds of every whirl)
//! printed, with optional SVG diagram, JSON and CSV (see
//! [`crate::report::campbell`]).

use clap::Args;

use super::{load_model_arg, CliError, Io};
use crate::campbell::CampbellOptions;
use crate::report::campbell::CampbellReport;

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
    /// Speed step of the diagram (rpm). Critical speeds are refined between
    /// the steps and do not depend on it.
    #[arg(
        long,
        default_value_t = 250.0,
        value_name = "RPM",
        allow_negative_numbers = true
    )]
    pub rpm_step: f64,
    /// Number of modes: those among the N lowest (by undamped natural
    /// frequency) at some speed, each followed across the speed range.
    #[arg(long, default_value_t = 8)]
    pub modes: usize,
    /// Write the diagram as SVG (frequency and log decrement panels).
    #[arg(long, value_name = "OUT.svg")]
    pub plot: Option<std::path::PathBuf>,
    /// Write the modes per speed and the critical speeds as JSON.
    #[arg(long, value_name = "OUT.json")]
    pub json: Option<std::path::PathBuf>,
    /// Write the modes per speed and the critical speeds as CSV.
    #[arg(long, value_name = "OUT.csv")]
    pub csv: Option<std::path::PathBuf>,
    /// Write the shapes of the lowest modes at `--modes-rpm` as SVG (at
    /// most `--modes`, and at most 6).
    #[arg(long, value_name = "OUT.svg")]
    pub modes_plot: Option<std::path::PathBuf>,
    /// Speed (rpm) of the `--modes-plot` shapes.
    #[arg(
        long,
        default_value_t = 0.0,
        value_name = "RPM",
        allow_negative_numbers = true
    )]
    pub modes_rpm: f64,
}

/// The label of MODEL in titles and files: the file's stem for a path,
/// the name for a built-in model.
pub fn model_label(model: &str) -> String {
    if crate::io::model_file::builtin_model(model).is_some() {
        return model.to_string();
    }
    std::path::Path::new(model)
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .filter(|s| !s.is_empty())
        .unwrap_or_else(|| model.to_string())
}

/// Runs `rotorid campbell`.
pub fn run(args: &CampbellArgs, io: &mut Io<'_>) -> Result<(), CliError> {
    let outputs = [
        ("--plot", args.plot.as_deref()),
        ("--json", args.json.as_deref()),
        ("--csv", args.csv.as_deref()),
        ("--modes-plot", args.modes_plot.as_deref()),
    ];
    super::refuse_overwriting_inputs(Some(&args.model), &[], &outputs)?;
    for (i, (fa, a)) in outputs.iter().enumerate() {
        for (fb, b) in &outputs[i + 1..] {
            if let (Some(a), Some(b)) = (a, b) {
                if crate::io::output::same_file(a, b) {
                    return Err(CliError(format!(
                        "{fa} and {fb} name the same file {}",
                        a.display()
                    )));
                }
            }
        }
    }
    let file = load_model_arg(&args.model)?;
    if !(args.rpm_max.is_finite() && args.rpm_max > 0.0) {
        return Err(CliError(format!(
            "--rpm-max must be finite and > 0, got {}",
            args.rpm_max
        )));
    }
    if args.modes == 0 {
        return Err(CliError("--modes must be at least 1".into()));
    }
    if !(args.modes_rpm.is_finite() && args.modes_rpm >= 0.0) {
        return Err(CliError(format!(
            "--modes-rpm must be finite and >= 0, got {}",
            args.modes_rpm
        )));
    }
    let opts = CampbellOptions {
        rpm_max: args.rpm_max,
        rpm_step: args.rpm_step,
        modes: args.modes,
    };
    let analysis = crate::campbell(&file.model, &opts)?;
    let report = CampbellReport::new(model_label(&args.model), &analysis);
    write!(io.out, "{}", report.text())?;
    if let Some(path) = &args.json {
        let t = serde_json::to_string_pretty(&report.json())?;
        crate::io::output::write_atomic(path, (t + "\n").as_bytes())
            .map_err(|e| CliError::new(format!("{}: {e}", path.display())))?;
        writeln!(io.err, "wrote {}", path.display())?;
    }
    if let Some(path) = &args.csv {
        crate::io::output::write_atomic(path, report.csv().as_bytes())
            .map_err(|e| CliError::new(format!("{}: {e}", path.display())))?;
        writeln!(io.err, "wrote {}", path.display())?;
    }
    if let Some(path) = &args.plot {
        report.plot(path, args.rpm_max)?;
        writeln!(io.err, "wrote {}", path.display())?;
    }
    if let Some(path) = &args.modes_plot {
        let n = args.modes.min(crate::report::campbell::MAX_SHAPE_MODES);
        let modes = crate::campbell::mode_shapes(&file.model, args.modes_rpm, n)?;
        if modes.is_empty() {
            return Err(CliError(format!(
                "--modes-plot: no mode with a positive damped frequency at {} rpm",
                args.modes_rpm
            )));
        }
        crate::report::campbell::mode_shape_plot(
            path,
            &model_label(&args.model),
            &file.model,
            &modes,
            args.modes_rpm,
        )?;
        writeln!(io.err, "wrote {}", path.display())?;
    }
    Ok(())
}
