//! Design of the test from the Fisher information: which parameters the
//! measured speeds pin down and which they do not, where in the speed
//! range each parameter's information comes from, and what a better test
//! would gain.
//!
//! With `F = sum_n F_n` the Fisher information per unit noise of the
//! output-error fit ([`crate::estimate::output_error::fisher_information`]; `F_n` the contribution of
//! speed `n`) and `s` the relative noise level, the Cramér-Rao bound of
//! parameter `i` is `s sqrt((F^-1)_ii)`. Each parameter's information
//! `(F_n)_ii` is accumulated over the speeds sorted by speed; the band
//! between 10 % and 90 % of it is where that parameter is measured. The
//! gain of a denser test in a band (twice the speeds there, e.g. a slower
//! sweep) is exact under the model: the information of the band is added
//! once more, `F' = F + F_band`, and the bounds recomputed.
//!
//! # Undetermined parameters
//!
//! [`TestDesign::undetermined`] names the parameters the data leave
//! undetermined, for a warning: those whose Cramér-Rao bound exceeds
//! [`UNKNOWN_MAGNITUDE`] times their reference magnitude (the data do not
//! fix even their size), and those in a near-null space of the Fisher
//! information. The latter is found on the scaled matrix
//! `F~ = D^-1/2 F D^-1/2`, `D = diag(F)` (unit diagonal, so the eigenvalues
//! compare parameters of any unit): an eigenvalue below [`NULL_FLOOR`]
//! times the largest is a combination of parameters the data do not see,
//! and every parameter with more than [`NULL_SHARE`] of its squared
//! eigenvector component in it is named (its bound is at least
//! `sqrt(NULL_SHARE / NULL_FLOOR)` = 1e4 times what its own information
//! alone would give); a parameter without any information (`F_ii` below
//! [`NULL_FLOOR`] times the largest diagonal) is named too. The bounds are
//! computed from the inverse of `F` on the remaining directions, so a
//! singular `F` still gives an analysis.

use nalgebra::DMatrix;
use num_complex::Complex64;
use rotorid_core::parametrization::BearingEstimate;

use crate::estimate::noise::NoiseModel;
use crate::estimate::output_error::{fisher_information_weighted, OutputErrorError, Weighting};
use crate::estimate::predictor::{Predictor, Terms};
use crate::io::measurement::Sample;
use crate::units::rad_s_to_rpm;

/// Cramér-Rao bound, relative to the parameter's reference magnitude, above
/// which a parameter is said not to be determined by the data. The
/// reference is the larger direct term (`yy`, `zz`) of the same kind of the
/// same bearing for a bearing coefficient (a cross term near zero is
/// determined when it is known well against the direct terms), or, if
/// larger, the size the term would need to make up the whole law at the
/// top speed `Omega_t` (the larger direct `K` or `C` over `Omega_t^p` for
/// the physical structure's `K_p`, `C_p`; `|Z_B(Omega_t)|` for `Z_0`: a
/// polynomial coefficient that is zero, as `K_0` of stiffness proportional
/// to `Omega^2`, is determined when it is known well against the law);
/// `|a|` of the plane for an unbalance part.
pub const UNDETERMINED: f64 = 0.1;

/// Correlation above which two parameters are said hard to separate.
pub const CORRELATED: f64 = 0.95;

/// Cramér-Rao bound, relative to the reference magnitude, above which a
/// parameter is named in the warning (see the module documentation).
pub const UNKNOWN_MAGNITUDE: f64 = 1.0;

/// Eigenvalue of the scaled Fisher information, relative to the largest,
/// below which its direction counts as not seen by the data.
pub const NULL_FLOOR: f64 = 1e-10;

/// Squared eigenvector component in the near-null space above which a
/// parameter is named.
pub const NULL_SHARE: f64 = 0.01;

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
    /// The parameters the data leave undetermined (see the module
    /// documentation), in parameter order.
    pub undetermined: Vec<String>,
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
    analyse_weighted(pr, samples, terms, theta, noise, None)
}

