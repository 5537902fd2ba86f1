//! The output-error (maximum-likelihood) estimate against the Cramér-Rao
//! bound computed from the Fisher information at the true parameters.

use num_complex::Complex64;
use rotorid::core::parametrization::Structure;
use rotorid::estimate::output_error::{fisher_information, fit_output_error, OutputErrorOptions};
use rotorid::estimate::predictor::{Predictor, Terms};
use rotorid::estimate::{auto_scaling, identify_with, Options, Parametrization};
use rotorid::fe::assembly::FeModel;
use rotorid::io::measurement::Measurements;
use rotorid::model::RotorModel;
use rotorid::reduce::Reducer;
use rotorid::simulate::{add_noise, simulate, SimOptions};
use rotorid::tables::grid::uniform_rpm;

/// A noise-free sweep of a model with its reduced terms, the physical
/// structure's predictor and the true parameters (shared with the
/// steady-running and firmware-estimator tests).
pub(crate) struct Case {
    pub(crate) model: RotorModel,
    pub(crate) clean: Measurements,
    pub(super) terms: Vec<Terms>,
    pub(crate) predictor: Predictor,
    pub(crate) truth: Vec<f64>,
}

/// The true scaled weights of the physical structure of `order` for a
/// model whose bearings are polynomial (or constant) in speed.
fn truth_weights(p: &Parametrization, model: &RotorModel) -> Vec<Complex64> {
    use rotorid::core::parametrization::{BearingTerm, UnbalancePart, Unknown};
    use rotorid::model::BearingLaw;
    (0..p.n_unknowns())
        .map(|j| {
            let s = p.scale(j);
            let v = match p.unknown(j).unwrap() {
                Unknown::Bearing {
                    bearing,
                    row,
                    col,
                    term,
                } => {
                    let e = 2 * row + col;
                    let (k, c) = match &model.bearings[bearing].law {
                        BearingLaw::Constant(co) => (vec![co.k], vec![co.c]),
                        BearingLaw::Polynomial { k, c } => (k.clone(), c.clone()),
                        other => panic!("{other:?}"),
                    };
                    match term {
                        BearingTerm::K { power } => k.get(power).map_or(0.0, |r| r[e]),
                        BearingTerm::C { power } => c.get(power).map_or(0.0, |r| r[e]),
                        BearingTerm::Z { .. } => unreachable!(),
                    }
                }
                Unknown::Unbalance { plane, part } => {
                    let node = p.plane_nodes[plane];
                    let u = model.unbalance.iter().find(|u| u.node == node).unwrap();
                    let a = Complex64::from_polar(u.me, u.phase);
                    match part {
                        UnbalancePart::Re => a.re,
                        UnbalancePart::Im => a.im,
                        UnbalancePart::Phasor => unreachable!(),
                    }
                }
            };
            Complex64::new(v / s, 0.0)
        })
        .collect()
}

pub(crate) fn case(model: RotorModel, order: usize, rpm: Vec<f64>) -> Case {
    let clean = simulate(
        &model,
        &SimOptions {
            speeds_rpm: rpm,
            noise: 0.0,
            seed: 0,
            effects: Default::default(),
        },
    )
    .unwrap();
    let fe = FeModel::new(&model).unwrap();
    let reducer = Reducer::new(&fe, &model).unwrap();
    let terms: Vec<Terms> = clean
        .samples
        .iter()
        .map(|s| {
            let t = reducer.reduce(s.omega).unwrap();
            (t.a, t.b)
        })
        .collect();
    let omega_max = clean.samples.iter().map(|s| s.omega).fold(0.0, f64::max);
    let param = Parametrization {
        structure: Structure::physical(order),
        scaling: auto_scaling(&model, omega_max),
        bearing_nodes: model.bearing_nodes(),
        plane_nodes: model.planes.clone(),
    };
    let predictor = Predictor::new(param.clone());
    let truth = predictor.theta(&truth_weights(&param, &model));
    Case {
        model,
        clean,
        terms,
        predictor,
        truth,
    }
}

