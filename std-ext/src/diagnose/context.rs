//! What the fits of the hypotheses share ([`Context`]): the model, the
//! measurements and their weights, the terms and their builder, the
//! nominal model and its estimates; with the helpers every hypothesis
//! starts its fits with, and the rule that stops a search once a fit
//! explains the data to the noise ([`NOISE_CHI2`]).

use num_complex::Complex64;

use crate::diagnose::candidate::Candidate;
use crate::diagnose::extended::{ExtendedModel, Extension};
use crate::diagnose::fit::{Fit, FitData};
use crate::diagnose::input::DiagnoseOptions;
use crate::diagnose::nominal::Setup;
use crate::diagnose::terms::{self, Builder, SpeedTerms};
use crate::io::measurement::Sample;
use crate::model::RotorModel;
use crate::reduce::ReductionError;

/// Chi-square per degree of freedom of the residual noise against the
/// model-free noise level below which a fit explains the data to the noise:
/// the searches stop trying further starts of its hypothesis.
pub const NOISE_CHI2: f64 = 1.2;

/// What the hypothesis fits, the choice and the pairs read.
#[derive(Clone)]
pub(crate) struct Context<'a> {
    /// The nominal rotor model.
    pub model: &'a RotorModel,
    /// The options of the diagnosis.
    pub opts: &'a DiagnoseOptions,
    /// The measured samples.
    pub samples: &'a [Sample],
    /// Readings of the probes at other nodes per sample (empty: none).
    pub node_q: &'a [Vec<Complex64>],
    /// The nodes (0-based) of those probes.
    pub probe_nodes: &'a [usize],
    /// The samples' speeds (rad/s).
    pub omegas: &'a [f64],
    /// The builder of the terms at any shaft-modulus factor.
    pub builder: &'a Builder,
    /// The model's own terms (factor 1) at each sample's speed.
    pub terms: &'a [SpeedTerms],
    /// The noise model, weights, scales and nominal start.
    pub setup: &'a Setup,
    /// The data of every fit on the model's own terms.
    pub data: &'a FitData<'a>,
    /// The nominal model (no extension).
    pub base: &'a ExtendedModel,
    /// The nominal candidate, fitted.
    pub nominal: &'a Candidate,
    /// The nominal estimate (scaled parameters): where every hypothesis
    /// starts.
    pub theta0: Vec<f64>,
    /// The nominal estimate with the bearings set to the model's own
    /// coefficients at half the top speed (a second start where an effect
    /// distorts the nominal fit).
    pub theta_model: Vec<f64>,
}

/// The screenings (the stiffness sections', the pedestal restarts') run on
/// every `SCREEN_EVERY`-th speed ([`Context::thinned`]): they rank starts
/// on the shape of the misfit, not its last digit.
pub(crate) const SCREEN_EVERY: usize = 3;

/// Every [`SCREEN_EVERY`]-th sample of a context ([`Context::thinned`]):
/// a screening's samples.
pub(crate) struct Thinned {
    /// The samples kept (indices into the context's).
    pub keep: Vec<usize>,
    /// Their speeds (rad/s).
    pub omegas: Vec<f64>,
    /// The samples.
    pub samples: Vec<Sample>,
    /// Their node probes' readings (empty: none).
    pub node_q: Vec<Vec<Complex64>>,
}

impl Context<'_> {
    /// Every [`SCREEN_EVERY`]-th sample (from the first), with its speed
    /// and node probes' readings.
    pub(crate) fn thinned(&self) -> Thinned {
        let keep: Vec<usize> = (0..self.samples.len()).step_by(SCREEN_EVERY).collect();
        Thinned {
            omegas: keep.iter().map(|&k| self.omegas[k]).collect(),
            samples: keep.iter().map(|&k| self.samples[k].clone()).collect(),
            node_q: if self.node_q.is_empty() {
                Vec::new()
            } else {
                keep.iter().map(|&k| self.node_q[k].clone()).collect()
            },
            keep,
        }
    }

    /// The terms of the context's model at its speeds with the stiffness
    /// form's change `change` ([`terms::build_form_columns`]).
    pub(crate) fn form_terms(
        &self,
        change: terms::FormChange,
        columns: terms::Columns,
    ) -> Result<Vec<SpeedTerms>, ReductionError> {
        terms::build_form_columns(
            self.builder,
            self.model,
            self.omegas,
            change,
            self.probe_nodes,
            columns,
        )
    }

    /// The nominal model with the extensions `ext`.
    pub(crate) fn with_ext(&self, ext: Vec<Extension>) -> ExtendedModel {
        ExtendedModel {
            ext,
            ..self.base.clone()
        }
    }

    /// The start of `m`: the nominal estimate, then `extra`, the rest zero.
    pub(crate) fn start_with(&self, m: &ExtendedModel, extra: &[f64]) -> Vec<f64> {
        let mut t = self.theta0.clone();
        t.extend_from_slice(extra);
        t.resize(m.n_params(), 0.0);
        t
    }

    /// The threads of the hypotheses' fits ([`DiagnoseOptions::threads`]).
    pub(crate) fn threads(&self) -> usize {
        match self.opts.threads {
            0 => crate::diagnose::parallel::available_threads(),
            n => n,
        }
    }

    /// Whether the real equations outnumber `p` parameters by more than 4.
    pub(crate) fn n_room(&self, p: usize) -> bool {
        self.setup.n_real > p + 4
    }

    /// A fit whose residual noise is within [`NOISE_CHI2`] of the
    /// model-free noise level `s` (`2 sigma^2 / s^2 <= NOISE_CHI2`):
    /// further starts or richer variants of its hypothesis are not tried
    /// (they could only move `S` by noise).
    pub(crate) fn at_noise(&self, f: &Fit) -> bool {
        match self.setup.noise_level {
            Some(s) if s > 0.0 => 2.0 * f.sigma2() / (s * s) <= NOISE_CHI2,
            _ => false,
        }
    }
}
