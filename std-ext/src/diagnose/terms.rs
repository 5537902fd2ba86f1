//! The reduced terms the hypotheses need at each measured speed.
//!
//! Besides the identification's `A(Omega)` and `B(Omega)` (model planes),
//! the diagnosis reduces, in the same reduction, a unit unbalance at
//! every node and a unit bow at every interior node:
//!
//! ```text
//!     b_n(Omega) = Omega^2 (t_B - Y t_i),      t = unit unbalance at node n   (1/s^2)
//!     g_n(Omega) = f_B - Y f_i,                f = K_s q_bow,n                (N/m)
//! ```
//!
//! with `Y = Z_Bi Z_ii^-1` ([`crate::reduce`]) and `q_bow,n` the bow shape
//! of a unit offset at node `n` (spline with zero offset at the shaft
//! ends, [`FeModel::bow_shape`]). An extra unbalance `u` at node `n` adds
//! `b_n u` to the reduced force, a bow of complex amplitude `beta` (m)
//! adds `g_n beta`.
//!
//! # Shaft modulus
//!
//! Scaling E and G by `e` scales `K_s` by `e`, so
//! `Z_R(e, Omega) = e Z_R(1, Omega / sqrt(e))` and, exactly,
//!
//! ```text
//!     A(e, Omega) = e A(Omega / sqrt(e)),   B(e, Omega) = e B(Omega / sqrt(e)),
//!     g(e, Omega) = e g(Omega / sqrt(e))
//! ```
//!
//! ([`build`] with `e != 1`); checked against a model rebuilt with the
//! scaled modulus in the tests.
//!
//! # Probes at other nodes
//!
//! A probe at shaft node `n` reads the shaft's absolute displacement there,
//! from the bearing response and the loads ([`crate::reduce::ProbeTerms`]):
//!
//! ```text
//!     x_n = P q + u a + sum_k u_k u_k' + sum_k h_k beta_k
//! ```
//!
//! (`u`: unbalance at the planes, `u_k`, `h_k`: a unit unbalance and a unit
//! bow at node `k`). `Z_ii^-1 Z_iB` is unchanged by the modulus factor and
//! the unbalance and bow forcings scale like `Z_R`, so all four are those
//! of `e = 1` at `Omega / sqrt(e)`, with `Omega^2` of that speed in `u`.

use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;

use crate::fe::assembly::{Dir, FeModel};
use crate::model::{BowPoint, RotorModel, ShaftBow};
use crate::reduce::{ModalReducer, Reducer, ReductionError};

/// The terms at one speed.
#[derive(Debug, Clone, PartialEq)]
pub struct SpeedTerms {
    /// Speed (rad/s).
    pub omega: f64,
    /// `A` (`2 N_b x 2 N_b`, N/m).
    pub a: DMatrix<Complex64>,
    /// `B` of the model's planes (`2 N_b x N_p`, 1/s^2).
    pub b: DMatrix<Complex64>,
    /// `b_n` of a unit unbalance at every node (`2 N_b x N_nodes`, 1/s^2).
    pub b_node: DMatrix<Complex64>,
    /// `g_n` of a unit bow at every node (`2 N_b x N_nodes`, N/m; zero
    /// columns at the shaft ends, where a bow offset is a rigid motion).
    pub g_node: DMatrix<Complex64>,
    /// `g_n` of a unit bow measured from the bearing line at every node
    /// ([`FeModel::line_bow_shape`]; zero columns at the bearings), when
    /// the bearings are not just the two shaft ends (where it is
    /// `g_node`).
    pub g_line: Option<DMatrix<Complex64>>,
    /// `dA/de` at the modulus factor the terms were built for, when asked.
    pub da_de: Option<DMatrix<Complex64>>,
    /// `dB/de`, likewise.
    pub db_de: Option<DMatrix<Complex64>>,
    /// The terms of the probes at other nodes, when there are any.
    pub probes: Option<NodeTerms>,
}

impl SpeedTerms {
    /// `g_n` of a unit bow at `node`: from the bearing line with `line`
    /// (the shaft-end one when the terms have no separate bearing-line
    /// columns: there the two are the same).
    pub fn bow_column(&self, node: usize, line: bool) -> nalgebra::DVectorView<'_, Complex64> {
        match (&self.g_line, line) {
            (Some(g), true) => g.column(node),
            _ => self.g_node.column(node),
        }
    }

    /// `(1 / n) sum_{i in first..=last} b_i`: the load of a unit
    /// unbalance shared equally by the `n` nodes `first..=last`
    /// (0-based).
    pub fn spread_column(&self, first: usize, last: usize) -> DVector<Complex64> {
        mean_columns(&self.b_node, first, last)
    }
}

/// The mean of the columns `first..=last` of `m`.
fn mean_columns(m: &DMatrix<Complex64>, first: usize, last: usize) -> DVector<Complex64> {
    let n = last + 1 - first;
    m.columns(first, n).column_sum() / Complex64::from(n as f64)
}

