//! `rotorid campbell`: critical speeds of every whirl against ROSS 3.1.0's
//! `run_critical_speed` on the fixtures of `tests/data/ross`, independent
//! of `--rpm-step`; the JSON and CSV outputs; the diagram.

use crate::common::{cli, tmp, Output};
use serde_json::Value;
use std::path::PathBuf;

fn fixture(name: &str) -> PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/ross")
        .join(name)
}

fn floats(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

/// ROSS's lateral critical speeds (rpm) of `key` (`wd` or `wn`) with their
/// whirl.
fn ross_criticals(name: &str, key: &str) -> Vec<(f64, String)> {
    let text = std::fs::read_to_string(fixture(&format!("{name}.results.json"))).unwrap();
    let r: Value = serde_json::from_str(&text).unwrap();
    crate::files::ross_fixtures::ross_lateral_criticals(&r, "critical_speeds", key)
        .into_iter()
        .map(|(w, whirl)| (w * 30.0 / std::f64::consts::PI, whirl))
        .collect()
}

/// Runs `campbell --json` (and `--plot` when given) and returns the JSON.
fn campbell_json(model: &str, rpm_max: f64, step: f64, tag: &str, plot: Option<&str>) -> Value {
    let j = tmp(&format!("campbell-{tag}.json"));
    let plot_args = plot.map(|p| vec!["--plot".to_string(), p.to_string()]);
    let Output { status, stderr, .. } = cli([
        "campbell",
        "--model",
        model,
        "--rpm-max",
        &rpm_max.to_string()[..],
        "--rpm-step",
        &step.to_string()[..],
        "--json",
        j.to_str().unwrap(),
    ]
    .into_iter()
    .map(String::from)
    .chain(plot_args.into_iter().flatten()));
    assert_eq!(status, 0, "{model} step {step}: {stderr}");
    serde_json::from_str(&std::fs::read_to_string(&j).unwrap()).unwrap()
}

/// `(rpm, whirl)` of a critical-speed list of the JSON.
fn ours(j: &Value, key: &str) -> Vec<(f64, String)> {
    j[key]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| {
            (
                c["rpm"].as_f64().unwrap(),
                c["whirl"].as_str().unwrap().to_string(),
            )
        })
        .collect()
}

/// Every lateral critical speed ROSS lists (damped `wd` and undamped
/// `wn`, forward, backward and mixed) is one of ours within 0.1 %, at
/// `--rpm-step` 100 and 1000, and the two steps give the same speeds (to
/// 1e-7 relative: the refinement, not the grid, sets them). ROSS converges
/// its Newton iteration only to `rtol = 0.005`; the measured agreement is
/// far better (printed). Where ROSS says forward or backward, so do we.
/// `support_masses` has pedestals (ROSS point masses, one with mx != my),
/// whose modes are among those checked.
#[test]
fn critical_speeds_of_every_whirl_match_ross_at_any_step() {
    for name in [
        "rotor_example",
        "rotor_example_with_damping",
        "stepped_hollow",
        "bearing_tables",
        "coaxial_sleeve",
        "support_masses",
    ] {
        let model = fixture(&format!("{name}.toml"));
        let model = model.to_str().unwrap();
        let wd = ross_criticals(name, "wd");
        let wn = ross_criticals(name, "wn");
        let top = wd.iter().chain(&wn).map(|c| c.0).fold(0.0, f64::max);
        let rpm_max = (1.1 * top / 1000.0).ceil() * 1000.0;
        let svg = tmp(&format!("{name}.svg"));
        let fine = campbell_json(model, rpm_max, 100.0, &format!("{name}-100"), None);
        let coarse = campbell_json(
            model,
            rpm_max,
            1000.0,
            &format!("{name}-1000"),
            Some(svg.to_str().unwrap()),
        );
        // The diagram names the file and marks every damped critical speed
        // in its legend, mixed ones included.
        let svg = std::fs::read_to_string(&svg).unwrap();
        assert!(svg.contains(&format!("Campbell diagram: {name}")), "{name}");
        for c in coarse["critical_speeds"].as_array().unwrap() {
            let label = format!(
                "{:.0} rpm  mode {} {}",
                c["rpm"].as_f64().unwrap(),
                c["mode"],
                c["whirl"].as_str().unwrap()[..1].to_uppercase()
            );
            assert!(svg.contains(&label), "{name}: {label}");
        }
        for (key, ross) in [("critical_speeds", &wd), ("critical_speeds_undamped", &wn)] {
            let (a, b) = (ours(&fine, key), ours(&coarse, key));
            assert_eq!(a.len(), b.len(), "{name} {key}: {a:?} vs {b:?}");
            for (x, y) in a.iter().zip(&b) {
                assert!(
                    (x.0 - y.0).abs() <= 1e-7 * x.0,
                    "{name} {key}: {x:?} vs {y:?}"
                );
                assert_eq!(x.1, y.1, "{name} {key}");
            }
            for (r, whirl) in ross {
                let m = a
                    .iter()
                    .min_by(|p, q| (p.0 - r).abs().total_cmp(&(q.0 - r).abs()))
                    .unwrap_or_else(|| panic!("{name} {key}: none of ours"));
                let rel = (m.0 - r).abs() / r;
                eprintln!(
                    "{name:>27} {key:>24}: ROSS {r:9.2} rpm {whirl:>8}, ours {:9.2} rpm {:>8}, rel {rel:.1e}",
                    m.0, m.1
                );
                assert!(rel < 1e-3, "{name} {key}: ROSS {r} rpm, ours {m:?}");
                match whirl.as_str() {
                    "Forward" => assert_eq!(m.1, "forward", "{name} {key} {r}"),
                    "Backward" => assert_eq!(m.1, "backward", "{name} {key} {r}"),
                    _ => {}
                }
            }
        }
    }
}

