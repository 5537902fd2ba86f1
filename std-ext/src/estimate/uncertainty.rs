//! Uncertainty of the equation-error estimate: the covariance of the scaled
//! weights and the standard deviations of the reported quantities.
//!
//! # Covariance
//!
//! White's heteroscedasticity-consistent sandwich with the HC3 leverage
//! correction ([`sandwich_covariance`]): with the row weights `v_j` (product
//! of the forgetting factors applied after row `j`), `Phi = R^H R`, the
//! final residuals `e_j = d_j - u_j w~` and the leverages
//! `h_j = v_j u_j Phi^-1 u_j^H`,
//!
//! ```text
//! Cov(w~) = Phi^-1 (sum_j v_j^2 |e_j / (1 - h_j)|^2 u_j^H u_j) Phi^-1.
//! ```
//!
//! The leverage correction matters here: the few speeds near the critical
//! speeds carry most of the information (large `|q_B|`), so their residuals
//! are strongly shrunk by the fit.
//!
//! # Standard deviations
//!
//! Every reported stiffness and damping is a linear functional `g . x` of
//! the scaled weights ([`crate::estimate::Parametrization::stiffness_functional`],
//! [`crate::estimate::Parametrization::damping_functional`]), so `var = g^T Cov g`; `m e`
//! and the phase are linearised about the estimate. For the complex paper
//! structure the errors are taken circular (`var Re = var Im = E|.|^2 / 2`).

use nalgebra::DMatrix;
use num_complex::Complex64;
use rotorid_core::parametrization::Formulation;

use crate::estimate::unknowns::Functional;
use crate::estimate::Identification;

/// One row of the regression as the filter saw it (scaled, normalised),
/// with the cumulative log forgetting `sum ln lambda` when it was folded in.
#[derive(Debug, Clone, PartialEq)]
pub struct WeightedRow {
    /// The row `u_j` of `U S` (complex; real rows in `re`).
    pub u: Vec<Complex64>,
    /// Its desired response `d_j`.
    pub d: Complex64,
    /// `sum ln lambda_used` up to and including this row's step.
    pub log_weight: f64,
}

/// The sandwich covariance (see the module documentation) of the scaled
/// weights `w` from the triangular factor `r` (row-major `M x M`, upper
/// triangle used), the rows and the final cumulative log forgetting.
/// `None` with no more rows than unknowns, a singular factor or a
/// non-finite result.
pub fn sandwich_covariance(
    r: &[Complex64],
    w: &[Complex64],
    rows: &[WeightedRow],
    log_w: f64,
) -> Option<DMatrix<Complex64>> {
    let m = w.len();
    if r.len() != m * m || rows.len() <= m {
        return None;
    }
    let rm = DMatrix::from_fn(m, m, |i, j| {
        if j >= i {
            r[i * m + j]
        } else {
            Complex64::new(0.0, 0.0)
        }
    });
    let rinv = rm.solve_upper_triangular(&DMatrix::identity(m, m))?;
    let phi_inv = &rinv * rinv.adjoint();
    let mut meat = DMatrix::<Complex64>::zeros(m, m);
    for row in rows {
        let u = &row.u;
        let v = (log_w - row.log_weight).exp();
        let e = row.d - u.iter().zip(w).map(|(a, b)| a * b).sum::<Complex64>();
        // Leverage h = v u Phi^-1 u^H in [0, 1): the fit pulls row j's
        // residual toward zero by (1 - h); undo it (HC3).
        let mut h = Complex64::new(0.0, 0.0);
        for i in 0..m {
            if u[i] == Complex64::new(0.0, 0.0) {
                continue;
            }
            for (k, uk) in u.iter().enumerate() {
                h += u[i] * phi_inv[(i, k)] * uk.conj();
            }
        }
        let one_minus_h = (1.0 - v * h.re).max(1e-3);
        let s2 = v * v * e.norm_sqr() / (one_minus_h * one_minus_h);
        if s2 == 0.0 {
            continue;
        }
        for i in 0..m {
            let ui = u[i].conj() * s2;
            for (k, uk) in u.iter().enumerate() {
                meat[(i, k)] += ui * uk;
            }
        }
    }
    let c = &phi_inv * meat * &phi_inv;
    c.iter()
        .all(|z| z.re.is_finite() && z.im.is_finite())
        .then_some(c)
}

/// Standard deviations of the final estimates (same units as the values).
#[derive(Debug, Clone, PartialEq)]
pub struct StdSet {
    /// Per bearing: std of `k` (N/m) and `c` (N s/m), `yy..zz`.
    pub bearings: Vec<([f64; 4], [f64; 4])>,
    /// Per plane: std of `m e` (kg m) and of the phase (deg).
    pub unbalance: Vec<(f64, f64)>,
}

/// `g^T Cov g` for a sparse real functional (real part, clamped at 0).
fn quad(cov: &DMatrix<Complex64>, g: &Functional) -> f64 {
    let mut v = Complex64::new(0.0, 0.0);
    for &(i, gi) in g {
        for &(j, gj) in g {
            v += cov[(i, j)] * gi * gj;
        }
    }
    v.re.max(0.0)
}

impl Identification {
    /// Standard deviations of the final estimates from
    /// [`Self::covariance`] (see the module documentation); `None` without
    /// a covariance.
    pub fn std(&self) -> Option<StdSet> {
        self.std_at(self.last.omega)
    }

    /// [`Self::std`] of the identified laws at the speed `omega` (rad/s):
    /// a bearing law of order `P > 1` changes with speed, and so does its
    /// uncertainty (the unbalance does not).
    pub fn std_at(&self, omega: f64) -> Option<StdSet> {
        let cov = self.covariance.as_ref()?;
        let p = &self.param;
        let complex = p.structure.formulation == Formulation::Paper;
        let half = if complex { 0.5 } else { 1.0 };
        let bearings = (0..p.n_bearings())
            .map(|m| {
                let ks = core::array::from_fn(|e| {
                    (half * quad(cov, &p.stiffness_functional(m, e, omega))).sqrt()
                });
                let cs = core::array::from_fn(|e| {
                    (half * quad(cov, &p.damping_functional(m, e, omega))).sqrt()
                });
                (ks, cs)
            })
            .collect();
        let sa = p.scaling.unbalance;
        let unbalance = self
            .last
            .unbalance
            .iter()
            .enumerate()
            .map(|(k, u)| {
                let j = p.structure.plane_index(p.n_bearings(), k);
                let (var_me, var_ph) = if complex {
                    let v = 0.5 * cov[(j, j)].re.max(0.0) * sa * sa;
                    (v, v / (u.me * u.me).max(f64::MIN_POSITIVE))
                } else {
                    // d me = (x dx + y dy) / |a|, d phase = (x dy - y dx) / |a|^2.
                    let (x, y) = (u.a.re, u.a.im);
                    let r2 = (x * x + y * y).max(f64::MIN_POSITIVE);
                    let r = r2.sqrt();
                    let me = quad(cov, &vec![(j, sa * x / r), (j + 1, sa * y / r)]);
                    let ph = quad(cov, &vec![(j, -sa * y / r2), (j + 1, sa * x / r2)]);
                    (me, ph)
                };
                (var_me.sqrt(), var_ph.sqrt().to_degrees())
            })
            .collect();
        Some(StdSet {
            bearings,
            unbalance,
        })
    }
}
