//! The signals configuration: channel roles, sensitivities and the
//! keyphasor edge, from a small TOML file (`--config FILE`) and the
//! command line (which overrides the file key by key).
//!
//! ```toml
//! [keyphasor]
//! source = 4            # WAV channel (0-based), or a CSV column name ("kp")
//! edge = "falling"      # "rising" (default) or "falling"
//! level = -12.0         # optional: the event level (the signal's unit, volts for a WAV)
//! hysteresis = 0.5      # optional: re-armed 0.5 below the level (after the sign turn of "falling")
//!
//! [probes]
//! full_scale_v = 10.0          # WAV: a full-scale sample (1.0) is 10 V
//! sensitivity_v_per_mm = 7.87  # probe sensitivity; then samples are volts
//!
//! [probes.channels]            # measurement channel = source
//! b1_y = 0
//! b1_z = 1
//! b2_y = 2
//! b2_z = 3
//!
//! [probes.sensitivity]         # optional, per channel (V/mm)
//! b2_z = 7.6
//! ```
//!
//! A probe value `v` in volts is `v / (S 1000)` metres for a sensitivity
//! `S` in V/mm (7.87 V/mm is the API 670 standard, 200 mV/mil). A negative
//! sensitivity turns the sign (a probe whose voltage falls as the shaft
//! comes closer). WAV samples are read as `x V_fs` volts, `x` the sample
//! normalised to full scale (integers over `2^(bits - 1)`, floats as they
//! are) and `V_fs` `full_scale_v` (default 1).

use std::collections::BTreeMap;
use std::path::Path;

use serde::Deserialize;
use thiserror::Error;

use super::channels::ChannelName;

/// Where a signal comes from: a WAV channel (0-based) or a CSV column.
#[derive(Debug, Clone, PartialEq, Eq, Deserialize)]
#[serde(untagged)]
pub enum Source {
    /// A channel index (0-based).
    Index(usize),
    /// A column name.
    Name(String),
}

impl std::fmt::Display for Source {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Source::Index(i) => write!(f, "channel {i}"),
            Source::Name(n) => write!(f, "column `{n}`"),
        }
    }
}

/// The keyphasor edge whose crossings are the events.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Edge {
    /// Rising crossings (the default).
    #[default]
    Rising,
    /// Falling crossings (a notch under a proximity probe).
    Falling,
}

/// An error in a signals configuration.
#[derive(Debug, Error)]
pub enum ConfigError {
    /// The file could not be read.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The error.
        source: std::io::Error,
    },
    /// Bad TOML or an unknown key.
    #[error("{path}: {reason}")]
    Toml {
        /// The file.
        path: String,
        /// The parser's message (one line).
        reason: String,
    },
    /// A value out of range or a name that is no channel.
    #[error("{0}")]
    Value(String),
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct FileKeyphasor {
    source: Option<Source>,
    edge: Option<Edge>,
    level: Option<f64>,
    hysteresis: Option<f64>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct FileProbes {
    full_scale_v: Option<f64>,
    sensitivity_v_per_mm: Option<f64>,
    #[serde(default)]
    channels: BTreeMap<String, Source>,
    #[serde(default)]
    sensitivity: BTreeMap<String, f64>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    #[serde(default)]
    keyphasor: FileKeyphasor,
    #[serde(default)]
    probes: FileProbes,
}

/// How to read a signals file beyond the SPEC's CSV layout.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SignalConfig {
    /// The keyphasor's source (`None`: the CSV column `kp`).
    pub kp_source: Option<Source>,
    /// The keyphasor edge.
    pub edge: Edge,
    /// The event level (`None`: midway between the signal's minimum and
    /// maximum), in the signal's unit before the sign turn of a falling
    /// edge.
    pub kp_level: Option<f64>,
    /// The hysteresis (`None`: a tenth of the signal's span).
    pub kp_hysteresis: Option<f64>,
    /// The volts of a full-scale WAV sample (`None`: 1).
    pub full_scale_v: Option<f64>,
    /// Every probe's sensitivity (V/mm); `None`: probe values are metres
    /// (CSV) and a WAV is refused.
    pub sensitivity_v_per_mm: Option<f64>,
    /// Per-channel sensitivities (V/mm) over the common one.
    pub channel_sensitivity: BTreeMap<ChannelName, f64>,
    /// Channel roles: measurement channel and its source.
    pub channels: Vec<(ChannelName, Source)>,
}

