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
//!      the terms rebuilt at each new `e` (exact scaling, [`terms`]);
//!    * `probe_sensitivity`: one probe channel read `1 + g` times its
//!      signal, the channels screened like the bow, the first, its pair's
//!      other direction and the second fitted.
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
//!    When the answer is a section's diameter alone, its factor's standard
//!    deviation takes in the runs of elements the data cannot tell from
//!    the section found (`bank::section_ends`); when it is an extra
//!    unbalance alone, the deviation of its `m e` takes in the runs of
//!    nodes it could be shared by (`bank::plane_spread`).
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
//! * step 3, the choice: `choice` (with [`MISFIT_CHI2`]) and the pairs:
//!   `pairs`; a section's ends: `bank::section_ends`; where an extra
//!   unbalance lies: `bank::plane_spread`;
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
mod choice;
mod context;
mod effect;
pub mod extended;
pub mod fit;
pub mod generator;
mod input;
mod nominal;
pub mod observe;
mod pairs;
mod parallel;
mod result;
mod stages;
mod stats;
pub mod terms;

pub use bank::PEDESTAL_RATIOS;
pub use candidate::{Candidate, FormFit};
pub use choice::MISFIT_CHI2;
pub use context::NOISE_CHI2;
pub use effect::Effect;
pub use input::{DiagnoseError, DiagnoseOptions};
pub(crate) use nominal::theta_from_model;
pub use nominal::{map_theta, rotor_mass, MIN_RELATIVE_NOISE};
pub use result::{
    estimates, findings, predictions, Diagnosis, Finding, PlaneRun, RunoutFinding, SectionRun,
    StiffnessAlike,
};
pub use stats::{chi2_quantile_upper, gamma_q, normal_quantile_upper};

use crate::io::measurement::Measurements;
use crate::model::RotorModel;
use context::Context;
use fit::FitData;
use stages::Stages;

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
        probe_nodes: probes,
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
        mut hypotheses,
        mut e_terms,
        terms_de,
    } = bank::run(&ctx, &mut clock)?;

    // 3. Choice.
    let choice = choice::choose(&ctx, &mut hypotheses, &mut e_terms)?;
    clock.lap("choice and pairs");
    // A diameter off on a section: how well the data place its ends.
    if let Some(c) = choice.chosen.and_then(|i| hypotheses.get_mut(i)) {
        if let Some(ends) = bank::section_ends(&ctx, c, choice.sigma2) {
            c.set_ends(ends.std, ends.extremes);
        }
    }
    clock.lap("section ends");
    // An extra unbalance: how well the data place it along the shaft.
    if let Some(c) = choice.chosen.and_then(|i| hypotheses.get_mut(i)) {
        if let Some(spread) = bank::plane_spread(&ctx, c, choice.sigma2) {
            c.spread_std = spread.std;
            c.spread = spread.extremes;
        }
    }
    clock.lap("plane spread");
    let effects = match choice.chosen {
        Some(i) => hypotheses[i].effects.clone(),
        None => Vec::new(),
    };
    let mut warnings = choice.warnings;
    if setup.noise_level.is_none() {
        warnings.push(
            "too few speeds to estimate the noise level without the model: a misfit cannot be told from noise"
                .into(),
        );
    }
    let omega_report = samples.last().map_or(omega_max, |s| s.omega);
    let mut d = Diagnosis {
        effect: choice.effect,
        effects,
        noise_level: setup.noise_level,
        noise: setup.noise_model,
        nominal,
        hypotheses,
        chosen: choice.chosen,
        sigma2: choice.sigma2,
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
