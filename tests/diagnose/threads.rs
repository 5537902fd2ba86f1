//! The diagnosis on one thread and on several gives the same result, bit
//! for bit: the bank's families and the pedestal searches' screening fits
//! run side by side (`DiagnoseOptions::threads`), each reading only what
//! the nominal fit left, and their results are put together in a fixed
//! order. A realistic pedestal case on the paper rotor (balance grade
//! G6.3, 0.5 % relative noise and a 0.5 um probe floor, 300 speeds), where
//! the pedestal search runs its screening fits under both bearings.

use rotorid::diagnose::generator::generate;
use rotorid::diagnose::{diagnose, DiagnoseOptions, Diagnosis, Effect};
use rotorid::model::RotorModel;
use rotorid::simulate::{add_floor_noise, at_balance_grade};
use rotorid::units::rpm_to_rad_s;

fn run(threads: usize) -> Diagnosis {
    let model = at_balance_grade(&RotorModel::paper(), 6.3, rpm_to_rad_s(15000.0)).unwrap();
    let speeds: Vec<f64> = (1..=300).map(|i| 50.0 * i as f64).collect();
    let mut case = generate(
        &model,
        Effect::FoundationFlexibility,
        3,
        &speeds,
        Some(0.005),
    )
    .unwrap();
    add_floor_noise(&mut case.meas, 0.5e-6, 3).unwrap();
    let opts = DiagnoseOptions {
        threads,
        ..Default::default()
    };
    diagnose(&model, &case.meas, &opts).unwrap()
}

#[test]
fn the_same_on_one_thread_and_on_several() {
    let one = run(1);
    assert_eq!(one.effect, Effect::FoundationFlexibility);
    for threads in [2, 5] {
        let many = run(threads);
        assert_eq!(many.effect, one.effect);
        assert_eq!(many.chosen, one.chosen);
        assert_eq!(many.hypotheses.len(), one.hypotheses.len());
        for (a, b) in many.hypotheses.iter().zip(&one.hypotheses) {
            assert_eq!(a.label, b.label);
            assert_eq!(a.fit.s.to_bits(), b.fit.s.to_bits(), "{}", a.label);
            assert_eq!(a.fit.theta, b.fit.theta, "{}", a.label);
            assert_eq!(a.significant, b.significant);
        }
        // One lap per stage, in the same order.
        let names = |d: &Diagnosis| d.stages.iter().map(|s| s.0).collect::<Vec<_>>();
        assert_eq!(names(&many), names(&one));
    }
}
