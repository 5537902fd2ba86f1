//! Input safety of the QRD/RLS: non-finite input leaves the state bit for
//! bit unchanged; data whose squares overflow or underflow the precision do
//! not poison the state.

use crate::common::*;
use num_complex::Complex;
use rotorid_core::qrdrls::{self, FilterError, VectorQrdRls};

type C32 = Complex<f32>;

fn bits_c64(x: &[C64]) -> Vec<(u64, u64)> {
    x.iter().map(|v| (v.re.to_bits(), v.im.to_bits())).collect()
}

fn state_bits_c64<const M: usize, const N: usize>(f: &VectorQrdRls<C64, M, N>) -> Vec<(u64, u64)> {
    let mut v = bits_c64(f.r().as_flattened());
    v.extend(bits_c64(f.p()));
    v
}

fn state_bits_f32<const M: usize, const N: usize>(f: &VectorQrdRls<f32, M, N>) -> Vec<u32> {
    f.r()
        .as_flattened()
        .iter()
        .chain(f.p().iter())
        .map(|x| x.to_bits())
        .collect()
}

#[test]
fn non_finite_input_leaves_state_unchanged_complex_f64() {
    const M: usize = 5;
    const N: usize = 3;
    let mut rng = SplitMix64::new(7);
    let mut f = VectorQrdRls::<C64, M, N>::new(0.95, 0.1).unwrap();
    let mk = |rng: &mut SplitMix64| -> ([[C64; M]; N], [C64; N]) {
        (
            core::array::from_fn(|_| core::array::from_fn(|_| rng.c())),
            core::array::from_fn(|_| rng.c()),
        )
    };
    for _ in 0..10 {
        let (u, d) = mk(&mut rng);
        f.update(&u, &d).unwrap();
    }
    let before = f.clone();
    let bits = state_bits_c64(&f);
    let bad = [f64::NAN, f64::INFINITY, f64::NEG_INFINITY];
    let mut rejected = 0;
    for &b in &bad {
        for j in 0..N {
            for k in 0..M {
                for part in 0..2 {
                    let (mut u, d) = mk(&mut rng);
                    if part == 0 {
                        u[j][k].re = b;
                    } else {
                        u[j][k].im = b;
                    }
                    assert_eq!(f.update(&u, &d), Err(FilterError::NonFinite));
                    rejected += 1;
                }
            }
            let (u, mut d) = mk(&mut rng);
            d[j].im = b;
            assert_eq!(
                f.update_with_lambda(&u, &d, 1.0),
                Err(FilterError::NonFinite)
            );
            rejected += 1;
        }
    }
    // A bad lambda is rejected before anything is touched too.
    let (u, d) = mk(&mut rng);
    for lam in [0.0, -0.5, 1.0 + 1e-12, f64::NAN, f64::INFINITY] {
        assert_eq!(
            f.update_with_lambda(&u, &d, lam),
            Err(FilterError::InvalidLambda)
        );
        rejected += 1;
    }
    assert_eq!(rejected, 3 * N * (2 * M + 1) + 5);
    assert_eq!(state_bits_c64(&f), bits);
    assert_eq!(f, before);
    // And the filter still works afterwards.
    f.update(&u, &d).unwrap();
    assert_ne!(state_bits_c64(&f), bits);
}

