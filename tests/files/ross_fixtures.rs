//! ROSS 3.1.0 fixtures (`tests/data/ross/`, written by ROSS's own
//! `Rotor.save`, with ROSS's results): every representable file loads and
//! agrees with ROSS, the others are refused in one line naming the element.
//!
//! Conventions (fixture README): ROSS's x, y, z are our y, z, x; phasors are
//! the same (`x(t) = Re{X e^(j w t)}`), so ROSS's `X`, `Y` at a node are our
//! `Y`, `Z`. ROSS is a 6-DOF model whose mode list mixes torsional and axial
//! modes between the lateral ones: modes are matched by type (lateral only)
//! and by the nearest eigenvalue, not by index.

use num_complex::Complex64;
use rotorid::fe::assembly::{Dir, FeModel};
use rotorid::fe::campbell::{diagram_with, Mode, ModeSelection, Whirl};
use rotorid::fe::response::{unbalance_response, Forcing};
use rotorid::io::model_file::{load_model, ModelFileError};
use rotorid::io::ross::RossError;
use rotorid::model::{RotorModel, Unbalance};
use serde_json::Value;
use std::path::PathBuf;

fn fixture(name: &str) -> PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/ross")
        .join(name)
}

fn results(name: &str) -> Value {
    let text = std::fs::read_to_string(fixture(&format!("{name}.results.json"))).unwrap();
    serde_json::from_str(&text).unwrap()
}

fn floats(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

fn strings(v: &Value) -> Vec<String> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_str().unwrap_or("None").to_string())
        .collect()
}

fn load(name: &str) -> RotorModel {
    load_model(fixture(&format!("{name}.toml")))
        .unwrap_or_else(|e| panic!("{name}.toml does not load: {e}"))
}

/// All our modes at `omega` (no cut-off).
fn modes(fe: &FeModel, omega: f64) -> Vec<Mode> {
    let opts = ModeSelection {
        max_frequency: None,
        max_modes: usize::MAX,
    };
    diagram_with(fe, &[omega], &opts)
        .unwrap()
        .points
        .pop()
        .unwrap()
        .modes
}

fn nearest(ours: &[Mode], lambda: Complex64) -> &Mode {
    ours.iter()
        .min_by(|a, b| {
            (a.eigenvalue - lambda)
                .norm()
                .total_cmp(&(b.eigenvalue - lambda).norm())
        })
        .unwrap()
}

/// Largest relative eigenvalue difference `|lambda - lambda_ross| /
/// |lambda_ross|` over ROSS's lateral modes at every modal speed, and the
/// largest log-decrement difference; whirl must agree for the forward and
/// backward modes at speed > 0 (ROSS's label at rest is decided by rounding).
fn modal_agreement(name: &str) -> (f64, f64) {
    modal_agreement_at(name, &load(name), &results(name)["modal"]["speeds"])
}

/// [`modal_agreement`] of `model` against ROSS's `speeds` list (`wn`,
/// `evalue_re`, ... per speed, as `make.py` writes them).
fn modal_agreement_at(name: &str, model: &RotorModel, speeds: &Value) -> (f64, f64) {
    let fe = FeModel::new(model).unwrap();
    let (mut worst, mut worst_dec) = (0.0f64, 0.0f64);
    for sp in speeds.as_array().unwrap() {
        let omega = sp["speed_rad_s"].as_f64().unwrap();
        let ours = modes(&fe, omega);
        let (re, im) = (floats(&sp["evalue_re"]), floats(&sp["evalue_im"]));
        let log_dec = floats(&sp["log_dec"]);
        let kind = strings(&sp["mode_type"]);
        let whirl = strings(&sp["whirl_direction"]);
        let mut used = Vec::new();
        for i in 0..re.len() {
            if kind[i] != "Lateral" {
                continue;
            }
            let lambda = Complex64::new(re[i], im[i]);
            let m = nearest(&ours, lambda);
            let idx = ours.iter().position(|x| std::ptr::eq(x, m)).unwrap();
            assert!(!used.contains(&idx), "{name}: two ROSS modes on one");
            used.push(idx);
            worst = worst.max((m.eigenvalue - lambda).norm() / lambda.norm());
            worst_dec = worst_dec.max((m.log_dec - log_dec[i]).abs());
            if omega > 0.0 {
                match whirl[i].as_str() {
                    "Forward" => assert_eq!(m.whirl, Whirl::Forward, "{name} {omega} mode {i}"),
                    "Backward" => {
                        assert_eq!(m.whirl, Whirl::Backward, "{name} {omega} mode {i}")
                    }
                    _ => {}
                }
            }
        }
        assert!(!used.is_empty());
    }
    (worst, worst_dec)
}

