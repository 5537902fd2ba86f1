//! The firmware path (core only: f32 table blob, const-generic identifier
//! set up from the blob's structure and scaling, the `Id` type of a
//! generated table source) against the desktop path (runtime sizes, dense
//! filter, f32) on the same sweep: with the Givens block filter,
//! bit-identical estimates; with the square-root-free block filter (the
//! generated `Id`), the same to f32 round-off.

use crate::common::*;
use num_complex::Complex;
use rotorid::core::factor::Factor;
use rotorid::core::identify::{
    Config, IdField, Identifier, IdentifierError, PaperDenseIdentifier, PaperGivensIdentifier,
    PaperIdentifier, PhysicalDenseIdentifier, PhysicalGivensIdentifier, PhysicalIdentifier,
};
use rotorid::core::parametrization::Structure;
use rotorid::core::scaling::ColumnScaling;
use rotorid::core::table::TableView;
use rotorid::estimate::{auto_scaling, identify_with, EstimateSet, Options, Precision};
use rotorid::model::RotorModel;
use rotorid::reduce::ReducedTerms;
use rotorid::simulate::add_noise;
use rotorid::tables::{ModelTable, Scalar};
use rotorid::units::rpm_to_rad_s;

const NQ: usize = 4;
const NP: usize = 3;

/// The committed generated source (physical 1): its `Id` type is the
/// firmware identifier of the first test (the rest of it is unused here).
#[allow(dead_code)]
mod generated {
    include!("../data/paper_table_f32.rs");
}

/// Runs the sweep through `id`, the terms from the blob.
fn firmware_run<F: IdField<f32>, const M: usize, const N: usize, R: Factor<F>>(
    blob: &[u8],
    mut id: Identifier<f32, F, NQ, NP, M, N, R>,
    meas: &rotorid::io::measurement::Measurements,
) -> rotorid::core::identify::Estimates<f32, NQ, NP> {
    let view = TableView::<f32>::parse(blob).unwrap();
    let mut last = 0.0f32;
    for s in &meas.samples {
        let q: [Complex<f32>; NQ] =
            core::array::from_fn(|j| Complex::new(s.q[j].re as f32, s.q[j].im as f32));
        last = s.omega as f32;
        id.update(&view, last, &q).unwrap();
    }
    id.estimates(last).unwrap()
}

fn max_rel_diff(fw: &rotorid::core::identify::Estimates<f32, NQ, NP>, desk: &EstimateSet) -> f64 {
    let mut worst = 0.0f64;
    for (a, b) in fw.bearings.iter().zip(&desk.bearings) {
        for j in 0..4 {
            worst = worst.max((a.k[j] as f64 - b.k[j]).abs() / b.k[j].abs());
            worst = worst.max((a.c[j] as f64 - b.c[j]).abs() / b.c[j].abs());
        }
    }
    for (a, b) in fw.unbalance.iter().zip(&desk.unbalance) {
        let za = Complex::new(a.a.re as f64, a.a.im as f64);
        worst = worst.max((za - b.a).norm() / b.a.norm());
    }
    worst
}

/// Largest relative difference between two sets of firmware estimates.
fn max_rel_between(
    a: &rotorid::core::identify::Estimates<f32, NQ, NP>,
    b: &rotorid::core::identify::Estimates<f32, NQ, NP>,
) -> f64 {
    let rel = |x: f32, y: f32| ((x as f64 - y as f64) / y as f64).abs();
    let mut worst = 0.0f64;
    for (p, q) in a.bearings.iter().zip(&b.bearings) {
        for j in 0..4 {
            worst = worst.max(rel(p.k[j], q.k[j])).max(rel(p.c[j], q.c[j]));
        }
    }
    for (p, q) in a.unbalance.iter().zip(&b.unbalance) {
        worst = worst.max(((p.a - q.a).norm() / q.a.norm()) as f64);
    }
    worst
}

