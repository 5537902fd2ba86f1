//! Pictures of extracted vectors, `rotorid vectors --plot DIR`: per
//! channel a Bode plot (`vectors_bode_<channel>.svg`: 1X amplitude and
//! phase against speed, each row a point with its error bar, `+-` one
//! standard error: `|Y| +- std` in amplitude, `+- asin(std / |Y|)` in
//! phase), and a polar plot of the bearing channels
//! (`vectors_polar.svg`, the vectors through the sweep, a few speeds
//! marked, as `rotorid simulate --plot` draws them).

use std::path::{Path, PathBuf};

use num_complex::Complex64;

use crate::io::measurement::{Measurements, Sample};
use crate::report::identify::ReportError;
use crate::report::plot::{panel_plot, Marker, Panel, PlotOptions, Series, PALETTE};
use crate::signals::{ChannelName, Vectors};
use crate::units::rad_s_to_rpm;

/// Metres to micrometres.
const UM: f64 = 1e6;

/// Error bars as one broken line: a vertical segment `lo..hi` at each `x`.
fn bars(label: &str, x: &[f64], lo: &[f64], hi: &[f64]) -> Series {
    let mut bx = Vec::with_capacity(3 * x.len());
    let mut by = Vec::with_capacity(3 * x.len());
    for ((x, l), h) in x.iter().zip(lo).zip(hi) {
        bx.extend_from_slice(&[*x, *x, *x]);
        by.extend_from_slice(&[*l, *h, f64::NAN]);
    }
    Series::line(label, bx, by).width(1)
}

/// The vectors of the bearing channels as a [`Measurements`] (for the
/// polar plot of `report::simulate`).
fn bearing_measurements(v: &Vectors) -> Measurements {
    let nb = v
        .channels
        .iter()
        .filter(|c| matches!(c, ChannelName::Bearing(..)))
        .count()
        / 2;
    Measurements {
        n_bearings: nb,
        samples: v
            .rows
            .iter()
            .map(|r| Sample {
                omega: r.omega,
                q: r.x1.iter().take(2 * nb).copied().collect(),
            })
            .collect(),
        ..Measurements::default()
    }
}

/// Writes the plots into `dir` (created if needed); returns the files.
pub fn write_plots(dir: &Path, v: &Vectors) -> Result<Vec<PathBuf>, ReportError> {
    std::fs::create_dir_all(dir).map_err(|source| ReportError::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    let rpm: Vec<f64> = v.rows.iter().map(|r| rad_s_to_rpm(r.omega)).collect();
    let mut files = Vec::new();
    for (c, name) in v.channels.iter().enumerate() {
        let color = PALETTE[c % PALETTE.len()];
        let q: Vec<Complex64> = v
            .rows
            .iter()
            .map(|r| {
                r.x1.get(c)
                    .copied()
                    .unwrap_or(Complex64::new(f64::NAN, 0.0))
            })
            .collect();
        let s: Vec<f64> = v
            .rows
            .iter()
            .map(|r| r.std.get(c).copied().unwrap_or(f64::NAN))
            .collect();
        let amp: Vec<f64> = q.iter().map(|z| z.norm() * UM).collect();
        let lo: Vec<f64> = amp.iter().zip(&s).map(|(a, s)| a - s * UM).collect();
        let hi: Vec<f64> = amp.iter().zip(&s).map(|(a, s)| a + s * UM).collect();
        let (px, py) = crate::report::simulate::phase_with_breaks(&rpm, &q);
        let dphi: Vec<f64> = q
            .iter()
            .zip(&s)
            .map(|(z, s)| (s / z.norm()).min(1.0).asin().to_degrees())
            .collect();
        let phase: Vec<f64> = q.iter().map(|z| z.arg().to_degrees()).collect();
        let plo: Vec<f64> = phase.iter().zip(&dphi).map(|(p, d)| p - d).collect();
        let phi: Vec<f64> = phase.iter().zip(&dphi).map(|(p, d)| p + d).collect();
        let label = name.to_string();
        let amp_series = [
            Series::line("", rpm.clone(), amp.clone())
                .color(crate::report::plot::pale(color, 0.6))
                .width(1),
            bars("+- 1 standard error", &rpm, &lo, &hi).color((60, 60, 60)),
            Series::points(label.clone(), rpm.clone(), amp, Marker::Circle).color(color),
        ];
        let phase_series = [
            Series::line("", px, py)
                .color(crate::report::plot::pale(color, 0.6))
                .width(1),
            bars("+- 1 standard error", &rpm, &plo, &phi).color((60, 60, 60)),
            Series::points(label.clone(), rpm.clone(), phase, Marker::Circle).color(color),
        ];
        let path = dir.join(format!("vectors_bode_{name}.svg"));
        let opts = PlotOptions::default();
        panel_plot(
            &path,
            &format!(
                "{name}: 1X amplitude and phase from the signals ({} rows)",
                v.rows.len()
            ),
            "speed (rpm)",
            &[
                Panel {
                    y_label: "amplitude (um, 0-pk)",
                    series: &amp_series,
                    opts: &opts,
                },
                Panel {
                    y_label: "phase arg Y (deg)",
                    series: &phase_series,
                    opts: &opts,
                },
            ],
            (1000, 800),
        )?;
        files.push(path);
    }
    let m = bearing_measurements(v);
    if m.n_bearings > 0 && m.samples.len() > 1 {
        let chans = crate::report::simulate::channels(&m, &[], &[]);
        let (mut series, annotations) = crate::report::simulate::polar_series(&m, &chans);
        for (i, c) in chans.iter().enumerate() {
            let x: Vec<f64> = c.q.iter().map(|z| z.re * UM).collect();
            let y: Vec<f64> = c.q.iter().map(|z| z.im * UM).collect();
            series.push(Series::points("", x, y, Marker::Circle).color(PALETTE[i % PALETTE.len()]));
        }
        let path = dir.join("vectors_polar.svg");
        crate::report::simulate::polar_plot(
            &path,
            "1X vectors from the signals at the bearing probes (marks: speed in rpm)",
            &series,
            annotations,
        )?;
        files.push(path);
    }
    Ok(files)
}
