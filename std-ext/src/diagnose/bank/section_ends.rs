//! How well the data place a section's ends: the spread of the diameter
//! factor over the runs of elements the data cannot tell from the section
//! found.
//!
//! The bank's sections run between the drawing's features
//! ([`super::modulus::sections`]); a diameter off on a machine runs
//! between any two elements, and with probes at the bearings the data
//! place its ends only roughly: a longer section at a smaller factor fits
//! about as well as a shorter one at a larger factor. The factor's
//! standard deviation of the fit holds for the section found, not for the
//! one on the machine (on realistic data, the factor found lay 5 to 600
//! of those deviations from the hidden one); this module adds the
//! part the ends leave open.
//!
//! **Every run, linearised.** About the fit found (the section `a..=b` at
//! the diameter factor `f`, the nominal parameters `theta_f`): with `r_f`
//! the weighted residual there and `D_e = (r(T_e) - r_f) / h` its change
//! per relative change of element `e`'s outer diameter (`T_e` the terms
//! with that element's diameter `1 + h` times more, `h` = [`STEP`]; on
//! every [`SCREEN_EVERY`](crate::diagnose::context::SCREEN_EVERY)-th
//! speed), the run `s` at a diameter factor `1 + x` (on the drawn
//! diameters) changes element `e` from the fit found by `x` outside
//! `a..=b`, `(1 + x) / f - 1` inside it, and `1 / f - 1` for the elements
//! of `a..=b` outside `s`. Its residual is then
//!
//! `r_0 + x C_s - J dtheta`, `r_0 = r_f + (1 / f - 1) sum_{e in a..=b} D_e`,
//! `C_s = sum_{e in s} w_e D_e`, `w_e = 1 / f` inside `a..=b`, else 1,
//!
//! with `J` the Jacobian of the predictions in the nominal parameters.
//! With `P` the projection off `J`'s columns (the parameters refitted),
//!
//! `S_s = |P r_0|^2 - (c_s . P r_0)^2 / |c_s|^2`, `x_s = -(c_s . P r_0) / |c_s|^2`,
//! `c_s = P C_s`,
//!
//! for every run at once from the prefix sums of the projected columns,
//! the runs whose every element moves by at most [`MAX_CHANGE`] from the
//! fit found (where the linearisation holds).
//!
//! **The leading runs, stepped.** One step refits the bearings only as far
//! as their linearisation reaches, and where they moved to absorb the
//! section found it overstates a distant run's misfit (on the stepped
//! shaft, the hidden run 180 noise variances above the found one
//! linearised, 12 below it after three steps). The found section and the
//! [`REFINED`] best runs outside the linearised tie (within
//! [`REFINE_WITHIN`] ties of the best) take up to [`STEPS`] Gauss-Newton
//! steps in the parameters and `x` together on their own exact terms.
//!
//! **The spread.** A run the data cannot tell from the best is one tied
//! with the least misfit ([`crate::diagnose::observe::tied`], the
//! differences scaled to every speed) by either reckoning: among all runs
//! linearised, or among the stepped ones. The half-width of the tied runs'
//! factors about the found section's own (as each reckoning has it),
//! divided by the two-sided 99 % normal quantile (the level of the tie),
//! is the ends' standard deviation, added in quadrature to the fit's.

use nalgebra::{DMatrix, DVector};

use crate::diagnose::candidate::Candidate;
use crate::diagnose::context::{Context, Thinned};
use crate::diagnose::effect::Effect;
use crate::diagnose::extended::E_STEP;
use crate::diagnose::fit::{self, FitData};
use crate::diagnose::observe::tied;
use crate::diagnose::parallel;
use crate::diagnose::stats::{chi2_quantile_upper, normal_quantile_upper};
use crate::diagnose::terms::{self, Columns, FormChange, SpeedTerms, StiffnessForm};
use crate::model::RotorModel;

/// The relative change of an element's outer diameter whose terms give
/// its column `D_e` (a forward difference; the forms' changes are a few
/// per cent, so `1 %` is in their range).
pub(crate) const STEP: f64 = 0.01;

