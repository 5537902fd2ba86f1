//! A full diagnosis of a 300-speed measurement on the paper rotor (50..15000
//! rpm in 50 rpm steps, 0.1 % noise), all hypotheses included, against the
//! nominal output-error identification of the same data in the same run;
//! and its parts: the terms (one adjoint reduction per speed with every
//! node's unbalance and bow columns) and one nominal-model Jacobian pass.
//! Then the same on realistic data, the cases of the realistic confusion
//! matrix (unbalance at balance grade G6.3, 0.5 % relative noise and a
//! 0.5 um probe floor): `none`, and the three effects whose diagnoses took
//! longest (a pedestal, runout, the shaft's modulus), on the machine's
//! cores (the default) and on one (`_one_core`). Then, on one core, the
//! two other rotors of the realistic matrices (ROSS's stepped hollow shaft
//! to 12000 rpm, the rotor on three bearings to 16500 rpm, as
//! `examples/diagnose_timing.rs` makes their cases): `none`, the speed
//! law, the pedestal and runout (runout the longest case on every rotor
//! until the fits behind one at the noise, the pedestal and the speed law
//! on the three-bearing rotor since), beside the nominal output-error
//! identification of the same data; and a diameter off on a run of
//! elements (`generator::Form::Diameter`), named as a section whose ends
//! the diagnosis then weighs.
//!
//! Last, the fits' Gram matrix `J^T J` ([`rotorid::diagnose::fit::gram`],
//! its upper triangle by column blocks) beside the whole product `J^T J`
//! it replaced, at the sizes of the three-bearing rotor's fits (300
//! speeds, 6 channels: 3600 real rows; 30 and 78 parameters).
//!
//! `cargo bench --bench diagnose -- --warm-up-time 1 --measurement-time 20`
//! (the other rotors alone: add the filter `rotor_`; the Gram matrix alone:
//! `gram`)

use criterion::measurement::WallTime;
use criterion::{criterion_group, criterion_main, BenchmarkGroup, Criterion};
use rotorid::diagnose::generator::{generate, generate_form, Form};
use rotorid::diagnose::terms::StiffnessForm;
use rotorid::diagnose::{diagnose, terms, DiagnoseOptions, Effect};
use rotorid::estimate::{identify, Estimator, Options};
use rotorid::io::measurement::Measurements;
use rotorid::model::RotorModel;
use std::hint::black_box;

/// The seed of the diameter cases of the other rotors (a section named on
/// both; on the three-bearing rotor the longest of ten).
const DIAMETER_SEED: u64 = 4_000_007;

