//! Rigid disk attached to a shaft node.
//!
//! With the node DOFs `(y, z, phi_y, phi_z)` (see [`crate::fe::shaft`] for the
//! axes: `phi_z = dy/dx`, `phi_y = -dz/dx`, spin `Omega` about +x), the
//! angular momentum of a disk of polar inertia `Ip` and diametral inertia
//! `Id`, tilted by small `phi_y`, `phi_z`, is `H = Ip Omega e_x' + Id (phi_y' e_y
//! + phi_z' e_z)` with the tilted spin axis `e_x' = e_x + phi_z e_y - phi_y e_z`.
//! Euler's law `dH/dt = moment` gives
//!
//! ```text
//! Id phi_y'' + Omega Ip phi_z' = M_y
//! Id phi_z'' - Omega Ip phi_y' = M_z
//! ```
//!
//! so, in `M q'' + Omega G q' = f` (Friswell et al., *Dynamics of Rotating
//! Machines*, CUP 2010, section 5.4.1; Lalanne & Ferraris, *Rotordynamics
//! Prediction in Engineering*, 1998, ch. 1):
//!
//! ```text
//! M = diag(m, m, Id, Id),     G = [0 0  0   0
//!                                  0 0  0   0
//!                                  0 0  0   Ip
//!                                  0 0 -Ip  0 ]
//! ```
//!
//! For a forward tilt whirl (`phi_z = cos w t`, `phi_y = -sin w t`) on a
//! rotational spring `k_r` this gives `Id w^2 - Ip Omega w - k_r = 0`: the
//! gyroscopic moment stiffens forward whirl.

use crate::model::Disk;

/// Mass and gyroscopic matrices of a rigid disk in its node's DOF order
/// `(y, z, phi_y, phi_z)` (kg, kg m^2).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DiskMatrices {
    /// `diag(m, m, Id, Id)`.
    pub m: [[f64; 4]; 4],
    /// `G[2][3] = Ip`, `G[3][2] = -Ip`.
    pub g: [[f64; 4]; 4],
}

/// The matrices of a disk (see the module documentation).
pub fn disk_matrices(d: &Disk) -> DiskMatrices {
    let mut m = [[0.0; 4]; 4];
    m[0][0] = d.mass;
    m[1][1] = d.mass;
    m[2][2] = d.id;
    m[3][3] = d.id;
    let mut g = [[0.0; 4]; 4];
    g[2][3] = d.ip;
    g[3][2] = -d.ip;
    DiskMatrices { m, g }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_disk() {
        let d = Disk::from_geometry(4, 7800.0, 0.12, 0.1, 0.05);
        let dm = disk_matrices(&d);
        assert!((dm.m[0][0] - 1.3477).abs() < 1e-4);
        assert_eq!(dm.g[2][3], -dm.g[3][2]);
        assert!(dm.g[2][3] > 0.0);
        assert!((dm.m[2][2] - (d.ip / 2.0 + d.mass * 0.05 * 0.05 / 12.0)).abs() < 1e-15);
    }
}
