//! Observability: how large an effect must be for these sensors and speeds
//! to see it, and which effects the data cannot tell apart.
//!
//! # Smallest detectable size
//!
//! At the nominal estimate, with `J = [J_n, J_e]` the weighted Jacobian of
//! the nominal and the effect's parameters (effect at zero) and `sigma^2`
//! the noise variance of one real reading, an effect `phi` (scaled) raises
//! the expected likelihood-ratio statistic of its hypothesis by the
//! non-centrality
//!
//! ```text
//!     lambda = phi^T S phi / sigma^2,   S = J_e^T J_e - J_e^T J_n (J_n^T J_n)^-1 J_n^T J_e
//! ```
//!
//! (the information left once the nominal parameters are refitted: an
//! effect the nominal model can mimic has a small `S`). The effect is
//! detected, in the worst phase, when `lambda` reaches the hypothesis'
//! threshold `t`: `|phi|_min = sqrt(t sigma^2 / mu_min(S))`. This is
//! computed for the effects that vanish at zero parameters (bow and extra
//! plane at every node, runout on every channel) and for the shaft modulus
//! factor (one parameter, its threshold the chi-square quantile of one
//! degree of freedom; `dA/de` from the terms at `e = 0.95` and `1.05`).
//!
//! # Effects the data cannot tell apart
//!
//! Two significant hypotheses whose misfits differ by less than the
//! chi-square quantile of 2 degrees of freedom at 1 % explain the data
//! equally well: the data do not tell them apart, and the report says which
//! measurement would.

use serde::Serialize;

use crate::diagnose::extended::{ExtendedModel, Extension};
use crate::diagnose::fit::{self, FitData};
use crate::diagnose::{chi2_quantile_upper, Diagnosis, Effect};

/// What the data can show of one effect.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Observability {
    /// The effect.
    pub effect: Effect,
    /// Smallest detectable size at the best location (unit in `unit`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub min_size: Option<f64>,
    /// Where `min_size` holds (node or channel).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub best_at: Option<String>,
    /// Smallest detectable size at the worst location.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub min_size_worst: Option<f64>,
    /// Where `min_size_worst` holds.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub worst_at: Option<String>,
    /// Unit of the sizes.
    pub unit: &'static str,
    /// Effects that explain the data equally well.
    pub indistinguishable_from: Vec<Effect>,
    /// One line for the report.
    pub note: String,
}

/// Smallest detectable size (physical units) of `make(k)` for each `k` in
/// `locations`, at `theta0` of `base` with threshold `t` (see the module
/// documentation). `scale` turns a scaled amplitude into physical units.
pub fn min_detectable(
    base: &ExtendedModel,
    data: &FitData<'_>,
    theta0: &[f64],
    sigma2: f64,
    t: f64,
    exts: &[Extension],
    scale: f64,
) -> Option<Vec<f64>> {
    let all = ExtendedModel {
        ext: exts.to_vec(),
        ..base.clone()
    };
    let mut theta = theta0.to_vec();
    theta.resize(all.n_params(), 0.0);
    let en = fit::entries(&all, data);
    let (_, jac) = fit::evaluate(&all, data, &en, &theta, true).ok()?;
    let j = jac?;
    let g = crate::diagnose::fit::gram(&j);
    let p0 = base.n_params();
    let gnn = g.view((0, 0), (p0, p0)).into_owned();
    let ch = gnn.cholesky()?;
    let nq = base.n_channels();
    let mut out = Vec::new();
    for (k, e) in exts.iter().enumerate() {
        let o = all.offset(k);
        let groups: Vec<usize> = match e {
            Extension::Runout => (0..nq).map(|c| o + 2 * c).collect(),
            _ => vec![o],
        };
        let w = if *e == Extension::EScale { 1 } else { 2 };
        for o2 in groups {
            let gne = g.view((0, o2), (p0, w)).into_owned();
            let gee = g.view((o2, o2), (w, w)).into_owned();
            let s = gee - gne.transpose() * ch.solve(&gne);
            let mu = s.symmetric_eigenvalues().min();
            let size = if mu > 0.0 {
                scale * (t * sigma2 / mu).sqrt()
            } else {
                f64::INFINITY
            };
            out.push(size);
        }
    }
    Some(out)
}

