//! Simple SVG line/scatter plots (plotters, SVG backend, no font files
//! needed): [`line_plot`] for the common case, [`line_plot_with`] for
//! logarithmic y, fixed ranges, equal axis scales, vertical markers and
//! point annotations, [`panel_plot`] for several panels stacked over one
//! speed axis (a Bode plot). Used by `rotorid campbell`, `simulate`,
//! `identify` and `diagnose`.
//!
//! The legend stands outside the data, to the right of the panels, one
//! entry per label, drawn with the series' own colour, width, dash and
//! marker. Non-finite points split a line into separate pieces (so a mode
//! that is missing at some speeds is not joined across the gap); on a log-y
//! plot, points with `y <= 0` are treated the same way.

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
    /// Hollow circle (a line under it stays visible).
    Ring,
    /// Diagonal cross.
    Cross,
    /// Triangle.
    Triangle,
}

/// One data series.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// Legend label (empty: not in the legend; a label repeated keeps its
    /// first series' entry only).
    pub label: String,
    /// Abscissae.
    pub x: Vec<f64>,
    /// Ordinates (same length as `x`).
    pub y: Vec<f64>,
    /// Draw a line through the points.
    pub line: bool,
    /// Dashed line.
    pub dashed: bool,
    /// Dash pattern of a dashed line: pixels drawn, pixels left out.
    pub dash: (u32, u32),
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
            dash: (8, 5),
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

    /// Dashed with this pattern: `on` pixels drawn, `off` left out (two
    /// dashed curves with different patterns stay both visible where they
    /// coincide).
    pub fn dash_pattern(mut self, on: u32, off: u32) -> Self {
        self.dashed = true;
        self.dash = (on.max(1), off.max(1));
        self
    }

    /// With markers too.
    pub fn marker(mut self, m: Marker) -> Self {
        self.marker = Some(m);
        self
    }

    /// With this line width / marker size (pixels).
    pub fn width(mut self, px: u32) -> Self {
        self.width = px;
        self
    }
}

/// `rgb` mixed with white: `amount` 0 keeps the colour, 1 gives white (a
/// pale band under a line of the full colour).
pub fn pale(rgb: (u8, u8, u8), amount: f64) -> (u8, u8, u8) {
    let a = amount.clamp(0.0, 1.0);
    let mix = |c: u8| (f64::from(c) + (255.0 - f64::from(c)) * a).round() as u8;
    (mix(rgb.0), mix(rgb.1), mix(rgb.2))
}

/// A labelled vertical line (e.g. a critical speed).
#[derive(Debug, Clone, PartialEq)]
pub struct VLine {
    /// Abscissa.
    pub x: f64,
    /// Label (in the legend when non-empty).
    pub label: String,
}

/// A text at a data point, with a dot on the point (e.g. a speed on a
/// polar plot).
#[derive(Debug, Clone, PartialEq)]
pub struct Annotation {
    /// Abscissa of the point.
    pub x: f64,
    /// Ordinate of the point.
    pub y: f64,
    /// The text, drawn up and to the right of the point.
    pub text: String,
    /// Colour of the dot and the text (RGB).
    pub color: (u8, u8, u8),
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
    /// Same scale on both axes (a polar plot of phasors): the ranges are
    /// widened so that one unit spans as many pixels on x as on y. Not with
    /// `log_y`.
    pub equal_aspect: bool,
    /// Texts at data points.
    pub annotations: Vec<Annotation>,
    /// Height of this panel of a [`panel_plot`] relative to the others'
    /// (default 1: equal heights).
    pub panel_weight: u32,
}

impl Default for PlotOptions {
    fn default() -> Self {
        PlotOptions {
            log_y: false,
            x_range: None,
            y_range: None,
            size: (900, 600),
            vlines: Vec::new(),
            equal_aspect: false,
            annotations: Vec::new(),
            panel_weight: 1,
        }
    }
}

