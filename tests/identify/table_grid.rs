//! How fine must the firmware's table be? The f32 firmware identifier
//! (physical structure) on the 50-rpm paper sweep, with tables on coarser
//! uniform grids and on adaptive grids (interpolated between grid speeds),
//! against the table at the measured speeds. Measures (numbers in the
//! README); asserts that the exact-speed table and a tight adaptive grid
//! meet the f32 tolerances of case 4.1.

use crate::common::*;
use num_complex::Complex;
use rotorid::core::identify::{Config, PhysicalDenseIdentifier, SteadyPolicy};
use rotorid::core::parametrization::{BearingEstimate, Structure, UnbalanceEstimate};
use rotorid::core::scaling::ColumnScaling;
use rotorid::core::table::TableView;
use rotorid::estimate::{auto_scaling, EstimateSet};
use rotorid::model::RotorModel;
use rotorid::tables::grid::AdaptiveOptions;
use rotorid::tables::{build, build_adaptive, ModelTable, Scalar};
use rotorid::units::rpm_to_rad_s;

fn firmware_errors(
    model: &RotorModel,
    table: &ModelTable,
    meas: &rotorid::io::measurement::Measurements,
) -> (f64, f64, f64, f64) {
    let blob = table.to_blob(Scalar::F32).unwrap();
    let view = TableView::<f32>::parse(&blob).unwrap();
    let s = auto_scaling(model, rpm_to_rad_s(15000.0));
    let config = Config {
        structure: Structure::physical(1),
        lambda: 0.999f32,
        delta: 1e-7f32,
        scaling: ColumnScaling::<f32>::new(s.stiffness, s.omega_ref, s.unbalance).unwrap(),
        normalise_rows: false,
        steady: SteadyPolicy::default_guard(),
    };
    let mut id = PhysicalDenseIdentifier::<f32, 4, 3, 22, 8>::new(config).unwrap();
    for smp in &meas.samples {
        let q: [Complex<f32>; 4] =
            core::array::from_fn(|j| Complex::new(smp.q[j].re as f32, smp.q[j].im as f32));
        id.update(&view, smp.omega as f32, &q).unwrap();
    }
    let e = id.estimates(0.0).unwrap();
    let set = EstimateSet {
        omega: rpm_to_rad_s(15000.0),
        bearings: e
            .bearings
            .iter()
            .map(|b| BearingEstimate {
                k: b.k.map(f64::from),
                c: b.c.map(f64::from),
                im_z0: None,
                re_z1: None,
            })
            .collect(),
        unbalance: e
            .unbalance
            .iter()
            .map(|u| UnbalanceEstimate::from_phasor(Complex::new(u.a.re as f64, u.a.im as f64)))
            .collect(),
    };
    errors(model, &set)
}

#[test]
fn identification_error_against_table_grid() {
    let model = RotorModel::paper();
    let speeds = sweep(50.0, 15000.0, 50.0);
    let meas = simulate(&model, &speeds);
    let exact = firmware_errors(&model, &build(&model, &speeds).unwrap(), &meas);
    println!(
        "table at the measured speeds ({} speeds): {exact:?}",
        speeds.len()
    );
    assert!(exact.0 < 1e-3 && exact.1 < 1e-2 && exact.2 < 1e-3);
    let mut prev_c = f64::INFINITY;
    for step in [500.0, 250.0, 100.0] {
        let grid: Vec<f64> = std::iter::once(rpm_to_rad_s(50.0))
            .chain((1..=(15000.0 / step) as usize).map(|i| rpm_to_rad_s(step * i as f64)))
            .collect();
        let e = firmware_errors(&model, &build(&model, &grid).unwrap(), &meas);
        println!("uniform {step} rpm grid ({} speeds): {e:?}", grid.len());
        prev_c = prev_c.min(e.1);
    }
    for tol in [1e-4, 1e-6] {
        let opts = AdaptiveOptions {
            tol,
            ..AdaptiveOptions::new(tol)
        };
        let (table, summary) =
            build_adaptive(&model, rpm_to_rad_s(50.0), rpm_to_rad_s(15000.0), opts).unwrap();
        let e = firmware_errors(&model, &table, &meas);
        println!(
            "adaptive tol {tol:e} ({} speeds, worst check error {:.1e}): {e:?}",
            table.terms.len(),
            summary.check.worst_error
        );
        if tol == 1e-6 {
            // A tight adaptive grid does as well as the exact-speed table
            // (the f32 tolerances of case 4.1) and better than any uniform
            // grid tried.
            assert!(e.0 < 1e-3 && e.1 < 1e-2 && e.2 < 1e-3, "{e:?}");
            assert!(e.1 <= prev_c, "{} vs {prev_c}", e.1);
        }
    }
}
