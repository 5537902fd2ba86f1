//! `rotorid campbell`: damped natural frequencies against speed, whirl
//! direction, log decrement and critical speeds; optional SVG diagram like
//! the method paper's Fig. 2(b).

use std::fmt::Write as _;

use clap::Args;

use super::{load_model, CliError, Io};
use crate::fe::assembly::FeModel;
use crate::fe::campbell::{
    campbell_with, critical_speeds, CampbellDiagram, CampbellOptions, CriticalSpeed, Whirl,
};
use crate::report::plot::{line_plot_with, Marker, PlotOptions, Series, VLine};
use crate::tables::grid::uniform_rpm;
use crate::units::{rad_s_to_hz, rad_s_to_rpm, rpm_to_rad_s};

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
    /// Number of modes (lowest damped natural frequencies) per speed.
    #[arg(long, default_value_t = 8)]
    pub modes: usize,
    /// Write the diagram as SVG.
    #[arg(long, value_name = "OUT.svg")]
    pub plot: Option<std::path::PathBuf>,
}

fn whirl_letter(w: Whirl) -> char {
    match w {
        Whirl::Forward => 'F',
        Whirl::Backward => 'B',
        Whirl::Mixed => 'M',
    }
}

/// The table printed by `rotorid campbell`: one row per speed with
/// `f (Hz) whirl log-dec` per mode, then the critical speeds.
pub fn format_table(
    diagram: &CampbellDiagram,
    forward: &[CriticalSpeed],
    backward: &[CriticalSpeed],
) -> String {
    let mut s = String::new();
    let n_modes = diagram
        .points
        .iter()
        .map(|p| p.modes.len())
        .max()
        .unwrap_or(0);
    let _ = write!(s, "{:>9}", "speed_rpm");
    for i in 1..=n_modes {
        let _ = write!(s, " | {:>21}", format!("mode {i}: Hz  W logdec"));
    }
    s.push('\n');
    for p in &diagram.points {
        let _ = write!(s, "{:>9.1}", rad_s_to_rpm(p.omega));
        for m in &p.modes {
            let _ = write!(
                s,
                " | {:>10.3} {} {:>8.4}",
                rad_s_to_hz(m.frequency),
                whirl_letter(m.whirl),
                m.log_dec
            );
        }
        s.push('\n');
    }
    s.push_str("\ncritical speeds (forward modes crossing 1X):\n");
    if forward.is_empty() {
        s.push_str("  none in the speed range\n");
    }
    for c in forward {
        let _ = writeln!(
            s,
            "  {:>9.1} rpm  ({:.3} Hz)",
            rad_s_to_rpm(c.omega),
            rad_s_to_hz(c.omega)
        );
    }
    if !backward.is_empty() {
        s.push_str(
            "backward modes crossing 1X (not excited by unbalance in isotropic supports):\n",
        );
        for c in backward {
            let _ = writeln!(
                s,
                "  {:>9.1} rpm  ({:.3} Hz)",
                rad_s_to_rpm(c.omega),
                rad_s_to_hz(c.omega)
            );
        }
    }
    s
}

