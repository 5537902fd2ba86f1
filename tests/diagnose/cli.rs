//! `rotorid diagnose` end to end: the SPEC JSON, exit statuses, one-line
//! errors.

use crate::common::*;
use rotorid::diagnose::generator::generate;
use rotorid::diagnose::Effect;
use rotorid::model::RotorModel;

fn speeds() -> Vec<f64> {
    (1..=300).map(|i| 50.0 * i as f64).collect()
}

/// A runout case written as CSV, diagnosed by the binary: exit 0, the
/// SPEC keys, the named effect, a gain above 10 and the runout phasor
/// within 5 % and within 3 reported standard deviations.
#[test]
fn diagnose_names_runout_and_writes_the_spec_json() {
    let m = RotorModel::paper();
    let case = generate(&m, Effect::ProbeRunout, 7, &speeds(), Some(0.001)).unwrap();
    let csv = tmp("diag-runout.csv");
    rotorid::io::measurement::write_csv(&case.meas, &csv, Default::default()).unwrap();
    let json = tmp("diag-runout.json");
    let plots = tmp("diag-runout-plots");
    let out = cli([
        "diagnose",
        "--model",
        "paper",
        "--measurements",
        csv.to_str().unwrap(),
        "--json",
        json.to_str().unwrap(),
        "--plot",
        plots.to_str().unwrap(),
    ]);
    assert!(out.success(), "{}", out.stderr);
    assert!(
        out.stdout.contains("diagnosis: probe_runout"),
        "{}",
        out.stdout
    );
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(v["effect"], "probe_runout");
    let rn = v["residual_nominal"].as_f64().unwrap();
    let re = v["residual_extended"].as_f64().unwrap();
    let gain = v["gain"].as_f64().unwrap();
    assert!((gain - rn / re).abs() <= 1e-9 * gain);
    assert!(gain >= 10.0, "gain {gain}");
    assert!(re < 1.5 * 0.001, "extended residual {re} above the noise");
    assert_eq!(v["bearings"].as_array().unwrap().len(), 2);
    assert!(v["bearings"][0]["k"]["yy"].as_f64().unwrap() > 0.0);
    assert_eq!(v["unbalance"].as_array().unwrap().len(), 3);
    let f = &v["findings"][0];
    assert_eq!(f["effect"], "probe_runout");
    for (ch, z) in &case.hidden.runout {
        let c = &f["channels"][*ch];
        let a = c["amplitude"].as_f64().unwrap();
        let sa = c["amplitude_std"].as_f64().unwrap();
        assert!(
            (a - z.norm()).abs() <= 0.05 * z.norm(),
            "{a} vs {}",
            z.norm()
        );
        assert!(
            (a - z.norm()).abs() <= 3.0 * sa + 1e-12,
            "{a} vs {} (std {sa})",
            z.norm()
        );
        let dp = (c["phase_deg"].as_f64().unwrap() - z.arg().to_degrees() + 540.0) % 360.0 - 180.0;
        assert!(dp.abs() < 3.0, "phase off by {dp} deg");
    }
    for name in [
        "diagnose_residual.svg",
        "diagnose_b1_y.svg",
        "diagnose_b2_z.svg",
    ] {
        assert!(plots.join(name).exists(), "{name}");
    }
}

/// Bad or inconsistent input: exit 2, one line.
#[test]
fn diagnose_rejects_bad_input() {
    let m = RotorModel::paper();
    // Too few speeds.
    let case = generate(&m, Effect::None, 1, &[1000.0, 2000.0, 3000.0], Some(0.001)).unwrap();
    let csv = tmp("diag-few.csv");
    rotorid::io::measurement::write_csv(&case.meas, &csv, Default::default()).unwrap();
    let out = cli([
        "diagnose",
        "--model",
        "paper",
        "--measurements",
        csv.to_str().unwrap(),
    ]);
    assert_eq!(out.status, 2, "{}", out.stderr);
    assert_eq!(out.stderr.trim().lines().count(), 1, "{}", out.stderr);
    assert!(out.stderr.contains("speeds"), "{}", out.stderr);
    // A measurement with a bearing count the model does not have.
    let many: Vec<f64> = speeds();
    let big = generate(&m, Effect::None, 2, &many, Some(0.001)).unwrap();
    let mut three = big.meas.clone();
    three.n_bearings = 3;
    for s in &mut three.samples {
        let extra = [s.q[0], s.q[1]];
        s.q.extend(extra);
    }
    let csv3 = tmp("diag-three.csv");
    rotorid::io::measurement::write_csv(&three, &csv3, Default::default()).unwrap();
    let out = cli([
        "diagnose",
        "--model",
        "paper",
        "--measurements",
        csv3.to_str().unwrap(),
    ]);
    assert_eq!(out.status, 2, "{}", out.stderr);
    assert!(out.stderr.contains("bearings"), "{}", out.stderr);
    assert_eq!(out.stderr.trim().lines().count(), 1, "{}", out.stderr);
    // Unknown model.
    let out = cli([
        "diagnose",
        "--model",
        "nope",
        "--measurements",
        csv3.to_str().unwrap(),
    ]);
    assert_eq!(out.status, 2, "{}", out.stderr);
}

