//! Finite beam element of a rotating shaft: 2 nodes, 8 DOFs.
//!
//! Reference: M. I. Friswell, J. E. T. Penny, S. D. Garvey, A. W. Lees,
//! *Dynamics of Rotating Machines*, Cambridge University Press, 2010,
//! section 5.4 and the Appendix (Timoshenko shaft element; the same
//! matrices are in Przemieniecki, *Theory of Matrix Structural Analysis*,
//! 1968, for one bending plane). Shear coefficient after G. R. Cowper,
//! "The shear coefficient in Timoshenko's beam theory", J. Appl. Mech. 33
//! (1966) 335-340.
//!
//! # Coordinates and DOFs
//!
//! The shaft axis is x; the transverse directions are y and z; the rotor
//! spins about +x at `Omega` (from +y toward +z). The element DOFs are
//! `q_e = (y1, z1, phi_y1, phi_z1, y2, z2, phi_y2, phi_z2)`, where `phi_y`
//! and `phi_z` are small rotations about the y and z axes (right-hand rule).
//! A rotation about z tilts the axis toward +y and a rotation about y tilts
//! it toward -z, so
//!
//! ```text
//! phi_z = dy/dx,      phi_y = -dz/dx.
//! ```
//!
//! Friswell et al. use the axis z, transverse u (along x) and v (along y),
//! and rotations theta (about x) and psi (about y) with `psi = du/dz`,
//! `theta = -dv/dz`. The cyclic relabelling (their x, y, z) -> (our y, z, x)
//! keeps the right-handed frame, so their `(u, v, theta, psi)` is our
//! `(y, z, phi_y, phi_z)` one for one, and their spin about +z is ours
//! about +x.
//!
//! # One bending plane
//!
//! In a plane with transverse displacement `w` and slope-like rotation
//! `theta = dw/dx` (for Euler-Bernoulli), the Timoshenko element with shear
//! parameter
//!
//! ```text
//! Phi = 12 E I / (kappa G A L^2)      (Phi = 0: Euler-Bernoulli)
//! ```
//!
//! interpolates, with `xi = x / L` and the nodal vector `(w1, theta1, w2, theta2)`,
//!
//! ```text
//! N_w     = [1 - 3xi^2 + 2xi^3 + Phi (1 - xi),
//!            L (xi - 2xi^2 + xi^3 + Phi (xi - xi^2) / 2),
//!            3xi^2 - 2xi^3 + Phi xi,
//!            L (-xi^2 + xi^3 - Phi (xi - xi^2) / 2)] / (1 + Phi)
//! N_theta = [6 (xi^2 - xi) / L,  1 - 4xi + 3xi^2 + Phi (1 - xi),
//!            6 (xi - xi^2) / L,  -2xi + 3xi^2 + Phi xi] / (1 + Phi)
//! ```
//!
//! (shear strain `dw/dx - theta` constant along the element), and the plane
//! matrices are (`m_T = rho A int N_w^T N_w`, `m_R = rho I int N_theta^T N_theta`,
//! `k = E I int N_theta'^T N_theta' + kappa G A int (N_w' - N_theta)^T (N_w' - N_theta)`):
//!
//! ```text
//! k   = E I / (L^3 (1 + Phi)) [ 12     6L            -12    6L
//!                               6L    (4 + Phi) L^2  -6L   (2 - Phi) L^2
//!                              -12    -6L             12   -6L
//!                               6L    (2 - Phi) L^2  -6L   (4 + Phi) L^2 ]
//!
//! m_T = rho A L / (1 + Phi)^2 [ m1  m2  m3  m4
//!                               m2  m5 -m4  m6
//!                               m3 -m4  m1 -m2
//!                               m4  m6 -m2  m5 ]
//!   m1 = 13/35 + 7 Phi/10 + Phi^2/3,        m2 = (11/210 + 11 Phi/120 + Phi^2/24) L,
//!   m3 = 9/70 + 3 Phi/10 + Phi^2/6,         m4 = -(13/420 + 3 Phi/40 + Phi^2/24) L,
//!   m5 = (1/105 + Phi/60 + Phi^2/120) L^2,  m6 = -(1/140 + Phi/60 + Phi^2/120) L^2
//!
//! m_R = rho I / (L (1 + Phi)^2) [ r1  r2 -r1  r2
//!                                 r2  r3 -r2  r4
//!                                -r1 -r2  r1 -r2
//!                                 r2  r4 -r2  r3 ]
//!   r1 = 6/5,  r2 = (1/10 - Phi/2) L,
//!   r3 = (2/15 + Phi/6 + Phi^2/3) L^2,  r4 = (-1/30 - Phi/6 + Phi^2/6) L^2
//! ```
//!
//! # Both planes and the gyroscopic matrix
//!
//! The x-y plane is the plane above with `(w, theta) = (y, phi_z)`, local
//! DOFs `P_y = (0, 3, 4, 7)`. The x-z plane has `(w, theta) = (z, -phi_y)`,
//! local DOFs `P_z = (1, 2, 5, 6)` and the sign matrix `S = diag(1, -1, 1, -1)`:
//! its blocks are `S k S`, `S m_T S`, `S m_R S` (the translation-rotation
//! couplings change sign).
//!
//! The rotations along the element are `phi_z = N_theta q_y` and
//! `phi_y = -N_theta S q_z`. The kinetic energy of the spinning section
//! (polar inertia `rho I_p = 2 rho I` per unit length) gives the gyroscopic
//! forces `Omega G q'` with
//!
//! ```text
//! G = int rho I_p (N_phiy^T N_phiz - N_phiz^T N_phiy) dx,
//! G[P_z, P_y] = -2 S m_R,     G[P_y, P_z] = 2 m_R S,
//! ```
//!
//! skew-symmetric, and for a rigid slice reducing to the disk's
//! `G[phi_y, phi_z] = I_p`, `G[phi_z, phi_y] = -I_p` (see [`crate::fe::disk`]).
//! With the equation of motion `M q'' + (C + Omega G) q' + K q = f` this
//! sign raises the forward-whirl frequencies (checked in the tests).

