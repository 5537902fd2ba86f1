//! `rotorid identify` end to end: SPEC flags, the JSON contract, one-line
//! errors with exit status 2.

use crate::common::*;
use rotorid::model::RotorModel;

#[test]
fn identify_writes_the_spec_json() {
    let model = RotorModel::paper();
    let meas = simulate(&model, &sweep(50.0, 15000.0, 50.0));
    let csv = tmp("sweep.csv");
    rotorid::io::measurement::write_csv(&meas, &csv, Default::default()).unwrap();
    for (formulation, order) in [("physical", "1"), ("paper", "1"), ("paper", "2")] {
        let json = tmp(&format!("out-{formulation}-{order}.json"));
        let out = cli([
            "identify",
            "--model",
            "paper",
            "--measurements",
            csv.to_str().unwrap(),
            "--formulation",
            formulation,
            "--order",
            order,
            "--lambda",
            "0.999",
            "--delta",
            "1e-7",
            "--json",
            json.to_str().unwrap(),
        ]);
        assert!(out.success(), "{}", out.stderr);
        let table = &out.stdout;
        assert!(
            table.contains("b1@1 kyy") && table.contains("n21 phase_deg"),
            "{table}"
        );
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        let b = v["bearings"].as_array().unwrap();
        assert_eq!(b.len(), 2);
        assert_eq!(b[0]["node"], 1);
        assert_eq!(b[1]["node"], 27);
        let truth = [
            ([5e7, 0.5e7, 1e7, 7e7], [500.0, 50.0, 100.0, 700.0]),
            ([5e7, 1e7, 0.5e7, 7e7], [500.0, 100.0, 50.0, 700.0]),
        ];
        for (m, (k, c)) in truth.iter().enumerate() {
            for (j, key) in ["yy", "yz", "zy", "zz"].iter().enumerate() {
                let kk = b[m]["k"][key].as_f64().unwrap();
                let cc = b[m]["c"][key].as_f64().unwrap();
                assert!(
                    (kk - k[j]).abs() < 1e-6 * k[j],
                    "{formulation} {order} k{key} {kk}"
                );
                assert!(
                    (cc - c[j]).abs() < 1e-5 * c[j],
                    "{formulation} {order} c{key} {cc}"
                );
            }
            assert_eq!(b[m].get("check").is_some(), formulation == "paper");
        }
        let u = v["unbalance"].as_array().unwrap();
        let nodes: Vec<i64> = u.iter().map(|x| x["node"].as_i64().unwrap()).collect();
        assert_eq!(nodes, [5, 11, 21]);
        for (x, (me, ph)) in u
            .iter()
            .zip([(0.0042, 0.0), (0.0030, 18.0), (0.0073, 23.0)])
        {
            assert!((x["me"].as_f64().unwrap() - me).abs() < 1e-6 * me);
            assert!((x["phase_deg"].as_f64().unwrap() - ph).abs() < 1e-4);
        }
        assert_eq!(v["order"].as_u64().unwrap().to_string(), order);
    }
}

#[test]
fn identify_bad_input_exits_2_with_one_line() {
    let model = RotorModel::paper();
    let meas = simulate(&model, &sweep(1000.0, 3000.0, 500.0));
    let csv = tmp("short.csv");
    rotorid::io::measurement::write_csv(&meas, &csv, Default::default()).unwrap();
    let cases: Vec<Vec<String>> = vec![
        vec!["--measurements".into(), "/nonexistent/x.csv".into()],
        vec![
            "--measurements".into(),
            csv.display().to_string(),
            "--lambda".into(),
            "1.5".into(),
        ],
        vec![
            "--measurements".into(),
            csv.display().to_string(),
            "--delta".into(),
            "-1".into(),
        ],
        vec![
            "--measurements".into(),
            csv.display().to_string(),
            "--order".into(),
            "0".into(),
        ],
        vec![
            "--measurements".into(),
            csv.display().to_string(),
            "--formulation".into(),
            "magic".into(),
        ],
    ];
    for extra in cases {
        let out = cli(["identify", "--model", "paper"]
            .iter()
            .map(|s| s.to_string())
            .chain(extra.clone()));
        assert_eq!(out.status, 2, "{extra:?}");
        let err = &out.stderr;
        assert_eq!(err.trim_end().lines().count(), 1, "{extra:?}: {err}");
    }
    // An unknown model name.
    let out = cli([
        "identify",
        "--model",
        "no-such-model",
        "--measurements",
        csv.to_str().unwrap(),
    ]);
    assert_eq!(out.status, 2);
}

