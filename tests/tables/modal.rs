//! The modal (pole-residue) reduction against the banded one: same `A`,
//! `B` on the paper grid, on a fine grid through the pinned-shaft poles,
//! and on a stepped rotor with three bearings.

use nalgebra::DMatrix;
use num_complex::Complex64;
use rotorid::fe::assembly::FeModel;
use rotorid::model::RotorModel;
use rotorid::reduce::{ReducedTerms, Reducer};
use rotorid::tables::grid::{linspace, uniform_rad_s};

fn rel(a: &DMatrix<Complex64>, b: &DMatrix<Complex64>) -> f64 {
    (a - b).norm() / b.norm()
}

fn worst(x: &ReducedTerms, y: &ReducedTerms) -> f64 {
    rel(&x.a, &y.a).max(rel(&x.b, &y.b))
}

/// Relative distance of `w` from the nearest pole.
fn pole_distance(w: f64, poles: &[f64]) -> f64 {
    poles
        .iter()
        .map(|&p| (w / p - 1.0).abs())
        .fold(f64::INFINITY, f64::min)
}

/// Modal against banded on the speeds of `grid`: both lose accuracy next
/// to a pole as `eps_pole / s` (`s` the relative distance from it, see
/// `rotorid::reduce::modal`); the difference must stay below
/// `1e-10 + 2e-12 / s`. Returns the worst difference and the worst ratio
/// to that bound.
fn compare(model: &RotorModel, grid: &[f64]) -> (f64, f64) {
    let fe = FeModel::new(model).unwrap();
    let banded = Reducer::new(&fe, model).unwrap();
    let modal = banded.modal().unwrap();
    let top = grid.iter().copied().fold(0.0, f64::max);
    let poles = banded.poles(2.0 * top, 64);
    let (mut diff, mut ratio): (f64, f64) = (0.0, 0.0);
    for &w in grid {
        let (Ok(x), Ok(y)) = (modal.reduce(w), banded.reduce(w)) else {
            continue;
        };
        let d = worst(&x, &y);
        diff = diff.max(d);
        ratio = ratio.max(d / (1e-10 + 2e-12 / pole_distance(w, &poles)));
    }
    (diff, ratio)
}

/// The paper rotor's interior is axisymmetric: the eigenproblem splits
/// into its whirl halves, with the same terms as the unsplit one.
#[test]
fn whirl_split_equals_the_whole_eigenproblem() {
    let model = RotorModel::paper();
    let fe = FeModel::new(&model).unwrap();
    let banded = Reducer::new(&fe, &model).unwrap();
    let (split, whole) = (banded.modal().unwrap(), banded.modal_unsplit().unwrap());
    assert!(split.whirl_split());
    assert!(!whole.whirl_split());
    let mut mu_s: Vec<f64> = split.mu().to_vec();
    let mut mu_w: Vec<f64> = whole.mu().to_vec();
    mu_s.sort_by(f64::total_cmp);
    mu_w.sort_by(f64::total_cmp);
    let scale = mu_w.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
    let d_mu = mu_s
        .iter()
        .zip(&mu_w)
        .fold(0.0_f64, |m, (a, b)| m.max((a - b).abs()));
    let poles = banded.poles(3200.0, 64);
    let mut ratio: f64 = 0.0;
    for w in uniform_rad_s(50.0, 15000.0, 50.0).unwrap() {
        let d = worst(&split.reduce(w).unwrap(), &whole.reduce(w).unwrap());
        ratio = ratio.max(d / (1e-10 + 2e-12 / pole_distance(w, &poles)));
    }
    println!(
        "whirl split vs whole: eigenvalues {:.2e} of the largest, terms {ratio:.3} of the bound",
        d_mu / scale
    );
    assert!(d_mu <= 1e-13 * scale, "{d_mu}");
    assert!(ratio < 1.0, "{ratio}");
}

#[test]
fn modal_equals_banded_on_the_paper_grid() {
    let grid = uniform_rad_s(5.0, 15000.0, 5.0).unwrap();
    let (diff, ratio) = compare(&RotorModel::paper(), &grid);
    println!("modal vs banded, 3000 speeds: worst difference {diff:.3e}, {ratio:.3} of the bound");
    assert!(ratio < 1.0, "{ratio}");
}

/// Within `1e-3 .. 1e-7` relative of each pole, both sides, and on a fine
/// grid through them.
#[test]
fn modal_equals_banded_next_to_the_poles() {
    let model = RotorModel::paper();
    let fe = FeModel::new(&model).unwrap();
    let poles = Reducer::new(&fe, &model).unwrap().poles(3000.0, 8);
    assert!(poles.len() >= 2, "{poles:?}");
    let mut near = Vec::new();
    for &p in &poles {
        for s in [1e-3, 1e-4, 1e-5, 1e-6, 1e-7] {
            near.extend([p * (1.0 - s), p * (1.0 + s)]);
        }
    }
    let (diff, ratio) = compare(&model, &near);
    println!(
        "next to {} poles: worst difference {diff:.3e}, {ratio:.3} of the bound",
        poles.len()
    );
    assert!(ratio < 1.0, "{ratio}");
    let (diff, ratio) = compare(&model, &linspace(1.0, 3000.0, 20011));
    println!("fine grid to 3000 rad/s: worst difference {diff:.3e}, {ratio:.3} of the bound");
    assert!(ratio < 1.0, "{ratio}");
}

/// Three bearings (a third at mid-span, node 14): the static condensation
/// `S_K` is no longer zero, the interior has a different band.
#[test]
fn modal_equals_banded_with_three_bearings() {
    let mut model = RotorModel::paper();
    let mid = rotorid::model::Bearing {
        node: 14,
        ..model.bearings[0].clone()
    };
    model.bearings.insert(1, mid);
    let grid = uniform_rad_s(50.0, 15000.0, 50.0).unwrap();
    let (diff, ratio) = compare(&model, &grid);
    println!("three bearings, 300 speeds: worst difference {diff:.3e}, {ratio:.3} of the bound");
    assert!(ratio < 1.0, "{ratio}");
    // A single bearing: the modal form refuses like the banded one.
    let mut one = RotorModel::paper();
    one.bearings.truncate(1);
    let fe = FeModel::new(&one).unwrap();
    assert!(Reducer::new(&fe, &one).is_err());
}
