//! The phase reference (`docs/guide/signals.md#phase-reference`) from the
//! probes' waveforms to a balancing weight: a rotor at balance grade G6.3
//! whose keyphasor probe sits `theta_k` from +y is sampled in time (25.6
//! kHz, a DC gap, a 2X component, white probe noise, 0.5 % relative noise
//! on the 1X), the core order tracker makes its 1X vectors and `identify`
//! its unbalance. Asserted, on the paper rotor and ROSS's stepped hollow
//! shaft:
//!
//! - the vectors are the steady-state response turned by `exp(j theta_k)`;
//! - the identified unbalance is the true one turned by `exp(j theta_k)`:
//!   its phase is the heavy spot's angle from +y at the keyphasor event, so
//!   the heavy spot is `arg a - theta_k` from the mark in the direction of
//!   rotation;
//! - a correction weight `m e` put `arg a - theta_k + 180` degrees from
//!   the mark (in the model's planes) removes nearly all the 1X response.

use num_complex::Complex64;
use rand::Rng;
use rand_distr::{Distribution, StandardNormal};
use rotorid::io::measurement::Measurements;
use rotorid::model::{RotorModel, Unbalance};
use rotorid::simulate::at_balance_grade;
use rotorid::units::rpm_to_rad_s;
use rotorid_core::ordertrack::{Config, OrderTracker};
use std::f64::consts::{PI, TAU};

use crate::common::{rng, simulate, sweep};

/// Sample rate (Hz).
const FS: f64 = 25_600.0;
/// 1536 samples per revolution at the slowest speed (1000 rpm), and 7.
const CAP: usize = 2048;
/// Bearing channels of both rotors: b1_y, b1_z, b2_y, b2_z.
const NC: usize = 4;
/// White noise on every probe sample (m): a 1X floor of 0.09-0.35 um over
/// the sweep after averaging 8 revolutions.
const SIGMA: f64 = 5e-6;
/// Relative noise of the 1X (SPEC section 7).
const S: f64 = 5e-3;

/// The keyphasor signal when the mark is `u` past the keyphasor probe: a
/// rising edge over 0.2 rad crossing 0.5 as the mark passes, high for a
/// quarter turn.
fn pulse(u: f64) -> f64 {
    let u = (u + PI).rem_euclid(TAU) - PI;
    if u >= PI / 2.0 {
        0.0
    } else {
        (0.5 + u / 0.2).clamp(0.0, 1.0)
    }
}

/// The averaged 1X vectors of a rotor running at `omega` whose bearing
/// response is `q` (mark at the rotor's angle 0, SPEC section 2), with its
/// keyphasor probe at `theta_k` from +y toward +z.
fn vectors(omega: f64, q: &[Complex64], theta_k: f64, seed: u64) -> Vec<Complex64> {
    let mut r = rng(seed);
    let mut normal = || -> f64 { StandardNormal.sample(&mut r) };
    // 0.5 % relative noise on the 1X, a 2X of 0.3 times it, a DC gap.
    let y1: Vec<Complex64> = q
        .iter()
        .map(|&y| y * (1.0 + S * Complex64::new(normal(), normal()) / 2f64.sqrt()))
        .collect();
    let y2: Vec<Complex64> = q
        .iter()
        .map(|&y| 0.3 * y.norm() * Complex64::from_polar(1.0, PI * normal()))
        .collect();
    let config = Config::new(FS, 0.5, 0.9 * omega, 1.1 * omega).with_hysteresis(0.2);
    let mut tracker = OrderTracker::<f64, NC, CAP>::new(config).unwrap();
    let psi0 = TAU * rng(seed + 1).random::<f64>();
    let mut i = 0u64;
    loop {
        // psi: the mark's angle from +y, in the sense of rotation.
        let psi = psi0 + omega * i as f64 / FS;
        let y: [f64; NC] = std::array::from_fn(|c| {
            (y1[c] * Complex64::from_polar(1.0, psi)).re
                + (y2[c] * Complex64::from_polar(1.0, 2.0 * psi)).re
                - 1e-3
                + SIGMA * normal()
        });
        if let Some(out) = tracker.push(pulse(psi - theta_k), &y) {
            if let Some(avg) = out.average {
                return avg.x1.to_vec();
            }
        }
        i += 1;
        assert!(i < 40 * CAP as u64, "no average: {:?}", tracker.counts());
    }
}

/// `model`'s sweep from its waveforms with the keyphasor probe at
/// `theta_k`.
fn extracted(model: &RotorModel, speeds: &[f64], theta_k: f64) -> Measurements {
    let mut m = simulate(model, speeds);
    for (n, s) in m.samples.iter_mut().enumerate() {
        s.q = vectors(s.omega, &s.q, theta_k, 1000 + n as u64);
    }
    m
}

/// RMS over the sweep of the bearing response.
fn rms(m: &Measurements) -> f64 {
    let s: f64 = m
        .samples
        .iter()
        .flat_map(|s| s.q.iter())
        .map(|y| y.norm_sqr())
        .sum();
    (s / (m.samples.len() * NC) as f64).sqrt()
}

