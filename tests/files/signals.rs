//! `rotorid::signals`: recorded signals to 1X vectors. Synthetic
//! run-downs of two rotors at balance grade G6.3 (the paper rotor through
//! its critical speed near 6111 rpm, ROSS's stepped hollow shaft through
//! its first at 2878 rpm) with a probe gap, 2X and sample noise with a
//! floor: the vectors equal the model's within their reported standard
//! errors; WAV files of every sample format give the CSV's vectors to
//! their quantisation.

use num_complex::Complex64;
use rotorid::model::RotorModel;
use rotorid::signals::{self, ExtractOptions, SignalConfig, Source};
use rotorid::units::rpm_to_rad_s;

use crate::common::signals::{record, Sweep, Synthetic};

/// The paper rotor at G6.3 (at 15000 rpm, as in the other tests).
pub fn paper_g63() -> RotorModel {
    rotorid::simulate::at_balance_grade(&RotorModel::paper(), 6.3, rpm_to_rad_s(15000.0)).unwrap()
}

/// ROSS's stepped hollow shaft on two bearings at G6.3 (at 11000 rpm).
pub fn stepped_g63() -> RotorModel {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/ross/stepped_hollow.toml");
    let mut m = rotorid::io::model_file::model_file_by_name_or_path(path.to_str().unwrap())
        .unwrap()
        .model;
    // Unbalance at its two disks (nodes 4 and 8), 40 degrees apart.
    m.unbalance = vec![
        rotorid::model::Unbalance {
            node: 4,
            me: 1.0,
            phase: 0.3,
        },
        rotorid::model::Unbalance {
            node: 8,
            me: 0.7,
            phase: 1.0,
        },
    ];
    rotorid::simulate::at_balance_grade(&m, 6.3, rpm_to_rad_s(11000.0)).unwrap()
}

/// A recording as the library's [`signals::Recording`].
pub fn recording(s: &Synthetic) -> signals::Recording {
    let channels = s
        .names
        .iter()
        .map(|n| signals::ChannelName::parse(n).unwrap())
        .collect();
    let mut probes = Vec::with_capacity(s.len() * s.y.len());
    for i in 0..s.len() {
        for c in &s.y {
            probes.push(c[i]);
        }
    }
    signals::Recording {
        sample_rate: s.fs,
        kp: s.kp.clone(),
        kp_level: None,
        channels,
        probes,
    }
}

/// Per channel: the RMS over the rows of `|Y - Y_true| / std` (pooled
/// std, then the rows' own), printed.
fn normalised_errors(s: &Synthetic, v: &signals::Vectors) -> (Vec<f64>, Vec<f64>) {
    let nch = v.channels.len();
    let (mut pooled, mut raw) = (vec![0.0; nch], vec![0.0; nch]);
    for r in &v.rows {
        let truth = s.truth(r.time.0, r.time.1);
        for c in 0..nch {
            let e = (r.x1[c] - truth[c]).norm();
            pooled[c] += (e / r.std[c]).powi(2);
            raw[c] += (e / r.std_raw[c]).powi(2);
        }
    }
    let n = v.rows.len() as f64;
    let f = |x: Vec<f64>| x.into_iter().map(|a| (a / n).sqrt()).collect::<Vec<_>>();
    (f(pooled), f(raw))
}

fn check_rotor(model: &RotorModel, sweep: Sweep, name: &str) {
    let s = record(model, &sweep);
    let rec = recording(&s);
    let v = signals::extract(&rec, &ExtractOptions::default(), None).unwrap();
    let (pooled, raw) = normalised_errors(&s, &v);
    let peak = v
        .rows
        .iter()
        .flat_map(|r| r.x1.iter().map(|z| z.norm()))
        .fold(0.0, f64::max);
    println!(
        "{name}: {} rows, {} accepted, {} rejected, peak 1X {:.2} um, sweep {:.2} rpm/s (true {:.2}); RMS |dY|/std pooled {pooled:.3?}, raw {raw:.3?}; noise {:?}",
        v.rows.len(),
        v.counts.accepted,
        v.counts.rejected(),
        peak * 1e6,
        v.sweep_rate_rpm_per_s.unwrap(),
        s.rate_rpm_per_s(),
        v.noise
    );
    assert!(v.rows.len() > 100, "{}", v.rows.len());
    // The first two revolutions have no reference; nothing else is rejected.
    assert_eq!(v.counts.no_reference, 2);
    assert!(v.counts.rejected() <= 3, "{:?}", v.counts);
    for (c, (p, r)) in pooled.iter().zip(&raw).enumerate() {
        assert!((0.7..=1.3).contains(p), "{name} channel {c}: pooled {p}");
        // The rows' own standard errors are right on average too, but each
        // is uncertain by some 40 %.
        assert!((0.6..=1.5).contains(r), "{name} channel {c}: raw {r}");
    }
    let rate = v.sweep_rate_rpm_per_s.unwrap();
    assert!((rate / s.rate_rpm_per_s() - 1.0).abs() < 1e-3, "{rate}");
    // Speeds as recorded: a run-down gives decreasing speeds.
    assert!(v.rows.windows(2).all(|w| w[1].omega < w[0].omega));
    // Every row's speed is the recording's mean speed over its revolutions.
    for r in &v.rows {
        let mid = s.omega(0.5 * (r.time.0 + r.time.1));
        assert!((r.omega / mid - 1.0).abs() < 1e-4, "{} {mid}", r.omega);
    }
}

