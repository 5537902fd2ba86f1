//! Measurement noise (SPEC noise model, seeded): the errors of each model
//! structure at 0.1% and 1% noise, median over 5 seeds of the worst entry.
//! This only measures (the numbers are in the README); the assertions are
//! loose sanity bounds.

use crate::common::*;
use rotorid::core::parametrization::Structure;
use rotorid::estimate::{auto_scaling, identify_with, Options, TermsAt};
use rotorid::model::RotorModel;
use rotorid::simulate::add_noise;
use rotorid::units::rpm_to_rad_s;
use std::collections::HashMap;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2]
}

#[test]
fn noise_sensitivity_of_each_structure() {
    let m1 = RotorModel::paper();
    let m2 = RotorModel::paper_speed_dependent();
    println!("| case | structure | rows | noise | k | c | m e | phase (deg) |");
    println!("|---|---|---|---|---|---|---|---|");
    for (case, model) in [("4.1", &m1), ("4.2", &m2)] {
        let clean = simulate(model, &sweep(50.0, 15000.0, 50.0));
        let red = DenseReduction::new(model);
        let terms: HashMap<u64, TermsAt> = clean
            .samples
            .iter()
            .map(|s| (s.omega.to_bits(), red.terms(s.omega)))
            .collect();
        let runs: Vec<(Structure, f64)> = if case == "4.1" {
            vec![
                (Structure::paper(1), 0.999),
                (Structure::physical(1), 0.999),
            ]
        } else {
            vec![(Structure::paper(2), 0.99), (Structure::physical(3), 0.99)]
        };
        for (structure, lambda) in runs {
            for normalise in [false, true] {
                for noise in [0.001, 0.01] {
                    let mut errs = [vec![], vec![], vec![], vec![]];
                    for seed in 1..=5 {
                        let mut meas = clean.clone();
                        add_noise(&mut meas, noise, seed).unwrap();
                        let mut opts = Options::new(structure);
                        opts.lambda = lambda;
                        opts.normalise_rows = normalise;
                        opts.record_history = false;
                        opts.scaling = Some(auto_scaling(model, rpm_to_rad_s(15000.0)));
                        let mut src = |w: f64| Ok(terms[&w.to_bits()].clone());
                        let id = identify_with(
                            &model.bearing_nodes(),
                            &model.planes,
                            &meas,
                            &opts,
                            &mut src,
                            None,
                        )
                        .unwrap();
                        let e = errors(model, &id.last);
                        errs[0].push(e.0);
                        errs[1].push(e.1);
                        errs[2].push(e.2);
                        errs[3].push(e.3);
                    }
                    let [k, c, me, ph] = errs.map(median);
                    let name =
                        format!("{:?} {}", structure.formulation, structure.order).to_lowercase();
                    let rows = if normalise { "normalised" } else { "plain" };
                    println!(
                        "| {case} | {name} | {rows} | {:.1}% | {k:.1e} | {c:.1e} | {me:.1e} | {ph:.1e} |",
                        noise * 100.0
                    );
                    // Sanity: finite, and stiffness / unbalance not absurd.
                    assert!(k.is_finite() && c.is_finite() && me.is_finite());
                    let (k_max, me_max) = if case == "4.1" {
                        (1.0, 0.1)
                    } else {
                        (50.0, 1.0)
                    };
                    assert!(k < k_max && me < me_max, "{k} {me}");
                }
            }
        }
    }
}
