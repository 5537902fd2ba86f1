//! The reduction to the bearing DOFs against independent computations:
//! the dense reference solve, the identity `A q_B + Z_B q_B - B a = 0` on a
//! noise-free FE simulation (the identity the identification rests on),
//! the pedestal-as-effective-bearing equivalence, and the poles.

use nalgebra::{DMatrix, DVector, Matrix2};
use num_complex::Complex64;
use rotorid::core::table::{BearingTable, TableView, Terms};
use rotorid::fe::assembly::FeModel;
use rotorid::fe::response::{unbalance_response, unbalance_response_dense, Forcing};
use rotorid::model::{Bearing, Pedestal, RotorModel, Unbalance};
use rotorid::reduce::{
    reduce, reduce_dense, reduce_schur_dense, DenseReducer, ReducedTerms, Reducer,
};
use rotorid::tables::grid::uniform_rad_s;
use rotorid::tables::{build, Scalar};

fn rel(a: &DMatrix<Complex64>, b: &DMatrix<Complex64>) -> f64 {
    (a - b).norm() / b.norm()
}

/// The paper's grid: 50 to 15000 rpm in steps of 50 (300 speeds).
fn paper_grid() -> Vec<f64> {
    uniform_rad_s(50.0, 15000.0, 50.0).unwrap()
}

#[test]
fn banded_equals_dense_on_the_paper_grid() {
    let model = RotorModel::paper();
    let fe = FeModel::new(&model).unwrap();
    let banded = Reducer::new(&fe, &model).unwrap();
    let dense = DenseReducer::new(&fe, &model).unwrap();
    let mut worst: f64 = 0.0;
    for w in paper_grid() {
        let x = banded.reduce(w).unwrap();
        let y = dense.reduce(w).unwrap();
        assert_eq!(x.a.shape(), (4, 4));
        assert_eq!(x.b.shape(), (4, 3));
        worst = worst.max(rel(&x.a, &y.a)).max(rel(&x.b, &y.b));
    }
    println!("banded vs dense, worst relative difference: {worst:.3e}");
    assert!(worst < 1e-10, "{worst}");
    // The one-shot functions agree with the prepared ones.
    let w = 700.0;
    assert_eq!(reduce(&fe, &model, w).unwrap(), banded.reduce(w).unwrap());
    assert_eq!(
        reduce_dense(&fe, &model, w).unwrap(),
        dense.reduce(w).unwrap()
    );
}

/// The literal Eqs. 38-39 (an independent derivation) agree with the split
/// formulation to the literal formula's own round-off, `~eps |Z_BB|`
/// absolute, which dominates at low speed where `A ~ Omega^2`.
#[test]
fn split_formulation_equals_the_literal_schur_complement() {
    let model = RotorModel::paper();
    let fe = FeModel::new(&model).unwrap();
    let r = Reducer::new(&fe, &model).unwrap();
    let k = fe.shaft_stiffness_matrix();
    let kbb = k[(0, 0)].abs();
    let mut worst_abs: f64 = 0.0;
    let mut worst_b: f64 = 0.0;
    let mut worst_rel_high: f64 = 0.0;
    for w in paper_grid() {
        let x = r.reduce(w).unwrap();
        let y = reduce_schur_dense(&fe, &model, w).unwrap();
        worst_abs = worst_abs.max((&x.a - &y.a).norm() / (f64::EPSILON * kbb));
        worst_b = worst_b.max(rel(&x.b, &y.b));
        if w > 300.0 {
            worst_rel_high = worst_rel_high.max(rel(&x.a, &y.a));
        }
    }
    println!(
        "split vs literal: |dA| <= {worst_abs:.1} eps |K_BB|; B {worst_b:.2e}; A above 300 rad/s {worst_rel_high:.2e}"
    );
    assert!(worst_abs < 1e4, "{worst_abs}");
    assert!(worst_b < 1e-10, "{worst_b}");
    assert!(worst_rel_high < 1e-10, "{worst_rel_high}");
}

