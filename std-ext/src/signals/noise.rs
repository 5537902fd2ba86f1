//! Pooled standard errors of the averaged vectors.
//!
//! The order tracker gives each averaged vector a standard error from the
//! scatter of its `N` revolutions about their trend: `2 (N - 2)` real
//! degrees of freedom, so with `N = 8` the variance itself is uncertain by
//! `1 / sqrt(N - 2)`, about 40 %. Weights that noisy would cost a
//! weighted fit part of its accuracy, so the variances are pooled over the
//! whole sweep, channel by channel, through the noise model of the
//! samples: white noise of variance `f^2 + s^2 |Y|^2` on each probe sample
//! (a floor `f` in metres and a part relative to the 1X amplitude, the
//! model of SPEC section 7 on the samples) gives an averaged vector of
//! variance (module `rotorid_core::ordertrack`, `E|dY|^2 = 4 sigma^2 / (M N)`)
//!
//! ```text
//! E|dY_k|^2 = g_k (f^2 + s^2 |Y_k|^2),     g_k = 4 / (M_k N_k),
//! ```
//!
//! `M_k = 2 pi f_s / Omega_k` the samples per revolution and `N_k` the
//! revolutions of row `k`. `a = f^2` and `b = s^2` are fitted to the
//! rows' variances `v_k` by iteratively reweighted least squares on
//! `u_k = v_k / g_k = a + b |Y_k|^2` with weights `1 / (a + b |Y_k|^2)^2`
//! (the variance of a scaled chi-square is proportional to its mean
//! squared: the maximum-likelihood weighting), `a, b >= 0`, starting from
//! `a = median(u)`, `b = 0`.
//!
//! A row whose own variance is beyond the model at the 0.1 % level,
//! `u_k > T_k (a + b |Y_k|^2)` with `T_k = chi2_0.999(nu_k) / nu_k`,
//! `nu_k = 2 (N_k - 2)` (about 2.74 for `N = 8`, Wilson-Hilferty), is no
//! noise the model knows: the vector changed faster than a straight line
//! within its group (a resonance passed quickly, a transient). It is left
//! out of the fit, and keeps its own standard error; every other row gets
//! the pooled one, `sqrt(g_k (a + b |Y_k|^2))`, with the
//! `2 (N - 2) K` degrees of freedom of the `K` pooled rows behind it
//! instead of `2 (N - 2)`.

/// The fitted noise of one channel's samples.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoiseFit {
    /// The floor `f` (m, standard deviation per sample).
    pub floor: f64,
    /// The relative part `s` (per sample, of the 1X amplitude).
    pub relative: f64,
    /// Rows the fit used.
    pub rows_used: usize,
}

impl NoiseFit {
    /// The variance of an averaged vector with factor `g = 4 / (M N)` and
    /// amplitude `|Y|^2 = y2`.
    pub fn variance(&self, g: f64, y2: f64) -> f64 {
        g * (self.floor * self.floor + self.relative * self.relative * y2)
    }
}

/// The fewest rows a pooled fit takes.
pub const MIN_ROWS: usize = 4;

/// `chi2_0.999(nu) / nu` by the Wilson-Hilferty approximation,
/// `(1 - 2 / (9 nu) + z sqrt(2 / (9 nu)))^3`, `z = 3.090`.
pub fn beyond_threshold(nu: f64) -> f64 {
    let c = 2.0 / (9.0 * nu.max(1.0));
    (1.0 - c + 3.090 * c.sqrt()).powi(3)
}

