//! What the unknowns of the identification are: one description that the
//! regressor ([`crate::regressor`]), the estimates ([`bearing_estimate`],
//! [`unbalance_estimate`]), the firmware identifier and the desktop
//! (laws, covariance, JSON, output-error predictor) all read.
//!
//! # The model of the bearings and the unbalance
//!
//! Per bearing `m` the dynamic stiffness `Z_B^(m)(Omega)` (2x2, N/m, entries
//! `yy, yz, zy, zz`) is a polynomial in the speed `Omega` (rad/s) whose
//! coefficients are the unknowns; per plane `k` the unbalance is the phasor
//! `a_k = m_k e_k exp(j alpha_k)` (kg m). With `w_j` an unknown in SI units,
//! `g_j(Omega)` its **Z-factor** and `B` the table's unbalance columns,
//!
//! ```text
//!     Z_B^(m)[r][c](Omega) = sum_{j of (m, r, c)} g_j(Omega) w_j,
//!     forcing of channel i  = sum_k B_ik a_k,
//! ```
//!
//! | [`BearingTerm`] | unknown | `g_j(Omega)` = `dZ_B / dw_j` | scale `s_j` |
//! |---|---|---|---|
//! | `Z { power: p }` (paper) | complex `Z_p` (N/m / (rad/s)^p) | `Omega^p` | `s_K / Omega_r^p` |
//! | `K { power: p }` (physical) | real `K_p` | `Omega^p` | `s_K / Omega_r^p` |
//! | `C { power: p }` (physical) | real `C_p` (N s/m / (rad/s)^p) | `j Omega^(p+1)` | `s_K / Omega_r^(p+1)` |
//!
//! | [`UnbalancePart`] | unknown | `da / dw_j` | scale |
//! |---|---|---|---|
//! | `Phasor` (paper) | complex `a_k` | `1` | `s_a` |
//! | `Re`, `Im` (physical) | `Re a_k`, `Im a_k` | `1`, `j` | `s_a` |
//!
//! The scales come from [`ColumnScaling`]; the filter works on `w~_j = w_j / s_j`.
//!
//! # Reading stiffness and damping (Eq. 43 at the speed)
//!
//! `Z_B = K + j Omega C` with real `K`, `C`, and a dynamic stiffness at
//! rest is real (a bearing cannot push against a static displacement with
//! a quadrature force). So at every speed
//!
//! ```text
//!     K(Omega) = Re Z_B(Omega),   C(Omega) = Im (Z_B(Omega) - Z_B(0)) / Omega
//! ```
//!
//! is the one reading of every structure and order ([`bearing_estimate`]);
//! the reported values, the identified rotor's bearing laws (its Campbell
//! diagram) and their standard deviations all use it. Term by term
//! ([`BearingTerm::k_weight`], [`BearingTerm::c_weight`]):
//!
//! * `Z_p`: `K += Omega^p Re Z_p`; `C += Omega^(p-1) Im Z_p` for `p >= 1`;
//! * `K_p`: `K += Omega^p K_p`; `C_p`: `C += Omega^p C_p`.
//!
//! `Im Z_0`, an imaginary stiffness at rest, is physically zero and is not
//! damping (as `Im Z_0 / Omega` it would grow without bound toward rest):
//! the paper structure reports it as a consistency value, with `Re Z_1`
//! (stiffness linear in speed, zero for constant bearings). The physical
//! structure cannot represent either. [`bearing_dynamic_stiffness`] gives
//! the whole fitted `Z_B`, `Im Z_0` included.
//!
//! # Unknown order
//!
//! * paper, order `P`: per bearing `m`, row direction `r`, power `p`,
//!   column `c`: `j = 4 (P+1) m + 2 (P+1) r + 2 p + c`, i.e.
//!   `(Z0yy Z0yz Z1yy Z1yz Z0zy Z0zz Z1zy Z1zz)` for `P = 1` (Eq. 48); then
//!   the planes `j = 4 (P+1) N_b + k`.
//! * physical, order `P`: `j = 8 P m + 4 P r + 4 p + 2 kind + c` with
//!   `kind` 0 for `K_p`, 1 for `C_p`, i.e. `(Kyy Kyz Cyy Cyz Kzy Kzz Czy Czz)`
//!   for `P = 1`; then `Re a_k`, `Im a_k` at `j = 8 P N_b + 2 k (+1)`.
//!
//! Every row of the regression touches only its own bearing and direction
//! and the planes; the unknowns of one bearing are contiguous.

