//! `shaft_stiffness_error`: a factor on the shaft's stiffness in one of its
//! forms ([`StiffnessForm`]): E and G together, E alone, or the outer
//! diameter of a section of the shaft (stiffness and mass). The terms
//! depend on the factor nonlinearly, so each form's fit runs in rounds:
//! fitted with the terms linearised in the factor about its current value
//! (`dA/df`, `dB/df` by a secant), the factor moved by `E_STEP` times its
//! offset, the terms rebuilt exactly there ([`crate::diagnose::terms`]),
//! until the factor stops moving or moves by less than 1 % of its standard
//! deviation (the rounds after the first with fewer iterations,
//! [`LATER_ITERATIONS`]). E and G's rounds start from the least
//! point of a profile of the nominal model's misfit over the factor (the
//! linearisation reaches a few per cent only where the reduced terms have
//! a pole in the range). The forms have one parameter each, so
//! the one of least misfit is the candidate, named in its label.
//!
//! The sections tried are the runs of one to three consecutive pieces of
//! the shaft between its features (ends, bearings, disks, planes, steps of
//! diameter or material), as a drawing divides it; they are ranked by the
//! misfit of the nominal model estimated afresh on each section's terms at
//! two diameter changes, the one that changes the shaft's bending
//! flexibility as the global factor does ([`section_step`]) and twice it,
//! the better of the two counting, and the best two are fitted.

use crate::diagnose::candidate::{Candidate, FormFit};
use crate::diagnose::context::{Context, Thinned};
use crate::diagnose::effect::Effect;
use crate::diagnose::extended::{ExtendedModel, Extension, E_STEP};
use crate::diagnose::fit::{self, Fit, FitData};
use crate::diagnose::input::DiagnoseError;
use crate::diagnose::nominal::oe_start;
use crate::diagnose::parallel;
use crate::diagnose::terms::{self, Columns, FormChange, SpeedTerms, StiffnessForm};
use crate::model::RotorModel;

/// Terms built at several factors: `(f, terms at f)`.
type Built = Vec<(f64, Vec<SpeedTerms>)>;

/// The start of the rounds: `(f, S at f, scaled parameters)`.
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
    /// The terms at the fitted factor of the candidate's form, when the
    /// last round's fit was at the factor they were built for (the pairs
    /// reuse them).
    pub e_terms: Option<(StiffnessForm, f64, Vec<SpeedTerms>)>,
    /// The nominal terms with `dA/de`, `dB/de` at `e = 1` (central secant
    /// through `e = 0.95` and `1.05`) of E and G, for the modulus'
    /// observability.
    pub terms_de: Option<Vec<SpeedTerms>>,
}

/// The terms of the context's model in `form` at the factor `f`, without
/// the node columns ([`Columns::Planes`]): the rounds, the profile
/// and the sections' ranking read `A`, `B` and the probes' `P`, `u` only.
fn build(ctx: &Context<'_>, form: StiffnessForm, f: f64) -> Result<Vec<SpeedTerms>, DiagnoseError> {
    let change = FormChange {
        form,
        f,
        derivative: false,
    };
    Ok(ctx.form_terms(change, Columns::Planes)?)
}