/// The largest relative change of an element's diameter from the fit
/// found for which a run counts: the range where the linearisation holds
/// (an element's stiffness goes as `(1 + delta)^4`, within 16 % of
/// `1 + 4 delta` up to `|delta| = 0.1`). A run of one or two elements at
/// a larger change fits the linearised data as well, but the machine
/// would show the difference.
pub(crate) const MAX_CHANGE: f64 = 0.1;

/// The most runs outside the linearised tie that take Gauss-Newton steps
/// on their own terms (module docs).
const REFINED: usize = 4;

/// How many ties ([`crate::diagnose::observe::tied`]'s threshold) above
/// the best a run's linearised misfit may lie to take steps.
const REFINE_WITHIN: f64 = 30.0;

/// The most Gauss-Newton steps a run takes on its own terms.
const STEPS: usize = 3;

/// A run's steps end once `x` moves by less than this.
const STEP_END: f64 = 1e-4;

/// Singular values of the Jacobian below this fraction of the largest
/// count as zero in its pseudo-inverse (parameters the data do not
/// determine move by nothing).
const RANK_TOL: f64 = 1e-10;

/// The runs of elements tied with the best: `(first, last, factor)`
/// (0-based elements, the diameter factor), best first.
pub(crate) type Tied = Vec<(usize, usize, f64)>;

/// What the data leave open of a section's ends.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Ends {
    /// The ends' standard deviation of the diameter factor.
    pub std: f64,
    /// The tied runs of least and greatest factor, with their diameter
    /// factors (empty when one run alone is tied).
    pub extremes: Vec<(StiffnessForm, f64)>,
}

