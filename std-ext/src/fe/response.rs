//! Synchronous (1X) forced response: unbalance and shaft bow.
//!
//! At each speed `Omega` the phasor response solves (Eqs. 30-34, with the
//! `Omega^2` of the unbalance force restored and the bow forcing added)
//!
//! ```text
//! Z(Omega) q = Omega^2 T a + K_s q_bow,
//! Z(Omega) = K(Omega) - Omega^2 M + j Omega (C(Omega) + Omega G)
//! ```
//!
//! on the shaft DOFs, pedestals condensed exactly
//! ([`crate::fe::bearing`]), by one banded LU factorisation per speed
//! ([`crate::fe::banded`]); the pedestal responses follow from
//! `q_p = (Z_B + Z_P)^-1 Z_B q_s`. A dense reference implementation that
//! keeps the pedestal DOFs explicitly is [`unbalance_response_dense`].

use crate::fe::assembly::{FeError, FeModel};
use crate::model::{RotorModel, ShaftBow, Unbalance};
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;

/// What drives the 1X response.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Forcing {
    /// Unbalance planes (force `Omega^2 a`, see [`crate::fe::assembly`]).
    pub unbalance: Vec<Unbalance>,
    /// Shaft bow (force `K_s q_bow`, speed-independent).
    pub bow: Option<ShaftBow>,
}

impl Forcing {
    /// The model's true unbalance and bow (what the simulator applies).
    pub fn from_model(model: &RotorModel) -> Self {
        Forcing {
            unbalance: model.unbalance.clone(),
            bow: model.bow.clone(),
        }
    }
}

/// Response at one speed.
#[derive(Debug, Clone, PartialEq)]
pub struct Response {
    /// Speed (rad/s).
    pub omega: f64,
    /// Phasors of all DOFs, order `n_dof`: shaft DOFs `4 node + dir`, then
    /// the pedestal DOFs (see [`FeModel::pedestal_dof`]) (m, rad).
    pub q: Vec<Complex64>,
    /// Shaft absolute displacement at the bearing nodes, `2 N_b` values
    /// `(b1_y, b1_z, b2_y, ...)` (m): what a probe on a rigid foundation sees.
    pub bearings: Vec<Complex64>,
    /// Pedestal displacement under each bearing, `2 N_b` values in the same
    /// order, zero where the bearing sits on the rigid ground (m).
    pub pedestals: Vec<Complex64>,
}

fn check_speeds(speeds: &[f64]) -> Result<(), FeError> {
    if let Some(s) = speeds.iter().find(|s| !s.is_finite() || **s < 0.0) {
        return Err(FeError::Invalid(format!(
            "speeds must be finite and >= 0, got {s}"
        )));
    }
    Ok(())
}

/// Unbalance (and bow) response at each speed in `speeds` (rad/s), by one
/// banded LU per speed.
pub fn unbalance_response(
    fe: &FeModel,
    forcing: &Forcing,
    speeds: &[f64],
) -> Result<Vec<Response>, FeError> {
    check_speeds(speeds)?;
    let bow_force = match &forcing.bow {
        Some(b) => Some(fe.bow_force(b)?),
        None => None,
    };
    let unit = fe.unbalance_force(&forcing.unbalance, 1.0)?;
    let bdofs = fe.bearing_dofs();
    let mut out = Vec::with_capacity(speeds.len());
    for &omega in speeds {
        let w2 = omega * omega;
        let mut rhs: Vec<Complex64> = unit.iter().map(|f| f * w2).collect();
        if let Some(fb) = &bow_force {
            for (r, b) in rhs.iter_mut().zip(fb) {
                *r += b;
            }
        }
        let z = fe.system_dynamic_stiffness(omega)?;
        z.into_lu()?.solve(&mut rhs)?;
        let pedestals = fe.pedestal_response(omega, &rhs)?;
        let bearings = bdofs.iter().map(|&d| rhs[d]).collect();
        let mut q = rhs;
        q.resize(fe.n_dof(), Complex64::new(0.0, 0.0));
        for (bi, _) in fe.model().bearings.iter().enumerate() {
            if let (Some(py), Some(pz)) = (
                fe.pedestal_dof(bi, crate::fe::assembly::Dir::Y),
                fe.pedestal_dof(bi, crate::fe::assembly::Dir::Z),
            ) {
                q[py] = pedestals[2 * bi];
                q[pz] = pedestals[2 * bi + 1];
            }
        }
        out.push(Response {
            omega,
            q,
            bearings,
            pedestals,
        });
    }
    Ok(out)
}

/// Only the bearing channels `(b1_y, b1_z, b2_y, ...)` of
/// [`unbalance_response`], one vector per speed (what a probe on each
/// bearing measures).
pub fn bearing_response(
    fe: &FeModel,
    forcing: &Forcing,
    speeds: &[f64],
) -> Result<Vec<Vec<Complex64>>, FeError> {
    Ok(unbalance_response(fe, forcing, speeds)?
        .into_iter()
        .map(|r| r.bearings)
        .collect())
}

/// Reference implementation: the same response from the dense matrices
/// with the pedestal DOFs kept explicitly, one dense complex LU per speed
/// (`O(n^3)`; for tests and benchmarks).
pub fn unbalance_response_dense(
    fe: &FeModel,
    forcing: &Forcing,
    speeds: &[f64],
) -> Result<Vec<Response>, FeError> {
    check_speeds(speeds)?;
    let n = fe.n_dof();
    let ns = fe.n_shaft_dof();
    let m = fe.mass_matrix();
    let g = fe.gyroscopic_matrix();
    let ks = fe.shaft_stiffness_matrix();
    let unit = fe.unbalance_force(&forcing.unbalance, 1.0)?;
    let mut bow = DVector::<Complex64>::zeros(n);
    if let Some(b) = &forcing.bow {
        let qb = fe.bow_shape(b)?;
        let mut qbv = DVector::<Complex64>::zeros(n);
        for (i, v) in qb.iter().enumerate() {
            qbv[i] = *v;
        }
        bow = ks.map(|v| Complex64::new(v, 0.0)) * qbv;
    }
    let bdofs = fe.bearing_dofs();
    let mut out = Vec::with_capacity(speeds.len());
    for &omega in speeds {
        let k = fe.stiffness_matrix(omega);
        let c = fe.damping_matrix(omega);
        let w2 = omega * omega;
        let z = DMatrix::from_fn(n, n, |i, j| {
            Complex64::new(
                k[(i, j)] - w2 * m[(i, j)],
                omega * c[(i, j)] + w2 * g[(i, j)],
            )
        });
        let mut rhs = bow.clone();
        for i in 0..ns {
            rhs[i] += unit[i] * w2;
        }
        let q = z.lu().solve(&rhs).ok_or(FeError::Invalid(format!(
            "singular dynamic stiffness at {omega} rad/s"
        )))?;
        let q: Vec<Complex64> = q.iter().copied().collect();
        let mut pedestals = vec![Complex64::new(0.0, 0.0); 2 * fe.model().bearings.len()];
        for (bi, _) in fe.model().bearings.iter().enumerate() {
            if let (Some(py), Some(pz)) = (
                fe.pedestal_dof(bi, crate::fe::assembly::Dir::Y),
                fe.pedestal_dof(bi, crate::fe::assembly::Dir::Z),
            ) {
                pedestals[2 * bi] = q[py];
                pedestals[2 * bi + 1] = q[pz];
            }
        }
        out.push(Response {
            omega,
            bearings: bdofs.iter().map(|&d| q[d]).collect(),
            q,
            pedestals,
        });
    }
    Ok(out)
}
