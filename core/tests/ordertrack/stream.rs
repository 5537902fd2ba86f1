//! The streaming 1X tracker (`rotorid_core::streamtrack`): accuracy at
//! constant speed and on ramps, the same vectors as the buffered tracker
//! where the acceleration is constant (noise included), rejections by
//! cause, random input.

use super::faults::expect;
use super::*;
use rotorid_core::ordertrack::{Config, Counts, Rejection};
use rotorid_core::streamtrack::{StreamAverage, StreamRevolution, StreamTracker};

const FS: f64 = 25_600.0;

/// 3000 rpm and an irrational offset: 509.6... samples per revolution.
fn w0() -> f64 {
    rpm(3000.0 + 10.0 * 2f64.sqrt())
}

fn config<T: Real>(fs: f64) -> Config<T> {
    Config::new(T::lit(fs), T::lit(LEVEL), T::lit(200.0), T::lit(400.0))
        .with_hysteresis(T::lit(HYSTERESIS))
        .with_adc_range(T::lit(-1e-2), T::lit(1e-2))
}

struct StreamRun<T, const NC: usize> {
    revolutions: Vec<StreamRevolution<T, NC>>,
    averages: Vec<StreamAverage<T, NC>>,
}

fn stream<T: Real, const NC: usize>(
    t: &mut StreamTracker<T, NC>,
    n: usize,
    mut sample: impl FnMut(usize) -> (f64, [f64; NC]),
) -> StreamRun<T, NC> {
    let mut out = StreamRun {
        revolutions: Vec::new(),
        averages: Vec::new(),
    };
    for i in 0..n {
        let (kp, y) = sample(i);
        if let Some(o) = t.push(T::lit(kp), &y.map(T::lit)) {
            out.revolutions.push(o.revolution);
            out.averages.extend(o.average);
        }
    }
    out
}

/// Worst relative and phase (degrees) error of the accepted revolutions'
/// and the averages' 1X vectors.
fn worst<T: Real, const NC: usize>(sig: &Signal<NC>, run: &StreamRun<T, NC>) -> (f64, f64) {
    let mut w = (0.0f64, 0.0f64);
    let mut check = |x: &[Complex<T>; NC]| {
        for (c, z) in x.iter().enumerate() {
            let (rel, deg) = errors(c64(*z), sig.truth(c, 1));
            w = (w.0.max(rel), w.1.max(deg));
        }
    };
    for r in &run.revolutions {
        if let Ok(x) = &r.result {
            check(x);
        }
    }
    for a in &run.averages {
        check(&a.x1);
    }
    w
}

fn accuracy<T: Real>(label: &str, rate: f64, tol_rel: f64, tol_deg: f64) {
    const NC: usize = 3;
    let w0 = w0();
    let mut sig = Signal::<NC>::steady(FS, w0, 2);
    sig.alpha = rate * w0;
    let mut t = StreamTracker::<T, NC>::new(config(FS)).unwrap();
    let run = stream(&mut t, FS as usize, |i| sig.sample(i));
    let c = *t.counts();
    assert_eq!(c.no_reference, 2, "{c:?}");
    assert_eq!(c.accepted, c.total() - 2, "{c:?}");
    assert!(c.accepted >= 40, "{c:?}");
    assert!(!run.averages.is_empty());
    let miss = run
        .revolutions
        .iter()
        .filter(|r| r.result.is_ok())
        .map(|r| r.angle_error.to_f64().abs())
        .fold(0.0, f64::max);
    let (rel, deg) = worst(&sig, &run);
    println!(
        "streamtrack {rate:+} /s {label}: {} revolutions, DC 100x and 2X..5X: 1X rel {rel:.2e}, \
         {deg:.2e} deg; largest angle miss {miss:.2e} rad",
        c.accepted
    );
    assert!(rel < tol_rel && deg < tol_deg, "1X {rel} {deg}");
}

#[test]
fn steady_speed_and_ramps_f64() {
    accuracy::<f64>("f64", 0.0, 1e-9, 1e-7);
    accuracy::<f64>("f64", 0.1, 1e-6, 1e-4);
    accuracy::<f64>("f64", -0.1, 1e-6, 1e-4);
}

