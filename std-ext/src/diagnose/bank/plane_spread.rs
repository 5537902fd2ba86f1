//! How well the data place an extra unbalance: the spread of its `m e`
//! over the runs of nodes the data cannot tell from the plane found.
//!
//! The bank's hypothesis puts the extra unbalance at one node; on a
//! machine it is often spread along a section (a coupling, an impeller's
//! hub, a shrunk-on part, a patch of erosion or deposit), and with probes
//! at the bearings the data place it only roughly: a plane at a
//! neighbouring node, or the same unbalance shared among a few
//! neighbouring nodes, fits about as well at another `m e`. The fit's
//! standard deviation holds for the plane found at its node, not for
//! the unbalance on the machine (on realistic data of the stepped hollow
//! shaft, the `m e` found at the middle node of an unbalance spread over
//! three lay 10 to 20 % and up to 25 of those deviations from its total);
//! this module adds the part the spread leaves open, as
//! [`super::section_ends`] does for a section's diameter. The same
//! reckoning ranks the runs the bank fits as the variant of an unbalance
//! shared by a run of nodes ([`best_runs`],
//! [`crate::diagnose::extended::Extension::Spread`]).
//!
//! **Every run, at once.** For fixed bearing parameters the response is
//! linear in an unbalance: with `C_i` the weighted residual's two columns
//! per (scaled) `m e` phasor at node `i` (the plane's Jacobian, the same
//! at any `m e`), `r_0` the weighted residual of the nominal parameters
//! `theta_f` of the fit found with no extra unbalance, and `J` the
//! Jacobian in the nominal parameters there, the run `s` of `n_s`
//! consecutive nodes sharing the phasor `p` equally has the residual
//!
//! `r_0 + C_s p - J dtheta`, `C_s = (1 / n_s) sum_{i in s} C_i`.
//!
//! With `P` the projection off `J`'s columns (the parameters refitted)
//! and `c_s = P C_s` (two columns), its misfit and phasor are
//!
//! `S_s = |P r_0|^2 - b^T A^-1 b`, `p_s = -A^-1 b`, `A = c_s^T c_s`, `b = c_s^T P r_0`,
//!
//! for every run at once from the prefix sums of the projected columns.
//! The runs hold the nodes the plane family searches (none of the model's
//! own balance planes, whose unbalance the nominal fit estimates).
//!
//! **The spread.** A run the data cannot tell from the best is one tied
//! with the least misfit ([`crate::diagnose::observe::tied`]). The
//! half-width of the tied runs' `m e = |p_s|` (times the unbalance scale)
//! about the plane found's own in the same reckoning, divided by the
//! two-sided 99 % normal quantile (the level of the tie), is the spread's
//! standard deviation, added in quadrature to the fit's. Only the size is
//! widened: the phase the runs share is the plane's within the fit's
//! deviation.

use nalgebra::{DMatrix, DVector, Matrix2, Vector2};

use crate::diagnose::candidate::Candidate;
use crate::diagnose::context::Context;
use crate::diagnose::effect::Effect;
use crate::diagnose::extended::Extension;
use crate::diagnose::fit;
use crate::diagnose::observe::tied;
use crate::diagnose::stats::normal_quantile_upper;

/// A run of nodes tied with the best: `(first, last, m e)` (0-based
/// nodes, kg m).
pub(crate) type PlaneRun = (usize, usize, f64);

/// What the data leave open of where an extra unbalance lies.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Spread {
    /// The spread's standard deviation of `m e` (kg m).
    pub std: f64,
    /// The tied runs of least and greatest `m e` (empty when one run
    /// alone is tied).
    pub extremes: Vec<PlaneRun>,
}

