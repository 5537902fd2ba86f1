//! Reduction of the shaft-and-disk finite-element model to the bearing
//! degrees of freedom, speed by speed (the paper's Eqs. 35-39, 44-46, with
//! the corrections of the project specification).
//!
//! # Derivation
//!
//! Split the shaft DOFs into `q_B` (the `y`, `z` translations at the
//! bearing nodes, `2 N_b` entries ordered `b1_y, b1_z, b2_y, ...`) and
//! `q_i` (every other shaft DOF, the rotations at the bearing nodes
//! included). With `Z_R = K - Omega^2 M + j Omega^2 G` the dynamic stiffness
//! of shaft and disks only (no bearings, no pedestals, no shaft damping: models with rotor-level
//! proportional damping are refused),
//! `Z_B` the bearings' dynamic stiffness (acting on `q_B` only) and the
//! unbalance force `f = Omega^2 T a = [f_i; f_B]` (`T`: `1` at a plane's `y`
//! DOF, `-j` at its `z` DOF; `a_k = m_k e_k exp(j alpha_k)`), the harmonic
//! equations of motion are (Eq. 35 with its top-right block read as
//! `Z_R,iB`)
//!
//! ```text
//! Z_ii q_i + Z_iB q_B             = f_i        (36)
//! Z_Bi q_i + (Z_BB + Z_B) q_B     = f_B        (37)
//! ```
//!
//! Eliminating `q_i = Z_ii^-1 (f_i - Z_iB q_B)` from (37), with
//! `Y = Z_Bi Z_ii^-1` (39):
//!
//! ```text
//! (Z_BB - Y Z_iB) q_B = -Z_B q_B + f_B - Y f_i
//! A q_B = -Z_B q_B + B a,   A = Z_BB - Y Z_iB,   B = Omega^2 (T_B - Y T_i)
//! ```
//!
//! (`T_B = 0` unless a plane sits at a bearing node, and then
//! `B = -Omega^2 Y T`, the paper's Eq. 44/46). `d = A q_B` is the
//! identifier's desired response (Eq. 45).
//!
//! # Computation, without cancellation
//!
//! Evaluated literally, `A = Z_BB - Z_Bi Z_ii^-1 Z_iB` subtracts numbers of
//! the order of the shaft's element stiffness (`~1e10 N/m` for the paper
//! rotor) to get a result of the order of `Omega^2` times the shaft mass
//! (`~2e3 N/m` at 50 rpm): for a shaft on two bearings `A(0) = 0` exactly
//! (any bearing displacement is a rigid-body motion of the free shaft), and
//! the literal formula keeps only `~eps |Z_BB| / |A|` relative accuracy
//! (`1e-9` at 50 rpm). So the static part is split off first. With
//! `Z = K - Omega^2 H` (`H = M - j G`, Hermitian, speed-independent) and the
//! static shapes `X_0 = -K_ii^-1 K_iB` (one banded solve, once):
//!
//! ```text
//! A(Omega) = S_K - Omega^2 M_red - Omega^4 V_L Z_ii(Omega)^-1 V
//! B(Omega) = Omega^2 (T_red + Omega^2 V_L Z_ii(Omega)^-1 T_i)
//!
//! S_K   = K_BB + K_Bi X_0                          (static condensation)
//! V     = H_ii X_0 + H_iB,   V_L = H_Bi + X_0^T H_ii
//! M_red = H_BB + H_Bi X_0 + X_0^T V
//! T_red = T_B + X_0^T T_i
//! ```
//!
//! (exact algebra: with `Phi = [X_0; I]`, `Z_ii X_0 + Z_iB = -Omega^2 V`
//! because `K_ii X_0 + K_iB = 0`, and `Z_Bi + X_0^T Z_ii = -Omega^2 V_L`).
//! `S_K` vanishes exactly for statically determinate supports (one or two
//! bearings); computed, it is round-off of order `eps |K_BB|`, and it is set
//! to zero when `|S_K|_F <= 1e-11 |K_BB|_F` (for three or more bearings it
//! is of the order of `|K_BB|` and is kept).
//!
//! Per speed this costs one banded LU of `Z_ii` (`Z_R` with the bearing
//! rows and columns removed, still banded with the same half bandwidth) and
//! `2 N_b + N_p` right-hand sides `[V, T_i]`, `O(n kl^2 + n kl (2 N_b + N_p))`.
//! Never an explicit inverse. [`DenseReducer`] is the same algebra with
//! dense matrices and dense LU (`O(n^3)` per speed), for the tests and the
//! benchmark; [`reduce_schur_dense`] is the literal Eq. 38/39 formula, an
//! independent check of the algebra.
//!
//! # Pedestals are part of "the bearing"
//!
//! Pedestals are NOT in the reduction. A probe measures the shaft's
//! absolute displacement at the bearing node; a pedestal of dynamic
//! stiffness `Z_P` under a bearing `Z_B` (the bearing acting between shaft
//! and pedestal) exerts on the shaft exactly the force of an effective,
//! speed-dependent bearing
//!
//! ```text
//! Z_eff = Z_B - Z_B (Z_B + Z_P)^-1 Z_B
//! ```
//!
//! so `A q_B = -Z_eff q_B + B a` holds with the same `A` and `B`. The
//! identification therefore estimates `Z_eff` (bearing and foundation in
//! series), and the table does not depend on the foundation at all.
//!
//! # Poles
//!
//! `Y`, hence `A` and `B / Omega^2`, has poles where `det Z_ii(Omega) = 0`:
//! the 1X resonances of the shaft with its bearing points held fixed. Since
//! `Z_ii = K_ii - Omega^2 H_ii` with `H = M - j G` Hermitian and `K_ii`
//! positive definite (two or more bearings pin the shaft), the poles are
//! `Omega_k = 1 / sqrt(mu_k)` for the positive eigenvalues `mu_k` of the
//! Hermitian matrix `L^-1 H_ii L^-H`, `K_ii = L L^T` ([`Reducer::poles`]).
//! The table's interpolation divides them out (see [`rotorid_core::table`]).