#[test]
fn steady_speed_and_ramps_f32() {
    accuracy::<f32>("f32", 0.0, 1e-5, 1e-3);
    accuracy::<f32>("f32", 0.1, 1e-5, 1e-3);
    accuracy::<f32>("f32", -0.1, 1e-5, 1e-3);
}

/// With white noise on every sample, on a ramp: every revolution's 1X and
/// every average (its standard error included) as the buffered tracker's,
/// which the noise tests of `noise.rs` check against the analytic scatter.
#[test]
fn the_same_vectors_as_the_buffered_tracker_with_noise() {
    const NC: usize = 2;
    let mut sig = Signal::<NC>::steady(FS, w0(), 7);
    sig.alpha = -0.05 * sig.w0;
    let mut rng = SplitMix64::new(11);
    let noisy: Vec<(f64, [f64; NC])> = (0..FS as usize)
        .map(|i| {
            let (kp, y) = sig.sample(i);
            (kp, y.map(|v| v + 3e-6 * gauss(&mut rng)))
        })
        .collect();
    let mut b = OrderTracker::<f64, NC, 820>::new(config(FS)).unwrap();
    let rb = run(&mut b, noisy.len(), |i| noisy[i]);
    let mut s = StreamTracker::<f64, NC>::new(config(FS)).unwrap();
    let rs = stream(&mut s, noisy.len(), |i| noisy[i]);
    assert_eq!(b.counts(), s.counts());
    assert_eq!(rb.revolutions.len(), rs.revolutions.len());
    // Each revolution within its own miss (the events' timing on the
    // ramp, some 1e-8 rad), and within 1e-9 in all.
    let mut worst = 0.0f64;
    for (x, y) in rb.revolutions.iter().zip(rs.revolutions.iter()) {
        assert_eq!(x.start, y.start);
        match (&x.result, &y.result) {
            (Ok(o), Ok(v)) => {
                for (x, z) in o.x1.iter().zip(v.iter()) {
                    let rel = (x - z).norm() / x.norm();
                    assert!(
                        rel <= y.angle_error.abs() + 1e-12,
                        "{rel} {}",
                        y.angle_error
                    );
                    worst = worst.max(rel);
                }
            }
            (Err(e), Err(f)) => assert_eq!(e, f),
            _ => panic!("{:?} {:?}", x.result, y.result),
        }
    }
    assert_eq!(rb.averages.len(), rs.averages.len());
    assert!(rb.averages.len() >= 5);
    let mut worst_std = 0.0f64;
    for (x, y) in rb.averages.iter().zip(rs.averages.iter()) {
        assert_eq!(x.revolutions, y.revolutions);
        for c in 0..NC {
            worst = worst.max((x.x1[c] - y.x1[c]).norm() / x.x1[c].norm());
            worst_std = worst_std.max((x.x1_std[c] - y.x1_std[c]).abs() / x.x1_std[c]);
        }
    }
    println!("streamtrack against ordertrack, noise: 1X rel {worst:.2e}, std rel {worst_std:.2e}");
    assert!(worst < 1e-8, "{worst}");
    assert!(worst_std < 1e-6, "{worst_std}");
}