/// [`analyse`] with the weights of the noise model `model` (a floor and a
/// relative part, [`Weighting::of_noise`]); `None`: proportional noise.
pub fn analyse_weighted(
    pr: &Predictor,
    samples: &[Sample],
    terms: &[Terms],
    theta: &[f64],
    noise: f64,
    model: Option<&NoiseModel>,
) -> Result<TestDesign, OutputErrorError> {
    let np = pr.n_params();
    let floor = 1e-6;
    let total = fisher_information(pr, samples, terms, theta, floor, model)?;
    let Spectral { cov: pseudo, null } = spectral_inverse(&total);
    let cov = invert(&total).unwrap_or(pseudo);
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
            model,
        )?;
        diag.push((0..np).map(|i| f[(i, i)]).collect::<Vec<f64>>());
    }
    let scale = |i: usize| pr.param.scale(pr.params[i].unknown);
    let name = |i: usize| parameter_name(pr, i);
    let w = pr.weights(theta);
    let nb = pr.param.n_bearings();
    let top = samples.iter().map(|s| s.omega).fold(0.0, f64::max);
    // The bearing laws at the top speed (direct entries yy, zz: 0 and 3).
    let laws: Vec<Option<_>> = (0..nb).map(|m| pr.param.bearing(&w, m, top)).collect();
    let mut parameters = Vec::with_capacity(np);
    for i in 0..np {
        let band_rpm = information_band(&diag, i, samples, &order);
        parameters.push(ParameterDesign {
            name: name(i),
            value: theta[i] * scale(i),
            crb: if null[i] {
                f64::INFINITY
            } else {
                noise * cov[(i, i)].max(0.0).sqrt() * scale(i)
            },
            reference: reference_magnitude(pr, &w, &laws, top, i),
            band_rpm,
        });
    }
    let mut correlated = Vec::new();
    for i in (0..np).filter(|&i| !null[i]) {
        for k in (i + 1..np).filter(|&k| !null[k]) {
            let r = cov[(i, k)] / (cov[(i, i)] * cov[(k, k)]).sqrt();
            if r.abs() > CORRELATED {
                correlated.push((name(i), name(k), r));
            }
        }
    }
    let mut notes = design_notes(&parameters, &correlated);
    // Where the least well determined parameter is measured, and what twice
    // the speeds there would gain for every parameter.
    let worst = (0..np)
        .filter(|&i| !null[i])
        .max_by(|&a, &b| relative_bound(&parameters[a]).total_cmp(&relative_bound(&parameters[b])));
    if let Some(w) = worst {
        let fisher_band =
            |s: &[Sample], t: &[Terms]| fisher_information(pr, s, t, theta, floor, model);
        if let Some(note) =
            slower_sweep_note(samples, terms, &total, &cov, &parameters, w, fisher_band)?
        {
            notes.push(note);
        }
    }
    let undetermined = parameters
        .iter()
        .filter(|p| p.crb.is_infinite() || relative_bound(p) > UNKNOWN_MAGNITUDE)
        .map(|p| p.name.clone())
        .collect();
    Ok(TestDesign {
        parameters,
        correlated,
        notes,
        undetermined,
    })
}

/// The Fisher information of `samples` at `theta`, weighted by the noise
/// model `model` (`None`: proportional noise) with the relative `floor`.
fn fisher_information(
    pr: &Predictor,
    samples: &[Sample],
    terms: &[Terms],
    theta: &[f64],
    floor: f64,
    model: Option<&NoiseModel>,
) -> Result<DMatrix<f64>, OutputErrorError> {
    let w = match model {
        Some(m) => Weighting::of_noise(samples, floor, m),
        None => Weighting::proportional(samples, floor),
    };
    fisher_information_weighted(pr, samples, terms, theta, &w)
}

/// The name of parameter `i` (with `re` or `im` for a complex structure).
fn parameter_name(pr: &Predictor, i: usize) -> String {
    let base = pr.param.name(pr.params[i].unknown);
    if pr.param.structure.is_complex() {
        format!(
            "{base} {}",
            if pr.params[i].imaginary { "im" } else { "re" }
        )
    } else {
        base
    }
}

