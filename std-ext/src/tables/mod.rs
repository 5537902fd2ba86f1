//! Bearing-level model tables for firmware: the per-speed reduced terms
//! `A(Omega)`, `B(Omega)` of [`crate::reduce`] on a speed grid
//! ([`crate::tables::grid`]), written as
//!
//! * a binary blob (little-endian, CRC-32; byte layout in
//!   [`rotorid_core::table`] and the README section "Model tables"), read in
//!   firmware by [`rotorid_core::table::TableView::parse`], or
//! * Rust source defining a `static TABLE: rotorid_core::table::Table<T, NQ,
//!   NP, NS>` (plus `N_NODES`, `BEARING_NODES`, `PLANE_NODES`) for
//!   `include!` in firmware.
//!
//! Both carry the poles of the reduced model (speeds where the shaft with
//! its bearing points held fixed resonates) that the firmware's
//! pole-factored interpolation needs, and the identification the table is
//! written for: the model structure (formulation, order) and the column
//! scaling ([`auto_scaling`] at the top of the grid), so that firmware sets
//! up its identifier from the table alone (the Rust source also defines
//! `STRUCTURE`, `SCALING`, the sizes and the identifier type `Id`; a
//! firmware that reads a blob defines the same sizes, `STRUCTURE` and `Id`
//! with `rotorid_core::identifier_types!` from the blob's scalar type,
//! structure, bearings and planes).

pub mod grid;

use std::fmt::Write as _;

use num_complex::Complex64;
use rotorid_core::crc32::crc32;
use rotorid_core::parametrization::{Formulation, Structure};
use rotorid_core::scaling::ColumnScaling;
use rotorid_core::table::{
    formulation_code, Layout, TableError, TableScalar, TableView, FORMAT_VERSION, HEADER_LEN,
    MAGIC, MAX_BEARINGS, MAX_PLANES, MAX_POLES,
};
use thiserror::Error;

use crate::fe::assembly::FeModel;
use crate::model::RotorModel;
use crate::reduce::PoleSets;
use crate::reduce::{ReducedTerms, Reducer, ReductionError};
use grid::{AdaptiveOptions, CheckReport};

