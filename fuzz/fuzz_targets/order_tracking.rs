//! Untrusted signals through the order trackers (`rotorid_core::ordertrack`
//! and `rotorid_core::streamtrack`): a keyphasor pulse train and two probes
//! whose speed wanders and whose samples the input glitches (NaN,
//! infinities, huge and tiny values, dropped and doubled pulses), under a
//! configuration the input picks, in `f32` or `f64`. Never a panic; every
//! revolution counted once; nothing non-finite accepted or averaged; the
//! streaming tracker's `push` equal to its `push_sample` and
//! `finish_sample`.
#![no_main]

use libfuzzer_sys::fuzz_target;
use rotorid_core::ordertrack::{Config, OrderTracker, Scatter};
use rotorid_core::streamtrack::StreamTracker;
use rotorid_core::Real;

/// Samples run per input (the input's bytes are cycled).
const SAMPLES: usize = 6000;
/// The buffered tracker's capacity.
const CAP: usize = 200;

fn byte(data: &[u8], i: usize) -> u8 {
    data.get(i % data.len().max(1)).copied().unwrap_or(0)
}

fn special(b: u8, normal: f64) -> f64 {
    match b {
        0 => f64::NAN,
        1 => f64::INFINITY,
        2 => f64::NEG_INFINITY,
        3 => 1e30,
        4 => -1e300,
        5 => f64::MIN_POSITIVE,
        6 => 0.0,
        _ => normal,
    }
}

fn run<T: Real>(data: &[u8]) {
    let h = |i: usize| f64::from(byte(data, i));
    let fs = 1000.0;
    let speed_min = 50.0 + h(1);
    let speed_max = speed_min * (1.2 + h(2) / 16.0);
    let config = Config::new(T::lit(fs), T::lit(0.5), T::lit(speed_min), T::lit(speed_max))
        .with_hysteresis(T::lit(h(3) / 512.0))
        .with_period_ratio(T::lit(0.01 + h(4) / 520.0))
        .with_min_samples(16 + byte(data, 5) as usize % 8)
        .with_revolutions(3 + u32::from(byte(data, 6) % 5))
        .with_scatter(if byte(data, 7) % 2 == 0 { Scatter::Mean } else { Scatter::Trend })
        .with_adc_range(T::lit(-2.0 - h(8) / 64.0), T::lit(2.0 + h(9) / 64.0));
    let buffered = OrderTracker::<T, 2, CAP>::new(config);
    let (Ok(mut stream), Ok(mut split)) = (
        StreamTracker::<T, 2>::new(config),
        StreamTracker::<T, 2>::new(config),
    ) else {
        // A configuration both refuse (a buffer too short for the speeds is
        // the buffered tracker's alone).
        return;
    };
    let mut buffered = buffered.ok();
    let (mut theta, mut w) = (0.3f64, (speed_min + speed_max) / 2.0);
    let (mut closed_b, mut closed_s) = (0u64, 0u64);
    for i in 0..SAMPLES {
        let b = byte(data, 10 + i);
        w = (w * (1.0 + (f64::from(b) - 127.5) / 4000.0)).clamp(10.0, 2.0 * speed_max);
        theta += w / fs;
        let u = (theta + core::f64::consts::PI).rem_euclid(core::f64::consts::TAU)
            - core::f64::consts::PI;
        let mut kp = if u < 1.0 { (0.5 + u / 0.2).clamp(0.0, 1.0) } else { 0.0 };
        match b % 53 {
            7 => kp = 0.0,
            8 => kp = 1.0,
            9 => kp = special(b % 7, kp),
            _ => {}
        }
        let y = [
            special(b % 37, 0.5 * (theta + 0.2).cos() + 0.1),
            special(b % 41, 0.3 * (theta - 1.0).cos() - 0.2),
        ];
        let (kp, y) = (T::lit(kp), y.map(T::lit));
        if let Some(t) = buffered.as_mut() {
            if let Some(o) = t.push(kp, &y) {
                closed_b += 1;
                if let Ok(v) = &o.revolution.result {
                    assert!(v.x1.iter().chain(v.x2.iter()).all(|z| z.re.is_finite() && z.im.is_finite()));
                }
                if let Some(a) = o.average {
                    assert!(a.x1_std.iter().chain(a.x2_std.iter()).all(|s| s.is_finite()));
                }
            }
        }
        let o = stream.push(kp, &y);
        let outcome = split.push_sample(kp, &y);
        let p = if outcome.is_quiet() { None } else { split.finish_sample(outcome) };
        assert_eq!(format!("{o:?}"), format!("{p:?}"));
        if let Some(o) = o {
            closed_s += 1;
            if let Ok(x) = &o.revolution.result {
                assert!(x.iter().all(|z| z.re.is_finite() && z.im.is_finite()));
            }
            if let Some(a) = o.average {
                assert!(a.x1_std.iter().all(|s| s.is_finite()) && a.speed.is_finite());
            }
        }
    }
    if let Some(t) = buffered.as_mut() {
        assert_eq!(t.counts().total(), closed_b);
        let _ = t.flush();
    }
    assert_eq!(stream.counts().total(), closed_s);
    assert_eq!(stream.counts(), split.counts());
    let _ = stream.flush();
}

fuzz_target!(|data: &[u8]| {
    if data.is_empty() {
        return;
    }
    if data[0] % 2 == 0 {
        run::<f32>(data);
    } else {
        run::<f64>(data);
    }
});
