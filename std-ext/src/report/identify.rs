//! The identification report: a text table of the estimates beside a
//! reference model, and SVG plots of the estimates against speed (like the
//! method paper's Figs. 4-6). Shared by `rotorid identify` and
//! `examples/paper.rs`.

use crate::estimate::noise::NoiseSource;
use thiserror::Error;

use crate::estimate::{Identification, StdSet};
use crate::model::RotorModel;
use rotorid_core::parametrization::Formulation;

const COEF: [&str; 4] = ["yy", "yz", "zy", "zz"];

/// The error of `x` against the model value `truth` (unit `unit`) as the
/// table prints it: relative, `|x - truth| / |truth|`, as a bare number;
/// where `truth` is 0 (no relative error exists) the absolute error
/// `|x - truth|` followed by its unit; for a phase (`phase`, degrees) the
/// absolute angle difference in (-180, 180] followed by `deg`.
pub fn error_cell(x: f64, truth: f64, unit: &str, phase: bool) -> String {
    if phase {
        let d = ((x - truth + 180.0).rem_euclid(360.0) - 180.0).abs();
        format!("{d:.2e} deg")
    } else if truth != 0.0 {
        format!("{:.2e}", (x - truth).abs() / truth.abs())
    } else {
        format!("{:.2e} {unit}", (x - truth).abs())
    }
}

/// A plain-text table of the final estimates (SI units, 1-based nodes),
/// their standard deviations when known ([`Identification::std`]) and,
/// when `reference` is given, the reference values (its bearing laws at the
/// last speed, its unbalance at the plane nodes) with their errors
/// ([`error_cell`]: relative as a bare number; absolute, followed by its
/// unit, for phases and where the model value is 0).
pub fn report_table(id: &Identification, reference: Option<&RotorModel>) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let omega = id.last.omega;
    let st = id.options.structure;
    let std = id.std();
    let rls = id.refinement.as_ref().map(|r| &r.rls);
    let _ = writeln!(
        s,
        "structure {} order {}, {} speeds ({} held by the steady-running guard), last speed {:.1} rpm",
        match st.formulation {
            Formulation::Paper => "paper",
            Formulation::Physical => "physical",
        },
        st.order,
        id.steps,
        id.frozen,
        crate::units::rad_s_to_rpm(omega)
    );
    let rows = table_rows(id, reference, std.as_ref(), rls);
    let absolute = write_rows(&mut s, rows, rls.is_some());
    if reference.is_some() {
        let _ = writeln!(
            s,
            "error: relative, |value - model| / |model|; phases: absolute, in deg{}",
            if absolute {
                "; where the model value is 0: absolute, |value - model|, with its unit"
            } else {
                ""
            }
        );
    }
    if st.formulation == Formulation::Paper {
        write_consistency(&mut s, id);
    }
    if std.is_some() {
        let _ = writeln!(
            s,
            "std: one standard deviation ({}); 95 % interval: value +- 1.96 std",
            if rls.is_some() {
                "inverse Fisher information at the estimate"
            } else {
                "sandwich covariance of the QRD/RLS estimate"
            }
        );
    }
    if let Some(d) = id.refinement.as_ref().and_then(|r| r.design.as_ref()) {
        write_design(&mut s, d);
    }
    if let Some(c) = &id.check {
        write_fit_check(&mut s, id, c);
    }
    if let Some(r) = id.refinement.as_ref().filter(|r| !r.runout.is_empty()) {
        let names = crate::io::measurement::default_channel_names(id.param.n_bearings());
        let _ = writeln!(s, "runout fitted (m, deg; one standard deviation):");
        for ((z, sd), n) in r.runout.iter().zip(&names) {
            let _ = writeln!(
                s,
                "  {n:<6} {:.3e} at {:7.2} deg  +- {:.2e}",
                z.norm(),
                z.arg().to_degrees(),
                sd
            );
        }
    }
    s
}

/// One quantity of [`report_table`]: its estimate, QRD/RLS estimate,
/// standard deviation and model value.
struct Row {
    name: String,
    value: f64,
    rls: Option<f64>,
    std: Option<f64>,
    model: Option<f64>,
    phase: bool,
    unit: &'static str,
}

