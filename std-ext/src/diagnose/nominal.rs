//! The nominal model (module docs of [`crate::diagnose`], step 1): the
//! noise model, weights and scales every fit of the diagnosis shares
//! (`Setup`), the output-error estimate of the nominal parameters
//! (QRD/RLS start, then the output-error fit) and its polish on the
//! diagnosis objective; the maps of nominal parameters onto other bearing
//! laws ([`map_theta`]) and from the model's own bearings
//! (`theta_from_model`); the rotor's mass the scales rest on
//! ([`rotor_mass`]).

use std::collections::HashMap;

use nalgebra::DMatrix;
use num_complex::Complex64;

use crate::diagnose::candidate::Candidate;
use crate::diagnose::extended::{ExtendedModel, Scales};
use crate::diagnose::fit::{self, FitData};
use crate::diagnose::input::{DiagnoseError, DiagnoseOptions};
use crate::diagnose::terms::SpeedTerms;
use crate::estimate::noise::NoiseModel;
use crate::estimate::output_error::{fit_output_error_with, FitNoise, OutputErrorOptions};
use crate::estimate::predictor::{Predictor, Terms};
use crate::estimate::{identify_with, IdentifyError, Options};
use crate::io::measurement::{Measurements, Sample};
use crate::model::RotorModel;
use crate::tables::auto_scaling;
use rotorid_core::parametrization::Structure;
use rotorid_core::scaling::ColumnScaling;

/// What every fit of the diagnosis shares, settled before the nominal fit:
/// the noise model and the weights it gives, the scales of the extension
/// parameters, and the output-error estimate the nominal fit starts from.
pub(crate) struct Setup {
    /// The nominal bearing law (`physical`, the options' order).
    pub structure: Structure,
    /// The identification's column scaling at the top measured speed.
    pub scaling: ColumnScaling<f64>,
    /// The noise model the fits are weighted with (SPEC section 7).
    pub noise_model: Option<NoiseModel>,
    /// The probes' floors per channel in relative units, `phi_c = f_c / s`
    /// (m; empty: proportional noise).
    pub phi: Vec<f64>,
    /// The model-free relative noise level `s`, when known.
    pub noise_level: Option<f64>,
    /// Real equations: `2 x 2 N_b` per sample.
    pub n_real: usize,
    /// Reference magnitudes of the extension parameters.
    pub scales: Scales,
    /// The nominal predictor.
    pub pr: Predictor,
    /// The output-error estimate of its scaled parameters.
    pub oe_theta: Vec<f64>,
}

