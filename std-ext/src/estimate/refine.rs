//! The QRD/RLS estimate refined by the output-error fit, with the noise
//! level, the model-fit check and the warnings an engineer must see.
//!
//! After [`refine`], an [`Identification`] reports the output-error
//! estimate (`last`, `scaled_weights`, `covariance`) and keeps the QRD/RLS
//! estimate beside it ([`Refinement::rls`]).
//!
//! # Model-fit check
//!
//! The relative noise level `s` is estimated without the model
//! ([`relative_noise_level`]); the fit's own residual gives
//! `s_fit^2 = S / (N - P/2)`. When the model describes the data,
//! `chi^2 / dof = s_fit^2 / s^2` is 1 within a few percent; a model that
//! lacks something leaves a systematic residual and a ratio well above 1,
//! whatever the standard deviations say: above [`MISFIT_CHI2`] (and above
//! a relative misfit of [`PERFECT_FIT`]) the result carries a warning
//! naming the misfit.
//!
//! # Undetermined parameters
//!
//! The design analysis of the fit ([`crate::estimate::design`]) names the
//! parameters the data leave undetermined; a warning lists them (and says
//! so when the Fisher information could not be analysed).

use nalgebra::DMatrix;
use num_complex::Complex64;

use crate::estimate::noise::{
    estimate_noise, noise_from_points, relative_noise_level, NoiseModel, NoiseSource, VariancePoint,
};
use crate::estimate::output_error::{
    fit_output_error_with, misfit_weighted, FitNoise, OutputErrorError, OutputErrorOptions,
    Weighting, MAX_OUTLIER_FRACTION,
};
use crate::estimate::predictor::{Predictor, Terms};
use crate::estimate::{EstimateSet, Identification};
use crate::io::measurement::Sample;

/// `chi^2 / dof` above which the model is said not to fit the data.
pub const MISFIT_CHI2: f64 = 2.0;

/// A relative misfit below this is a fit to round-off, whatever the noise
/// estimate of noise-free data says.
pub const PERFECT_FIT: f64 = 1e-6;

/// How well the reported estimate explains the data.
#[derive(Debug, Clone, PartialEq)]
pub struct FitCheck {
    /// The relative noise level estimated without the model, when the
    /// speeds allow it.
    pub noise_level: Option<f64>,
    /// The relative RMS misfit of the reported estimate.
    pub residual: f64,
    /// `s_fit^2 / s^2` (see the module documentation).
    pub chi2_per_dof: Option<f64>,
    /// One line each: what an engineer must know before trusting the result.
    pub warnings: Vec<String>,
    /// The noise model the estimate was weighted with (SPEC section 7).
    pub noise: Option<NoiseModel>,
    /// The samples excluded as outliers.
    pub outliers: Vec<OutlierReport>,
}

/// A sample excluded as an outlier, as reported.
#[derive(Debug, Clone, PartialEq)]
pub struct OutlierReport {
    /// Index of the sample in the measurement (0-based).
    pub sample: usize,
    /// Its speed (rad/s).
    pub omega: f64,
    /// Its channel (index, `b1_y, b1_z, b2_y, ...`).
    pub channel: usize,
    /// Its residual in standard deviations of the noise model.
    pub sigmas: f64,
}

impl FitCheck {
    /// The check of an estimate with residual noise `s_fit` and misfit
    /// `residual` on `samples` (proportional noise).
    pub fn new(samples: &[Sample], residual: f64, s_fit: f64) -> Self {
        let noise_level = relative_noise_level(samples);
        let chi2_per_dof = noise_level
            .filter(|s| *s > 0.0)
            .map(|s| (s_fit / s).powi(2));
        Self::with_chi2(noise_level, residual, s_fit, chi2_per_dof, None)
    }

    /// The check with `chi2_per_dof` computed against `noise` (the
    /// model-free estimate, relative part `noise_level`).
    pub fn with_chi2(
        noise_level: Option<f64>,
        residual: f64,
        s_fit: f64,
        chi2_per_dof: Option<f64>,
        noise: Option<NoiseModel>,
    ) -> Self {
        let mut warnings = Vec::new();
        match (noise_level, chi2_per_dof) {
            (Some(s), Some(chi2)) if chi2 > MISFIT_CHI2 && s_fit > PERFECT_FIT => warnings.push(format!(
                "residual {:.1}x the noise level ({:.2e} against {:.2e}): the model lacks something; `rotorid diagnose` looks for what",
                chi2.sqrt(),
                s * chi2.sqrt(),
                s
            )),
            (None, _) => warnings.push(
                "too few speeds to estimate the noise level without the model: the fit cannot be checked"
                    .to_string(),
            ),
            _ => {}
        }
        FitCheck {
            noise_level,
            residual,
            chi2_per_dof,
            warnings,
            noise,
            outliers: Vec::new(),
        }
    }
}

