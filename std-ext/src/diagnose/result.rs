//! The result of a diagnosis and its shaping for reports: [`Diagnosis`]
//! (the named effect, every model fitted, the choice, the observability),
//! the identified size of each effect with standard deviations
//! ([`Finding`], [`findings`]), the bearings and plane unbalances of a
//! model in the identification's result types ([`estimates`]), and the
//! readings a model predicts ([`predictions`]).

use num_complex::Complex64;
use serde::Serialize;

use crate::diagnose::candidate::{Candidate, FormFit};
use crate::diagnose::effect::Effect;
use crate::diagnose::extended::{Extension, PedestalParams, E_STEP, GAIN_STEP};
use crate::diagnose::fit::{Fit, FitData};
use crate::diagnose::input::DiagnoseError;
use crate::diagnose::observe;
use crate::diagnose::terms::{self, SpeedTerms};
use crate::estimate::noise::NoiseModel;
use crate::estimate::results::{BearingResult, BearingStd, Coefficients, UnbalanceResult};
use crate::io::measurement::Measurements;
use crate::model::{BowPoint, RotorModel};

/// The size of an identified effect, with standard deviations.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "effect", rename_all = "snake_case")]
pub enum Finding {
    /// Speed-dependent bearings: the law's order and each bearing's
    /// stiffness at the lowest and highest speed (N/m).
    SpeedDependentBearing {
        /// Polynomial order identified (the nominal one for the film law).
        order: usize,
        /// The law's form: `"polynomial"` (of `order`), or `"film"`
        /// ([`Extension::FilmLaw`]: the direct and cross-coupled
        /// stiffness and the direct damping in proportion to the speed,
        /// beside the nominal law).
        form: &'static str,
        /// Per bearing: `(node, K at the lowest speed, K at the highest)`.
        stiffness: Vec<(usize, Coefficients, Coefficients)>,
    },
    /// A pedestal under a bearing.
    FoundationFlexibility {
        /// Bearing node (1-based).
        node: usize,
        /// Mass (kg): the geometric mean of `masses`.
        mass: f64,
        /// Its standard deviation.
        mass_std: f64,
        /// Masses in y and z (kg): equal unless the variant with two
        /// masses was found.
        masses: [f64; 2],
        /// Natural frequencies on its springs, y and z (Hz).
        natural_frequency_hz: [f64; 2],
        /// Their standard deviations.
        natural_frequency_hz_std: [f64; 2],
        /// Damping ratios, y and z.
        damping_ratio: [f64; 2],
        /// Stiffness y, z (N/m).
        k: [f64; 2],
        /// Damping y, z (N s/m).
        c: [f64; 2],
    },
    /// A bent shaft.
    ShaftBow {
        /// Node of the offset (1-based).
        node: usize,
        /// Offset amplitude (m).
        amplitude: f64,
        /// Its standard deviation.
        amplitude_std: f64,
        /// Phase (deg).
        phase_deg: f64,
        /// Its standard deviation.
        phase_deg_std: f64,
        /// What the offset is measured from: `"shaft ends"` (the shape
        /// zero at the first and last node) or `"bearing line"` (zero at
        /// every bearing).
        reference: &'static str,
    },
    /// Probe runout per channel.
    ProbeRunout {
        /// Each channel's phasor.
        channels: Vec<RunoutFinding>,
    },
    /// Unbalance at another node, or shared equally by a run of nodes.
    ExtraUnbalancePlane {
        /// Node (1-based); for a run of nodes, the middle one (the lower
        /// of the two middle ones for an even run).
        node: usize,
        /// The nodes the unbalance is at, 1-based: `"7"` for a plane,
        /// `"6..8"` for an unbalance shared equally by nodes 6 to 8 (the
        /// bank's variant for an unbalance spread along a section).
        nodes: String,
        /// `m e` (kg m), the total of a run.
        me: f64,
        /// Its standard deviation: the fit's, with the part added in
        /// quadrature that the runs of nodes the data cannot tell from the
        /// plane leave open (`Candidate::spread_std`).
        me_std: f64,
        /// Phase (deg).
        phase_deg: f64,
        /// Its standard deviation.
        phase_deg_std: f64,
        /// The runs of nodes, with the `m e` shared equally along each, of
        /// least and greatest `m e` among those the data cannot tell from
        /// the best run (`Candidate::spread`): where along the shaft the
        /// unbalance may lie; empty when the plane alone fits.
        spread: Vec<PlaneRun>,
    },
    /// The shaft's modulus off.
    ShaftStiffnessError {
        /// The factor (on what `form` says).
        factor: f64,
        /// Its standard deviation; for a section's diameter, the fit's
        /// with the part the section's ends leave open added in
        /// quadrature (`Candidate::ends_std`).
        factor_std: f64,
        /// What the factor multiplies: "the shaft's E and G", "the
        /// shaft's E (G kept)" or "the outer diameter of shaft elements
        /// a..b" (1-based).
        form: String,
        /// The other forms that fit within the noise as well
        /// ([`Diagnosis::stiffness_alike`]), best first: the data cannot
        /// tell them from `form`.
        alike: Vec<StiffnessAlike>,
        /// For a section's diameter: the runs of elements of least and
        /// greatest factor among those the data cannot tell from the best
        /// run (which fits at least as well as `form`): the section's ends
        /// the data leave open (`Candidate::ends`); empty otherwise.
        ends: Vec<SectionRun>,
    },
    /// A probe whose scale factor is off: it reads `gain` times the
    /// signal (`gain - 1` the sensitivity error).
    ProbeSensitivity {
        /// The channel (`b1_y`, ..., or `n7_z` for a probe at node 7).
        channel: String,
        /// The factor on the reading.
        gain: f64,
        /// Its standard deviation.
        gain_std: f64,
    },
}