/// The speeds (rpm) between which parameter `i` gathers 10 % and 90 % of
/// its information: `diag` holds the per-speed diagonals of the Fisher
/// information in the speed order `order` of `samples`.
fn information_band(
    diag: &[Vec<f64>],
    i: usize,
    samples: &[Sample],
    order: &[usize],
) -> (f64, f64) {
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
    (lo.unwrap_or(0.0), hi.unwrap_or(0.0))
}

/// The magnitude parameter `i`'s bound is measured against: for a bearing
/// term the larger of its direct estimates and its part of the estimated
/// law `laws` at the top speed `top`; for an unbalance its estimated
/// magnitude (`w`: the estimate's weights).
fn reference_magnitude(
    pr: &Predictor,
    w: &[Complex64],
    laws: &[Option<BearingEstimate<f64>>],
    top: f64,
    i: usize,
) -> f64 {
    use rotorid_core::parametrization::{BearingTerm, Unknown};
    let physical = |j: usize| w[j] * pr.param.scale(j);
    let nb = pr.param.n_bearings();
    let st = &pr.param.structure;
    match pr.param.unknown(pr.params[i].unknown) {
        Some(Unknown::Bearing { bearing, term, .. }) => {
            let own = [(0, 0), (1, 1)]
                .iter()
                .filter_map(|&(r, c)| st.bearing_index(bearing, r, c, term))
                .map(|j| physical(j).norm())
                .fold(0.0, f64::max);
            let law = laws.get(bearing).copied().flatten();
            let direct = |v: [f64; 4]| v[0].abs().max(v[3].abs());
            let at_top = match (term, law) {
                (BearingTerm::K { power }, Some(l)) => direct(l.k) / top.powi(power as i32),
                (BearingTerm::C { power }, Some(l)) => direct(l.c) / top.powi(power as i32),
                (BearingTerm::Z { power: 0 }, Some(l)) => [0, 3]
                    .iter()
                    .map(|&e| l.k[e].hypot(top * l.c[e]))
                    .fold(0.0, f64::max),
                _ => 0.0,
            };
            own.max(if at_top.is_finite() { at_top } else { 0.0 })
        }
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
}

/// A parameter's Cramér-Rao bound relative to its reference magnitude.
fn relative_bound(p: &ParameterDesign) -> f64 {
    p.crb / p.reference.max(f64::MIN_POSITIVE)
}

/// The notes on the parameters these data do not determine and on the
/// `correlated` pairs.
fn design_notes(
    parameters: &[ParameterDesign],
    correlated: &[(String, String, f64)],
) -> Vec<String> {
    let mut notes = Vec::new();
    for p in parameters {
        if p.crb.is_infinite() {
            notes.push(format!(
                "{}: in a combination of parameters these data do not see (near-null space of the Fisher information): these data do not determine it",
                p.name
            ));
        } else if relative_bound(p) > UNDETERMINED {
            notes.push(format!(
                "{}: Cramér-Rao bound {:.0} % of its reference magnitude {:.3e}: these data do not determine it",
                p.name,
                100.0 * relative_bound(p),
                p.reference
            ));
        }
    }
    for (a, b, r) in correlated {
        notes.push(format!(
            "{a} and {b} are hard to tell apart (correlation {r:+.3})"
        ));
    }
    notes
}

/// The note on the least well determined parameter `w`: the speeds where
/// it is measured and what twice those speeds would lower every bound by
/// (`total`, `cov`: the Fisher information and covariance of all the
/// data; `fisher_band`: the Fisher information of some of them). `None`
/// when the band is empty or all the speeds, or the sum is singular.
fn slower_sweep_note(
    samples: &[Sample],
    terms: &[Terms],
    total: &DMatrix<f64>,
    cov: &DMatrix<f64>,
    parameters: &[ParameterDesign],
    w: usize,
    fisher_band: impl Fn(&[Sample], &[Terms]) -> Result<DMatrix<f64>, OutputErrorError>,
) -> Result<Option<String>, OutputErrorError> {
    let np = parameters.len();
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
        let f_band = fisher_band(&s_band, &t_band)?;
        if let Some(c2) = invert(&(total + f_band)) {
            let gain = |i: usize| 1.0 - (c2[(i, i)] / cov[(i, i)]).max(0.0).sqrt();
            let g: Vec<f64> = (0..np).map(gain).collect();
            return Ok(Some(format!(
                "{} is measured mostly between {lo:.0} and {hi:.0} rpm ({} of {} speeds): twice the speeds there (a slower sweep) would lower its bound by {:.0} % (every bound by {:.0} to {:.0} %)",
                parameters[w].name,
                band.len(),
                samples.len(),
                100.0 * g[w],
                100.0 * g.iter().copied().fold(f64::INFINITY, f64::min),
                100.0 * g.iter().copied().fold(0.0, f64::max),
            )));
        }
    }
    Ok(None)
}

