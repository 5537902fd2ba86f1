//! The bank of hypotheses (module docs of [`crate::diagnose`], step 2):
//! each family of model extensions fitted by the same Levenberg-Marquardt
//! from the nominal estimate, the best variant of each kept as a
//! candidate. One module per family:
//!
//! * `speed_law`: `speed_dependent_bearing`;
//! * `pedestal`: `foundation_flexibility` (and the two pedestals of the
//!   pairs);
//! * `nodes`: `shaft_bow` and `extra_unbalance_plane`, screened over nodes;
//!   after the choice, `plane_spread` weighs the runs of nodes an extra
//!   unbalance could be spread over;
//! * `runout`: `probe_runout`;
//! * `modulus`: `shaft_stiffness_error`;
//! * `gain`: `probe_sensitivity`.

mod gain;
mod modulus;
mod nodes;
mod pedestal;
mod plane_spread;
mod runout;
mod section_ends;
mod speed_law;

pub(crate) use nodes::rescreen;
pub(crate) use pedestal::two_pedestals;
pub use pedestal::PEDESTAL_RATIOS;
pub(crate) use plane_spread::plane_spread;
pub(crate) use section_ends::section_ends;

use nalgebra::{DMatrix, DVector};

use crate::diagnose::candidate::Candidate;
use crate::diagnose::context::Context;
use crate::diagnose::effect::Effect;
use crate::diagnose::extended::{ExtendedModel, Extension};
use crate::diagnose::fit::{self, FitData};
use crate::diagnose::input::DiagnoseError;
use crate::diagnose::stages::Stages;
use crate::diagnose::terms::{SpeedTerms, StiffnessForm};
use modulus::ModulusFit;

/// The fitted bank.
pub(crate) struct Bank {
    /// The best fit of each family that fitted, in the order tried:
    /// speed law, pedestal, bow, extra plane, runout, modulus, gain.
    pub hypotheses: Vec<Candidate>,
    /// The terms at the fitted shaft-modulus factor, when the modulus'
    /// last round was fitted on them.
    pub e_terms: Option<(StiffnessForm, f64, Vec<SpeedTerms>)>,
    /// The model's own terms with their derivatives in the modulus factor
    /// at `e = 1`, when the modulus hypothesis was tried.
    pub terms_de: Option<Vec<SpeedTerms>>,
}

/// The families of the bank, in the order of [`Bank::hypotheses`] (bow
/// and extra plane one family).
#[derive(Debug, Clone, Copy)]
enum Family {
    SpeedLaw,
    Pedestal,
    Nodes,
    Runout,
    Modulus,
    Gain,
}

impl Family {
    const ALL: [Family; 6] = [
        Family::SpeedLaw,
        Family::Pedestal,
        Family::Nodes,
        Family::Runout,
        Family::Modulus,
        Family::Gain,
    ];

    /// The families fitted first: short, and each able to explain the
    /// data on its own, so that the others may stop behind them
    /// ([`run`]).
    const SHORT: [usize; 2] = [3, 5];

    /// The node effects, fitted next.
    const NODES: [usize; 1] = [2];

    /// The others, in the order the workers take them in: the longest
    /// first (measured on the paper, stepped hollow and three-bearing
    /// rotors).
    const LONG: [usize; 3] = [1, 0, 4];

    /// Whether its fits stop behind a fit at the noise of an earlier
    /// group ([`run`]). Not the pedestal search's: its fits cross the
    /// rotor's resonances and may creep before they fall, and a search
    /// whose fits end above the noise goes on to more starts (on a
    /// paper-rotor probe-gain case its stage took three to five times as
    /// long).
    fn stops_behind(self) -> bool {
        !matches!(self, Family::Pedestal)
    }

    /// The name of its lap.
    fn name(self) -> &'static str {
        match self {
            Family::SpeedLaw => Effect::SpeedDependentBearing.name(),
            Family::Pedestal => Effect::FoundationFlexibility.name(),
            Family::Nodes => "shaft_bow, extra_unbalance_plane",
            Family::Runout => Effect::ProbeRunout.name(),
            Family::Modulus => Effect::ShaftStiffnessError.name(),
            Family::Gain => Effect::ProbeSensitivity.name(),
        }
    }

    /// Its fit: the best candidate of each of its hypotheses, and for the
    /// modulus its terms.
    fn fit(self, ctx: &Context<'_>) -> Result<(Vec<Candidate>, Option<ModulusFit>), DiagnoseError> {
        Ok(match self {
            Family::SpeedLaw => (
                speed_law::speed_dependent_bearing(ctx)
                    .into_iter()
                    .collect(),
                None,
            ),
            Family::Pedestal => (
                pedestal::foundation_flexibility(ctx).into_iter().collect(),
                None,
            ),
            Family::Nodes => {
                let mut c = Vec::new();
                for effect in [Effect::ShaftBow, Effect::ExtraUnbalancePlane] {
                    c.extend(nodes::node_effect(ctx, effect)?);
                }
                (c, None)
            }
            Family::Runout => (runout::probe_runout(ctx).into_iter().collect(), None),
            Family::Modulus => (Vec::new(), Some(modulus::shaft_stiffness_error(ctx)?)),
            Family::Gain => (gain::probe_sensitivity(ctx)?.into_iter().collect(), None),
        })
    }
}

