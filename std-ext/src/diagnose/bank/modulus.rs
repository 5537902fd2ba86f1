//! `shaft_stiffness_error`: a factor `e` on the shaft's E and G. The terms
//! depend on `e` nonlinearly, so the fit runs in rounds: fitted with the
//! terms linearised in `e` about the current factor (`dA/de`, `dB/de` by a
//! secant), the factor moved by `E_STEP` times its offset, the terms
//! rebuilt exactly there ([`crate::diagnose::terms`]), until the factor
//! stops moving.

use crate::diagnose::candidate::Candidate;
use crate::diagnose::context::Context;
use crate::diagnose::effect::Effect;
use crate::diagnose::extended::{ExtendedModel, Extension, E_STEP};
use crate::diagnose::fit::{self, Fit, FitData};
use crate::diagnose::input::DiagnoseError;
use crate::diagnose::nominal::oe_start;
use crate::diagnose::terms::{self, SpeedTerms};

/// Terms built at several factors: `(e, terms at e)`.
type Built = Vec<(f64, Vec<SpeedTerms>)>;

/// The start of the rounds: `(e, S at e, scaled parameters)`.
type Start = (f64, f64, Vec<f64>);

/// Where the rounds end.
struct End {
    /// The last fit, with the factor its terms were built at.
    last: Option<(Fit, f64)>,
    /// The factor reached.
    e: f64,
    /// The terms built at `e`.
    cur: Vec<SpeedTerms>,
}

/// What the modulus hypothesis leaves behind.
pub(crate) struct ModulusFit {
    /// Its fit, when it has one.
    pub candidate: Option<Candidate>,
    /// The terms at the fitted factor, when the last round's fit was at
    /// the factor they were built for (the pairs reuse them).
    pub e_terms: Option<(f64, Vec<SpeedTerms>)>,
    /// The nominal terms with `dA/de`, `dB/de` at `e = 1` (central secant
    /// through `e = 0.95` and `1.05`), for the modulus' observability.
    pub terms_de: Option<Vec<SpeedTerms>>,
}

/// The fit of the factor on the shaft's modulus: the best start of
/// `e = 1` and `e = 1 -+ 5 %` (`starts`), then up to six rounds
/// (`rounds`).
pub(crate) fn shaft_stiffness_error(ctx: &Context<'_>) -> Result<ModulusFit, DiagnoseError> {
    let mut out = ModulusFit {
        candidate: None,
        e_terms: None,
        terms_de: None,
    };
    let m = ctx.with_ext(vec![Extension::EScale]);
    if !ctx.n_room(m.n_params()) {
        return Ok(out);
    }
    let (best, built) = starts(ctx, &m)?;
    out.terms_de = derivative_at_one(ctx, &built)?;
    let (e, _, theta) = best;
    let End { last, e, cur } = rounds(ctx, &m, built, e, theta)?;
    if let Some((_, e_fit)) = &last {
        if *e_fit == e {
            out.e_terms = Some((e, cur));
        }
    }
    if let Some((f, e)) = last {
        out.candidate = Some(Candidate::new(
            vec![Effect::ShaftStiffnessError],
            "factor on the shaft's E and G".into(),
            m,
            f,
            e,
            1,
        ));
    }
    Ok(out)
}

/// The best start of `m` of `e = 1` (the nominal estimate) and
/// `e = 0.95`, `1.05` (the nominal parameters estimated again on the
/// terms there), by the misfit `S` of the nominal model; with the terms
/// built at the three factors, `e = 1` first.
fn starts(ctx: &Context<'_>, m: &ExtendedModel) -> Result<(Start, Built), DiagnoseError> {
    let setup = ctx.setup;
    let base = ctx.base;
    // Start: the best of e = 1 and e = 1 -+ 5 % with the nominal
    // parameters refitted at each (the nominal estimate adapts the
    // bearings to the wrong shaft: a local minimum in between).
    let mut built: Built = vec![(1.0, ctx.terms.to_vec())];
    let mut best = (1.0, ctx.nominal.fit.s, ctx.start_with(m, &[0.0]));
    for e_try in [0.95, 1.05] {
        let te = ctx.builder.build(ctx.omegas, e_try, false)?;
        if let Ok((_, mut th, _)) = oe_start(
            ctx.model,
            ctx.samples,
            &te,
            setup.structure,
            setup.scaling,
            setup.held_noise(),
        ) {
            let d = FitData::with_probes(ctx.samples, ctx.node_q, &te).with_floors(&setup.phi);
            let en = fit::entries(base, &d);
            if let Ok((r, _)) = fit::evaluate(base, &d, &en, &th, false) {
                let s_try = r.norm_squared();
                if s_try < best.1 {
                    th.push(0.0);
                    best = (e_try, s_try, th);
                }
            }
        }
        built.push((e_try, te));
    }
    Ok((best, built))
}