/// Data that cannot determine the parameters is an input error with a
/// reason, for both estimators: one or two speeds (8 or 16 real equations
/// for 22 unknowns), many samples at one speed, no signal.
#[test]
fn data_that_cannot_determine_the_parameters_exits_2() {
    let model = RotorModel::paper();
    let two = simulate(&model, &sweep(3000.0, 3500.0, 500.0));
    let mut one_speed = simulate(&model, &sweep(3000.0, 3000.0, 500.0));
    let s0 = one_speed.samples[0].clone();
    one_speed.samples = vec![s0; 500];
    let mut zeros = simulate(&model, &sweep(1000.0, 5000.0, 100.0));
    for s in &mut zeros.samples {
        for q in &mut s.q {
            *q = num_complex::Complex64::new(0.0, 0.0);
        }
    }
    for (name, meas, reason) in [
        ("two.csv", &two, "cannot determine"),
        ("one-speed.csv", &one_speed, "cannot determine"),
        ("zeros.csv", &zeros, "no signal"),
    ] {
        let csv = tmp(name);
        rotorid::io::measurement::write_csv(meas, &csv, Default::default()).unwrap();
        for estimator in ["oe", "rls"] {
            let out = cli([
                "identify",
                "--model",
                "paper",
                "--measurements",
                csv.to_str().unwrap(),
                "--estimator",
                estimator,
            ]);
            assert_eq!(out.status, 2, "{name} {estimator}: {}", out.stdout);
            assert_eq!(out.stderr.trim_end().lines().count(), 1, "{}", out.stderr);
            assert!(out.stderr.contains(reason), "{name}: {}", out.stderr);
        }
    }
}