use crate::model::{BeamTheory, ShaftElement};
use core::f64::consts::PI;

/// An 8 x 8 element matrix in the DOF order `(y1, z1, phi_y1, phi_z1, y2, z2, phi_y2, phi_z2)`.
pub type ElementMatrix = [[f64; 8]; 8];

/// A 4 x 4 matrix of one bending plane, order `(w1, theta1, w2, theta2)`.
pub type PlaneMatrix = [[f64; 4]; 4];

/// Local DOFs of the x-y plane `(y1, phi_z1, y2, phi_z2)`.
const P_Y: [usize; 4] = [0, 3, 4, 7];
/// Local DOFs of the x-z plane `(z1, phi_y1, z2, phi_y2)`.
const P_Z: [usize; 4] = [1, 2, 5, 6];
/// Sign of the x-z plane's DOFs relative to `(w, theta) = (z, -phi_y)`.
const S_Z: [f64; 4] = [1.0, -1.0, 1.0, -1.0];

/// Cross-section properties of a circular tube.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Section {
    /// Area `A = pi (Do^2 - Di^2) / 4` (m^2).
    pub area: f64,
    /// Second moment of area about a diameter `I = pi (Do^4 - Di^4) / 64` (m^4).
    pub inertia: f64,
    /// Cowper's shear coefficient kappa (-).
    pub kappa: f64,
}

impl Section {
    /// The section of a tube of outer diameter `d_o` and bore `d_i` (m),
    /// Poisson's ratio `nu` (for the shear coefficient).
    pub fn tube(d_o: f64, d_i: f64, nu: f64) -> Self {
        let area = PI * (d_o * d_o - d_i * d_i) / 4.0;
        let inertia = PI * (d_o.powi(4) - d_i.powi(4)) / 64.0;
        Section {
            area,
            inertia,
            kappa: cowper_kappa(nu, d_i / d_o),
        }
    }
}

/// Cowper's (1966) shear coefficient of a hollow circular section with
/// diameter ratio `m = Di / Do`:
///
/// `kappa = 6 (1 + nu) (1 + m^2)^2 / ((7 + 6 nu) (1 + m^2)^2 + (20 + 12 nu) m^2)`,
///
/// which for a solid section (`m = 0`) is `6 (1 + nu) / (7 + 6 nu)`
/// (0.886 for `nu = 0.3`).
pub fn cowper_kappa(nu: f64, m: f64) -> f64 {
    let a = (1.0 + m * m).powi(2);
    6.0 * (1.0 + nu) * a / ((7.0 + 6.0 * nu) * a + (20.0 + 12.0 * nu) * m * m)
}

/// Shear parameter `Phi = 12 E I / (kappa G A L^2)` of an element, 0 for
/// Euler-Bernoulli elements.
pub fn shear_parameter(e: &ShaftElement, theory: BeamTheory) -> f64 {
    match theory {
        BeamTheory::EulerBernoulli => 0.0,
        BeamTheory::Timoshenko => {
            let s = Section::tube(e.outer_diameter, e.inner_diameter, e.material.nu());
            12.0 * e.material.e * s.inertia
                / (s.kappa * e.material.g * s.area * e.length * e.length)
        }
    }
}