/// The model's own terms with `dA/de`, `dB/de` (and the node probes'
/// derivatives) at `e = 1` from the central secant through the terms at
/// `e = 0.95` and `1.05` of `built`.
fn derivative_at_one(
    ctx: &Context<'_>,
    built: &Built,
) -> Result<Option<Vec<SpeedTerms>>, DiagnoseError> {
    let mut terms_de = None;
    if let [_, (em, minus), (ep, plus)] = &built[..] {
        let mut central = plus.clone();
        terms::set_secant_derivative(&mut central, *ep, minus, *em)?;
        let mut t1 = ctx.terms.to_vec();
        for (t, c) in t1.iter_mut().zip(central) {
            t.da_de = c.da_de;
            t.db_de = c.db_de;
            if let (Some(tp), Some(cp)) = (t.probes.as_mut(), c.probes) {
                tp.dp_de = cp.dp_de;
                tp.du_de = cp.du_de;
            }
        }
        terms_de = Some(t1);
    }
    Ok(terms_de)
}

/// Up to six rounds from the factor `e` and the parameters `theta`, the
/// terms at `e` and at the factor nearest it taken from `built`.
fn rounds(
    ctx: &Context<'_>,
    m: &ExtendedModel,
    mut built: Built,
    mut e: f64,
    mut theta: Vec<f64>,
) -> Result<End, DiagnoseError> {
    let setup = ctx.setup;
    // Rounds: fit with the terms linearised in e about the current
    // factor, move the factor, rebuild the terms there. dA/de and
    // dB/de are the secant through the previous factor's terms (one
    // reduction per round instead of two): at convergence the
    // offset is zero and the residual is that of the exact terms.
    let pick = |k: usize, built: &mut Built| built.swap_remove(k);
    let k_cur = built.iter().position(|(x, _)| *x == e).unwrap_or(0);
    let (_, mut cur) = pick(k_cur, &mut built);
    let k_prev = (0..built.len())
        .min_by(|&a, &b| (built[a].0 - e).abs().total_cmp(&(built[b].0 - e).abs()))
        .unwrap_or(0);
    let (mut e_prev, mut prev) = pick(k_prev, &mut built);
    drop(built);
    let mut last: Option<(Fit, f64)> = None;
    for _round in 0..6 {
        if cur.first().is_none_or(|t| t.da_de.is_none()) {
            terms::set_secant_derivative(&mut cur, e, &prev, e_prev)?;
        }
        let d = FitData::with_probes(ctx.samples, ctx.node_q, &cur)
            .with_floors(&setup.phi)
            .with_noise_level(setup.noise_level);
        let Ok(f) = fit::fit(m, &d, &theta, 50) else {
            break;
        };
        let x = f.theta[m.offset(0)];
        let e_new = e + E_STEP * x;
        let done = (e_new - e).abs() < 1e-7 * e || e_new.is_nan() || e_new <= 0.0;
        theta = f.theta.clone();
        last = Some((f, e));
        if done {
            break;
        }
        theta[m.offset(0)] = 0.0;
        let mut next = ctx.builder.build(ctx.omegas, e_new, false)?;
        if (e_new - e).abs() < 1e-5 * e {
            // Too close for a secant without cancellation: the
            // derivative of the current factor is as good.
            for (n, c) in next.iter_mut().zip(&cur) {
                n.da_de.clone_from(&c.da_de);
                n.db_de.clone_from(&c.db_de);
                if let (Some(np), Some(cp)) = (n.probes.as_mut(), c.probes.as_ref()) {
                    np.dp_de.clone_from(&cp.dp_de);
                    np.du_de.clone_from(&cp.du_de);
                }
            }
        }
        (e_prev, prev) = (e, std::mem::replace(&mut cur, next));
        e = e_new;
    }
    Ok(End { last, e, cur })
}