/// The spread's standard deviation of `m e` when `c` is an extra
/// unbalance alone, at a plane or shared by a run of nodes (module docs;
/// the half-width taken about `c`'s own), with the tied runs of least
/// and greatest `m e`; `None` for any other candidate, or when the residual
/// or its Jacobian cannot be evaluated (the fit's deviation then stands
/// alone). `sigma2`: the noise variance of the choice.
pub(crate) fn plane_spread(ctx: &Context<'_>, c: &Candidate, sigma2: f64) -> Option<Spread> {
    let [ext] = c.model.ext.as_slice() else {
        return None;
    };
    let (first, last) = ext.unbalance_nodes()?;
    if c.effects != [Effect::ExtraUnbalancePlane] || sigma2.is_nan() || sigma2 <= 0.0 {
        return None;
    }
    let nodes = searched_nodes(ctx);
    let at = (
        nodes.iter().position(|n| *n == first)?,
        nodes.iter().position(|n| *n == last)?,
    );
    let (j, r0, cols) = columns(ctx, &nodes, c.fit.theta.get(..ctx.base.n_params())?)?;
    let runs = linear_runs(&j, &r0, &cols, &nodes)?;
    let scale = c.model.pr.param.scaling.unbalance;
    let p_found = runs.iter().find(|r| (r.1, r.2) == at)?.3;
    let (half, tied_runs) = tie(&runs, p_found, sigma2);
    let node_at = |i: usize| nodes.get(i).copied();
    let extremes = match (tied_runs.first(), tied_runs.last()) {
        (Some(lo), Some(hi)) if (lo.1, lo.2) != (hi.1, hi.2) => [lo, hi]
            .iter()
            .filter_map(|r| Some((node_at(r.1)?, node_at(r.2)?, scale * r.3)))
            .collect(),
        _ => Vec::new(),
    };
    Some(Spread {
        std: scale * half / normal_quantile_upper(0.005),
        extremes,
    })
}

/// The nodes an extra unbalance may be at: every node but the model's
/// balance planes, in order.
fn searched_nodes(ctx: &Context<'_>) -> Vec<usize> {
    let model = ctx.model;
    (0..model.n_nodes())
        .filter(|n| !model.planes.contains(n))
        .collect()
}

/// At the nominal parameters `theta_nom` with no extra unbalance: the
/// Jacobian `J` in the nominal parameters, the weighted residual `r_0`,
/// and the two columns `C_i` of each node of `nodes` in turn (module
/// docs).
fn columns(
    ctx: &Context<'_>,
    nodes: &[usize],
    theta_nom: &[f64],
) -> Option<(DMatrix<f64>, DVector<f64>, DMatrix<f64>)> {
    let all = ctx.with_ext(
        nodes
            .iter()
            .map(|&node| Extension::Plane { node })
            .collect(),
    );
    let nom = ctx.base.n_params();
    let mut theta = theta_nom.to_vec();
    theta.resize(all.n_params(), 0.0);
    let en = fit::entries(&all, ctx.data);
    let (r0, Some(jac)) = fit::evaluate(&all, ctx.data, &en, &theta, true).ok()? else {
        return None;
    };
    let j = jac.columns(0, nom).into_owned();
    let cols = jac.columns(nom, 2 * nodes.len()).into_owned();
    Some((j, r0, cols))
}

/// A run of nodes as an extension, with the start of its (scaled) phasor.
pub(crate) type RunStart = (Extension, [f64; 2]);

/// The `n` runs of two or more nodes that fit best, linearised about the
/// nominal parameters `theta_nom` (module docs), as extensions with the
/// start of their (scaled) phasor, least misfit first: the starts of the
/// bank's variant of an unbalance spread along a section; and the number
/// of runs of two or more nodes weighed (the alternatives of the search).
pub(crate) fn best_runs(
    ctx: &Context<'_>,
    theta_nom: &[f64],
    n: usize,
) -> Option<(Vec<RunStart>, usize)> {
    let nodes = searched_nodes(ctx);
    let (j, r0, cols) = columns(ctx, &nodes, theta_nom)?;
    let runs: Vec<RunFit> = linear_run_fits(&j, &r0, &cols, &nodes)?
        .into_iter()
        .filter(|r| r.2 > r.1)
        .collect();
    let weighed = runs.len();
    let best = runs
        .into_iter()
        .take(n)
        .map(|(_, a, b, p)| {
            (
                Extension::Spread {
                    first: nodes[a],
                    last: nodes[b],
                },
                [p[0], p[1]],
            )
        })
        .collect();
    Some((best, weighed))
}

/// A run in the linearised model: `(S_s, first, last, |p_s|)`, `first`
/// and `last` indices into the searched nodes, `|p_s|` scaled.
type Run = (f64, usize, usize, f64);

