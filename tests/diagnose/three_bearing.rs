//! A rotor on three bearings (`tests/data/rotors/three_bearing.toml`: a
//! stepped shaft 2 m long, bearings at nodes 1, 21 and 33, an overhung
//! disk at node 41; criticals near 3600, 8000 and 12000 rpm) end to end,
//! on realistic data (balance grade G6.3 at 12000 rpm, 0.5 % + 0.5 um
//! probe floor, 300 speeds 40..12000 rpm):
//!
//! - through the binary: `simulate`, `identify` (with `--ross-out`, the
//!   ROSS file read back), `diagnose` (nothing to name), `campbell`;
//! - a bow measured from the bearing line (zero at all three bearings,
//!   two knots in the second span, not the hypothesis's one-knot shape),
//!   with a mid-span probe: named `shaft_bow` from the bearing line;
//! - runout on the mid-span probe as well as on the bearing probes: named
//!   `probe_runout`, the mid-span probe's runout within 3 standard
//!   deviations.
//!
//! The last two are `#[ignore]`d (about 10 s each):
//! `cargo test --release --test lib diagnose::three_bearing -- --ignored --nocapture`.

use std::path::PathBuf;

use rotorid::diagnose::{diagnose, DiagnoseOptions, Effect, Finding};
use rotorid::io::model_file::model_file_by_name_or_path;
use rotorid::model::extension::{Effects, Runout};
use rotorid::model::{BowPoint, RotorModel};
use rotorid::simulate::{
    add_floor_noise, add_floor_noise_nodes, at_balance_grade, simulate_at_nodes, SimOptions,
};
use rotorid::units::rpm_to_rad_s;

use crate::common::{cli, tmp};

const NOISE: f64 = 0.005;
const FLOOR: f64 = 0.5e-6;
const RPM_MAX: f64 = 12000.0;

fn path() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/rotors/three_bearing.toml")
}

fn model() -> RotorModel {
    let m = model_file_by_name_or_path(path().to_str().unwrap())
        .unwrap()
        .model;
    at_balance_grade(&m, 6.3, rpm_to_rad_s(RPM_MAX)).unwrap()
}

fn speeds() -> Vec<f64> {
    (1..=300).map(|i| 40.0 * i as f64).collect()
}

/// `simulate`, `identify --json --ross-out`, `diagnose --json`,
/// `campbell --plot` on the three-bearing rotor: the identified direct
/// stiffnesses within 4 standard deviations of the model's, nothing
/// named, the ROSS file read back with the identified bearings.
#[test]
fn end_to_end_through_the_binary() {
    let model_path = path();
    let model_arg = model_path.to_str().unwrap();
    let csv = tmp("three.csv");
    let out = cli([
        "simulate",
        "--model",
        model_arg,
        "--out",
        csv.to_str().unwrap(),
        "--rpm-min",
        "40",
        "--rpm-max",
        "12000",
        "--rpm-step",
        "40",
        "--balance-grade",
        "6.3",
        "--noise",
        "0.005",
        "--noise-floor",
        "5e-7",
        "--seed",
        "4",
    ]);
    assert!(out.success(), "{}", out.stderr);
    let json = tmp("three-identify.json");
    let ross = tmp("three-ross.toml");
    let out = cli([
        "identify",
        "--model",
        model_arg,
        "--measurements",
        csv.to_str().unwrap(),
        "--json",
        json.to_str().unwrap(),
        "--ross-out",
        ross.to_str().unwrap(),
    ]);
    assert!(out.success(), "{}", out.stderr);
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let bearings = v["bearings"].as_array().unwrap();
    assert_eq!(bearings.len(), 3);
    let truth = model();
    for (b, t) in bearings.iter().zip(&truth.bearings) {
        let co = t.law.at(rpm_to_rad_s(RPM_MAX));
        for (key, want) in [("yy", co.k[0]), ("zz", co.k[3])] {
            let k = b["k"][key].as_f64().unwrap();
            let sd = b["std"]["k"][key].as_f64().unwrap();
            assert!(
                (k - want).abs() <= 4.0 * sd && sd <= 0.05 * want,
                "node {}: k_{key} {k} +- {sd} vs {want}",
                b["node"]
            );
        }
    }
    // The ROSS file: rotorid reads it back with the identified bearings.
    let back = model_file_by_name_or_path(ross.to_str().unwrap())
        .unwrap()
        .model;
    assert_eq!(back.bearings.len(), 3);
    for (b, j) in back.bearings.iter().zip(bearings) {
        let co = b.law.at(rpm_to_rad_s(RPM_MAX));
        let k = j["k"]["yy"].as_f64().unwrap();
        assert!((co.k[0] - k).abs() <= 1e-6 * k, "{} vs {k}", co.k[0]);
    }
    assert_eq!(back.n_nodes(), truth.n_nodes());
    let djson = tmp("three-diagnose.json");
    let out = cli([
        "diagnose",
        "--model",
        model_arg,
        "--measurements",
        csv.to_str().unwrap(),
        "--json",
        djson.to_str().unwrap(),
    ]);
    assert!(out.success(), "{}", out.stderr);
    let d: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&djson).unwrap()).unwrap();
    assert_eq!(d["effect"], "none", "{}", out.stdout);
    let svg = tmp("three-campbell.svg");
    let out = cli([
        "campbell",
        "--model",
        model_arg,
        "--rpm-max",
        "12000",
        "--plot",
        svg.to_str().unwrap(),
    ]);
    assert!(out.success(), "{}", out.stderr);
    assert!(std::fs::metadata(&svg).unwrap().len() > 1000);
}