impl NodeTerms {
    /// `h_k` of a unit bow at `node`, as [`SpeedTerms::bow_column`].
    pub fn bow_column(
        &self,
        node: usize,
        line: bool,
    ) -> Result<nalgebra::DVectorView<'_, Complex64>, crate::estimate::predictor::PredictError>
    {
        match (&self.h_line, line) {
            (Some(h), true) => Ok(h.column(node)),
            (None, true) => Err(crate::estimate::predictor::PredictError::Dimension),
            _ => Ok(self.h_node.column(node)),
        }
    }

    /// `u_k` of a unit unbalance shared equally by the nodes
    /// `first..=last`, as [`SpeedTerms::spread_column`].
    pub fn spread_column(&self, first: usize, last: usize) -> DVector<Complex64> {
        mean_columns(&self.u_node, first, last)
    }
}

/// The terms of probes at shaft nodes at one speed (module docs), rows
/// `y, z` per probe node.
#[derive(Debug, Clone, PartialEq)]
pub struct NodeTerms {
    /// `P` (`2 N_n x 2 N_b`): the response to the bearing displacements.
    pub p: DMatrix<Complex64>,
    /// `u` (`2 N_n x N_p`, m per kg m): unbalance at the model's planes.
    pub u: DMatrix<Complex64>,
    /// `u_k` of a unit unbalance at every node (`2 N_n x N_nodes`, m per
    /// kg m).
    pub u_node: DMatrix<Complex64>,
    /// `h_k` of a unit bow at every node (`2 N_n x N_nodes`, m per m).
    pub h_node: DMatrix<Complex64>,
    /// `h_k` of a unit bow from the bearing line at every node, when the
    /// terms have them ([`SpeedTerms::g_line`]).
    pub h_line: Option<DMatrix<Complex64>>,
    /// `dP/de`, when derivatives were asked.
    pub dp_de: Option<DMatrix<Complex64>>,
    /// `du/de`, likewise.
    pub du_de: Option<DMatrix<Complex64>>,
}

/// Builds the terms at every speed of `omegas` (rad/s, > 0) for the shaft
/// modulus factor `e` (1: the model as given); with `derivative`, also
/// `dA/de`, `dB/de` by a forward difference (step `1e-4 e`, error `~1e-4`
/// relative: a Jacobian for the iteration, whose optimum the residual
/// fixes). One modal sum per speed after one set-up ([`Builder`]; the
/// banded adjoint reduction, [`Reducer::reduce_adjoint`], if the modal form
/// cannot be set up).
pub fn build(
    model: &RotorModel,
    omegas: &[f64],
    e: f64,
    derivative: bool,
) -> Result<Vec<SpeedTerms>, ReductionError> {
    build_with_probes(model, omegas, e, derivative, &[])
}

/// [`build`] with the [`NodeTerms`] of probes at the shaft nodes
/// `probe_nodes` (0-based; none: no [`SpeedTerms::probes`]), from the same
/// reduction per speed. Prepares a [`Builder`] and builds once; to build
/// at several factors, keep the [`Builder`].
pub fn build_with_probes(
    model: &RotorModel,
    omegas: &[f64],
    e: f64,
    derivative: bool,
    probe_nodes: &[usize],
) -> Result<Vec<SpeedTerms>, ReductionError> {
    Builder::new(model, probe_nodes)?.build(omegas, e, derivative)
}

/// The reduction of a model's load columns (plane and node unbalances,
/// node bows) and probe rows, prepared once: [`Builder::build`] then gives
/// the terms at any speeds and modulus factor (the factor only moves the
/// speed, module docs), one modal sum per speed
/// ([`crate::reduce::modal`]; the banded adjoint reduction when the modal
/// form cannot be set up, or with [`Builder::banded`]).
#[derive(Debug, Clone)]
pub struct Builder {
    model: RotorModel,
    fe: FeModel,
    /// Load columns: planes, unit unbalance at every node, unit bow at
    /// every node, and unit bow from the bearing line at every node when
    /// `line`.
    loads: DMatrix<Complex64>,
    /// Whether the bearing-line bows differ from the shaft-end ones (the
    /// bearings are not exactly the two shaft ends).
    line: bool,
    probe_dofs: Vec<usize>,
    np: usize,
    n_nodes: usize,
    /// Whether `loads` has the node columns (unbalance and bows at every
    /// node) after the planes' ([`Builder::planes_only`]: not).
    node_loads: bool,
    modal: Option<ModalReducer>,
}

impl Builder {
    /// The modal builder (banded if the modal set-up fails) for `model` and
    /// probes at `probe_nodes` (0-based).
    pub fn new(model: &RotorModel, probe_nodes: &[usize]) -> Result<Self, ReductionError> {
        let mut b = Self::banded(model, probe_nodes)?;
        let modal = Reducer::with_loads(&b.fe, &b.model, b.loads.clone())?
            .modal_probes(&b.probe_dofs)
            .ok();
        b.modal = modal;
        Ok(b)
    }