/// The plane matrices `(k, m_T, m_R)` in the order `(w1, theta1, w2, theta2)`,
/// see the module documentation.
pub fn plane_matrices(
    ei: f64,
    rho_a: f64,
    rho_i: f64,
    l: f64,
    phi: f64,
) -> (PlaneMatrix, PlaneMatrix, PlaneMatrix) {
    let p = phi;
    let p2 = p * p;
    let c = ei / (l.powi(3) * (1.0 + p));
    let k = [
        [12.0 * c, 6.0 * l * c, -12.0 * c, 6.0 * l * c],
        [
            6.0 * l * c,
            (4.0 + p) * l * l * c,
            -6.0 * l * c,
            (2.0 - p) * l * l * c,
        ],
        [-12.0 * c, -6.0 * l * c, 12.0 * c, -6.0 * l * c],
        [
            6.0 * l * c,
            (2.0 - p) * l * l * c,
            -6.0 * l * c,
            (4.0 + p) * l * l * c,
        ],
    ];
    let ct = rho_a * l / (1.0 + p).powi(2);
    let m1 = ct * (13.0 / 35.0 + 7.0 * p / 10.0 + p2 / 3.0);
    let m2 = ct * (11.0 / 210.0 + 11.0 * p / 120.0 + p2 / 24.0) * l;
    let m3 = ct * (9.0 / 70.0 + 3.0 * p / 10.0 + p2 / 6.0);
    let m4 = -ct * (13.0 / 420.0 + 3.0 * p / 40.0 + p2 / 24.0) * l;
    let m5 = ct * (1.0 / 105.0 + p / 60.0 + p2 / 120.0) * l * l;
    let m6 = -ct * (1.0 / 140.0 + p / 60.0 + p2 / 120.0) * l * l;
    let mt = [
        [m1, m2, m3, m4],
        [m2, m5, -m4, m6],
        [m3, -m4, m1, -m2],
        [m4, m6, -m2, m5],
    ];
    let cr = rho_i / (l * (1.0 + p).powi(2));
    let r1 = cr * 6.0 / 5.0;
    let r2 = cr * (0.1 - p / 2.0) * l;
    let r3 = cr * (2.0 / 15.0 + p / 6.0 + p2 / 3.0) * l * l;
    let r4 = cr * (-1.0 / 30.0 - p / 6.0 + p2 / 6.0) * l * l;
    let mr = [
        [r1, r2, -r1, r2],
        [r2, r3, -r2, r4],
        [-r1, -r2, r1, -r2],
        [r2, r4, -r2, r3],
    ];
    (k, mt, mr)
}

/// Mass (translational + rotary), gyroscopic and stiffness matrices of one
/// shaft element, in the local DOF order of [`ElementMatrix`] (SI: kg,
/// kg m, kg m^2; N/m, N, N m).
#[derive(Debug, Clone, PartialEq)]
pub struct ShaftMatrices {
    /// Mass `M = M_T + M_R`.
    pub m: ElementMatrix,
    /// Gyroscopic matrix `G` (multiplies `Omega q'`), skew-symmetric.
    pub g: ElementMatrix,
    /// Stiffness `K`.
    pub k: ElementMatrix,
}

