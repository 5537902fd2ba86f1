//! Pictures of a simulated (or measured) sweep, `rotorid simulate --plot
//! DIR`: a Bode plot (1X amplitude and phase against speed, one curve per
//! probe channel, `simulate_bode.svg`) and a polar plot (the bearing probes'
//! 1X phasors, real against imaginary part, through the speed range, a few
//! speeds marked, `simulate_polar.svg`).
//!
//! Styles: one colour per channel; `y` channels solid, `z` channels dashed
//! (a dashed curve over a solid one leaves both visible where they meet).
//! Amplitudes and phasors in micrometres, phases `arg q` in degrees in
//! (-180, 180], the line broken where the phase wraps.

use std::path::{Path, PathBuf};

use num_complex::Complex64;

use crate::io::measurement::Measurements;
use crate::model::extension::Channel;
use crate::report::identify::ReportError;
use crate::report::plot::{
    line_plot_with, panel_plot, Annotation, Panel, PlotError, PlotOptions, Series, PALETTE,
};
use crate::units::rad_s_to_rpm;

/// Metres to micrometres.
const UM: f64 = 1e6;

/// One probe channel of a sweep: its name and its phasor (m) per sample.
#[derive(Debug, Clone, PartialEq)]
pub struct ChannelData {
    /// Channel name as in the CSV header (`b1_y`, `n7_z`, ...).
    pub name: String,
    /// Phasor per sample (m), in sweep order.
    pub q: Vec<Complex64>,
}

/// The channels of `m` (`b1_y, b1_z, b2_y, ...`) followed by node probes at
/// the shaft nodes `nodes` (0-based; named from 1) with phasors `node_q`
/// (per sample, `y, z` per node, as
/// [`crate::simulate::simulate_at_nodes`] returns them; empty for none).
pub fn channels(m: &Measurements, nodes: &[usize], node_q: &[Vec<Complex64>]) -> Vec<ChannelData> {
    let mut out = Vec::new();
    for ch in 0..2 * m.n_bearings {
        out.push(ChannelData {
            name: Channel::of_index(ch).to_string(),
            q: m.samples
                .iter()
                .map(|s| {
                    s.q.get(ch)
                        .copied()
                        .unwrap_or(Complex64::new(f64::NAN, 0.0))
                })
                .collect(),
        });
    }
    for (k, n) in nodes.iter().enumerate() {
        for (d, dir) in ["y", "z"].iter().enumerate() {
            out.push(ChannelData {
                name: format!("n{}_{dir}", n + 1),
                q: node_q
                    .iter()
                    .map(|q| {
                        q.get(2 * k + d)
                            .copied()
                            .unwrap_or(Complex64::new(f64::NAN, 0.0))
                    })
                    .collect(),
            });
        }
    }
    out
}

/// Phases `arg q` (deg, in (-180, 180]) against `rpm`, with a break (a
/// point at the middle speed with no value) wherever the phase jumps by
/// more than 180 degrees between samples (where it wraps), so that the line
/// is not drawn across the plot. A zero or non-finite phasor has no phase.
pub fn phase_with_breaks(rpm: &[f64], q: &[Complex64]) -> (Vec<f64>, Vec<f64>) {
    let mut x = Vec::with_capacity(rpm.len());
    let mut y = Vec::with_capacity(rpm.len());
    let mut prev: Option<(f64, f64)> = None;
    for (&r, z) in rpm.iter().zip(q) {
        let p = if z.re.is_finite() && z.im.is_finite() && z.norm() > 0.0 {
            z.arg().to_degrees()
        } else {
            f64::NAN
        };
        if let Some((r0, p0)) = prev {
            if (p - p0).abs() > 180.0 {
                x.push(0.5 * (r0 + r));
                y.push(f64::NAN);
            }
        }
        x.push(r);
        y.push(p);
        prev = p.is_finite().then_some((r, p));
    }
    (x, y)
}

/// The style of channel `i` of `n` (0-based over [`channels`]): its own
/// colour; `y` solid, the first drawn widest (4 px down to 2 px) so that a
/// later curve over an earlier one leaves a rim of it visible; `z` dashed,
/// each with its own dash pattern.
fn styled(s: Series, i: usize, n: usize, name: &str) -> Series {
    const DASHES: [(u32, u32); 4] = [(8, 5), (4, 3), (12, 4), (2, 3)];
    let s = s.color(PALETTE[i % PALETTE.len()]);
    if name.ends_with("_z") {
        let (on, off) = DASHES[(i / 2) % DASHES.len()];
        s.dash_pattern(on, off)
    } else {
        let spread = (n.saturating_sub(1)).max(1) as f64;
        s.width(2 + (2.0 * (n.saturating_sub(1 + i)) as f64 / spread).round() as u32)
    }
}

/// The Bode plot's series: amplitude (um) and phase (deg, broken where
/// it wraps: [`phase_with_breaks`]) against speed (rpm), one of each per
/// channel, in channel order.
pub fn bode_series(m: &Measurements, chans: &[ChannelData]) -> (Vec<Series>, Vec<Series>) {
    let rpm: Vec<f64> = m.samples.iter().map(|s| rad_s_to_rpm(s.omega)).collect();
    let mut amp = Vec::new();
    let mut phase = Vec::new();
    let n = chans.len();
    for (i, c) in chans.iter().enumerate() {
        let a: Vec<f64> = c.q.iter().map(|z| z.norm() * UM).collect();
        amp.push(styled(
            Series::line(c.name.clone(), rpm.clone(), a),
            i,
            n,
            &c.name,
        ));
        let (x, y) = phase_with_breaks(&rpm, &c.q);
        phase.push(styled(Series::line(c.name.clone(), x, y), i, n, &c.name));
    }
    (amp, phase)
}

