//! The vectors as the measurement CSV (SPEC section 4 with the `_std`
//! columns of section 7): comment lines, then
//! `speed_rpm,b1_y_re,b1_y_im,b1_y_std,...`, one row per revolution group
//! in recording order, values in metres.
//!
//! The comments carry what a later step may read: exactly
//! `# sweep: rate_rpm_per_s=<value>` (the mean sweep rate), the revolution
//! counts (`# revolutions: accepted=.. rejected=..` and
//! `# rejected: no_reference=.. period_jump=.. ...` by cause) and the
//! pooled noise per channel (`# noise: b1_y floor_m=.. relative=..`).

use std::fmt::Write as _;
use std::path::Path;

use super::extract::Vectors;

/// The rejection causes as written, with their counts.
pub fn rejection_counts(v: &Vectors) -> [(&'static str, u64); 7] {
    let c = &v.counts;
    [
        ("no_reference", c.no_reference),
        ("period_jump", c.period_jump),
        ("undersampled", c.undersampled),
        ("speed_range", c.speed_range),
        ("non_finite", c.non_finite),
        ("clipped", c.clipped),
        ("no_event", c.no_event),
    ]
}

/// The CSV text; `source` names the signals file in the first comment.
pub fn vectors_csv_string(v: &Vectors, source: &str) -> String {
    let mut out = String::new();
    let rpm = crate::units::rad_s_to_rpm;
    let _ = writeln!(
        out,
        "# rotorid vectors: {} ({} samples at {} Hz, {} keyphasor events), 1X per group of up to {} revolutions",
        source.replace('\n', " "),
        v.samples,
        v.sample_rate,
        v.events,
        v.rows.iter().map(|r| r.revolutions).max().unwrap_or(0)
    );
    if let Some(rate) = v.sweep_rate_rpm_per_s {
        let _ = writeln!(out, "# sweep: rate_rpm_per_s={rate:.6}");
    }
    let _ = writeln!(
        out,
        "# speed range accepted: {:.3} .. {:.3} rpm",
        rpm(v.speed_range.0),
        rpm(v.speed_range.1)
    );
    let _ = writeln!(
        out,
        "# revolutions: accepted={} rejected={}",
        v.counts.accepted,
        v.counts.rejected()
    );
    let causes: Vec<String> = rejection_counts(v)
        .iter()
        .map(|(k, n)| format!("{k}={n}"))
        .collect();
    let _ = writeln!(out, "# rejected: {}", causes.join(" "));
    let pooled = v.noise.iter().any(Option::is_some);
    if pooled {
        let _ = writeln!(
            out,
            "# std: pooled per channel over the rows, std^2 = 4 (floor^2 + relative^2 |Y|^2) / (samples per revolution * revolutions)"
        );
        for (c, f) in v.channels.iter().zip(&v.noise) {
            if let Some(f) = f {
                let _ = writeln!(
                    out,
                    "# noise: {c} floor_m={:e} relative={:e} rows={}",
                    f.floor, f.relative, f.rows_used
                );
            }
        }
    } else {
        let _ = writeln!(
            out,
            "# std: each row's own revolution-to-revolution scatter"
        );
    }
    out.push_str("speed_rpm");
    for c in &v.channels {
        let _ = write!(out, ",{c}_re,{c}_im,{c}_std");
    }
    out.push('\n');
    for r in &v.rows {
        let _ = write!(out, "{}", rpm(r.omega));
        for (z, s) in r.x1.iter().zip(&r.std) {
            let _ = write!(out, ",{:e},{:e},{:e}", z.re, z.im, s);
        }
        out.push('\n');
    }
    out
}

/// Writes the CSV atomically ([`crate::io::output::write_atomic`]).
pub fn write_vectors(
    v: &Vectors,
    source: &str,
    path: impl AsRef<Path>,
) -> Result<(), crate::io::output::OutputError> {
    crate::io::output::write_atomic(path, vectors_csv_string(v, source).as_bytes())
}
