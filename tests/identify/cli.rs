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

/// The paper rotor's model file with angled probes declared: API 670 X-Y
/// probes at +-45 deg on bearing 1, and a non-orthogonal pair (30, 100
/// deg) on bearing 2.
fn paper_with_probes() -> String {
    let text = std::fs::read_to_string(example("paper.toml")).unwrap();
    let text = text.replacen(
        "node = 1\n",
        "node = 1\nprobes = [{ name = \"1X\", angle_deg = 45.0 }, { name = \"1Y\", angle_deg = -45.0 }]\n",
        1,
    );
    text.replacen(
        "node = 27\n",
        "node = 27\nprobes = [{ name = \"DE_a\", angle_deg = 30.0 }, { name = \"DE_b\", angle_deg = 100.0 }]\n",
        1,
    )
}

fn identify_json(model: &str, csv: &std::path::Path, json: &std::path::Path) -> serde_json::Value {
    let out = cli([
        "identify",
        "--model",
        model,
        "--measurements",
        csv.to_str().unwrap(),
        "--json",
        json.to_str().unwrap(),
    ]);
    assert!(out.success(), "{}", out.stderr);
    serde_json::from_str(&std::fs::read_to_string(json).unwrap()).unwrap()
}

/// Largest relative difference between two identify JSONs' bearing
/// coefficients and unbalance `m e` (and absolute, in degrees, of the
/// phases).
fn json_difference(a: &serde_json::Value, b: &serde_json::Value) -> f64 {
    let mut worst = 0.0f64;
    for m in 0..2 {
        for kc in ["k", "c"] {
            for key in ["yy", "yz", "zy", "zz"] {
                let x = a["bearings"][m][kc][key].as_f64().unwrap();
                let y = b["bearings"][m][kc][key].as_f64().unwrap();
                worst = worst.max((x - y).abs() / y.abs());
            }
        }
    }
    for k in 0..3 {
        let x = a["unbalance"][k]["me"].as_f64().unwrap();
        let y = b["unbalance"][k]["me"].as_f64().unwrap();
        worst = worst.max((x - y).abs() / y);
        let x = a["unbalance"][k]["phase_deg"].as_f64().unwrap();
        let y = b["unbalance"][k]["phase_deg"].as_f64().unwrap();
        worst = worst.max((x - y).abs());
    }
    worst
}

/// `simulate` on a model with angled probes writes the probe-named columns
/// (the readings `cos theta y + sin theta z` of the same noisy sweep), and
/// `identify` reads them back into `y`, `z`: the estimates equal those from
/// the plain `y`, `z` file of the same sweep to round-off (1e-9, complex
/// and amplitude/phase layouts). The model with probes also reads a
/// `y`, `z` file as before.
#[test]
fn angled_probes_round_trip_through_simulate_and_identify() {
    let model = tmp("probes.toml");
    std::fs::write(&model, paper_with_probes()).unwrap();
    let plain = example("paper.toml");
    let sim = |m: &std::path::Path, out: &std::path::Path, layout: &str| {
        let o = cli([
            "simulate",
            "--model",
            m.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--noise",
            "0.01",
            "--seed",
            "3",
            "--layout",
            layout,
        ]);
        assert!(o.success(), "{}", o.stderr);
    };
    let yz = tmp("yz.csv");
    sim(&plain, &yz, "complex");
    let reference = identify_json(plain.to_str().unwrap(), &yz, &tmp("yz.json"));
    for layout in ["complex", "amp-phase"] {
        let csv = tmp(&format!("probes-{layout}.csv"));
        sim(&model, &csv, layout);
        let text = std::fs::read_to_string(&csv).unwrap();
        let header = text.lines().find(|l| !l.starts_with('#')).unwrap();
        let want = if layout == "complex" {
            "speed_rpm,1X_re,1X_im,1Y_re,1Y_im,DE_a_re,DE_a_im,DE_b_re,DE_b_im"
        } else {
            "speed_rpm,1X_amp,1X_phase_deg,1Y_amp,1Y_phase_deg,DE_a_amp,DE_a_phase_deg,DE_b_amp,DE_b_phase_deg"
        };
        assert_eq!(header, want);
        assert!(text.contains("# bearing 1: probes 1X at 45 deg, 1Y at -45 deg"));
        // The readings are the projections of the y, z file's phasors.
        let a = rotorid::io::measurement::read_csv(&yz).unwrap();
        let names = ["1X", "1Y", "DE_a", "DE_b"].map(String::from);
        let (b, _) = rotorid::io::measurement::read_csv_channels(&csv, Some(&names)).unwrap();
        let (s, t) = (&a.samples[123], &b.samples[123]);
        let r = |deg: f64, y: num_complex::Complex64, z: num_complex::Complex64| {
            y * deg.to_radians().cos() + z * deg.to_radians().sin()
        };
        for (got, want) in [
            (t.q[0], r(45.0, s.q[0], s.q[1])),
            (t.q[1], r(-45.0, s.q[0], s.q[1])),
            (t.q[2], r(30.0, s.q[2], s.q[3])),
            (t.q[3], r(100.0, s.q[2], s.q[3])),
        ] {
            assert!((got - want).norm() <= 1e-14 * want.norm(), "{got} {want}");
        }
        let probed = identify_json(model.to_str().unwrap(), &csv, &tmp("p.json"));
        let d = json_difference(&probed, &reference);
        eprintln!("{layout}: probe file vs y, z file, largest difference {d:.1e}");
        assert!(d < 1e-9, "{layout}: {d:e}");
    }
    // The model with probes still reads a SPEC y, z file, unchanged.
    let again = identify_json(model.to_str().unwrap(), &yz, &tmp("again.json"));
    assert_eq!(json_difference(&again, &reference), 0.0);
    // A file with other probe names is refused naming the expected column.
    let csv = tmp("probes-complex.csv");
    let text = std::fs::read_to_string(&csv)
        .unwrap()
        .replace("1Y_re,1Y_im", "1Z_re,1Z_im");
    let bad = tmp("bad.csv");
    std::fs::write(&bad, text).unwrap();
    let out = cli([
        "identify",
        "--model",
        model.to_str().unwrap(),
        "--measurements",
        bad.to_str().unwrap(),
    ]);
    assert_eq!(out.status, 2);
    assert!(
        out.stderr
            .contains("column 4 must be `1Y_re`, found `1Z_re`"),
        "{}",
        out.stderr
    );
    assert_eq!(out.stderr.trim_end().lines().count(), 1);
}
