//! The command line's error contract: exit status 2 and exactly one line on
//! stderr for bad arguments, missing files, unknown models and bad model
//! files; never a panic. In-process ([`cli`]), and once through the real
//! binary for its wiring.

use crate::common::{binary, cli, example, tmp, Output};

/// Asserts exit 2, one stderr line containing `needle`, no panic.
fn fails(args: &[&str], needle: &str) {
    let Output {
        status: code,
        stderr: err,
        ..
    } = cli(args);
    assert_eq!(code, 2, "args {args:?}: stderr {err:?}");
    assert!(!err.contains("panicked"), "args {args:?}: {err}");
    assert_eq!(err.trim_end().lines().count(), 1, "args {args:?}: {err:?}");
    assert!(
        err.contains(needle),
        "args {args:?}: {err:?} lacks {needle:?}"
    );
}

#[test]
fn usage_errors_exit_2_with_one_line() {
    fails(&[], "a command is required");
    fails(&["frobnicate"], "unrecognized subcommand");
    fails(&["simulate", "--model", "paper"], "--out");
    fails(&["simulate", "--out", "x.csv"], "--model");
    fails(
        &[
            "simulate", "--model", "paper", "--out", "x.csv", "--noise", "abc",
        ],
        "--noise",
    );
    fails(
        &[
            "simulate", "--model", "paper", "--out", "x.csv", "--seed", "-1",
        ],
        "-1",
    );
    fails(
        &["simulate", "--model", "paper", "--out", "x.csv", "--bogus"],
        "--bogus",
    );
    fails(
        &[
            "simulate",
            "--model",
            "paper",
            "--out",
            "x.csv",
            "--pedestal-mass",
            "3",
        ],
        "--pedestal-k",
    );
    fails(
        &[
            "simulate", "--model", "paper", "--out", "x.csv", "--bow", "3:1e-5",
        ],
        "NODE:AMOUNT:PHASE_DEG",
    );
    fails(
        &[
            "identify",
            "--model",
            "paper",
            "--measurements",
            "m.csv",
            "--formulation",
            "magic",
        ],
        "magic",
    );
    fails(
        &[
            "identify",
            "--model",
            "paper",
            "--measurements",
            "m.csv",
            "--order",
            "x",
        ],
        "--order",
    );
    fails(
        &["campbell", "--model", "paper", "--rpm-max", "fast"],
        "--rpm-max",
    );
    fails(&["tables", "--model", "paper"], "--out");
}

#[test]
fn help_and_version_exit_0() {
    let Output {
        status: code,
        stdout: out,
        ..
    } = cli(["--help"]);
    assert_eq!(code, 0);
    for cmd in ["simulate", "tables", "identify", "diagnose", "campbell"] {
        assert!(out.contains(cmd), "{out}");
    }
    let Output {
        status: code,
        stdout: out,
        ..
    } = cli(["--version"]);
    assert_eq!(code, 0);
    assert!(out.starts_with("rotorid "));
    let Output {
        status: code,
        stdout: out,
        ..
    } = cli(["simulate", "--help"]);
    assert_eq!(code, 0);
    for flag in [
        "--rpm-min",
        "--rpm-max",
        "--rpm-step",
        "--noise",
        "--seed",
        "--out",
        "--model",
    ] {
        assert!(out.contains(flag), "{flag}: {out}");
    }
}

#[test]
fn bad_values_exit_2() {
    let out = tmp("never.csv");
    let o = out.to_str().unwrap();
    fails(
        &[
            "simulate",
            "--model",
            "paper",
            "--out",
            o,
            "--rpm-step",
            "0",
        ],
        "--rpm-step",
    );
    fails(
        &[
            "simulate",
            "--model",
            "paper",
            "--out",
            o,
            "--rpm-step",
            "-5",
        ],
        "--rpm-step",
    );
    fails(
        &[
            "simulate",
            "--model",
            "paper",
            "--out",
            o,
            "--rpm-min",
            "200",
            "--rpm-max",
            "100",
        ],
        "--rpm-max",
    );
    fails(
        &[
            "simulate",
            "--model",
            "paper",
            "--out",
            o,
            "--rpm-min",
            "-1",
        ],
        "--rpm-min",
    );
    fails(
        &[
            "simulate", "--model", "paper", "--out", o, "--noise", "-0.1",
        ],
        "--noise",
    );
    fails(
        &["simulate", "--model", "paper", "--out", o, "--noise", "NaN"],
        "--noise",
    );
    fails(
        &["simulate", "--model", "paper", "--out", o, "--e-scale", "0"],
        "--e-scale",
    );
    fails(
        &[
            "simulate",
            "--model",
            "paper",
            "--out",
            o,
            "--bow",
            "99:1e-5:0",
        ],
        "node 99",
    );
    fails(
        &[
            "simulate",
            "--model",
            "paper",
            "--out",
            o,
            "--runout",
            "b3_y:1e-6:0",
        ],
        "bad channel",
    );
    fails(
        &[
            "simulate",
            "--model",
            "paper",
            "--out",
            o,
            "--probe-gain",
            "b3_z:1.1",
        ],
        "bad channel",
    );
    fails(
        &[
            "simulate",
            "--model",
            "paper",
            "--out",
            o,
            "--probe-gain",
            "b1_z:-1",
        ],
        "factor > 0",
    );
    fails(
        &[
            "simulate",
            "--model",
            "paper",
            "--out",
            o,
            "--extra-unbalance",
            "0:1e-3:0",
        ],
        "node 0",
    );
    assert!(!out.exists(), "nothing written on error");
    // Unwritable output.
    fails(
        &[
            "simulate",
            "--model",
            "paper",
            "--out",
            "/no/such/dir/x.csv",
            "--rpm-max",
            "100",
        ],
        "/no/such/dir/x.csv",
    );
}