/// A run with its phasor: `(S_s, first, last, p_s)` (`p_s` scaled, real
/// and imaginary parts).
pub(crate) type RunFit = (f64, usize, usize, Vector2<f64>);

/// Every run of consecutive searched nodes (`nodes`, in order; a run
/// does not jump a node left out) with its `S_s` and `|p_s|` (module
/// docs), least `S_s` first. `cols`: the two columns of each node in
/// turn.
fn linear_runs(
    j: &DMatrix<f64>,
    r0: &DVector<f64>,
    cols: &DMatrix<f64>,
    nodes: &[usize],
) -> Option<Vec<Run>> {
    Some(
        linear_run_fits(j, r0, cols, nodes)?
            .into_iter()
            .map(|(s, a, b, p)| (s, a, b, p.norm()))
            .collect(),
    )
}

/// [`linear_runs`] with each run's phasor.
fn linear_run_fits(
    j: &DMatrix<f64>,
    r0: &DVector<f64>,
    cols: &DMatrix<f64>,
    nodes: &[usize],
) -> Option<Vec<RunFit>> {
    let n = nodes.len();
    if cols.ncols() != 2 * n || j.nrows() != r0.len() || cols.nrows() != r0.len() {
        return None;
    }
    // P v = v - Q Q^T v, Q an orthonormal basis of J's columns (thin QR).
    let q = j.clone().qr().q();
    let project = |v: DVector<f64>| {
        let t = q.tr_mul(&v);
        v - &q * t
    };
    let pr = project(r0.clone());
    let pr2 = pr.norm_squared();
    // Prefix sums of the projected columns: pre[k] holds nodes 0..k.
    let mut pre = DMatrix::<f64>::zeros(r0.len(), 2 * (n + 1));
    for i in 0..n {
        for k in 0..2 {
            let pc = project(cols.column(2 * i + k).into_owned());
            let next = pre.column(2 * i + k) + pc;
            pre.set_column(2 * (i + 1) + k, &next);
        }
    }
    let fit_run = |a: usize, b: usize| -> Option<(f64, Vector2<f64>)> {
        let w = 1.0 / (b + 1 - a) as f64;
        let c0 = (pre.column(2 * (b + 1)) - pre.column(2 * a)) * w;
        let c1 = (pre.column(2 * (b + 1) + 1) - pre.column(2 * a + 1)) * w;
        let a2 = Matrix2::new(
            c0.norm_squared(),
            c0.dot(&c1),
            c0.dot(&c1),
            c1.norm_squared(),
        );
        let b2 = Vector2::new(c0.dot(&pr), c1.dot(&pr));
        let p = -a2.try_inverse()? * b2;
        let s = pr2 + b2.dot(&p);
        (s.is_finite() && p.iter().all(|x| x.is_finite())).then_some((s, p))
    };
    let mut runs: Vec<RunFit> = Vec::new();
    for a in 0..n {
        for b in a..n {
            if b > a && nodes[b] != nodes[b - 1] + 1 {
                break;
            }
            if let Some((s, p)) = fit_run(a, b) {
                runs.push((s, a, b, p));
            }
        }
    }
    runs.sort_by(|p, q| p.0.total_cmp(&q.0));
    Some(runs)
}