fn where_min(
    v: &[f64],
    names: &[String],
) -> (Option<f64>, Option<String>, Option<f64>, Option<String>) {
    let mut best: Option<(f64, usize)> = None;
    let mut worst: Option<(f64, usize)> = None;
    for (i, &x) in v.iter().enumerate() {
        if best.is_none_or(|b| x < b.0) {
            best = Some((x, i));
        }
        if worst.is_none_or(|w| x > w.0) {
            worst = Some((x, i));
        }
    }
    (
        best.map(|b| b.0),
        best.and_then(|b| names.get(b.1).cloned()),
        worst.map(|w| w.0),
        worst.and_then(|w| names.get(w.1).cloned()),
    )
}

/// The statistic a `k`-parameter effect must reach: the chi-square quantile
/// at the choice's false-alarm rate split over the alternatives tried.
fn detection_threshold(d: &Diagnosis, k: f64) -> f64 {
    let alternatives: usize = d
        .hypotheses
        .iter()
        .filter(|c| c.effects.len() == 1)
        .map(|c| c.alternatives)
        .sum::<usize>()
        .max(1);
    chi2_quantile_upper(k, d.false_alarm / alternatives as f64)
}

/// What would tell `a` from `b`.
pub fn suggestion(a: Effect, b: Effect) -> &'static str {
    use Effect::*;
    let (x, y) = if a <= b { (a, b) } else { (b, a) };
    match (x, y) {
        (ShaftBow, ExtraUnbalancePlane) => {
            "a slow-roll reading (well below the first critical speed) or a probe near mid-span: a bow shows at low speed, an unbalance grows with speed squared"
        }
        (ShaftBow, ProbeRunout) | (ProbeRunout, ExtraUnbalancePlane) => {
            "a slow-roll reading on every probe: runout is the same at every speed"
        }
        (SpeedDependentBearing, FoundationFlexibility) => {
            "a seismic (absolute) sensor on the bearing housing: a moving pedestal shows there"
        }
        (SpeedDependentBearing, ShaftStiffnessError) | (FoundationFlexibility, ShaftStiffnessError) => {
            "a probe at mid-span, or a speed range through the shaft's bending critical"
        }
        _ => "more speeds near the critical speeds, or a probe at another node",
    }
}