    /// The modal builder of the plane unbalances alone: its terms
    /// ([`Builder::build`]) have no node columns ([`SpeedTerms::b_node`],
    /// [`SpeedTerms::g_node`] and the probes' likewise are empty,
    /// [`SpeedTerms::g_line`] is `None`), and it costs a fraction of
    /// [`Builder::new`]'s set-up and sums (`2 N_b + N_planes` load columns
    /// against `2 N_b + N_planes + 3 N_nodes`). For the fits of a shaft
    /// stiffness factor, which read `A`, `B` and the probes' `P` and `u`
    /// only; their entries equal [`Builder::new`]'s to round-off.
    pub fn planes_only(model: &RotorModel, probe_nodes: &[usize]) -> Result<Self, ReductionError> {
        let fe = FeModel::new(model)?;
        let loads = fe.unbalance_distribution(&model.planes)?;
        let probe_dofs = Self::probe_dofs(&fe, model, probe_nodes)?;
        let reducer = Reducer::with_loads(&fe, model, loads.clone())?;
        let modal = reducer.modal_probes(&probe_dofs).ok();
        Ok(Builder {
            model: model.clone(),
            fe,
            loads,
            line: false,
            probe_dofs,
            np: model.planes.len(),
            n_nodes: model.n_nodes(),
            node_loads: false,
            modal,
        })
    }

    /// The shaft DOFs `(y, z)` of the probes at `probe_nodes` (0-based).
    fn probe_dofs(
        fe: &FeModel,
        model: &RotorModel,
        probe_nodes: &[usize],
    ) -> Result<Vec<usize>, ReductionError> {
        let n_nodes = model.n_nodes();
        if let Some(n) = probe_nodes.iter().find(|&&n| n >= n_nodes) {
            return Err(ReductionError::Invalid(format!(
                "probe at node {} beyond the shaft's {n_nodes} nodes",
                n + 1
            )));
        }
        Ok(probe_nodes
            .iter()
            .flat_map(|&n| [fe.dof(n, Dir::Y), fe.dof(n, Dir::Z)])
            .collect())
    }

    /// The builder with the banded adjoint reduction at every speed
    /// ([`Reducer::reduce_adjoint_probes`]): the reference the modal form
    /// is checked against.
    pub fn banded(model: &RotorModel, probe_nodes: &[usize]) -> Result<Self, ReductionError> {
        let fe = FeModel::new(model)?;
        let n_nodes = model.n_nodes();
        let np = model.planes.len();
        let all: Vec<usize> = (0..n_nodes).collect();
        let t_planes = fe.unbalance_distribution(&model.planes)?;
        let t_nodes = fe.unbalance_distribution(&all)?;
        let ns = fe.n_shaft_dof();
        let mut bearing_nodes = model.bearing_nodes();
        bearing_nodes.sort_unstable();
        let line = bearing_nodes != [0, n_nodes.saturating_sub(1)];
        let n_loads = np + if line { 3 } else { 2 } * n_nodes;
        let mut loads = DMatrix::<Complex64>::zeros(ns, n_loads);
        loads.view_mut((0, 0), (ns, np)).copy_from(&t_planes);
        loads.view_mut((0, np), (ns, n_nodes)).copy_from(&t_nodes);
        for n in 1..n_nodes.saturating_sub(1) {
            let bow = ShaftBow {
                points: vec![BowPoint {
                    node: n,
                    amplitude: 1.0,
                    phase: 0.0,
                }],
            };
            let f = fe.bow_force(&bow)?;
            for (r, v) in f.iter().enumerate() {
                loads[(r, np + n_nodes + n)] = *v;
            }
        }
        if line {
            for n in (0..n_nodes).filter(|n| !bearing_nodes.contains(n)) {
                let f = fe.shaft_force(&fe.line_bow_shape(n, &bearing_nodes)?);
                for (r, v) in f.iter().enumerate() {
                    loads[(r, np + 2 * n_nodes + n)] = *v;
                }
            }
        }
        let probe_dofs = Self::probe_dofs(&fe, model, probe_nodes)?;
        // Fails here, once, if the bearings do not hold the shaft.
        Reducer::with_loads(&fe, model, loads.clone())?;
        Ok(Builder {
            model: model.clone(),
            fe,
            loads,
            line,
            probe_dofs,
            np,
            n_nodes,
            node_loads: true,
            modal: None,
        })
    }

    /// Whether the terms come from the modal form.
    pub fn is_modal(&self) -> bool {
        self.modal.is_some()
    }

    /// The terms at every speed of `omegas` (rad/s, > 0) for the shaft
    /// modulus factor `e`, as [`build`] describes.
    pub fn build(
        &self,
        omegas: &[f64],
        e: f64,
        derivative: bool,
    ) -> Result<Vec<SpeedTerms>, ReductionError> {
        self.build_with(
            omegas,
            e,
            derivative,
            self.modal.is_some(),
            !self.node_loads,
        )
    }

    /// [`Builder::build`] without the node columns, as a
    /// [`Builder::planes_only`] builder's: the modal sum over the plane
    /// columns alone, the entries those of [`Builder::build`] bit for bit
    /// ([`ModalReducer::reduce_probes_loads`]).
    pub fn build_planes(
        &self,
        omegas: &[f64],
        e: f64,
        derivative: bool,
    ) -> Result<Vec<SpeedTerms>, ReductionError> {
        self.build_with(omegas, e, derivative, self.modal.is_some(), true)
    }