/// A form of a stiffness error that fits as well as the one found.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StiffnessAlike {
    /// What the factor multiplies (as [`Finding::ShaftStiffnessError`]'s
    /// `form`).
    pub form: String,
    /// The factor.
    pub factor: f64,
    /// Its standard deviation.
    pub factor_std: f64,
}

/// A run of the shaft's elements the data cannot tell from the best run,
/// with its diameter factor (linearised about the fit found, or after its
/// Gauss-Newton steps: `diagnose::bank::section_ends`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SectionRun {
    /// What the factor multiplies ("the outer diameter of shaft elements
    /// a..b", 1-based).
    pub form: String,
    /// The diameter factor.
    pub factor: f64,
}

/// A run of nodes an extra unbalance may be spread over, equally, that
/// the data cannot tell from the best run (`diagnose::bank::plane_spread`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PlaneRun {
    /// The nodes, 1-based (`"7"` or `"7..9"`).
    pub nodes: String,
    /// The total `m e` along them (kg m).
    pub me: f64,
}

/// The runout of one channel.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RunoutFinding {
    /// Channel name (`b1_y`, ...).
    pub channel: String,
    /// Amplitude (m).
    pub amplitude: f64,
    /// Its standard deviation.
    pub amplitude_std: f64,
    /// Phase (deg).
    pub phase_deg: f64,
    /// Its standard deviation.
    pub phase_deg_std: f64,
    /// Whether it is above 3 standard deviations.
    pub significant: bool,
}

/// The result of [`diagnose`](crate::diagnose::diagnose()).
#[derive(Debug, Clone)]
pub struct Diagnosis {
    /// The named effect (the stronger of a pair).
    pub effect: Effect,
    /// The effects of the chosen model (empty for `none`/`unexplained`).
    pub effects: Vec<Effect>,
    /// The model-free noise level, when the speeds allow it.
    pub noise_level: Option<f64>,
    /// The noise model the fits were weighted with (SPEC section 7).
    pub noise: Option<NoiseModel>,
    /// The nominal model.
    pub nominal: Candidate,
    /// Every hypothesis fitted (best variant of each), pairs included.
    pub hypotheses: Vec<Candidate>,
    /// Index in `hypotheses` of the chosen model (`None`: nominal).
    pub chosen: Option<usize>,
    /// `sigma^2` used for the statistics.
    pub sigma2: f64,
    /// The false-alarm rate of the choice.
    pub false_alarm: f64,
    /// Observability of each hypothesis.
    pub observability: Vec<observe::Observability>,
    /// What must be known before trusting the result.
    pub warnings: Vec<String>,
    /// The speeds (rad/s) and the terms used (for plots).
    pub terms: Vec<SpeedTerms>,
    /// Speed at which bearings are reported (rad/s).
    pub omega_report: f64,
    /// Shaft nodes (0-based) of the measurement's probes at other nodes.
    pub probe_nodes: Vec<usize>,
    /// Wall-clock time of each stage of
    /// [`diagnose`](crate::diagnose::diagnose()) (seconds), in order: where
    /// a diagnosis spends its time.
    pub stages: Vec<(&'static str, f64)>,
}

impl Diagnosis {
    /// The chosen model (the nominal one for `none`/`unexplained`).
    pub fn extended(&self) -> &Candidate {
        self.chosen
            .and_then(|i| self.hypotheses.get(i))
            .unwrap_or(&self.nominal)
    }

