//! The signals CSV of the SPEC (section 8):
//!
//! ```text
//! # any number of comment lines starting with '#'
//! time_s,kp,b1_y,b1_z,b2_y,b2_z
//! 0.0000000,0.0,1.2e-6,-3.1e-7,...
//! ```
//!
//! `time_s` in seconds, uniform and increasing; `kp` the keyphasor (any
//! unit); the probe columns named as measurement channels (`bK_y`, `bK_z`,
//! `nN_y`, `nN_z`) in metres. A [`SignalConfig`] may name other columns
//! (`[probes.channels] b1_y = "probe_1x"`, `[keyphasor] source = "tach"`),
//! give volts with a sensitivity, and a falling edge or a level.
//!
//! Time is uniform when every step `t_i - t_(i-1)` is within a quarter of
//! `dt = (t_last - t_0) / (n - 1)` and every `t_i` within a quarter `dt` of
//! the line `t_0 + i dt` (time stamps
//! rounded to a few digits pass; a missing or repeated sample does not).
//! `nan` in a probe or keyphasor field is a dropout (the revolutions it
//! touches are rejected and counted as `non_finite`); an empty field or one
//! that is no number is an error naming its line.

use std::path::Path;

use super::channels::ChannelName;
use super::config::{Edge, SignalConfig, Source};
use super::{Recording, SignalsError, MAX_SAMPLES};

/// Reads the SPEC's signals CSV with no options.
pub fn read_csv(path: impl AsRef<Path>) -> Result<Recording, SignalsError> {
    read_csv_with(path, &SignalConfig::default())
}

/// Reads a signals CSV with a configuration (names, volts, edge).
pub fn read_csv_with(
    path: impl AsRef<Path>,
    config: &SignalConfig,
) -> Result<Recording, SignalsError> {
    let path = path.as_ref();
    let text = std::fs::read_to_string(path).map_err(|source| SignalsError::Io {
        path: path.display().to_string(),
        source,
    })?;
    parse_csv(&text, config)
}

/// The role of a column.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Role {
    Time,
    Kp,
    /// A probe: its index among the probes and the factor to metres.
    Probe(usize, f64),
}

/// The columns' roles from the header.
fn roles(
    header: &[&str],
    config: &SignalConfig,
) -> Result<(Vec<Role>, Vec<ChannelName>), SignalsError> {
    let fmt = |m: String| SignalsError::Format(m);
    let matches = |s: &Source, i: usize, name: &str| match s {
        Source::Index(j) => *j == i,
        Source::Name(n) => n == name,
    };
    let kp_source = config
        .kp_source
        .clone()
        .unwrap_or_else(|| Source::Name("kp".into()));
    let mut roles = Vec::with_capacity(header.len());
    let mut channels = Vec::new();
    for (i, &name) in header.iter().enumerate() {
        let role = if name == "time_s" {
            Role::Time
        } else if matches(&kp_source, i, name) {
            Role::Kp
        } else {
            let mapped = config
                .channels
                .iter()
                .find(|(_, s)| matches(s, i, name))
                .map(|(c, _)| *c);
            let c = match mapped.or_else(|| ChannelName::parse(name)) {
                Some(c) => c,
                None => {
                    return Err(fmt(format!(
                        "line header: unknown column `{}` (expected time_s, kp and probe channels bK_y, bK_z, nN_y, nN_z, or names given in --config)",
                        crate::io::clip(name)
                    )))
                }
            };
            channels.push(c);
            Role::Probe(channels.len() - 1, config.metres_per_unit(c).unwrap_or(1.0))
        };
        if role == Role::Time && roles.contains(&Role::Time) {
            return Err(fmt("column `time_s` appears twice".into()));
        }
        if role == Role::Kp && roles.contains(&Role::Kp) {
            return Err(fmt(format!("keyphasor {kp_source} appears twice")));
        }
        roles.push(role);
    }
    if !roles.contains(&Role::Time) {
        return Err(fmt("no `time_s` column in the header".into()));
    }
    if !roles.contains(&Role::Kp) {
        return Err(fmt(format!(
            "no keyphasor column ({kp_source}; name it `kp` or give [keyphasor] source in --config)"
        )));
    }
    for (c, s) in &config.channels {
        if let Source::Name(n) = s {
            if !header.contains(&n.as_str()) {
                return Err(fmt(format!(
                    "no column `{}` for channel {c}",
                    crate::io::clip(n)
                )));
            }
        }
    }
    super::channels::measurement_order(&channels).map_err(fmt)?;
    Ok((roles, channels))
}