/// A round step near `span / count`: 1, 2 or 5 times a power of ten.
fn nice_step(span: f64, count: f64) -> f64 {
    let raw = (span / count).abs();
    if !(raw.is_finite() && raw > 0.0) {
        return 1.0;
    }
    let p = 10f64.powf(raw.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * p)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * p)
}

/// Indices of the samples marked on the polar plot: for round speeds
/// (a step of 1, 2 or 5 times a power of ten giving about five of them
/// within the sweep), the sample at that speed (the nearest within 1 % of
/// the step). At most one index per round speed, in sweep order.
pub fn marked_samples(m: &Measurements) -> Vec<usize> {
    let rpm: Vec<f64> = m.samples.iter().map(|s| rad_s_to_rpm(s.omega)).collect();
    let (lo, hi) = rpm
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &r| {
            (a.min(r), b.max(r))
        });
    if !(lo.is_finite() && hi > lo) {
        return Vec::new();
    }
    let step = nice_step(hi - lo, 5.0);
    let mut out = Vec::new();
    let mut k = (lo / step).ceil();
    while k * step <= hi {
        let target = k * step;
        let best = rpm
            .iter()
            .enumerate()
            .min_by(|a, b| (a.1 - target).abs().total_cmp(&(b.1 - target).abs()));
        if let Some((i, r)) = best {
            if (r - target).abs() <= 0.01 * step && target > 0.0 && !out.contains(&i) {
                out.push(i);
            }
        }
        k += 1.0;
    }
    out.sort_unstable();
    out
}

/// The polar plot's series (x = Re q, y = Im q, um, one per bearing
/// channel, in channel order; the node probes are left out) and the
/// annotations marking [`marked_samples`] with their speed in rpm.
pub fn polar_series(m: &Measurements, chans: &[ChannelData]) -> (Vec<Series>, Vec<Annotation>) {
    let marks = marked_samples(m);
    let n = chans.len();
    let mut series = Vec::new();
    let mut notes = Vec::new();
    for (i, c) in chans
        .iter()
        .enumerate()
        .filter(|(_, c)| c.name.starts_with('b'))
    {
        let x: Vec<f64> = c.q.iter().map(|z| z.re * UM).collect();
        let y: Vec<f64> = c.q.iter().map(|z| z.im * UM).collect();
        series.push(styled(Series::line(c.name.clone(), x, y), i, n, &c.name));
        // The round speeds, and the speed of the largest response.
        let peak =
            c.q.iter()
                .enumerate()
                .max_by(|a, b| a.1.norm().total_cmp(&b.1.norm()))
                .map(|(k, _)| k);
        let mut marks = marks.clone();
        if let Some(k) = peak.filter(|k| !marks.contains(k)) {
            marks.push(k);
        }
        for &k in &marks {
            if let (Some(z), Some(s)) = (c.q.get(k), m.samples.get(k)) {
                notes.push(Annotation {
                    x: z.re * UM,
                    y: z.im * UM,
                    text: format!("{:.0}", rad_s_to_rpm(s.omega)),
                    color: PALETTE[i % PALETTE.len()],
                });
            }
        }
    }
    (series, notes)
}

/// Writes the Bode plot (`simulate_bode.svg`) of every channel of `m` and
/// of the node probes (`nodes`, `node_q` as for [`channels`]) and the polar
/// plot of the bearing channels (`simulate_polar.svg`) into `dir` (created
/// if needed). Returns the files written.
pub fn write_plots(
    dir: &Path,
    m: &Measurements,
    nodes: &[usize],
    node_q: &[Vec<Complex64>],
) -> Result<Vec<PathBuf>, ReportError> {
    std::fs::create_dir_all(dir).map_err(|source| ReportError::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    let chans = channels(m, nodes, node_q);
    let (amp, phase) = bode_series(m, &chans);
    let amp_opts = PlotOptions {
        log_y: true,
        ..PlotOptions::default()
    };
    let phase_opts = PlotOptions::default();
    let bode = dir.join("simulate_bode.svg");
    panel_plot(
        &bode,
        "1X response: amplitude and phase against speed",
        "speed (rpm)",
        &[
            Panel {
                y_label: "amplitude (um)",
                series: &amp,
                opts: &amp_opts,
            },
            Panel {
                y_label: "phase (deg)",
                series: &phase,
                opts: &phase_opts,
            },
        ],
        (1000, 900),
    )?;
    let (series, annotations) = polar_series(m, &chans);
    let polar = dir.join("simulate_polar.svg");
    polar_plot(
        &polar,
        "1X phasors at the bearing probes (marks: speed in rpm)",
        &series,
        annotations,
    )?;
    Ok(vec![bode, polar])
}

/// The polar plot of [`polar_series`]: imaginary against real part (um),
/// equal axes, the speed marks as `annotations`.
pub fn polar_plot(
    path: &std::path::Path,
    title: &str,
    series: &[Series],
    annotations: Vec<Annotation>,
) -> Result<(), PlotError> {
    line_plot_with(
        path,
        title,
        "real part (um)",
        "imaginary part (um)",
        series,
        &PlotOptions {
            equal_aspect: true,
            annotations,
            size: (1000, 850),
            ..PlotOptions::default()
        },
    )
}
