//! The library's front door on the built-in reference rotor (the paper's):
//! a realistic sweep is simulated (unbalance at balance grade G6.3, 0.5 %
//! noise plus a 0.5 um probe floor), then identified and diagnosed with the
//! defaults of the `rotorid` command; the critical speeds of the
//! identified rotor come from its Campbell analysis.
//!
//! `cargo run --release --example library`

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let paper = rotorid::RotorModel::paper();
    let model =
        rotorid::simulate::at_balance_grade(&paper, 6.3, rotorid::units::rpm_to_rad_s(15000.0))
            .ok_or("no unbalance to scale")?;
    let mut meas = rotorid::simulate(
        &model,
        &rotorid::SimOptions {
            noise: 0.005,
            ..Default::default()
        },
    )?;
    rotorid::simulate::add_floor_noise(&mut meas, 0.5e-6, 1)?;

    let id = rotorid::identify(&model, &meas, &rotorid::IdentifyOptions::default())?;
    print!(
        "{}",
        rotorid::report::identify::report_table(&id, Some(&model))
    );
    let d = rotorid::diagnose(&model, &meas, &rotorid::DiagnoseOptions::default())?;
    println!("diagnosis: {}", d.effect.name());

    let c = rotorid::campbell(
        &id.identified_model(&model),
        &rotorid::CampbellOptions::default(),
    )?;
    for s in &c.critical {
        let rpm = rotorid::units::rad_s_to_rpm(s.omega);
        println!(
            "critical speed: {rpm:.0} rpm (mode {}, {:?})",
            s.mode + 1,
            s.whirl
        );
    }
    Ok(())
}
