//! The Rust-source table format: the committed files in `tests/data/` are
//! `include!`d (so they are compile-checked), must equal what the generator
//! writes today (so they cannot drift), and must give the same lookups as a
//! freshly built table.
//!
//! Regenerate after an intended change of the FE model or the format with
//! `ROTORID_BLESS=1 cargo test --test lib tables::source`, or equivalently
//! `cargo run -- tables --model paper --rpm-min 6000 --rpm-max 7500 --rpm-step 500 --out tests/data/paper_table.rs`
//! (and `--f32 --out tests/data/paper_table_f32.rs`).

use rotorid::core::parametrization::Structure;
use rotorid::core::scaling::ColumnScaling;
use rotorid::core::table::{BearingTable, TableView, Terms};
use rotorid::estimate::auto_scaling;
use rotorid::model::RotorModel;
use rotorid::tables::grid::uniform_rad_s;
use rotorid::tables::{build, ModelTable, Scalar};

mod paper64 {
    include!("../data/paper_table.rs");
}
mod paper32 {
    include!("../data/paper_table_f32.rs");
}

/// The compile-time side of a blob of the same table, from its header's
/// scalar type, structure, bearings and planes.
mod blob32 {
    rotorid::core::identifier_types!(f32, physical(1), bearings: 2, planes: 3);
}
/// The same, generic over the scalar type.
mod blob {
    rotorid::core::identifier_types!(<T>, physical(1), bearings: 2, planes: 3);
}

/// The table the committed files were generated from: the paper rotor at
/// 6000, 6500, 7000, 7500 rpm (around the poles near 6808 and 6860 rpm).
fn fresh() -> ModelTable {
    build(
        &RotorModel::paper(),
        &uniform_rad_s(6000.0, 7500.0, 500.0).unwrap(),
    )
    .unwrap()
}

fn check_file(path: &str, committed: &str, generated: &str) {
    if std::env::var_os("ROTORID_BLESS").is_some() {
        let full = format!("{}/tests/data/{path}", env!("CARGO_MANIFEST_DIR"));
        std::fs::write(&full, generated).unwrap();
        return;
    }
    assert!(
        committed == generated,
        "tests/data/{path} differs from the generator's output; regenerate it (see this file's docs)"
    );
}

#[test]
fn committed_sources_equal_the_generator_output() {
    let t = fresh();
    check_file(
        "paper_table.rs",
        include_str!("../data/paper_table.rs"),
        &t.to_rust_source(Scalar::F64).unwrap(),
    );
    check_file(
        "paper_table_f32.rs",
        include_str!("../data/paper_table_f32.rs"),
        &t.to_rust_source(Scalar::F32).unwrap(),
    );
}

/// A firmware that reads the blob gets the source's constants and `Id`
/// from `identifier_types!`, and that `Id` set up from the blob is the one
/// set up from the source's `TABLE`.
#[test]
fn a_blob_gets_the_constants_of_the_source() {
    let t = fresh();
    let bytes = t.to_blob(Scalar::F32).unwrap();
    let view = TableView::<f32>::parse(&bytes).unwrap();
    assert_eq!(
        (view.structure(), view.n_channels(), view.n_planes()),
        (blob32::STRUCTURE, blob32::NQ, blob32::NP)
    );
    let sizes = (
        blob32::STRUCTURE,
        blob32::NQ,
        blob32::NP,
        blob32::M,
        blob32::N,
        blob32::W,
        blob32::S,
    );
    for source in [
        (
            paper32::STRUCTURE,
            paper32::NQ,
            paper32::NP,
            paper32::M,
            paper32::N,
            paper32::W,
            paper32::S,
        ),
        (
            paper64::STRUCTURE,
            paper64::NQ,
            paper64::NP,
            paper64::M,
            paper64::N,
            paper64::W,
            paper64::S,
        ),
        (
            blob::STRUCTURE,
            blob::NQ,
            blob::NP,
            blob::M,
            blob::N,
            blob::W,
            blob::S,
        ),
    ] {
        assert_eq!(source, sizes);
    }
    // The same types.
    let same32: fn(blob32::Id) -> paper32::Id = |id| id;
    let _: fn(blob::Id<f64>) -> paper64::Id = |id| id;
    let _: fn(blob::Id<f32>) -> blob32::Id = |id| id;
    let from_blob = same32(blob32::Id::from_table(&view).unwrap());
    assert_eq!(from_blob, paper32::Id::from_table(&paper32::TABLE).unwrap());
}

