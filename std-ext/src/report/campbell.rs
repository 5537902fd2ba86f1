//! The Campbell diagram report of `rotorid campbell`: the text table, the
//! JSON and CSV files and the SVG diagram, all from one [`CampbellReport`].
//!
//! Units at this edge: speeds in rpm, frequencies in Hz (`f = w / (2 pi)`),
//! logarithmic decrement `delta = -2 pi Re lambda / Im lambda` and damping
//! ratio `zeta = -Re lambda / |lambda|` dimensionless. Modes are numbered
//! from 1 in every output, in the order of [`crate::fe::campbell::track_modes`]
//! (by the speed where a mode first appears, then by frequency there).

use std::fmt::Write as _;
use std::path::Path;

use serde::Serialize;

use crate::campbell::CampbellAnalysis;
use crate::fe::campbell::{CriticalSpeed, Whirl};
use crate::report::plot::{panel_plot, Marker, Panel, PlotError, PlotOptions, Series, VLine};
use crate::units::{rad_s_to_hz, rad_s_to_rpm};

/// One tracked mode at one speed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModePoint {
    /// Damped natural frequency `Im lambda / (2 pi)` (Hz).
    pub frequency_hz: f64,
    /// Whirl direction at this speed.
    pub whirl: Whirl,
    /// Logarithmic decrement (-).
    pub log_dec: f64,
    /// Damping ratio (-).
    pub damping_ratio: f64,
}

/// A critical speed as reported.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CriticalRow {
    /// Speed (rpm); the natural frequency there is `rpm / 60` Hz.
    pub rpm: f64,
    /// Mode index (0-based here, printed from 1).
    pub mode: usize,
    /// Whirl of the mode at the critical speed.
    pub whirl: Whirl,
    /// Logarithmic decrement at the critical speed (-).
    pub log_dec: f64,
    /// Damping ratio at the critical speed (-).
    pub damping_ratio: f64,
}

impl CriticalRow {
    fn from_fe(c: &CriticalSpeed) -> Self {
        CriticalRow {
            rpm: rad_s_to_rpm(c.omega),
            mode: c.mode,
            whirl: c.whirl,
            log_dec: c.log_dec,
            damping_ratio: c.damping_ratio,
        }
    }
}

/// Everything `rotorid campbell` reports.
#[derive(Debug, Clone, PartialEq)]
pub struct CampbellReport {
    /// The model's label: the model file's stem, or the built-in name.
    pub label: String,
    /// The diagram's speeds (rpm).
    pub speeds_rpm: Vec<f64>,
    /// Per tracked mode, per speed: the mode there (`None`: not present).
    pub modes: Vec<Vec<Option<ModePoint>>>,
    /// Critical speeds where a damped natural frequency meets the speed.
    pub critical: Vec<CriticalRow>,
    /// Critical speeds where an undamped natural frequency `|lambda|`
    /// meets the speed.
    pub critical_undamped: Vec<CriticalRow>,
}

/// One-letter whirl code of the table: F, B, M.
pub fn whirl_letter(w: Whirl) -> char {
    match w {
        Whirl::Forward => 'F',
        Whirl::Backward => 'B',
        Whirl::Mixed => 'M',
    }
}

/// Whirl name in JSON and CSV: `forward`, `backward`, `mixed`.
pub fn whirl_name(w: Whirl) -> &'static str {
    match w {
        Whirl::Forward => "forward",
        Whirl::Backward => "backward",
        Whirl::Mixed => "mixed",
    }
}

/// The JSON file of `rotorid campbell --json`.
#[derive(Debug, Clone, Serialize)]
pub struct CampbellJson {
    /// Model label (file stem or built-in name).
    pub model: String,
    /// `"rpm"`.
    pub speed_unit: &'static str,
    /// `"Hz"`.
    pub frequency_unit: &'static str,
    /// Number of tracked modes (numbered 1..=n_modes).
    pub n_modes: usize,
    /// Per speed, the tracked modes present there.
    pub speeds: Vec<SpeedJson>,
    /// Damped natural frequency = speed (ROSS `wd`), by speed.
    pub critical_speeds: Vec<CriticalJson>,
    /// Undamped natural frequency `|lambda|` = speed (ROSS `wn`), by speed.
    pub critical_speeds_undamped: Vec<CriticalJson>,
}

/// One speed of the JSON file.
#[derive(Debug, Clone, Serialize)]
pub struct SpeedJson {
    /// Speed (rpm).
    pub rpm: f64,
    /// The tracked modes present at this speed.
    pub modes: Vec<ModeJson>,
}