fn channel(name: &str) -> Result<ChannelName, ConfigError> {
    ChannelName::parse(name).ok_or_else(|| {
        ConfigError::Value(format!(
            "`{}` is no measurement channel (bK_y, bK_z, nN_y, nN_z)",
            crate::io::clip(name)
        ))
    })
}

impl SignalConfig {
    /// Parses the TOML text of a configuration (`path` names it in errors).
    pub fn from_toml_str(text: &str, path: &str) -> Result<Self, ConfigError> {
        let file: File = toml::from_str(text).map_err(|e| ConfigError::Toml {
            path: path.to_string(),
            reason: e
                .to_string()
                .lines()
                .map(str::trim)
                .filter(|l| !l.is_empty())
                .collect::<Vec<_>>()
                .join("; "),
        })?;
        let mut c = SignalConfig {
            kp_source: file.keyphasor.source,
            edge: file.keyphasor.edge.unwrap_or_default(),
            kp_level: file.keyphasor.level,
            kp_hysteresis: file.keyphasor.hysteresis,
            full_scale_v: file.probes.full_scale_v,
            sensitivity_v_per_mm: file.probes.sensitivity_v_per_mm,
            ..SignalConfig::default()
        };
        for (name, s) in file.probes.sensitivity {
            c.channel_sensitivity.insert(channel(&name)?, s);
        }
        for (name, src) in file.probes.channels {
            c.channels.push((channel(&name)?, src));
        }
        c.validate().map_err(|e| match e {
            ConfigError::Value(r) => ConfigError::Value(format!("{path}: {r}")),
            other => other,
        })?;
        Ok(c)
    }