/// The JSON, the CSV and the printed table carry the same modes and
/// critical speeds; modes are whole curves (every tracked mode of this
/// rotor is present at every speed and moves by less than 10 % per 500
/// rpm); outputs never overwrite the model; a missing model file says so.
#[test]
fn campbell_json_csv_and_table_agree() {
    let model = fixture("rotor_example.toml");
    let model = model.to_str().unwrap();
    let (j, c) = (tmp("c.json"), tmp("c.csv"));
    let o = cli([
        "campbell",
        "--model",
        model,
        "--rpm-max",
        "12000",
        "--rpm-step",
        "500",
        "--modes",
        "6",
        "--json",
        j.to_str().unwrap(),
        "--csv",
        c.to_str().unwrap(),
    ]);
    assert_eq!(o.status, 0, "{}", o.stderr);
    let json: Value = serde_json::from_str(&std::fs::read_to_string(&j).unwrap()).unwrap();
    assert_eq!(json["model"], "rotor_example");
    assert_eq!(json["speed_unit"], "rpm");
    assert_eq!(json["frequency_unit"], "Hz");
    let n_modes = json["n_modes"].as_u64().unwrap() as usize;
    assert_eq!(n_modes, 6);
    let speeds = json["speeds"].as_array().unwrap();
    assert_eq!(speeds.len(), 25);
    let mut last = vec![f64::NAN; n_modes];
    for sp in speeds {
        let modes = sp["modes"].as_array().unwrap();
        assert_eq!(modes.len(), n_modes, "{sp}");
        for (k, m) in modes.iter().enumerate() {
            assert_eq!(m["mode"].as_u64().unwrap() as usize, k + 1);
            let f = m["frequency_hz"].as_f64().unwrap();
            if last[k].is_finite() {
                assert!(
                    (f - last[k]).abs() < 0.1 * last[k],
                    "mode {}: {} -> {f}",
                    k + 1,
                    last[k]
                );
            }
            last[k] = f;
            assert!(["forward", "backward", "mixed"].contains(&m["whirl"].as_str().unwrap()));
        }
    }
    // 0 rpm: ROSS's lateral modes of this rotor (rest frequencies 876.6,
    // 919.3, 2622, 2831, 6903, 7305 rpm in its modal results).
    let f0: Vec<f64> = speeds[0]["modes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m["frequency_hz"].as_f64().unwrap() * 60.0)
        .collect();
    for (ours, ross) in f0
        .iter()
        .zip([877.0, 919.0, 2622.0, 2831.0, 6903.0, 7305.0])
    {
        assert!((ours - ross).abs() < 1.0, "{f0:?}");
    }
    // Critical speeds: ROSS's 876.5, 919.6, 2590.3, 2868.1, 6073.5 rpm and
    // the forward mode 6 at 8277.6 rpm (ROSS's documented
    // `speed_range=(100, 1000)` example lists 8278), each once.
    let crit: Vec<(f64, u64, String)> = json["critical_speeds"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| {
            (
                c["rpm"].as_f64().unwrap(),
                c["mode"].as_u64().unwrap(),
                c["whirl"].as_str().unwrap().to_string(),
            )
        })
        .collect();
    let expect = [
        (876.5, 1, "backward"),
        (919.6, 2, "forward"),
        (2590.3, 3, "backward"),
        (2868.1, 4, "forward"),
        (6073.5, 5, "backward"),
        (8277.6, 6, "forward"),
    ];
    assert_eq!(crit.len(), expect.len(), "{crit:?}");
    for (c, e) in crit.iter().zip(expect) {
        assert!((c.0 - e.0).abs() < 0.1, "{crit:?}");
        assert_eq!((c.1, c.2.as_str()), (e.1, e.2), "{crit:?}");
    }
    // The CSV: same rows.
    let csv = std::fs::read_to_string(&c).unwrap();
    let mut lines = csv.lines();
    assert!(lines.next().unwrap().starts_with('#'));
    assert_eq!(
        lines.next().unwrap(),
        "kind,speed_rpm,mode,frequency_hz,whirl,log_dec,damping_ratio"
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert!(rows.iter().all(|r| r.len() == 7));
    assert_eq!(rows.iter().filter(|r| r[0] == "mode").count(), 25 * 6);
    let csv_crit: Vec<&Vec<&str>> = rows.iter().filter(|r| r[0] == "critical").collect();
    assert_eq!(csv_crit.len(), crit.len());
    for (r, c) in csv_crit.iter().zip(&crit) {
        assert_eq!(r[1].parse::<f64>().unwrap(), c.0);
        assert_eq!(r[2].parse::<u64>().unwrap(), c.1);
        assert_eq!(r[4], c.2);
    }
    assert_eq!(
        rows.iter().filter(|r| r[0] == "critical_undamped").count(),
        json["critical_speeds_undamped"].as_array().unwrap().len()
    );
    let m = &rows[rows.len() / 2];
    let sp = speeds
        .iter()
        .find(|s| s["rpm"].as_f64().unwrap() == m[1].parse::<f64>().unwrap())
        .unwrap();
    let k: usize = m[2].parse().unwrap();
    assert_eq!(
        sp["modes"][k - 1]["frequency_hz"].as_f64().unwrap(),
        m[3].parse::<f64>().unwrap()
    );
    // The table lists the same critical speeds.
    let table = o.stdout.split("every whirl):").nth(1).unwrap();
    for c in &crit {
        assert!(table.contains(&format!("{:.1}", c.0)), "{table}");
    }
    // Outputs that are the model, or each other, are refused before running.
    for args in [
        vec!["--json", model],
        vec!["--csv", model],
        vec!["--plot", model],
        vec!["--json", j.to_str().unwrap(), "--csv", j.to_str().unwrap()],
    ] {
        let o = cli(["campbell", "--model", model, "--rpm-max", "1000"]
            .into_iter()
            .chain(args.iter().copied()));
        assert_eq!(o.status, 2, "{args:?}");
        assert_eq!(o.stderr.trim_end().lines().count(), 1, "{}", o.stderr);
        assert!(
            o.stderr.contains("refusing") || o.stderr.contains("same file"),
            "{}",
            o.stderr
        );
    }
    assert!(std::fs::read_to_string(model)
        .unwrap()
        .contains("ross_version"));
    let o = cli(["campbell", "--model", "/no/such/dir/rotor.toml"]);
    assert_eq!(o.status, 2);
    assert_eq!(
        o.stderr.trim(),
        "error: file not found: /no/such/dir/rotor.toml"
    );
}

/// `--modes-plot` draws the lowest `--modes` mode shapes at `--modes-rpm`:
/// its legend names each mode by the damped frequency the JSON lists at
/// that speed (here 3000 rpm, a diagram speed) and draws each mode's shape
/// over the 27 shaft nodes in both panels; bad speeds and an output
/// colliding with another are refused in one line.
#[test]
fn modes_plot_draws_the_lowest_modes_at_the_speed() {
    let svg = tmp("modes.svg");
    let json = tmp("modes.json");
    let out = cli([
        "campbell",
        "--model",
        "paper",
        "--rpm-max",
        "6000",
        "--rpm-step",
        "1000",
        "--modes",
        "3",
        "--json",
        json.to_str().unwrap(),
        "--modes-plot",
        svg.to_str().unwrap(),
        "--modes-rpm",
        "3000",
    ]);
    assert!(out.success(), "{}", out.stderr);
    let j: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let at = j["speeds"]
        .as_array()
        .unwrap()
        .iter()
        .find(|s| s["rpm"].as_f64() == Some(3000.0))
        .unwrap();
    let mut hz: Vec<f64> = at["modes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m["frequency_hz"].as_f64().unwrap())
        .collect();
    hz.sort_by(f64::total_cmp);
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(text.contains("Mode shapes: paper at 3000 rpm"));
    for f in &hz[..3] {
        assert!(
            text.contains(&format!("{f:.2} Hz, ")),
            "{f:.2} Hz not in the legend"
        );
    }
    // Three modes, each at t = 0 and t = T/4 in the legend.
    assert_eq!(text.matches(" Hz, ").count(), 6);
    // Each mode's colour draws its shape at t = 0 as one solid line of 27
    // points (the paper rotor's nodes) in each panel.
    for hex in ["#1F77B4", "#FF7F0E", "#2CA02C"] {
        let full = text
            .lines()
            .filter(|l| l.contains("<polyline") && l.contains(&format!("stroke=\"{hex}\"")))
            .filter(|l| {
                let pts = l.split("points=\"").nth(1).unwrap_or("");
                pts[..pts.find('"').unwrap_or(0)].split_whitespace().count() == 27
            })
            .count();
        assert_eq!(full, 2, "{hex}");
    }
    for (args, needle) in [
        (
            vec!["--modes-rpm", "-5"],
            "--modes-rpm must be finite and >= 0",
        ),
        (vec!["--plot", svg.to_str().unwrap()], "name the same file"),
    ] {
        let mut all = vec![
            "campbell",
            "--model",
            "paper",
            "--modes-plot",
            svg.to_str().unwrap(),
        ];
        all.extend(args);
        let o = cli(all);
        assert_eq!(o.status, 2);
        assert!(o.stderr.contains(needle), "{}", o.stderr);
        assert_eq!(o.stderr.trim_end().lines().count(), 1);
    }
}

/// ROSS's compressor example without its seals loads in the commands:
/// `simulate` (with an unbalance given on the command line: a ROSS rotor
/// carries none) writes its bearing channels, and `campbell` lists at 0
/// rpm the lowest lateral mode ROSS's `run_modal` gives (6572.2 rpm,
/// within 1e-6).
#[test]
fn compressor_without_seals_loads_in_simulate_and_campbell() {
    let model = fixture("compressor_no_seals.toml");
    let model = model.to_str().unwrap();
    let out = tmp("compressor_sim.csv");
    let o = cli([
        "simulate",
        "--model",
        model,
        "--out",
        out.to_str().unwrap(),
        "--rpm-max",
        "12000",
        "--extra-unbalance",
        "21:3.57e-4:0",
        "--extra-unbalance",
        "36:1.79e-4:90",
    ]);
    assert_eq!(o.status, 0, "{}", o.stderr);
    let csv = std::fs::read_to_string(&out).unwrap();
    let rows = csv.lines().filter(|l| !l.starts_with('#')).count();
    assert_eq!(rows, 241, "header and 240 speeds");
    let j = campbell_json(model, 1000.0, 1000.0, "compressor", None);
    let text = std::fs::read_to_string(fixture("compressor_no_seals.results.json")).unwrap();
    let r: Value = serde_json::from_str(&text).unwrap();
    let rest = &r["modal"]["speeds"][0];
    assert_eq!(rest["speed_rpm"].as_f64(), Some(0.0));
    let ross = floats(&rest["wd"])[0] * 30.0 / std::f64::consts::PI;
    let ours = j["speeds"][0]["modes"][0]["frequency_hz"].as_f64().unwrap() * 60.0;
    assert!((ours - ross).abs() < 1e-6 * ross, "{ours} vs {ross} rpm");
}