#[test]
fn firmware_and_desktop_paths_agree_in_f32() {
    let model = RotorModel::paper();
    let speeds = sweep(50.0, 15000.0, 50.0);
    let mut meas = simulate(&model, &speeds);
    add_noise(&mut meas, 0.001, 5).unwrap();
    // The table on the measurement grid, from the dense reduction.
    let red = DenseReduction::new(&model);
    let table = ModelTable {
        model_name: model.name.clone(),
        structure: Structure::physical(1),
        scaling: auto_scaling(&model, rpm_to_rad_s(15000.0)),
        n_nodes: model.n_nodes(),
        bearing_nodes: model.bearing_nodes(),
        plane_nodes: model.planes.clone(),
        poles: Default::default(),
        terms: speeds
            .iter()
            .map(|&w| {
                let (a, b) = red.terms(w);
                ReducedTerms { omega: w, a, b }
            })
            .collect(),
    };
    let scaling = auto_scaling(&model, rpm_to_rad_s(15000.0));
    let scaling32 =
        ColumnScaling::<f32>::new(scaling.stiffness, scaling.omega_ref, scaling.unbalance).unwrap();
    for structure in [Structure::physical(1), Structure::paper(1)] {
        // The blob carries the structure and the scaling; the firmware sets
        // its identifier up from the blob alone.
        let blob = table
            .clone()
            .with_structure(structure)
            .with_scaling(scaling)
            .to_blob(Scalar::F32)
            .unwrap();
        let view = TableView::<f32>::parse(&blob).unwrap();
        assert_eq!(view.scaling(), scaling32);
        // `sf`: the same with the square-root-free filter.
        let (fw, sf) = if structure == Structure::physical(1) {
            // The type the generated source defines for physical 1.
            assert_eq!(generated::STRUCTURE, structure);
            assert_eq!(generated::Id::STRUCTURE, structure);
            let id = generated::Id::from_table(&view).unwrap();
            assert_eq!(*id.config(), Config::new(structure, scaling32));
            // A blob written for another structure is refused at run time.
            assert!(matches!(
                PaperDenseIdentifier::<f32, NQ, NP, 19, 4>::from_table(&view),
                Err(IdentifierError::Structure { .. })
            ));
            // The generated `Id` is the square-root-free filter: the same
            // estimates to f32 round-off (checked below).
            let sf = firmware_run(&blob, id, &meas);
            // The Givens block filter: the desktop's kernel, bit for bit.
            let fw =
                PhysicalGivensIdentifier::<f32, NQ, NP, 22, 8, 4, 6>::from_table(&view).unwrap();
            let fw = firmware_run(&blob, fw, &meas);
            (fw, sf)
        } else {
            let sf = PaperIdentifier::<f32, NQ, NP, 19, 4, 4, 3>::from_table(&view).unwrap();
            let id = PaperGivensIdentifier::<f32, NQ, NP, 19, 4, 4, 3>::from_table(&view).unwrap();
            assert_eq!(id.config().structure, Structure::paper(1));
            let dense = PaperDenseIdentifier::<f32, NQ, NP, 19, 4>::from_table(&view).unwrap();
            // Block-structured and dense filters: the same estimates.
            let fw = firmware_run(&blob, id, &meas);
            assert_eq!(fw, firmware_run(&blob, dense, &meas));
            let sf = firmware_run(&blob, sf, &meas);
            (fw, sf)
        };
        let mut opts = Options::new(structure);
        opts.precision = Precision::F32;
        opts.scaling = Some(scaling);
        let mut src = red.source();
        let desk = identify_with(
            &model.bearing_nodes(),
            &model.planes,
            &meas,
            &opts,
            &mut src,
            None,
        )
        .unwrap();
        let diff = max_rel_diff(&fw, &desk.last);
        let e_desk = errors(&model, &desk.last);
        println!("{structure:?}: firmware vs desktop (f32) worst relative difference {diff:.2e}; desktop errors {e_desk:?}");
        // The same kernel on the same f32 data: bit-identical estimates.
        assert_eq!(diff, 0.0);
        // The square-root-free filter's f32 estimates against the f64 ones:
        // f32 round-off, of the size of the Givens filter's.
        opts.precision = Precision::F64;
        let desk64 = identify_with(
            &model.bearing_nodes(),
            &model.planes,
            &meas,
            &opts,
            &mut red.source(),
            None,
        )
        .unwrap();
        let round = max_rel_diff(&fw, &desk64.last);
        let round_sf = max_rel_diff(&sf, &desk64.last);
        let d_sf = max_rel_between(&sf, &fw);
        println!(
            "{structure:?}: f32 against f64, Givens {round:.2e}, square-root-free {round_sf:.2e}; between the two {d_sf:.2e}"
        );
        assert!(round_sf < 1.5 * round, "{round_sf:e} against {round:e}");
    }
    // The generated `Id` is the recommended alias.
    let _: fn(Config<f32>) -> Result<generated::Id, IdentifierError> =
        PhysicalIdentifier::<f32, NQ, NP, 22, 8, 4, 6>::new;
}