/// The paper rotor run down through its critical speed: 9000 to 3000 rpm
/// in 24 s at 20 kHz (133 to 400 samples per revolution, never an integer
/// number), 0.5 um floor and 0.5 % relative sample noise.
#[test]
fn paper_rotor_rundown_vectors_within_their_standard_errors() {
    let sweep = Sweep {
        rpm: (9000.0, 3000.0),
        seconds: 24.0,
        fs: 20_000.0,
        floor: 0.5e-6,
        relative: 0.005,
        seed: 11,
    };
    check_rotor(&paper_g63(), sweep, "paper");
}

/// The stepped hollow shaft run down through its first critical speed
/// (2878 rpm): 5000 to 1500 rpm in 24 s at 12.8 kHz, 0.5 um floor and 0.5 %.
#[test]
fn second_rotor_rundown_vectors_within_their_standard_errors() {
    let sweep = Sweep {
        rpm: (5000.0, 1500.0),
        seconds: 24.0,
        fs: 12_800.0,
        floor: 0.5e-6,
        relative: 0.005,
        seed: 12,
    };
    check_rotor(&stepped_g63(), sweep, "stepped hollow");
}

/// A short run-down of the paper rotor for the file round trips.
pub fn short_paper() -> Synthetic {
    record(
        &paper_g63(),
        &Sweep {
            rpm: (7000.0, 5000.0),
            seconds: 4.0,
            fs: 12_800.0,
            floor: 0.5e-6,
            relative: 0.005,
            seed: 5,
        },
    )
}

/// Sensitivity (V/mm) and full scale (V) of the WAV round trips.
const SENS: f64 = 7.87;
const FULL_SCALE: f64 = 20.0;

/// Writes `s` as a WAV: the probes in volts (`SENS`), channels 0..n-1, the
/// keyphasor last, scaled to `FULL_SCALE`.
fn write_wav(s: &Synthetic, path: &std::path::Path, bits: u16, float: bool) {
    let nch = s.y.len() + 1;
    let spec = hound::WavSpec {
        channels: nch as u16,
        sample_rate: s.fs as u32,
        bits_per_sample: bits,
        sample_format: if float {
            hound::SampleFormat::Float
        } else {
            hound::SampleFormat::Int
        },
    };
    let mut w = hound::WavWriter::create(path, spec).unwrap();
    let full = f64::from(1u32 << (bits - 1));
    for i in 0..s.len() {
        for c in 0..nch {
            let volts = if c < s.y.len() {
                s.y[c][i] * SENS * 1000.0
            } else {
                s.kp[i]
            };
            let x = volts / FULL_SCALE;
            if float {
                w.write_sample(x as f32).unwrap();
            } else {
                let q = (x * full).round().clamp(-full, full - 1.0) as i32;
                w.write_sample(q).unwrap();
            }
        }
    }
    w.finalize().unwrap();
}

fn wav_config(nprobes: usize) -> SignalConfig {
    SignalConfig {
        kp_source: Some(Source::Index(nprobes)),
        sensitivity_v_per_mm: Some(SENS),
        full_scale_v: Some(FULL_SCALE),
        channels: (0..nprobes)
            .map(|c| {
                let n = format!("b{}_{}", c / 2 + 1, if c % 2 == 0 { "y" } else { "z" });
                (signals::ChannelName::parse(&n).unwrap(), Source::Index(c))
            })
            .collect(),
        ..SignalConfig::default()
    }
}

