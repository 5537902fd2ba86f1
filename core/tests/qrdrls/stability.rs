//! Long-run stability in f32: lambda = 0.99, rows whose condition number is
//! about 1e4, one million updates (M = 6 complex unknowns, N = 3 rows per
//! update, i.e. 3 million rows), against the same filter in f64; and what
//! the conventional RLS does on the same stream.

use crate::common::*;
use nalgebra::DMatrix;
use num_complex::Complex;
use rotorid_core::qrdrls::VectorQrdRls;

const M: usize = 6;
const N: usize = 3;
const STEPS: usize = 1_000_000;
const CHECK_EVERY: usize = 100_000;
const LAMBDA: f64 = 0.99;
const COND: f64 = 1e4;

type C32 = Complex<f32>;

/// Rows u = (x .* s)^T Q with x uniform complex, s log-spaced from 1 to
/// 1/COND, Q a fixed random unitary matrix; d = u w_true + 1e-6 noise.
struct Stream {
    rng: SplitMix64,
    q: DMatrix<C64>,
    s: [f64; M],
    w: [C64; M],
}

impl Stream {
    fn new(seed: u64) -> Self {
        let mut rng = SplitMix64::new(seed);
        let a = DMatrix::from_fn(M, M, |_, _| rng.c());
        let q = a.qr().q();
        let s = core::array::from_fn(|i| COND.powf(-(i as f64) / (M - 1) as f64));
        let w = core::array::from_fn(|_| rng.c());
        Self { rng, q, s, w }
    }

    fn row(&mut self) -> ([C64; M], C64) {
        let x: [C64; M] = core::array::from_fn(|i| self.rng.c() * self.s[i]);
        let u: [C64; M] = core::array::from_fn(|k| (0..M).map(|i| x[i] * self.q[(i, k)]).sum());
        // Round through f32 so that both precisions see the same data.
        let u = u.map(|v| C64::new(v.re as f32 as f64, v.im as f32 as f64));
        let d: C64 = (0..M).map(|k| u[k] * self.w[k]).sum::<C64>() + self.rng.c() * 1e-6;
        (u, C64::new(d.re as f32 as f64, d.im as f32 as f64))
    }

    fn step(&mut self) -> ([[C64; M]; N], [C64; N]) {
        let mut u = [[C64::new(0.0, 0.0); M]; N];
        let mut d = [C64::new(0.0, 0.0); N];
        for j in 0..N {
            (u[j], d[j]) = self.row();
        }
        (u, d)
    }
}

fn to32<const K: usize>(x: &[C64; K]) -> [C32; K] {
    x.map(|v| C32::new(v.re as f32, v.im as f32))
}

fn widen(x: &[C32]) -> Vec<C64> {
    x.iter()
        .map(|v| C64::new(v.re as f64, v.im as f64))
        .collect()
}

#[test]
fn stream_rows_have_condition_about_1e4() {
    let mut st = Stream::new(42);
    let rows: Vec<[C64; M]> = (0..300).map(|_| st.row().0).collect();
    let a = DMatrix::from_fn(rows.len(), M, |i, k| rows[i][k]);
    let sv = a.singular_values();
    let cond = sv.max() / sv.min();
    assert!((3e3..3e4).contains(&cond), "cond {cond:e}");
}

#[test]
fn f32_qrdrls_stays_with_f64_over_a_million_updates() {
    let mut st = Stream::new(42);
    let mut f64f = VectorQrdRls::<C64, M, N>::new(LAMBDA, 1e-2).unwrap();
    let mut f32f = VectorQrdRls::<C32, M, N>::new(LAMBDA as f32, 1e-2).unwrap();
    let mut worst: f64 = 0.0;
    for n in 1..=STEPS {
        let (u, d) = st.step();
        f64f.update(&u, &d).unwrap();
        let u32: [[C32; M]; N] = core::array::from_fn(|j| to32(&u[j]));
        f32f.update(&u32, &to32(&d)).unwrap();
        if n % CHECK_EVERY == 0 {
            assert!(f32f
                .r()
                .as_flattened()
                .iter()
                .chain(f32f.p())
                .all(|x| x.re.is_finite() && x.im.is_finite()));
            let w64 = f64f.weights().unwrap();
            let w32 = widen(&f32f.weights().unwrap());
            let rd = rel_diff(&w32, &w64);
            // The f64 run itself is the least-squares solution (checked in
            // qrdrls_batch); it sits close to the true weights here.
            assert!(rel_diff(&w64, &st.w) < 1e-1);
            eprintln!(
                "step {n}: f32 vs f64 rel diff {rd:.2e}, r_diag_ratio f32 {:.2e}",
                f32f.r_diag_ratio()
            );
            worst = worst.max(rd);
            assert!(rd <= 1e-2, "step {n}: rel diff {rd:e}");
        }
    }
    eprintln!("worst f32 vs f64 relative difference: {worst:.2e}");
}

