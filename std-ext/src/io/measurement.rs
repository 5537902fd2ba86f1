//! Measured (or simulated) 1X responses at the bearings, and the
//! measurement CSV format (see the README, "Measurement file").
//!
//! # File format
//!
//! ```text
//! # any number of comment lines starting with '#'
//! speed_rpm,b1_y_re,b1_y_im,b1_z_re,b1_z_im,b2_y_re,b2_y_im,b2_z_re,b2_z_im
//! 10,1.2e-9,-3.4e-10,...
//! ```
//!
//! - One row per speed (rpm, `>= 0`, any order: run-ups and run-downs are
//!   both valid); one group of four columns per bearing, `b1..bNb` in
//!   bearing order; values in metres, phasor convention
//!   `y(t) = Re{ Y exp(j Omega t) }`.
//! - Alternative header with amplitude and phase per channel:
//!   `speed_rpm,b1_y_amp,b1_y_phase_deg,b1_z_amp,b1_z_phase_deg,...`
//!   (amplitude `|Y|` in metres, `>= 0`; phase `arg Y` in degrees).
//! - Comment lines (first non-blank character `#`) may appear anywhere;
//!   blank lines are ignored. Fields may carry surrounding spaces; line
//!   endings `\n` or `\r\n`.
//! - N_b comes from the header. Every bad row (wrong column count, a field
//!   that is not a number, NaN, infinity, negative speed or amplitude) is an
//!   error carrying its 1-based line number and its column (1-based number
//!   and header name): nothing is silently dropped. A quoted field is cut
//!   to its first 40 characters.
//! - Every line ends with a line break, the last one included: a file whose
//!   last data row has none is taken as cut short (a write that stopped
//!   half way, e.g. `...,-3.8` for `...,-3.85e-7`) and refused.
//! - At most [`MAX_ROWS`] data rows.
//! - Probes at other shaft nodes may follow the bearing columns, four
//!   columns per node in the file's layout: `nN_y_re,nN_y_im,nN_z_re,nN_z_im`
//!   (or `nN_y_amp,nN_y_phase_deg,...`) for node `N` numbered from 1, each
//!   node at most once. They read the shaft's absolute displacement at that
//!   node ([`Measurements::node_probes`], [`Measurements::node_q`]); the
//!   identification uses the bearing columns only, the diagnosis uses all.
//! - For a model that declares probes at an angle
//!   ([`crate::model::ProbePair`]), the bearing columns are named by
//!   channel ([`model_channel_names`], [`parse_csv_channels`]) and hold the
//!   probes' readings, which [`probes_to_yz`] turns into `y`, `z`.
//!
//! - A comment line before the header may declare the file's instrument
//!   conventions (SPEC section 7, [`conventions`]):
//!   `# conventions: amplitude_unit=um amplitude=pk-pk phase=lag`. The
//!   values are turned into rotorid's own (metres, zero-to-peak, `arg Y`)
//!   as they are read; [`parse_csv_conventions`] and
//!   [`read_for_model_with`] take overrides (the command line's). Other
//!   comment lines are free text; a file without the line is read as
//!   rotorid's own.
//!
//! The writer prints every number with Rust's shortest round-trip
//! representation (`{:e}`), so the phasors read back bit for bit; the speed
//! is converted rad/s -> rpm -> rad/s, exact to about one ulp. It writes
//! rotorid's own conventions and no `# conventions:` line.

use std::fmt::Write as _;
use std::path::Path;

use num_complex::Complex64;
use thiserror::Error;

use crate::io::clip;
use crate::model::ProbePair;
use crate::units::{rad_s_to_rpm, rpm_to_rad_s};

pub mod conventions;

pub use conventions::{
    parse_conventions_comment, AmplitudeKind, AmplitudeUnit, Conventions, ConventionsError,
    DeclaredConventions, PhaseConvention,
};

/// Most data rows a measurement file may hold (a sweep of one million
/// speeds; far beyond any run-up, and a bound on the memory a file can ask
/// for).
pub const MAX_ROWS: usize = 1_000_000;

/// The 1X response phasors at all bearing channels at one speed.
#[derive(Debug, Clone, PartialEq)]
pub struct Sample {
    /// Rotor speed Omega (rad/s).
    pub omega: f64,
    /// Phasors (m), `2 N_b` entries in the order `b1_y, b1_z, b2_y, b2_z, ...`.
    pub q: Vec<Complex64>,
}

/// A sweep of samples, in file order (run-ups and run-downs are both valid).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Measurements {
    /// Comment lines of the file, without the leading `#` (the
    /// `# conventions:` line is not among them: it is applied, see
    /// [`CsvLocations::conventions`]).
    pub comments: Vec<String>,
    /// Number of bearings N_b.
    pub n_bearings: usize,
    /// One sample per row.
    pub samples: Vec<Sample>,
    /// Shaft nodes (0-based) of the probes at other nodes, in column order;
    /// empty for a file with bearing probes only.
    pub node_probes: Vec<usize>,
    /// The node probes' phasors (m) per sample, `2 node_probes.len()` each,
    /// `y, z` per node; empty when there are no node probes.
    pub node_q: Vec<Vec<Complex64>>,
}

/// How the phasors are written in the CSV columns.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum CsvLayout {
    /// `bK_y_re, bK_y_im, bK_z_re, bK_z_im` (the default).
    #[default]
    Complex,
    /// `bK_y_amp, bK_y_phase_deg, bK_z_amp, bK_z_phase_deg`.
    AmplitudePhase,
}

