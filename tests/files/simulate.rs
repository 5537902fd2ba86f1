//! The simulator: each effect changes the data as the physics says, and the
//! noise has the SPEC's statistics and is reproducible.

use num_complex::Complex64;
use rotorid::io::measurement::Measurements;
use rotorid::model::extension::{Channel, Effects, Runout, SpeedLaw, SpeedScaling};
use rotorid::model::{BowPoint, Pedestal, RotorModel, ShaftBow, Unbalance};
use rotorid::simulate::{simulate, SimOptions};
use rotorid::tables::grid::uniform_rpm;

fn run(model: &RotorModel, rpm: Vec<f64>, effects: Effects) -> Measurements {
    simulate(
        model,
        &SimOptions {
            speeds_rpm: rpm,
            noise: 0.0,
            seed: 1,
            effects,
        },
    )
    .unwrap()
}

fn power(q: &[Complex64]) -> f64 {
    q.iter().map(|z| z.norm_sqr()).sum()
}

fn max_rel_diff(a: &Measurements, b: &Measurements) -> f64 {
    let mut worst = 0.0f64;
    for (x, y) in a.samples.iter().zip(&b.samples) {
        let scale = power(&y.q).sqrt().max(1e-300);
        let d: Vec<Complex64> = x.q.iter().zip(&y.q).map(|(p, q)| p - q).collect();
        worst = worst.max(power(&d).sqrt() / scale);
    }
    worst
}

#[test]
fn paper_sweep_shape_and_low_speed_scaling() {
    let m = RotorModel::paper();
    let d = run(
        &m,
        uniform_rpm(0.0, 15000.0, 50.0).unwrap(),
        Effects::default(),
    );
    assert_eq!(d.n_bearings, 2);
    assert_eq!(d.samples.len(), 301);
    // No forcing at rest; unbalance response grows as Omega^2 far below the
    // first critical speed (~5800 rpm).
    assert!(d.samples[0].q.iter().all(|z| z.norm() == 0.0));
    let r = power(&d.samples[2].q).sqrt() / power(&d.samples[1].q).sqrt();
    assert!((r - 4.0).abs() < 0.02, "ratio {r}");
    assert!(d
        .samples
        .iter()
        .all(|s| s.q.iter().all(|z| z.re.is_finite() && z.im.is_finite())));
}

#[test]
fn runout_is_a_constant_phasor_on_its_channel() {
    let m = RotorModel::paper();
    let rpm = uniform_rpm(50.0, 15000.0, 250.0).unwrap();
    let base = run(&m, rpm.clone(), Effects::default());
    let z = Complex64::from_polar(3e-6, 0.7);
    let eff = Effects {
        runout: vec![Runout {
            channel: Channel::parse("b2_z", 2).unwrap(),
            amplitude: 3e-6,
            phase: 0.7,
        }],
        ..Effects::default()
    };
    let with = run(&m, rpm, eff);
    for (a, b) in with.samples.iter().zip(&base.samples) {
        for ch in 0..4 {
            let d = a.q[ch] - b.q[ch];
            if ch == 3 {
                assert!((d - z).norm() < 1e-18, "{d}");
            } else {
                assert_eq!(d.norm(), 0.0);
            }
        }
    }
}

