//! The time-domain check of the steady-state simulator: the full FE model
//! integrated through constant speed and speed ramps
//! (`rotorid::fe::transient`), sampled as probe and keyphasor signals and
//! turned into 1X vectors by the core's order tracker
//! (`rotorid::simulate::transient`).
//!
//! - [`constant`]: at constant speed the integration stays on the scheme's
//!   own steady state, which converges to `simulate`'s at second order in
//!   the step; the whole chain gives `simulate`'s vectors;
//! - [`coastdown`]: coast-downs of two rotors at a balance grade with
//!   probe noise, against the steady state away from the critical speeds;
//! - [`identify`]: `identify` on extracted vectors against the exact ones;
//! - [`rate`]: the deviation at a critical speed against the sweep rate;
//! - [`warning`]: the `# sweep:` line and the warning of a too fast sweep.

mod coastdown;
mod constant;
mod identify;
mod rate;
mod warning;

use rotorid::model::RotorModel;
use rotorid::simulate::at_balance_grade;
use rotorid::units::rpm_to_rad_s;

/// The paper rotor at balance grade G2.5 at 12000 rpm.
pub(crate) fn paper_g25() -> RotorModel {
    at_balance_grade(&RotorModel::paper(), 2.5, rpm_to_rad_s(12000.0)).unwrap()
}

/// ROSS's stepped hollow shaft (`tests/data/ross/stepped_hollow.toml`;
/// forward critical speeds 2878 and 9224 rpm; the file has no unbalance)
/// with an unbalance in each of its planes (shares 1 and 0.6, phases 0.4
/// and 2.1 rad) at balance grade G6.3 at 9000 rpm in all.
pub(crate) fn stepped_hollow_g63() -> RotorModel {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/ross/stepped_hollow.toml");
    let m = rotorid::io::model_file::model_file_by_name_or_path(path.to_str().unwrap())
        .unwrap()
        .model;
    assert!(!m.planes.is_empty() && m.unbalance.is_empty());
    let m = rotorid::diagnose::generator::with_plane_unbalance(m);
    at_balance_grade(&m, 6.3, rpm_to_rad_s(9000.0)).unwrap()
}
