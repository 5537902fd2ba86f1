//! The measurement's relative noise level, estimated without the rotor
//! model, so that a model's misfit can be told from noise.
//!
//! # Method
//!
//! The noise model is the measurement file's: each complex sample carries
//! `s |q| eps`, `eps` standard complex Gaussian (`E|eps|^2 = 1`). The true
//! 1X response is smooth in the speed, the noise is independent from
//! sample to sample. Per channel, with the samples sorted by speed, a
//! quadratic in `Omega` is fitted by least squares to each window of
//! [`WINDOW`] consecutive samples; the residual of the window's centre
//! sample has variance `s^2 |q|^2 (1 - h)` with `h` the centre's leverage
//! (hat-matrix diagonal) when the window holds only noise around a
//! quadratic. So `x = |e|^2 / ((1 - h) |q|^2)` is `s^2` times an `Exp(1)`
//! variable, whose median is `ln 2`, and
//!
//! ```text
//!     s^2 = median_(samples, channels) x / ln 2 .
//! ```
//!
//! The median ignores the minority of windows where the response is not
//! locally quadratic (across a resonance on a coarse grid): the estimate
//! is model-free and robust, not exact; its relative standard error is
//! about `1.25 / sqrt(n)` for `n` windows (`~1e-2` for 3000 speeds x 4
//! channels), plus the curvature bias of a coarse grid (the speeds must be
//! dense enough that the response is locally quadratic over [`WINDOW`]
//! samples over most of the range).

use crate::io::measurement::Sample;

/// Samples per local fit.
pub const WINDOW: usize = 7;

/// The relative noise level `s` (see the module documentation), or `None`
/// with fewer than [`WINDOW`] samples of distinct speed or no signal.
pub fn relative_noise_level(samples: &[Sample]) -> Option<f64> {
    let nq = samples.first()?.q.len();
    let mut order: Vec<usize> = (0..samples.len()).collect();
    order.sort_by(|&i, &j| samples[i].omega.total_cmp(&samples[j].omega));
    let half = WINDOW / 2;
    let mut ratios = Vec::with_capacity(samples.len() * nq);
    for centre in half..order.len().saturating_sub(half) {
        let idx = &order[centre - half..=centre + half];
        let w0 = samples[order[centre]].omega;
        let span = samples[idx[WINDOW - 1]].omega - samples[idx[0]].omega;
        if span.is_nan() || span <= 0.0 {
            continue;
        }
        // Quadratic design in x = (Omega - Omega_centre) / span.
        let x: Vec<f64> = idx
            .iter()
            .map(|&i| (samples[i].omega - w0) / span)
            .collect();
        let Some((coef_of, h)) = centre_smoother(&x, half) else {
            continue;
        };
        for c in 0..nq {
            let qc = samples[order[centre]].q[c];
            let mag2 = qc.norm_sqr();
            if mag2.is_nan() || mag2 <= 0.0 || h >= 1.0 {
                continue;
            }
            let fit: num_complex::Complex64 = idx
                .iter()
                .zip(&coef_of)
                .map(|(&i, &l)| samples[i].q[c] * l)
                .sum();
            let e = qc - fit;
            ratios.push(e.norm_sqr() / ((1.0 - h) * mag2));
        }
    }
    if ratios.is_empty() {
        return None;
    }
    let mid = ratios.len() / 2;
    let (_, median, _) = ratios.select_nth_unstable_by(mid, f64::total_cmp);
    let s2 = *median / core::f64::consts::LN_2;
    s2.is_finite().then_some(s2.sqrt())
}

/// The weights `l` with `fit(centre) = sum_i l_i y_i` of a least-squares
/// quadratic through the points `x`, and the centre's leverage `h = l_centre`.
fn centre_smoother(x: &[f64], centre: usize) -> Option<(Vec<f64>, f64)> {
    // Normal matrix of the basis (1, x, x^2).
    let mut n = nalgebra::Matrix3::<f64>::zeros();
    for &xi in x {
        let v = nalgebra::Vector3::new(1.0, xi, xi * xi);
        n += v * v.transpose();
    }
    let inv = n.try_inverse()?;
    let x0 = x[centre];
    let v0 = nalgebra::Vector3::new(1.0, x0, x0 * x0);
    let row = v0.transpose() * inv;
    let l: Vec<f64> = x
        .iter()
        .map(|&xi| (row * nalgebra::Vector3::new(1.0, xi, xi * xi))[0])
        .collect();
    let h = l[centre];
    Some((l, h))
}

#[cfg(test)]
mod tests {
    use super::*;
    use num_complex::Complex64;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, StandardNormal};

    #[test]
    fn recovers_the_noise_of_a_smooth_response() {
        for s in [1e-3, 1e-2] {
            let mut rng = ChaCha8Rng::seed_from_u64(7);
            let samples: Vec<Sample> = (1..=3000)
                .map(|i| {
                    let w = i as f64 * 0.5;
                    // A resonance-like response (smooth at this density).
                    let q0 = Complex64::new(w * w, 0.0) / Complex64::new(1e6 - w * w, 2e3 * w);
                    let q: Vec<Complex64> = (0..4)
                        .map(|c| {
                            let qt = q0 * (1.0 + 0.3 * c as f64);
                            let n1: f64 = StandardNormal.sample(&mut rng);
                            let n2: f64 = StandardNormal.sample(&mut rng);
                            qt + Complex64::new(n1, n2) * (s * qt.norm() / 2f64.sqrt())
                        })
                        .collect();
                    Sample { omega: w, q }
                })
                .collect();
            let est = relative_noise_level(&samples).unwrap();
            assert!((est / s - 1.0).abs() < 0.05, "{s}: {est}");
        }
        assert!(relative_noise_level(&[]).is_none());
    }
}
