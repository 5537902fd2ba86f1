//! Simple SVG line/scatter plots (plotters, SVG backend, no font files
//! needed): [`line_plot`] for the common case, [`line_plot_with`] for
//! logarithmic y, fixed ranges and vertical markers. Used by
//! `rotorid campbell` and by the identification plots.
//!
//! Non-finite points split a line into separate pieces (so a mode that is
//! missing at some speeds is not joined across the gap); on a log-y plot,
//! points with `y <= 0` are treated the same way.

use std::path::Path;

use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::coord::Shift;
use plotters::prelude::*;
use thiserror::Error;

/// Error drawing or writing a plot.
#[derive(Debug, Error)]
pub enum PlotError {
    /// The data cannot be plotted.
    #[error("plot {path}: {reason}")]
    Data {
        /// Output file.
        path: String,
        /// What is wrong.
        reason: String,
    },
    /// The drawing backend failed (e.g. the file cannot be written).
    #[error("plot {path}: {reason}")]
    Backend {
        /// Output file.
        path: String,
        /// The backend's message.
        reason: String,
    },
}

/// Point marker.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Marker {
    /// Filled circle.
    Circle,
    /// Diagonal cross.
    Cross,
    /// Triangle.
    Triangle,
}

/// One data series.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// Legend label (empty: not in the legend).
    pub label: String,
    /// Abscissae.
    pub x: Vec<f64>,
    /// Ordinates (same length as `x`).
    pub y: Vec<f64>,
    /// Draw a line through the points.
    pub line: bool,
    /// Dashed line.
    pub dashed: bool,
    /// Marker at each point.
    pub marker: Option<Marker>,
    /// Colour (RGB); `None` picks from a palette by series index.
    pub color: Option<(u8, u8, u8)>,
    /// Line width / marker size (pixels).
    pub width: u32,
}

impl Series {
    /// A solid line.
    pub fn line(label: impl Into<String>, x: Vec<f64>, y: Vec<f64>) -> Self {
        Series {
            label: label.into(),
            x,
            y,
            line: true,
            dashed: false,
            marker: None,
            color: None,
            width: 2,
        }
    }

    /// Points only.
    pub fn points(label: impl Into<String>, x: Vec<f64>, y: Vec<f64>, marker: Marker) -> Self {
        Series {
            line: false,
            marker: Some(marker),
            width: 3,
            ..Series::line(label, x, y)
        }
    }

    /// With this colour.
    pub fn color(mut self, rgb: (u8, u8, u8)) -> Self {
        self.color = Some(rgb);
        self
    }

    /// Dashed.
    pub fn dashed(mut self) -> Self {
        self.dashed = true;
        self
    }

    /// With markers too.
    pub fn marker(mut self, m: Marker) -> Self {
        self.marker = Some(m);
        self
    }
}

/// A labelled vertical line (e.g. a critical speed).
#[derive(Debug, Clone, PartialEq)]
pub struct VLine {
    /// Abscissa.
    pub x: f64,
    /// Label (in the legend when non-empty).
    pub label: String,
}

/// Plot options.
#[derive(Debug, Clone, PartialEq)]
pub struct PlotOptions {
    /// Logarithmic y axis.
    pub log_y: bool,
    /// Fixed x range (default: the data's).
    pub x_range: Option<(f64, f64)>,
    /// Fixed y range (default: the data's, with a margin).
    pub y_range: Option<(f64, f64)>,
    /// Image size in pixels.
    pub size: (u32, u32),
    /// Vertical marker lines.
    pub vlines: Vec<VLine>,
}

impl Default for PlotOptions {
    fn default() -> Self {
        PlotOptions {
            log_y: false,
            x_range: None,
            y_range: None,
            size: (900, 600),
            vlines: Vec::new(),
        }
    }
}

const PALETTE: [(u8, u8, u8); 8] = [
    (31, 119, 180),
    (214, 39, 40),
    (44, 160, 44),
    (255, 127, 14),
    (148, 103, 189),
    (140, 86, 75),
    (227, 119, 194),
    (23, 190, 207),
];

/// A line plot with the default options.
pub fn line_plot(
    path: impl AsRef<Path>,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
) -> Result<(), PlotError> {
    line_plot_with(
        path,
        title,
        x_label,
        y_label,
        series,
        &PlotOptions::default(),
    )
}

fn usable(log_y: bool, x: f64, y: f64) -> bool {
    x.is_finite() && y.is_finite() && (!log_y || y > 0.0)
}

/// Splits a series into runs of usable points.
fn runs(s: &Series, log_y: bool) -> Vec<Vec<(f64, f64)>> {
    let mut out = Vec::new();
    let mut cur = Vec::new();
    for (&x, &y) in s.x.iter().zip(&s.y) {
        if usable(log_y, x, y) {
            cur.push((x, y));
        } else if !cur.is_empty() {
            out.push(std::mem::take(&mut cur));
        }
    }
    if !cur.is_empty() {
        out.push(cur);
    }
    out
}

