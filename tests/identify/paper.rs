//! The method paper's section 4 reproduced on the FE model, noise-free
//! (issue 5, "What must be shown"). Sweep 50..15000 rpm in steps of 50 rpm
//! (300 speeds), data from the FE unbalance response, terms from an
//! independent dense reduction of the same FE model.

use crate::common::*;
use rotorid::core::parametrization::Structure;
use rotorid::core::scaling::ColumnScaling;
use rotorid::estimate::{auto_scaling, identify_with, Identification, Options, Precision, TermsAt};
use rotorid::io::measurement::Measurements;
use rotorid::model::RotorModel;
use rotorid::units::rpm_to_rad_s;
use std::collections::HashMap;

struct Case {
    model: RotorModel,
    meas: Measurements,
    terms: HashMap<u64, TermsAt>,
}

impl Case {
    fn new(model: RotorModel) -> Self {
        let meas = simulate(&model, &sweep(50.0, 15000.0, 50.0));
        let red = DenseReduction::new(&model);
        let terms = meas
            .samples
            .iter()
            .map(|s| (s.omega.to_bits(), red.terms(s.omega)))
            .collect();
        Case { model, meas, terms }
    }

    fn run_with(&self, meas: &Measurements, opts: &Options) -> Identification {
        let mut src = |w: f64| Ok(self.terms[&w.to_bits()].clone());
        identify_with(
            &self.model.bearing_nodes(),
            &self.model.planes,
            meas,
            opts,
            &mut src,
            None,
        )
        .unwrap()
    }

    fn run(&self, structure: Structure, lambda: f64, precision: Precision) -> Identification {
        let mut opts = Options::new(structure);
        opts.lambda = lambda;
        opts.delta = 1e-7;
        opts.precision = precision;
        opts.scaling = Some(auto_scaling(&self.model, rpm_to_rad_s(15000.0)));
        self.run_with(&self.meas, &opts)
    }
}

/// Number of speeds after which all tolerances hold until the end.
fn speeds_to_converge(
    model: &RotorModel,
    id: &Identification,
    tol: f64,
    tol_deg: f64,
) -> Option<usize> {
    let mut first = None;
    for (i, h) in id.history.iter().enumerate() {
        let (ek, ec, em, ep) = errors(model, &h.estimate);
        if ek < tol && ec < tol && em < tol && ep < tol_deg {
            first.get_or_insert(i + 1);
        } else {
            first = None;
        }
    }
    first
}

#[test]
fn case_4_1_paper_structure_f64_within_1e_6() {
    let case = Case::new(RotorModel::paper());
    let id = case.run(Structure::paper(1), 0.999, Precision::F64);
    let (ek, ec, em, ep) = errors(&case.model, &id.last);
    let n = speeds_to_converge(&case.model, &id, 1e-6, 1e-4);
    println!("4.1 paper order 1 f64: k {ek:.2e} c {ec:.2e} me {em:.2e} phase {ep:.2e} deg; within tolerance from speed {n:?} of 300");
    assert!(ek < 1e-6 && ec < 1e-6 && em < 1e-6, "{ek} {ec} {em}");
    assert!(ep < 1e-4, "{ep}");
    // With scaled unknowns the sweep needs fewer than 300 speeds (measured:
    // 169, i.e. up to ~8450 rpm).
    assert!(n.is_some_and(|n| n < 300), "{n:?}");
    // The consistency values are physically zero: |Im Z0| << |K|, |Re Z1| << |C|.
    for b in &id.last.bearings {
        let (i0, r1) = (b.im_z0.unwrap(), b.re_z1.unwrap());
        for j in 0..4 {
            assert!(i0[j].abs() < 1e-6 * 5e7, "{i0:?}");
            assert!(r1[j].abs() < 1e-6 * 500.0, "{r1:?}");
        }
    }
}

