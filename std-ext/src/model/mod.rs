//! Physical description of a rotor-bearing system, in SI units.
//!
//! This is what a model file (TOML, ROSS) is parsed into and what the
//! finite-element assembly, the simulator and the table generator read. It
//! holds no matrices: see [`crate::fe::assembly`] for those.
//!
//! Node indices here are **0-based** (`node = 0` is the left end of the
//! shaft); files, reports and the CLI number nodes from 1, and convert once at
//! the edge. Shaft element `i` joins nodes `i` and `i + 1`.
//!
//! Phasor convention: a physical signal is `y(t) = Re{ Y exp(j Omega t) }`;
//! the rotor turns from +y toward +z, so a feature at angle `alpha` in the
//! rotating frame (measured from +y at `t = 0`) has phasors
//! `Y = r exp(j alpha)`, `Z = -j r exp(j alpha)`.

pub mod extension;
pub mod plausible;

use core::f64::consts::PI;
use num_complex::Complex64;
use thiserror::Error;

/// Error in a rotor description: names the offending field.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ModelError {
    /// A field is missing, non-finite or out of its physical range.
    #[error("{field}: {reason}")]
    Invalid {
        /// Dotted path of the field, e.g. `shaft[3].length` (1-based nodes).
        field: String,
        /// What is wrong with it.
        reason: String,
    },
}

impl ModelError {
    /// Shorthand constructor.
    pub fn invalid(field: impl Into<String>, reason: impl Into<String>) -> Self {
        ModelError::Invalid {
            field: field.into(),
            reason: reason.into(),
        }
    }
}

/// Isotropic linear-elastic material.
#[derive(Debug, Clone, PartialEq)]
pub struct Material {
    /// Name, for reports.
    pub name: String,
    /// Young's modulus E (Pa).
    pub e: f64,
    /// Shear modulus G (Pa).
    pub g: f64,
    /// Density rho (kg/m^3).
    pub rho: f64,
}

impl Material {
    /// From E, density and Poisson's ratio: `G = E / (2 (1 + nu))`.
    pub fn from_e_nu(name: impl Into<String>, e: f64, rho: f64, nu: f64) -> Self {
        Material {
            name: name.into(),
            e,
            g: e / (2.0 * (1.0 + nu)),
            rho,
        }
    }

    /// Poisson's ratio implied by E and G: `nu = E / (2 G) - 1`.
    pub fn nu(&self) -> f64 {
        self.e / (2.0 * self.g) - 1.0
    }

    /// The reference steel of the paper: E = 200 GPa, rho = 7800 kg/m^3, nu = 0.3.
    pub fn steel() -> Self {
        Material::from_e_nu("steel", 200e9, 7800.0, 0.3)
    }
}

/// Beam theory of the shaft elements.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum BeamTheory {
    /// Shear deformation and rotary inertia (the default).
    #[default]
    Timoshenko,
    /// Slender-beam theory: no shear deformation. Rotary inertia is kept.
    EulerBernoulli,
}

/// One shaft element: a uniform circular tube between two consecutive nodes.
#[derive(Debug, Clone, PartialEq)]
pub struct ShaftElement {
    /// Length L (m).
    pub length: f64,
    /// Outer diameter (m).
    pub outer_diameter: f64,
    /// Inner diameter, 0 for a solid section (m).
    pub inner_diameter: f64,
    /// Material of the element.
    pub material: Material,
}

/// A rigid disk attached to one node.
#[derive(Debug, Clone, PartialEq)]
pub struct Disk {
    /// Node (0-based).
    pub node: usize,
    /// Mass m (kg).
    pub mass: f64,
    /// Diametral (transverse) moment of inertia Id (kg m^2).
    pub id: f64,
    /// Polar moment of inertia Ip (kg m^2).
    pub ip: f64,
}