/// One mode at one speed in the JSON file.
#[derive(Debug, Clone, Serialize)]
pub struct ModeJson {
    /// Mode number (from 1).
    pub mode: usize,
    /// Damped natural frequency (Hz).
    pub frequency_hz: f64,
    /// `forward`, `backward` or `mixed`.
    pub whirl: &'static str,
    /// Logarithmic decrement (-).
    pub log_dec: f64,
    /// Damping ratio (-).
    pub damping_ratio: f64,
}

/// One critical speed in the JSON file.
#[derive(Debug, Clone, Serialize)]
pub struct CriticalJson {
    /// Speed (rpm).
    pub rpm: f64,
    /// The crossing natural frequency, `rpm / 60` (Hz).
    pub frequency_hz: f64,
    /// Mode number (from 1).
    pub mode: usize,
    /// Whirl of the mode at the critical speed.
    pub whirl: &'static str,
    /// Logarithmic decrement there (-).
    pub log_dec: f64,
    /// Damping ratio there (-).
    pub damping_ratio: f64,
}

impl From<&CriticalRow> for CriticalJson {
    fn from(c: &CriticalRow) -> Self {
        CriticalJson {
            rpm: c.rpm,
            frequency_hz: c.rpm / 60.0,
            mode: c.mode + 1,
            whirl: whirl_name(c.whirl),
            log_dec: c.log_dec,
            damping_ratio: c.damping_ratio,
        }
    }
}

impl CampbellReport {
    /// The report of an analysis ([`crate::campbell()`]) under the model's
    /// label.
    pub fn new(label: impl Into<String>, analysis: &CampbellAnalysis) -> Self {
        let CampbellAnalysis {
            diagram,
            tracks,
            critical,
            critical_undamped,
        } = analysis;
        let modes = tracks
            .iter()
            .map(|t| {
                (0..diagram.points.len())
                    .map(|p| {
                        t.mode(diagram, p).map(|m| ModePoint {
                            frequency_hz: rad_s_to_hz(m.frequency),
                            whirl: m.whirl,
                            log_dec: m.log_dec,
                            damping_ratio: m.damping_ratio,
                        })
                    })
                    .collect()
            })
            .collect();
        CampbellReport {
            label: label.into(),
            speeds_rpm: diagram
                .points
                .iter()
                .map(|p| rad_s_to_rpm(p.omega))
                .collect(),
            modes,
            critical: critical.iter().map(CriticalRow::from_fe).collect(),
            critical_undamped: critical_undamped.iter().map(CriticalRow::from_fe).collect(),
        }
    }

    /// The undamped crossing of the same mode nearest to `c` (within 10 %).
    fn undamped_partner(&self, c: &CriticalRow) -> Option<&CriticalRow> {
        self.critical_undamped
            .iter()
            .filter(|u| u.mode == c.mode && (u.rpm - c.rpm).abs() <= 0.1 * c.rpm)
            .min_by(|a, b| (a.rpm - c.rpm).abs().total_cmp(&(b.rpm - c.rpm).abs()))
    }

    /// The printed table: one row per speed with `f (Hz) whirl log-dec` per
    /// tracked mode (blank where the mode is absent), then the critical
    /// speeds of every whirl.
    pub fn text(&self) -> String {
        let mut s = String::new();
        let _ = write!(s, "{:>9}", "speed_rpm");
        for i in 1..=self.modes.len() {
            let _ = write!(s, " | {:>21}", format!("mode {i}: Hz  W logdec"));
        }
        s.push('\n');
        for (p, rpm) in self.speeds_rpm.iter().enumerate() {
            let _ = write!(s, "{rpm:>9.1}");
            for m in &self.modes {
                match m.get(p).copied().flatten() {
                    Some(m) => {
                        let _ = write!(
                            s,
                            " | {:>10.3} {} {:>8.4}",
                            m.frequency_hz,
                            whirl_letter(m.whirl),
                            m.log_dec
                        );
                    }
                    None => {
                        let _ = write!(s, " | {:>21}", "");
                    }
                }
            }
            s.push('\n');
        }
        s.push_str(
            "\ncritical speeds (a mode's damped natural frequency equals the speed; every whirl):\n",
        );
        if self.critical.is_empty() {
            s.push_str("  none in the speed range\n");
        } else {
            let _ = writeln!(
                s,
                "  {:>9} {:>10} {:>5}  {:<8} {:>8}  {:>12}",
                "rpm", "Hz", "mode", "whirl", "log_dec", "undamped_rpm"
            );
        }
        for c in &self.critical {
            let und = self
                .undamped_partner(c)
                .map_or_else(|| "-".to_string(), |u| format!("{:.1}", u.rpm));
            let _ = writeln!(
                s,
                "  {:>9.1} {:>10.3} {:>5}  {:<8} {:>8.4}  {:>12}",
                c.rpm,
                c.rpm / 60.0,
                c.mode + 1,
                whirl_name(c.whirl),
                c.log_dec,
                und
            );
        }
        s
    }

