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
