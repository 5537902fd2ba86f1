//! Rejections counted by cause: keyphasor faults (a missing pulse, an extra
//! pulse, a pulse train that stops, a non-finite keyphasor sample), clipped
//! and non-finite probe samples, a sample rate too low for the speed, a
//! speed out of range; bad configurations; and random input, finite or
//! not, that must never panic.

use super::*;
use rotorid_core::ordertrack::{Config, ConfigError, Counts, Rejection, Scatter};

const NC: usize = 2;
/// Two revolutions at the test speed (127.4 samples): a missing pulse
/// makes a revolution twice as long, which must fit to be told a period
/// jump (a shorter buffer drops it as `NoEvent`).
const CAP: usize = 300;
const FS: f64 = 6400.0;

fn w0() -> f64 {
    rpm(3000.0 + 10.0 * 2f64.sqrt())
}

fn config<T: Real>(fs: f64) -> Config<T> {
    Config::new(T::lit(fs), T::lit(LEVEL), T::lit(200.0), T::lit(400.0))
        .with_hysteresis(T::lit(HYSTERESIS))
        .with_adc_range(T::lit(-1e-2), T::lit(1e-2))
}

/// The index of the keyphasor pulse nearest the angle.
fn pulse_index(theta: f64) -> i64 {
    ((theta - wrap(theta)) / TAU).round() as i64
}

/// Sample index of the angle (the sample at or before it).
fn sample_at(sig: &Signal<NC>, theta: f64) -> usize {
    (sig.time_of(theta) * sig.fs).floor() as usize
}

/// Runs `revs` revolutions of the steady signal at `fs` through `tracker`,
/// with `edit` applied to each sample; checks the vectors of every accepted
/// revolution and that every revolution is counted once.
fn faulty<T: Real, const C: usize>(
    tracker: &mut OrderTracker<T, NC, C>,
    fs: f64,
    revs: f64,
    tol: f64,
    mut edit: impl FnMut(usize, f64, &mut f64, &mut [f64; NC]),
) -> Counts {
    let sig = Signal::<NC>::steady(fs, w0(), 4);
    let n = (revs * TAU / w0() * fs) as usize;
    let run = run(tracker, n, |i| {
        let th = sig.theta(i);
        let (mut kp, mut y) = sig.sample(i);
        edit(i, th, &mut kp, &mut y);
        (kp, y)
    });
    let counts = *tracker.counts();
    assert_eq!(counts.total(), run.revolutions.len() as u64);
    for r in &run.revolutions {
        if let Ok(o) = &r.result {
            for c in 0..NC {
                let (rel, _) = errors(c64(o.x1[c]), sig.truth(c, 1));
                assert!(rel < tol, "{rel}");
            }
        }
    }
    for cause in [
        Rejection::NoReference,
        Rejection::PeriodJump,
        Rejection::Undersampled,
        Rejection::SpeedRange,
        Rejection::NonFinite,
        Rejection::Clipped,
        Rejection::NoEvent,
    ] {
        let listed = run
            .revolutions
            .iter()
            .filter(|r| r.result.err() == Some(cause))
            .count() as u64;
        assert_eq!(listed, counts.of(cause), "{cause}");
    }
    counts
}

/// `counts` has exactly the rejections `want` (and some accepted).
pub(super) fn expect(counts: Counts, want: &[(Rejection, u64)]) {
    let rejected: u64 = want.iter().map(|w| w.1).sum();
    for &(cause, n) in want {
        assert_eq!(counts.of(cause), n, "{cause}: {counts:?}");
    }
    assert_eq!(counts.rejected(), rejected, "{counts:?}");
    assert!(counts.accepted > 0, "{counts:?}");
}

