//! Estimates on data as probes give them (SPEC section 7): the paper rotor
//! with its unbalance at balance grade G6.3, 0.5 % relative noise plus a
//! probe noise floor, through the library's front door (`identify`, the
//! output-error estimator), against the Cramér-Rao bound of that composite
//! noise model at the true parameters.

use num_complex::Complex64;
use rotorid::estimate::noise::{NoiseModel, NoiseSource};
use rotorid::estimate::output_error::{fisher_information_weighted, Weighting};
use rotorid::estimate::{identify, Estimator, Options, RunoutHandling};
use rotorid::io::measurement::Measurements;
use rotorid::model::RotorModel;
use rotorid::simulate::{add_floor_noise, add_glitches, add_noise, add_runout, at_balance_grade};
use rotorid::tables::grid::uniform_rpm;
use rotorid::units::rpm_to_rad_s;

use super::output_error::{case, Case};

/// The paper rotor at balance grade G6.3 at 15000 rpm (its unbalance / 43).
pub(crate) fn g63_paper() -> RotorModel {
    at_balance_grade(&RotorModel::paper(), 6.3, rpm_to_rad_s(15000.0)).unwrap()
}

/// Relative noise of every sweep here.
const S: f64 = 5e-3;

/// How the noise is handed to the identification.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Floor {
    /// Estimated from the data.
    Estimated,
    /// Given (`--noise-floor`).
    Given,
}

/// Per parameter: RMS error / CRB, bias / CRB, mean reported std / spread.
struct Stats {
    rms: Vec<f64>,
    bias: Vec<f64>,
    std_ratio: Vec<f64>,
    names: Vec<String>,
    crb: Vec<f64>,
    scale: Vec<f64>,
}

fn options(c: &Case, floor: Option<f64>) -> Options {
    let mut o = Options::new(c.predictor.param.structure);
    o.estimator = Estimator::OutputError;
    o.scaling = Some(c.predictor.param.scaling);
    o.record_history = false;
    o.noise_floor = floor;
    o.runout = RunoutHandling::None;
    o
}

/// The Cramér-Rao bound (standard deviations of the scaled parameters) of
/// `c` under floor `f` and relative noise `s`.
fn crb(c: &Case, f: f64, s: f64) -> Vec<f64> {
    let nq = c.clean.samples[0].q.len();
    let noise = NoiseModel {
        floor_m: vec![f; nq],
        relative: s,
        source: NoiseSource::Given,
    };
    let w = Weighting::of_noise(&c.clean.samples, 1e-6, &noise);
    let fi = fisher_information_weighted(&c.predictor, &c.clean.samples, &c.terms, &c.truth, &w)
        .unwrap()
        / (s * s);
    let cov = fi.cholesky().unwrap().inverse();
    (0..c.truth.len()).map(|i| cov[(i, i)].sqrt()).collect()
}

fn noisy(c: &Case, f: f64, seed: u64) -> Measurements {
    let mut m = c.clean.clone();
    add_noise(&mut m, S, seed).unwrap();
    add_floor_noise(&mut m, f, seed).unwrap();
    m
}

fn monte_carlo(c: &Case, f: f64, floor: Floor, seeds: std::ops::Range<u64>) -> Stats {
    let pr = &c.predictor;
    let np = pr.n_params();
    let bound = crb(c, f, S);
    let n = (seeds.end - seeds.start) as f64;
    let mut err = vec![Vec::new(); np];
    let mut std = vec![Vec::new(); np];
    for seed in seeds {
        let m = noisy(c, f, seed);
        let given = (floor == Floor::Given).then_some(f);
        let id = identify(&c.model, &m, &options(c, given), None).unwrap();
        let theta = pr.theta(&id.scaled_weights);
        let cov = id.covariance.as_ref().unwrap();
        for i in 0..np {
            err[i].push(theta[i] - c.truth[i]);
            std[i].push(cov[(i, i)].re.sqrt());
        }
    }
    let mut st = Stats {
        rms: vec![],
        bias: vec![],
        std_ratio: vec![],
        names: vec![],
        crb: bound.clone(),
        scale: vec![],
    };
    for i in 0..np {
        let mean = err[i].iter().sum::<f64>() / n;
        let rms = (err[i].iter().map(|e| e * e).sum::<f64>() / n).sqrt();
        let spread = (err[i].iter().map(|e| (e - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        let rep = std[i].iter().sum::<f64>() / n;
        st.rms.push(rms / bound[i]);
        st.bias.push(mean / bound[i]);
        st.std_ratio.push(rep / spread);
        st.names.push(pr.param.name(pr.params[i].unknown));
        st.scale.push(pr.param.scale(pr.params[i].unknown));
    }
    st
}

fn report(label: &str, st: &Stats) {
    println!("{label}");
    println!("| parameter | CRB | RMS error / CRB | bias / CRB | reported std / spread |");
    println!("|---|---|---|---|---|");
    for i in 0..st.rms.len() {
        println!(
            "| {} | {:.3e} | {:.2} | {:+.2} | {:.2} |",
            st.names[i],
            st.crb[i] * st.scale[i],
            st.rms[i],
            st.bias[i],
            st.std_ratio[i]
        );
    }
    let worst = |v: &[f64]| v.iter().fold(0.0f64, |a, x| a.max(x.abs()));
    println!(
        "worst: RMS/CRB {:.2}, |bias|/CRB {:.2}, |std/spread - 1| {:.2}",
        worst(&st.rms),
        worst(&st.bias),
        st.std_ratio
            .iter()
            .fold(0.0f64, |a, x| a.max((x - 1.0).abs()))
    );
}

fn assert_at_the_bound(label: &str, st: &Stats) {
    report(label, st);
    for i in 0..st.rms.len() {
        assert!(
            st.rms[i] <= 1.5,
            "{label}: {} RMS/CRB {}",
            st.names[i],
            st.rms[i]
        );
        assert!(
            st.bias[i].abs() < 0.5,
            "{label}: {} bias/CRB {}",
            st.names[i],
            st.bias[i]
        );
        assert!(
            (st.std_ratio[i] - 1.0).abs() <= 0.3,
            "{label}: {} std/spread {}",
            st.names[i],
            st.std_ratio[i]
        );
    }
}

fn g63_case() -> Case {
    case(g63_paper(), 1, uniform_rpm(50.0, 15000.0, 50.0).unwrap())
}

#[test]
#[ignore]
fn explore_floor() {
    let c = g63_case();
    for (f, fl) in [
        (1e-7, Floor::Estimated),
        (2e-6, Floor::Estimated),
        (5e-7, Floor::Estimated),
    ] {
        let st = monte_carlo(&c, f, fl, 1..61);
        report(&format!("floor {f:e} {fl:?}"), &st);
    }
}