/// Largest relative difference of the unbalance responses at every ROSS
/// probe (bearing and disk nodes), relative to the probe's largest
/// amplitude over the sweep.
fn response_agreement(name: &str) -> f64 {
    let mut worst = 0.0f64;
    for p in response_pairs(name) {
        let scale = p.ross.iter().map(|v| v.norm()).fold(0.0, f64::max);
        for (a, b) in p.ours.iter().zip(&p.ross) {
            worst = worst.max((a.y - b.y).norm() / scale);
            worst = worst.max((a.z - b.z).norm() / scale);
        }
    }
    worst
}

/// The 1X response at one probe node and speed: our `Y`, `Z` (ROSS's
/// `X`, `Y`), m.
#[derive(Debug, Clone, Copy)]
struct Phasors {
    y: Complex64,
    z: Complex64,
}

impl Phasors {
    /// `sqrt(|Y|^2 + |Z|^2)`, m.
    fn norm(&self) -> f64 {
        self.y.norm().hypot(self.z.norm())
    }
}

/// Ours and ROSS's unbalance response at one ROSS probe node over the
/// fixture's speeds (`speeds`, rad/s).
struct ProbePair {
    node: usize,
    speeds: Vec<f64>,
    ours: Vec<Phasors>,
    ross: Vec<Phasors>,
}

/// Our unbalance response (the fixture's unbalance, ROSS's phase taken as
/// ours: both put the heavy spot at angle `phase` from ROSS x / our y
/// towards ROSS y / our z at t = 0) next to ROSS's at every probe of the
/// results file.
fn response_pairs(name: &str) -> Vec<ProbePair> {
    let model = load(name);
    let fe = FeModel::new(&model).unwrap();
    let r = &results(name)["unbalance_response"];
    let unbalance: Vec<Unbalance> = r["unbalance"]
        .as_array()
        .unwrap()
        .iter()
        .map(|u| Unbalance {
            node: u["node"].as_u64().unwrap() as usize,
            me: u["magnitude_kg_m"].as_f64().unwrap(),
            phase: u["phase_rad"].as_f64().unwrap(),
        })
        .collect();
    let speeds = floats(&r["speed_rad_s"]);
    // ROSS point-mass nodes (beyond the shaft) are our pedestal DOFs: the
    // point mass `p` is under the bearing whose `n_link` is `p`.
    let ross_file: toml::Value =
        toml::from_str(&std::fs::read_to_string(fixture(&format!("{name}.toml"))).unwrap())
            .unwrap();
    let linked_bearing = |p: usize| -> usize {
        let shaft_node = ross_file
            .as_table()
            .unwrap()
            .values()
            .find(|v| v.get("n_link").and_then(|x| x.as_integer()) == Some(p as i64))
            .and_then(|v| v.get("n")?.as_integer())
            .unwrap() as usize;
        model
            .bearings
            .iter()
            .position(|b| b.node == shaft_node)
            .unwrap()
    };
    let dofs = |node: usize| -> (usize, usize) {
        if node < fe.n_nodes() {
            (fe.dof(node, Dir::Y), fe.dof(node, Dir::Z))
        } else {
            let b = linked_bearing(node);
            (
                fe.pedestal_dof(b, Dir::Y).unwrap(),
                fe.pedestal_dof(b, Dir::Z).unwrap(),
            )
        }
    };
    let forcing = Forcing {
        unbalance,
        bow: None,
    };
    let resp = unbalance_response(&fe, &forcing, &speeds).unwrap();
    let complex = |p: &Value, axis: &str| -> Vec<Complex64> {
        floats(&p[format!("{axis}_re")])
            .into_iter()
            .zip(floats(&p[format!("{axis}_im")]))
            .map(|(a, b)| Complex64::new(a, b))
            .collect()
    };
    r["probes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| {
            let node = p["node"].as_u64().unwrap() as usize;
            let (x, y) = (complex(p, "x"), complex(p, "y"));
            let (dy, dz) = dofs(node);
            ProbePair {
                node,
                speeds: speeds.clone(),
                ours: resp
                    .iter()
                    .map(|q| Phasors {
                        y: q.q[dy],
                        z: q.q[dz],
                    })
                    .collect(),
                ross: x
                    .into_iter()
                    .zip(y)
                    .map(|(y, z)| Phasors { y, z })
                    .collect(),
            }
        })
        .collect()
}