/// The colours series take by index when they have none of their own.
pub const PALETTE: [(u8, u8, u8); 8] = [
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

/// One panel of a [`panel_plot`]: its y label, series and options (of the
/// options, `size` is unused and `x_range` is taken from the first panel
/// that has one).
#[derive(Debug, Clone, Copy)]
pub struct Panel<'a> {
    /// Label of the y axis.
    pub y_label: &'a str,
    /// The series.
    pub series: &'a [Series],
    /// Log scale, ranges, vertical lines, annotations.
    pub opts: &'a PlotOptions,
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
    panel_plot(
        path,
        title,
        x_label,
        &[Panel {
            y_label,
            series,
            opts,
        }],
        opts.size,
    )
}

/// The ranges of a panel: `(x0, x1, y0, y1)`, x from the data unless given.
fn panel_ranges(
    p: &Panel<'_>,
    x_given: Option<(f64, f64)>,
) -> Result<(f64, f64, f64, f64), String> {
    let opts = p.opts;
    for s in p.series {
        if s.x.len() != s.y.len() {
            return Err(format!(
                "series `{}` has {} x and {} y values",
                s.label,
                s.x.len(),
                s.y.len()
            ));
        }
    }
    if opts.equal_aspect && opts.log_y {
        return Err("equal axis scales need linear axes".into());
    }
    let (mut x0, mut x1, mut y0, mut y1) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for s in p.series {
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
    if let Some((a, b)) = x_given {
        (x0, x1) = (a, b);
    }
    if let Some((a, b)) = opts.y_range {
        (y0, y1) = (a, b);
    }
    if !(x0.is_finite() && x1.is_finite() && y0.is_finite() && y1.is_finite()) {
        return Err("no finite data to plot".into());
    }
    if opts.log_y && y0 <= 0.0 {
        return Err("log-y range must be positive".into());
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
        return Err("empty y range".into());
    }
    Ok((x0, x1, y0, y1))
}

/// Margin around a panel's chart and the sizes of its label areas (px).
const MARGIN: u32 = 15;
const X_LABEL_AREA: u32 = 45;
const Y_LABEL_AREA: u32 = 80;

/// Widens `(x0, x1)` or `(y0, y1)` about its middle so that both span the
/// same data units per pixel on a plotting area of `w x h` pixels.
fn equalise(r: (f64, f64, f64, f64), w: u32, h: u32) -> (f64, f64, f64, f64) {
    let (x0, x1, y0, y1) = r;
    let (w, h) = (f64::from(w.max(1)), f64::from(h.max(1)));
    let per_px = ((x1 - x0) / w).max((y1 - y0) / h);
    let (cx, cy) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
    (
        cx - 0.5 * per_px * w,
        cx + 0.5 * per_px * w,
        cy - 0.5 * per_px * h,
        cy + 0.5 * per_px * h,
    )
}

/// A legend entry: what a series looks like.
#[derive(Debug, Clone, PartialEq)]
struct LegendEntry {
    label: String,
    color: (u8, u8, u8),
    width: u32,
    line: bool,
    dashed: bool,
    dash: (u32, u32),
    marker: Option<Marker>,
}

/// The legend of panels: one entry per distinct label, first occurrence,
/// then the first labelled vertical line.
fn legend_entries(panels: &[Panel<'_>]) -> Vec<LegendEntry> {
    let mut out: Vec<LegendEntry> = Vec::new();
    for p in panels {
        for (i, s) in p.series.iter().enumerate() {
            if s.label.is_empty() || out.iter().any(|e| e.label == s.label) {
                continue;
            }
            out.push(LegendEntry {
                label: s.label.clone(),
                color: s.color.unwrap_or(PALETTE[i % PALETTE.len()]),
                width: s.width,
                line: s.line,
                dashed: s.dashed,
                dash: s.dash,
                marker: s.marker,
            });
        }
    }
    for p in panels {
        if let Some(v) = p.opts.vlines.iter().find(|v| !v.label.is_empty()) {
            if !out.iter().any(|e| e.label == v.label) {
                out.push(LegendEntry {
                    label: v.label.clone(),
                    color: VLINE_COLOR,
                    width: 1,
                    line: true,
                    dashed: true,
                    dash: (6, 4),
                    marker: None,
                });
            }
        }
    }
    out
}

const VLINE_COLOR: (u8, u8, u8) = (90, 90, 90);
const LEGEND_FONT: u32 = 14;
const LEGEND_ROW: i32 = 22;

/// Width (px) of the legend column for these entries.
fn legend_width(entries: &[LegendEntry], total: u32) -> u32 {
    let chars = entries
        .iter()
        .map(|e| e.label.chars().count())
        .max()
        .unwrap_or(0) as u32;
    (60 + chars * 8).clamp(120, (total / 2).max(120))
}

/// Several panels over one x axis, stacked top to bottom, with one legend
/// to their right, written as SVG to `path` (`size` in pixels).
pub fn panel_plot(
    path: impl AsRef<Path>,
    title: &str,
    x_label: &str,
    panels: &[Panel<'_>],
    size: (u32, u32),
) -> Result<(), PlotError> {
    let path = path.as_ref();
    let pstr = path.display().to_string();
    let data_err = |reason: String| PlotError::Data {
        path: pstr.clone(),
        reason,
    };
    if panels.is_empty() {
        return Err(data_err("no panels".into()));
    }
    // One x range for all panels: the first given, else the union of the
    // panels' data.
    let x_given = panels.iter().find_map(|p| p.opts.x_range);
    let mut ranges = Vec::with_capacity(panels.len());
    for p in panels {
        ranges.push(panel_ranges(p, x_given).map_err(&data_err)?);
    }
    if x_given.is_none() {
        let x0 = ranges.iter().map(|r| r.0).fold(f64::INFINITY, f64::min);
        let x1 = ranges.iter().map(|r| r.1).fold(f64::NEG_INFINITY, f64::max);
        for r in &mut ranges {
            (r.0, r.1) = (x0, x1);
        }
    }
    let entries = legend_entries(panels);

    let be = |e: String| PlotError::Backend {
        path: pstr.clone(),
        reason: e,
    };
    // Drawn in memory, then written whole (temporary file + rename): a
    // failed write never leaves a partial SVG.
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        root.fill(&WHITE).map_err(|e| be(e.to_string()))?;
        let body = root
            .titled(title, ("sans-serif", 22))
            .map_err(|e| be(e.to_string()))?;
        let (w, _) = body.dim_in_pixel();
        let (charts, legend) = if entries.is_empty() {
            (body, None)
        } else {
            let lw = legend_width(&entries, w);
            let (c, l) = body.split_horizontally(w.saturating_sub(lw));
            (c, Some(l))
        };
        let areas = split_by_weight(&charts, panels);
        let last = panels.len() - 1;
        for (k, ((p, area), r)) in panels.iter().zip(&areas).zip(&ranges).enumerate() {
            let mut r = *r;
            if p.opts.equal_aspect {
                let (aw, ah) = area.dim_in_pixel();
                r = equalise(
                    r,
                    aw.saturating_sub(2 * MARGIN + Y_LABEL_AREA),
                    ah.saturating_sub(2 * MARGIN + X_LABEL_AREA),
                );
            }
            let labels = Labels {
                x: if k == last { x_label } else { "" },
                y: p.y_label,
            };
            if p.opts.log_y {
                draw(area, &labels, p, r.0..r.1, (r.2..r.3).log_scale()).map_err(&be)?;
            } else {
                draw(area, &labels, p, r.0..r.1, r.2..r.3).map_err(&be)?;
            }
        }
        if let Some(l) = legend {
            draw_legend(&l, &entries).map_err(&be)?;
        }
        root.present().map_err(|e| be(e.to_string()))?;
    }
    crate::io::output::write_atomic(path, svg.as_bytes()).map_err(|e| match e {
        crate::io::output::OutputError::Io { source, .. } => be(format!("cannot write: {source}")),
        other => be(other.to_string()),
    })?;
    Ok(())
}

/// The panels' areas, top to bottom: equal heights, or heights in
/// proportion to [`PlotOptions::panel_weight`] when the weights differ.
fn split_by_weight<'a>(
    charts: &DrawingArea<SVGBackend<'a>, Shift>,
    panels: &[Panel<'_>],
) -> Vec<DrawingArea<SVGBackend<'a>, Shift>> {
    let weights: Vec<u32> = panels.iter().map(|p| p.opts.panel_weight.max(1)).collect();
    if weights.iter().all(|&w| w == weights[0]) {
        return charts.split_evenly((panels.len(), 1));
    }
    let (_, h) = charts.dim_in_pixel();
    let total: u32 = weights.iter().sum();
    let mut at = 0u32;
    let breaks: Vec<i32> = weights[..weights.len() - 1]
        .iter()
        .map(|w| {
            at += w;
            (u64::from(h) * u64::from(at) / u64::from(total)) as i32
        })
        .collect();
    charts.split_by_breakpoints::<i32, i32, _, _>([], breaks)
}

/// Draws the legend entries in `area` (pixel coordinates), each with a
/// sample of its series' line (solid or dashed, its width) and marker; an
/// entry with neither (a series with no line and no marker) is a heading,
/// its text in bold from the left edge.
fn draw_legend(
    area: &DrawingArea<SVGBackend<'_>, Shift>,
    entries: &[LegendEntry],
) -> Result<(), String> {
    let top = (MARGIN + 5) as i32;
    let (w, _) = area.dim_in_pixel();
    let bottom = top + LEGEND_ROW * entries.len() as i32 + 6;
    area.draw(&Rectangle::new(
        [(4, top - 8), (w as i32 - 6, bottom)],
        ShapeStyle::from(&RGBColor(160, 160, 160)).stroke_width(1),
    ))
    .map_err(|e| e.to_string())?;
    for (i, e) in entries.iter().enumerate() {
        let y = top + 6 + LEGEND_ROW * i as i32;
        let (r, g, b) = e.color;
        let style = ShapeStyle::from(&RGBColor(r, g, b)).stroke_width(e.width.max(1));
        let (x0, x1) = (12, 48);
        if e.line {
            if e.dashed {
                // The series' own dash pattern.
                let (on, off) = (e.dash.0.max(1) as i32, e.dash.1.max(1) as i32);
                let mut x = x0;
                while x < x1 {
                    let end = (x + on).min(x1);
                    area.draw(&PathElement::new(vec![(x, y), (end, y)], style))
                        .map_err(|e| e.to_string())?;
                    x = end + off;
                }
            } else {
                area.draw(&PathElement::new(vec![(x0, y), (x1, y)], style))
                    .map_err(|e| e.to_string())?;
            }
        }
        if let Some(m) = e.marker {
            draw_marker(area, m, (30, y), (e.width + 1) as i32, style)?;
        }
        let heading = !e.line && e.marker.is_none();
        let font = ("sans-serif", LEGEND_FONT).into_font();
        area.draw(&Text::new(
            e.label.clone(),
            (
                if heading { x0 } else { x1 + 8 },
                y - LEGEND_FONT as i32 / 2 - 1,
            ),
            if heading {
                font.style(FontStyle::Bold)
            } else {
                font
            },
        ))
        .map_err(|e| e.to_string())?;
    }
    Ok(())
}

/// One marker at pixel `at` of `area`.
fn draw_marker(
    area: &DrawingArea<SVGBackend<'_>, Shift>,
    m: Marker,
    at: (i32, i32),
    size: i32,
    style: ShapeStyle,
) -> Result<(), String> {
    let r = match m {
        Marker::Circle => area.draw(&Circle::new(at, size, style.filled())),
        Marker::Ring => area.draw(&Circle::new(at, size + 1, style.stroke_width(1))),
        Marker::Cross => area.draw(&Cross::new(at, size, style)),
        Marker::Triangle => area.draw(&TriangleMarker::new(at, size, style.filled())),
    };
    r.map_err(|e| e.to_string())
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

/// The axis labels of a panel.
struct Labels<'a> {
    x: &'a str,
    y: &'a str,
}

fn draw<'a, Y>(
    root: &DrawingArea<SVGBackend<'a>, Shift>,
    labels: &Labels<'_>,
    panel: &Panel<'_>,
    xr: std::ops::Range<f64>,
    yr: Y,
) -> Result<(), String>
where
    Y: AsRangedCoord<Value = f64>,
    Y::CoordDescType: ValueFormatter<f64>,
{
    let opts = panel.opts;
    let mut chart = ChartBuilder::on(root)
        .margin(MARGIN)
        .x_label_area_size(X_LABEL_AREA)
        .y_label_area_size(Y_LABEL_AREA)
        .build_cartesian_2d(xr.clone(), yr)
        .map_err(|e| e.to_string())?;
    // A tick at zero computed from the range may come out as round-off
    // (-2.2e-16): within 1e-9 of the axis span it is 0 (linear axes only).
    let x_span = xr.end - xr.start;
    let y_span = {
        let r = chart.y_range();
        r.end - r.start
    };
    let snap = |v: f64, span: f64, linear: bool| {
        if linear && v.abs() <= 1e-9 * span.abs() {
            0.0
        } else {
            v
        }
    };
    let log_y = opts.log_y;
    chart
        .configure_mesh()
        .x_desc(labels.x)
        .y_desc(labels.y)
        .x_label_formatter(&|v| tick_label(snap(*v, x_span, true)))
        .y_label_formatter(&|v| tick_label(snap(*v, y_span, !log_y)))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()
        .map_err(|e| e.to_string())?;
    let (y_lo, y_hi) = {
        let r = chart.y_range();
        (r.start, r.end)
    };
    for (i, s) in panel.series.iter().enumerate() {
        let (r, g, b) = s.color.unwrap_or(PALETTE[i % PALETTE.len()]);
        let color = RGBColor(r, g, b);
        let style = ShapeStyle::from(&color).stroke_width(s.width.max(1));
        for run in runs(s, opts.log_y) {
            if s.line && run.len() > 1 {
                if s.dashed {
                    chart
                        .draw_series(DashedLineSeries::new(
                            run.clone(),
                            s.dash.0,
                            s.dash.1,
                            style,
                        ))
                        .map_err(|e| e.to_string())?;
                } else {
                    chart
                        .draw_series(LineSeries::new(run.clone(), style))
                        .map_err(|e| e.to_string())?;
                }
            }
            if let Some(m) = s.marker {
                let size = (s.width + 1) as i32;
                match m {
                    Marker::Circle => chart
                        .draw_series(run.iter().map(|&p| Circle::new(p, size, style.filled())))
                        .map(|_| ()),
                    Marker::Ring => chart
                        .draw_series(
                            run.iter()
                                .map(|&p| Circle::new(p, size + 1, style.stroke_width(1))),
                        )
                        .map(|_| ()),
                    Marker::Cross => chart
                        .draw_series(run.iter().map(|&p| Cross::new(p, size, style)))
                        .map(|_| ()),
                    Marker::Triangle => chart
                        .draw_series(
                            run.iter()
                                .map(|&p| TriangleMarker::new(p, size, style.filled())),
                        )
                        .map(|_| ()),
                }
                .map_err(|e| e.to_string())?;
            }
        }
    }
    for v in &opts.vlines {
        if !v.x.is_finite() {
            continue;
        }
        let (r, g, b) = VLINE_COLOR;
        let style = ShapeStyle::from(&RGBColor(r, g, b)).stroke_width(1);
        chart
            .draw_series(DashedLineSeries::new(
                vec![(v.x, y_lo), (v.x, y_hi)],
                6,
                4,
                style,
            ))
            .map_err(|e| e.to_string())?;
    }
    // Every annotated point gets its dot; a text that would overlap one
    // already written is left out (the dot still marks the point).
    let mut texts: Vec<(i32, i32, i32)> = Vec::new();
    for a in &opts.annotations {
        if !usable(opts.log_y, a.x, a.y) {
            continue;
        }
        let (r, g, b) = a.color;
        let color = RGBColor(r, g, b);
        let dot = ShapeStyle::from(&color).filled();
        let (px, py) = chart.backend_coord(&(a.x, a.y));
        let width = 7 * a.text.chars().count() as i32;
        let free = texts
            .iter()
            .all(|&(x, y, w)| (px - x).abs() > w.max(width) || (py - y).abs() > 14);
        if free {
            texts.push((px, py, width));
            chart
                .draw_series(std::iter::once(
                    EmptyElement::at((a.x, a.y))
                        + Circle::new((0, 0), 3, dot)
                        + Text::new(
                            a.text.clone(),
                            (5, -15),
                            ("sans-serif", 12).into_font().color(&color),
                        ),
                ))
                .map_err(|e| e.to_string())?;
        } else {
            chart
                .draw_series(std::iter::once(Circle::new((a.x, a.y), 3, dot)))
                .map_err(|e| e.to_string())?;
        }
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
