//! `rotorid identify`: bearing coefficients and unbalance from a
//! measurement CSV.

use clap::{Args, ValueEnum};

use super::{CliError, Io};
use crate::estimate::IdentifyError;
use rotorid_core::identify::{delta_range, MIN_LAMBDA};

/// `x` for a message: plain for ordinary magnitudes, scientific otherwise
/// (so `1e-300` is not printed with 300 zeros).
fn short_number(x: f64) -> String {
    if x == 0.0 || (1e-4..1e6).contains(&x.abs()) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// Model structure of the identification.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum FormulationArg {
    /// Real K and C per bearing and complex unbalance (physics enforced).
    Physical,
    /// The paper's complex Z0, Z1 per bearing (Eqs. 43, 47, 48).
    Paper,
}

/// Which estimate `identify` reports.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum EstimatorArg {
    /// The QRD/RLS estimate refined by the output-error (maximum-likelihood) fit.
    Oe,
    /// The QRD/RLS estimate alone (the paper's method).
    Rls,
}

/// Arguments of `rotorid identify`.
#[derive(Debug, Clone, PartialEq, Args)]
pub struct IdentifyArgs {
    /// Model: `paper` or a model file (rotorid or ROSS TOML).
    #[arg(long, value_name = "MODEL")]
    pub model: String,
    /// Measurement CSV (see the README, "Measurement file").
    #[arg(long, value_name = "FILE.csv")]
    pub measurements: std::path::PathBuf,
    /// Model structure.
    #[arg(long, value_enum, default_value_t = FormulationArg::Physical)]
    pub formulation: FormulationArg,
    /// The estimate reported.
    #[arg(long, value_enum, default_value_t = EstimatorArg::Oe)]
    pub estimator: EstimatorArg,
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
    /// Write the estimates as JSON (keys in the README, "Identification").
    #[arg(long, value_name = "OUT.json")]
    pub json: Option<std::path::PathBuf>,
    /// Write plots (SVG) into this folder.
    #[arg(long, value_name = "DIR")]
    pub plot: Option<std::path::PathBuf>,
    /// Write the model as a ROSS rotor file with its bearings replaced by
    /// the identified ones (constant K, C; a law that changes with speed as
    /// a PCHIP table over the measured speed range).
    #[arg(long, value_name = "FILE.toml")]
    pub ross_out: Option<std::path::PathBuf>,
    /// Divide each equation by the norm of its regressor row (weights the
    /// speeds evenly; better with noise proportional to the response).
    #[arg(long)]
    pub normalise_rows: bool,
    /// Steady-running guard: a sample whose speed is within this many rpm
    /// of one of the last 4 new samples (or closely between two of them)
    /// is skipped; the others count as new and forget.
    #[arg(
        long,
        default_value_t = 0.0,
        value_name = "RPM",
        allow_negative_numbers = true
    )]
    pub steady_margin: f64,
    /// No steady-running guard: every sample forgets (the paper).
    #[arg(long)]
    pub no_steady_guard: bool,
    /// Raw SI unknowns (no column scaling), as in the paper.
    #[arg(long)]
    pub no_scaling: bool,
    /// The probes' noise floor (m, every channel), e.g. from the probe
    /// system's data sheet; without it the floor is estimated from the data
    /// (SPEC section 7).
    #[arg(long, value_name = "M", allow_negative_numbers = true)]
    pub noise_floor: Option<f64>,
    /// Runout: `auto` fits a runout phasor per channel when the low-speed
    /// samples show one, `fit` always, `none` never.
    #[arg(long, value_enum, default_value_t = RunoutArg::Auto, conflicts_with = "slow_roll")]
    pub runout: RunoutArg,
    /// Slow-roll vector subtraction instead: the mean vector of the samples
    /// at or below this speed (rpm) is subtracted from every sample.
    #[arg(long, value_name = "RPM", allow_negative_numbers = true)]
    pub slow_roll: Option<f64>,
    /// Keep every sample in the output-error fit (no outlier exclusion).
    #[arg(long)]
    pub no_outliers: bool,
    /// The measurement file's instrument conventions (over its
    /// `# conventions:` line).
    #[command(flatten)]
    pub conventions: super::ConventionArgs,
}

/// `--runout`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum RunoutArg {
    /// Fit the runout when the low-speed samples show one.
    Auto,
    /// Always fit a runout phasor per channel.
    Fit,
    /// No runout.
    None,
}

