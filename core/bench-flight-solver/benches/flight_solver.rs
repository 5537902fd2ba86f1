//! Per speed step (8 real rows, 22 real unknowns, f32): rotorid-core's
//! Givens QRD/RLS against flight-solver's inverse QR-RLS (`InverseQrRls<22, 1>`,
//! one output, called once per row). flight-solver applies its forgetting
//! per row, so it gets `lambda^(1/8)` per row (the same memory per step);
//! it also updates the weights at every row (it has no deferred
//! back-substitution), so the Givens filter is measured both without and
//! with a back-substitution of the weights per step.

use criterion::measurement::WallTime;
use criterion::{criterion_group, criterion_main, BenchmarkGroup, Criterion};
use flight_solver::rls::InverseQrRls;
use nalgebra::SVector;
use rotorid_bench_flight_solver::{stream, stream_structured, Step, DELTA, LAMBDA, M, N, NB, S, W};
use rotorid_core::blockqrd::BlockQrdRls;
use rotorid_core::qrdrls::VectorQrdRls;
use rotorid_core::sqrtfree::SqrtFreeQrdRls;
use std::hint::black_box;

const STEPS: usize = 256;

/// flight-solver's inverse QR-RLS on `data`, one call per row.
fn flight_solver(group: &mut BenchmarkGroup<'_, WallTime>, data: &[Step]) {
    let rows: Vec<[(SVector<f32, M>, SVector<f32, 1>); N]> = data
        .iter()
        .map(|(u, d)| {
            core::array::from_fn(|j| (SVector::from_row_slice(&u[j]), SVector::from_element(d[j])))
        })
        .collect();
    let mut fs = InverseQrRls::<M, 1>::new(1.0 / DELTA, LAMBDA.powf(1.0 / N as f32));
    let mut i = 0usize;
    group.bench_function("flight_solver_inverse_qr", |b| {
        b.iter(|| {
            for (a, y) in &rows[i % STEPS] {
                black_box(fs.update(black_box(a), black_box(y)));
            }
            i += 1;
            black_box(fs.params());
        })
    });
}

fn benches(c: &mut Criterion) {
    let data: Vec<Step> = stream(STEPS, 0x5EED).collect();
    let mut group = c.benchmark_group("real_f32_M22_N8");

    let mut f = VectorQrdRls::<f32, M, N>::new(LAMBDA, DELTA).expect("valid parameters");
    let mut i = 0usize;
    group.bench_function("rotorid_givens", |b| {
        b.iter(|| {
            let (u, d) = &data[i % STEPS];
            i += 1;
            black_box(f.update(black_box(u), black_box(d)).expect("finite data"))
        })
    });

    let mut f = VectorQrdRls::<f32, M, N>::new(LAMBDA, DELTA).expect("valid parameters");
    let mut i = 0usize;
    group.bench_function("rotorid_givens_plus_weights", |b| {
        b.iter(|| {
            let (u, d) = &data[i % STEPS];
            i += 1;
            f.update(black_box(u), black_box(d)).expect("finite data");
            black_box(f.weights().expect("regular"))
        })
    });

    flight_solver(&mut group, &data);
    group.finish();

    // The rows of the identification (block structure): the block-
    // structured filter against flight-solver on the same rows.
    let data: Vec<Step> = stream_structured(STEPS, 0x5EED).collect();
    let mut group = c.benchmark_group("real_f32_M22_N8_structured_rows");
    let mut f = BlockQrdRls::<f32, NB, W, S>::new(LAMBDA, DELTA).expect("valid parameters");
    let (mut xi, mut gamma) = ([0.0f32; N], [0.0f32; N]);
    let mut i = 0usize;
    group.bench_function("rotorid_block_structured", |b| {
        b.iter(|| {
            let (u, d) = &data[i % STEPS];
            i += 1;
            f.update_rows(
                black_box(u.as_flattened()),
                black_box(d),
                &mut xi,
                &mut gamma,
            )
            .expect("finite data");
            black_box(&xi);
        })
    });
    let mut f = BlockQrdRls::<f32, NB, W, S>::new(LAMBDA, DELTA).expect("valid parameters");
    let mut w = [0.0f32; M];
    let mut i = 0usize;
    group.bench_function("rotorid_block_structured_plus_weights", |b| {
        b.iter(|| {
            let (u, d) = &data[i % STEPS];
            i += 1;
            f.update_rows(
                black_box(u.as_flattened()),
                black_box(d),
                &mut xi,
                &mut gamma,
            )
            .expect("finite data");
            f.weights(&mut w).expect("regular");
            black_box(&w);
        })
    });
    // The square-root-free block filter, on rows of `M` entries (checked,
    // grouped) and on compact rows (block index, block entries, shared
    // entries).
    let mut f = SqrtFreeQrdRls::<f32, NB, W, S>::new(LAMBDA, DELTA).expect("valid parameters");
    let mut i = 0usize;
    group.bench_function("rotorid_sqrt_free", |b| {
        b.iter(|| {
            let (u, d) = &data[i % STEPS];
            i += 1;
            f.update_rows(
                black_box(u.as_flattened()),
                black_box(d),
                &mut xi,
                &mut gamma,
            )
            .expect("finite data");
            black_box(&xi);
        })
    });
    // Grouped rows: the same rows of `M` entries, read as the identifier
    // hands them (two rows per channel, each in its channel's block).
    let mut f = SqrtFreeQrdRls::<f32, NB, W, S>::new(LAMBDA, DELTA).expect("valid parameters");
    let mut i = 0usize;
    group.bench_function("rotorid_sqrt_free_grouped", |b| {
        b.iter(|| {
            let (u, d) = &data[i % STEPS];
            i += 1;
            f.update_grouped_rows(
                black_box(u.as_flattened()),
                black_box(d),
                &mut xi,
                &mut gamma,
            )
            .expect("finite data");
            black_box(&xi);
        })
    });
    #[allow(clippy::type_complexity)]
    let compact: Vec<([usize; N], [[f32; W]; N], [[f32; S]; N])> = data
        .iter()
        .map(|(u, _)| {
            (
                core::array::from_fn(|j| j / 2),
                core::array::from_fn(|j| core::array::from_fn(|k| u[j][(j / 2) * W + k])),
                core::array::from_fn(|j| core::array::from_fn(|k| u[j][NB * W + k])),
            )
        })
        .collect();
    for weights in [false, true] {
        let name = if weights {
            "rotorid_sqrt_free_compact_plus_weights"
        } else {
            "rotorid_sqrt_free_compact"
        };
        let mut f = SqrtFreeQrdRls::<f32, NB, W, S>::new(LAMBDA, DELTA).expect("valid parameters");
        let mut w = [0.0f32; M];
        let mut i = 0usize;
        group.bench_function(name, |b| {
            b.iter(|| {
                let (blocks, a, c) = &compact[i % STEPS];
                let d = &data[i % STEPS].1;
                i += 1;
                f.update_block_rows(
                    black_box(blocks),
                    black_box(a.as_flattened()),
                    black_box(c.as_flattened()),
                    black_box(d),
                    &mut xi,
                    &mut gamma,
                )
                .expect("finite data");
                if weights {
                    f.weights(&mut w).expect("regular");
                }
                black_box(&xi);
                black_box(&w);
            })
        });
    }
    flight_solver(&mut group, &data);
    group.finish();
}

criterion_group!(flight, benches);
criterion_main!(flight);