#[test]
fn unknown_model_and_missing_files_exit_2() {
    let o = tmp("x.csv");
    let o = o.to_str().unwrap();
    fails(
        &["simulate", "--model", "nosuchmodel", "--out", o],
        "unknown model `nosuchmodel`",
    );
    fails(
        &["simulate", "--model", "/no/such/dir/model.toml", "--out", o],
        "file not found: /no/such/dir/model.toml",
    );
    fails(&["campbell", "--model", "nosuchmodel"], "unknown model");
    fails(&["tables", "--model", "nosuchmodel", "--out", o], "");
    fails(
        &[
            "identify",
            "--model",
            "paper",
            "--measurements",
            "/no/such/file.csv",
        ],
        "file not found: /no/such/file.csv",
    );
    fails(
        &[
            "diagnose",
            "--model",
            "paper",
            "--measurements",
            "/no/such/file.csv",
        ],
        "file not found: /no/such/file.csv",
    );
}

#[test]
fn bad_model_files_exit_2_naming_the_field() {
    let paper = std::fs::read_to_string(example("paper.toml")).unwrap();
    let out = tmp("y.csv");
    let o = out.to_str().unwrap();
    let cases = [
        (
            paper.replace("node = 27\n", "node = 40\n"),
            "bearing[2].node: node 40 is not on the shaft (nodes 1..=27)",
        ),
        (
            paper.replace("length = 1.3", "length = -1.3"),
            "shaft[1].length",
        ),
        (
            paper.replace("node = 27\n", "node = 27\nstiff = 1\n"),
            "unknown field `stiff`",
        ),
        (paper.replace("node = 27\n", ""), "missing field `node`"),
        (paper.replace("elements = 26", "elements = = 26"), "line 20"),
        (
            "ross_version = \"2.0\"\n[\"SealElement_S\"]\nn = 0\n".to_string(),
            "SealElement_S: not supported",
        ),
        (
            String::from_utf8_lossy(&[0xff, 0xfe, 0x00]).into_owned(),
            "model",
        ),
    ];
    for (i, (text, needle)) in cases.iter().enumerate() {
        let p = tmp(&format!("bad{i}.toml"));
        std::fs::write(&p, text).unwrap();
        fails(
            &["simulate", "--model", p.to_str().unwrap(), "--out", o],
            needle,
        );
        fails(&["campbell", "--model", p.to_str().unwrap()], needle);
    }
    // A directory and an unreadable (binary) file.
    let d = tmp("adir.toml");
    std::fs::create_dir_all(&d).unwrap();
    fails(
        &["simulate", "--model", d.to_str().unwrap(), "--out", o],
        "model",
    );
    let b = tmp("bin.toml");
    std::fs::write(&b, [0xffu8, 0xfe, 0xfd]).unwrap();
    fails(
        &["simulate", "--model", b.to_str().unwrap(), "--out", o],
        "model",
    );
    assert!(!out.exists());
}

/// The binary itself (`main` -> `main_from_env`): exit status and one-line
/// stderr on errors, help and a real command on success.
#[test]
fn the_binary_keeps_the_exit_status_contract() {
    for (args, needle) in [
        (vec![], "a command is required"),
        (vec!["frobnicate"], "unrecognized subcommand"),
        (
            vec!["simulate", "--model", "nosuchmodel", "--out", "x.csv"],
            "unknown model `nosuchmodel`",
        ),
        (
            vec!["diagnose", "--model", "paper", "--measurements", "m.csv"],
            "",
        ),
    ] {
        let o = binary(&args);
        assert_eq!(o.status, 2, "args {args:?}: stderr {:?}", o.stderr);
        assert!(
            !o.stderr.contains("panicked"),
            "args {args:?}: {}",
            o.stderr
        );
        assert_eq!(
            o.stderr.trim_end().lines().count(),
            1,
            "{args:?}: {:?}",
            o.stderr
        );
        assert!(o.stderr.contains(needle), "{args:?}: {:?}", o.stderr);
        assert!(o.stdout.is_empty(), "{args:?}: {:?}", o.stdout);
    }
    let o = binary(["--help"]);
    assert_eq!(o.status, 0);
    assert!(o.stdout.contains("campbell"), "{}", o.stdout);
    let csv = tmp("binary.csv");
    let o = binary([
        "simulate",
        "--model",
        "paper",
        "--out",
        csv.to_str().unwrap(),
        "--rpm-max",
        "200",
    ]);
    assert_eq!(o.status, 0, "{}", o.stderr);
    assert!(o.stderr.starts_with("wrote 4 speeds"), "{}", o.stderr);
    // In-process and the binary agree.
    assert_eq!(
        cli([
            "simulate",
            "--model",
            "paper",
            "--out",
            csv.to_str().unwrap(),
            "--rpm-max",
            "200"
        ]),
        o
    );
}