/// Error reading or writing a measurement file. Line numbers are 1-based.
#[derive(Debug, Error)]
pub enum MeasurementError {
    /// The file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The operating-system error.
        source: std::io::Error,
    },
    /// No header line at all.
    #[error("no header line (expected `speed_rpm,b1_y_re,...` or `speed_rpm,b1_y_amp,...`)")]
    MissingHeader,
    /// The header is not one of the two accepted forms.
    #[error("line {line}: bad header: {reason}")]
    Header {
        /// Line of the header.
        line: usize,
        /// What is wrong.
        reason: String,
    },
    /// A data row has the wrong number of columns.
    #[error("line {line}: expected {expected} columns (from the header), found {found}")]
    ColumnCount {
        /// Line of the row.
        line: usize,
        /// Columns in the header.
        expected: usize,
        /// Columns in the row.
        found: usize,
    },
    /// A field is not a valid value for its column.
    #[error("line {line}, column {index} ({column}): {reason}")]
    Field {
        /// Line of the row.
        line: usize,
        /// 1-based number of the column.
        index: usize,
        /// Header name of the column.
        column: String,
        /// What is wrong (e.g. `not a number: "abc"`).
        reason: String,
    },
    /// The last data row has no line break: the file was cut short.
    #[error("line {line}: the last row has no line break: the file looks cut short (a complete measurement file ends with a newline)")]
    Truncated {
        /// Line of the last row.
        line: usize,
    },
    /// More data rows than [`MAX_ROWS`].
    #[error("line {line}: more than {max} data rows")]
    TooManyRows {
        /// Line of the first row beyond the limit.
        line: usize,
        /// The limit.
        max: usize,
    },
    /// The header is followed by no data rows.
    #[error("no data rows after the header")]
    NoData,
    /// The `# conventions:` line (SPEC section 7) is not valid: an unknown
    /// key or value, a key given twice, a second such line, or one after
    /// the header.
    #[error("line {line}: {source}")]
    Conventions {
        /// Line of the `# conventions:` line.
        line: usize,
        /// What is wrong.
        source: ConventionsError,
    },
    /// A bad `# sweep:` line.
    #[error("line {line}: bad `# sweep: rate_rpm_per_s=<value>` line: {reason}")]
    Sweep {
        /// Line of the `# sweep:` line.
        line: usize,
        /// What is wrong.
        reason: String,
    },
    /// A comment to write would read back as a `# conventions:` line,
    /// while the writer writes rotorid's own conventions.
    #[error("comment {} (counting from 1) would read back as a `# conventions:` line (the writer writes metres, 0-pk, arg Y; leave that line out)", index + 1)]
    ConventionsComment {
        /// 0-based index of the comment.
        index: usize,
    },
    /// The measurements to write are inconsistent.
    #[error("sample {} (counting from 1): {reason}", index + 1)]
    Inconsistent {
        /// 0-based sample index.
        index: usize,
        /// What is wrong.
        reason: String,
    },
}

/// Header names of the `2 N_b` channels' columns for a layout.
pub fn header_columns(n_bearings: usize, layout: CsvLayout) -> Vec<String> {
    named_header_columns(&default_channel_names(n_bearings), layout)
}

/// The SPEC's channel names `b1_y, b1_z, b2_y, ...` of `n_bearings`
/// bearings.
pub fn default_channel_names(n_bearings: usize) -> Vec<String> {
    (1..=n_bearings)
        .flat_map(|b| [format!("b{b}_y"), format!("b{b}_z")])
        .collect()
}

/// The channel names of a model's bearings, two per bearing in bearing
/// order: the names of its declared probes ([`ProbePair`]), or `bK_y`,
/// `bK_z` for a bearing without.
pub fn model_channel_names(probes: &[Option<ProbePair>]) -> Vec<String> {
    let defaults = default_channel_names(probes.len());
    probes
        .iter()
        .enumerate()
        .flat_map(|(b, p)| match p {
            Some(p) => p.names.clone(),
            None => [defaults[2 * b].clone(), defaults[2 * b + 1].clone()],
        })
        .collect()
}

/// Header (with `speed_rpm`) of channels named `names` (`<name>_re,
/// <name>_im` or `<name>_amp,<name>_phase_deg` each).
pub fn named_header_columns(names: &[String], layout: CsvLayout) -> Vec<String> {
    let mut cols = vec!["speed_rpm".to_string()];
    for n in names {
        match layout {
            CsvLayout::Complex => {
                cols.push(format!("{n}_re"));
                cols.push(format!("{n}_im"));
            }
            CsvLayout::AmplitudePhase => {
                cols.push(format!("{n}_amp"));
                cols.push(format!("{n}_phase_deg"));
            }
        }
    }
    cols
}

/// Replaces, at every sample, the readings of each bearing's declared
/// probes (in its two channels, as read from a probe-named file) by the
/// shaft's `Y`, `Z` there ([`ProbePair::to_yz`]). `probes` has one entry per
/// bearing; bearings without probes are left as they are.
pub fn probes_to_yz(m: &mut Measurements, probes: &[Option<ProbePair>]) {
    for s in &mut m.samples {
        for (b, p) in probes.iter().enumerate() {
            if let (Some(p), Some(q)) = (p, s.q.get_mut(2 * b..2 * b + 2)) {
                let yz = p.to_yz([q[0], q[1]]);
                q.copy_from_slice(&yz);
            }
        }
    }
}

/// The inverse of [`probes_to_yz`]: each declared probe pair's readings
/// ([`ProbePair::readings`]) in place of the bearing's `Y`, `Z`.
pub fn yz_to_probes(m: &mut Measurements, probes: &[Option<ProbePair>]) {
    for s in &mut m.samples {
        for (b, p) in probes.iter().enumerate() {
            if let (Some(p), Some(q)) = (p, s.q.get_mut(2 * b..2 * b + 2)) {
                let r = p.readings(q[0], q[1]);
                q.copy_from_slice(&r);
            }
        }
    }
}