    /// The JSON file's content.
    pub fn json(&self) -> CampbellJson {
        let speeds = self
            .speeds_rpm
            .iter()
            .enumerate()
            .map(|(p, &rpm)| SpeedJson {
                rpm,
                modes: self
                    .modes
                    .iter()
                    .enumerate()
                    .filter_map(|(k, m)| {
                        let m = m.get(p).copied().flatten()?;
                        Some(ModeJson {
                            mode: k + 1,
                            frequency_hz: m.frequency_hz,
                            whirl: whirl_name(m.whirl),
                            log_dec: m.log_dec,
                            damping_ratio: m.damping_ratio,
                        })
                    })
                    .collect(),
            })
            .collect();
        CampbellJson {
            model: self.label.clone(),
            speed_unit: "rpm",
            frequency_unit: "Hz",
            n_modes: self.modes.len(),
            speeds,
            critical_speeds: self.critical.iter().map(CriticalJson::from).collect(),
            critical_speeds_undamped: self
                .critical_undamped
                .iter()
                .map(CriticalJson::from)
                .collect(),
        }
    }

    /// The CSV file's content: one table, one row per tracked mode and
    /// speed (`kind = mode`), then one per critical speed (`kind =
    /// critical` for the damped, `critical_undamped` for the undamped
    /// crossing; there `frequency_hz = speed_rpm / 60`):
    ///
    /// ```text
    /// kind,speed_rpm,mode,frequency_hz,whirl,log_dec,damping_ratio
    /// ```
    pub fn csv(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "# rotorid campbell: model {}", self.label);
        s.push_str("kind,speed_rpm,mode,frequency_hz,whirl,log_dec,damping_ratio\n");
        for (p, rpm) in self.speeds_rpm.iter().enumerate() {
            for (k, m) in self.modes.iter().enumerate() {
                if let Some(m) = m.get(p).copied().flatten() {
                    let _ = writeln!(
                        s,
                        "mode,{rpm},{},{},{},{},{}",
                        k + 1,
                        m.frequency_hz,
                        whirl_name(m.whirl),
                        m.log_dec,
                        m.damping_ratio
                    );
                }
            }
        }
        for (kind, list) in [
            ("critical", &self.critical),
            ("critical_undamped", &self.critical_undamped),
        ] {
            for c in list {
                let _ = writeln!(
                    s,
                    "{kind},{},{},{},{},{},{}",
                    c.rpm,
                    c.mode + 1,
                    c.rpm / 60.0,
                    whirl_name(c.whirl),
                    c.log_dec,
                    c.damping_ratio
                );
            }
        }
        s
    }

    /// Writes the diagram as SVG (see [`diagram_plot`]).
    pub fn plot(&self, path: &Path, rpm_max: f64) -> Result<(), PlotError> {
        diagram_plot(self, path, rpm_max)
    }
}

/// Ten distinct colours (one per mode, repeated beyond ten).
const MODE_COLORS: [(u8, u8, u8); 10] = [
    (31, 119, 180),
    (255, 127, 14),
    (44, 160, 44),
    (214, 39, 40),
    (148, 103, 189),
    (140, 86, 75),
    (227, 119, 194),
    (127, 127, 127),
    (188, 189, 34),
    (23, 190, 207),
];

fn mode_color(k: usize) -> (u8, u8, u8) {
    MODE_COLORS[k % MODE_COLORS.len()]
}

/// Dash pattern of a whirl: forward solid, backward dashed, mixed dotted.
fn dash(w: Whirl) -> Option<(u32, u32)> {
    match w {
        Whirl::Forward => None,
        Whirl::Backward => Some((9, 5)),
        Whirl::Mixed => Some((2, 4)),
    }
}