fn keyphasor_faults<T: Real>() {
    let mk = || OrderTracker::<T, NC, CAP>::new(config(FS)).unwrap();
    // 31.3 revolutions from theta0 = 1 rad: pulses 1..=31, 30 revolutions.
    let revs = 31.3;
    let c = faulty(&mut mk(), FS, revs, 1e-4, |_, _, _, _| {});
    expect(c, &[(Rejection::NoReference, 2)]);
    assert_eq!(c.accepted, 28);

    // Pulse 12 missing: its revolution, the next (against the long one),
    // and the one after (whose angle would use the long one's neighbour).
    let c = faulty(&mut mk(), FS, revs, 1e-4, |_, th, kp, _| {
        if pulse_index(th) == 12 {
            *kp = 0.0;
        }
    });
    expect(
        c,
        &[(Rejection::NoReference, 2), (Rejection::PeriodJump, 3)],
    );
    assert_eq!(c.total(), 29);

    // An extra pulse half a turn after pulse 12.
    let c = faulty(&mut mk(), FS, revs, 1e-4, |_, th, kp, _| {
        if pulse_index(th - PI) == 12 {
            *kp = kp.max(pulse(th - PI));
        }
    });
    expect(
        c,
        &[(Rejection::NoReference, 2), (Rejection::PeriodJump, 4)],
    );
    assert_eq!(c.total(), 31);

    // The pulse train stops after pulse 15 for three buffers, then comes
    // back: the open revolution is dropped once, the chain starts again.
    let sig = Signal::<NC>::steady(FS, w0(), 4);
    let stop = sample_at(&sig, TAU * 15.5);
    let c = faulty(&mut mk(), FS, revs + 6.0, 1e-4, |i, _, kp, _| {
        if (stop..stop + 3 * CAP).contains(&i) {
            *kp = 0.0;
        }
    });
    expect(c, &[(Rejection::NoReference, 4), (Rejection::NoEvent, 1)]);

    // A NaN keyphasor sample in revolution 10: dropped, the chain restarts.
    let nan = sample_at(&sig, TAU * 10.5);
    let c = faulty(&mut mk(), FS, revs, 1e-4, |i, _, kp, _| {
        if i == nan {
            *kp = f64::NAN;
        }
    });
    expect(c, &[(Rejection::NoReference, 4), (Rejection::NonFinite, 1)]);
}

#[test]
fn keyphasor_faults_are_rejected_by_cause_f64() {
    keyphasor_faults::<f64>();
}

#[test]
fn keyphasor_faults_are_rejected_by_cause_f32() {
    keyphasor_faults::<f32>();
}

fn probe_faults<T: Real>() {
    let mk = || OrderTracker::<T, NC, CAP>::new(config(FS)).unwrap();
    let sig = Signal::<NC>::steady(FS, w0(), 4);
    let mid = sample_at(&sig, TAU * 10.5);
    // The sample just before event 20 takes part in revolutions 19 and 20.
    let edge = sample_at(&sig, TAU * 20.0);
    for (bad, cause) in [
        (1e-2, Rejection::Clipped),
        (-1.5e-2, Rejection::Clipped),
        (f64::NAN, Rejection::NonFinite),
        (f64::NEG_INFINITY, Rejection::NonFinite),
    ] {
        let c = faulty(&mut mk(), FS, 31.3, 1e-4, |i, _, _, y| {
            if i == mid || i == edge {
                y[1] = bad;
            }
        });
        expect(c, &[(Rejection::NoReference, 2), (cause, 3)]);
    }
}

#[test]
fn clipped_and_non_finite_probe_samples_f64() {
    probe_faults::<f64>();
}

#[test]
fn clipped_and_non_finite_probe_samples_f32() {
    probe_faults::<f32>();
}

