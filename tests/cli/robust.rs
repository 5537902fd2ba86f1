//! Nothing lost, nothing presented as fine when it is not: outputs written
//! whole or not at all, inputs never overwritten, truncated files and data
//! that cannot determine the parameters refused, messages that name the
//! place, size limits. Every case: exit 2, one line on stderr naming the
//! problem, inputs unchanged, no output (or temporary) left behind.

use std::path::{Path, PathBuf};

use crate::common::{binary, cli, example, tmp, Output};

/// Asserts exit 2, one stderr line containing every needle, no panic.
fn fails(args: &[&str], needles: &[&str]) -> String {
    let Output { status, stderr, .. } = cli(args);
    assert_eq!(status, 2, "args {args:?}: stderr {stderr:?}");
    assert!(!stderr.contains("panicked"), "args {args:?}: {stderr}");
    assert_eq!(
        stderr.trim_end().lines().count(),
        1,
        "args {args:?}: {stderr:?}"
    );
    for n in needles {
        assert!(stderr.contains(n), "args {args:?}: {stderr:?} lacks {n:?}");
    }
    stderr
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Files in `dir` whose name marks a temporary of the atomic writer.
fn temporaries(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains(".tmp-"))
        .collect()
}

/// A small noise-free sweep of the paper rotor written by `simulate`.
fn sweep_csv(name: &str, rpm_min: &str, rpm_max: &str, step: &str) -> PathBuf {
    let p = tmp(name);
    let o = cli([
        "simulate",
        "--model",
        "paper",
        "--out",
        s(&p),
        "--rpm-min",
        rpm_min,
        "--rpm-max",
        rpm_max,
        "--rpm-step",
        step,
    ]);
    assert!(o.success(), "{o:?}");
    p
}

#[test]
fn an_output_that_is_an_input_is_refused_before_anything_runs() {
    let model = tmp("m.toml");
    std::fs::copy(example("paper.toml"), &model).unwrap();
    let model_text = std::fs::read(&model).unwrap();
    let m = s(&model);
    fails(
        &["simulate", "--model", m, "--out", m],
        &["--out", "--model", "refusing to overwrite an input"],
    );
    fails(
        &["tables", "--model", m, "--out", m],
        &["--out", "refusing to overwrite an input"],
    );
    fails(
        &["campbell", "--model", m, "--plot", m],
        &["--plot", "refusing to overwrite an input"],
    );
    assert_eq!(std::fs::read(&model).unwrap(), model_text);

    let csv = sweep_csv("x.csv", "500", "15000", "500");
    let csv_text = std::fs::read(&csv).unwrap();
    let c = s(&csv);
    fails(
        &[
            "identify",
            "--model",
            "paper",
            "--measurements",
            c,
            "--json",
            c,
        ],
        &["--json", "--measurements", "refusing to overwrite an input"],
    );
    fails(
        &["identify", "--model", m, "--measurements", c, "--json", m],
        &["--json", "--model"],
    );
    // The same file under another name: `..`, a hard link, a symbolic link.
    let dir = csv.parent().unwrap();
    std::fs::create_dir_all(dir.join("sub")).unwrap();
    let dotted = dir.join("sub").join("..").join("x.csv");
    fails(
        &[
            "identify",
            "--model",
            "paper",
            "--measurements",
            c,
            "--json",
            s(&dotted),
        ],
        &["refusing to overwrite an input"],
    );
    #[cfg(unix)]
    {
        let hard = dir.join("hard.csv");
        let soft = dir.join("soft.json");
        std::fs::hard_link(&csv, &hard).unwrap();
        std::os::unix::fs::symlink(&csv, &soft).unwrap();
        for out in [&hard, &soft] {
            fails(
                &[
                    "identify",
                    "--model",
                    "paper",
                    "--measurements",
                    c,
                    "--json",
                    s(out),
                ],
                &["refusing to overwrite an input"],
            );
        }
    }
    assert_eq!(std::fs::read(&csv).unwrap(), csv_text);
    assert!(temporaries(dir).is_empty());
}