/// Recognises a header line; returns N_b, the layout and the node probes
/// (0-based nodes). With `channels`, the bearing columns are those
/// channels' (`<name>_re`, ...), `channels.len() / 2` bearings.
fn parse_header(
    line_no: usize,
    line: &str,
    channels: Option<&[String]>,
) -> Result<(usize, CsvLayout, Vec<usize>), MeasurementError> {
    let cols: Vec<&str> = line.split(',').map(str::trim).collect();
    let bad = |reason: String| MeasurementError::Header {
        line: line_no,
        reason,
    };
    if cols.first() != Some(&"speed_rpm") {
        return Err(bad(format!(
            "first column must be `speed_rpm`, found `{}`",
            clip(cols.first().copied().unwrap_or(""))
        )));
    }
    let n_bearing_cols = match channels {
        Some(names) => (2 * names.len()).min(cols.len() - 1),
        None => cols[1..].iter().take_while(|c| c.starts_with('b')).count(),
    };
    let n_node_cols = cols.len() - 1 - n_bearing_cols;
    if n_bearing_cols == 0 || n_bearing_cols % 4 != 0 {
        return Err(bad(format!(
            "expected 4 columns per bearing after `speed_rpm`, found {n_bearing_cols}"
        )));
    }
    if n_node_cols % 4 != 0 {
        return Err(bad(format!(
            "expected 4 columns per node probe after the bearing columns, found {n_node_cols}"
        )));
    }
    let n_b = n_bearing_cols / 4;
    let layout = if cols[1].ends_with("_amp") {
        CsvLayout::AmplitudePhase
    } else {
        CsvLayout::Complex
    };
    let mut nodes = Vec::with_capacity(n_node_cols / 4);
    for (g, group) in cols[1 + n_bearing_cols..].chunks_exact(4).enumerate() {
        let first = 2 + n_bearing_cols + 4 * g;
        let node = group[0]
            .strip_prefix('n')
            .and_then(|r| r.split_once('_'))
            .and_then(|(n, _)| n.parse::<usize>().ok())
            .filter(|&n| n >= 1)
            .ok_or_else(|| {
                bad(format!(
                    "column {first} must be a bearing or node-probe column (`nN_y_re`, N from 1), found `{}`",
                    clip(group[0])
                ))
            })?;
        if nodes.contains(&(node - 1)) {
            return Err(bad(format!("column {first}: node {node} appears twice")));
        }
        nodes.push(node - 1);
    }
    let bearing_header = match channels {
        Some(names) => named_header_columns(names, layout),
        None => header_columns(n_b, layout),
    };
    let expected: Vec<String> = bearing_header
        .into_iter()
        .chain(node_probe_columns(&nodes, layout))
        .collect();
    for (i, (got, want)) in cols.iter().zip(expected.iter()).enumerate() {
        if got != want {
            return Err(bad(format!(
                "column {} must be `{want}`, found `{}`",
                i + 1,
                clip(got)
            )));
        }
    }
    Ok((n_b, layout, nodes))
}

/// Parses the text of a measurement file.
pub fn parse_csv(text: &str) -> Result<Measurements, MeasurementError> {
    parse_csv_located(text).map(|(m, _)| m)
}

/// Where the samples of a parsed file came from (for messages about a
/// sample: line and column, 1-based).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct CsvLocations {
    /// 1-based line of every sample.
    pub lines: Vec<usize>,
    /// The file's column layout.
    pub layout: CsvLayout,
    /// The channels' names in the file (`b1_y`, ... or probe names); empty
    /// means the SPEC's `b1_y, b1_z, ...`.
    pub channels: Vec<String>,
    /// The per-sample standard deviations of the file's `_std` columns (m,
    /// SPEC section 7): per sample, one per channel (bearing channels, then
    /// node probes); empty when the file has none.
    pub sample_std: Vec<Vec<f64>>,
    /// The conventions the values were read in and turned from (the
    /// file's `# conventions:` line under any overrides; rotorid's own
    /// without either).
    pub conventions: Conventions,
    /// 1-based line of the file's `# conventions:` line, if it has one.
    pub conventions_line: Option<usize>,
    /// The sweep rate of the file's `# sweep: rate_rpm_per_s=<value>` line
    /// (rpm/s, negative on a coast-down; [`parse_sweep_comment`]), if it
    /// has one.
    pub sweep_rate_rpm_per_s: Option<f64>,
}

impl CsvLocations {
    /// 1-based column number and header name of the column holding the
    /// real part (complex layout) or the amplitude (amplitude/phase
    /// layout) of channel `ch` (0-based, `b1_y, b1_z, b2_y, ...`).
    pub fn channel_column(&self, ch: usize) -> (usize, String) {
        let base = match self.channels.get(ch) {
            Some(n) => n.clone(),
            None => {
                let b = ch / 2 + 1;
                let dir = if ch % 2 == 0 { "y" } else { "z" };
                format!("b{b}_{dir}")
            }
        };
        let name = match self.layout {
            CsvLayout::Complex => format!("{base}_re"),
            CsvLayout::AmplitudePhase => format!("{base}_amp"),
        };
        let per = if self.sample_std.is_empty() { 2 } else { 3 };
        (2 + per * ch, name)
    }
}

/// The sweep rate of a comment (the text after `#`) of the form `sweep:
/// rate_rpm_per_s=<value>` (spaces around the parts allowed): `None` for
/// any other comment, `Some(Err(reason))` for a `sweep:` comment whose
/// value is not a finite number or that names another key. The rate is in
/// rpm/s, negative on a coast-down; `identify` and `diagnose` warn when it
/// passes a critical speed too fast for the steady-state model
/// ([`crate::campbell::sweep_rate_warnings`]).
pub fn parse_sweep_comment(comment: &str) -> Option<Result<f64, String>> {
    let rest = comment.trim().strip_prefix("sweep:")?;
    let rest = rest.trim();
    let Some(v) = rest.strip_prefix("rate_rpm_per_s") else {
        return Some(Err(format!(
            "expected `rate_rpm_per_s=<value>`, found `{}`",
            clip(rest)
        )));
    };
    let Some(v) = v.trim_start().strip_prefix('=') else {
        return Some(Err("expected `=` after `rate_rpm_per_s`".into()));
    };
    let v = v.trim();
    Some(match v.parse::<f64>() {
        Ok(r) if r.is_finite() => Ok(r),
        _ => Err(format!("rate `{}` is not a finite number", clip(v))),
    })
}

/// [`parse_csv`], also returning where every sample came from.
pub fn parse_csv_located(text: &str) -> Result<(Measurements, CsvLocations), MeasurementError> {
    parse_csv_channels(text, None)
}

