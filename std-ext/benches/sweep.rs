//! A 1000-speed unbalance sweep of the paper rotor (50 to 15000 rpm):
//! banded LU per speed (the library path) against a dense complex LU per
//! speed (nalgebra), same inputs, same criterion run.
//!
//! `cargo bench --bench sweep -- --warm-up-time 1 --measurement-time 3`

use criterion::{criterion_group, criterion_main, Criterion};
use rotorid::fe::assembly::FeModel;
use rotorid::fe::response::{unbalance_response, unbalance_response_dense, Forcing};
use rotorid::model::RotorModel;
use rotorid::units::rpm_to_rad_s;
use std::hint::black_box;

fn sweep(c: &mut Criterion) {
    let model = RotorModel::paper();
    let fe = FeModel::new(&model).expect("paper model is valid");
    let forcing = Forcing::from_model(&model);
    let speeds: Vec<f64> = (0..1000)
        .map(|i| rpm_to_rad_s(50.0 + (15000.0 - 50.0) * i as f64 / 999.0))
        .collect();
    // Same answer from both paths before timing them.
    let a = unbalance_response(&fe, &forcing, &speeds[..5]).expect("banded");
    let b = unbalance_response_dense(&fe, &forcing, &speeds[..5]).expect("dense");
    for (x, y) in a.iter().zip(&b) {
        for (u, v) in x.q.iter().zip(&y.q) {
            assert!((u - v).norm() <= 1e-9 * (1.0 + v.norm()));
        }
    }
    let mut g = c.benchmark_group("unbalance_sweep_1000_speeds");
    g.sample_size(10);
    g.bench_function("banded_lu", |bch| {
        bch.iter(|| {
            unbalance_response(black_box(&fe), &forcing, black_box(&speeds)).expect("banded")
        })
    });
    g.bench_function("dense_lu", |bch| {
        bch.iter(|| {
            unbalance_response_dense(black_box(&fe), &forcing, black_box(&speeds)).expect("dense")
        })
    });
    g.finish();
}

criterion_group!(benches, sweep);
criterion_main!(benches);
