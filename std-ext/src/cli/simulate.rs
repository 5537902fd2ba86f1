//! `rotorid simulate`: a measurement CSV from a model (see the README,
//! "Simulator").

use clap::{Args, ValueEnum};

use super::{load_model_arg, CliError, Io, RpmGridArgs};
use crate::io::measurement::{write_csv_with_node_probes, CsvLayout};
use crate::model::extension::{Channel, Effects, ProbeGain, Runout, SpeedLaw, SpeedScaling};
use crate::model::{BowPoint, Pedestal, Unbalance};
use crate::simulate::SimOptions;

/// Column layout of the written CSV.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum LayoutArg {
    /// `bK_y_re, bK_y_im, ...`.
    Complex,
    /// `bK_y_amp, bK_y_phase_deg, ...`.
    AmpPhase,
}

/// Stiffness-versus-speed law of `--bearing-speed-law`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum SpeedLawArg {
    /// `K (rpm / rpm_ref)^2` (the paper's Eq. 49 with rpm_ref = 15000).
    Quadratic,
    /// `K rpm / rpm_ref`.
    Linear,
}

/// Three numbers `A:B:C` of an effect flag.
#[derive(Debug, Clone, PartialEq)]
pub struct Triple<T> {
    /// First field.
    pub first: T,
    /// Second field.
    pub amplitude: f64,
    /// Third field (deg).
    pub phase_deg: f64,
}

fn parse_triple<T: std::str::FromStr>(s: &str, what: &str) -> Result<Triple<T>, String> {
    let parts: Vec<&str> = s.split(':').collect();
    let bad = || format!("expected {what}, got `{s}`");
    if parts.len() != 3 {
        return Err(bad());
    }
    let first = parts[0].trim().parse::<T>().map_err(|_| bad())?;
    let amplitude: f64 = parts[1].trim().parse().map_err(|_| bad())?;
    let phase_deg: f64 = parts[2].trim().parse().map_err(|_| bad())?;
    if !(amplitude.is_finite() && amplitude >= 0.0 && phase_deg.is_finite()) {
        return Err(format!(
            "{}: amplitude must be finite and >= 0, phase finite",
            bad()
        ));
    }
    Ok(Triple {
        first,
        amplitude,
        phase_deg,
    })
}

fn parse_node_triple(s: &str) -> Result<Triple<usize>, String> {
    parse_triple::<usize>(s, "NODE:AMOUNT:PHASE_DEG (node from 1)")
}

/// A `--runout` value.
#[derive(Debug, Clone, PartialEq)]
pub enum RunoutSpec {
    /// `CHANNEL:AMPLITUDE_M:PHASE_DEG`.
    Channel(Triple<String>),
    /// `AMPLITUDE_M` on every bearing channel, phases from the seed.
    Every(f64),
}

fn parse_runout(s: &str) -> Result<RunoutSpec, String> {
    if !s.contains(':') {
        return match s.trim().parse::<f64>() {
            Ok(a) if a.is_finite() && a >= 0.0 => Ok(RunoutSpec::Every(a)),
            _ => Err(format!(
                "expected CHANNEL:AMPLITUDE_M:PHASE_DEG (e.g. b1_y:2e-6:30) or an amplitude in metres >= 0, got `{s}`"
            )),
        };
    }
    parse_triple::<String>(s, "CHANNEL:AMPLITUDE_M:PHASE_DEG (e.g. b1_y:2e-6:30)")
        .map(RunoutSpec::Channel)
}

fn parse_probe_gain(s: &str) -> Result<(String, f64), String> {
    let bad = || format!("expected CHANNEL:FACTOR with a factor > 0 (e.g. b2_z:1.1), got `{s}`");
    let (ch, f) = s.split_once(':').ok_or_else(bad)?;
    match f.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok((ch.trim().to_string(), v)),
        _ => Err(bad()),
    }
}

