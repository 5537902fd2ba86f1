//! WAV recordings (through the `hound` crate): any number of channels,
//! 16-, 24- or 32-bit integer or 32-bit float samples.
//!
//! A WAV has no channel names and no units: the [`SignalConfig`] says which
//! channel is the keyphasor (`[keyphasor] source = N`, 0-based), which
//! channel is which measurement channel (`[probes.channels] b1_y = 0`), the
//! volts of a full-scale sample (`full_scale_v`, default 1) and the probes'
//! sensitivity (`sensitivity_v_per_mm`). A sample `s` of a `b`-bit integer
//! file is `x = s / 2^(b - 1)` of full scale, a float sample is `x = s`;
//! its value is `x V_fs` volts, `x V_fs / (S 1000)` metres for a probe of
//! sensitivity `S` V/mm. Channels with no role are not read.

use std::path::Path;

use super::channels::ChannelName;
use super::config::{Edge, SignalConfig, Source};
use super::{Recording, SignalsError, MAX_SAMPLES};

/// Reads a WAV recording; the configuration must give the keyphasor
/// channel, the probe channels and the sensitivity.
pub fn read_wav(path: impl AsRef<Path>, config: &SignalConfig) -> Result<Recording, SignalsError> {
    read_wav_with(path, config)
}

/// [`read_wav`] (the same; named like [`super::read_csv_with`]).
pub fn read_wav_with(
    path: impl AsRef<Path>,
    config: &SignalConfig,
) -> Result<Recording, SignalsError> {
    let path = path.as_ref();
    let p = path.display().to_string();
    config.validate()?;
    let fmt = |m: String| SignalsError::Format(m);
    let mut reader = hound::WavReader::open(path).map_err(|e| match e {
        hound::Error::IoError(source) => SignalsError::Io {
            path: p.clone(),
            source,
        },
        other => fmt(format!("not a WAV file this reader knows: {other}")),
    })?;
    let spec = reader.spec();
    let nch = usize::from(spec.channels);
    let index = |s: &Source, what: &str| match s {
        Source::Index(i) if *i < nch => Ok(*i),
        Source::Index(i) => Err(fmt(format!(
            "{what}: channel {i} does not exist (the file has channels 0..{})",
            nch.saturating_sub(1)
        ))),
        Source::Name(n) => Err(fmt(format!(
            "{what}: `{}` is a name, a WAV's channels are numbers (0-based)",
            crate::io::clip(n)
        ))),
    };
    let kp_ch = match &config.kp_source {
        Some(s) => index(s, "keyphasor")?,
        None => {
            return Err(fmt(
                "a WAV file has no channel names: give the keyphasor channel (--kp N or [keyphasor] source = N in --config)".into(),
            ))
        }
    };
    if config.channels.is_empty() {
        return Err(fmt(
            "a WAV file has no channel names: give the probe channels (--channels b1_y=0,... or [probes.channels] in --config)".into(),
        ));
    }
    let mut probe_ch = Vec::with_capacity(config.channels.len());
    let mut channels: Vec<ChannelName> = Vec::with_capacity(config.channels.len());
    let mut scale = Vec::with_capacity(config.channels.len());
    let full_scale = config.full_scale_v.unwrap_or(1.0);
    for (c, s) in &config.channels {
        probe_ch.push(index(s, &c.to_string())?);
        channels.push(*c);
        let m = config.metres_per_unit(*c).ok_or_else(|| {
            fmt(format!(
                "a WAV holds volts: give the probes' sensitivity (--sensitivity V/mm or sensitivity_v_per_mm in --config) for {c}"
            ))
        })?;
        scale.push(m * full_scale);
    }
    super::channels::measurement_order(&channels).map_err(fmt)?;
    let frames = reader.duration() as usize;
    if frames > MAX_SAMPLES {
        return Err(fmt(format!(
            "{frames} samples per channel, more than {MAX_SAMPLES}"
        )));
    }
    let sample_rate = f64::from(spec.sample_rate);
    if sample_rate <= 0.0 {
        return Err(fmt("sample rate 0".into()));
    }
    let sign = if config.edge == Edge::Falling {
        -1.0
    } else {
        1.0
    };
    let kp_scale = sign * full_scale;
    let nc = channels.len();
    let mut kp = Vec::with_capacity(frames);
    let mut probes = Vec::with_capacity(frames * nc);
    let mut row = vec![0.0; nc];
    let mut push = |sample: &dyn Fn(usize) -> f64, kp: &mut Vec<f64>, probes: &mut Vec<f64>| {
        kp.push(sample(kp_ch) * kp_scale);
        for ((slot, &ch), &s) in row.iter_mut().zip(&probe_ch).zip(&scale) {
            *slot = sample(ch) * s;
        }
        probes.extend_from_slice(&row);
    };
    let bad = |e: hound::Error| fmt(format!("{p}: bad sample data: {e}"));
    match (spec.sample_format, spec.bits_per_sample) {
        (f @ (hound::SampleFormat::Float | hound::SampleFormat::Int), 32) => {
            // 32 bits fill their 4-byte container: hound has read the header
            // and left the reader at the samples, which are read whole and
            // decoded frame by frame (hound's per-sample iterator costs
            // several times more).
            let decode: fn([u8; 4]) -> f64 = if f == hound::SampleFormat::Float {
                |b| f64::from(f32::from_le_bytes(b))
            } else {
                |b| f64::from(i32::from_le_bytes(b)) / 2_147_483_648.0
            };
            let frame_bytes = 4 * nch;
            let mut data = Vec::new();
            {
                use std::io::Read;
                reader
                    .into_inner()
                    .take((frames * frame_bytes) as u64)
                    .read_to_end(&mut data)
                    .map_err(|e| fmt(format!("{p}: reading the samples: {e}")))?;
            }
            for frame in data.chunks_exact(frame_bytes) {
                let sample = |ch: usize| {
                    frame
                        .get(4 * ch..4 * ch + 4)
                        .and_then(|b| <[u8; 4]>::try_from(b).ok())
                        .map_or(f64::NAN, decode)
                };
                push(&sample, &mut kp, &mut probes);
            }
        }
        (hound::SampleFormat::Int, b @ (16 | 24)) => {
            let norm = 1.0 / f64::from(1u32 << (b - 1));
            let mut frame = vec![0.0; nch];
            let mut samples = reader.samples::<i32>();
            'frames: loop {
                for slot in frame.iter_mut() {
                    match samples.next() {
                        Some(s) => *slot = f64::from(s.map_err(bad)?) * norm,
                        None => break 'frames,
                    }
                }
                let sample = |ch: usize| frame.get(ch).copied().unwrap_or(f64::NAN);
                push(&sample, &mut kp, &mut probes);
            }
        }
        (f, b) => {
            return Err(fmt(format!(
                "{b}-bit {} samples: a signals WAV has 16-, 24- or 32-bit integer or 32-bit float samples",
                if f == hound::SampleFormat::Float { "float" } else { "integer" }
            )))
        }
    }
    if kp.len() < 2 {
        return Err(fmt("fewer than two samples".into()));
    }
    Ok(Recording {
        sample_rate,
        kp,
        kp_level: config.kp_level.map(|l| sign * l),
        channels,
        probes,
    })
}
