//! One identification step at the paper's size (2 bearings, 3 planes) on the
//! firmware type: form the regression from given terms, scale, guard, Givens
//! update; for each structure in f32 and f64, beside the bare filter update
//! of the same size (the baseline: what the regression formation adds).
//!
//! `cargo bench --bench identify -- --warm-up-time 1 --measurement-time 3`

use criterion::{criterion_group, criterion_main, Criterion};
use num_complex::Complex;
use rotorid::core::identify::{Config, IdField, Identifier, SteadyPolicy};
use rotorid::core::parametrization::Structure;
use rotorid::core::qrdrls::VectorQrdRls;
use rotorid::core::scaling::ColumnScaling;
use rotorid::core::Real;
use rotorid::fe::assembly::FeModel;
use rotorid::fe::response::{unbalance_response, Forcing};
use rotorid::model::RotorModel;
use rotorid::reduce::reduce;
use rotorid::units::rpm_to_rad_s;
use std::hint::black_box;

const NQ: usize = 4;
const NP: usize = 3;

struct Data<T> {
    omega: Vec<T>,
    a: Vec<[[Complex<T>; NQ]; NQ]>,
    b: Vec<[[Complex<T>; NP]; NQ]>,
    q: Vec<[Complex<T>; NQ]>,
}

fn data<T: Real>() -> Data<T> {
    let model = RotorModel::paper();
    let fe = FeModel::new(&model).expect("model");
    let speeds: Vec<f64> = (1..=300).map(|i| rpm_to_rad_s(50.0 * i as f64)).collect();
    let resp = unbalance_response(&fe, &Forcing::from_model(&model), &speeds).expect("response");
    let c = |z: Complex<f64>| Complex::new(T::lit(z.re), T::lit(z.im));
    let mut d = Data {
        omega: vec![],
        a: vec![],
        b: vec![],
        q: vec![],
    };
    for (w, r) in speeds.iter().zip(&resp) {
        let t = reduce(&fe, &model, *w).expect("terms");
        let (a, b) = (t.a, t.b);
        d.omega.push(T::lit(*w));
        d.a.push(core::array::from_fn(|i| {
            core::array::from_fn(|j| c(a[(i, j)]))
        }));
        d.b.push(core::array::from_fn(|i| {
            core::array::from_fn(|j| c(b[(i, j)]))
        }));
        d.q.push(core::array::from_fn(|i| c(r.bearings[i])));
    }
    d
}

fn bench_one<T: Real, F: IdField<T>, const M: usize, const N: usize>(
    c: &mut Criterion,
    name: &str,
    structure: Structure,
    d: &Data<T>,
) {
    let config = Config {
        structure,
        lambda: T::lit(0.999),
        delta: T::lit(1e-7),
        scaling: ColumnScaling::new(2.1e7, rpm_to_rad_s(15000.0), 3.4e-4).expect("scaling"),
        normalise_rows: false,
        steady: SteadyPolicy::off(),
    };
    let mut g = c.benchmark_group(format!("identify_step_{name}"));
    g.bench_function("identifier_step", |bch| {
        let mut id = Identifier::<T, F, NQ, NP, M, N>::new(config).expect("config");
        let mut i = 0;
        bch.iter(|| {
            i = (i + 1) % d.omega.len();
            black_box(
                id.update_with_terms(d.omega[i], &d.a[i], &d.b[i], &d.q[i])
                    .expect("step"),
            )
        })
    });
    g.bench_function("filter_update_only", |bch| {
        let mut f = VectorQrdRls::<F, M, N>::new(T::lit(0.999), T::lit(1e-7)).expect("filter");
        let u = [[F::one(); M]; N];
        let mut dd = [F::zero(); N];
        let mut i = 0;
        bch.iter(|| {
            i = (i + 1) % 97;
            dd[0] = F::from_real(T::lit(i as f64));
            black_box(f.update(black_box(&u), &dd).expect("update"))
        })
    });
    g.finish();
}

fn identify(c: &mut Criterion) {
    let d64 = data::<f64>();
    let d32 = data::<f32>();
    bench_one::<f64, Complex<f64>, 19, 4>(c, "paper1_f64", Structure::paper(1), &d64);
    bench_one::<f32, Complex<f32>, 19, 4>(c, "paper1_f32", Structure::paper(1), &d32);
    bench_one::<f64, f64, 22, 8>(c, "physical1_f64", Structure::physical(1), &d64);
    bench_one::<f32, f32, 22, 8>(c, "physical1_f32", Structure::physical(1), &d32);
}

criterion_group!(benches, identify);
criterion_main!(benches);