/// A write that fails half way (the process's file size limit, as a full
/// disk would): exit 2, the old file intact, no temporary left.
#[cfg(unix)]
#[test]
fn a_failed_write_leaves_the_old_file_and_no_temporary() {
    let csv = sweep_csv("in.csv", "500", "15000", "500");
    let dir = csv.parent().unwrap().to_path_buf();
    let bin = env!("CARGO_BIN_EXE_rotorid");
    let cases: Vec<(&str, Vec<String>)> = vec![
        (
            "out.csv",
            vec![
                "simulate".into(),
                "--model".into(),
                "paper".into(),
                "--out".into(),
            ],
        ),
        (
            "out.bin",
            vec![
                "tables".into(),
                "--model".into(),
                "paper".into(),
                "--out".into(),
            ],
        ),
        (
            "out.svg",
            vec![
                "campbell".into(),
                "--model".into(),
                "paper".into(),
                "--plot".into(),
            ],
        ),
        (
            "out.json",
            vec![
                "identify".into(),
                "--model".into(),
                "paper".into(),
                "--estimator".into(),
                "rls".into(),
                "--measurements".into(),
                s(&csv).into(),
                "--json".into(),
            ],
        ),
    ];
    for (name, mut args) in cases {
        let out = dir.join(name);
        std::fs::write(&out, b"old\n").unwrap();
        args.push(s(&out).into());
        // SIGXFSZ ignored: a write beyond the limit fails with EFBIG.
        let script = format!(
            "trap '' XFSZ; ulimit -f 1; exec \"$0\" {}",
            args.iter()
                .map(|a| format!("'{a}'"))
                .collect::<Vec<_>>()
                .join(" ")
        );
        let o = std::process::Command::new("sh")
            .arg("-c")
            .arg(&script)
            .arg(bin)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{name}: {stderr}");
        assert_eq!(stderr.trim_end().lines().count(), 1, "{name}: {stderr}");
        assert!(stderr.contains(name), "{name}: {stderr}");
        assert_eq!(std::fs::read(&out).unwrap(), b"old\n", "{name}");
        assert!(
            temporaries(&dir).is_empty(),
            "{name}: {:?}",
            temporaries(&dir)
        );
    }
    // Without the limit the same commands replace the file whole.
    let out = dir.join("out.csv");
    let o = binary(["simulate", "--model", "paper", "--out", s(&out)]);
    assert!(o.success(), "{o:?}");
    assert!(std::fs::read_to_string(&out).unwrap().starts_with('#'));
}

#[test]
fn a_csv_cut_short_is_refused() {
    let csv = sweep_csv("full.csv", "500", "15000", "500");
    let text = std::fs::read_to_string(&csv).unwrap();
    // Cut in the middle of the last number.
    let cut = tmp("cut.csv");
    std::fs::write(&cut, &text[..text.len() - 4]).unwrap();
    let lines = text.lines().count();
    for est in ["rls", "oe"] {
        fails(
            &[
                "identify",
                "--model",
                "paper",
                "--estimator",
                est,
                "--measurements",
                s(&cut),
            ],
            &[&format!("line {lines}"), "cut short"],
        );
    }
    // The whole file identifies.
    assert!(cli([
        "identify",
        "--model",
        "paper",
        "--estimator",
        "rls",
        "--measurements",
        s(&csv)
    ])
    .success());
}

/// Writes a CSV of `rows` (speed rpm, then 8 values) for two bearings.
fn csv_of(name: &str, rows: &[(f64, [f64; 8])]) -> PathBuf {
    let mut t =
        String::from("speed_rpm,b1_y_re,b1_y_im,b1_z_re,b1_z_im,b2_y_re,b2_y_im,b2_z_re,b2_z_im\n");
    for (rpm, v) in rows {
        t.push_str(&format!("{rpm}"));
        for x in v {
            t.push_str(&format!(",{x:e}"));
        }
        t.push('\n');
    }
    let p = tmp(name);
    std::fs::write(&p, t).unwrap();
    p
}

