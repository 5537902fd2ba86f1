//! Test helpers: the deterministic generator (core's one, `src/testrng.rs`),
//! field conversions and the independent batch least-squares reference
//! (nalgebra SVD in f64).
#![allow(dead_code)]

use nalgebra::{ComplexField, DMatrix, DVector};
use num_complex::Complex;
use rotorid_core::Real;

#[path = "../../src/testrng.rs"]
mod testrng;
pub use testrng::SplitMix64;

pub type C64 = Complex<f64>;

/// A field the filter runs on, convertible to and from `Complex<f64>`
/// (real fields drop the imaginary part).
pub trait TestField: ComplexField<RealField = Self::R> + Copy {
    type R: Real;
    const COMPLEX: bool;
    fn from_c64(x: C64) -> Self;
    fn to_c64(self) -> C64;
}

impl TestField for f64 {
    type R = f64;
    const COMPLEX: bool = false;
    fn from_c64(x: C64) -> Self {
        x.re
    }
    fn to_c64(self) -> C64 {
        C64::new(self, 0.0)
    }
}
impl TestField for f32 {
    type R = f32;
    const COMPLEX: bool = false;
    fn from_c64(x: C64) -> Self {
        x.re as f32
    }
    fn to_c64(self) -> C64 {
        C64::new(self as f64, 0.0)
    }
}
impl TestField for Complex<f64> {
    type R = f64;
    const COMPLEX: bool = true;
    fn from_c64(x: C64) -> Self {
        x
    }
    fn to_c64(self) -> C64 {
        self
    }
}
impl TestField for Complex<f32> {
    type R = f32;
    const COMPLEX: bool = true;
    fn from_c64(x: C64) -> Self {
        Complex::new(x.re as f32, x.im as f32)
    }
    fn to_c64(self) -> C64 {
        C64::new(self.re as f64, self.im as f64)
    }
}

/// A random number of the field (imaginary part only for complex fields).
pub fn rand_field<F: TestField>(rng: &mut SplitMix64) -> C64 {
    if F::COMPLEX {
        rng.c()
    } else {
        C64::new(rng.sym(), 0.0)
    }
}

/// One step of data: `u` (`N x M` row-major) and `d`, in f64.
#[derive(Clone, Debug)]
pub struct Step {
    pub u: Vec<C64>,
    pub d: Vec<C64>,
}

/// Random well-conditioned steps `d = U w + noise`, values representable in
/// `F` (rounded through `F` so the f64 reference sees the same data).
pub fn random_steps<F: TestField>(
    rng: &mut SplitMix64,
    m: usize,
    n: usize,
    steps: usize,
    w: &[C64],
    noise: f64,
) -> Vec<Step> {
    (0..steps)
        .map(|_| {
            let u: Vec<C64> = (0..n * m)
                .map(|_| F::from_c64(rand_field::<F>(rng)).to_c64())
                .collect();
            let d = (0..n)
                .map(|j| {
                    let mut acc = C64::new(0.0, 0.0);
                    for k in 0..m {
                        acc += u[j * m + k] * w[k];
                    }
                    F::from_c64(acc + rand_field::<F>(rng) * noise).to_c64()
                })
                .collect();
            Step { u, d }
        })
        .collect()
}

/// The exponentially weighted, regularised least-squares problem after the
/// given rows, written as the stacked system
/// `[sqrt(lambda^n delta) I; sqrt(lambda^(n-k)) U(k)] w = [sqrt(lambda^n delta) w0; sqrt(lambda^(n-k)) d(k)]`.
/// `steps` are the complete steps, `partial_rows` the first rows of the
/// current step (weight 1, lambda already applied for it: the current step
/// counts in `n`), if any.
pub fn stacked_system(
    m: usize,
    lambda: f64,
    delta: f64,
    w0: &[C64],
    steps: &[Step],
    partial: Option<(&Step, usize)>,
) -> (DMatrix<C64>, DVector<C64>) {
    let n_total = steps.len() + usize::from(partial.is_some());
    let mut rows: Vec<(Vec<C64>, C64)> = Vec::new();
    let s0 = (lambda.powi(n_total as i32) * delta).sqrt();
    for i in 0..m {
        let mut r = vec![C64::new(0.0, 0.0); m];
        r[i] = C64::new(s0, 0.0);
        rows.push((r, w0[i] * s0));
    }
    for (k, st) in steps.iter().enumerate() {
        let s = lambda.powi((n_total - 1 - k) as i32).sqrt();
        for (j, dj) in st.d.iter().enumerate() {
            rows.push((
                st.u[j * m..(j + 1) * m].iter().map(|x| x * s).collect(),
                dj * s,
            ));
        }
    }
    if let Some((st, nrows)) = partial {
        for j in 0..nrows {
            rows.push((st.u[j * m..(j + 1) * m].to_vec(), st.d[j]));
        }
    }
    let a = DMatrix::from_fn(rows.len(), m, |i, k| rows[i].0[k]);
    let b = DVector::from_iterator(rows.len(), rows.iter().map(|r| r.1));
    (a, b)
}

/// Least-squares solution of the stacked system by SVD (f64).
pub fn batch_solution(a: &DMatrix<C64>, b: &DVector<C64>) -> DVector<C64> {
    a.clone()
        .svd(true, true)
        .solve(b, 1e-300)
        .expect("SVD solve of the reference problem")
}

/// `||x - y|| / ||y||` over complex vectors.
pub fn rel_diff(x: &[C64], y: &[C64]) -> f64 {
    let num: f64 = x.iter().zip(y).map(|(a, b)| (a - b).norm_sqr()).sum();
    let den: f64 = y.iter().map(|b| b.norm_sqr()).sum();
    (num / den).sqrt()
}

/// Converts a row-major slice of `C64` to the field.
pub fn to_field<F: TestField>(x: &[C64]) -> Vec<F> {
    x.iter().map(|v| F::from_c64(*v)).collect()
}
