//! Global finite-element matrices of a rotor-bearing system.
//!
//! # DOF numbering
//!
//! Shaft node `n` (0-based) carries the DOFs `(y, z, phi_y, phi_z)` numbered
//!
//! ```text
//! dof(n, dir) = 4 n + dir,    dir: Y = 0, Z = 1, PhiY = 2, PhiZ = 3
//! ```
//!
//! so the shaft + disk + bearing matrices have half bandwidth
//! [`HALF_BANDWIDTH`] = 7 (an element couples `4n .. 4n + 7`). The harmonic
//! analyses work on these `4 N_nodes` shaft DOFs only, pedestals being
//! condensed exactly at each frequency (see [`crate::fe::bearing`]), so the
//! band never widens. The dense matrices (for eigenvalues) append the
//! pedestal DOFs after the shaft DOFs: the `p`-th pedestal (in bearing
//! order, counting only bearings that have one) has
//! `pedestal_dof = 4 N_nodes + 2 p + {0: y, 1: z}`.
//!
//! # Equation of motion
//!
//! `M q'' + (C + Omega G) q' + K q = f` (the paper's Eq. 30), `f` and `q`
//! phasors at the rotor speed (`q(t) = Re{ q exp(j Omega t) }`), hence the
//! dynamic stiffness (Eq. 34)
//!
//! ```text
//! Z(Omega) = K - Omega^2 M + j Omega (C + Omega G)
//! ```
//!
//! and more generally, for eigenvalues `s`, `Z(s) = K + s (C + Omega G) + s^2 M`.
//! `M`, `G`, `K` of the shaft are the Timoshenko (default) or
//! Euler-Bernoulli elements of [`crate::fe::shaft`] (coaxial layers add
//! their own element matrices to their element's); disks add `M` and `G`
//! ([`crate::fe::disk`]); bearings add `K(Omega)` and `C(Omega)` ([`crate::fe::bearing`]).
//! Rotor-level proportional damping ([`crate::model::ProportionalDamping`])
//! adds `C_R = alpha M_R + beta K_R` (shaft and disks, N s/m) to `C`.
//!
//! # Forcing
//!
//! - Unbalance `a = m e exp(j alpha)` at node `n` (Eqs. 31-33, with the
//!   `Omega^2` of the force restored): `F_y = Omega^2 a`, `F_z = -j Omega^2 a`.
//! - Shaft bow: the unstressed centre line is bent by `q_bow` (fixed in the
//!   rotating frame), so the elastic force is `K_s (q - q_bow)` and the
//!   synchronous forcing is `K_s q_bow`, independent of speed. See
//!   [`FeModel::bow_shape`] for the interpolation of the given points.

use crate::fe::banded::{BandedError, BandedMatrix};
use crate::fe::bearing::{
    condense_pedestal, damping, law_dynamic_stiffness, pedestal_dynamic_stiffness, stiffness,
    BearingError,
};
use crate::fe::disk::disk_matrices;
use crate::fe::shaft::element_matrices;
use crate::model::{ModelError, RotorModel, ShaftBow, Unbalance};
use nalgebra::{DMatrix, Matrix2};
use num_complex::Complex64;
use thiserror::Error;

/// Half bandwidth of the shaft DOF numbering: `kl = ku = 7`.
pub const HALF_BANDWIDTH: usize = 7;

/// Direction of a node DOF.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Dir {
    /// Translation along y (m).
    Y = 0,
    /// Translation along z (m).
    Z = 1,
    /// Rotation about y, `phi_y = -dz/dx` (rad).
    PhiY = 2,
    /// Rotation about z, `phi_z = dy/dx` (rad).
    PhiZ = 3,
}

/// Global index of a shaft DOF: `dof(node, dir) = 4 node + dir` (no range
/// check).
pub fn dof(node: usize, dir: Dir) -> usize {
    4 * node + dir as usize
}