    /// [`Builder::build`] by the banded adjoint reduction at every speed
    /// whatever the builder holds: the diagnosis's terms of the model as
    /// given (`e = 1`), on which the nominal fit runs. That fit can stop
    /// at its iteration limit on data the nominal model misfits, and where
    /// it stops moves with the `1e-10` difference of the two reductions.
    pub fn build_banded(
        &self,
        omegas: &[f64],
        e: f64,
        derivative: bool,
    ) -> Result<Vec<SpeedTerms>, ReductionError> {
        self.build_with(omegas, e, derivative, false, !self.node_loads)
    }

    fn build_with(
        &self,
        omegas: &[f64],
        e: f64,
        derivative: bool,
        modal: bool,
        planes_only: bool,
    ) -> Result<Vec<SpeedTerms>, ReductionError> {
        if !(e.is_finite() && e > 0.0) {
            return Err(ReductionError::Invalid(format!(
                "shaft modulus factor must be finite and > 0, got {e}"
            )));
        }
        let (np, n_nodes) = (self.np, self.n_nodes);
        let line = self.line && !planes_only;
        let probe_dofs = &self.probe_dofs;
        let modal = self.modal.as_ref().filter(|_| modal);
        let banded = match modal {
            Some(_) => None,
            None => Some(Reducer::with_loads(
                &self.fe,
                &self.model,
                self.loads.clone(),
            )?),
        };
        // The node columns' blocks of the loads (empty without them).
        let nn = if planes_only { 0 } else { n_nodes };
        type Reduced = (DMatrix<Complex64>, DMatrix<Complex64>, Option<NodeTerms>);
        let at = |omega: f64, e: f64| -> Result<Reduced, ReductionError> {
            let w = omega / e.sqrt();
            let (t, pt) = match (modal, &banded) {
                (Some(m), _) if planes_only => m.reduce_probes_loads(w, np)?,
                (Some(m), _) => m.reduce_probes(w)?,
                (None, Some(r)) => r.reduce_adjoint_probes(w, probe_dofs)?,
                (None, None) => unreachable!("a builder has one of the two reductions"),
            };
            let probes = (!probe_dofs.is_empty()).then(|| {
                let w2 = Complex64::from(w * w);
                NodeTerms {
                    u: pt.l.columns(0, np) * w2,
                    u_node: pt.l.columns(np, nn) * w2,
                    h_node: pt.l.columns(np + nn, nn).into_owned(),
                    h_line: line.then(|| pt.l.columns(np + 2 * nn, nn).into_owned()),
                    p: pt.p,
                    dp_de: None,
                    du_de: None,
                }
            });
            Ok((t.a * Complex64::from(e), t.b * Complex64::from(e), probes))
        };
        let mut out = Vec::with_capacity(omegas.len());
        for &omega in omegas {
            if !(omega.is_finite() && omega > 0.0) {
                return Err(ReductionError::Invalid(format!(
                    "the diagnosis needs speeds > 0, got {omega} rad/s"
                )));
            }
            let (a, b_all, mut probes) = at(omega, e)?;
            let nq = a.nrows();
            let b = b_all.columns(0, np).into_owned();
            let b_node = b_all.columns(np, nn).into_owned();
            // `e B / Omega^2` is the bow load of the unscaled `K_s` reduced at
            // `Omega / sqrt(e)`; the shaft's bow forcing is `e K_s q_bow`.
            let g_node =
                b_all.columns(np + nn, nn).into_owned() * Complex64::from(e / (omega * omega));
            let g_line = line.then(|| {
                b_all.columns(np + 2 * nn, nn).into_owned() * Complex64::from(e / (omega * omega))
            });
            let (da_de, db_de) = if derivative {
                let h = 1e-4 * e;
                let (ap, bp, pp) = at(omega, e + h)?;
                let s = Complex64::from(1.0 / h);
                if let (Some(nt), Some(np_)) = (probes.as_mut(), pp) {
                    nt.dp_de = Some((np_.p - &nt.p) * s);
                    nt.du_de = Some((np_.u - &nt.u) * s);
                }
                (Some((ap - &a) * s), Some((bp.columns(0, np) - &b) * s))
            } else {
                (None, None)
            };
            debug_assert_eq!(b.nrows(), nq);
            out.push(SpeedTerms {
                omega,
                a,
                b,
                b_node,
                g_node,
                g_line,
                da_de,
                db_de,
                probes,
            });
        }
        Ok(out)
    }
}