/// The ends' standard deviation of the diameter factor when `c` is a
/// stiffness error on a section alone (module docs), with the tied runs
/// of least and greatest factor; `None` for any other
/// candidate, or when the terms or the residuals cannot be evaluated (the
/// fit's deviation then stands alone). `sigma2`: the noise variance of the
/// choice.
pub(crate) fn section_ends(ctx: &Context<'_>, c: &Candidate, sigma2: f64) -> Option<Ends> {
    let StiffnessForm::Section { first, last } = c.stiffness else {
        return None;
    };
    if c.effects != [Effect::ShaftStiffnessError] || sigma2.is_nan() || sigma2 <= 0.0 {
        return None;
    }
    let n_el = ctx.model.shaft.len();
    if last >= n_el {
        return None;
    }
    let thin = ctx.thinned();
    let nom = ctx.base.n_params();
    let theta = &c.fit.theta[..nom];
    let f = c.e_terms + E_STEP * c.fit.theta[c.model.offset(0)];
    let found = c.stiffness.apply(ctx.model, f).ok()?;
    // The fit found's terms through the same reduction as the changed
    // ones (a change of `1` on one element), so that a column holds the
    // element's change, not the method's.
    let t_f = run_terms(ctx, &thin, &found, (0, 0), 1.0)?;
    let (r_f, Some(j), n_thin) = residual(ctx, &thin, &t_f, theta, true)? else {
        return None;
    };
    let columns = parallel::map(&(0..n_el).collect::<Vec<_>>(), ctx.threads(), |&e| {
        let te = run_terms(ctx, &thin, &found, (e, e), 1.0 + STEP)?;
        let (re, _, _) = residual(ctx, &thin, &te, theta, false)?;
        Some((re - &r_f) / STEP)
    });
    let mut cols = DMatrix::<f64>::zeros(r_f.len(), n_el);
    for (e, col) in columns.into_iter().enumerate() {
        cols.set_column(e, &col?);
    }
    let scale = ctx.data.n_equations() as f64 / n_thin.max(1) as f64;
    let found_run = (first, last, f);
    let (runs, x_lin) = linear_runs(&j, &r_f, &cols, found_run)?;
    let (half_lin, tied_lin) = tie(&runs, x_lin, scale, sigma2);
    // The found section and the leading runs outside the tie, stepped.
    let limit = REFINE_WITHIN * chi2_quantile_upper(2.0, 0.01) * sigma2 / scale;
    let s_min = runs.first()?.0;
    let mut picked: Vec<(usize, usize, f64)> = vec![(first, last, x_lin)];
    picked.extend(
        runs.iter()
            .filter(|r| r.0 - s_min <= limit && !tied_lin.iter().any(|t| (t.0, t.1) == (r.1, r.2)))
            .filter(|r| (r.1, r.2) != (first, last))
            .take(REFINED)
            .map(|r| (r.1, r.2, r.3)),
    );
    let r0 = reverted(&r_f, &cols, found_run);
    let svd = j.svd(true, true);
    let mut stepped: Vec<Run> = Vec::new();
    let mut x_found = None;
    for (a, b, x) in picked {
        // C_s (the weights of the module docs) and sum_{e in s} D_e.
        let (mut c_s, mut d_s) = (
            DVector::<f64>::zeros(r_f.len()),
            DVector::<f64>::zeros(r_f.len()),
        );
        for e in a..=b {
            let w = if (first..=last).contains(&e) {
                1.0 / f
            } else {
                1.0
            };
            c_s.axpy(w, &cols.column(e), 1.0);
            d_s += cols.column(e);
        }
        // The parameters of the linearised fit: J^+ (r_0 + x C_s).
        let Ok(dtheta) = svd.solve(&(&r0 + &c_s * x), RANK_TOL * svd.singular_values.max()) else {
            continue;
        };
        let start: Vec<f64> = theta
            .iter()
            .zip(dtheta.iter())
            .map(|(t, d)| t + d)
            .collect();
        let Some((s, x)) = steps(ctx, &thin, (a, b), &d_s, x, start) else {
            continue;
        };
        if (a, b) == (first, last) {
            x_found = Some(x);
        }
        if in_range(found_run, a, b, x) {
            stepped.push((s, a, b, x));
        }
    }
    let (half_stepped, tied_stepped) =
        x_found.map_or((0.0, Vec::new()), |x| tie(&stepped, x, scale, sigma2));
    let mut tied_all: Tied = tied_lin.into_iter().chain(tied_stepped).collect();
    tied_all.sort_by(|p, q| p.2.total_cmp(&q.2));
    let extremes = match (tied_all.first(), tied_all.last()) {
        (Some(lo), Some(hi)) if (lo.0, lo.1) != (hi.0, hi.1) => [lo, hi]
            .iter()
            .map(|&&(first, last, f)| (StiffnessForm::Section { first, last }, f))
            .collect(),
        _ => Vec::new(),
    };
    Some(Ends {
        std: half_lin.max(half_stepped) / normal_quantile_upper(0.005),
        extremes,
    })
}

/// The terms of `model` with the run `first..=last` of its elements at
/// `f` times their outer diameter, on the thinned speeds, the planes'
/// columns only.
fn run_terms(
    ctx: &Context<'_>,
    thin: &Thinned,
    model: &RotorModel,
    (first, last): (usize, usize),
    f: f64,
) -> Option<Vec<SpeedTerms>> {
    terms::build_form_columns(
        ctx.builder,
        model,
        &thin.omegas,
        FormChange {
            form: StiffnessForm::Section { first, last },
            f,
            derivative: false,
        },
        ctx.probe_nodes,
        Columns::Planes,
    )
    .ok()
}

/// The weighted residual of the nominal parameters `theta` on the terms
/// `t` of the thinned speeds, the Jacobian of the predictions when
/// `jacobian`, and the number of real equations.
fn residual(
    ctx: &Context<'_>,
    thin: &Thinned,
    t: &[SpeedTerms],
    theta: &[f64],
    jacobian: bool,
) -> Option<(DVector<f64>, Option<DMatrix<f64>>, usize)> {
    let d = FitData::with_probes(&thin.samples, &thin.node_q, t)
        .with_floors(&ctx.setup.phi)
        .with_noise_level(ctx.setup.noise_level);
    let en = fit::entries(ctx.base, &d);
    let (r, j) = fit::evaluate(ctx.base, &d, &en, theta, jacobian).ok()?;
    Some((r, j, d.n_equations()))
}