/// The fit of the factor on the shaft's stiffness: for E and G, the best
/// point of the misfit's profile over `f` (`starts`), then up to six rounds
/// (`rounds`); for E alone, rounds from where E and G ended; for the
/// sections, the two that `rank_sections`
/// puts first, from their screening start. The form of least misfit is the
/// candidate; its alternatives are the two global forms and the sections.
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
    let mut ends: Vec<(StiffnessForm, End)> = Vec::new();
    let (best, built) = starts(ctx, &m, StiffnessForm::EAndG)?;
    out.terms_de = derivative_at_one(ctx, &built)?;
    let (e, _, theta) = best;
    ends.push((
        StiffnessForm::EAndG,
        rounds(ctx, &m, StiffnessForm::EAndG, built, e, theta)?,
    ));
    // E alone from where E and G ended (the two differ by the shear
    // deformation only): its terms at that factor, the parameters with the
    // factor's offset folded in.
    if let Some((f, e_fit)) = ends[0].1.last.as_ref() {
        let o = m.offset(0);
        let e = e_fit + E_STEP * f.theta[o];
        if e.is_finite() && e > 0.0 {
            let mut theta = f.theta.clone();
            theta[o] = 0.0;
            let built = vec![
                (e, build(ctx, StiffnessForm::EAlone, e)?),
                (1.0, ctx.terms.to_vec()),
            ];
            ends.push((
                StiffnessForm::EAlone,
                rounds(ctx, &m, StiffnessForm::EAlone, built, e, theta)?,
            ));
        }
    }
    let sections = sections(ctx.model);
    // A section's diameter moves the critical speeds the way the whole
    // shaft's modulus does (its stiffness, `d^4`, outweighs its mass,
    // `d^2`): the sections are screened on the side of the better global
    // factor.
    let global = ends
        .iter()
        .filter_map(|(_, end)| end.last.as_ref())
        .min_by(|a, b| a.0.s.total_cmp(&b.0.s))
        .map_or(1.0, |(f, e)| e + E_STEP * f.theta[m.offset(0)]);
    let ranked = rank_sections(ctx, &sections, global)?;
    let fitted = parallel::map(&ranked, ctx.threads(), |(form, f, theta, at)| {
        let built = vec![(*f, at.clone()), (1.0, ctx.terms.to_vec())];
        rounds(ctx, &m, *form, built, *f, theta.clone()).map(|end| (*form, end))
    });
    for end in fitted {
        ends.push(end?);
    }
    let alternatives = 2 + sections.len();
    let o = m.offset(0);
    let forms: Vec<FormFit> = ends
        .iter()
        .filter_map(|(form, end)| {
            end.last.as_ref().map(|(f, e_fit)| FormFit {
                form: *form,
                factor: e_fit + E_STEP * f.theta[o],
                factor_std: E_STEP * f.std(o).unwrap_or(f64::NAN),
                s: f.s,
            })
        })
        .collect();
    let best = ends
        .into_iter()
        .filter(|(_, end)| end.last.is_some())
        .min_by(|a, b| {
            let s = |x: &End| x.last.as_ref().map_or(f64::INFINITY, |l| l.0.s);
            s(&a.1).total_cmp(&s(&b.1))
        });
    let Some((form, End { last, e, cur })) = best else {
        return Ok(out);
    };
    if let Some((f, e_fit)) = last {
        if e_fit == e {
            out.e_terms = Some((form, e, cur));
        }
        let mut c = Candidate::new(
            vec![Effect::ShaftStiffnessError],
            format!("factor on {}", form.describe()),
            m,
            f,
            e_fit,
            alternatives,
        );
        c.stiffness = form;
        c.stiffness_forms = forms;
        out.candidate = Some(c);
    }
    Ok(out)
}

/// The most iterations of a section's screening fit ([`Screen::score`]):
/// from the nominal estimate it ends in 4 to 6 where the nominal model
/// fits, and creeps to the limit where it misfits (the ranking needs the
/// shape of the misfit, not its last digit).
const SCREEN_ITERATIONS: usize = 20;

/// How many sections, the best of the screening, are fitted.
const SECTIONS_FITTED: usize = 2;

/// The two factors on a section's diameter its screening tries:
/// [`section_step`]'s and the change twice as large (half as large when
/// that one is at the greatest change of [`SECTION_STEPS`]). The
/// flexibility under a uniform moment weighs a section near a bearing as
/// much as one at mid-span, where the bending moment of the modes is
/// larger: the second point covers the part of the shaft the weighting
/// misjudges.
fn section_steps(model: &RotorModel, form: StiffnessForm, global: f64) -> [f64; 2] {
    let f = section_step(model, form, global);
    let eps = f - 1.0;
    let other = if eps.abs() >= SECTION_STEPS[1] {
        0.5 * eps
    } else {
        (2.0 * eps).clamp(-SECTION_STEPS[1], SECTION_STEPS[1])
    };
    [f, 1.0 + other]
}

/// The least and greatest change of a section's diameter its screening
/// fit is made at ([`section_step`]; a diameter a few per cent off changes
/// the section's stiffness by four times as much).
const SECTION_STEPS: [f64; 2] = [0.005, 0.08];

