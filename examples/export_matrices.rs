//! Writes the paper rotor's shaft matrices, unbalance loads and bearing DOFs
//! as raw files, for an independent reduction outside rotorid (the NumPy
//! comparison in `std-ext/benches/numpy/`), together with rotorid's own `A`
//! and `B` at three speeds to check it against.
//!
//! ```sh
//! cargo run --release --example export_matrices -- DIR
//! ```
//!
//! Files in `DIR` (created if missing), all little-endian `f64`, row-major
//! (C order); complex entries as interleaved `re, im` pairs:
//!
//! - `K.f64`, `M.f64`, `G.f64`: `n x n` real, the shaft stiffness, mass and
//!   gyroscopic matrices of the shaft DOFs (`n = 4 N_nodes`; shaft and
//!   disks, no bearings, no pedestals), as `Z = K - w^2 M + j w^2 G`;
//! - `T.c128`: `n x N_p` complex, the unbalance distribution (`1` at a
//!   plane's `y` DOF, `-j` at its `z` DOF);
//! - `check_A.c128`: `3 x 2N_b x 2N_b` and `check_B.c128`: `3 x 2N_b x N_p`
//!   complex, rotorid's banded split reduction (`Reducer::reduce`) at the
//!   speeds `check_omega` of the JSON; `check_A_modal.c128`,
//!   `check_B_modal.c128` the same from the modal reduction
//!   (`ModalReducer::reduce`, what `rotorid tables` uses);
//! - `model.json`: `n`, `n_planes`, `bearing_dofs` (0-based, channel order
//!   `b1_y, b1_z, b2_y, ...`), `planes`, `check_omega` (rad/s), file names
//!   and shapes.

use std::fs;
use std::path::{Path, PathBuf};

use nalgebra::DMatrix;
use num_complex::Complex64;
use rotorid::fe::assembly::{Dir, FeModel};
use rotorid::model::RotorModel;
use rotorid::reduce::Reducer;
use rotorid::tables::grid::linspace;
use rotorid::units::rpm_to_rad_s;
use serde_json::json;

type Error = Box<dyn std::error::Error>;

/// Row-major little-endian bytes of a real matrix.
fn real_bytes(m: &DMatrix<f64>) -> Vec<u8> {
    let mut out = Vec::with_capacity(8 * m.len());
    for i in 0..m.nrows() {
        for j in 0..m.ncols() {
            out.extend_from_slice(&m[(i, j)].to_le_bytes());
        }
    }
    out
}

/// Row-major little-endian bytes of a complex matrix (`re, im` pairs),
/// appended to `out`.
fn push_complex(out: &mut Vec<u8>, m: &DMatrix<Complex64>) {
    for i in 0..m.nrows() {
        for j in 0..m.ncols() {
            out.extend_from_slice(&m[(i, j)].re.to_le_bytes());
            out.extend_from_slice(&m[(i, j)].im.to_le_bytes());
        }
    }
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> Result<(), Error> {
    fs::write(dir.join(name), bytes)?;
    Ok(())
}

fn main() -> Result<(), Error> {
    let dir = PathBuf::from(
        std::env::args()
            .nth(1)
            .ok_or("usage: export_matrices DIR")?,
    );
    fs::create_dir_all(&dir)?;

    let model = RotorModel::paper();
    let fe = FeModel::new(&model)?;
    let n = fe.n_shaft_dof();
    let shaft = |d: DMatrix<f64>| d.view((0, 0), (n, n)).into_owned();
    let k = shaft(fe.shaft_stiffness_matrix());
    let m = shaft(fe.mass_matrix());
    let g = shaft(fe.gyroscopic_matrix());
    let t = fe.unbalance_distribution(&model.planes)?;
    let bearing_dofs: Vec<usize> = model
        .bearings
        .iter()
        .flat_map(|b| [fe.dof(b.node, Dir::Y), fe.dof(b.node, Dir::Z)])
        .collect();
    assert_eq!(bearing_dofs, fe.bearing_dofs());

    write(&dir, "K.f64", &real_bytes(&k))?;
    write(&dir, "M.f64", &real_bytes(&m))?;
    write(&dir, "G.f64", &real_bytes(&g))?;
    let mut tb = Vec::new();
    push_complex(&mut tb, &t);
    write(&dir, "T.c128", &tb)?;

    // Three speeds of the benchmark grid (15..15000 rpm, 1000 speeds):
    // indices 66, 400 and 900, i.e. about 1000, 6000 and 13500 rpm.
    let grid = linspace(rpm_to_rad_s(15.0), rpm_to_rad_s(15000.0), 1000);
    let check_index = [66usize, 400, 900];
    let check_omega: Vec<f64> = check_index.iter().map(|&i| grid[i]).collect();
    let reducer = Reducer::new(&fe, &model)?;
    let modal = reducer.modal()?;
    let (mut a_b, mut b_b, mut a_m, mut b_m) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for &w in &check_omega {
        let r = reducer.reduce(w)?;
        push_complex(&mut a_b, &r.a);
        push_complex(&mut b_b, &r.b);
        let r = modal.reduce(w)?;
        push_complex(&mut a_m, &r.a);
        push_complex(&mut b_m, &r.b);
    }
    write(&dir, "check_A.c128", &a_b)?;
    write(&dir, "check_B.c128", &b_b)?;
    write(&dir, "check_A_modal.c128", &a_m)?;
    write(&dir, "check_B_modal.c128", &b_m)?;

    let nq = bearing_dofs.len();
    let np = model.planes.len();
    let meta = json!({
        "model": "paper",
        "n": n,
        "n_planes": np,
        "bearing_dofs": bearing_dofs,
        "planes": model.planes,
        "check_index": check_index,
        "check_omega": check_omega,
        "layout": "little-endian f64, row-major; .c128 = interleaved re, im",
        "files": {
            "K.f64": [n, n],
            "M.f64": [n, n],
            "G.f64": [n, n],
            "T.c128": [n, np],
            "check_A.c128": [check_omega.len(), nq, nq],
            "check_B.c128": [check_omega.len(), nq, np],
            "check_A_modal.c128": [check_omega.len(), nq, nq],
            "check_B_modal.c128": [check_omega.len(), nq, np],
        },
    });
    fs::write(
        dir.join("model.json"),
        serde_json::to_string_pretty(&meta)? + "\n",
    )?;
    println!(
        "wrote {}: n = {n}, {nq} bearing DOFs {:?}, {np} planes, check speeds {:?} rad/s",
        dir.display(),
        bearing_dofs,
        check_omega
    );
    Ok(())
}
