//! Diagnosis: what the nominal model gets wrong, which physical effect
//! explains it, and how much better the extended model fits.
//!
//! # Procedure
//!
//! 1. **Nominal fit**: the output-error estimate of the bearing laws
//!    (`physical`, the given order) and plane unbalances, polished on the
//!    diagnosis objective of [`fit`] (weights fixed by the data, the same
//!    for every model, so misfits compare).
//! 2. **Bank of hypotheses** ([`Effect`]), each a model extension
//!    ([`extended`]) fitted by the same Levenberg-Marquardt from the
//!    nominal estimate:
//!    * `speed_dependent_bearing`: `K(Omega)`, `C(Omega)` polynomials one
//!      and two orders higher (the paper's own `Z_0 + Omega Z_1 + Omega^2
//!      Z_2` family: it contains Eq. 49's `K ~ Omega^2`, and a smooth law
//!      over a speed range is a low-order polynomial in it);
//!    * `foundation_flexibility`: a pedestal (mass, two springs, two
//!      dampers) under each bearing in turn, started from a grid of
//!      natural frequencies across the speed range;
//!    * `shaft_bow`: a bow offset at each interior node, screened by one
//!      Gauss-Newton step from the nominal estimate, the best two fitted;
//!    * `probe_runout`: a constant phasor on every channel;
//!    * `extra_unbalance_plane`: unbalance at each node that is not a
//!      plane, screened like the bow;
//!    * `shaft_stiffness_error`: a factor `e` on the shaft's E and G, with
//!      the terms rebuilt at each new `e` (exact scaling, [`terms`]).
//! 3. **Honest choice**: a hypothesis is significant when its drop in misfit,
//!    in units of the noise variance `sigma^2` (from the best-fitting
//!    model), exceeds the chi-square quantile of its extra parameters at
//!    the false-alarm rate [`DiagnoseOptions::false_alarm`] divided by the
//!    number of alternatives tried (Bonferroni, so a search over nodes
//!    does not raise the false-alarm rate). Among the nominal model and the
//!    significant hypotheses the one of least `BIC = S / sigma^2 + P ln(2N)`
//!    is chosen. When the chosen model's residual noise is still above the
//!    model-free noise level ([`crate::estimate::noise`]) by more than a
//!    chi-square per degree of freedom of [`MISFIT_CHI2`], the strongest
//!    effect is paired with each other significant one, and if none fits, the
//!    answer is `unexplained`.
//! 4. **Observability** ([`observe`]): from the Fisher information, the
//!    smallest size of each effect these sensors and speeds can detect,
//!    and which effects the data cannot tell apart.
//!
//! The residual reported for every model is the relative RMS misfit of
//! [`fit`]: `sqrt(S / N)` with `S = sum |y_meas - y|^2 / max(|y_meas|,
//! f_c)^2` over the `N` complex readings.
//!
//! # Layout
//!
//! [`diagnose()`] runs the steps above in order; each lives in its own
//! module:
//!
//! * the input checks, [`DiagnoseOptions`] and [`DiagnoseError`]: `input`;
//! * step 1, the nominal model, the noise model and the scales every fit
//!   shares: `nominal` (with [`map_theta`], [`rotor_mass`]);
//! * what the steps after it share: `context` (with [`NOISE_CHI2`]);
//! * step 2, one module per hypothesis family: `bank` (with
//!   [`PEDESTAL_RATIOS`]);
//! * step 3, the choice and the pairs: [`diagnose()`] itself;
//! * step 4, the observability: [`observe`];
//! * the statistics ([`chi2_quantile_upper`], [`gamma_q`],
//!   [`normal_quantile_upper`], the BIC): `stats`;
//! * one fitted model, [`Candidate`]: `candidate`; the effects,
//!   [`Effect`]: `effect`;
//! * the result, [`Diagnosis`], and its shaping ([`findings`],
//!   [`estimates`], [`predictions`]): `result`;
//! * the wall-clock laps of [`Diagnosis::stages`]: `stages`;
//! * the model extensions, the reduced terms, the fit and the case
//!   generator: [`extended`], [`terms`], [`fit`], [`generator`].