/// How the noise of the measurements is described to the identification.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct NoiseSetup {
    /// The probes' noise floor (m, every channel), e.g. from a data sheet;
    /// `None`: estimated from the data.
    pub floor: Option<f64>,
    /// Per-sample standard deviations (m) at `n * nq + c`, from the
    /// measurement file's `_std` columns.
    pub sample_std: Option<Vec<f64>>,
    /// Exclude the samples the noise model cannot explain (glitches).
    pub outliers: bool,
    /// Fit a runout phasor per channel from these start values (m).
    pub runout: Option<Vec<Complex64>>,
}

impl NoiseSetup {
    /// The noise model of `samples` without the rotor model: the file's
    /// standard deviations summarised as floor and relative part, or the
    /// model-free estimate ([`estimate_noise`]) with the given floor.
    pub fn reference(&self, samples: &[Sample]) -> Option<NoiseModel> {
        match &self.sample_std {
            Some(std) => {
                let nq = samples.first()?.q.len();
                let points: Vec<VariancePoint> = samples
                    .iter()
                    .enumerate()
                    .flat_map(|(n, s)| {
                        s.q.iter().enumerate().map(move |(c, q)| {
                            VariancePoint::known(
                                c,
                                std.get(n * nq + c).map_or(0.0, |x| x * x),
                                q.norm_sqr(),
                            )
                        })
                    })
                    .collect();
                let m = noise_from_points(&points, nq, None)?;
                Some(NoiseModel {
                    source: NoiseSource::File,
                    ..m
                })
            }
            // A runout fitted: the model-free estimate on the data less its
            // start, so that the relative part reads the shaft's vibration
            // (a constant runout would otherwise pass for a relative part
            // as large as floor / runout).
            None => match &self.runout {
                Some(r0) => {
                    let shifted: Vec<Sample> = samples
                        .iter()
                        .map(|s| Sample {
                            omega: s.omega,
                            q: s.q.iter().zip(r0).map(|(q, r)| q - r).collect(),
                        })
                        .collect();
                    estimate_noise(&shifted, self.floor)
                }
                None => estimate_noise(samples, self.floor),
            },
        }
    }
}

/// What the output-error refinement found.
#[derive(Debug, Clone, PartialEq)]
pub struct Refinement {
    /// The QRD/RLS estimate it started from (bearings at the last speed).
    pub rls: EstimateSet,
    /// The QRD/RLS scaled weights.
    pub rls_weights: Vec<Complex64>,
    /// Levenberg-Marquardt iterations.
    pub iterations: usize,
    /// Whether the fit converged.
    pub converged: bool,
    /// What these speeds determine and what would help
    /// ([`crate::estimate::design`]).
    pub design: Option<crate::estimate::design::TestDesign>,
    /// The fitted runout phasor per channel (m) with its standard deviation
    /// `sqrt(E|dr|^2)` (m); empty unless fitted.
    pub runout: Vec<(Complex64, f64)>,
}

/// Checks the (QRD/RLS) estimate of `id` against `samples` without refining
/// it: sets [`Identification::check`].
pub fn check(
    id: &mut Identification,
    samples: &[Sample],
    terms: &[Terms],
    setup: &NoiseSetup,
) -> Result<(), OutputErrorError> {
    let pr = Predictor::new(id.param.clone());
    let floor = OutputErrorOptions::default().floor;
    let reference = setup.reference(samples);
    let weighting = weighting_of(samples, floor, setup, reference.as_ref());
    let (residual, s_fit) = misfit_weighted(&pr, samples, terms, &id.scaled_weights, &weighting)?;
    let noise_level = noise_level_of(samples, reference.as_ref());
    let chi2 = reference_chi2(reference.as_ref(), setup, s_fit);
    id.check = Some(FitCheck::with_chi2(
        noise_level,
        residual,
        s_fit,
        chi2,
        reference,
    ));
    Ok(())
}