/// Error writing or reading a table.
#[derive(Debug, Error)]
pub enum TablesError {
    /// The table cannot be written (sizes, ordering, non-finite values).
    #[error("invalid table: {0}")]
    Invalid(String),
    /// A blob was rejected by the firmware parser.
    #[error("table blob rejected: {0}")]
    Blob(#[from] TableError),
    /// The FE model or the reduction failed.
    #[error(transparent)]
    Reduction(#[from] ReductionError),
    /// Bad grid parameters, or the adaptive grid failed.
    #[error("speed grid: {0}")]
    Grid(String),
}

/// Poles are kept up to this multiple of the highest grid speed.
pub const POLE_RANGE_FACTOR: f64 = 2.0;

/// The structure a table is written for unless told otherwise
/// ([`ModelTable::with_structure`]): `physical` 1, as `rotorid identify`.
pub const DEFAULT_STRUCTURE: Structure = Structure::physical(1);

/// Reference magnitudes for the column scaling from the known part of the
/// model (the shaft), never from the unknown bearings:
///
/// * stiffness `s_K = 48 E I / L^3`, the midspan stiffness of the shaft as a
///   simply supported beam (length-weighted mean `E I`, total length `L`);
/// * `omega_ref` = the given highest speed (rad/s);
/// * unbalance `s_a = m_rotor * G / omega_ref` with the ISO 1940 balance
///   grade `G = 6.3 mm/s` and `m_rotor` = shaft + disk mass.
///
/// For the paper rotor: `s_K` = 2.1e7 N/m, `s_a` = 3.4e-4 kg m at 15000 rpm.
pub fn auto_scaling(model: &RotorModel, omega_ref: f64) -> ColumnScaling<f64> {
    let mut len = 0.0;
    let mut ei_l = 0.0;
    let mut mass = 0.0;
    for e in &model.shaft {
        let (d_o, d_i) = (e.outer_diameter, e.inner_diameter);
        let i = core::f64::consts::PI * (d_o.powi(4) - d_i.powi(4)) / 64.0;
        let area = core::f64::consts::PI * (d_o * d_o - d_i * d_i) / 4.0;
        len += e.length;
        ei_l += e.material.e * i * e.length;
        mass += e.material.rho * area * e.length;
    }
    mass += model.disks.iter().map(|d| d.mass).sum::<f64>();
    let omega_ref = if omega_ref.is_finite() && omega_ref > 0.0 {
        omega_ref
    } else {
        1.0
    };
    let stiffness = if len > 0.0 {
        48.0 * (ei_l / len) / len.powi(3)
    } else {
        1.0
    };
    let unbalance = mass * 6.3e-3 / omega_ref;
    ColumnScaling::new(stiffness, omega_ref, unbalance)
        .unwrap_or_else(|_| ColumnScaling::identity())
}

fn model_table(model: &RotorModel, poles: PoleSets, terms: Vec<ReducedTerms>) -> ModelTable {
    let top = terms.iter().map(|t| t.omega).fold(0.0, f64::max);
    ModelTable {
        model_name: model.name.clone(),
        structure: DEFAULT_STRUCTURE,
        scaling: auto_scaling(model, top),
        n_nodes: model.n_nodes(),
        bearing_nodes: model.bearing_nodes(),
        plane_nodes: model.planes.clone(),
        poles,
        terms,
    }
}

/// The table of `model` on the given speeds (rad/s, > 0, strictly
/// increasing): the modal reduction at every speed ([`Reducer::many`]:
/// one eigendecomposition, then a matrix-vector product per speed), plus the poles
/// up to [`POLE_RANGE_FACTOR`] times the highest speed (at most
/// [`MAX_POLES`]), for the [`DEFAULT_STRUCTURE`] and the
/// [`auto_scaling`] at the highest speed.
pub fn build(model: &RotorModel, speeds: &[f64]) -> Result<ModelTable, TablesError> {
    let fe = FeModel::new(model).map_err(ReductionError::from)?;
    let reducer = Reducer::new(&fe, model)?;
    let top = speeds.iter().copied().fold(0.0, f64::max);
    let poles = reducer.pole_sets(POLE_RANGE_FACTOR * top, MAX_POLES);
    let many = reducer.many();
    let terms = speeds
        .iter()
        .map(|&w| many.reduce(w))
        .collect::<Result<Vec<_>, _>>()?;
    let table = model_table(model, poles, terms);
    table.validate()?;
    Ok(table)
}

/// What the adaptive grid achieved.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AdaptiveSummary {
    /// Tolerance asked.
    pub tol: f64,
    /// Worst error on the 10x finer check grid, and where.
    pub check: CheckReport,
    /// Direct reductions computed (grid, midpoints and checks).
    pub evaluations: usize,
    /// Whether the tolerance was met.
    pub met_tolerance: bool,
}

/// The table of `model` on an adaptive grid over `[omega_min, omega_max]`
/// (rad/s) meeting `opts.tol` on a 10x finer check grid (see
/// [`grid::adaptive`]). An error if the tolerance cannot be met within
/// `opts.max_points`.
pub fn build_adaptive(
    model: &RotorModel,
    omega_min: f64,
    omega_max: f64,
    opts: AdaptiveOptions,
) -> Result<(ModelTable, AdaptiveSummary), TablesError> {
    let fe = FeModel::new(model).map_err(ReductionError::from)?;
    let reducer = Reducer::new(&fe, model)?;
    let poles = reducer.pole_sets(POLE_RANGE_FACTOR * omega_max, MAX_POLES);
    let many = reducer.many();
    let g = grid::adaptive(|w| many.reduce(w), &poles, omega_min, omega_max, opts)
        .map_err(|e| TablesError::Grid(e.to_string()))?;
    let summary = AdaptiveSummary {
        tol: opts.tol,
        check: g.check,
        evaluations: g.evaluations,
        met_tolerance: g.met_tolerance,
    };
    if !g.met_tolerance {
        return Err(TablesError::Grid(format!(
            "tolerance {} not met with {} speeds (worst check error {:.3e} at {:.3} rad/s)",
            opts.tol,
            g.terms.len(),
            g.check.worst_error,
            g.check.at_omega
        )));
    }
    let table = model_table(model, poles, g.terms);
    table.validate()?;
    Ok((table, summary))
}

/// Scalar type of a written table.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scalar {
    /// 4-byte IEEE floats (type code 4).
    F32,
    /// 8-byte IEEE floats (type code 8).
    F64,
}