use nalgebra::{Cholesky, DMatrix, SymmetricEigen};
use num_complex::Complex64;
use thiserror::Error;

use crate::fe::assembly::{Dir, FeError, FeModel};
use crate::fe::banded::{BandedError, BandedMatrix};
use crate::model::{ModelError, RotorModel};

pub mod modal;
pub use modal::ModalReducer;

/// The poles of the reduced model (rad/s, increasing), per matrix: `A`
/// has every pole of `Y`, `B` only those the unbalance excites (see
/// [`rotorid_core::table`]).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PoleSets {
    /// Poles of `A`.
    pub a: Vec<f64>,
    /// Poles of `B`.
    pub b: Vec<f64>,
}

impl PoleSets {
    /// No poles: plain linear interpolation of `X / Omega^2`.
    pub fn none() -> Self {
        PoleSets::default()
    }
}

/// `A` and `B` at one speed.
#[derive(Debug, Clone, PartialEq)]
pub struct ReducedTerms {
    /// Speed Omega (rad/s).
    pub omega: f64,
    /// `A = Z_R,BB - Y Z_R,iB` (N/m), `2 N_b x 2 N_b`.
    pub a: DMatrix<Complex64>,
    /// `B = Omega^2 (T_B - Y T_i)` (1/s^2, times `a` in kg m gives N),
    /// `2 N_b x N_p`.
    pub b: DMatrix<Complex64>,
}