/// [`parse_csv_located`] of a file whose bearing columns are the channels
/// `channels` (two per bearing, e.g. [`model_channel_names`]: probe names
/// `<name>_re,<name>_im` or `<name>_amp,<name>_phase_deg`), in that order;
/// `None` is the SPEC's header. The phasors are the columns' values in the
/// file's conventions turned into rotorid's (probe readings: see
/// [`probes_to_yz`]).
pub fn parse_csv_channels(
    text: &str,
    channels: Option<&[String]>,
) -> Result<(Measurements, CsvLocations), MeasurementError> {
    parse_csv_conventions(text, channels, &DeclaredConventions::default())
}

/// [`parse_csv_channels`] with the conventions `overrides` (the command
/// line's `--amplitude-unit`, `--amplitude`, `--phase`) over the file's
/// `# conventions:` line, key by key. The values are read in
/// `Conventions::default().with(file_line).with(overrides)` and turned
/// into rotorid's ([`Conventions::polar_to_internal`],
/// [`Conventions::phasor_to_internal`]; `_std` columns by
/// [`Conventions::amplitude_to_metres`]), node probes included. A file
/// without the line and no overrides reads bit for bit as rotorid's own.
pub fn parse_csv_conventions(
    text: &str,
    channels: Option<&[String]>,
    overrides: &DeclaredConventions,
) -> Result<(Measurements, CsvLocations), MeasurementError> {
    let mut declared: Option<(usize, DeclaredConventions)> = None;
    let mut conventions = Conventions::default();
    let mut header_line = 0;
    let mut sweep: Option<(usize, f64)> = None;
    let mut comments = Vec::new();
    let mut header: Option<(usize, CsvLayout, Vec<String>)> = None;
    let mut node_probes = Vec::new();
    let mut node_q = Vec::new();
    let mut samples = Vec::new();
    let mut lines = Vec::new();
    let mut file_layout = CsvLayout::default();
    // A byte-order mark (spreadsheet exports) is not part of the header.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut last_row_line = None;
    let mut kept: Vec<usize> = Vec::new();
    let mut std_names: Vec<(usize, String)> = Vec::new();
    let mut sample_std: Vec<Vec<f64>> = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line_no = i + 1;
        let line = raw.trim();
        if line.is_empty() {
            continue;
        }
        if let Some(c) = line.strip_prefix('#') {
            if let Some(d) = parse_conventions_comment(c) {
                let err = |source| MeasurementError::Conventions {
                    line: line_no,
                    source,
                };
                if header.is_some() {
                    return Err(err(ConventionsError::AfterHeader {
                        header: header_line,
                    }));
                }
                if let Some((first, _)) = declared {
                    return Err(err(ConventionsError::SecondLine { first }));
                }
                declared = Some((line_no, d.map_err(err)?));
                continue;
            }
            if let Some(r) = parse_sweep_comment(c) {
                let rate = r.map_err(|reason| MeasurementError::Sweep {
                    line: line_no,
                    reason,
                })?;
                if let Some((first, _)) = sweep {
                    return Err(MeasurementError::Sweep {
                        line: line_no,
                        reason: format!("a second `# sweep:` line (the first is line {first})"),
                    });
                }
                sweep = Some((line_no, rate));
            }
            comments.push(c.strip_prefix(' ').unwrap_or(c).to_string());
            continue;
        }
        let Some((n_b, layout, names)) = &header else {
            // `_std` columns (SPEC section 7): every channel's or none.
            let (stripped, std_cols) = std_columns(line_no, line)?;
            kept = (0..line.split(',').count())
                .filter(|i| !std_cols.iter().any(|(c, _)| c == i))
                .collect();
            std_names = std_cols;
            let (n_b, layout, nodes) = parse_header(line_no, &stripped, channels)?;
            let bearing_header = match channels {
                Some(c) => named_header_columns(c, layout),
                None => header_columns(n_b, layout),
            };
            let names = bearing_header
                .into_iter()
                .chain(node_probe_columns(&nodes, layout))
                .collect();
            header = Some((n_b, layout, names));
            node_probes = nodes;
            file_layout = layout;
            header_line = line_no;
            let file = declared.map(|(_, d)| d).unwrap_or_default();
            conventions = Conventions::default().with(&file.overridden_by(overrides));
            continue;
        };
        if samples.len() == MAX_ROWS {
            return Err(MeasurementError::TooManyRows {
                line: line_no,
                max: MAX_ROWS,
            });
        }
        let all: Vec<&str> = line.split(',').map(str::trim).collect();
        if all.len() != names.len() + std_names.len() {
            return Err(MeasurementError::ColumnCount {
                line: line_no,
                expected: names.len() + std_names.len(),
                found: all.len(),
            });
        }
        if !std_names.is_empty() {
            sample_std.push(row_std(line_no, &all, &std_names, &conventions)?);
        }
        let fields: Vec<&str> = kept.iter().map(|&i| all[i]).collect();
        let values = row_values(line_no, &fields, names, &kept)?;
        let mut q = values[1..]
            .chunks_exact(2)
            .map(|p| match layout {
                CsvLayout::Complex => conventions.phasor_to_internal(Complex64::new(p[0], p[1])),
                CsvLayout::AmplitudePhase => conventions.polar_to_internal(p[0], p[1]),
            })
            .collect::<Vec<_>>();
        debug_assert_eq!(q.len(), 2 * n_b + 2 * node_probes.len());
        let omega = row_omega(line_no, &values, &q, &fields, names, &kept)?;
        if !node_probes.is_empty() {
            node_q.push(q.split_off(2 * n_b));
        }
        samples.push(Sample { omega, q });
        lines.push(line_no);
        last_row_line = Some(line_no);
    }
    let Some((n_bearings, _, _)) = header else {
        return Err(MeasurementError::MissingHeader);
    };
    if samples.is_empty() {
        return Err(MeasurementError::NoData);
    }
    // The last data row must end with a line break (only trailing blank or
    // comment lines may follow it, themselves ended or not).
    if let Some(line) = last_row_line {
        let ended = text
            .split_inclusive('\n')
            .nth(line - 1)
            .is_some_and(|l| l.ends_with('\n'));
        if !ended {
            return Err(MeasurementError::Truncated { line });
        }
    }
    Ok((
        Measurements {
            comments,
            n_bearings,
            samples,
            node_probes,
            node_q,
        },
        CsvLocations {
            lines,
            layout: file_layout,
            channels: channels.map(<[String]>::to_vec).unwrap_or_default(),
            sample_std,
            conventions,
            conventions_line: declared.map(|(l, _)| l),
            sweep_rate_rpm_per_s: sweep.map(|(_, r)| r),
        },
    ))
}

