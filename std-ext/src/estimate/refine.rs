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

use crate::estimate::noise::relative_noise_level;
use crate::estimate::output_error::{fit_output_error, OutputErrorError, OutputErrorOptions};
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
}

impl FitCheck {
    /// The check of an estimate with residual noise `s_fit` and misfit
    /// `residual` on `samples`.
    pub fn new(samples: &[Sample], residual: f64, s_fit: f64) -> Self {
        let noise_level = relative_noise_level(samples);
        let chi2_per_dof = noise_level
            .filter(|s| *s > 0.0)
            .map(|s| (s_fit / s).powi(2));
        let mut warnings = Vec::new();
        match (noise_level, chi2_per_dof) {
            (Some(s), Some(chi2)) if chi2 > MISFIT_CHI2 && s_fit > PERFECT_FIT => warnings.push(format!(
                "residual {:.1}x the noise level ({:.2e} against {:.2e}): the model lacks something; `rotorid diagnose` looks for what",
                chi2.sqrt(),
                s_fit,
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
}

/// Checks the (QRD/RLS) estimate of `id` against `samples` without refining
/// it: sets [`Identification::check`].
pub fn check(
    id: &mut Identification,
    samples: &[Sample],
    terms: &[Terms],
) -> Result<(), OutputErrorError> {
    let pr = Predictor::new(id.param.clone());
    let (residual, s_fit) = crate::estimate::output_error::misfit(
        &pr,
        samples,
        terms,
        &id.scaled_weights,
        OutputErrorOptions::default().floor,
    )?;
    id.check = Some(FitCheck::new(samples, residual, s_fit));
    Ok(())
}

/// Refines `id` (a QRD/RLS identification of `samples`, with their
/// reduced `terms` in the same order) by the output-error fit.
pub fn refine(
    id: &mut Identification,
    samples: &[Sample],
    terms: &[Terms],
) -> Result<(), OutputErrorError> {
    let pr = Predictor::new(id.param.clone());
    let opts = OutputErrorOptions::default();
    let fit = fit_output_error(&pr, samples, terms, &id.scaled_weights, &opts)?;
    let mut check = FitCheck::new(samples, fit.residual, fit.residual_noise);
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
    let design = crate::estimate::design::analyse(&pr, samples, terms, &fit.theta, noise);
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
    });
    id.check = Some(check);
    Ok(())
}

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