/// A line plot written as SVG to `path`.
pub fn line_plot_with(
    path: impl AsRef<Path>,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
    opts: &PlotOptions,
) -> Result<(), PlotError> {
    let path = path.as_ref();
    let pstr = path.display().to_string();
    let data_err = |reason: String| PlotError::Data {
        path: pstr.clone(),
        reason,
    };
    for s in series {
        if s.x.len() != s.y.len() {
            return Err(data_err(format!(
                "series `{}` has {} x and {} y values",
                s.label,
                s.x.len(),
                s.y.len()
            )));
        }
    }
    let (mut x0, mut x1, mut y0, mut y1) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for s in series {
        for (&x, &y) in s.x.iter().zip(&s.y) {
            if usable(opts.log_y, x, y) {
                x0 = x0.min(x);
                x1 = x1.max(x);
                y0 = y0.min(y);
                y1 = y1.max(y);
            }
        }
    }
    for v in &opts.vlines {
        if v.x.is_finite() {
            x0 = x0.min(v.x);
            x1 = x1.max(v.x);
        }
    }
    if let Some((a, b)) = opts.x_range {
        (x0, x1) = (a, b);
    }
    if let Some((a, b)) = opts.y_range {
        (y0, y1) = (a, b);
    }
    if !(x0.is_finite() && x1.is_finite() && y0.is_finite() && y1.is_finite()) {
        return Err(data_err("no finite data to plot".into()));
    }
    if opts.log_y && y0 <= 0.0 {
        return Err(data_err("log-y range must be positive".into()));
    }
    if x1 <= x0 {
        let d = if x0 == 0.0 { 1.0 } else { x0.abs() * 0.05 };
        (x0, x1) = (x0 - d, x1 + d);
    }
    if opts.y_range.is_none() {
        if opts.log_y {
            if y1 <= y0 {
                (y0, y1) = (y0 / 2.0, y1 * 2.0);
            } else {
                (y0, y1) = (y0 / 1.5, y1 * 1.5);
            }
        } else {
            let d = if y1 > y0 {
                0.05 * (y1 - y0)
            } else if y0 == 0.0 {
                1.0
            } else {
                0.05 * y0.abs()
            };
            (y0, y1) = (y0 - d, y1 + d);
        }
    } else if y1 <= y0 {
        return Err(data_err("empty y range".into()));
    }

    let be = |e: String| PlotError::Backend {
        path: pstr.clone(),
        reason: e,
    };
    // Drawn in memory, then written whole (temporary file + rename): a
    // failed write never leaves a partial SVG.
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, opts.size).into_drawing_area();
        root.fill(&WHITE).map_err(|e| be(e.to_string()))?;
        let labels = Labels {
            title,
            x: x_label,
            y: y_label,
        };
        if opts.log_y {
            draw(&root, &labels, series, opts, x0..x1, (y0..y1).log_scale()).map_err(be)?;
        } else {
            draw(&root, &labels, series, opts, x0..x1, y0..y1).map_err(be)?;
        }
        root.present().map_err(|e| be(e.to_string()))?;
    }
    crate::io::output::write_atomic(path, svg.as_bytes()).map_err(|e| match e {
        crate::io::output::OutputError::Io { source, .. } => be(format!("cannot write: {source}")),
        other => be(other.to_string()),
    })?;
    Ok(())
}

/// A short tick label: `0`, plain decimals with trailing zeros trimmed for
/// magnitudes in `[1e-3, 1e6)` (`2000`, `0.0042`, `17.5`), otherwise
/// scientific notation with at most four significant digits (`5e7`,
/// `2.5e-5`).
pub fn tick_label(v: f64) -> String {
    fn trim(s: &str) -> &str {
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.')
        } else {
            s
        }
    }
    let a = v.abs();
    if v == 0.0 || !v.is_finite() {
        return if v == 0.0 { "0".into() } else { format!("{v}") };
    }
    if (1e-3..1e6).contains(&a) {
        let s = format!("{v:.4}");
        return trim(&s).to_string();
    }
    let s = format!("{v:.3e}");
    match s.split_once('e') {
        Some((mantissa, exp)) => format!("{}e{exp}", trim(mantissa)),
        None => s,
    }
}

/// The texts of a plot: title and axis labels.
struct Labels<'a> {
    title: &'a str,
    x: &'a str,
    y: &'a str,
}