/// The observability of every hypothesis of `d` (see the module docs).
///
/// `data_de`: the same data with the nominal terms carrying `dA/de` at
/// `e = 1`, for the shaft modulus (without it the modulus gets a note only).
pub fn analyse(
    d: &Diagnosis,
    data: &FitData<'_>,
    data_de: Option<&FitData<'_>>,
) -> Vec<Observability> {
    let nominal = &d.nominal;
    let base = &nominal.model;
    let theta0 = &nominal.fit.theta;
    let n_nodes = data.terms.first().map_or(0, |t| t.b_node.ncols());
    let t2 = detection_threshold(d, 2.0);
    let planes = &base.pr.param.plane_nodes;
    let mut out = Vec::new();
    for effect in Effect::BANK {
        let (exts, names, scale, unit): (Vec<Extension>, Vec<String>, f64, &'static str) =
            match effect {
                Effect::ShaftBow => {
                    let nodes: Vec<usize> = (1..n_nodes.saturating_sub(1)).collect();
                    (
                        nodes.iter().map(|&node| Extension::Bow { node }).collect(),
                        nodes.iter().map(|n| format!("node {}", n + 1)).collect(),
                        base.scales.q,
                        "m",
                    )
                }
                Effect::ExtraUnbalancePlane => {
                    let nodes: Vec<usize> = (0..n_nodes).filter(|n| !planes.contains(n)).collect();
                    (
                        nodes
                            .iter()
                            .map(|&node| Extension::Plane { node })
                            .collect(),
                        nodes.iter().map(|n| format!("node {}", n + 1)).collect(),
                        base.pr.param.scaling.unbalance,
                        "kg m",
                    )
                }
                Effect::ProbeRunout => (
                    vec![Extension::Runout],
                    (0..base.n_channels())
                        .map(|c| format!("b{}_{}", c / 2 + 1, if c % 2 == 0 { "y" } else { "z" }))
                        .collect(),
                    base.scales.q,
                    "m",
                ),
                Effect::ShaftStiffnessError if data_de.is_some() => (
                    vec![Extension::EScale],
                    vec!["the shaft".to_string()],
                    crate::diagnose::extended::E_STEP,
                    "(relative change of E and G)",
                ),
                _ => (Vec::new(), Vec::new(), 1.0, ""),
            };
        let sizes = match (effect, data_de) {
            _ if exts.is_empty() => None,
            (Effect::ShaftStiffnessError, Some(dd)) => {
                let t1 = detection_threshold(d, 1.0);
                min_detectable(base, dd, theta0, d.sigma2, t1, &exts, scale)
            }
            _ => min_detectable(base, data, theta0, d.sigma2, t2, &exts, scale),
        };
        let (min_size, best_at, min_size_worst, worst_at) = match &sizes {
            Some(v) => where_min(v, &names),
            None => (None, None, None, None),
        };
        // Equally good significant alternatives.
        let me = d
            .hypotheses
            .iter()
            .filter(|c| c.effects == [effect])
            .map(|c| c.fit.s)
            .next();
        let tie = chi2_quantile_upper(2.0, 0.01) * d.sigma2;
        let indistinguishable_from: Vec<Effect> = match me {
            Some(s)
                if d.hypotheses
                    .iter()
                    .any(|c| c.effects == [effect] && c.significant) =>
            {
                d.hypotheses
                    .iter()
                    .filter(|c| c.effects.len() == 1 && c.effects[0] != effect && c.significant)
                    .filter(|c| (c.fit.s - s).abs() < tie)
                    .map(|c| c.effects[0])
                    .collect()
            }
            _ => Vec::new(),
        };
        let mut note = match (min_size, &best_at, min_size_worst, &worst_at) {
            (Some(a), Some(_), Some(_), Some(_))
                if a.is_finite() && effect == Effect::ShaftStiffnessError =>
            {
                format!(
                    "{}: detectable from a {:.1e} relative change of the shaft's modulus (through the shift of the critical speeds and mode shapes in the range)",
                    effect.name(),
                    a
                )
            }
            (Some(a), Some(wa), Some(b), Some(wb)) if a.is_finite() => {
                if b.is_finite() {
                    format!(
                        "{}: detectable from {a:.2e} {unit} ({wa}) to {b:.2e} {unit} ({wb})",
                        effect.name()
                    )
                } else {
                    format!(
                        "{}: detectable from {a:.2e} {unit} ({wa}); not at all at {wb} (the nominal model absorbs it)",
                        effect.name()
                    )
                }
            }
            _ => match effect {
                Effect::SpeedDependentBearing => {
                    "speed_dependent_bearing: refitted as a polynomial law one and two orders higher".to_string()
                }
                Effect::FoundationFlexibility => {
                    "foundation_flexibility: seen when the pedestal's resonance lies in or near the speed range; far above it, a pedestal only softens the bearing"
                        .to_string()
                }
                Effect::ShaftStiffnessError => {
                    "shaft_stiffness_error: seen through the shift of the critical speeds in the range".to_string()
                }
                _ => format!("{}: not observable with these data", effect.name()),
            },
        };
        for other in &indistinguishable_from {
            note.push_str(&format!(
                "; explains the data as well as {}: {}",
                other.name(),
                suggestion(effect, *other)
            ));
        }
        out.push(Observability {
            effect,
            min_size,
            best_at,
            min_size_worst,
            worst_at,
            unit,
            indistinguishable_from,
            note,
        });
    }
    out
}

/// The smallest detectable size of `ext` alone at the nominal estimate of
/// `d` (physical units: m for bow and runout, kg m for a plane).
pub fn min_detectable_single(d: &Diagnosis, data: &FitData<'_>, ext: Extension) -> Option<f64> {
    let base = &d.nominal.model;
    let scale = match ext {
        Extension::Plane { .. } => base.pr.param.scaling.unbalance,
        Extension::Bow { .. } | Extension::Runout => base.scales.q,
        _ => return None,
    };
    let t2 = detection_threshold(d, 2.0);
    let v = min_detectable(
        base,
        data,
        &d.nominal.fit.theta,
        d.sigma2,
        t2,
        &[ext],
        scale,
    )?;
    v.into_iter().reduce(f64::min)
}