#[test]
fn non_finite_input_leaves_state_unchanged_real_f32_and_slices() {
    const M: usize = 4;
    const N: usize = 2;
    let mut rng = SplitMix64::new(8);
    let mut f = VectorQrdRls::<f32, M, N>::with_weights(0.99, 1.0, &[1.0, -2.0, 0.5, 3.0]).unwrap();
    for _ in 0..5 {
        let u: [[f32; M]; N] = core::array::from_fn(|_| core::array::from_fn(|_| rng.sym() as f32));
        let d: [f32; N] = core::array::from_fn(|_| rng.sym() as f32);
        f.update(&u, &d).unwrap();
    }
    let bits = state_bits_f32(&f);
    let u = [[1.0, f32::NAN, 0.0, 0.0], [0.0; M]];
    assert_eq!(f.update(&u, &[0.0, 0.0]), Err(FilterError::NonFinite));
    assert_eq!(
        f.update(&[[1.0; M]; N], &[0.0, f32::INFINITY]),
        Err(FilterError::NonFinite)
    );
    assert_eq!(state_bits_f32(&f), bits);

    // The slice kernel: same contract, plus dimension checks.
    let mut r = vec![C32::new(0.0, 0.0); M * M];
    let mut p = vec![C32::new(0.0, 0.0); M];
    qrdrls::init(&mut r, &mut p, 0.5f32, None).unwrap();
    let (mut xi, mut g) = ([C32::new(0.0, 0.0); 1], [0.0f32; 1]);
    qrdrls::update_rows(
        &mut r,
        &mut p,
        &[C32::new(1.0, 2.0); M],
        &[C32::new(1.0, 0.0)],
        0.9,
        &mut xi,
        &mut g,
    )
    .unwrap();
    let (r0, p0) = (r.clone(), p.clone());
    let mut u = [C32::new(1.0, 2.0); M];
    u[M - 1].im = f32::NAN;
    assert_eq!(
        qrdrls::update_rows(
            &mut r,
            &mut p,
            &u,
            &[C32::new(1.0, 0.0)],
            0.9,
            &mut xi,
            &mut g
        ),
        Err(FilterError::NonFinite)
    );
    assert_eq!(
        qrdrls::update_rows(
            &mut r,
            &mut p,
            &u[..M - 1],
            &[C32::new(1.0, 0.0)],
            0.9,
            &mut xi,
            &mut g
        ),
        Err(FilterError::Dimension)
    );
    let bits = |v: &[C32]| {
        v.iter()
            .map(|x| (x.re.to_bits(), x.im.to_bits()))
            .collect::<Vec<_>>()
    };
    assert_eq!(bits(&r), bits(&r0));
    assert_eq!(bits(&p), bits(&p0));
}

/// Rows of size 4e18 in f32 (right-hand sides up to 1.5e19), below the input limit sqrt(f32::MAX) =
/// 1.8e19: the column sums of squares (600 rows of 1.6e37) overflow f32 (max 3.4e38), yet
/// the range-safe rotations keep the state finite and the weights right.
/// Likewise rows of size 1e-25, whose squares (1e-50) underflow to zero.
/// Rows of size 1e25 are beyond the limit and refused (`OutOfRange`).
#[test]
fn huge_and_tiny_rows_in_f32() {
    const M: usize = 3;
    const N: usize = 2;
    let w_true = [0.5f32, -1.25, 2.0];
    let mut f = VectorQrdRls::<f32, M, N>::new(0.9, 1.0).unwrap();
    assert_eq!(
        f.update(&[[1e25; M]; N], &[0.0; N]),
        Err(FilterError::OutOfRange)
    );
    for &scale in &[4e18f32, 1e-25f32] {
        let mut rng = SplitMix64::new(9);
        // delta^2 * 1e-25 would underflow: the prior is made negligible by
        // forgetting instead (0.9^600 = 2e-28).
        let delta = if scale > 1.0 { 1.0 } else { 1e-40 };
        let mut f = VectorQrdRls::<f32, M, N>::new(0.9, delta).unwrap();
        for _ in 0..600 {
            let u: [[f32; M]; N] =
                core::array::from_fn(|_| core::array::from_fn(|_| rng.sym() as f32 * scale));
            let d: [f32; N] = core::array::from_fn(|j| (0..M).map(|k| u[j][k] * w_true[k]).sum());
            let info = f.update(&u, &d).unwrap();
            // gamma = 1 / (1 + u P u^H) can underflow to 0 in f32 on the first
            // huge rows (u P u^H ~ 1e50): it stays in [0, 1].
            assert!(info
                .gamma
                .iter()
                .all(|g| g.is_finite() && *g >= 0.0 && *g <= 1.0));
        }
        assert!(f
            .r()
            .as_flattened()
            .iter()
            .chain(f.p())
            .all(|x| x.is_finite()));
        let w = f.weights().unwrap();
        for k in 0..M {
            assert!(
                (w[k] - w_true[k]).abs() <= 1e-4 * w_true[k].abs(),
                "scale {scale}: {w:?}"
            );
        }
    }
}

