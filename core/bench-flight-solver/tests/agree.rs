//! Both filters solve (nearly) the same problem: after a few hundred steps
//! their weights agree. The forgetting differs in detail (per step of 8
//! rows here, lambda^(1/8) per row in flight-solver), hence the tolerance.

use flight_solver::rls::InverseQrRls;
use nalgebra::SVector;
use rotorid_bench_flight_solver::{stream, stream_structured, DELTA, LAMBDA, M, N, NB, S, W};
use rotorid_core::blockqrd::BlockQrdRls;
use rotorid_core::qrdrls::VectorQrdRls;

#[test]
fn same_problem_same_weights() {
    let mut f = VectorQrdRls::<f32, M, N>::new(LAMBDA, DELTA).unwrap();
    let mut fs = InverseQrRls::<M, 1>::new(1.0 / DELTA, LAMBDA.powf(1.0 / N as f32));
    for (u, d) in stream(500, 7) {
        f.update(&u, &d).unwrap();
        for j in 0..N {
            fs.update(
                &SVector::from_row_slice(&u[j]),
                &SVector::from_element(d[j]),
            );
        }
    }
    let w = f.weights().unwrap();
    let rd = rel_diff(&w, fs.params());
    assert!(rd < 1e-3, "relative difference {rd:e}");
}

#[test]
fn same_problem_same_weights_on_structured_rows() {
    let mut f = BlockQrdRls::<f32, NB, W, S>::new(LAMBDA, DELTA).unwrap();
    let mut fs = InverseQrRls::<M, 1>::new(1.0 / DELTA, LAMBDA.powf(1.0 / N as f32));
    let (mut xi, mut gamma) = ([0.0f32; N], [0.0f32; N]);
    for (u, d) in stream_structured(500, 7) {
        f.update_rows(u.as_flattened(), &d, &mut xi, &mut gamma)
            .unwrap();
        for j in 0..N {
            fs.update(
                &SVector::from_row_slice(&u[j]),
                &SVector::from_element(d[j]),
            );
        }
    }
    let mut w = [0.0f32; M];
    f.weights(&mut w).unwrap();
    let rd = rel_diff(&w, fs.params());
    assert!(rd < 1e-3, "relative difference {rd:e}");
}

/// `|w - wf| / |w|` (Euclidean).
fn rel_diff(w: &[f32], wf: &nalgebra::SMatrix<f32, M, 1>) -> f64 {
    let mut num = 0.0f64;
    let mut den = 0.0f64;
    for k in 0..M {
        num += ((w[k] - wf[(k, 0)]) as f64).powi(2);
        den += (w[k] as f64).powi(2);
    }
    (num / den).sqrt()
}