/// WAV files, 16-, 24-, 32-bit integer and 32-bit float, give the CSV's
/// vectors: each row within 6 standard deviations of the quantisation's
/// share, `2 q / sqrt(12 M N)` for a step `q` (m) and `M N` samples (the
/// keyphasor's quantisation moves the events by far less; for floats `q`
/// is the rounding at 10 V), and 1e-6 of the amplitude. Full scale 20 V:
/// nothing clips.
#[test]
fn wav_round_trips_give_the_csv_vectors() {
    let s = short_paper();
    let csv = crate::common::tmp("signals.csv");
    std::fs::write(&csv, s.csv()).unwrap();
    let from_csv = signals::extract(
        &signals::read_csv(&csv).unwrap(),
        &ExtractOptions::default(),
        None,
    )
    .unwrap();
    // The CSV (9-decimal time, %e values) against the samples themselves.
    let direct = signals::extract(&recording(&s), &ExtractOptions::default(), None).unwrap();
    assert_eq!(from_csv.rows.len(), direct.rows.len());
    for (a, b) in from_csv.rows.iter().zip(&direct.rows) {
        for (x, y) in a.x1.iter().zip(&b.x1) {
            assert!((x - y).norm() <= 1e-9 * y.norm(), "{x} {y}");
        }
    }
    for (bits, float) in [(16u16, false), (24, false), (32, false), (32, true)] {
        let path = crate::common::tmp(&format!("signals_{bits}_{float}.wav"));
        write_wav(&s, &path, bits, float);
        let rec = signals::read_wav(&path, &wav_config(s.y.len())).unwrap();
        assert_eq!(rec.len(), s.len());
        let v = signals::extract(&rec, &ExtractOptions::default(), None).unwrap();
        assert_eq!(v.rows.len(), from_csv.rows.len(), "{bits} {float}");
        // Quantisation step in metres.
        // (a float's: its rounding at the largest sample, 10 V)
        let step = if float {
            f64::from(f32::EPSILON) * 10.0 / (SENS * 1000.0)
        } else {
            FULL_SCALE / f64::from(1u32 << (bits - 1)) / (SENS * 1000.0)
        };
        let mut worst: f64 = 0.0;
        for (a, b) in v.rows.iter().zip(&from_csv.rows) {
            let m = 2.0 * std::f64::consts::PI * s.fs / b.omega;
            let share = 2.0 * step / (12.0 * m * f64::from(b.revolutions)).sqrt();
            for (x, y) in a.x1.iter().zip(&b.x1) {
                let d = (x - y).norm();
                let bound = 6.0 * share + 1e-6 * y.norm();
                assert!(d <= bound, "{bits} bits float {float}: {d:e} > {bound:e}");
                worst = worst.max(d / bound);
            }
        }
        println!("wav {bits}-bit float {float}: worst difference {worst:.3} of the bound");
    }
}

/// A WAV with no keyphasor role, or no sensitivity, is refused with a
/// message naming what is missing.
#[test]
fn wav_needs_roles_and_sensitivity() {
    let s = short_paper();
    let path = crate::common::tmp("roles.wav");
    write_wav(&s, &path, 16, false);
    let mut c = wav_config(s.y.len());
    c.kp_source = None;
    let e = signals::read_wav(&path, &c).unwrap_err().to_string();
    assert!(e.contains("keyphasor channel"), "{e}");
    let mut c = wav_config(s.y.len());
    c.sensitivity_v_per_mm = None;
    let e = signals::read_wav(&path, &c).unwrap_err().to_string();
    assert!(e.contains("sensitivity"), "{e}");
    let mut c = wav_config(s.y.len());
    c.kp_source = Some(Source::Index(9));
    let e = signals::read_wav(&path, &c).unwrap_err().to_string();
    assert!(e.contains("channel 9 does not exist"), "{e}");
}

/// A missing keyphasor pulse is no vector error: the revolutions around
/// it are rejected as period jumps (three, per the core), the rest agree.
#[test]
fn a_missing_pulse_is_counted_not_averaged() {
    let s = short_paper();
    let mut rec = recording(&s);
    let clean = signals::extract(&rec, &ExtractOptions::default(), None).unwrap();
    // Blank one pulse in the middle.
    let mid = rec.len() / 2;
    let start = (mid..rec.len()).find(|&i| rec.kp[i] > 2.5).unwrap();
    for k in &mut rec.kp[start..start + 60] {
        *k = 0.0;
    }
    let v = signals::extract(&rec, &ExtractOptions::default(), None).unwrap();
    println!("missing pulse: {:?}", v.counts);
    assert_eq!(v.counts.period_jump, 3, "{:?}", v.counts);
    assert_eq!(
        v.counts.accepted + 4,
        clean.counts.accepted,
        "{:?} {:?}",
        v.counts,
        clean.counts
    );
    let _: Complex64 = v.rows[0].x1[0];
}

/// A slow lowest speed asks for a large buffer (`CAP = 2^20`, a 42 MB
/// tracker state for 4 channels, far above a test thread's 2 MiB stack):
/// the tracker is built and run on its own thread and gives the same
/// vectors as with the buffer chosen from the keyphasor.
#[test]
fn a_large_tracker_state_runs_on_its_own_thread() {
    let s = short_paper();
    let rec = recording(&s);
    let small = signals::extract(&rec, &ExtractOptions::default(), None).unwrap();
    let opts = ExtractOptions {
        speed_min_rpm: Some(5.0),
        speed_max_rpm: Some(10_000.0),
        ..ExtractOptions::default()
    };
    let big = signals::extract(&rec, &opts, None).unwrap();
    assert!(big.tracker.1 >= 1 << 20, "{:?}", big.tracker);
    assert!(small.tracker.1 < big.tracker.1);
    assert_eq!(big.rows.len(), small.rows.len());
    for (a, b) in big.rows.iter().zip(&small.rows) {
        assert_eq!(a.x1, b.x1);
    }
}