use crate::scalar::Real;
use crate::scaling::ColumnScaling;
use nalgebra::ComplexField;
use num_complex::Complex;

/// Which unknowns describe the bearings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Formulation {
    /// Complex `Z_p` per bearing (the paper's Eqs. 43, 47, 48 for order 1).
    Paper,
    /// Real polynomial `K(Omega)`, `C(Omega)` per bearing, complex unbalance
    /// as two reals; each complex equation split into two real rows.
    Physical,
}

/// A model structure: formulation and polynomial order `P` of the bearing
/// dynamic stiffness in `Omega` (`Z_B` of degree `P`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Structure {
    /// The formulation.
    pub formulation: Formulation,
    /// The order `P >= 1`.
    pub order: usize,
}

/// Highest supported order (keeps `(Omega/Omega_r)^P` meaningful in f32).
pub const MAX_ORDER: usize = 8;

/// The bearing coefficient names in storage order.
pub const COEFFICIENTS: [&str; 4] = ["yy", "yz", "zy", "zz"];

/// A structure, size or index that does not fit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ParamError {
    /// Order outside `1..=MAX_ORDER`.
    InvalidOrder,
    /// A buffer length, bearing or plane index does not match the structure.
    Dimension,
}

/// How one bearing unknown enters `Z_B(Omega)` (see the module table).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BearingTerm {
    /// Complex `Z_p`: `Z_B += Omega^p Z_p` (paper structure).
    Z {
        /// The power `p` of `Omega`.
        power: usize,
    },
    /// Real `K_p`: `Z_B += Omega^p K_p` (physical structure).
    K {
        /// The power `p` of `Omega`.
        power: usize,
    },
    /// Real `C_p`: `Z_B += j Omega^(p+1) C_p` (physical structure).
    C {
        /// The power `p` of `Omega` in `C(Omega)`.
        power: usize,
    },
}

/// Which part of a plane's unbalance an unknown is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum UnbalancePart {
    /// The complex phasor `a_k` (paper structure).
    Phasor,
    /// `Re a_k` (physical structure).
    Re,
    /// `Im a_k` (physical structure).
    Im,
}

/// What one unknown is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Unknown {
    /// A coefficient of bearing `bearing`'s dynamic stiffness, entry
    /// `[row][col]` (`0` = y, `1` = z; entry index `2 row + col` in the
    /// order `yy, yz, zy, zz`).
    Bearing {
        /// Bearing index (0-based, in bearing order).
        bearing: usize,
        /// Row direction of `Z_B` (0 = y, 1 = z): the equation it enters.
        row: usize,
        /// Column direction of `Z_B` (0 = y, 1 = z): the response it multiplies.
        col: usize,
        /// How it enters `Z_B(Omega)`.
        term: BearingTerm,
    },
    /// (Part of) the unbalance of plane `plane` (0-based, in plane order).
    Unbalance {
        /// Plane index.
        plane: usize,
        /// Which part.
        part: UnbalancePart,
    },
}

impl BearingTerm {
    /// The exponent `e` of the scale `s_j = s_K / Omega_r^e`: `p` for `Z_p`
    /// and `K_p`, `p + 1` for `C_p`.
    pub const fn scale_power(&self) -> usize {
        match *self {
            BearingTerm::Z { power } | BearingTerm::K { power } => power,
            BearingTerm::C { power } => power + 1,
        }
    }

    /// `g(Omega) = dZ_B / dw` for the unknown in SI units: `Omega^p`, or
    /// `j Omega^(p+1)` for `C_p`.
    pub fn z_factor<T: Real>(&self, omega: T) -> Complex<T> {
        let pw = |p: usize| (0..p).fold(T::one(), |acc, _| acc * omega);
        match *self {
            BearingTerm::Z { power } | BearingTerm::K { power } => {
                Complex::new(pw(power), T::zero())
            }
            BearingTerm::C { power } => Complex::new(T::zero(), pw(power + 1)),
        }
    }

    /// `g(Omega) s_j` evaluated without overflow as
    /// `s_K (Omega / Omega_r)^e` (times `j` for `C_p`): the factor of the
    /// **scaled** unknown `w~_j` in `Z_B` (N/m).
    pub fn scaled_z_factor<T: Real>(&self, scaling: &ColumnScaling<T>, omega: T) -> Complex<T> {
        let f = scaling.speed_power(omega, self.scale_power()) * scaling.stiffness;
        match self {
            BearingTerm::C { .. } => Complex::new(T::zero(), f),
            _ => Complex::new(f, T::zero()),
        }
    }