/// Our critical speed of the lateral mode ROSS found at `c` (fixed point
/// `w_d(Omega) = Omega`, the mode followed by its eigenvalue), by secant
/// iteration to 1e-12 relative.
fn our_critical_speed(fe: &FeModel, c: f64, lambda0: Complex64) -> f64 {
    let mut lambda = lambda0;
    let mut g = |s: f64| {
        let ours = modes(fe, s);
        let m = nearest(&ours, lambda);
        lambda = m.eigenvalue;
        m.frequency - s
    };
    let (mut s0, mut s1) = (c, c * 1.001);
    let (mut g0, mut g1) = (g(s0), g(s1));
    for _ in 0..30 {
        if (s1 - s0).abs() <= 1e-12 * s1 || g1 == g0 {
            break;
        }
        let s2 = s1 - g1 * (s1 - s0) / (g1 - g0);
        (s0, g0) = (s1, g1);
        s1 = s2;
        g1 = g(s1);
    }
    s1
}

/// Largest relative difference between ROSS's lateral critical speeds
/// (`wd` list of `run_critical_speed`) and ours.
fn critical_agreement(name: &str) -> f64 {
    let fe = FeModel::new(&load(name)).unwrap();
    let cs = &results(name)["critical_speeds"];
    let (wd, kind) = (floats(&cs["wd"]), strings(&cs["mode_type"]));
    let log_dec = floats(&cs["log_dec"]);
    let mut worst = 0.0f64;
    for i in 0..wd.len() {
        if kind[i] != "Lateral" {
            continue;
        }
        // Eigenvalue guess from ROSS's damped frequency and log decrement.
        let sigma = -log_dec[i] * wd[i] / (2.0 * std::f64::consts::PI);
        let ours = our_critical_speed(&fe, wd[i], Complex64::new(sigma, wd[i]));
        worst = worst.max((ours - wd[i]).abs() / wd[i]);
    }
    worst
}

/// Constant-coefficient rotors: eigenvalues and responses to 1e-9
/// relative (measured: eigenvalues up to 4e-10, ROSS's ARPACK tolerance;
/// responses up to 3e-11), log decrements to 1e-9 absolute.
#[test]
fn constant_coefficient_fixtures_agree_with_ross() {
    for name in [
        "rotor_example",
        "stepped_hollow",
        "coaxial_sleeve",
        "support_masses",
    ] {
        let (ev, dec) = modal_agreement(name);
        let resp = response_agreement(name);
        eprintln!("{name}: eigenvalues {ev:.1e}, log_dec {dec:.1e}, response {resp:.1e}");
        assert!(ev < 1e-9, "{name}: eigenvalues differ by {ev:e}");
        assert!(dec < 1e-9, "{name}: log decrements differ by {dec:e}");
        assert!(resp < 1e-9, "{name}: responses differ by {resp:e}");
    }
}

/// ROSS's critical speeds are Newton iterates converged to its `rtol =
/// 0.005`; ours are converged fixed points: they agree within that rtol.
#[test]
fn critical_speeds_agree_with_ross_to_its_tolerance() {
    for name in [
        "rotor_example",
        "stepped_hollow",
        "bearing_tables",
        "support_masses",
    ] {
        let d = critical_agreement(name);
        eprintln!("{name}: critical speeds {d:.1e}");
        assert!(d < 5e-3, "{name}: critical speeds differ by {d:e}");
    }
}