/// The inverse of a Fisher information on the directions the data see,
/// and which parameters lie in the near-null space (see the module
/// documentation).
struct Spectral {
    cov: DMatrix<f64>,
    null: Vec<bool>,
}

fn spectral_inverse(f: &DMatrix<f64>) -> Spectral {
    let n = f.nrows();
    let dmax = (0..n).map(|i| f[(i, i)]).fold(0.0, f64::max);
    let mut null: Vec<bool> = (0..n)
        .map(|i| !(f[(i, i)] > NULL_FLOOR * dmax && f[(i, i)].is_finite()))
        .collect();
    let seen: Vec<usize> = (0..n).filter(|&i| !null[i]).collect();
    let s: Vec<f64> = seen.iter().map(|&i| 1.0 / f[(i, i)].sqrt()).collect();
    let scaled = DMatrix::from_fn(seen.len(), seen.len(), |a, b| {
        s[a] * f[(seen[a], seen[b])] * s[b]
    });
    let eig = scaled.symmetric_eigen();
    let lmax = eig.eigenvalues.iter().copied().fold(0.0, f64::max);
    let mut inv = DMatrix::<f64>::zeros(seen.len(), seen.len());
    for (k, &l) in eig.eigenvalues.iter().enumerate() {
        let v = eig.eigenvectors.column(k);
        if l > NULL_FLOOR * lmax {
            inv += v * v.transpose() / l;
        } else {
            for (a, &i) in seen.iter().enumerate() {
                if v[a] * v[a] > NULL_SHARE {
                    null[i] = true;
                }
            }
        }
    }
    let mut cov = DMatrix::<f64>::zeros(n, n);
    for (a, &i) in seen.iter().enumerate() {
        for (b, &k) in seen.iter().enumerate() {
            cov[(i, k)] = s[a] * inv[(a, b)] * s[b];
        }
    }
    Spectral { cov, null }
}

fn invert(f: &DMatrix<f64>) -> Option<DMatrix<f64>> {
    f.clone().cholesky().map(|c| c.inverse())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A singular information (parameters 0 and 1 enter only as their
    /// sum, parameter 3 not at all) names those three and inverts the rest;
    /// a regular one names nothing and gives the inverse.
    #[test]
    fn the_near_null_space_is_named() {
        let f = DMatrix::from_row_slice(
            4,
            4,
            &[
                4.0, 4.0, 0.0, 0.0, //
                4.0, 4.0, 0.0, 0.0, //
                0.0, 0.0, 9.0, 0.0, //
                0.0, 0.0, 0.0, 0.0,
            ],
        );
        let s = spectral_inverse(&f);
        assert_eq!(s.null, [true, true, false, true]);
        assert!((s.cov[(2, 2)] - 1.0 / 9.0).abs() < 1e-15);
        // Nearly singular, below the floor: still named.
        let eps = 1e-12;
        let g = DMatrix::from_row_slice(2, 2, &[1.0, 1.0 - eps, 1.0 - eps, 1.0]);
        assert_eq!(spectral_inverse(&g).null, [true, true]);
        // Correlated but above the floor (eigenvalue 1e-6 of 2): seen.
        let h = DMatrix::from_row_slice(2, 2, &[1.0, 1.0 - 1e-6, 1.0 - 1e-6, 1.0]);
        let s = spectral_inverse(&h);
        assert_eq!(s.null, [false, false]);
        let inv = invert(&h).unwrap();
        for i in 0..2 {
            for k in 0..2 {
                assert!((s.cov[(i, k)] - inv[(i, k)]).abs() <= 1e-6 * inv[(i, i)]);
            }
        }
    }
}
