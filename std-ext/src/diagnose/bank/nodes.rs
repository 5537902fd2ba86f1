//! `shaft_bow` and `extra_unbalance_plane`: an effect at one node (a bow
//! offset at an interior node; unbalance at a node that is not a plane),
//! the nodes ranked by the drop in misfit one Gauss-Newton step predicts
//! ([`screen`]), the best two fitted; and the same search again on top of
//! another effect's fit for the pairs (`rescreen`).

use crate::diagnose::bank::screen;
use crate::diagnose::candidate::Candidate;
use crate::diagnose::context::Context;
use crate::diagnose::effect::Effect;
use crate::diagnose::extended::{ExtendedModel, Extension};
use crate::diagnose::fit::{self, Fit, FitData};
use crate::diagnose::input::DiagnoseError;
use crate::model::RotorModel;

/// The best fit of `effect` (`ShaftBow` or `ExtraUnbalancePlane`) at one
/// node: the two nodes `screen` ranks first, each fitted from the nominal
/// estimate with the effect at zero. A bow has two shapes where the
/// bearings are not just the shaft's two ends: offset from the line
/// through the shaft's ends, and from the bearing line (zero at every
/// bearing, [`crate::fe::assembly::FeModel::line_bow_shape`]); the two
/// best nodes of each are fitted and the better fit (same parameter count)
/// kept. `None` when none fits.
pub(crate) fn node_effect(
    ctx: &Context<'_>,
    effect: Effect,
) -> Result<Option<Candidate>, DiagnoseError> {
    let model = ctx.model;
    let n_nodes = model.n_nodes();
    let families: Vec<Vec<Extension>> = match effect {
        Effect::ShaftBow => {
            let mut f = vec![(1..n_nodes.saturating_sub(1))
                .map(|node| Extension::Bow { node, line: false })
                .collect::<Vec<_>>()];
            if ctx.terms.first().is_some_and(|t| t.g_line.is_some()) {
                let bearings = model.bearing_nodes();
                f.push(
                    (0..n_nodes)
                        .filter(|n| !bearings.contains(n))
                        .map(|node| Extension::Bow { node, line: true })
                        .collect(),
                );
            }
            f
        }
        _ => vec![(0..n_nodes)
            .filter(|n| !model.planes.contains(n))
            .map(|node| Extension::Plane { node })
            .collect()],
    };
    let mut best: Option<(Fit, ExtendedModel, Extension)> = None;
    for exts in &families {
        let ranked = screen(ctx.base, ctx.data, &ctx.theta0, exts)?;
        for &i in ranked.iter().take(2) {
            let m = ctx.with_ext(vec![exts[i]]);
            if !ctx.n_room(m.n_params()) {
                continue;
            }
            let t = ctx.start_with(&m, &[]);
            if let Ok(f) = fit::fit(&m, ctx.data, &t, 50) {
                if best.as_ref().is_none_or(|b| f.s < b.0.s) {
                    best = Some((f, m, exts[i]));
                }
            }
        }
    }
    let Some((f, m, ext)) = best else {
        return Ok(None);
    };
    Ok(Some(Candidate::new(
        vec![effect],
        node_label(ext),
        m,
        f,
        1.0,
        families.iter().map(Vec::len).sum(),
    )))
}

/// The label of a node effect.
fn node_label(ext: Extension) -> String {
    match ext {
        Extension::Bow { node, line: false } => {
            format!("bow with its offset at node {}", node + 1)
        }
        Extension::Bow { node, line: true } => {
            format!("bow from the bearing line, offset at node {}", node + 1)
        }
        Extension::Plane { node } => format!("extra unbalance plane at node {}", node + 1),
        other => format!("{other:?}"),
    }
}

/// `b` (a node-searched effect) with its node searched again on top of
/// `a`'s fit: the two best nodes, each as a candidate whose effect
/// parameters start at zero.
pub(crate) fn rescreen(
    model: &RotorModel,
    data: &FitData<'_>,
    a: &Candidate,
    b: &Candidate,
) -> Result<Vec<Candidate>, DiagnoseError> {
    let n_nodes = model.n_nodes();
    let exts: Vec<Extension> = match b.model.ext.as_slice() {
        [Extension::Plane { .. }] => (0..n_nodes)
            .filter(|n| !model.planes.contains(n))
            .map(|node| Extension::Plane { node })
            .collect(),
        [Extension::Bow { line: false, .. }] => (1..n_nodes.saturating_sub(1))
            .map(|node| Extension::Bow { node, line: false })
            .collect(),
        [Extension::Bow { line: true, .. }] => {
            let bearings = model.bearing_nodes();
            (0..n_nodes)
                .filter(|n| !bearings.contains(n))
                .map(|node| Extension::Bow { node, line: true })
                .collect()
        }
        _ => return Ok(Vec::new()),
    };
    let ranked: Vec<Extension> = match screen(&a.model, data, &a.fit.theta, &exts) {
        Ok(r) => r.into_iter().map(|i| exts[i]).collect(),
        Err(_) => return Ok(Vec::new()),
    };
    let nom = b.model.pr.n_params();
    Ok(ranked
        .into_iter()
        .take(2)
        .filter(|e| b.model.ext != [*e])
        .map(|e| {
            let mut c = b.clone();
            c.model.ext = vec![e];
            c.fit.theta.truncate(nom);
            c.fit.theta.extend([0.0, 0.0]);
            c.label = node_label(e);
            c
        })
        .collect())
}
