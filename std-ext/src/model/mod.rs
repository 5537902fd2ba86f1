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
    /// A table against speed, interpolated between entries as `interpolation`
    /// says. `speeds` strictly increasing (rad/s).
    Table {
        /// Speeds (rad/s).
        speeds: Vec<f64>,
        /// Coefficients at each speed.
        coefficients: Vec<BearingCoefficients>,
        /// How values between and beyond the entries are obtained.
        interpolation: TableInterpolation,
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

/// How a [`BearingLaw::Table`] is evaluated between and beyond its speeds
/// `x_0 < x_1 < ... < x_(n-1)` with values `y_i` (one coefficient at a time).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum TableInterpolation {
    /// Linear between entries, `y = y_i + t (y_(i+1) - y_i)` with
    /// `t = (x - x_i) / (x_(i+1) - x_i)`, and held at the end values beyond
    /// the table (rotorid's own model files).
    #[default]
    LinearHold,
    /// Linear between entries and linear extrapolation of the first and last
    /// segments beyond the table (ROSS's `interpolation = "linear"`, SciPy's
    /// `interp1d(..., fill_value="extrapolate")`).
    LinearExtrapolate,
    /// Monotone piecewise cubic Hermite interpolation (Fritsch-Carlson, as
    /// SciPy's `PchipInterpolator`) between entries and, beyond the table,
    /// the straight line through the end point with the interpolant's end
    /// slope: `y = y_0 + d_0 (x - x_0)` below, `y = y_(n-1) + d_(n-1) (x -
    /// x_(n-1))` above (ROSS 3's `interpolation = "pchip"`). Two entries give
    /// the straight line through them, one entry a constant. See
    /// [`pchip_slopes`] for the slopes `d_i`.
    Pchip,
}

impl TableInterpolation {
    /// Value at `x` of the table `(xs, ys)` (`xs` strictly increasing, same
    /// length as `ys`, at least one entry; an empty table gives 0).
    pub fn eval(self, xs: &[f64], ys: &[f64], x: f64) -> f64 {
        let n = xs.len().min(ys.len());
        if n == 0 {
            return 0.0;
        }
        if n == 1 {
            return ys[0];
        }
        match self {
            TableInterpolation::LinearHold | TableInterpolation::LinearExtrapolate => {
                if self == TableInterpolation::LinearHold {
                    if x <= xs[0] {
                        return ys[0];
                    }
                    if x >= xs[n - 1] {
                        return ys[n - 1];
                    }
                }
                // Segment i: the one containing x, or the end segment beyond.
                let i = xs[..n].partition_point(|&s| s <= x).clamp(1, n - 1) - 1;
                let t = (x - xs[i]) / (xs[i + 1] - xs[i]);
                ys[i] + t * (ys[i + 1] - ys[i])
            }
            TableInterpolation::Pchip => {
                let d = pchip_slopes(&xs[..n], &ys[..n]);
                if x < xs[0] {
                    return ys[0] + d[0] * (x - xs[0]);
                }
                if x > xs[n - 1] {
                    return ys[n - 1] + d[n - 1] * (x - xs[n - 1]);
                }
                let i = xs[..n].partition_point(|&s| s <= x).clamp(1, n - 1) - 1;
                let h = xs[i + 1] - xs[i];
                let t = (x - xs[i]) / h;
                // Cubic Hermite basis on [x_i, x_(i+1)].
                let t2 = t * t;
                let t3 = t2 * t;
                let h00 = 2.0 * t3 - 3.0 * t2 + 1.0;
                let h10 = t3 - 2.0 * t2 + t;
                let h01 = -2.0 * t3 + 3.0 * t2;
                let h11 = t3 - t2;
                h00 * ys[i] + h10 * h * d[i] + h01 * ys[i + 1] + h11 * h * d[i + 1]
            }
        }
    }
}