/// The sections of the shaft a diameter error is sought in: the runs of one
/// to three consecutive pieces between the shaft's features (its ends, the
/// bearings, disks and planes, and every change of diameter or material
/// between neighbouring elements).
pub(crate) fn sections(model: &RotorModel) -> Vec<StiffnessForm> {
    let n = model.shaft.len();
    let mut at: Vec<usize> = vec![0, n];
    at.extend(model.bearing_nodes());
    at.extend(model.disks.iter().map(|d| d.node));
    at.extend(model.planes.iter().copied());
    for (i, w) in model.shaft.windows(2).enumerate() {
        if w[0].outer_diameter != w[1].outer_diameter
            || w[0].inner_diameter != w[1].inner_diameter
            || w[0].material != w[1].material
        {
            at.push(i + 1);
        }
    }
    at.retain(|&k| k <= n);
    at.sort_unstable();
    at.dedup();
    let mut out = Vec::new();
    for run in 1..=3 {
        for w in at.windows(run + 1) {
            out.push(StiffnessForm::Section {
                first: w[0],
                last: w[run] - 1,
            });
        }
    }
    out
}

/// A section's start: its form, the factor, the nominal parameters fitted
/// on the terms there (with the factor's offset zero), and those terms.
type SectionStart = (StiffnessForm, f64, Vec<f64>, Vec<SpeedTerms>);

/// The two sections of least misfit of the nominal model estimated
/// afresh on the terms of the section's diameter at the better of
/// [`section_steps`]' two factors for the global factor `global` (the
/// bearings of the nominal estimate have absorbed part of the effect, so a
/// step from it in the factor alone says little; [`Screen::score`]), on
/// every [`SCREEN_EVERY`](crate::diagnose::context::SCREEN_EVERY)-th speed; each
/// with that start and its terms at every speed. Sections whose terms
/// cannot be built (a diameter at or below the bore) are left out.
fn rank_sections(
    ctx: &Context<'_>,
    sections: &[StiffnessForm],
    global: f64,
) -> Result<Vec<SectionStart>, DiagnoseError> {
    let screen = Screen::new(ctx);
    // Side by side on the context's threads, in the sections' order.
    // Each section at two diameter changes (`section_steps`), the better
    // kept: two points of its misfit's profile.
    let tries: Vec<(StiffnessForm, f64)> = sections
        .iter()
        .flat_map(|&form| section_steps(ctx.model, form, global).map(|f| (form, f)))
        .collect();
    let screened = parallel::map(&tries, ctx.threads(), |&(form, step)| {
        screen
            .score(form, step)
            .map(|(s, theta)| (s, form, step, theta))
    });
    // Each section's better point, the sections in order of it.
    let mut scored: Vec<(f64, StiffnessForm, f64, Vec<f64>)> = Vec::new();
    for x in screened.into_iter().flatten() {
        match scored.iter_mut().find(|b| b.1 == x.1) {
            Some(b) if x.0 < b.0 => *b = x,
            Some(_) => {}
            None => scored.push(x),
        }
    }
    scored.sort_by(|a, b| a.0.total_cmp(&b.0));
    // The best ones' terms at every speed, for their rounds.
    let mut out = Vec::new();
    for (_, form, step, theta) in scored.into_iter().take(SECTIONS_FITTED) {
        let at = build(ctx, form, step)?;
        out.push((form, step, theta, at));
    }
    Ok(out)
}

/// The screening of a section's diameter on every [`SCREEN_EVERY`](crate::diagnose::context::SCREEN_EVERY)-th
/// speed: the ranking needs the shape of the misfit, not its last digit.
struct Screen<'c, 'a> {
    ctx: &'c Context<'a>,
    thin: Thinned,
}

impl<'c, 'a> Screen<'c, 'a> {
    fn new(ctx: &'c Context<'a>) -> Self {
        Screen {
            ctx,
            thin: ctx.thinned(),
        }
    }