impl Disk {
    /// A disk from its geometry: `m = rho pi (Do^2 - Di^2) t / 4`,
    /// `Ip = m (Do^2 + Di^2) / 8`, `Id = Ip / 2 + m t^2 / 12`.
    pub fn from_geometry(
        node: usize,
        rho: f64,
        outer_diameter: f64,
        inner_diameter: f64,
        thickness: f64,
    ) -> Self {
        let (d_o, d_i, t) = (outer_diameter, inner_diameter, thickness);
        let mass = rho * PI * (d_o * d_o - d_i * d_i) * t / 4.0;
        let ip = mass * (d_o * d_o + d_i * d_i) / 8.0;
        let id = ip / 2.0 + mass * t * t / 12.0;
        Disk { node, mass, id, ip }
    }
}

/// Eight linear bearing coefficients at one speed.
///
/// Order `yy, yz, zy, zz`: the bearing force on the shaft is
/// `f = -(K q + C dq/dt)` with `q = (y, z)`, i.e. dynamic stiffness
/// `Z_B = K + j Omega C` (Eq. 43).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct BearingCoefficients {
    /// Stiffness `[kyy, kyz, kzy, kzz]` (N/m).
    pub k: [f64; 4],
    /// Damping `[cyy, cyz, czy, czz]` (N s/m).
    pub c: [f64; 4],
}

/// How a bearing's coefficients depend on the rotor speed Omega (rad/s).
#[derive(Debug, Clone, PartialEq)]
pub enum BearingLaw {
    /// The same coefficients at every speed.
    Constant(BearingCoefficients),
    /// A table against speed, interpolated linearly between entries and held
    /// constant beyond the ends. `speeds` strictly increasing (rad/s).
    Table {
        /// Speeds (rad/s).
        speeds: Vec<f64>,
        /// Coefficients at each speed.
        coefficients: Vec<BearingCoefficients>,
    },
    /// Polynomials in Omega: `K(Omega) = sum_p k[p] Omega^p`,
    /// `C(Omega) = sum_p c[p] Omega^p` (the paper's Eq. 49 is
    /// `k = [0, 0, K_ref / Omega_ref^2]`, with `Omega_ref` = 15000 rpm).
    Polynomial {
        /// Stiffness coefficients per power of Omega (N/m / (rad/s)^p).
        k: Vec<[f64; 4]>,
        /// Damping coefficients per power of Omega (N s/m / (rad/s)^p).
        c: Vec<[f64; 4]>,
    },
    /// A complex polynomial dynamic stiffness on the 1X line,
    /// `Z_B(Omega) = sum_p Omega^p z[p]` (the paper's Eq. 43 for `p <= 1`;
    /// what its identification structure fits), read at each speed as
    /// `K(Omega) = Re Z_B(Omega)`, `C(Omega) = Im (Z_B(Omega) - Z_B(0)) /
    /// Omega = sum_(p>=1) Omega^(p-1) Im z[p]` (`Im z[0]`, an imaginary
    /// stiffness at rest, is physically zero and not damping).
    DynamicStiffness {
        /// Coefficients per power of Omega (N/m / (rad/s)^p).
        z: Vec<[Complex64; 4]>,
    },
}

impl BearingLaw {
    /// Coefficients at speed `omega` (rad/s).
    pub fn at(&self, omega: f64) -> BearingCoefficients {
        match self {
            BearingLaw::Constant(c) => *c,
            BearingLaw::Table {
                speeds,
                coefficients,
            } => {
                let n = speeds.len();
                if n == 0 {
                    return BearingCoefficients::default();
                }
                if omega <= speeds[0] {
                    return coefficients[0];
                }
                if omega >= speeds[n - 1] {
                    return coefficients[n - 1];
                }
                // First index with speeds[i] > omega; 1 <= i <= n-1 here.
                let i = speeds.partition_point(|&s| s <= omega);
                let (s0, s1) = (speeds[i - 1], speeds[i]);
                let t = (omega - s0) / (s1 - s0);
                let (a, b) = (coefficients[i - 1], coefficients[i]);
                let mut out = BearingCoefficients::default();
                for j in 0..4 {
                    out.k[j] = a.k[j] + t * (b.k[j] - a.k[j]);
                    out.c[j] = a.c[j] + t * (b.c[j] - a.c[j]);
                }
                out
            }
            BearingLaw::DynamicStiffness { z } => {
                let mut out = BearingCoefficients::default();
                for j in 0..4 {
                    out.k[j] = z.iter().rev().fold(0.0, |acc, row| acc * omega + row[j].re);
                    out.c[j] = z
                        .iter()
                        .skip(1)
                        .rev()
                        .fold(0.0, |acc, row| acc * omega + row[j].im);
                }
                out
            }
            BearingLaw::Polynomial { k, c } => {
                let mut out = BearingCoefficients::default();
                let horner = |coef: &[[f64; 4]], j: usize| {
                    coef.iter().rev().fold(0.0, |acc, row| acc * omega + row[j])
                };
                for j in 0..4 {
                    out.k[j] = horner(k, j);
                    out.c[j] = horner(c, j);
                }
                out
            }
        }
    }
}