impl Setup {
    /// The diagnosis's noise model, held as it stands by the fit it
    /// weights ([`StartNoise`]).
    pub(crate) fn held_noise(&self) -> StartNoise<'_> {
        StartNoise {
            model: self.noise_model.as_ref(),
            refine: false,
        }
    }

    /// The nominal output-error estimate on `samples` with the model's own
    /// `terms`, the noise model (model-free, its relative part refined by
    /// that fit where a floor is known), and the scales: `q` the RMS
    /// reading (m; `1e-6` when all are zero), `mass` the rotor's mass per
    /// bearing (kg), `omega` the top speed `omega_max` (rad/s).
    pub(crate) fn new(
        model: &RotorModel,
        samples: &[Sample],
        terms: &[SpeedTerms],
        opts: &DiagnoseOptions,
        omega_max: f64,
    ) -> Result<Self, DiagnoseError> {
        let nb = model.bearings.len();
        let structure = Structure::physical(opts.order);
        let scaling = auto_scaling(model, omega_max);
        // The noise model: model-free, its relative part refined by the nominal
        // output-error fit where a floor leaves it to the few samples near the
        // critical speeds (the same rule as `identify`).
        let reference = crate::estimate::noise::estimate_noise(samples, opts.noise_floor);
        let (pr, oe_theta, fitted) = oe_start(
            model,
            samples,
            terms,
            structure,
            scaling,
            StartNoise {
                model: reference.as_ref(),
                refine: true,
            },
        )?;
        // A runout the slow roll shows plainly: the noise model refined by
        // the nominal fit with the runout among its unknowns (as `identify`
        // does by default), not by a fit that must misfit the low speeds.
        let fitted =
            match crate::estimate::sweep::slow_roll_estimate(samples).filter(|e| e.significant()) {
                Some(e) => match oe_start_with_runout(
                    model,
                    samples,
                    terms,
                    structure,
                    scaling,
                    StartNoise {
                        model: reference.as_ref(),
                        refine: true,
                    },
                    Some(&e.runout),
                ) {
                    Ok((_, _, f, _)) => f.or(fitted),
                    Err(_) => fitted,
                },
                None => fitted,
            };
        // Each part of the noise model is the smaller of the two reads (a
        // model that misfits reads its misfit as noise); a channel whose
        // model-free floor reads zero (its readings dominated by runout)
        // takes the fitted one; the relative part is at least
        // [`MIN_RELATIVE_NOISE`].
        let noise_model = match (reference, fitted) {
            (Some(r), Some(f)) if r.has_floor() => Some(NoiseModel {
                relative: f.relative.min(r.relative).max(MIN_RELATIVE_NOISE),
                floor_m: r
                    .floor_m
                    .iter()
                    .zip(f.floor_m.iter().chain(std::iter::repeat(&0.0)))
                    .map(|(&a, &b)| match (a > 0.0, b > 0.0) {
                        (true, true) => a.min(b),
                        (true, false) => a,
                        _ => b.max(0.0),
                    })
                    .collect(),
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
        Ok(Setup {
            structure,
            scaling,
            noise_model,
            phi,
            noise_level,
            n_real,
            scales,
            pr,
            oe_theta,
        })
    }
}

/// The nominal model (`base`, no extension) and its fit on the diagnosis
/// objective from the output-error estimate, as the candidate every
/// hypothesis is judged against; refused when the real equations do not
/// outnumber its parameters.
pub(crate) fn fit_nominal(
    setup: &Setup,
    data: &FitData<'_>,
    opts: &DiagnoseOptions,
) -> Result<(ExtendedModel, Candidate), DiagnoseError> {
    let base = ExtendedModel {
        pr: setup.pr.clone(),
        ext: Vec::new(),
        scales: setup.scales,
        relative_probes: opts.relative_probes,
    };
    let nominal_fit = fit::fit(&base, data, &setup.oe_theta, 50)?;
    if setup.n_real <= nominal_fit.n_params() {
        return Err(DiagnoseError::Input(format!(
            "{} real equations for {} nominal parameters: too few speeds to diagnose",
            setup.n_real,
            nominal_fit.n_params()
        )));
    }
    let nominal = Candidate::new(
        Vec::new(),
        format!("nominal (physical order {})", opts.order),
        base.clone(),
        nominal_fit,
        1.0,
        1,
    );
    Ok((base, nominal))
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

/// The least relative noise the diagnosis assumes when the probes have a
/// floor (0.1 %: the calibration and linearity tolerance of a proximity
/// probe chain). The fits' misfits are in units relative to it; without
/// this bound a floor that explains every sample drives the relative part
/// to zero and the floor to infinity in those units.
pub const MIN_RELATIVE_NOISE: f64 = 1e-3;

/// The output-error estimate of the nominal parameters on `samples` with
/// the terms `terms` (same order): QRD/RLS start, then
/// [`fit_output_error_with`]. Returns the predictor and its scaled parameters.
pub(crate) fn oe_start(
    model: &RotorModel,
    samples: &[Sample],
    terms: &[SpeedTerms],
    structure: Structure,
    scaling: ColumnScaling<f64>,
    noise: StartNoise<'_>,
) -> Result<(Predictor, Vec<f64>, Option<NoiseModel>), DiagnoseError> {
    oe_start_with_runout(model, samples, terms, structure, scaling, noise, None)
        .map(|(pr, theta, noise, _)| (pr, theta, noise))
}

/// The noise model an output-error start is weighted by, when the data
/// show a floor (`None`: proportional weights), and whether the fit
/// refines its variance parameters: the nominal fit does (it settles the
/// diagnosis's noise model); the bank's starts hold it as it stands (their
/// fits are weighted by the diagnosis's model anyway, and a refinement
/// costs a second and third polish).
#[derive(Debug, Clone, Copy)]
pub(crate) struct StartNoise<'a> {
    /// The noise model.
    pub model: Option<&'a NoiseModel>,
    /// Refine its variance parameters.
    pub refine: bool,
}

/// What [`oe_start_with_runout`] returns: the predictor, the scaled
/// parameters, the refined noise model and the fitted runout per channel
/// (m; empty without a runout start).
pub(crate) type RunoutStart = (Predictor, Vec<f64>, Option<NoiseModel>, Vec<Complex64>);

/// [`oe_start`] with a runout phasor per channel fitted beside the nominal
/// parameters, from `runout` (m): the filter sees the samples less
/// `runout`, the output-error fit the samples as measured with the runout
/// among its unknowns (linearised in its instrumental-variable passes,
/// [`crate::estimate::output_error`]), as `identify` does by default.
pub(crate) fn oe_start_with_runout(
    model: &RotorModel,
    samples: &[Sample],
    terms: &[SpeedTerms],
    structure: Structure,
    scaling: ColumnScaling<f64>,
    noise: StartNoise<'_>,
    runout: Option<&[Complex64]>,
) -> Result<RunoutStart, DiagnoseError> {
    let StartNoise {
        model: noise,
        refine,
    } = noise;
    let mut o = Options::new(structure);
    o.scaling = Some(scaling);
    // A start needs the weights only: no path, no covariance.
    o.record_history = false;
    o.covariance = false;
    let index: HashMap<u64, usize> = terms
        .iter()
        .enumerate()
        .map(|(i, t)| (t.omega.to_bits(), i))
        .collect();
    let mut serve = |w: f64| -> Result<(DMatrix<Complex64>, DMatrix<Complex64>), IdentifyError> {
        let i = index.get(&w.to_bits()).copied().unwrap_or(0);
        Ok((terms[i].a.clone(), terms[i].b.clone()))
    };
    let seen: Vec<Sample> = match runout {
        Some(r) => samples
            .iter()
            .map(|s| Sample {
                omega: s.omega,
                q: s.q.iter().zip(r).map(|(y, r)| y - r).collect(),
            })
            .collect(),
        None => samples.to_vec(),
    };
    let meas = Measurements {
        comments: Vec::new(),
        n_bearings: model.bearings.len(),
        samples: seen,
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
    let runout = runout.map(<[Complex64]>::to_vec);
    let fit = |noise: FitNoise| {
        fit_output_error_with(
            &pr,
            samples,
            &oe_terms,
            &id.scaled_weights,
            &OutputErrorOptions::default(),
            &noise,
        )
    };
    // Proportional weights (with the runout unknowns when started from one).
    let proportional = || {
        fit(FitNoise {
            runout: runout.clone(),
            ..Default::default()
        })
    };
    // With a floor, the fit under the noise model; where it cannot be
    // done (a model far from the data can make its weighted normal
    // equations singular), the proportional fit, and the noise model as
    // estimated without the model.
    let oe = match noise.filter(|m| m.has_floor()) {
        Some(m) => fit(FitNoise {
            model: Some(m.clone()),
            refine,
            // A bank's start: the hypothesis's fit goes on from it.
            stall: !refine,
            runout: runout.clone(),
            ..Default::default()
        })
        .or_else(|_| proportional())?,
        None => proportional()?,
    };
    Ok((pr, oe.theta, oe.noise, oe.runout))
}
