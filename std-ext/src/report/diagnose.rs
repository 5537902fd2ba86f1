//! The diagnosis report: text, the JSON of the command-line contract
//! (SPEC section 5), and plots (measured, nominal and extended responses
//! and the residuals against speed).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::diagnose::observe::Observability;
use crate::diagnose::{estimates, Diagnosis, Effect, Finding};
use crate::estimate::results::{BearingResult, UnbalanceResult};
use crate::io::measurement::Sample;
use crate::model::extension::Channel;
use crate::report::plot::{line_plot_with, Marker, PlotError, PlotOptions, Series};
use crate::units::rad_s_to_rpm;

/// One hypothesis in the JSON.
#[derive(Debug, Clone, Serialize)]
pub struct HypothesisJson {
    /// Effect names.
    pub effects: Vec<&'static str>,
    /// Description.
    pub label: String,
    /// Relative RMS misfit.
    pub residual: f64,
    /// Parameters beyond the nominal model.
    pub extra_params: usize,
    /// Likelihood-ratio statistic (noise variances).
    pub statistic: f64,
    /// Its threshold.
    pub threshold: f64,
    /// Whether it is significant.
    pub significant: bool,
}

/// Bearings and unbalance of one model.
#[derive(Debug, Clone, Serialize)]
pub struct ModelEstimates {
    /// Bearings at the last speed.
    pub bearings: Vec<BearingResult>,
    /// Plane unbalances.
    pub unbalance: Vec<UnbalanceResult>,
}

/// `rotorid diagnose --json`.
#[derive(Debug, Clone, Serialize)]
pub struct DiagnoseJson {
    /// The named effect (SPEC section 5).
    pub effect: &'static str,
    /// The effects of the extended model (two for a pair).
    pub effects: Vec<&'static str>,
    /// Relative RMS misfit of the nominal model.
    pub residual_nominal: f64,
    /// Of the extended model (same definition).
    pub residual_extended: f64,
    /// `residual_nominal / residual_extended`.
    pub gain: f64,
    /// Model-free relative noise level.
    pub noise_level: Option<f64>,
    /// Speed at which the bearings are given (rpm).
    pub last_speed_rpm: f64,
    /// Bearings of the extended model.
    pub bearings: Vec<BearingResult>,
    /// Unbalance of the extended model.
    pub unbalance: Vec<UnbalanceResult>,
    /// The identified size of each effect.
    pub findings: Vec<Finding>,
    /// The nominal model's estimates.
    pub nominal: ModelEstimates,
    /// Every hypothesis fitted.
    pub hypotheses: Vec<HypothesisJson>,
    /// What the data can show.
    pub observability: Vec<Observability>,
    /// Warnings.
    pub warnings: Vec<String>,
    /// The noise model the fits were weighted with (SPEC section 7).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub noise: Option<crate::estimate::results::NoiseResult>,
    /// Samples excluded as outliers: none, the diagnosis keeps every
    /// sample (a glitch shows as a misfit there).
    pub outliers: Vec<crate::estimate::results::OutlierResult>,
}

/// The JSON of `d`.
pub fn json(d: &Diagnosis) -> DiagnoseJson {
    let ext = d.extended();
    let (bearings, unbalance) = estimates(ext, d.omega_report);
    let (nb, nu) = estimates(&d.nominal, d.omega_report);
    let p0 = d.nominal.fit.n_params();
    DiagnoseJson {
        effect: d.effect.name(),
        effects: d.effects.iter().map(|e| e.name()).collect(),
        residual_nominal: d.residual_nominal(),
        residual_extended: d.residual_extended(),
        gain: d.residual_nominal() / d.residual_extended(),
        noise_level: d.noise_level,
        last_speed_rpm: rad_s_to_rpm(d.omega_report),
        bearings,
        unbalance,
        findings: d.findings(),
        nominal: ModelEstimates {
            bearings: nb,
            unbalance: nu,
        },
        hypotheses: d
            .hypotheses
            .iter()
            .map(|c| HypothesisJson {
                effects: c.effects.iter().map(|e| e.name()).collect(),
                label: c.label.clone(),
                residual: c.residual(),
                extra_params: c.fit.n_params().saturating_sub(p0),
                statistic: c.statistic,
                threshold: c.threshold,
                significant: c.significant,
            })
            .collect(),
        observability: d.observability.clone(),
        warnings: d.warnings.clone(),
        noise: d
            .noise
            .as_ref()
            .map(crate::estimate::results::NoiseResult::from),
        outliers: Vec::new(),
    }
}