/// The weights of `setup` (fixed by the file's standard deviations, or
/// of the noise model).
fn weighting_of(
    samples: &[Sample],
    floor: f64,
    setup: &NoiseSetup,
    reference: Option<&NoiseModel>,
) -> Weighting {
    match (&setup.sample_std, reference) {
        (Some(std), _) => Weighting::fixed(samples, floor, std.clone()),
        (None, Some(m)) => Weighting::of_noise(samples, floor, m),
        (None, None) => Weighting::proportional(samples, floor),
    }
}

/// The relative noise level reported (`noise_level`): the model-free
/// estimate of SPEC section 4's `s` when the noise is proportional, the
/// relative part of the noise model otherwise.
fn noise_level_of(samples: &[Sample], reference: Option<&NoiseModel>) -> Option<f64> {
    match reference {
        Some(m) if m.has_floor() || m.source == NoiseSource::File => Some(m.relative),
        _ => relative_noise_level(samples),
    }
}

/// The relative noise level reported after the fit: the model-free one
/// where the data determine it without the model, the fit's otherwise.
fn fitted_noise_level(
    samples: &[Sample],
    reference: Option<&NoiseModel>,
    fitted: Option<&NoiseModel>,
) -> Option<f64> {
    match (reference, fitted) {
        (Some(r), Some(f)) if r.has_floor() => Some(f.relative.min(r.relative)),
        _ => noise_level_of(samples, reference),
    }
}

/// `chi^2 / dof` of a misfit `s_fit` (relative units of the weights)
/// against the reference noise model: `(s_fit / s)^2`, and for the file's
/// standard deviations (weights in metres) `s_fit^2`.
fn reference_chi2(reference: Option<&NoiseModel>, setup: &NoiseSetup, s_fit: f64) -> Option<f64> {
    if setup.sample_std.is_some() {
        return Some(s_fit * s_fit);
    }
    reference
        .filter(|m| m.relative > 0.0)
        .map(|m| (s_fit / m.relative.max(crate::estimate::noise::MIN_RELATIVE)).powi(2))
}