/// Sets `dA/de` and `dB/de` of `terms` (built for the modulus factor `e`)
/// to the secant through `prev` (the same speeds, built for `e_prev`):
/// `(A(e) - A(e_prev)) / (e - e_prev)`, first-order accurate in
/// `e - e_prev`. A Jacobian for the iteration, as in [`build`].
///
/// At a speed where `A` or `B` changes by more than [`POLE_RATIO`] times
/// the relative change of the factor (`|dA| / |A| > POLE_RATIO |de| / e`,
/// Frobenius norms), a pole of the reduced terms (a mode of the shaft
/// with its bearing nodes held) lies within a fraction of a per cent of
/// that speed: there both terms grow like `1 / (omega - omega_p)` and
/// their derivatives like its square, the response stays finite only by
/// their cancellation, and a secant (or the linearisation in `e` itself)
/// is wrong by orders of magnitude within a step of the factor. Its
/// derivatives are set to zero: the step leaves that speed's response as
/// it is (the next round's exact terms take it up), and the factor's
/// standard deviation comes from the other speeds.
pub fn set_secant_derivative(
    terms: &mut [SpeedTerms],
    e: f64,
    prev: &[SpeedTerms],
    e_prev: f64,
) -> Result<(), ReductionError> {
    let h = e - e_prev;
    if terms.len() != prev.len() || !(h.is_finite() && h != 0.0) {
        return Err(ReductionError::Invalid(format!(
            "secant between {} and {} speeds at e = {e}, {e_prev}",
            terms.len(),
            prev.len()
        )));
    }
    let s = Complex64::from(1.0 / h);
    let rel = (h / e).abs();
    for (t, p) in terms.iter_mut().zip(prev) {
        if t.omega != p.omega || t.a.shape() != p.a.shape() || t.b.shape() != p.b.shape() {
            return Err(ReductionError::Invalid(
                "secant between terms of different speeds or shapes".into(),
            ));
        }
        let (da, db) = (&t.a - &p.a, &t.b - &p.b);
        let steep = |d: &DMatrix<Complex64>, x: &DMatrix<Complex64>| {
            // Beyond the ratio, or not comparable (a non-finite term).
            !matches!(
                d.norm().partial_cmp(&(POLE_RATIO * rel * x.norm())),
                Some(std::cmp::Ordering::Less | std::cmp::Ordering::Equal)
            )
        };
        let near_pole = steep(&da, &t.a) || steep(&db, &t.b);
        let secant = |mut d: DMatrix<Complex64>| {
            if near_pole {
                d.fill(Complex64::new(0.0, 0.0));
            } else {
                d *= s;
            }
            Some(d)
        };
        t.da_de = secant(da);
        t.db_de = secant(db);
        if let (Some(tn), Some(pn)) = (t.probes.as_mut(), p.probes.as_ref()) {
            tn.dp_de = secant(&tn.p - &pn.p);
            tn.du_de = secant(&tn.u - &pn.u);
        }
    }
    Ok(())
}

/// The relative change of a speed's reduced terms per relative change of
/// the stiffness factor above which [`set_secant_derivative`] takes that
/// speed as at a pole. Away from the poles the ratio is of order one (the
/// terms scale with the stiffness); it exceeds `1e3` only within about
/// `1 / 2000` of a pole's speed (`A ~ 1 / (omega - omega_p)`, `omega_p`
/// moving with `sqrt(e)`), where a step of the factor of the size of its
/// standard deviation moves the pole across the speed.
pub const POLE_RATIO: f64 = 1e3;

/// The form of a shaft stiffness error (`shaft_stiffness_error`): what a
/// factor `f` changes in the model.
///
/// | form | changed | what it stands for |
/// |---|---|---|
/// | [`StiffnessForm::EAndG`] | `E` and `G` of every element times `f` | temperature, a material's modulus with its shear modulus |
/// | [`StiffnessForm::EAlone`] | `E` of every element times `f`, `G` kept | a material's Young's modulus |
/// | [`StiffnessForm::Section`] | the outer diameter of elements `first..=last` times `f` (stiffness and mass) | a section of the drawing's shaft off, a softer fit |
///
/// Only `EAndG` scales the shaft's stiffness matrix as a whole (so its
/// terms are the model's own at another speed, module docs); the others
/// are built from the changed model ([`build_form`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum StiffnessForm {
    /// `E` and `G` together.
    #[default]
    EAndG,
    /// `E` alone.
    EAlone,
    /// The outer diameter of the shaft elements `first..=last` (0-based).
    Section {
        /// First element (0-based).
        first: usize,
        /// Last element (0-based, inclusive).
        last: usize,
    },
}

impl StiffnessForm {
    /// `model` with the factor `f` applied in this form. A section whose
    /// outer diameter would not exceed its inner one is an error.
    pub fn apply(self, model: &RotorModel, f: f64) -> Result<RotorModel, ReductionError> {
        if !(f.is_finite() && f > 0.0) {
            return Err(ReductionError::Invalid(format!(
                "shaft stiffness factor must be finite and > 0, got {f}"
            )));
        }
        let mut m = model.clone();
        match self {
            StiffnessForm::EAndG => {
                for el in &mut m.shaft {
                    el.material.e *= f;
                    el.material.g *= f;
                }
            }
            StiffnessForm::EAlone => {
                for el in &mut m.shaft {
                    el.material.e *= f;
                }
            }
            StiffnessForm::Section { first, last } => {
                let n = m.shaft.len();
                if first > last || last >= n {
                    return Err(ReductionError::Invalid(format!(
                        "shaft section {}..{} outside the {n} elements",
                        first + 1,
                        last + 1
                    )));
                }
                for el in &mut m.shaft[first..=last] {
                    el.outer_diameter *= f;
                    if el.outer_diameter <= el.inner_diameter {
                        return Err(ReductionError::Invalid(format!(
                            "outer diameter {} m at or below the inner {} m",
                            el.outer_diameter, el.inner_diameter
                        )));
                    }
                }
            }
        }
        Ok(m)
    }

