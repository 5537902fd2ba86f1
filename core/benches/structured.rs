//! The identification's filter update, block-structured against dense:
//! the block-arrowhead QRD/RLS (`rotorid_core::blockqrd`), the dense Givens
//! QRD/RLS (`rotorid_core::qrdrls`), the conventional RLS (Eqs. 10-13) and
//! the paper's stack-and-QR, on the same stream of rows with the structure
//! of the physical regression: `2 N_b` channels, each giving a real and an
//! imaginary row that touch only that channel's `W` bearing coefficients
//! and the `S` shared unbalance unknowns (`BlockShape::of`). Cases:
//! `N_b = 2, N_p = 3` and `N_b = 4, N_p = 5`, order 1 and 2, f32 and f64;
//! and the growth of the cost with `N_b = 1..8` (`N_p = 3`, order 1, f64),
//! structured against dense Givens. `dense_givens_dense_rows` is the dense
//! filter on rows without structural zeros: the general `O(M^2)` per row
//! cost that the structure avoids (on the structured rows the dense kernel
//! already skips the rotations of zero entries).
//!
//! `cargo bench -p rotorid-core --features baseline --bench structured -- --warm-up-time 1 --measurement-time 2`

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use nalgebra::ComplexField;
use num_complex::Complex;
use rotorid_core::baseline::{ConventionalRls, StackQrRls};
use rotorid_core::blockqrd::{BlockQrdRls, BlockShape};
use rotorid_core::parametrization::Structure;
use rotorid_core::qrdrls::VectorQrdRls;
use rotorid_core::sqrtfree::SqrtFreeQrdRls;
use rotorid_core::Real;
use std::hint::black_box;

const STEPS: usize = 256;
const LAMBDA: f64 = 0.999;
const DELTA: f64 = 1e-3;

#[path = "../src/testrng.rs"]
mod testrng;
use testrng::SplitMix64;

/// A field element with both parts uniform in [-1, 1) (the imaginary part
/// dropped for a real field).
trait Sample: ComplexField<RealField = <Self as Sample>::Re> + Copy {
    type Re: Real;
    fn sample(rng: &mut SplitMix64) -> Self;
}
impl Sample for f64 {
    type Re = f64;
    fn sample(rng: &mut SplitMix64) -> Self {
        rng.sym()
    }
}
impl Sample for f32 {
    type Re = f32;
    fn sample(rng: &mut SplitMix64) -> Self {
        rng.sym() as f32
    }
}
impl<T: Real> Sample for Complex<T> {
    type Re = T;
    fn sample(rng: &mut SplitMix64) -> Self {
        Complex::new(T::lit(rng.sym()), T::lit(rng.sym()))
    }
}

/// A stream of `STEPS` updates of `N` rows over `shape`: row `j` belongs
/// to channel `j / (N / NB)` (the real and imaginary row of each channel in
/// the real formulation, one complex row in the complex one), non-zero in
/// that channel's block and in the shared columns.
#[allow(clippy::type_complexity)]
fn stream<F: Sample, const M: usize, const N: usize>(
    shape: BlockShape,
    all_dense: bool,
) -> Vec<([[F; M]; N], [F; N])> {
    let mut rng = SplitMix64::new(0x5EED);
    let w: [F; M] = core::array::from_fn(|_| F::sample(&mut rng));
    let nbw = shape.blocks * shape.width;
    let per_block = N / shape.blocks;
    (0..STEPS)
        .map(|_| {
            let u: [[F; M]; N] = core::array::from_fn(|j| {
                let b = j / per_block;
                core::array::from_fn(|k| {
                    let in_block = k >= b * shape.width && k < (b + 1) * shape.width;
                    if all_dense || in_block || k >= nbw {
                        F::sample(&mut rng)
                    } else {
                        F::zero()
                    }
                })
            });
            let d: [F; N] = core::array::from_fn(|j| {
                let mut acc = F::sample(&mut rng).scale(F::Re::lit(1e-3));
                for k in 0..M {
                    acc += u[j][k] * w[k];
                }
                acc
            });
            (u, d)
        })
        .collect()
}