    /// Contribution of the scaled unknown to `K(Omega)` per unit of its real
    /// part: `K += k_weight Re w~` (N/m per unit).
    pub fn k_weight<T: Real>(&self, scaling: &ColumnScaling<T>, omega: T) -> T {
        match *self {
            BearingTerm::Z { power } | BearingTerm::K { power } => {
                scaling.speed_power(omega, power) * scaling.stiffness
            }
            BearingTerm::C { .. } => T::zero(),
        }
    }

    /// Contribution of the scaled unknown to `C(Omega)`: `C += c_weight x`
    /// with `x = Im w~` for the complex `Z_p` and `x = w~` for `C_p`
    /// (N s/m per unit). `Z_0` contributes nothing (see the module
    /// documentation).
    pub fn c_weight<T: Real>(&self, scaling: &ColumnScaling<T>, omega: T) -> T {
        match *self {
            BearingTerm::K { .. } => T::zero(),
            BearingTerm::C { power } => {
                scaling.speed_power(omega, power) * scaling.stiffness / scaling.omega_ref
            }
            BearingTerm::Z { power: 0 } => T::zero(),
            BearingTerm::Z { power } => {
                scaling.speed_power(omega, power - 1) * scaling.stiffness / scaling.omega_ref
            }
        }
    }
}

impl UnbalancePart {
    /// `da / dw` of the unknown: `1` (phasor, real part) or `j` (imaginary part).
    pub fn factor<T: Real>(&self) -> Complex<T> {
        match self {
            UnbalancePart::Im => Complex::new(T::zero(), T::one()),
            _ => Complex::new(T::one(), T::zero()),
        }
    }
}

impl Structure {
    /// The paper's complex formulation of order `order`.
    pub const fn paper(order: usize) -> Self {
        Structure {
            formulation: Formulation::Paper,
            order,
        }
    }

    /// The physical (real K, C) formulation of order `order`.
    pub const fn physical(order: usize) -> Self {
        Structure {
            formulation: Formulation::Physical,
            order,
        }
    }

    /// Checks the order.
    pub const fn validate(&self) -> Result<(), ParamError> {
        if self.order >= 1 && self.order <= MAX_ORDER {
            Ok(())
        } else {
            Err(ParamError::InvalidOrder)
        }
    }

    /// Whether the unknowns and rows are complex (`Paper`) or real.
    pub const fn is_complex(&self) -> bool {
        matches!(self.formulation, Formulation::Paper)
    }

    /// Unknowns per bearing: `4 (P+1)` (paper) or `8 P` (physical).
    pub const fn per_bearing(&self) -> usize {
        match self.formulation {
            Formulation::Paper => 4 * (self.order + 1),
            Formulation::Physical => 8 * self.order,
        }
    }

    /// Unknowns per plane: 1 complex (paper) or 2 real (physical).
    pub const fn per_plane(&self) -> usize {
        match self.formulation {
            Formulation::Paper => 1,
            Formulation::Physical => 2,
        }
    }

    /// Number of unknowns `M` for `nb` bearings and `np` planes.
    pub const fn n_unknowns(&self, nb: usize, np: usize) -> usize {
        self.per_bearing() * nb + self.per_plane() * np
    }

    /// Number of rows `N` per update for `nb` bearings: `2 N_b` complex
    /// (paper) or `4 N_b` real (physical).
    pub const fn n_rows(&self, nb: usize) -> usize {
        match self.formulation {
            Formulation::Paper => 2 * nb,
            Formulation::Physical => 4 * nb,
        }
    }

    /// The bearing terms of one entry `[row][col]`, in unknown order:
    /// `Z_0 .. Z_P` (paper) or `K_0, C_0, .., K_(P-1), C_(P-1)` (physical).
    /// `i` runs over `0..terms_per_entry()`.
    pub const fn entry_term(&self, i: usize) -> BearingTerm {
        match self.formulation {
            Formulation::Paper => BearingTerm::Z { power: i },
            Formulation::Physical => {
                if i % 2 == 0 {
                    BearingTerm::K { power: i / 2 }
                } else {
                    BearingTerm::C { power: i / 2 }
                }
            }
        }
    }