/// The `_std` values of a data row (`all`, every field of line `line_no`)
/// in metres 0-pk: the columns `std_names` (0-based index, name), each
/// finite and > 0 in the file's `conventions` and in metres.
fn row_std(
    line_no: usize,
    all: &[&str],
    std_names: &[(usize, String)],
    conventions: &Conventions,
) -> Result<Vec<f64>, MeasurementError> {
    let mut row = Vec::with_capacity(std_names.len());
    for (col, name) in std_names {
        let f = all[*col];
        let v: f64 = f.parse().map_err(|_| MeasurementError::Field {
            line: line_no,
            index: col + 1,
            column: name.clone(),
            reason: format!("not a number: {:?}", clip(f)),
        })?;
        if !(v.is_finite() && v > 0.0) {
            return Err(MeasurementError::Field {
                line: line_no,
                index: col + 1,
                column: name.clone(),
                reason: format!(
                    "a standard deviation must be finite and > 0, got {}",
                    clip(f)
                ),
            });
        }
        // In metres, 0-pk: a huge rms value or a subnormal one in
        // mils can leave the finite positive range.
        let metres = conventions.amplitude_to_metres(v);
        if !(metres.is_finite() && metres > 0.0) {
            return Err(MeasurementError::Field {
                line: line_no,
                index: col + 1,
                column: name.clone(),
                reason: format!(
                    "{} ({} {}) is {metres:e} m, not a standard deviation",
                    clip(f),
                    conventions.amplitude_unit,
                    conventions.amplitude
                ),
            });
        }
        row.push(metres);
    }
    Ok(row)
}

/// 1-based column in the file of the `i`-th (0-based) of the `kept` (value)
/// fields.
fn file_column(kept: &[usize], i: usize) -> usize {
    kept.get(i).map_or(i, |k| *k) + 1
}

/// The numbers of a data row's value `fields` (columns `names`; `kept`:
/// their 0-based columns in the file), finite, speeds and amplitudes >= 0.
fn row_values(
    line_no: usize,
    fields: &[&str],
    names: &[String],
    kept: &[usize],
) -> Result<Vec<f64>, MeasurementError> {
    let mut values = Vec::with_capacity(fields.len());
    for (col, (f, name)) in fields.iter().zip(names.iter()).enumerate() {
        let field_err = |reason: String| MeasurementError::Field {
            line: line_no,
            index: file_column(kept, col),
            column: name.clone(),
            reason,
        };
        let v: f64 = f
            .parse()
            .map_err(|_| field_err(format!("not a number: {:?}", clip(f))))?;
        if !v.is_finite() {
            return Err(field_err(format!("not finite: {:?}", clip(f))));
        }
        if (name == "speed_rpm" || name.ends_with("_amp")) && v < 0.0 {
            return Err(field_err(format!("must be >= 0, got {}", clip(f))));
        }
        values.push(v);
    }
    Ok(values)
}

/// A data row's speed (rad/s) from its `values`, once it and the row's
/// phasors `q` are found finite (`fields`, `names`, `kept` as for
/// [`row_values`], to name the culprit).
fn row_omega(
    line_no: usize,
    values: &[f64],
    q: &[Complex64],
    fields: &[&str],
    names: &[String],
    kept: &[usize],
) -> Result<f64, MeasurementError> {
    let omega = rpm_to_rad_s(values[0]);
    if !omega.is_finite() {
        return Err(MeasurementError::Field {
            line: line_no,
            index: 1,
            column: "speed_rpm".into(),
            reason: format!("too large: {}", clip(fields[0])),
        });
    }
    if let Some(col) = q
        .iter()
        .position(|z| !(z.re.is_finite() && z.im.is_finite()))
    {
        // An amplitude near f64::MAX times cos/sin of its phase.
        return Err(MeasurementError::Field {
            line: line_no,
            index: file_column(kept, 1 + 2 * col),
            column: names[1 + 2 * col].clone(),
            reason: format!("too large: {}", clip(fields[1 + 2 * col])),
        });
    }
    Ok(omega)
}

/// The header `line` without its `_std` columns, and those columns (0-based
/// index, name). A channel's `_std` column follows its two value columns
/// (`b1_y_re,b1_y_im,b1_y_std` or `b1_y_amp,b1_y_phase_deg,b1_y_std`); a
/// file has them for every channel or for none.
fn std_columns(
    line_no: usize,
    line: &str,
) -> Result<(String, Vec<(usize, String)>), MeasurementError> {
    let cols: Vec<&str> = line.split(',').map(str::trim).collect();
    if !cols.iter().any(|c| c.ends_with("_std")) {
        return Ok((line.to_string(), Vec::new()));
    }
    let bad = |reason: String| MeasurementError::Header {
        line: line_no,
        reason,
    };
    if (cols.len() - 1) % 3 != 0 {
        return Err(bad(
            "with `_std` columns every channel needs its two value columns and its `_std` column"
                .into(),
        ));
    }
    let mut std = Vec::new();
    let mut kept = vec![cols[0]];
    for (g, group) in cols[1..].chunks_exact(3).enumerate() {
        let first = group[0];
        let channel = first
            .strip_suffix("_re")
            .or_else(|| first.strip_suffix("_amp"))
            .unwrap_or(first);
        let want = format!("{channel}_std");
        if group[2] != want {
            return Err(bad(format!(
                "column {} must be `{want}` (a file has `_std` columns for every channel or for none), found `{}`",
                2 + 3 * g + 2,
                clip(group[2])
            )));
        }
        kept.extend_from_slice(&group[..2]);
        std.push((1 + 3 * g + 2, want));
    }
    Ok((kept.join(","), std))
}