/// Derivatives `d_i` of the monotone cubic Hermite interpolant at the table
/// points, exactly as SciPy's `PchipInterpolator` (Fritsch-Carlson with
/// Moler's end conditions). With `h_k = x_(k+1) - x_k` and secants
/// `m_k = (y_(k+1) - y_k) / h_k`:
///
/// - interior point `k`: `d_k = 0` if `m_(k-1)` and `m_k` differ in sign or
///   either is 0, else the weighted harmonic mean
///   `(w_1 + w_2) / d_k = w_1 / m_(k-1) + w_2 / m_k` with
///   `w_1 = 2 h_k + h_(k-1)`, `w_2 = h_k + 2 h_(k-1)`;
/// - end point (shown for the left end): the one-sided three-point estimate
///   `d_0 = ((2 h_0 + h_1) m_0 - h_0 m_1) / (h_0 + h_1)`, set to 0 if its
///   sign differs from `m_0`'s, and to `3 m_0` if `m_0`, `m_1` differ in
///   sign and `|d_0| > 3 |m_0|`;
/// - two points: `d_0 = d_1 = m_0` (a straight line).
///
/// Units: those of `y` per unit of `x`.
pub fn pchip_slopes(xs: &[f64], ys: &[f64]) -> Vec<f64> {
    let n = xs.len().min(ys.len());
    if n < 2 {
        return vec![0.0; n];
    }
    let h: Vec<f64> = (0..n - 1).map(|k| xs[k + 1] - xs[k]).collect();
    let m: Vec<f64> = (0..n - 1).map(|k| (ys[k + 1] - ys[k]) / h[k]).collect();
    if n == 2 {
        return vec![m[0]; 2];
    }
    let sign = |v: f64| {
        if v > 0.0 {
            1
        } else if v < 0.0 {
            -1
        } else {
            0
        }
    };
    let mut d = vec![0.0; n];
    for k in 1..n - 1 {
        let (m0, m1) = (m[k - 1], m[k]);
        if sign(m0) != sign(m1) || m0 == 0.0 || m1 == 0.0 {
            d[k] = 0.0;
        } else {
            let w1 = 2.0 * h[k] + h[k - 1];
            let w2 = h[k] + 2.0 * h[k - 1];
            d[k] = 1.0 / ((w1 / m0 + w2 / m1) / (w1 + w2));
        }
    }
    let edge = |h0: f64, h1: f64, m0: f64, m1: f64| {
        let d = ((2.0 * h0 + h1) * m0 - h0 * m1) / (h0 + h1);
        if sign(d) != sign(m0) {
            0.0
        } else if sign(m0) != sign(m1) && d.abs() > 3.0 * m0.abs() {
            3.0 * m0
        } else {
            d
        }
    };
    d[0] = edge(h[0], h[1], m[0], m[1]);
    d[n - 1] = edge(h[n - 2], h[n - 3], m[n - 2], m[n - 3]);
    d
}