    /// `S` of the nominal model estimated afresh on the terms of `form`
    /// at the factor `f`: fitted from the nominal estimate by the bank's
    /// own fit ([`fit::fit_with`], at most [`SCREEN_ITERATIONS`]
    /// iterations), which minimises the `S` the sections are ranked by. A
    /// diameter a few per cent off moves the bearings' minimum a little
    /// from the nominal estimate, so the fit from there is short: on the
    /// three-bearing rotor's runout case, 437 iterations over the 24
    /// screenings against 1 121 for the filter's starts and output-error
    /// fits they replace. With those parameters and the factor's offset
    /// (zero); `None` where the terms cannot be built (a diameter at or
    /// below the bore) or the fit fails.
    fn score(&self, form: StiffnessForm, f: f64) -> Option<(f64, Vec<f64>)> {
        let (ctx, setup) = (self.ctx, self.ctx.setup);
        let change = FormChange {
            form,
            f,
            derivative: false,
        };
        let at = terms::build_form_columns(
            ctx.builder,
            ctx.model,
            &self.thin.omegas,
            change,
            ctx.probe_nodes,
            Columns::Planes,
        )
        .ok()?;
        let d = FitData::with_probes(&self.thin.samples, &self.thin.node_q, &at)
            .with_floors(&setup.phi)
            .with_noise_level(setup.noise_level)
            .with_explained(ctx.data.explained);
        let fitted = fit::fit_with(ctx.base, &d, &ctx.theta0, SCREEN_ITERATIONS, false).ok()?;
        let (s, mut theta) = (fitted.s, fitted.theta);
        theta.push(0.0);
        Some((s, theta))
    }
}

/// The factor on the outer diameter of `form`'s section that changes the
/// shaft's bending flexibility as the global factor `global` on E does:
/// with the flexibility taken as `sum L / (E I)` over the elements (a
/// uniform bending moment), `I = pi (d_o^4 - d_i^4) / 64`, a factor
/// `1 + eps` on `d_o` changes an element's `1 / I` by
/// `-4 eps d_o^4 / (d_o^4 - d_i^4)`, so
/// `eps = (global - 1) sum_all L / (E I) / sum_section 4 L d_o^4 / (E I (d_o^4 - d_i^4))`,
/// its size held within [`SECTION_STEPS`] (`0.5 %` to `8 %`, on the side
/// of `global`). A section ranked at the diameter change its own share of
/// the flexibility asks for is compared by its shape, not by how near a
/// fixed step happens to be.
fn section_step(model: &RotorModel, form: StiffnessForm, global: f64) -> f64 {
    let StiffnessForm::Section { first, last } = form else {
        return 1.0;
    };
    let (all, sec) = (
        flexibility(model, 0, usize::MAX).0,
        flexibility(model, first, last).1,
    );
    let eps = if sec > 0.0 && all.is_finite() {
        (global - 1.0) * all / sec
    } else {
        0.0
    };
    let [lo, hi] = SECTION_STEPS;
    let size = eps.abs().clamp(lo, hi);
    if eps < 0.0 || (eps == 0.0 && global < 1.0) {
        1.0 - size
    } else {
        1.0 + size
    }
}

/// The bending flexibility `sum L / (E I)` (1/(N m)) of the shaft elements
/// `first..=last` (those that exist), and its change per unit relative
/// change of their outer diameter, `sum 4 L d_o^4 / (E I (d_o^4 - d_i^4))`
/// (its sign dropped; [`section_step`]).
fn flexibility(model: &RotorModel, first: usize, last: usize) -> (f64, f64) {
    let n = model.shaft.len();
    let run = if first < n {
        &model.shaft[first..=last.min(n - 1)]
    } else {
        &[]
    };
    run.iter().fold((0.0, 0.0), |(a, b), el| {
        let (o4, i4) = (el.outer_diameter.powi(4), el.inner_diameter.powi(4));
        let i = std::f64::consts::PI * (o4 - i4) / 64.0;
        let f = el.length / (el.material.e * i);
        (a + f, b + f * 4.0 * o4 / (o4 - i4))
    })
}

/// The best start of `m` in `form`: the profile of the nominal model's
/// misfit `S(e)` over the factor (the nominal parameters estimated afresh
/// on the terms at each `e`), at `e = 1` (the nominal estimate) and
/// `e = 0.95`, `1.05`, then up to [`PROFILE_STEPS`] more factors placed by
/// [`next_profile_point`]; with the terms built at each factor, `e = 1`
/// first and `0.95`, `1.05` next.
///
/// The rounds alone linearise the terms in `e`; on a rotor whose bearing
/// nodes pinned have a mode in the speed range (three bearings), the
/// reduced terms have a pole there and the linearisation only reaches a
/// few per cent, so the rounds stop at the first factor they are given.
/// The profile needs no derivative and brings them to the minimum's
/// neighbourhood.
fn starts(
    ctx: &Context<'_>,
    m: &ExtendedModel,
    form: StiffnessForm,
) -> Result<(Start, Built), DiagnoseError> {
    let setup = ctx.setup;
    let base = ctx.base;
    let mut built: Built = vec![(1.0, ctx.terms.to_vec())];
    let mut best = (1.0, ctx.nominal.fit.s, ctx.start_with(m, &[0.0]));
    let mut profile: Vec<(f64, f64)> = vec![(1.0, ctx.nominal.fit.s)];
    let mut evaluations = 0;
    let mut next = Some(0.95);
    while let Some(e_try) = next {
        evaluations += 1;
        if let Ok(te) = build(ctx, form, e_try) {
            let mut s_try = f64::INFINITY;
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
                    s_try = r.norm_squared();
                    if s_try < best.1 {
                        th.push(0.0);
                        best = (e_try, s_try, th);
                    }
                }
            }
            profile.push((e_try, s_try));
            built.push((e_try, te));
        } else {
            profile.push((e_try, f64::INFINITY));
        }
        next = match evaluations {
            1 => Some(1.05),
            k if k < 2 + PROFILE_STEPS => next_profile_point(&profile),
            _ => None,
        };
    }
    Ok((best, built))
}

