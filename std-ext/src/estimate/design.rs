//! Design of the test from the Fisher information: which parameters the
//! measured speeds pin down and which they do not, where in the speed
//! range each parameter's information comes from, and what a better test
//! would gain.
//!
//! With `F = sum_n F_n` the Fisher information per unit noise of the
//! output-error fit ([`fisher_information`]; `F_n` the contribution of
//! speed `n`) and `s` the relative noise level, the Cramér-Rao bound of
//! parameter `i` is `s sqrt((F^-1)_ii)`. Each parameter's information
//! `(F_n)_ii` is accumulated over the speeds sorted by speed; the band
//! between 10 % and 90 % of it is where that parameter is measured. The
//! gain of a denser test in a band (twice the speeds there, e.g. a slower
//! sweep) is exact under the model: the information of the band is added
//! once more, `F' = F + F_band`, and the bounds recomputed.

use nalgebra::DMatrix;

use crate::estimate::output_error::{fisher_information, OutputErrorError};
use crate::estimate::predictor::{Predictor, Terms};
use crate::io::measurement::Sample;
use crate::units::rad_s_to_rpm;

/// Cramér-Rao bound, relative to the parameter's reference magnitude, above
/// which a parameter is said not to be determined by the data. The
/// reference is the larger direct term (`yy`, `zz`) of the same kind of the
/// same bearing for a bearing coefficient (a cross term near zero is
/// determined when it is known well against the direct terms), `|a|` of the
/// plane for an unbalance part.
pub const UNDETERMINED: f64 = 0.1;

/// Correlation above which two parameters are said hard to separate.
pub const CORRELATED: f64 = 0.95;

/// One parameter's information.
#[derive(Debug, Clone, PartialEq)]
pub struct ParameterDesign {
    /// Its name (see `Parametrization::name`; complex unknowns get `re`/`im`).
    pub name: String,
    /// Its value (SI).
    pub value: f64,
    /// Cramér-Rao bound at the noise level (SI).
    pub crb: f64,
    /// The magnitude it is judged against (SI, see [`UNDETERMINED`]).
    pub reference: f64,
    /// Speeds (rpm) between which the central 80 % of its information lies.
    pub band_rpm: (f64, f64),
}

/// The analysis of a test.
#[derive(Debug, Clone, PartialEq)]
pub struct TestDesign {
    /// Per parameter.
    pub parameters: Vec<ParameterDesign>,
    /// Pairs of parameters with `|correlation| > CORRELATED`.
    pub correlated: Vec<(String, String, f64)>,
    /// One line each: what the data cannot pin down and what would help.
    pub notes: Vec<String>,
}