/// A pedestal (foundation mass) under a bearing: the bearing acts between
/// the shaft node and the pedestal mass, which is tied to ground by its own
/// stiffness and damping in y and z.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pedestal {
    /// Mass (kg), the same in y and z.
    pub mass: f64,
    /// Stiffness to ground `[ky, kz]` (N/m).
    pub k: [f64; 2],
    /// Damping to ground `[cy, cz]` (N s/m).
    pub c: [f64; 2],
}

/// A linear bearing at a shaft node, optionally on a pedestal.
#[derive(Debug, Clone, PartialEq)]
pub struct Bearing {
    /// Node (0-based).
    pub node: usize,
    /// Speed dependence of the coefficients.
    pub law: BearingLaw,
    /// `None` for a rigid foundation.
    pub pedestal: Option<Pedestal>,
}

/// Unbalance in one plane: `a = m e exp(j alpha)`, forcing
/// `F_y = Omega^2 a`, `F_z = -j Omega^2 a` (Eqs. 31, 40).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Unbalance {
    /// Node (0-based).
    pub node: usize,
    /// Unbalance m e (kg m).
    pub me: f64,
    /// Phase alpha (rad), from +y in the rotating frame at t = 0.
    pub phase: f64,
}

impl Unbalance {
    /// The complex unbalance `a = m e exp(j alpha)` (kg m).
    pub fn phasor(&self) -> num_complex::Complex64 {
        num_complex::Complex64::from_polar(self.me, self.phase)
    }
}

/// One point of a shaft bow: the lateral offset of the shaft centre line at
/// a node, fixed in the rotating frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BowPoint {
    /// Node (0-based).
    pub node: usize,
    /// Offset amplitude (m).
    pub amplitude: f64,
    /// Angle (rad) from +y in the rotating frame at t = 0.
    pub phase: f64,
}

/// A bent shaft: a bow shape given at some nodes (see
/// [`crate::fe::assembly`] for how it is interpolated to all DOFs). Its
/// synchronous forcing is `K_shaft q_bow`, independent of speed.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ShaftBow {
    /// The given points, nodes strictly increasing.
    pub points: Vec<BowPoint>,
}

/// A complete rotor-bearing system.
#[derive(Debug, Clone, PartialEq)]
pub struct RotorModel {
    /// Name, for reports.
    pub name: String,
    /// Beam theory of all shaft elements.
    pub theory: BeamTheory,
    /// Shaft elements, left to right; element `i` joins nodes `i`, `i + 1`.
    pub shaft: Vec<ShaftElement>,
    /// Rigid disks.
    pub disks: Vec<Disk>,
    /// Bearings, sorted by node (bearing `b1` is the lowest node).
    pub bearings: Vec<Bearing>,
    /// Nodes (0-based) of the unbalance planes the identification estimates.
    pub planes: Vec<usize>,
    /// The true unbalance, used by the simulator (empty when unknown).
    pub unbalance: Vec<Unbalance>,
    /// Optional shaft bow, used by the simulator.
    pub bow: Option<ShaftBow>,
    /// What the bearing probes measure (matters only under pedestals).
    pub probes: ProbeReference,
}