/// A long run of zero rows with lambda < 1: the factor decays (the classic
/// wind-up) but stays finite; the weights are kept (to round-off) while R is
/// a normal number, and once a diagonal entry of R is subnormal (precision
/// lost) `weights()` reports `Singular` instead of returning a ratio of
/// denormals.
#[test]
fn zero_rows_decay_without_poisoning() {
    let mut f = VectorQrdRls::<f64, 2, 1>::with_weights(0.5, 1.0, &[3.0, -4.0]).unwrap();
    let mut singular_at = None;
    for n in 0..3000 {
        let info = f.update(&[[0.0, 0.0]], &[7.0]).unwrap();
        assert_eq!(info.xi, [7.0]);
        assert_eq!(info.gamma, [1.0]);
        let normal = f.r()[0][0] >= f64::MIN_POSITIVE && f.r()[1][1] >= f64::MIN_POSITIVE;
        match f.weights() {
            Ok(w) => {
                assert!(singular_at.is_none());
                assert!(w.iter().all(|x| x.is_finite()));
                if normal {
                    assert!(
                        (w[0] - 3.0).abs() < 1e-12 && (w[1] + 4.0).abs() < 1e-12,
                        "{n}: {w:?}"
                    );
                }
            }
            Err(e) => {
                assert_eq!(e, FilterError::Singular);
                singular_at.get_or_insert(n);
            }
        }
    }
    // After k scalings R = 0.5^(k/2), below 2^-1022 (the smallest normal
    // f64) from k = 2045 on, i.e. at step index n = k - 1 = 2044.
    let n = singular_at.expect("R becomes subnormal");
    assert_eq!(n, 2044);
    assert!(f.r().as_flattened().iter().all(|x| x.is_finite()));
}

/// Entries beyond `sqrt(T::MAX)` are rejected before the state is touched
/// (the fuzz target `qrdrls_update` found rows of entries near `f32::MAX`
/// that overflowed the factor), entries at the limit are accepted and keep
/// the state finite, and a `delta` beyond the limit is refused.
#[test]
fn out_of_range_input_is_rejected_and_state_kept() {
    use num_complex::Complex;
    use rotorid_core::qrdrls::{input_limit, VectorQrdRls};
    let big = 3.39e38f32;
    let mut f = VectorQrdRls::<Complex<f32>, 5, 2>::new(0.5, 1e-3).unwrap();
    let u0 = [[Complex::new(0.25f32, -0.5); 5]; 2];
    f.update(&u0, &[Complex::new(1.0, 0.0); 2]).unwrap();
    let before = f.clone();
    let mut u = [[Complex::new(big, big); 5]; 2];
    assert_eq!(
        f.update(&u, &[Complex::new(0.0, 0.0); 2]),
        Err(FilterError::OutOfRange)
    );
    assert_eq!(f, before);
    let lim = input_limit::<f32>();
    assert!((lim - f32::MAX.sqrt()).abs() <= f32::EPSILON * lim);
    u = [[Complex::new(lim, -lim); 5]; 2];
    for _ in 0..1000 {
        f.update_with_lambda(&u, &[Complex::new(lim, lim); 2], 1.0)
            .unwrap();
    }
    assert!(f
        .r()
        .iter()
        .flatten()
        .chain(f.p().iter())
        .all(|z| z.re.is_finite() && z.im.is_finite()));
    assert_eq!(
        VectorQrdRls::<Complex<f32>, 5, 2>::new(0.99, 1e20).unwrap_err(),
        FilterError::InvalidDelta
    );
}
