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

pub mod extended;
pub mod fit;
pub mod generator;
pub mod observe;
pub mod terms;

use std::collections::HashMap;

use nalgebra::DMatrix;
use num_complex::Complex64;
use serde::Serialize;
use thiserror::Error;

use crate::estimate::noise::NoiseModel;
use crate::estimate::output_error::{fit_output_error, OutputErrorError, OutputErrorOptions};
use crate::estimate::predictor::{PredictError, Predictor, Terms};
use crate::estimate::results::{BearingResult, BearingStd, Coefficients, UnbalanceResult};
use crate::estimate::{identify_with, IdentifyError, Options, Parametrization};
use crate::io::measurement::Measurements;
use crate::model::RotorModel;
use crate::reduce::ReductionError;
use crate::tables::auto_scaling;
use crate::units::rad_s_to_rpm;
use extended::{ExtendedModel, Extension, PedestalParams, Scales, E_STEP};
use fit::{Fit, FitData};
use rotorid_core::parametrization::{Structure, MAX_ORDER};
use terms::SpeedTerms;

/// Chi-square per degree of freedom of the residual noise against the
/// model-free noise level above which a model does not fit.
pub const MISFIT_CHI2: f64 = 2.0;

/// Natural frequencies of the starts of the pedestal search, as fractions
/// of the top measured speed (besides two at the largest nominal misfit).
pub const PEDESTAL_RATIOS: [f64; 7] = [0.3, 0.45, 0.6, 0.75, 0.9, 1.1, 1.4];

/// Chi-square per degree of freedom of the residual noise against the
/// model-free noise level below which a fit explains the data to the noise:
/// the searches stop trying further starts of its hypothesis.
pub const NOISE_CHI2: f64 = 1.2;

/// What the data show beyond the nominal model (SPEC section 5 names).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Effect {
    /// Nothing beyond measurement noise.
    None,
    /// Bearing coefficients that vary with speed.
    SpeedDependentBearing,
    /// A pedestal that moves.
    FoundationFlexibility,
    /// A bent shaft.
    ShaftBow,
    /// A constant phasor added to a probe.
    ProbeRunout,
    /// Unbalance at a node not among the planes.
    ExtraUnbalancePlane,
    /// The shaft stiffer or softer than the model.
    ShaftStiffnessError,
    /// A misfit none of the above removes.
    Unexplained,
}

impl Effect {
    /// The hypotheses of the bank, in the order they are tried.
    pub const BANK: [Effect; 6] = [
        Effect::SpeedDependentBearing,
        Effect::FoundationFlexibility,
        Effect::ShaftBow,
        Effect::ProbeRunout,
        Effect::ExtraUnbalancePlane,
        Effect::ShaftStiffnessError,
    ];

    /// The name of the command-line contract.
    pub fn name(&self) -> &'static str {
        match self {
            Effect::None => "none",
            Effect::SpeedDependentBearing => "speed_dependent_bearing",
            Effect::FoundationFlexibility => "foundation_flexibility",
            Effect::ShaftBow => "shaft_bow",
            Effect::ProbeRunout => "probe_runout",
            Effect::ExtraUnbalancePlane => "extra_unbalance_plane",
            Effect::ShaftStiffnessError => "shaft_stiffness_error",
            Effect::Unexplained => "unexplained",
        }
    }

    /// Parses a name of [`Effect::name`].
    pub fn from_name(s: &str) -> Option<Effect> {
        [
            Effect::None,
            Effect::SpeedDependentBearing,
            Effect::FoundationFlexibility,
            Effect::ShaftBow,
            Effect::ProbeRunout,
            Effect::ExtraUnbalancePlane,
            Effect::ShaftStiffnessError,
            Effect::Unexplained,
        ]
        .into_iter()
        .find(|e| e.name() == s)
    }
}

/// Options of the diagnosis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DiagnoseOptions {
    /// Polynomial order of the nominal bearing law (`physical`).
    pub order: usize,
    /// False-alarm rate of the choice (probability that noise alone names
    /// an effect), split over all alternatives tried.
    pub false_alarm: f64,
    /// Probes on a pedestal read the shaft relative to it (the default, as
    /// proximity probes are mounted) rather than absolutely.
    pub relative_probes: bool,
    /// The probes' noise floor (m, every channel); `None`: estimated from
    /// the data (SPEC section 7).
    pub noise_floor: Option<f64>,
}

impl Default for DiagnoseOptions {
    fn default() -> Self {
        DiagnoseOptions {
            order: 1,
            false_alarm: 1e-3,
            relative_probes: true,
            noise_floor: None,
        }
    }
}