/// Refines `id` (a QRD/RLS identification of `samples`, with their
/// reduced `terms` in the same order) by the output-error fit, with the
/// noise described by `setup`.
pub fn refine(
    id: &mut Identification,
    samples: &[Sample],
    terms: &[Terms],
    setup: &NoiseSetup,
) -> Result<(), OutputErrorError> {
    let pr = Predictor::new(id.param.clone());
    let opts = OutputErrorOptions::default();
    let reference = setup.reference(samples);
    let noise = FitNoise {
        model: reference.clone(),
        refine: setup.sample_std.is_none(),
        sample_std: setup.sample_std.clone(),
        outliers: setup.outliers,
        runout: setup.runout.clone(),
        reference: reference.clone(),
        stall: false,
    };
    // Where the fit under the noise model cannot be done (its weighted
    // normal equations singular), the proportional fit, with a warning.
    let (fit, fallback) =
        match fit_output_error_with(&pr, samples, terms, &id.scaled_weights, &opts, &noise) {
            Ok(f) => (f, None),
            Err(e @ (OutputErrorError::Singular | OutputErrorError::Predict(_)))
                if noise.model.as_ref().is_some_and(|m| m.has_floor()) =>
            {
                let plain = FitNoise {
                    outliers: setup.outliers,
                    ..FitNoise::default()
                };
                let f =
                    fit_output_error_with(&pr, samples, terms, &id.scaled_weights, &opts, &plain)?;
                (f, Some(e))
            }
            Err(e) => return Err(e),
        };
    let noise_level = fitted_noise_level(samples, reference.as_ref(), fit.noise.as_ref());
    let chi2 = if setup.sample_std.is_some() {
        Some(fit.residual_noise * fit.residual_noise)
    } else {
        fit.chi2_per_dof
    };
    let reported = if setup.sample_std.is_some() {
        reference.clone()
    } else {
        fit.noise.clone()
    };
    let mut check = FitCheck::with_chi2(
        noise_level,
        fit.residual,
        fit.residual_noise,
        chi2,
        reported,
    );
    check.outliers = fit
        .outliers
        .iter()
        .map(|o| OutlierReport {
            sample: o.sample,
            omega: samples.get(o.sample).map_or(0.0, |s| s.omega),
            channel: o.channel,
            sigmas: o.sigmas,
        })
        .collect();
    let n_all = samples.len() * samples.first().map_or(0, |s| s.q.len());
    if fit.outliers_capped {
        check.warnings.push(format!(
            "more than {:.0} % of the samples lie beyond the noise model ({} excluded as outliers, more remain): the noise model does not describe these data",
            100.0 * MAX_OUTLIER_FRACTION,
            fit.outliers.len()
        ));
    } else if fit.outliers.len() as f64 > OUTLIER_WARNING * n_all as f64 {
        check.warnings.push(format!(
            "{} of {} samples ({:.1} %) excluded as outliers: more than a few per cent, the noise model does not describe these data",
            fit.outliers.len(),
            n_all,
            100.0 * fit.outliers.len() as f64 / n_all.max(1) as f64
        ));
    }
    if let Some(e) = fallback {
        check.warnings.push(format!(
            "the fit under the probe noise model could not be done ({e}): the estimate is the proportional-noise fit's, and its standard deviations ignore the floor"
        ));
    }
    if !fit.converged {
        check.warnings.insert(
            0,
            format!(
                "the output-error fit did not converge in {} iterations: the estimate may be a local minimum",
                fit.iterations
            ),
        );
    }
    // The reported estimate becomes the output-error one.
    let omega = id.last.omega;
    let p = &pr.param;
    let bearings = (0..p.n_bearings())
        .map(|m| p.bearing(&fit.weights, m, omega))
        .collect::<Option<Vec<_>>>()
        .ok_or(OutputErrorError::Dimension)?;
    let unbalance = (0..p.n_planes())
        .map(|k| p.unbalance(&fit.weights, k))
        .collect::<Option<Vec<_>>>()
        .ok_or(OutputErrorError::Dimension)?;
    let rls = std::mem::replace(
        &mut id.last,
        EstimateSet {
            omega,
            bearings,
            unbalance,
        },
    );
    let rls_weights = std::mem::replace(&mut id.scaled_weights, fit.weights.clone());
    id.covariance = Some(weight_covariance(&pr, &fit.covariance));
    let noise = check.noise_level.unwrap_or(fit.residual_noise);
    let design_noise = match &fit.noise {
        Some(m) if setup.sample_std.is_none() => Some(m),
        _ => reference.as_ref(),
    };
    let design = crate::estimate::design::analyse_weighted(
        &pr,
        samples,
        terms,
        &fit.theta,
        noise,
        design_noise.filter(|m| m.has_floor()),
    );
    match &design {
        Ok(d) if !d.undetermined.is_empty() => check.warnings.push(undetermined_warning(d)),
        Ok(_) => {}
        Err(e) => check.warnings.push(format!(
            "the Fisher information could not be analysed ({e}): which parameters these data determine is not known"
        )),
    }
    let design = design.ok();
    id.refinement = Some(Refinement {
        rls,
        rls_weights,
        iterations: fit.iterations,
        converged: fit.converged,
        design,
        runout: fit
            .runout
            .iter()
            .zip(&fit.runout_std)
            .map(|(r, s)| (*r, *s))
            .collect(),
    });
    id.check = Some(check);
    Ok(())
}

/// Outliers above this fraction of the samples draw a warning.
pub const OUTLIER_WARNING: f64 = 0.02;

/// The warning naming the parameters `d` finds undetermined.
fn undetermined_warning(d: &crate::estimate::design::TestDesign) -> String {
    format!(
        "these data do not determine {}: Cramér-Rao bound above {:.0} % of the parameter's magnitude, or in a combination of parameters the speeds do not see; do not use their values",
        d.undetermined.join(", "),
        100.0 * crate::estimate::design::UNKNOWN_MAGNITUDE
    )
}

/// The covariance of the complex scaled weights, `E[dw dw^H]`, from that
/// of the real parameters (`w = x + j y`:
/// `C_xx + C_yy + j (C_yx - C_xy)`).
fn weight_covariance(pr: &Predictor, cov: &DMatrix<f64>) -> DMatrix<Complex64> {
    let m = pr.param.n_unknowns();
    let mut out = DMatrix::<Complex64>::zeros(m, m);
    for (i, pi) in pr.params.iter().enumerate() {
        for (k, pk) in pr.params.iter().enumerate() {
            let c = cov[(i, k)];
            let z = match (pi.imaginary, pk.imaginary) {
                (false, false) | (true, true) => Complex64::new(c, 0.0),
                // E[y_j x_k] enters with +j, E[x_j y_k] with -j.
                (true, false) => Complex64::new(0.0, c),
                (false, true) => Complex64::new(0.0, -c),
            };
            out[(pi.unknown, pk.unknown)] += z;
        }
    }
    out
}
