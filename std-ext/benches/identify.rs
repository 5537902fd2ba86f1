//! One identification step at the paper's size (2 bearings, 3 planes) on the
//! firmware type: form the regression from given terms, scale, guard, filter
//! update; for each structure in f32 and f64, beside the bare filter update
//! of the same size (the baseline: what the regression formation adds).
//! The identifier runs with the square-root-free block filter (the generated
//! `type Id`), the Givens block filter and the dense one; the bare filters
//! are compared on rows of the identification's structure (one channel's
//! block plus the shared unbalance columns), and the growth of the update cost with the number of
//! bearings `N_b = 1, 2, 4, 8` (physical order 1, 3 planes, f64).
//!
//! `cargo bench --bench identify -- --warm-up-time 1 --measurement-time 3`

use criterion::{criterion_group, criterion_main, Criterion};
use num_complex::Complex;
use rotorid::core::blockqrd::{BlockFactor, BlockQrdRls};
use rotorid::core::factor::DenseFactor;
use rotorid::core::identify::{Config, IdField, Identifier, SteadyPolicy};
use rotorid::core::parametrization::Structure;
use rotorid::core::qrdrls::VectorQrdRls;
use rotorid::core::scaling::ColumnScaling;
use rotorid::core::sqrtfree::SqrtFreeFactor;
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

/// Rows of the identification's structure: row `j` in block `j / (N / NB)`
/// (its `W` columns) and the `S` shared columns, pseudo-random values.
fn structured_rows<T: Real, F: IdField<T>>(nb: usize, w: usize, m: usize, n: usize) -> Vec<F> {
    let per = n / nb;
    let mut u = vec![F::zero(); n * m];
    let mut x = 0x2545_f491_4f6c_dd1d_u64;
    for j in 0..n {
        let b = j / per;
        for k in 0..m {
            if (k >= b * w && k < (b + 1) * w) || k >= nb * w {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                u[j * m + k] = F::from_real(T::lit((x >> 11) as f64 / (1u64 << 53) as f64 - 0.5));
            }
        }
    }
    u
}

fn bench_one<
    T: Real,
    F: IdField<T>,
    const M: usize,
    const N: usize,
    const W: usize,
    const S: usize,
>(
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
        let mut id =
            Identifier::<T, F, NQ, NP, M, N, DenseFactor<F, M>>::new(config).expect("config");
        let mut i = 0;
        bch.iter(|| {
            i = (i + 1) % d.omega.len();
            black_box(
                id.update_with_terms(d.omega[i], &d.a[i], &d.b[i], &d.q[i])
                    .expect("step"),
            )
        })
    });
    g.bench_function("identifier_step_block", |bch| {
        let mut id = Identifier::<T, F, NQ, NP, M, N, BlockFactor<F, NQ, W, S>>::new(config)
            .expect("config");
        let mut i = 0;
        bch.iter(|| {
            i = (i + 1) % d.omega.len();
            black_box(
                id.update_with_terms(d.omega[i], &d.a[i], &d.b[i], &d.q[i])
                    .expect("step"),
            )
        })
    });
    g.bench_function("identifier_step_sqrt_free", |bch| {
        let mut id = Identifier::<T, F, NQ, NP, M, N, SqrtFreeFactor<F, NQ, W, S>>::new(config)
            .expect("config");
        let mut i = 0;
        bch.iter(|| {
            i = (i + 1) % d.omega.len();
            black_box(
                id.update_with_terms(d.omega[i], &d.a[i], &d.b[i], &d.q[i])
                    .expect("step"),
            )
        })
    });
    let su = structured_rows::<T, F>(NQ, W, M, N);
    g.bench_function("filter_dense_structured_rows", |bch| {
        let mut u = [[F::zero(); M]; N];
        for (row, src) in u.iter_mut().zip(su.chunks_exact(M)) {
            row.copy_from_slice(src);
        }
        let mut f = VectorQrdRls::<F, M, N>::new(T::lit(0.999), T::lit(1e-7)).expect("filter");
        let mut dd = [F::zero(); N];
        let mut i = 0;
        bch.iter(|| {
            i = (i + 1) % 97;
            dd[0] = F::from_real(T::lit(i as f64));
            black_box(f.update(black_box(&u), &dd).expect("update"))
        })
    });
    g.bench_function("filter_block_structured_rows", |bch| {
        let mut f = BlockQrdRls::<F, NQ, W, S>::new(T::lit(0.999), T::lit(1e-7)).expect("filter");
        let mut dd = [F::zero(); N];
        let (mut xi, mut gamma) = ([F::zero(); N], [T::zero(); N]);
        let mut i = 0;
        bch.iter(|| {
            i = (i + 1) % 97;
            dd[0] = F::from_real(T::lit(i as f64));
            f.update_rows(black_box(&su), &dd, &mut xi, &mut gamma)
                .expect("update");
            black_box((&xi, &gamma));
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
    bench_one::<f64, Complex<f64>, 19, 4, 4, 3>(c, "paper1_f64", Structure::paper(1), &d64);
    bench_one::<f32, Complex<f32>, 19, 4, 4, 3>(c, "paper1_f32", Structure::paper(1), &d32);
    bench_one::<f64, f64, 22, 8, 4, 6>(c, "physical1_f64", Structure::physical(1), &d64);
    bench_one::<f32, f32, 22, 8, 4, 6>(c, "physical1_f32", Structure::physical(1), &d32);
}

/// One update of `N = 4 N_b` real rows (physical order 1, 3 planes:
/// `M = 8 N_b + 6`), dense against block-structured, for `N_b` = `NBR`.
fn growth_one<const NBR: usize, const NB: usize, const M: usize, const N: usize>(
    g: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>,
) {
    let su = structured_rows::<f64, f64>(NB, 4, M, N);
    g.bench_function(format!("dense_nb{NBR}"), |bch| {
        let mut u = [[0.0; M]; N];
        for (row, src) in u.iter_mut().zip(su.chunks_exact(M)) {
            row.copy_from_slice(src);
        }
        let mut f = VectorQrdRls::<f64, M, N>::new(0.999, 1e-7).expect("filter");
        let mut dd = [0.0; N];
        let mut i = 0;
        bch.iter(|| {
            i = (i + 1) % 97;
            dd[0] = i as f64;
            black_box(f.update(black_box(&u), &dd).expect("update"))
        })
    });
    g.bench_function(format!("block_nb{NBR}"), |bch| {
        let mut f = BlockQrdRls::<f64, NB, 4, 6>::new(0.999, 1e-7).expect("filter");
        let mut dd = [0.0; N];
        let (mut xi, mut gamma) = ([0.0; N], [0.0; N]);
        let mut i = 0;
        bch.iter(|| {
            i = (i + 1) % 97;
            dd[0] = i as f64;
            f.update_rows(black_box(&su), &dd, &mut xi, &mut gamma)
                .expect("update");
            black_box((&xi, &gamma));
        })
    });
}

fn growth(c: &mut Criterion) {
    let mut g = c.benchmark_group("filter_growth_physical1_f64");
    growth_one::<1, 2, 14, 4>(&mut g);
    growth_one::<2, 4, 22, 8>(&mut g);
    growth_one::<4, 8, 38, 16>(&mut g);
    growth_one::<8, 16, 70, 32>(&mut g);
    g.finish();
}

criterion_group!(benches, identify, growth);
criterion_main!(benches);