impl Scalar {
    /// Rust type name.
    pub fn rust_name(self) -> &'static str {
        match self {
            Scalar::F32 => "f32",
            Scalar::F64 => "f64",
        }
    }
}

/// A complete model table, in f64, nodes 0-based.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelTable {
    /// Name of the model, for the Rust source header comment.
    pub model_name: String,
    /// The model structure the identification will use (written to the
    /// blob header and as `STRUCTURE` into the Rust source).
    pub structure: Structure,
    /// The column scaling the identification will use (written to the blob
    /// header and as `SCALING` into the Rust source).
    pub scaling: ColumnScaling<f64>,
    /// Number of shaft nodes of the model.
    pub n_nodes: usize,
    /// Bearing nodes (0-based), increasing: channel `2 m` is bearing `m`'s
    /// `y`, `2 m + 1` its `z`.
    pub bearing_nodes: Vec<usize>,
    /// Unbalance plane nodes (0-based): column `k` of `B` is plane `k`.
    pub plane_nodes: Vec<usize>,
    /// Poles of `A` and of `B` used by the interpolation (rad/s),
    /// increasing, at most [`MAX_POLES`] each.
    pub poles: PoleSets,
    /// Terms per grid speed, strictly increasing speed.
    pub terms: Vec<ReducedTerms>,
}

impl ModelTable {
    /// The same table for another model structure.
    pub fn with_structure(mut self, structure: Structure) -> Self {
        self.structure = structure;
        self
    }

    /// The same table with another column scaling.
    pub fn with_scaling(mut self, scaling: ColumnScaling<f64>) -> Self {
        self.scaling = scaling;
        self
    }

    /// Grid speeds (rad/s).
    pub fn speeds(&self) -> Vec<f64> {
        self.terms.iter().map(|t| t.omega).collect()
    }

    /// `A` and `B` at `omega` with the firmware's interpolation scheme.
    pub fn interpolate(&self, omega: f64) -> Result<ReducedTerms, TableError> {
        grid::interpolate(&self.terms, &self.poles, omega)
    }

