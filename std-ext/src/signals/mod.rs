//! Recorded signals to 1X vectors: `rotorid vectors`.
//!
//! A recording ([`Recording`]) holds a keyphasor signal and the probes'
//! displacements (m) sampled together at a uniform rate, read from the
//! signals CSV of the SPEC ([`read_csv`]) or from a WAV file ([`read_wav`],
//! channel roles and sensitivities from a [`SignalConfig`]). [`extract()`]
//! runs the core's order tracker (`rotorid_core::ordertrack`, the code the
//! firmware runs) over it in `f64` and returns the averaged 1X vectors per
//! revolution group with standard errors pooled over the sweep
//! ([`noise`]); [`write_vectors`] writes them as the measurement CSV with
//! `_std` columns.

pub mod channels;
pub mod config;
pub mod csv;
pub mod extract;
pub mod noise;
pub mod output;
pub mod wav;

pub use channels::{ChannelName, Direction};
pub use config::{ConfigError, Edge, SignalConfig, Source};
pub use csv::{read_csv, read_csv_with};
pub use extract::{extract, ExtractError, ExtractOptions, VectorRow, Vectors};
pub use output::{vectors_csv_string, write_vectors};
pub use wav::{read_wav, read_wav_with};

use thiserror::Error;

/// A recording: the keyphasor and the probe channels, sampled together.
#[derive(Debug, Clone, PartialEq)]
pub struct Recording {
    /// Sample rate `f_s` (Hz).
    pub sample_rate: f64,
    /// The keyphasor signal, one value per sample (its own unit), already
    /// turned so that the event is a rising crossing (a falling edge is
    /// read negated).
    pub kp: Vec<f64>,
    /// The keyphasor level, when given (same sign turn as `kp`); `None`:
    /// midway between the signal's minimum and maximum.
    pub kp_level: Option<f64>,
    /// The probe channels, measurement channel names, in column order.
    pub channels: Vec<ChannelName>,
    /// The probes' displacements (m), row-major: `channels.len()` values
    /// per sample.
    pub probes: Vec<f64>,
}

impl Recording {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.kp.len()
    }

    /// No samples.
    pub fn is_empty(&self) -> bool {
        self.kp.is_empty()
    }

    /// Duration `len / f_s` (s).
    pub fn duration(&self) -> f64 {
        self.len() as f64 / self.sample_rate
    }
}

/// An error reading a signals file.
#[derive(Debug, Error)]
pub enum SignalsError {
    /// The file could not be read.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The error.
        source: std::io::Error,
    },
    /// The file is not a signals file this reader knows.
    #[error("{0}")]
    Format(String),
    /// A bad row (1-based line number).
    #[error("line {line}: {reason}")]
    Row {
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        reason: String,
    },
    /// Time not uniform or not increasing (1-based line number).
    #[error("line {line}: {reason}")]
    Time {
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        reason: String,
    },
    /// The configuration does not fit the file.
    #[error(transparent)]
    Config(#[from] ConfigError),
}

/// Most samples a recording may hold (2^31: about 23 hours at 25.6 kHz; a
/// bound on the memory a file can ask for).
pub const MAX_SAMPLES: usize = 1 << 31;
