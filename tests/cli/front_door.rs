//! The library's front door and the `rotorid` command give the same
//! answer: the same file through `rotorid::read_for_model`,
//! `rotorid::identify` / `rotorid::diagnose` with the default options, and
//! the JSON of the command, byte for byte; likewise `rotorid::campbell`
//! of the model alone.

use crate::common::*;
use rotorid::model::RotorModel;

/// A realistic sweep of the paper rotor: unbalance at balance grade G6.3,
/// 0.5 % noise plus a 0.5 um probe floor, 5 um of runout, 300 speeds.
fn realistic_csv() -> std::path::PathBuf {
    let paper = RotorModel::paper();
    let model =
        rotorid::simulate::at_balance_grade(&paper, 6.3, rotorid::units::rpm_to_rad_s(15000.0))
            .unwrap();
    let effects = rotorid::model::extension::Effects {
        runout: rotorid::simulate::random_runout(2, 5e-6, 11),
        ..Default::default()
    };
    let opts = rotorid::SimOptions {
        noise: 0.005,
        seed: 3,
        effects,
        ..Default::default()
    };
    let mut meas = rotorid::simulate(&model, &opts).unwrap();
    rotorid::simulate::add_floor_noise(&mut meas, 5e-7, 3).unwrap();
    let csv = tmp("realistic.csv");
    rotorid::io::measurement::write_csv(&meas, &csv, Default::default()).unwrap();
    csv
}

/// The JSON `rotorid CMD --model paper --measurements CSV --json ...`
/// writes.
fn command_json(cmd: &str, csv: &std::path::Path) -> String {
    let json = tmp(&format!("{cmd}.json"));
    let out = cli([
        cmd,
        "--model",
        "paper",
        "--measurements",
        csv.to_str().unwrap(),
        "--json",
        json.to_str().unwrap(),
    ]);
    assert!(out.success(), "{}", out.stderr);
    std::fs::read_to_string(&json).unwrap()
}

#[test]
fn library_and_command_write_the_same_json() {
    let csv = realistic_csv();
    let file = rotorid::io::model_file::model_file_by_name_or_path("paper").unwrap();
    let read = rotorid::read_for_model(&csv, &file).unwrap();

    let id = rotorid::identify(&file.model, &read.measurements, &Default::default()).unwrap();
    let lib = serde_json::to_string_pretty(&id.result()).unwrap() + "\n";
    assert_eq!(command_json("identify", &csv), lib);
    // The runout was found and fitted on every channel (the default
    // handles it).
    assert_eq!(id.result().runout.len(), 4, "{lib}");

    let d = rotorid::diagnose(&file.model, &read.measurements, &Default::default()).unwrap();
    let lib = serde_json::to_string_pretty(&rotorid::report::diagnose::json(&d)).unwrap() + "\n";
    assert_eq!(command_json("diagnose", &csv), lib);
}

#[test]
fn campbell_library_and_command_write_the_same_json() {
    let file = rotorid::io::model_file::model_file_by_name_or_path("paper").unwrap();
    let analysis = rotorid::campbell(&file.model, &rotorid::CampbellOptions::default()).unwrap();
    let report = rotorid::report::campbell::CampbellReport::new("paper", &analysis);
    let lib = serde_json::to_string_pretty(&report.json()).unwrap() + "\n";
    let json = tmp("campbell-front-door.json");
    let out = cli([
        "campbell",
        "--model",
        "paper",
        "--json",
        json.to_str().unwrap(),
    ]);
    assert!(out.success(), "{}", out.stderr);
    assert_eq!(std::fs::read_to_string(&json).unwrap(), lib);
    // The critical speeds are there, and the table printed is the report's.
    assert!(!analysis.critical.is_empty());
    assert_eq!(out.stdout, report.text());
}
