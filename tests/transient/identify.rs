//! `identify` on 1X vectors extracted from time-domain signals (a slow
//! coast-down with probe noise) against `identify` on the exact
//! steady-state vectors at the same speeds, in units of the Cramér-Rao
//! bound of the extracted vectors' noise.

use rotorid::estimate::{identify, Estimator, Options, RunoutHandling};
use rotorid::simulate::transient::{signals, vectors, SweepOptions};
use rotorid::units::rad_s_to_rpm;

use super::paper_g25;
use crate::identify::output_error::{case, Case};
use crate::identify::real_noise::crb;

const S: f64 = 5e-3;
const FLOOR: f64 = 0.2e-6;
const N: u32 = 8;

fn options(c: &Case) -> Options {
    let mut o = Options::new(c.predictor.param.structure);
    o.estimator = Estimator::OutputError;
    o.scaling = Some(c.predictor.param.scaling);
    o.record_history = false;
    o.runout = RunoutHandling::None;
    o
}

/// The paper rotor at G2.5, 12000 -> 8000 rpm at 1000 rpm/s (82 vectors
/// of 8 revolutions, 0.5 % + 0.2 um per revolution): every parameter of
/// the physical first-order structure within 2 CRB in the RMS over the
/// parameters, none beyond 4 (the CRB of the averaged vectors' noise,
/// `f / sqrt(N)` and `s / sqrt(N)`).
#[test]
fn identify_on_extracted_vectors_is_within_the_bound() {
    let model = paper_g25();
    let mut o = SweepOptions::ramp(12000.0, 8000.0, 1000.0, 12_800.0);
    o.substeps = 2;
    o.noise = S;
    o.noise_floor = FLOOR;
    o.seed = 21;
    let ex = vectors(&signals(&model, &o).unwrap(), N).unwrap();
    let rpm: Vec<f64> = ex
        .measurements
        .samples
        .iter()
        .map(|s| rad_s_to_rpm(s.omega))
        .collect();
    let c = case(model, 1, rpm);
    let root_n = (N as f64).sqrt();
    let bound = crb(&c, FLOOR / root_n, S / root_n);
    let pr = &c.predictor;
    let exact = pr.theta(
        &identify(&c.model, &c.clean, &options(&c))
            .unwrap()
            .scaled_weights,
    );
    let mut measured = ex.measurements.clone();
    // The speeds of the exact sweep (rpm round trip), the extracted vectors.
    for (m, s) in measured.samples.iter_mut().zip(&c.clean.samples) {
        m.omega = s.omega;
    }
    let got = pr.theta(
        &identify(&c.model, &measured, &options(&c))
            .unwrap()
            .scaled_weights,
    );
    let z: Vec<f64> = (0..bound.len())
        .map(|i| (got[i] - exact[i]) / bound[i])
        .collect();
    let rms = (z.iter().map(|v| v * v).sum::<f64>() / z.len() as f64).sqrt();
    let worst = z.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    for i in 0..z.len() {
        println!(
            "{}: exact {:.6e}, extracted {:.6e}, difference / CRB {:+.2}",
            pr.param.name(pr.params[i].unknown),
            exact[i],
            got[i],
            z[i]
        );
    }
    println!(
        "{} parameters: RMS difference / CRB {rms:.2}, worst {worst:.2}",
        z.len()
    );
    assert!(rms <= 2.0, "RMS {rms}");
    assert!(worst <= 4.0, "worst {worst}");
}
