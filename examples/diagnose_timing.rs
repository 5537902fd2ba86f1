//! Where a diagnosis spends its time: one generated case per effect of the
//! bank (and `none`) on the paper rotor (or another), 300 speeds up to 15000 rpm,
//! 0.1 % noise, each diagnosed once with every hypothesis; prints the
//! wall-clock time of each stage ([`rotorid::diagnose::Diagnosis::stages`])
//! and the total. The criterion benchmark `cargo bench --bench diagnose`
//! gives the statistics of the total; this gives its breakdown.
//!
//! ```sh
//! cargo run --release --example diagnose_timing [SEED]
//! cargo run --release --example diagnose_timing SEED realistic
//! cargo run --release --example diagnose_timing SEED realistic tests/data/ross/stepped_hollow.toml 11000
//! cargo run --release --example diagnose_timing SEED realistic tests/data/rotors/three_bearing.toml 12000
//! cargo run --release --example diagnose_timing SEED realistic paper 15000 1
//! ```
//!
//! `realistic`: the cases of the realistic confusion matrix instead, the
//! unbalance at balance grade G6.3, 0.5 % relative noise and a 0.5 um
//! probe floor (SPEC section 7). Then, optionally, another rotor (a model
//! file, rotorid's or ROSS's) and its top speed in rpm (300 speeds up to
//! it), and the threads of the hypotheses' fits (default 0: one per core;
//! with more than one the stage laps are each family's own duration and
//! add up to more than the total).

use rotorid::diagnose::generator::generate;
use rotorid::diagnose::{diagnose, DiagnoseOptions, Effect};
use rotorid::model::RotorModel;

/// Hidden effect, named effect, stage times (s), total (s).
type Run = (Effect, Effect, Vec<(&'static str, f64)>, f64);

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let seed: u64 = match std::env::args().nth(1) {
        Some(s) => s.parse()?,
        None => 11,
    };
    let realistic = std::env::args().nth(2).as_deref() == Some("realistic");
    let base = match std::env::args().nth(3) {
        Some(path) => rotorid::io::model_file::model_file_by_name_or_path(&path)?.model,
        None => RotorModel::paper(),
    };
    let rpm_max: f64 = match std::env::args().nth(4) {
        Some(s) => s.parse()?,
        None => 15000.0,
    };
    let opts = DiagnoseOptions {
        threads: match std::env::args().nth(5) {
            Some(s) => s.parse()?,
            None => 0,
        },
        ..Default::default()
    };
    // A model without unbalance (a ROSS file) gets the generator's own,
    // balance grade G2.5 on its planes.
    let model = if realistic {
        rotorid::simulate::at_balance_grade(&base, 6.3, rotorid::units::rpm_to_rad_s(rpm_max))
            .unwrap_or(base)
    } else {
        base
    };
    let (noise, floor) = if realistic {
        (0.005, 0.5e-6)
    } else {
        (0.001, 0.0)
    };
    let speeds: Vec<f64> = (1..=300).map(|i| rpm_max * i as f64 / 300.0).collect();
    let mut effects = vec![Effect::None];
    effects.extend_from_slice(&Effect::BANK);
    let mut runs: Vec<Run> = Vec::new();
    for effect in effects {
        let mut case = generate(&model, effect, seed, &speeds, Some(noise))?;
        rotorid::simulate::add_floor_noise(&mut case.meas, floor, seed)?;
        let t = std::time::Instant::now();
        let d = diagnose(&model, &case.meas, &opts)?;
        let total = t.elapsed().as_secs_f64();
        runs.push((effect, d.effect, d.stages, total));
    }
    // One row per stage, one column per hidden effect (seconds).
    print!("{:<34}", "stage \\ hidden effect");
    for (hidden, ..) in &runs {
        print!(" {:>9}", short(hidden.name()));
    }
    println!();
    let stages: Vec<&str> = runs
        .first()
        .map_or(Vec::new(), |r| r.2.iter().map(|s| s.0).collect());
    for (i, name) in stages.iter().enumerate() {
        print!("{name:<34}");
        for (_, _, st, _) in &runs {
            print!(" {:>9.3}", st.get(i).map_or(f64::NAN, |s| s.1));
        }
        println!();
    }
    print!("{:<34}", "total");
    for (.., total) in &runs {
        print!(" {total:>9.3}");
    }
    println!();
    print!("{:<34}", "named");
    for (_, named, ..) in &runs {
        print!(" {:>9}", short(named.name()));
    }
    println!();
    Ok(())
}

/// A short column label for an effect.
fn short(name: &str) -> &'static str {
    match name {
        "none" => "none",
        "speed_dependent_bearing" => "speed_law",
        "foundation_flexibility" => "pedestal",
        "shaft_bow" => "bow",
        "probe_runout" => "runout",
        "extra_unbalance_plane" => "plane",
        "shaft_stiffness_error" => "modulus",
        "probe_sensitivity" => "gain",
        _ => "unexpl.",
    }
}