fn to_dm<const NQ: usize, const NP: usize, T: rotorid::core::Real>(
    t: &Terms<T, NQ, NP>,
) -> (DMatrix<Complex64>, DMatrix<Complex64>) {
    let c = |z: &rotorid::core::Complex<T>| Complex64::new(z.re.to_f64(), z.im.to_f64());
    (
        DMatrix::from_fn(NQ, NQ, |r, k| c(&t.a[r][k])),
        DMatrix::from_fn(NQ, NP, |r, k| c(&t.b[r][k])),
    )
}

/// At its grid speeds the table returns the reduction it was built from
/// (the modal form, [`Reducer::many`]) to round-off, and the dense
/// reference to the agreement of the two forms: `1e-10` away from the
/// poles, `2e-12 / s` at a relative distance `s` from one (both forms carry
/// a pole position perturbed by about `1e-12`, `rotorid::reduce::modal`).
#[test]
fn table_lookups_at_grid_speeds_equal_the_dense_computation() {
    let model = RotorModel::paper();
    let fe = FeModel::new(&model).unwrap();
    let dense = DenseReducer::new(&fe, &model).unwrap();
    let banded = Reducer::new(&fe, &model).unwrap();
    let source = banded.many();
    assert!(matches!(
        source,
        rotorid::reduce::modal::ManySpeeds::Modal(_)
    ));
    let poles = banded.poles(3000.0, 16);
    let speeds = paper_grid();
    let table = build(&model, &speeds).unwrap();
    let b64 = table.to_blob(Scalar::F64).unwrap();
    let b32 = table.to_blob(Scalar::F32).unwrap();
    let v64 = TableView::<f64>::parse(&b64).unwrap();
    let v32 = TableView::<f32>::parse(&b32).unwrap();
    let (mut e_src, mut e_dense, mut e32): (f64, f64, f64) = (0.0, 0.0, 0.0);
    for &w in &speeds {
        let d = dense.reduce(w).unwrap();
        let m = source.reduce(w).unwrap();
        let t: Terms<f64, 4, 3> = v64.terms(w).unwrap();
        let (a, b) = to_dm(&t);
        e_src = e_src.max(rel(&a, &m.a)).max(rel(&b, &m.b));
        let s = poles
            .iter()
            .map(|&p| (w / p - 1.0).abs())
            .fold(f64::INFINITY, f64::min);
        e_dense = e_dense.max(rel(&a, &d.a).max(rel(&b, &d.b)) / (1e-10 + 2e-12 / s));
        // The f32 table is looked up at the f32 speed it stores.
        let w32 = w as f32;
        let t: Terms<f32, 4, 3> = v32.terms(w32).unwrap();
        let (a, b) = to_dm(&t);
        e32 = e32.max(rel(&a, &d.a)).max(rel(&b, &d.b));
    }
    println!(
        "table at grid speeds: f64 vs its source {e_src:.3e}, vs dense {e_dense:.3} of the bound; f32 vs dense {e32:.3e}"
    );
    assert!(e_src < 1e-13, "{e_src}");
    assert!(e_dense < 1.0, "{e_dense}");
    assert!(e32 < 1e-5, "{e32}");
}

/// Bearing dynamic stiffness `K + j Omega C` of each bearing at `omega`,
/// block-diagonal over the channels.
fn bearing_z(model: &RotorModel, omega: f64) -> DMatrix<Complex64> {
    let nb = model.bearings.len();
    let mut z = DMatrix::zeros(2 * nb, 2 * nb);
    for (m, b) in model.bearings.iter().enumerate() {
        let c = b.law.at(omega);
        for r in 0..2 {
            for k in 0..2 {
                z[(2 * m + r, 2 * m + k)] = Complex64::new(c.k[2 * r + k], omega * c.c[2 * r + k]);
            }
        }
        if let Some(p) = &b.pedestal {
            // Z_eff = Z_B - Z_B (Z_B + Z_P)^-1 Z_B.
            let zb = Matrix2::from_fn(|r, k| z[(2 * m + r, 2 * m + k)]);
            let zp = Matrix2::from_fn(|r, k| {
                if r == k {
                    Complex64::new(p.k[r] - omega * omega * p.mass[r], omega * p.c[r])
                } else {
                    Complex64::new(0.0, 0.0)
                }
            });
            let zeff = zb - zb * (zb + zp).try_inverse().unwrap() * zb;
            for r in 0..2 {
                for k in 0..2 {
                    z[(2 * m + r, 2 * m + k)] = zeff[(r, k)];
                }
            }
        }
    }
    z
}