/// The matrices of a shaft element under the given beam theory.
pub fn element_matrices(e: &ShaftElement, theory: BeamTheory) -> ShaftMatrices {
    let s = Section::tube(e.outer_diameter, e.inner_diameter, e.material.nu());
    let phi = shear_parameter(e, theory);
    let (k4, mt4, mr4) = plane_matrices(
        e.material.e * s.inertia,
        e.material.rho * s.area,
        e.material.rho * s.inertia,
        e.length,
        phi,
    );
    let mut m = [[0.0; 8]; 8];
    let mut g = [[0.0; 8]; 8];
    let mut k = [[0.0; 8]; 8];
    for a in 0..4 {
        for b in 0..4 {
            // x-y plane: identity map.
            k[P_Y[a]][P_Y[b]] = k4[a][b];
            m[P_Y[a]][P_Y[b]] = mt4[a][b] + mr4[a][b];
            // x-z plane: S (.) S.
            let s = S_Z[a] * S_Z[b];
            k[P_Z[a]][P_Z[b]] = s * k4[a][b];
            m[P_Z[a]][P_Z[b]] = s * (mt4[a][b] + mr4[a][b]);
            // Gyroscopic coupling of the planes.
            g[P_Z[a]][P_Y[b]] = -2.0 * S_Z[a] * mr4[a][b];
            g[P_Y[a]][P_Z[b]] = 2.0 * mr4[a][b] * S_Z[b];
        }
    }
    ShaftMatrices { m, g, k }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Material;

    /// 5-point Gauss-Legendre on [0, 1]: exact for degree 9.
    fn gauss<F: Fn(f64) -> f64>(f: F) -> f64 {
        let x = [
            -0.906_179_845_938_664,
            -0.538_469_310_105_683,
            0.0,
            0.538_469_310_105_683,
            0.906_179_845_938_664,
        ];
        let w = [
            0.236_926_885_056_189,
            0.478_628_670_499_366,
            0.568_888_888_888_889,
            0.478_628_670_499_366,
            0.236_926_885_056_189,
        ];
        x.iter()
            .zip(&w)
            .map(|(xi, wi)| 0.5 * wi * f(0.5 * (xi + 1.0)))
            .sum()
    }

    /// Shape functions of the module documentation and their x-derivatives.
    fn shapes(xi: f64, l: f64, p: f64) -> ([f64; 4], [f64; 4], [f64; 4], [f64; 4]) {
        let d = 1.0 + p;
        let nw = [
            (1.0 - 3.0 * xi * xi + 2.0 * xi.powi(3) + p * (1.0 - xi)) / d,
            l * (xi - 2.0 * xi * xi + xi.powi(3) + p * (xi - xi * xi) / 2.0) / d,
            (3.0 * xi * xi - 2.0 * xi.powi(3) + p * xi) / d,
            l * (-xi * xi + xi.powi(3) - p * (xi - xi * xi) / 2.0) / d,
        ];
        let dnw = [
            (-6.0 * xi + 6.0 * xi * xi - p) / (l * d),
            (1.0 - 4.0 * xi + 3.0 * xi * xi + p * (1.0 - 2.0 * xi) / 2.0) / d,
            (6.0 * xi - 6.0 * xi * xi + p) / (l * d),
            (-2.0 * xi + 3.0 * xi * xi - p * (1.0 - 2.0 * xi) / 2.0) / d,
        ];
        let nt = [
            6.0 * (xi * xi - xi) / (l * d),
            (1.0 - 4.0 * xi + 3.0 * xi * xi + p * (1.0 - xi)) / d,
            6.0 * (xi - xi * xi) / (l * d),
            (-2.0 * xi + 3.0 * xi * xi + p * xi) / d,
        ];
        let dnt = [
            6.0 * (2.0 * xi - 1.0) / (l * l * d),
            (-4.0 + 6.0 * xi - p) / (l * d),
            6.0 * (1.0 - 2.0 * xi) / (l * l * d),
            (-2.0 + 6.0 * xi + p) / (l * d),
        ];
        (nw, dnw, nt, dnt)
    }

    #[test]
    fn cowper_values() {
        assert!((cowper_kappa(0.3, 0.0) - 6.0 * 1.3 / 8.8).abs() < 1e-15);
        assert!((cowper_kappa(0.3, 0.0) - 0.886).abs() < 1e-3);
        // Thin-walled tube limit m -> 1: 2 (1 + nu) / (4 + 3 nu) (Cowper, Table 1).
        assert!((cowper_kappa(0.3, 1.0) - 2.0 * 1.3 / 4.9).abs() < 1e-12);
    }

    /// The closed-form plane matrices equal the energy integrals of the
    /// shape functions (independent quadrature), for EB and a thick
    /// Timoshenko element.
    #[test]
    fn plane_matrices_equal_shape_function_integrals() {
        let (ei, rho_a, rho_i, kga_kappa, l) = (3.0e5, 40.0, 0.02, 7.0e8, 0.2);
        for &p in &[0.0, 12.0 * ei / (kga_kappa * l * l)] {
            let (k, mt, mr) = plane_matrices(ei, rho_a, rho_i, l, p);
            // With Phi = 0 there is no shear term in the energy.
            let kga = if p == 0.0 { 0.0 } else { kga_kappa };
            for a in 0..4 {
                for b in 0..4 {
                    let mt_q = gauss(|xi| {
                        let (nw, ..) = shapes(xi, l, p);
                        rho_a * nw[a] * nw[b] * l
                    });
                    let mr_q = gauss(|xi| {
                        let (_, _, nt, _) = shapes(xi, l, p);
                        rho_i * nt[a] * nt[b] * l
                    });
                    let k_q = gauss(|xi| {
                        let (_, dnw, nt, dnt) = shapes(xi, l, p);
                        let ga = dnw[a] - nt[a];
                        let gb = dnw[b] - nt[b];
                        (ei * dnt[a] * dnt[b] + kga * ga * gb) * l
                    });
                    let tol =
                        |x: f64, y: f64| (x - y).abs() <= 1e-10 * (1.0 + x.abs().max(y.abs()));
                    assert!(
                        tol(mt[a][b], mt_q),
                        "mT[{a}][{b}] phi={p}: {} vs {mt_q}",
                        mt[a][b]
                    );
                    assert!(
                        tol(mr[a][b], mr_q),
                        "mR[{a}][{b}] phi={p}: {} vs {mr_q}",
                        mr[a][b]
                    );
                    assert!(
                        tol(k[a][b], k_q),
                        "k[{a}][{b}] phi={p}: {} vs {k_q}",
                        k[a][b]
                    );
                }
            }
        }
    }

    fn element() -> ShaftElement {
        ShaftElement {
            length: 0.05,
            outer_diameter: 0.1,
            inner_diameter: 0.02,
            material: Material::steel(),
        }
    }

    #[test]
    fn symmetry_and_rigid_body_modes() {
        let e = element();
        let sm = element_matrices(&e, BeamTheory::Timoshenko);
        for i in 0..8 {
            for j in 0..8 {
                assert!((sm.m[i][j] - sm.m[j][i]).abs() < 1e-14);
                assert!((sm.k[i][j] - sm.k[j][i]).abs() < 1e-3);
                assert!((sm.g[i][j] + sm.g[j][i]).abs() < 1e-16);
            }
        }
        // Rigid translation in y and a rigid tilt about z (y = x, phi_z = 1)
        // and about y (z = -x, phi_y = 1) carry no strain energy.
        let l = e.length;
        let modes = [
            [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0],
            [0.0, 0.0, 0.0, 1.0, l, 0.0, 0.0, 1.0],
            [0.0, 0.0, 1.0, 0.0, 0.0, -l, 1.0, 0.0],
        ];
        let kmax = sm.k.iter().flatten().fold(0.0f64, |a, b| a.max(b.abs()));
        for q in &modes {
            for i in 0..8 {
                let f: f64 = (0..8).map(|j| sm.k[i][j] * q[j]).sum();
                assert!(f.abs() < 1e-12 * kmax, "row {i}: {f}");
            }
        }
        // A wrongly signed tilt (z = +x, phi_y = 1) is strained.
        let bad = [0.0, 0.0, 1.0, 0.0, 0.0, l, 1.0, 0.0];
        let f: f64 = (0..8).map(|j| sm.k[1][j] * bad[j]).sum();
        assert!(f.abs() > 1e-3 * kmax * l);
    }

    #[test]
    fn mass_totals_and_gyroscopic_rigid_slice() {
        let e = element();
        let s = Section::tube(e.outer_diameter, e.inner_diameter, 0.3);
        let sm = element_matrices(&e, BeamTheory::Timoshenko);
        // Kinetic energy of a rigid translation: total mass.
        let mass = e.material.rho * s.area * e.length;
        let total: f64 = [0, 4]
            .iter()
            .flat_map(|&i| [0, 4].map(|j| sm.m[i][j]))
            .sum();
        assert!((total - mass).abs() < 1e-12 * mass);
        // A rigid tilt about y (phi_y = 1, z = -x + L/2 about the centre)
        // has rotary inertia rho I L + translational rho A L^3 / 12.
        let l = e.length;
        let q = [0.0, l / 2.0, 1.0, 0.0, 0.0, -l / 2.0, 1.0, 0.0];
        let ke: f64 = (0..8)
            .map(|i| (0..8).map(|j| q[i] * sm.m[i][j] * q[j]).sum::<f64>())
            .sum();
        let expect = e.material.rho * (s.inertia * l + s.area * l.powi(3) / 12.0);
        assert!((ke - expect).abs() < 1e-10 * expect, "{ke} vs {expect}");
        // Gyroscopic coupling of rigid tilts: phi_y^T G phi_z = Ip = 2 rho I L.
        let qy = [0.0, l / 2.0, 1.0, 0.0, 0.0, -l / 2.0, 1.0, 0.0];
        let qz = [-l / 2.0, 0.0, 0.0, 1.0, l / 2.0, 0.0, 0.0, 1.0];
        let gyz: f64 = (0..8)
            .map(|i| (0..8).map(|j| qy[i] * sm.g[i][j] * qz[j]).sum::<f64>())
            .sum();
        let ip = 2.0 * e.material.rho * s.inertia * l;
        assert!((gyz - ip).abs() < 1e-10 * ip, "{gyz} vs {ip}");
    }
}
