//! One fitted model ([`Candidate`]): the nominal model or a hypothesis of
//! the bank, with its fit and the likelihood-ratio test that judges it
//! against the nominal fit.

use super::effect::Effect;
use super::extended::ExtendedModel;
use super::fit::Fit;
use super::stats::chi2_quantile_upper;
use super::terms::StiffnessForm;

/// One fitted model of the bank (or the nominal one).
#[derive(Debug, Clone)]
pub struct Candidate {
    /// The effects it adds (empty: nominal).
    pub effects: Vec<Effect>,
    /// A short description (e.g. "extra plane at node 17").
    pub label: String,
    /// The model.
    pub model: ExtendedModel,
    /// Its fit.
    pub fit: Fit,
    /// The shaft stiffness factor its terms were built for.
    pub e_terms: f64,
    /// What that factor changes (E and G unless the modulus hypothesis
    /// found another form).
    pub stiffness: StiffnessForm,
    /// For the stiffness hypothesis: every form fitted (the one of
    /// `stiffness` among them), with its factor and misfit, so that the
    /// forms the data cannot tell apart can be named
    /// ([`Diagnosis::stiffness_alike`]).
    ///
    /// [`Diagnosis::stiffness_alike`]: super::Diagnosis::stiffness_alike
    pub stiffness_forms: Vec<FormFit>,
    /// For a stiffness error on a section: the standard deviation of its
    /// factor that the section's ends leave open (the runs of elements
    /// the data cannot tell from it, `bank::section_ends`), added in
    /// quadrature to the fit's in the findings; zero otherwise.
    pub ends_std: f64,
    /// For a stiffness error on a section: the runs of elements of least
    /// and greatest factor among those the data cannot tell from the best
    /// run, `(section, diameter factor)` (empty otherwise, or when one run
    /// alone is tied).
    pub ends: Vec<(StiffnessForm, f64)>,
    /// For an extra unbalance plane alone: the standard deviation of its
    /// `m e` (kg m) that the runs of nodes the data cannot tell from it
    /// leave open (`bank::plane_spread`), added in quadrature to the fit's
    /// in the findings; zero otherwise.
    pub spread_std: f64,
    /// For an extra unbalance plane alone: the runs of nodes of least and
    /// greatest `m e` among those the data cannot tell from the best run,
    /// `(first node, last node, m e)` (0-based nodes, kg m; empty
    /// otherwise, or when one run alone is tied).
    pub spread: Vec<(usize, usize, f64)>,
    /// Alternatives tried for this hypothesis (nodes, bearings, orders).
    pub alternatives: usize,
    /// For a bow of two knots (two [`Extension::Bow`] extensions, knots
    /// `a < b`): `[s_b(a), s_a(b)]`, the offset the unit shape of each
    /// knot has at the other one, so that the bow's offsets at its knots
    /// are `beta_a = c_a + s_b(a) c_b` and `beta_b = s_a(b) c_a + c_b`
    /// (`c` the fitted amplitudes of the two shapes).
    ///
    /// [`Extension::Bow`]: super::extended::Extension::Bow
    pub bow_coupling: Option<[f64; 2]>,
    /// `(S_nominal - S) / sigma^2`.
    pub statistic: f64,
    /// The chi-square threshold it had to exceed.
    pub threshold: f64,
    /// Whether it is significant.
    pub significant: bool,
}

/// One form of the shaft's stiffness error as fitted.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FormFit {
    /// The form.
    pub form: StiffnessForm,
    /// The factor on what the form changes (1: as the model).
    pub factor: f64,
    /// Its standard deviation.
    pub factor_std: f64,
    /// The weighted misfit `S` of its fit.
    pub s: f64,
}

impl Candidate {
    /// Relative RMS misfit.
    pub fn residual(&self) -> f64 {
        self.fit.residual()
    }
    /// Sets [`Candidate::ends_std`] and [`Candidate::ends`], the fit's
    /// standard deviation of the section's factor in
    /// [`Candidate::stiffness_forms`] widened by the first (in quadrature).
    pub(crate) fn set_ends(&mut self, std: f64, ends: Vec<(StiffnessForm, f64)>) {
        self.ends = ends;
        self.ends_std = std;
        for f in &mut self.stiffness_forms {
            if f.form == self.stiffness {
                f.factor_std = f.factor_std.hypot(std);
            }
        }
    }
    /// A model fitted for `effects` (empty: nominal), not yet judged: its
    /// statistic and threshold zero, not significant.
    pub(crate) fn new(
        effects: Vec<Effect>,
        label: String,
        model: ExtendedModel,
        fit: Fit,
        e_terms: f64,
        alternatives: usize,
    ) -> Self {
        Candidate {
            effects,
            label,
            model,
            fit,
            e_terms,
            stiffness: StiffnessForm::EAndG,
            stiffness_forms: Vec::new(),
            ends_std: 0.0,
            ends: Vec::new(),
            spread_std: 0.0,
            spread: Vec::new(),
            alternatives,
            bow_coupling: None,
            statistic: 0.0,
            threshold: 0.0,
            significant: false,
        }
    }

    /// The likelihood-ratio test against the nominal fit: the drop in `S`
    /// in units of `sigma2`, `(S_nominal - S) / sigma2`, against the
    /// chi-square quantile of the extra parameters (`max(P - P_nominal, 1)`
    /// degrees of freedom) at the rate `alpha`.
    pub(crate) fn judge(&mut self, nominal: &Fit, sigma2: f64, alpha: f64) {
        let dp = self
            .fit
            .n_params()
            .saturating_sub(nominal.n_params())
            .max(1);
        self.statistic = (nominal.s - self.fit.s) / sigma2;
        self.threshold = chi2_quantile_upper(dp as f64, alpha);
        self.significant = self.statistic > self.threshold;
    }
}
