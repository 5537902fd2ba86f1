//! `rotorid identify`: bearing coefficients and unbalance from a
//! measurement CSV.

use clap::{Args, ValueEnum};

use super::{CliError, Io};

/// Model structure of the identification.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Formulation {
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
    #[arg(long, value_enum, default_value_t = Formulation::Physical)]
    pub formulation: Formulation,
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
}

/// Runs `rotorid identify`: loads the model and the measurements, reduces
/// the model at every measured speed, runs the identification (progress bar
/// on the process's stderr when `io.progress` and the sweep is long), prints the table
/// of identified values next to the model's with relative errors, and
/// optionally writes the JSON and SVG plots.
pub fn run(args: &IdentifyArgs, io: &mut Io<'_>) -> Result<(), CliError> {
    use crate::core::parametrization::{Structure, MAX_ORDER};
    use crate::estimate::{identify, Estimator, Options, Precision};
    use crate::report::identify::{report_table, write_plots};

    if !(1..=MAX_ORDER).contains(&args.order) {
        return Err(CliError::new(format!(
            "--order must be in 1..={MAX_ORDER}, got {}",
            args.order
        )));
    }
    if !(args.lambda > 0.0 && args.lambda <= 1.0) {
        return Err(CliError::new(format!(
            "--lambda must be in (0, 1], got {}",
            args.lambda
        )));
    }
    if !(args.delta > 0.0 && args.delta.is_finite()) {
        return Err(CliError::new(format!(
            "--delta must be finite and > 0, got {}",
            args.delta
        )));
    }
    let model = super::load_model(&args.model)?.model;
    let meas = crate::io::measurement::read_csv(&args.measurements)
        .map_err(|e| CliError::new(format!("{}: {e}", args.measurements.display())))?;
    let structure = match args.formulation {
        Formulation::Physical => Structure::physical(args.order),
        Formulation::Paper => Structure::paper(args.order),
    };
    let mut opts = Options::new(structure);
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
    let tick = |done: usize| {
        if let Some(pb) = &bar {
            pb.set_position(done as u64);
        }
    };
    let result = identify(&model, &meas, &opts, Some(&tick));
    if let Some(pb) = &bar {
        pb.finish_and_clear();
    }
    let id = result?;

    write!(io.out, "{}", report_table(&id, Some(&model)))?;
    if let Some(check) = &id.check {
        for w in &check.warnings {
            writeln!(io.err, "warning: {w}")?;
        }
    }
    if let Some(path) = &args.json {
        let text = serde_json::to_string_pretty(&id.result())?;
        std::fs::write(path, text + "\n")
            .map_err(|e| CliError::new(format!("{}: {e}", path.display())))?;
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