/// Reads a measurement file.
pub fn read_csv(path: impl AsRef<Path>) -> Result<Measurements, MeasurementError> {
    read_csv_located(path).map(|(m, _)| m)
}

/// Largest magnitude (m) of a measured response component a measurement
/// file may hold: a 1X bearing vibration beyond a metre is not a
/// measurement (values are in metres), and larger values would overflow
/// the identification's products in single precision.
pub const MAX_RESPONSE_M: f64 = 1.0;

/// A measurement file read for a model ([`read_for_model`]).
#[derive(Debug, Clone, PartialEq)]
pub struct ModelMeasurements {
    /// The samples, in the shaft's `y`, `z` at every bearing (probe
    /// readings turned by [`probes_to_yz`]).
    pub measurements: Measurements,
    /// The file's per-sample standard deviations in the same channels (m;
    /// a probe pair at an angle gives each of `y`, `z` the pair's mean
    /// variance, exact for orthogonal probes of equal noise); empty when
    /// the file has none.
    pub sample_std: Vec<Vec<f64>>,
    /// Where every value stood in the file (for messages).
    pub located: CsvLocations,
    /// Whether the file held probe readings (named by probe).
    pub probe_readings: bool,
}

/// Reads the measurement file `path` for the model `file`. Without declared
/// probes this is [`read_csv_located`] (the SPEC header). With probes
/// ([`crate::model::ProbePair`]) the bearing columns are named by channel
/// ([`model_channel_names`]: probe names, `bK_y`, `bK_z` for bearings
/// without); a file with the SPEC's `y`, `z` header is also accepted.
/// Probe readings are turned into the shaft's `y`, `z`
/// ([`probes_to_yz`]). A response component beyond [`MAX_RESPONSE_M`] is
/// refused with its line and column.
pub fn read_for_model(
    path: &std::path::Path,
    file: &crate::io::model_file::ModelFile,
) -> Result<ModelMeasurements, MeasurementError> {
    read_for_model_with(path, file, &DeclaredConventions::default())
}

/// [`read_for_model`] with the conventions `overrides` over the file's
/// `# conventions:` line ([`parse_csv_conventions`]): `identify` and
/// `diagnose` pass their `--amplitude-unit`, `--amplitude`, `--phase`.
pub fn read_for_model_with(
    path: &std::path::Path,
    file: &crate::io::model_file::ModelFile,
    overrides: &DeclaredConventions,
) -> Result<ModelMeasurements, MeasurementError> {
    let (mut measurements, located, probe_readings) = if !file.has_probes() {
        let (m, l) = read_csv_conventions(path, None, overrides)?;
        (m, l, false)
    } else {
        let names = model_channel_names(&file.probes);
        match read_csv_conventions(path, Some(&names), overrides) {
            Ok((m, l)) => (m, l, true),
            Err(named @ MeasurementError::Header { .. }) => {
                match read_csv_conventions(path, None, overrides) {
                    Ok((m, l)) => (m, l, false),
                    Err(_) => return Err(named),
                }
            }
            Err(e) => return Err(e),
        }
    };
    check_response_range(&measurements, &located)?;
    let mut sample_std = located.sample_std.clone();
    if probe_readings {
        probes_to_yz(&mut measurements, &file.probes);
        for row in &mut sample_std {
            for (b, p) in file.probes.iter().enumerate() {
                if let (Some(_), Some(pair)) = (p, row.get_mut(2 * b..2 * b + 2)) {
                    let v = (0.5 * (pair[0] * pair[0] + pair[1] * pair[1])).sqrt();
                    pair.fill(v);
                }
            }
        }
    }
    Ok(ModelMeasurements {
        measurements,
        sample_std,
        located,
        probe_readings,
    })
}

/// Refuses a response component beyond [`MAX_RESPONSE_M`], naming its line
/// and column.
pub fn check_response_range(
    meas: &Measurements,
    located: &CsvLocations,
) -> Result<(), MeasurementError> {
    for (i, s) in meas.samples.iter().enumerate() {
        for (ch, z) in s.q.iter().enumerate() {
            let over = |v: f64| v.abs() > MAX_RESPONSE_M;
            let (re_col, name) = located.channel_column(ch);
            let (index, column, v) = match located.layout {
                CsvLayout::Complex if over(z.re) => (re_col, name, z.re),
                CsvLayout::Complex if over(z.im) => (re_col + 1, name.replace("_re", "_im"), z.im),
                CsvLayout::AmplitudePhase if over(z.norm()) => (re_col, name, z.norm()),
                _ => continue,
            };
            return Err(MeasurementError::Field {
                line: located.lines.get(i).copied().unwrap_or(0),
                index,
                column,
                reason: format!(
                    "{} m is beyond {MAX_RESPONSE_M} m, not a bearing vibration in metres",
                    clip(&format!("{v:e}"))
                ),
            });
        }
    }
    Ok(())
}

/// [`read_csv`], also returning where every sample came from.
pub fn read_csv_located(
    path: impl AsRef<Path>,
) -> Result<(Measurements, CsvLocations), MeasurementError> {
    read_csv_channels(path, None)
}

/// [`read_csv_located`] with the bearing channels named `channels`
/// ([`parse_csv_channels`]).
pub fn read_csv_channels(
    path: impl AsRef<Path>,
    channels: Option<&[String]>,
) -> Result<(Measurements, CsvLocations), MeasurementError> {
    read_csv_conventions(path, channels, &DeclaredConventions::default())
}

/// [`read_csv_channels`] with conventions `overrides` over the file's
/// `# conventions:` line ([`parse_csv_conventions`]).
pub fn read_csv_conventions(
    path: impl AsRef<Path>,
    channels: Option<&[String]>,
    overrides: &DeclaredConventions,
) -> Result<(Measurements, CsvLocations), MeasurementError> {
    let path = path.as_ref();
    let text = std::fs::read_to_string(path).map_err(|source| MeasurementError::Io {
        path: path.display().to_string(),
        source,
    })?;
    parse_csv_conventions(&text, channels, overrides)
}