/// The identification options `args` ask for: the library's defaults, then
/// the arguments, each checked (the message names the option). The
/// command and the Python package build their options here.
pub fn options(args: &IdentifyArgs) -> Result<crate::estimate::Options, CliError> {
    use crate::core::parametrization::{Structure, MAX_ORDER};
    use crate::estimate::{Estimator, Options, Precision};

    if !(1..=MAX_ORDER).contains(&args.order) {
        return Err(CliError::new(format!(
            "--order must be in 1..={MAX_ORDER}, got {}",
            args.order
        )));
    }
    if !(args.lambda >= MIN_LAMBDA && args.lambda <= 1.0) {
        return Err(CliError::new(format!(
            "--lambda must be in [{MIN_LAMBDA:.3}, 1] (a memory of at least one update: -1/ln(lambda) >= 1), got {}",
            short_number(args.lambda)
        )));
    }
    let (delta_lo, delta_hi, precision) = if args.f32 {
        let (lo, hi) = delta_range::<f32>();
        (f64::from(lo), f64::from(hi), "--f32")
    } else {
        let (lo, hi) = delta_range::<f64>();
        (lo, hi, "double precision")
    };
    if !(args.delta >= delta_lo && args.delta <= delta_hi) {
        return Err(CliError::new(format!(
            "--delta must be in [{delta_lo:.2e}, {delta_hi:.2e}] with {precision}, got {:e}",
            args.delta
        )));
    }
    let structure = match args.formulation {
        FormulationArg::Physical => Structure::physical(args.order),
        FormulationArg::Paper => Structure::paper(args.order),
    };
    // The library's defaults, then the arguments.
    let mut opts = Options {
        structure,
        ..Options::default()
    };
    opts.lambda = args.lambda;
    opts.delta = args.delta;
    opts.precision = if args.f32 {
        Precision::F32
    } else {
        Precision::F64
    };
    opts.record_history = args.plot.is_some();
    opts.estimator = match args.estimator {
        EstimatorArg::Oe => Estimator::OutputError,
        EstimatorArg::Rls => Estimator::Rls,
    };
    opts.normalise_rows = args.normalise_rows;
    if !(args.steady_margin >= 0.0 && args.steady_margin.is_finite()) {
        return Err(CliError::new(format!(
            "--steady-margin must be finite and >= 0, got {}",
            args.steady_margin
        )));
    }
    opts.steady.margin = crate::units::rpm_to_rad_s(args.steady_margin);
    opts.steady.coverage = !args.no_steady_guard;
    if args.no_scaling {
        opts.scaling = Some(crate::core::scaling::ColumnScaling::identity());
    }
    opts.noise_floor = super::noise_floor_option(args.noise_floor)?;
    opts.outliers = !args.no_outliers;
    opts.runout = match (args.slow_roll, args.runout) {
        (Some(rpm), _) => {
            if !(rpm.is_finite() && rpm >= 0.0) {
                return Err(CliError::new(format!(
                    "--slow-roll must be finite and >= 0 rpm, got {rpm}"
                )));
            }
            crate::estimate::RunoutHandling::SlowRoll(crate::units::rpm_to_rad_s(rpm))
        }
        (None, RunoutArg::Auto) => crate::estimate::RunoutHandling::Auto,
        (None, RunoutArg::Fit) => crate::estimate::RunoutHandling::Fit,
        (None, RunoutArg::None) => crate::estimate::RunoutHandling::None,
    };
    Ok(opts)
}

/// Runs `rotorid identify`: loads the model and the measurements, reduces
/// the model at every measured speed, runs the identification (progress bar
/// on the process's stderr when `io.progress` and the sweep is long), prints the table
/// of identified values next to the model's with relative errors, and
/// optionally writes the JSON and SVG plots.
pub fn run(args: &IdentifyArgs, io: &mut Io<'_>) -> Result<(), CliError> {
    use crate::report::identify::{report_table, write_plots};

    let mut opts = options(args)?;
    super::refuse_overwriting_inputs(
        Some(&args.model),
        &[("--measurements", &args.measurements)],
        &[
            ("--json", args.json.as_deref()),
            ("--plot", args.plot.as_deref()),
            ("--ross-out", args.ross_out.as_deref()),
        ],
    )?;
    let model_file = super::load_model_arg(&args.model)?;
    let file = args.measurements.display().to_string();
    let read = super::read_measurements(&args.measurements, &model_file, &args.conventions)?;
    let (meas, located, sample_std) = (read.measurements, read.located, read.sample_std);
    let model = model_file.model;
    let n = meas.samples.len();
    let bar = if io.progress && n >= 100 {
        let pb = indicatif::ProgressBar::new(n as u64);
        pb.set_style(
            indicatif::ProgressStyle::with_template("identify {bar:40} {pos}/{len} speeds {eta}")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        Some(pb)
    } else {
        None
    };
    if let Some(pb) = bar.clone() {
        opts.progress = Some(crate::estimate::Progress::new(move |done| {
            pb.set_position(done as u64)
        }));
    }
    let std_rows = (!sample_std.is_empty()).then_some(sample_std.as_slice());
    let result = crate::estimate::identify_with_std(&model, &meas, std_rows, &opts);
    if let Some(pb) = &bar {
        pb.finish_and_clear();
    }
    let mut id = result.map_err(|e| match e {
        IdentifyError::Step { index, rpm, source } => {
            let line = located.lines.get(index).copied().unwrap_or(0);
            CliError::new(format!("{file}: line {line} ({rpm} rpm): {source}"))
        }
        other => CliError::new(other.to_string()),
    })?;

    let sweep = super::sweep_warnings(&model, &meas, located.sweep_rate_rpm_per_s);
    match &mut id.check {
        Some(check) => check.warnings.extend(sweep),
        None => {
            for w in &sweep {
                writeln!(io.err, "warning: {w}")?;
            }
        }
    }
    write!(io.out, "{}", report_table(&id, Some(&model)))?;
    if let Some(check) = &id.check {
        for w in &check.warnings {
            writeln!(io.err, "warning: {w}")?;
        }
    }
    if let Some(path) = &args.json {
        let text = serde_json::to_string_pretty(&id.result())?;
        crate::io::output::write_atomic(path, (text + "\n").as_bytes())?;
    }
    if let Some(path) = &args.ross_out {
        let text = id
            .ross_toml(&model, &meas)
            .map_err(|e| CliError::new(format!("--ross-out: {e}")))?;
        crate::io::output::write_atomic(path, text.as_bytes())
            .map_err(|e| CliError::new(format!("{}: {e}", path.display())))?;
        writeln!(io.err, "wrote {}", path.display())?;
    }
    if let Some(dir) = &args.plot {
        let rpm_max = crate::units::rad_s_to_rpm(crate::estimate::max_speed(&meas.samples));
        let files = write_plots(dir, "", &id, &model, Some(&model), rpm_max.max(1.0))?;
        for f in files {
            writeln!(io.err, "wrote {}", f.display())?;
        }
    }
    Ok(())
}