fn check(label: &str, model: &RotorModel) {
    let speeds = sweep(1000.0, 15000.0, 100.0);
    let truth = simulate(model, &speeds);
    let mut first: Option<Vec<Complex64>> = None;
    for deg in [0.0f64, 30.0, -135.0] {
        let theta_k = deg.to_radians();
        let meas = extracted(model, &speeds, theta_k);

        // The vectors: the steady state turned by exp(j theta_k). Each
        // vector's phase error has the variance (f^2 + s^2 |Y|^2) / (2 |Y|^2)
        // (rad^2), f^2 = 4 sigma^2 / (M N) the floor of an average of N = 8
        // revolutions of M samples; their inverse-variance mean and its
        // standard deviation:
        let (mut sw, mut swd) = (0.0, 0.0);
        for (x, t) in meas.samples.iter().zip(&truth.samples) {
            let m = TAU * FS / t.omega;
            let f2 = 4.0 * SIGMA * SIGMA / (m * 8.0);
            for (a, b) in x.q.iter().zip(&t.q) {
                let w = 2.0 * b.norm_sqr() / (f2 + S * S * b.norm_sqr());
                let d = (a * b.conj() * Complex64::from_polar(1.0, -theta_k)).arg();
                sw += w;
                swd += w * d;
            }
        }
        let (offset, sd) = ((swd / sw).to_degrees(), (1.0 / sw).sqrt().to_degrees());
        println!(
            "{label}, keyphasor at {deg} deg: vectors turned by theta_k {offset:+.4} deg \
             (standard deviation {sd:.4} deg)"
        );
        assert!(offset.abs() < 4.0 * sd, "{label} {deg}: {offset} {sd}");
        // The unbalance: the truth turned by exp(j theta_k).
        let id = rotorid::identify(model, &meas, &rotorid::IdentifyOptions::default()).unwrap();
        let std = id.std().expect("standard deviations");
        let turn = Complex64::from_polar(1.0, theta_k);
        let mut planes = Vec::new();
        for ((u, t), &(s_me, s_deg)) in id
            .last
            .unbalance
            .iter()
            .zip(&model.unbalance)
            .zip(&std.unbalance)
        {
            let a_true = Complex64::from_polar(t.me, t.phase);
            let err = (u.a - a_true * turn).norm();
            let sigma = s_me.hypot(t.me * s_deg.to_radians());
            let from_mark = (u.phase - theta_k).to_degrees().rem_euclid(360.0);
            println!(
                "  plane n{}: m e {:.3e} kg m (true {:.3e}), heavy spot {from_mark:.2} deg from \
                 the mark (true {:.2}), error {:.2} sigma",
                t.node + 1,
                u.me,
                t.me,
                t.phase.to_degrees().rem_euclid(360.0),
                err / sigma
            );
            assert!(
                err < 4.0 * sigma,
                "{label} {deg} n{}: {err} {sigma}",
                t.node + 1
            );
            assert!(err < 0.1 * t.me, "{label} {deg}: {err}");
            planes.push(u.a);
        }
        // The same rotor seen through another keyphasor angle.
        if let Some(a0) = &first {
            for (a, b) in planes.iter().zip(a0) {
                let moved = (a - b * turn).norm() / b.norm();
                assert!(moved < 0.1, "{label} {deg}: {moved}");
            }
        } else {
            first = Some(planes.clone());
        }

        // Balancing: the correction weight opposite the heavy spot, its
        // angle counted from the mark (the model's angle 0).
        let mut balanced = model.clone();
        for (u, t) in planes.iter().zip(&model.unbalance) {
            balanced.unbalance.push(Unbalance {
                node: t.node,
                me: u.norm(),
                phase: u.arg() - theta_k + PI,
            });
        }
        let left = rms(&simulate(&balanced, &speeds)) / rms(&truth);
        println!(
            "  after the correction weights: {:.2} % of the 1X left",
            100.0 * left
        );
        assert!(left < 0.1, "{label} {deg}: {left}");
    }
}

#[test]
fn paper_rotor_keyphasor_angles() {
    let m = at_balance_grade(&RotorModel::paper(), 6.3, rpm_to_rad_s(15000.0)).unwrap();
    check("paper rotor", &m);
}

/// ROSS's stepped hollow shaft (`tests/data/ross/stepped_hollow.toml`),
/// its two disks the unbalance planes, at G6.3.
#[test]
fn stepped_hollow_keyphasor_angles() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/ross/stepped_hollow.toml");
    let mut m = rotorid::io::model_file::model_file_by_name_or_path(path.to_str().unwrap())
        .unwrap()
        .model;
    m.planes = m.disks.iter().map(|d| d.node).collect();
    m.unbalance = m
        .planes
        .iter()
        .zip([0.7, -2.1])
        .map(|(&node, phase)| Unbalance {
            node,
            me: 1e-4,
            phase,
        })
        .collect();
    let m = at_balance_grade(&m, 6.3, rpm_to_rad_s(11000.0)).unwrap();
    check("stepped hollow shaft", &m);
}