#[test]
fn too_low_a_sample_rate_and_a_speed_out_of_range() {
    // 1200 Hz: 23.9 samples per revolution, below the default 32.
    let mut t = OrderTracker::<f64, NC, 64>::new(config(1200.0)).unwrap();
    let c = faulty(&mut t, 1200.0, 20.0, 0.0, |_, _, _, _| {});
    assert_eq!(c.accepted, 0);
    assert_eq!((c.no_reference, c.undersampled), (2, c.total() - 2));
    // Accepted with 16 (the keyphasor's edge, 0.2 rad, then falls between
    // two samples and its linear interpolation is no longer exact).
    let mut t = OrderTracker::<f64, NC, 64>::new(config(1200.0).with_min_samples(16)).unwrap();
    let c = faulty(&mut t, 1200.0, 20.0, 0.1, |_, _, _, _| {});
    assert_eq!(c.accepted, c.total() - 2);
    // 315.6 rad/s against 100..250 rad/s, then 330..400.
    for (lo, hi) in [(100.0, 250.0), (330.0, 400.0)] {
        let cfg = config::<f32>(FS).with_adc_range(-1.0, 1.0);
        let cfg = Config {
            speed_min: lo,
            speed_max: hi,
            ..cfg
        };
        let mut t = OrderTracker::<f32, NC, 420>::new(cfg).unwrap();
        let c = faulty(&mut t, FS, 20.0, 1e-4, |_, _, _, _| {});
        assert_eq!(c.accepted, 0);
        assert_eq!((c.no_reference, c.speed_range), (2, c.total() - 2));
    }
}

#[test]
fn bad_configurations_are_refused_by_type() {
    let ok = config::<f64>(FS);
    assert!(OrderTracker::<f64, NC, CAP>::new(ok).is_ok());
    let cases: [(Config<f64>, ConfigError); 14] = [
        (
            Config {
                sample_rate: 0.0,
                ..ok
            },
            ConfigError::SampleRate,
        ),
        (
            Config {
                sample_rate: f64::NAN,
                ..ok
            },
            ConfigError::SampleRate,
        ),
        (
            Config {
                level: f64::INFINITY,
                ..ok
            },
            ConfigError::Keyphasor,
        ),
        (
            Config {
                hysteresis: -0.1,
                ..ok
            },
            ConfigError::Keyphasor,
        ),
        (
            Config {
                speed_min: 0.0,
                ..ok
            },
            ConfigError::SpeedRange,
        ),
        (
            Config {
                speed_max: 200.0,
                ..ok
            },
            ConfigError::SpeedRange,
        ),
        (
            Config {
                period_ratio: 0.0,
                ..ok
            },
            ConfigError::PeriodRatio,
        ),
        (
            Config {
                period_ratio: 0.6,
                ..ok
            },
            ConfigError::PeriodRatio,
        ),
        (
            Config {
                adc_min: 1.0,
                adc_max: 1.0,
                ..ok
            },
            ConfigError::AdcRange,
        ),
        (
            Config {
                adc_max: f64::INFINITY,
                ..ok
            },
            ConfigError::AdcRange,
        ),
        (
            Config {
                min_samples: 15,
                ..ok
            },
            ConfigError::MinSamples,
        ),
        (
            Config {
                revolutions: 2,
                ..ok
            },
            ConfigError::Revolutions,
        ),
        (
            Config {
                revolutions: 1,
                scatter: Scatter::Mean,
                ..ok
            },
            ConfigError::Revolutions,
        ),
        // 2 pi 6400 / 50 = 804.2 samples and 7 more.
        (
            Config {
                speed_min: 50.0,
                ..ok
            },
            ConfigError::Capacity { needed: 811 },
        ),
    ];
    for (c, e) in cases {
        assert_eq!(OrderTracker::<f64, NC, CAP>::new(c).err(), Some(e), "{c:?}");
        assert!(!e.to_string().is_empty());
    }
    assert!(OrderTracker::<f64, NC, 811>::new(Config {
        speed_min: 50.0,
        ..ok
    })
    .is_ok());
    let mean2 = Config {
        revolutions: 2,
        scatter: Scatter::Mean,
        ..ok
    };
    assert!(OrderTracker::<f64, NC, CAP>::new(mean2).is_ok());
    let tiny = Config {
        speed_min: 1e-300,
        ..ok
    };
    assert_eq!(
        OrderTracker::<f64, NC, CAP>::new(tiny).err(),
        Some(ConfigError::Capacity { needed: usize::MAX })
    );
}