/// The table's quantities: per bearing its stiffnesses and dampings, per
/// plane its unbalance m e and phase.
fn table_rows(
    id: &Identification,
    reference: Option<&RotorModel>,
    std: Option<&StdSet>,
    rls: Option<&crate::estimate::EstimateSet>,
) -> Vec<Row> {
    let omega = id.last.omega;
    let mut rows = Vec::new();
    for (m, b) in id.last.bearings.iter().enumerate() {
        let node = id
            .param
            .bearing_nodes
            .get(m)
            .map(|n| n + 1)
            .unwrap_or(m + 1);
        let truth = reference
            .and_then(|r| r.bearings.get(m))
            .map(|rb| rb.law.at(omega));
        let sd = std.and_then(|x| x.bearings.get(m));
        for (e, name) in COEF.iter().enumerate() {
            rows.push(Row {
                name: format!("b{}@{node} k{name}", m + 1),
                value: b.k[e],
                rls: rls.map(|r| r.bearings[m].k[e]),
                std: sd.map(|x| x.0[e]),
                model: truth.map(|t| t.k[e]),
                phase: false,
                unit: "N/m",
            });
        }
        for (e, name) in COEF.iter().enumerate() {
            rows.push(Row {
                name: format!("b{}@{node} c{name}", m + 1),
                value: b.c[e],
                rls: rls.map(|r| r.bearings[m].c[e]),
                std: sd.map(|x| x.1[e]),
                model: truth.map(|t| t.c[e]),
                phase: false,
                unit: "N s/m",
            });
        }
    }
    for (k, u) in id.last.unbalance.iter().enumerate() {
        let node = id.param.plane_nodes.get(k).copied().unwrap_or(k);
        let truth = reference.and_then(|r| r.unbalance.iter().find(|t| t.node == node));
        let sd = std.and_then(|x| x.unbalance.get(k));
        rows.push(Row {
            name: format!("n{} me", node + 1),
            value: u.me,
            rls: rls.map(|r| r.unbalance[k].me),
            std: sd.map(|x| x.0),
            model: truth.map(|t| t.me),
            phase: false,
            unit: "kg m",
        });
        rows.push(Row {
            name: format!("n{} phase_deg", node + 1),
            value: u.phase_deg(),
            rls: rls.map(|r| r.unbalance[k].phase_deg()),
            std: sd.map(|x| x.1),
            model: truth.map(|t| t.phase.to_degrees()),
            phase: true,
            unit: "deg",
        });
    }
    rows
}

/// Writes the table's header and `rows` (with the QRD/RLS columns when
/// `with_rls`); returns whether some error is absolute (a model value of
/// 0 that is not a phase).
fn write_rows(s: &mut String, rows: Vec<Row>, with_rls: bool) -> bool {
    use std::fmt::Write;
    let _ = writeln!(
        s,
        "{:<14} {:>14} {:>10} {:>14} {:>14}{}",
        "quantity",
        if with_rls {
            "output-error"
        } else {
            "identified"
        },
        "std",
        "model",
        "error",
        if with_rls {
            format!(" {:>14} {:>14}", "QRD/RLS", "error")
        } else {
            String::new()
        }
    );
    let num = |x: f64, phase: bool| {
        if phase {
            format!("{x:.6}")
        } else {
            format!("{x:.6e}")
        }
    };
    let mut absolute = false;
    for r in rows {
        let sd = r
            .std
            .map(|x| format!("{x:.2e}"))
            .unwrap_or_else(|| "-".into());
        absolute |= r.model == Some(0.0) && !r.phase;
        let err_of = |v: f64| match r.model {
            Some(t) => error_cell(v, t, r.unit, r.phase),
            None => "-".into(),
        };
        let model = r.model.map_or_else(|| "-".into(), |t| num(t, r.phase));
        let side = r
            .rls
            .map(|v| format!(" {:>14} {:>14}", num(v, r.phase), err_of(v)))
            .unwrap_or_default();
        let _ = writeln!(
            s,
            "{:<14} {:>14} {:>10} {:>14} {:>14}{side}",
            r.name,
            num(r.value, r.phase),
            sd,
            model,
            err_of(r.value)
        );
    }
    absolute
}

/// Writes the paper formulation's consistency terms (Im Z0, Re Z1, zero
/// for a physical bearing) per bearing.
fn write_consistency(s: &mut String, id: &Identification) {
    use std::fmt::Write;
    let _ = writeln!(
        s,
        "consistency (physically zero): Im Z0 (N/m), Re Z1 (N s/m)"
    );
    for (m, b) in id.last.bearings.iter().enumerate() {
        if let (Some(i0), Some(r1)) = (b.im_z0, b.re_z1) {
            let _ = writeln!(
                s,
                "b{} Im Z0 {:.3e} {:.3e} {:.3e} {:.3e}   Re Z1 {:.3e} {:.3e} {:.3e} {:.3e}",
                m + 1,
                i0[0],
                i0[1],
                i0[2],
                i0[3],
                r1[0],
                r1[1],
                r1[2],
                r1[3]
            );
        }
    }
}