    /// The form in words, e.g. "outer diameter of shaft elements 5..8"
    /// (1-based).
    pub fn describe(self) -> String {
        match self {
            StiffnessForm::EAndG => "the shaft's E and G".into(),
            StiffnessForm::EAlone => "the shaft's E (G kept)".into(),
            StiffnessForm::Section { first, last } => format!(
                "the outer diameter of shaft elements {}..{}",
                first + 1,
                last + 1
            ),
        }
    }
}

/// Which load columns a build gives: all of them, or the plane
/// unbalances' alone ([`Builder::build_planes`], [`Builder::planes_only`]:
/// what a fit of a stiffness factor alone reads, at a fraction of the
/// cost; `A`, `B` and the probes' `P`, `u` as the whole build's).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Columns {
    /// Planes, then unbalance and bows at every node.
    All,
    /// The planes alone: the node columns empty, no bearing-line bows.
    Planes,
}

/// The terms of `model` with a stiffness error of `form` and factor `f`
/// at every speed of `omegas`, with `dA/df`, `dB/df` by a forward
/// difference (step `1e-4 f`) when `derivative`. `EAndG` through
/// `builder` (the model's own, [`Builder::build`]); the other forms from
/// a [`Builder`] of the changed model (probes at `probe_nodes`).
pub fn build_form(
    builder: &Builder,
    model: &RotorModel,
    omegas: &[f64],
    form: StiffnessForm,
    f: f64,
    derivative: bool,
    probe_nodes: &[usize],
) -> Result<Vec<SpeedTerms>, ReductionError> {
    let changed = FormChange {
        form,
        f,
        derivative,
    };
    build_form_columns(builder, model, omegas, changed, probe_nodes, Columns::All)
}

/// A stiffness form's change to build: the form, its factor, and whether
/// with its derivative ([`build_form`]).
#[derive(Debug, Clone, Copy)]
pub struct FormChange {
    /// The form.
    pub form: StiffnessForm,
    /// Its factor.
    pub f: f64,
    /// Whether `dA/df`, `dB/df` are built (a forward difference).
    pub derivative: bool,
}

/// [`build_form`] with the load columns `columns`.
pub fn build_form_columns(
    builder: &Builder,
    model: &RotorModel,
    omegas: &[f64],
    change: FormChange,
    probe_nodes: &[usize],
    columns: Columns,
) -> Result<Vec<SpeedTerms>, ReductionError> {
    let FormChange {
        form,
        f,
        derivative,
    } = change;
    let planes_only = columns == Columns::Planes;
    if form == StiffnessForm::EAndG {
        return if planes_only {
            builder.build_planes(omegas, f, derivative)
        } else {
            builder.build(omegas, f, derivative)
        };
    }
    let at = |x: f64| -> Result<Vec<SpeedTerms>, ReductionError> {
        let changed = form.apply(model, x)?;
        if planes_only {
            Builder::planes_only(&changed, probe_nodes)?.build(omegas, 1.0, false)
        } else {
            Builder::new(&changed, probe_nodes)?.build(omegas, 1.0, false)
        }
    };
    let mut t = at(f)?;
    if derivative {
        let h = 1e-4 * f;
        let ahead = at(f + h)?;
        set_secant_derivative(&mut t, f, &ahead, f + h)?;
    }
    Ok(t)
}

/// Copies `dA/de`, `dB/de` and the probes' `dP/de`, `du/de` of `from` onto
/// `terms` (the same speeds and plane columns).
pub fn copy_derivative(
    terms: &mut [SpeedTerms],
    from: &[SpeedTerms],
) -> Result<(), ReductionError> {
    if terms.len() != from.len() {
        return Err(ReductionError::Invalid(format!(
            "derivative of {} speeds copied onto {}",
            from.len(),
            terms.len()
        )));
    }
    for (t, c) in terms.iter_mut().zip(from) {
        if t.omega != c.omega || t.a.shape() != c.a.shape() || t.b.shape() != c.b.shape() {
            return Err(ReductionError::Invalid(
                "derivative copied between terms of different speeds or shapes".into(),
            ));
        }
        t.da_de.clone_from(&c.da_de);
        t.db_de.clone_from(&c.db_de);
        if let (Some(tp), Some(cp)) = (t.probes.as_mut(), c.probes.as_ref()) {
            tp.dp_de.clone_from(&cp.dp_de);
            tp.du_de.clone_from(&cp.du_de);
        }
    }
    Ok(())
}

