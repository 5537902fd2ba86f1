//! `rotorid simulate` and `rotorid campbell` on the built-in paper rotor.

use crate::common::{cli, tmp, Output};
use rotorid::io::measurement::read_csv;
use rotorid::model::extension::Effects;
use rotorid::model::RotorModel;
use rotorid::simulate::{simulate, SimOptions};
use rotorid::tables::grid::uniform_rpm;

#[test]
fn simulate_paper_writes_a_valid_csv() {
    let p = tmp("paper.csv");
    let Output {
        status: code,
        stderr: err,
        ..
    } = cli(["simulate", "--model", "paper", "--out", p.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    let m = read_csv(&p).unwrap();
    assert_eq!(m.n_bearings, 2);
    // Default grid: 50, 100, ..., 15000 rpm.
    assert_eq!(m.samples.len(), 300);
    let lib = simulate(
        &RotorModel::paper(),
        &SimOptions {
            speeds_rpm: uniform_rpm(50.0, 15000.0, 50.0).unwrap(),
            noise: 0.0,
            seed: 1,
            effects: Effects::default(),
        },
    )
    .unwrap();
    for (a, b) in m.samples.iter().zip(&lib.samples) {
        assert_eq!(a.q, b.q);
        assert!((a.omega - b.omega).abs() <= 1e-12 * b.omega);
    }
    let text = std::fs::read_to_string(&p).unwrap();
    assert!(
        text.contains("speed_rpm,b1_y_re,b1_y_im,b1_z_re,b1_z_im,b2_y_re,b2_y_im,b2_z_re,b2_z_im")
    );
}

#[test]
fn simulate_with_flags_noise_and_layout() {
    let a = tmp("a.csv");
    let b = tmp("b.csv");
    let args = |out: &std::path::Path| {
        vec![
            "simulate".to_string(),
            "--model".into(),
            "paper".into(),
            "--out".into(),
            out.to_str().unwrap().into(),
            "--rpm-min".into(),
            "100".into(),
            "--rpm-max".into(),
            "1000".into(),
            "--rpm-step".into(),
            "300".into(),
            "--noise".into(),
            "0.01".into(),
            "--seed".into(),
            "3".into(),
            "--runout".into(),
            "b1_y:1e-6:45".into(),
            "--e-scale".into(),
            "1.02".into(),
            "--extra-unbalance".into(),
            "14:0.001:90".into(),
            "--pedestal-mass".into(),
            "50".into(),
            "--pedestal-k".into(),
            "1e8".into(),
            "--pedestal-c".into(),
            "1e3".into(),
            "--bearing-speed-law".into(),
            "linear".into(),
            "--bow".into(),
            "14:1e-5:0".into(),
            "--probe-gain".into(),
            "b2_z:1.1".into(),
        ]
    };
    let run = |out: &std::path::Path| {
        let o = cli(args(out));
        assert_eq!(o.status, 0, "{}", o.stderr);
    };
    run(&a);
    run(&b);
    // Same seed, same file; 100, 400, 700, 1000 rpm.
    assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
    let m = read_csv(&a).unwrap();
    assert_eq!(m.samples.len(), 4);
    let text = std::fs::read_to_string(&a).unwrap();
    for needle in [
        "runout on b1_y",
        "E and G scaled by 1.02",
        "extra unbalance at node 14",
        "pedestal",
        "bow at node 14",
        "(rpm/15000)^1",
        "probe b2_z reads x 1.1",
        "seed 3",
    ] {
        assert!(text.contains(needle), "{needle}: {text}");
    }
    let c = tmp("c.csv");
    let Output {
        status: code,
        stderr: err,
        ..
    } = cli([
        "simulate",
        "--model",
        "paper",
        "--out",
        c.to_str().unwrap(),
        "--rpm-max",
        "500",
        "--layout",
        "amp-phase",
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(std::fs::read_to_string(&c)
        .unwrap()
        .contains("b1_y_amp,b1_y_phase_deg"));
    assert_eq!(read_csv(&c).unwrap().samples.len(), 10);
}

#[test]
fn simulate_from_model_files_own_and_ross() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let a = tmp("own.csv");
    let b = tmp("ross.csv");
    let ross = root.join("examples/paper_ross.toml");
    let ross = ross.to_str().unwrap();
    let run = |model: &str, out: &std::path::Path, extra: &[&str]| {
        let mut args = vec![
            "simulate",
            "--model",
            model,
            "--out",
            out.to_str().unwrap(),
            "--rpm-max",
            "1000",
        ];
        args.extend_from_slice(extra);
        cli(args)
    };
    let own = root.join("examples/paper.toml");
    let o = run(own.to_str().unwrap(), &a, &[]);
    assert_eq!(o.status, 0, "{}", o.stderr);
    let own = read_csv(&a).unwrap();
    assert!(own
        .samples
        .iter()
        .all(|s| s.q.iter().any(|z| z.norm() > 0.0)));
    // The ROSS file carries no unbalance: an all-zero sweep is refused, on
    // one line naming the flag that adds unbalance, and nothing is written.
    let o = run(ross, &b, &[]);
    assert_eq!(o.status, 2, "{o:?}");
    assert_eq!(o.stderr.trim_end().lines().count(), 1, "{}", o.stderr);
    for needle in [
        "no unbalance",
        "every response would be zero",
        "--extra-unbalance NODE:ME_KGM:PHASE_DEG",
    ] {
        assert!(o.stderr.contains(needle), "{needle}: {}", o.stderr);
    }
    assert!(!b.exists());
    // A zero extra unbalance excites nothing either.
    let o = run(ross, &b, &["--extra-unbalance", "5:0:0"]);
    assert_eq!(o.status, 2, "{o:?}");
    assert!(o.stderr.contains("--extra-unbalance"), "{}", o.stderr);
    // With the flag it names: a response at every speed.
    let o = run(ross, &b, &["--extra-unbalance", "5:1e-4:0"]);
    assert_eq!(o.status, 0, "{}", o.stderr);
    let ross = read_csv(&b).unwrap();
    assert_eq!(ross.samples.len(), 20);
    assert!(ross
        .samples
        .iter()
        .all(|s| s.q.iter().all(|z| z.norm() > 0.0)));
}

#[test]
fn campbell_prints_table_and_critical_speeds_and_writes_svg() {
    let p = tmp("campbell.svg");
    let Output {
        status: code,
        stdout: out,
        stderr: err,
    } = cli([
        "campbell",
        "--model",
        "paper",
        "--plot",
        p.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("speed_rpm"));
    assert!(out.contains(" F "), "{out}");
    assert!(out.contains(" B "), "{out}");
    // Critical speeds of every whirl, with the paper rotor's backward and
    // forward crossings near 5796 and 6111 rpm (SPEC section 3).
    let crit: Vec<(f64, String)> = out
        .split("every whirl):")
        .nth(1)
        .unwrap()
        .lines()
        .filter_map(|l| {
            let w: Vec<&str> = l.split_whitespace().collect();
            Some((w.first()?.parse().ok()?, w.get(3)?.to_string()))
        })
        .collect();
    assert_eq!(crit.len(), 2, "{crit:?}\n{out}");
    assert!(
        (crit[0].0 - 5796.0).abs() < 5.0 && crit[0].1 == "backward",
        "{crit:?}"
    );
    assert!(
        (crit[1].0 - 6111.0).abs() < 5.0 && crit[1].1 == "forward",
        "{crit:?}"
    );
    let svg = std::fs::read_to_string(&p).unwrap();
    assert!(svg.starts_with("<svg"));
    assert!(svg.contains("Campbell diagram: paper"));
    assert!(svg.contains("1X"));
    assert!(svg.contains("forward"));
    assert!(svg.contains("backward"));
    // Unwritable plot path: exit 2, one line.
    let Output {
        status: code,
        stderr: err,
        ..
    } = cli([
        "campbell",
        "--model",
        "paper",
        "--rpm-max",
        "1000",
        "--plot",
        "/no/such/dir/x.svg",
    ]);
    assert_eq!(code, 2);
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
}