impl BearingLaw {
    /// Coefficients at speed `omega` (rad/s).
    pub fn at(&self, omega: f64) -> BearingCoefficients {
        match self {
            BearingLaw::Constant(c) => *c,
            BearingLaw::Table {
                speeds,
                coefficients,
                interpolation,
            } => {
                let mut out = BearingCoefficients::default();
                let mut column = Vec::with_capacity(speeds.len());
                for j in 0..8 {
                    column.clear();
                    column.extend(coefficients.iter().map(
                        |c| {
                            if j < 4 {
                                c.k[j]
                            } else {
                                c.c[j - 4]
                            }
                        },
                    ));
                    let v = interpolation.eval(speeds, &column, omega);
                    if j < 4 {
                        out.k[j] = v;
                    } else {
                        out.c[j - 4] = v;
                    }
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
/// stiffness and damping in y and z. The mass may differ between the
/// directions (a ROSS `PointMass` with `mx != my`: a support that is
/// heavier in one direction, e.g. a frame that carries mass horizontally
/// only): the pedestal's equation is, per direction `d = y, z`,
/// `m_d q_p,d'' + c_d q_p,d' + k_d q_p,d = (bearing force)_d`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pedestal {
    /// Mass `[m_y, m_z]` (kg), in y and in z.
    pub mass: [f64; 2],
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
    /// Rotor-level proportional damping of the shaft and disks (zero for
    /// rotorid's own model files; ROSS's `[parameters] alpha, beta`).
    pub rotor_damping: ProportionalDamping,
    /// Extra coaxial layers on shaft elements (empty for rotorid's own
    /// model files; ROSS's shaft elements sharing an `n`).
    pub shaft_layers: Vec<ShaftLayer>,
}

/// An extra coaxial layer on a shaft element (a sleeve, possibly of another
/// material): a uniform tube between the same two nodes whose element
/// matrices (same beam theory, its own section and material) are added to
/// those of [`RotorModel::shaft`]`[element]`, as ROSS does with shaft
/// elements that share an `n`.
#[derive(Debug, Clone, PartialEq)]
pub struct ShaftLayer {
    /// Index of the shaft element it lies on (0-based).
    pub element: usize,
    /// The layer's section and material; `length` equals the element's.
    pub section: ShaftElement,
}

/// Rotor-level proportional (Rayleigh) damping of the shaft and disks:
/// `C_R = alpha M_R + beta K_R`, with `M_R` the mass matrix of shaft and
/// disks and `K_R` the shaft stiffness (bearings and pedestals excluded),
/// as ROSS applies its `[parameters] alpha, beta`. It adds `j Omega C_R` to
/// the harmonic dynamic stiffness, i.e. a loss factor `beta Omega` on the
/// shaft's elasticity and a viscous `alpha` per unit mass.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ProportionalDamping {
    /// Mass-proportional coefficient alpha (1/s).
    pub alpha: f64,
    /// Stiffness-proportional coefficient beta (s).
    pub beta: f64,
}

impl ProportionalDamping {
    /// True when both coefficients are zero (no rotor damping).
    pub fn is_zero(&self) -> bool {
        self.alpha == 0.0 && self.beta == 0.0
    }
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

/// Two displacement probes at a bearing whose axes lie in the y-z plane at
/// angles `theta_1`, `theta_2` (rad) measured from +y toward +z (the sense
/// of rotation, README "Conventions"): a probe at `theta` reads the
/// displacement along `u = (cos theta, sin theta)`, phasor
/// `P = cos theta Y + sin theta Z` (m, same phasor convention as `Y`, `Z`).
/// API 670 X-Y probes at 45 degrees either side of a vertical +y are
/// `theta = +45` and `-45` degrees. The two readings give `Y`, `Z` by
/// solving the 2 x 2 projection,
///
/// ```text
/// [P1]   [cos t1  sin t1] [Y]        Y = ( sin t2 P1 - sin t1 P2) / D
/// [P2] = [cos t2  sin t2] [Z],       Z = (-cos t2 P1 + cos t1 P2) / D,
///                                    D = sin(t2 - t1),
/// ```
///
/// which amplifies a probe's noise by up to `1 / |D|` and, unless the
/// probes are orthogonal, correlates the noise of `Y` and `Z`.
#[derive(Debug, Clone, PartialEq)]
pub struct ProbePair {
    /// Probe names (the measurement file's column prefixes).
    pub names: [String; 2],
    /// Angles `theta_1`, `theta_2` (rad) from +y toward +z.
    pub angles: [f64; 2],
}

impl ProbePair {
    /// Smallest accepted angle between the two probe axes (deg): below it
    /// the projection amplifies noise more than `1 / sin(5 deg)` = 11.5 times.
    pub const MIN_SEPARATION_DEG: f64 = 5.0;

    /// `D = sin(theta_2 - theta_1)`, the determinant of the projection.
    pub fn determinant(&self) -> f64 {
        (self.angles[1] - self.angles[0]).sin()
    }

    /// The probes' readings `P_i = cos theta_i Y + sin theta_i Z` (m).
    pub fn readings(&self, y: Complex64, z: Complex64) -> [Complex64; 2] {
        self.angles.map(|t| y * t.cos() + z * t.sin())
    }

    /// `Y`, `Z` (m) from the readings (the projection solved, see above).
    pub fn to_yz(&self, p: [Complex64; 2]) -> [Complex64; 2] {
        let d = self.determinant();
        let (c1, s1) = (self.angles[0].cos(), self.angles[0].sin());
        let (c2, s2) = (self.angles[1].cos(), self.angles[1].sin());
        [(p[0] * s2 - p[1] * s1) / d, (p[1] * c1 - p[0] * c2) / d]
    }
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

    /// Total mass of the shaft and the disks (kg): `sum rho A L` over the
    /// shaft elements plus the disks' masses (mass-only layers not counted).
    pub fn rotor_mass(&self) -> f64 {
        let shaft: f64 = self
            .shaft
            .iter()
            .map(|e| {
                let a = std::f64::consts::PI / 4.0
                    * (e.outer_diameter.powi(2) - e.inner_diameter.powi(2));
                e.material.rho * a * e.length
            })
            .sum();
        shaft + self.disks.iter().map(|d| d.mass).sum::<f64>()
    }

    /// The total unbalance `sum_k m_k e_k` (kg m) of a balance grade `G`
    /// (mm/s) at the service speed `omega` (rad/s), ISO 21940-11: the
    /// permissible specific unbalance `e = G / Omega`, times the rotor mass.
    pub fn balance_grade_unbalance(&self, grade_mm_s: f64, omega: f64) -> f64 {
        grade_mm_s * 1e-3 / omega * self.rotor_mass()
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
            rotor_damping: ProportionalDamping::default(),
            shaft_layers: Vec::new(),
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
        self.validate_shaft()?;
        let n = self.n_nodes();
        for (i, d) in self.disks.iter().enumerate() {
            let f = |name: &str| format!("disk[{}].{name}", i + 1);
            on_shaft(f("node"), d.node, n)?;
            positive(f("mass"), d.mass)?;
            non_negative(f("id"), d.id)?;
            non_negative(f("ip"), d.ip)?;
        }
        self.validate_bearings(n)?;
        self.validate_shaft_layers()?;
        finite("rotor_damping.alpha".into(), self.rotor_damping.alpha)?;
        finite("rotor_damping.beta".into(), self.rotor_damping.beta)?;
        self.validate_loads(n)
    }

    /// [`Self::validate`]'s shaft elements: at least one, with positive
    /// dimensions and material constants, hollow or solid.
    fn validate_shaft(&self) -> Result<(), ModelError> {
        if self.shaft.is_empty() {
            return Err(ModelError::invalid("shaft", "needs at least one element"));
        }
        for (i, e) in self.shaft.iter().enumerate() {
            let f = |name: &str| format!("shaft[{}].{name}", i + 1);
            positive(f("length"), e.length)?;
            positive(f("outer_diameter"), e.outer_diameter)?;
            if !(e.inner_diameter.is_finite()
                && e.inner_diameter >= 0.0
                && e.inner_diameter < e.outer_diameter)
            {
                return Err(ModelError::invalid(
                    f("inner_diameter"),
                    format!("must be in [0, outer_diameter), got {}", e.inner_diameter),
                ));
            }
            positive(f("material.e"), e.material.e)?;
            positive(f("material.g"), e.material.g)?;
            positive(f("material.rho"), e.material.rho)?;
        }
        Ok(())
    }

    /// [`Self::validate`]'s bearings: at least one, on the shaft's `n`
    /// nodes, sorted by node, with finite laws and physical pedestals.
    fn validate_bearings(&self, n: usize) -> Result<(), ModelError> {
        if self.bearings.is_empty() {
            return Err(ModelError::invalid("bearing", "needs at least one bearing"));
        }
        for (i, b) in self.bearings.iter().enumerate() {
            let f = |name: &str| format!("bearing[{}].{name}", i + 1);
            on_shaft(f("node"), b.node, n)?;
            if i > 0 && b.node <= self.bearings[i - 1].node {
                return Err(ModelError::invalid(
                    f("node"),
                    "bearings must be sorted by node, one per node",
                ));
            }
            validate_law(&f, &b.law)?;
            if let Some(p) = &b.pedestal {
                for j in 0..2 {
                    positive(f(&format!("pedestal.mass[{}]", j + 1)), p.mass[j])?;
                    positive(f(&format!("pedestal.k[{}]", j + 1)), p.k[j])?;
                    if !(p.c[j].is_finite() && p.c[j] >= 0.0) {
                        return Err(ModelError::invalid(
                            f(&format!("pedestal.c[{}]", j + 1)),
                            "must be finite and >= 0",
                        ));
                    }
                }
            }
        }
        Ok(())
    }

    /// [`Self::validate`]'s coaxial shaft layers: each on an existing
    /// element, of its length, with a valid section.
    fn validate_shaft_layers(&self) -> Result<(), ModelError> {
        for (i, l) in self.shaft_layers.iter().enumerate() {
            let f = |name: &str| format!("shaft_layers[{}].{name}", i + 1);
            let Some(e) = self.shaft.get(l.element) else {
                return Err(ModelError::invalid(
                    f("element"),
                    format!("no shaft element {}", l.element + 1),
                ));
            };
            if l.section.length != e.length {
                return Err(ModelError::invalid(
                    f("length"),
                    format!(
                        "{} differs from its element's {}",
                        l.section.length, e.length
                    ),
                ));
            }
            positive(f("outer_diameter"), l.section.outer_diameter)?;
            if !(l.section.inner_diameter.is_finite()
                && l.section.inner_diameter >= 0.0
                && l.section.inner_diameter < l.section.outer_diameter)
            {
                return Err(ModelError::invalid(
                    f("inner_diameter"),
                    "must be in [0, outer_diameter)",
                ));
            }
            positive(f("material.e"), l.section.material.e)?;
            positive(f("material.g"), l.section.material.g)?;
            positive(f("material.rho"), l.section.material.rho)?;
        }
        Ok(())
    }

    /// [`Self::validate`]'s balancing planes, unbalances and shaft bow: on
    /// the shaft's `n` nodes, finite, planes distinct, bow points sorted.
    fn validate_loads(&self, n: usize) -> Result<(), ModelError> {
        for (i, &p) in self.planes.iter().enumerate() {
            on_shaft(format!("planes[{}]", i + 1), p, n)?;
            if self.planes[..i].contains(&p) {
                return Err(ModelError::invalid(
                    format!("planes[{}]", i + 1),
                    format!("node {} listed twice", p + 1),
                ));
            }
        }
        for (i, u) in self.unbalance.iter().enumerate() {
            let f = |name: &str| format!("unbalance[{}].{name}", i + 1);
            on_shaft(f("node"), u.node, n)?;
            finite(f("me"), u.me)?;
            finite(f("phase"), u.phase)?;
        }
        if let Some(bow) = &self.bow {
            for (i, p) in bow.points.iter().enumerate() {
                let f = |name: &str| format!("bow[{}].{name}", i + 1);
                on_shaft(f("node"), p.node, n)?;
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

/// [`RotorModel::validate`]: `v` finite and > 0.
fn positive(field: String, v: f64) -> Result<(), ModelError> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(ModelError::invalid(
            field,
            format!("must be finite and > 0, got {v}"),
        ))
    }
}

/// [`RotorModel::validate`]: `v` finite.
/// A disk's moments of inertia may be 0: a mass without rotary inertia.
fn non_negative(field: String, v: f64) -> Result<(), ModelError> {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        Err(ModelError::invalid(
            field,
            format!("must be finite and >= 0, got {v}"),
        ))
    }
}

fn finite(field: String, v: f64) -> Result<(), ModelError> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(ModelError::invalid(
            field,
            format!("must be finite, got {v}"),
        ))
    }
}

/// [`RotorModel::validate`]: `node` (0-based) one of the shaft's `n` nodes.
fn on_shaft(field: String, node: usize, n: usize) -> Result<(), ModelError> {
    if node < n {
        Ok(())
    } else {
        Err(ModelError::invalid(
            field,
            format!("node {} is not on the shaft (nodes 1..={n})", node + 1),
        ))
    }
}

/// [`RotorModel::validate`]: a bearing law's coefficients, speeds and
/// polynomial terms finite, a table's speeds >= 0 and strictly increasing
/// (fields named by `f`).
fn validate_law(f: &impl Fn(&str) -> String, law: &BearingLaw) -> Result<(), ModelError> {
    let check = |c: &BearingCoefficients, at: &str| -> Result<(), ModelError> {
        for j in 0..4 {
            finite(f(&format!("{at}k[{}]", j + 1)), c.k[j])?;
            finite(f(&format!("{at}c[{}]", j + 1)), c.c[j])?;
        }
        Ok(())
    };
    match law {
        BearingLaw::Constant(c) => check(c, "")?,
        BearingLaw::Table {
            speeds,
            coefficients,
            ..
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
    Ok(())
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
            interpolation: TableInterpolation::LinearHold,
        };
        assert_eq!(law.at(15.0).k[2], 2.0);
        assert_eq!(law.at(0.0).c[0], 2.0);
        assert_eq!(law.at(99.0).c[0], 6.0);
    }

    /// Reference values computed once with ROSS 3.1.0's `_AxisInterpolator`
    /// (SciPy 1.18.1 `PchipInterpolator` inside the table, linear
    /// extrapolation with the end derivatives outside): a non-uniform table
    /// with a flat part, a local extremum and a sign change.
    #[test]
    fn pchip_matches_scipy_and_ross_extrapolation() {
        let x = [100.0, 250.0, 300.0, 520.0, 800.0, 810.0];
        let y = [1.0e6, 1.6e6, 1.55e6, 1.55e6, 3.9e6, -2.0e5];
        let d_ref = [7750.0, 0.0, 0.0, 0.0, 0.0, -424427.3399014778];
        let d = pchip_slopes(&x, &y);
        for (a, b) in d.iter().zip(d_ref) {
            assert!((a - b).abs() <= 1e-12 * b.abs().max(1.0), "{a} {b}");
        }
        let at = [
            0.0, 100.0, 175.0, 260.0, 300.0, 410.0, 600.0, 805.0, 810.0, 1000.0,
        ];
        let v_ref = [
            225000.0,
            1000000.0,
            1445312.5,
            1594800.0,
            1550000.0,
            1550000.0,
            2015889.2128279884,
            2380534.1748768473,
            -199999.99999999953,
            -80841194.58128078,
        ];
        for (w, r) in at.iter().zip(v_ref) {
            let v = TableInterpolation::Pchip.eval(&x, &y, *w);
            assert!((v - r).abs() <= 1e-12 * r.abs(), "at {w}: {v} vs {r}");
        }
        // Three points with a sign change of the secants (end slope limited).
        let (x3, y3) = ([1.0, 2.0, 4.0], [3.0, -1.0, 5.0]);
        let p3 = [
            9.333333333333332,
            0.20833333333333337,
            0.08333333333333326,
            20.333333333333336,
        ];
        let l3 = [7.0, 1.0, 2.0, 11.0];
        for (i, w) in [0.0, 1.5, 3.0, 6.0].iter().enumerate() {
            let v = TableInterpolation::Pchip.eval(&x3, &y3, *w);
            assert!((v - p3[i]).abs() <= 1e-13 * p3[i].abs(), "{v} {}", p3[i]);
            let v = TableInterpolation::LinearExtrapolate.eval(&x3, &y3, *w);
            assert!((v - l3[i]).abs() <= 1e-13 * l3[i].abs(), "{v} {}", l3[i]);
        }
        // Two points: the straight line, extended.
        for (w, r) in [(0.0, 0.0), (2.0, 4.0), (5.0, 10.0)] {
            let v = TableInterpolation::Pchip.eval(&[1.0, 3.0], &[2.0, 6.0], w);
            assert!((v - r).abs() <= 1e-14, "{v} {r}");
        }
        // One point: constant.
        assert_eq!(TableInterpolation::Pchip.eval(&[5.0], &[7.0], 100.0), 7.0);
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
