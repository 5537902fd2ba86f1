//! Accuracy without noise: at constant speed with a non-integer number of
//! samples per revolution (DC and 2X..5X present), and on speed ramps of
//! +-10 % per second, in f64 and f32. Run with `--nocapture` for the
//! measured errors.

use super::*;
use rotorid_core::ordertrack::Config;

const NC: usize = 3;
/// 25.6 kHz down to 200 rad/s: 805 samples, and 7.
const CAP: usize = 820;
const FS: f64 = 25_600.0;

/// 3000 rpm and an irrational offset: 509.6... samples per revolution.
fn w0() -> f64 {
    rpm(3000.0 + 10.0 * 2f64.sqrt())
}

fn tracker<T: Real>() -> OrderTracker<T, NC, CAP> {
    let c = Config::new(T::lit(FS), T::lit(LEVEL), T::lit(200.0), T::lit(400.0))
        .with_hysteresis(T::lit(HYSTERESIS));
    OrderTracker::new(c).unwrap()
}

/// Largest relative and phase (degrees) errors of the accepted
/// revolutions' nX vectors (and of the averages').
struct Worst {
    rel: f64,
    deg: f64,
}

fn worst<T: Real>(sig: &Signal<NC>, run: &Run<T, NC>) -> [Worst; 2] {
    let mut w = [Worst { rel: 0.0, deg: 0.0 }, Worst { rel: 0.0, deg: 0.0 }];
    let mut check = |n: usize, x: &[Complex<T>; NC]| {
        for (c, z) in x.iter().enumerate() {
            let (rel, deg) = errors(c64(*z), sig.truth(c, n));
            w[n - 1].rel = w[n - 1].rel.max(rel);
            w[n - 1].deg = w[n - 1].deg.max(deg);
        }
    };
    for r in &run.revolutions {
        if let Ok(o) = &r.result {
            check(1, &o.x1);
            check(2, &o.x2);
        }
    }
    for a in &run.averages {
        check(1, &a.x1);
        check(2, &a.x2);
    }
    w
}

fn steady<T: Real>(label: &str, tol_rel: f64, tol_deg: f64) {
    let w0 = w0();
    let sig = Signal::<NC>::steady(FS, w0, 1);
    let mut t = tracker::<T>();
    let n = (20.0 * TAU / w0 * FS) as usize;
    let run = run(&mut t, n, |i| sig.sample(i));
    let counts = *t.counts();
    assert_eq!(counts.no_reference, 2);
    assert_eq!(counts.accepted, counts.total() - 2);
    assert!(counts.accepted >= 16, "{counts:?}");
    assert_eq!(run.averages.len(), 2);
    let m = TAU * FS / w0;
    let mut speed = 0.0f64;
    for r in run.revolutions.iter().filter(|r| r.result.is_ok()) {
        speed = speed.max((r.speed.to_f64() - w0).abs() / w0);
        assert!((r.samples.to_f64() - m).abs() < 1e-6 * m);
        assert!(r.acceleration.to_f64().abs() < 1e-3 * w0);
    }
    let [x1, x2] = worst(&sig, &run);
    println!(
        "ordertrack steady {label}: {m:.4} samples/rev, DC 100x and 2X..5X 0.3..1x the 1X: \
         1X rel {:.2e}, {:.2e} deg; 2X rel {:.2e}, {:.2e} deg; speed rel {speed:.2e}",
        x1.rel, x1.deg, x2.rel, x2.deg
    );
    assert!(
        x1.rel < tol_rel && x1.deg < tol_deg,
        "1X {} {}",
        x1.rel,
        x1.deg
    );
    assert!(
        x2.rel < tol_rel && x2.deg < tol_deg,
        "2X {} {}",
        x2.rel,
        x2.deg
    );
    assert!(speed < tol_rel, "speed {speed}");
}

#[test]
fn steady_speed_f64_is_exact_to_1e_9() {
    steady::<f64>("f64", 1e-9, 1e-7);
}

#[test]
fn steady_speed_f32() {
    steady::<f32>("f32", 1e-5, 1e-3);
}

fn ramp<T: Real>(label: &str, rate: f64, tol_rel: f64, tol_deg: f64) {
    let w0 = w0();
    let mut sig = Signal::<NC>::steady(FS, w0, 2);
    sig.alpha = rate * w0;
    let mut t = tracker::<T>();
    let n = FS as usize; // one second
    let run = run(&mut t, n, |i| sig.sample(i));
    let counts = *t.counts();
    assert_eq!(counts.no_reference, 2);
    assert_eq!(counts.accepted, counts.total() - 2, "{counts:?}");
    assert!(counts.accepted >= 40, "{counts:?}");
    // Speed and acceleration against the exact event times.
    let (mut speed, mut accel) = (0.0f64, 0.0f64);
    for r in run.revolutions.iter().filter(|r| r.result.is_ok()) {
        let ts = r.start.seconds(FS);
        let k = ((sig.theta0 + sig.w0 * ts + 0.5 * sig.alpha * ts * ts) / TAU).round();
        let period = sig.time_of(TAU * (k + 1.0)) - sig.time_of(TAU * k);
        let exact = TAU / period;
        speed = speed.max((r.speed.to_f64() - exact).abs() / exact);
        accel = accel.max((r.acceleration.to_f64() - sig.alpha).abs() / sig.alpha.abs());
    }
    let [x1, x2] = worst(&sig, &run);
    println!(
        "ordertrack ramp {rate:+} /s {label}: {} revolutions: 1X rel {:.2e}, {:.2e} deg; \
         2X rel {:.2e}, {:.2e} deg; speed rel {speed:.2e}, acceleration rel {accel:.2e}",
        counts.accepted, x1.rel, x1.deg, x2.rel, x2.deg
    );
    assert!(
        x1.rel < tol_rel && x1.deg < tol_deg,
        "1X {} {}",
        x1.rel,
        x1.deg
    );
    assert!(
        x2.rel < tol_rel && x2.deg < tol_deg,
        "2X {} {}",
        x2.rel,
        x2.deg
    );
    assert!(speed < tol_rel, "speed {speed}");
    assert!(accel < 1e3 * tol_rel, "acceleration {accel}");
}

#[test]
fn speed_ramps_f64_are_exact_to_1e_6() {
    ramp::<f64>("f64", 0.1, 1e-6, 1e-4);
    ramp::<f64>("f64", -0.1, 1e-6, 1e-4);
}

#[test]
fn speed_ramps_f32() {
    ramp::<f32>("f32", 0.1, 1e-5, 1e-3);
    ramp::<f32>("f32", -0.1, 1e-5, 1e-3);
}