    /// Checks that the table can be written: structure valid, scaling
    /// finite and > 0, counts within the format's limits, nodes valid, poles
    /// and speeds finite, > 0, strictly increasing, matrices of the right
    /// shape with finite entries.
    pub fn validate(&self) -> Result<(), TablesError> {
        let bad = |s: String| Err(TablesError::Invalid(s));
        if self.structure.validate().is_err() {
            return bad(format!("order {} out of range", self.structure.order));
        }
        let sc = &self.scaling;
        if ColumnScaling::<f64>::new(sc.stiffness, sc.omega_ref, sc.unbalance).is_err() {
            return bad(format!("column scaling {sc:?} not finite and > 0"));
        }
        let (n_b, n_p) = (self.bearing_nodes.len(), self.plane_nodes.len());
        if self.n_nodes < 2 || self.n_nodes > u16::MAX as usize {
            return bad(format!("{} nodes (must be 2..=65535)", self.n_nodes));
        }
        if n_b == 0 || n_b > MAX_BEARINGS || n_b > self.n_nodes {
            return bad(format!("{n_b} bearings (must be 1..={MAX_BEARINGS})"));
        }
        if n_p > MAX_PLANES {
            return bad(format!("{n_p} planes (at most {MAX_PLANES})"));
        }
        if self.poles.a.len() > MAX_POLES || self.poles.b.len() > MAX_POLES {
            return bad(format!("more than {MAX_POLES} poles"));
        }
        if self.terms.is_empty() || self.terms.len() > u32::MAX as usize {
            return bad(format!("{} speeds", self.terms.len()));
        }
        for (i, &n) in self.bearing_nodes.iter().enumerate() {
            if n >= self.n_nodes || (i > 0 && n <= self.bearing_nodes[i - 1]) {
                return bad("bearing nodes must be on the shaft and increasing".into());
            }
        }
        for (i, &n) in self.plane_nodes.iter().enumerate() {
            if n >= self.n_nodes || self.plane_nodes[..i].contains(&n) {
                return bad("plane nodes must be on the shaft and distinct".into());
            }
        }
        fn increasing(v: impl Iterator<Item = f64>) -> bool {
            let mut prev = 0.0;
            for x in v {
                if !(x.is_finite() && x > prev) {
                    return false;
                }
                prev = x;
            }
            true
        }
        if !increasing(self.poles.a.iter().copied()) || !increasing(self.poles.b.iter().copied()) {
            return bad("poles must be finite, > 0 and increasing".into());
        }
        if !increasing(self.terms.iter().map(|t| t.omega)) {
            return bad("speeds must be finite, > 0 and strictly increasing".into());
        }
        let nq = 2 * n_b;
        for t in &self.terms {
            if t.a.shape() != (nq, nq) || t.b.shape() != (nq, n_p) {
                return bad(format!("terms at {} rad/s have the wrong shape", t.omega));
            }
            if t.a
                .iter()
                .chain(t.b.iter())
                .any(|z| !(z.re.is_finite() && z.im.is_finite()))
            {
                return bad(format!("non-finite entry at {} rad/s", t.omega));
            }
        }
        Ok(())
    }

    /// The binary blob (format version 2, layout in [`rotorid_core::table`]).
    /// In f32 every value is rounded to nearest; a value that overflows f32
    /// is an error. The scaling is stored in f64 whatever the scalar type
    /// (and must not round to 0 or infinity in f32).
    pub fn to_blob(&self, scalar: Scalar) -> Result<Vec<u8>, TablesError> {
        self.validate()?;
        let (n_b, n_p, n_ka, n_kb, n_s) = (
            self.bearing_nodes.len(),
            self.plane_nodes.len(),
            self.poles.a.len(),
            self.poles.b.len(),
            self.terms.len(),
        );
        let w = match scalar {
            Scalar::F32 => f32::WIDTH,
            Scalar::F64 => f64::WIDTH,
        };
        let lay = Layout::new(w, n_b, n_p, n_ka, n_kb, n_s)
            .ok_or_else(|| TablesError::Invalid("table too large".into()))?;
        let mut out = Vec::with_capacity(lay.total);
        out.extend_from_slice(&MAGIC);
        out.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
        out.push(match scalar {
            Scalar::F32 => f32::TYPE_CODE,
            Scalar::F64 => f64::TYPE_CODE,
        });
        out.push(0);
        // Counts were range-checked by validate().
        for v in [self.n_nodes, n_b, n_p] {
            out.extend_from_slice(&(v as u16).to_le_bytes());
        }
        out.push(n_ka as u8);
        out.push(n_kb as u8);
        out.extend_from_slice(&(n_s as u32).to_le_bytes());
        // The order was range-checked by validate() (1..=MAX_ORDER < 256).
        out.push(formulation_code(self.structure.formulation));
        out.push(self.structure.order as u8);
        out.extend_from_slice(&[0; 6]);
        let sc = &self.scaling;
        for x in [sc.stiffness, sc.omega_ref, sc.unbalance] {
            out.extend_from_slice(&x.to_le_bytes());
        }
        self.check_scaling_fits(scalar)?;
        debug_assert_eq!(out.len(), HEADER_LEN);
        for &n in self.plane_nodes.iter().chain(&self.bearing_nodes) {
            out.extend_from_slice(&((n + 1) as u16).to_le_bytes());
        }
        let mut overflow = false;
        let mut put = |out: &mut Vec<u8>, x: f64| match scalar {
            Scalar::F32 => {
                let y = x as f32;
                overflow |= !y.is_finite();
                out.extend_from_slice(&y.to_le_bytes());
            }
            Scalar::F64 => out.extend_from_slice(&x.to_le_bytes()),
        };
        for &p in self.poles.a.iter().chain(&self.poles.b) {
            put(&mut out, p);
        }
        for t in &self.terms {
            put(&mut out, t.omega);
        }
        for t in &self.terms {
            for z in row_major(&t.a).chain(row_major(&t.b)) {
                put(&mut out, z.re);
                put(&mut out, z.im);
            }
        }
        if overflow {
            return Err(TablesError::Invalid(
                "a value overflows f32; write the table in f64".into(),
            ));
        }
        let crc = crc32(&out);
        out.extend_from_slice(&crc.to_le_bytes());
        debug_assert_eq!(out.len(), lay.total);
        Ok(out)
    }

