//! The pairs (module docs of [`crate::diagnose`], step 3), tried when the
//! chosen model still misfits: the strongest significant effect with each
//! other significant one (`fit_pair`), node effects searched again on top
//! of the other effect's fit, and pedestals under two bearings; the best
//! by BIC.

use crate::diagnose::bank::{rescreen, two_pedestals};
use crate::diagnose::candidate::Candidate;
use crate::diagnose::choice::Judge;
use crate::diagnose::context::Context;
use crate::diagnose::extended::{ExtendedModel, Extension};
use crate::diagnose::fit::{self, FitData};
use crate::diagnose::input::DiagnoseError;
use crate::diagnose::nominal::map_theta;
use crate::diagnose::terms::{self, Columns, FormChange, SpeedTerms, StiffnessForm};

/// The pair (or the single pedestal found by the search for two) of least
/// BIC among: the strongest significant hypothesis of `hyps` with each
/// other significant one, with the node of a node effect searched again
/// on top of the other's fit; then, only when none of these fits, two
/// pedestals. `None` when nothing fits.
pub(crate) fn best_pair(
    ctx: &Context<'_>,
    hyps: &[Candidate],
    judge: &Judge,
    e_cache: &mut Option<(StiffnessForm, f64, Vec<SpeedTerms>)>,
) -> Result<Option<Candidate>, DiagnoseError> {
    // Pairs of the strongest effect with each other significant one.
    let mut strong: Vec<usize> = (0..hyps.len()).filter(|&i| hyps[i].significant).collect();
    strong.sort_by(|&a, &b| hyps[b].statistic.total_cmp(&hyps[a].statistic));
    let mut pair_best: Option<Candidate> = None;
    let mut trials: Vec<(Candidate, Candidate)> = Vec::new();
    // The strongest effect with every other significant one.
    for &i in strong.iter().take(1) {
        for &k in strong.iter().skip(1) {
            trials.push((hyps[i].clone(), hyps[k].clone()));
            // A node searched against the nominal model may be wrong
            // when another effect dominates: search it again on top of
            // the other effect's fit.
            for (a, b) in [(&hyps[i], &hyps[k]), (&hyps[k], &hyps[i])] {
                if a.model.ext.contains(&Extension::EScale) {
                    continue;
                }
                for moved in rescreen(ctx.model, ctx.data, a, b)? {
                    trials.push((a.clone(), moved));
                }
            }
        }
    }
    for (a, b) in &trials {
        if let Some(c) = fit_pair(ctx, a, b, e_cache)? {
            // By BIC: a pair with a lean law beats one whose
            // extra bearing orders merely absorb the second effect.
            if pair_best
                .as_ref()
                .is_none_or(|b| judge.bic(&c) < judge.bic(b))
            {
                pair_best = Some(c);
            }
        }
    }
    // Pedestals under two bearings: the single pedestal's bearing with
    // each other one, both started on the grid of the single search
    // (every pair of its frequencies, from the nominal fit and from the
    // model's bearings; three iterations each), the two best fitted in
    // full. (The single pedestal's own fit is no start: fitted alone it
    // takes on the other pedestal's resonance.)
    // Tried last, and only when no other pair fits: it costs a hundred
    // screening fits.
    let pair_fits = pair_best.as_ref().is_some_and(|c| !judge.misfit(c));
    for c in hyps.iter().filter(|c| c.significant && !pair_fits) {
        two_pedestals(ctx, c, judge, &mut pair_best);
    }
    Ok(pair_best)
}

/// A pair of hypotheses fitted together, from their own estimates: the
/// richer bearing law of the two, `a`'s extensions then `b`'s; on the
/// terms at the modulus factor when one of them has it (`e_cache` when
/// built at that factor). `None` when the parameters do not match, the
/// equations leave no room or the fit fails.
fn fit_pair(
    ctx: &Context<'_>,
    a: &Candidate,
    b: &Candidate,
    e_cache: &mut Option<(StiffnessForm, f64, Vec<SpeedTerms>)>,
) -> Result<Option<Candidate>, DiagnoseError> {
    let data = ctx.data;
    // The richer bearing law of the two.
    let (pa, pb) = (&a.model.pr, &b.model.pr);
    let pr = if pb.param.structure.order > pa.param.structure.order {
        pb.clone()
    } else {
        pa.clone()
    };
    let mut ext = a.model.ext.clone();
    ext.extend(b.model.ext.iter().copied());
    let m = ExtendedModel {
        pr: pr.clone(),
        ext,
        ..a.model.clone()
    };
    let nom_a = &a.fit.theta[..pa.n_params()];
    let mut theta = map_theta(pa, nom_a, &pr);
    theta.extend_from_slice(&a.fit.theta[pa.n_params()..]);
    theta.extend_from_slice(&b.fit.theta[pb.n_params()..]);
    if theta.len() != m.n_params() || data.n_equations() <= m.n_params() + 4 {
        return Ok(None);
    }
    let uses_e = m.ext.contains(&Extension::EScale);
    let (e, form) = if a.model.ext.contains(&Extension::EScale) {
        (a.e_terms, a.stiffness)
    } else {
        (b.e_terms, b.stiffness)
    };
    let fit = if uses_e {
        let build = |derivative| {
            ctx.form_terms(
                FormChange {
                    form,
                    f: e,
                    derivative,
                },
                Columns::All,
            )
        };
        let te = match e_cache {
            Some((fc, ec, t)) if *fc == form && *ec == e && !t.is_empty() => {
                if terms::planes_only(t, ctx.model.n_nodes()) {
                    // The stiffness rounds' terms lack the node columns a
                    // bow or a plane reads: those terms at the same
                    // factor, with the rounds' derivative, kept in the
                    // cache for the other pairs.
                    let mut full = build(false)?;
                    terms::copy_derivative(&mut full, t)?;
                    *t = full;
                }
                t.clone()
            }
            _ => build(true)?,
        };
        let d = FitData::with_probes(data.samples, data.node_q, &te)
            .with_floors(&data.phi)
            .with_noise_level(data.noise_level);
        // The e parameter of the pair starts at the single fit's offset.
        let k = m
            .ext
            .iter()
            .position(|x| *x == Extension::EScale)
            .unwrap_or(0);
        let o = m.offset(k);
        if o < theta.len() {
            theta[o] = 0.0;
        }
        fit::fit(&m, &d, &theta, 60)
    } else {
        fit::fit(&m, data, &theta, 60)
    };
    let Ok(fit) = fit else { return Ok(None) };
    let mut effects = a.effects.clone();
    effects.extend(b.effects.iter().copied());
    let mut c = Candidate::new(
        effects,
        format!("{} + {}", a.label, b.label),
        m,
        fit,
        if uses_e { e } else { 1.0 },
        1,
    );
    if uses_e {
        c.stiffness = form;
    }
    Ok(Some(c))
}
