//! Steady running: a sweep, then a long stretch at (almost) constant speed
//! with 1% noise (issue 5, item 5). Without the excitation guard the factor
//! decays in the directions the constant speed does not excite and the
//! estimates wind up; with it they stay where the sweep put them.

use crate::common::*;
use rotorid::core::identify::{SteadyAction, SteadyPolicy};
use rotorid::core::parametrization::Structure;
use rotorid::estimate::{
    auto_scaling, identify_with, EstimateSet, Identification, Options, Precision, TermsAt,
};
use rotorid::model::RotorModel;
use rotorid::simulate::add_noise;
use rotorid::units::rpm_to_rad_s;
use std::collections::HashMap;

const N_SWEEP: usize = 300;
const N_STEADY: usize = 20_000;

fn at_rest(e: &EstimateSet) -> EstimateSet {
    // Order-1 structures: coefficients do not depend on the speed.
    let mut e = e.clone();
    e.omega = 0.0;
    e
}

#[test]
fn guard_keeps_estimates_through_a_long_constant_speed_stretch() {
    let model = RotorModel::paper();
    let mut meas = simulate(&model, &sweep(50.0, 15000.0, 50.0));
    // 9000 rpm with +-2 rpm jitter: 20000 samples (hours at one sample per second or so).
    let jitter: Vec<f64> = (-2..=2).map(|d| rpm_to_rad_s(9000.0 + d as f64)).collect();
    let steady = simulate(&model, &jitter);
    for i in 0..N_STEADY {
        meas.samples
            .push(steady.samples[(i * 7) % jitter.len()].clone());
    }
    add_noise(&mut meas, 0.01, 11).unwrap();
    let red = DenseReduction::new(&model);
    let mut terms: HashMap<u64, TermsAt> = HashMap::new();
    for s in &meas.samples {
        terms
            .entry(s.omega.to_bits())
            .or_insert_with(|| red.terms(s.omega));
    }
    let run =
        |structure: Structure, precision: Precision, steady: SteadyPolicy<f64>| -> Identification {
            let mut opts = Options::new(structure);
            opts.lambda = 0.99;
            opts.precision = precision;
            opts.steady = steady;
            opts.scaling = Some(auto_scaling(&model, rpm_to_rad_s(15000.0)));
            let mut src = |w: f64| Ok(terms[&w.to_bits()].clone());
            identify_with(
                &model.bearing_nodes(),
                &model.planes,
                &meas,
                &opts,
                &mut src,
                None,
            )
            .unwrap()
        };
    let freeze = SteadyPolicy {
        action: SteadyAction::FreezeForgetting,
        ..SteadyPolicy::default_guard()
    };
    for (structure, precision) in [
        (Structure::physical(1), Precision::F64),
        (Structure::physical(1), Precision::F32),
        (Structure::paper(1), Precision::F64),
        (Structure::paper(1), Precision::F32),
    ] {
        let off = run(structure, precision, SteadyPolicy::off());
        let frz = run(structure, precision, freeze);
        let skp = run(structure, precision, SteadyPolicy::default_guard());
        let after_sweep = errors(&model, &at_rest(&frz.history[N_SWEEP - 1].estimate));
        let e_off = errors(&model, &at_rest(&off.last));
        let e_frz = errors(&model, &at_rest(&frz.last));
        let e_skp = errors(&model, &at_rest(&skp.last));
        println!(
            "{structure:?} {precision:?}: after sweep k {:.2e} c {:.2e} me {:.2e}; after {N_STEADY} steady samples: \
             no guard k {:.2e} c {:.2e} me {:.2e}; lambda=1 k {:.2e} c {:.2e} me {:.2e}; skip k {:.2e} c {:.2e} me {:.2e}",
            after_sweep.0, after_sweep.1, after_sweep.2, e_off.0, e_off.1, e_off.2, e_frz.0, e_frz.1, e_frz.2,
            e_skp.0, e_skp.1, e_skp.2
        );
        // The guard judged every steady sample unexcited (jitter < 10 rpm)
        // and no sweep sample.
        assert_eq!(frz.frozen, (N_STEADY - 1) as u64, "{}", frz.frozen);
        assert_eq!(skp.frozen, (N_STEADY - 1) as u64, "{}", skp.frozen);
        assert!(frz.history[..N_SWEEP].iter().all(|h| h.excited));
        // Without the guard: wind-up, the estimates leave.
        assert!(
            e_off.0 > 10.0 * after_sweep.0 || e_off.2 > 10.0 * after_sweep.2,
            "{e_off:?} vs {after_sweep:?}"
        );
        // lambda = 1: no wind-up; errors grow a few times at most (measured
        // 1.1-3x for k, 2-7x for m e, 2-15x for c).
        assert!(
            e_frz.0 < 5.0 * after_sweep.0 && e_frz.2 < 10.0 * after_sweep.2,
            "{e_frz:?} vs {after_sweep:?}"
        );
        assert!(
            e_frz.1 < 20.0 * after_sweep.1,
            "{e_frz:?} vs {after_sweep:?}"
        );
        assert!(
            e_off.0 > 2.0 * e_frz.0 && e_off.2 > 2.0 * e_frz.2,
            "{e_off:?} vs {e_frz:?}"
        );
        // Skip: exactly where the sweep (and the first steady sample) left them.
        assert_eq!(skp.last.unbalance, skp.history[N_SWEEP].estimate.unbalance);
        assert_eq!(
            skp.history[N_SWEEP].estimate.unbalance,
            frz.history[N_SWEEP].estimate.unbalance
        );
        for h in &frz.history {
            assert!(h
                .estimate
                .bearings
                .iter()
                .all(|b| b.k.iter().all(|x| x.is_finite())));
        }
    }
}