    /// The scaling must stay finite and > 0 once rounded to the scalar type.
    fn check_scaling_fits(&self, scalar: Scalar) -> Result<(), TablesError> {
        let sc = &self.scaling;
        if scalar == Scalar::F32
            && ColumnScaling::<f32>::new(sc.stiffness, sc.omega_ref, sc.unbalance).is_err()
        {
            return Err(TablesError::Invalid(
                "the column scaling does not fit f32; write the table in f64".into(),
            ));
        }
        Ok(())
    }

    /// Reads a blob (either scalar type) through the firmware parser, which
    /// validates it, and widens it to f64. Returns the table and its scalar
    /// type. The model name is not stored in blobs (it comes back empty).
    pub fn from_blob(bytes: &[u8]) -> Result<(ModelTable, Scalar), TablesError> {
        match bytes.get(10) {
            Some(&c) if c == f32::TYPE_CODE => Ok((
                Self::from_view(&TableView::<f32>::parse(bytes)?)?,
                Scalar::F32,
            )),
            _ => Ok((
                Self::from_view(&TableView::<f64>::parse(bytes)?)?,
                Scalar::F64,
            )),
        }
    }

    fn from_view<T: TableScalar>(v: &TableView<'_, T>) -> Result<ModelTable, TablesError> {
        let c = TablesError::Blob(TableError::Corrupt);
        let node = |n: Option<u16>| n.map(|n| n as usize - 1).ok_or(TableError::Corrupt);
        let nq = v.n_channels();
        let mut terms = Vec::with_capacity(v.n_speeds());
        for s in 0..v.n_speeds() {
            let z = |x: Option<num_complex::Complex<T>>| {
                x.map(|x| Complex64::new(x.re.to_f64(), x.im.to_f64()))
                    .ok_or(TableError::Corrupt)
            };
            let mut a = nalgebra::DMatrix::zeros(nq, nq);
            let mut b = nalgebra::DMatrix::zeros(nq, v.n_planes());
            for r in 0..nq {
                for col in 0..nq {
                    a[(r, col)] = z(v.a_entry(s, r, col))?;
                }
                for col in 0..v.n_planes() {
                    b[(r, col)] = z(v.b_entry(s, r, col))?;
                }
            }
            let omega = v.speed(s).ok_or(TableError::Corrupt)?.to_f64();
            terms.push(ReducedTerms { omega, a, b });
        }
        let poles_a = (0..v.n_poles_a())
            .map(|i| v.pole_a(i).map(|p| p.to_f64()))
            .collect::<Option<Vec<_>>>()
            .ok_or(TablesError::Blob(TableError::Corrupt))?;
        let poles = PoleSets {
            a: poles_a,
            b: (0..v.n_poles_b())
                .map(|i| v.pole_b(i).map(|p| p.to_f64()))
                .collect::<Option<Vec<_>>>()
                .ok_or(c)?,
        };
        Ok(ModelTable {
            model_name: String::new(),
            structure: v.structure(),
            scaling: v.stored_scaling(),
            n_nodes: v.n_nodes() as usize,
            bearing_nodes: (0..v.n_bearings())
                .map(|i| node(v.bearing_node(i)))
                .collect::<Result<_, _>>()?,
            plane_nodes: (0..v.n_planes())
                .map(|i| node(v.plane_node(i)))
                .collect::<Result<_, _>>()?,
            poles,
            terms,
        })
    }