/// The paper's "slow convergence": raw SI unknowns (|w| ~ 1e8) with
/// delta = 1e-7. The prior delta lambda^n |w|^2 outweighs the data for
/// thousands of speeds; with a negligible delta the same raw run converges
/// in one sweep, so the prior, not the method (nor the conditioning in f64),
/// is the cause.
#[test]
fn case_4_1_raw_si_converges_slowly_because_of_the_prior() {
    let case = Case::new(RotorModel::paper());
    let raw = |delta: f64, cycles: usize| {
        let mut meas = case.meas.clone();
        meas.samples = (0..cycles)
            .flat_map(|_| case.meas.samples.clone())
            .collect();
        let mut opts = Options::new(Structure::paper(1));
        opts.delta = delta;
        opts.record_history = false;
        opts.scaling = Some(ColumnScaling::identity());
        let id = case.run_with(&meas, &opts);
        errors(&case.model, &id.last)
    };
    let one = raw(1e-7, 1);
    let tiny_delta = raw(1e-30, 1);
    let many = raw(1e-7, 80);
    println!("raw SI, delta 1e-7, 300 speeds: {one:?}");
    println!("raw SI, delta 1e-30, 300 speeds: {tiny_delta:?}");
    println!("raw SI, delta 1e-7, sweep repeated 80 times (24000 speeds): {many:?}");
    assert!(one.0 > 0.1 && one.1 > 1.0, "{one:?}");
    assert!(
        tiny_delta.0 < 1e-6 && tiny_delta.1 < 1e-6 && tiny_delta.2 < 1e-6,
        "{tiny_delta:?}"
    );
    assert!(many.0 < 1e-6 && many.1 < 1e-6 && many.2 < 1e-6, "{many:?}");
}

#[test]
fn case_4_1_physical_structure_f32_and_f64() {
    let case = Case::new(RotorModel::paper());
    let id = case.run(Structure::physical(1), 0.999, Precision::F32);
    let (ek, ec, em, ep) = errors(&case.model, &id.last);
    println!("4.1 physical order 1 f32: k {ek:.2e} c {ec:.2e} me {em:.2e} phase {ep:.2e} deg");
    assert!(ek < 1e-3 && em < 1e-3 && ec < 1e-2, "{ek} {ec} {em}");
    let id = case.run(Structure::physical(1), 0.999, Precision::F64);
    let (ek, ec, em, ep) = errors(&case.model, &id.last);
    let n = speeds_to_converge(&case.model, &id, 1e-6, 1e-4);
    println!("4.1 physical order 1 f64: k {ek:.2e} c {ec:.2e} me {em:.2e} phase {ep:.2e} deg; within 1e-6 from speed {n:?}");
    assert!(ek < 1e-8 && ec < 1e-8 && em < 1e-8, "{ek} {ec} {em}");
    assert!(ep < 1e-6, "{ep}");
}

#[test]
fn case_4_2_paper_order_1_damping_does_not_converge() {
    let case = Case::new(RotorModel::paper_speed_dependent());
    let id = case.run(Structure::paper(1), 0.99, Precision::F64);
    let (ek, ec, em, ep) = errors(&case.model, &id.last);
    println!(
        "4.2 paper order 1 f64 at 15000 rpm: k {ek:.2e} c {ec:.2e} me {em:.2e} phase {ep:.2e} deg"
    );
    // The paper's finding (damping wrong), and also what the SPEC notes:
    // neither stiffness nor unbalance come out right with Z0 + Omega Z1.
    assert!(ec > 1.0, "damping error {ec}");
    assert!(ek > 1e-2 && em > 1e-2, "{ek} {em}");
}

#[test]
fn case_4_2_order_2_polynomial_recovers_k_and_c() {
    let case = Case::new(RotorModel::paper_speed_dependent());
    let id = case.run(Structure::paper(2), 0.99, Precision::F64);
    let (ek, ec, em, ep) = errors(&case.model, &id.last);
    println!(
        "4.2 paper order 2 f64 at 15000 rpm: k {ek:.2e} c {ec:.2e} me {em:.2e} phase {ep:.2e} deg"
    );
    assert!(ek < 1e-4 && ec < 1e-4 && em < 1e-4, "{ek} {ec} {em}");
    // K(Omega) tracked over the upper half of the sweep too.
    for h in &id.history[150..] {
        let (ek, ec, _, _) = errors(&case.model, &h.estimate);
        assert!(ek < 1e-4 && ec < 1e-4, "at {} rad/s: {ek} {ec}", h.omega);
    }
    // Physical structure: Z_B of degree 3 in Omega (K, C quadratic).
    let id = case.run(Structure::physical(3), 0.99, Precision::F64);
    let (ek, ec, em, ep) = errors(&case.model, &id.last);
    println!("4.2 physical order 3 f64 at 15000 rpm: k {ek:.2e} c {ec:.2e} me {em:.2e} phase {ep:.2e} deg");
    assert!(ek < 1e-4 && ec < 1e-4 && em < 1e-4, "{ek} {ec} {em}");
}
