//! `rotorid vectors`: recorded probe and keyphasor signals (the SPEC's
//! signals CSV, or a WAV) to the measurement CSV with standard errors.

use clap::Args;

use super::{CliError, Io};
use crate::signals::{self, Edge, ExtractOptions, SignalConfig, Source};

/// Arguments of `rotorid vectors`.
#[derive(Debug, Clone, PartialEq, Args)]
pub struct VectorsArgs {
    /// The recording: a signals CSV (`time_s,kp,b1_y,...`) or a WAV file
    /// (told by its first bytes).
    #[arg(long, value_name = "FILE")]
    pub signals: std::path::PathBuf,
    /// The measurement CSV written (`speed_rpm,b1_y_re,b1_y_im,b1_y_std,...`).
    #[arg(long, value_name = "VECTORS.csv")]
    pub out: std::path::PathBuf,
    /// Write Bode and polar plots (SVG) of the vectors into this folder.
    #[arg(long, value_name = "DIR")]
    pub plot: Option<std::path::PathBuf>,
    /// Write a JSON summary (rows, revolutions by cause, speeds, sweep rate).
    #[arg(long, value_name = "OUT.json")]
    pub json: Option<std::path::PathBuf>,
    /// Signals configuration (TOML: channel roles, sensitivity, keyphasor
    /// edge and level; see docs/guide/signals.md).
    #[arg(long, value_name = "FILE.toml")]
    pub config: Option<std::path::PathBuf>,
    /// The keyphasor: a WAV channel (0-based) or a CSV column name.
    #[arg(long, value_name = "SOURCE")]
    pub kp: Option<String>,
    /// Probe channel roles, `b1_y=0,b1_z=1,...` (WAV channels or CSV
    /// column names).
    #[arg(long, value_name = "LIST")]
    pub channels: Option<String>,
    /// Every probe's sensitivity (V/mm, e.g. 7.87): probe samples are volts.
    #[arg(long, value_name = "V_PER_MM", allow_negative_numbers = true)]
    pub sensitivity: Option<f64>,
    /// The volts of a full-scale WAV sample (default 1).
    #[arg(long, value_name = "VOLTS", allow_negative_numbers = true)]
    pub full_scale: Option<f64>,
    /// The keyphasor edge whose crossings are the events.
    #[arg(long, value_enum)]
    pub edge: Option<Edge>,
    /// The keyphasor level (default: midway between its minimum and maximum).
    #[arg(long, value_name = "X", allow_negative_numbers = true)]
    pub kp_level: Option<f64>,
    /// The keyphasor hysteresis (default: a tenth of its span).
    #[arg(long, value_name = "X", allow_negative_numbers = true)]
    pub kp_hysteresis: Option<f64>,
    /// Lowest speed accepted (rpm; default from the keyphasor).
    #[arg(long, value_name = "RPM", allow_negative_numbers = true)]
    pub speed_min: Option<f64>,
    /// Highest speed accepted (rpm; default from the keyphasor).
    #[arg(long, value_name = "RPM", allow_negative_numbers = true)]
    pub speed_max: Option<f64>,
    /// Revolutions per averaged vector (3..=65536).
    #[arg(long, default_value_t = 8, value_name = "N")]
    pub revolutions: u32,
    /// Each row's standard errors from its own revolutions only (no
    /// pooling over the sweep).
    #[arg(long)]
    pub no_pool: bool,
}

/// Whether `path` starts like a WAV file (`RIFF`, `RIFX` or `RF64`).
pub fn is_wav(path: &std::path::Path) -> Result<bool, CliError> {
    use std::io::Read;
    let mut f = std::fs::File::open(path).map_err(|e| {
        if e.kind() == std::io::ErrorKind::NotFound {
            CliError::new(format!("file not found: {}", path.display()))
        } else {
            CliError::new(format!("{}: {e}", path.display()))
        }
    })?;
    let mut magic = [0u8; 4];
    let n = f
        .read(&mut magic)
        .map_err(|e| CliError::new(format!("{}: {e}", path.display())))?;
    Ok(n == 4 && matches!(&magic, b"RIFF" | b"RIFX" | b"RF64"))
}

impl VectorsArgs {
    /// The configuration: the file's, then the command line's keys.
    pub fn signal_config(&self) -> Result<SignalConfig, CliError> {
        let base = match &self.config {
            Some(p) => SignalConfig::from_file(p)?,
            None => SignalConfig::default(),
        };
        let mut cli = SignalConfig {
            kp_source: self.kp.as_deref().map(Source::parse),
            edge: self.edge.unwrap_or_default(),
            kp_level: self.kp_level,
            kp_hysteresis: self.kp_hysteresis,
            full_scale_v: self.full_scale,
            sensitivity_v_per_mm: self.sensitivity,
            ..SignalConfig::default()
        };
        if let Some(list) = &self.channels {
            cli.channels = SignalConfig::parse_channels(list)?;
        }
        let merged = base.with(&cli);
        let merged = if self.edge == Some(Edge::Rising) {
            SignalConfig {
                edge: Edge::Rising,
                ..merged
            }
        } else {
            merged
        };
        merged.validate()?;
        Ok(merged)
    }
}