    /// Rust source defining the same table for firmware `include!`:
    ///
    /// ```text
    /// pub const N_NODES: u16 = ..;
    /// pub const BEARING_NODES: [u16; N_b] = [..];   // 1-based
    /// pub const PLANE_NODES: [u16; N_p] = [..];     // 1-based
    /// pub const NQ: usize = 2 N_b;  pub const NP: usize = N_p;  pub const NS: usize = ..;
    /// pub const STRUCTURE: rotorid_core::parametrization::Structure = Structure::physical(1);
    /// pub const SCALING: rotorid_core::scaling::ColumnScaling<T> = ColumnScaling { .. };
    /// pub const M: usize = STRUCTURE.n_unknowns(NQ / 2, NP);
    /// pub const N: usize = STRUCTURE.n_rows(NQ / 2);
    /// pub const W: usize = BlockShape::of(STRUCTURE, NQ / 2, NP).width;
    /// pub const S: usize = BlockShape::of(STRUCTURE, NQ / 2, NP).shared;
    /// pub type Id = rotorid_core::identify::PhysicalIdentifier<T, NQ, NP, M, N, W, S>; // or PaperIdentifier
    /// pub static TABLE: rotorid_core::table::Table<T, NQ, NP, NS> = ..;
    /// ```
    ///
    /// so that the firmware's whole set-up is
    /// `Id::new(Config::new(STRUCTURE, SCALING))` (or `Id::from_table(&TABLE)`).
    /// `rotorid_core::identifier_types!` defines the same `NQ`, `NP`,
    /// `STRUCTURE`, `M`, `N`, `W`, `S` and `Id` for a blob of the table
    /// (checked by `tests/tables/source.rs`).
    ///
    /// Values are written with Rust's shortest round-trip formatting of the
    /// chosen scalar type, so the included table equals the blob bit for
    /// bit. The output is deterministic (no dates or versions in it).
    pub fn to_rust_source(&self, scalar: Scalar) -> Result<String, TablesError> {
        self.validate()?;
        self.check_scaling_fits(scalar)?;
        let mut s = String::new();
        self.write_source_header(&mut s, scalar)?;
        self.write_source_constants(&mut s, scalar)?;
        self.write_source_table(&mut s, scalar)?;
        Ok(s)
    }

    /// [`Self::to_rust_source`]'s opening comment and the model's nodes.
    fn write_source_header(&self, w: &mut String, scalar: Scalar) -> Result<(), TablesError> {
        let fmt = |x: f64| rust_literal(scalar, x);
        let (n_b, n_p, n_s) = (
            self.bearing_nodes.len(),
            self.plane_nodes.len(),
            self.terms.len(),
        );
        let ty = scalar.rust_name();
        let list = |v: &[usize]| {
            v.iter()
                .map(|n| (n + 1).to_string())
                .collect::<Vec<_>>()
                .join(", ")
        };
        // writeln! into a String cannot fail.
        let _ = writeln!(
            w,
            "// rotorid bearing-level model table, generated by `rotorid tables`: do not edit."
        );
        let _ = writeln!(
            w,
            "// Model `{}`: {n_b} bearings, {n_p} unbalance planes, {n_s} speeds from {} to {} rad/s, {ty}.",
            self.model_name.replace('\n', " "),
            fmt(self.terms[0].omega)?,
            fmt(self.terms[n_s - 1].omega)?
        );
        let _ = writeln!(
            w,
            "// A(Omega) q_B = -Z_B(Omega) q_B + B(Omega) a; see rotorid_core::table."
        );
        let _ = writeln!(w, "\n/// Number of shaft nodes of the model.");
        let _ = writeln!(w, "pub const N_NODES: u16 = {};", self.n_nodes);
        let _ = writeln!(
            w,
            "/// Bearing nodes (1-based); channels are b1_y, b1_z, b2_y, ..."
        );
        let _ = writeln!(
            w,
            "pub const BEARING_NODES: [u16; {n_b}] = [{}];",
            list(&self.bearing_nodes)
        );
        let _ = writeln!(w, "/// Unbalance plane nodes (1-based), the columns of B.");
        let _ = writeln!(
            w,
            "pub const PLANE_NODES: [u16; {n_p}] = [{}];",
            list(&self.plane_nodes)
        );
        Ok(())
    }