/// Arguments of `rotorid simulate`. The effect flags add to (or, for the
/// single-valued ones, override) the model file's `[simulate]` section.
#[derive(Debug, Clone, PartialEq, Args)]
pub struct SimulateArgs {
    /// Model: `paper` or a model file (rotorid or ROSS TOML).
    #[arg(long, value_name = "MODEL")]
    pub model: String,
    /// Output CSV.
    #[arg(long, value_name = "FILE.csv")]
    pub out: std::path::PathBuf,
    /// Speed grid.
    #[command(flatten)]
    pub grid: RpmGridArgs,
    /// Relative noise level s: each complex sample gets s |q| eps, eps
    /// standard complex Gaussian (0 = noise-free).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub noise: f64,
    /// Seed of the noise generator (ChaCha8).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// The probes' noise floor F (m): each complex sample also gets F eps,
    /// eps standard complex Gaussian independent of the relative part
    /// (SPEC section 7: E|e|^2 = F^2 + s^2 |q|^2).
    #[arg(
        long,
        default_value_t = 0.0,
        value_name = "M",
        allow_negative_numbers = true
    )]
    pub noise_floor: f64,
    /// Spoil K samples (speed, channel) drawn from the seed: each is
    /// multiplied by 8 (a glitch of the monitoring system).
    #[arg(long, default_value_t = 0, value_name = "K")]
    pub glitches: usize,
    /// Scale the model's unbalance (every plane's m e) by this factor.
    #[arg(
        long,
        value_name = "FACTOR",
        allow_negative_numbers = true,
        conflicts_with = "balance_grade"
    )]
    pub unbalance_scale: Option<f64>,
    /// Scale the model's unbalance to balance grade G (mm/s, ISO 21940-11)
    /// at --rpm-max: total m e = G / Omega_max x rotor mass, the planes'
    /// shares and phases kept (e.g. 6.3 or 2.5).
    #[arg(long, value_name = "G_MM_S", allow_negative_numbers = true)]
    pub balance_grade: Option<f64>,
    /// Column layout of the CSV.
    #[arg(long, value_enum, default_value_t = LayoutArg::Complex)]
    pub layout: LayoutArg,
    /// Shaft modulus scale: E and G of every element times this factor.
    #[arg(long, value_name = "FACTOR", allow_negative_numbers = true)]
    pub e_scale: Option<f64>,
    /// Speed-dependent bearing stiffness: every bearing's stiffness times
    /// (rpm/rpm_ref)^2 (quadratic) or rpm/rpm_ref (linear).
    #[arg(long, value_enum)]
    pub bearing_speed_law: Option<SpeedLawArg>,
    /// Reference speed of --bearing-speed-law (rpm).
    #[arg(
        long,
        default_value_t = 15000.0,
        value_name = "RPM",
        allow_negative_numbers = true
    )]
    pub rpm_ref: f64,
    /// Pedestal mass (kg) under every bearing without one (needs
    /// --pedestal-k and --pedestal-c).
    #[arg(long, value_name = "KG", requires_all = ["pedestal_k", "pedestal_c"], allow_negative_numbers = true)]
    pub pedestal_mass: Option<f64>,
    /// Pedestal stiffness to ground, y and z (N/m).
    #[arg(
        long,
        value_name = "N/M",
        requires = "pedestal_mass",
        allow_negative_numbers = true
    )]
    pub pedestal_k: Option<f64>,
    /// Pedestal damping to ground, y and z (N s/m).
    #[arg(
        long,
        value_name = "NS/M",
        requires = "pedestal_mass",
        allow_negative_numbers = true
    )]
    pub pedestal_c: Option<f64>,
    /// Shaft bow point NODE:AMPLITUDE_M:PHASE_DEG (repeatable).
    #[arg(long, value_name = "NODE:AMP:PHASE", value_parser = parse_node_triple)]
    pub bow: Vec<Triple<usize>>,
    /// Probe runout CHANNEL:AMPLITUDE_M:PHASE_DEG, e.g. b1_y:2e-6:30, or
    /// AMPLITUDE_M alone: that runout on every bearing channel, phases
    /// drawn from the seed (repeatable).
    #[arg(long, value_name = "CH:AMP:PHASE|AMP", value_parser = parse_runout)]
    pub runout: Vec<RunoutSpec>,
    /// Probe scale factor off: CHANNEL:FACTOR, e.g. b2_z:1.1 (that probe
    /// reads 10 % high; repeatable).
    #[arg(long, value_name = "CH:FACTOR", value_parser = parse_probe_gain)]
    pub probe_gain: Vec<(String, f64)>,
    /// Extra unbalance NODE:ME_KGM:PHASE_DEG (repeatable).
    #[arg(long, value_name = "NODE:ME:PHASE", value_parser = parse_node_triple)]
    pub extra_unbalance: Vec<Triple<usize>>,
    /// Probes at these shaft nodes too (numbered from 1, comma-separated,
    /// e.g. 3,7): columns nN_y_re,nN_y_im,nN_z_re,nN_z_im after the
    /// bearing columns (the shaft's absolute displacement, m).
    #[arg(long, value_name = "N,N,...", value_delimiter = ',')]
    pub nodes: Vec<usize>,
    /// Write the Bode plot (amplitude and phase against speed per channel)
    /// and the polar plot of the bearing probes' phasors (SVG) into this
    /// folder.
    #[arg(long, value_name = "DIR")]
    pub plot: Option<std::path::PathBuf>,
}