/// Rotor-level proportional damping (`alpha`, `beta`): responses as ROSS's
/// to 1e-9 (measured ~4e-11); eigenvalues to 1e-7 relative (measured
/// ~2e-8) and log decrements to 1e-7 absolute. The `beta K` damping makes
/// the high modes heavily damped and the eigenproblem less well
/// conditioned: ROSS's own dense and ARPACK eigenvalues of this rotor
/// differ by up to 2e-9, and both solvers here work on a state matrix
/// whose damping block grows with `beta K / M`.
#[test]
fn proportional_damping_agrees_with_ross() {
    let name = "rotor_example_with_damping";
    let m = load(name);
    assert_eq!(m.rotor_damping.alpha, 8.0501);
    assert_eq!(m.rotor_damping.beta, 1e-5);
    let (ev, dec) = modal_agreement(name);
    let resp = response_agreement(name);
    eprintln!("{name}: eigenvalues {ev:.1e}, log_dec {dec:.1e}, response {resp:.1e}");
    assert!(ev < 1e-7, "eigenvalues differ by {ev:e}");
    assert!(dec < 1e-7, "log decrements differ by {dec:e}");
    assert!(resp < 1e-9, "responses differ by {resp:e}");
    // The identification cannot include it: refused, not dropped.
    let fe = FeModel::new(&m).unwrap();
    let e = rotorid::reduce::Reducer::new(&fe, &m)
        .unwrap_err()
        .to_string();
    assert!(e.contains("proportional damping"), "{e}");
}

/// Speed tables interpolated with PCHIP and extrapolated with the end
/// slopes: the coefficients equal ROSS's own evaluation below, inside and
/// above the table (1e-12 relative to the coefficient's table scale), so
/// eigenvalues and responses agree as for constant bearings.
#[test]
fn bearing_tables_agree_with_ross_between_and_beyond_the_points() {
    let name = "bearing_tables";
    let m = load(name);
    let r = results(name);
    let keys_k = ["kxx", "kxy", "kyx", "kyy"];
    let keys_c = ["cxx", "cxy", "cyx", "cyy"];
    let mut worst = 0.0f64;
    for b in r["bearing_coefficients"].as_array().unwrap() {
        let node = b["n"].as_u64().unwrap() as usize;
        let law = &m.bearings.iter().find(|x| x.node == node).unwrap().law;
        let at = floats(&b["at_rad_s"]);
        let table = floats(&b["table_axis_rad_s"]);
        assert!(at.iter().any(|w| *w < table[0]) && at.iter().any(|w| *w > table[4]));
        for j in 0..4 {
            for (key, ours_of) in [(keys_k[j], true), (keys_c[j], false)] {
                let ross = floats(&b[key]);
                let scale = ross.iter().map(|v| v.abs()).fold(0.0, f64::max);
                for (w, v) in at.iter().zip(&ross) {
                    let c = law.at(*w);
                    let ours = if ours_of { c.k[j] } else { c.c[j] };
                    worst = worst.max((ours - v).abs() / scale);
                }
            }
        }
    }
    let (ev, dec) = modal_agreement(name);
    let resp = response_agreement(name);
    eprintln!(
        "{name}: coefficients {worst:.1e}, eigenvalues {ev:.1e}, log_dec {dec:.1e}, response {resp:.1e}"
    );
    assert!(worst < 1e-12, "coefficients differ by {worst:e}");
    assert!(ev < 1e-9, "eigenvalues differ by {ev:e}");
    assert!(dec < 1e-9, "log decrements differ by {dec:e}");
    assert!(resp < 1e-9, "responses differ by {resp:e}");
}

fn refused(file: &str) -> String {
    let e = load_model(fixture(file)).unwrap_err();
    let ModelFileError::Ross(r @ RossError::Unsupported { .. }) = &e else {
        panic!("{file}: {e}")
    };
    let s = r.to_string();
    assert!(!s.contains('\n'), "{s}");
    s
}

#[test]
fn refused_fixtures_say_why_in_one_line() {
    let mag = refused("refused_magnetic_bearing.toml");
    assert!(
        mag.starts_with("BearingElement_Magnetic Bearing 0: ")
            && mag.contains("magnetic bearings are not supported"),
        "{mag}"
    );
    let seal = refused("refused_seal.toml");
    assert!(seal.starts_with("SealElement_"), "{seal}");
    assert!(seal.contains("seal"), "{seal}");
    let tapered = refused("refused_tapered_shaft.toml");
    assert!(tapered.contains("tapered"), "{tapered}");
}