fn bench(c: &mut Criterion) {
    let model = RotorModel::paper();
    let speeds: Vec<f64> = (1..=300).map(|i| 50.0 * i as f64).collect();
    let omegas: Vec<f64> = speeds
        .iter()
        .map(|r| rotorid::units::rpm_to_rad_s(*r))
        .collect();
    let mut g = c.benchmark_group("diagnose_300_speeds");
    g.sample_size(10);
    for effect in [
        Effect::None,
        Effect::FoundationFlexibility,
        Effect::ProbeRunout,
    ] {
        let case = generate(&model, effect, 11, &speeds, Some(0.001)).expect("case");
        g.bench_function(format!("diagnose_{}", effect.name()), |b| {
            b.iter(|| {
                black_box(
                    diagnose(&model, &case.meas, &DiagnoseOptions::default()).expect("diagnose"),
                )
            })
        });
        if effect == Effect::None {
            let mut o = Options::new(rotorid::core::parametrization::Structure::physical(1));
            o.estimator = Estimator::OutputError;
            g.bench_function("baseline_identify_oe", |b| {
                b.iter(|| black_box(identify(&model, &case.meas, &o).expect("identify")))
            });
        }
    }
    let real =
        rotorid::simulate::at_balance_grade(&model, 6.3, rotorid::units::rpm_to_rad_s(15000.0))
            .expect("unbalance");
    for effect in [
        Effect::None,
        Effect::FoundationFlexibility,
        Effect::ProbeRunout,
        Effect::ShaftStiffnessError,
    ] {
        let mut case = generate(&real, effect, 11, &speeds, Some(0.005)).expect("case");
        rotorid::simulate::add_floor_noise(&mut case.meas, 0.5e-6, 11).expect("floor");
        g.bench_function(format!("diagnose_realistic_{}", effect.name()), |b| {
            b.iter(|| {
                black_box(
                    diagnose(&real, &case.meas, &DiagnoseOptions::default()).expect("diagnose"),
                )
            })
        });
        // The same on one core (the requirement's reading).
        one_core(&mut g, "", &real, &case.meas, effect);
    }
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    for (name, path, rpm_max) in [
        (
            "stepped_hollow",
            "tests/data/ross/stepped_hollow.toml",
            12000.0,
        ),
        (
            "three_bearing",
            "tests/data/rotors/three_bearing.toml",
            16500.0,
        ),
    ] {
        let file = dir.join(path);
        let base = rotorid::io::model_file::model_file_by_name_or_path(
            file.to_str().expect("a UTF-8 path"),
        )
        .expect("model file")
        .model;
        let omega_max = rotorid::units::rpm_to_rad_s(rpm_max);
        let m = rotorid::simulate::at_balance_grade(&base, 6.3, omega_max).unwrap_or(base);
        let sp: Vec<f64> = (1..=300).map(|i| rpm_max * i as f64 / 300.0).collect();
        for effect in [
            Effect::None,
            Effect::SpeedDependentBearing,
            Effect::FoundationFlexibility,
            Effect::ProbeRunout,
        ] {
            let mut case = generate(&m, effect, 11, &sp, Some(0.005)).expect("case");
            rotorid::simulate::add_floor_noise(&mut case.meas, 0.5e-6, 11).expect("floor");
            one_core(&mut g, &format!("rotor_{name}_"), &m, &case.meas, effect);
        }
        // A diameter off on a run of elements the bank's sections do not
        // hold (the machine's form): a section is named, and its ends
        // weighed (`diagnose::bank::section_ends`).
        let mut case = generate_form(
            &m,
            Effect::ShaftStiffnessError,
            Form::Diameter,
            DIAMETER_SEED,
            &sp,
            Some(0.005),
        )
        .expect("case");
        rotorid::simulate::add_floor_noise(&mut case.meas, 0.5e-6, DIAMETER_SEED).expect("floor");
        let named = diagnose(&m, &case.meas, &DiagnoseOptions::default()).expect("diagnose");
        assert!(
            matches!(named.extended().stiffness, StiffnessForm::Section { .. }),
            "{name}: the diameter case is named {}",
            named.extended().label
        );
        one_core(
            &mut g,
            &format!("rotor_{name}_diameter_"),
            &m,
            &case.meas,
            Effect::ShaftStiffnessError,
        );
    }
    g.bench_function("terms_all_nodes", |b| {
        b.iter(|| black_box(terms::build(&model, &omegas, 1.0, false).expect("terms")))
    });
    g.finish();
    gram(c);
}

/// [`rotorid::diagnose::fit::gram`] against the whole product `J^T J`
/// (mirrored, as it was formed before), the same numbers bit for bit.
fn gram(c: &mut Criterion) {
    let mut g = c.benchmark_group("gram");
    for (m, p) in [(3600, 30), (3600, 78)] {
        let mut x = 0.61_f64;
        let j = nalgebra::DMatrix::from_fn(m, p, |_, _| {
            x = (x * 997.0 + 0.377).fract();
            x - 0.5
        });
        g.bench_function(format!("gram_{m}x{p}"), |b| {
            b.iter(|| black_box(rotorid::diagnose::fit::gram(black_box(&j))))
        });
        g.bench_function(format!("gram_{m}x{p}_whole_product"), |b| {
            b.iter(|| {
                let j = black_box(&j);
                let mut w = j.transpose() * j;
                for a in 0..p {
                    for b in a + 1..p {
                        w[(b, a)] = w[(a, b)];
                    }
                }
                black_box(w)
            })
        });
    }
    g.finish();
}

/// `{prefix}diagnose_realistic_{effect}_one_core`: the diagnosis of `meas`
/// on one core; for `none` also `{prefix}baseline_identify_oe_realistic`,
/// the nominal output-error identification of the same data beside it.
fn one_core(
    g: &mut BenchmarkGroup<'_, WallTime>,
    prefix: &str,
    model: &RotorModel,
    meas: &Measurements,
    effect: Effect,
) {
    let one = DiagnoseOptions {
        threads: 1,
        ..Default::default()
    };
    g.bench_function(
        format!("{prefix}diagnose_realistic_{}_one_core", effect.name()),
        |b| b.iter(|| black_box(diagnose(model, meas, &one).expect("diagnose"))),
    );
    if effect == Effect::None {
        let mut o = Options::new(rotorid::core::parametrization::Structure::physical(1));
        o.estimator = Estimator::OutputError;
        g.bench_function(format!("{prefix}baseline_identify_oe_realistic"), |b| {
            b.iter(|| black_box(identify(model, meas, &o).expect("identify")))
        });
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
