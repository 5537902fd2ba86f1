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
    /// Write plots (SVG) into this folder: residual against speed, and
    /// measured/nominal/extended amplitude per probe.
    #[arg(long, value_name = "DIR")]
    pub plot: Option<std::path::PathBuf>,
    /// Polynomial order of the nominal bearing law (physical K, C).
    #[arg(long, default_value_t = 1)]
    pub order: usize,
    /// False-alarm rate of the choice: the probability that noise alone
    /// names an effect.
    #[arg(long, default_value_t = 1e-3)]
    pub false_alarm: f64,
    /// The probes' noise floor (m, every channel), e.g. from the probe
    /// system's data sheet; without it the floor is estimated from the data
    /// (SPEC section 7).
    #[arg(long, value_name = "M", allow_negative_numbers = true)]
    pub noise_floor: Option<f64>,
    /// The measurement file's instrument conventions (over its
    /// `# conventions:` line).
    #[command(flatten)]
    pub conventions: super::ConventionArgs,
}

/// Runs `rotorid diagnose`.
pub fn run(args: &DiagnoseArgs, io: &mut Io<'_>) -> Result<(), CliError> {
    use crate::diagnose::{diagnose, predictions, DiagnoseOptions};
    use crate::model::ProbeReference;
    use crate::report::diagnose::{json, text, write_plots};

    super::refuse_overwriting_inputs(
        Some(&args.model),
        &[("--measurements", &args.measurements)],
        &[
            ("--json", args.json.as_deref()),
            ("--plot", args.plot.as_deref()),
        ],
    )?;
    let model_file = super::load_model_arg(&args.model)?;
    let read = super::read_measurements(&args.measurements, &model_file, &args.conventions)?;
    let (meas, sweep_rate) = (read.measurements, read.located.sweep_rate_rpm_per_s);
    let model = model_file.model;
    if meas.samples.len() < 8 {
        return Err(CliError::new(format!(
            "{}: {} speeds: the diagnosis needs at least 8 (and many more to tell effects apart)",
            args.measurements.display(),
            meas.samples.len()
        )));
    }
    let opts = DiagnoseOptions {
        order: args.order,
        false_alarm: args.false_alarm,
        relative_probes: model.probes == ProbeReference::Relative,
        noise_floor: super::noise_floor_option(args.noise_floor)?,
        ..Default::default()
    };
    let mut d =
        diagnose(&model, &meas, &opts).map_err(|e| CliError::new(format!("diagnose: {e}")))?;
    d.warnings
        .extend(super::sweep_warnings(&model, &meas, sweep_rate));
    let nominal =
        predictions(&model, &d, &d.nominal).map_err(|e| CliError::new(format!("diagnose: {e}")))?;
    write!(io.out, "{}", text(&d, &meas.samples, &nominal))?;
    for w in &d.warnings {
        writeln!(io.err, "warning: {w}")?;
    }
    if let Some(path) = &args.json {
        let t = serde_json::to_string_pretty(&json(&d))?;
        crate::io::output::write_atomic(path, (t + "\n").as_bytes())
            .map_err(|e| CliError::new(format!("{}: {e}", path.display())))?;
    }
    if let Some(dir) = &args.plot {
        std::fs::create_dir_all(dir)
            .map_err(|e| CliError::new(format!("{}: {e}", dir.display())))?;
        let ext = predictions(&model, &d, d.extended())
            .map_err(|e| CliError::new(format!("diagnose: {e}")))?;
        let files = write_plots(dir, &d, &meas.samples, &nominal, &ext)
            .map_err(|e| CliError::new(e.to_string()))?;
        for f in files {
            writeln!(io.err, "wrote {}", f.display())?;
        }
    }
    Ok(())
}