#[test]
fn data_that_cannot_determine_the_parameters_is_refused() {
    let v = [1e-6, 2e-7, -3e-7, 1e-6, 2e-6, -1e-7, 4e-7, 9e-7];
    let one = csv_of("one.csv", &[(3000.0, v)]);
    let two = csv_of("two.csv", &[(3000.0, v), (3100.0, v)]);
    let same: Vec<(f64, [f64; 8])> = (0..500).map(|_| (3000.0, v)).collect();
    let same = csv_of("same.csv", &same);
    let zero: Vec<(f64, [f64; 8])> = (1..=50).map(|i| (100.0 * i as f64, [0.0; 8])).collect();
    let zero = csv_of("zero.csv", &zero);
    let sub: Vec<(f64, [f64; 8])> = (1..=50)
        .map(|i| {
            (
                100.0 * i as f64,
                [4.9e-324, 0.0, 1e-310, 0.0, 0.0, 2e-320, 0.0, 0.0],
            )
        })
        .collect();
    let sub = csv_of("sub.csv", &sub);
    let tiny: Vec<(f64, [f64; 8])> = (1..=50).map(|i| (100.0 * i as f64, [1e-17; 8])).collect();
    let tiny = csv_of("tiny.csv", &tiny);
    for est in ["rls", "oe"] {
        for f32 in [false, true] {
            let run = |file: &Path, needles: &[&str]| {
                let mut args = vec![
                    "identify",
                    "--model",
                    "paper",
                    "--estimator",
                    est,
                    "--measurements",
                    s(file),
                ];
                if f32 {
                    args.push("--f32");
                }
                fails(&args, needles);
            };
            run(
                &one,
                &["1 distinct speed(s)", "22 unknowns", "cannot determine"],
            );
            run(&two, &["2 distinct speed(s)", "16 real equations"]);
            run(&same, &["1 distinct speed(s)"]);
            run(&zero, &["no signal"]);
            run(&sub, &["no signal"]);
            run(&tiny, &["no signal", "1e-15 m"]);
        }
    }
    // The paper structure counts complex unknowns twice.
    fails(
        &[
            "identify",
            "--model",
            "paper",
            "--formulation",
            "paper",
            "--measurements",
            s(&two),
        ],
        &["2 distinct speed(s)", "38 unknowns"],
    );
}

#[test]
fn lambda_and_delta_out_of_range_name_the_option() {
    let csv = sweep_csv("ok.csv", "500", "15000", "500");
    let c = s(&csv);
    let base = ["identify", "--model", "paper", "--measurements", c];
    let with = |extra: &[&str]| -> Vec<String> {
        base.iter().chain(extra).map(|x| x.to_string()).collect()
    };
    for (extra, needle) in [
        (
            &["--lambda", "1e-300"][..],
            "--lambda must be in [0.368, 1]",
        ),
        (&["--lambda", "0.3"][..], "--lambda"),
        (&["--lambda", "1.5e-32", "--f32"][..], "--lambda"),
        (&["--delta", "1e300"][..], "--delta must be in"),
        (&["--delta", "1e-300"][..], "--delta must be in"),
        (&["--delta", "1e-25", "--f32"][..], "with --f32"),
        (&["--delta", "1e20", "--f32"][..], "with --f32"),
    ] {
        let args = with(extra);
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let e = fails(&args, &[needle]);
        assert!(!e.contains("thresholds"), "{e}");
    }
    // In range at both ends still runs.
    for extra in [
        &["--lambda", "0.37"][..],
        &["--delta", "1e-19", "--f32"][..],
    ] {
        let args = with(extra);
        let o = cli(args
            .iter()
            .chain(&["--estimator".to_string(), "rls".to_string()]));
        assert!(o.success(), "{extra:?}: {o:?}");
    }
}

fn model_with(name: &str, from: &str, to: &str) -> PathBuf {
    let text = std::fs::read_to_string(example("paper.toml")).unwrap();
    assert!(text.contains(from), "{from}");
    let p = tmp(name);
    std::fs::write(&p, text.replacen(from, to, 1)).unwrap();
    p
}

