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
/// estimate with the effect at zero. `None` when neither fits.
pub(crate) fn node_effect(
    ctx: &Context<'_>,
    effect: Effect,
) -> Result<Option<Candidate>, DiagnoseError> {
    let model = ctx.model;
    let n_nodes = model.n_nodes();
    let nodes: Vec<usize> = match effect {
        Effect::ShaftBow => (1..n_nodes.saturating_sub(1)).collect(),
        _ => (0..n_nodes).filter(|n| !model.planes.contains(n)).collect(),
    };
    let make = |node: usize| match effect {
        Effect::ShaftBow => Extension::Bow { node },
        _ => Extension::Plane { node },
    };
    let exts: Vec<Extension> = nodes.iter().map(|&n| make(n)).collect();
    let ranked: Vec<usize> = screen(ctx.base, ctx.data, &ctx.theta0, &exts)?
        .into_iter()
        .map(|i| nodes[i])
        .collect();
    let mut best: Option<(Fit, ExtendedModel, usize)> = None;
    for &node in ranked.iter().take(2) {
        let m = ctx.with_ext(vec![make(node)]);
        if !ctx.n_room(m.n_params()) {
            continue;
        }
        let t = ctx.start_with(&m, &[]);
        if let Ok(f) = fit::fit(&m, ctx.data, &t, 50) {
            if best.as_ref().is_none_or(|b| f.s < b.0.s) {
                best = Some((f, m, node));
            }
        }
    }
    let Some((f, m, node)) = best else {
        return Ok(None);
    };
    let label = match effect {
        Effect::ShaftBow => format!("bow with its offset at node {}", node + 1),
        _ => format!("extra unbalance plane at node {}", node + 1),
    };
    Ok(Some(Candidate::new(
        vec![effect],
        label,
        m,
        f,
        1.0,
        nodes.len(),
    )))
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
    let kind = match b.model.ext.as_slice() {
        [Extension::Plane { .. }] => 0,
        [Extension::Bow { .. }] => 1,
        _ => return Ok(Vec::new()),
    };
    let n_nodes = model.n_nodes();
    let nodes: Vec<usize> = if kind == 1 {
        (1..n_nodes.saturating_sub(1)).collect()
    } else {
        (0..n_nodes).filter(|n| !model.planes.contains(n)).collect()
    };
    let make = |node: usize| {
        if kind == 1 {
            Extension::Bow { node }
        } else {
            Extension::Plane { node }
        }
    };
    let exts: Vec<Extension> = nodes.iter().map(|&n| make(n)).collect();
    let ranked: Vec<usize> = match screen(&a.model, data, &a.fit.theta, &exts) {
        Ok(r) => r.into_iter().map(|i| nodes[i]).collect(),
        Err(_) => return Ok(Vec::new()),
    };
    let nom = b.model.pr.n_params();
    Ok(ranked
        .into_iter()
        .take(2)
        .filter(|&n| b.model.ext != [make(n)])
        .map(|n| {
            let mut c = b.clone();
            c.model.ext = vec![make(n)];
            c.fit.theta.truncate(nom);
            c.fit.theta.extend([0.0, 0.0]);
            c.label = match kind {
                1 => format!("bow with its offset at node {}", n + 1),
                _ => format!("extra unbalance plane at node {}", n + 1),
            };
            c
        })
        .collect())
}