/// A deceleration that changes within the revolution (`d Omega / dt = -k
/// Omega^2`, windage): the prediction misses by `e`, reported, and the
/// vectors stay within `|e|` (relative) of the buffered tracker's
/// exact-angle ones; a tolerance below the miss rejects the revolutions.
#[test]
fn a_changing_deceleration_is_measured_and_bounded() {
    const NC: usize = 2;
    let fs = 6400.0;
    let sig = Signal::<NC>::steady(fs, w0(), 9);
    // Omega(t) = w0 / (1 + k w0 t): 20 %/s at the start.
    let k = 0.2 / sig.w0;
    let theta = |i: usize| {
        let t = i as f64 / fs;
        sig.theta0 + (1.0 + k * sig.w0 * t).ln() / k
    };
    let n = (2.0 * fs) as usize;
    let sample = |i: usize| {
        let th = theta(i);
        (pulse(th), sig.probes(th))
    };
    let mut s = StreamTracker::<f64, NC>::new(config(fs)).unwrap();
    let rs = stream(&mut s, n, sample);
    let mut b = OrderTracker::<f64, NC, 300>::new(config(fs)).unwrap();
    let rb = run(&mut b, n, sample);
    let (mut miss, mut ratio) = (0.0f64, 0.0f64);
    let mut compared = 0;
    for (x, y) in rb.revolutions.iter().zip(rs.revolutions.iter()) {
        if let (Ok(o), Ok(v)) = (&x.result, &y.result) {
            let e = y.angle_error.abs();
            assert!(e > 0.0 && e < 1e-3);
            miss = miss.max(e);
            for (x, z) in o.x1.iter().zip(v.iter()) {
                let rel = (x - z).norm() / x.norm();
                ratio = ratio.max(rel / e);
            }
            compared += 1;
        }
    }
    println!(
        "streamtrack, deceleration ~ Omega^2 at 20 %/s: {compared} revolutions, largest miss \
         {miss:.2e} rad, difference from the exact angle at most {ratio:.2} |e|"
    );
    assert!(compared >= 40);
    assert!(ratio < 1.0, "{ratio}");
    // A tolerance below the misses: every predicted revolution rejected.
    let mut strict = StreamTracker::<f64, NC>::new(config(fs)).unwrap();
    assert!(strict.set_angle_tolerance(1e-9));
    assert!(!strict.set_angle_tolerance(f64::NAN));
    assert!(!strict.set_angle_tolerance(0.0));
    let _ = stream(&mut strict, n, sample);
    let c = *strict.counts();
    assert_eq!(c.accepted, 0, "{c:?}");
    assert_eq!(c.period_jump, c.total() - c.no_reference, "{c:?}");
}

fn faulty<T: Real>(
    revs: f64,
    tol: f64,
    mut edit: impl FnMut(usize, f64, &mut f64, &mut [f64; 2]),
) -> Counts {
    const NC: usize = 2;
    let fs = 6400.0;
    let sig = Signal::<NC>::steady(fs, w0(), 4);
    let n = (revs * TAU / w0() * fs) as usize;
    let mut t = StreamTracker::<T, NC>::new(config(fs)).unwrap();
    let run = stream(&mut t, n, |i| {
        let th = sig.theta(i);
        let (mut kp, mut y) = sig.sample(i);
        edit(i, th, &mut kp, &mut y);
        (kp, y)
    });
    let counts = *t.counts();
    assert_eq!(counts.total(), run.revolutions.len() as u64);
    for r in &run.revolutions {
        if let Ok(x) = &r.result {
            for (c, z) in x.iter().enumerate() {
                let (rel, _) = errors(c64(*z), sig.truth(c, 1));
                assert!(rel < tol, "{rel}");
            }
        }
    }
    counts
}