    /// Residual of the nominal model.
    pub fn residual_nominal(&self) -> f64 {
        self.nominal.residual()
    }

    /// Residual of the chosen model.
    pub fn residual_extended(&self) -> f64 {
        self.extended().residual()
    }

    /// The smallest detectable size of `ext` alone at the nominal estimate
    /// (m for a bow or runout, kg m for a plane; see [`observe`]); `None`
    /// for effects without a zero (pedestal, modulus, speed law).
    pub fn min_detectable(&self, meas: &Measurements, ext: Extension) -> Option<f64> {
        observe::min_detectable_single(self, &self.weighted(meas), ext)
    }

    /// `meas` against this diagnosis's terms, weighted as its fits were
    /// (the noise model's probe floor, when it has one).
    fn weighted<'a>(&'a self, meas: &'a Measurements) -> FitData<'a> {
        let phi = self
            .noise
            .as_ref()
            .filter(|m| m.has_floor())
            .map(|m| m.relative_floor())
            .unwrap_or_default();
        FitData::with_probes(&meas.samples, &meas.node_q, &self.terms).with_floors(&phi)
    }

    /// The smallest detectable multiple of the bow through the knots
    /// `points` of the nominal `model` ([`observe::min_detectable_bow`]):
    /// the bow is seen by its own hypothesis once it is at least this many
    /// times `points`, in its worst common phase.
    pub fn min_detectable_bow(
        &self,
        model: &RotorModel,
        meas: &Measurements,
        points: &[BowPoint],
    ) -> Option<f64> {
        observe::min_detectable_bow(self, &self.weighted(meas), model, points)
    }

    /// The identified size of every effect of the chosen model, with the
    /// forms of a stiffness error the data cannot tell from the one found
    /// ([`Diagnosis::stiffness_alike`]).
    pub fn findings(&self) -> Vec<Finding> {
        let c = self.extended();
        let mut out = findings(c, &self.terms, &self.probe_nodes);
        for f in &mut out {
            if let Finding::ShaftStiffnessError { alike, .. } = f {
                *alike = self
                    .stiffness_alike()
                    .into_iter()
                    .map(|a| StiffnessAlike {
                        form: a.form.describe(),
                        factor: a.factor,
                        factor_std: a.factor_std,
                    })
                    .collect();
            }
        }
        out
    }