    /// [`Self::to_rust_source`]'s sizes, structure, scaling and identifier
    /// type.
    fn write_source_constants(&self, w: &mut String, scalar: Scalar) -> Result<(), TablesError> {
        let fmt = |x: f64| rust_literal(scalar, x);
        let (n_b, n_p, n_s) = (
            self.bearing_nodes.len(),
            self.plane_nodes.len(),
            self.terms.len(),
        );
        let nq = 2 * n_b;
        let ty = scalar.rust_name();
        let (ctor, id_alias) = match self.structure.formulation {
            Formulation::Physical => ("physical", "PhysicalIdentifier"),
            Formulation::Paper => ("paper", "PaperIdentifier"),
        };
        let order = self.structure.order;
        let _ = writeln!(
            w,
            "/// Channels `NQ = 2 N_b`, unbalance planes `NP`, grid speeds `NS`."
        );
        let _ = writeln!(w, "pub const NQ: usize = {nq};");
        let _ = writeln!(w, "/// Unbalance planes.");
        let _ = writeln!(w, "pub const NP: usize = {n_p};");
        let _ = writeln!(w, "/// Grid speeds.");
        let _ = writeln!(w, "pub const NS: usize = {n_s};");
        let _ = writeln!(
            w,
            "/// The model structure the table was written for (`--formulation {ctor} --order {order}`)."
        );
        let _ = writeln!(
            w,
            "pub const STRUCTURE: rotorid_core::parametrization::Structure = rotorid_core::parametrization::Structure::{ctor}({order});"
        );
        let _ = writeln!(
            w,
            "/// Column scaling: reference stiffness (N/m), speed (rad/s), unbalance (kg m)."
        );
        let _ = writeln!(
            w,
            "#[allow(clippy::approx_constant, clippy::excessive_precision, clippy::unreadable_literal)]"
        );
        let sc = &self.scaling;
        let _ = writeln!(
            w,
            "pub const SCALING: rotorid_core::scaling::ColumnScaling<{ty}> = rotorid_core::scaling::ColumnScaling {{ stiffness: {}, omega_ref: {}, unbalance: {} }};",
            fmt(sc.stiffness)?,
            fmt(sc.omega_ref)?,
            fmt(sc.unbalance)?
        );
        let _ = writeln!(w, "/// Unknowns `M` of the structure.");
        let _ = writeln!(w, "pub const M: usize = STRUCTURE.n_unknowns(NQ / 2, NP);");
        let _ = writeln!(w, "/// Rows `N` per update of the structure.");
        let _ = writeln!(w, "pub const N: usize = STRUCTURE.n_rows(NQ / 2);");
        let _ = writeln!(
            w,
            "/// Block layout of the filter: `W` coefficients per channel, `S` shared unbalance unknowns."
        );
        let _ = writeln!(
            w,
            "pub const W: usize = rotorid_core::blockqrd::BlockShape::of(STRUCTURE, NQ / 2, NP).width;"
        );
        let _ = writeln!(w, "/// Shared (unbalance) unknowns of the block layout.");
        let _ = writeln!(
            w,
            "pub const S: usize = rotorid_core::blockqrd::BlockShape::of(STRUCTURE, NQ / 2, NP).shared;"
        );
        let _ = writeln!(
            w,
            "/// The firmware identifier for this table (square-root-free block filter): `Id::new(Config::new(STRUCTURE, SCALING))`."
        );
        let _ = writeln!(
            w,
            "pub type Id = rotorid_core::identify::{id_alias}<{ty}, NQ, NP, M, N, W, S>;"
        );
        Ok(())
    }