/// A bent shaft: its synchronous forcing `K_s q_bow` does not scale with
/// Omega^2. On its two bearings the shaft settles at rest into its bow
/// shape with the journals on the axis (the bearing forces of a two-bearing
/// rotor must vanish at rest), so the deflection at the bow persists as
/// Omega -> 0 while the unbalance response vanishes; the bearing probes read
/// zero at rest for both, both growing like Omega^2 at low speed. Far above
/// the critical speeds the unbalance response tends to a constant (mass
/// dominated, `-M^-1 T a`) while the bow response decays as `Omega^-2`
/// (`-M^-1 K_s q_bow / Omega^2`): the bow's share of the probe signal falls.
#[test]
fn bow_forcing_does_not_grow_with_speed() {
    use rotorid::fe::assembly::{Dir, FeModel};
    use rotorid::fe::response::{unbalance_response, Forcing};
    let mut bowed = RotorModel::paper();
    bowed.unbalance.clear();
    let bow = ShaftBow {
        points: vec![BowPoint {
            node: 13,
            amplitude: 3e-5,
            phase: 0.0,
        }],
    };
    bowed.bow = Some(bow.clone());
    // Shaft deflection at the bow node (FE response on all DOFs).
    let fe = FeModel::new(&bowed).unwrap();
    let at_rest = |forcing: &Forcing| {
        let r = unbalance_response(&fe, forcing, &[0.0, 0.1]).unwrap();
        let k = fe.dof(13, Dir::Y);
        (r[0].q[k].norm(), r[1].q[k].norm())
    };
    let (b0, b1) = at_rest(&Forcing {
        unbalance: vec![],
        bow: Some(bow.clone()),
    });
    assert!(
        (b0 - 3e-5).abs() < 1e-9,
        "bowed shaft at rest sits in its bow: {b0}"
    );
    assert!((b1 / b0 - 1.0).abs() < 1e-4);
    let (u0, _) = at_rest(&Forcing::from_model(&RotorModel::paper()));
    assert_eq!(u0, 0.0);

    // At the bearing probes.
    let rpm = vec![0.0, 10.0, 20.0, 1000.0, 300_000.0];
    let b = run(&bowed, rpm.clone(), Effects::default());
    let u = run(&RotorModel::paper(), rpm.clone(), Effects::default());
    let pb: Vec<f64> = b.samples.iter().map(|s| power(&s.q).sqrt()).collect();
    let pu: Vec<f64> = u.samples.iter().map(|s| power(&s.q).sqrt()).collect();
    assert!(pb[0] < 1e-9 * pb[3], "{pb:?}");
    assert!((pb[2] / pb[1] - 4.0).abs() < 1e-2, "{pb:?}");
    assert!(pb[3] > 0.0);
    let r_low = pb[3] / pu[3];
    let r_high = pb[4] / pu[4];
    assert!(
        r_high < 0.01 * r_low,
        "bow/unbalance {r_low} at 1000 rpm, {r_high} at 300000 rpm"
    );

    // The same bow from the flag path gives the same data.
    let mut plain = RotorModel::paper();
    plain.unbalance.clear();
    let eff = Effects {
        bow: bow.points.clone(),
        ..Effects::default()
    };
    assert_eq!(run(&plain, rpm, eff).samples, b.samples);
}

/// Local maxima of the response power on the grid, with a prominence
/// criterion (each peak at least 2x the valley before it).
fn peaks(d: &Measurements) -> Vec<f64> {
    let p: Vec<f64> = d.samples.iter().map(|s| power(&s.q)).collect();
    let mut out = Vec::new();
    let mut valley = f64::INFINITY;
    for i in 1..p.len() - 1 {
        valley = valley.min(p[i]);
        if p[i] > p[i - 1] && p[i] >= p[i + 1] && p[i] > 2.0 * valley {
            out.push(rotorid::units::rad_s_to_rpm(d.samples[i].omega));
            valley = p[i];
        }
    }
    out
}

#[test]
fn pedestal_adds_a_resonance() {
    let m = RotorModel::paper();
    let rpm = uniform_rpm(50.0, 15000.0, 10.0).unwrap();
    let base = run(&m, rpm.clone(), Effects::default());
    // A soft, heavy pedestal: m = 200 kg on 5e7 N/m, about 4800 rpm alone.
    let eff = Effects {
        pedestal: Some(Pedestal {
            mass: [200.0, 200.0],
            k: [5e7, 5e7],
            c: [500.0, 500.0],
        }),
        ..Effects::default()
    };
    let ped = run(&m, rpm, eff);
    let (pb, pp) = (peaks(&base), peaks(&ped));
    assert!(
        pp.len() > pb.len(),
        "peaks without {pb:?}, with pedestal {pp:?}"
    );
}

#[test]
fn stiffer_shaft_raises_the_critical_speeds() {
    // Response peaks near the first backward/forward pair (~5800 and
    // ~6110 rpm): every peak moves up with E x 1.1 and down with E x 0.9.
    let m = RotorModel::paper();
    let rpm = uniform_rpm(4000.0, 9000.0, 5.0).unwrap();
    let peaks_of = |e_scale: f64| {
        let d = run(
            &m,
            rpm.clone(),
            Effects {
                e_scale,
                ..Effects::default()
            },
        );
        let p: Vec<f64> = d.samples.iter().map(|s| power(&s.q)).collect();
        (1..p.len() - 1)
            .filter(|&i| p[i] > p[i - 1] && p[i] >= p[i + 1])
            .map(|i| rotorid::units::rad_s_to_rpm(d.samples[i].omega))
            .collect::<Vec<f64>>()
    };
    let (base, stiff, soft) = (peaks_of(1.0), peaks_of(1.1), peaks_of(0.9));
    assert_eq!(base.len(), 2, "{base:?}");
    assert!(base.iter().any(|c| (c - 6111.0).abs() < 20.0), "{base:?}");
    assert_eq!(stiff.len(), base.len(), "{stiff:?}");
    assert_eq!(soft.len(), base.len(), "{soft:?}");
    for i in 0..base.len() {
        assert!(stiff[i] > base[i] + 100.0, "{base:?} {stiff:?}");
        assert!(soft[i] < base[i] - 100.0, "{base:?} {soft:?}");
    }
}

