//! One generated diagnosis case in full: the hidden effect, then the
//! diagnosis's text with its stages (as `rotorid diagnose` prints it). The
//! cases are those of the confusion matrices
//! (`rotorid::diagnose::generator`): 300 speeds up to RPM_MAX.
//!
//! ```sh
//! cargo run --release --example diagnose_case -- shaft_bow 3 draw
//! cargo run --release --example diagnose_case -- EFFECT [SEED [NOISE [MODEL [RPM_MAX]]]]
//! ```
//!
//! EFFECT is an effect's name (`none`, `shaft_bow`, ...); SEED the case's
//! seed (0); NOISE a relative level (0.001) or `draw` for the generator's
//! own draw, as the confusion matrix does; MODEL `paper` or a model file;
//! RPM_MAX the top speed (15000).

use rotorid::diagnose::generator::generate;
use rotorid::diagnose::{diagnose, DiagnoseOptions, Effect};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |i: usize| args.get(i).map(String::as_str);
    let effect = match arg(0) {
        Some(name) => Effect::from_name(name).ok_or(format!("no effect named {name}"))?,
        None => Effect::None,
    };
    let seed: u64 = arg(1).map_or(Ok(0), str::parse)?;
    let noise = match arg(2) {
        Some("draw") => None,
        Some(s) => Some(s.parse()?),
        None => Some(0.001),
    };
    let model =
        rotorid::io::model_file::model_file_by_name_or_path(arg(3).unwrap_or("paper"))?.model;
    let rpm_max: f64 = arg(4).map_or(Ok(15000.0), str::parse)?;
    let speeds: Vec<f64> = (1..=300).map(|i| rpm_max * i as f64 / 300.0).collect();

    let case = generate(&model, effect, seed, &speeds, noise)?;
    let d = diagnose(&model, &case.meas, &DiagnoseOptions::default())?;
    println!("hidden {} (noise {})", case.hidden.description, case.noise);
    let nominal = rotorid::diagnose::predictions(&model, &d, &d.nominal)?;
    println!(
        "{}",
        rotorid::report::diagnose::text(&d, &case.meas.samples, &nominal)
    );
    Ok(())
}