    /// Number of terms per entry `[row][col]`: `P + 1` (paper) or `2 P`.
    pub const fn terms_per_entry(&self) -> usize {
        self.per_bearing() / 4
    }

    /// Index of the bearing unknown `(m, row, col, term)`, or `None` if the
    /// term is not of this structure.
    pub const fn bearing_index(
        &self,
        m: usize,
        row: usize,
        col: usize,
        term: BearingTerm,
    ) -> Option<usize> {
        let base = self.per_bearing() * m + (self.per_bearing() / 2) * row;
        match (self.formulation, term) {
            (Formulation::Paper, BearingTerm::Z { power }) if power <= self.order => {
                Some(base + 2 * power + col)
            }
            (Formulation::Physical, BearingTerm::K { power }) if power < self.order => {
                Some(base + 4 * power + col)
            }
            (Formulation::Physical, BearingTerm::C { power }) if power < self.order => {
                Some(base + 4 * power + 2 + col)
            }
            _ => None,
        }
    }

    /// Index of the (first) unknown of plane `k` for `nb` bearings.
    pub const fn plane_index(&self, nb: usize, k: usize) -> usize {
        self.per_bearing() * nb + self.per_plane() * k
    }

    /// Index of an unknown (no range check on bearing or plane).
    pub const fn index(&self, nb: usize, unknown: Unknown) -> Option<usize> {
        match unknown {
            Unknown::Bearing {
                bearing,
                row,
                col,
                term,
            } => self.bearing_index(bearing, row, col, term),
            Unknown::Unbalance { plane, part } => match (self.formulation, part) {
                (Formulation::Paper, UnbalancePart::Phasor) => Some(self.plane_index(nb, plane)),
                (Formulation::Physical, UnbalancePart::Re) => Some(self.plane_index(nb, plane)),
                (Formulation::Physical, UnbalancePart::Im) => Some(self.plane_index(nb, plane) + 1),
                _ => None,
            },
        }
    }

    /// What unknown `j` is, for `nb` bearings and `np` planes (`None` if
    /// `j >= M`).
    pub const fn unknown(&self, nb: usize, np: usize, j: usize) -> Option<Unknown> {
        if j >= self.n_unknowns(nb, np) {
            return None;
        }
        let nbear = self.per_bearing() * nb;
        if j >= nbear {
            let plane = (j - nbear) / self.per_plane();
            let part = match self.formulation {
                Formulation::Paper => UnbalancePart::Phasor,
                Formulation::Physical => {
                    if (j - nbear) % 2 == 0 {
                        UnbalancePart::Re
                    } else {
                        UnbalancePart::Im
                    }
                }
            };
            return Some(Unknown::Unbalance { plane, part });
        }
        let bearing = j / self.per_bearing();
        let within = j % self.per_bearing();
        let half = self.per_bearing() / 2;
        let row = within / half;
        let rem = within % half;
        let (col, term) = match self.formulation {
            Formulation::Paper => (rem % 2, BearingTerm::Z { power: rem / 2 }),
            Formulation::Physical => {
                let power = rem / 4;
                let col = rem % 2;
                if (rem % 4) / 2 == 0 {
                    (col, BearingTerm::K { power })
                } else {
                    (col, BearingTerm::C { power })
                }
            }
        };
        Some(Unknown::Bearing {
            bearing,
            row,
            col,
            term,
        })
    }

    /// The column scale `s_j` of unknown `j` (the physical unknown is
    /// `w_j = s_j w~_j`), see [`crate::scaling`]. `None` if `j >= M`.
    pub fn column_scale<T: Real>(
        &self,
        scaling: &ColumnScaling<T>,
        nb: usize,
        np: usize,
        j: usize,
    ) -> Option<T> {
        Some(match self.unknown(nb, np, j)? {
            Unknown::Bearing { term, .. } => scaling.power_scale(term.scale_power()),
            Unknown::Unbalance { .. } => scaling.unbalance,
        })
    }

    fn check(&self, nb: usize, np: usize, len: usize) -> Result<(), ParamError> {
        self.validate()?;
        if len != self.n_unknowns(nb, np) {
            return Err(ParamError::Dimension);
        }
        Ok(())
    }
}

