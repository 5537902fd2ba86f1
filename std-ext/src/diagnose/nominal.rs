//! What the nominal model's fits rest on: the output-error estimate of the
//! nominal parameters (QRD/RLS start, then the output-error fit), the maps
//! of nominal parameters onto other bearing laws ([`map_theta`]) and from
//! the model's own bearings (`theta_from_model`), and the rotor's mass the
//! scales rest on ([`rotor_mass`]).

use std::collections::HashMap;

use nalgebra::DMatrix;
use num_complex::Complex64;

use crate::diagnose::input::DiagnoseError;
use crate::diagnose::terms::SpeedTerms;
use crate::estimate::noise::NoiseModel;
use crate::estimate::output_error::{fit_output_error, OutputErrorOptions};
use crate::estimate::predictor::{Predictor, Terms};
use crate::estimate::{identify_with, IdentifyError, Options};
use crate::io::measurement::{Measurements, Sample};
use crate::model::RotorModel;
use rotorid_core::parametrization::Structure;
use rotorid_core::scaling::ColumnScaling;

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

/// The output-error estimate of the nominal parameters on `samples` with
/// the terms `terms` (same order): QRD/RLS start, then
/// [`fit_output_error`]. Returns the predictor and its scaled parameters.
pub(crate) fn oe_start(
    model: &RotorModel,
    samples: &[Sample],
    terms: &[SpeedTerms],
    structure: Structure,
    scaling: ColumnScaling<f64>,
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