/// Errors of the FE analyses.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum FeError {
    /// The rotor description is invalid.
    #[error(transparent)]
    Model(#[from] ModelError),
    /// The band solver failed (singular dynamic stiffness, e.g. exactly at
    /// an undamped resonance).
    #[error(transparent)]
    Banded(#[from] BandedError),
    /// A pedestal condensation failed.
    #[error(transparent)]
    Bearing(#[from] BearingError),
    /// The eigenvalue solver did not converge.
    #[error("eigenvalue computation failed: {0}")]
    Eigen(String),
    /// A bad argument (non-finite speed, out-of-range node, ...).
    #[error("invalid argument: {0}")]
    Invalid(String),
}

/// Assembled FE model of a [`RotorModel`].
#[derive(Debug, Clone)]
pub struct FeModel {
    model: RotorModel,
    n_nodes: usize,
    /// Per bearing: index of its pedestal among the pedestals, if any.
    pedestal_index: Vec<Option<usize>>,
    n_pedestals: usize,
    /// Real band storage (layout of [`BandedMatrix::from_storage`] with
    /// `kl = ku = 7`) of M (shaft + disks), G (shaft + disks), K (shaft).
    m_band: Vec<f64>,
    g_band: Vec<f64>,
    k_band: Vec<f64>,
    /// Rotor damping `C_R = alpha M + beta K` (shaft + disks), same storage.
    c_band: Vec<f64>,
}

const KL: usize = HALF_BANDWIDTH;
const LDAB: usize = 3 * KL + 1;

#[inline]
fn bidx(i: usize, j: usize) -> usize {
    BandedMatrix::storage_index(KL, KL, i, j)
}

impl FeModel {
    /// Validates the model and assembles the global shaft and disk matrices.
    pub fn new(model: &RotorModel) -> Result<FeModel, ModelError> {
        model.validate()?;
        let n_nodes = model.n_nodes();
        let n = 4 * n_nodes;
        let mut m_band = vec![0.0; LDAB * n];
        let mut g_band = vec![0.0; LDAB * n];
        let mut k_band = vec![0.0; LDAB * n];
        for (e_idx, e) in model.shaft.iter().enumerate() {
            let em = element_matrices(e, model.theory);
            let base = 4 * e_idx;
            for a in 0..8 {
                for b in 0..8 {
                    let k = bidx(base + a, base + b);
                    m_band[k] += em.m[a][b];
                    g_band[k] += em.g[a][b];
                    k_band[k] += em.k[a][b];
                }
            }
        }
        for l in &model.shaft_layers {
            let em = element_matrices(&l.section, model.theory);
            let base = 4 * l.element;
            for a in 0..8 {
                for b in 0..8 {
                    let k = bidx(base + a, base + b);
                    m_band[k] += em.m[a][b];
                    g_band[k] += em.g[a][b];
                    k_band[k] += em.k[a][b];
                }
            }
        }
        for d in &model.disks {
            let dm = disk_matrices(d);
            let base = 4 * d.node;
            for a in 0..4 {
                for b in 0..4 {
                    let k = bidx(base + a, base + b);
                    m_band[k] += dm.m[a][b];
                    g_band[k] += dm.g[a][b];
                }
            }
        }
        let (alpha, beta) = (model.rotor_damping.alpha, model.rotor_damping.beta);
        let c_band = m_band
            .iter()
            .zip(&k_band)
            .map(|(&m, &k)| alpha * m + beta * k)
            .collect();
        let mut pedestal_index = Vec::with_capacity(model.bearings.len());
        let mut n_pedestals = 0;
        for b in &model.bearings {
            if b.pedestal.is_some() {
                pedestal_index.push(Some(n_pedestals));
                n_pedestals += 1;
            } else {
                pedestal_index.push(None);
            }
        }
        Ok(FeModel {
            model: model.clone(),
            n_nodes,
            pedestal_index,
            n_pedestals,
            m_band,
            g_band,
            k_band,
            c_band,
        })
    }

    /// The rotor description this model was built from.
    pub fn model(&self) -> &RotorModel {
        &self.model
    }

    /// Number of shaft nodes.
    pub fn n_nodes(&self) -> usize {
        self.n_nodes
    }

    /// Number of shaft DOFs, `4 N_nodes`: the order of the banded dynamic
    /// stiffness matrices.
    pub fn n_shaft_dof(&self) -> usize {
        4 * self.n_nodes
    }

    /// Number of pedestals.
    pub fn n_pedestals(&self) -> usize {
        self.n_pedestals
    }

    /// Number of DOFs including the pedestals, `4 N_nodes + 2 N_pedestals`:
    /// the order of the dense matrices and the length of
    /// [`crate::fe::response::Response::q`].
    pub fn n_dof(&self) -> usize {
        4 * self.n_nodes + 2 * self.n_pedestals
    }

    /// Global index of a shaft DOF: `4 node + dir` (no range check; the
    /// same as the free function [`dof`]).
    pub fn dof(&self, node: usize, dir: Dir) -> usize {
        dof(node, dir)
    }

    /// Global index of a pedestal DOF (`Dir::Y` or `Dir::Z`) of bearing
    /// `bearing` (0-based), after all shaft DOFs; `None` if that bearing has
    /// no pedestal or `dir` is a rotation.
    pub fn pedestal_dof(&self, bearing: usize, dir: Dir) -> Option<usize> {
        let p = (*self.pedestal_index.get(bearing)?)?;
        let off = match dir {
            Dir::Y => 0,
            Dir::Z => 1,
            _ => return None,
        };
        Some(4 * self.n_nodes + 2 * p + off)
    }

    /// The shaft DOFs at the bearings in measurement-channel order
    /// `(b1_y, b1_z, b2_y, b2_z, ...)`.
    pub fn bearing_dofs(&self) -> Vec<usize> {
        self.model
            .bearings
            .iter()
            .flat_map(|b| [dof(b.node, Dir::Y), dof(b.node, Dir::Z)])
            .collect()
    }

    /// The shaft DOFs that are not bearing translations (the "inner" DOFs
    /// `i` of the paper's Eq. 35), ascending: `Z_R,ii` is
    /// `rotor_dynamic_stiffness(omega).remove(&bearing_dofs())`.
    pub fn interior_dofs(&self) -> Vec<usize> {
        let b = self.bearing_dofs();
        (0..self.n_shaft_dof()).filter(|d| !b.contains(d)).collect()
    }

    fn check_speed(omega: f64) -> Result<(), FeError> {
        if omega.is_finite() {
            Ok(())
        } else {
            Err(FeError::Invalid(format!(
                "speed must be finite, got {omega}"
            )))
        }
    }

    /// `K + s (C_R + Omega G) + s^2 M` of shaft and disks in band storage.
    fn rotor_band(&self, omega: f64, s: Complex64) -> Vec<Complex64> {
        let sg = s * omega;
        let s2 = s * s;
        self.k_band
            .iter()
            .zip(&self.g_band)
            .zip(&self.m_band)
            .zip(&self.c_band)
            .map(|(((&k, &g), &m), &c)| sg * g + s * c + s2 * m + k)
            .collect()
    }

    /// Dynamic stiffness of shaft and disks ONLY (no bearings or pedestals)
    /// at speed `omega` (rad/s), harmonic at `omega`:
    /// `Z_R = K - Omega^2 M + j Omega (Omega G + C_R)`, order `4 N_nodes`,
    /// `kl = ku = 7`; `C_R` is the rotor's proportional damping, zero unless
    /// the model has one.
    pub fn rotor_dynamic_stiffness(&self, omega: f64) -> BandedMatrix {
        let ab = self.rotor_band(omega, Complex64::new(0.0, omega));
        BandedMatrix::from_storage(self.n_shaft_dof(), KL, KL, ab)
            .unwrap_or_else(|_| unreachable!("storage length fixed at assembly"))
    }

    /// Dynamic stiffness of the whole system at speed `omega` (rad/s),
    /// harmonic at `omega`: `Z_R` plus the bearings `K(Omega) + j Omega
    /// C(Omega)`, pedestals condensed exactly (shaft DOFs only).
    pub fn system_dynamic_stiffness(&self, omega: f64) -> Result<BandedMatrix, FeError> {
        self.system_dynamic_stiffness_at(omega, Complex64::new(0.0, omega))
    }

    /// `Z(s) = K + s (C + Omega G) + s^2 M` of the whole system on the shaft
    /// DOFs, bearing coefficients at speed `omega`, pedestals condensed at
    /// `s` (used for eigenvectors).
    pub fn system_dynamic_stiffness_at(
        &self,
        omega: f64,
        s: Complex64,
    ) -> Result<BandedMatrix, FeError> {
        Self::check_speed(omega)?;
        if !(s.re.is_finite() && s.im.is_finite()) {
            return Err(FeError::Invalid(format!(
                "frequency must be finite, got {s}"
            )));
        }
        let mut ab = self.rotor_band(omega, s);
        for (zb, node) in self.bearing_impedances(omega, s)? {
            let base = 4 * node;
            for a in 0..2 {
                for b in 0..2 {
                    ab[bidx(base + a, base + b)] += zb.0[(a, b)];
                }
            }
        }
        Ok(BandedMatrix::from_storage(self.n_shaft_dof(), KL, KL, ab)?)
    }

    /// Per bearing: (the 2 x 2 stiffness the shaft sees, the pedestal
    /// transfer `T` with `q_p = T q_s` if there is a pedestal), and the node.
    #[allow(clippy::type_complexity)]
    fn bearing_impedances(
        &self,
        omega: f64,
        s: Complex64,
    ) -> Result<Vec<((Matrix2<Complex64>, Option<Matrix2<Complex64>>), usize)>, FeError> {
        let mut out = Vec::with_capacity(self.model.bearings.len());
        for b in &self.model.bearings {
            let zb = law_dynamic_stiffness(&b.law, omega, s);
            match &b.pedestal {
                None => out.push(((zb, None), b.node)),
                Some(p) => {
                    let zp = pedestal_dynamic_stiffness(p, s);
                    let (zeff, t) = condense_pedestal(&zb, &zp, s)?;
                    out.push(((zeff, Some(t)), b.node));
                }
            }
        }
        Ok(out)
    }

    /// Pedestal responses `q_p = (Z_B + Z_P)^-1 Z_B q_s` at speed `omega`
    /// (harmonic), given the shaft response `q_shaft` (length
    /// `n_shaft_dof`): `2 N_b` values `(b1_y, b1_z, ...)`, zero where a
    /// bearing sits on the rigid ground.
    pub fn pedestal_response(
        &self,
        omega: f64,
        q_shaft: &[Complex64],
    ) -> Result<Vec<Complex64>, FeError> {
        if q_shaft.len() < self.n_shaft_dof() {
            return Err(FeError::Invalid(format!(
                "shaft response of length {} for {} shaft DOFs",
                q_shaft.len(),
                self.n_shaft_dof()
            )));
        }
        let s = Complex64::new(0.0, omega);
        let mut out = Vec::with_capacity(2 * self.model.bearings.len());
        for ((_, t), node) in self.bearing_impedances(omega, s)? {
            match t {
                None => out.extend([Complex64::new(0.0, 0.0); 2]),
                Some(t) => {
                    let qs = nalgebra::Vector2::new(q_shaft[4 * node], q_shaft[4 * node + 1]);
                    let qp = t * qs;
                    out.extend([qp[0], qp[1]]);
                }
            }
        }
        Ok(out)
    }

    fn band_to_dense(&self, band: &[f64]) -> DMatrix<f64> {
        let n = self.n_dof();
        let ns = self.n_shaft_dof();
        let mut d = DMatrix::zeros(n, n);
        for j in 0..ns {
            for i in j.saturating_sub(KL)..=(j + KL).min(ns - 1) {
                d[(i, j)] = band[bidx(i, j)];
            }
        }
        d
    }

    /// Dense mass matrix (shaft + disks + pedestal masses), order `n_dof` (kg, kg m^2).
    pub fn mass_matrix(&self) -> DMatrix<f64> {
        let mut d = self.band_to_dense(&self.m_band);
        for (bi, b) in self.model.bearings.iter().enumerate() {
            if let (Some(p), Some(iy), Some(iz)) = (
                &b.pedestal,
                self.pedestal_dof(bi, Dir::Y),
                self.pedestal_dof(bi, Dir::Z),
            ) {
                d[(iy, iy)] += p.mass[0];
                d[(iz, iz)] += p.mass[1];
            }
        }
        d
    }

    /// Dense gyroscopic matrix (shaft + disks), order `n_dof`, multiplying
    /// `Omega q'` (kg m^2).
    pub fn gyroscopic_matrix(&self) -> DMatrix<f64> {
        self.band_to_dense(&self.g_band)
    }

    /// Dense shaft stiffness `K_s` (no bearings), order `n_dof`.
    pub fn shaft_stiffness_matrix(&self) -> DMatrix<f64> {
        self.band_to_dense(&self.k_band)
    }

    /// Adds a 2 x 2 bearing/pedestal coupling (`x` = K or C of the bearing,
    /// `g` = the pedestal's own term to ground) into a dense matrix.
    fn add_supports(&self, d: &mut DMatrix<f64>, omega: f64, use_k: bool) {
        for (bi, b) in self.model.bearings.iter().enumerate() {
            let coefs = b.law.at(omega);
            let x = if use_k {
                stiffness(&coefs)
            } else {
                damping(&coefs)
            };
            let s = [dof(b.node, Dir::Y), dof(b.node, Dir::Z)];
            match (
                &b.pedestal,
                self.pedestal_dof(bi, Dir::Y),
                self.pedestal_dof(bi, Dir::Z),
            ) {
                (Some(p), Some(py), Some(pz)) => {
                    let pd = [py, pz];
                    for a in 0..2 {
                        for c in 0..2 {
                            d[(s[a], s[c])] += x[(a, c)];
                            d[(s[a], pd[c])] -= x[(a, c)];
                            d[(pd[a], s[c])] -= x[(a, c)];
                            d[(pd[a], pd[c])] += x[(a, c)];
                        }
                        d[(pd[a], pd[a])] += if use_k { p.k[a] } else { p.c[a] };
                    }
                }
                _ => {
                    for a in 0..2 {
                        for c in 0..2 {
                            d[(s[a], s[c])] += x[(a, c)];
                        }
                    }
                }
            }
        }
    }

    /// Dense stiffness of the whole system at speed `omega`: shaft, bearings
    /// `K(Omega)` (between shaft and pedestal where there is one) and
    /// pedestal stiffness to ground, order `n_dof` (N/m).
    pub fn stiffness_matrix(&self, omega: f64) -> DMatrix<f64> {
        let mut d = self.shaft_stiffness_matrix();
        self.add_supports(&mut d, omega, true);
        d
    }

    /// Dense damping of the whole system at speed `omega`: rotor damping
    /// `C_R = alpha M + beta K` of shaft and disks, bearings `C(Omega)` and
    /// pedestal damping, order `n_dof` (N s/m).
    pub fn damping_matrix(&self, omega: f64) -> DMatrix<f64> {
        let mut d = self.band_to_dense(&self.c_band);
        self.add_supports(&mut d, omega, false);
        d
    }

    /// Unbalance distribution `T` (Eqs. 40, 42): column `k` has `1` at
    /// `dof(planes[k], Y)` and `-j` at `dof(planes[k], Z)`, so the unbalance
    /// force is `Omega^2 T a`. Order `n_shaft_dof x N_p`.
    pub fn unbalance_distribution(&self, planes: &[usize]) -> Result<DMatrix<Complex64>, FeError> {
        let mut t = DMatrix::zeros(self.n_shaft_dof(), planes.len());
        for (k, &node) in planes.iter().enumerate() {
            self.check_node(node)?;
            t[(dof(node, Dir::Y), k)] = Complex64::new(1.0, 0.0);
            t[(dof(node, Dir::Z), k)] = Complex64::new(0.0, -1.0);
        }
        Ok(t)
    }

    fn check_node(&self, node: usize) -> Result<(), FeError> {
        if node < self.n_nodes {
            Ok(())
        } else {
            Err(FeError::Invalid(format!(
                "node {} is not on the shaft (nodes 1..={})",
                node + 1,
                self.n_nodes
            )))
        }
    }

    /// Unbalance force at speed `omega` on the shaft DOFs:
    /// `F_y = Omega^2 a`, `F_z = -j Omega^2 a` at each plane's node (N).
    pub fn unbalance_force(
        &self,
        unbalance: &[Unbalance],
        omega: f64,
    ) -> Result<Vec<Complex64>, FeError> {
        Self::check_speed(omega)?;
        let mut f = vec![Complex64::new(0.0, 0.0); self.n_shaft_dof()];
        let w2 = omega * omega;
        for u in unbalance {
            self.check_node(u.node)?;
            let a = u.phasor();
            if !(a.re.is_finite() && a.im.is_finite()) {
                return Err(FeError::Invalid("non-finite unbalance".into()));
            }
            f[dof(u.node, Dir::Y)] += a * w2;
            f[dof(u.node, Dir::Z)] += Complex64::new(0.0, -1.0) * a * w2;
        }
        Ok(f)
    }

    /// The bow shape on all shaft DOFs, as stationary-frame phasors.
    ///
    /// Each point gives the complex offset `c = r exp(j beta)` of the centre
    /// line at its node. The interpolation knots are the given points plus,
    /// where no point is given there, a zero offset at the first and at the
    /// last node (the shaft ends lie on the reference axis unless given).
    /// Between knots `c(x)` is the natural cubic spline through the knots in
    /// the axial coordinate x (complex values; linear if only two knots);
    /// slopes come from the spline's derivative. At every node
    ///
    /// ```text
    /// Y = c(x),  Z = -j c(x),  phi_z = dY/dx = c'(x),  phi_y = -dZ/dx = j c'(x)
    /// ```
    ///
    /// (a feature fixed in the rotating frame, see [`crate::model`]).
    pub fn bow_shape(&self, bow: &ShaftBow) -> Result<Vec<Complex64>, FeError> {
        let mut knots: Vec<(usize, Complex64)> = Vec::with_capacity(bow.points.len());
        for (i, p) in bow.points.iter().enumerate() {
            self.check_node(p.node)?;
            if i > 0 && p.node <= bow.points[i - 1].node {
                return Err(FeError::Invalid("bow points must be sorted by node".into()));
            }
            if !(p.amplitude.is_finite() && p.phase.is_finite()) {
                return Err(FeError::Invalid("non-finite bow point".into()));
            }
            knots.push((p.node, Complex64::from_polar(p.amplitude, p.phase)));
        }
        Ok(self.spline_shape(&knots, true))
    }

    /// The bow shape of a unit offset at `node` measured from the bearing
    /// line: zero at every node of `bearing_nodes` (but `node`), one at
    /// `node`, the natural cubic spline through these knots, continued as
    /// a straight line beyond the outermost ones (no curvature, so no bow
    /// forcing, in an overhang). With bearings at the shaft ends only this
    /// is [`FeModel::bow_shape`] of the one point; with more bearings, or
    /// overhung ones, it is the bow a mid-span or overhang probe sees from
    /// the line through the bearings.
    pub fn line_bow_shape(
        &self,
        node: usize,
        bearing_nodes: &[usize],
    ) -> Result<Vec<Complex64>, FeError> {
        self.check_node(node)?;
        let mut knots: Vec<(usize, Complex64)> = bearing_nodes
            .iter()
            .filter(|&&b| b != node)
            .map(|&b| (b, Complex64::new(0.0, 0.0)))
            .collect();
        for &(b, _) in &knots {
            self.check_node(b)?;
        }
        knots.push((node, Complex64::new(1.0, 0.0)));
        knots.sort_by_key(|k| k.0);
        knots.dedup_by_key(|k| k.0);
        Ok(self.spline_shape(&knots, false))
    }

    /// The shaft DOFs of the spline through `knots` (node, offset; sorted
    /// by node, distinct): with `pin_ends`, a zero offset added at the
    /// first and the last node where no knot is; beyond the outermost
    /// knots the spline continues as a straight line.
    fn spline_shape(&self, knots: &[(usize, Complex64)], pin_ends: bool) -> Vec<Complex64> {
        let x_nodes = self.model.node_positions();
        let mut q = vec![Complex64::new(0.0, 0.0); self.n_shaft_dof()];
        let (Some(first), Some(end)) = (knots.first(), knots.last()) else {
            return q;
        };
        let last = self.n_nodes - 1;
        let mut xk: Vec<(f64, Complex64)> = knots.iter().map(|&(n, c)| (x_nodes[n], c)).collect();
        if pin_ends && first.0 != 0 {
            xk.insert(0, (x_nodes[0], Complex64::new(0.0, 0.0)));
        }
        if pin_ends && end.0 != last {
            xk.push((x_nodes[last], Complex64::new(0.0, 0.0)));
        }
        let spline = NaturalSpline::new(&xk);
        let j = Complex64::new(0.0, 1.0);
        for (node, &x) in x_nodes.iter().enumerate() {
            let (c, dc) = spline.eval(x);
            q[dof(node, Dir::Y)] = c;
            q[dof(node, Dir::Z)] = -j * c;
            q[dof(node, Dir::PhiY)] = j * dc;
            q[dof(node, Dir::PhiZ)] = dc;
        }
        q
    }

    /// `K_s q` on the shaft DOFs for a shape `q` of the shaft DOFs.
    pub fn shaft_force(&self, q: &[Complex64]) -> Vec<Complex64> {
        let ns = self.n_shaft_dof();
        let mut f = vec![Complex64::new(0.0, 0.0); ns];
        for (j, qj) in q.iter().enumerate().take(ns) {
            for (i, fi) in f
                .iter_mut()
                .enumerate()
                .take((j + KL).min(ns - 1) + 1)
                .skip(j.saturating_sub(KL))
            {
                *fi += self.k_band[bidx(i, j)] * qj;
            }
        }
        f
    }

    /// Bow forcing `K_s q_bow` on the shaft DOFs (N, N m), independent of speed.
    pub fn bow_force(&self, bow: &ShaftBow) -> Result<Vec<Complex64>, FeError> {
        let q = self.bow_shape(bow)?;
        Ok(self.shaft_force(&q))
    }
}

/// Natural cubic spline through complex values at increasing abscissae.
struct NaturalSpline {
    x: Vec<f64>,
    y: Vec<Complex64>,
    /// Second derivatives at the knots.
    m: Vec<Complex64>,
}

impl NaturalSpline {
    /// `knots` sorted by strictly increasing x, at least one.
    fn new(knots: &[(f64, Complex64)]) -> Self {
        let n = knots.len();
        let x: Vec<f64> = knots.iter().map(|k| k.0).collect();
        let y: Vec<Complex64> = knots.iter().map(|k| k.1).collect();
        let mut m = vec![Complex64::new(0.0, 0.0); n];
        if n > 2 {
            // Tridiagonal system for the interior second derivatives
            // (Thomas algorithm; diagonally dominant).
            let k = n - 2;
            let mut diag = vec![0.0; k];
            let mut rhs = vec![Complex64::new(0.0, 0.0); k];
            let mut upper = vec![0.0; k];
            let mut lower = vec![0.0; k];
            for i in 0..k {
                let h0 = x[i + 1] - x[i];
                let h1 = x[i + 2] - x[i + 1];
                diag[i] = 2.0 * (h0 + h1);
                lower[i] = h0;
                upper[i] = h1;
                rhs[i] = ((y[i + 2] - y[i + 1]) / h1 - (y[i + 1] - y[i]) / h0) * 6.0;
            }
            for i in 1..k {
                let w = lower[i] / diag[i - 1];
                diag[i] -= w * upper[i - 1];
                let r = rhs[i - 1] * w;
                rhs[i] -= r;
            }
            let mut sol = vec![Complex64::new(0.0, 0.0); k];
            for i in (0..k).rev() {
                let next = if i + 1 < k {
                    sol[i + 1] * upper[i]
                } else {
                    Complex64::new(0.0, 0.0)
                };
                sol[i] = (rhs[i] - next) / diag[i];
            }
            m[1..(k + 1)].copy_from_slice(&sol);
        }
        NaturalSpline { x, y, m }
    }

    /// Value and derivative at `t`; outside the knot range the straight
    /// line through the end knot with its slope (the natural spline's
    /// curvature is zero there, so the continuation is smooth).
    fn eval(&self, t: f64) -> (Complex64, Complex64) {
        let n = self.x.len();
        if n == 1 {
            return (self.y[0], Complex64::new(0.0, 0.0));
        }
        if t < self.x[0] {
            let (v, d) = self.piece(0, self.x[0]);
            return (v + d * (t - self.x[0]), d);
        }
        if t > self.x[n - 1] {
            let (v, d) = self.piece(n - 2, self.x[n - 1]);
            return (v + d * (t - self.x[n - 1]), d);
        }
        let i = self
            .x
            .partition_point(|&v| v <= t)
            .saturating_sub(1)
            .min(n - 2);
        self.piece(i, t)
    }

    fn piece(&self, i: usize, t: f64) -> (Complex64, Complex64) {
        let h = self.x[i + 1] - self.x[i];
        let a = (self.x[i + 1] - t) / h;
        let b = (t - self.x[i]) / h;
        let (y0, y1, m0, m1) = (self.y[i], self.y[i + 1], self.m[i], self.m[i + 1]);
        let v = y0 * a + y1 * b + (m0 * (a * a * a - a) + m1 * (b * b * b - b)) * (h * h / 6.0);
        let d = (y1 - y0) / h + (-m0 * (3.0 * a * a - 1.0) + m1 * (3.0 * b * b - 1.0)) * (h / 6.0);
        (v, d)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::BowPoint;

    #[test]
    fn band_and_dense_agree_and_sizes() {
        let m = RotorModel::paper();
        let fe = FeModel::new(&m).unwrap();
        assert_eq!(fe.n_shaft_dof(), 108);
        assert_eq!(fe.n_dof(), 108);
        let omega = 500.0;
        let z = fe.system_dynamic_stiffness(omega).unwrap().to_dense();
        let mm = fe.mass_matrix();
        let g = fe.gyroscopic_matrix();
        let k = fe.stiffness_matrix(omega);
        let c = fe.damping_matrix(omega);
        let j = Complex64::new(0.0, 1.0);
        for r in 0..108 {
            for col in 0..108 {
                let zd = Complex64::new(k[(r, col)] - omega * omega * mm[(r, col)], 0.0)
                    + j * omega * (c[(r, col)] + omega * g[(r, col)]);
                assert!((zd - z[(r, col)]).norm() <= 1e-9 * (1.0 + zd.norm()));
            }
        }
        // Total translational mass: shaft + 3 disks.
        let rho_a = 7800.0 * core::f64::consts::PI * 0.01 / 4.0;
        let total: f64 = (0..27)
            .map(|a| (0..27).map(|b| mm[(4 * a, 4 * b)]).sum::<f64>())
            .sum();
        let expect = rho_a * 1.3 + 3.0 * m.disks[0].mass;
        assert!((total - expect).abs() < 1e-10 * expect);
    }

    #[test]
    fn bow_spline_reproduces_a_cubic_free_shape() {
        // Points on a straight line through both ends: the natural spline is
        // that line, and a straight shaft is unstressed: zero bow force.
        let m = RotorModel::paper();
        let fe = FeModel::new(&m).unwrap();
        let points: Vec<BowPoint> = [0usize, 9, 26]
            .iter()
            .map(|&n| BowPoint {
                node: n,
                amplitude: 1e-4 * (1.0 + n as f64),
                phase: 0.3,
            })
            .collect();
        let bow = ShaftBow { points };
        let q = fe.bow_shape(&bow).unwrap();
        let y5 = q[dof(5, Dir::Y)];
        assert!((y5 - Complex64::from_polar(6e-4, 0.3)).norm() < 1e-15);
        assert!((q[dof(5, Dir::Z)] - Complex64::new(0.0, -1.0) * y5).norm() < 1e-18);
        let f = fe.bow_force(&bow).unwrap();
        let fmax = f.iter().map(|v| v.norm()).fold(0.0, f64::max);
        assert!(fmax < 1e-6, "{fmax}");
        // A mid-span bow with zero ends is curved and loads the shaft.
        let bow = ShaftBow {
            points: vec![BowPoint {
                node: 13,
                amplitude: 1e-4,
                phase: 0.0,
            }],
        };
        let q = fe.bow_shape(&bow).unwrap();
        assert!((q[dof(13, Dir::Y)].re - 1e-4).abs() < 1e-16);
        assert_eq!(q[dof(0, Dir::Y)].norm(), 0.0);
        // Slope signs: y rises from node 0, so phi_z > 0 there, and
        // z = -j y gives phi_y = j phi_z.
        let pz = q[dof(0, Dir::PhiZ)];
        assert!(pz.re > 0.0);
        assert!((q[dof(0, Dir::PhiY)] - Complex64::new(0.0, 1.0) * pz).norm() < 1e-18);
        let f = fe.bow_force(&bow).unwrap();
        assert!(f.iter().map(|v| v.norm()).fold(0.0, f64::max) > 1.0);
    }

    /// The bow from the bearing line: with bearings at the two shaft ends
    /// it is the shaft-end bow of the one point; with an overhung bearing
    /// it is zero at every bearing, one at its node, and straight (no
    /// curvature, no bow forcing) beyond the outermost bearings.
    #[test]
    fn line_bow_shape_is_zero_at_the_bearings_and_straight_outside() {
        let m = RotorModel::paper();
        let fe = FeModel::new(&m).unwrap();
        let one = ShaftBow {
            points: vec![BowPoint {
                node: 9,
                amplitude: 1.0,
                phase: 0.0,
            }],
        };
        let a = fe.bow_shape(&one).unwrap();
        let b = fe.line_bow_shape(9, &[0, 26]).unwrap();
        for (x, y) in a.iter().zip(&b) {
            assert!((x - y).norm() <= 1e-15, "{x} vs {y}");
        }
        // Bearings at nodes 4 and 20 (overhangs at both ends), offset at 12.
        let q = fe.line_bow_shape(12, &[4, 20]).unwrap();
        assert!(q[dof(4, Dir::Y)].norm() < 1e-15 && q[dof(20, Dir::Y)].norm() < 1e-15);
        assert!((q[dof(12, Dir::Y)] - 1.0).norm() < 1e-15);
        let x = m.node_positions();
        for ends in [[0, 1, 2, 3, 4], [20, 21, 22, 24, 26]] {
            let slope = q[dof(ends[0], Dir::PhiZ)];
            for &n in &ends {
                assert!((q[dof(n, Dir::PhiZ)] - slope).norm() < 1e-12, "node {n}");
                let lin = q[dof(ends[0], Dir::Y)] + slope * (x[n] - x[ends[0]]);
                assert!((q[dof(n, Dir::Y)] - lin).norm() < 1e-12, "node {n}");
            }
        }
        // A straight overhang carries no bow forcing beyond the bearing.
        let f = fe.shaft_force(&q);
        for n in [0, 1, 2, 3, 22, 23, 24, 25, 26] {
            assert!(
                f[dof(n, Dir::Y)].norm() < 1e-6 * f[dof(12, Dir::Y)].norm(),
                "node {n}"
            );
        }
    }
}