/// Up to [`STEPS`] Gauss-Newton steps of the run `a..=b` in the nominal
/// parameters and its factor `1 + x` together, from `theta` and `x`, on
/// the run's own terms; `d_s = sum_{e in s} D_e`, the residual's change
/// per relative change of the run's diameters (at `1 + x`, per unit
/// change of `x`: `d_s / (1 + x)`). The misfit the last step predicts
/// and the `x` it reaches.
fn steps(
    ctx: &Context<'_>,
    thin: &Thinned,
    (a, b): (usize, usize),
    d_s: &DVector<f64>,
    mut x: f64,
    mut theta: Vec<f64>,
) -> Option<(f64, f64)> {
    let mut s = None;
    for _ in 0..STEPS {
        let Some(t) = run_terms(ctx, thin, ctx.model, (a, b), 1.0 + x) else {
            break;
        };
        let Some((r, Some(j), _)) = residual(ctx, thin, &t, &theta, true) else {
            break;
        };
        // One factorisation for both: P v = v - U U^T v, and J^+.
        let svd = j.svd(true, true);
        let Some(u) = svd.u.as_ref() else {
            break;
        };
        let project = |v: DVector<f64>| {
            let t = u.tr_mul(&v);
            v - u * t
        };
        let col = d_s / (1.0 + x);
        let pr = project(r.clone());
        let pc = project(col.clone());
        let cc = pc.norm_squared();
        if cc.is_nan() || cc <= 0.0 {
            break;
        }
        let cr = pc.dot(&pr);
        let dx = -cr / cc;
        s = Some(pr.norm_squared() - cr * cr / cc);
        let tol = RANK_TOL * svd.singular_values.max();
        let Ok(dtheta) = svd.solve(&(r + col * dx), tol) else {
            break;
        };
        for (t, d) in theta.iter_mut().zip(dtheta.iter()) {
            *t += d;
        }
        x += dx;
        if dx.abs() < STEP_END {
            break;
        }
    }
    s.filter(|s| s.is_finite()).map(|s| (s, x))
}

/// A run in the linearised model: `(S_s, first, last, x_s)`.
type Run = (f64, usize, usize, f64);

/// Every run whose elements stay within [`MAX_CHANGE`] of the fit found,
/// with its `S_s` and `x_s` (module docs), least `S_s` first; and the
/// found section's own `x_s`.
fn linear_runs(
    j: &DMatrix<f64>,
    r_f: &DVector<f64>,
    cols: &DMatrix<f64>,
    found: (usize, usize, f64),
) -> Option<(Vec<Run>, f64)> {
    let n_el = cols.ncols();
    let (first, last, f) = found;
    if last >= n_el || first > last || j.nrows() != r_f.len() || f.is_nan() || f <= 0.0 {
        return None;
    }
    let inside = |e: usize| (first..=last).contains(&e);
    let r0 = reverted(r_f, cols, found);
    // P v = v - Q Q^T v, Q an orthonormal basis of J's columns (thin QR).
    let q = j.clone().qr().q();
    let project = |v: DVector<f64>| {
        let t = q.tr_mul(&v);
        v - &q * t
    };
    let pr = project(r0);
    let pr2 = pr.norm_squared();
    // Prefix sums of the projected, weighted columns: c_s = pre[b + 1] - pre[a].
    let mut pre = DMatrix::<f64>::zeros(r_f.len(), n_el + 1);
    for e in 0..n_el {
        let w = if inside(e) { 1.0 / f } else { 1.0 };
        let pc = project(cols.column(e) * w);
        let next = pre.column(e) + pc;
        pre.set_column(e + 1, &next);
    }
    let fit_run = |a: usize, b: usize| -> Option<(f64, f64)> {
        let c = pre.column(b + 1) - pre.column(a);
        let cc = c.norm_squared();
        if cc.is_nan() || cc <= 0.0 {
            return None;
        }
        let cr = c.dot(&pr);
        let x = -cr / cc;
        let s = pr2 - cr * cr / cc;
        in_range(found, a, b, x)
            .then_some((s, x))
            .filter(|_| s.is_finite())
    };
    let (_, x_found) = fit_run(first, last)?;
    let mut runs: Vec<Run> = Vec::new();
    for a in 0..n_el {
        for b in a..n_el {
            if let Some((s, x)) = fit_run(a, b) {
                runs.push((s, a, b, x));
            }
        }
    }
    runs.sort_by(|p, q| p.0.total_cmp(&q.0));
    Some((runs, x_found))
}