/// The three-bearing rotor simulated with `effects`, a probe at node 27
/// (0-based 26, mid-span of the second span) with `node_runout` (m)
/// added to its readings, realistic noise.
fn case(
    effects: Effects,
    node_runout: [num_complex::Complex64; 2],
    seed: u64,
) -> rotorid::diagnose::Diagnosis {
    let m = model();
    let opts = SimOptions {
        speeds_rpm: speeds(),
        noise: NOISE,
        seed,
        effects,
    };
    let (mut meas, mut node_q) = simulate_at_nodes(&m, &opts, &[26]).unwrap();
    for q in &mut node_q {
        q[0] += node_runout[0];
        q[1] += node_runout[1];
    }
    add_floor_noise(&mut meas, FLOOR, seed).unwrap();
    add_floor_noise_nodes(&mut node_q, FLOOR, seed).unwrap();
    meas.node_probes = vec![26];
    meas.node_q = node_q;
    let d = diagnose(&m, &meas, &DiagnoseOptions::default()).unwrap();
    for h in &d.hypotheses {
        println!(
            "    {:<55} statistic {:10.1} threshold {:5.1}",
            h.label, h.statistic, h.threshold
        );
    }
    println!(
        "named {} ({}), nominal {:.2e}, extended {:.2e}",
        d.effect.name(),
        d.extended().label,
        d.residual_nominal(),
        d.residual_extended()
    );
    d
}

/// A bow from the bearing line in the second span with two knots (node
/// 25 at 12 um, node 27 at 15 um, 0.3 rad apart), zero at the three
/// bearings and straight in the overhang: the natural spline through these
/// knots continued as a line, which is the simulator's spline through them
/// and the continuation's value at the shaft's last node (the natural
/// interpolating spline is unique).
fn two_knot_bow(m: &RotorModel) -> Vec<BowPoint> {
    use rotorid::fe::assembly::{Dir, FeModel};
    let fe = FeModel::new(m).unwrap();
    let knots = [
        (24, num_complex::Complex64::from_polar(12e-6, 0.8)),
        (26, num_complex::Complex64::from_polar(15e-6, 1.1)),
    ];
    let last = m.n_nodes() - 1;
    let mut end = num_complex::Complex64::new(0.0, 0.0);
    for (i, &(n, c)) in knots.iter().enumerate() {
        // The shape of a unit offset at `n`, zero at the bearings and at
        // the other knot: the natural spline is linear in its knot values.
        let other = knots[1 - i].0;
        let shape = fe.line_bow_shape(n, &[0, 20, other, 32]).unwrap();
        end += c * shape[fe.dof(last, Dir::Y)];
    }
    let mut points = vec![BowPoint {
        node: 20,
        amplitude: 0.0,
        phase: 0.0,
    }];
    points.extend(knots.iter().map(|&(node, c)| BowPoint {
        node,
        amplitude: c.norm(),
        phase: c.arg(),
    }));
    points.push(BowPoint {
        node: 32,
        amplitude: 0.0,
        phase: 0.0,
    });
    points.push(BowPoint {
        node: last,
        amplitude: end.norm(),
        phase: end.arg(),
    });
    points
}

#[test]
#[ignore = "about 10 s: cargo test --release --test lib diagnose::three_bearing -- --ignored"]
fn bow_from_the_bearing_line_with_a_mid_span_probe() {
    let effects = Effects {
        bow: two_knot_bow(&model()),
        ..Effects::default()
    };
    let zero = num_complex::Complex64::new(0.0, 0.0);
    let d = case(effects, [zero, zero], 21);
    assert_eq!(d.effect, Effect::ShaftBow);
    let found = d.findings().into_iter().find_map(|f| match f {
        Finding::ShaftBow {
            node,
            amplitude,
            amplitude_std,
            reference,
            ..
        } => Some((node, amplitude, amplitude_std, reference)),
        _ => None,
    });
    let (node, a, sd, reference) = found.unwrap();
    println!("bow at node {node} from the {reference}: {a:.3e} +- {sd:.1e} m");
    assert_eq!(reference, "bearing line");
    assert!((25..=27).contains(&node), "node {node}");
    // The one-knot shape's offset lies between the two knots' 12 and 15 um.
    assert!((10e-6..=17e-6).contains(&a), "amplitude {a}");
}

#[test]
#[ignore = "about 10 s: cargo test --release --test lib diagnose::three_bearing -- --ignored"]
fn runout_on_a_mid_span_probe() {
    let runout: Vec<Runout> = rotorid::simulate::random_runout(3, 4e-6, 9);
    let effects = Effects {
        runout,
        ..Effects::default()
    };
    let r = [
        num_complex::Complex64::from_polar(5e-6, 2.0),
        num_complex::Complex64::from_polar(5e-6, -0.5),
    ];
    let d = case(effects, r, 22);
    assert_eq!(d.effect, Effect::ProbeRunout);
    let channels = d
        .findings()
        .into_iter()
        .find_map(|f| match f {
            Finding::ProbeRunout { channels } => Some(channels),
            _ => None,
        })
        .unwrap();
    assert_eq!(channels.len(), 8);
    for (c, want) in channels[6..].iter().zip(r) {
        let got = num_complex::Complex64::from_polar(c.amplitude, c.phase_deg.to_radians());
        println!(
            "{}: {got} vs {want} (std {:.1e})",
            c.channel, c.amplitude_std
        );
        assert!(c.channel.starts_with("n27_"));
        assert!(
            (got - want).norm() <= 3.0 * c.amplitude_std.max(1e-9) * std::f64::consts::SQRT_2,
            "{}: {got} vs {want}",
            c.channel
        );
    }
}