#[test]
fn absurd_model_values_name_their_field() {
    for (from, to, field) in [
        ("length = 1.3", "length = 1e300", "shaft[1].length"),
        ("length = 1.3", "length = 1e-300", "shaft[1].length"),
        (
            "outer_diameter = 0.1\n",
            "outer_diameter = 1e300\n",
            "shaft[1].outer_diameter",
        ),
        (
            "outer_diameter = 0.1\n",
            "outer_diameter = 1e-300\n",
            "shaft[1].outer_diameter",
        ),
        ("e = 200e9", "e = 1e300", "materials.steel.e"),
        // (A tiny positive modulus is valid: ROSS's mass-carrying layers.)
        ("rho = 7800.0", "rho = 1e300", "materials.steel.rho"),
        ("rho = 7800.0", "rho = 1e-300", "materials.steel.rho"),
        ("thickness = 0.05", "thickness = 1e300", "disk[1].thickness"),
        (
            "k = [5e7, 0.5e7, 1e7, 7e7]",
            "k = [5e7, 0.5e7, 1e300, 7e7]",
            "bearing[1].k[3]",
        ),
    ] {
        let m = model_with("bad.toml", from, to);
        for cmd in [
            vec!["campbell", "--model", s(&m)],
            vec!["simulate", "--model", s(&m), "--out", s(&tmp("never.csv"))],
        ] {
            let e = fails(&cmd, &[field, "physically plausible"]);
            assert!(!e.contains("singular"), "{e}");
        }
        assert!(!tmp("never.csv").exists());
    }
    // ROSS: a NaN coefficient is named with 1-based indices.
    let text = std::fs::read_to_string(example("paper_ross.toml")).unwrap();
    let p = tmp("nan_ross.toml");
    std::fs::write(&p, text.replacen("kxx = [50000000.0]", "kxx = [nan]", 1)).unwrap();
    let e = fails(
        &["campbell", "--model", s(&p)],
        &["bearing[1].k[1]", "finite"],
    );
    assert!(!e.contains("k[0]"), "{e}");
    let p = tmp("e_ross.toml");
    std::fs::write(&p, text.replacen("E = 200000000000.0", "E = 1e300", 1)).unwrap();
    fails(
        &["campbell", "--model", s(&p)],
        &["ShaftElement", "material.E", "physically plausible"],
    );
    // A tiny modulus is valid (ROSS carries impeller mass on such layers:
    // 6.89475e3 Pa in its compressor example).
    let p = tmp("soft_ross.toml");
    std::fs::write(&p, text.replacen("E = 200000000000.0", "E = 6894.75", 1)).unwrap();
    let out = cli(["campbell", "--model", s(&p)]);
    assert_eq!(out.status, 0, "{}", out.stderr);
}

#[test]
fn csv_messages_give_line_and_column_and_cut_long_fields() {
    let csv = sweep_csv("base.csv", "500", "15000", "500");
    let text = std::fs::read_to_string(&csv).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let n = lines.len();
    // A huge value in a response column of the last row.
    let mut fields: Vec<String> = lines[n - 1].split(',').map(str::to_string).collect();
    fields[3] = "1e308".into();
    let mut edited: Vec<String> = lines.iter().map(|l| l.to_string()).collect();
    edited[n - 1] = fields.join(",");
    let big = tmp("big.csv");
    std::fs::write(&big, edited.join("\n") + "\n").unwrap();
    for est in ["rls", "oe"] {
        let e = fails(
            &[
                "identify",
                "--model",
                "paper",
                "--estimator",
                est,
                "--measurements",
                s(&big),
            ],
            &[&format!("line {n}, column 4 (b1_z_re)"), "1e308"],
        );
        assert!(!e.contains("sample"), "{e}");
    }
    // A 5 MB field is cut in the message.
    fields[3] = "7".repeat(5_000_000) + "x";
    edited[n - 1] = fields.join(",");
    let long = tmp("long.csv");
    std::fs::write(&long, edited.join("\n") + "\n").unwrap();
    let e = fails(
        &["identify", "--model", "paper", "--measurements", s(&long)],
        &[
            &format!("line {n}, column 4 (b1_z_re)"),
            "not a number",
            "…",
        ],
    );
    assert!(e.len() < 300, "{} bytes", e.len());
}

#[test]
fn campbell_refuses_models_and_grids_beyond_its_limits() {
    let big = model_with("big.toml", "elements = 26", "elements = 100000");
    let t = std::time::Instant::now();
    fails(
        &["campbell", "--model", s(&big)],
        &["degrees of freedom", "at most 400"],
    );
    let mid = model_with("mid.toml", "elements = 26", "elements = 1000");
    fails(&["campbell", "--model", s(&mid)], &["at most 400"]);
    assert!(t.elapsed().as_secs_f64() < 10.0, "{:?}", t.elapsed());
    fails(
        &["campbell", "--model", "paper", "--rpm-step", "0.01"],
        &["speeds", "larger speed step"],
    );
    // An adaptive table grid with a tiny tolerance would not end.
    fails(
        &[
            "tables",
            "--model",
            "paper",
            "--out",
            s(&tmp("t.bin")),
            "--adaptive",
            "1e-300",
        ],
        &["--adaptive must be in [1e-7, 1)", "got 1e-300"],
    );
    assert!(!tmp("t.bin").exists());
}