/// A line in the whirl's style (legend label `label`).
fn whirl_line(label: String, xy: Vec<(f64, f64)>, w: Whirl, color: (u8, u8, u8)) -> Series {
    let (x, y) = xy.into_iter().unzip();
    let s = Series::line(label, x, y).color(color);
    match dash(w) {
        None => s,
        Some((on, off)) => s.dash_pattern(on, off),
    }
}

/// The runs of consecutive present points of one mode with the same
/// whirl; each run also takes the next run's first point, so the curve is
/// continuous where the whirl changes.
fn whirl_runs(
    rpm: &[f64],
    pts: &[Option<ModePoint>],
    value: impl Fn(&ModePoint) -> f64,
) -> Vec<(Whirl, Vec<(f64, f64)>)> {
    let mut out: Vec<(Whirl, Vec<(f64, f64)>)> = Vec::new();
    let mut open = false;
    for (x, p) in rpm.iter().zip(pts) {
        let Some(p) = p else {
            open = false;
            continue;
        };
        let xy = (*x, value(p));
        if !xy.1.is_finite() {
            open = false;
            continue;
        }
        match out.last_mut() {
            Some((w, run)) if open && *w == p.whirl => run.push(xy),
            Some((_, run)) if open => {
                run.push(xy);
                out.push((p.whirl, vec![xy]));
            }
            _ => out.push((p.whirl, vec![xy])),
        }
        open = true;
    }
    out
}

/// The curves of every mode (`value` of each point), one series per run of
/// one whirl in the mode's colour and the whirl's style; a lone point as a
/// dot. No legend labels: [`legend_series`] gives those.
fn mode_curves(report: &CampbellReport, value: impl Fn(&ModePoint) -> f64) -> Vec<Series> {
    let mut out = Vec::new();
    for (k, m) in report.modes.iter().enumerate() {
        for (w, run) in whirl_runs(&report.speeds_rpm, m, &value) {
            if run.len() < 2 {
                let (x, y) = run.into_iter().unzip();
                out.push(
                    Series::points("", x, y, Marker::Circle)
                        .color(mode_color(k))
                        .width(1),
                );
            } else {
                out.push(whirl_line(String::new(), run, w, mode_color(k)).width(2));
            }
        }
    }
    out
}

/// The legend, as series without data (drawn by the plot's legend only):
/// one entry per mode (colour, with the whirls it takes), the whirl line
/// styles; then the 1X line up to `rpm_max` and the heading of the
/// critical speeds (the entries are their dots).
fn legend_series(report: &CampbellReport, rpm_max: f64) -> Vec<Series> {
    // A series with neither line nor marker is a heading of the legend.
    let heading = |text: &str| Series {
        line: false,
        ..Series::line(text, vec![], vec![])
    };
    let mut out = vec![heading("modes")];
    for (k, m) in report.modes.iter().enumerate() {
        let mut whirls: Vec<Whirl> = Vec::new();
        for p in m.iter().flatten() {
            if !whirls.contains(&p.whirl) {
                whirls.push(p.whirl);
            }
        }
        let code: String = whirls.iter().map(|w| whirl_letter(*w)).collect();
        out.push(
            Series::line(format!("mode {} ({code})", k + 1), vec![], vec![]).color(mode_color(k)),
        );
    }
    out.push(heading("whirl"));
    for w in [Whirl::Forward, Whirl::Backward, Whirl::Mixed] {
        let label = format!("{} ({})", whirl_name(w), whirl_letter(w));
        out.push(whirl_line(label, vec![], w, (60, 60, 60)));
    }
    out.push(
        Series::line("1X (speed)", vec![0.0, rpm_max], vec![0.0, rpm_max / 60.0])
            .color((0, 0, 0))
            .width(1),
    );
    out.push(heading("critical speeds"));
    out.push(heading("(damped freq. = speed)"));
    if report.critical.is_empty() {
        out.push(heading("none in range"));
    }
    out
}