#[test]
fn included_tables_equal_the_blob_bit_for_bit() {
    let t = fresh();
    assert_eq!(paper64::N_NODES, 27);
    assert_eq!(paper64::BEARING_NODES, [1, 27]);
    assert_eq!(paper64::PLANE_NODES, [5, 11, 21]);
    assert_eq!(paper32::BEARING_NODES, paper64::BEARING_NODES);
    assert_eq!(paper32::PLANE_NODES, paper64::PLANE_NODES);
    assert_eq!(paper32::N_NODES, paper64::N_NODES);
    paper64::TABLE.validate().unwrap();
    paper32::TABLE.validate().unwrap();
    // The identification set-up: the default structure, the scaling at the
    // top of the grid, the identifier type and its sizes.
    let top = *t.speeds().last().unwrap();
    let scaling = auto_scaling(&RotorModel::paper(), top);
    assert_eq!(t.scaling, scaling);
    assert_eq!(paper64::STRUCTURE, Structure::physical(1));
    assert_eq!(paper32::STRUCTURE, Structure::physical(1));
    assert_eq!(paper64::SCALING, scaling);
    assert_eq!(
        paper32::SCALING,
        ColumnScaling::<f32>::new(scaling.stiffness, scaling.omega_ref, scaling.unbalance).unwrap()
    );
    assert_eq!(paper64::TABLE.structure, paper64::STRUCTURE);
    assert_eq!(paper32::TABLE.scaling, paper32::SCALING);
    assert_eq!(
        (
            paper64::NQ,
            paper64::NP,
            paper64::NS,
            paper64::M,
            paper64::N
        ),
        (4, 3, 4, 22, 8)
    );
    assert_eq!(paper32::Id::STRUCTURE, paper32::STRUCTURE);
    assert_eq!(paper64::Id::ORDER, 1);
    let id = paper32::Id::from_table(&paper32::TABLE).unwrap();
    assert_eq!(id.config().scaling, paper32::SCALING);
    assert_eq!(paper64::TABLE.n_poles_a, t.poles.a.len());
    assert_eq!(paper64::TABLE.n_poles_b, t.poles.b.len());
    assert!(
        t.poles.a.len() >= 2 && t.poles.b.len() < t.poles.a.len(),
        "{:?}",
        t.poles
    );

    let b64 = t.to_blob(Scalar::F64).unwrap();
    let v64 = TableView::<f64>::parse(&b64).unwrap();
    let b32 = t.to_blob(Scalar::F32).unwrap();
    let v32 = TableView::<f32>::parse(&b32).unwrap();
    // The owned tables built from the blobs equal the included ones exactly.
    let own64 = rotorid::core::table::Table::<f64, 4, 3, 4>::from_view(&v64).unwrap();
    let own32 = rotorid::core::table::Table::<f32, 4, 3, 4>::from_view(&v32).unwrap();
    assert_eq!(own64, paper64::TABLE);
    assert_eq!(own32, paper32::TABLE);

    // Lookups agree everywhere, at grid speeds and between (across the poles).
    let (lo, hi) = BearingTable::<f64, 4, 3>::speed_range(&paper64::TABLE);
    for k in 0..=300 {
        let w = lo + (hi - lo) * k as f64 / 300.0;
        let x: Result<Terms<f64, 4, 3>, _> = paper64::TABLE.terms(w);
        let y: Result<Terms<f64, 4, 3>, _> = v64.terms(w);
        assert_eq!(x, y);
        let x: Result<Terms<f32, 4, 3>, _> = paper32::TABLE.terms(w as f32);
        let y: Result<Terms<f32, 4, 3>, _> = v32.terms(w as f32);
        assert_eq!(x, y);
    }
}
