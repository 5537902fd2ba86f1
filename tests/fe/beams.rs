//! Non-rotating uniform beams: FE natural frequencies against closed forms.
//!
//! - Euler-Bernoulli elements against the Euler-Bernoulli closed forms
//!   (pinned-pinned `w_n = (n pi)^2 sqrt(E I / (rho A L^4))`; free-free
//!   `w_n = (beta_n L)^2 sqrt(E I / (rho A L^4))` with `beta_n L` = 4.7300,
//!   7.8532, 10.9956, 14.1372), first four bending frequencies within 0.1%.
//!   The elements keep rotary inertia, so the beam is made slender
//!   (L/d = 200, rotary-inertia shift below 0.02%).
//! - Timoshenko elements against the exact frequency equation of a simply
//!   supported Timoshenko beam (Timoshenko 1921; e.g. Han, Benaroya, Wei,
//!   J. Sound Vib. 225 (1999) 935-988, Eq. 66):
//!   `E I k^4 - rho A w^2 - rho I w^2 k^2 (1 + E/(kappa G)) + rho^2 I w^4 / (kappa G) = 0`,
//!   `k = n pi / L`, lower root, for a thick beam (L/d = 5): within 0.1% for
//!   the first four modes with 80 elements, converging at second order in
//!   the element length (the interdependent-interpolation element has a
//!   constant shear strain per element), while Euler-Bernoulli elements
//!   overestimate by 3% to 30%.

use nalgebra::{DMatrix, SymmetricEigen};
use rotorid::fe::assembly::{dof, Dir, FeModel};
use rotorid::fe::shaft::{cowper_kappa, Section};
use rotorid::model::{
    BeamTheory, Bearing, BearingCoefficients, BearingLaw, Material, RotorModel, ShaftElement,
};

fn uniform_beam(theory: BeamTheory, length: f64, d: f64, n_el: usize) -> RotorModel {
    RotorModel {
        name: "beam".into(),
        theory,
        shaft: (0..n_el)
            .map(|_| ShaftElement {
                length: length / n_el as f64,
                outer_diameter: d,
                inner_diameter: 0.0,
                material: Material::steel(),
            })
            .collect(),
        disks: vec![],
        // A bearing with zero coefficients: the model needs one, it adds nothing.
        bearings: vec![Bearing {
            node: 0,
            law: BearingLaw::Constant(BearingCoefficients::default()),
            pedestal: None,
        }],
        planes: vec![],
        unbalance: vec![],
        bow: None,
        probes: rotorid::model::ProbeReference::Relative,
        rotor_damping: rotorid::model::ProportionalDamping::default(),
        shaft_layers: Vec::new(),
    }
}

/// Natural frequencies (rad/s, ascending) of the x-y plane of a
/// non-rotating beam with the translations at `pinned` nodes held.
fn plane_frequencies(fe: &FeModel, pinned: &[usize]) -> Vec<f64> {
    let m = fe.mass_matrix();
    let k = fe.shaft_stiffness_matrix();
    let dofs: Vec<usize> = (0..fe.n_nodes())
        .flat_map(|n| {
            let mut v = vec![];
            if !pinned.contains(&n) {
                v.push(dof(n, Dir::Y));
            }
            v.push(dof(n, Dir::PhiZ));
            v
        })
        .collect();
    let sel =
        |a: &DMatrix<f64>| DMatrix::from_fn(dofs.len(), dofs.len(), |i, j| a[(dofs[i], dofs[j])]);
    let (ms, ks) = (sel(&m), sel(&k));
    let l = ms.cholesky().unwrap();
    let linv = l.l().try_inverse().unwrap();
    let a = &linv * ks * linv.transpose();
    let a = (&a + a.transpose()) * 0.5;
    let mut w: Vec<f64> = SymmetricEigen::new(a)
        .eigenvalues
        .iter()
        .map(|&x| x.max(0.0).sqrt())
        .collect();
    w.sort_by(f64::total_cmp);
    w
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b
}