/// Parses the text of a signals CSV.
pub fn parse_csv(text: &str, config: &SignalConfig) -> Result<Recording, SignalsError> {
    config.validate()?;
    let mut lines = text.lines().enumerate().map(|(i, l)| (i + 1, l));
    let (header_line, header) = loop {
        match lines.next() {
            None => {
                return Err(SignalsError::Format(
                    "no header line (time_s,kp,b1_y,...)".into(),
                ))
            }
            Some((_, l)) if l.trim_start().starts_with('#') || l.trim().is_empty() => continue,
            Some((n, l)) => break (n, l),
        }
    };
    let header: Vec<&str> = header.split(',').map(str::trim).collect();
    let (roles, channels) = roles(&header, config).map_err(|e| match e {
        SignalsError::Format(m) => SignalsError::Format(format!(
            "line {header_line}: {}",
            m.trim_start_matches("line header: ")
        )),
        other => other,
    })?;
    let nc = channels.len();
    let sign = if config.edge == Edge::Falling {
        -1.0
    } else {
        1.0
    };
    let mut time = Vec::new();
    let mut line_of = Vec::new();
    let mut kp = Vec::new();
    let mut probes = Vec::new();
    let mut row = vec![0.0; nc];
    for (n, l) in lines {
        if l.trim_start().starts_with('#') || l.trim().is_empty() {
            continue;
        }
        if time.len() >= MAX_SAMPLES {
            return Err(SignalsError::Row {
                line: n,
                reason: format!("more than {MAX_SAMPLES} samples"),
            });
        }
        let mut fields = l.split(',');
        let mut t = f64::NAN;
        let mut k = f64::NAN;
        for (col, role) in roles.iter().enumerate() {
            let f = fields.next().ok_or_else(|| SignalsError::Row {
                line: n,
                reason: format!("{} fields, the header has {}", col, roles.len()),
            })?;
            let f = f.trim();
            let v: f64 = f.parse().map_err(|_| SignalsError::Row {
                line: n,
                reason: format!(
                    "column {} (`{}`): `{}` is not a number",
                    col + 1,
                    header[col],
                    crate::io::clip(f)
                ),
            })?;
            match role {
                Role::Time => t = v,
                Role::Kp => k = v,
                Role::Probe(i, scale) => {
                    if let Some(slot) = row.get_mut(*i) {
                        *slot = v * scale;
                    }
                }
            }
        }
        if fields.next().is_some() {
            return Err(SignalsError::Row {
                line: n,
                reason: format!(
                    "{} fields, the header has {}",
                    l.split(',').count(),
                    roles.len()
                ),
            });
        }
        if !t.is_finite() {
            return Err(SignalsError::Row {
                line: n,
                reason: format!("time {t} is not finite"),
            });
        }
        time.push(t);
        line_of.push(n);
        kp.push(sign * k);
        probes.extend_from_slice(&row);
    }
    let sample_rate = uniform_rate(&time, &line_of)?;
    Ok(Recording {
        sample_rate,
        kp,
        kp_level: config.kp_level.map(|l| sign * l),
        channels,
        probes,
    })
}

/// The sample rate `1 / dt` of uniform, increasing times (see the module
/// documentation); an error names the first line out of step.
fn uniform_rate(time: &[f64], line_of: &[usize]) -> Result<f64, SignalsError> {
    let n = time.len();
    let (Some(&t0), Some(&tn)) = (time.first(), time.last()) else {
        return Err(SignalsError::Format("no data rows".into()));
    };
    if n < 2 {
        return Err(SignalsError::Format("one data row: no sample rate".into()));
    }
    for (i, w) in time.windows(2).enumerate() {
        if let [a, b] = w {
            if b <= a {
                return Err(SignalsError::Time {
                    line: line_of.get(i + 1).copied().unwrap_or(0),
                    reason: format!("time {b} s does not increase (previous {a} s)"),
                });
            }
        }
    }
    let dt = (tn - t0) / (n - 1) as f64;
    for (i, w) in time.windows(2).enumerate() {
        if let [a, b] = w {
            if ((b - a) - dt).abs() > 0.25 * dt {
                return Err(SignalsError::Time {
                    line: line_of.get(i + 1).copied().unwrap_or(0),
                    reason: format!(
                        "time {b} s is not uniform: {} s after the previous sample, the record's interval is {dt} s",
                        b - a
                    ),
                });
            }
        }
    }
    for (i, &t) in time.iter().enumerate() {
        let want = t0 + i as f64 * dt;
        if (t - want).abs() > 0.25 * dt {
            return Err(SignalsError::Time {
                line: line_of.get(i).copied().unwrap_or(0),
                reason: format!(
                    "time {t} s is not uniform: sample {i} of a uniform record is at {want} s (interval {dt} s)"
                ),
            });
        }
    }
    let rate = 1.0 / dt;
    if !(rate.is_finite() && rate > 0.0) {
        return Err(SignalsError::Format(format!(
            "sample interval {dt} s gives no sample rate"
        )));
    }
    Ok(rate)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spec_layout_and_errors() {
        let ok =
            "# rig\ntime_s,kp,b1_y,b1_z\n0.0,0,1e-6,2e-6\n0.001,5,1e-6,2e-6\n0.002,0,nan,2e-6\n";
        let r = parse_csv(ok, &SignalConfig::default()).unwrap();
        assert!((r.sample_rate - 1000.0).abs() < 1e-9);
        assert_eq!(r.probes.len(), 6);
        assert!(r.probes[4].is_nan());
        let err = |t: &str| {
            parse_csv(t, &SignalConfig::default())
                .unwrap_err()
                .to_string()
        };
        assert!(err("time_s,b1_y,b1_z\n0,1,1\n").contains("keyphasor"));
        assert!(err("time_s,kp,b1_y,b1_z,foo\n0,0,1,1,1\n").contains("unknown column `foo`"));
        assert!(err("time_s,kp,b1_y,b1_z\n0,0,1,1\n0.001,0,x,1\n").starts_with("line 3:"));
        assert!(err("time_s,kp,b1_y,b1_z\n0,0,1,1\n0.001,0,1\n").starts_with("line 3:"));
        assert!(err("time_s,kp,b1_y,b1_z\n0,0,1,1\n0.001,0,1,1\n0.002,0,1,1\n0.004,0,1,1\n0.005,0,1,1\n0.006,0,1,1\n0.007,0,1,1\n").starts_with("line 5:"));
        assert!(
            err("time_s,kp,b1_y,b1_z\n0,0,1,1\n0.001,0,1,1\n0.001,0,1,1\n")
                .contains("does not increase")
        );
        assert!(err("time_s,kp,b1_y\n0,0,1\n0.001,0,1\n").contains("b1_z"));
    }
}
