//! Runs `STEPS` speed steps of one filter on the identification's rows, for
//! instruction counts under callgrind (the difference of two step counts
//! divided by the difference of steps is the cost per step, free of set-up):
//!
//! ```sh
//! cargo build --release --example icount
//! for n in 1000 2000; do valgrind --tool=callgrind --callgrind-out-file=cg.$n \
//!   target/release/examples/icount flight_solver $n; done
//! ```
//!
//! Filters: `flight_solver`, `block_structured`, `sqrt_free`, `sqrt_free_grouped`, `sqrt_free_compact`.
use flight_solver::rls::InverseQrRls;
use nalgebra::SVector;
use rotorid_bench_flight_solver::{stream_structured, Step, DELTA, LAMBDA, M, N, NB, S, W};
use rotorid_core::blockqrd::BlockQrdRls;
use rotorid_core::sqrtfree::SqrtFreeQrdRls;
use std::hint::black_box;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let (Some(which), Some(steps)) = (
        args.get(1),
        args.get(2).and_then(|s| s.parse::<usize>().ok()),
    ) else {
        eprintln!("usage: icount FILTER STEPS");
        std::process::exit(2);
    };
    let data: Vec<Step> = stream_structured(256, 0x5EED).collect();
    let (mut xi, mut gamma) = ([0.0f32; N], [0.0f32; N]);
    match which.as_str() {
        "flight_solver" => {
            let rows: Vec<[(SVector<f32, M>, SVector<f32, 1>); N]> = data
                .iter()
                .map(|(u, d)| {
                    core::array::from_fn(|j| {
                        (SVector::from_row_slice(&u[j]), SVector::from_element(d[j]))
                    })
                })
                .collect();
            let mut fs = InverseQrRls::<M, 1>::new(1.0 / DELTA, LAMBDA.powf(1.0 / N as f32));
            for i in 0..steps {
                for (a, y) in &rows[i % 256] {
                    black_box(fs.update(black_box(a), black_box(y)));
                }
                black_box(fs.params());
            }
        }
        "block_structured" => {
            let mut f = BlockQrdRls::<f32, NB, W, S>::new(LAMBDA, DELTA).expect("valid");
            for i in 0..steps {
                let (u, d) = &data[i % 256];
                f.update_rows(
                    black_box(u.as_flattened()),
                    black_box(d),
                    &mut xi,
                    &mut gamma,
                )
                .expect("finite");
                black_box(&xi);
            }
        }
        "sqrt_free" => {
            let mut f = SqrtFreeQrdRls::<f32, NB, W, S>::new(LAMBDA, DELTA).expect("valid");
            for i in 0..steps {
                let (u, d) = &data[i % 256];
                f.update_rows(
                    black_box(u.as_flattened()),
                    black_box(d),
                    &mut xi,
                    &mut gamma,
                )
                .expect("finite");
                black_box(&xi);
            }
        }
        "sqrt_free_grouped" => {
            let mut f = SqrtFreeQrdRls::<f32, NB, W, S>::new(LAMBDA, DELTA).expect("valid");
            for i in 0..steps {
                let (u, d) = &data[i % 256];
                f.update_grouped_rows(
                    black_box(u.as_flattened()),
                    black_box(d),
                    &mut xi,
                    &mut gamma,
                )
                .expect("finite");
                black_box(&xi);
            }
        }
        "sqrt_free_compact" => {
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
            let mut f = SqrtFreeQrdRls::<f32, NB, W, S>::new(LAMBDA, DELTA).expect("valid");
            for i in 0..steps {
                let (blocks, a, c) = &compact[i % 256];
                f.update_block_rows(
                    black_box(blocks),
                    black_box(a.as_flattened()),
                    black_box(c.as_flattened()),
                    black_box(&data[i % 256].1),
                    &mut xi,
                    &mut gamma,
                )
                .expect("finite");
                black_box(&xi);
            }
        }
        _ => {
            eprintln!("unknown filter {which}");
            std::process::exit(2);
        }
    }
}