/// Writes the design of the test: each parameter's Cramer-Rao bound and
/// the speeds that measure it, then the design's notes.
fn write_design(s: &mut String, d: &crate::estimate::design::TestDesign) {
    use std::fmt::Write;
    let _ = writeln!(
        s,
        "design of the test (Cramer-Rao bounds at the noise level):"
    );
    for p in &d.parameters {
        let _ = writeln!(
            s,
            "  {:<14} bound {:.2e} ({:.2e} of {:.3e}), measured between {:.0} and {:.0} rpm",
            p.name,
            p.crb,
            p.crb / p.reference.max(f64::MIN_POSITIVE),
            p.reference,
            p.band_rpm.0,
            p.band_rpm.1
        );
    }
    for n in &d.notes {
        let _ = writeln!(s, "  {n}");
    }
}

/// Writes the check of the fit: noise level, misfit and chi2/dof, the noise
/// model, and the outliers left out.
fn write_fit_check(s: &mut String, id: &Identification, c: &crate::estimate::refine::FitCheck) {
    use std::fmt::Write;
    let _ = writeln!(
        s,
        "noise level (from the data, without the model) {}; misfit {:.3e}; chi2/dof {}",
        c.noise_level.map_or("-".into(), |x| format!("{x:.3e}")),
        c.residual,
        c.chi2_per_dof.map_or("-".into(), |x| format!("{x:.2}"))
    );
    let names = crate::io::measurement::default_channel_names(id.param.n_bearings());
    if let Some(m) = c
        .noise
        .as_ref()
        .filter(|m| m.has_floor() || m.source != NoiseSource::Estimated)
    {
        let floors: Vec<String> = m.floor_m.iter().map(|f| format!("{f:.2e}")).collect();
        let _ = writeln!(
            s,
            "noise model ({}): floor {} m ({}), relative {:.3e}",
            m.source.name(),
            floors.join(", "),
            names.join(", "),
            m.relative
        );
    }
    if !c.outliers.is_empty() {
        let _ = writeln!(s, "outliers excluded from the fit: {}", c.outliers.len());
        for o in &c.outliers {
            let _ = writeln!(
                s,
                "  {} at {:.1} rpm: {:.1} standard deviations",
                names.get(o.channel).map_or("?", String::as_str),
                crate::units::rad_s_to_rpm(o.omega),
                o.sigmas
            );
        }
    }
}

/// A reference curve drawn as a pale band 8 px wide in a light tint of
/// `color`, to go under the estimate's 2 px line of the same colour.
pub fn model_band(
    label: String,
    x: Vec<f64>,
    y: Vec<f64>,
    color: (u8, u8, u8),
) -> crate::report::plot::Series {
    crate::report::plot::Series::line(label, x, y)
        .color(crate::report::plot::pale(color, 0.6))
        .width(8)
}

/// The reported estimate along the speeds `rpm` (`value`), a dashed line,
/// and with its standard deviations `std` its 95 % band (`+-1.96 std`), two
/// dotted lines of one legend entry.
fn reported_series(
    label: &str,
    rpm: &[f64],
    value: impl Iterator<Item = f64>,
    std: Option<Vec<f64>>,
    color: (u8, u8, u8),
) -> Vec<crate::report::plot::Series> {
    use crate::report::plot::{pale, Series};
    let v: Vec<f64> = value.collect();
    let mut out = vec![
        Series::line(format!("{label} reported"), rpm.to_vec(), v.clone())
            .color(color)
            .dash_pattern(10, 4)
            .width(2),
    ];
    if let Some(sd) = std {
        for sign in [1.0, -1.0] {
            let y = v
                .iter()
                .zip(&sd)
                .map(|(a, s)| a + sign * 1.96 * s)
                .collect();
            out.push(
                Series::line(format!("{label} reported, 95 %"), rpm.to_vec(), y)
                    .color(pale(color, 0.3))
                    .dash_pattern(2, 3),
            );
        }
    }
    out
}