mod bank;
mod candidate;
mod context;
mod effect;
pub mod extended;
pub mod fit;
pub mod generator;
mod input;
mod nominal;
pub mod observe;
mod result;
mod stages;
mod stats;
pub mod terms;

pub use bank::PEDESTAL_RATIOS;
pub use candidate::Candidate;
pub use context::NOISE_CHI2;
pub use effect::Effect;
pub use input::{DiagnoseError, DiagnoseOptions};
pub(crate) use nominal::theta_from_model;
pub use nominal::{map_theta, rotor_mass};
pub use result::{estimates, findings, predictions, Diagnosis, Finding, RunoutFinding};
pub use stats::{chi2_quantile_upper, gamma_q, normal_quantile_upper};

use crate::io::measurement::Measurements;
use crate::model::RotorModel;
use context::Context;
use fit::FitData;
use stages::Stages;

use crate::diagnose::extended::{ExtendedModel, Extension, PedestalParams};
use crate::diagnose::fit::Fit;
use crate::diagnose::terms::SpeedTerms;
use bank::rescreen;

/// Chi-square per degree of freedom of the residual noise against the
/// model-free noise level above which a model does not fit.
pub const MISFIT_CHI2: f64 = 2.0;

/// Runs the diagnosis of `meas` against `model` (see the module docs).
pub fn diagnose(
    model: &RotorModel,
    meas: &Measurements,
    opts: &DiagnoseOptions,
) -> Result<Diagnosis, DiagnoseError> {
    input::check(model, meas, opts)?;
    let mut clock = Stages::start();
    let samples = &meas.samples;
    let omegas: Vec<f64> = samples.iter().map(|s| s.omega).collect();
    let omega_max = omegas.iter().copied().fold(0.0, f64::max);
    let probes = &meas.node_probes;
    let node_q = &meas.node_q[..];
    // One modal reduction for every factor of the shaft modulus (the factor
    // only moves the speed, `terms` module docs); the model's own terms by
    // the banded reduction (see `Builder::build_banded`).
    let builder = terms::Builder::new(model, probes)?;
    let terms = builder.build_banded(&omegas, 1.0, false)?;
    clock.lap("terms");

    // 1. Nominal: QRD/RLS start, output-error fit, polish on our objective.
    let setup = nominal::Setup::new(model, samples, &terms, opts, omega_max)?;
    let data = FitData::with_probes(samples, node_q, &terms)
        .with_floors(&setup.phi)
        .with_noise_level(setup.noise_level);
    let (base, nominal) = nominal::fit_nominal(&setup, &data, opts)?;
    clock.lap("nominal fit");
    let theta0 = nominal.fit.theta.clone();
    let ctx = Context {
        model,
        opts,
        samples,
        node_q,
        omegas: &omegas,
        builder: &builder,
        terms: &terms,
        setup: &setup,
        data: &data,
        base: &base,
        nominal: &nominal,
        theta_model: theta_from_model(&setup.pr, model, &theta0, 0.5 * omega_max),
        theta0,
    };

    // 2. The bank.
    let bank::Bank {
        hypotheses,
        e_terms,
        terms_de,
    } = bank::run(&ctx, &mut clock)?;

    // 3. Choice.
    let (noise_level, n_real, scales) = (setup.noise_level, setup.n_real, setup.scales);
    let nb = model.bearings.len();
    let (theta0, theta_model) = (ctx.theta0.clone(), ctx.theta_model.clone());
    let n_room = |p: usize| ctx.n_room(p);
    let with_ext = |ext: Vec<Extension>| ctx.with_ext(ext);
    let mut hyps = hypotheses;
    let mut e_terms_cache = e_terms;
    let sigma2 = hyps
        .iter()
        .map(|c| c.fit.sigma2())
        .fold(nominal.fit.sigma2(), f64::min)
        .max(f64::MIN_POSITIVE);
    let alternatives: usize = hyps.iter().map(|c| c.alternatives).sum::<usize>().max(1);
    let alpha = opts.false_alarm / alternatives as f64;
    for c in &mut hyps {
        c.judge(&nominal.fit, sigma2, alpha);
    }
    let misfit = |c: &Candidate| -> bool {
        match noise_level {
            Some(s) if s > 0.0 => {
                let s_fit2 = 2.0 * c.fit.sigma2();
                s_fit2 / (s * s) > MISFIT_CHI2 && c.fit.residual() > 1e-6
            }
            _ => false,
        }
    };
    let bic_of = |c: &Candidate| c.fit.s / sigma2 + c.fit.n_params() as f64 * (n_real as f64).ln();
    let mut chosen: Option<usize> = None;
    let mut best_bic = bic_of(&nominal);
    for (i, c) in hyps.iter().enumerate() {
        if c.significant && bic_of(c) < best_bic {
            best_bic = bic_of(c);
            chosen = Some(i);
        }
    }
    let mut warnings = Vec::new();
    let mut effect = match chosen {
        Some(i) => hyps[i].effects[0],
        None => Effect::None,
    };
    let chosen_misfit = match chosen {
        Some(i) => misfit(&hyps[i]),
        None => misfit(&nominal),
    };
    if chosen_misfit {
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
                    for nb in rescreen(model, &data, a, b)? {
                        trials.push((a.clone(), nb));
                    }
                }
            }
        }
        for (a, b) in &trials {
            {
                if let Some(c) = fit_pair(&builder, &omegas, &data, a, b, &mut e_terms_cache)? {
                    // By BIC: a pair with a lean law beats one whose
                    // extra bearing orders merely absorb the second effect.
                    if pair_best.as_ref().is_none_or(|b| bic_of(&c) < bic_of(b)) {
                        pair_best = Some(c);
                    }
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
        let pair_fits = pair_best.as_ref().is_some_and(|c| !misfit(c));
        for c in hyps.iter().filter(|c| c.significant && !pair_fits) {
            let [Extension::Pedestal { bearing }] = c.model.ext[..] else {
                continue;
            };
            for other in (0..nb).filter(|&o| o != bearing) {
                let m2 = ExtendedModel {
                    ext: vec![
                        Extension::Pedestal { bearing },
                        Extension::Pedestal { bearing: other },
                    ],
                    ..c.model.clone()
                };
                if !n_room(m2.n_params()) {
                    continue;
                }
                let mut starts: Vec<Fit> = Vec::new();
                for nominal_start in [&theta0, &theta_model] {
                    for &r1 in &PEDESTAL_RATIOS {
                        for &r2 in &PEDESTAL_RATIOS {
                            let mut t = nominal_start.clone();
                            for r in [r1, r2] {
                                let ped = PedestalParams {
                                    mass: scales.mass,
                                    omega: [r * scales.omega; 2],
                                    zeta: [0.05; 2],
                                };
                                t.extend_from_slice(&ped.to_scaled(&scales));
                            }
                            if let Ok(f) = fit::fit_with(&m2, &data, &t, 3, false) {
                                starts.push(f);
                            }
                        }
                    }
                }
                starts.sort_by(|a, b| a.s.total_cmp(&b.s));
                for st in starts.iter().take(2) {
                    let Ok(f) = fit::fit(&m2, &data, &st.theta, 60) else {
                        continue;
                    };
                    // Each pedestal of the pair alone, from the pair's
                    // values: the joint search often finds a single
                    // pedestal the single search missed, beside a second
                    // one gone rigid (no trace in the data); by BIC the
                    // single one then wins.
                    let p0 = m2.pr.n_params();
                    for (k, b) in [bearing, other].into_iter().enumerate() {
                        let m1 = with_ext(vec![Extension::Pedestal { bearing: b }]);
                        let mut t = f.theta[..p0].to_vec();
                        t.extend_from_slice(&f.theta[m2.offset(k)..m2.offset(k) + 5]);
                        let Ok(f1) = fit::fit(&m1, &data, &t, 60) else {
                            continue;
                        };
                        let single = Candidate {
                            effects: vec![Effect::FoundationFlexibility],
                            label: format!(
                                "pedestal under bearing {} (node {}), from the search for two",
                                b + 1,
                                model.bearings[b].node + 1
                            ),
                            model: m1,
                            fit: f1,
                            e_terms: 1.0,
                            alternatives: 1,
                            statistic: 0.0,
                            threshold: 0.0,
                            significant: false,
                        };
                        if pair_best
                            .as_ref()
                            .is_none_or(|c| bic_of(&single) < bic_of(c))
                        {
                            pair_best = Some(single);
                        }
                    }
                    let pair = Candidate {
                        effects: vec![Effect::FoundationFlexibility; 2],
                        label: format!(
                            "pedestals under bearings {} and {} (nodes {} and {})",
                            bearing + 1,
                            other + 1,
                            model.bearings[bearing].node + 1,
                            model.bearings[other].node + 1
                        ),
                        model: m2.clone(),
                        fit: f,
                        e_terms: 1.0,
                        alternatives: 1,
                        statistic: 0.0,
                        threshold: 0.0,
                        significant: false,
                    };
                    if pair_best.as_ref().is_none_or(|b| bic_of(&pair) < bic_of(b)) {
                        pair_best = Some(pair);
                    }
                }
            }
        }
        match pair_best {
            Some(mut c) if !misfit(&c) => {
                c.judge(&nominal.fit, sigma2, alpha);
                effect = c.effects[0];
                hyps.push(c);
                chosen = Some(hyps.len() - 1);
            }
            other => {
                if let Some(mut c) = other {
                    c.statistic = (nominal.fit.s - c.fit.s) / sigma2;
                    hyps.push(c);
                }
                effect = Effect::Unexplained;
                chosen = None;
                warnings.push(format!(
                    "the misfit stays {:.1}x the noise level whatever effect is added: unexplained",
                    ((2.0 * nominal.fit.sigma2()).sqrt() / noise_level.unwrap_or(1.0)).max(0.0)
                ));
            }
        }
    }
    clock.lap("choice and pairs");
    let effects = match chosen {
        Some(i) => hyps[i].effects.clone(),
        None => Vec::new(),
    };
    if noise_level.is_none() {
        warnings.push(
            "too few speeds to estimate the noise level without the model: a misfit cannot be told from noise"
                .into(),
        );
    }
    let omega_report = samples.last().map_or(omega_max, |s| s.omega);
    let mut d = Diagnosis {
        effect,
        effects,
        noise_level,
        noise: setup.noise_model,
        nominal,
        hypotheses: hyps,
        chosen,
        sigma2,
        false_alarm: opts.false_alarm,
        observability: Vec::new(),
        warnings,
        terms: Vec::new(),
        omega_report,
        probe_nodes: probes.clone(),
        stages: Vec::new(),
    };

    // 4. Observability.
    let data_de = terms_de
        .as_ref()
        .map(|t| FitData::with_probes(samples, node_q, t).with_floors(&setup.phi));
    d.observability = observe::analyse(&d, &data, data_de.as_ref());
    clock.lap("observability");
    d.stages = clock.laps;
    drop(data);
    d.terms = terms;
    Ok(d)
}

/// A pair of hypotheses fitted together, from their own estimates.
fn fit_pair(
    builder: &terms::Builder,
    omegas: &[f64],
    data: &FitData<'_>,
    a: &Candidate,
    b: &Candidate,
    e_cache: &mut Option<(f64, Vec<SpeedTerms>)>,
) -> Result<Option<Candidate>, DiagnoseError> {
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
    let e = if a.model.ext.contains(&Extension::EScale) {
        a.e_terms
    } else {
        b.e_terms
    };
    let fit = if uses_e {
        let te = match e_cache {
            Some((ec, t)) if *ec == e && !t.is_empty() => t.clone(),
            _ => builder.build(omegas, e, true)?,
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
    Ok(Some(Candidate {
        effects,
        label: format!("{} + {}", a.label, b.label),
        model: m,
        fit,
        e_terms: if uses_e { e } else { 1.0 },
        alternatives: 1,
        statistic: 0.0,
        threshold: 0.0,
        significant: false,
    }))
}
