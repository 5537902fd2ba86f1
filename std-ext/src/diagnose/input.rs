//! What [`diagnose`](super::diagnose()) takes and refuses: its options
//! ([`DiagnoseOptions`]), the reasons it cannot run ([`DiagnoseError`]),
//! and the checks of the measurements against the model and the options
//! that come before any computation.

use thiserror::Error;

use crate::estimate::output_error::OutputErrorError;
use crate::estimate::predictor::PredictError;
use crate::estimate::IdentifyError;
use crate::io::measurement::Measurements;
use crate::model::RotorModel;
use crate::reduce::ReductionError;
use crate::units::rad_s_to_rpm;
use rotorid_core::parametrization::MAX_ORDER;

/// Options of the diagnosis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DiagnoseOptions {
    /// Polynomial order of the nominal bearing law (`physical`).
    pub order: usize,
    /// False-alarm rate of the choice (probability that noise alone names
    /// an effect), split over all alternatives tried.
    pub false_alarm: f64,
    /// Probes on a pedestal read the shaft relative to it (the default, as
    /// proximity probes are mounted) rather than absolutely.
    pub relative_probes: bool,
    /// The probes' noise floor (m, every channel); `None`: estimated from
    /// the data (SPEC section 7).
    pub noise_floor: Option<f64>,
    /// Threads for the hypotheses' fits (0: one per core of the machine).
    /// The diagnosis is the same on any number.
    pub threads: usize,
}

impl Default for DiagnoseOptions {
    fn default() -> Self {
        DiagnoseOptions {
            order: 1,
            false_alarm: 1e-3,
            relative_probes: true,
            noise_floor: None,
            threads: 0,
        }
    }
}

/// Why the diagnosis could not run.
#[derive(Debug, Error)]
pub enum DiagnoseError {
    /// Bad or inconsistent input.
    #[error("{0}")]
    Input(String),
    /// The nominal identification failed.
    #[error("{0}")]
    Identify(#[from] IdentifyError),
    /// The model reduction failed.
    #[error("{0}")]
    Reduction(#[from] ReductionError),
    /// The nominal output-error fit failed.
    #[error("{0}")]
    OutputError(#[from] OutputErrorError),
    /// A prediction failed.
    #[error("{0}")]
    Predict(#[from] PredictError),
}

/// Refuses inputs the diagnosis cannot run on: bearings of the
/// measurement and the model differing, a nominal order outside
/// `1..=MAX_ORDER`, a false-alarm rate outside `(0, 0.5)`, a speed not
/// above 0, node-probe readings not matching the samples and probes, a
/// probe beyond the model's nodes.
pub(crate) fn check(
    model: &RotorModel,
    meas: &Measurements,
    opts: &DiagnoseOptions,
) -> Result<(), DiagnoseError> {
    let nb = model.bearings.len();
    if meas.n_bearings != nb || meas.samples.iter().any(|s| s.q.len() != 2 * nb) {
        return Err(DiagnoseError::Input(format!(
            "the measurement has {} bearings, the model {}",
            meas.n_bearings, nb
        )));
    }
    if !(1..=MAX_ORDER).contains(&opts.order) {
        return Err(DiagnoseError::Input(format!(
            "order must be in 1..={MAX_ORDER}, got {}",
            opts.order
        )));
    }
    if !(opts.false_alarm > 0.0 && opts.false_alarm < 0.5) {
        return Err(DiagnoseError::Input(format!(
            "false-alarm rate must be in (0, 0.5), got {}",
            opts.false_alarm
        )));
    }
    if let Some(s) = meas
        .samples
        .iter()
        .find(|s| s.omega.is_nan() || s.omega <= 0.0)
    {
        return Err(DiagnoseError::Input(format!(
            "the diagnosis needs speeds above 0 rpm, got {} rpm",
            rad_s_to_rpm(s.omega)
        )));
    }
    let samples = &meas.samples;
    let probes = &meas.node_probes;
    let node_q = &meas.node_q[..];
    if !probes.is_empty()
        && (node_q.len() != samples.len() || node_q.iter().any(|x| x.len() != 2 * probes.len()))
    {
        return Err(DiagnoseError::Input(format!(
            "{} node-probe rows for {} samples of {} probes",
            node_q.len(),
            samples.len(),
            probes.len()
        )));
    }
    if let Some(n) = probes.iter().find(|&&n| n >= model.n_nodes()) {
        return Err(DiagnoseError::Input(format!(
            "a probe at node {} but the model has {} nodes",
            n + 1,
            model.n_nodes()
        )));
    }
    Ok(())
}
