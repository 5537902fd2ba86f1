//! Tracking: with lambda < 1 the QRD/RLS follows a parameter vector that
//! changes mid-stream; with lambda = 1 it does not.

use crate::common::*;
use rotorid_core::qrdrls::VectorQrdRls;

const M: usize = 4;
const N: usize = 2;

fn run(lambda: f64) -> Vec<f64> {
    let mut rng = SplitMix64::new(31);
    let w1: [C64; M] = core::array::from_fn(|_| rng.c());
    let w2: [C64; M] = core::array::from_fn(|_| rng.c());
    let mut f = VectorQrdRls::<C64, M, N>::new(lambda, 1e-3).unwrap();
    let mut errs = Vec::new();
    for n in 0..1000 {
        let w = if n < 400 { &w1 } else { &w2 };
        let u: [[C64; M]; N] = core::array::from_fn(|_| core::array::from_fn(|_| rng.c()));
        let d: [C64; N] = core::array::from_fn(|j| (0..M).map(|k| u[j][k] * w[k]).sum());
        f.update(&u, &d).unwrap();
        let est = f.weights().unwrap();
        errs.push(rel_diff(&est, w));
    }
    errs
}

#[test]
fn forgetting_tracks_a_parameter_change() {
    let e = run(0.95);
    // Before the change: converged to w1 (the prior weighs 0.95^399 * 1e-3).
    assert!(e[399] < 1e-8, "{:e}", e[399]);
    // Just after: the estimate still carries the old data.
    assert!(e[405] > 1e-2, "{:e}", e[405]);
    // Old data weigh 0.95^k after k steps: about 1e-9 after 400 steps.
    assert!(e[799] < 1e-6, "{:e}", e[799]);
    assert!(e[999] < 1e-8, "{:e}", e[999]);
    // The error decays monotonically-ish: each 100 steps gain at least 10x.
    for k in [450, 550, 650] {
        assert!(
            e[k + 100] < 0.1 * e[k],
            "{k}: {:e} -> {:e}",
            e[k],
            e[k + 100]
        );
    }
}

#[test]
fn without_forgetting_the_change_is_averaged() {
    let e = run(1.0);
    // No forgetting: the prior delta = 1e-3 keeps a small bias (~1e-6).
    assert!(e[399] < 1e-5, "{:e}", e[399]);
    // 600 new steps against 400 old ones: a compromise, not w2.
    assert!(e[999] > 0.1, "{:e}", e[999]);
}