/// `r_0 = r_f + (1 / f - 1) sum_{e in first..=last} D_e`: the residual with
/// the found section back at its drawn diameter, linearised.
fn reverted(r_f: &DVector<f64>, cols: &DMatrix<f64>, found: (usize, usize, f64)) -> DVector<f64> {
    let (first, last, f) = found;
    let mut r0 = r_f.clone();
    for e in first..=last {
        r0.axpy(1.0 / f - 1.0, &cols.column(e), 1.0);
    }
    r0
}

/// Whether the run `a..=b` at the diameter factor `1 + x` keeps every
/// element within [`MAX_CHANGE`] of the fit found `found`.
fn in_range(found: (usize, usize, f64), a: usize, b: usize, x: f64) -> bool {
    let (first, last, f) = found;
    let inside = |e: usize| (first..=last).contains(&e);
    let outside_ok = (a..=b).all(inside) || x.abs() <= MAX_CHANGE;
    let inside_ok = !(a..=b).any(inside) || ((1.0 + x) / f - 1.0).abs() <= MAX_CHANGE;
    let dropped_ok =
        (1.0 / f - 1.0).abs() <= MAX_CHANGE || (first..=last).all(|e| (a..=b).contains(&e));
    outside_ok && inside_ok && dropped_ok
}