/// The bounds of the issue against the CRB, with the honesty of the
/// reported standard deviations (see `case_4_1_reaches_the_cramer_rao_bound`).
fn assert_efficient(label: &str, mc: &MonteCarlo) {
    println!(
        "{label}: RMS/CRB worst {:.2} median {:.2}; |bias|/CRB worst {:.2}; |std/spread - 1| worst {:.2}; |std/CRB - 1| worst {:.3}; pooled z {:.3}",
        mc.worst_rms, mc.median_rms, mc.worst_bias, mc.worst_std, mc.worst_std_crb, mc.pooled_z
    );
    assert!(mc.worst_rms <= 1.5, "{label}: {}", mc.worst_rms);
    assert!(mc.worst_bias < 0.5, "{label}: {}", mc.worst_bias);
    assert!((mc.pooled_z - 1.0).abs() <= 0.3, "{label}: {}", mc.pooled_z);
    assert!(mc.worst_std_crb <= 0.1, "{label}: {}", mc.worst_std_crb);
}

struct MonteCarlo {
    /// Worst over parameters of RMS error / CRB.
    worst_rms: f64,
    /// Worst |bias| / CRB.
    worst_bias: f64,
    /// Worst |reported std / MC spread - 1|.
    worst_std: f64,
    /// Worst |reported std / CRB - 1|.
    worst_std_crb: f64,
    /// `sqrt(mean((error / reported std)^2))` over every seed and parameter.
    pooled_z: f64,
    median_rms: f64,
}