/// Observed (and asserted): on this stream the conventional RLS of
/// Eqs. 10-13 in f32 does NOT diverge. It stays finite over the million
/// updates and within the 1e-2 of the f64 solution (worst seen,
/// checked every 1000 updates: 1.1e-3, against 3.5e-4 for the f32 QRD/RLS
/// on the same checks; both values are printed).
/// The covariance form squares the condition number (cond(Phi) ~ 1e8 >
/// 1/eps_f32 here) but, with lambda = 0.99 and persistent excitation in
/// every direction, its errors are forgotten as fast as they arise.
#[cfg(feature = "baseline")]
#[test]
fn conventional_rls_on_the_same_stream() {
    use rotorid_core::baseline::ConventionalRls;
    let mut st = Stream::new(42);
    let mut q64 = VectorQrdRls::<C64, M, N>::new(LAMBDA, 1e-2).unwrap();
    let mut q32 = VectorQrdRls::<C32, M, N>::new(LAMBDA as f32, 1e-2).unwrap();
    let mut c64 = ConventionalRls::<C64>::new(M, 1e-2, None).unwrap();
    let mut c32 = ConventionalRls::<C32>::new(M, 1e-2, None).unwrap();
    let (mut e64, mut g64) = ([C64::new(0.0, 0.0); N], [0.0f64; N]);
    let (mut e32, mut g32) = ([C32::new(0.0, 0.0); N], [0.0f32; N]);
    let (mut worst_c32, mut worst_c64, mut worst_q32) = (0.0f64, 0.0f64, 0.0f64);
    let mut nonfinite = 0usize;
    for n in 1..=STEPS {
        let (u, d) = st.step();
        q64.update(&u, &d).unwrap();
        c64.update(u.as_flattened(), &d, LAMBDA, &mut e64, &mut g64)
            .unwrap();
        let u32: [[C32; M]; N] = core::array::from_fn(|j| to32(&u[j]));
        q32.update(&u32, &to32(&d)).unwrap();
        c32.update(
            u32.as_flattened(),
            &to32(&d),
            LAMBDA as f32,
            &mut e32,
            &mut g32,
        )
        .unwrap();
        if n % 1000 == 0 {
            let finite = c32
                .weights()
                .iter()
                .chain(c32.p_matrix())
                .all(|x| x.re.is_finite() && x.im.is_finite());
            nonfinite += usize::from(!finite);
            let w = q64.weights().unwrap();
            // NaN-propagating maxima: a NaN difference makes the worst NaN.
            let upd = |worst: &mut f64, rd: f64| {
                if rd.is_nan() || rd > *worst {
                    *worst = rd;
                }
            };
            upd(&mut worst_c32, rel_diff(&widen(c32.weights()), &w));
            upd(&mut worst_c64, rel_diff(c64.weights(), &w));
            upd(
                &mut worst_q32,
                rel_diff(&widen(&q32.weights().unwrap()), &w),
            );
        }
    }
    eprintln!(
        "worst rel diff to the f64 QRD/RLS (every 1000 updates): conventional f32 {worst_c32:.2e}, \
         conventional f64 {worst_c64:.2e}, QRD/RLS f32 {worst_q32:.2e}"
    );
    assert_eq!(nonfinite, 0);
    assert!(worst_c64 < 1e-9, "{worst_c64:e}");
    assert!(worst_q32 < 1e-3, "{worst_q32:e}");
    assert!(worst_c32 < 1e-2, "{worst_c32:e}");
}