    /// The other forms of the chosen model's stiffness error
    /// ([`StiffnessForm`](crate::diagnose::terms::StiffnessForm): E and G,
    /// E alone, a section's diameter) whose misfit `S` lies within
    /// `chi2_{2, 0.01} sigma^2` of the form found, the rule by which
    /// effects are told apart ([`observe::Observability`]; the forms have
    /// as many parameters), best first.
    /// The forms have one parameter each, so a difference within it is no
    /// evidence for either: a slender shaft's shear deformation is a small
    /// part of its flexibility, and E alone moves the critical speeds the
    /// way E and G do. Empty when the chosen model has no stiffness error
    /// or has it beside another effect (the pairs fit one form).
    pub fn stiffness_alike(&self) -> Vec<FormFit> {
        let c = self.extended();
        let Some(own) = c.stiffness_forms.iter().find(|f| f.form == c.stiffness) else {
            return Vec::new();
        };
        let mut out: Vec<FormFit> = c
            .stiffness_forms
            .iter()
            .filter(|f| f.form != c.stiffness && observe::tied(f.s, own.s, self.sigma2))
            .copied()
            .collect();
        out.sort_by(|a, b| a.s.total_cmp(&b.s));
        out
    }
}

/// The probe readings `c` predicts at every speed of `d` (m), with the
/// terms rebuilt for its shaft modulus when it has one.
pub fn predictions(
    model: &RotorModel,
    d: &Diagnosis,
    c: &Candidate,
) -> Result<Vec<Vec<Complex64>>, DiagnoseError> {
    let own;
    let terms: &[SpeedTerms] = if c.model.ext.contains(&Extension::EScale) {
        let omegas: Vec<f64> = d.terms.iter().map(|t| t.omega).collect();
        let builder = terms::Builder::new(model, &d.probe_nodes)?;
        own = terms::build_form(
            &builder,
            model,
            &omegas,
            c.stiffness,
            c.e_terms,
            true,
            &d.probe_nodes,
        )?;
        &own
    } else {
        &d.terms
    };
    terms
        .iter()
        .map(|st| {
            c.model
                .predict(st, &c.model.pr.entries(st.omega), &c.fit.theta, None)
                .map(|y| y.iter().copied().collect())
                .map_err(DiagnoseError::from)
        })
        .collect()
}

/// The 1-based name of the run of nodes `first..=last` (0-based): `"7"`
/// or `"6..8"`.
fn run_name(first: usize, last: usize) -> String {
    if first == last {
        format!("{}", first + 1)
    } else {
        format!("{}..{}", first + 1, last + 1)
    }
}

/// Amplitude and phase (deg) of `z = s (x + j y)` with their standard
/// deviations from the 2x2 covariance of `(x, y)` (linearised).
fn polar_with_std(x: f64, y: f64, s: f64, cov: Option<[[f64; 2]; 2]>) -> (f64, f64, f64, f64) {
    let z = Complex64::new(x, y) * s;
    let r = z.norm();
    let (mut sa, mut sp) = (f64::NAN, f64::NAN);
    if let (Some(c), true) = (cov, r > 0.0) {
        let (u, v) = (z.re / r, z.im / r);
        // d r = u dx' + v dy', d phi = (-v dx' + u dy') / r, x' = s x.
        let var_r = s * s * (u * u * c[0][0] + 2.0 * u * v * c[0][1] + v * v * c[1][1]);
        let var_p = s * s * (v * v * c[0][0] - 2.0 * u * v * c[0][1] + u * u * c[1][1]) / (r * r);
        sa = var_r.max(0.0).sqrt();
        sp = var_p.max(0.0).sqrt().to_degrees();
    }
    (r, z.arg().to_degrees(), sa, sp)
}

/// For the bow extension `k` of `c` when `c` is a bow of two knots: the
/// offset of the other knot's parameters and the other knot's unit shape
/// at this knot (`Candidate::bow_coupling`).
fn bow_partner(c: &Candidate, k: usize) -> Option<(usize, f64)> {
    let [s_ba, s_ab] = c.bow_coupling?;
    match (k, c.model.ext.len()) {
        (0, 2) => Some((c.model.offset(1), s_ba)),
        (1, 2) => Some((c.model.offset(0), s_ab)),
        _ => None,
    }
}

/// The 2x2 covariance of `sum_i w_i (theta_{o_i}, theta_{o_i + 1})` for
/// `terms` `(o_i, w_i)` of `f`, when it has one.
fn cov_combo(f: &Fit, terms: &[(usize, f64)]) -> Option<[[f64; 2]; 2]> {
    f.covariance.as_ref().map(|c| {
        let mut out = [[0.0; 2]; 2];
        for (r, row) in out.iter_mut().enumerate() {
            for (q, v) in row.iter_mut().enumerate() {
                *v = terms
                    .iter()
                    .flat_map(|&(i, wi)| {
                        terms
                            .iter()
                            .map(move |&(j, wj)| wi * wj * c[(i + r, j + q)])
                    })
                    .sum();
            }
        }
        out
    })
}

/// The 2x2 covariance of parameters `o` and `o + 1` of `f`, when it has one.
fn cov2(f: &Fit, o: usize) -> Option<[[f64; 2]; 2]> {
    f.covariance.as_ref().map(|c| {
        [
            [c[(o, o)], c[(o, o + 1)]],
            [c[(o + 1, o)], c[(o + 1, o + 1)]],
        ]
    })
}

/// The name of output `ch` with `nq` bearing channels and probes at the
/// nodes `probe_nodes` (0-based): `b1_y`, ..., then `n7_y`, `n7_z`, ...
/// (1-based, as in the measurement file).
pub fn output_name(ch: usize, nq: usize, probe_nodes: &[usize]) -> String {
    let dir = if ch % 2 == 0 { "y" } else { "z" };
    match ch.checked_sub(nq) {
        None => format!("b{}_{dir}", ch / 2 + 1),
        Some(k) => match probe_nodes.get(k / 2) {
            Some(n) => format!("n{}_{dir}", n + 1),
            None => format!("output {}", ch + 1),
        },
    }
}

/// The runout of one channel from parameters `o`, `o + 1` of `f` (scaled
/// by `q_s`).
fn runout_finding(f: &Fit, o: usize, q_s: f64, channel: String) -> RunoutFinding {
    let (a, p, sa, sp) = polar_with_std(f.theta[o], f.theta[o + 1], q_s, cov2(f, o));
    RunoutFinding {
        channel,
        amplitude: a,
        amplitude_std: sa,
        phase_deg: p,
        phase_deg_std: sp,
        significant: a > 3.0 * sa,
    }
}

/// The findings of a candidate's extensions; `probe_nodes` (0-based) the
/// nodes of the probes beyond the bearings, to name their channels. A
/// stiffness error's `alike` is left empty here: the forms the data cannot
/// tell apart need the noise variance of a diagnosis, and
/// [`Diagnosis::findings`] fills them in.
pub fn findings(c: &Candidate, terms: &[SpeedTerms], probe_nodes: &[usize]) -> Vec<Finding> {
    let m = &c.model;
    let f = &c.fit;
    let param = &m.pr.param;
    let nom = m.pr.n_params();
    let mut out = Vec::new();
    let film = m.ext.contains(&Extension::FilmLaw);
    if (param.structure.order > 1 || film) && c.effects.contains(&Effect::SpeedDependentBearing) {
        let w = m.pr.weights(&f.theta[..nom]);
        let lo = terms.iter().map(|t| t.omega).fold(f64::INFINITY, f64::min);
        let hi = terms.iter().map(|t| t.omega).fold(0.0, f64::max);
        let k_at = |b: usize, omega: f64| -> Option<[f64; 4]> {
            let mut k = param.bearing(&w, b, omega)?.k;
            if let Some((dk, _)) = film_coefficients(c, b, omega) {
                for (k, d) in k.iter_mut().zip(dk) {
                    *k += d;
                }
            }
            Some(k)
        };
        let stiffness = (0..param.n_bearings())
            .filter_map(|b| {
                let kl = k_at(b, lo)?;
                let kh = k_at(b, hi)?;
                Some((param.bearing_nodes[b] + 1, kl.into(), kh.into()))
            })
            .collect();
        out.push(Finding::SpeedDependentBearing {
            order: param.structure.order,
            form: if film { "film" } else { "polynomial" },
            stiffness,
        });
    }
    for (k, ext) in m.ext.iter().enumerate() {
        let o = m.offset(k);
        match *ext {
            Extension::Runout => {
                let channels = (0..m.n_channels())
                    .map(|ch| {
                        runout_finding(
                            f,
                            o + 2 * ch,
                            m.scales.q,
                            output_name(ch, m.n_channels(), &[]),
                        )
                    })
                    .collect();
                out.push(Finding::ProbeRunout { channels });
            }
            Extension::NodeRunout { output } => {
                let r = runout_finding(
                    f,
                    o,
                    m.scales.q,
                    output_name(output, m.n_channels(), probe_nodes),
                );
                match out.iter_mut().find_map(|x| match x {
                    Finding::ProbeRunout { channels } => Some(channels),
                    _ => None,
                }) {
                    Some(channels) => channels.push(r),
                    None => out.push(Finding::ProbeRunout { channels: vec![r] }),
                }
            }
            Extension::Plane { .. } | Extension::Spread { .. } => {
                let Some((first, last)) = ext.unbalance_nodes() else {
                    continue;
                };
                let (a, p, sa, sp) = polar_with_std(
                    f.theta[o],
                    f.theta[o + 1],
                    param.scaling.unbalance,
                    cov2(f, o),
                );
                out.push(Finding::ExtraUnbalancePlane {
                    node: (first + last) / 2 + 1,
                    nodes: run_name(first, last),
                    me: a,
                    me_std: sa.hypot(c.spread_std),
                    phase_deg: p,
                    phase_deg_std: sp,
                    spread: c
                        .spread
                        .iter()
                        .map(|&(first, last, me)| PlaneRun {
                            nodes: run_name(first, last),
                            me,
                        })
                        .collect(),
                });
            }
            Extension::Bow { node, line } => {
                // A bow of two knots: this knot's offset is its own
                // amplitude plus the other knot's shape there times the
                // other's amplitude (`Candidate::bow_coupling`).
                let other = bow_partner(c, k);
                let terms: Vec<(usize, f64)> = match other {
                    Some((o2, s)) => vec![(o, 1.0), (o2, s)],
                    None => vec![(o, 1.0)],
                };
                let x: f64 = terms.iter().map(|&(i, w)| w * f.theta[i]).sum();
                let y: f64 = terms.iter().map(|&(i, w)| w * f.theta[i + 1]).sum();
                let (a, p, sa, sp) = polar_with_std(x, y, m.scales.q, cov_combo(f, &terms));
                out.push(Finding::ShaftBow {
                    node: node + 1,
                    amplitude: a,
                    amplitude_std: sa,
                    phase_deg: p,
                    phase_deg_std: sp,
                    reference: if line { "bearing line" } else { "shaft ends" },
                });
            }
            Extension::Gain { channel } => {
                out.push(Finding::ProbeSensitivity {
                    channel: output_name(channel, m.n_channels(), probe_nodes),
                    gain: 1.0 + GAIN_STEP * f.theta[o],
                    gain_std: GAIN_STEP * f.std(o).unwrap_or(f64::NAN),
                });
            }
            Extension::EScale => {
                out.push(Finding::ShaftStiffnessError {
                    factor: c.e_terms + E_STEP * f.theta[o],
                    factor_std: (E_STEP * f.std(o).unwrap_or(f64::NAN)).hypot(c.ends_std),
                    form: c.stiffness.describe(),
                    alike: Vec::new(),
                    ends: c
                        .ends
                        .iter()
                        .map(|&(form, factor)| SectionRun {
                            form: form.describe(),
                            factor,
                        })
                        .collect(),
                });
            }
            // With the polynomial law's finding (above).
            Extension::FilmLaw => {}
            Extension::Pedestal { bearing, split } => {
                let p =
                    PedestalParams::from_scaled(&f.theta[o..o + 5 + usize::from(split)], &m.scales);
                let (k, cc) = p.k_c();
                let sd = |i: usize| f.std(o + i).unwrap_or(f64::NAN);
                let hz = |w: f64| w / (2.0 * std::f64::consts::PI);
                out.push(Finding::FoundationFlexibility {
                    node: param
                        .bearing_nodes
                        .get(bearing)
                        .map_or(bearing + 1, |n| n + 1),
                    mass: p.mass,
                    mass_std: p.mass * sd(0),
                    masses: p.masses(),
                    natural_frequency_hz: [hz(p.omega[0]), hz(p.omega[1])],
                    natural_frequency_hz_std: [hz(p.omega[0]) * sd(1), hz(p.omega[1]) * sd(2)],
                    damping_ratio: p.zeta,
                    k,
                    c: cc,
                });
            }
        }
    }
    out
}

/// What a candidate's [`Extension::FilmLaw`] adds to bearing `b` at
/// `omega` (rad/s): `(dK, dC)` in the order `yy, yz, zy, zz` (N/m, N s/m);
/// `None` without the law.
pub(crate) fn film_coefficients(
    c: &Candidate,
    b: usize,
    omega: f64,
) -> Option<([f64; 4], [f64; 4])> {
    let k = film_functionals(c, b, omega)?;
    let value = |func: &[(usize, f64)]| -> f64 {
        func.iter()
            .map(|&(i, g)| g * c.fit.theta.get(i).copied().unwrap_or(f64::NAN))
            .sum()
    };
    Some((
        std::array::from_fn(|e| value(&k[e])),
        std::array::from_fn(|e| value(&k[4 + e])),
    ))
}

/// The film law's coefficients at `omega` as functionals of the
/// parameters, `(index, weight)` pairs ([`crate::diagnose::extended::film_entries`]):
/// `K_yy, K_yz, K_zy, K_zz`, then `C_yy .. C_zz` of bearing `b`. `None`
/// without the law.
fn film_functionals(c: &Candidate, b: usize, omega: f64) -> Option<[Vec<(usize, f64)>; 8]> {
    let m = &c.model;
    let k = m.ext.iter().position(|e| *e == Extension::FilmLaw)?;
    if b >= m.n_channels() / 2 {
        return None;
    }
    let o = m.offset(k);
    let sc = &m.pr.param.scaling;
    let r = omega / sc.omega_ref;
    let (sk, sc_) = (sc.stiffness * r, sc.stiffness / sc.omega_ref * r);
    let p = o + 3 * b;
    Some([
        vec![(p, sk)],
        vec![(p + 1, sk)],
        vec![(p + 1, -sk)],
        vec![(p, sk)],
        vec![(p + 2, sc_)],
        Vec::new(),
        Vec::new(),
        vec![(p + 2, sc_)],
    ])
}

/// Bearings (at `omega`) and plane unbalances of a candidate, with
/// standard deviations, in the identification's result types.
pub fn estimates(c: &Candidate, omega: f64) -> (Vec<BearingResult>, Vec<UnbalanceResult>) {
    let m = &c.model;
    let param = &m.pr.param;
    let nom = m.pr.n_params();
    let w = m.pr.weights(&c.fit.theta[..nom]);
    let cov = c.fit.covariance.as_ref();
    // Physical structure: parameter i is unknown i (real).
    let fstd = |func: &[(usize, f64)]| -> f64 {
        cov.map_or(f64::NAN, |cv| {
            let mut v = 0.0;
            for &(i, gi) in func {
                for &(k, gk) in func {
                    v += gi * gk * cv[(i, k)];
                }
            }
            v.max(0.0).sqrt()
        })
    };
    let bearings = (0..param.n_bearings())
        .filter_map(|b| {
            let mut est = param.bearing(&w, b, omega)?;
            let film = film_functionals(c, b, omega);
            let with_film = |mut func: Vec<(usize, f64)>, e: usize| {
                if let Some(f) = &film {
                    func.extend(f[e].iter().copied());
                }
                func
            };
            if let Some((dk, dc)) = film_coefficients(c, b, omega) {
                for e in 0..4 {
                    est.k[e] += dk[e];
                    est.c[e] += dc[e];
                }
            }
            let ks: [f64; 4] = std::array::from_fn(|e| {
                fstd(&with_film(param.stiffness_functional(b, e, omega), e))
            });
            let cs: [f64; 4] = std::array::from_fn(|e| {
                fstd(&with_film(param.damping_functional(b, e, omega), 4 + e))
            });
            Some(BearingResult {
                node: param.bearing_nodes[b] + 1,
                k: est.k.into(),
                c: est.c.into(),
                check: None,
                std: cov.map(|_| BearingStd {
                    k: ks.into(),
                    c: cs.into(),
                }),
            })
        })
        .collect();
    let unbalance = (0..param.n_planes())
        .filter_map(|k| {
            let u = param.unbalance(&w, k)?;
            // Re and Im parameters of plane k.
            let (ir, ii) =
                (0..param.n_unknowns()).fold((None, None), |acc, j| match param.unknown(j) {
                    Some(rotorid_core::parametrization::Unknown::Unbalance { plane, part })
                        if plane == k =>
                    {
                        match part {
                            rotorid_core::parametrization::UnbalancePart::Re => (Some(j), acc.1),
                            rotorid_core::parametrization::UnbalancePart::Im => (acc.0, Some(j)),
                            rotorid_core::parametrization::UnbalancePart::Phasor => acc,
                        }
                    }
                    _ => acc,
                });
            let sd = match (ir, ii, cov) {
                (Some(a), Some(b), Some(cv)) => {
                    let s = param.scale(a);
                    let z = Complex64::new(w[a].re, w[b].re);
                    let c2 = [[cv[(a, a)], cv[(a, b)]], [cv[(b, a)], cv[(b, b)]]];
                    let (_, _, sa, sp) = polar_with_std(z.re, z.im, s, Some(c2));
                    Some((sa, sp))
                }
                _ => None,
            };
            Some(UnbalanceResult::new(param.plane_nodes[k] + 1, &u, sd))
        })
        .collect();
    (bearings, unbalance)
}
