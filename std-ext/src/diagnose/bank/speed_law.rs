//! `speed_dependent_bearing`: the bearing law one and two polynomial
//! orders above the nominal one (`K(Omega) = K_0 + Omega K_1 + Omega^2
//! K_2 + ...`, the same for `C`), and the film law
//! ([`Extension::FilmLaw`]: the direct and cross-coupled stiffness and
//! the direct damping of each bearing in proportion to the speed, three
//! parameters per bearing against the polynomial's eight); the best of the
//! three by BIC.
//!
//! Why the film law: the coefficients of a fluid-film bearing follow its
//! Sommerfeld number, which grows with the speed: the direct stiffness
//! rises, a cross-coupled stiffness of opposite signs (`k_yz > 0 > k_zy`)
//! grows from zero, the direct damping falls. A polynomial one order
//! higher covers that with 16 parameters on two bearings, whose BIC
//! penalty (16 ln n) can exceed what the law's misfit drop pays where the
//! effect is near the noise; a one-parameter effect elsewhere then wins.
//! The film law's 6 cost less than half as much.

use crate::diagnose::candidate::Candidate;
use crate::diagnose::context::Context;
use crate::diagnose::effect::Effect;
use crate::diagnose::extended::{ExtendedModel, Extension};
use crate::diagnose::fit::{self, Fit};
use crate::diagnose::nominal::{map_theta, oe_start};
use crate::diagnose::stats::bic;
use crate::estimate::predictor::Predictor;
use crate::estimate::Parametrization;
use rotorid_core::parametrization::{Structure, MAX_ORDER};

/// The best fit of the bearing laws of `physical` orders `order + 1` and
/// `order + 2` (up to `MAX_ORDER`, where the equations leave room): the
/// first the better of two starts ([`fit_from_two_starts`]), the second from
/// the first's fit with its new coefficients zero (the laws are nested, so
/// it starts where the lower order ended and can only fit better; a second
/// start would cost a filter and a fit with the most parameters of the
/// bank); chosen by BIC. `None` when none fits.
pub(crate) fn speed_dependent_bearing(ctx: &Context<'_>) -> Option<Candidate> {
    let (pr, n_real) = (&ctx.setup.pr, ctx.setup.n_real);
    let mut best: Option<(Fit, ExtendedModel, usize)> = None;
    // The estimate of the order below and its predictor, as the start of
    // the next (nested laws).
    let mut lower: Option<(Vec<f64>, Predictor)> = None;
    let mut alt = 0;
    for order in ctx.opts.order + 1..=(ctx.opts.order + 2).min(MAX_ORDER) {
        let param = Parametrization {
            structure: Structure::physical(order),
            ..pr.param.clone()
        };
        let prn = Predictor::new(param);
        if !ctx.n_room(prn.n_params()) {
            continue;
        }
        alt += 1;
        let m = ExtendedModel {
            pr: prn.clone(),
            ..ctx.base.clone()
        };
        let f_order = match lower.take() {
            // The law one order higher contains the one below: from its
            // fit, the new coefficients zero, `S` can only fall.
            Some((theta_low, pr_low)) => {
                let t = map_theta(&pr_low, &theta_low, &prn);
                fit::fit(&m, ctx.data, &t, 50).ok()
            }
            None => fit_from_two_starts(ctx, &m, order),
        };
        if let Some(f) = f_order {
            lower = Some((f.theta.clone(), prn));
            if best
                .as_ref()
                .is_none_or(|b| bic(&f, n_real) < bic(&b.0, n_real))
            {
                best = Some((f, m, order));
            }
        }
    }
    // The film law beside the nominal one, from the nominal estimate.
    let film = ctx.with_ext(vec![Extension::FilmLaw]);
    let mut film_fit = None;
    if ctx.n_room(film.n_params()) {
        alt += 1;
        let t = ctx.start_with(&film, &[]);
        film_fit = fit::fit(&film, ctx.data, &t, 50).ok();
    }
    let poly = best.map(|(f, m, order)| (f, m, format!("bearing law of physical order {order}")));
    let film = film_fit.map(|f| {
        (
            f,
            film,
            "film law: direct and cross-coupled stiffness, direct damping in proportion to the speed"
                .to_string(),
        )
    });
    let (f, m, label) = match (poly, film) {
        (Some(p), Some(q)) => {
            if bic(&q.0, n_real) < bic(&p.0, n_real) {
                q
            } else {
                p
            }
        }
        (p, q) => p.or(q)?,
    };
    Some(Candidate::new(
        vec![Effect::SpeedDependentBearing],
        label,
        m,
        f,
        1.0,
        alt,
    ))
}

/// The fit of the bearing law of `physical` order `order` (the model `m`),
/// the better of two starts: the nominal estimate with the higher orders
/// zero, and the law identified directly (filter, then output-error fit).
/// Its equations are linear in the law's coefficients, so the filter needs
/// no start, while the nominal constants can lie far from a law that
/// varies strongly.
fn fit_from_two_starts(ctx: &Context<'_>, m: &ExtendedModel, order: usize) -> Option<Fit> {
    let setup = ctx.setup;
    let t = map_theta(&setup.pr, &ctx.theta0, &m.pr);
    let mut best = fit::fit(m, ctx.data, &t, 50).ok();
    if let Ok((_, t2, _)) = oe_start(
        ctx.model,
        ctx.samples,
        ctx.terms,
        Structure::physical(order),
        setup.scaling,
        setup.held_noise(),
    ) {
        if t2.len() == m.n_params() {
            // From the filter's start to the first start's minimum: it
            // ends there.
            let known: Vec<&Fit> = best.iter().collect();
            if let Ok(f2) = fit::fit_known(m, ctx.data, &t2, 50, &known) {
                if best.as_ref().is_none_or(|b| f2.s < b.s) {
                    best = Some(f2);
                }
            }
        }
    }
    best
}