    /// Reads a configuration file.
    pub fn from_file(path: impl AsRef<Path>) -> Result<Self, ConfigError> {
        let path = path.as_ref();
        let p = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Io {
            path: p.clone(),
            source,
        })?;
        Self::from_toml_str(&text, &p)
    }

    /// Checks the values: sensitivities finite and non-zero, full scale
    /// finite and > 0, level finite, hysteresis finite and >= 0, each
    /// channel and each source once.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let bad = |m: String| Err(ConfigError::Value(m));
        if let Some(v) = self.full_scale_v {
            if !(v.is_finite() && v > 0.0) {
                return bad(format!("full_scale_v must be finite and > 0, got {v}"));
            }
        }
        let sens = self
            .sensitivity_v_per_mm
            .iter()
            .map(|s| ("sensitivity_v_per_mm".to_string(), *s));
        let per = self
            .channel_sensitivity
            .iter()
            .map(|(c, s)| (format!("sensitivity of {c}"), *s));
        for (what, s) in sens.chain(per) {
            if !(s.is_finite() && s != 0.0) {
                return bad(format!(
                    "{what} must be finite and non-zero (V/mm), got {s}"
                ));
            }
        }
        if let Some(l) = self.kp_level {
            if !l.is_finite() {
                return bad(format!("keyphasor level must be finite, got {l}"));
            }
        }
        if let Some(h) = self.kp_hysteresis {
            if !(h.is_finite() && h >= 0.0) {
                return bad(format!(
                    "keyphasor hysteresis must be finite and >= 0, got {h}"
                ));
            }
        }
        for (i, (c, s)) in self.channels.iter().enumerate() {
            if self.channels[..i].iter().any(|(d, _)| d == c) {
                return bad(format!("channel {c} given twice"));
            }
            if self.channels[..i].iter().any(|(_, t)| t == s) || self.kp_source.as_ref() == Some(s)
            {
                return bad(format!("{s} given two roles"));
            }
        }
        Ok(())
    }

    /// `other`'s keys where it has them, this one's elsewhere (the command
    /// line over the file); the channel roles are `other`'s when it has any.
    pub fn with(mut self, other: &SignalConfig) -> Self {
        if other.kp_source.is_some() {
            self.kp_source.clone_from(&other.kp_source);
        }
        if other.edge != Edge::Rising {
            self.edge = other.edge;
        }
        self.kp_level = other.kp_level.or(self.kp_level);
        self.kp_hysteresis = other.kp_hysteresis.or(self.kp_hysteresis);
        self.full_scale_v = other.full_scale_v.or(self.full_scale_v);
        self.sensitivity_v_per_mm = other.sensitivity_v_per_mm.or(self.sensitivity_v_per_mm);
        for (c, s) in &other.channel_sensitivity {
            self.channel_sensitivity.insert(*c, *s);
        }
        if !other.channels.is_empty() {
            self.channels.clone_from(&other.channels);
        }
        self
    }

    /// The factor from a probe value to metres for channel `c`:
    /// `1 / (S 1000)` with its sensitivity `S` (V/mm), `None` when no
    /// sensitivity is given (values are metres).
    pub fn metres_per_unit(&self, c: ChannelName) -> Option<f64> {
        self.channel_sensitivity
            .get(&c)
            .copied()
            .or(self.sensitivity_v_per_mm)
            .map(|s| 1.0 / (s * 1000.0))
    }

    /// Parses the command line's `--channels b1_y=0,b1_z=1,...` (a source
    /// is an index or a column name).
    pub fn parse_channels(list: &str) -> Result<Vec<(ChannelName, Source)>, ConfigError> {
        let mut out = Vec::new();
        for item in list.split(',').map(str::trim).filter(|s| !s.is_empty()) {
            let (name, src) = item.split_once('=').ok_or_else(|| {
                ConfigError::Value(format!(
                    "--channels: `{}` is not CHANNEL=SOURCE (e.g. b1_y=0)",
                    crate::io::clip(item)
                ))
            })?;
            out.push((channel(name.trim())?, Source::parse(src.trim())));
        }
        Ok(out)
    }
}

impl Source {
    /// A number is an index, anything else a column name.
    pub fn parse(s: &str) -> Source {
        s.parse::<usize>()
            .map(Source::Index)
            .unwrap_or_else(|_| Source::Name(s.to_string()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_documented_example_parses() {
        let text = r#"
[keyphasor]
source = 4
edge = "falling"
level = -12.0
hysteresis = 0.5

[probes]
full_scale_v = 10.0
sensitivity_v_per_mm = 7.87

[probes.channels]
b1_y = 0
b1_z = 1
b2_y = 2
b2_z = 3

[probes.sensitivity]
b2_z = 7.6
"#;
        let c = SignalConfig::from_toml_str(text, "x.toml").unwrap();
        assert_eq!(c.kp_source, Some(Source::Index(4)));
        assert_eq!(c.edge, Edge::Falling);
        assert_eq!(c.channels.len(), 4);
        let b2z = ChannelName::parse("b2_z").unwrap();
        assert!((c.metres_per_unit(b2z).unwrap() - 1.0 / 7600.0).abs() < 1e-18);
        let b1y = ChannelName::parse("b1_y").unwrap();
        assert!((c.metres_per_unit(b1y).unwrap() - 1.0 / 7870.0).abs() < 1e-18);
        for bad in [
            "[probes]\nfull_scale_v = 0.0",
            "[probes]\nsensitivity_v_per_mm = 0.0",
            "[probes.channels]\nb1_x = 0",
            "[probes.channels]\nb1_y = 0\nb1_z = 0",
            "[keyphasor]\nsource = 1\n[probes.channels]\nb1_y = 1",
            "[keyphasor]\nwhat = 1",
        ] {
            assert!(SignalConfig::from_toml_str(bad, "x").is_err(), "{bad}");
        }
    }
}
