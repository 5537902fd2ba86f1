//! The honest choice (module docs of [`crate::diagnose`], step 3): every
//! hypothesis judged against the nominal fit by its likelihood ratio at
//! the false-alarm rate split over all alternatives tried (Bonferroni);
//! among the nominal model and the significant hypotheses the one of
//! least BIC; and, when that one still misfits ([`MISFIT_CHI2`]), the
//! pairs (`crate::diagnose::pairs`) or `unexplained`.

use crate::diagnose::candidate::Candidate;
use crate::diagnose::context::Context;
use crate::diagnose::effect::Effect;
use crate::diagnose::input::DiagnoseError;
use crate::diagnose::pairs::best_pair;
use crate::diagnose::terms::{SpeedTerms, StiffnessForm};

/// Chi-square per degree of freedom of the residual noise against the
/// model-free noise level above which a model does not fit: the same
/// threshold as `identify`'s misfit test.
pub use crate::estimate::refine::MISFIT_CHI2;

/// The yardsticks every candidate is measured with.
pub(crate) struct Judge {
    /// `sigma^2` of the statistics: the least of all fits.
    pub sigma2: f64,
    /// Real equations `N`.
    pub n_real: usize,
    /// The model-free relative noise level `s`, when known.
    pub noise_level: Option<f64>,
}

impl Judge {
    /// `BIC = S / sigma^2 + P ln N`.
    pub(crate) fn bic(&self, c: &Candidate) -> f64 {
        c.fit.s / self.sigma2 + c.fit.n_params() as f64 * (self.n_real as f64).ln()
    }

    /// Whether `c` does not fit: its residual noise above the noise level,
    /// `2 sigma_c^2 / s^2 > MISFIT_CHI2`, and its residual above `1e-6`.
    pub(crate) fn misfit(&self, c: &Candidate) -> bool {
        match self.noise_level {
            Some(s) if s > 0.0 => {
                let s_fit2 = 2.0 * c.fit.sigma2();
                s_fit2 / (s * s) > MISFIT_CHI2 && c.fit.residual() > 1e-6
            }
            _ => false,
        }
    }
}

/// The outcome of the choice.
pub(crate) struct Choice {
    /// The named effect.
    pub effect: Effect,
    /// Index of the chosen model in the hypotheses (`None`: nominal).
    pub chosen: Option<usize>,
    /// `sigma^2` used for the statistics.
    pub sigma2: f64,
    /// The warning of an unexplained misfit, if any.
    pub warnings: Vec<String>,
}

/// Judges every hypothesis of `hyps`, chooses among them and the nominal
/// model, and, when the chosen model misfits, appends the best pair to
/// `hyps` (chosen when it fits, else the answer is `unexplained`).
/// `e_cache`: the terms at the fitted modulus factor, for the pairs.
pub(crate) fn choose(
    ctx: &Context<'_>,
    hyps: &mut Vec<Candidate>,
    e_cache: &mut Option<(StiffnessForm, f64, Vec<SpeedTerms>)>,
) -> Result<Choice, DiagnoseError> {
    let nominal = ctx.nominal;
    let noise_level = ctx.setup.noise_level;
    let sigma2 = hyps
        .iter()
        .map(|c| c.fit.sigma2())
        .fold(nominal.fit.sigma2(), f64::min)
        .max(f64::MIN_POSITIVE);
    let alternatives: usize = hyps.iter().map(|c| c.alternatives).sum::<usize>().max(1);
    let alpha = ctx.opts.false_alarm / alternatives as f64;
    for c in hyps.iter_mut() {
        c.judge(&nominal.fit, sigma2, alpha);
    }
    let judge = Judge {
        sigma2,
        n_real: ctx.setup.n_real,
        noise_level,
    };
    let mut chosen: Option<usize> = None;
    let mut best_bic = judge.bic(nominal);
    for (i, c) in hyps.iter().enumerate() {
        if c.significant && judge.bic(c) < best_bic {
            best_bic = judge.bic(c);
            chosen = Some(i);
        }
    }
    let mut warnings = Vec::new();
    let mut effect = match chosen {
        Some(i) => hyps[i].effects[0],
        None => Effect::None,
    };
    let chosen_misfit = match chosen {
        Some(i) => judge.misfit(&hyps[i]),
        None => judge.misfit(nominal),
    };
    if chosen_misfit {
        match best_pair(ctx, hyps, &judge, e_cache)? {
            Some(mut c) if !judge.misfit(&c) => {
                c.judge(&nominal.fit, sigma2, alpha);
                effect = c.effects[0];
                hyps.push(c);
                chosen = Some(hyps.len() - 1);
            }
            other => {
                if let Some(mut c) = other {
                    c.statistic = (nominal.fit.s - c.fit.s) / sigma2;
                    hyps.push(c);
                }
                effect = Effect::Unexplained;
                chosen = None;
                warnings.push(format!(
                    "the misfit stays {:.1}x the noise level whatever effect is added: unexplained",
                    ((2.0 * nominal.fit.sigma2()).sqrt() / noise_level.unwrap_or(1.0)).max(0.0)
                ));
            }
        }
    }
    Ok(Choice {
        effect,
        chosen,
        sigma2,
        warnings,
    })
}