/// Identified parameters of one bearing at one speed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BearingEstimate<T> {
    /// Stiffness `K(Omega) = Re Z_B(Omega)`, `[kyy, kyz, kzy, kzz]` (N/m).
    pub k: [T; 4],
    /// Damping `C(Omega) = Im (Z_B(Omega) - Z_B(0)) / Omega`,
    /// `[cyy, cyz, czy, czz]` (N s/m).
    pub c: [T; 4],
    /// For the paper structure: `Im(Z_0)` (N/m), physically zero (the
    /// dynamic stiffness at rest is real); `None` for the physical one.
    pub im_z0: Option<[T; 4]>,
    /// For the paper structure: `Re(Z_1)` (N s/m), physically zero when the
    /// stiffness does not vary linearly with speed; `None` for the physical
    /// one.
    pub re_z1: Option<[T; 4]>,
}

/// Identified unbalance of one plane.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UnbalanceEstimate<T> {
    /// `a = m e exp(j alpha)` (kg m).
    pub a: Complex<T>,
    /// `m e = |a|` (kg m).
    pub me: T,
    /// `alpha = arg a` (rad), in `(-pi, pi]`.
    pub phase: T,
}

impl<T: Real> UnbalanceEstimate<T> {
    /// From the complex unbalance.
    pub fn from_phasor(a: Complex<T>) -> Self {
        UnbalanceEstimate {
            a,
            me: T::magnitude(a.re, a.im),
            phase: a.im.atan2(a.re),
        }
    }

    /// The phase in degrees.
    pub fn phase_deg(&self) -> T {
        self.phase * T::lit(180.0) / T::pi()
    }
}

/// Calls `f(e, term, w_j)` for every unknown of bearing `m` (entry `e` in
/// `yy, yz, zy, zz`), after checking the sizes.
fn for_each_bearing_unknown<T: Real, F: ComplexField<RealField = T> + Copy>(
    structure: &Structure,
    w: &[F],
    nb: usize,
    np: usize,
    m: usize,
    mut f: impl FnMut(usize, BearingTerm, F),
) -> Result<(), ParamError> {
    structure.check(nb, np, w.len())?;
    if m >= nb {
        return Err(ParamError::Dimension);
    }
    for e in 0..4 {
        for i in 0..structure.terms_per_entry() {
            let term = structure.entry_term(i);
            let j = structure
                .bearing_index(m, e / 2, e % 2, term)
                .ok_or(ParamError::Dimension)?;
            f(e, term, *w.get(j).ok_or(ParamError::Dimension)?);
        }
    }
    Ok(())
}

/// `Z_B^(m)(Omega)` (N/m, `yy, yz, zy, zz`) from the **scaled** weights `w~`
/// (complex for the paper structure, real for the physical one):
/// `sum_j g_j(Omega) s_j w~_j`.
// index proven: `for_each_bearing_unknown` passes entries `e` in `0..4`.
#[allow(clippy::indexing_slicing)]
pub fn bearing_dynamic_stiffness<T: Real, F: ComplexField<RealField = T> + Copy>(
    structure: &Structure,
    scaling: &ColumnScaling<T>,
    w: &[F],
    nb: usize,
    np: usize,
    m: usize,
    omega: T,
) -> Result<[Complex<T>; 4], ParamError> {
    let mut z = [Complex::new(T::zero(), T::zero()); 4];
    for_each_bearing_unknown(structure, w, nb, np, m, |e, term, wj| {
        z[e] += term.scaled_z_factor(scaling, omega) * Complex::new(wj.real(), wj.imaginary());
    })?;
    Ok(z)
}

/// Stiffness and damping of bearing `m` at `omega` from the **scaled**
/// weights (see "Reading stiffness and damping" in the module docs), with
/// the paper structure's consistency values.
// index proven: `for_each_bearing_unknown` passes entries `e` in `0..4`.
#[allow(clippy::indexing_slicing)]
pub fn bearing_estimate<T: Real, F: ComplexField<RealField = T> + Copy>(
    structure: &Structure,
    scaling: &ColumnScaling<T>,
    w: &[F],
    nb: usize,
    np: usize,
    m: usize,
    omega: T,
) -> Result<BearingEstimate<T>, ParamError> {
    let complex = structure.is_complex();
    let mut out = BearingEstimate {
        k: [T::zero(); 4],
        c: [T::zero(); 4],
        im_z0: complex.then_some([T::zero(); 4]),
        re_z1: complex.then_some([T::zero(); 4]),
    };
    for_each_bearing_unknown(structure, w, nb, np, m, |e, term, wj| {
        let (re, im) = (wj.real(), wj.imaginary());
        out.k[e] += term.k_weight(scaling, omega) * re;
        out.c[e] += term.c_weight(scaling, omega) * if complex { im } else { re };
        let s = scaling.power_scale(term.scale_power());
        match term {
            BearingTerm::Z { power: 0 } => {
                if let Some(v) = out.im_z0.as_mut() {
                    v[e] = im * s;
                }
            }
            BearingTerm::Z { power: 1 } => {
                if let Some(v) = out.re_z1.as_mut() {
                    v[e] = re * s;
                }
            }
            _ => {}
        }
    })?;
    Ok(out)
}