fn structured<
    F: Sample<Re = T>,
    T: Real,
    const NB: usize,
    const W: usize,
    const S: usize,
    const M: usize,
    const N: usize,
>(
    c: &mut Criterion,
    group: &str,
    param: &str,
    baselines: bool,
) {
    let shape = BlockShape {
        blocks: NB,
        width: W,
        shared: S,
    };
    assert_eq!(shape.unknowns(), M);
    assert_eq!(N % NB, 0);
    let data = stream::<F, M, N>(shape, false);
    let dense_rows = stream::<F, M, N>(shape, true);
    let (lambda, delta) = (T::lit(LAMBDA), T::lit(DELTA));
    let mut g = c.benchmark_group(group.to_string());
    let (mut xi, mut gamma) = ([F::zero(); N], [T::zero(); N]);

    let mut blk = BlockQrdRls::<F, NB, W, S>::new(lambda, delta).expect("valid parameters");
    let mut i = 0usize;
    g.bench_function(BenchmarkId::new("structured", param), |b| {
        b.iter(|| {
            let (u, d) = &data[i % STEPS];
            i += 1;
            blk.update_rows(
                black_box(u.as_flattened()),
                black_box(d),
                &mut xi,
                &mut gamma,
            )
            .expect("finite data");
            black_box(&xi);
        })
    });

    // The square-root-free filter on the same rows, given as rows of `M`
    // entries and in the compact form (block index, block and shared
    // entries).
    let mut sf = SqrtFreeQrdRls::<F, NB, W, S>::new(lambda, delta).expect("valid parameters");
    let mut i = 0usize;
    g.bench_function(BenchmarkId::new("sqrt_free", param), |b| {
        b.iter(|| {
            let (u, d) = &data[i % STEPS];
            i += 1;
            sf.update_rows(
                black_box(u.as_flattened()),
                black_box(d),
                &mut xi,
                &mut gamma,
            )
            .expect("finite data");
            black_box(&xi);
        })
    });
    let per_block = N / NB;
    #[allow(clippy::type_complexity)]
    let compact: Vec<([usize; N], [[F; W]; N], [[F; S]; N])> = data
        .iter()
        .map(|(u, _)| {
            (
                core::array::from_fn(|j| j / per_block),
                core::array::from_fn(|j| {
                    let b = j / per_block;
                    core::array::from_fn(|k| u[j][b * W + k])
                }),
                core::array::from_fn(|j| core::array::from_fn(|k| u[j][NB * W + k])),
            )
        })
        .collect();
    let mut sf = SqrtFreeQrdRls::<F, NB, W, S>::new(lambda, delta).expect("valid parameters");
    let mut i = 0usize;
    g.bench_function(BenchmarkId::new("sqrt_free_compact", param), |b| {
        b.iter(|| {
            let (blocks, a, c) = &compact[i % STEPS];
            let d = &data[i % STEPS].1;
            i += 1;
            sf.update_block_rows(
                black_box(blocks),
                black_box(a.as_flattened()),
                black_box(c.as_flattened()),
                black_box(d),
                &mut xi,
                &mut gamma,
            )
            .expect("finite data");
            black_box(&xi);
        })
    });

    let mut dense = VectorQrdRls::<F, M, N>::new(lambda, delta).expect("valid parameters");
    let mut i = 0usize;
    g.bench_function(BenchmarkId::new("dense_givens", param), |b| {
        b.iter(|| {
            let (u, d) = &data[i % STEPS];
            i += 1;
            black_box(
                dense
                    .update(black_box(u), black_box(d))
                    .expect("finite data"),
            )
        })
    });

    if baselines {
        // The general filter's cost: every entry of every row non-zero, no
        // rotation skipped (O(M^2) per row).
        let mut general = VectorQrdRls::<F, M, N>::new(lambda, delta).expect("valid parameters");
        let mut i = 0usize;
        g.bench_function(BenchmarkId::new("dense_givens_dense_rows", param), |b| {
            b.iter(|| {
                let (u, d) = &dense_rows[i % STEPS];
                i += 1;
                black_box(
                    general
                        .update(black_box(u), black_box(d))
                        .expect("finite data"),
                )
            })
        });
        let mut conv = ConventionalRls::<F>::new(M, delta, None).expect("valid parameters");
        let mut i = 0usize;
        g.bench_function(BenchmarkId::new("conventional_rls", param), |b| {
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
        g.bench_function(BenchmarkId::new("stack_and_qr", param), |b| {
            b.iter(|| {
                let (u, d) = &data[i % STEPS];
                i += 1;
                stack
                    .update(black_box(u.as_flattened()), black_box(d), lambda)
                    .expect("finite data");
            })
        });
    }
    g.finish();
}

/// `case!(T, N_b, N_p, order, group, param, baselines)`.
macro_rules! case {
    ($t:ty, $nb:expr, $np:expr, $order:expr, $c:expr, $group:expr, $param:expr, $base:expr) => {{
        const SH: BlockShape = BlockShape::of(Structure::physical($order), $nb, $np);
        structured::<
            $t,
            $t,
            { SH.blocks },
            { SH.width },
            { SH.shared },
            { SH.blocks * SH.width + SH.shared },
            { 2 * SH.blocks },
        >($c, $group, $param, $base);
    }};
}

/// The paper's own formulation at its size: complex, `N_b = 2`, `N_p = 3`,
/// order 1 (`M = 19`: 4 channel blocks of 4, 3 shared unbalance unknowns;
/// one complex row per channel, `N = 4`).
fn paper_size(c: &mut Criterion) {
    const SH: BlockShape = BlockShape::of(Structure::paper(1), 2, 3);
    structured::<Complex<f64>, f64, { SH.blocks }, { SH.width }, { SH.shared }, 19, 4>(
        c,
        "paper_size/complex_f64",
        "Nb2_Np3_order1",
        true,
    );
    structured::<Complex<f32>, f32, { SH.blocks }, { SH.width }, { SH.shared }, 19, 4>(
        c,
        "paper_size/complex_f32",
        "Nb2_Np3_order1",
        true,
    );
}

fn benches(c: &mut Criterion) {
    paper_size(c);
    case!(
        f64,
        2,
        3,
        1,
        c,
        "identification_update/f64",
        "Nb2_Np3_order1",
        true
    );
    case!(
        f64,
        2,
        3,
        2,
        c,
        "identification_update/f64",
        "Nb2_Np3_order2",
        true
    );
    case!(
        f64,
        4,
        5,
        1,
        c,
        "identification_update/f64",
        "Nb4_Np5_order1",
        true
    );
    case!(
        f64,
        4,
        5,
        2,
        c,
        "identification_update/f64",
        "Nb4_Np5_order2",
        true
    );
    case!(
        f32,
        2,
        3,
        1,
        c,
        "identification_update/f32",
        "Nb2_Np3_order1",
        true
    );
    case!(
        f32,
        2,
        3,
        2,
        c,
        "identification_update/f32",
        "Nb2_Np3_order2",
        true
    );
    case!(
        f32,
        4,
        5,
        1,
        c,
        "identification_update/f32",
        "Nb4_Np5_order1",
        true
    );
    case!(
        f32,
        4,
        5,
        2,
        c,
        "identification_update/f32",
        "Nb4_Np5_order2",
        true
    );
    case!(f64, 1, 3, 1, c, "growth_with_bearings/f64", "Nb1", false);
    case!(f64, 2, 3, 1, c, "growth_with_bearings/f64", "Nb2", false);
    case!(f64, 3, 3, 1, c, "growth_with_bearings/f64", "Nb3", false);
    case!(f64, 4, 3, 1, c, "growth_with_bearings/f64", "Nb4", false);
    case!(f64, 5, 3, 1, c, "growth_with_bearings/f64", "Nb5", false);
    case!(f64, 6, 3, 1, c, "growth_with_bearings/f64", "Nb6", false);
    case!(f64, 7, 3, 1, c, "growth_with_bearings/f64", "Nb7", false);
    case!(f64, 8, 3, 1, c, "growth_with_bearings/f64", "Nb8", false);
}

criterion_group!(structured_benches, benches);
criterion_main!(structured_benches);