/// The runs of `runs` tied with the least `S` (against `sigma2`), least
/// `m e` first, and the half-width of their `|p|` about `p_found`.
fn tie(runs: &[Run], p_found: f64, sigma2: f64) -> (f64, Vec<Run>) {
    let s_min = runs.iter().map(|r| r.0).fold(f64::INFINITY, f64::min);
    let mut tied_runs: Vec<Run> = runs
        .iter()
        .copied()
        .filter(|r| tied(r.0, s_min, sigma2))
        .collect();
    tied_runs.sort_by(|p, q| p.3.total_cmp(&q.3));
    let half = tied_runs
        .iter()
        .map(|r| (r.3 - p_found).abs())
        .fold(0.0, f64::max);
    (half, tied_runs)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// The prefix-sum arithmetic against a dense least-squares solve of
    /// every run (`[J, C_s]` by SVD), on random data with an unbalance
    /// spread over a run planted: the same misfits and `|p|`, and the
    /// planted run fits best at its phasor.
    #[test]
    fn every_runs_fit_is_the_dense_solves() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let (rows, n_nom) = (120, 5);
        // Nodes 0..4 and 6..9 (node 5 a balance plane, left out).
        let nodes: Vec<usize> = (0..10).filter(|&n| n != 5).collect();
        let j = DMatrix::from_fn(rows, n_nom, |_, _| rng.random_range(-1.0..1.0));
        let cols = DMatrix::from_fn(rows, 2 * nodes.len(), |_, _| rng.random_range(-1.0..1.0));
        // Planted: nodes 6..8 (indices 5..=7) share p = (0.3, -0.4).
        let p = Vector2::new(0.3, -0.4);
        let mut r0 = DVector::from_fn(rows, |_, _| 1e-3 * rng.random_range(-1.0..1.0));
        r0 += &j * DVector::from_fn(n_nom, |_, _| rng.random_range(-1.0..1.0));
        for i in 5..=7 {
            r0 -= (cols.column(2 * i) * p[0] + cols.column(2 * i + 1) * p[1]) / 3.0;
        }
        let runs = linear_runs(&j, &r0, &cols, &nodes).unwrap();
        // No run jumps node 5 (indices 4 and 5 are nodes 4 and 6).
        assert!(runs.iter().all(|r| !(r.1 <= 4 && r.2 >= 5)));
        // Runs of nodes 0..=4 (15) and of nodes 6..=9 (10).
        assert_eq!(runs.len(), 15 + 10);
        // Every run's misfit and |p| by the dense solve.
        let mut dense: Vec<(f64, usize, usize, f64)> = Vec::new();
        for &(s, a, b, pn) in &runs {
            let n_s = (b + 1 - a) as f64;
            let mut m = DMatrix::zeros(rows, n_nom + 2);
            m.columns_mut(0, n_nom).copy_from(&j);
            for i in a..=b {
                for k in 0..2 {
                    let col = m.column(n_nom + k) + cols.column(2 * i + k) / n_s;
                    m.set_column(n_nom + k, &col);
                }
            }
            let x = m.clone().svd(true, true).solve(&(-&r0), 1e-14).unwrap();
            let res = &r0 + &m * &x;
            let sd = res.norm_squared();
            assert!(
                (sd - s).abs() <= 1e-9 * sd.max(1e-12),
                "run {a}..{b}: {s} against {sd}"
            );
            let pd = (x[n_nom].powi(2) + x[n_nom + 1].powi(2)).sqrt();
            assert!(
                (pd - pn).abs() <= 1e-9 * pd,
                "run {a}..{b}: {pn} against {pd}"
            );
            dense.push((sd, a, b, pd));
        }
        let best = runs[0];
        assert_eq!((best.1, best.2), (5, 7));
        assert!((best.3 - p.norm()).abs() < 1e-2 * p.norm());
        // The tie and the half-width about the single node 6 (index 5),
        // against the dense solves': the runs within the chi-square
        // quantile of 2 degrees of freedom at 1 % (9.21) noise variances
        // of the least misfit.
        let sigma2 = 1e-6 / 3.0;
        let p_found = runs.iter().find(|r| (r.1, r.2) == (5, 5)).unwrap().3;
        let (half, tied_runs) = tie(&runs, p_found, sigma2);
        let s_min = dense.iter().map(|d| d.0).fold(f64::INFINITY, f64::min);
        let want: Vec<(usize, usize)> = dense
            .iter()
            .filter(|d| d.0 - s_min < 9.2103 * sigma2)
            .map(|d| (d.1, d.2))
            .collect();
        let mut got: Vec<(usize, usize)> = tied_runs.iter().map(|r| (r.1, r.2)).collect();
        let mut want_sorted = want.clone();
        got.sort();
        want_sorted.sort();
        assert_eq!(got, want_sorted);
        assert!(got.contains(&(5, 7)));
        let half_dense = dense
            .iter()
            .filter(|d| want.contains(&(d.1, d.2)))
            .map(|d| (d.3 - p_found).abs())
            .fold(0.0, f64::max);
        assert!((half - half_dense).abs() <= 1e-9 * half_dense.max(1e-12));
        // The single node is not the planted run: its |p| differs, and
        // the half-width reaches the planted run's.
        assert!((best.3 - p_found).abs() > 0.01 * best.3);
        assert!(half >= (best.3 - p_found).abs());
    }
}