fn node0(node: usize, n_nodes: usize, flag: &str) -> Result<usize, CliError> {
    if node == 0 || node > n_nodes {
        Err(CliError(format!(
            "{flag}: node {node} is not on the shaft (nodes 1..={n_nodes})"
        )))
    } else {
        Ok(node - 1)
    }
}

impl SimulateArgs {
    /// The effects asked for on the command line, for a model with
    /// `n_nodes` nodes and `n_bearings` bearings.
    pub fn effects(&self, n_nodes: usize, n_bearings: usize) -> Result<Effects, CliError> {
        let mut e = Effects::default();
        if let Some(f) = self.e_scale {
            if !(f.is_finite() && f > 0.0) {
                return Err(CliError(format!(
                    "--e-scale must be finite and > 0, got {f}"
                )));
            }
            e.e_scale = f;
        }
        if let Some(law) = self.bearing_speed_law {
            if !(self.rpm_ref.is_finite() && self.rpm_ref > 0.0) {
                return Err(CliError(format!(
                    "--rpm-ref must be finite and > 0, got {}",
                    self.rpm_ref
                )));
            }
            e.bearing_speed_law = Some(SpeedScaling {
                rpm_ref: self.rpm_ref,
                law: match law {
                    SpeedLawArg::Quadratic => SpeedLaw::Quadratic,
                    SpeedLawArg::Linear => SpeedLaw::Linear,
                },
            });
        }
        if let (Some(m), Some(k), Some(c)) = (self.pedestal_mass, self.pedestal_k, self.pedestal_c)
        {
            if !(m.is_finite() && m > 0.0 && k.is_finite() && k > 0.0 && c.is_finite() && c >= 0.0)
            {
                return Err(CliError(
                    "--pedestal-mass and --pedestal-k must be finite and > 0, --pedestal-c finite and >= 0"
                        .into(),
                ));
            }
            e.pedestal = Some(Pedestal {
                mass: [m, m],
                k: [k, k],
                c: [c, c],
            });
        }
        for b in &self.bow {
            e.bow.push(BowPoint {
                node: node0(b.first, n_nodes, "--bow")?,
                amplitude: b.amplitude,
                phase: b.phase_deg.to_radians(),
            });
        }
        for r in &self.runout {
            match r {
                RunoutSpec::Channel(r) => {
                    let channel = Channel::parse(&r.first, n_bearings)
                        .map_err(|m| CliError(format!("--runout: {m}")))?;
                    e.runout.push(Runout {
                        channel,
                        amplitude: r.amplitude,
                        phase: r.phase_deg.to_radians(),
                    });
                }
                RunoutSpec::Every(a) => e
                    .runout
                    .extend(crate::simulate::random_runout(n_bearings, *a, self.seed)),
            }
        }
        for (ch, factor) in &self.probe_gain {
            let channel = Channel::parse(ch, n_bearings)
                .map_err(|m| CliError(format!("--probe-gain: {m}")))?;
            e.probe_gain.push(ProbeGain {
                channel,
                factor: *factor,
            });
        }
        for u in &self.extra_unbalance {
            e.extra_unbalance.push(Unbalance {
                node: node0(u.first, n_nodes, "--extra-unbalance")?,
                me: u.amplitude,
                phase: u.phase_deg.to_radians(),
            });
        }
        Ok(e)
    }
}

