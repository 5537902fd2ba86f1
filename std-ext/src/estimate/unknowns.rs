//! The unknowns of an identification on the desktop: the core's
//! [`rotorid_core::parametrization`] (what each unknown is, its scale, how
//! it enters `Z_B(Omega)` or the forcing) bound to a rotor's bearing and
//! plane nodes and to a column scaling. Everything that turns weights into
//! physics reads it: the bearing laws of the identified rotor, the
//! estimates, their linearised covariance, the names in reports.
//!
//! The weights handed to it are the **scaled** weights `w~` of the filter
//! (physical unknown `w_j = s_j w~_j`), widened to `Complex64` (real
//! unknowns in `re`).

use num_complex::Complex64;
use rotorid_core::parametrization::{
    bearing_dynamic_stiffness, bearing_estimate, unbalance_estimate, BearingEstimate, BearingTerm,
    Formulation, Structure, UnbalanceEstimate, UnbalancePart, Unknown, COEFFICIENTS,
};
use rotorid_core::scaling::ColumnScaling;

use crate::model::{BearingCoefficients, BearingLaw};

/// A sparse real linear functional of the scaled weights, `sum_j g_j x_j`,
/// as `(j, g_j)`; `x_j` is `Re w~_j`, or `Im w~_j` where the functional says
/// so (see [`Parametrization::damping_functional`]).
pub type Functional = Vec<(usize, f64)>;

/// The unknowns of one identification (see the module documentation).
#[derive(Debug, Clone, PartialEq)]
pub struct Parametrization {
    /// Formulation and order.
    pub structure: Structure,
    /// Column scaling (`w_j = s_j w~_j`).
    pub scaling: ColumnScaling<f64>,
    /// Bearing nodes (0-based), in bearing order.
    pub bearing_nodes: Vec<usize>,
    /// Unbalance plane nodes (0-based), in plane order.
    pub plane_nodes: Vec<usize>,
}

impl Parametrization {
    /// Number of bearings.
    pub fn n_bearings(&self) -> usize {
        self.bearing_nodes.len()
    }

    /// Number of planes.
    pub fn n_planes(&self) -> usize {
        self.plane_nodes.len()
    }

    /// Number of unknowns `M`.
    pub fn n_unknowns(&self) -> usize {
        self.structure
            .n_unknowns(self.n_bearings(), self.n_planes())
    }

    /// What unknown `j` is.
    pub fn unknown(&self, j: usize) -> Option<Unknown> {
        self.structure
            .unknown(self.n_bearings(), self.n_planes(), j)
    }

    /// Column scale `s_j` (0 outside `0..M`).
    pub fn scale(&self, j: usize) -> f64 {
        self.structure
            .column_scale(&self.scaling, self.n_bearings(), self.n_planes(), j)
            .unwrap_or(0.0)
    }

    /// A short name of unknown `j` for reports: `b1 K0yy`, `b2 C1zy`,
    /// `b1 Z1yz`, `n5 a`, `n5 Re a`.
    pub fn name(&self, j: usize) -> String {
        match self.unknown(j) {
            Some(Unknown::Bearing {
                bearing,
                row,
                col,
                term,
            }) => {
                let e = COEFFICIENTS[2 * row + col];
                let t = match term {
                    BearingTerm::Z { power } => format!("Z{power}"),
                    BearingTerm::K { power } => format!("K{power}"),
                    BearingTerm::C { power } => format!("C{power}"),
                };
                format!("b{} {t}{e}", bearing + 1)
            }
            Some(Unknown::Unbalance { plane, part }) => {
                let node = self.plane_nodes.get(plane).map_or(plane + 1, |n| n + 1);
                match part {
                    UnbalancePart::Phasor => format!("n{node} a"),
                    UnbalancePart::Re => format!("n{node} Re a"),
                    UnbalancePart::Im => format!("n{node} Im a"),
                }
            }
            None => format!("w{j}"),
        }
    }

    /// `Z_B(Omega)` of bearing `m` (N/m, `yy, yz, zy, zz`). The weights are
    /// complex for both structures (real unknowns in `re`, `im` ignored by
    /// the physical structure's reading).
    pub fn bearing_dynamic_stiffness(
        &self,
        w: &[Complex64],
        m: usize,
        omega: f64,
    ) -> Option<[Complex64; 4]> {
        let (nb, np) = (self.n_bearings(), self.n_planes());
        bearing_dynamic_stiffness(&self.structure, &self.scaling, w, nb, np, m, omega).ok()
    }

    /// Stiffness and damping of bearing `m` at `omega`: Eq. 43 read at the
    /// speed, `K = Re Z_B`, `C = Im (Z_B - Z_B(0)) / Omega`.
    pub fn bearing(&self, w: &[Complex64], m: usize, omega: f64) -> Option<BearingEstimate<f64>> {
        let (nb, np) = (self.n_bearings(), self.n_planes());
        bearing_estimate(&self.structure, &self.scaling, w, nb, np, m, omega).ok()
    }

    /// The unbalance of plane `k`.
    pub fn unbalance(&self, w: &[Complex64], k: usize) -> Option<UnbalanceEstimate<f64>> {
        let (nb, np) = (self.n_bearings(), self.n_planes());
        unbalance_estimate(&self.structure, &self.scaling, w, nb, np, k).ok()
    }

