//! Numerical stability: arbitrary f32 rows (including NaN, infinities,
//! subnormals and huge values) and forgetting factors fed to the Givens
//! QRD/RLS. A rejected update must leave the state bit-identical; an
//! accepted one must leave it finite.
#![no_main]

use libfuzzer_sys::fuzz_target;
use num_complex::Complex;
use rotorid_core::qrdrls::VectorQrdRls;

const M: usize = 5;
const N: usize = 2;

fn take_f32(data: &mut &[u8]) -> Option<f32> {
    let (head, rest) = data.split_first_chunk::<4>()?;
    *data = rest;
    Some(f32::from_le_bytes(*head))
}

fn finite_state(f: &VectorQrdRls<Complex<f32>, M, N>) -> bool {
    f.r()
        .iter()
        .flatten()
        .chain(f.p().iter())
        .all(|z| z.re.is_finite() && z.im.is_finite())
}

fuzz_target!(|data: &[u8]| {
    let mut data = data;
    let Some(lambda) = take_f32(&mut data) else {
        return;
    };
    let Some(delta) = take_f32(&mut data) else {
        return;
    };
    let Ok(mut filter) = VectorQrdRls::<Complex<f32>, M, N>::new(lambda, delta) else {
        return;
    };
    loop {
        let mut u = [[Complex::new(0.0f32, 0.0); M]; N];
        let mut d = [Complex::new(0.0f32, 0.0); N];
        let Some(lam) = take_f32(&mut data) else {
            break;
        };
        for row in u.iter_mut() {
            for z in row.iter_mut() {
                let (Some(re), Some(im)) = (take_f32(&mut data), take_f32(&mut data)) else {
                    return;
                };
                *z = Complex::new(re, im);
            }
        }
        for z in d.iter_mut() {
            let (Some(re), Some(im)) = (take_f32(&mut data), take_f32(&mut data)) else {
                return;
            };
            *z = Complex::new(re, im);
        }
        let before = filter.clone();
        match filter.update_with_lambda(&u, &d, lam) {
            Ok(_) => assert!(
                finite_state(&filter),
                "accepted update left a non-finite state"
            ),
            Err(_) => assert_eq!(before, filter, "rejected update changed the state"),
        }
        // Weights may fail (singular factor) but must not panic.
        let _ = filter.weights();
        let _ = filter.r_diag_ratio();
    }
});
