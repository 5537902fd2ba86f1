//! Numerical stability of the square-root-free block QRD/RLS
//! (`rotorid_core::sqrtfree`): arbitrary rows (NaN, infinities, subnormals,
//! huge values, squares beyond the range), block indices and forgetting
//! factors, in the three row forms (rows of `M` entries, grouped rows of
//! `M` entries, compact rows), over several layouts and both precisions,
//! real and complex. A rejected update must leave the stored state
//! unchanged; an accepted one must leave it finite (and `gamma`, `xi`);
//! weights and the Givens form are finite or an error.
//!
//! The first byte picks the case: field (f32, f64, complex f32, complex
//! f64) and layout (NB, W, S) in {(1, 1, 0), (2, 2, 1), (4, 4, 3), (4, 4, 6)}.
#![no_main]

use libfuzzer_sys::fuzz_target;
use num_complex::Complex;
use rotorid_core::sqrtfree::{SqrtFreeFactor, SqrtFreeQrdRls};
use rotorid_core::Real as _;

#[path = "common/field.rs"]
mod field;
use field::Field;

/// The Givens form `R = D^(1/2) U` of the factor, when it is finite:
/// then every entry must be (the conversion's own contract).
fn check_givens_form<F: Field, const NB: usize, const W: usize, const S: usize>(
    fac: &SqrtFreeFactor<F, NB, W, S>,
) {
    let mut block = rotorid_core::blockqrd::BlockFactor::<F, NB, W, S>::zeroed();
    if fac.to_block(&mut block).is_ok() {
        let v = block.view();
        assert!(
            v.diag
                .iter()
                .chain(v.coupling)
                .chain(v.shared)
                .chain(v.pb)
                .chain(v.ps)
                .all(Field::finite),
            "Ok Givens form not finite"
        );
    }
}

fn run<F: Field, const NB: usize, const W: usize, const S: usize>(mut data: &[u8]) {
    let m = NB * W + S;
    let n = 2 * NB;
    let data = &mut data;
    let (Some(lambda), Some(delta)) = (F::take_real(data), F::take_real(data)) else {
        return;
    };
    let Ok(mut filter) = SqrtFreeQrdRls::<F, NB, W, S>::new(lambda, delta) else {
        return;
    };
    while let Some((&mode, rest)) = data.split_first() {
        *data = rest;
        // Block of each row: from the data (compact form, may be out of
        // range) or row j in block j % NB (rows of M entries).
        let mut blocks = vec![0usize; n];
        for (j, b) in blocks.iter_mut().enumerate() {
            *b = if mode & 1 == 1 {
                let Some((&x, rest)) = data.split_first() else {
                    return;
                };
                *data = rest;
                usize::from(x % (NB as u8 + 1))
            } else {
                j % NB
            };
        }
        let mut a = vec![F::zero(); n * W];
        let mut c = vec![F::zero(); n * S];
        let mut d = vec![F::zero(); n];
        for z in a.iter_mut().chain(c.iter_mut()).chain(d.iter_mut()) {
            let Some(v) = F::take(data) else {
                return;
            };
            *z = v;
        }
        let (mut xi, mut gamma) = (vec![F::zero(); n], vec![F::zero().real(); n]);
        let before: SqrtFreeFactor<F, NB, W, S> = *filter.factor();
        let result = if mode & 1 == 1 {
            filter.update_block_rows(&blocks, &a, &c, &d, &mut xi, &mut gamma)
        } else {
            // Rows of M entries, zero outside their block and the shared
            // columns; with `mode & 2` one row also gets an entry in the
            // next block (rejected: two blocks).
            let mut u = vec![F::zero(); n * m];
            for j in 0..n {
                let b = blocks[j];
                u[j * m + b * W..j * m + (b + 1) * W].copy_from_slice(&a[j * W..(j + 1) * W]);
                u[j * m + NB * W..(j + 1) * m].copy_from_slice(&c[j * S..(j + 1) * S]);
            }
            if mode & 2 == 2 && NB > 1 {
                u[((blocks[0] + 1) % NB) * W] = F::one();
            }
            if mode & 4 == 4 {
                // Read as grouped rows (row j in block j / 2): whatever
                // the rows hold, the same contract.
                filter.update_grouped_rows(&u, &d, &mut xi, &mut gamma)
            } else {
                filter.update_rows(&u, &d, &mut xi, &mut gamma)
            }
        };
        let after = filter.factor();
        match result {
            Ok(()) => {
                assert!(after.is_finite(), "accepted update left a non-finite state");
                assert!(
                    xi.iter().all(Field::finite) && gamma.iter().all(|g| g.to_f64().is_finite()),
                    "accepted update returned non-finite xi or gamma"
                );
            }
            // The stored state is finite, so `==` is bit identity up to
            // the sign of zeros.
            Err(_) => assert!(before == *after, "rejected update changed the state"),
        }
        let mut w = vec![F::zero(); m];
        if filter.weights(&mut w).is_ok() {
            assert!(w.iter().all(Field::finite), "Ok weights not finite");
        }
        check_givens_form(filter.factor());
        let _ = filter.factor().diag_ratio();
    }
}

fn sized<F: Field>(size: u8, data: &[u8]) {
    match size % 4 {
        0 => run::<F, 1, 1, 0>(data),
        1 => run::<F, 2, 2, 1>(data),
        2 => run::<F, 4, 4, 3>(data),
        _ => run::<F, 4, 4, 6>(data),
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