fn faults<T: Real>() {
    let fs = 6400.0;
    let sig = Signal::<2>::steady(fs, w0(), 4);
    let at = |theta: f64| (sig.time_of(theta) * fs).floor() as usize;
    let index = |theta: f64| ((theta - wrap(theta)) / TAU).round() as i64;
    let revs = 31.3;
    let c = faulty::<T>(revs, 1e-4, |_, _, _, _| {});
    expect(c, &[(Rejection::NoReference, 2)]);
    assert_eq!(c.accepted, 28);
    // A missing pulse, an extra pulse: as the buffered tracker.
    let c = faulty::<T>(revs, 1e-4, |_, th, kp, _| {
        if index(th) == 12 {
            *kp = 0.0;
        }
    });
    expect(
        c,
        &[(Rejection::NoReference, 2), (Rejection::PeriodJump, 3)],
    );
    let c = faulty::<T>(revs, 1e-4, |_, th, kp, _| {
        if index(th - PI) == 12 {
            *kp = kp.max(pulse(th - PI));
        }
    });
    expect(
        c,
        &[(Rejection::NoReference, 2), (Rejection::PeriodJump, 4)],
    );
    // The pulse train stops for 900 samples (7 revolutions).
    let stop = at(TAU * 15.5);
    let c = faulty::<T>(revs + 6.0, 1e-4, |i, _, kp, _| {
        if (stop..stop + 900).contains(&i) {
            *kp = 0.0;
        }
    });
    expect(c, &[(Rejection::NoReference, 4), (Rejection::NoEvent, 1)]);
    // A NaN keyphasor sample.
    let nan = at(TAU * 10.5);
    let c = faulty::<T>(revs, 1e-4, |i, _, kp, _| {
        if i == nan {
            *kp = f64::NAN;
        }
    });
    expect(c, &[(Rejection::NoReference, 4), (Rejection::NonFinite, 1)]);
    // Clipped and non-finite probe samples, one mid-revolution and one
    // next to an event (in both revolutions' integrals).
    let (mid, edge) = (at(TAU * 10.5), at(TAU * 20.0));
    for (bad, cause) in [
        (1e-2, Rejection::Clipped),
        (-1.5e-2, Rejection::Clipped),
        (f64::NAN, Rejection::NonFinite),
        (f64::NEG_INFINITY, Rejection::NonFinite),
    ] {
        let c = faulty::<T>(revs, 1e-4, |i, _, _, y| {
            if i == mid || i == edge {
                y[1] = bad;
            }
        });
        expect(c, &[(Rejection::NoReference, 2), (cause, 3)]);
    }
}

#[test]
fn faults_are_rejected_by_cause_f64() {
    faults::<f64>();
}

#[test]
fn faults_are_rejected_by_cause_f32() {
    faults::<f32>();
}

/// 1 kHz, 100..1000 rad/s, revolutions of 16 samples and more, periods
/// within 50 % of the last, averages of 3: a configuration that random
/// input with glitches exercises.
fn glitch_config<T: Real>() -> Config<T> {
    Config::new(T::lit(1000.0), T::lit(0.5), T::lit(100.0), T::lit(1000.0))
        .with_min_samples(16)
        .with_period_ratio(T::lit(0.5))
        .with_hysteresis(T::lit(0.1))
        .with_revolutions(3)
}

/// Random samples, finite or not: never a panic, every revolution counted
/// once, nothing non-finite accepted or averaged.
#[test]
fn random_input_never_panics() {
    for seed in 0..6u64 {
        let mut rng = SplitMix64::new(seed);
        let mut t = StreamTracker::<f32, 3>::new(glitch_config()).unwrap();
        let (mut theta, mut w) = (0.0f64, 300.0f64);
        let mut closed = 0u64;
        for _ in 0..40_000 {
            w = (w * (1.0 + 0.02 * rng.sym())).clamp(50.0, 1500.0);
            theta += w / 1000.0;
            let glitch = |rng: &mut SplitMix64, v: f64| match rng.next_u64() % 64 {
                0 => f64::NAN,
                1 => f64::INFINITY,
                2 => 1e30 * rng.sym(),
                3 => f64::MAX,
                _ => v,
            };
            let kp = if seed % 2 == 0 {
                let k = pulse(theta) + 0.05 * rng.sym();
                glitch(&mut rng, k)
            } else {
                rng.sym()
            };
            let y: [f64; 3] = core::array::from_fn(|_| glitch(&mut rng, (theta + 0.3).cos()));
            if let Some(o) = t.push(kp as f32, &y.map(|v| v as f32)) {
                closed += 1;
                if let Ok(x) = &o.revolution.result {
                    assert!(x.iter().all(|z| z.re.is_finite() && z.im.is_finite()));
                }
                if let Some(a) = o.average {
                    assert!(a.x1_std.iter().all(|s| s.is_finite()));
                }
            }
        }
        assert_eq!(t.counts().total(), closed);
        let _ = t.flush();
    }
}