/// Fits `a + b y2_k` to `u_k` (see the module documentation), rows with
/// `u_k > t_k` times the model left out; `None` with fewer than
/// [`MIN_ROWS`] usable rows.
pub fn fit(y2: &[f64], u: &[f64], t: &[f64]) -> Option<NoiseFit> {
    let rows: Vec<(f64, f64, f64)> = y2
        .iter()
        .zip(u)
        .zip(t)
        .filter(|((y, u), t)| y.is_finite() && u.is_finite() && **u >= 0.0 && t.is_finite())
        .map(|((y, u), t)| (*y, *u, *t))
        .collect();
    if rows.len() < MIN_ROWS {
        return None;
    }
    let mut sorted: Vec<f64> = rows.iter().map(|r| r.1).collect();
    sorted.sort_by(f64::total_cmp);
    let median = sorted.get(sorted.len() / 2).copied().unwrap_or(0.0);
    let (mut a, mut b) = (median, 0.0);
    let mut used = rows.len();
    for _ in 0..30 {
        let model = |y: f64| a + b * y;
        let top = rows.iter().map(|r| model(r.0)).fold(0.0, f64::max);
        let tiny = (1e-9 * top).max(f64::MIN_POSITIVE);
        let kept: Vec<(f64, f64, f64)> = rows
            .iter()
            .filter(|(y, u, t)| *u <= t * model(*y))
            .map(|(y, u, _)| {
                let m = model(*y).max(tiny);
                (*y, *u, 1.0 / (m * m))
            })
            .collect();
        if kept.len() < MIN_ROWS {
            break;
        }
        used = kept.len();
        let (mut sw, mut sy, mut syy, mut su, mut syu) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for (y, u, w) in &kept {
            sw += w;
            sy += w * y;
            syy += w * y * y;
            su += w * u;
            syu += w * y * u;
        }
        let det = sw * syy - sy * sy;
        let (mut na, mut nb) = if det > 1e-12 * sw * syy {
            ((syy * su - sy * syu) / det, (sw * syu - sy * su) / det)
        } else {
            (su / sw, 0.0)
        };
        if na < 0.0 || nb < 0.0 {
            // The better of the one-parameter fits.
            let a_only = su / sw;
            let b_only = if syy > 0.0 { (syu / syy).max(0.0) } else { 0.0 };
            let sse = |a: f64, b: f64| -> f64 {
                kept.iter()
                    .map(|(y, u, w)| w * (u - a - b * y).powi(2))
                    .sum()
            };
            (na, nb) = if b_only > 0.0 && sse(0.0, b_only) < sse(a_only, 0.0) {
                (0.0, b_only)
            } else {
                (a_only, 0.0)
            };
        }
        let done = (na - a).abs() <= 1e-10 * na.abs().max(1e-300)
            && (nb - b).abs() <= 1e-10 * nb.abs().max(1e-300);
        (a, b) = (na, nb);
        if done {
            break;
        }
    }
    (a.is_finite() && b.is_finite()).then(|| NoiseFit {
        floor: a.max(0.0).sqrt(),
        relative: b.max(0.0).sqrt(),
        rows_used: used,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Gamma};

    /// Scaled chi-square variances (12 degrees of freedom, as from 8
    /// revolutions about a trend) of a known floor and relative part:
    /// the pooled fit finds both within a few percent from 200 rows.
    #[test]
    fn recovers_floor_and_relative_part() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let (a, b) = (0.25e-12, 6.25e-3);
        let dof = 12.0;
        let gamma = Gamma::new(dof / 2.0, 2.0 / dof).unwrap();
        let y2: Vec<f64> = (0..200)
            .map(|k| (1e-7 * (1.0 + k as f64)).powi(2))
            .collect();
        let u: Vec<f64> = y2
            .iter()
            .map(|y| (a + b * y) * gamma.sample(&mut rng))
            .collect();
        let t = vec![beyond_threshold(dof); y2.len()];
        let f = fit(&y2, &u, &t).unwrap();
        assert!((f.floor.powi(2) / a - 1.0).abs() < 0.1, "{f:?}");
        assert!((f.relative.powi(2) / b - 1.0).abs() < 0.1, "{f:?}");
        // A pure floor: b stays 0, a within 10 %.
        let u: Vec<f64> = y2.iter().map(|_| a * gamma.sample(&mut rng)).collect();
        let f = fit(&y2, &u, &t).unwrap();
        assert!((f.floor.powi(2) / a - 1.0).abs() < 0.1, "{f:?}");
        assert!(f.relative.powi(2) * y2[199] < 0.2 * a, "{f:?}");
        assert!(fit(&y2[..3], &u[..3], &t[..3]).is_none());
        // Wilson-Hilferty against the tabulated chi2_0.999(12) = 32.91.
        assert!((beyond_threshold(12.0) * 12.0 / 32.91 - 1.0).abs() < 0.01);
    }
}
