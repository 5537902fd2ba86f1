//! The Campbell analysis of a model, as `rotorid campbell` runs it: the
//! damped modes on a uniform speed grid from rest, the modes followed
//! across speed by their shapes, and the critical speeds of every whirl
//! where a damped or an undamped natural frequency meets the speed
//! ([`campbell()`], [`CampbellOptions`], [`CampbellAnalysis`]); the
//! shapes of the lowest modes at one speed ([`mode_shapes`]).
//!
//! The eigen-solve, the tracking and the refinement of the critical speeds
//! are [`crate::fe::campbell`]'s; the text, JSON, CSV and SVG of the
//! command are [`crate::report::campbell`]'s.
//!
//! ```no_run
//! let model = rotorid::RotorModel::paper();
//! let analysis = rotorid::campbell(&model, &rotorid::CampbellOptions::default())?;
//! for c in &analysis.critical {
//!     println!("{:.0} rpm, mode {}, {:?}", rotorid::units::rad_s_to_rpm(c.omega), c.mode + 1, c.whirl);
//! }
//! # Ok::<(), rotorid::campbell::CampbellError>(())
//! ```

use thiserror::Error;

use crate::fe::assembly::{FeError, FeModel};
use crate::fe::campbell::{
    check_size, critical_speeds, diagram_with, modes_at, track_modes, CampbellDiagram,
    CriticalSpeed, Crossing, Mode, ModeSelection, Track,
};
use crate::model::{ModelError, RotorModel};
use crate::tables::grid::{uniform_rpm, SpeedGridError};
use crate::units::rpm_to_rad_s;

/// What a Campbell analysis covers; the `Default` is the command's
/// (`rotorid campbell` without options).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CampbellOptions {
    /// Highest speed (rpm); the diagram runs from 0. Default 15000.
    pub rpm_max: f64,
    /// Speed step of the diagram (rpm). The critical speeds are refined
    /// between the steps and do not depend on it. Default 250.
    pub rpm_step: f64,
    /// Number of modes: those among the `modes` lowest (by undamped natural
    /// frequency) at some speed, each followed across the speed range.
    /// Default 8.
    pub modes: usize,
}

impl Default for CampbellOptions {
    fn default() -> Self {
        CampbellOptions {
            rpm_max: 15000.0,
            rpm_step: 250.0,
            modes: 8,
        }
    }
}

/// A Campbell analysis: the diagram, the modes followed across it and the
/// critical speeds.
#[derive(Debug, Clone, PartialEq)]
pub struct CampbellAnalysis {
    /// The modes at each speed of the grid (rad/s), more than
    /// [`CampbellOptions::modes`] so that a mode leaving the lowest is still
    /// followed for a while.
    pub diagram: CampbellDiagram,
    /// The modes shown: the tracks of [`track_modes`] that are among the
    /// [`CampbellOptions::modes`] lowest at some speed, in its order.
    pub tracks: Vec<Track>,
    /// Critical speeds where a damped natural frequency meets the speed
    /// ([`Crossing::Damped`], ROSS `wd`), by speed; `mode` indexes
    /// [`Self::tracks`].
    pub critical: Vec<CriticalSpeed>,
    /// Critical speeds where an undamped natural frequency `|lambda|` meets
    /// the speed ([`Crossing::Undamped`], ROSS `wn`), by speed.
    pub critical_undamped: Vec<CriticalSpeed>,
}