/// What a bearing probe measures.
///
/// Proximity probes are mounted on the bearing housing and read the
/// shaft's motion relative to it: on a pedestal of displacement `q_p` they
/// read `q_s - q_p`. Seismic or inertially referenced probes read the
/// shaft's absolute motion `q_s`. On a rigid foundation both are the same.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ProbeReference {
    /// Shaft relative to the bearing housing (the default).
    #[default]
    Relative,
    /// Shaft absolute motion.
    Absolute,
}

impl RotorModel {
    /// Number of nodes: shaft elements + 1.
    pub fn n_nodes(&self) -> usize {
        self.shaft.len() + 1
    }

    /// Axial positions of the nodes (m), node 0 at x = 0.
    pub fn node_positions(&self) -> Vec<f64> {
        let mut x = Vec::with_capacity(self.n_nodes());
        x.push(0.0);
        for e in &self.shaft {
            x.push(x[x.len() - 1] + e.length);
        }
        x
    }

    /// Bearing nodes (0-based), in bearing order.
    pub fn bearing_nodes(&self) -> Vec<usize> {
        self.bearings.iter().map(|b| b.node).collect()
    }

    /// The reference rotor of the method paper (section 4, with the
    /// unbalance chosen by this project since the paper's Table 2 is
    /// missing): steel shaft 1.3 m, diameter 0.1 m, 26 Timoshenko elements,
    /// disks at nodes 5, 11, 21 (1-based), bearings at nodes 1 and 27.
    pub fn paper() -> Self {
        let steel = Material::steel();
        let n_el = 26;
        let shaft = (0..n_el)
            .map(|_| ShaftElement {
                length: 1.3 / n_el as f64,
                outer_diameter: 0.1,
                inner_diameter: 0.0,
                material: steel.clone(),
            })
            .collect();
        let disks = [4, 10, 20]
            .iter()
            .map(|&n| Disk::from_geometry(n, steel.rho, 0.12, 0.1, 0.05))
            .collect();
        let bearings = vec![
            Bearing {
                node: 0,
                law: BearingLaw::Constant(BearingCoefficients {
                    k: [5e7, 0.5e7, 1e7, 7e7],
                    c: [500.0, 50.0, 100.0, 700.0],
                }),
                pedestal: None,
            },
            Bearing {
                node: 26,
                law: BearingLaw::Constant(BearingCoefficients {
                    k: [5e7, 1e7, 0.5e7, 7e7],
                    c: [500.0, 100.0, 50.0, 700.0],
                }),
                pedestal: None,
            },
        ];
        let deg = PI / 180.0;
        let unbalance = vec![
            Unbalance {
                node: 4,
                me: 0.0042,
                phase: 0.0,
            },
            Unbalance {
                node: 10,
                me: 0.0030,
                phase: 18.0 * deg,
            },
            Unbalance {
                node: 20,
                me: 0.0073,
                phase: 23.0 * deg,
            },
        ];
        RotorModel {
            name: "paper".into(),
            theory: BeamTheory::Timoshenko,
            shaft,
            disks,
            bearings,
            planes: vec![4, 10, 20],
            unbalance,
            bow: None,
            probes: ProbeReference::Relative,
        }
    }

    /// The paper's speed-dependent case (section 4.2, Eq. 49): every
    /// stiffness scales as `rpm^2 / 2.25e8`, so it equals the constant case
    /// at 15000 rpm and vanishes at rest; damping and unbalance unchanged.
    pub fn paper_speed_dependent() -> Self {
        let mut m = Self::paper();
        // rpm^2 / 2.25e8 = (Omega / Omega_ref)^2 with Omega_ref = 15000 rpm.
        let omega_ref = 15000.0 * PI / 30.0;
        for b in &mut m.bearings {
            if let BearingLaw::Constant(c) = b.law {
                let k2 = c.k.map(|k| k / (omega_ref * omega_ref));
                b.law = BearingLaw::Polynomial {
                    k: vec![[0.0; 4], [0.0; 4], k2],
                    c: vec![c.c],
                };
            }
        }
        m.name = "paper-speed-dependent".into();
        m
    }