#[test]
fn euler_bernoulli_pinned_pinned_and_free_free() {
    let (l, d) = (2.0, 0.01);
    let n_el = 40;
    let fe = FeModel::new(&uniform_beam(BeamTheory::EulerBernoulli, l, d, n_el)).unwrap();
    let s = Section::tube(d, 0.0, 0.3);
    let mat = Material::steel();
    let c = (mat.e * s.inertia / (mat.rho * s.area * l.powi(4))).sqrt();

    let pp = plane_frequencies(&fe, &[0, n_el]);
    for n in 1..=4 {
        let exact = (n as f64 * core::f64::consts::PI).powi(2) * c;
        let e = rel(pp[n - 1], exact);
        println!(
            "pinned-pinned mode {n}: FE {:.4} exact {:.4} rad/s, rel err {e:.2e}",
            pp[n - 1],
            exact
        );
        assert!(e < 1e-3, "pinned-pinned mode {n}: rel err {e}");
    }

    let ff = plane_frequencies(&fe, &[]);
    // Two rigid-body modes (translation, tilt) first.
    assert!(
        ff[0] < 1e-3 * ff[2] && ff[1] < 1e-3 * ff[2],
        "{:?}",
        &ff[..3]
    );
    let beta_l = [4.730_040_745, 7.853_204_624, 10.995_607_84, 14.137_165_49];
    for (n, bl) in beta_l.iter().enumerate() {
        let exact = bl * bl * c;
        let e = rel(ff[n + 2], exact);
        println!(
            "free-free mode {}: FE {:.4} exact {:.4} rad/s, rel err {e:.2e}",
            n + 1,
            ff[n + 2],
            exact
        );
        assert!(e < 1e-3, "free-free mode {}: rel err {e}", n + 1);
    }
}

#[test]
fn timoshenko_thick_beam_pinned_pinned() {
    let (l, d) = (1.0, 0.2);
    let n_el = 80;
    let mat = Material::steel();
    let s = Section::tube(d, 0.0, mat.nu());
    let kappa = cowper_kappa(mat.nu(), 0.0);
    assert!((s.kappa - kappa).abs() < 1e-15);
    let (e, g, rho, a, i) = (mat.e, mat.g, mat.rho, s.area, s.inertia);
    let exact = |n: usize| {
        let k = n as f64 * core::f64::consts::PI / l;
        let qa = rho * rho * i / (kappa * g);
        let qb = -(rho * a + rho * i * k * k * (1.0 + e / (kappa * g)));
        let qc = e * i * k.powi(4);
        ((-qb - (qb * qb - 4.0 * qa * qc).sqrt()) / (2.0 * qa)).sqrt()
    };
    let timo = plane_frequencies(
        &FeModel::new(&uniform_beam(BeamTheory::Timoshenko, l, d, n_el)).unwrap(),
        &[0, n_el],
    );
    let timo40 = plane_frequencies(
        &FeModel::new(&uniform_beam(BeamTheory::Timoshenko, l, d, 40)).unwrap(),
        &[0, 40],
    );
    let eb = plane_frequencies(
        &FeModel::new(&uniform_beam(BeamTheory::EulerBernoulli, l, d, n_el)).unwrap(),
        &[0, n_el],
    );
    for n in 1..=4 {
        let x = exact(n);
        let et = rel(timo[n - 1], x);
        let ee = rel(eb[n - 1], x);
        println!(
            "thick beam mode {n}: exact Timoshenko {x:.2}, Timoshenko FE {:.2} ({et:.2e}), EB FE {:.2} ({ee:.2e}) rad/s",
            timo[n - 1], eb[n - 1]
        );
        // Timoshenko elements converge to the Timoshenko beam (80 elements: 0.1%).
        assert!(et < 1e-3, "mode {n}: Timoshenko FE rel err {et}");
        // ... at second order in the element length: the element's shear
        // strain is constant along it, so halving the elements divides the
        // error by about 4.
        let e40 = rel(timo40[n - 1], x);
        println!("   40 elements: {e40:.2e}, ratio {:.2}", e40 / et);
        assert!(
            e40 / et > 3.5 && e40 / et < 4.5,
            "mode {n}: ratio {}",
            e40 / et
        );
        // Euler-Bernoulli elements stay well above it (shear flexibility missing).
        assert!(eb[n - 1] > x * (1.0 + 10.0 * et.max(1e-4)), "mode {n}");
    }
}
