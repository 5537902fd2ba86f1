//! `rotorid tables` end to end: blob (f64, f32), Rust source, adaptive grid,
//! and bad input (exit status 2, one line on stderr, no file).

use crate::common::{cli, tmp};
use rotorid::core::identify::PaperIdentifier;
use rotorid::core::parametrization::Structure;
use rotorid::core::table::TableView;
use rotorid::estimate::auto_scaling;
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

/// `--formulation paper --order 2`: the blob's header and the source's
/// constants name the structure and the scaling (`auto_scaling` at the top
/// of the grid), and the source's `Id` is the paper identifier of order 2.
#[test]
fn structure_and_scaling_from_the_command_line() {
    let blob = tmp("paper2.tbl");
    let src = tmp("paper2.rs");
    for out in [&blob, &src] {
        let o = cli([
            "tables",
            "--model",
            "paper",
            "--out",
            out.to_str().unwrap(),
            "--rpm-min",
            "6000",
            "--rpm-max",
            "7500",
            "--rpm-step",
            "500",
            "--formulation",
            "paper",
            "--order",
            "2",
        ]);
        assert!(o.success(), "{}", o.stderr);
        assert!(o.stdout.contains("paper 2"), "{}", o.stdout);
        // A blob's summary gives the firmware its types (the macro's own
        // doctest compiles the same invocation).
        let types = "firmware types for this blob: \
                     rotorid_core::identifier_types!(f64, paper(2), bearings: 2, planes: 3);";
        assert_eq!(o.stdout.contains(types), out == &blob, "{}", o.stdout);
    }
    let model = RotorModel::paper();
    let speeds = uniform_rad_s(6000.0, 7500.0, 500.0).unwrap();
    let scaling = auto_scaling(&model, *speeds.last().unwrap());
    let bytes = std::fs::read(&blob).unwrap();
    let view = TableView::<f64>::parse(&bytes).unwrap();
    assert_eq!(view.structure(), Structure::paper(2));
    assert_eq!(view.scaling(), scaling);
    let lib = build(&model, &speeds)
        .unwrap()
        .with_structure(Structure::paper(2));
    assert_eq!(lib.to_blob(Scalar::F64).unwrap(), bytes);
    let text = std::fs::read_to_string(&src).unwrap();
    assert_eq!(text, lib.to_rust_source(Scalar::F64).unwrap());
    for line in [
        "pub const STRUCTURE: rotorid_core::parametrization::Structure = rotorid_core::parametrization::Structure::paper(2);".to_string(),
        format!(
            "pub const SCALING: rotorid_core::scaling::ColumnScaling<f64> = rotorid_core::scaling::ColumnScaling {{ stiffness: {:?}, omega_ref: {:?}, unbalance: {:?} }};",
            scaling.stiffness, scaling.omega_ref, scaling.unbalance
        ),
        "pub const M: usize = STRUCTURE.n_unknowns(NQ / 2, NP);".to_string(),
        "pub const W: usize = rotorid_core::blockqrd::BlockShape::of(STRUCTURE, NQ / 2, NP).width;".to_string(),
        "pub type Id = rotorid_core::identify::PaperIdentifier<f64, NQ, NP, M, N, W, S>;".to_string(),
    ] {
        assert!(text.lines().any(|l| l == line), "missing: {line}");
    }
    // The type the source names for paper 2 (M = 4 (P+1) N_b + N_p = 27,
    // W = 2 (P+1) = 6, S = N_p = 3) takes its set-up from the blob.
    let id = PaperIdentifier::<f64, 4, 3, 27, 4, 6, 3>::from_table(&view).unwrap();
    assert_eq!(PaperIdentifier::<f64, 4, 3, 27, 4, 6, 3>::ORDER, 2);
    assert_eq!(id.config().scaling, scaling);
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
        vec!["tables", "--model", "paper", "--out", out, "--order", "0"],
        vec!["tables", "--model", "paper", "--out", out, "--order", "9"],
        vec![
            "tables",
            "--model",
            "paper",
            "--out",
            out,
            "--formulation",
            "complex",
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
