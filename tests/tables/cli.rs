//! `rotorid tables` end to end: blob (f64, f32), Rust source, adaptive grid,
//! and bad input (exit status 2, one line on stderr, no file).

use crate::common::{cli, tmp};
use rotorid::core::table::TableView;
use rotorid::model::RotorModel;
use rotorid::tables::grid::uniform_rad_s;
use rotorid::tables::{build, ModelTable, Scalar};

#[test]
fn blob_and_source_from_the_command_line() {
    let blob = tmp("paper.tbl");
    let o = cli([
        "tables",
        "--model",
        "paper",
        "--out",
        blob.to_str().unwrap(),
        "--rpm-min",
        "100",
        "--rpm-max",
        "3000",
        "--rpm-step",
        "100",
    ]);
    assert!(o.success(), "{}", o.stderr);
    let bytes = std::fs::read(&blob).unwrap();
    let view = TableView::<f64>::parse(&bytes).unwrap();
    assert_eq!(view.n_speeds(), 30);
    // Same as the library's table.
    let lib = build(
        &RotorModel::paper(),
        &uniform_rad_s(100.0, 3000.0, 100.0).unwrap(),
    )
    .unwrap();
    assert_eq!(lib.to_blob(Scalar::F64).unwrap(), bytes);

    let blob32 = tmp("paper32.tbl");
    let o = cli([
        "tables",
        "--model",
        "paper",
        "--out",
        blob32.to_str().unwrap(),
        "--f32",
        "--rpm-max",
        "1000",
    ]);
    assert!(o.success());
    let (t, sc) = ModelTable::from_blob(&std::fs::read(&blob32).unwrap()).unwrap();
    assert_eq!(sc, Scalar::F32);
    assert_eq!(t.terms.len(), 20); // 50, 100, ..., 1000 rpm

    let src = tmp("paper_table.rs");
    let o = cli([
        "tables",
        "--model",
        "paper",
        "--out",
        src.to_str().unwrap(),
        "--rpm-min",
        "6000",
        "--rpm-max",
        "7500",
        "--rpm-step",
        "500",
    ]);
    assert!(o.success());
    assert_eq!(
        std::fs::read_to_string(&src).unwrap(),
        include_str!("../data/paper_table.rs")
    );
}

#[test]
fn adaptive_grid_from_the_command_line() {
    let blob = tmp("adaptive.tbl");
    let o = cli([
        "tables",
        "--model",
        "paper",
        "--out",
        blob.to_str().unwrap(),
        "--adaptive",
        "1e-4",
    ]);
    assert!(o.success(), "{}", o.stderr);
    let stdout = &o.stdout;
    assert!(stdout.contains("worst check error"), "{stdout}");
    let (t, _) = ModelTable::from_blob(&std::fs::read(&blob).unwrap()).unwrap();
    assert!(t.terms.len() > 16 && t.terms.len() < 1000);
    assert_eq!(t.poles.a.len(), 4);
}

#[test]
fn bad_input_exits_2_with_one_line() {
    let out = tmp("x.tbl");
    let out = out.to_str().unwrap();
    for args in [
        vec!["tables", "--model", "nosuchmodel", "--out", out],
        vec!["tables", "--model", "paper", "--out", out, "--rpm-min", "0"],
        vec![
            "tables",
            "--model",
            "paper",
            "--out",
            out,
            "--rpm-step",
            "-5",
        ],
        vec![
            "tables",
            "--model",
            "paper",
            "--out",
            out,
            "--adaptive",
            "-1",
        ],
        vec![
            "tables",
            "--model",
            "paper",
            "--out",
            out,
            "--adaptive",
            "nan",
        ],
        vec![
            "tables",
            "--model",
            "paper",
            "--out",
            "/nonexistent-dir/x.tbl",
        ],
    ] {
        let o = cli(&args);
        assert_eq!(o.status, 2, "{args:?}");
        let err = &o.stderr;
        assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
    assert!(!std::path::Path::new(out).exists());
}