/// A Campbell analysis that cannot be done.
#[derive(Debug, Error)]
pub enum CampbellError {
    /// An option out of range (named).
    #[error("{0}")]
    Invalid(String),
    /// The model is not one the FE model can be built from.
    #[error(transparent)]
    Model(#[from] ModelError),
    /// The speed grid cannot be built.
    #[error(transparent)]
    Grid(#[from] SpeedGridError),
    /// The eigen-solve failed, or the model is beyond the limits of
    /// [`check_size`].
    #[error(transparent)]
    Fe(#[from] FeError),
}

/// Extra modes solved per speed beyond `modes`, so that a mode leaving
/// the lowest `modes` is still followed for a while.
fn tracking_margin(modes: usize) -> usize {
    (modes / 2).max(4)
}

/// The Campbell analysis of `model` (see the module documentation).
///
/// Errors: options out of range (`rpm_max` not finite and positive,
/// `modes` zero, a bad step), a model or grid beyond [`check_size`]
/// (checked before the FE model is assembled), a failed eigen-solve.
pub fn campbell(
    model: &RotorModel,
    opts: &CampbellOptions,
) -> Result<CampbellAnalysis, CampbellError> {
    if !(opts.rpm_max.is_finite() && opts.rpm_max > 0.0) {
        return Err(CampbellError::Invalid(format!(
            "rpm_max must be finite and > 0, got {}",
            opts.rpm_max
        )));
    }
    if opts.modes == 0 {
        return Err(CampbellError::Invalid("modes must be at least 1".into()));
    }
    let omegas: Vec<f64> = uniform_rpm(0.0, opts.rpm_max, opts.rpm_step)?
        .into_iter()
        .map(rpm_to_rad_s)
        .collect();
    // Size limits before the FE model is even assembled (4 DOF per node,
    // 2 more per pedestal).
    check_size(4 * model.n_nodes(), omegas.len())?;
    let fe = FeModel::new(model)?;
    let selection = ModeSelection {
        max_modes: opts.modes.saturating_add(tracking_margin(opts.modes)),
        ..ModeSelection::default()
    };
    let diagram = diagram_with(&fe, &omegas, &selection)?;
    let tracks: Vec<Track> = track_modes(&diagram)
        .into_iter()
        .filter(|t| t.modes.iter().any(|m| m.is_some_and(|i| i < opts.modes)))
        .collect();
    let critical = critical_speeds(&fe, &diagram, &tracks, Crossing::Damped)?;
    let critical_undamped = critical_speeds(&fe, &diagram, &tracks, Crossing::Undamped)?;
    Ok(CampbellAnalysis {
        diagram,
        tracks,
        critical,
        critical_undamped,
    })
}

/// The `n` lowest modes of `model` at `rpm` (by undamped natural frequency,
/// sorted by damped frequency), with their shapes; empty when no mode has
/// a positive damped frequency there.
///
/// Errors: `rpm` not finite or negative, `n` zero, a failed FE model or
/// eigen-solve.
pub fn mode_shapes(model: &RotorModel, rpm: f64, n: usize) -> Result<Vec<Mode>, CampbellError> {
    if !(rpm.is_finite() && rpm >= 0.0) {
        return Err(CampbellError::Invalid(format!(
            "the speed of the mode shapes must be finite and >= 0 rpm, got {rpm}"
        )));
    }
    if n == 0 {
        return Err(CampbellError::Invalid("modes must be at least 1".into()));
    }
    let fe = FeModel::new(model)?;
    let selection = ModeSelection {
        max_modes: n,
        ..ModeSelection::default()
    };
    Ok(modes_at(&fe, rpm_to_rad_s(rpm), &selection)?)
}

/// The largest passage parameter `kappa = |alpha| / (zeta omega_n)^2` at
/// which a sweep's 1X vectors near a critical speed stay within about 1 %
/// of the peak of the steady state: the deviation is `kappa` of the peak to
/// first order (docs/guide/signals.md, "Sweep rate"; measured in
/// docs/validation.md).
pub const KAPPA_MAX: f64 = 0.01;

/// A critical speed a sweep passed too fast for the steady-state model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FastPassage {
    /// The critical speed (rpm).
    pub rpm: f64,
    /// Its damping ratio (-).
    pub damping_ratio: f64,
    /// The passage parameter `kappa = |alpha| / (zeta omega_n)^2` (-).
    pub kappa: f64,
    /// The fastest rate at which `kappa <= KAPPA_MAX` (rpm/s).
    pub rate_max_rpm_per_s: f64,
}

impl FastPassage {
    /// The warning `identify` and `diagnose` print.
    pub fn message(&self, rate_rpm_per_s: f64) -> String {
        format!(
            "the sweep rate {} rpm/s passes the critical speed at {:.0} rpm (damping ratio {:.4}) too fast for the steady-state model: passage parameter {:.3} > {KAPPA_MAX}, the 1X vectors near it deviate from the steady state by about {:.0} % of the peak; keep the rate below {:.3} rpm/s there",
            rate_rpm_per_s.abs(),
            self.rpm,
            self.damping_ratio,
            self.kappa,
            100.0 * self.kappa.min(1.0),
            self.rate_max_rpm_per_s
        )
    }
}

/// The forward (or mixed-whirl) critical speeds of `model` between
/// `rpm_min` and `rpm_max` that a sweep at `rate_rpm_per_s` (sign
/// ignored) passes with a passage parameter `kappa = |alpha| / (zeta
/// omega_n)^2` above [`KAPPA_MAX`]: there the steady-state model the
/// identification and the diagnosis fit does not hold. The critical
/// speeds and damping ratios are [`campbell`]'s (default options, up to
/// `rpm_max`); backward modes, which unbalance hardly excites, are left
/// out.
pub fn sweep_rate_warnings(
    model: &RotorModel,
    rpm_min: f64,
    rpm_max: f64,
    rate_rpm_per_s: f64,
) -> Result<Vec<FastPassage>, CampbellError> {
    if !(rpm_min.is_finite() && rpm_max.is_finite() && rpm_max > 0.0 && rate_rpm_per_s.is_finite())
    {
        return Err(CampbellError::Invalid(format!(
            "sweep check: speeds {rpm_min}..{rpm_max} rpm and rate {rate_rpm_per_s} rpm/s must be finite"
        )));
    }
    if rate_rpm_per_s == 0.0 {
        return Ok(Vec::new());
    }
    let opts = CampbellOptions {
        rpm_max: rpm_max * 1.001,
        ..CampbellOptions::default()
    };
    let a = campbell(model, &opts)?;
    let alpha = crate::units::rpm_to_rad_s(rate_rpm_per_s.abs());
    Ok(a.critical
        .iter()
        .filter(|c| c.whirl != crate::fe::campbell::Whirl::Backward)
        .filter_map(|c| {
            let rpm = crate::units::rad_s_to_rpm(c.omega);
            let bw2 = (c.damping_ratio * c.omega).powi(2);
            // An undamped mode (bw2 = 0) gives kappa = infinity.
            let kappa = alpha / bw2;
            (rpm >= rpm_min && rpm <= rpm_max && (kappa > KAPPA_MAX || kappa.is_nan())).then(|| {
                FastPassage {
                    rpm,
                    damping_ratio: c.damping_ratio,
                    kappa,
                    rate_max_rpm_per_s: crate::units::rad_s_to_rpm(KAPPA_MAX * bw2),
                }
            })
        })
        .collect())
}
