//! Per-update time of the Givens vector QRD/RLS against the conventional
//! RLS (Eqs. 10-13) and the paper's stack-and-QR method, on the same
//! random data stream, at the paper's size (M = 19 complex unknowns, N = 4
//! rows), at M = 40, N = 8 (complex), in f32 and f64, and for the real
//! formulation in f32 (M = 22, N = 8). The `paper_rows` cases use rows
//! with the sparsity of the paper's own data matrix (Eq. 46: a row of
//! bearing `m`, direction y or z, touches the 4 `Z_0`, `Z_1` columns of
//! that bearing and direction and the 3 unbalance columns, 7 of 19), which
//! the Givens kernel exploits (a zero entry skips its rotation) and a dense
//! QR or the matrix-inversion-lemma RLS cannot.
//!
//! `cargo bench -p rotorid-core --features baseline --bench qrdrls`

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use nalgebra::ComplexField;
use num_complex::Complex;
use rotorid_core::baseline::{ConventionalRls, StackQrRls};
use rotorid_core::qrdrls::VectorQrdRls;
use rotorid_core::Real;
use std::hint::black_box;

/// Number of distinct steps cycled through (keeps data in cache, avoids
/// measuring the generator).
const STEPS: usize = 256;
const LAMBDA: f64 = 0.999;
const DELTA: f64 = 1e-3;

#[path = "../src/testrng.rs"]
mod testrng;
use testrng::SplitMix64;

trait BenchField: ComplexField<RealField = Self::R> + Copy {
    type R: Real;
    fn gen(rng: &mut SplitMix64) -> Self;
}
impl BenchField for f32 {
    type R = f32;
    fn gen(rng: &mut SplitMix64) -> Self {
        rng.sym() as f32
    }
}
impl BenchField for f64 {
    type R = f64;
    fn gen(rng: &mut SplitMix64) -> Self {
        rng.sym()
    }
}
impl BenchField for Complex<f32> {
    type R = f32;
    fn gen(rng: &mut SplitMix64) -> Self {
        Complex::new(rng.sym() as f32, rng.sym() as f32)
    }
}
impl BenchField for Complex<f64> {
    type R = f64;
    fn gen(rng: &mut SplitMix64) -> Self {
        Complex::new(rng.sym(), rng.sym())
    }
}

/// Dense rows: every entry non-zero.
fn dense(_row: usize, _col: usize) -> bool {
    true
}

/// The non-zero pattern of the paper's data matrix for 2 bearings and 3
/// planes (Eqs. 46-48, M = 19, N = 4): unknowns of bearing `m` at columns
/// `8 m .. 8 m + 8` ordered `Z0yy, Z0yz, Z1yy, Z1yz, Z0zy, Z0zz, Z1zy,
/// Z1zz`, planes at 16..19; row `2 m` is bearing `m`'s y equation, `2 m + 1`
/// its z equation.
fn paper_pattern(row: usize, col: usize) -> bool {
    let (m, dir) = (row / 2, row % 2);
    col >= 16 || (col / 8 == m && (col % 8) / 4 == dir)
}

#[allow(clippy::type_complexity)]
fn stream<F: BenchField, const M: usize, const N: usize>(
    pattern: fn(usize, usize) -> bool,
) -> Vec<([[F; M]; N], [F; N])> {
    let mut rng = SplitMix64::new(0x5EED);
    let w: [F; M] = core::array::from_fn(|_| F::gen(&mut rng));
    (0..STEPS)
        .map(|_| {
            let u: [[F; M]; N] = core::array::from_fn(|j| {
                core::array::from_fn(|k| {
                    if pattern(j, k) {
                        F::gen(&mut rng)
                    } else {
                        F::zero()
                    }
                })
            });
            let d: [F; N] = core::array::from_fn(|j| {
                let mut acc = F::gen(&mut rng).scale(F::R::lit(1e-3));
                for k in 0..M {
                    acc += u[j][k] * w[k];
                }
                acc
            });
            (u, d)
        })
        .collect()
}

fn bench_case<F: BenchField, const M: usize, const N: usize>(c: &mut Criterion, label: &str) {
    bench_pattern::<F, M, N>(c, label, dense);
}

fn bench_pattern<F: BenchField, const M: usize, const N: usize>(
    c: &mut Criterion,
    label: &str,
    pattern: fn(usize, usize) -> bool,
) {
    let data = stream::<F, M, N>(pattern);
    let lambda = F::R::lit(LAMBDA);
    let delta = F::R::lit(DELTA);
    let mut group = c.benchmark_group(format!("qrdrls_update/{label}"));

    let mut f = VectorQrdRls::<F, M, N>::new(lambda, delta).expect("valid parameters");
    let mut i = 0usize;
    group.bench_function(BenchmarkId::from_parameter("givens"), |b| {
        b.iter(|| {
            let (u, d) = &data[i % STEPS];
            i += 1;
            black_box(f.update(black_box(u), black_box(d)).expect("finite data"))
        })
    });

    let mut conv = ConventionalRls::<F>::new(M, delta, None).expect("valid parameters");
    let (mut xi, mut gamma) = ([F::zero(); N], [F::R::lit(0.0); N]);
    let mut i = 0usize;
    group.bench_function(BenchmarkId::from_parameter("conventional_rls"), |b| {
        b.iter(|| {
            let (u, d) = &data[i % STEPS];
            i += 1;
            conv.update(
                black_box(u.as_flattened()),
                black_box(d),
                lambda,
                &mut xi,
                &mut gamma,
            )
            .expect("finite data");
            black_box(&xi);
        })
    });

    let mut stack = StackQrRls::<F>::new(M, delta, None).expect("valid parameters");
    let mut i = 0usize;
    group.bench_function(BenchmarkId::from_parameter("stack_and_qr"), |b| {
        b.iter(|| {
            let (u, d) = &data[i % STEPS];
            i += 1;
            stack
                .update(black_box(u.as_flattened()), black_box(d), lambda)
                .expect("finite data");
        })
    });
    group.finish();
}

fn benches(c: &mut Criterion) {
    bench_case::<Complex<f64>, 19, 4>(c, "M19_N4_complex_f64");
    bench_case::<Complex<f32>, 19, 4>(c, "M19_N4_complex_f32");
    bench_case::<Complex<f64>, 40, 8>(c, "M40_N8_complex_f64");
    bench_case::<Complex<f32>, 40, 8>(c, "M40_N8_complex_f32");
    bench_case::<f32, 22, 8>(c, "M22_N8_real_f32");
    bench_pattern::<Complex<f64>, 19, 4>(c, "M19_N4_complex_f64_paper_rows", paper_pattern);
    bench_pattern::<Complex<f32>, 19, 4>(c, "M19_N4_complex_f32_paper_rows", paper_pattern);
}

criterion_group!(qrdrls, benches);
criterion_main!(qrdrls);
