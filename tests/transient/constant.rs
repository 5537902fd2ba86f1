//! Constant speed: the integration stays on the Newmark scheme's own
//! steady state `Q_h` (the dynamic stiffness at the warped frequency
//! `Omega_h = (2/h) tan(Omega h / 2)`), `Q_h` tends to `simulate`'s `Q` at
//! second order in the step with the predicted first-order term, and the
//! signals through the keyphasor and the order tracker give `Q_h` (so
//! `simulate`'s vectors within `|Q_h - Q|`): phase reference and sense of
//! rotation as `simulate`.

use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;
use rotorid::fe::assembly::{Dir, FeModel};
use rotorid::fe::response::{unbalance_response, Forcing};
use rotorid::fe::transient::{warped_frequency, warped_response, Integrator, Ramp};
use rotorid::model::RotorModel;
use rotorid::simulate::transient::{signals, vectors, SweepOptions};
use rotorid::units::rpm_to_rad_s;
use std::f64::consts::TAU;

use super::{paper_g25, stepped_hollow_g63};

/// Largest translation of a phasor vector (shaft y, z and pedestals).
fn translation_scale(fe: &FeModel, q: &[Complex64]) -> f64 {
    (0..fe.n_dof())
        .filter(|&d| d >= fe.n_shaft_dof() || d % 4 < 2)
        .map(|d| q[d].norm())
        .fold(0.0, f64::max)
}

fn stays_on_discrete_steady_state(model: &RotorModel, rpm: f64) {
    let fe = FeModel::new(model).unwrap();
    let forcing = Forcing::from_model(model);
    let w = rpm_to_rad_s(rpm);
    let h = TAU / (128.0 * w);
    let ramp = Ramp {
        omega0: w,
        alpha: 0.0,
        theta0: 0.3,
    };
    let qh = warped_response(&fe, &forcing, w, h).unwrap();
    let scale_t = translation_scale(&fe, &qh);
    let scale_r = (0..fe.n_shaft_dof())
        .filter(|d| d % 4 >= 2)
        .map(|d| qh[d].norm())
        .fold(0.0, f64::max);
    let mut it = Integrator::new(&fe, &forcing, ramp, h).unwrap();
    let (mut et, mut er) = (0.0f64, 0.0f64);
    for _ in 0..1280 {
        it.step().unwrap();
        let e = Complex64::from_polar(1.0, ramp.theta(it.time()));
        for (d, q) in qh.iter().enumerate() {
            let err = (it.displacement(d) - (q * e).re).abs();
            if d >= fe.n_shaft_dof() || d % 4 < 2 {
                et = et.max(err);
            } else {
                er = er.max(err);
            }
        }
    }
    let (solves, factors) = it.work();
    println!(
        "{} at {rpm} rpm: 1280 steps, error {:.2e} (translations), {:.2e} (rotations) relative, {solves} solves, {factors} factorisations",
        model.name,
        et / scale_t,
        er / scale_r
    );
    assert!(
        et <= 1e-9 * scale_t,
        "translation error {et:e} of {scale_t:e}"
    );
    assert!(er <= 1e-9 * scale_r, "rotation error {er:e} of {scale_r:e}");
    // At constant speed one factorisation, and each step converges at once.
    assert_eq!(factors, 1);
    assert!(solves <= 2 * 1280, "{solves} solves");
}

#[test]
fn integration_stays_on_the_discrete_steady_state() {
    stays_on_discrete_steady_state(&paper_g25(), 4000.0);
    stays_on_discrete_steady_state(&paper_g25(), 9000.0);
    stays_on_discrete_steady_state(&stepped_hollow_g63(), 5000.0);
}

