//! Coast-downs in the time domain at a slow rate, away from the critical
//! speeds, with probe noise (SPEC section 7: 0.5 % relative and a floor):
//! every extracted vector is within the noise of `simulate`'s steady state
//! at its speed, and the tracker's standard errors match the noise.

use rotorid::model::RotorModel;
use rotorid::simulate::transient::{signals, vectors, SweepOptions};
use rotorid::units::rad_s_to_rpm;

use super::{paper_g25, stepped_hollow_g63};
use crate::common;

/// Relative noise and floor (m) of one revolution's 1X.
const S: f64 = 5e-3;
const FLOOR: f64 = 0.2e-6;
/// Revolutions per vector.
const N: u32 = 8;

/// Checks the normalised squared deviations `|Y - Q|^2 / sigma^2`,
/// `sigma^2 = (f^2 + s^2 |Q|^2) / N`, and the ratios `std^2 / sigma^2`.
fn coastdown(model: &RotorModel, rpm_start: f64, rpm_end: f64, rate: f64, seed: u64) {
    let fs = 64.0 * rpm_start.max(rpm_end) / 60.0;
    let mut o = SweepOptions::ramp(rpm_start, rpm_end, rate, fs);
    o.noise = S;
    o.noise_floor = FLOOR;
    o.substeps = 2;
    o.seed = seed;
    let sig = signals(model, &o).unwrap();
    let ex = vectors(&sig, N).unwrap();
    let m = &ex.measurements;
    let speeds: Vec<f64> = m.samples.iter().map(|s| s.omega).collect();
    let ss = common::simulate(model, &speeds);
    let (mut z, mut r) = (Vec::new(), Vec::new());
    let mut amp = 0.0f64;
    for ((s, t), std) in m.samples.iter().zip(&ss.samples).zip(&ex.std) {
        for ((y, q), e) in s.q.iter().zip(&t.q).zip(std) {
            amp = amp.max(q.norm());
            let sigma2 = (FLOOR * FLOOR + S * S * q.norm_sqr()) / N as f64;
            z.push((y - q).norm_sqr() / sigma2);
            r.push(e * e / sigma2);
        }
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let zmax = z.iter().cloned().fold(0.0, f64::max);
    println!(
        "{}: {rpm_start} -> {rpm_end} rpm at {rate} rpm/s, {} samples, {} vectors ({:.0}..{:.0} rpm), largest |Q| {:.2e} m, mean |dY|^2/sigma^2 {:.3}, max {:.1}, mean std^2/sigma^2 {:.3}, counts {:?}",
        model.name,
        sig.kp.len(),
        m.samples.len(),
        rad_s_to_rpm(speeds[speeds.len() - 1]),
        rad_s_to_rpm(speeds[0]),
        amp,
        mean(&z),
        zmax,
        mean(&r),
        ex.counts
    );
    assert!(m.samples.len() >= 40);
    // |dY|^2 / sigma^2 of a complex Gaussian is exponential with mean 1:
    // the mean of n >= 160 draws within 0.75..1.3 (> 3 standard errors),
    // none above 25 (probability e^-25 each).
    assert!((0.75..1.3).contains(&mean(&z)), "mean {}", mean(&z));
    assert!(zmax < 25.0, "max {zmax}");
    // The tracker's standard errors (scatter about the trend, 6 degrees of
    // freedom) estimate sigma.
    assert!((0.8..1.25).contains(&mean(&r)), "std ratio {}", mean(&r));
}

/// The paper rotor at G2.5, 12000 -> 8000 rpm at 1000 rpm/s: above its
/// critical speeds (5796, 6111 rpm).
#[test]
fn paper_rotor_coastdown_matches_steady_state() {
    coastdown(&paper_g25(), 12000.0, 8000.0, 1000.0, 3);
}

/// ROSS's stepped hollow shaft at G6.3, 7000 -> 4500 rpm at 600 rpm/s:
/// between its critical speeds (2878 and 8446 / 9224 rpm).
#[test]
fn stepped_hollow_coastdown_matches_steady_state() {
    coastdown(&stepped_hollow_g63(), 7000.0, 4500.0, 600.0, 4);
}