#[test]
fn flush_and_reset() {
    let mut t = OrderTracker::<f64, NC, CAP>::new(config(FS).with_revolutions(100)).unwrap();
    let c = faulty(&mut t, FS, 12.3, 1e-4, |_, _, _, _| {});
    assert_eq!(c.accepted, 9);
    let a = t.flush().unwrap();
    assert_eq!(a.revolutions, 9);
    assert!(a.start.seconds(FS) < a.end.seconds(FS));
    assert!((a.speed - w0()).abs() < 1e-9 * w0());
    assert!(t.flush().is_none());
    t.reset();
    assert_eq!((t.counts().total(), t.samples()), (0, 0));
    let c = faulty(&mut t, FS, 12.3, 1e-4, |_, _, _, _| {});
    assert_eq!(c.accepted, 9);
}

/// Random samples, finite or not, on every channel: never a panic, every
/// revolution counted once, nothing non-finite accepted or averaged.
fn random_input<T: Real>(seed: u64) {
    let mut rng = SplitMix64::new(seed);
    let cfg = Config::new(T::lit(1000.0), T::lit(0.5), T::lit(100.0), T::lit(1000.0))
        .with_min_samples(16)
        .with_period_ratio(T::lit(0.5))
        .with_hysteresis(T::lit(0.1))
        .with_revolutions(3);
    let mut t = OrderTracker::<T, 3, 72>::new(cfg).unwrap();
    let mode = seed % 3;
    // One sample in 64 is a glitch; one in 8192 in mode 2.
    let rate = if mode == 2 { 8192 } else { 64 };
    let pick = |rng: &mut SplitMix64, base: f64| -> f64 {
        match rng.next_u64() % rate {
            0 => f64::NAN,
            1 => f64::INFINITY,
            2 => f64::NEG_INFINITY,
            3 => f64::MAX * rng.sym(),
            4 => 1e30 * rng.sym(),
            5 => f64::MIN_POSITIVE * rng.sym(),
            6 => 0.0,
            _ => base,
        }
    };
    let (mut theta, mut w) = (0.0f64, 300.0f64);
    let (mut closed, mut accepted, mut averages) = (0u64, 0u64, 0u64);
    for _ in 0..60_000 {
        // A pulse train with a wandering speed (mode 0), pure noise (1),
        // or a pulse train with glitches only on the probes (2).
        let hi = if mode == 2 { 380.0 } else { 1500.0 };
        w = (w * (1.0 + 0.02 * rng.sym())).clamp(50.0, hi);
        theta += w / 1000.0;
        let clean = pulse(theta);
        let kp = match mode {
            0 => {
                let k = clean + 0.05 * rng.sym();
                pick(&mut rng, k)
            }
            1 => {
                let k = rng.sym();
                pick(&mut rng, k)
            }
            _ => clean,
        };
        let y: [f64; 3] = core::array::from_fn(|_| pick(&mut rng, (theta + 0.3).cos()));
        let out = t.push(T::lit(kp), &y.map(T::lit));
        if let Some(o) = out {
            closed += 1;
            if let Ok(v) = &o.revolution.result {
                accepted += 1;
                assert!(v
                    .x1
                    .iter()
                    .chain(v.x2.iter())
                    .all(|z| z.re.is_finite() && z.im.is_finite()));
            }
            if let Some(a) = o.average {
                averages += 1;
                assert!(a
                    .x1_std
                    .iter()
                    .chain(a.x2_std.iter())
                    .all(|s| s.is_finite()));
            }
        }
    }
    let c = *t.counts();
    assert_eq!(c.total(), closed, "{c:?}");
    assert_eq!(c.accepted, accepted);
    assert!(averages <= accepted / 3);
    if mode == 2 {
        assert!(c.accepted > 0, "{c:?}");
    }
    let _ = t.flush();
}

#[test]
fn random_input_never_panics() {
    for seed in 0..6 {
        random_input::<f64>(seed);
        random_input::<f32>(seed);
    }
}