/// The identity's residual `r = A q_B + Z_B q_B - B a` over a grid.
#[derive(Debug, Clone, Copy)]
struct Residual {
    /// Worst `|r| / max(|A q_B|, |Z_B q_B|, |B a|)`: the round-off level of
    /// the three terms.
    vs_terms: f64,
    /// Worst `|r| / |A q_B|` over all speeds.
    vs_d: f64,
    /// Worst `|r| / |A q_B|` where `|A q_B|` is at least a tenth of the
    /// largest term (no cancellation between the terms).
    vs_d_no_cancel: f64,
    /// Worst relative difference of `q_B` between the banded and the dense
    /// FE solvers: the simulation's own round-off.
    fe_diff: f64,
}

/// The residual `r` of `A q_B = -Z_B q_B + B a` with `q_B` from the FE
/// unbalance response of the full system (bearings, pedestals) and `a` the
/// true unbalance of the model's planes (zero for a plane without one).
///
/// At low speed `|A q_B| ~ Omega^2` is far smaller than `|Z_B q_B| ~ |B a|`
/// (the shaft barely bends: the bearing forces balance the unbalance), so
/// `|r| / |A q_B|` there measures the cancellation of the two large terms,
/// not the table: the round-off criterion is `|r|` against the largest term.
/// With soft bearings (Eq. 49 at low speed) the full FE system is itself
/// ill-conditioned (the free shaft's rigid-body modes), and its solution
/// carries a relative error estimated by the difference of two FE solvers;
/// the bound allows ten times that on top of `1e-10`.
fn identity_residual(model: &RotorModel, speeds: &[f64]) -> Residual {
    let table = build(model, speeds).unwrap();
    let fe = FeModel::new(model).unwrap();
    let resp = unbalance_response(&fe, &Forcing::from_model(model), speeds).unwrap();
    let resp_dense = unbalance_response_dense(&fe, &Forcing::from_model(model), speeds).unwrap();
    let a_true = DVector::from_iterator(
        model.planes.len(),
        model.planes.iter().map(|&n| {
            model
                .unbalance
                .iter()
                .filter(|u| u.node == n)
                .map(|u| u.phasor())
                .sum::<Complex64>()
        }),
    );
    let mut out = Residual {
        vs_terms: 0.0,
        vs_d: 0.0,
        vs_d_no_cancel: 0.0,
        fe_diff: 0.0,
    };
    for ((t, r), rd) in table.terms.iter().zip(&resp).zip(&resp_dense) {
        assert_eq!(t.omega, r.omega);
        let qb = DVector::from_column_slice(&r.bearings);
        let d = &t.a * &qb;
        let zq = bearing_z(model, t.omega) * &qb;
        let ba = &t.b * &a_true;
        let res = (&d + &zq - &ba).norm();
        let scale = d.norm().max(zq.norm()).max(ba.norm());
        let fe_diff = (&qb - DVector::from_column_slice(&rd.bearings)).norm() / qb.norm();
        out.fe_diff = out.fe_diff.max(fe_diff);
        assert!(
            res / scale < 1e-10 + 10.0 * fe_diff,
            "{} rad/s: {} vs FE {fe_diff}",
            t.omega,
            res / scale
        );
        out.vs_terms = out.vs_terms.max(res / scale);
        out.vs_d = out.vs_d.max(res / d.norm());
        if d.norm() >= 0.1 * scale {
            out.vs_d_no_cancel = out.vs_d_no_cancel.max(res / d.norm());
        }
    }
    println!("{}: {out:?}", model.name);
    assert!(out.vs_d_no_cancel < 1e-10 + 10.0 * out.fe_diff, "{out:?}");
    out
}

#[test]
fn identity_holds_on_noise_free_simulations() {
    let speeds = paper_grid();
    let r = identity_residual(&RotorModel::paper(), &speeds);
    assert!(r.vs_terms < 1e-10 && r.vs_d_no_cancel < 1e-10, "{r:?}");
    identity_residual(&RotorModel::paper_speed_dependent(), &speeds);
}