/// A file ROSS writes for one element (`BearingElement.save`, as the
/// ROSS wheel's `tests/data/v2/bearing.toml`) is told from a rotor file:
/// the error names the element's table and says which file to give.
#[test]
fn a_ross_element_file_is_not_taken_for_a_rotor() {
    let path = crate::common::tmp("ross_element.toml");
    std::fs::write(
        &path,
        "[BearingElement_brg]\ncolor = \"#355d7a\"\ncxx = [ 1000.0, 1200.0,]\n\
         frequency = [ 100.0, 200.0,]\nkxx = [ 1000000.0, 1100000.0,]\nn = 0\n\
         scale_factor = 1\ntag = \"brg\"\n",
    )
    .unwrap();
    let e = load_model(&path).unwrap_err();
    assert!(
        matches!(&e, ModelFileError::RossElement(t) if t == "BearingElement_brg"),
        "{e}"
    );
    assert!(e.to_string().contains("Rotor.save"), "{e}");
    // A rotorid model file whose first table happens to be a bearing is
    // still read as one.
    let own = rotorid::io::model_file::ross_element_file("[[bearing]]\nnode = 1\n");
    assert_eq!(own, None);
}

/// The pedestal pattern of `support_masses` (bearing -> `PointMass` by
/// `n_link`, point mass -> ground): point mass 7 with `mx = 15`, `my = 20`
/// kg is a pedestal with masses [15, 20] in our y, z (point mass 8, `m =
/// 18`, [18, 18]); the supports' kxx, kyy and cxx, cyy are its stiffness
/// and damping. Eigenvalues, log decrements and responses (shaft and
/// point-mass nodes) are checked in `constant_coefficient_fixtures_agree_with_ross`.
#[test]
fn support_masses_become_pedestals_with_a_mass_per_direction() {
    let m = load("support_masses");
    let p: Vec<_> = m.bearings.iter().map(|b| (b.node, b.pedestal)).collect();
    assert_eq!(
        p,
        [
            (
                0,
                Some(rotorid::model::Pedestal {
                    mass: [15.0, 20.0],
                    k: [2.0e6, 3.0e6],
                    c: [2000.0, 2500.0]
                })
            ),
            (
                6,
                Some(rotorid::model::Pedestal {
                    mass: [18.0, 18.0],
                    k: [2.2e6, 3.3e6],
                    c: [2100.0, 2600.0]
                })
            ),
        ]
    );
}

/// What rotorid writes back in ROSS format reads back to the same model,
/// layers, PCHIP tables and rotor damping included.
#[test]
fn ross_writer_round_trips_the_fixtures() {
    for name in [
        "rotor_example",
        "rotor_example_with_damping",
        "stepped_hollow",
        "coaxial_sleeve",
        "bearing_tables",
        "support_masses",
    ] {
        let m = load(name);
        let text = rotorid::io::ross::to_ross_toml(&m).unwrap();
        let back = rotorid::io::ross::parse_ross(&text).unwrap();
        assert_eq!(back.shaft, m.shaft, "{name}");
        assert_eq!(back.shaft_layers, m.shaft_layers, "{name}");
        assert_eq!(back.disks, m.disks, "{name}");
        assert_eq!(back.bearings, m.bearings, "{name}");
        assert_eq!(back.rotor_damping, m.rotor_damping, "{name}");
    }
}

/// A file written by `rotorid identify --ross-out` (physical order 2 from
/// the paper rotor's sweep with 1 % noise, seed 1: bearings as 31-point
/// PCHIP tables over 50..15000 rpm) loads in ROSS 3.1.0 without a warning,
/// and ROSS's eigenvalues of it at 0..6000 rpm (0 rpm: below the table,
/// extrapolated with the end slopes by both) are ours to 1e-9 relative,
/// log decrements to 1e-9 (`paper_identified.check.json`, from `make.py
/// --check-export`).
#[test]
fn identify_export_agrees_with_ross() {
    let name = "paper_identified";
    let model = load(name);
    for b in &model.bearings {
        let rotorid::model::BearingLaw::Table { speeds, .. } = &b.law else {
            panic!("table expected: {:?}", b.law)
        };
        assert_eq!(speeds.len(), rotorid::io::ross::ROSS_TABLE_POINTS);
    }
    let text = std::fs::read_to_string(fixture(&format!("{name}.check.json"))).unwrap();
    let check: Value = serde_json::from_str(&text).unwrap();
    assert_eq!(check["loads"], true);
    assert_eq!(check["load_warnings"].as_array().unwrap().len(), 0);
    let (ev, dec) = modal_agreement_at(name, &model, &check["modal"]);
    eprintln!("{name}: eigenvalues {ev:.1e}, log_dec {dec:.1e}");
    assert!(ev < 1e-9, "eigenvalues differ by {ev:e}");
    assert!(dec < 1e-9, "log decrements differ by {dec:e}");
}