/// The Campbell diagram as SVG: top panel damped natural frequency (Hz)
/// against speed (rpm), one colour per tracked mode, line style per whirl
/// (forward solid, backward dashed, mixed dotted), the 1X line and the
/// critical speeds (damped crossings, every whirl) as circles on it in the
/// mode's colour, with a dashed vertical line; bottom panel the log
/// decrement of each mode. Title `Campbell diagram: LABEL`; the legend
/// (modes, whirl styles, the critical speeds in rpm) sits right of the
/// panels, outside the data ([`panel_plot`]).
pub fn diagram_plot(report: &CampbellReport, path: &Path, rpm_max: f64) -> Result<(), PlotError> {
    if !(rpm_max.is_finite() && rpm_max > 0.0) {
        return Err(PlotError::Data {
            path: path.display().to_string(),
            reason: format!("speed range up to {rpm_max} rpm"),
        });
    }
    let vlines: Vec<VLine> = report
        .critical
        .iter()
        .map(|c| VLine {
            x: c.rpm,
            label: String::new(),
        })
        .collect();

    // Top: frequency.
    let f_max = report
        .modes
        .iter()
        .flatten()
        .flatten()
        .map(|m| m.frequency_hz)
        .filter(|f| f.is_finite())
        .fold(rpm_max / 60.0, f64::max);
    let mut top = legend_series(report, rpm_max);
    top.extend(mode_curves(report, |p| p.frequency_hz));
    // The critical speeds: each a dot in its mode's colour, ringed in black,
    // with its legend entry.
    for c in &report.critical {
        let label = format!(
            "{:.0} rpm  mode {} {}",
            c.rpm,
            c.mode + 1,
            whirl_letter(c.whirl)
        );
        let (x, y) = (vec![c.rpm], vec![c.rpm / 60.0]);
        top.push(
            Series::points(label, x.clone(), y.clone(), Marker::Circle)
                .color(mode_color(c.mode))
                .width(5),
        );
        top.push(
            Series::points("", x, y, Marker::Ring)
                .color((0, 0, 0))
                .width(4),
        );
    }
    let top_opts = PlotOptions {
        x_range: Some((0.0, rpm_max)),
        y_range: Some((0.0, 1.05 * f_max)),
        vlines: vlines.clone(),
        panel_weight: 2,
        ..PlotOptions::default()
    };

    // Bottom: log decrement.
    let decs: Vec<f64> = report
        .modes
        .iter()
        .flatten()
        .flatten()
        .map(|m| m.log_dec)
        .filter(|d| d.is_finite())
        .collect();
    let d_lo = decs.iter().copied().fold(0.0, f64::min);
    let d_hi = decs.iter().copied().fold(0.0, f64::max);
    // Undamped rotors give log decrements of rounding size (1e-12): a span
    // of at least 0.01 keeps them on a readable zero line.
    let pad = (0.05 * (d_hi - d_lo)).max(0.005);
    let (d_lo, d_hi) = (d_lo - if d_lo < 0.0 { pad } else { 0.0 }, d_hi + pad);
    let bottom = mode_curves(report, |p| p.log_dec);
    let bottom_opts = PlotOptions {
        y_range: Some((d_lo, d_hi)),
        vlines,
        ..PlotOptions::default()
    };
    panel_plot(
        path,
        &format!("Campbell diagram: {}", report.label),
        "speed (rpm)",
        &[
            Panel {
                y_label: "damped natural frequency (Hz)",
                series: &top,
                opts: &top_opts,
            },
            Panel {
                y_label: "log decrement",
                series: &bottom,
                opts: &bottom_opts,
            },
        ],
        (1150, 860),
    )
}

/// Most modes [`mode_shape_plot`] draws (more curves are not readable).
pub const MAX_SHAPE_MODES: usize = 6;