/// Errors of the reduction.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ReductionError {
    /// The rotor description is invalid.
    #[error(transparent)]
    Model(#[from] ModelError),
    /// The FE model could not be evaluated.
    #[error(transparent)]
    Fe(#[from] FeError),
    /// The band solve failed: `Z_ii` singular, i.e. the speed is exactly on
    /// a resonance of the shaft with its bearing points held fixed.
    #[error("Z_ii singular (speed on a pinned-shaft resonance): {0}")]
    Banded(#[from] BandedError),
    /// The dense solve failed (same cause).
    #[error("Z_ii singular at {0} rad/s (dense reference)")]
    DenseSingular(f64),
    /// Bad input (non-finite speed, model and FE model disagree, ...).
    #[error("{0}")]
    Invalid(String),
}

/// Speed-independent parts of the split formulation (module docs).
#[derive(Debug, Clone)]
struct Statics {
    /// `S_K` (`2 N_b x 2 N_b`), zeroed when round-off.
    s_k: DMatrix<Complex64>,
    /// `M_red` (`2 N_b x 2 N_b`).
    m_red: DMatrix<Complex64>,
    /// `V_L` (`2 N_b x n_i`).
    v_l: DMatrix<Complex64>,
    /// `[V, T_i]` (`n_i x (2 N_b + N_p)`), the right-hand sides.
    rhs: DMatrix<Complex64>,
    /// `T_red` (`2 N_b x N_p`).
    t_red: DMatrix<Complex64>,
}

/// Relative size below which `S_K` is round-off (module docs).
pub const STATIC_ROUNDOFF: f64 = 1e-11;

/// Dense `K_s` (real) and `H = M - j G` of the shaft DOFs, from the FE
/// model's dense accessors (not from differences of `Z_R`, which would lose
/// `M` against `K`).
fn dense_k_h(fe: &FeModel) -> (DMatrix<f64>, DMatrix<Complex64>) {
    let n = fe.n_shaft_dof();
    let shaft = |d: DMatrix<f64>| d.view((0, 0), (n, n)).into_owned();
    let (k, m, g) = (
        shaft(fe.shaft_stiffness_matrix()),
        shaft(fe.mass_matrix()),
        shaft(fe.gyroscopic_matrix()),
    );
    let h = DMatrix::from_fn(n, n, |i, j| Complex64::new(m[(i, j)], -g[(i, j)]));
    (k, h)
}

/// The split formulation needs `Z_R = K - Omega^2 H` with `H` independent
/// of speed; rotor-level proportional damping (`C_R = alpha M + beta K`)
/// breaks that, so the reduction (and the identification and tables built
/// on it) refuses such models rather than dropping the damping.
fn refuse_rotor_damping(fe: &FeModel) -> Result<(), ReductionError> {
    let d = fe.model().rotor_damping;
    if d.is_zero() {
        Ok(())
    } else {
        Err(ReductionError::Invalid(format!(
            "rotor-level proportional damping (alpha = {}, beta = {}) is not supported by the reduction to the bearings used for identification; it is used by the response and Campbell analyses only",
            d.alpha, d.beta
        )))
    }
}

/// Splits the shaft DOFs into bearing DOFs `q_B` (channel order) and the
/// interior `q_i` (increasing), checking the bearing nodes.
fn partition(fe: &FeModel, model: &RotorModel) -> Result<(Vec<usize>, Vec<usize>), ReductionError> {
    let n = fe.n_shaft_dof();
    if model.n_nodes() != fe.n_nodes() {
        return Err(ReductionError::Invalid(format!(
            "model has {} nodes, FE model {}",
            model.n_nodes(),
            fe.n_nodes()
        )));
    }
    if model.bearings.len() < 2 {
        // One bearing cannot stop the free shaft tilting about it: K_ii is
        // singular (numerically, a tiny pivot), the reduction meaningless.
        return Err(ReductionError::Invalid(
            "the reduction needs at least two bearings to hold the shaft".into(),
        ));
    }
    let bearing: Vec<usize> = model
        .bearings
        .iter()
        .flat_map(|b| [fe.dof(b.node, Dir::Y), fe.dof(b.node, Dir::Z)])
        .collect();
    let mut is_b = vec![false; n];
    for &d in &bearing {
        match is_b.get_mut(d) {
            Some(x) if !*x => *x = true,
            _ => {
                return Err(ReductionError::Invalid(
                    "bearing nodes must be distinct and on the shaft".into(),
                ))
            }
        }
    }
    let interior: Vec<usize> = (0..n).filter(|&i| !is_b[i]).collect();
    Ok((bearing, interior))
}

/// The DOF partition, band structure and static parts of a model,
/// prepared once; then [`Reducer::reduce`] per speed.
#[derive(Debug, Clone)]
pub struct Reducer<'a> {
    fe: &'a FeModel,
    /// Bearing DOFs `q_B` (global shaft DOF indices), channel order.
    bearing: Vec<usize>,
    /// Interior DOFs `q_i` (global indices, increasing).
    interior: Vec<usize>,
    statics: Statics,
    /// `X_0 = -K_ii^-1 K_iB` (`n_i x 2 N_b`).
    x0: DMatrix<Complex64>,
}

/// The shaft's response at probe DOFs (any shaft DOFs, bearing DOFs
/// included) in terms of the bearing response, at one speed:
///
/// ```text
///     q_probe = P q_B + L f,      q_i = X_0 q_B + Z_ii^-1 (Omega^2 V q_B + f_i)
/// ```
///
/// (the interior rows of Eq. 36 with `Z_ii X_0 + Z_iB = -Omega^2 V`), `f`
/// any load of the reducer's load columns: `L` holds `R t_i` per column,
/// `R` the probe rows of `Z_ii^-1`, so an unbalance `a` (kg m) adds
/// `Omega^2 L a` and a bow forcing column adds `L beta`. A probe at a
/// bearing DOF reads `q_B` itself (`P` a unit row, `L` zero).
#[derive(Debug, Clone, PartialEq)]
pub struct ProbeTerms {
    /// `P` (`n_probe x 2 N_b`, dimensionless).
    pub p: DMatrix<Complex64>,
    /// `L` (`n_probe x N_loads`, m per unit of the load column).
    pub l: DMatrix<Complex64>,
}

/// `Z_ii` in band storage: `zr` without the bearing rows and columns
/// (removing rows and columns together never widens the band). Only the
/// band is visited: `O(n kl)`.
fn interior_block(zr: &BandedMatrix, interior: &[usize]) -> Result<BandedMatrix, BandedError> {
    let (kl, ku) = (zr.kl(), zr.ku());
    let ni = interior.len();
    let mut out = BandedMatrix::zeros(ni, kl, ku);
    for (pj, &j) in interior.iter().enumerate() {
        let lo = pj.saturating_sub(kl.max(ku));
        let hi = (pj + kl.max(ku) + 1).min(ni);
        for (pi, &i) in interior.iter().enumerate().take(hi).skip(lo) {
            if zr.in_band(i, j) && out.in_band(pi, pj) {
                let v = zr.get(i, j);
                if v.re != 0.0 || v.im != 0.0 {
                    out.set(pi, pj, v)?;
                }
            }
        }
    }
    Ok(out)
}

/// The static parts from dense `K`, `H` (shaft DOFs), the partition and
/// `X_0` (`n_i x 2 N_b`).
fn statics(
    k: &DMatrix<Complex64>,
    h: &DMatrix<Complex64>,
    t: &DMatrix<Complex64>,
    bearing: &[usize],
    interior: &[usize],
    x0: &DMatrix<Complex64>,
) -> Statics {
    let pick = |m: &DMatrix<Complex64>, rows: &[usize], cols: &[usize]| {
        DMatrix::from_fn(rows.len(), cols.len(), |r, c| m[(rows[r], cols[c])])
    };
    let (b, i) = (bearing, interior);
    let k_bb = pick(k, b, b);
    let mut s_k = &k_bb + pick(k, b, i) * x0;
    if s_k.norm() <= STATIC_ROUNDOFF * k_bb.norm() {
        s_k.fill(Complex64::new(0.0, 0.0));
    }
    let x0t = x0.transpose();
    let h_ii = pick(h, i, i);
    let h_bi = pick(h, b, i);
    let v = &h_ii * x0 + pick(h, i, b);
    let v_l = &h_bi + &x0t * &h_ii;
    let m_red = pick(h, b, b) + &h_bi * x0 + &x0t * &v;
    let t_i = t.select_rows(i.iter());
    let t_red = t.select_rows(b.iter()) + &x0t * &t_i;
    let mut rhs = DMatrix::zeros(i.len(), b.len() + t.ncols());
    rhs.view_mut((0, 0), (i.len(), b.len())).copy_from(&v);
    rhs.view_mut((0, b.len()), (i.len(), t.ncols()))
        .copy_from(&t_i);
    Statics {
        s_k,
        m_red,
        v_l,
        rhs,
        t_red,
    }
}

/// `A` and `B` from the statics and the solution `Y = Z_ii^-1 [V, T_i]`.
fn assemble(st: &Statics, y: &DMatrix<Complex64>, omega: f64) -> ReducedTerms {
    debug_assert_eq!(y.nrows(), st.v_l.ncols());
    let vy = &st.v_l * y; // 2 N_b x (2 N_b + N_p)
    assemble_vy(st, &vy, omega)
}

/// `A` and `B` from `V_L Z_ii^-1 [V, T_i]`.
fn assemble_vy(st: &Statics, vy: &DMatrix<Complex64>, omega: f64) -> ReducedTerms {
    let nq = st.s_k.nrows();
    let np = st.t_red.ncols();
    let w2 = Complex64::from(omega * omega);
    let a = &st.s_k - &st.m_red * w2 - vy.view((0, 0), (nq, nq)) * (w2 * w2);
    let b = (&st.t_red + vy.view((0, nq), (nq, np)) * w2) * w2;
    ReducedTerms { omega, a, b }
}

impl<'a> Reducer<'a> {
    /// Prepares the partition for the bearings and unbalance planes of
    /// `model` (the model `fe` was built from), and the static parts: one
    /// banded LU of `K_ii` for `X_0`. Fails if `K_ii` is singular (a shaft
    /// on a single bearing is a mechanism).
    pub fn new(fe: &'a FeModel, model: &RotorModel) -> Result<Self, ReductionError> {
        let t = fe.unbalance_distribution(&model.planes)?;
        Self::with_loads(fe, model, t)
    }

    /// [`Reducer::new`] with arbitrary load columns instead of the unbalance
    /// planes: each column of `loads` (`4 N_nodes` shaft DOFs, any unit) is a
    /// load shape `t`, and [`Reducer::reduce`] returns in column `k` of `B`
    /// `Omega^2 (t_B - Y t_i)`, so `B / Omega^2` is the load reduced to the
    /// bearing DOFs. A unit unbalance at a node is the column of
    /// [`FeModel::unbalance_distribution`]; a bow forcing `K_s q_bow`
    /// ([`FeModel::bow_force`]) gives its reduced force after dividing by
    /// `Omega^2`.
    pub fn with_loads(
        fe: &'a FeModel,
        model: &RotorModel,
        t: DMatrix<Complex64>,
    ) -> Result<Self, ReductionError> {
        let (bearing, interior) = partition(fe, model)?;
        refuse_rotor_damping(fe)?;
        if t.nrows() != fe.n_shaft_dof() {
            return Err(ReductionError::Invalid(format!(
                "load columns have {} rows, the shaft has {} DOFs",
                t.nrows(),
                fe.n_shaft_dof()
            )));
        }
        let z0 = fe.rotor_dynamic_stiffness(0.0);
        // Dense K and H = M - j G of the shaft DOFs (set-up only).
        let (kd, h) = dense_k_h(fe);
        let k = kd.map(Complex64::from);
        let mut x0 = DMatrix::from_fn(interior.len(), bearing.len(), |r, c| {
            -z0.get(interior[r], bearing[c])
        });
        interior_block(&z0, &interior)?
            .into_lu()
            .and_then(|lu| lu.solve_many(&mut x0))
            .map_err(|e| {
                ReductionError::Invalid(format!(
                    "the bearings do not hold the shaft (K_ii singular, e.g. a single bearing): {e}"
                ))
            })?;
        let statics = statics(&k, &h, &t, &bearing, &interior, &x0);
        Ok(Reducer {
            fe,
            bearing,
            interior,
            statics,
            x0,
        })
    }

    /// Number of bearing channels `2 N_b`.
    pub fn n_channels(&self) -> usize {
        self.bearing.len()
    }

    /// Number of unbalance planes.
    pub fn n_planes(&self) -> usize {
        self.statics.t_red.ncols()
    }

    /// `A(omega)` and `B(omega)` by one banded LU of `Z_ii` with
    /// `2 N_b + N_p` right-hand sides (see the module docs).
    pub fn reduce(&self, omega: f64) -> Result<ReducedTerms, ReductionError> {
        if !omega.is_finite() {
            return Err(ReductionError::Invalid(format!(
                "speed must be finite, got {omega}"
            )));
        }
        let zr = self.fe.rotor_dynamic_stiffness(omega);
        let zii = interior_block(&zr, &self.interior)?;
        let mut y = self.statics.rhs.clone();
        zii.into_lu()?.solve_many(&mut y)?;
        Ok(assemble(&self.statics, &y, omega))
    }

    /// [`Reducer::reduce`] by the adjoint: `W = V_L Z_ii^-1` from one
    /// banded LU of `Z_ii^T` with `2 N_b` right-hand sides
    /// (`Z_ii^T W^T = V_L^T`; `Z_ii` is not symmetric, the gyroscopic part
    /// is skew), then `V_L Z_ii^-1 [V, T_i] = W [V, T_i]` by products. The
    /// same numbers for any number of load columns at the cost of `2 N_b`
    /// solves: the choice when there are many loads
    /// ([`Reducer::with_loads`]).
    pub fn reduce_adjoint(&self, omega: f64) -> Result<ReducedTerms, ReductionError> {
        self.reduce_adjoint_probes(omega, &[]).map(|(t, _)| t)
    }

    /// [`Reducer::reduce_adjoint`] and the [`ProbeTerms`] of the shaft DOFs
    /// `probe_dofs` (global shaft DOF indices) from the same banded LU of
    /// `Z_ii^T`: the probe rows `R` of `Z_ii^-1` are `n_probe` more
    /// right-hand sides (`Z_ii^T R^T = E`, `E` the interior probe
    /// selector), then `[R V, R T_i] = R [V, T_i]` by one product.
    pub fn reduce_adjoint_probes(
        &self,
        omega: f64,
        probe_dofs: &[usize],
    ) -> Result<(ReducedTerms, ProbeTerms), ReductionError> {
        if !omega.is_finite() {
            return Err(ReductionError::Invalid(format!(
                "speed must be finite, got {omega}"
            )));
        }
        let n_shaft = self.fe.n_shaft_dof();
        if let Some(d) = probe_dofs.iter().find(|&&d| d >= n_shaft) {
            return Err(ReductionError::Invalid(format!(
                "probe DOF {d} beyond the shaft's {n_shaft} DOFs"
            )));
        }
        let zr = self.fe.rotor_dynamic_stiffness(omega);
        let zii = interior_block(&zr, &self.interior)?;
        let n = zii.n();
        let (kl, ku) = (zii.kl(), zii.ku());
        let mut zt = BandedMatrix::zeros(n, ku, kl);
        for j in 0..n {
            for i in j.saturating_sub(ku)..(j + kl + 1).min(n) {
                if zii.in_band(i, j) {
                    zt.set(j, i, zii.get(i, j))?;
                }
            }
        }
        let nq = self.bearing.len();
        let np = probe_dofs.len();
        let mut wt = DMatrix::<Complex64>::zeros(n, nq + np);
        wt.view_mut((0, 0), (n, nq))
            .copy_from(&self.statics.v_l.transpose());
        // Interior index of each probe DOF, or its bearing channel.
        let mut place: Vec<Result<usize, usize>> = Vec::with_capacity(np);
        for (k, d) in probe_dofs.iter().enumerate() {
            match self.interior.binary_search(d) {
                Ok(i) => {
                    wt[(i, nq + k)] = Complex64::new(1.0, 0.0);
                    place.push(Ok(i));
                }
                Err(_) => {
                    let ch = self.bearing.iter().position(|b| b == d).ok_or_else(|| {
                        ReductionError::Invalid(format!("probe DOF {d} is not a shaft DOF"))
                    })?;
                    place.push(Err(ch));
                }
            }
        }
        zt.into_lu()?.solve_many(&mut wt)?;
        let all = wt.tr_mul(&self.statics.rhs); // (nq + np) x (nq + N_loads)
        let terms = assemble_vy(&self.statics, &all.rows(0, nq).into_owned(), omega);
        let n_loads = self.statics.rhs.ncols() - nq;
        let w2 = Complex64::from(omega * omega);
        let mut p = DMatrix::<Complex64>::zeros(np, nq);
        let mut l = DMatrix::<Complex64>::zeros(np, n_loads);
        for (k, pl) in place.iter().enumerate() {
            match *pl {
                Ok(i) => {
                    for c in 0..nq {
                        p[(k, c)] = self.x0[(i, c)] + all[(nq + k, c)] * w2;
                    }
                    for c in 0..n_loads {
                        l[(k, c)] = all[(nq + k, nq + c)];
                    }
                }
                Err(ch) => p[(k, ch)] = Complex64::new(1.0, 0.0),
            }
        }
        Ok((terms, ProbeTerms { p, l }))
    }

    /// The poles of the reduced model (rad/s, increasing): the speeds where
    /// `Z_ii(Omega) = K_ii - Omega^2 H_ii` is singular, from the positive
    /// eigenvalues `mu` of `L^-1 H_ii L^-H` (`K_ii = L L^T` Cholesky,
    /// `H = M - j G`): `Omega_k = mu^-1/2`. Only poles up
    /// to `omega_max` are returned, at most `max_count` (the lowest).
    /// Empty if `K_ii` is not positive definite (fewer than two bearings:
    /// the shaft is not pinned), in which case the interpolation is plain
    /// linear.
    pub fn poles(&self, omega_max: f64, max_count: usize) -> Vec<f64> {
        let (kd, hd) = dense_k_h(self.fe);
        let ii = &self.interior;
        let k = DMatrix::<Complex64>::from_fn(ii.len(), ii.len(), |r, c| {
            // K is real symmetric; symmetrise against round-off.
            Complex64::from(0.5 * (kd[(ii[r], ii[c])] + kd[(ii[c], ii[r])]))
        });
        let h = DMatrix::<Complex64>::from_fn(ii.len(), ii.len(), |r, c| hd[(ii[r], ii[c])]);
        let h = (&h + h.adjoint()) * Complex64::from(0.5);
        let Some(chol) = Cholesky::new(k) else {
            return Vec::new();
        };
        let l = chol.l();
        // C = L^-1 H L^-H by two triangular solves.
        let Some(y) = l.solve_lower_triangular(&h) else {
            return Vec::new();
        };
        let Some(ct) = l.solve_lower_triangular(&y.adjoint()) else {
            return Vec::new();
        };
        let c = (&ct + ct.adjoint()) * Complex64::from(0.5);
        let eig = SymmetricEigen::new(c);
        let mut poles: Vec<f64> = eig
            .eigenvalues
            .iter()
            .filter(|&&mu| mu > 0.0)
            .map(|&mu| 1.0 / mu.sqrt())
            .filter(|&w| w.is_finite() && w <= omega_max)
            .collect();
        poles.sort_by(f64::total_cmp);
        poles.dedup();
        poles.truncate(max_count);
        poles.iter().map(|&p| self.refine_pole(p)).collect()
    }

    /// The poles split per matrix ([`PoleSets`]): [`Reducer::poles`], each
    /// kept for `X = A` (resp. `B`) if `X` really has it, i.e. if
    /// `|X(p (1 + 1e-6))| > 30 |X(p (1 + 1e-3))|` (a simple pole gives a
    /// ratio near 1000, no pole a ratio near 1). For an axisymmetric shaft
    /// the backward-whirl poles drop out of `B`.
    pub fn pole_sets(&self, omega_max: f64, max_count: usize) -> PoleSets {
        let mut sets = PoleSets::none();
        for p in self.poles(omega_max, max_count) {
            let (Ok(near), Ok(far)) =
                (self.reduce(p * (1.0 + 1e-6)), self.reduce(p * (1.0 + 1e-3)))
            else {
                sets.a.push(p);
                sets.b.push(p);
                continue;
            };
            if near.a.norm() > 30.0 * far.a.norm() {
                sets.a.push(p);
            }
            if near.b.norm() > 30.0 * far.b.norm() {
                sets.b.push(p);
            }
        }
        sets
    }

    /// Moves an eigenvalue pole `p` onto the pole of [`Reducer::reduce`]
    /// itself: `1 / A_kk(Omega)` (`A` is Hermitian, its diagonal real) is
    /// smooth and crosses zero linearly at the pole, for the `k` with the
    /// largest `|A_kk|` near `p`; a few secant steps from `p (1 -+ 1e-7)`
    /// find that zero to round-off. The eigenvalue computation alone leaves
    /// `~1e-12` relative, which would limit the interpolation error within
    /// `1e-5` of the pole. Returns `p` unchanged if the secant steps leave
    /// `p (1 +- 1e-6)`.
    pub fn refine_pole(&self, p: f64) -> f64 {
        let diag = |w: f64| self.reduce(w).ok().map(|t| t.a.diagonal());
        let Some(d) = diag(p * (1.0 + 1e-7)) else {
            return p;
        };
        let Some(k) = (0..d.len()).max_by(|&i, &j| d[i].norm().total_cmp(&d[j].norm())) else {
            return p;
        };
        let g = |w: f64| diag(w).and_then(|d| d.get(k).map(|z| 1.0 / z.re));
        let (mut x0, mut x1) = (p * (1.0 - 1e-7), p * (1.0 + 1e-7));
        let (Some(mut f0), Some(mut f1)) = (g(x0), g(x1)) else {
            return p;
        };
        for _ in 0..8 {
            if f1 == f0 {
                break;
            }
            let x2 = x1 - f1 * (x1 - x0) / (f1 - f0);
            if !(x2.is_finite() && (x2 - p).abs() <= 1e-6 * p) {
                return p;
            }
            if (x2 - x1).abs() <= 4.0 * f64::EPSILON * p {
                return x2;
            }
            let Some(f2) = g(x2) else {
                // Exactly singular: x2 is the pole.
                return x2;
            };
            (x0, f0, x1, f1) = (x1, f1, x2, f2);
        }
        x1
    }
}

/// `A(omega)` and `B(omega)` for the bearings and planes of `model` (built
/// into `fe`), banded. For many speeds, prepare a [`Reducer`] once.
pub fn reduce(
    fe: &FeModel,
    model: &RotorModel,
    omega: f64,
) -> Result<ReducedTerms, ReductionError> {
    Reducer::new(fe, model)?.reduce(omega)
}

/// Dense reference for [`Reducer`]: the same split formulation (module
/// docs) with the dense `K_s`, `M`, `G` of the FE model (shaft DOFs only),
/// `Z_R = K_s - Omega^2 M + j Omega^2 G` formed densely and dense complex LU
/// (nalgebra) for `X_0` and for `Z_ii` at every speed: `O(n^3)` per speed.
#[derive(Debug, Clone)]
pub struct DenseReducer {
    k: DMatrix<f64>,
    m: DMatrix<f64>,
    g: DMatrix<f64>,
    interior: Vec<usize>,
    statics: Statics,
}

impl DenseReducer {
    /// Prepares the dense matrices and the static parts.
    pub fn new(fe: &FeModel, model: &RotorModel) -> Result<Self, ReductionError> {
        let (bearing, interior) = partition(fe, model)?;
        refuse_rotor_damping(fe)?;
        let n = fe.n_shaft_dof();
        let shaft = |d: DMatrix<f64>| d.view((0, 0), (n, n)).into_owned();
        let (k, m, g) = (
            shaft(fe.shaft_stiffness_matrix()),
            shaft(fe.mass_matrix()),
            shaft(fe.gyroscopic_matrix()),
        );
        let kc = k.map(Complex64::from);
        let h = DMatrix::from_fn(n, n, |i, j| Complex64::new(m[(i, j)], -g[(i, j)]));
        let pick = |rows: &[usize], cols: &[usize]| {
            DMatrix::from_fn(rows.len(), cols.len(), |r, c| kc[(rows[r], cols[c])])
        };
        let x0 = -pick(&interior, &interior)
            .lu()
            .solve(&pick(&interior, &bearing))
            .ok_or(ReductionError::DenseSingular(0.0))?;
        let t = fe.unbalance_distribution(&model.planes)?;
        let statics = statics(&kc, &h, &t, &bearing, &interior, &x0);
        Ok(DenseReducer {
            k,
            m,
            g,
            interior,
            statics,
        })
    }

    /// `A` and `B` at `omega` (dense).
    pub fn reduce(&self, omega: f64) -> Result<ReducedTerms, ReductionError> {
        let w2 = omega * omega;
        let ii = &self.interior;
        let zii = DMatrix::<Complex64>::from_fn(ii.len(), ii.len(), |r, c| {
            let (i, j) = (ii[r], ii[c]);
            Complex64::new(self.k[(i, j)] - w2 * self.m[(i, j)], w2 * self.g[(i, j)])
        });
        let y = zii
            .lu()
            .solve(&self.statics.rhs)
            .ok_or(ReductionError::DenseSingular(omega))?;
        Ok(assemble(&self.statics, &y, omega))
    }
}

/// Dense reference for [`reduce`] (see [`DenseReducer`]).
pub fn reduce_dense(
    fe: &FeModel,
    model: &RotorModel,
    omega: f64,
) -> Result<ReducedTerms, ReductionError> {
    DenseReducer::new(fe, model)?.reduce(omega)
}

/// The literal Eqs. 38-39 with dense matrices: `Y = Z_Bi Z_ii^-1` by a
/// dense LU, `A = Z_BB - Y Z_iB`, `B = Omega^2 (T_B - Y T_i)`. Independent
/// of the split formulation, but accurate only to `~eps |Z_BB| / |A|`
/// relative (see the module docs); for tests.
pub fn reduce_schur_dense(
    fe: &FeModel,
    model: &RotorModel,
    omega: f64,
) -> Result<ReducedTerms, ReductionError> {
    let (bearing, interior) = partition(fe, model)?;
    let n = fe.n_shaft_dof();
    let w2 = omega * omega;
    let (k, m, g) = (
        fe.shaft_stiffness_matrix(),
        fe.mass_matrix(),
        fe.gyroscopic_matrix(),
    );
    let z = DMatrix::<Complex64>::from_fn(n, n, |i, j| {
        Complex64::new(k[(i, j)] - w2 * m[(i, j)], w2 * g[(i, j)])
    });
    let pick = |rows: &[usize], cols: &[usize]| {
        DMatrix::from_fn(rows.len(), cols.len(), |r, c| z[(rows[r], cols[c])])
    };
    let t = fe.unbalance_distribution(&model.planes)?;
    let (t_i, t_b) = (
        t.select_rows(interior.iter()),
        t.select_rows(bearing.iter()),
    );
    // Y = Z_Bi Z_ii^-1, i.e. Y^T = Z_ii^-T Z_Bi^T.
    let y = pick(&interior, &interior)
        .transpose()
        .lu()
        .solve(&pick(&bearing, &interior).transpose())
        .ok_or(ReductionError::DenseSingular(omega))?
        .transpose();
    let a = pick(&bearing, &bearing) - &y * pick(&interior, &bearing);
    let b = (t_b - &y * t_i) * Complex64::from(w2);
    Ok(ReducedTerms { omega, a, b })
}