/// `Q_h - Q` against its first-order prediction: with `Z_h = Z + dZ`,
/// `dZ = -(Omega_h^2 - Omega^2) M + j (Omega_h - Omega) D`, `Q_h - Q =
/// -Z^-1 dZ Q + O(dZ^2)`, and `Omega_h - Omega = Omega (Omega h)^2 / 12 +
/// O(h^4)`: second order in `h`.
fn converges_at_second_order(model: &RotorModel, rpm: f64) {
    let fe = FeModel::new(model).unwrap();
    let forcing = Forcing::from_model(model);
    let w = rpm_to_rad_s(rpm);
    let q = unbalance_response(&fe, &forcing, &[w]).unwrap().remove(0).q;
    let n = fe.n_dof();
    let (m, g) = (fe.mass_matrix(), fe.gyroscopic_matrix());
    let (k, c) = (fe.stiffness_matrix(w), fe.damping_matrix(w));
    let z = DMatrix::from_fn(n, n, |i, j| {
        Complex64::new(
            k[(i, j)] - w * w * m[(i, j)],
            w * (c[(i, j)] + w * g[(i, j)]),
        )
    });
    let qv = DVector::from_column_slice(&q);
    let scale = translation_scale(&fe, &q);
    let mut errors = Vec::new();
    for per_rev in [64.0, 128.0, 256.0] {
        let h = TAU / (per_rev * w);
        let wh = warped_frequency(w, h);
        let dz = DMatrix::from_fn(n, n, |i, j| {
            Complex64::new(
                -(wh * wh - w * w) * m[(i, j)],
                (wh - w) * (c[(i, j)] + w * g[(i, j)]),
            )
        });
        let pred = -z.clone().lu().solve(&(dz * &qv)).unwrap();
        let qh = warped_response(&fe, &forcing, w, h).unwrap();
        let diff = DVector::from_iterator(n, qh.iter().zip(&q).map(|(a, b)| a - b));
        let err = translation_scale(&fe, diff.as_slice()) / scale;
        let miss = translation_scale(&fe, (&diff - &pred).as_slice()) / scale;
        let eps = (w * h).powi(2) / 12.0;
        println!(
            "{} at {rpm} rpm, {per_rev} steps/rev: frequency error {eps:.2e}, |Q_h - Q| {err:.3e}, first-order miss {miss:.1e}",
            model.name
        );
        assert!(miss <= 0.02 * err, "{miss:e} of {err:e}");
        errors.push(err);
    }
    for p in errors.windows(2) {
        let r = p[0] / p[1];
        assert!(
            (3.9..4.1).contains(&r),
            "error ratio {r} on halving the step"
        );
    }
}

#[test]
fn discrete_steady_state_converges_at_second_order() {
    converges_at_second_order(&paper_g25(), 4000.0);
    converges_at_second_order(&paper_g25(), 9000.0);
    converges_at_second_order(&stepped_hollow_g63(), 5000.0);
}

/// Signals at constant speed through the keyphasor and the order tracker:
/// every average equals the scheme's `Q_h` at the bearings (to the
/// tracker's precision), hence `simulate`'s `Q` within `|Q_h - Q|`.
fn signals_give_simulate_vectors(model: &RotorModel, rpm: f64) {
    let fe = FeModel::new(model).unwrap();
    let forcing = Forcing::from_model(model);
    let w = rpm_to_rad_s(rpm);
    let fs = 64.0 * rpm / 60.0;
    let mut o = SweepOptions::constant(rpm, 0.5, fs);
    o.substeps = 2;
    let h = 1.0 / (fs * 2.0);
    let sig = signals(model, &o).unwrap();
    let ex = vectors(&sig, 8).unwrap();
    assert!(ex.measurements.samples.len() >= 3);
    let qh = warped_response(&fe, &forcing, w, h).unwrap();
    let q = unbalance_response(&fe, &forcing, &[w]).unwrap().remove(0);
    let qh_b: Vec<Complex64> = model
        .bearings
        .iter()
        .flat_map(|b| [qh[fe.dof(b.node, Dir::Y)], qh[fe.dof(b.node, Dir::Z)]])
        .collect();
    let scale = q.bearings.iter().map(|z| z.norm()).fold(0.0, f64::max);
    let gap = qh_b
        .iter()
        .zip(&q.bearings)
        .map(|(a, b)| (a - b).norm())
        .fold(0.0, f64::max);
    let mut worst = 0.0f64;
    let mut worst_ss = 0.0f64;
    for s in &ex.measurements.samples {
        assert!((s.omega - w).abs() <= 1e-9 * w, "speed {} for {w}", s.omega);
        for (c, y) in s.q.iter().enumerate() {
            worst = worst.max((y - qh_b[c]).norm());
            worst_ss = worst_ss.max((y - q.bearings[c]).norm());
        }
    }
    println!(
        "{} at {rpm} rpm: |Y - Q_h| {:.1e}, |Y - Q| {:.2e}, |Q_h - Q| {:.2e} (relative)",
        model.name,
        worst / scale,
        worst_ss / scale,
        gap / scale
    );
    assert!(worst <= 1e-8 * scale, "{worst:e} of {scale:e}");
    assert!(worst_ss <= gap + 1e-8 * scale);
}

#[test]
fn constant_speed_signals_give_simulate_vectors() {
    signals_give_simulate_vectors(&paper_g25(), 4000.0);
    signals_give_simulate_vectors(&stepped_hollow_g63(), 5000.0);
}