/// Why the diagnosis could not run.
#[derive(Debug, Error)]
pub enum DiagnoseError {
    /// Bad or inconsistent input.
    #[error("{0}")]
    Input(String),
    /// The nominal identification failed.
    #[error("{0}")]
    Identify(#[from] IdentifyError),
    /// The model reduction failed.
    #[error("{0}")]
    Reduction(#[from] ReductionError),
    /// The nominal output-error fit failed.
    #[error("{0}")]
    OutputError(#[from] OutputErrorError),
    /// A prediction failed.
    #[error("{0}")]
    Predict(#[from] PredictError),
}

/// One fitted model of the bank (or the nominal one).
#[derive(Debug, Clone)]
pub struct Candidate {
    /// The effects it adds (empty: nominal).
    pub effects: Vec<Effect>,
    /// A short description (e.g. "extra plane at node 17").
    pub label: String,
    /// The model.
    pub model: ExtendedModel,
    /// Its fit.
    pub fit: Fit,
    /// The shaft modulus factor its terms were built for.
    pub e_terms: f64,
    /// Alternatives tried for this hypothesis (nodes, bearings, orders).
    pub alternatives: usize,
    /// `(S_nominal - S) / sigma^2`.
    pub statistic: f64,
    /// The chi-square threshold it had to exceed.
    pub threshold: f64,
    /// Whether it is significant.
    pub significant: bool,
}

impl Candidate {
    /// Relative RMS misfit.
    pub fn residual(&self) -> f64 {
        self.fit.residual()
    }

    /// The likelihood-ratio test against the nominal fit: the drop in `S`
    /// in units of `sigma2` against the chi-square quantile of the extra
    /// parameters at the rate `alpha`.
    fn judge(&mut self, nominal: &Fit, sigma2: f64, alpha: f64) {
        let dp = self
            .fit
            .n_params()
            .saturating_sub(nominal.n_params())
            .max(1);
        self.statistic = (nominal.s - self.fit.s) / sigma2;
        self.threshold = chi2_quantile_upper(dp as f64, alpha);
        self.significant = self.statistic > self.threshold;
    }
}

/// The size of an identified effect, with standard deviations.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "effect", rename_all = "snake_case")]
pub enum Finding {
    /// Speed-dependent bearings: the law's order and each bearing's
    /// stiffness at the lowest and highest speed (N/m).
    SpeedDependentBearing {
        /// Polynomial order identified.
        order: usize,
        /// Per bearing: `(node, K at the lowest speed, K at the highest)`.
        stiffness: Vec<(usize, Coefficients, Coefficients)>,
    },
    /// A pedestal under a bearing.
    FoundationFlexibility {
        /// Bearing node (1-based).
        node: usize,
        /// Mass (kg).
        mass: f64,
        /// Its standard deviation.
        mass_std: f64,
        /// Natural frequencies on its springs, y and z (Hz).
        natural_frequency_hz: [f64; 2],
        /// Their standard deviations.
        natural_frequency_hz_std: [f64; 2],
        /// Damping ratios, y and z.
        damping_ratio: [f64; 2],
        /// Stiffness y, z (N/m).
        k: [f64; 2],
        /// Damping y, z (N s/m).
        c: [f64; 2],
    },
    /// A bent shaft.
    ShaftBow {
        /// Node of the offset (1-based).
        node: usize,
        /// Offset amplitude (m).
        amplitude: f64,
        /// Its standard deviation.
        amplitude_std: f64,
        /// Phase (deg).
        phase_deg: f64,
        /// Its standard deviation.
        phase_deg_std: f64,
    },
    /// Probe runout per channel.
    ProbeRunout {
        /// Each channel's phasor.
        channels: Vec<RunoutFinding>,
    },
    /// Unbalance at another node.
    ExtraUnbalancePlane {
        /// Node (1-based).
        node: usize,
        /// `m e` (kg m).
        me: f64,
        /// Its standard deviation.
        me_std: f64,
        /// Phase (deg).
        phase_deg: f64,
        /// Its standard deviation.
        phase_deg_std: f64,
    },
    /// The shaft's modulus off.
    ShaftStiffnessError {
        /// Factor on E and G.
        factor: f64,
        /// Its standard deviation.
        factor_std: f64,
    },
}

/// The runout of one channel.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RunoutFinding {
    /// Channel name (`b1_y`, ...).
    pub channel: String,
    /// Amplitude (m).
    pub amplitude: f64,
    /// Its standard deviation.
    pub amplitude_std: f64,
    /// Phase (deg).
    pub phase_deg: f64,
    /// Its standard deviation.
    pub phase_deg_std: f64,
    /// Whether it is above 3 standard deviations.
    pub significant: bool,
}

/// The result of [`diagnose`].
#[derive(Debug, Clone)]
pub struct Diagnosis {
    /// The named effect (the stronger of a pair).
    pub effect: Effect,
    /// The effects of the chosen model (empty for `none`/`unexplained`).
    pub effects: Vec<Effect>,
    /// The model-free noise level, when the speeds allow it.
    pub noise_level: Option<f64>,
    /// The noise model the fits were weighted with (SPEC section 7).
    pub noise: Option<NoiseModel>,
    /// The nominal model.
    pub nominal: Candidate,
    /// Every hypothesis fitted (best variant of each), pairs included.
    pub hypotheses: Vec<Candidate>,
    /// Index in `hypotheses` of the chosen model (`None`: nominal).
    pub chosen: Option<usize>,
    /// `sigma^2` used for the statistics.
    pub sigma2: f64,
    /// The false-alarm rate of the choice.
    pub false_alarm: f64,
    /// Observability of each hypothesis.
    pub observability: Vec<observe::Observability>,
    /// What must be known before trusting the result.
    pub warnings: Vec<String>,
    /// The speeds (rad/s) and the terms used (for plots).
    pub terms: Vec<SpeedTerms>,
    /// Speed at which bearings are reported (rad/s).
    pub omega_report: f64,
    /// Shaft nodes (0-based) of the measurement's probes at other nodes.
    pub probe_nodes: Vec<usize>,
    /// Wall-clock time of each stage of [`diagnose`] (seconds), in order:
    /// where a diagnosis spends its time.
    pub stages: Vec<(&'static str, f64)>,
}

impl Diagnosis {
    /// The chosen model (the nominal one for `none`/`unexplained`).
    pub fn extended(&self) -> &Candidate {
        self.chosen
            .and_then(|i| self.hypotheses.get(i))
            .unwrap_or(&self.nominal)
    }

    /// Residual of the nominal model.
    pub fn residual_nominal(&self) -> f64 {
        self.nominal.residual()
    }

    /// Residual of the chosen model.
    pub fn residual_extended(&self) -> f64 {
        self.extended().residual()
    }

    /// The smallest detectable size of `ext` alone at the nominal estimate
    /// (m for a bow or runout, kg m for a plane; see [`observe`]); `None`
    /// for effects without a zero (pedestal, modulus, speed law).
    pub fn min_detectable(&self, meas: &Measurements, ext: Extension) -> Option<f64> {
        let phi = self
            .noise
            .as_ref()
            .filter(|m| m.has_floor())
            .map(|m| m.relative_floor())
            .unwrap_or_default();
        let data = FitData::with_probes(&meas.samples, &meas.node_q, &self.terms).with_floors(&phi);
        observe::min_detectable_single(self, &data, ext)
    }

    /// The identified size of every effect of the chosen model.
    pub fn findings(&self) -> Vec<Finding> {
        let c = self.extended();
        findings(c, &self.terms)
    }
}

/// The probe readings `c` predicts at every speed of `d` (m), with the
/// terms rebuilt for its shaft modulus when it has one.
pub fn predictions(
    model: &RotorModel,
    d: &Diagnosis,
    c: &Candidate,
) -> Result<Vec<Vec<Complex64>>, DiagnoseError> {
    let own;
    let terms: &[SpeedTerms] = if c.model.ext.contains(&Extension::EScale) {
        let omegas: Vec<f64> = d.terms.iter().map(|t| t.omega).collect();
        own = terms::build_with_probes(model, &omegas, c.e_terms, true, &d.probe_nodes)?;
        &own
    } else {
        &d.terms
    };
    terms
        .iter()
        .map(|st| {
            c.model
                .predict(st, &c.model.pr.entries(st.omega), &c.fit.theta, None)
                .map(|y| y.iter().copied().collect())
                .map_err(DiagnoseError::from)
        })
        .collect()
}

/// The scaled parameters of `to` from those of `from` (same unknowns
/// matched; unknowns `from` lacks start at zero).
pub fn map_theta(from: &Predictor, theta: &[f64], to: &Predictor) -> Vec<f64> {
    let w = from.weights(theta);
    let mut out = vec![Complex64::new(0.0, 0.0); to.param.n_unknowns()];
    for (j, o) in out.iter_mut().enumerate() {
        let u = to.param.unknown(j);
        if let Some(i) = (0..from.param.n_unknowns()).find(|&i| from.param.unknown(i) == u) {
            let s = to.param.scale(j);
            if s != 0.0 {
                *o = w[i] * (from.param.scale(i) / s);
            }
        }
    }
    to.theta(&out)
}

/// The nominal parameters with the bearings set to the model's own
/// coefficients at `omega` (constant; higher orders zero) and the
/// unbalance of `theta0`.
pub(crate) fn theta_from_model(
    pr: &Predictor,
    model: &RotorModel,
    theta0: &[f64],
    omega: f64,
) -> Vec<f64> {
    use rotorid_core::parametrization::{BearingTerm, Unknown};
    let p = &pr.param;
    let mut w = pr.weights(theta0);
    for (j, wj) in w.iter_mut().enumerate() {
        if let Some(Unknown::Bearing {
            bearing,
            row,
            col,
            term,
        }) = p.unknown(j)
        {
            let co = model.bearings[bearing].law.at(omega);
            let e = 2 * row + col;
            let s = p.scale(j);
            let v = match term {
                BearingTerm::K { power: 0 } => co.k[e],
                BearingTerm::C { power: 0 } => co.c[e],
                _ => 0.0,
            };
            if s != 0.0 {
                *wj = Complex64::from(v / s);
            }
        }
    }
    pr.theta(&w)
}

/// Runs the diagnosis of `meas` against `model` (see the module docs).
pub fn diagnose(
    model: &RotorModel,
    meas: &Measurements,
    opts: &DiagnoseOptions,
) -> Result<Diagnosis, DiagnoseError> {
    let nb = model.bearings.len();
    if meas.n_bearings != nb || meas.samples.iter().any(|s| s.q.len() != 2 * nb) {
        return Err(DiagnoseError::Input(format!(
            "the measurement has {} bearings, the model {}",
            meas.n_bearings, nb
        )));
    }
    if !(1..=MAX_ORDER).contains(&opts.order) {
        return Err(DiagnoseError::Input(format!(
            "order must be in 1..={MAX_ORDER}, got {}",
            opts.order
        )));
    }
    if !(opts.false_alarm > 0.0 && opts.false_alarm < 0.5) {
        return Err(DiagnoseError::Input(format!(
            "false-alarm rate must be in (0, 0.5), got {}",
            opts.false_alarm
        )));
    }
    if let Some(s) = meas
        .samples
        .iter()
        .find(|s| s.omega.is_nan() || s.omega <= 0.0)
    {
        return Err(DiagnoseError::Input(format!(
            "the diagnosis needs speeds above 0 rpm, got {} rpm",
            rad_s_to_rpm(s.omega)
        )));
    }
    let mut clock = Stages::start();
    let samples = &meas.samples;
    let omegas: Vec<f64> = samples.iter().map(|s| s.omega).collect();
    let omega_max = omegas.iter().copied().fold(0.0, f64::max);
    let probes = &meas.node_probes;
    let node_q = &meas.node_q[..];
    if !probes.is_empty()
        && (node_q.len() != samples.len() || node_q.iter().any(|x| x.len() != 2 * probes.len()))
    {
        return Err(DiagnoseError::Input(format!(
            "{} node-probe rows for {} samples of {} probes",
            node_q.len(),
            samples.len(),
            probes.len()
        )));
    }
    if let Some(n) = probes.iter().find(|&&n| n >= model.n_nodes()) {
        return Err(DiagnoseError::Input(format!(
            "a probe at node {} but the model has {} nodes",
            n + 1,
            model.n_nodes()
        )));
    }
    // One modal reduction for every factor of the shaft modulus (the factor
    // only moves the speed, `terms` module docs); the model's own terms by
    // the banded reduction (see `Builder::build_banded`).
    let builder = terms::Builder::new(model, probes)?;
    let terms = builder.build_banded(&omegas, 1.0, false)?;
    clock.lap("terms");

    // 1. Nominal: QRD/RLS start, output-error fit, polish on our objective.
    let structure = Structure::physical(opts.order);
    let scaling = auto_scaling(model, omega_max);
    // The noise model: model-free, its relative part refined by the nominal
    // output-error fit where a floor leaves it to the few samples near the
    // critical speeds (the same rule as `identify`).
    let reference = crate::estimate::noise::estimate_noise(samples, opts.noise_floor);
    let (pr, oe_theta, fitted) = oe_start(
        model,
        samples,
        &terms,
        structure,
        scaling,
        reference.as_ref(),
    )?;
    let noise_model = match (reference, fitted) {
        (Some(r), Some(f)) if r.has_floor() => Some(NoiseModel {
            relative: f.relative.min(r.relative),
            ..r
        }),
        (r, _) => r,
    };
    let phi: Vec<f64> = noise_model
        .as_ref()
        .filter(|m| m.has_floor())
        .map(|m| m.relative_floor())
        .unwrap_or_default();
    let n_real = 2 * samples.len() * 2 * nb;
    let q_rms = (samples
        .iter()
        .flat_map(|s| &s.q)
        .map(|z| z.norm_sqr())
        .sum::<f64>()
        / (samples.len() * 2 * nb).max(1) as f64)
        .sqrt();
    let rotor_mass = rotor_mass(model);
    let scales = Scales {
        q: if q_rms > 0.0 { q_rms } else { 1e-6 },
        mass: rotor_mass / nb as f64,
        omega: omega_max,
    };
    // The model-free noise level: lets fits far above it stop stalled
    // (`fit` module docs) and judges the misfit below.
    let noise_level = match &noise_model {
        Some(m) if m.has_floor() => Some(m.relative),
        _ => crate::estimate::noise::relative_noise_level(samples),
    };
    let data = FitData::with_probes(samples, node_q, &terms)
        .with_floors(&phi)
        .with_noise_level(noise_level);
    let base = ExtendedModel {
        pr: pr.clone(),
        ext: Vec::new(),
        scales,
        relative_probes: opts.relative_probes,
    };
    let nominal_fit = fit::fit(&base, &data, &oe_theta, 50)?;
    if n_real <= nominal_fit.n_params() {
        return Err(DiagnoseError::Input(format!(
            "{} real equations for {} nominal parameters: too few speeds to diagnose",
            n_real,
            nominal_fit.n_params()
        )));
    }
    let nominal = Candidate {
        effects: Vec::new(),
        label: format!("nominal (physical order {})", opts.order),
        model: base.clone(),
        fit: nominal_fit,
        e_terms: 1.0,
        alternatives: 1,
        statistic: 0.0,
        threshold: 0.0,
        significant: false,
    };
    clock.lap("nominal fit");
    let theta0 = nominal.fit.theta.clone();
    let theta_model = theta_from_model(&pr, model, &theta0, 0.5 * omega_max);
    let nominal_s = nominal.fit.s;

    // 2. The bank.
    let mut hyps: Vec<Candidate> = Vec::new();
    let mut push =
        |effect: Effect, label: String, model: ExtendedModel, fit: Fit, e: f64, alt: usize| {
            hyps.push(Candidate {
                effects: vec![effect],
                label,
                model,
                fit,
                e_terms: e,
                alternatives: alt,
                statistic: 0.0,
                threshold: 0.0,
                significant: false,
            })
        };
    let with_ext = |ext: Vec<Extension>| ExtendedModel {
        ext,
        ..base.clone()
    };
    let start_with = |m: &ExtendedModel, extra: &[f64]| -> Vec<f64> {
        let mut t = theta0.clone();
        t.extend_from_slice(extra);
        t.resize(m.n_params(), 0.0);
        t
    };
    let n_room = |p: usize| n_real > p + 4;
    // A fit whose residual noise is within NOISE_CHI2 of the model-free
    // noise level: further starts or richer variants of its hypothesis are
    // not tried (they could only move `S` by noise).
    let at_noise = |f: &Fit| match noise_level {
        Some(s) if s > 0.0 => 2.0 * f.sigma2() / (s * s) <= NOISE_CHI2,
        _ => false,
    };

    // speed_dependent_bearing
    {
        let mut best: Option<(Fit, ExtendedModel, usize)> = None;
        let mut alt = 0;
        for order in opts.order + 1..=(opts.order + 2).min(MAX_ORDER) {
            let param = Parametrization {
                structure: Structure::physical(order),
                ..pr.param.clone()
            };
            let prn = Predictor::new(param);
            if !n_room(prn.n_params()) {
                continue;
            }
            alt += 1;
            let t = map_theta(&pr, &theta0, &prn);
            let m = ExtendedModel {
                pr: prn,
                ..base.clone()
            };
            if let Ok(f) = fit::fit(&m, &data, &t, 50) {
                if best
                    .as_ref()
                    .is_none_or(|b| bic(&f, n_real) < bic(&b.0, n_real))
                {
                    best = Some((f, m, order));
                }
            }
        }
        if let Some((f, m, order)) = best {
            push(
                Effect::SpeedDependentBearing,
                format!("bearing law of physical order {order}"),
                m,
                f,
                1.0,
                alt,
            );
        }
    }
    clock.lap(Effect::SpeedDependentBearing.name());
    // foundation_flexibility: a pedestal under each bearing in turn.
    {
        let mut best: Option<(Fit, ExtendedModel, usize)> = None;
        let mut alt = 0;
        // Where the nominal model misfits a bearing's channels most: a
        // pedestal's resonance shows there.
        let r_nominal = fit::evaluate(&base, &data, &fit::entries(&base, &data), &theta0, false)
            .map(|(r, _)| r)
            .ok();
        let n_out = data.inv_w.first().map_or(0, Vec::len);
        let mut queue: Vec<(Fit, usize)> = Vec::new();
        for bearing in 0..nb {
            let m = with_ext(vec![Extension::Pedestal { bearing }]);
            if !n_room(m.n_params()) {
                continue;
            }
            alt += 1;
            let peak_ratio = r_nominal.as_ref().and_then(|r| {
                let k = (0..samples.len()).max_by(|&a, &b| {
                    let e = |k: usize| -> f64 {
                        (4 * bearing..4 * bearing + 4)
                            .map(|i| r[2 * k * n_out + i].powi(2))
                            .sum()
                    };
                    e(a).total_cmp(&e(b))
                })?;
                Some(samples[k].omega / scales.omega)
            });
            let mut ratios = PEDESTAL_RATIOS.to_vec();
            if let Some(p) = peak_ratio {
                ratios.extend([0.97 * p, 1.03 * p]);
            }
            // Screen a grid of natural frequencies and masses by three
            // iterations each (fewer rank the starts wrongly: the basin of
            // a resonance is narrow), then fit from the two best starts.
            // The bearings start from the nominal fit and from the model's
            // own values (a large pedestal distorts the nominal fit).
            // (Ranking on every second speed only halves this and loses
            // pedestals whose y and z frequencies lie apart.)
            let mut starts: Vec<Fit> = Vec::new();
            for nominal_start in [&theta0, &theta_model] {
                for &ratio in &ratios {
                    for mass in [0.5, 1.5] {
                        let ped = PedestalParams {
                            mass: mass * scales.mass,
                            omega: [ratio * scales.omega; 2],
                            zeta: [0.05; 2],
                        };
                        let mut t = nominal_start.clone();
                        t.extend_from_slice(&ped.to_scaled(&scales));
                        if let Ok(f) = fit::fit_with(&m, &data, &t, 3, false) {
                            starts.push(f);
                        }
                    }
                }
            }
            starts.sort_by(|a, b| a.s.total_cmp(&b.s));
            queue.extend(starts.into_iter().take(2).map(|f| (f, bearing)));
        }
        // The full fits, best screened start first (the thinned `S` of all
        // bearings are comparable), until one fits to the noise: another
        // start could then only move `S` by noise.
        queue.sort_by(|a, b| a.0.s.total_cmp(&b.0.s));
        for (start, bearing) in queue {
            if best.as_ref().is_some_and(|b| at_noise(&b.0)) {
                break;
            }
            let m = with_ext(vec![Extension::Pedestal { bearing }]);
            if let Ok(f) = fit::fit(&m, &data, &start.theta, 60) {
                if best.as_ref().is_none_or(|b| f.s < b.0.s) {
                    best = Some((f, m, bearing));
                }
            }
        }
        if let Some((f, m, bearing)) = best {
            push(
                Effect::FoundationFlexibility,
                format!(
                    "pedestal under bearing {} (node {})",
                    bearing + 1,
                    model.bearings[bearing].node + 1
                ),
                m,
                f,
                1.0,
                alt,
            );
        }
    }
    clock.lap(Effect::FoundationFlexibility.name());
    // shaft_bow and extra_unbalance_plane: screened over nodes.
    let n_nodes = model.n_nodes();
    for effect in [Effect::ShaftBow, Effect::ExtraUnbalancePlane] {
        let nodes: Vec<usize> = match effect {
            Effect::ShaftBow => (1..n_nodes.saturating_sub(1)).collect(),
            _ => (0..n_nodes).filter(|n| !model.planes.contains(n)).collect(),
        };
        let make = |node: usize| match effect {
            Effect::ShaftBow => Extension::Bow { node },
            _ => Extension::Plane { node },
        };
        let ranked = screen(&base, &data, &theta0, &nodes, &make)?;
        let mut best: Option<(Fit, ExtendedModel, usize)> = None;
        for &node in ranked.iter().take(2) {
            let m = with_ext(vec![make(node)]);
            if !n_room(m.n_params()) {
                continue;
            }
            let t = start_with(&m, &[]);
            if let Ok(f) = fit::fit(&m, &data, &t, 50) {
                if best.as_ref().is_none_or(|b| f.s < b.0.s) {
                    best = Some((f, m, node));
                }
            }
        }
        if let Some((f, m, node)) = best {
            let label = match effect {
                Effect::ShaftBow => format!("bow with its offset at node {}", node + 1),
                _ => format!("extra unbalance plane at node {}", node + 1),
            };
            push(effect, label, m, f, 1.0, nodes.len());
        }
    }
    clock.lap("shaft_bow, extra_unbalance_plane");
    // probe_runout
    {
        let m = with_ext(vec![Extension::Runout]);
        if n_room(m.n_params()) {
            // Start: the reading at the lowest speed is mostly runout (the
            // unbalance response vanishes like Omega^2); the nominal
            // parameters refitted to the data without it.
            let low = samples
                .iter()
                .min_by(|a, b| a.omega.total_cmp(&b.omega))
                .map(|s| s.q.clone())
                .unwrap_or_default();
            let corrected: Vec<crate::io::measurement::Sample> = samples
                .iter()
                .map(|s| crate::io::measurement::Sample {
                    omega: s.omega,
                    q: s.q.iter().zip(&low).map(|(y, r)| y - r).collect(),
                })
                .collect();
            let r0: Vec<f64> = low
                .iter()
                .flat_map(|r| [r.re / scales.q, r.im / scales.q])
                .collect();
            let mut t = match oe_start(
                model,
                &corrected,
                &terms,
                structure,
                scaling,
                noise_model.as_ref(),
            ) {
                Ok((_, th, _)) => th,
                Err(_) => theta0.clone(),
            };
            t.extend_from_slice(&r0);
            t.resize(m.n_params(), 0.0);
            if let Ok(f) = fit::fit(&m, &data, &t, 50) {
                push(
                    Effect::ProbeRunout,
                    "runout phasor on every channel".into(),
                    m,
                    f,
                    1.0,
                    1,
                );
            }
        }
    }
    clock.lap(Effect::ProbeRunout.name());
    // shaft_stiffness_error: rounds of terms rebuilt at the new factor.
    let mut e_terms_cache: Option<(f64, Vec<SpeedTerms>)> = None;
    // The nominal terms with dA/de, dB/de at e = 1 (central secant through
    // e = 0.95 and 1.05), for the modulus' observability.
    let mut terms_de: Option<Vec<SpeedTerms>> = None;
    {
        let m = with_ext(vec![Extension::EScale]);
        if n_room(m.n_params()) {
            // Start: the best of e = 1 and e = 1 -+ 5 % with the nominal
            // parameters refitted at each (the nominal estimate adapts the
            // bearings to the wrong shaft: a local minimum in between).
            let mut built: Vec<(f64, Vec<SpeedTerms>)> = vec![(1.0, terms.clone())];
            let mut best = (1.0, nominal_s, start_with(&m, &[0.0]));
            for e_try in [0.95, 1.05] {
                let te = builder.build(&omegas, e_try, false)?;
                if let Ok((_, mut th, _)) = oe_start(
                    model,
                    samples,
                    &te,
                    structure,
                    scaling,
                    noise_model.as_ref(),
                ) {
                    let d = FitData::with_probes(samples, node_q, &te).with_floors(&phi);
                    let en = fit::entries(&base, &d);
                    if let Ok((r, _)) = fit::evaluate(&base, &d, &en, &th, false) {
                        let s_try = r.norm_squared();
                        if s_try < best.1 {
                            th.push(0.0);
                            best = (e_try, s_try, th);
                        }
                    }
                }
                built.push((e_try, te));
            }
            if let [_, (em, minus), (ep, plus)] = &built[..] {
                let mut central = plus.clone();
                terms::set_secant_derivative(&mut central, *ep, minus, *em)?;
                let mut t1 = terms.clone();
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
            let (mut e, _, mut theta) = best;
            // Rounds: fit with the terms linearised in e about the current
            // factor, move the factor, rebuild the terms there. dA/de and
            // dB/de are the secant through the previous factor's terms (one
            // reduction per round instead of two): at convergence the
            // offset is zero and the residual is that of the exact terms.
            let pick = |k: usize, built: &mut Vec<(f64, Vec<SpeedTerms>)>| built.swap_remove(k);
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
                let d = FitData::with_probes(samples, node_q, &cur)
                    .with_floors(&phi)
                    .with_noise_level(noise_level);
                let Ok(f) = fit::fit(&m, &d, &theta, 50) else {
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
                let mut next = builder.build(&omegas, e_new, false)?;
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
            if let Some((_, e_fit)) = &last {
                if *e_fit == e {
                    e_terms_cache = Some((e, cur));
                }
            }
            if let Some((f, e)) = last {
                push(
                    Effect::ShaftStiffnessError,
                    "factor on the shaft's E and G".into(),
                    m,
                    f,
                    e,
                    1,
                );
            }
        }
    }

    clock.lap(Effect::ShaftStiffnessError.name());
    // 3. Choice.
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
        noise: noise_model,
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
    let data_de = terms_de
        .as_ref()
        .map(|t| FitData::with_probes(samples, node_q, t).with_floors(&phi));
    d.observability = observe::analyse(&d, &data, data_de.as_ref());
    clock.lap("observability");
    d.stages = clock.laps;
    drop(data);
    d.terms = terms;
    Ok(d)
}

/// Wall-clock laps of the stages of [`diagnose`].
struct Stages {
    last: std::time::Instant,
    laps: Vec<(&'static str, f64)>,
}

impl Stages {
    fn start() -> Self {
        Stages {
            last: std::time::Instant::now(),
            laps: Vec::new(),
        }
    }

    /// Records the time since the previous lap under `name`.
    fn lap(&mut self, name: &'static str) {
        let now = std::time::Instant::now();
        self.laps
            .push((name, now.duration_since(self.last).as_secs_f64()));
        self.last = now;
    }
}

/// The output-error estimate of the nominal parameters on `samples` with
/// the terms `terms` (same order): QRD/RLS start, then
/// [`fit_output_error`]. Returns the predictor and its scaled parameters.
fn oe_start(
    model: &RotorModel,
    samples: &[crate::io::measurement::Sample],
    terms: &[SpeedTerms],
    structure: Structure,
    scaling: rotorid_core::scaling::ColumnScaling<f64>,
    noise: Option<&NoiseModel>,
) -> Result<(Predictor, Vec<f64>, Option<NoiseModel>), DiagnoseError> {
    let mut o = Options::new(structure);
    o.scaling = Some(scaling);
    let index: HashMap<u64, usize> = terms
        .iter()
        .enumerate()
        .map(|(i, t)| (t.omega.to_bits(), i))
        .collect();
    let mut serve = |w: f64| -> Result<(DMatrix<Complex64>, DMatrix<Complex64>), IdentifyError> {
        let i = index.get(&w.to_bits()).copied().unwrap_or(0);
        Ok((terms[i].a.clone(), terms[i].b.clone()))
    };
    let meas = Measurements {
        comments: Vec::new(),
        n_bearings: model.bearings.len(),
        samples: samples.to_vec(),
        ..Measurements::default()
    };
    let id = identify_with(
        &model.bearing_nodes(),
        &model.planes,
        &meas,
        &o,
        &mut serve,
        None,
    )?;
    let pr = Predictor::new(id.param.clone());
    let oe_terms: Vec<Terms> = terms.iter().map(|t| (t.a.clone(), t.b.clone())).collect();
    let proportional = || {
        fit_output_error(
            &pr,
            samples,
            &oe_terms,
            &id.scaled_weights,
            &OutputErrorOptions::default(),
        )
    };
    // With a floor, the fit under the noise model; where it cannot be
    // done (a model far from the data can make its weighted normal
    // equations singular), the proportional fit, and the noise model as
    // estimated without the model.
    let oe = match noise.filter(|m| m.has_floor()) {
        Some(m) => crate::estimate::output_error::fit_output_error_with(
            &pr,
            samples,
            &oe_terms,
            &id.scaled_weights,
            &OutputErrorOptions::default(),
            &crate::estimate::output_error::FitNoise {
                model: Some(m.clone()),
                refine: true,
                ..Default::default()
            },
        )
        .or_else(|_| proportional())?,
        None => proportional()?,
    };
    Ok((pr, oe.theta, oe.noise))
}

/// `b` (a node-searched effect) with its node searched again on top of
/// `a`'s fit: the two best nodes, each as a candidate whose effect
/// parameters start at zero.
fn rescreen(
    model: &RotorModel,
    data: &FitData<'_>,
    a: &Candidate,
    b: &Candidate,
) -> Result<Vec<Candidate>, DiagnoseError> {
    let kind = match b.model.ext.as_slice() {
        [Extension::Plane { .. }] => 0,
        [Extension::Bow { .. }] => 1,
        _ => return Ok(Vec::new()),
    };
    let n_nodes = model.n_nodes();
    let nodes: Vec<usize> = if kind == 1 {
        (1..n_nodes.saturating_sub(1)).collect()
    } else {
        (0..n_nodes).filter(|n| !model.planes.contains(n)).collect()
    };
    let make = |node: usize| {
        if kind == 1 {
            Extension::Bow { node }
        } else {
            Extension::Plane { node }
        }
    };
    let ranked = match screen(&a.model, data, &a.fit.theta, &nodes, &make) {
        Ok(r) => r,
        Err(_) => return Ok(Vec::new()),
    };
    let nom = b.model.pr.n_params();
    Ok(ranked
        .into_iter()
        .take(2)
        .filter(|&n| b.model.ext != [make(n)])
        .map(|n| {
            let mut c = b.clone();
            c.model.ext = vec![make(n)];
            c.fit.theta.truncate(nom);
            c.fit.theta.extend([0.0, 0.0]);
            c.label = match kind {
                1 => format!("bow with its offset at node {}", n + 1),
                _ => format!("extra unbalance plane at node {}", n + 1),
            };
            c
        })
        .collect())
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

/// Ranks `nodes` by the drop in `S` that one Gauss-Newton step from the
/// estimate `theta0` of `base` predicts when the node's effect is added
/// (all of `base`'s parameters free): `g_s^T G_ss^-1 g_s` over the nominal columns
/// and the node's two, from one Jacobian holding every node's columns.
fn screen(
    base: &ExtendedModel,
    data: &FitData<'_>,
    theta0: &[f64],
    nodes: &[usize],
    make: &dyn Fn(usize) -> Extension,
) -> Result<Vec<usize>, DiagnoseError> {
    let all = ExtendedModel {
        ext: base
            .ext
            .iter()
            .copied()
            .chain(nodes.iter().map(|&n| make(n)))
            .collect(),
        ..base.clone()
    };
    let mut theta = theta0.to_vec();
    theta.resize(all.n_params(), 0.0);
    let en = fit::entries(&all, data);
    let (r, jac) = fit::evaluate(&all, data, &en, &theta, true)?;
    let Some(j) = jac else {
        return Ok(Vec::new());
    };
    let g = j.tr_mul(&r);
    let gram = fit::gram(&j);
    let p0 = base.n_params();
    let mut scored: Vec<(f64, usize)> = Vec::new();
    for (k, &node) in nodes.iter().enumerate() {
        let o = all.offset(base.ext.len() + k);
        let idx: Vec<usize> = (0..p0).chain([o, o + 1]).collect();
        let gs = nalgebra::DVector::from_iterator(idx.len(), idx.iter().map(|&i| g[i]));
        let gss = DMatrix::from_fn(idx.len(), idx.len(), |a, b| gram[(idx[a], idx[b])]);
        let drop = gss.cholesky().map(|c| gs.dot(&c.solve(&gs))).unwrap_or(0.0);
        scored.push((drop, node));
    }
    scored.sort_by(|a, b| b.0.total_cmp(&a.0));
    Ok(scored.into_iter().map(|(_, n)| n).collect())
}

fn bic(f: &Fit, n: usize) -> f64 {
    // With sigma^2 from the fit itself: n ln(S/n) + P ln n.
    let n = n as f64;
    n * (f.s / n).max(f64::MIN_POSITIVE).ln() + f.n_params() as f64 * n.ln()
}

/// Total mass of shaft and disks (kg).
pub fn rotor_mass(model: &RotorModel) -> f64 {
    let shaft: f64 = model
        .shaft
        .iter()
        .map(|e| {
            let a =
                std::f64::consts::PI / 4.0 * (e.outer_diameter.powi(2) - e.inner_diameter.powi(2));
            e.material.rho * a * e.length
        })
        .sum();
    shaft + model.disks.iter().map(|d| d.mass).sum::<f64>()
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

/// Amplitude and phase (deg) of `z = s (x + j y)` with their standard
/// deviations from the 2x2 covariance of `(x, y)` (linearised).
fn polar_with_std(x: f64, y: f64, s: f64, cov: Option<[[f64; 2]; 2]>) -> (f64, f64, f64, f64) {
    let z = Complex64::new(x, y) * s;
    let r = z.norm();
    let (mut sa, mut sp) = (f64::NAN, f64::NAN);
    if let (Some(c), true) = (cov, r > 0.0) {
        let (u, v) = (z.re / r, z.im / r);
        // d r = u dx' + v dy', d phi = (-v dx' + u dy') / r, x' = s x.
        let var_r = s * s * (u * u * c[0][0] + 2.0 * u * v * c[0][1] + v * v * c[1][1]);
        let var_p = s * s * (v * v * c[0][0] - 2.0 * u * v * c[0][1] + u * u * c[1][1]) / (r * r);
        sa = var_r.max(0.0).sqrt();
        sp = var_p.max(0.0).sqrt().to_degrees();
    }
    (r, z.arg().to_degrees(), sa, sp)
}

fn cov2(f: &Fit, o: usize) -> Option<[[f64; 2]; 2]> {
    f.covariance.as_ref().map(|c| {
        [
            [c[(o, o)], c[(o, o + 1)]],
            [c[(o + 1, o)], c[(o + 1, o + 1)]],
        ]
    })
}

/// The findings of a candidate's extensions.
pub fn findings(c: &Candidate, terms: &[SpeedTerms]) -> Vec<Finding> {
    let m = &c.model;
    let f = &c.fit;
    let param = &m.pr.param;
    let nom = m.pr.n_params();
    let mut out = Vec::new();
    if param.structure.order > 1 && c.effects.contains(&Effect::SpeedDependentBearing) {
        let w = m.pr.weights(&f.theta[..nom]);
        let lo = terms.iter().map(|t| t.omega).fold(f64::INFINITY, f64::min);
        let hi = terms.iter().map(|t| t.omega).fold(0.0, f64::max);
        let stiffness = (0..param.n_bearings())
            .filter_map(|b| {
                let kl = param.bearing(&w, b, lo)?.k;
                let kh = param.bearing(&w, b, hi)?.k;
                Some((param.bearing_nodes[b] + 1, kl.into(), kh.into()))
            })
            .collect();
        out.push(Finding::SpeedDependentBearing {
            order: param.structure.order,
            stiffness,
        });
    }
    for (k, ext) in m.ext.iter().enumerate() {
        let o = m.offset(k);
        match *ext {
            Extension::Runout => {
                let channels = (0..m.n_channels())
                    .map(|ch| {
                        let oo = o + 2 * ch;
                        let (a, p, sa, sp) =
                            polar_with_std(f.theta[oo], f.theta[oo + 1], m.scales.q, cov2(f, oo));
                        RunoutFinding {
                            channel: format!(
                                "b{}_{}",
                                ch / 2 + 1,
                                if ch % 2 == 0 { "y" } else { "z" }
                            ),
                            amplitude: a,
                            amplitude_std: sa,
                            phase_deg: p,
                            phase_deg_std: sp,
                            significant: a > 3.0 * sa,
                        }
                    })
                    .collect();
                out.push(Finding::ProbeRunout { channels });
            }
            Extension::Plane { node } => {
                let (a, p, sa, sp) = polar_with_std(
                    f.theta[o],
                    f.theta[o + 1],
                    param.scaling.unbalance,
                    cov2(f, o),
                );
                out.push(Finding::ExtraUnbalancePlane {
                    node: node + 1,
                    me: a,
                    me_std: sa,
                    phase_deg: p,
                    phase_deg_std: sp,
                });
            }
            Extension::Bow { node } => {
                let (a, p, sa, sp) =
                    polar_with_std(f.theta[o], f.theta[o + 1], m.scales.q, cov2(f, o));
                out.push(Finding::ShaftBow {
                    node: node + 1,
                    amplitude: a,
                    amplitude_std: sa,
                    phase_deg: p,
                    phase_deg_std: sp,
                });
            }
            Extension::EScale => {
                out.push(Finding::ShaftStiffnessError {
                    factor: c.e_terms + E_STEP * f.theta[o],
                    factor_std: E_STEP * f.std(o).unwrap_or(f64::NAN),
                });
            }
            Extension::Pedestal { bearing } => {
                let p = PedestalParams::from_scaled(&f.theta[o..o + 5], &m.scales);
                let (k, cc) = p.k_c();
                let sd = |i: usize| f.std(o + i).unwrap_or(f64::NAN);
                let hz = |w: f64| w / (2.0 * std::f64::consts::PI);
                out.push(Finding::FoundationFlexibility {
                    node: param
                        .bearing_nodes
                        .get(bearing)
                        .map_or(bearing + 1, |n| n + 1),
                    mass: p.mass,
                    mass_std: p.mass * sd(0),
                    natural_frequency_hz: [hz(p.omega[0]), hz(p.omega[1])],
                    natural_frequency_hz_std: [hz(p.omega[0]) * sd(1), hz(p.omega[1]) * sd(2)],
                    damping_ratio: p.zeta,
                    k,
                    c: cc,
                });
            }
        }
    }
    out
}

/// Bearings (at `omega`) and plane unbalances of a candidate, with
/// standard deviations, in the identification's result types.
pub fn estimates(c: &Candidate, omega: f64) -> (Vec<BearingResult>, Vec<UnbalanceResult>) {
    let m = &c.model;
    let param = &m.pr.param;
    let nom = m.pr.n_params();
    let w = m.pr.weights(&c.fit.theta[..nom]);
    let cov = c.fit.covariance.as_ref();
    // Physical structure: parameter i is unknown i (real).
    let fstd = |func: &[(usize, f64)]| -> f64 {
        cov.map_or(f64::NAN, |cv| {
            let mut v = 0.0;
            for &(i, gi) in func {
                for &(k, gk) in func {
                    v += gi * gk * cv[(i, k)];
                }
            }
            v.max(0.0).sqrt()
        })
    };
    let bearings = (0..param.n_bearings())
        .filter_map(|b| {
            let est = param.bearing(&w, b, omega)?;
            let ks: [f64; 4] =
                std::array::from_fn(|e| fstd(&param.stiffness_functional(b, e, omega)));
            let cs: [f64; 4] =
                std::array::from_fn(|e| fstd(&param.damping_functional(b, e, omega)));
            Some(BearingResult {
                node: param.bearing_nodes[b] + 1,
                k: est.k.into(),
                c: est.c.into(),
                check: None,
                std: cov.map(|_| BearingStd {
                    k: ks.into(),
                    c: cs.into(),
                }),
            })
        })
        .collect();
    let unbalance = (0..param.n_planes())
        .filter_map(|k| {
            let u = param.unbalance(&w, k)?;
            // Re and Im parameters of plane k.
            let (ir, ii) =
                (0..param.n_unknowns()).fold((None, None), |acc, j| match param.unknown(j) {
                    Some(rotorid_core::parametrization::Unknown::Unbalance { plane, part })
                        if plane == k =>
                    {
                        match part {
                            rotorid_core::parametrization::UnbalancePart::Re => (Some(j), acc.1),
                            rotorid_core::parametrization::UnbalancePart::Im => (acc.0, Some(j)),
                            rotorid_core::parametrization::UnbalancePart::Phasor => acc,
                        }
                    }
                    _ => acc,
                });
            let sd = match (ir, ii, cov) {
                (Some(a), Some(b), Some(cv)) => {
                    let s = param.scale(a);
                    let z = Complex64::new(w[a].re, w[b].re);
                    let c2 = [[cv[(a, a)], cv[(a, b)]], [cv[(b, a)], cv[(b, b)]]];
                    let (_, _, sa, sp) = polar_with_std(z.re, z.im, s, Some(c2));
                    Some((sa, sp))
                }
                _ => None,
            };
            Some(UnbalanceResult::new(param.plane_nodes[k] + 1, &u, sd))
        })
        .collect();
    (bearings, unbalance)
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