#[test]
fn identity_holds_with_a_plane_at_a_bearing_node() {
    // T_B != 0: unbalance at node 1 (a bearing) identified as a plane there.
    let mut m = RotorModel::paper();
    m.name = "plane at a bearing node".into();
    m.planes = vec![0, 4, 10, 20];
    m.unbalance.push(Unbalance {
        node: 0,
        me: 0.002,
        phase: 1.0,
    });
    identity_residual(&m, &paper_grid());
}

#[test]
fn pedestals_are_an_effective_bearing() {
    let mut m = RotorModel::paper();
    let ped = |mass: f64, k: f64, c: f64| Pedestal {
        mass: [mass, 1.2 * mass],
        k: [k, 1.3 * k],
        c: [c, 0.7 * c],
    };
    m.bearings[0].pedestal = Some(ped(40.0, 2e8, 2e3));
    m.bearings[1].pedestal = Some(ped(25.0, 1e8, 1e3));
    let speeds = paper_grid();
    // The table does not see the pedestals at all ...
    let plain = build(&RotorModel::paper(), &speeds).unwrap();
    let with = build(&m, &speeds).unwrap();
    assert_eq!(plain.terms, with.terms);
    // ... and the identity holds with Z_eff = Z_B - Z_B (Z_B + Z_P)^-1 Z_B.
    m.name = "pedestals as effective bearings".into();
    identity_residual(&m, &speeds);
}

#[test]
fn poles_are_where_the_pinned_shaft_resonates() {
    let model = RotorModel::paper();
    let fe = FeModel::new(&model).unwrap();
    let r = Reducer::new(&fe, &model).unwrap();
    let wmax = rotorid::units::rpm_to_rad_s(15000.0);
    let poles = r.poles(2.0 * wmax, 16);
    let rpm: Vec<f64> = poles
        .iter()
        .map(|&w| rotorid::units::rad_s_to_rpm(w))
        .collect();
    println!("poles up to 30000 rpm: {rpm:?}");
    // The SPEC: the shaft with its bearing points held fixed resonates near 6870 rpm.
    assert!(rpm.iter().any(|&p| (p - 6870.0).abs() < 100.0), "{rpm:?}");
    for &p in &poles {
        // A blows up at the pole: det Z_ii = 0 there.
        let near = r.reduce(p * (1.0 + 1e-9)).unwrap().a.norm();
        let far = r.reduce(p * 0.9).unwrap().a.norm();
        assert!(near > 1e5 * far, "pole {p}: {near} vs {far}");
        // And p A is smooth: on either side, the products agree.
        let lo = r.reduce(p * (1.0 - 1e-7)).unwrap();
        let hi = r.reduce(p * (1.0 + 1e-7)).unwrap();
        let f = |t: &ReducedTerms| &t.a * Complex64::from(p * p - t.omega * t.omega);
        assert!(rel(&f(&lo), &f(&hi)) < 1e-4);
    }
    // A speed exactly on a pole is not a silent infinity.
    let _ = r.reduce(poles[0]).map(|t| assert!(t.a.norm() > 1e12));
}

#[test]
fn bad_bearing_layout_is_an_error() {
    let mut m = RotorModel::paper();
    let fe = FeModel::new(&m).unwrap();
    m.bearings.push(Bearing {
        node: 26,
        ..m.bearings[1].clone()
    });
    assert!(Reducer::new(&fe, &m).is_err());
    let m2 = RotorModel::paper();
    let r = Reducer::new(&fe, &m2).unwrap();
    assert!(r.reduce(f64::NAN).is_err());
    // A single bearing does not hold the shaft: a clear error, no panic.
    let mut m3 = RotorModel::paper();
    m3.bearings.truncate(1);
    let fe3 = FeModel::new(&m3).unwrap();
    let e = Reducer::new(&fe3, &m3).err().map(|e| e.to_string());
    assert!(
        e.as_deref().is_some_and(|e| e.contains("two bearings")),
        "{e:?}"
    );
}
