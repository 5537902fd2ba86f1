//! One case of the pedestal grid (`tests/diagnose/pedestal_grid.rs`) in
//! full: a pedestal of the rotor's mass per bearing under BEARING (from
//! 1), resonating at F_HZ in y and 1.15 times it in z, the bearings
//! constant (their laws at half the top speed), 300 speeds up to the top
//! speed, unbalance at G6.3, 0.5 % noise and a 0.5 um probe floor; prints
//! the diagnosis's text.
//!
//! ```sh
//! cargo run --release --example pedestal_case -- paper 1 55.89 7002
//! cargo run --release --example pedestal_case -- tests/data/ross/stepped_hollow.toml 2 24.83 7001 12000
//! ```
//!
//! MODEL is `paper` or a model file (a ROSS file gets the generator's
//! plane unbalance); SEED the case's seed (the grid's case `i` has
//! `7000 + i`); RPM_MAX the top speed (15000); SCATTER a relative
//! error of the model's bearings against the truth's (0): the truth's
//! stiffness of bearing `i` is `1 + SCATTER sin(0.7 (i + 1))` times the
//! model's, its damping divided by the same.

use rotorid::diagnose::{diagnose, rotor_mass, DiagnoseOptions};
use rotorid::simulate::{add_floor_noise, at_balance_grade, simulate, SimOptions};
use rotorid::units::rpm_to_rad_s;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |i: usize| args.get(i).map(String::as_str);
    let usage = "usage: pedestal_case MODEL BEARING F_HZ [SEED [RPM_MAX [SCATTER]]]";
    let base = rotorid::diagnose::generator::with_plane_unbalance(
        rotorid::io::model_file::model_file_by_name_or_path(arg(0).ok_or(usage)?)?.model,
    );
    let bearing: usize = arg(1)
        .ok_or(usage)?
        .parse::<usize>()?
        .checked_sub(1)
        .ok_or(usage)?;
    let f_hz: f64 = arg(2).ok_or(usage)?.parse()?;
    let seed: u64 = arg(3).map_or(Ok(7000), str::parse)?;
    let rpm_max: f64 = arg(4).map_or(Ok(15000.0), str::parse)?;
    // The grid's scaling: the paper rotor at its top speed, a ROSS rotor
    // at 9000 rpm (`tests/transient`).
    let grade_rpm = if arg(0) == Some("paper") {
        rpm_max
    } else {
        9000.0
    };
    let model = at_balance_grade(&base, 6.3, rpm_to_rad_s(grade_rpm))
        .ok_or("the model has no unbalance to scale")?;
    let scatter: f64 = arg(5).map_or(Ok(0.0), str::parse)?;
    let (nominal, truth) =
        rotorid::diagnose::generator::pedestal_grid_case(&model, rpm_max, bearing, f_hz, scatter)
            .ok_or(format!("the model has {} bearings", model.bearings.len()))?;
    let mass = rotor_mass(&nominal) / nominal.bearings.len() as f64;
    let opts = SimOptions {
        speeds_rpm: (1..=300).map(|i| rpm_max * i as f64 / 300.0).collect(),
        noise: 0.005,
        seed,
        ..SimOptions::default()
    };
    let mut meas = simulate(&truth, &opts)?;
    add_floor_noise(&mut meas, 0.5e-6, seed)?;
    let d = diagnose(&nominal, &meas, &DiagnoseOptions::default())?;
    println!(
        "hidden: pedestal under bearing {} of {mass:.1} kg at {f_hz:.2} Hz (y), {:.2} Hz (z)",
        bearing + 1,
        1.15 * f_hz
    );
    let predicted = rotorid::diagnose::predictions(&nominal, &d, &d.nominal)?;
    println!(
        "{}",
        rotorid::report::diagnose::text(&d, &meas.samples, &predicted)
    );
    Ok(())
}