/// A model whose bearings declare probes at an angle (+-45 deg on bearing
/// 1, 30 and 100 deg on bearing 2): `diagnose` reads the probe-named file
/// (the readings of the runout case's `y`, `z`) back into `y`, `z` and
/// gives the diagnosis of the `y`, `z` file: the same effect, bearings and
/// unbalance to round-off (1e-9), and the gain (nominal over extended
/// residual) within what a one-ulp change of the data does to it.
#[test]
fn diagnose_reads_probes_at_an_angle() {
    let m = RotorModel::paper();
    let case = generate(&m, Effect::ProbeRunout, 7, &speeds(), Some(0.001)).unwrap();
    let text = std::fs::read_to_string(example("paper.toml"))
        .unwrap()
        .replacen(
            "node = 1\n",
            "node = 1\nprobes = [{ name = \"1X\", angle_deg = 45.0 }, { name = \"1Y\", angle_deg = -45.0 }]\n",
            1,
        )
        .replacen(
            "node = 27\n",
            "node = 27\nprobes = [{ name = \"2A\", angle_deg = 30.0 }, { name = \"2B\", angle_deg = 100.0 }]\n",
            1,
        );
    let model = tmp("probes.toml");
    std::fs::write(&model, &text).unwrap();
    let probes = rotorid::io::model_file::parse_model_file(&text)
        .unwrap()
        .probes;
    let yz = tmp("yz.csv");
    rotorid::io::measurement::write_csv(&case.meas, &yz, Default::default()).unwrap();
    let mut readings = case.meas.clone();
    rotorid::io::measurement::yz_to_probes(&mut readings, &probes);
    let named = tmp("named.csv");
    let names = rotorid::io::measurement::model_channel_names(&probes);
    rotorid::io::measurement::write_csv_channels(
        &readings,
        &named,
        Default::default(),
        Some(&names),
        &[],
        &[],
    )
    .unwrap();
    let run = |model: &str, csv: &std::path::Path, tag: &str| -> serde_json::Value {
        let json = tmp(&format!("{tag}.json"));
        let out = cli([
            "diagnose",
            "--model",
            model,
            "--measurements",
            csv.to_str().unwrap(),
            "--json",
            json.to_str().unwrap(),
        ]);
        assert!(out.success(), "{}", out.stderr);
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap()
    };
    let a = run("paper", &yz, "yz");
    let b = run(model.to_str().unwrap(), &named, "named");
    assert_eq!(a["effect"], "probe_runout");
    assert_eq!(b["effect"], a["effect"]);
    let rel = |x: &serde_json::Value, y: &serde_json::Value| {
        let (x, y) = (x.as_f64().unwrap(), y.as_f64().unwrap());
        (x - y).abs() / y.abs()
    };
    let mut worst = 0.0f64;
    for bi in 0..2 {
        for kc in ["k", "c"] {
            for key in ["yy", "yz", "zy", "zz"] {
                worst = worst.max(rel(
                    &b["bearings"][bi][kc][key],
                    &a["bearings"][bi][kc][key],
                ));
            }
        }
    }
    for k in 0..3 {
        worst = worst.max(rel(&b["unbalance"][k]["me"], &a["unbalance"][k]["me"]));
    }
    let gain = rel(&b["gain"], &a["gain"]);
    eprintln!("probe file vs y, z file: bearings and unbalance {worst:.1e}, gain {gain:.1e}");
    assert!(worst < 1e-9, "{worst:e}");
    // The gain is a ratio of residuals whose extended fit stops at its
    // tolerance: y, z scaled by (1 + 2.2e-16) alone moves it by 4.5e-4.
    assert!(gain < 1e-2, "{gain:e}");
}

/// A probe reading 10 % low, simulated by the binary on realistic data
/// (balance grade G6.3, 0.5 % + 0.5 um probe floor) and diagnosed by it:
/// `probe_sensitivity` in the JSON, on that probe's pair, the gain (or
/// the pair's equivalent `1 / g` on the other direction) within 3.5
/// reported standard deviations of 0.9.
#[test]
fn diagnose_names_a_probe_sensitivity_from_simulate() {
    let csv = tmp("diag-gain.csv");
    let json = tmp("diag-gain.json");
    let sim = cli([
        "simulate",
        "--model",
        "paper",
        "--out",
        csv.to_str().unwrap(),
        "--balance-grade",
        "6.3",
        "--noise",
        "0.005",
        "--noise-floor",
        "5e-7",
        "--probe-gain",
        "b1_z:0.9",
        "--seed",
        "5",
    ]);
    assert!(sim.success(), "{}", sim.stderr);
    let out = cli([
        "diagnose",
        "--model",
        "paper",
        "--measurements",
        csv.to_str().unwrap(),
        "--json",
        json.to_str().unwrap(),
    ]);
    assert!(out.success(), "{}", out.stderr);
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(v["effect"], "probe_sensitivity", "{}", out.stdout);
    let f = &v["findings"][0];
    assert_eq!(f["effect"], "probe_sensitivity");
    let g = f["gain"].as_f64().unwrap();
    let sd = f["gain_std"].as_f64().unwrap();
    let (g, sd) = match f["channel"].as_str().unwrap() {
        "b1_z" => (g, sd),
        "b1_y" => (1.0 / g, sd / (g * g)),
        other => panic!("channel {other}: {}", out.stdout),
    };
    assert!((g - 0.9).abs() <= 3.5 * sd, "gain {g} +- {sd}");
    assert!(out.stdout.contains("probe b1_"), "{}", out.stdout);
}