/// The design analysis of `samples` (with their `terms`) at the estimate
/// `theta` and relative noise level `noise`.
pub fn analyse(
    pr: &Predictor,
    samples: &[Sample],
    terms: &[Terms],
    theta: &[f64],
    noise: f64,
) -> Result<TestDesign, OutputErrorError> {
    let np = pr.n_params();
    let floor = 1e-6;
    let total = fisher_information(pr, samples, terms, theta, floor)?;
    let cov = invert(&total).ok_or(OutputErrorError::Singular)?;
    // Per-speed diagonals, in speed order.
    let mut order: Vec<usize> = (0..samples.len()).collect();
    order.sort_by(|&a, &b| samples[a].omega.total_cmp(&samples[b].omega));
    let mut diag = Vec::with_capacity(samples.len());
    for &n in &order {
        let f = fisher_information(
            pr,
            std::slice::from_ref(&samples[n]),
            std::slice::from_ref(&terms[n]),
            theta,
            floor,
        )?;
        diag.push((0..np).map(|i| f[(i, i)]).collect::<Vec<f64>>());
    }
    let scale = |i: usize| pr.param.scale(pr.params[i].unknown);
    let name = |i: usize| {
        let base = pr.param.name(pr.params[i].unknown);
        if pr.param.structure.is_complex() {
            format!(
                "{base} {}",
                if pr.params[i].imaginary { "im" } else { "re" }
            )
        } else {
            base
        }
    };
    let w = pr.weights(theta);
    let physical = |j: usize| w[j] * pr.param.scale(j);
    let nb = pr.param.n_bearings();
    let reference = |i: usize| -> f64 {
        use rotorid_core::parametrization::Unknown;
        let st = &pr.param.structure;
        match pr.param.unknown(pr.params[i].unknown) {
            Some(Unknown::Bearing { bearing, term, .. }) => [(0, 0), (1, 1)]
                .iter()
                .filter_map(|&(r, c)| st.bearing_index(bearing, r, c, term))
                .map(|j| physical(j).norm())
                .fold(0.0, f64::max),
            Some(Unknown::Unbalance { plane, .. }) => {
                let j = st.plane_index(nb, plane);
                if st.is_complex() {
                    physical(j).norm()
                } else {
                    physical(j).re.hypot(physical(j + 1).re)
                }
            }
            None => 0.0,
        }
    };
    let mut parameters = Vec::with_capacity(np);
    for i in 0..np {
        let sum: f64 = diag.iter().map(|d| d[i]).sum();
        let (mut lo, mut hi, mut acc) = (None, None, 0.0);
        for (k, d) in diag.iter().enumerate() {
            acc += d[i];
            let rpm = rad_s_to_rpm(samples[order[k]].omega);
            if lo.is_none() && acc >= 0.1 * sum {
                lo = Some(rpm);
            }
            if hi.is_none() && acc >= 0.9 * sum {
                hi = Some(rpm);
            }
        }
        parameters.push(ParameterDesign {
            name: name(i),
            value: theta[i] * scale(i),
            crb: noise * cov[(i, i)].max(0.0).sqrt() * scale(i),
            reference: reference(i),
            band_rpm: (lo.unwrap_or(0.0), hi.unwrap_or(0.0)),
        });
    }
    let mut correlated = Vec::new();
    for i in 0..np {
        for k in i + 1..np {
            let r = cov[(i, k)] / (cov[(i, i)] * cov[(k, k)]).sqrt();
            if r.abs() > CORRELATED {
                correlated.push((name(i), name(k), r));
            }
        }
    }
    let mut notes = Vec::new();
    let relative = |p: &ParameterDesign| p.crb / p.reference.max(f64::MIN_POSITIVE);
    for p in &parameters {
        if relative(p) > UNDETERMINED {
            notes.push(format!(
                "{}: Cramér-Rao bound {:.0} % of its reference magnitude {:.3e}: these data do not determine it",
                p.name,
                100.0 * relative(p),
                p.reference
            ));
        }
    }
    for (a, b, r) in &correlated {
        notes.push(format!(
            "{a} and {b} are hard to tell apart (correlation {r:+.3})"
        ));
    }
    // Where the least well determined parameter is measured, and what twice
    // the speeds there would gain for every parameter.
    let worst =
        (0..np).max_by(|&a, &b| relative(&parameters[a]).total_cmp(&relative(&parameters[b])));
    if let Some(w) = worst {
        let (lo, hi) = parameters[w].band_rpm;
        let band: Vec<usize> = (0..samples.len())
            .filter(|&n| {
                let r = rad_s_to_rpm(samples[n].omega);
                r >= lo && r <= hi
            })
            .collect();
        if !band.is_empty() && band.len() < samples.len() {
            let s_band: Vec<Sample> = band.iter().map(|&n| samples[n].clone()).collect();
            let t_band: Vec<Terms> = band.iter().map(|&n| terms[n].clone()).collect();
            let f_band = fisher_information(pr, &s_band, &t_band, theta, floor)?;
            if let Some(c2) = invert(&(&total + f_band)) {
                let gain = |i: usize| 1.0 - (c2[(i, i)] / cov[(i, i)]).max(0.0).sqrt();
                let g: Vec<f64> = (0..np).map(gain).collect();
                notes.push(format!(
                    "{} is measured mostly between {lo:.0} and {hi:.0} rpm ({} of {} speeds): twice the speeds there (a slower sweep) would lower its bound by {:.0} % (every bound by {:.0} to {:.0} %)",
                    parameters[w].name,
                    band.len(),
                    samples.len(),
                    100.0 * g[w],
                    100.0 * g.iter().copied().fold(f64::INFINITY, f64::min),
                    100.0 * g.iter().copied().fold(0.0, f64::max),
                ));
            }
        }
    }
    Ok(TestDesign {
        parameters,
        correlated,
        notes,
    })
}

fn invert(f: &DMatrix<f64>) -> Option<DMatrix<f64>> {
    f.clone().cholesky().map(|c| c.inverse())
}