/// The speed column's value for `omega` (rad/s): rpm rounded to 12
/// significant digits, so that a grid speed such as 1000 rpm, which the
/// rad/s round trip turns into 999.9999999999999, is written as `1000`.
/// The relative change (at most 5e-13) is far below any measurement's.
fn speed_for_file(omega: f64) -> f64 {
    let rpm = rad_s_to_rpm(omega);
    format!("{rpm:.11e}").parse().unwrap_or(rpm)
}

/// Formats measurements as CSV text (comments, header, one row per sample).
///
/// Fails if a sample does not have `2 n_bearings` phasors or holds a
/// non-finite or negative speed or a non-finite phasor.
pub fn to_csv_string(m: &Measurements, layout: CsvLayout) -> Result<String, MeasurementError> {
    if m.node_probes.is_empty() {
        bearing_csv_string(m, layout, None)
    } else {
        to_csv_string_with_node_probes(m, layout, &m.node_probes, &m.node_q)
    }
}

/// The comments, the bearing columns and the rows of [`to_csv_string`].
fn bearing_csv_string(
    m: &Measurements,
    layout: CsvLayout,
    channels: Option<&[String]>,
) -> Result<String, MeasurementError> {
    if let Some(c) = channels {
        if c.len() != 2 * m.n_bearings {
            return Err(MeasurementError::Inconsistent {
                index: 0,
                reason: format!(
                    "{} channel names for {} bearings (expected {})",
                    c.len(),
                    m.n_bearings,
                    2 * m.n_bearings
                ),
            });
        }
    }
    let mut out = String::new();
    for (index, c) in m.comments.iter().enumerate() {
        // A comment containing a line break would break the format.
        for part in c.lines() {
            if parse_conventions_comment(part).is_some() {
                return Err(MeasurementError::ConventionsComment { index });
            }
            let _ = writeln!(out, "# {part}");
        }
    }
    let header = match channels {
        Some(c) => named_header_columns(c, layout),
        None => header_columns(m.n_bearings, layout),
    };
    out.push_str(&header.join(","));
    out.push('\n');
    for (index, s) in m.samples.iter().enumerate() {
        let bad = |reason: String| MeasurementError::Inconsistent { index, reason };
        if s.q.len() != 2 * m.n_bearings {
            return Err(bad(format!(
                "{} phasors for {} bearings (expected {})",
                s.q.len(),
                m.n_bearings,
                2 * m.n_bearings
            )));
        }
        if !(s.omega.is_finite() && s.omega >= 0.0) {
            return Err(bad(format!(
                "speed {} rad/s is not finite and >= 0",
                s.omega
            )));
        }
        if s.q.iter().any(|z| !(z.re.is_finite() && z.im.is_finite())) {
            return Err(bad("non-finite phasor".into()));
        }
        if layout == CsvLayout::AmplitudePhase && s.q.iter().any(|z| !z.norm().is_finite()) {
            // |z| beyond f64::MAX: the amplitude column cannot hold it.
            return Err(bad(
                "a phasor's amplitude exceeds the largest number (use the complex layout)".into(),
            ));
        }
        let _ = write!(out, "{}", speed_for_file(s.omega));
        for z in &s.q {
            match layout {
                CsvLayout::Complex => {
                    let _ = write!(out, ",{:e},{:e}", z.re, z.im);
                }
                CsvLayout::AmplitudePhase => {
                    let _ = write!(out, ",{:e},{:e}", z.norm(), z.arg().to_degrees());
                }
            }
        }
        out.push('\n');
    }
    Ok(out)
}

/// Writes a measurement file.
pub fn write_csv(
    m: &Measurements,
    path: impl AsRef<Path>,
    layout: CsvLayout,
) -> Result<(), MeasurementError> {
    let path = path.as_ref();
    let text = to_csv_string(m, layout)?;
    crate::io::output::write_atomic(path, text.as_bytes()).map_err(|e| match e {
        crate::io::output::OutputError::Io { source, .. } => MeasurementError::Io {
            path: path.display().to_string(),
            source,
        },
        other => MeasurementError::Io {
            path: path.display().to_string(),
            source: std::io::Error::other(other.to_string()),
        },
    })
}

/// Header names of the node-probe columns (SPEC section 6) for shaft
/// nodes `nodes` (0-based; written 1-based): `nN_y_re,nN_y_im,nN_z_re,nN_z_im`
/// per node, or `nN_y_amp,nN_y_phase_deg,nN_z_amp,nN_z_phase_deg`.
pub fn node_probe_columns(nodes: &[usize], layout: CsvLayout) -> Vec<String> {
    let mut cols = Vec::with_capacity(4 * nodes.len());
    for n in nodes {
        for dir in ["y", "z"] {
            let (a, b) = match layout {
                CsvLayout::Complex => ("re", "im"),
                CsvLayout::AmplitudePhase => ("amp", "phase_deg"),
            };
            cols.push(format!("n{}_{dir}_{a}", n + 1));
            cols.push(format!("n{}_{dir}_{b}", n + 1));
        }
    }
    cols
}

/// [`to_csv_string`] with node-probe columns after the bearing columns:
/// for each sample `node_q[i]` holds `2 nodes.len()` phasors (m), `y, z`
/// per node in the order of `nodes` (0-based shaft nodes, distinct),
/// written as [`node_probe_columns`] in the same layout and number format
/// as the bearing columns. With no nodes the text is [`to_csv_string`]'s.
pub fn to_csv_string_with_node_probes(
    m: &Measurements,
    layout: CsvLayout,
    nodes: &[usize],
    node_q: &[Vec<Complex64>],
) -> Result<String, MeasurementError> {
    to_csv_string_channels(m, layout, None, nodes, node_q)
}