/// ROSS's lateral critical speeds (rad/s) of `key` (`wd` or `wn`) in the
/// list `list` of a results file, with ROSS's whirl.
pub(crate) fn ross_lateral_criticals(r: &Value, list: &str, key: &str) -> Vec<(f64, String)> {
    let cs = &r[list];
    let kind = strings(&cs["mode_type"]);
    let whirl = strings(&cs["whirl_direction"]);
    floats(&cs[key])
        .into_iter()
        .enumerate()
        .filter(|(i, _)| kind[*i] == "Lateral")
        .map(|(i, w)| (w, whirl[i].clone()))
        .collect()
}

/// Fraction of a critical speed within which a response speed counts as
/// near it: the response there is compared only to the probe's largest
/// amplitude, not pointwise.
const NEAR_CRITICAL: f64 = 0.05;

/// ROSS's compressor example (`ross/data/compressor_example.toml`, shipped
/// in the ROSS wheel) with its 12 seals removed, as ROSS 3.1.0 saves it
/// (`compressor_no_seals.toml`): 55 shaft elements with 36 coaxial
/// layers (some of a mass-only material, E = G = 6894.75 Pa), 7 disks, 2
/// bearings on 8-point speed tables over 4000..11000 rpm (PCHIP, linear
/// extrapolation beyond: the sweep runs from 100 to 23145 rpm). Unbalance:
/// balance grade G2.5 at 11000 rpm of ROSS's rotor mass (246.9 kg), 2/3 on
/// the first impeller (phase 0), 1/3 on the last (phase pi/2).
///
/// At every response speed more than 5 % from every lateral critical
/// speed ROSS lists (damped `wd` and undamped `wn`, converged with
/// `rtol = 1e-8`), our phasors at each of the 9 probe nodes (2 bearings, 7
/// disks) equal ROSS's to 1e-6 relative, pointwise:
/// `sqrt(|dY|^2 + |dZ|^2) / sqrt(|Y|^2 + |Z|^2)`. Near the critical speeds
/// they agree to 1e-6 of the probe's largest amplitude over the sweep.
#[test]
fn compressor_without_seals_responds_as_ross_away_from_critical_speeds() {
    let name = "compressor_no_seals";
    let model = load(name);
    let r = results(name);
    // What was read: the shaft, its layers, the disks and the two tables.
    assert_eq!(model.shaft.len(), 55);
    assert_eq!(model.shaft.len() + model.shaft_layers.len(), 91);
    assert_eq!(model.disks.len(), 7);
    assert_eq!(model.bearing_nodes(), [7, 48]);
    for b in &model.bearings {
        let rotorid::model::BearingLaw::Table {
            speeds,
            interpolation,
            ..
        } = &b.law
        else {
            panic!("table expected: {:?}", b.law)
        };
        assert_eq!(speeds.len(), 8);
        assert_eq!(*interpolation, rotorid::model::TableInterpolation::Pchip);
    }
    // Balance grade G2.5 at 11000 rpm: sum m e = G / Omega * mass.
    let mass = r["rotor"]["mass_kg"].as_f64().unwrap();
    let omega_service = 11000.0 * std::f64::consts::PI / 30.0;
    let total: f64 = r["unbalance_response"]["unbalance"]
        .as_array()
        .unwrap()
        .iter()
        .map(|u| u["magnitude_kg_m"].as_f64().unwrap())
        .sum();
    assert!((total - 2.5e-3 / omega_service * mass).abs() < 1e-12 * total);

    let criticals: Vec<f64> = ["wd", "wn"]
        .iter()
        .flat_map(|k| ross_lateral_criticals(&r, "critical_speeds_tight", k))
        .map(|c| c.0)
        .collect();
    assert_eq!(criticals.len(), 12);
    let near = |w: f64| criticals.iter().any(|c| (w - c).abs() <= NEAR_CRITICAL * c);
    let pairs = response_pairs(name);
    assert_eq!(pairs.len(), 9);
    let (mut away, mut near_crit, mut n_away) = (0.0f64, 0.0f64, 0usize);
    let mut worst_at = (0, 0.0);
    for p in &pairs {
        let scale = p.ross.iter().map(|v| v.norm()).fold(0.0, f64::max);
        for ((w, a), b) in p.speeds.iter().zip(&p.ours).zip(&p.ross) {
            let d = Phasors {
                y: a.y - b.y,
                z: a.z - b.z,
            };
            if near(*w) {
                near_crit = near_crit.max(d.norm() / scale);
            } else {
                n_away += 1;
                let rel = d.norm() / b.norm();
                if rel > away {
                    away = rel;
                    worst_at = (p.node, w * 30.0 / std::f64::consts::PI);
                }
            }
        }
    }
    eprintln!(
        "{name}: response {away:.1e} pointwise at {n_away} probe-speeds away from the critical \
         speeds (worst at node {} {:.0} rpm), {near_crit:.1e} of the probe maximum near them",
        worst_at.0, worst_at.1
    );
    assert!(n_away >= 9 * 40, "{n_away}");
    assert!(
        away < 1e-6,
        "responses differ by {away:e} away from the critical speeds"
    );
    assert!(
        near_crit < 1e-6,
        "responses differ by {near_crit:e} near the critical speeds"
    );
}