/// The most factors the profile of [`starts`] evaluates beyond its three
/// starts.
const PROFILE_STEPS: usize = 4;

/// The profile stops once its next factor would be within this of one it
/// has (the rounds take it from there).
const PROFILE_TOL: f64 = 3e-3;

/// The factors the profile keeps within (a shaft's modulus or a section's
/// diameter this far off is a wrong model, not an error to be found).
const PROFILE_RANGE: (f64, f64) = (0.6, 1.6);

/// The next factor of a profile `(e, S(e))`: past the end where the least
/// `S` is at an end (a step as wide as the last), else the vertex of the
/// parabola through the least and its two neighbours, kept inside them;
/// `None` when that is within [`PROFILE_TOL`] of a factor evaluated or
/// outside [`PROFILE_RANGE`].
fn next_profile_point(profile: &[(f64, f64)]) -> Option<f64> {
    let mut p: Vec<(f64, f64)> = profile
        .iter()
        .copied()
        .filter(|x| x.1.is_finite())
        .collect();
    p.sort_by(|a, b| a.0.total_cmp(&b.0));
    if p.len() < 2 {
        return None;
    }
    let i = (0..p.len()).min_by(|&a, &b| p[a].1.total_cmp(&p[b].1))?;
    let e = if i == 0 {
        p[0].0 - (p[1].0 - p[0].0)
    } else if i == p.len() - 1 {
        p[i].0 + (p[i].0 - p[i - 1].0)
    } else {
        let (a, b, c) = (p[i - 1], p[i], p[i + 1]);
        let (da, dc) = (b.0 - a.0, b.0 - c.0);
        let (fa, fc) = (b.1 - a.1, b.1 - c.1);
        let den = da * fc - dc * fa;
        let v = if den != 0.0 {
            b.0 - 0.5 * (da * da * fc - dc * dc * fa) / den
        } else {
            b.0
        };
        // Inside the bracket, not on its ends.
        let margin = 0.1 * (c.0 - a.0);
        v.clamp(a.0 + margin, c.0 - margin)
    };
    let near = profile.iter().any(|x| (x.0 - e).abs() < PROFILE_TOL);
    (e.is_finite() && !near && e > PROFILE_RANGE.0 && e < PROFILE_RANGE.1).then_some(e)
}

