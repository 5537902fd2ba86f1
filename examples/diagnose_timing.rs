//! Where a diagnosis spends its time: one generated case per effect of the
//! bank (and `none`) on the paper rotor, 300 speeds from 50 to 15000 rpm,
//! 0.1 % noise, each diagnosed once with every hypothesis; prints the
//! wall-clock time of each stage ([`rotorid::diagnose::Diagnosis::stages`])
//! and the total. The criterion benchmark `cargo bench --bench diagnose`
//! gives the statistics of the total; this gives its breakdown.
//!
//! ```sh
//! cargo run --release --example diagnose_timing [SEED]
//! ```

use rotorid::diagnose::generator::generate;
use rotorid::diagnose::{diagnose, DiagnoseOptions, Effect};
use rotorid::model::RotorModel;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let seed: u64 = match std::env::args().nth(1) {
        Some(s) => s.parse()?,
        None => 11,
    };
    let model = RotorModel::paper();
    let speeds: Vec<f64> = (1..=300).map(|i| 50.0 * i as f64).collect();
    let mut effects = vec![Effect::None];
    effects.extend_from_slice(&Effect::BANK);
    let mut header_done = false;
    for effect in effects {
        let case = generate(&model, effect, seed, &speeds, Some(0.001))?;
        let t = std::time::Instant::now();
        let d = diagnose(&model, &case.meas, &DiagnoseOptions::default())?;
        let total = t.elapsed().as_secs_f64();
        if !header_done {
            print!("{:<24}", "hidden -> named");
            for (name, _) in &d.stages {
                print!(" {:>10}", short(name));
            }
            println!(" {:>8}", "total s");
            header_done = true;
        }
        print!(
            "{:<24}",
            format!("{} -> {}", short(effect.name()), short(d.effect.name()))
        );
        for (_, s) in &d.stages {
            print!(" {s:>10.3}");
        }
        println!(" {total:>8.3}");
    }
    Ok(())
}

/// A column-wide abbreviation of a stage or effect name.
fn short(name: &str) -> String {
    let s: String = name
        .split(['_', ' ', ','])
        .filter(|w| !w.is_empty())
        .map(|w| w.chars().take(4).collect::<String>())
        .collect::<Vec<_>>()
        .join("_");
    s.chars().take(10).collect()
}