/// [`to_csv_string_with_node_probes`] with the bearing channels named
/// `channels` (two per bearing, e.g. probe names; `None`: `b1_y, ...`);
/// the phasors are written as they stand (see [`yz_to_probes`]).
pub fn to_csv_string_channels(
    m: &Measurements,
    layout: CsvLayout,
    channels: Option<&[String]>,
    nodes: &[usize],
    node_q: &[Vec<Complex64>],
) -> Result<String, MeasurementError> {
    let text = bearing_csv_string(m, layout, channels)?;
    if nodes.is_empty() {
        return Ok(text);
    }
    if let Some((i, &n)) = nodes
        .iter()
        .enumerate()
        .find(|(i, n)| nodes[..*i].contains(n))
    {
        return Err(MeasurementError::Inconsistent {
            index: 0,
            reason: format!("node probe {} repeats node {}", i + 1, n + 1),
        });
    }
    if node_q.len() != m.samples.len() {
        return Err(MeasurementError::Inconsistent {
            index: node_q.len().min(m.samples.len()),
            reason: format!(
                "{} node-probe rows for {} samples",
                node_q.len(),
                m.samples.len()
            ),
        });
    }
    // The bearing text is comments, the header, then one row per sample;
    // the node columns are appended to the header and to each row.
    let mut out = String::with_capacity(text.len() * (1 + nodes.len()));
    let mut rows = node_q.iter().enumerate();
    let mut header_done = false;
    for raw in text.split_inclusive('\n') {
        let line = raw.strip_suffix('\n').unwrap_or(raw);
        out.push_str(line);
        if line.starts_with('#') {
            out.push('\n');
            continue;
        }
        if !header_done {
            for c in node_probe_columns(nodes, layout) {
                out.push(',');
                out.push_str(&c);
            }
            header_done = true;
        } else if let Some((index, q)) = rows.next() {
            let bad = |reason: String| MeasurementError::Inconsistent { index, reason };
            if q.len() != 2 * nodes.len() {
                return Err(bad(format!(
                    "{} node-probe phasors for {} nodes (expected {})",
                    q.len(),
                    nodes.len(),
                    2 * nodes.len()
                )));
            }
            for z in q {
                if !(z.re.is_finite() && z.im.is_finite()) {
                    return Err(bad("non-finite node-probe phasor".into()));
                }
                match layout {
                    CsvLayout::Complex => {
                        let _ = write!(out, ",{:e},{:e}", z.re, z.im);
                    }
                    CsvLayout::AmplitudePhase => {
                        if !z.norm().is_finite() {
                            return Err(bad(
                                "a node-probe phasor's amplitude exceeds the largest number (use the complex layout)".into(),
                            ));
                        }
                        let _ = write!(out, ",{:e},{:e}", z.norm(), z.arg().to_degrees());
                    }
                }
            }
        }
        out.push('\n');
    }
    Ok(out)
}

/// [`write_csv`] with node-probe columns ([`to_csv_string_with_node_probes`]),
/// written atomically.
pub fn write_csv_with_node_probes(
    m: &Measurements,
    path: impl AsRef<Path>,
    layout: CsvLayout,
    nodes: &[usize],
    node_q: &[Vec<Complex64>],
) -> Result<(), MeasurementError> {
    write_csv_channels(m, path, layout, None, nodes, node_q)
}

/// [`write_csv_with_node_probes`] with named bearing channels
/// ([`to_csv_string_channels`]), written atomically.
pub fn write_csv_channels(
    m: &Measurements,
    path: impl AsRef<Path>,
    layout: CsvLayout,
    channels: Option<&[String]>,
    nodes: &[usize],
    node_q: &[Vec<Complex64>],
) -> Result<(), MeasurementError> {
    let path = path.as_ref();
    let text = to_csv_string_channels(m, layout, channels, nodes, node_q)?;
    crate::io::output::write_atomic(path, text.as_bytes()).map_err(|e| MeasurementError::Io {
        path: path.display().to_string(),
        source: match e {
            crate::io::output::OutputError::Io { source, .. } => source,
            other => std::io::Error::other(other.to_string()),
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_both_layouts() {
        assert_eq!(
            parse_header(1, "speed_rpm,b1_y_re,b1_y_im,b1_z_re,b1_z_im", None).unwrap(),
            (1, CsvLayout::Complex, vec![])
        );
        assert_eq!(
            parse_header(
                1,
                "speed_rpm, b1_y_amp,b1_y_phase_deg,b1_z_amp,b1_z_phase_deg",
                None
            )
            .unwrap(),
            (1, CsvLayout::AmplitudePhase, vec![])
        );
        assert_eq!(
            parse_header(
                1,
                "speed_rpm,b1_y_re,b1_y_im,b1_z_re,b1_z_im,n14_y_re,n14_y_im,n14_z_re,n14_z_im",
                None
            )
            .unwrap(),
            (1, CsvLayout::Complex, vec![13])
        );
        // Repeated node, node 0, mixed layouts, a short group.
        for bad in [
            "speed_rpm,b1_y_re,b1_y_im,b1_z_re,b1_z_im,n3_y_re,n3_y_im,n3_z_re,n3_z_im,n3_y_re,n3_y_im,n3_z_re,n3_z_im",
            "speed_rpm,b1_y_re,b1_y_im,b1_z_re,b1_z_im,n0_y_re,n0_y_im,n0_z_re,n0_z_im",
            "speed_rpm,b1_y_re,b1_y_im,b1_z_re,b1_z_im,n3_y_amp,n3_y_phase_deg,n3_z_amp,n3_z_phase_deg",
            "speed_rpm,b1_y_re,b1_y_im,b1_z_re,b1_z_im,n3_y_re,n3_y_im",
        ] {
            assert!(parse_header(1, bad, None).is_err(), "{bad}");
        }
        assert!(parse_header(1, "speed_rpm,b1_y_re,b1_y_im,b1_z_im,b1_z_re", None).is_err());
        assert!(parse_header(1, "speed,b1_y_re,b1_y_im,b1_z_re,b1_z_im", None).is_err());
        assert!(parse_header(1, "speed_rpm", None).is_err());
    }
}