/// The mode shapes `modes` (the shaft DOFs of [`crate::fe::campbell::Mode::shape`], as
/// [`crate::fe::campbell::diagram_with`] returns them at one speed) of
/// `model` at `rpm`, as SVG: the displacement along the shaft (axial
/// position x in m from the left end) in y (top panel) and z (bottom
/// panel). Each shape is scaled so that its largest translation
/// `max_n max(|Y_n|, |Z_n|)` is 1 and turned so that this component is
/// real and positive; the motion `Re{Y exp(j w t)}` is drawn at `t = 0`
/// (`Re Y`, solid) and a quarter period later (`-Im Y`, dashed), which
/// together fix each node's orbit (a forward circular mode shows in y at
/// `t = 0` and in z a quarter period later). Grey vertical lines mark the
/// bearings. At most [`MAX_SHAPE_MODES`] modes.
pub fn mode_shape_plot(
    path: &Path,
    label: &str,
    model: &crate::model::RotorModel,
    modes: &[crate::fe::campbell::Mode],
    rpm: f64,
) -> Result<(), PlotError> {
    let data_err = |reason: String| PlotError::Data {
        path: path.display().to_string(),
        reason,
    };
    if modes.is_empty() || modes.len() > MAX_SHAPE_MODES {
        return Err(data_err(format!(
            "{} modes to draw (1..={MAX_SHAPE_MODES})",
            modes.len()
        )));
    }
    let mut x = vec![0.0];
    for e in &model.shaft {
        x.push(x[x.len() - 1] + e.length);
    }
    let n_nodes = x.len();
    let mut top = Vec::new();
    let mut bottom = Vec::new();
    for (k, m) in modes.iter().enumerate() {
        if m.shape.len() < 4 * n_nodes {
            return Err(data_err(format!(
                "mode {} has {} shaft DOFs, the model {}",
                k + 1,
                m.shape.len(),
                4 * n_nodes
            )));
        }
        // The largest translation, made real and positive.
        let peak = (0..n_nodes)
            .flat_map(|n| [m.shape[4 * n], m.shape[4 * n + 1]])
            .max_by(|a, b| a.norm().total_cmp(&b.norm()))
            .unwrap_or_default();
        if peak.norm() == 0.0 {
            return Err(data_err(format!("mode {} has no translation", k + 1)));
        }
        let scale = peak.conj() / (peak.norm() * peak.norm());
        let at = |dir: usize| -> Vec<num_complex::Complex64> {
            (0..n_nodes).map(|n| m.shape[4 * n + dir] * scale).collect()
        };
        let (y, z) = (at(0), at(1));
        let color = mode_color(k);
        let name = format!(
            "{:.2} Hz, {}, log dec {:.3}",
            rad_s_to_hz(m.frequency),
            whirl_name(m.whirl),
            m.log_dec
        );
        for (panel, v) in [(&mut top, &y), (&mut bottom, &z)] {
            panel.push(
                Series::line(
                    format!("{name}, t = 0"),
                    x.clone(),
                    v.iter().map(|c| c.re).collect(),
                )
                .color(color)
                .width(2),
            );
            panel.push(
                Series::line(
                    format!("{name}, t = T/4"),
                    x.clone(),
                    v.iter().map(|c| -c.im).collect(),
                )
                .color(color)
                .dash_pattern(7, 4),
            );
        }
    }
    let bearings: Vec<VLine> = model
        .bearings
        .iter()
        .map(|b| VLine {
            x: x[b.node],
            label: "bearings".to_string(),
        })
        .collect();
    let range = Some((-1.1, 1.1));
    let top_opts = PlotOptions {
        y_range: range,
        vlines: bearings.clone(),
        ..PlotOptions::default()
    };
    let bottom_opts = PlotOptions {
        y_range: range,
        vlines: bearings
            .into_iter()
            .map(|v| VLine {
                label: String::new(),
                ..v
            })
            .collect(),
        ..PlotOptions::default()
    };
    // Each mode's series are in both panels: the legend lists the top's.
    let bottom: Vec<Series> = bottom
        .into_iter()
        .map(|s| Series {
            label: String::new(),
            ..s
        })
        .collect();
    panel_plot(
        path,
        &format!("Mode shapes: {label} at {rpm} rpm (largest displacement 1)"),
        "axial position x (m)",
        &[
            Panel {
                y_label: "y (-)",
                series: &top,
                opts: &top_opts,
            },
            Panel {
                y_label: "z (-)",
                series: &bottom,
                opts: &bottom_opts,
            },
        ],
        (1150, 800),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pt(f: f64, w: Whirl) -> Option<ModePoint> {
        Some(ModePoint {
            frequency_hz: f,
            whirl: w,
            log_dec: 0.1,
            damping_ratio: 0.016,
        })
    }

    #[test]
    fn whirl_runs_join_at_changes_and_break_at_gaps() {
        let rpm = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0];
        let pts = [
            pt(10.0, Whirl::Mixed),
            pt(11.0, Whirl::Backward),
            pt(12.0, Whirl::Backward),
            None,
            pt(14.0, Whirl::Forward),
            pt(15.0, Whirl::Forward),
        ];
        let runs = whirl_runs(&rpm, &pts, |p| p.frequency_hz);
        assert_eq!(runs.len(), 3);
        assert_eq!(runs[0], (Whirl::Mixed, vec![(0.0, 10.0), (1.0, 11.0)]));
        assert_eq!(runs[1], (Whirl::Backward, vec![(1.0, 11.0), (2.0, 12.0)]));
        assert_eq!(runs[2], (Whirl::Forward, vec![(4.0, 14.0), (5.0, 15.0)]));
    }
}
