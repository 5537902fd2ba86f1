//! The pedestal search across the rotor's critical speeds: a pedestal whose
//! resonance lies at each of 20 frequencies from 0.5 to 2 times the first
//! critical speed (where its mode and the rotor's couple) is named
//! `foundation_flexibility`, under the right bearing, with its natural
//! frequency within 5 % and within 3.5 reported standard deviations.
//!
//! Realistic data: unbalance at balance grade G6.3, 0.5 % relative noise
//! and a 0.5 um probe floor (SPEC section 7), two rotors (the paper rotor
//! and ROSS's stepped hollow shaft, whose responses come from rotorid's
//! steady-state solver with the pedestal in the FE model, not from the
//! hypothesis's reduced form). The pedestal is not symmetric: its z
//! stiffness is 1.15^2 times its y stiffness, its damping ratios differ.
//!
//! The model's bearings are the truth's, and, in a third grid, 13 and 20 %
//! off it (the pedestal search holds them at the model's values to start).
//!
//! `#[ignore]`d (60 diagnoses, under a minute in release on two cores):
//! `cargo test --release --test lib diagnose::pedestal_grid -- --ignored --nocapture`.

use rotorid::diagnose::{diagnose, DiagnoseOptions, Effect, Finding};
use rotorid::model::RotorModel;
use rotorid::simulate::{add_floor_noise, at_balance_grade, simulate, SimOptions};
use rotorid::units::rpm_to_rad_s;

use crate::transient::stepped_hollow_g63;

/// Relative noise and probe floor (m) of the data.
const NOISE: f64 = 0.005;
const FLOOR: f64 = 0.5e-6;

/// One pedestal case: `model` with constant bearings (its laws at half the
/// top speed), a pedestal of the rotor's mass per bearing under `bearing`
/// resonating at `f_hz` in y; the truth's bearing `i` stiffer than the
/// model's by `1 + scatter sin(0.7 (i + 1))`, its damping lower by as
/// much; 300 speeds up to `rpm_max`. Returns whether it was named right
/// and the frequency's error (relative, in stds).
fn case(
    model: &RotorModel,
    rpm_max: f64,
    bearing: usize,
    f_hz: f64,
    seed: u64,
    scatter: f64,
) -> (bool, f64, f64) {
    let (nominal, truth) =
        rotorid::diagnose::generator::pedestal_grid_case(model, rpm_max, bearing, f_hz, scatter)
            .unwrap();
    let speeds_rpm: Vec<f64> = (1..=300).map(|i| rpm_max * i as f64 / 300.0).collect();
    let opts = SimOptions {
        speeds_rpm,
        noise: NOISE,
        seed,
        ..SimOptions::default()
    };
    let mut meas = simulate(&truth, &opts).unwrap();
    add_floor_noise(&mut meas, FLOOR, seed).unwrap();
    let d = diagnose(&nominal, &meas, &DiagnoseOptions::default()).unwrap();
    let node = nominal.bearings[bearing].node + 1;
    let found = d.findings().into_iter().find_map(|f| match f {
        Finding::FoundationFlexibility {
            node: n,
            natural_frequency_hz,
            natural_frequency_hz_std,
            ..
        } if n == node => Some((natural_frequency_hz[0], natural_frequency_hz_std[0])),
        _ => None,
    });
    let named = d.effect == Effect::FoundationFlexibility;
    let (rel, z) = found.map_or((f64::INFINITY, f64::INFINITY), |(f, sd)| {
        ((f - f_hz).abs() / f_hz, (f - f_hz).abs() / sd)
    });
    println!(
        "bearing {} at {f_hz:7.2} Hz: named {} ({}), frequency {:+.2} %, {:.2} std",
        bearing + 1,
        d.effect.name(),
        d.extended().label,
        100.0 * rel,
        z
    );
    (named && found.is_some(), rel, z)
}

/// The grid on one rotor: of 20 frequencies `0.5 .. 2` times
/// `critical_rpm` (geometric), the pedestal under each bearing in turn,
/// the cases `points`, the bearings `scatter` off ([`case`]).
fn grid(model: &RotorModel, rpm_max: f64, critical_rpm: f64, points: &[usize], scatter: f64) {
    let f1 = critical_rpm / 60.0;
    let mut failed = Vec::new();
    for &i in points {
        let f = f1 * 0.5 * 4f64.powf(i as f64 / 19.0);
        let bearing = i % model.bearings.len();
        let (ok, rel, z) = case(model, rpm_max, bearing, f, 7000 + i as u64, scatter);
        if !(ok && rel <= 0.05 && z <= 3.5) {
            failed.push((f, ok, rel, z));
        }
    }
    assert!(failed.is_empty(), "missed: {failed:?}");
}

/// The paper rotor's grid cases where the pedestal and the rotor couple
/// most (56 Hz, and 100 and 108 Hz about the first critical speed, 97
/// Hz): the screened starts of the earlier search stalled at 2.4 to 5
/// times the noise on each, named a pedestal under the wrong bearing,
/// two pedestals or a speed-dependent bearing; the fits from the misfit
/// profile's least point reach the noise.
#[test]
fn pedestals_coupled_with_the_first_critical_speed_are_found() {
    let m = at_balance_grade(&RotorModel::paper(), 6.3, rpm_to_rad_s(15000.0)).unwrap();
    grid(&m, 15000.0, 5796.4, &[2, 10, 11], 0.0);
}

#[test]
#[ignore = "20 diagnoses: cargo test --release --test lib diagnose::pedestal_grid -- --ignored"]
fn pedestal_grid_paper_rotor() {
    let m = at_balance_grade(&RotorModel::paper(), 6.3, rpm_to_rad_s(15000.0)).unwrap();
    // First critical speed 5796 rpm (backward; `rotorid campbell --model paper`).
    grid(&m, 15000.0, 5796.4, &(0..20).collect::<Vec<_>>(), 0.0);
}

/// The paper rotor's grid with the model's bearings off the truth's (its
/// stiffness 1.13 and 1.20 times the model's, its damping as much lower):
/// the search's profile holds the bearings at the model's values, and
/// must find the pedestal all the same.
#[test]
#[ignore = "20 diagnoses: cargo test --release --test lib diagnose::pedestal_grid -- --ignored"]
fn pedestal_grid_paper_rotor_bearings_off() {
    let m = at_balance_grade(&RotorModel::paper(), 6.3, rpm_to_rad_s(15000.0)).unwrap();
    grid(&m, 15000.0, 5796.4, &(0..20).collect::<Vec<_>>(), 0.2);
}

#[test]
#[ignore = "20 diagnoses: cargo test --release --test lib diagnose::pedestal_grid -- --ignored"]
fn pedestal_grid_stepped_hollow_shaft() {
    // First critical speed 2770 rpm (backward; `rotorid campbell`).
    grid(
        &stepped_hollow_g63(),
        12000.0,
        2769.7,
        &(0..20).collect::<Vec<_>>(),
        0.0,
    );
}