/// The compressor's critical speeds by the Campbell analysis's own steps
/// (`diagram_with` with the `campbell` command's 12 modes per speed,
/// `track_modes`, `critical_speeds`: crossings refined between the
/// diagram speeds to 1e-10) are ROSS's (`run_critical_speed(rtol=1e-8)`,
/// damped `wd` and undamped `wn`, all 12 lateral ones) within 0.1 %, with
/// ROSS's whirl. The diagram covers two windows, 5800..6600 rpm and
/// 17500..22500 rpm (step 2500), which bracket ROSS's two groups
/// of critical speeds (each eigen-solve of this 224-DOF rotor takes
/// ~0.7 s; the whole diagram from 0 rpm would take ~18 s).
/// Also the eigenvalues at 0, 4000, 8000 and 11000 rpm (below, at the
/// ends of and inside the bearing tables) are ROSS's `run_modal` ones
/// (measured 7.8e-9 relative: ARPACK).
#[test]
fn compressor_without_seals_critical_speeds_match_ross() {
    use rotorid::fe::campbell::{critical_speeds, track_modes, CriticalSpeed, Crossing};
    let name = "compressor_no_seals";
    let fe = FeModel::new(&load(name)).unwrap();
    let r = results(name);
    let rpm = std::f64::consts::PI / 30.0;
    let selection = ModeSelection {
        max_frequency: None,
        max_modes: 12,
    };
    let mut ours: [Vec<CriticalSpeed>; 2] = [Vec::new(), Vec::new()];
    for window in [[5800.0, 6600.0].as_slice(), &[17500.0, 20000.0, 22500.0]] {
        let speeds: Vec<f64> = window.iter().map(|w| w * rpm).collect();
        let d = diagram_with(&fe, &speeds, &selection).unwrap();
        let tracks = track_modes(&d);
        for (k, crossing) in [Crossing::Damped, Crossing::Undamped]
            .into_iter()
            .enumerate()
        {
            ours[k].extend(critical_speeds(&fe, &d, &tracks, crossing).unwrap());
        }
    }
    let mut worst = 0.0f64;
    for (key, ours) in [("wd", &ours[0]), ("wn", &ours[1])] {
        for (c, whirl) in ross_lateral_criticals(&r, "critical_speeds_tight", key) {
            let m = ours
                .iter()
                .min_by(|p, q| (p.omega - c).abs().total_cmp(&(q.omega - c).abs()))
                .unwrap();
            let rel = (m.omega - c).abs() / c;
            eprintln!(
                "{name} {key}: ROSS {:9.2} rpm {whirl:>8}, ours {:9.2} rpm {:?}, rel {rel:.1e}",
                c / rpm,
                m.omega / rpm,
                m.whirl
            );
            worst = worst.max(rel);
            match whirl.as_str() {
                "Forward" => assert_eq!(m.whirl, Whirl::Forward, "{key} {c}"),
                "Backward" => assert_eq!(m.whirl, Whirl::Backward, "{key} {c}"),
                _ => {}
            }
        }
    }
    let (ev, dec) = modal_agreement(name);
    eprintln!("{name}: critical speeds {worst:.1e}, eigenvalues {ev:.1e}, log_dec {dec:.1e}");
    assert!(worst < 1e-3, "critical speeds differ by {worst:e}");
    assert!(ev < 1e-7, "eigenvalues differ by {ev:e}");
}