fn what(effect: Effect) -> &'static str {
    match effect {
        Effect::None => "nothing beyond measurement noise",
        Effect::SpeedDependentBearing => "bearing coefficients that vary with speed",
        Effect::FoundationFlexibility => "a pedestal that moves under a bearing",
        Effect::ShaftBow => {
            "a bent shaft (synchronous forcing that does not scale with speed squared)"
        }
        Effect::ProbeRunout => "a constant phasor added to a probe at every speed (runout)",
        Effect::ExtraUnbalancePlane => "unbalance at a node that is not one of the model's planes",
        Effect::ShaftStiffnessError => "a shaft stiffer or softer than the model",
        Effect::ProbeSensitivity => {
            "a probe whose scale factor is off (a real gain on its channel at every speed)"
        }
        Effect::Unexplained => "a misfit well above the noise that no effect of the bank removes",
    }
}

/// Per speed, the RMS over channels of the weighted residual of `pred`,
/// with the fits' weights (`max(|y|, floor)`, or with a probe noise floor
/// `sqrt(|y|^2 + (f_c / s)^2)`, [`crate::diagnose::fit::FitData::with_floors`]).
fn residual_by_speed(
    d: &Diagnosis,
    samples: &[Sample],
    pred: &[Vec<num_complex::Complex64>],
) -> Vec<f64> {
    let phi: Vec<f64> = d
        .noise
        .as_ref()
        .filter(|m| m.has_floor())
        .map(|m| m.relative_floor())
        .unwrap_or_default();
    let nq = samples.first().map_or(0, |s| s.q.len());
    let floor: Vec<f64> = (0..nq)
        .map(|c| {
            let ms = samples.iter().map(|s| s.q[c].norm_sqr()).sum::<f64>()
                / samples.len().max(1) as f64;
            crate::diagnose::fit::FLOOR * ms.sqrt()
        })
        .collect();
    samples
        .iter()
        .zip(pred)
        .map(|(s, y)| {
            let v: f64 = (0..nq)
                .map(|c| {
                    let w = match phi.get(c) {
                        Some(&p) if p > 0.0 => s.q[c].norm().hypot(p),
                        _ => s.q[c].norm().max(floor[c]),
                    };
                    (s.q[c] - y[c]).norm_sqr() / (w * w)
                })
                .sum::<f64>()
                / nq.max(1) as f64;
            v.sqrt()
        })
        .collect()
}

/// Where in the speed range the nominal misfit is worst: the speed bands
/// (tenths of the range) whose RMS residual is above twice the noise.
fn misfit_bands(samples: &[Sample], res: &[f64], noise: f64) -> Vec<(f64, f64, f64)> {
    let lo = samples
        .iter()
        .map(|s| s.omega)
        .fold(f64::INFINITY, f64::min);
    let hi = samples.iter().map(|s| s.omega).fold(0.0, f64::max);
    let mut out = Vec::new();
    if hi.is_nan() || hi <= lo {
        return out;
    }
    for k in 0..10 {
        let a = lo + (hi - lo) * k as f64 / 10.0;
        let b = lo + (hi - lo) * (k + 1) as f64 / 10.0;
        let v: Vec<f64> = samples
            .iter()
            .zip(res)
            .filter(|(s, _)| s.omega >= a && (s.omega < b || k == 9))
            .map(|(_, r)| r * r)
            .collect();
        if v.is_empty() {
            continue;
        }
        let rms = (v.iter().sum::<f64>() / v.len() as f64).sqrt();
        if rms > 2.0 * noise {
            out.push((rad_s_to_rpm(a), rad_s_to_rpm(b), rms));
        }
    }
    out
}

