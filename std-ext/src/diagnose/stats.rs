//! The statistics of the choice: the upper quantiles of the chi-square
//! distribution (the likelihood-ratio thresholds, [`chi2_quantile_upper`])
//! and of the standard normal one ([`normal_quantile_upper`]), the
//! regularised upper incomplete gamma function they rest on
//! ([`gamma_q`], with `ln Gamma`), and the Bayesian information criterion
//! of a fit with its own noise variance (`bic`).

use super::fit::Fit;

/// The Bayesian information criterion of `f` over `n` real equations,
/// with `sigma^2 = S / n` from the fit itself: `n ln(S / n) + P ln n`
/// (`S / n` floored at the smallest positive number).
pub(crate) fn bic(f: &Fit, n: usize) -> f64 {
    // With sigma^2 from the fit itself: n ln(S/n) + P ln n.
    let n = n as f64;
    n * (f.s / n).max(f64::MIN_POSITIVE).ln() + f.n_params() as f64 * n.ln()
}

/// The upper quantile `x` with `P(chi2_k > x) = alpha`: the root of
/// `Q(k/2, x/2) = alpha` (regularised upper incomplete gamma function,
/// [`gamma_q`]) by bisection to `1e-10` relative.
pub fn chi2_quantile_upper(k: f64, alpha: f64) -> f64 {
    let s = 0.5 * k.max(1e-3);
    let (mut lo, mut hi) = (0.0_f64, 2.0 * k.max(1.0) + 100.0);
    while gamma_q(s, 0.5 * hi) > alpha && hi < 1e6 {
        hi *= 2.0;
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if gamma_q(s, 0.5 * mid) > alpha {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo <= 1e-10 * hi {
            break;
        }
    }
    0.5 * (lo + hi)
}

/// `ln Gamma(x)` for `x > 0` (Lanczos, `g = 7`, 9 terms; relative error
/// below `1e-13`).
fn ln_gamma(x: f64) -> f64 {
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        let pi = std::f64::consts::PI;
        return (pi / (pi * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + 7.5;
    for (i, c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// The regularised upper incomplete gamma function `Q(s, x)`: the series
/// of `P` for `x < s + 1`, Lentz's continued fraction otherwise.
pub fn gamma_q(s: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    let lg = ln_gamma(s);
    if x < s + 1.0 {
        let (mut sum, mut term, mut n) = (1.0 / s, 1.0 / s, s);
        for _ in 0..1000 {
            n += 1.0;
            term *= x / n;
            sum += term;
            if term.abs() < sum.abs() * 1e-16 {
                break;
            }
        }
        1.0 - sum * (-x + s * x.ln() - lg).exp()
    } else {
        let tiny = 1e-300;
        let mut b = x + 1.0 - s;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..1000 {
            let an = -(i as f64) * (i as f64 - s);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let del = d * c;
            h *= del;
            if (del - 1.0).abs() < 1e-16 {
                break;
            }
        }
        (-x + s * x.ln() - lg).exp() * h
    }
}

/// The upper quantile `z` with `P(N(0,1) > z) = alpha` (Acklam's rational
/// approximation, relative error `1.2e-9`).
pub fn normal_quantile_upper(alpha: f64) -> f64 {
    let p = (1.0 - alpha).clamp(1e-300, 1.0 - 1e-16);
    const A: [f64; 6] = [
        -3.969683028665376e1,
        2.209460984245205e2,
        -2.759285104469687e2,
        1.383_577_518_672_69e2,
        -3.066479806614716e1,
        2.506628277459239,
    ];
    const B: [f64; 5] = [
        -5.447609879822406e1,
        1.615858368580409e2,
        -1.556989798598866e2,
        6.680131188771972e1,
        -1.328068155288572e1,
    ];
    const C: [f64; 6] = [
        -7.784894002430293e-3,
        -3.223964580411365e-1,
        -2.400758277161838,
        -2.549732539343734,
        4.374664141464968,
        2.938163982698783,
    ];
    const D: [f64; 4] = [
        7.784695709041462e-3,
        3.224671290700398e-1,
        2.445134137142996,
        3.754408661907416,
    ];
    let tail = |q: f64| {
        (((((C[0] * q + C[1]) * q + C[2]) * q + C[3]) * q + C[4]) * q + C[5])
            / ((((D[0] * q + D[1]) * q + D[2]) * q + D[3]) * q + 1.0)
    };
    if p < 0.02425 {
        tail((-2.0 * p.ln()).sqrt())
    } else if p > 1.0 - 0.02425 {
        -tail((-2.0 * (1.0 - p).ln()).sqrt())
    } else {
        let q = p - 0.5;
        let r = q * q;
        (((((A[0] * r + A[1]) * r + A[2]) * r + A[3]) * r + A[4]) * r + A[5]) * q
            / (((((B[0] * r + B[1]) * r + B[2]) * r + B[3]) * r + B[4]) * r + 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles() {
        assert!((normal_quantile_upper(0.025) - 1.959964).abs() < 1e-5);
        assert!((normal_quantile_upper(1e-6) - 4.753424).abs() < 1e-4);
        // chi2_2 upper alpha is -2 ln(alpha) exactly.
        for alpha in [0.1, 1e-3, 1e-7] {
            let x = chi2_quantile_upper(2.0, alpha);
            assert!((x / (-2.0 * f64::ln(alpha)) - 1.0).abs() < 1e-8, "{x}");
        }
        // Tables: chi2_8 upper 0.01 = 20.0902, chi2_1 upper 0.05 = 3.84146,
        // chi2_30 upper 0.001 = 59.70306 (SciPy).
        assert!((chi2_quantile_upper(8.0, 0.01) / 20.0902 - 1.0).abs() < 1e-5);
        assert!((chi2_quantile_upper(1.0, 0.05) / 3.84146 - 1.0).abs() < 1e-5);
        assert!((chi2_quantile_upper(30.0, 0.001) / 59.703064 - 1.0).abs() < 1e-5);
    }
}