/// The model's own terms with `dA/de`, `dB/de` (and the node probes'
/// derivatives) at `e = 1` from the central secant through the terms at
/// `e = 0.95` and `1.05` of `built`.
fn derivative_at_one(
    ctx: &Context<'_>,
    built: &Built,
) -> Result<Option<Vec<SpeedTerms>>, DiagnoseError> {
    let mut terms_de = None;
    let at = |f: f64| built.iter().find(|(x, _)| *x == f);
    if let (Some((em, minus)), Some((ep, plus))) = (at(0.95), at(1.05)) {
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

/// The farthest neighbour (relative to the factor) whose terms give a
/// round of [`rounds`] its secant.
const SECANT_FAR: f64 = 1e-4;

/// Where [`rounds`] builds the terms of a round's secant when the
/// neighbour it has is beyond [`SECANT_FAR`] (relative, on the side of
/// that neighbour): a pole of the reduced terms moves by about half this
/// in speed, so that one crossing a measured speed between the two is
/// rare.
const SECANT_NEAR: f64 = 1e-5;

/// The rounds end once the factor's move is below this fraction of its
/// standard deviation.
const ROUND_END: f64 = 0.01;

/// The iterations of a round's fit after the first: the first brings the
/// parameters to the minimum at the start's terms, and the later ones,
/// from there, converge in a few where the form fits the data (under ten on
/// the three rotors' stiffness cases). Where it does not (a runout, a
/// pedestal), each round's fit creeps to its limit; the factor's next
/// move is as uncertain after 20 iterations as after 50.
const LATER_ITERATIONS: usize = 20;

/// Up to six rounds of `form` from the factor `e` and the parameters
/// `theta`, the terms at `e` and at the factor nearest it taken from
/// `built`.
fn rounds(
    ctx: &Context<'_>,
    m: &ExtendedModel,
    form: StiffnessForm,
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
    for round in 0..6 {
        if cur.first().is_none_or(|t| t.da_de.is_none()) {
            // A neighbour farther than `SECANT_FAR` gives a secant, not a
            // derivative: where the reduced terms have a pole in the speed
            // range (the shaft pinned at three bearings has a mode there),
            // a speed the pole crosses between the two factors makes its
            // column wrong by orders of magnitude; the factor then creeps
            // by a fraction of its standard deviation a round, and that
            // deviation is as many times too small. The derivative comes
            // from terms built `SECANT_NEAR` away instead.
            if (e_prev - e).abs() > SECANT_FAR * e {
                let near = e * (1.0 - SECANT_NEAR * (e - e_prev).signum());
                if let Ok(t) = build(ctx, form, near) {
                    (e_prev, prev) = (near, t);
                }
            }
            terms::set_secant_derivative(&mut cur, e, &prev, e_prev)?;
        }
        let d = FitData::with_probes(ctx.samples, ctx.node_q, &cur)
            .with_floors(&setup.phi)
            .with_noise_level(setup.noise_level)
            .with_explained(ctx.data.explained);
        let iterations = if round == 0 { 50 } else { LATER_ITERATIONS };
        let Ok(f) = fit::fit(m, &d, &theta, iterations) else {
            break;
        };
        let x = f.theta[m.offset(0)];
        let e_new = e + E_STEP * x;
        // Done when the factor stands still, or when its move is a small
        // fraction of its standard deviation: a round more moves the
        // misfit by the square of that fraction (noise variances), nothing
        // a test could see.
        let insignificant = f
            .std(m.offset(0))
            .is_some_and(|sd| (e_new - e).abs() < ROUND_END * E_STEP * sd);
        // A fit stopped behind one at the noise: this form is not the
        // answer, and a round more would move it by a fraction of
        // its misfit (module docs of `fit`, "Behind a fit at the noise").
        let behind = f.stalled && d.explained;
        let done = (e_new - e).abs() < 1e-7 * e
            || insignificant
            || behind
            || e_new.is_nan()
            || e_new <= 0.0;
        theta = f.theta.clone();
        last = Some((f, e));
        if done {
            break;
        }
        theta[m.offset(0)] = 0.0;
        // A factor the form cannot take (a section's outer diameter at or
        // below its inner one on a hollow shaft): the rounds end at the
        // last fit.
        let Ok(mut next) = build(ctx, form, e_new) else {
            break;
        };
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The profile's next factor on `S(e) = (e - 1.07)^2 + 0.2`, from
    /// the three starts: past the end where the least is at an end, then
    /// the parabola's vertex (exact on a parabola), then nothing once the
    /// vertex has been evaluated; a vertex outside the range is not
    /// proposed, nor one by a factor already evaluated.
    #[test]
    fn the_profile_walks_to_the_vertex() {
        let s = |e: f64| (e - 1.07) * (e - 1.07) + 0.2;
        let mut p: Vec<(f64, f64)> = [1.0, 0.95, 1.05].iter().map(|&e| (e, s(e))).collect();
        let e = next_profile_point(&p).unwrap();
        assert!((e - 1.10).abs() < 1e-12, "{e}");
        p.push((e, s(e)));
        let e = next_profile_point(&p).unwrap();
        assert!((e - 1.07).abs() < 1e-9, "{e}");
        p.push((e, s(e)));
        assert_eq!(next_profile_point(&p), None);
        // A least at the end of the range is not stepped past.
        let q: Vec<(f64, f64)> = [1.5, 1.55, 1.58].iter().map(|&e: &f64| (e, -e)).collect();
        assert_eq!(next_profile_point(&q), None);
        // A vertex near an evaluated factor (within PROFILE_TOL) stops it.
        let r: Vec<(f64, f64)> = [0.95, 1.0, 1.05]
            .iter()
            .map(|&e: &f64| (e, (e - 1.001).powi(2)))
            .collect();
        assert_eq!(next_profile_point(&r), None);
        // Non-finite misfits (terms that could not be built) are left out.
        let t = vec![(1.0, 1.0), (0.95, f64::INFINITY), (1.05, 0.5)];
        assert!((next_profile_point(&t).unwrap() - 1.10).abs() < 1e-12);
    }

    /// On a shaft of one solid section, a section's diameter change that
    /// matches a global factor `g` is `(g - 1) L / (4 L_section)` (the
    /// closed form of [`section_step`]'s sum), `4 d_o^4 / (d_o^4 - d_i^4)`
    /// times smaller on a hollow one; held within 0.5 % and 8 %, on the
    /// side of `g`; the second point twice as far, or half when held at
    /// 8 %.
    #[test]
    fn a_sections_step_matches_the_global_factor() {
        let m = RotorModel::paper();
        let total: f64 = m.shaft.iter().map(|e| e.length).sum();
        let len = |a: usize, b: usize| -> f64 { m.shaft[a..=b].iter().map(|e| e.length).sum() };
        let sec = |first, last| StiffnessForm::Section { first, last };
        let want = 0.026 * total / (4.0 * len(10, 19));
        let [a, b] = section_steps(&m, sec(10, 19), 1.026);
        assert!((a - 1.0 - want).abs() < 1e-12 * want, "{a} {want}");
        assert!((b - 1.0 - 2.0 * want).abs() < 1e-12 * want, "{b}");
        let want = -0.01 * total / (4.0 * len(0, 3));
        let [a, b] = section_steps(&m, sec(0, 3), 0.99);
        assert!((a - 1.0 - want).abs() < 1e-12, "{a} {want}");
        assert!((b - 1.0 - 2.0 * want).abs() < 1e-12, "{b}");
        let near = |got: [f64; 2], want: [f64; 2]| {
            assert!(
                (got[0] - want[0]).abs() < 1e-12 && (got[1] - want[1]).abs() < 1e-12,
                "{got:?} against {want:?}"
            );
        };
        near(section_steps(&m, sec(0, 3), 1.2), [1.08, 1.04]);
        near(section_steps(&m, sec(0, 25), 1.0001), [1.005, 1.01]);
        near(section_steps(&m, sec(0, 25), 0.9999), [0.995, 0.99]);
        // A bore of half the outer diameter.
        let mut hollow = m.clone();
        for el in &mut hollow.shaft {
            el.inner_diameter = 0.5 * el.outer_diameter;
        }
        let k = 4.0 * 16.0 / 15.0;
        let want = 0.026 * total / (k * len(10, 19));
        let a = section_step(&hollow, sec(10, 19), 1.026);
        assert!((a - 1.0 - want).abs() < 1e-12 * want, "{a} {want}");
        // The global forms have no diameter.
        assert_eq!(section_step(&m, StiffnessForm::EAlone, 1.05), 1.0);
    }

    /// The paper rotor's features (shaft ends, bearings at its ends, disks
    /// and planes at nodes 4, 10 and 20, one diameter) cut it into four
    /// pieces; the sections are the runs of one to three of them.
    #[test]
    fn sections_run_between_the_shafts_features() {
        let m = RotorModel::paper();
        let got: Vec<(usize, usize)> = sections(&m)
            .into_iter()
            .map(|s| match s {
                StiffnessForm::Section { first, last } => (first, last),
                other => panic!("{other:?}"),
            })
            .collect();
        let want = vec![
            (0, 3),
            (4, 9),
            (10, 19),
            (20, 25),
            (0, 9),
            (4, 19),
            (10, 25),
            (0, 19),
            (4, 25),
        ];
        assert_eq!(got, want);
        // A step of diameter is a feature.
        let mut stepped = m.clone();
        for el in &mut stepped.shaft[13..] {
            el.outer_diameter *= 1.2;
        }
        assert!(sections(&stepped).contains(&StiffnessForm::Section {
            first: 10,
            last: 12
        }));
    }
}