/// Fits every family of the bank, side by side on the context's threads
/// ([`crate::diagnose::parallel::map`]), in three groups: the short ones
/// (runout, gains), the node effects, the long ones; each group on data
/// marked explained when a group before it has a fit at the noise (module
/// docs of `fit`, "Behind a fit at the noise"). The families read the
/// context only, and the groups are fixed, so the result is the same on
/// any number of cores. A lap of
/// `clock` each, its own duration (with more than one core the laps add
/// up to more than the bank's wall-clock time).
pub(crate) fn run(ctx: &Context<'_>, clock: &mut Stages) -> Result<Bank, DiagnoseError> {
    let lap = |ctx: &Context<'_>, k: usize| {
        let t = std::time::Instant::now();
        let out = Family::ALL[k].fit(ctx);
        (k, out, t.elapsed().as_secs_f64())
    };
    // The short families first, then the node effects, then the long
    // ones; once a family explains the data to the noise, the fits of
    // those after it that stop behind one stop behind it.
    let mut fitted = Vec::new();
    let mut explained = false;
    for group in [&Family::SHORT[..], &Family::NODES, &Family::LONG] {
        let data = ctx.data.clone().with_explained(explained);
        let now = Context {
            data: &data,
            ..ctx.clone()
        };
        let out = crate::diagnose::parallel::map(group, ctx.threads(), |&k| {
            lap(
                if Family::ALL[k].stops_behind() {
                    &now
                } else {
                    ctx
                },
                k,
            )
        });
        explained |= out.iter().any(|(_, out, _)| {
            out.as_ref()
                .is_ok_and(|(c, _)| c.iter().any(|c| ctx.at_noise(&c.fit)))
        });
        fitted.extend(out);
    }
    // Back in the order of the hypotheses.
    fitted.sort_by_key(|(k, ..)| *k);
    let mut hypotheses: Vec<Candidate> = Vec::new();
    let (mut e_terms, mut terms_de) = (None, None);
    for (k, out, seconds) in fitted {
        let (c, m) = out?;
        hypotheses.extend(c);
        if let Some(m) = m {
            hypotheses.extend(m.candidate);
            (e_terms, terms_de) = (m.e_terms, m.terms_de);
        }
        clock.record(Family::ALL[k].name(), seconds);
    }
    Ok(Bank {
        hypotheses,
        e_terms,
        terms_de,
    })
}

/// Ranks the alternatives `exts` of one hypothesis (indices into `exts`)
/// by the drop in `S` that one Gauss-Newton step from the estimate
/// `theta0` of `base` predicts when the alternative is added (all of
/// `base`'s parameters free):
///
/// ```text
///     drop_k = g_k^T G_kk^-1 g_k,   g = J^T r,   G = J^T J
/// ```
///
/// over the nominal columns and the alternative's own, from one Jacobian
/// holding every alternative's columns.
pub(crate) fn screen(
    base: &ExtendedModel,
    data: &FitData<'_>,
    theta0: &[f64],
    exts: &[Extension],
) -> Result<Vec<usize>, DiagnoseError> {
    let singles: Vec<Vec<usize>> = (0..exts.len()).map(|k| vec![k]).collect();
    screen_groups(base, data, theta0, exts, &singles)
}

/// [`screen`] for groups of alternatives added together (indices into
/// `exts`; a group's columns are those of all its members): the groups
/// ranked (indices into `groups`) by the drop one Gauss-Newton step
/// predicts, from the same single Jacobian.
pub(crate) fn screen_groups(
    base: &ExtendedModel,
    data: &FitData<'_>,
    theta0: &[f64],
    exts: &[Extension],
    groups: &[Vec<usize>],
) -> Result<Vec<usize>, DiagnoseError> {
    let all = ExtendedModel {
        ext: base.ext.iter().chain(exts).copied().collect(),
        ..base.clone()
    };
    let mut theta = theta0.to_vec();
    theta.resize(all.n_params(), 0.0);
    let en = fit::entries(&all, data);
    let (r, jac) = fit::evaluate(&all, data, &en, &theta, true)?;
    let Some(j) = jac else {
        return Ok(Vec::new());
    };
    let g = j.tr_mul(&r);
    let gram = fit::gram(&j);
    let p0 = base.n_params();
    let nq = base.n_channels();
    let mut scored: Vec<(f64, usize)> = Vec::new();
    for (k, group) in groups.iter().enumerate() {
        let mut idx: Vec<usize> = (0..p0).collect();
        for &m in group {
            let o = all.offset(base.ext.len() + m);
            idx.extend(o..o + exts[m].n_params(nq));
        }
        let gs = DVector::from_iterator(idx.len(), idx.iter().map(|&i| g[i]));
        let gss = DMatrix::from_fn(idx.len(), idx.len(), |a, b| gram[(idx[a], idx[b])]);
        let drop = gss.cholesky().map(|c| gs.dot(&c.solve(&gs))).unwrap_or(0.0);
        scored.push((drop, k));
    }
    scored.sort_by(|a, b| b.0.total_cmp(&a.0));
    Ok(scored.into_iter().map(|(_, k)| k).collect())
}