#[test]
fn extra_unbalance_plane_adds_its_own_response() {
    let m = RotorModel::paper();
    let rpm = uniform_rpm(100.0, 15000.0, 500.0).unwrap();
    let extra = Unbalance {
        node: 14,
        me: 0.002,
        phase: 1.0,
    };
    assert!(!m.planes.contains(&extra.node));
    let base = run(&m, rpm.clone(), Effects::default());
    let with = run(
        &m,
        rpm.clone(),
        Effects {
            extra_unbalance: vec![extra],
            ..Effects::default()
        },
    );
    let mut alone_model = m.clone();
    alone_model.unbalance = vec![extra];
    let alone = run(&alone_model, rpm, Effects::default());
    // Linearity: with = base + alone, and the change is not small.
    let mut worst = 0.0f64;
    let mut change = 0.0f64;
    for ((w, b), a) in with.samples.iter().zip(&base.samples).zip(&alone.samples) {
        for ch in 0..4 {
            worst = worst.max((w.q[ch] - b.q[ch] - a.q[ch]).norm() / w.q[ch].norm());
        }
        change = change.max(power(&a.q).sqrt() / power(&b.q).sqrt());
    }
    assert!(worst < 1e-10, "superposition error {worst}");
    assert!(
        change > 0.05,
        "extra plane changes the response by {change}"
    );
}

#[test]
fn speed_dependent_bearings_change_the_data_with_speed() {
    let m = RotorModel::paper();
    let rpm = vec![3000.0, 6000.0, 15000.0];
    let base = run(&m, rpm.clone(), Effects::default());
    let sd = run(
        &m,
        rpm.clone(),
        Effects {
            bearing_speed_law: Some(SpeedScaling {
                rpm_ref: 15000.0,
                law: SpeedLaw::Quadratic,
            }),
            ..Effects::default()
        },
    );
    let rel = |i: usize| {
        let d: Vec<Complex64> = sd.samples[i]
            .q
            .iter()
            .zip(&base.samples[i].q)
            .map(|(a, b)| a - b)
            .collect();
        power(&d).sqrt() / power(&base.samples[i].q).sqrt()
    };
    // Same coefficients at the reference speed, very different below it.
    assert!(rel(2) < 1e-9, "{}", rel(2));
    assert!(rel(0) > 0.1, "{}", rel(0));
    // And equal to the paper's Eq. 49 model.
    let eq49 = run(
        &RotorModel::paper_speed_dependent(),
        rpm,
        Effects::default(),
    );
    assert!(max_rel_diff(&sd, &eq49) < 1e-9);
}

#[test]
fn noise_has_the_spec_statistics_and_is_reproducible() {
    let m = RotorModel::paper();
    let rpm = uniform_rpm(50.0, 15000.0, 10.0).unwrap();
    let clean = run(&m, rpm.clone(), Effects::default());
    let s = 0.01;
    let noisy = |seed| {
        simulate(
            &m,
            &SimOptions {
                speeds_rpm: rpm.clone(),
                noise: s,
                seed,
                effects: Effects::default(),
            },
        )
        .unwrap()
    };
    let a = noisy(5);
    assert_eq!(a, noisy(5));
    assert_ne!(a.samples, noisy(6).samples);
    let (mut sum, mut n) = (0.0, 0.0);
    let mut mean = Complex64::new(0.0, 0.0);
    for (x, c) in a.samples.iter().zip(&clean.samples) {
        for (p, q) in x.q.iter().zip(&c.q) {
            let e = (p - q) / (s * q.norm());
            sum += e.norm_sqr();
            mean += e;
            n += 1.0;
        }
    }
    // 1500 speeds x 4 channels: standard error of E|eps|^2 is 1/sqrt(6000) ~ 0.013.
    assert!((sum / n - 1.0).abs() < 0.06, "E|eps|^2 = {}", sum / n);
    assert!((mean / n).norm() < 0.05);
}