/// The text report.
pub fn text(
    d: &Diagnosis,
    samples: &[Sample],
    nominal_pred: &[Vec<num_complex::Complex64>],
) -> String {
    let mut s = String::new();
    let j = json(d);
    let noise = d.noise_level;
    let _ = writeln!(s, "diagnosis: {}", d.effect.name());
    let _ = writeln!(s, "  {}", what(d.effect));
    if d.effects.len() > 1 {
        let names: Vec<&str> = d.effects.iter().map(|e| e.name()).collect();
        let _ = writeln!(s, "  (a pair: {})", names.join(" + "));
    }
    let _ = writeln!(
        s,
        "residual (relative RMS misfit): nominal {:.3e}, extended {:.3e}, gain {:.1}x; noise level {}",
        j.residual_nominal,
        j.residual_extended,
        j.gain,
        noise.map_or("unknown".to_string(), |n| format!("{n:.3e}"))
    );
    if d.nominal.fit.stalled {
        let _ = writeln!(
            s,
            "  (the nominal fit stopped stalled: its parameters wander off while its misfit, over three times the noise, no longer falls; the nominal residual is an upper bound)"
        );
    }
    if let Some(n) = noise {
        let res = residual_by_speed(d, samples, nominal_pred);
        let bands = misfit_bands(samples, &res, n);
        if bands.is_empty() {
            let _ = writeln!(
                s,
                "the nominal model fits within twice the noise at every speed band"
            );
        } else {
            let _ = writeln!(
                s,
                "where the nominal model misfits (RMS residual above twice the noise):"
            );
            for (a, b, r) in bands {
                let _ = writeln!(s, "  {a:7.0} - {b:7.0} rpm: {:.1}x the noise", r / n);
            }
        }
    }
    for f in &j.findings {
        let _ = writeln!(s, "identified: {}", finding_line(f));
    }
    let _ = writeln!(
        s,
        "hypotheses (statistic = drop in misfit in noise variances):"
    );
    let _ = writeln!(
        s,
        "  {:<62} {:>10} {:>6} {:>12} {:>9}  significant",
        "model", "residual", "+P", "statistic", "threshold"
    );
    for h in &j.hypotheses {
        let _ = writeln!(
            s,
            "  {:<62} {:>10.3e} {:>6} {:>12.1} {:>9.1}  {}",
            h.label,
            h.residual,
            h.extra_params,
            h.statistic,
            h.threshold,
            if h.significant { "yes" } else { "no" }
        );
    }
    let _ = writeln!(
        s,
        "bearings at {:.0} rpm (nominal -> extended):",
        j.last_speed_rpm
    );
    for (a, b) in j.nominal.bearings.iter().zip(&j.bearings) {
        let _ = writeln!(
            s,
            "  node {:>3}  K yy {:.4e} -> {:.4e}  zz {:.4e} -> {:.4e} N/m;  C yy {:.4e} -> {:.4e}  zz {:.4e} -> {:.4e} N s/m",
            a.node, a.k.yy, b.k.yy, a.k.zz, b.k.zz, a.c.yy, b.c.yy, a.c.zz, b.c.zz
        );
    }
    let _ = writeln!(s, "unbalance (nominal -> extended):");
    for (a, b) in j.nominal.unbalance.iter().zip(&j.unbalance) {
        let _ = writeln!(
            s,
            "  node {:>3}  {:.4e} kg m at {:.1} deg -> {:.4e} kg m at {:.1} deg",
            a.node, a.me, a.phase_deg, b.me, b.phase_deg
        );
    }
    let _ = writeln!(s, "observability:");
    for o in &j.observability {
        let _ = writeln!(s, "  {}", o.note);
    }
    s
}

