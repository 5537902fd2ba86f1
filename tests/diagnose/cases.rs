//! Generated cases (`rotorid::diagnose::generator`): the test does not tell
//! `diagnose` what was hidden.

use std::time::Instant;

use rotorid::diagnose::generator::generate;
use rotorid::diagnose::{diagnose, DiagnoseOptions, Effect};
use rotorid::model::RotorModel;

fn speeds() -> Vec<f64> {
    (1..=300).map(|i| 50.0 * i as f64).collect()
}

/// Exploration: one case per effect, printed.
#[test]
#[ignore]
fn explore() {
    let m = RotorModel::paper();
    let sp = speeds();
    for (k, effect) in std::iter::once(Effect::None)
        .chain(Effect::BANK)
        .enumerate()
    {
        for seed in 0..3u64 {
            let case = generate(&m, effect, 1000 * k as u64 + seed, &sp, Some(0.001)).unwrap();
            let t = Instant::now();
            let d = diagnose(&m, &case.meas, &DiagnoseOptions::default()).unwrap();
            println!(
                "hidden {:<24} ({}) -> {:<24} nominal {:.2e} extended {:.2e} noise {:?} [{:.2} s]",
                effect.name(),
                case.hidden.description,
                d.effect.name(),
                d.residual_nominal(),
                d.residual_extended(),
                d.noise_level,
                t.elapsed().as_secs_f64()
            );
            for h in d.hypotheses.iter().filter(|_| d.effect != effect) {
                println!(
                    "    {:<50} res {:.2e} stat {:10.1} thr {:6.1} sig {} P {}",
                    h.label,
                    h.residual(),
                    h.statistic,
                    h.threshold,
                    h.significant,
                    h.fit.n_params()
                );
            }
            if d.effect != effect {
                println!("    findings {:?}", d.findings());
            }
        }
    }
}

#[test]
#[ignore]
fn time_terms() {
    let m = RotorModel::paper();
    let om: Vec<f64> = speeds()
        .iter()
        .map(|r| rotorid::units::rpm_to_rad_s(*r))
        .collect();
    for _ in 0..3 {
        let t = Instant::now();
        let _ = rotorid::diagnose::terms::build(&m, &om, 1.0, false).unwrap();
        println!("terms {:?}", t.elapsed());
    }
}