fn draw<'a, Y>(
    root: &DrawingArea<SVGBackend<'a>, Shift>,
    labels: &Labels<'_>,
    series: &[Series],
    opts: &PlotOptions,
    xr: std::ops::Range<f64>,
    yr: Y,
) -> Result<(), String>
where
    Y: AsRangedCoord<Value = f64>,
    Y::CoordDescType: ValueFormatter<f64>,
{
    let mut chart = ChartBuilder::on(root)
        .caption(labels.title, ("sans-serif", 22))
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(80)
        .build_cartesian_2d(xr.clone(), yr)
        .map_err(|e| e.to_string())?;
    chart
        .configure_mesh()
        .x_desc(labels.x)
        .y_desc(labels.y)
        .x_label_formatter(&|v| tick_label(*v))
        .y_label_formatter(&|v| tick_label(*v))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()
        .map_err(|e| e.to_string())?;
    let (y_lo, y_hi) = {
        let r = chart.y_range();
        (r.start, r.end)
    };
    let mut any_label = false;
    for (i, s) in series.iter().enumerate() {
        let (r, g, b) = s.color.unwrap_or(PALETTE[i % PALETTE.len()]);
        let color = RGBColor(r, g, b);
        let style = ShapeStyle::from(&color).stroke_width(s.width.max(1));
        let mut labelled = false;
        for run in runs(s, opts.log_y) {
            if s.line && run.len() > 1 {
                let anno = if s.dashed {
                    chart
                        .draw_series(DashedLineSeries::new(run.clone(), 8, 5, style))
                        .map_err(|e| e.to_string())?
                } else {
                    chart
                        .draw_series(LineSeries::new(run.clone(), style))
                        .map_err(|e| e.to_string())?
                };
                if !labelled && !s.label.is_empty() {
                    anno.label(s.label.clone())
                        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], style));
                    labelled = true;
                    any_label = true;
                }
            }
            if let Some(m) = s.marker {
                let size = (s.width + 1) as i32;
                let filled = style.filled();
                let anno = match m {
                    Marker::Circle => chart
                        .draw_series(run.iter().map(|&p| Circle::new(p, size, filled)))
                        .map_err(|e| e.to_string())?,
                    Marker::Cross => chart
                        .draw_series(run.iter().map(|&p| Cross::new(p, size, style)))
                        .map_err(|e| e.to_string())?,
                    Marker::Triangle => chart
                        .draw_series(run.iter().map(|&p| TriangleMarker::new(p, size, filled)))
                        .map_err(|e| e.to_string())?,
                };
                if !labelled && !s.label.is_empty() {
                    anno.label(s.label.clone())
                        .legend(move |(x, y)| Circle::new((x + 10, y), size, filled));
                    labelled = true;
                    any_label = true;
                }
            }
        }
    }
    for (i, v) in opts.vlines.iter().enumerate() {
        if !v.x.is_finite() {
            continue;
        }
        let style = ShapeStyle::from(&RGBColor(90, 90, 90)).stroke_width(1);
        let anno = chart
            .draw_series(DashedLineSeries::new(
                vec![(v.x, y_lo), (v.x, y_hi)],
                6,
                4,
                style,
            ))
            .map_err(|e| e.to_string())?;
        if !v.label.is_empty() && i == 0 {
            anno.label(v.label.clone())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], style));
            any_label = true;
        }
    }
    if any_label {
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .position(SeriesLabelPosition::UpperLeft)
            .draw()
            .map_err(|e| e.to_string())?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tick_labels_are_short() {
        assert_eq!(tick_label(0.0), "0");
        assert_eq!(tick_label(2000.0), "2000");
        assert_eq!(tick_label(14000.0), "14000");
        assert_eq!(tick_label(0.0042), "0.0042");
        assert_eq!(tick_label(-17.5), "-17.5");
        assert_eq!(tick_label(1e8), "1e8");
        assert_eq!(tick_label(-2.5e7), "-2.5e7");
        assert_eq!(tick_label(2.5e-5), "2.5e-5");
    }

    #[test]
    fn writes_svg_linear_and_log() {
        let dir = std::env::temp_dir().join(format!("rotorid-plot-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let x: Vec<f64> = (0..50).map(|i| i as f64).collect();
        let y: Vec<f64> = x.iter().map(|v| (v / 5.0).sin() + 2.0).collect();
        let mut gap = y.clone();
        gap[20] = f64::NAN;
        let s = [
            Series::line("sin", x.clone(), y.clone()),
            Series::points("pts", x.clone(), gap, Marker::Cross),
            Series::line("dash", x.clone(), y.iter().map(|v| v * 2.0).collect()).dashed(),
        ];
        let p = dir.join("a.svg");
        line_plot(&p, "title", "x (rpm)", "y (Hz)", &s).unwrap();
        let text = std::fs::read_to_string(&p).unwrap();
        assert!(text.starts_with("<svg"));
        assert!(text.contains("title"));
        assert!(text.contains("polyline"));
        let p = dir.join("b.svg");
        let opts = PlotOptions {
            log_y: true,
            vlines: vec![VLine {
                x: 25.0,
                label: "critical".into(),
            }],
            ..PlotOptions::default()
        };
        line_plot_with(&p, "log", "x", "y", &s, &opts).unwrap();
        assert!(std::fs::read_to_string(&p).unwrap().contains("critical"));
        // Errors: mismatched lengths, nothing finite, unwritable path.
        let bad = [Series::line("bad", vec![1.0], vec![])];
        assert!(line_plot(dir.join("c.svg"), "t", "x", "y", &bad).is_err());
        let nan = [Series::line("nan", vec![f64::NAN], vec![1.0])];
        assert!(line_plot(dir.join("c.svg"), "t", "x", "y", &nan).is_err());
        assert!(line_plot(dir.join("no/such/dir/c.svg"), "t", "x", "y", &s).is_err());
        std::fs::remove_dir_all(&dir).ok();
    }
}
