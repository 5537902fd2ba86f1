//! The firmware's coast-down generator (`examples/firmware/src/coastdown.rs`,
//! the same source) through the order tracker, on the host, with the
//! firmware's tracker (the streaming one, f32, 4 probes) at its sample
//! rate:
//! the paper rotor at balance grade G6.3, its 1X phasors simulated every
//! 20 rpm from 2900 to 12100 rpm, a 2X of 5 % and probe gaps of 1.3 mm.
//!
//! - without noise, every accepted revolution's 1X equals the phasor the
//!   generator used for it, to f32 rounding of the gap and the step of the
//!   phasor between revolutions (the samples just outside the revolution
//!   carry the neighbouring revolutions' phasors, weight about `1.5 / M`);
//! - with the probe noise of the firmware (floor + relative, per sample),
//!   the averages' departure from the noise-free run's (the tracker is
//!   linear in the samples: the difference is the noise's own vector) has
//!   the analytic `E|dY|^2 = 4 sigma^2 / (M N)`, and the reported standard
//!   errors match it where the vector changes along a line within the
//!   group (near the critical speed the change within 8 revolutions is
//!   not linear and the reported standard error takes it for scatter).

#[allow(dead_code)]
#[path = "../../examples/firmware/src/coastdown.rs"]
mod generator;

use generator::{Coastdown, Setup};
use rotorid::model::RotorModel;
use rotorid::simulate::{at_balance_grade, simulate, SimOptions};
use rotorid::units::rpm_to_rad_s;
use rotorid_core::ordertrack::Config;
use rotorid_core::streamtrack::{StreamAverage, StreamTracker};
use rotorid_core::Complex;
use std::collections::HashMap;

const FS: f32 = 25_600.0;
const N: u32 = 8;
type Tracker = StreamTracker<f32, 4>;

/// The G6.3 paper rotor's 1X phasors, 2900..12100 rpm every 20 rpm (f32).
fn table() -> Vec<(f32, [Complex<f32>; 4])> {
    let model = at_balance_grade(&RotorModel::paper(), 6.3, rpm_to_rad_s(15000.0)).unwrap();
    let opts = SimOptions {
        speeds_rpm: (0..=460).map(|i| 2900.0 + 20.0 * i as f64).collect(),
        noise: 0.0,
        seed: 1,
        effects: Default::default(),
    };
    let meas = simulate(&model, &opts).unwrap();
    meas.samples
        .iter()
        .map(|s| {
            let q: [Complex<f32>; 4] =
                std::array::from_fn(|c| Complex::new(s.q[c].re as f32, s.q[c].im as f32));
            (s.omega as f32, q)
        })
        .collect()
}

fn setup(noise_floor: f32, noise_relative: f32) -> Setup<4> {
    Setup {
        sample_rate: FS,
        speed_start: rpm_to_rad_s(12_100.0) as f32,
        speed_end: rpm_to_rad_s(2900.0) as f32,
        deceleration: 150.0,
        x2_ratio: Complex::new(0.027, 0.042),
        gap: [1.25e-3, 1.3e-3, 1.35e-3, 1.3e-3],
        noise_floor,
        noise_relative,
        seed: 7,
    }
}

fn tracker() -> Tracker {
    let config = Config::new(
        FS,
        0.5,
        rpm_to_rad_s(3000.0) as f32,
        rpm_to_rad_s(12_000.0) as f32,
    )
    .with_hysteresis(0.2)
    .with_adc_range(0.0, 2.8e-3)
    .with_revolutions(N);
    Tracker::new(config).unwrap()
}

