//! The output-error fit of a 3000-speed sweep (case 4.1, 5..15000 rpm in
//! 5 rpm steps, 1 % noise, physical structure of order 1: 22 parameters)
//! against the QRD/RLS sweep over the same data in the same run, and the
//! parts of the fit: one prediction pass with the Jacobian and normal
//! equations, and the model-free noise level.
//!
//! Beside them, the fit under the probe noise model of SPEC section 7 (the
//! paper rotor at balance grade G6.3, 0.5 % relative noise plus a 0.5 um
//! floor, 3000 speeds): floor and relative part estimated and refined,
//! outliers sought; on data without runout, and on data with 5 um of runout
//! on every channel with runout unknowns (and there the proportional fit,
//! which cannot describe such data, as a baseline of what it costs).
//!
//! `cargo bench --bench output_error -- --warm-up-time 1 --measurement-time 5`

use criterion::{criterion_group, criterion_main, Criterion};
use rotorid::core::parametrization::Structure;
use rotorid::estimate::noise::estimate_noise;
use rotorid::estimate::noise::relative_noise_level;
use rotorid::estimate::output_error::{
    fisher_information, fit_output_error, fit_output_error_with, FitNoise, OutputErrorOptions,
};
use rotorid::estimate::predictor::{Predictor, Terms};
use rotorid::estimate::{auto_scaling, identify_with, Options, Parametrization};
use rotorid::fe::assembly::FeModel;
use rotorid::io::measurement::Measurements;
use rotorid::model::RotorModel;
use rotorid::reduce::Reducer;
use rotorid::simulate::{simulate, SimOptions};
use rotorid::tables::grid::uniform_rpm;
use std::hint::black_box;

struct Setup {
    model: RotorModel,
    meas: Measurements,
    terms: Vec<Terms>,
    predictor: Predictor,
    options: Options,
}

fn setup() -> Setup {
    setup_of(RotorModel::paper(), 0.01, 0.0, 0.0)
}

/// The paper rotor at G6.3 with 0.5 % + 0.5 um noise and `runout` (m) on
/// every channel.
fn setup_real(runout: f64) -> Setup {
    let model = rotorid::simulate::at_balance_grade(
        &RotorModel::paper(),
        6.3,
        rotorid::units::rpm_to_rad_s(15000.0),
    )
    .expect("unbalance");
    setup_of(model, 0.005, 5e-7, runout)
}

fn setup_of(model: RotorModel, noise: f64, floor: f64, runout: f64) -> Setup {
    let mut effects = rotorid::model::extension::Effects::default();
    if runout > 0.0 {
        effects.runout = rotorid::simulate::random_runout(2, runout, 7);
    }
    let mut meas = simulate(
        &model,
        &SimOptions {
            speeds_rpm: uniform_rpm(5.0, 15000.0, 5.0).expect("grid"),
            noise,
            seed: 1,
            effects,
        },
    )
    .expect("simulate");
    rotorid::simulate::add_floor_noise(&mut meas, floor, 1).expect("floor");
    let fe = FeModel::new(&model).expect("model");
    let reducer = Reducer::new(&fe, &model).expect("reducer");
    let terms: Vec<Terms> = meas
        .samples
        .iter()
        .map(|s| {
            let t = reducer.reduce(s.omega).expect("terms");
            (t.a, t.b)
        })
        .collect();
    let omega_max = meas.samples.iter().map(|s| s.omega).fold(0.0, f64::max);
    let param = Parametrization {
        structure: Structure::physical(1),
        scaling: auto_scaling(&model, omega_max),
        bearing_nodes: model.bearing_nodes(),
        plane_nodes: model.planes.clone(),
    };
    let mut options = Options::new(param.structure);
    options.scaling = Some(param.scaling);
    options.record_history = false;
    Setup {
        model,
        meas,
        terms,
        predictor: Predictor::new(param),
        options,
    }
}