/// `push_block` (blocks of 16 instants, each outcome finished before the
/// call goes on) gives what `push` gives instant by instant: the same
/// revolutions, averages, counts and flush, bit for bit, on clean sweeps
/// and on random input with glitches (events, re-arms, non-finite
/// keyphasor samples and revolutions run too long inside blocks, on a
/// block's first and last instants), also after single instants that
/// leave the blocks unaligned.
#[test]
fn blocks_give_what_single_instants_give() {
    use rotorid_core::streamtrack::BLOCK;
    fn check<T: Real>(cfg: Config<T>, samples: &[(f64, [f64; 3])], lead: usize) -> u64 {
        let conv = |(k, y): &(f64, [f64; 3])| (T::lit(*k), y.map(T::lit));
        let mut one = StreamTracker::<T, 3>::new(cfg).unwrap();
        let mut blk = StreamTracker::<T, 3>::new(cfg).unwrap();
        let (mut a, mut b) = (Vec::new(), Vec::new());
        for s in samples {
            let (k, y) = conv(s);
            a.extend(one.push(k, &y).map(|o| format!("{o:?}")));
        }
        let (head, rest) = samples.split_at(lead.min(samples.len()));
        for s in head {
            let (k, y) = conv(s);
            b.extend(blk.push(k, &y).map(|o| format!("{o:?}")));
        }
        let mut chunks = rest.chunks_exact(BLOCK);
        for chunk in &mut chunks {
            let kp: [T; BLOCK] = core::array::from_fn(|j| conv(&chunk[j]).0);
            let y: [[T; 3]; BLOCK] = core::array::from_fn(|j| conv(&chunk[j]).1);
            let mut from = 0;
            while from < BLOCK {
                let (outcome, next) = blk.push_block(&kp, &y, from);
                assert!(next > from);
                if !outcome.is_quiet() {
                    b.extend(blk.finish_sample(outcome).map(|o| format!("{o:?}")));
                }
                from = next;
            }
        }
        for s in chunks.remainder() {
            let (k, y) = conv(s);
            b.extend(blk.push(k, &y).map(|o| format!("{o:?}")));
        }
        assert_eq!(a, b, "lead {lead}");
        assert_eq!(one.counts(), blk.counts());
        assert_eq!(one.samples(), blk.samples());
        assert_eq!(format!("{:?}", one.flush()), format!("{:?}", blk.flush()));
        one.counts().total()
    }
    // A clean ramp with noise.
    let mut sig = Signal::<3>::steady(FS, w0(), 7);
    sig.alpha = -0.1 * sig.w0;
    let mut rng = SplitMix64::new(3);
    let clean: Vec<(f64, [f64; 3])> = (0..FS as usize)
        .map(|i| {
            let (kp, y) = sig.sample(i);
            (kp, y.map(|v| v + 3e-6 * gauss(&mut rng)))
        })
        .collect();
    for lead in [0, 5, 16] {
        assert!(check::<f64>(config(FS), &clean, lead) >= 40);
        assert!(check::<f32>(config(FS), &clean, lead) >= 40);
    }
    // Random speed, glitches on every channel, pulse trains that stop.
    for seed in 0..4u64 {
        let mut rng = SplitMix64::new(100 + seed);
        let (mut theta, mut w) = (0.0f64, 300.0f64);
        let samples: Vec<(f64, [f64; 3])> = (0..30_000)
            .map(|i| {
                w = (w * (1.0 + 0.02 * rng.sym())).clamp(50.0, 1500.0);
                theta += w / 1000.0;
                let glitch = |rng: &mut SplitMix64, v: f64| match rng.next_u64() % 256 {
                    0 => f64::NAN,
                    1 => f64::INFINITY,
                    2 => 1e30 * rng.sym(),
                    _ => v,
                };
                // The pulse train stops for a while now and then.
                let kp = if (i / 3000) % 4 == 3 {
                    0.0
                } else {
                    let k = pulse(theta) + 0.05 * rng.sym();
                    glitch(&mut rng, k)
                };
                let y = core::array::from_fn(|c| glitch(&mut rng, (theta + 0.3 * c as f64).cos()));
                (kp, y)
            })
            .collect();
        for lead in [0, 3] {
            assert!(check::<f64>(glitch_config(), &samples, lead) > 50);
            assert!(check::<f32>(glitch_config(), &samples, lead) > 50);
        }
    }
}