/// Runs `rotorid vectors`.
pub fn run(args: &VectorsArgs, io: &mut Io<'_>) -> Result<(), CliError> {
    let mut inputs: Vec<(&str, &std::path::Path)> = vec![("--signals", &args.signals)];
    if let Some(c) = &args.config {
        inputs.push(("--config", c));
    }
    super::refuse_overwriting_inputs(
        None,
        &inputs,
        &[
            ("--out", Some(&args.out)),
            ("--json", args.json.as_deref()),
            ("--plot", args.plot.as_deref()),
        ],
    )?;
    let rev_max = rotorid_core::ordertrack::MAX_REVOLUTIONS;
    if !(3..=rev_max).contains(&args.revolutions) {
        return Err(CliError::new(format!(
            "--revolutions must be in 3..={rev_max}, got {}",
            args.revolutions
        )));
    }
    let config = args.signal_config()?;
    let path = &args.signals;
    let shown = path.display().to_string();
    let rec = if is_wav(path)? {
        signals::read_wav(path, &config)
    } else {
        signals::read_csv_with(path, &config)
    }
    .map_err(|e| match e {
        signals::SignalsError::Io { source, .. }
            if source.kind() == std::io::ErrorKind::NotFound =>
        {
            CliError::new(format!("file not found: {shown}"))
        }
        e => CliError::new(format!("{shown}: {e}")),
    })?;
    let opts = ExtractOptions {
        speed_min_rpm: args.speed_min,
        speed_max_rpm: args.speed_max,
        revolutions: args.revolutions,
        hysteresis: config.kp_hysteresis,
        pool: !args.no_pool,
    };
    let bar = (io.progress && rec.len() >= 1 << 20).then(|| {
        let pb = indicatif::ProgressBar::new(rec.len() as u64);
        pb.set_style(
            indicatif::ProgressStyle::with_template("vectors {bar:40} {percent}% {eta}")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        pb
    });
    let report = |done: u64| {
        if let Some(pb) = &bar {
            pb.set_position(done);
        }
    };
    let progress: Option<&(dyn Fn(u64) + Sync)> = if bar.is_some() { Some(&report) } else { None };
    let result = signals::extract(&rec, &opts, progress);
    if let Some(pb) = &bar {
        pb.finish_and_clear();
    }
    let v = result.map_err(|e| CliError::new(format!("{shown}: {e}")))?;
    if v.rows.is_empty() {
        return Err(CliError::new(format!(
            "{shown}: no averaged vectors: {} revolutions accepted, {} rejected ({})",
            v.counts.accepted,
            v.counts.rejected(),
            causes(&v)
        )));
    }
    signals::write_vectors(&v, &shown, &args.out)
        .map_err(|e| CliError::new(format!("{}: {e}", args.out.display())))?;
    let s = summary(&v);
    write!(io.out, "{}", s.text())?;
    writeln!(io.err, "wrote {}", args.out.display())?;
    if let Some(p) = &args.json {
        let text = serde_json::to_string_pretty(&s.json())?;
        crate::io::output::write_atomic(p, (text + "\n").as_bytes())?;
        writeln!(io.err, "wrote {}", p.display())?;
    }
    if let Some(dir) = &args.plot {
        for f in crate::report::vectors::write_plots(dir, &v)? {
            writeln!(io.err, "wrote {}", f.display())?;
        }
    }
    Ok(())
}

/// `cause n, ...` of the non-zero rejection counts, or `none`.
fn causes(v: &signals::Vectors) -> String {
    let c: Vec<String> = signals::output::rejection_counts(v)
        .iter()
        .filter(|(_, n)| *n > 0)
        .map(|(k, n)| format!("{k} {n}"))
        .collect();
    if c.is_empty() {
        "none".into()
    } else {
        c.join(", ")
    }
}

/// The run's summary (stdout and `--json`).
pub struct Summary<'a> {
    v: &'a signals::Vectors,
}

/// The summary of `v`.
pub fn summary(v: &signals::Vectors) -> Summary<'_> {
    Summary { v }
}

impl Summary<'_> {
    /// The speeds of the first and last rows (rpm).
    fn speeds(&self) -> (f64, f64) {
        let rpm = crate::units::rad_s_to_rpm;
        let first = self.v.rows.first().map_or(f64::NAN, |r| rpm(r.omega));
        let last = self.v.rows.last().map_or(f64::NAN, |r| rpm(r.omega));
        (first, last)
    }

    /// The lines printed on stdout.
    pub fn text(&self) -> String {
        let v = self.v;
        let (a, b) = self.speeds();
        let rate = v
            .sweep_rate_rpm_per_s
            .map_or("unknown".to_string(), |r| format!("{r:.2} rpm/s"));
        format!(
            "rows: {} ({} channels, {} Hz, {} samples)\nspeeds: {a:.1} .. {b:.1} rpm as recorded, sweep rate {rate}\nrevolutions: {} accepted, {} rejected ({})\n",
            v.rows.len(),
            v.channels.len(),
            v.sample_rate,
            v.samples,
            v.counts.accepted,
            v.counts.rejected(),
            causes(v)
        )
    }

    /// The JSON summary.
    pub fn json(&self) -> serde_json::Value {
        let v = self.v;
        let (a, b) = self.speeds();
        let rejected: serde_json::Map<String, serde_json::Value> =
            signals::output::rejection_counts(v)
                .iter()
                .map(|(k, n)| (k.to_string(), serde_json::Value::from(*n)))
                .collect();
        let noise: Vec<serde_json::Value> = v
            .channels
            .iter()
            .zip(&v.noise)
            .map(|(c, f)| {
                serde_json::json!({
                    "channel": c.to_string(),
                    "floor_m": f.map(|f| f.floor),
                    "relative": f.map(|f| f.relative),
                })
            })
            .collect();
        serde_json::json!({
            "rows": v.rows.len(),
            "channels": v.channels.iter().map(ToString::to_string).collect::<Vec<_>>(),
            "sample_rate_hz": v.sample_rate,
            "samples": v.samples,
            "speed_first_rpm": a,
            "speed_last_rpm": b,
            "sweep_rate_rpm_per_s": v.sweep_rate_rpm_per_s,
            "revolutions": {"accepted": v.counts.accepted, "rejected": rejected},
            "noise": noise,
        })
    }
}