fn finding_line(f: &Finding) -> String {
    match f {
        Finding::SpeedDependentBearing {
            order,
            form,
            stiffness,
        } => {
            let parts: Vec<String> = stiffness
                .iter()
                .map(|(n, lo, hi)| {
                    format!(
                        "node {n}: K yy {:.3e} -> {:.3e}, zz {:.3e} -> {:.3e} N/m",
                        lo.yy, hi.yy, lo.zz, hi.zz
                    )
                })
                .collect();
            let law = if *form == "film" {
                "film law (direct and cross-coupled stiffness, direct damping in proportion to the speed)".to_string()
            } else {
                format!("bearing law of order {order}")
            };
            format!("{law} (lowest -> highest speed) {}", parts.join("; "))
        }
        Finding::FoundationFlexibility {
            node,
            mass,
            mass_std,
            masses,
            natural_frequency_hz,
            natural_frequency_hz_std,
            damping_ratio,
            ..
        } => format!(
            "pedestal under the bearing at node {node}: mass {mass:.2} +- {mass_std:.2} kg{}, natural frequency y {:.1} +- {:.1} Hz ({:.0} rpm), z {:.1} +- {:.1} Hz ({:.0} rpm), damping ratio {:.3}/{:.3}",
            if masses[0] == masses[1] {
                String::new()
            } else {
                format!(" (y {:.2}, z {:.2} kg)", masses[0], masses[1])
            },
            natural_frequency_hz[0],
            natural_frequency_hz_std[0],
            natural_frequency_hz[0] * 60.0,
            natural_frequency_hz[1],
            natural_frequency_hz_std[1],
            natural_frequency_hz[1] * 60.0,
            damping_ratio[0],
            damping_ratio[1]
        ),
        Finding::ShaftBow {
            node,
            amplitude,
            amplitude_std,
            phase_deg,
            phase_deg_std,
            reference,
        } => format!(
            "bow at node {node} (from the {reference}): {:.2} +- {:.2} um at {phase_deg:.1} +- {phase_deg_std:.1} deg",
            amplitude * 1e6,
            amplitude_std * 1e6
        ),
        Finding::ProbeRunout { channels } => {
            let parts: Vec<String> = channels
                .iter()
                .filter(|c| c.significant)
                .map(|c| {
                    format!(
                        "{} {:.2} +- {:.2} um at {:.1} +- {:.1} deg",
                        c.channel,
                        c.amplitude * 1e6,
                        c.amplitude_std * 1e6,
                        c.phase_deg,
                        c.phase_deg_std
                    )
                })
                .collect();
            format!("runout {}", parts.join(", "))
        }
        Finding::ExtraUnbalancePlane {
            node,
            nodes,
            me,
            me_std,
            phase_deg,
            phase_deg_std,
            spread,
        } => {
            let at = if nodes.contains("..") {
                format!("shared equally by nodes {nodes}")
            } else {
                format!("at node {node}")
            };
            let mut line = format!(
                "extra unbalance {at}: {me:.4e} +- {me_std:.1e} kg m at {phase_deg:.1} +- {phase_deg_std:.1} deg"
            );
            if let [lo, hi] = &spread[..] {
                line.push_str(&format!(
                    " (the data do not fix where it lies: {:.4e} kg m spread over nodes {} to {:.4e} over nodes {} fit as well or better)",
                    lo.me, lo.nodes, hi.me, hi.nodes
                ));
            }
            line
        }
        Finding::ShaftStiffnessError {
            factor,
            factor_std,
            form,
            alike,
            ends,
        } => {
            let mut line = format!("{form} x {factor:.4} +- {factor_std:.4}");
            if let [lo, hi] = &ends[..] {
                line.push_str(&format!(
                    " (the data do not fix its ends: runs from {} x {:.4} to {} x {:.4} fit as well or better)",
                    lo.form, lo.factor, hi.form, hi.factor
                ));
            }
            if !alike.is_empty() {
                let others: Vec<String> = alike
                    .iter()
                    .map(|a| format!("{} x {:.4} +- {:.4}", a.form, a.factor, a.factor_std))
                    .collect();
                line.push_str(&format!(
                    "; fitting as well within the noise (the data cannot tell them apart): {}",
                    others.join("; ")
                ));
            }
            line
        }
        Finding::ProbeSensitivity {
            channel,
            gain,
            gain_std,
        } => format!(
            "probe {channel} reads x {gain:.4} +- {gain_std:.4} ({:+.1} % sensitivity error)",
            100.0 * (gain - 1.0)
        ),
    }
}