/// Whether `terms` lack the node columns ([`Columns::Planes`]) that a
/// model with `n_nodes` nodes has.
pub fn planes_only(terms: &[SpeedTerms], n_nodes: usize) -> bool {
    terms.first().is_some_and(|t| t.b_node.ncols() < n_nodes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::extension::{apply_effects, Effects};

    /// The modal terms equal the banded adjoint ones on the diagnosis'
    /// grid (300 speeds, 50..15000 rpm) at two modulus factors, every
    /// column: `A`, `B`, node unbalances and bows, probes at two interior
    /// nodes and at a bearing node, and the difference quotients in `e`.
    #[test]
    fn modal_terms_equal_banded_terms() {
        let m = RotorModel::paper();
        let omegas: Vec<f64> = (1..=300)
            .map(|i| crate::units::rpm_to_rad_s(50.0 * i as f64))
            .collect();
        let nodes = [9, 26, m.bearings[0].node];
        let modal = Builder::new(&m, &nodes).unwrap();
        assert!(modal.is_modal());
        let banded = Builder::banded(&m, &nodes).unwrap();
        assert!(!banded.is_modal());
        // The same numbers from the modal builder's banded path.
        let own = modal.build_banded(&omegas[..3], 1.02, true).unwrap();
        assert_eq!(own, banded.build(&omegas[..3], 1.02, true).unwrap());
        let rel = |x: &DMatrix<Complex64>, y: &DMatrix<Complex64>| {
            let n = y.norm();
            if n == 0.0 {
                x.norm()
            } else {
                (x - y).norm() / n
            }
        };
        for e in [1.0, 1.03] {
            let tm = modal.build(&omegas, e, true).unwrap();
            let tb = banded.build(&omegas, e, true).unwrap();
            let (mut worst, mut worst_d) = (0.0_f64, 0.0_f64);
            for (x, y) in tm.iter().zip(&tb) {
                assert_eq!(x.omega, y.omega);
                let (px, py) = (x.probes.as_ref().unwrap(), y.probes.as_ref().unwrap());
                for (a, b) in [
                    (&x.a, &y.a),
                    (&x.b, &y.b),
                    (&x.b_node, &y.b_node),
                    (&x.g_node, &y.g_node),
                    (&px.p, &py.p),
                    (&px.u, &py.u),
                    (&px.u_node, &py.u_node),
                    (&px.h_node, &py.h_node),
                ] {
                    worst = worst.max(rel(a, b));
                }
                for (a, b) in [
                    (&x.da_de, &y.da_de),
                    (&x.db_de, &y.db_de),
                    (&px.dp_de, &py.dp_de),
                    (&px.du_de, &py.du_de),
                ] {
                    worst_d = worst_d.max(rel(a.as_ref().unwrap(), b.as_ref().unwrap()));
                }
            }
            assert!(worst <= 2e-9, "e {e}: terms differ by {worst:.2e}");
            // The forward difference (step 1e-4 e) divides the difference
            // of two terms by 1e-4.
            assert!(
                worst_d <= 1e-5,
                "e {e}: derivatives differ by {worst_d:.2e}"
            );
            println!("e {e}: terms {worst:.2e}, derivatives {worst_d:.2e}");
        }
    }

    /// `A(e, Omega) = e A(Omega / sqrt(e))` equals the terms of the model
    /// rebuilt with E and G scaled; the node column of a plane equals
    /// `B`'s; `dA/de` equals a difference quotient. (The bow columns are
    /// checked against the full FE response in [`super::extended`].)
    #[test]
    fn modulus_scaling_and_columns_match_direct_reduction() {
        let m = RotorModel::paper();
        let omegas = [300.0, 900.0];
        let e = 1.04;
        let t = build(&m, &omegas, e, true).unwrap();
        let scaled = apply_effects(
            &m,
            &Effects {
                e_scale: e,
                ..Effects::default()
            },
        )
        .unwrap();
        let fe = FeModel::new(&scaled).unwrap();
        let r = Reducer::new(&fe, &scaled).unwrap();
        for (k, &w) in omegas.iter().enumerate() {
            let d = r.reduce(w).unwrap();
            // The adjoint reduction equals the direct one.
            let adj = r.reduce_adjoint(w).unwrap();
            assert!((&adj.a - &d.a).norm() <= 1e-10 * d.a.norm());
            assert!((&adj.b - &d.b).norm() <= 1e-10 * d.b.norm());
            assert!((&t[k].a - &d.a).norm() <= 1e-9 * d.a.norm());
            assert!((&t[k].b - &d.b).norm() <= 1e-9 * d.b.norm());
            for (p, &node) in m.planes.iter().enumerate() {
                let c = t[k].b_node.column(node) - d.b.column(p);
                assert!(c.norm() <= 1e-9 * d.b.norm());
            }
            // dA/de against a difference of two scaled models.
            let h = 1e-3;
            let t2 = build(&m, &[w], e + h, false).unwrap();
            let fd = (&t2[0].a - &t[k].a) / Complex64::from(h);
            let da = t[k].da_de.as_ref().unwrap();
            assert!((fd - da).norm() <= 1e-2 * da.norm());
        }
    }

    /// Each stiffness form changes what it names, and [`build_form`]'s
    /// terms are the reduction of the changed model: E alone leaves G; a
    /// section changes the outer diameter of its elements only (the FE
    /// model's stiffness and mass there, the dense reduction of that model
    /// at two speeds equal to the built terms); E and G through the builder
    /// equal the modulus scaling; the forward-difference derivative agrees
    /// with a central one; a diameter at the bore is an error.
    #[test]
    fn stiffness_forms_build_the_changed_model() {
        let m = RotorModel::paper();
        let f = 0.97;
        let e_alone = StiffnessForm::EAlone.apply(&m, f).unwrap();
        for (a, b) in e_alone.shaft.iter().zip(&m.shaft) {
            assert_eq!(a.material.e, f * b.material.e);
            assert_eq!(a.material.g, b.material.g);
        }
        let form = StiffnessForm::Section { first: 4, last: 9 };
        let sec = form.apply(&m, f).unwrap();
        for (i, (a, b)) in sec.shaft.iter().zip(&m.shaft).enumerate() {
            let want = if (4..=9).contains(&i) { f } else { 1.0 };
            assert_eq!(a.outer_diameter, want * b.outer_diameter);
            assert_eq!(a.material, b.material);
        }
        assert_eq!(
            form.describe(),
            "the outer diameter of shaft elements 5..10"
        );
        let omegas = [400.0, 1100.0];
        let builder = Builder::new(&m, &[]).unwrap();
        let t = build_form(&builder, &m, &omegas, form, f, true, &[]).unwrap();
        let fe = FeModel::new(&sec).unwrap();
        let r = Reducer::new(&fe, &sec).unwrap();
        for (k, &w) in omegas.iter().enumerate() {
            let d = r.reduce(w).unwrap();
            assert!((&t[k].a - &d.a).norm() <= 1e-9 * d.a.norm());
            assert!((&t[k].b - &d.b).norm() <= 1e-9 * d.b.norm());
            // The derivative against a central difference of the reduction.
            let h = 1e-3;
            let at = |x: f64| {
                let mx = form.apply(&m, x).unwrap();
                Reducer::new(&FeModel::new(&mx).unwrap(), &mx)
                    .unwrap()
                    .reduce(w)
                    .unwrap()
                    .a
            };
            let central = (at(f + h) - at(f - h)) / Complex64::from(2.0 * h);
            let da = t[k].da_de.as_ref().unwrap();
            assert!((da - &central).norm() <= 2e-3 * central.norm());
        }
        let eg = build_form(&builder, &m, &omegas, StiffnessForm::EAndG, f, false, &[]).unwrap();
        let direct = builder.build(&omegas, f, false).unwrap();
        assert_eq!(eg, direct);
        let mut hollow = m.clone();
        for el in &mut hollow.shaft {
            el.inner_diameter = 0.99 * el.outer_diameter;
        }
        assert!(form.apply(&hollow, 0.98).is_err());
        assert!(form.apply(&m, f64::NAN).is_err());
        assert!(StiffnessForm::Section { first: 3, last: 99 }
            .apply(&m, 1.0)
            .is_err());
    }

    /// The plane-only terms of a stiffness form (`Columns::Planes`) are
    /// the whole terms' `A`, `B`, probe `P`, `u` and derivatives: bit for
    /// bit for E and G (a prefix of the same modal sum), to round-off for
    /// a section (its own, smaller set-up); they have no node columns,
    /// `planes_only` tells them apart, and `copy_derivative` restores the
    /// whole terms with the same derivative.
    #[test]
    fn plane_terms_are_the_whole_terms_without_node_columns() {
        let m = RotorModel::paper();
        let probes = [5, 0];
        let omegas = [300.0, 900.0, 1500.0];
        let builder = Builder::new(&m, &probes).unwrap();
        let forms = [
            StiffnessForm::EAndG,
            StiffnessForm::EAlone,
            StiffnessForm::Section { first: 4, last: 9 },
        ];
        for form in forms {
            let f = 0.97;
            let whole = build_form(&builder, &m, &omegas, form, f, true, &probes).unwrap();
            let change = FormChange {
                form,
                f,
                derivative: true,
            };
            let lean = build_form_columns(&builder, &m, &omegas, change, &probes, Columns::Planes)
                .unwrap();
            assert!(!planes_only(&whole, m.n_nodes()));
            assert!(planes_only(&lean, m.n_nodes()));
            let tol = if form == StiffnessForm::EAndG {
                0.0
            } else {
                1e-10
            };
            let close = |a: &DMatrix<Complex64>, b: &DMatrix<Complex64>| {
                assert_eq!(a.shape(), b.shape());
                assert!((a - b).norm() <= tol * b.norm(), "{form:?}");
            };
            for (w, l) in whole.iter().zip(&lean) {
                close(&l.a, &w.a);
                close(&l.b, &w.b);
                close(l.da_de.as_ref().unwrap(), w.da_de.as_ref().unwrap());
                close(l.db_de.as_ref().unwrap(), w.db_de.as_ref().unwrap());
                let (lp, wp) = (l.probes.as_ref().unwrap(), w.probes.as_ref().unwrap());
                close(&lp.p, &wp.p);
                close(&lp.u, &wp.u);
                assert_eq!(l.b_node.ncols(), 0);
                assert_eq!(l.g_node.ncols(), 0);
                assert!(l.g_line.is_none() && lp.h_line.is_none());
                assert_eq!((lp.u_node.ncols(), lp.h_node.ncols()), (0, 0));
            }
            let mut restored = build_form(&builder, &m, &omegas, form, f, false, &probes).unwrap();
            copy_derivative(&mut restored, &lean).unwrap();
            for (r, l) in restored.iter().zip(&lean) {
                assert_eq!(r.da_de, l.da_de);
                assert_eq!(
                    r.probes.as_ref().unwrap().du_de,
                    l.probes.as_ref().unwrap().du_de
                );
            }
            assert!(copy_derivative(&mut restored[..2], &lean).is_err());
        }
    }
}