fn monte_carlo(c: &Case, noise: f64, seeds: std::ops::Range<u64>, lambda: f64) -> MonteCarlo {
    let pr = &c.predictor;
    let np = pr.n_params();
    let f1 = fisher_information(pr, &c.clean.samples, &c.terms, &c.truth, 1e-6).unwrap();
    let crb_cov = f1.clone().cholesky().unwrap().inverse() * (noise * noise);
    let crb: Vec<f64> = (0..np).map(|i| crb_cov[(i, i)].sqrt()).collect();
    let n = (seeds.end - seeds.start) as f64;
    let mut err = vec![Vec::new(); np];
    let mut std = vec![Vec::new(); np];
    let mut rls_err = vec![Vec::new(); np];
    for seed in seeds {
        let mut m = c.clean.clone();
        add_noise(&mut m, noise, seed).unwrap();
        let mut opts = Options::new(pr.param.structure);
        opts.lambda = lambda;
        opts.scaling = Some(pr.param.scaling);
        opts.record_history = false;
        let lookup: std::collections::HashMap<u64, Terms> = m
            .samples
            .iter()
            .zip(&c.terms)
            .map(|(s, t)| (s.omega.to_bits(), t.clone()))
            .collect();
        let mut src = |w: f64| Ok(lookup[&w.to_bits()].clone());
        let t0 = std::time::Instant::now();
        let rls = identify_with(
            &c.model.bearing_nodes(),
            &c.model.planes,
            &m,
            &opts,
            &mut src,
            None,
        )
        .unwrap();
        let t1 = std::time::Instant::now();
        let fit = fit_output_error(
            pr,
            &m.samples,
            &c.terms,
            &rls.scaled_weights,
            &OutputErrorOptions::default(),
        )
        .unwrap();
        let _ = (t0, t1);
        let rls_theta = pr.theta(&rls.scaled_weights);
        for i in 0..np {
            rls_err[i].push(rls_theta[i] - c.truth[i]);
            err[i].push(fit.theta[i] - c.truth[i]);
            std[i].push(fit.covariance[(i, i)].sqrt());
        }
    }
    println!(
        "| parameter | true | CRB std | output-error bias | output-error std | QRD/RLS RMS error |"
    );
    println!("|---|---|---|---|---|---|");
    for i in 0..np {
        let sc = pr.param.scale(pr.params[i].unknown);
        let mean = err[i].iter().sum::<f64>() / n;
        let sd = (err[i].iter().map(|e| (e - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        let rr = (rls_err[i].iter().map(|e| e * e).sum::<f64>() / n).sqrt();
        println!(
            "| {} | {:.4e} | {:.2e} | {:+.2e} | {:.2e} | {:.2e} |",
            pr.param.name(pr.params[i].unknown),
            c.truth[i] * sc,
            crb[i] * sc,
            mean * sc,
            sd * sc,
            rr * sc
        );
    }
    let mut rms_ratio = Vec::new();
    let (mut worst_rms, mut worst_bias, mut worst_std) = (0.0f64, 0.0f64, 0.0f64);
    let mut worst_std_crb = 0.0f64;
    let mut z2 = 0.0;
    for i in 0..np {
        let mean = err[i].iter().sum::<f64>() / n;
        let rms = (err[i].iter().map(|e| e * e).sum::<f64>() / n).sqrt();
        let spread = (err[i].iter().map(|e| (e - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        let rep = std[i].iter().sum::<f64>() / n;
        println!(
            "{:>10}: crb {:.3e} rms/crb {:.2} bias/crb {:+.2} std/spread {:.2}",
            pr.param.name(pr.params[i].unknown),
            crb[i],
            rms / crb[i],
            mean / crb[i],
            rep / spread
        );
        rms_ratio.push(rms / crb[i]);
        worst_rms = worst_rms.max(rms / crb[i]);
        worst_bias = worst_bias.max((mean / crb[i]).abs());
        worst_std = worst_std.max((rep / spread - 1.0).abs());
        worst_std_crb = worst_std_crb.max((rep / crb[i] - 1.0).abs());
        z2 += err[i]
            .iter()
            .zip(&std[i])
            .map(|(e, s)| (e / s).powi(2))
            .sum::<f64>();
    }
    rms_ratio.sort_by(f64::total_cmp);
    MonteCarlo {
        worst_rms,
        worst_bias,
        worst_std,
        worst_std_crb,
        pooled_z: (z2 / (n * np as f64)).sqrt(),
        median_rms: rms_ratio[np / 2],
    }
}

/// Case 4.1 (constant bearings), 3000 speeds 5..15000 rpm, physical
/// structure of order 1, 30 seeds at 1 % noise and 30 other seeds at
/// 0.1 %: every parameter's RMS error within 1.5 CRB and its bias within
/// 0.5 CRB; the reported standard deviations honest: the errors divided by
/// them have an RMS within 30 % of 1 pooled over every seed and parameter,
/// and each is within 10 % of its CRB. (A per-parameter comparison with
/// the spread of 30 seeds cannot resolve 30 %: that spread has a relative
/// standard error of 13 %; `case_4_1_std_against_the_spread_100_seeds`
/// makes it with 100 seeds.)
#[test]
fn case_4_1_reaches_the_cramer_rao_bound() {
    let c = case(
        RotorModel::paper(),
        1,
        uniform_rpm(5.0, 15000.0, 5.0).unwrap(),
    );
    for (noise, seeds) in [(0.01, 100..130), (0.001, 200..230)] {
        let mc = monte_carlo(&c, noise, seeds, 0.999);
        assert_efficient(&format!("case 4.1, noise {noise}"), &mc);
    }
}

/// The per-parameter criterion with enough seeds to resolve it:
/// every reported standard deviation within 30 % of the Monte Carlo
/// spread over 100 seeds (relative standard error of that spread 7 %).
#[test]
#[ignore]
fn case_4_1_std_against_the_spread_100_seeds() {
    let c = case(
        RotorModel::paper(),
        1,
        uniform_rpm(5.0, 15000.0, 5.0).unwrap(),
    );
    for (noise, seeds) in [(0.01, 1000..1100), (0.001, 2000..2100)] {
        let mc = monte_carlo(&c, noise, seeds, 0.999);
        println!(
            "case 4.1, noise {noise}, 100 seeds: RMS/CRB worst {:.2}; |bias|/CRB worst {:.2}; |std/spread - 1| worst {:.2}",
            mc.worst_rms, mc.worst_bias, mc.worst_std
        );
        assert!(mc.worst_rms <= 1.5 && mc.worst_bias < 0.5 && mc.worst_std <= 0.3);
    }
}

/// Case 4.2 (stiffness as in Eq. 49), 0.1 % noise, physical order 3 (which
/// represents stiffness proportional to Omega^2), 30 seeds: the same bounds
/// against this structure's own CRB.
#[test]
#[ignore]
fn case_4_2_reaches_the_cramer_rao_bound() {
    let c = case(
        RotorModel::paper_speed_dependent(),
        3,
        uniform_rpm(5.0, 15000.0, 5.0).unwrap(),
    );
    let mc = monte_carlo(&c, 0.001, 300..330, 1.0);
    assert_efficient("case 4.2, noise 0.001", &mc);
}

/// From a start 20 % off on every parameter (alternating signs) the fit
/// reaches the same optimum as from the QRD/RLS start, within 3 CRB of the
/// truth, and says it converged.
#[test]
fn converges_from_a_start_twenty_percent_off() {
    let c = case(
        RotorModel::paper(),
        1,
        uniform_rpm(5.0, 15000.0, 5.0).unwrap(),
    );
    let pr = &c.predictor;
    let mut m = c.clean.clone();
    add_noise(&mut m, 0.01, 77).unwrap();
    let off: Vec<f64> = c
        .truth
        .iter()
        .enumerate()
        .map(|(i, t)| t * if i % 2 == 0 { 1.2 } else { 0.8 })
        .collect();
    let opts = OutputErrorOptions::default();
    let far = fit_output_error(pr, &m.samples, &c.terms, &pr.weights(&off), &opts).unwrap();
    let near = fit_output_error(pr, &m.samples, &c.terms, &pr.weights(&c.truth), &opts).unwrap();
    assert!(far.converged && near.converged);
    for i in 0..pr.n_params() {
        let sd = far.covariance[(i, i)].sqrt();
        assert!(
            (far.theta[i] - near.theta[i]).abs() <= 1e-3 * sd,
            "param {i}"
        );
        assert!((far.theta[i] - c.truth[i]).abs() <= 3.0 * sd, "param {i}");
    }
}

/// A model that cannot represent the data (physical order 2 on the
/// paper's Eq. 49 bearings, stiffness proportional to Omega^2) is not
/// presented as fine: the check warns that the residual is far above the
/// noise level.
#[test]
fn a_model_that_does_not_fit_is_reported() {
    use rotorid::estimate::{identify, Estimator};
    let model = RotorModel::paper_speed_dependent();
    let m = simulate(
        &model,
        &SimOptions {
            speeds_rpm: uniform_rpm(10.0, 15000.0, 10.0).unwrap(),
            noise: 0.001,
            seed: 5,
            effects: Default::default(),
        },
    )
    .unwrap();
    for (order, fits) in [(2, false), (3, true)] {
        let mut opts = Options::new(Structure::physical(order));
        opts.estimator = Estimator::OutputError;
        opts.record_history = false;
        let id = identify(&model, &m, &opts).unwrap();
        let check = id.check.as_ref().unwrap();
        let chi2 = check.chi2_per_dof.unwrap();
        println!(
            "physical {order}: chi2/dof {chi2:.3}, warnings {:?}",
            check.warnings
        );
        if fits {
            assert!(chi2 < 1.3, "{chi2}");
            assert!(check.warnings.is_empty(), "{:?}", check.warnings);
        } else {
            assert!(chi2 > 100.0, "{chi2}");
            assert!(
                check
                    .warnings
                    .iter()
                    .any(|w| w.contains("the model lacks something")),
                "{:?}",
                check.warnings
            );
        }
        let json = serde_json::to_value(id.result()).unwrap();
        assert_eq!(json["estimator"], "oe");
        assert!(json["noise_level"].as_f64().unwrap() > 0.0);
        assert_eq!(json["warnings"].as_array().unwrap().is_empty(), fits);
    }
}

/// The design analysis: with the whole sweep every parameter of case 4.1
/// is determined at 1 % noise; a test that stays below 3000 rpm (far below
/// the critical speeds) cannot determine the damping, and the analysis says
/// so; the gain it promises for twice the speeds in a band is what the
/// Fisher information of the doubled test gives.
#[test]
fn the_design_analysis_names_what_the_speeds_cannot_determine() {
    use rotorid::estimate::design::analyse;
    let full = case(
        RotorModel::paper(),
        1,
        uniform_rpm(50.0, 15000.0, 50.0).unwrap(),
    );
    let d = analyse(
        &full.predictor,
        &full.clean.samples,
        &full.terms,
        &full.truth,
        0.01,
    )
    .unwrap();
    assert!(
        d.notes.iter().all(|n| !n.contains("do not determine")),
        "{:?}",
        d.notes
    );
    // The CRB of the analysis is the one of the Monte Carlo test.
    let f = fisher_information(
        &full.predictor,
        &full.clean.samples,
        &full.terms,
        &full.truth,
        1e-6,
    )
    .unwrap();
    let cov = f.cholesky().unwrap().inverse();
    for (i, p) in d.parameters.iter().enumerate() {
        let s = full.predictor.param.scale(full.predictor.params[i].unknown);
        assert!((p.crb - 0.01 * cov[(i, i)].sqrt() * s).abs() <= 1e-9 * p.crb);
    }
    let low = case(
        RotorModel::paper(),
        1,
        uniform_rpm(500.0, 3000.0, 25.0).unwrap(),
    );
    let d = analyse(
        &low.predictor,
        &low.clean.samples,
        &low.terms,
        &low.truth,
        0.01,
    )
    .unwrap();
    let undetermined: Vec<&String> = d
        .notes
        .iter()
        .filter(|n| n.contains("do not determine"))
        .collect();
    println!("{undetermined:?}");
    assert!(
        undetermined.iter().any(|n| n.contains(" C0")),
        "{:?}",
        d.notes
    );
}

/// Data that cannot determine some parameters say which: a test between
/// 500 and 3000 rpm (far below the critical speeds, 1 % noise) sees the
/// stiffness and the unbalance of node 21 but not the damping, and
/// `identify` names every damping coefficient in a warning (JSON
/// `warnings` too) and none of the well-determined parameters; over the
/// whole speed range (`a_model_that_does_not_fit_is_reported`, order 3)
/// nothing is named.
#[test]
fn identify_names_the_parameters_the_data_leave_undetermined() {
    use rotorid::estimate::{identify, Estimator};
    let model = RotorModel::paper();
    let m = simulate(
        &model,
        &SimOptions {
            speeds_rpm: uniform_rpm(500.0, 3000.0, 25.0).unwrap(),
            noise: 0.01,
            seed: 11,
            effects: Default::default(),
        },
    )
    .unwrap();
    let mut opts = Options::new(Structure::physical(1));
    opts.estimator = Estimator::OutputError;
    opts.record_history = false;
    let id = identify(&model, &m, &opts).unwrap();
    let design = id
        .refinement
        .as_ref()
        .and_then(|r| r.design.as_ref())
        .unwrap();
    println!("undetermined: {:?}", design.undetermined);
    let warnings = &id.check.as_ref().unwrap().warnings;
    let named: Vec<&String> = warnings
        .iter()
        .filter(|w| w.starts_with("these data do not determine"))
        .collect();
    assert_eq!(named.len(), 1, "{warnings:?}");
    let line = named[0];
    // The names as the warning lists them, between "determine " and ":".
    let list: Vec<&str> = line["these data do not determine ".len()..]
        .split(':')
        .next()
        .unwrap()
        .split(", ")
        .collect();
    assert_eq!(list, design.undetermined, "{line}");
    for b in 1..=2 {
        for e in ["yy", "yz", "zy", "zz"] {
            let c = format!("b{b} C0{e}");
            let k = format!("b{b} K0{e}");
            assert!(list.contains(&c.as_str()), "{c} not named: {line}");
            assert!(!list.contains(&k.as_str()), "{k} named: {line}");
        }
    }
    for a in ["n21 Re a", "n21 Im a"] {
        assert!(!list.contains(&a), "{a} named: {line}");
    }
    let json = serde_json::to_value(id.result()).unwrap();
    assert!(json["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .any(|w| w.as_str() == Some(line.as_str())));
}