/// Writes the plots into `dir`: `diagnose_residual.svg` (weighted residual
/// against speed, nominal and extended, with the noise level) and
/// `diagnose_b<k>_<y|z>.svg` (measured, nominal and extended amplitudes).
pub fn write_plots(
    dir: &Path,
    d: &Diagnosis,
    samples: &[Sample],
    nominal: &[Vec<num_complex::Complex64>],
    extended: &[Vec<num_complex::Complex64>],
) -> Result<Vec<PathBuf>, PlotError> {
    let rpm: Vec<f64> = samples.iter().map(|s| rad_s_to_rpm(s.omega)).collect();
    let mut files = Vec::new();
    let rn = residual_by_speed(d, samples, nominal);
    let re = residual_by_speed(d, samples, extended);
    let mut series = vec![
        Series::line("nominal model", rpm.clone(), rn).color((214, 39, 40)),
        Series::line(format!("extended ({})", d.effect.name()), rpm.clone(), re)
            .color((31, 119, 180)),
    ];
    if let Some(n) = d.noise_level {
        series.push(
            Series::line("noise level", vec![rpm[0], rpm[rpm.len() - 1]], vec![n, n])
                .color((100, 100, 100))
                .dashed(),
        );
    }
    let path = dir.join("diagnose_residual.svg");
    line_plot_with(
        &path,
        &format!("Relative residual against speed: {}", d.effect.name()),
        "speed (rpm)",
        "RMS relative residual",
        &series,
        &PlotOptions {
            log_y: true,
            ..PlotOptions::default()
        },
    )?;
    files.push(path);
    let nq = samples.first().map_or(0, |s| s.q.len());
    for c in 0..nq {
        let name = Channel::of_index(c).to_string();
        let amp = |v: &dyn Fn(usize) -> f64| (0..samples.len()).map(v).collect::<Vec<f64>>();
        // The nominal model as a pale wide band under the rest: where the
        // extended model equals it (effect `none`) both stay visible.
        let series = vec![
            crate::report::identify::model_band(
                "nominal model".into(),
                rpm.clone(),
                amp(&|k| nominal[k][c].norm() * 1e6),
                (214, 39, 40),
            ),
            Series::points(
                "measured",
                rpm.clone(),
                amp(&|k| samples[k].q[c].norm() * 1e6),
                Marker::Circle,
            )
            .color((60, 60, 60)),
            Series::line(
                format!("extended ({})", d.effect.name()),
                rpm.clone(),
                amp(&|k| extended[k][c].norm() * 1e6),
            )
            .color((31, 119, 180)),
        ];
        let path = dir.join(format!("diagnose_{name}.svg"));
        line_plot_with(
            &path,
            &format!("Probe {name}: measured and predicted 1X amplitude"),
            "speed (rpm)",
            "amplitude (um)",
            &series,
            &PlotOptions {
                log_y: true,
                ..PlotOptions::default()
            },
        )?;
        files.push(path);
    }
    Ok(files)
}