    /// The unknowns of entry `e` (`yy, yz, zy, zz`) of bearing `m` with their
    /// terms.
    fn entry(&self, m: usize, e: usize) -> impl Iterator<Item = (usize, BearingTerm)> + '_ {
        (0..self.structure.terms_per_entry()).filter_map(move |i| {
            let term = self.structure.entry_term(i);
            self.structure
                .bearing_index(m, e / 2, e % 2, term)
                .map(|j| (j, term))
        })
    }

    /// `K(Omega)[e]` of bearing `m` as a functional of `Re w~`.
    pub fn stiffness_functional(&self, m: usize, e: usize, omega: f64) -> Functional {
        self.entry(m, e)
            .map(|(j, t)| (j, t.k_weight(&self.scaling, omega)))
            .filter(|&(_, g)| g != 0.0)
            .collect()
    }

    /// `C(Omega)[e]` of bearing `m` as a functional of `Im w~` (paper
    /// structure, complex unknowns) or of `w~` (physical structure).
    pub fn damping_functional(&self, m: usize, e: usize, omega: f64) -> Functional {
        self.entry(m, e)
            .map(|(j, t)| (j, t.c_weight(&self.scaling, omega)))
            .filter(|&(_, g)| g != 0.0)
            .collect()
    }

    /// The identified bearing laws, exactly the `Z_B(Omega)` the structure
    /// fitted: physical order 1 gives constant `K`, `C`; physical order
    /// `P` the polynomials `K(Omega) = sum_p K_p Omega^p`,
    /// `C(Omega) = sum_p C_p Omega^p`; the paper structure the dynamic
    /// stiffness polynomial `Z_B = sum_p Omega^p Z_p`
    /// ([`BearingLaw::DynamicStiffness`]).
    pub fn bearing_laws(&self, w: &[Complex64]) -> Vec<BearingLaw> {
        let st = self.structure;
        let weight = |j: usize| w.get(j).copied().unwrap_or_default() * self.scale(j);
        (0..self.n_bearings())
            .map(|m| {
                let coef = |term: BearingTerm| -> [Complex64; 4] {
                    core::array::from_fn(|e| {
                        st.bearing_index(m, e / 2, e % 2, term)
                            .map_or(Complex64::default(), weight)
                    })
                };
                match st.formulation {
                    Formulation::Paper => BearingLaw::DynamicStiffness {
                        z: (0..=st.order)
                            .map(|power| coef(BearingTerm::Z { power }))
                            .collect(),
                    },
                    Formulation::Physical => {
                        let k = |power| coef(BearingTerm::K { power }).map(|x| x.re);
                        let c = |power| coef(BearingTerm::C { power }).map(|x| x.re);
                        if st.order == 1 {
                            BearingLaw::Constant(BearingCoefficients { k: k(0), c: c(0) })
                        } else {
                            BearingLaw::Polynomial {
                                k: (0..st.order).map(k).collect(),
                                c: (0..st.order).map(c).collect(),
                            }
                        }
                    }
                }
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn param(structure: Structure) -> Parametrization {
        Parametrization {
            structure,
            scaling: ColumnScaling::new(2e7, 1500.0, 3e-4).unwrap(),
            bearing_nodes: vec![0, 26],
            plane_nodes: vec![4, 10, 20],
        }
    }

    fn weights(p: &Parametrization) -> Vec<Complex64> {
        (0..p.n_unknowns())
            .map(|j| {
                let x = 0.5 + 0.37 * ((j * 7919) % 13) as f64 / 13.0;
                if p.structure.is_complex() {
                    Complex64::new(x, 0.1 - 0.2 * x)
                } else {
                    Complex64::new(x, 0.0)
                }
            })
            .collect()
    }

    #[test]
    fn laws_estimates_and_functionals_agree() {
        for st in [
            Structure::paper(1),
            Structure::paper(2),
            Structure::physical(1),
            Structure::physical(3),
        ] {
            let p = param(st);
            let w = weights(&p);
            let laws = p.bearing_laws(&w);
            for omega in [0.0, 300.0, 1571.0] {
                for (m, law) in laws.iter().enumerate() {
                    let est = p.bearing(&w, m, omega).unwrap();
                    let at = law.at(omega);
                    for e in 0..4 {
                        let tol = 1e-12 * (1.0 + est.k[e].abs());
                        assert!((at.k[e] - est.k[e]).abs() <= tol, "{st:?} {omega} k{e}");
                        let tol = 1e-12 * (1.0 + est.c[e].abs());
                        assert!((at.c[e] - est.c[e]).abs() <= tol, "{st:?} {omega} c{e}");
                        // The functionals give the same numbers.
                        let k: f64 = p
                            .stiffness_functional(m, e, omega)
                            .iter()
                            .map(|&(j, g)| g * w[j].re)
                            .sum();
                        let c: f64 = p
                            .damping_functional(m, e, omega)
                            .iter()
                            .map(|&(j, g)| g * if st.is_complex() { w[j].im } else { w[j].re })
                            .sum();
                        assert!((k - est.k[e]).abs() <= 1e-9 * (1.0 + k.abs()));
                        assert!((c - est.c[e]).abs() <= 1e-9 * (1.0 + c.abs()));
                    }
                    if omega > 0.0 {
                        let z = p.bearing_dynamic_stiffness(&w, m, omega).unwrap();
                        let z0 = p.bearing_dynamic_stiffness(&w, m, 0.0).unwrap();
                        for e in 0..4 {
                            assert!((z[e].re - est.k[e]).abs() <= 1e-9 * z[e].norm());
                            let c = (z[e].im - z0[e].im) / omega;
                            assert!((c - est.c[e]).abs() <= 1e-9 * z[e].norm() / omega);
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn names_follow_the_unknowns() {
        let p = param(Structure::physical(1));
        assert_eq!(p.name(0), "b1 K0yy");
        assert_eq!(p.name(2), "b1 C0yy");
        assert_eq!(p.name(16), "n5 Re a");
        assert_eq!(p.name(17), "n5 Im a");
        let p = param(Structure::paper(1));
        assert_eq!(p.name(2), "b1 Z1yy");
        assert_eq!(p.name(16), "n5 a");
    }
}