/// The product paths end to end: `rotorid::tables::build` (banded
/// reduction, poles) written as an f32 blob for the firmware identifier,
/// against `rotorid::estimate::identify` (banded reduction at each
/// measured speed) in f32; and the banded product path against the
/// independent dense reduction in f64.
#[test]
fn product_paths_agree() {
    let model = RotorModel::paper();
    let speeds = sweep(50.0, 15000.0, 50.0);
    let mut meas = simulate(&model, &speeds);
    add_noise(&mut meas, 0.001, 9).unwrap();
    let scaling = auto_scaling(&model, rpm_to_rad_s(15000.0));
    let blob = rotorid::tables::build(&model, &speeds)
        .unwrap()
        .to_blob(Scalar::F32)
        .unwrap();
    let config = Config::new(
        Structure::physical(1),
        ColumnScaling::<f32>::new(scaling.stiffness, scaling.omega_ref, scaling.unbalance).unwrap(),
    );
    let id = PhysicalDenseIdentifier::<f32, NQ, NP, 22, 8>::new(config).unwrap();
    let fw = firmware_run(&blob, id, &meas);
    let mut opts = Options::new(Structure::physical(1));
    opts.precision = Precision::F32;
    let desk = rotorid::estimate::identify(&model, &meas, &opts).unwrap();
    let diff = max_rel_diff(&fw, &desk.last);
    println!("tables::build blob (firmware) vs identify() (desktop), f32: {diff:.2e}");
    assert!(diff < 1e-4, "{diff}");
    // Banded (product) against dense (test) reduction, f64.
    let mut opts = Options::new(Structure::paper(1));
    opts.scaling = Some(scaling);
    let banded = rotorid::estimate::identify(&model, &meas, &opts).unwrap();
    let red = DenseReduction::new(&model);
    let mut src = red.source();
    let dense = identify_with(
        &model.bearing_nodes(),
        &model.planes,
        &meas,
        &opts,
        &mut src,
        None,
    )
    .unwrap();
    let mut worst = 0.0f64;
    for (a, b) in banded.last.bearings.iter().zip(&dense.last.bearings) {
        for j in 0..4 {
            worst = worst.max((a.k[j] - b.k[j]).abs() / b.k[j].abs());
            worst = worst.max((a.c[j] - b.c[j]).abs() / b.c[j].abs());
        }
    }
    for (a, b) in banded.last.unbalance.iter().zip(&dense.last.unbalance) {
        worst = worst.max((a.a - b.a).norm() / b.a.norm());
    }
    println!("banded vs dense reduction, identified parameters (0.1% noise, f64): {worst:.2e}");
    assert!(worst < 1e-6, "{worst}");
}