/// The unbalance of plane `k` from the **scaled** weights.
pub fn unbalance_estimate<T: Real, F: ComplexField<RealField = T> + Copy>(
    structure: &Structure,
    scaling: &ColumnScaling<T>,
    w: &[F],
    nb: usize,
    np: usize,
    k: usize,
) -> Result<UnbalanceEstimate<T>, ParamError> {
    structure.check(nb, np, w.len())?;
    if k >= np {
        return Err(ParamError::Dimension);
    }
    let j = structure.plane_index(nb, k);
    let wj = |j: usize| w.get(j).copied().ok_or(ParamError::Dimension);
    let a = match structure.formulation {
        Formulation::Paper => Complex::new(wj(j)?.real(), wj(j)?.imaginary()),
        Formulation::Physical => Complex::new(wj(j)?.real(), wj(j + 1)?.real()),
    };
    Ok(UnbalanceEstimate::from_phasor(a * scaling.unbalance))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unknown_and_index_are_inverse() {
        for st in [
            Structure::paper(1),
            Structure::paper(3),
            Structure::physical(1),
            Structure::physical(2),
        ] {
            let (nb, np) = (3, 2);
            for j in 0..st.n_unknowns(nb, np) {
                let u = st.unknown(nb, np, j).unwrap();
                assert_eq!(st.index(nb, u), Some(j), "{st:?} {j} {u:?}");
            }
            assert!(st.unknown(nb, np, st.n_unknowns(nb, np)).is_none());
        }
        // Eq. 48 order for the paper structure, order 1.
        let st = Structure::paper(1);
        let names: [(usize, usize, usize); 8] = [
            (0, 0, 0),
            (0, 1, 0),
            (0, 0, 1),
            (0, 1, 1),
            (1, 0, 0),
            (1, 1, 0),
            (1, 0, 1),
            (1, 1, 1),
        ];
        for (j, (row, col, power)) in names.into_iter().enumerate() {
            assert_eq!(
                st.unknown(2, 3, j),
                Some(Unknown::Bearing {
                    bearing: 0,
                    row,
                    col,
                    term: BearingTerm::Z { power }
                })
            );
        }
    }

    #[test]
    fn weights_read_z_b_as_k_plus_j_omega_c() {
        let sc = ColumnScaling::<f64>::new(3e7, 1500.0, 1e-3).unwrap();
        let omega = 900.0;
        for st in [Structure::paper(2), Structure::physical(3)] {
            let (nb, np) = (2, 1);
            let m = st.n_unknowns(nb, np);
            let w: std::vec::Vec<num_complex::Complex<f64>> = (0..m)
                .map(|j| {
                    let x = 0.3 + 0.1 * j as f64;
                    if st.is_complex() {
                        Complex::new(x, -0.5 * x)
                    } else {
                        Complex::new(x, 0.0)
                    }
                })
                .collect();
            for b in 0..nb {
                let z = bearing_dynamic_stiffness(&st, &sc, &w, nb, np, b, omega).unwrap();
                let z0 = bearing_dynamic_stiffness(&st, &sc, &w, nb, np, b, 0.0).unwrap();
                let e = bearing_estimate(&st, &sc, &w, nb, np, b, omega).unwrap();
                for i in 0..4 {
                    assert!((z[i].re - e.k[i]).abs() <= 1e-12 * z[i].norm());
                    let c = (z[i].im - z0[i].im) / omega;
                    assert!((c - e.c[i]).abs() <= 1e-12 * z[i].norm() / omega);
                    if let Some(im_z0) = e.im_z0 {
                        assert!((im_z0[i] - z0[i].im).abs() <= 1e-12 * z0[i].norm());
                    }
                }
            }
        }
    }
}
