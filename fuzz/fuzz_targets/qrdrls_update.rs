//! Numerical stability: arbitrary rows (including NaN, infinities,
//! subnormals and huge values) and forgetting factors fed to the Givens
//! QRD/RLS, over several sizes (M unknowns, N rows per update) and both
//! precisions, real and complex. A rejected update must leave the state
//! bit-identical; an accepted one must leave it finite; weights are finite
//! or an error.
//!
//! The first byte picks the case: field (f32, f64, complex f32, complex
//! f64) and size (M, N) in {(1, 1), (5, 2), (19, 4), (22, 8)}.
#![no_main]

use libfuzzer_sys::fuzz_target;
use num_complex::Complex;
use rotorid_core::qrdrls::VectorQrdRls;

#[path = "common/field.rs"]
mod field;
use field::Field;

fn finite_state<F: Field, const M: usize, const N: usize>(f: &VectorQrdRls<F, M, N>) -> bool {
    f.r()
        .iter()
        .flatten()
        .chain(f.p().iter())
        .all(Field::finite)
}

/// Bit patterns of the state (so that a rejected update is checked to
/// leave it bit-identical, `-0.0` and `0.0` told apart).
fn bits<F: Field, const M: usize, const N: usize>(f: &VectorQrdRls<F, M, N>) -> Vec<u64> {
    f.r()
        .iter()
        .flatten()
        .chain(f.p().iter())
        .flat_map(|z| {
            [
                z.real().to_f64().to_bits(),
                z.imaginary().to_f64().to_bits(),
            ]
        })
        .collect()
}

use rotorid_core::Real as _;

fn run<F: Field, const M: usize, const N: usize>(mut data: &[u8]) {
    let data = &mut data;
    let (Some(lambda), Some(delta)) = (F::take_real(data), F::take_real(data)) else {
        return;
    };
    let Ok(mut filter) = VectorQrdRls::<F, M, N>::new(lambda, delta) else {
        return;
    };
    loop {
        let Some(lam) = F::take_real(data) else {
            break;
        };
        let mut u = [[F::zero(); M]; N];
        let mut d = [F::zero(); N];
        for z in u.iter_mut().flatten().chain(d.iter_mut()) {
            let Some(v) = F::take(data) else {
                return;
            };
            *z = v;
        }
        let before = bits(&filter);
        match filter.update_with_lambda(&u, &d, lam) {
            Ok(_) => assert!(
                finite_state(&filter),
                "accepted update left a non-finite state"
            ),
            Err(_) => assert_eq!(before, bits(&filter), "rejected update changed the state"),
        }
        if let Ok(w) = filter.weights() {
            assert!(w.iter().all(Field::finite), "Ok weights not finite");
        }
        let _ = filter.r_diag_ratio();
    }
}

fn sized<F: Field>(size: u8, data: &[u8]) {
    match size % 4 {
        0 => run::<F, 1, 1>(data),
        1 => run::<F, 5, 2>(data),
        2 => run::<F, 19, 4>(data),
        _ => run::<F, 22, 8>(data),
    }
}

fuzz_target!(|data: &[u8]| {
    let Some((&case, data)) = data.split_first() else {
        return;
    };
    let size = case >> 2;
    match case % 4 {
        0 => sized::<f32>(size, data),
        1 => sized::<f64>(size, data),
        2 => sized::<Complex<f32>>(size, data),
        _ => sized::<Complex<f64>>(size, data),
    }
});