/// Errors of [`write_plots`].
#[derive(Debug, Error)]
pub enum ReportError {
    /// Writing a plot failed.
    #[error(transparent)]
    Plot(#[from] crate::report::plot::PlotError),
    /// Creating the folder failed.
    #[error("{}: {source}", path.display())]
    Io {
        /// The folder.
        path: std::path::PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The identified rotor is not a valid model.
    #[error("identified model: {0}")]
    Model(#[from] crate::model::ModelError),
    /// The Campbell analysis failed.
    #[error("campbell: {0}")]
    Campbell(#[from] crate::fe::assembly::FeError),
    /// No history was recorded.
    #[error("no estimates recorded against speed")]
    NoHistory,
}

/// Writes SVG plots of the estimates against speed into `dir` (created if
/// needed), like the paper's Figs. 4 and 5: per bearing its stiffness and its
/// damping (identified as lines; the `reference` model's values as dashed
/// lines), the unbalance m e and phase per plane, and the Campbell diagram
/// of the identified rotor (lines) against the reference rotor (points) up to
/// `rpm_max`, like Fig. 6 (left out for a model beyond the limits of
/// [`crate::fe::campbell::check_size`]). `prefix` starts every file name.
/// Returns the files written.
pub fn write_plots(
    dir: &std::path::Path,
    prefix: &str,
    id: &Identification,
    model: &RotorModel,
    reference: Option<&RotorModel>,
    rpm_max: f64,
) -> Result<Vec<std::path::PathBuf>, ReportError> {
    use crate::units::rad_s_to_rpm;
    if id.history.is_empty() {
        return Err(ReportError::NoHistory);
    }
    std::fs::create_dir_all(dir).map_err(|source| ReportError::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    let mut files = Vec::new();
    let rpm: Vec<f64> = id.history.iter().map(|h| rad_s_to_rpm(h.omega)).collect();
    // The reported estimate (the output-error one by default; the path is
    // the QRD/RLS's) and its standard deviations along the speeds.
    let laws = id.bearing_laws();
    let stds: Option<Vec<StdSet>> = id.history.iter().map(|h| id.std_at(h.omega)).collect();
    let inputs = PlotInputs {
        dir,
        prefix,
        id,
        reference,
        rpm,
        laws,
        stds,
    };
    for (m, _) in id.last.bearings.iter().enumerate() {
        for (what, unit, pick) in [("stiffness", "N/m", 0usize), ("damping", "N s/m", 1usize)] {
            files.push(bearing_plot(&inputs, m, what, unit, pick)?);
        }
    }
    for (what, unit) in [("me", "kg m"), ("phase", "deg")] {
        files.push(unbalance_plot(&inputs, what, unit)?);
    }
    if let Some(path) = campbell_plot(dir, prefix, id, model, reference, rpm_max)? {
        files.push(path);
    }
    Ok(files)
}

/// What the plots against speed of [`write_plots`] draw from.
struct PlotInputs<'a> {
    /// The folder of the plots.
    dir: &'a std::path::Path,
    /// The start of every file name.
    prefix: &'a str,
    /// The identification.
    id: &'a Identification,
    /// The model drawn under the estimates.
    reference: Option<&'a RotorModel>,
    /// The speeds of the history (rpm).
    rpm: Vec<f64>,
    /// The reported bearing laws.
    laws: Vec<crate::model::BearingLaw>,
    /// The reported standard deviations along the speeds.
    stds: Option<Vec<StdSet>>,
}

/// The plot of bearing `m`'s stiffnesses (`pick` 0) or dampings (`pick` 1)
/// against speed; returns its file.
fn bearing_plot(
    inputs: &PlotInputs,
    m: usize,
    what: &str,
    unit: &str,
    pick: usize,
) -> Result<std::path::PathBuf, ReportError> {
    use crate::report::plot::{line_plot_with, PlotOptions};
    let id = inputs.id;
    let series = bearing_series(inputs, m, pick);
    let path = inputs
        .dir
        .join(format!("{}bearing{}_{what}.svg", inputs.prefix, m + 1));
    let node = id
        .param
        .bearing_nodes
        .get(m)
        .map(|n| n + 1)
        .unwrap_or(m + 1);
    let title = format!("Bearing {} (node {node}): identified {what}", m + 1);
    // Keep the axis on the physical range: early transients of an
    // RLS run can be orders of magnitude off.
    let mut opts = PlotOptions::default();
    if let Some(r) = inputs.reference.and_then(|r| r.bearings.get(m)) {
        let mut lo = f64::INFINITY;
        let mut hi = f64::NEG_INFINITY;
        for h in &id.history {
            let c = r.law.at(h.omega);
            for v in if pick == 0 { c.k } else { c.c } {
                lo = lo.min(v);
                hi = hi.max(v);
            }
        }
        // ... and on the reported estimate with its band.
        for sr in series.iter().filter(|sr| sr.label.contains("reported")) {
            for v in sr.y.iter().filter(|v| v.is_finite()) {
                lo = lo.min(*v);
                hi = hi.max(*v);
            }
        }
        let span = (hi - lo).max(hi.abs().max(lo.abs()) * 0.1).max(1e-12);
        opts.y_range = Some((lo - 0.5 * span, hi + 0.5 * span));
    }
    line_plot_with(&path, &title, "speed (rpm)", unit, &series, &opts)?;
    Ok(path)
}

/// The curves of bearing `m`'s stiffness (`pick` 0) or damping (`pick` 1)
/// plot, per coefficient: the model's band, the QRD/RLS path and the
/// reported estimate with its 95 % band.
fn bearing_series(inputs: &PlotInputs, m: usize, pick: usize) -> Vec<crate::report::plot::Series> {
    use crate::report::plot::{Series, PALETTE};
    let (id, rpm) = (inputs.id, &inputs.rpm);
    let mut series = Vec::new();
    for (e, name) in COEF.iter().enumerate() {
        let y: Vec<f64> = id
            .history
            .iter()
            .map(|h| {
                let b = &h.estimate.bearings[m];
                if pick == 0 {
                    b.k[e]
                } else {
                    b.c[e]
                }
            })
            .collect();
        let letter = if pick == 0 { "k" } else { "c" };
        let color = PALETTE[e % PALETTE.len()];
        // The model under the estimate: a pale wide band of the
        // same colour, so that neither hides the other where they
        // agree.
        if let Some(r) = inputs.reference.and_then(|r| r.bearings.get(m)) {
            let yt: Vec<f64> = id
                .history
                .iter()
                .map(|h| {
                    let c = r.law.at(h.omega);
                    if pick == 0 {
                        c.k[e]
                    } else {
                        c.c[e]
                    }
                })
                .collect();
            series.push(model_band(
                format!("{letter}{name} model"),
                rpm.clone(),
                yt,
                color,
            ));
        }
        series.push(
            Series::line(format!("{letter}{name} QRD/RLS path"), rpm.clone(), y).color(color),
        );
        if let Some(law) = inputs.laws.get(m) {
            series.extend(reported_series(
                &format!("{letter}{name}"),
                rpm,
                id.history.iter().map(|h| {
                    let c = law.at(h.omega);
                    if pick == 0 {
                        c.k[e]
                    } else {
                        c.c[e]
                    }
                }),
                inputs.stds.as_ref().map(|sd| {
                    sd.iter()
                        .map(|s| {
                            let (k, c) = s.bearings[m];
                            if pick == 0 {
                                k[e]
                            } else {
                                c[e]
                            }
                        })
                        .collect()
                }),
                color,
            ));
        }
    }
    series
}

/// The plot of the unbalances' m e (`what` `"me"`) or phase against speed,
/// one curve set per plane; returns its file.
fn unbalance_plot(
    inputs: &PlotInputs,
    what: &str,
    unit: &str,
) -> Result<std::path::PathBuf, ReportError> {
    use crate::report::plot::{line_plot_with, PlotOptions, Series, PALETTE};
    let (id, reference, rpm) = (inputs.id, inputs.reference, &inputs.rpm);
    let mut series = Vec::new();
    for (k, _) in id.last.unbalance.iter().enumerate() {
        let node = id.param.plane_nodes.get(k).copied().unwrap_or(k);
        let y: Vec<f64> = id
            .history
            .iter()
            .map(|h| {
                let u = &h.estimate.unbalance[k];
                if what == "me" {
                    u.me
                } else {
                    u.phase_deg()
                }
            })
            .collect();
        let color = PALETTE[k % PALETTE.len()];
        if let Some(t) = reference.and_then(|r| r.unbalance.iter().find(|t| t.node == node)) {
            let v = if what == "me" {
                t.me
            } else {
                t.phase.to_degrees()
            };
            series.push(model_band(
                format!("node {} model", node + 1),
                rpm.clone(),
                vec![v; rpm.len()],
                color,
            ));
        }
        series.push(
            Series::line(format!("node {} QRD/RLS path", node + 1), rpm.clone(), y).color(color),
        );
        let u = &id.last.unbalance[k];
        let v = if what == "me" { u.me } else { u.phase_deg() };
        series.extend(reported_series(
            &format!("node {}", node + 1),
            rpm,
            std::iter::repeat_n(v, rpm.len()),
            inputs.stds.as_ref().map(|sd| {
                sd.iter()
                    .map(|s| {
                        let (me, ph) = s.unbalance[k];
                        if what == "me" {
                            me
                        } else {
                            ph
                        }
                    })
                    .collect()
            }),
            color,
        ));
    }
    let path = inputs
        .dir
        .join(format!("{}unbalance_{what}.svg", inputs.prefix));
    let mut opts = PlotOptions::default();
    if what == "me" {
        let top = reference
            .map(|r| r.unbalance.iter().map(|u| u.me).fold(0.0, f64::max))
            .unwrap_or(0.0);
        if top > 0.0 {
            opts.y_range = Some((0.0, 2.0 * top));
        }
    } else {
        opts.y_range = Some((-180.0, 180.0));
    }
    line_plot_with(
        &path,
        &format!("Identified unbalance: {what}"),
        "speed (rpm)",
        unit,
        &series,
        &opts,
    )?;
    Ok(path)
}

/// The Campbell diagram of the identified rotor (Fig. 6) against the
/// `reference` rotor up to `rpm_max`; returns its file, or `None` for a
/// model beyond the diagram's size limits.
fn campbell_plot(
    dir: &std::path::Path,
    prefix: &str,
    id: &Identification,
    model: &RotorModel,
    reference: Option<&RotorModel>,
    rpm_max: f64,
) -> Result<Option<std::path::PathBuf>, ReportError> {
    use crate::report::plot::{line_plot, Marker, Series};
    use crate::units::rad_s_to_rpm;
    let ident = id.identified_model(model);
    let speeds: Vec<f64> = (0..=30)
        .map(|i| crate::units::rpm_to_rad_s(rpm_max * i as f64 / 30.0))
        .collect();
    // A model beyond the Campbell diagram's size limits gets the other
    // plots only.
    if crate::fe::campbell::check_size(4 * ident.n_nodes(), 2 * speeds.len()).is_err() {
        return Ok(None);
    }
    let copts = crate::fe::campbell::ModeSelection {
        max_frequency: Some(2.0 * crate::units::rpm_to_rad_s(rpm_max)),
        max_modes: 8,
    };
    let diagram = |m: &RotorModel| -> Result<_, ReportError> {
        let fe = crate::fe::assembly::FeModel::new(m)?;
        Ok(crate::fe::campbell::diagram_with(&fe, &speeds, &copts)?)
    };
    let di = diagram(&ident)?;
    let mut series = Vec::new();
    let n_modes = di.points.iter().map(|p| p.modes.len()).max().unwrap_or(0);
    let hz = |w: f64| w / (2.0 * core::f64::consts::PI);
    for j in 0..n_modes {
        let (x, y): (Vec<f64>, Vec<f64>) = di
            .points
            .iter()
            .filter_map(|p| {
                p.modes
                    .get(j)
                    .map(|md| (rad_s_to_rpm(p.omega), hz(md.frequency)))
            })
            .unzip();
        // One legend entry for all the identified rotor's modes.
        let label = if j == 0 { "identified rotor" } else { "" };
        series.push(Series::line(label, x, y).color((31, 119, 180)));
    }
    if let Some(r) = reference {
        let dr = diagram(r)?;
        let (x, y): (Vec<f64>, Vec<f64>) = dr
            .points
            .iter()
            .flat_map(|p| {
                p.modes
                    .iter()
                    .map(move |md| (rad_s_to_rpm(p.omega), hz(md.frequency)))
            })
            .unzip();
        // Hollow: the identified line through a point stays visible.
        series.push(Series::points("model rotor", x, y, Marker::Ring).color((214, 39, 40)));
    }
    series.push(
        Series::line("1X", vec![0.0, rpm_max], vec![0.0, rpm_max / 60.0])
            .dashed()
            .color((0, 0, 0)),
    );
    let path = dir.join(format!("{prefix}campbell_identified.svg"));
    line_plot(
        &path,
        "Campbell diagram of the identified rotor",
        "speed (rpm)",
        "frequency (Hz)",
        &series,
    )?;
    Ok(Some(path))
}
