//! The firmware identifier (the dense filter, whose state `parts()` shows
//! bit for bit) against a table: arbitrary speeds, responses,
//! forgetting factor and regularisation, both structures (physical and
//! paper, order 1), f32 and f64, on the paper rotor's committed table
//! blobs. Properties: a configuration is refused or the identifier is
//! built; an update that is refused leaves the state bit-identical; an
//! accepted update leaves it finite; the estimates are finite or an error.
//!
//! Input: one byte (bit 0: f64, bit 1: paper structure), `lambda` and
//! `delta` (f32 bits each), then per update a speed (u16, spread over 125 %
//! of the table's range, so beyond it too) and the four response phasors
//! (eight f32 bit patterns: NaN, infinities, subnormals and huge values
//! included).
#![no_main]

use libfuzzer_sys::fuzz_target;
use rotorid_core::factor::DenseFactor;
use rotorid_core::identify::{Config, IdField, Identifier, SteadyPolicy};
use rotorid_core::parametrization::Structure;
use rotorid_core::table::{BearingTable, TableSetup, TableView};
use rotorid_core::{Complex, Real};

const NQ: usize = 4;
const NP: usize = 3;

/// The table-blob target's seeds: 16 bytes of lookup speeds, then the blob.
static SEED_F32: &[u8] = include_bytes!("../regressions/table_blob/paper-f32-5-speeds.bin");
static SEED_F64: &[u8] = include_bytes!("../regressions/table_blob/paper-f64-3-speeds.bin");

fn take_f32(data: &mut &[u8]) -> Option<f32> {
    let (head, rest) = data.split_first_chunk::<4>()?;
    *data = rest;
    Some(f32::from_le_bytes(*head))
}

fn take_u16(data: &mut &[u8]) -> Option<u16> {
    let (head, rest) = data.split_first_chunk::<2>()?;
    *data = rest;
    Some(u16::from_le_bytes(*head))
}

fn bits<T: Real, F: IdField<T>, const M: usize, const N: usize>(
    id: &Identifier<T, F, NQ, NP, M, N, DenseFactor<F, M>>,
) -> Vec<u64> {
    let (r, p) = id.state().parts();
    r.iter()
        .flatten()
        .chain(p.iter())
        .flat_map(|z| {
            [
                z.real().to_f64().to_bits(),
                z.imaginary().to_f64().to_bits(),
            ]
        })
        .collect()
}

fn finite<T: Real>(x: T) -> bool {
    x.is_finite()
}

fn run<T: Real, F: IdField<T>, const M: usize, const N: usize>(
    blob: &[u8],
    structure: Structure,
    mut data: &[u8],
) where
    T: rotorid_core::table::TableScalar,
{
    let view = match TableView::<T>::parse(blob) {
        Ok(v) => v,
        Err(e) => panic!("committed blob does not parse: {e:?}"),
    };
    let data = &mut data;
    let (Some(lambda), Some(delta)) = (take_f32(data), take_f32(data)) else {
        return;
    };
    let config = Config::new(structure, TableSetup::scaling(&view))
        .with_lambda(T::lit(f64::from(lambda)))
        .with_delta(T::lit(f64::from(delta)))
        .with_steady(SteadyPolicy::off());
    let Ok(mut id) = Identifier::<T, F, NQ, NP, M, N, DenseFactor<F, M>>::new(config) else {
        return;
    };
    let (lo, hi) = BearingTable::<T, NQ, NP>::speed_range(&view);
    let span = (hi - lo).to_f64() * 1.25;
    while let Some(s) = take_u16(data) {
        let omega = T::lit(lo.to_f64() + span * f64::from(s) / 65535.0);
        let mut q = [Complex::new(T::zero(), T::zero()); NQ];
        for z in q.iter_mut() {
            let (Some(re), Some(im)) = (take_f32(data), take_f32(data)) else {
                return;
            };
            *z = Complex::new(T::lit(f64::from(re)), T::lit(f64::from(im)));
        }
        let before = bits(&id);
        let guard = *id.guard();
        match id.update(&view, omega, &q) {
            Ok(_) => {
                let (r, p) = id.state().parts();
                assert!(
                    r.iter()
                        .flatten()
                        .chain(p.iter())
                        .all(|z| z.real().is_finite() && z.imaginary().is_finite()),
                    "accepted update left a non-finite state"
                );
            }
            Err(_) => {
                assert_eq!(before, bits(&id), "refused update changed the state");
                assert_eq!(guard, *id.guard(), "refused update moved the guard");
            }
        }
        if let Ok(e) = id.estimates(omega) {
            for b in &e.bearings {
                assert!(
                    b.k.iter().chain(&b.c).all(|&x| finite(x)),
                    "Ok estimate not finite: {e:?}"
                );
                for v in b.im_z0.iter().chain(b.re_z1.iter()) {
                    assert!(
                        v.iter().all(|&x| finite(x)),
                        "Ok estimate not finite: {e:?}"
                    );
                }
            }
            for u in &e.unbalance {
                assert!(finite(u.a.re) && finite(u.a.im) && finite(u.me) && finite(u.phase));
            }
        }
    }
}

fuzz_target!(|data: &[u8]| {
    let Some((&case, data)) = data.split_first() else {
        return;
    };
    match case % 4 {
        0 => run::<f32, f32, 22, 8>(&SEED_F32[16..], Structure::physical(1), data),
        1 => run::<f64, f64, 22, 8>(&SEED_F64[16..], Structure::physical(1), data),
        2 => run::<f32, Complex<f32>, 19, 4>(&SEED_F32[16..], Structure::paper(1), data),
        _ => run::<f64, Complex<f64>, 19, 4>(&SEED_F64[16..], Structure::paper(1), data),
    }
});