/// The diagram's series: for each whirl class, the k-th lowest mode of
/// that class against speed (Hz vs rpm); forward solid, backward dashed,
/// mixed as points; the 1X line; critical speeds as markers.
pub fn diagram_series(diagram: &CampbellDiagram, forward: &[CriticalSpeed]) -> Vec<Series> {
    let rpm: Vec<f64> = diagram
        .points
        .iter()
        .map(|p| rad_s_to_rpm(p.omega))
        .collect();
    let mut out = Vec::new();
    for (whirl, name, color) in [
        (Whirl::Forward, "forward", (31, 119, 180)),
        (Whirl::Backward, "backward", (214, 39, 40)),
        (Whirl::Mixed, "mixed", (120, 120, 120)),
    ] {
        let per_speed: Vec<Vec<f64>> = diagram
            .points
            .iter()
            .map(|p| {
                p.modes
                    .iter()
                    .filter(|m| m.whirl == whirl)
                    .map(|m| rad_s_to_hz(m.frequency))
                    .collect()
            })
            .collect();
        let k_max = per_speed.iter().map(Vec::len).max().unwrap_or(0);
        for k in 0..k_max {
            let y: Vec<f64> = per_speed
                .iter()
                .map(|v| v.get(k).copied().unwrap_or(f64::NAN))
                .collect();
            let label = if k == 0 {
                name.to_string()
            } else {
                String::new()
            };
            let s = match whirl {
                Whirl::Forward => Series::line(label, rpm.clone(), y),
                Whirl::Backward => Series::line(label, rpm.clone(), y).dashed(),
                Whirl::Mixed => Series::points(label, rpm.clone(), y, Marker::Circle),
            };
            out.push(s.color(color));
        }
    }
    let x1 = rpm.last().copied().unwrap_or(0.0);
    out.push(Series::line("1X", vec![0.0, x1], vec![0.0, x1 / 60.0]).color((0, 0, 0)));
    if !forward.is_empty() {
        out.push(
            Series {
                width: 6,
                ..Series::points(
                    "forward critical speeds",
                    forward.iter().map(|c| rad_s_to_rpm(c.omega)).collect(),
                    forward.iter().map(|c| rad_s_to_hz(c.omega)).collect(),
                    Marker::Triangle,
                )
            }
            .color((44, 160, 44)),
        );
    }
    out
}

/// Runs `rotorid campbell`.
pub fn run(args: &CampbellArgs, io: &mut Io<'_>) -> Result<(), CliError> {
    super::refuse_overwriting_inputs(Some(&args.model), &[], &[("--plot", args.plot.as_deref())])?;
    let file = load_model(&args.model)?;
    if !(args.rpm_max.is_finite() && args.rpm_max > 0.0) {
        return Err(CliError(format!(
            "--rpm-max must be finite and > 0, got {}",
            args.rpm_max
        )));
    }
    if args.modes == 0 {
        return Err(CliError("--modes must be at least 1".into()));
    }
    let rpm = uniform_rpm(0.0, args.rpm_max, args.rpm_step)?;
    let omegas: Vec<f64> = rpm.iter().map(|&r| rpm_to_rad_s(r)).collect();
    // Size limits before the FE model is even assembled (4 DOF per node,
    // 2 more per pedestal).
    let n_dof_est = 4 * file.model.n_nodes();
    crate::fe::campbell::check_size(n_dof_est, omegas.len())?;
    let fe = FeModel::new(&file.model)?;
    let opts = CampbellOptions {
        max_modes: args.modes,
        ..CampbellOptions::default()
    };
    let diagram = campbell_with(&fe, &omegas, &opts)?;
    let forward = critical_speeds(&diagram, Whirl::Forward);
    let backward = critical_speeds(&diagram, Whirl::Backward);
    write!(io.out, "{}", format_table(&diagram, &forward, &backward))?;
    if let Some(path) = &args.plot {
        let series = diagram_series(&diagram, &forward);
        // Frequency axis up to the highest mode shown (and the 1X line's end).
        let f_max = diagram
            .points
            .iter()
            .flat_map(|p| p.modes.iter().map(|m| rad_s_to_hz(m.frequency)))
            .fold(0.0f64, f64::max);
        let opts = PlotOptions {
            x_range: Some((0.0, args.rpm_max)),
            y_range: Some((0.0, 1.05 * f_max.max(args.rpm_max / 60.0))),
            vlines: forward
                .iter()
                .map(|c| VLine {
                    x: rad_s_to_rpm(c.omega),
                    label: String::new(),
                })
                .collect(),
            ..PlotOptions::default()
        };
        line_plot_with(
            path,
            &format!("Campbell diagram: {}", file.model.name),
            "speed (rpm)",
            "damped natural frequency (Hz)",
            &series,
            &opts,
        )?;
        writeln!(io.err, "wrote {}", path.display())?;
    }
    Ok(())
}