fn bench(c: &mut Criterion) {
    let s = setup();
    let rls = |s: &Setup| {
        let mut i = 0;
        let mut src = |_w: f64| {
            i += 1;
            Ok(s.terms[i - 1].clone())
        };
        identify_with(
            &s.model.bearing_nodes(),
            &s.model.planes,
            &s.meas,
            &s.options,
            &mut src,
            None,
        )
        .expect("rls")
    };
    let start = rls(&s).scaled_weights;
    let mut g = c.benchmark_group("3000 speeds, 22 parameters");
    g.sample_size(10);
    g.bench_function("QRD/RLS sweep (baseline)", |b| {
        b.iter(|| black_box(rls(&s)))
    });
    g.bench_function("output-error fit", |b| {
        b.iter(|| {
            black_box(
                fit_output_error(
                    &s.predictor,
                    &s.meas.samples,
                    &s.terms,
                    &start,
                    &OutputErrorOptions::default(),
                )
                .expect("fit"),
            )
        })
    });
    let theta = s.predictor.theta(&start);
    g.bench_function("one pass: predictions, Jacobian, normal equations", |b| {
        b.iter(|| {
            black_box(
                fisher_information(&s.predictor, &s.meas.samples, &s.terms, &theta, 1e-6)
                    .expect("pass"),
            )
        })
    });
    g.bench_function("noise level without the model", |b| {
        b.iter(|| black_box(relative_noise_level(&s.meas.samples)))
    });
    // The probe noise model: the same fit on realistic data, without
    // runout and with 5 um of runout on every channel.
    let f = setup_real(0.0);
    let reference_f = estimate_noise(&f.meas.samples, None);
    let start_f = rls(&f).scaled_weights;
    let noise = FitNoise {
        model: reference_f.clone(),
        refine: true,
        outliers: true,
        reference: reference_f.clone(),
        ..Default::default()
    };
    g.bench_function("output-error fit, probe noise model", |b| {
        b.iter(|| {
            black_box(
                fit_output_error_with(
                    &f.predictor,
                    &f.meas.samples,
                    &f.terms,
                    &start_f,
                    &OutputErrorOptions::default(),
                    &noise,
                )
                .expect("fit"),
            )
        })
    });
    let r = setup_real(5e-6);
    let reference = estimate_noise(&r.meas.samples, None);
    let runout = rotorid::estimate::slow_roll_estimate(&r.meas.samples).expect("slow roll");
    let mut shifted = r.meas.clone();
    for smp in &mut shifted.samples {
        for (q, z) in smp.q.iter_mut().zip(&runout.runout) {
            *q -= z;
        }
    }
    let start_real = rls(&Setup {
        meas: shifted,
        ..setup_of_clone(&r)
    })
    .scaled_weights;
    {
        let noise = FitNoise {
            model: reference.clone(),
            refine: true,
            outliers: true,
            runout: Some(runout.runout.clone()),
            reference: reference.clone(),
            ..Default::default()
        };
        g.bench_function("output-error fit, probe noise model and runout", |b| {
            b.iter(|| {
                black_box(
                    fit_output_error_with(
                        &r.predictor,
                        &r.meas.samples,
                        &r.terms,
                        &start_real,
                        &OutputErrorOptions::default(),
                        &noise,
                    )
                    .expect("fit"),
                )
            })
        });
    }
    g.bench_function(
        "output-error fit, proportional weights, same data (baseline)",
        |b| {
            b.iter(|| {
                black_box(
                    fit_output_error(
                        &r.predictor,
                        &r.meas.samples,
                        &r.terms,
                        &start_real,
                        &OutputErrorOptions::default(),
                    )
                    .expect("fit"),
                )
            })
        },
    );
    g.bench_function("probe noise model without the model", |b| {
        b.iter(|| black_box(estimate_noise(&r.meas.samples, None)))
    });
    g.finish();
}

fn setup_of_clone(s: &Setup) -> Setup {
    Setup {
        model: s.model.clone(),
        meas: s.meas.clone(),
        terms: s.terms.clone(),
        predictor: s.predictor.clone(),
        options: s.options.clone(),
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