    /// Checks every field: positive lengths, diameters and masses, finite
    /// coefficients, nodes on the shaft, bearings sorted and distinct,
    /// planes on the shaft. The error names the field (1-based nodes).
    pub fn validate(&self) -> Result<(), ModelError> {
        let pos = |field: String, v: f64| -> Result<(), ModelError> {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(ModelError::invalid(
                    field,
                    format!("must be finite and > 0, got {v}"),
                ))
            }
        };
        let finite = |field: String, v: f64| -> Result<(), ModelError> {
            if v.is_finite() {
                Ok(())
            } else {
                Err(ModelError::invalid(
                    field,
                    format!("must be finite, got {v}"),
                ))
            }
        };
        if self.shaft.is_empty() {
            return Err(ModelError::invalid("shaft", "needs at least one element"));
        }
        for (i, e) in self.shaft.iter().enumerate() {
            let f = |name: &str| format!("shaft[{}].{name}", i + 1);
            pos(f("length"), e.length)?;
            pos(f("outer_diameter"), e.outer_diameter)?;
            if !(e.inner_diameter.is_finite()
                && e.inner_diameter >= 0.0
                && e.inner_diameter < e.outer_diameter)
            {
                return Err(ModelError::invalid(
                    f("inner_diameter"),
                    format!("must be in [0, outer_diameter), got {}", e.inner_diameter),
                ));
            }
            pos(f("material.e"), e.material.e)?;
            pos(f("material.g"), e.material.g)?;
            pos(f("material.rho"), e.material.rho)?;
        }
        let n = self.n_nodes();
        let on_shaft = |field: String, node: usize| -> Result<(), ModelError> {
            if node < n {
                Ok(())
            } else {
                Err(ModelError::invalid(
                    field,
                    format!("node {} is not on the shaft (nodes 1..={n})", node + 1),
                ))
            }
        };
        for (i, d) in self.disks.iter().enumerate() {
            let f = |name: &str| format!("disk[{}].{name}", i + 1);
            on_shaft(f("node"), d.node)?;
            pos(f("mass"), d.mass)?;
            pos(f("id"), d.id)?;
            pos(f("ip"), d.ip)?;
        }
        if self.bearings.is_empty() {
            return Err(ModelError::invalid("bearing", "needs at least one bearing"));
        }
        for (i, b) in self.bearings.iter().enumerate() {
            let f = |name: &str| format!("bearing[{}].{name}", i + 1);
            on_shaft(f("node"), b.node)?;
            if i > 0 && b.node <= self.bearings[i - 1].node {
                return Err(ModelError::invalid(
                    f("node"),
                    "bearings must be sorted by node, one per node",
                ));
            }
            let check = |c: &BearingCoefficients, at: &str| -> Result<(), ModelError> {
                for j in 0..4 {
                    finite(f(&format!("{at}k[{}]", j + 1)), c.k[j])?;
                    finite(f(&format!("{at}c[{}]", j + 1)), c.c[j])?;
                }
                Ok(())
            };
            match &b.law {
                BearingLaw::Constant(c) => check(c, "")?,
                BearingLaw::Table {
                    speeds,
                    coefficients,
                } => {
                    if speeds.is_empty() || speeds.len() != coefficients.len() {
                        return Err(ModelError::invalid(
                            f("speed"),
                            "table needs one or more speeds and one coefficient set per speed",
                        ));
                    }
                    for (j, s) in speeds.iter().enumerate() {
                        if !(s.is_finite() && *s >= 0.0) || (j > 0 && *s <= speeds[j - 1]) {
                            return Err(ModelError::invalid(
                                f("speed"),
                                "speeds must be finite, >= 0 and strictly increasing",
                            ));
                        }
                    }
                    for (j, c) in coefficients.iter().enumerate() {
                        check(c, &format!("table[{}].", j + 1))?;
                    }
                }
                BearingLaw::DynamicStiffness { z } => {
                    for (p, row) in z.iter().enumerate() {
                        for (j, v) in row.iter().enumerate() {
                            finite(f(&format!("z_poly[{}][{}].re", p + 1, j + 1)), v.re)?;
                            finite(f(&format!("z_poly[{}][{}].im", p + 1, j + 1)), v.im)?;
                        }
                    }
                }
                BearingLaw::Polynomial { k, c } => {
                    for (p, row) in k.iter().enumerate() {
                        for (j, v) in row.iter().enumerate() {
                            finite(f(&format!("k_poly[{}][{}]", p + 1, j + 1)), *v)?;
                        }
                    }
                    for (p, row) in c.iter().enumerate() {
                        for (j, v) in row.iter().enumerate() {
                            finite(f(&format!("c_poly[{}][{}]", p + 1, j + 1)), *v)?;
                        }
                    }
                }
            }
            if let Some(p) = &b.pedestal {
                pos(f("pedestal.mass"), p.mass)?;
                for j in 0..2 {
                    pos(f(&format!("pedestal.k[{}]", j + 1)), p.k[j])?;
                    if !(p.c[j].is_finite() && p.c[j] >= 0.0) {
                        return Err(ModelError::invalid(
                            f(&format!("pedestal.c[{}]", j + 1)),
                            "must be finite and >= 0",
                        ));
                    }
                }
            }
        }
        for (i, &p) in self.planes.iter().enumerate() {
            on_shaft(format!("planes[{}]", i + 1), p)?;
            if self.planes[..i].contains(&p) {
                return Err(ModelError::invalid(
                    format!("planes[{}]", i + 1),
                    format!("node {} listed twice", p + 1),
                ));
            }
        }
        for (i, u) in self.unbalance.iter().enumerate() {
            let f = |name: &str| format!("unbalance[{}].{name}", i + 1);
            on_shaft(f("node"), u.node)?;
            finite(f("me"), u.me)?;
            finite(f("phase"), u.phase)?;
        }
        if let Some(bow) = &self.bow {
            for (i, p) in bow.points.iter().enumerate() {
                let f = |name: &str| format!("bow[{}].{name}", i + 1);
                on_shaft(f("node"), p.node)?;
                finite(f("amplitude"), p.amplitude)?;
                finite(f("phase"), p.phase)?;
                if i > 0 && p.node <= bow.points[i - 1].node {
                    return Err(ModelError::invalid(
                        f("node"),
                        "bow points must be sorted by node",
                    ));
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_disk_mass_matches_spec() {
        let m = RotorModel::paper();
        assert!((m.disks[0].mass - 1.3477).abs() < 1e-4);
        m.validate().unwrap();
        assert_eq!(m.n_nodes(), 27);
        assert!((m.node_positions()[26] - 1.3).abs() < 1e-12);
    }

    #[test]
    fn eq49_equals_table1_at_15000_rpm_and_zero_at_rest() {
        let m = RotorModel::paper_speed_dependent();
        let omega = 15000.0 * PI / 30.0;
        let c = m.bearings[0].law.at(omega);
        assert!((c.k[0] - 5e7).abs() < 1e-6 * 5e7);
        assert_eq!(m.bearings[0].law.at(0.0).k[0], 0.0);
        assert_eq!(c.c[3], 700.0);
    }

    #[test]
    fn table_law_interpolates_and_clamps() {
        let a = BearingCoefficients {
            k: [1.0; 4],
            c: [2.0; 4],
        };
        let b = BearingCoefficients {
            k: [3.0; 4],
            c: [6.0; 4],
        };
        let law = BearingLaw::Table {
            speeds: vec![10.0, 20.0],
            coefficients: vec![a, b],
        };
        assert_eq!(law.at(15.0).k[2], 2.0);
        assert_eq!(law.at(0.0).c[0], 2.0);
        assert_eq!(law.at(99.0).c[0], 6.0);
    }

    #[test]
    fn validate_names_the_field() {
        let mut m = RotorModel::paper();
        m.shaft[2].length = -1.0;
        let e = m.validate().unwrap_err().to_string();
        assert!(e.contains("shaft[3].length"), "{e}");
        let mut m = RotorModel::paper();
        m.bearings[1].node = 40;
        let e = m.validate().unwrap_err().to_string();
        assert!(e.contains("bearing[2].node"), "{e}");
    }
}