/// A model that does not fit the data: exit 0, the warning on stderr and
/// in the JSON.
#[test]
fn a_misfit_is_a_warning_not_an_error() {
    let model = RotorModel::paper_speed_dependent();
    let meas = simulate(&model, &sweep(50.0, 15000.0, 25.0));
    let csv = tmp("eq49.csv");
    rotorid::io::measurement::write_csv(&meas, &csv, Default::default()).unwrap();
    let json = tmp("eq49.json");
    let out = cli([
        "identify",
        "--model",
        "paper-speed-dependent",
        "--measurements",
        csv.to_str().unwrap(),
        "--order",
        "2",
        "--json",
        json.to_str().unwrap(),
    ]);
    assert!(out.success(), "{}", out.stderr);
    assert!(out.stderr.contains("warning: residual"), "{}", out.stderr);
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(v["estimator"], "oe");
    assert!(v["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .any(|w| w.as_str().unwrap().contains("the model lacks something")));
}

/// `--ross-out` writes the model with the identified bearings, as
/// rotorid's ROSS reader reads them back: constant `K`, `C` equal to the
/// JSON's (physical structure, order 1; the JSON is read back through
/// serde_json's float parser, hence 1e-15 relative, a few ulps); a law
/// that changes with speed (physical order 2, the paper structure) as a
/// 31-point PCHIP table over the measured speeds (50..15000 rpm) whose
/// last point is the JSON's coefficients at the last speed. The noise-free
/// data make every table entry the model's values to 1e-6 (stiffness) and
/// 1e-5 (damping). Writing over an input is refused.
#[test]
fn identify_ross_out_holds_the_identified_bearings() {
    use rotorid::model::{BearingLaw, TableInterpolation};
    let model = RotorModel::paper();
    let meas = simulate(&model, &sweep(50.0, 15000.0, 50.0));
    let csv = tmp("sweep.csv");
    rotorid::io::measurement::write_csv(&meas, &csv, Default::default()).unwrap();
    let truth = [
        ([5e7, 0.5e7, 1e7, 7e7], [500.0, 50.0, 100.0, 700.0]),
        ([5e7, 1e7, 0.5e7, 7e7], [500.0, 100.0, 50.0, 700.0]),
    ];
    let keys = ["yy", "yz", "zy", "zz"];
    for (formulation, order) in [("physical", "1"), ("physical", "2"), ("paper", "1")] {
        let json = tmp(&format!("id-{formulation}-{order}.json"));
        let ross = tmp(&format!("id-{formulation}-{order}.toml"));
        let out = cli([
            "identify",
            "--model",
            "paper",
            "--measurements",
            csv.to_str().unwrap(),
            "--formulation",
            formulation,
            "--order",
            order,
            "--json",
            json.to_str().unwrap(),
            "--ross-out",
            ross.to_str().unwrap(),
        ]);
        assert!(out.success(), "{}", out.stderr);
        assert!(
            out.stderr.contains(&format!("wrote {}", ross.display())),
            "{}",
            out.stderr
        );
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        let text = std::fs::read_to_string(&ross).unwrap();
        assert!(rotorid::io::model_file::is_ross(&text));
        let back = rotorid::io::model_file::load_model(&ross).unwrap();
        assert_eq!(back.shaft, model.shaft);
        assert_eq!(back.disks, model.disks);
        assert_eq!(back.planes, model.planes);
        assert_eq!(back.bearings.len(), 2);
        for (m, b) in back.bearings.iter().enumerate() {
            assert_eq!(b.node, model.bearings[m].node);
            assert_eq!(b.pedestal, None);
            let last = match (&b.law, formulation, order) {
                (BearingLaw::Constant(c), "physical", "1") => *c,
                (
                    BearingLaw::Table {
                        speeds,
                        coefficients,
                        interpolation,
                    },
                    _,
                    _,
                ) if (formulation, order) != ("physical", "1") => {
                    assert_eq!(*interpolation, TableInterpolation::Pchip);
                    assert_eq!(speeds.len(), rotorid::io::ross::ROSS_TABLE_POINTS);
                    assert_eq!(speeds[0], rotorid::units::rpm_to_rad_s(50.0));
                    assert_eq!(speeds[30], rotorid::units::rpm_to_rad_s(15000.0));
                    for c in coefficients {
                        for j in 0..4 {
                            let (k, d) = (truth[m].0[j], truth[m].1[j]);
                            assert!((c.k[j] - k).abs() < 1e-6 * k, "{formulation} {order}");
                            assert!((c.c[j] - d).abs() < 1e-5 * d, "{formulation} {order}");
                        }
                    }
                    coefficients[30]
                }
                (law, _, _) => panic!("{formulation} {order}: {law:?}"),
            };
            let tol = if order == "1" && formulation == "physical" {
                1e-15
            } else {
                1e-12
            };
            for (j, key) in keys.iter().enumerate() {
                let k = v["bearings"][m]["k"][key].as_f64().unwrap();
                let c = v["bearings"][m]["c"][key].as_f64().unwrap();
                assert!(
                    (last.k[j] - k).abs() <= tol * k.abs(),
                    "k{key} {}",
                    last.k[j]
                );
                assert!(
                    (last.c[j] - c).abs() <= tol * c.abs(),
                    "c{key} {}",
                    last.c[j]
                );
            }
        }
    }
    let out = cli([
        "identify",
        "--model",
        "paper",
        "--measurements",
        csv.to_str().unwrap(),
        "--ross-out",
        csv.to_str().unwrap(),
    ]);
    assert_eq!(out.status, 2);
    assert!(
        out.stderr.contains("--ross-out") && out.stderr.contains("refusing to overwrite an input"),
        "{}",
        out.stderr
    );
    assert_eq!(out.stderr.trim_end().lines().count(), 1);
}