/// Runs `rotorid simulate`.
pub fn run(args: &SimulateArgs, io: &mut Io<'_>) -> Result<(), CliError> {
    super::refuse_overwriting_inputs(
        Some(&args.model),
        &[],
        &[("--out", Some(&args.out)), ("--plot", args.plot.as_deref())],
    )?;
    let file = load_model_arg(&args.model)?;
    let speeds_rpm = args.grid.speeds_rpm()?;
    if !(args.noise.is_finite() && args.noise >= 0.0) {
        return Err(CliError(format!(
            "--noise must be finite and >= 0, got {}",
            args.noise
        )));
    }
    if !(args.noise_floor.is_finite() && args.noise_floor >= 0.0) {
        return Err(CliError(format!(
            "--noise-floor must be finite and >= 0 (metres), got {}",
            args.noise_floor
        )));
    }
    let mut file = file;
    if let Some(g) = args.unbalance_scale {
        if !(g.is_finite() && g >= 0.0) {
            return Err(CliError(format!(
                "--unbalance-scale must be finite and >= 0, got {g}"
            )));
        }
        for u in &mut file.model.unbalance {
            u.me *= g;
        }
    }
    if let Some(g) = args.balance_grade {
        let top = speeds_rpm.iter().copied().fold(0.0, f64::max);
        if !(g.is_finite() && g > 0.0 && top > 0.0) {
            return Err(CliError(format!(
                "--balance-grade must be finite and > 0 mm/s with a speed above 0, got {g}"
            )));
        }
        file.model =
            crate::simulate::at_balance_grade(&file.model, g, crate::units::rpm_to_rad_s(top))
                .ok_or_else(|| {
                    CliError(format!(
                        "--balance-grade: model {} has no unbalance to scale",
                        args.model
                    ))
                })?;
    }
    let flags = args.effects(file.model.n_nodes(), file.model.bearings.len())?;
    let mut effects = file.effects.clone().merged_with(&flags);
    if let Some(f) = args.e_scale {
        // An explicit flag wins, also when it is 1 (merging treats 1 as unset).
        effects.e_scale = f;
    }
    let opts = SimOptions {
        speeds_rpm,
        noise: args.noise,
        seed: args.seed,
        effects,
    };
    let n_nodes = file.model.n_nodes();
    let mut nodes = Vec::with_capacity(args.nodes.len());
    for &n in &args.nodes {
        let n = node0(n, n_nodes, "--nodes")?;
        if nodes.contains(&n) {
            return Err(CliError::new(format!(
                "--nodes: node {} given twice",
                n + 1
            )));
        }
        nodes.push(n);
    }
    let (m, node_q) = crate::simulate::simulate_at_nodes(&file.model, &opts, &nodes).map_err(|e| match e {
        crate::simulate::SimulateError::NoExcitation => CliError::new(format!(
            "model {}: no unbalance, bow or runout, so every response would be zero; add unbalance with --extra-unbalance NODE:ME_KGM:PHASE_DEG (node from 1, e.g. --extra-unbalance {}:1e-4:0)",
            args.model,
            file.model.planes.first().map_or(1, |n| n + 1)
        )),
        other => CliError::from(other),
    })?;
    let (mut m, mut node_q) = (m, node_q);
    crate::simulate::add_floor_noise(&mut m, args.noise_floor, args.seed)?;
    crate::simulate::add_floor_noise_nodes(&mut node_q, args.noise_floor, args.seed)?;
    let glitched = crate::simulate::add_glitches(&mut m, args.glitches, args.seed)?;
    if args.noise_floor > 0.0 {
        m.comments.push(format!(
            "noise floor: {:e} m (complex Gaussian, every channel)",
            args.noise_floor
        ));
    }
    for (n, c) in &glitched {
        m.comments.push(format!(
            "glitch: sample {} ({} rpm), channel {} x{}",
            n + 1,
            crate::units::rad_s_to_rpm(m.samples[*n].omega),
            crate::io::measurement::default_channel_names(m.n_bearings)
                .get(*c)
                .cloned()
                .unwrap_or_default(),
            crate::simulate::GLITCH_FACTOR
        ));
    }
    let layout = match args.layout {
        LayoutArg::Complex => CsvLayout::Complex,
        LayoutArg::AmpPhase => CsvLayout::AmplitudePhase,
    };
    if file.has_probes() {
        // The bearing channels as the declared probes read them (noise and
        // runout were added to y, z).
        let mut readings = m.clone();
        crate::io::measurement::yz_to_probes(&mut readings, &file.probes);
        for (b, p) in file.probes.iter().enumerate() {
            if let Some(p) = p {
                readings.comments.push(format!(
                    "bearing {}: probes {} at {} deg, {} at {} deg from +y toward +z (reading cos(theta) y + sin(theta) z)",
                    b + 1,
                    p.names[0],
                    p.angles[0].to_degrees(),
                    p.names[1],
                    p.angles[1].to_degrees()
                ));
            }
        }
        let names = crate::io::measurement::model_channel_names(&file.probes);
        crate::io::measurement::write_csv_channels(
            &readings,
            &args.out,
            layout,
            Some(&names),
            &nodes,
            &node_q,
        )?;
    } else {
        write_csv_with_node_probes(&m, &args.out, layout, &nodes, &node_q)?;
    }
    writeln!(
        io.err,
        "wrote {} speeds x {} channels to {}",
        m.samples.len(),
        2 * m.n_bearings + 2 * nodes.len(),
        args.out.display()
    )?;
    if let Some(dir) = &args.plot {
        for f in crate::report::simulate::write_plots(dir, &m, &nodes, &node_q)? {
            writeln!(io.err, "wrote {}", f.display())?;
        }
    }
    Ok(())
}