/// The runs of `runs` tied with the least `S` (scaled by `scale` to every
/// speed, against `sigma2`), best first, and the ends' standard deviation:
/// the half-width of their `x` about `x_found` over the two-sided 99 %
/// normal quantile.
fn tie(runs: &[Run], x_found: f64, scale: f64, sigma2: f64) -> (f64, Tied) {
    let s_min = runs.iter().map(|r| r.0).fold(f64::INFINITY, f64::min);
    let mut tied_runs: Vec<Run> = runs
        .iter()
        .copied()
        .filter(|r| tied(scale * r.0, scale * s_min, sigma2))
        .collect();
    tied_runs.sort_by(|p, q| p.0.total_cmp(&q.0));
    let half = tied_runs
        .iter()
        .map(|r| (r.3 - x_found).abs())
        .fold(0.0, f64::max);
    (
        half,
        tied_runs.iter().map(|r| (r.1, r.2, 1.0 + r.3)).collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// `S_s` and `x_s` of the run `a..=b` by a dense least-squares solve
    /// (SVD) of `min |r_0 + J dtheta + x C_s|^2` over `(dtheta, x)`, with
    /// `r_0` and `C_s` as the module docs define them for the fit found
    /// `found = (first, last, f)`.
    fn dense(
        j: &DMatrix<f64>,
        r_f: &DVector<f64>,
        cols: &DMatrix<f64>,
        found: (usize, usize, f64),
        a: usize,
        b: usize,
    ) -> (f64, f64) {
        let (first, last, f) = found;
        let p = j.ncols();
        let mut r0 = r_f.clone();
        for e in first..=last {
            r0 += cols.column(e) * (1.0 / f - 1.0);
        }
        let mut c = DVector::<f64>::zeros(j.nrows());
        for e in a..=b {
            let w = if (first..=last).contains(&e) {
                1.0 / f
            } else {
                1.0
            };
            c += cols.column(e) * w;
        }
        let mut m = DMatrix::<f64>::zeros(j.nrows(), p + 1);
        m.columns_mut(0, p).copy_from(j);
        m.set_column(p, &c);
        let sol = m.clone().svd(true, true).solve(&(-&r0), 1e-12).unwrap();
        let s = (&r0 + &m * &sol).norm_squared();
        (s, sol[p])
    }

    /// On random data with a run's change planted (elements 5..=9 at
    /// `1.03` on the nominal diameters, the nominal parameters off, noise
    /// of `1e-2`) and the fit found on 3..=11 at `1.02`: the spread's runs
    /// are those a dense solve ties, with the dense solve's factors; the
    /// planted run is among them, at its factor; and the half-width is
    /// that of the tied factors about the found run's.
    #[test]
    fn the_spread_is_the_dense_solves_tie() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let (m, p, n) = (240, 6, 16);
        let j = DMatrix::<f64>::from_fn(m, p, |_, _| rng.random_range(-1.0..1.0));
        // Neighbouring elements alike, as along a shaft.
        let shapes = DMatrix::<f64>::from_fn(m, 3, |_, _| rng.random_range(-1.0..1.0));
        let cols = DMatrix::<f64>::from_fn(m, n, |i, e| {
            let t = e as f64 / (n - 1) as f64;
            shapes[(i, 0)]
                + t * shapes[(i, 1)]
                + t * t * shapes[(i, 2)]
                + 0.01 * rng.random_range(-1.0..1.0)
        });
        let theta = DVector::<f64>::from_fn(p, |_, _| rng.random_range(-1.0..1.0));
        let found = (3, 11, 1.02);
        // The truth's change of each element from the fit found.
        let delta = |e: usize| match e {
            5..=9 => 1.03 / 1.02 - 1.0,
            3..=11 => 1.0 / 1.02 - 1.0,
            _ => 0.0,
        };
        let mut r_f = -(&j * &theta);
        for e in 0..n {
            r_f -= cols.column(e) * delta(e);
        }
        r_f += DVector::<f64>::from_fn(m, |_, _| 1e-2 * rng.random_range(-1.0..1.0));
        let sigma2 = 1e-4 / 3.0;
        let (runs, x_lin) = linear_runs(&j, &r_f, &cols, found).unwrap();
        let (half_got, tied_runs) = tie(&runs, x_lin, 1.0, sigma2);
        let x_found = dense(&j, &r_f, &cols, found, 3, 11).1;
        let in_range = |a: usize, b: usize, x: f64| {
            (a..=b).all(|e| {
                let d = if (3..=11).contains(&e) {
                    (1.0 + x) / 1.02 - 1.0
                } else {
                    x
                };
                d.abs() <= MAX_CHANGE
            })
        };
        let mut all = Vec::new();
        for a in 0..n {
            for b in a..n {
                let (s, x) = dense(&j, &r_f, &cols, found, a, b);
                if in_range(a, b, x) {
                    all.push((s, a, b, x));
                }
            }
        }
        let s_min = all.iter().map(|r| r.0).fold(f64::INFINITY, f64::min);
        let want: Vec<&(f64, usize, usize, f64)> =
            all.iter().filter(|r| tied(r.0, s_min, sigma2)).collect();
        assert!(want.len() >= 2, "{want:?}");
        assert_eq!(
            tied_runs.len(),
            want.len(),
            "{tied_runs:?} against {want:?}"
        );
        for (a, b, f) in &tied_runs {
            let w = want
                .iter()
                .find(|r| r.1 == *a && r.2 == *b)
                .expect("a run the dense solve ties");
            assert!(
                (f - 1.0 - w.3).abs() < 1e-9,
                "{a}..{b}: {f} against {}",
                1.0 + w.3
            );
        }
        let planted = tied_runs
            .iter()
            .find(|r| r.0 == 5 && r.1 == 9)
            .expect("the planted run tied");
        assert!((planted.2 - 1.03).abs() < 1e-3, "{planted:?}");
        let half = want
            .iter()
            .map(|r| (r.3 - x_found).abs())
            .fold(0.0, f64::max);
        assert!(half > 1e-3, "{half}");
        assert!((x_lin - x_found).abs() < 1e-9, "{x_lin} {x_found}");
        assert!((half_got - half).abs() < 1e-9 * half, "{half_got} {half}");
    }
}
