//! White noise on the probe samples: over 200 seeds, the scatter of the
//! averaged vectors against the analytic `E|dY|^2 = 4 sigma^2 / (M N)`
//! (`M` samples per revolution, `N` revolutions), and the reported standard
//! errors against that scatter, for both scatter models, f64 and f32.

use super::*;
use rotorid_core::ordertrack::{Config, Scatter};

const NC: usize = 2;
const CAP: usize = 128;
const FS: f64 = 3200.0;
const SEEDS: u64 = 200;
const N: u32 = 8;
const SIGMA: f64 = 2e-6;

fn scatter<T: Real>(label: &str, model: Scatter) {
    let w0 = rpm(3000.0 + 10.0 * 2f64.sqrt());
    let m = TAU * FS / w0;
    let sig = Signal::<NC>::steady(FS, w0, 3);
    let config = Config::new(T::lit(FS), T::lit(LEVEL), T::lit(200.0), T::lit(400.0))
        .with_hysteresis(T::lit(HYSTERESIS))
        .with_revolutions(N)
        .with_scatter(model);
    let samples = ((N as f64 + 3.5) * m) as usize;
    // Per order: sum of |Y - Y_true|^2 and of the reported std^2.
    let (mut err2, mut se2, mut count) = ([0.0f64; 2], [0.0f64; 2], 0.0);
    for seed in 0..SEEDS {
        let mut rng = SplitMix64::new(1000 + seed);
        let mut t = OrderTracker::<T, NC, CAP>::new(config).unwrap();
        let run = run(&mut t, samples, |i| {
            let (kp, y) = sig.sample(i);
            (kp, y.map(|v| v + SIGMA * gauss(&mut rng)))
        });
        assert_eq!(run.averages.len(), 1, "{:?}", t.counts());
        let a = &run.averages[0];
        assert_eq!(a.revolutions, N);
        for c in 0..NC {
            err2[0] += (c64(a.x1[c]) - sig.truth(c, 1)).norm_sqr();
            err2[1] += (c64(a.x2[c]) - sig.truth(c, 2)).norm_sqr();
            se2[0] += a.x1_std[c].to_f64().powi(2);
            se2[1] += a.x2_std[c].to_f64().powi(2);
            count += 1.0;
        }
    }
    let analytic = (4.0 * SIGMA * SIGMA / (m * N as f64)).sqrt();
    for (k, name) in ["1X", "2X"].iter().enumerate() {
        let observed = (err2[k] / count).sqrt();
        let reported = (se2[k] / count).sqrt();
        println!(
            "ordertrack noise {label} {model:?} {name}: {m:.2} samples/rev, N {N}, {SEEDS} seeds: \
             scatter / analytic {:.3}, reported / scatter {:.3}",
            observed / analytic,
            reported / observed
        );
        assert!(
            (observed / analytic - 1.0).abs() < 0.2,
            "{name}: {observed} {analytic}"
        );
        assert!(
            (reported / observed - 1.0).abs() < 0.2,
            "{name}: {reported} {observed}"
        );
    }
}

#[test]
fn scatter_and_standard_errors_match_the_analytic_variance_f64() {
    scatter::<f64>("f64", Scatter::Trend);
    scatter::<f64>("f64", Scatter::Mean);
}

#[test]
fn scatter_and_standard_errors_match_the_analytic_variance_f32() {
    scatter::<f32>("f32", Scatter::Trend);
    scatter::<f32>("f32", Scatter::Mean);
}
