//! Building the bearing-level tables of the paper rotor for 1000 speeds:
//! the modal reduction (one Hermitian eigendecomposition, then one
//! matrix-vector product per speed; what `rotorid tables` uses), the banded
//! reduction (one banded LU of `Z_ii` per speed) and the dense reference
//! (dense `Z_ii` and dense LU per speed), same algebra, same run, set-up
//! included.
//!
//! ```sh
//! cargo bench --bench tables
//! ```

use criterion::{criterion_group, criterion_main, Criterion};
use rotorid::fe::assembly::FeModel;
use rotorid::model::RotorModel;
use rotorid::reduce::{DenseReducer, Reducer};
use rotorid::tables::grid::linspace;
use rotorid::units::rpm_to_rad_s;
use std::hint::black_box;

fn tables_1000_speeds(c: &mut Criterion) {
    let model = RotorModel::paper();
    let fe = FeModel::new(&model).expect("paper model");
    let speeds = linspace(rpm_to_rad_s(15.0), rpm_to_rad_s(15000.0), 1000);
    let mut g = c.benchmark_group("tables_1000_speeds");
    g.sample_size(10);
    g.bench_function("modal", |b| {
        b.iter(|| {
            let r = Reducer::new(&fe, &model).expect("reducer");
            let m = r.modal().expect("modal");
            for &w in &speeds {
                black_box(m.reduce(black_box(w)).expect("reduce"));
            }
        })
    });
    g.bench_function("banded", |b| {
        b.iter(|| {
            let r = Reducer::new(&fe, &model).expect("reducer");
            for &w in &speeds {
                black_box(r.reduce(black_box(w)).expect("reduce"));
            }
        })
    });
    g.bench_function("dense", |b| {
        b.iter(|| {
            let r = DenseReducer::new(&fe, &model).expect("reducer");
            for &w in &speeds {
                black_box(r.reduce(black_box(w)).expect("reduce"));
            }
        })
    });
    g.finish();
}

criterion_group!(benches, tables_1000_speeds);
criterion_main!(benches);