    /// [`Self::to_rust_source`]'s `TABLE`: poles, speeds and the A and B
    /// matrices per speed.
    fn write_source_table(&self, w: &mut String, scalar: Scalar) -> Result<(), TablesError> {
        let fmt = |x: f64| rust_literal(scalar, x);
        let ty = scalar.rust_name();
        let _ = writeln!(w, "/// A (N/m) and B (1/s^2) per speed (rad/s), with the poles (rad/s) of the reduced model.");
        let _ = writeln!(
            w,
            "#[allow(clippy::approx_constant, clippy::excessive_precision, clippy::unreadable_literal)]"
        );
        let _ = writeln!(
            w,
            "pub static TABLE: rotorid_core::table::Table<{ty}, NQ, NP, NS> = rotorid_core::table::Table {{"
        );
        let _ = writeln!(w, "    structure: STRUCTURE,");
        let _ = writeln!(w, "    scaling: SCALING,");
        for (name, list) in [("a", &self.poles.a), ("b", &self.poles.b)] {
            let mut poles = Vec::with_capacity(MAX_POLES);
            for i in 0..MAX_POLES {
                poles.push(fmt(list.get(i).copied().unwrap_or(0.0))?);
            }
            let _ = writeln!(w, "    poles_{name}: [{}],", poles.join(", "));
            let _ = writeln!(w, "    n_poles_{name}: {},", list.len());
        }
        let speeds = self
            .terms
            .iter()
            .map(|t| fmt(t.omega))
            .collect::<Result<Vec<_>, _>>()?;
        let _ = writeln!(w, "    speeds: [{}],", speeds.join(", "));
        let cplx = |z: &Complex64| -> Result<String, TablesError> {
            Ok(format!(
                "rotorid_core::Complex {{ re: {}, im: {} }}",
                fmt(z.re)?,
                fmt(z.im)?
            ))
        };
        for (name, pick) in [("a", 0usize), ("b", 1)] {
            let _ = writeln!(w, "    {name}: [");
            for t in &self.terms {
                let m = if pick == 0 { &t.a } else { &t.b };
                let _ = writeln!(w, "        [");
                for r in 0..m.nrows() {
                    let row = (0..m.ncols())
                        .map(|c| cplx(&m[(r, c)]))
                        .collect::<Result<Vec<_>, _>>()?;
                    let _ = writeln!(w, "            [{}],", row.join(", "));
                }
                let _ = writeln!(w, "        ],");
            }
            let _ = writeln!(w, "    ],");
        }
        let _ = writeln!(w, "}};");
        Ok(())
    }
}

/// `x` as a Rust literal of `scalar` (shortest round-trip form); an error
/// where it overflows f32.
fn rust_literal(scalar: Scalar, x: f64) -> Result<String, TablesError> {
    let s = match scalar {
        Scalar::F32 => {
            let y = x as f32;
            if !y.is_finite() {
                return Err(TablesError::Invalid(
                    "a value overflows f32; write the table in f64".into(),
                ));
            }
            format!("{y:?}")
        }
        Scalar::F64 => format!("{x:?}"),
    };
    Ok(s)
}

/// Entries of a matrix in row-major order.
fn row_major(m: &nalgebra::DMatrix<Complex64>) -> impl Iterator<Item = Complex64> + '_ {
    (0..m.nrows()).flat_map(move |r| (0..m.ncols()).map(move |c| m[(r, c)]))
}