#[test]
fn every_revolution_gives_back_the_generated_phasor() {
    let table = table();
    let mut gen = Coastdown::new(&table, setup(0.0, 0.0));
    let mut t = tracker();
    // The generator's phasors by the first sample of their revolution.
    let mut phasors: Vec<(u64, [Complex<f32>; 4])> = vec![(0, *gen.x1())];
    let mut closed = Vec::new();
    let mut i = 0u64;
    while let Some((kp, y)) = gen.next_sample() {
        if let Some(o) = t.push(kp, &y) {
            closed.push(o.revolution);
        }
        i += 1;
        if gen.revolutions() as usize > phasors.len() {
            phasors.push((i, *gen.x1()));
        }
    }
    let by_start: HashMap<u64, usize> = phasors
        .iter()
        .enumerate()
        .map(|(k, (s, _))| (*s, k))
        .collect();
    let c = t.counts();
    assert_eq!(c.rejected(), c.no_reference + c.speed_range, "{c:?}");
    assert!(c.accepted > 750, "{c:?}");
    let (mut worst, mut worst_rel) = (0.0f64, 0.0f64);
    for r in &closed {
        let Ok(x1) = &r.result else { continue };
        // The event lies between `start.sample` and the revolution's first sample.
        let k = by_start[&(r.start.sample + 1)];
        let (y, prev, next) = (&phasors[k].1, &phasors[k - 1].1, &phasors[k + 1].1);
        let m = r.samples as f64;
        for ch in 0..4 {
            let yc = Complex::new(y[ch].re as f64, y[ch].im as f64);
            let got = Complex::new(x1[ch].re as f64, x1[ch].im as f64);
            let step = ((y[ch] - prev[ch]).norm() + (next[ch] - y[ch]).norm()) as f64;
            // f32 rounding of a 1.3 mm gap (ulp 1.2e-10 m) over the
            // revolution, the phasor steps at its ends, and 1e-5 relative.
            let bound = 1e-5 * yc.norm() + 2.0 * 1.2e-10 + 1.5 * step / m;
            let err = (got - yc).norm();
            assert!(
                err <= bound,
                "rev at {}: ch {ch}: {got} {yc}: {err:.3e} > {bound:.3e}",
                r.speed
            );
            worst = worst.max(err / bound);
            worst_rel = worst_rel.max(err / yc.norm());
        }
    }
    println!(
        "coastdown: {} revolutions accepted, 1X error at most {worst:.2} of its bound, {worst_rel:.2e} relative",
        c.accepted
    );
}

/// The averages of a run and the generator's per-sample noise levels and
/// samples per revolution behind each.
fn averages(floor: f32, relative: f32) -> Vec<(StreamAverage<f32, 4>, [f64; 4])> {
    let table = table();
    let mut gen = Coastdown::new(&table, setup(floor, relative));
    let mut t = tracker();
    let mut out = Vec::new();
    let mut sig2 = [0.0f64; 4];
    let mut n = 0.0;
    while let Some((kp, y)) = gen.next_sample() {
        for (s, g) in sig2.iter_mut().zip(gen.sigma()) {
            *s += (*g as f64).powi(2);
        }
        n += 1.0;
        if let Some(a) = t.push(kp, &y).and_then(|o| o.average) {
            out.push((a, sig2.map(|s| s / n)));
            sig2 = [0.0; 4];
            n = 0.0;
        }
    }
    out
}

#[test]
fn probe_noise_gives_the_analytic_scatter_of_the_averages() {
    let (floor, relative) = (2e-6, 0.02);
    let clean = averages(0.0, 0.0);
    let noisy = averages(floor, relative);
    assert_eq!(clean.len(), noisy.len());
    assert!(clean.len() > 90, "{}", clean.len());
    let (mut z2, mut count) = (0.0, 0.0);
    // The reported standard errors where the vector's own change within
    // the group, not about a line (near the critical speed), is below a
    // tenth of the noise (the noise-free run's standard error tells it).
    let (mut reported, mut steady) = (0.0, 0.0);
    for ((a, _), (b, sig2)) in clean.iter().zip(noisy.iter()) {
        assert_eq!(a.start, b.start);
        // Samples per revolution, from the group's span.
        let m = b.end.since(&b.start) as f64 / b.revolutions as f64;
        for (c, s2) in sig2.iter().enumerate() {
            let d = Complex::new(
                (b.x1[c].re - a.x1[c].re) as f64,
                (b.x1[c].im - a.x1[c].im) as f64,
            );
            let analytic = 4.0 * s2 / (m * N as f64);
            z2 += d.norm_sqr() / analytic;
            count += 1.0;
            if (a.x1_std[c] as f64).powi(2) < 0.1 * analytic {
                reported += (b.x1_std[c] as f64).powi(2) / analytic;
                steady += 1.0;
            }
        }
    }
    let (scatter, reported) = ((z2 / count).sqrt(), (reported / steady).sqrt());
    println!(
        "coastdown noise ({floor:e} m + {relative} per sample): {} averages, \
         scatter / analytic {scatter:.3}; reported / analytic {reported:.3} \
         over the {steady} of {count} where the vector's curvature is below the noise",
        clean.len()
    );
    assert!(steady > 0.5 * count, "{steady} {count}");
    assert!((scatter - 1.0).abs() < 0.15, "{scatter}");
    assert!((reported - 1.0).abs() < 0.2, "{reported}");
}
