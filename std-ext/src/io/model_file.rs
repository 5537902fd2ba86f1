//! The rotorid model file: a TOML description of a rotor-bearing system
//! (see the README, "Model files", for a commented example).
//!
//! Units are SI (m, kg, Pa, N/m, N s/m, kg m) except where a key says
//! otherwise (`rpm`, `phase_deg`). Nodes are numbered from 1, left to
//! right; a shaft of sections with `elements` e_1, e_2, ... has
//! `1 + sum e_i` nodes.
//!
//! ```toml
//! name = "paper"                 # optional, for reports
//! theory = "timoshenko"          # or "euler-bernoulli" (default timoshenko)
//! planes = [5, 11, 21]           # unbalance planes to identify (nodes)
//! probes = "relative"            # bearing probes read the shaft relative to the
//!                                # housing (default) or "absolute" (seismic)
//!
//! [materials.steel]              # any number of named materials
//! e = 200e9                      # Young's modulus (Pa)
//! rho = 7800.0                   # density (kg/m^3)
//! nu = 0.3                       # Poisson's ratio, or `g = ...` (Pa), not both
//!
//! [[shaft]]                      # sections, left to right
//! length = 1.3                   # section length (m)
//! outer_diameter = 0.1           # (m)
//! inner_diameter = 0.0           # (m), optional, default 0 (solid)
//! elements = 26                  # equal elements the section is split into (default 1)
//! material = "steel"
//!
//! [[disk]]                       # from geometry (density from `material` or `rho`) ...
//! node = 5
//! material = "steel"
//! outer_diameter = 0.12
//! inner_diameter = 0.1
//! thickness = 0.05
//! # ... or from inertia: `node = 5, mass = 1.35, id = 2.1e-3, ip = 4.1e-3`
//!
//! [[bearing]]                    # constant coefficients, order yy, yz, zy, zz
//! node = 1
//! k = [5e7, 0.5e7, 1e7, 7e7]     # N/m
//! c = [500.0, 50.0, 100.0, 700.0]  # N s/m
//! # or a table against speed (linear interpolation, held beyond the ends):
//! #   table = { rpm = [0, 15000], k = [[...], [...]], c = [[...], [...]] }
//! # or polynomials in Omega (rad/s): K(Omega) = sum_p k[p] Omega^p
//! #   polynomial = { k = [[0,0,0,0], [0,0,0,0], [k2yy, k2yz, k2zy, k2zz]], c = [[...]] }
//! # optional pedestal (foundation mass) under the bearing:
//! #   pedestal = { mass = 50.0, k = [1e8, 1e8], c = [2e3, 2e3] }   # [y, z]
//! #   (mass in kg: one value for y and z, or [m_y, m_z])
//! # optional two probes, angles (deg) from +y toward +z ([`ProbePair`]):
//! #   probes = [{ name = "1X", angle_deg = 45.0 }, { name = "1Y", angle_deg = -45.0 }]
//!
//! [[unbalance]]                  # optional true unbalance (used by the simulator)
//! node = 5
//! me = 0.0042                    # kg m
//! phase_deg = 0.0
//!
//! [[bow]]                        # optional shaft bow (used by the simulator)
//! node = 14
//! amplitude = 1e-5               # m
//! phase_deg = 0.0
//!
//! [simulate]                     # optional effects for `rotorid simulate`
//! e_scale = 1.03                 # E and G of every shaft element x 1.03
//! bearing_speed_law = { rpm_ref = 15000.0, law = "quadratic" }  # or "linear"
//! pedestal = { mass = 50.0, k = [1e8, 1e8], c = [2e3, 2e3] }  # under every bearing without one
//! runout = [{ channel = "b1_y", amplitude = 2e-6, phase_deg = 30.0 }]
//! probe_gain = [{ channel = "b2_z", factor = 1.1 }]
//! extra_unbalance = [{ node = 14, me = 0.002, phase_deg = 90.0 }]
//! ```
//!
//! Unknown keys are errors, and every error names the field, with 1-based
//! array indices (`bearing[2].node: node 40 is not on the shaft (nodes 1..=27)`).
//! A file with a top-level `ross_version` key is read as a ROSS rotor
//! instead (see [`crate::io::ross`]).

use std::collections::BTreeMap;
use std::path::Path;

use serde::Deserialize;
use thiserror::Error;

use crate::io::ross::RossError;
use crate::model::extension::{Channel, Effects, ProbeGain, Runout, SpeedLaw, SpeedScaling};
use crate::model::plausible::{
    check, check_magnitude, Range, DAMPING_MAX, DENSITY, DIAMETER, INERTIA, LENGTH, MASS, SHEAR,
    STIFFNESS_MAX, YOUNG,
};
use crate::model::{
    BeamTheory, Bearing, BearingCoefficients, BearingLaw, BowPoint, Disk, Material, ModelError,
    Pedestal, ProbePair, ProbeReference, ProportionalDamping, RotorModel, ShaftBow, ShaftElement,
    TableInterpolation, Unbalance,
};
use crate::units::rpm_to_rad_s;

/// Error loading a model file or model name.
#[derive(Debug, Error)]
pub enum ModelFileError {
    /// The file could not be read.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The operating-system error.
        source: std::io::Error,
    },
    /// Not valid TOML.
    #[error("line {line}: {message}")]
    Syntax {
        /// 1-based line of the error.
        line: usize,
        /// The parser's message.
        message: String,
    },
    /// A field is missing, unknown, of the wrong type or out of range.
    #[error("{field}: {reason}")]
    Field {
        /// Dotted path of the field, 1-based array indices (`bearing[2].node`).
        field: String,
        /// What is wrong.
        reason: String,
    },
    /// The assembled model is inconsistent.
    #[error("{0}")]
    Model(#[from] ModelError),
    /// A ROSS file that cannot be read.
    #[error("ROSS file: {0}")]
    Ross(#[from] RossError),
    /// A file ROSS wrote for one element (`BearingElement.save`), not for
    /// a rotor.
    #[error("a ROSS file of one element ([{0}]), not of a rotor: rotorid reads the file of the ross.Rotor that holds it (Rotor.save)")]
    RossElement(String),
    /// Neither a built-in model name nor an existing file.
    #[error(
        "unknown model `{0}`: not a built-in model (paper, paper-speed-dependent) nor a .toml file"
    )]
    UnknownModel(String),
    /// A path (it names a folder or has an extension) to a file that does
    /// not exist.
    #[error("file not found: {0}")]
    NotFound(String),
}

impl ModelFileError {
    fn field(field: impl Into<String>, reason: impl Into<String>) -> Self {
        ModelFileError::Field {
            field: field.into(),
            reason: reason.into(),
        }
    }
}

/// A loaded model file: the rotor and the simulator effects it asks for.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelFile {
    /// The rotor.
    pub model: RotorModel,
    /// Effects of the `[simulate]` section (all off when absent).
    pub effects: Effects,
    /// The probes declared per bearing (bearing order; `None`: the SPEC's
    /// `y`, `z` channels), see [`ProbePair`].
    pub probes: Vec<Option<ProbePair>>,
}

impl ModelFile {
    /// A model with no `[simulate]` effects and no declared probes.
    pub fn plain(model: RotorModel) -> Self {
        let probes = vec![None; model.bearings.len()];
        ModelFile {
            model,
            effects: Effects::default(),
            probes,
        }
    }

    /// True if some bearing declares its probes.
    pub fn has_probes(&self) -> bool {
        self.probes.iter().any(Option::is_some)
    }
}

// ---------------------------------------------------------------------------
// Raw file structures (what serde reads), 1-based nodes.

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFile {
    name: Option<String>,
    theory: Option<String>,
    #[serde(default)]
    materials: BTreeMap<String, RawMaterial>,
    shaft: Vec<RawSection>,
    #[serde(default)]
    disk: Vec<RawDisk>,
    bearing: Vec<RawBearing>,
    #[serde(default)]
    planes: Vec<usize>,
    #[serde(default)]
    unbalance: Vec<RawUnbalance>,
    #[serde(default)]
    bow: Vec<RawBow>,
    probes: Option<String>,
    simulate: Option<RawSimulate>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMaterial {
    e: f64,
    rho: f64,
    nu: Option<f64>,
    g: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSection {
    length: f64,
    outer_diameter: f64,
    #[serde(default)]
    inner_diameter: f64,
    #[serde(default = "one")]
    elements: usize,
    material: String,
}

/// Upper bound on the total number of shaft elements of a model file.
pub const MAX_ELEMENTS: usize = 100_000;

fn one() -> usize {
    1
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawDisk {
    node: usize,
    mass: Option<f64>,
    id: Option<f64>,
    ip: Option<f64>,
    material: Option<String>,
    rho: Option<f64>,
    outer_diameter: Option<f64>,
    inner_diameter: Option<f64>,
    thickness: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawBearing {
    node: usize,
    k: Option<[f64; 4]>,
    c: Option<[f64; 4]>,
    table: Option<RawTable>,
    polynomial: Option<RawPolynomial>,
    pedestal: Option<RawPedestal>,
    probes: Option<Vec<RawProbe>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawProbe {
    name: String,
    angle_deg: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawTable {
    rpm: Vec<f64>,
    k: Vec<[f64; 4]>,
    c: Vec<[f64; 4]>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPolynomial {
    k: Vec<[f64; 4]>,
    c: Vec<[f64; 4]>,
}

/// A pedestal mass: one number for both directions, or `[m_y, m_z]`.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(untagged, expecting = "a mass in kg, or [m_y, m_z] in kg")]
enum RawMass {
    One(f64),
    Two([f64; 2]),
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPedestal {
    mass: RawMass,
    k: [f64; 2],
    c: [f64; 2],
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawUnbalance {
    node: usize,
    me: f64,
    phase_deg: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawBow {
    node: usize,
    amplitude: f64,
    phase_deg: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSimulate {
    e_scale: Option<f64>,
    bearing_speed_law: Option<RawSpeedLaw>,
    pedestal: Option<RawPedestal>,
    #[serde(default)]
    runout: Vec<RawRunout>,
    #[serde(default)]
    probe_gain: Vec<RawProbeGain>,
    #[serde(default)]
    extra_unbalance: Vec<RawUnbalance>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawProbeGain {
    channel: String,
    factor: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSpeedLaw {
    rpm_ref: f64,
    law: String,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawRunout {
    channel: String,
    amplitude: f64,
    phase_deg: f64,
}

// ---------------------------------------------------------------------------

/// Formats a serde path with 1-based sequence indices: `bearing[2].node`.
fn format_path(path: &serde_path_to_error::Path) -> String {
    use serde_path_to_error::Segment;
    let mut out = String::new();
    for seg in path.iter() {
        match seg {
            Segment::Seq { index } => out.push_str(&format!("[{}]", index + 1)),
            Segment::Map { key } => {
                if !out.is_empty() {
                    out.push('.');
                }
                out.push_str(key);
            }
            Segment::Enum { variant } => {
                if !out.is_empty() {
                    out.push('.');
                }
                out.push_str(variant);
            }
            Segment::Unknown => out.push_str(".?"),
        }
    }
    out
}

/// 1-based line of a byte offset.
fn line_of(text: &str, offset: usize) -> usize {
    text.as_bytes()[..offset.min(text.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

/// Deserializes `T` from TOML text; errors name the field path (1-based
/// indices) and the line.
pub(crate) fn deserialize_toml<T: serde::de::DeserializeOwned>(
    text: &str,
) -> Result<T, ModelFileError> {
    let de = toml::Deserializer::parse(text).map_err(|e| ModelFileError::Syntax {
        line: e.span().map(|s| line_of(text, s.start)).unwrap_or(1),
        message: e.message().trim().to_string(),
    })?;
    serde_path_to_error::deserialize(de).map_err(|e| {
        let field = format_path(e.path());
        let inner = e.inner();
        let mut reason = inner.message().trim().replace('\n', " ");
        if let Some(span) = inner.span() {
            reason = format!("{reason} (line {})", line_of(text, span.start));
        }
        if field.is_empty() || field == "." {
            ModelFileError::field("(top level)", reason)
        } else {
            ModelFileError::Field { field, reason }
        }
    })
}

fn finite_pos(field: &str, v: f64) -> Result<f64, ModelFileError> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(ModelFileError::field(
            field,
            format!("must be finite and > 0, got {v}"),
        ))
    }
}

fn finite_nonneg(field: &str, v: f64) -> Result<f64, ModelFileError> {
    if v.is_finite() && v >= 0.0 {
        Ok(v)
    } else {
        Err(ModelFileError::field(
            field,
            format!("must be finite and >= 0, got {v}"),
        ))
    }
}

fn finite(field: &str, v: f64) -> Result<f64, ModelFileError> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(ModelFileError::field(
            field,
            format!("must be finite, got {v}"),
        ))
    }
}

/// A finite value > 0 inside a physically plausible range
/// ([`crate::model::plausible`]).
fn plausible(field: &str, v: f64, range: Range) -> Result<f64, ModelFileError> {
    let v = finite_pos(field, v)?;
    check(v, range).map_err(|reason| ModelFileError::field(field, reason))
}

/// A bearing or pedestal coefficient array of plausible magnitude.
fn plausible4(field: &str, v: &[f64], max: f64, unit: &str) -> Result<(), ModelFileError> {
    for (j, x) in v.iter().enumerate() {
        check_magnitude(*x, max, unit)
            .map_err(|reason| ModelFileError::field(format!("{field}[{}]", j + 1), reason))?;
    }
    Ok(())
}

/// 1-based file node -> 0-based, checked against the node count.
fn node(field: &str, n: usize, n_nodes: usize) -> Result<usize, ModelFileError> {
    if n == 0 || n > n_nodes {
        Err(ModelFileError::field(
            field,
            format!("node {n} is not on the shaft (nodes 1..={n_nodes})"),
        ))
    } else {
        Ok(n - 1)
    }
}

fn pedestal(field: &str, p: &RawPedestal) -> Result<Pedestal, ModelFileError> {
    let mass = match p.mass {
        RawMass::One(m) => {
            let m = finite_pos(&format!("{field}.mass"), m)?;
            let m = plausible(&format!("{field}.mass"), m, MASS)?;
            [m, m]
        }
        RawMass::Two(m) => {
            let mut out = [0.0; 2];
            for j in 0..2 {
                let name = format!("{field}.mass[{}]", j + 1);
                out[j] = plausible(&name, finite_pos(&name, m[j])?, MASS)?;
            }
            out
        }
    };
    let mut k = [0.0; 2];
    let mut c = [0.0; 2];
    for j in 0..2 {
        k[j] = finite_pos(&format!("{field}.k[{}]", j + 1), p.k[j])?;
        c[j] = finite_nonneg(&format!("{field}.c[{}]", j + 1), p.c[j])?;
    }
    plausible4(&format!("{field}.k"), &k, STIFFNESS_MAX, "N/m")?;
    plausible4(&format!("{field}.c"), &c, DAMPING_MAX, "N s/m")?;
    Ok(Pedestal { mass, k, c })
}

fn check4(field: &str, v: &[f64; 4]) -> Result<(), ModelFileError> {
    for (j, x) in v.iter().enumerate() {
        finite(&format!("{field}[{}]", j + 1), *x)?;
    }
    Ok(())
}

fn parse_channel(field: &str, s: &str, n_bearings: usize) -> Result<Channel, ModelFileError> {
    Channel::parse(s, n_bearings).map_err(|reason| ModelFileError::field(field, reason))
}

/// Parses the text of a rotorid model file (not ROSS).
pub fn parse_model_file(text: &str) -> Result<ModelFile, ModelFileError> {
    let raw: RawFile = deserialize_toml(text)?;

    let theory = beam_theory(raw.theory.as_deref())?;
    let materials = materials(&raw.materials)?;
    let shaft = shaft_elements(&raw.shaft, &materials)?;
    let n_nodes = shaft.len() + 1;

    let mut disks = Vec::new();
    for (i, d) in raw.disk.iter().enumerate() {
        disks.push(disk(i, d, n_nodes, &materials)?);
    }

    let (bearings, probes) = bearings(&raw.bearing, n_nodes)?;

    let mut planes = Vec::new();
    for (i, &p) in raw.planes.iter().enumerate() {
        planes.push(node(&format!("planes[{}]", i + 1), p, n_nodes)?);
    }

    let unbalance = raw
        .unbalance
        .iter()
        .enumerate()
        .map(|(i, u)| unbalance_entry(&format!("unbalance[{}]", i + 1), u, n_nodes))
        .collect::<Result<Vec<_>, _>>()?;

    let bow = shaft_bow(&raw.bow, n_nodes)?;
    let probe_reference = probe_reference(raw.probes.as_deref())?;
    let model = RotorModel {
        name: raw.name.unwrap_or_else(|| "model".into()),
        theory,
        shaft,
        disks,
        bearings,
        planes,
        unbalance,
        bow,
        probes: probe_reference,
        rotor_damping: ProportionalDamping::default(),
        shaft_layers: Vec::new(),
    };
    model.validate()?;

    let effects = match &raw.simulate {
        Some(s) => effects(s, model.bearings.len(), n_nodes)?,
        None => Effects::default(),
    };
    Ok(ModelFile {
        model,
        effects,
        probes,
    })
}

/// The top-level `theory` key: Timoshenko (the default) or Euler-Bernoulli.
fn beam_theory(theory: Option<&str>) -> Result<BeamTheory, ModelFileError> {
    match theory {
        None | Some("timoshenko") => Ok(BeamTheory::Timoshenko),
        Some("euler-bernoulli") => Ok(BeamTheory::EulerBernoulli),
        Some(other) => Err(ModelFileError::field(
            "theory",
            format!("unknown beam theory `{other}` (timoshenko, euler-bernoulli)"),
        )),
    }
}

/// The `[materials.<name>]` tables: E, density and either Poisson's ratio
/// or the shear modulus, by name.
fn materials(
    raw: &BTreeMap<String, RawMaterial>,
) -> Result<BTreeMap<String, Material>, ModelFileError> {
    let mut materials = BTreeMap::new();
    for (name, m) in raw {
        let f = |k: &str| format!("materials.{name}.{k}");
        let e = plausible(&f("e"), m.e, YOUNG)?;
        let rho = plausible(&f("rho"), m.rho, DENSITY)?;
        let mat = match (m.nu, m.g) {
            (Some(nu), None) => {
                if !(nu.is_finite() && nu > -1.0 && nu < 0.5) {
                    return Err(ModelFileError::field(
                        f("nu"),
                        format!("Poisson's ratio must be in (-1, 0.5), got {nu}"),
                    ));
                }
                Material::from_e_nu(name.clone(), e, rho, nu)
            }
            (None, Some(g)) => Material {
                name: name.clone(),
                e,
                g: plausible(&f("g"), g, SHEAR)?,
                rho,
            },
            (Some(_), Some(_)) => {
                return Err(ModelFileError::field(
                    f("g"),
                    "give either nu or g, not both",
                ))
            }
            (None, None) => return Err(ModelFileError::field(f("nu"), "missing: give nu or g")),
        };
        materials.insert(name.clone(), mat);
    }
    Ok(materials)
}

/// The material `name` refers to (reported against `field` when it is not
/// defined).
fn material(
    materials: &BTreeMap<String, Material>,
    field: String,
    name: &str,
) -> Result<Material, ModelFileError> {
    materials.get(name).cloned().ok_or_else(|| {
        ModelFileError::field(
            field,
            format!(
                "unknown material `{name}` (defined: {})",
                materials.keys().cloned().collect::<Vec<_>>().join(", ")
            ),
        )
    })
}

/// The `[[shaft]]` sections, each cut into its `elements` equal shaft
/// elements.
fn shaft_elements(
    sections: &[RawSection],
    materials: &BTreeMap<String, Material>,
) -> Result<Vec<ShaftElement>, ModelFileError> {
    if sections.is_empty() {
        return Err(ModelFileError::field("shaft", "needs at least one section"));
    }
    let mut shaft = Vec::new();
    for (i, s) in sections.iter().enumerate() {
        let f = |k: &str| format!("shaft[{}].{k}", i + 1);
        let length = plausible(&f("length"), s.length, LENGTH)?;
        let od = plausible(&f("outer_diameter"), s.outer_diameter, DIAMETER)?;
        let id = finite_nonneg(&f("inner_diameter"), s.inner_diameter)?;
        if id >= od {
            return Err(ModelFileError::field(
                f("inner_diameter"),
                format!("must be smaller than outer_diameter ({od}), got {id}"),
            ));
        }
        if s.elements == 0 || s.elements > 100_000 {
            return Err(ModelFileError::field(
                f("elements"),
                format!("must be in 1..=100000, got {}", s.elements),
            ));
        }
        if shaft.len() + s.elements > MAX_ELEMENTS {
            return Err(ModelFileError::field(
                f("elements"),
                format!("more than {MAX_ELEMENTS} shaft elements in all"),
            ));
        }
        if length / (s.elements as f64) < LENGTH.lo {
            return Err(ModelFileError::field(
                f("elements"),
                format!(
                    "{} elements of {length:e} m are shorter than {:e} m each",
                    s.elements, LENGTH.lo
                ),
            ));
        }
        let mat = material(materials, f("material"), &s.material)?;
        for _ in 0..s.elements {
            shaft.push(ShaftElement {
                length: length / s.elements as f64,
                outer_diameter: od,
                inner_diameter: id,
                material: mat.clone(),
            });
        }
    }
    Ok(shaft)
}

/// The `i`-th (0-based) `[[disk]]`: given by its mass and inertias, or by
/// its geometry and a density.
fn disk(
    i: usize,
    d: &RawDisk,
    n_nodes: usize,
    materials: &BTreeMap<String, Material>,
) -> Result<Disk, ModelFileError> {
    let f = |k: &str| format!("disk[{}].{k}", i + 1);
    let n = node(&f("node"), d.node, n_nodes)?;
    let geometry = d.outer_diameter.is_some() || d.thickness.is_some();
    let inertia = d.mass.is_some() || d.id.is_some() || d.ip.is_some();
    match (geometry, inertia) {
        (true, true) => Err(ModelFileError::field(
            f("mass"),
            "give either geometry (outer_diameter, thickness, ...) or mass/id/ip, not both",
        )),
        (false, false) => Err(ModelFileError::field(
            f("mass"),
            "missing: give mass, id, ip or outer_diameter, thickness and a density",
        )),
        (false, true) => disk_from_inertia(&f, n, d),
        (true, false) => disk_from_geometry(&f, n, d, materials),
    }
}

/// A disk given by `mass`, `id` and `ip` (fields named by `f`).
fn disk_from_inertia(
    f: &impl Fn(&str) -> String,
    n: usize,
    d: &RawDisk,
) -> Result<Disk, ModelFileError> {
    let get = |k: &str, v: Option<f64>| -> Result<f64, ModelFileError> {
        let range = if k == "mass" { MASS } else { INERTIA };
        match v {
            Some(v) => plausible(&f(k), v, range),
            None => Err(ModelFileError::field(f(k), "missing")),
        }
    };
    if d.material.is_some() || d.rho.is_some() || d.inner_diameter.is_some() {
        return Err(ModelFileError::field(
            f("material"),
            "only used with the geometry form (outer_diameter, thickness)",
        ));
    }
    Ok(Disk {
        node: n,
        mass: get("mass", d.mass)?,
        id: get("id", d.id)?,
        ip: get("ip", d.ip)?,
    })
}

/// A disk given by `outer_diameter`, `thickness`, an optional
/// `inner_diameter` and a `material` or `rho` (fields named by `f`).
fn disk_from_geometry(
    f: &impl Fn(&str) -> String,
    n: usize,
    d: &RawDisk,
    materials: &BTreeMap<String, Material>,
) -> Result<Disk, ModelFileError> {
    let od = match d.outer_diameter {
        Some(v) => plausible(&f("outer_diameter"), v, DIAMETER)?,
        None => return Err(ModelFileError::field(f("outer_diameter"), "missing")),
    };
    let t = match d.thickness {
        Some(v) => plausible(&f("thickness"), v, DIAMETER)?,
        None => return Err(ModelFileError::field(f("thickness"), "missing")),
    };
    let id = finite_nonneg(&f("inner_diameter"), d.inner_diameter.unwrap_or(0.0))?;
    if id >= od {
        return Err(ModelFileError::field(
            f("inner_diameter"),
            format!("must be smaller than outer_diameter ({od}), got {id}"),
        ));
    }
    let rho = match (&d.material, d.rho) {
        (Some(m), None) => material(materials, f("material"), m)?.rho,
        (None, Some(r)) => plausible(&f("rho"), r, DENSITY)?,
        (Some(_), Some(_)) => {
            return Err(ModelFileError::field(
                f("rho"),
                "give either material or rho, not both",
            ))
        }
        (None, None) => {
            return Err(ModelFileError::field(
                f("material"),
                "missing: give material or rho for a disk from geometry",
            ))
        }
    };
    Ok(Disk::from_geometry(n, rho, od, id, t))
}

/// The `[[bearing]]` tables, sorted by node, with their declared probes in
/// the same order (channel names checked unique).
fn bearings(
    raw: &[RawBearing],
    n_nodes: usize,
) -> Result<(Vec<Bearing>, Vec<Option<ProbePair>>), ModelFileError> {
    if raw.is_empty() {
        return Err(ModelFileError::field(
            "bearing",
            "needs at least one bearing",
        ));
    }
    let mut bearings = Vec::new();
    let mut probe_pairs = Vec::new();
    for (i, b) in raw.iter().enumerate() {
        let f = |k: &str| format!("bearing[{}].{k}", i + 1);
        let pair = match &b.probes {
            Some(p) => Some(probe_pair(&f("probes"), p)?),
            None => None,
        };
        probe_pairs.push((b.node, i, pair));
        let n = node(&f("node"), b.node, n_nodes)?;
        let law = bearing_law(&f, b)?;
        let ped = match &b.pedestal {
            Some(p) => Some(pedestal(&f("pedestal"), p)?),
            None => None,
        };
        bearings.push(Bearing {
            node: n,
            law,
            pedestal: ped,
        });
    }
    bearings.sort_by_key(|b| b.node);
    probe_pairs.sort_by_key(|p| p.0);
    unique_channel_names(&probe_pairs)?;
    let probes: Vec<Option<ProbePair>> = probe_pairs.into_iter().map(|p| p.2).collect();
    Ok((bearings, probes))
}

/// A bearing's law: constant `k` and `c`, a `table` over speed or a
/// `polynomial` (fields named by `f`).
fn bearing_law(f: &impl Fn(&str) -> String, b: &RawBearing) -> Result<BearingLaw, ModelFileError> {
    Ok(match (&b.k, &b.c, &b.table, &b.polynomial) {
        (Some(k), Some(c), None, None) => {
            check4(&f("k"), k)?;
            check4(&f("c"), c)?;
            plausible4(&f("k"), k, STIFFNESS_MAX, "N/m")?;
            plausible4(&f("c"), c, DAMPING_MAX, "N s/m")?;
            BearingLaw::Constant(BearingCoefficients { k: *k, c: *c })
        }
        (None, None, Some(t), None) => bearing_table(f, t)?,
        (None, None, None, Some(p)) => {
            if p.k.is_empty() && p.c.is_empty() {
                return Err(ModelFileError::field(
                    f("polynomial"),
                    "k and c are both empty",
                ));
            }
            for (j, row) in p.k.iter().enumerate() {
                check4(&f(&format!("polynomial.k[{}]", j + 1)), row)?;
            }
            for (j, row) in p.c.iter().enumerate() {
                check4(&f(&format!("polynomial.c[{}]", j + 1)), row)?;
            }
            BearingLaw::Polynomial {
                k: p.k.clone(),
                c: p.c.clone(),
            }
        }
        (Some(_), None, None, None) => {
            return Err(ModelFileError::field(f("c"), "missing (k given without c)"))
        }
        (None, Some(_), None, None) => {
            return Err(ModelFileError::field(f("k"), "missing (c given without k)"))
        }
        (None, None, None, None) => {
            return Err(ModelFileError::field(
                f("k"),
                "missing: give k and c, or a table, or a polynomial",
            ))
        }
        _ => {
            return Err(ModelFileError::field(
                f("table"),
                "give exactly one of: k and c, table, polynomial",
            ))
        }
    })
}

/// A bearing's `table`: coefficients at strictly increasing speeds (rpm),
/// interpolated linearly and held beyond the ends.
fn bearing_table(f: &impl Fn(&str) -> String, t: &RawTable) -> Result<BearingLaw, ModelFileError> {
    if t.rpm.is_empty() || t.rpm.len() != t.k.len() || t.rpm.len() != t.c.len() {
        return Err(ModelFileError::field(
            f("table"),
            format!(
                "rpm, k and c need the same non-zero length (got {}, {}, {})",
                t.rpm.len(),
                t.k.len(),
                t.c.len()
            ),
        ));
    }
    for (j, r) in t.rpm.iter().enumerate() {
        finite_nonneg(&f(&format!("table.rpm[{}]", j + 1)), *r)?;
        if j > 0 && *r <= t.rpm[j - 1] {
            return Err(ModelFileError::field(
                f(&format!("table.rpm[{}]", j + 1)),
                "speeds must be strictly increasing",
            ));
        }
    }
    let mut coefficients = Vec::new();
    for (j, (k, c)) in t.k.iter().zip(t.c.iter()).enumerate() {
        check4(&f(&format!("table.k[{}]", j + 1)), k)?;
        check4(&f(&format!("table.c[{}]", j + 1)), c)?;
        plausible4(&f(&format!("table.k[{}]", j + 1)), k, STIFFNESS_MAX, "N/m")?;
        plausible4(&f(&format!("table.c[{}]", j + 1)), c, DAMPING_MAX, "N s/m")?;
        coefficients.push(BearingCoefficients { k: *k, c: *c });
    }
    Ok(BearingLaw::Table {
        speeds: t.rpm.iter().map(|&r| rpm_to_rad_s(r)).collect(),
        coefficients,
        interpolation: TableInterpolation::LinearHold,
    })
}

/// Channel names must be unique over the model (the file's columns): the
/// declared probe names and the `b<K>_y`, `b<K>_z` of bearings without
/// probes. `probe_pairs` holds (node, 0-based file index, probes) in node
/// order.
fn unique_channel_names(
    probe_pairs: &[(usize, usize, Option<ProbePair>)],
) -> Result<(), ModelFileError> {
    let mut seen: Vec<String> = Vec::new();
    for (b, (_, i, pair)) in probe_pairs.iter().enumerate() {
        let names: Vec<(String, String)> = match pair {
            Some(p) => p
                .names
                .iter()
                .enumerate()
                .map(|(j, n)| {
                    (
                        n.clone(),
                        format!("bearing[{}].probes[{}].name", i + 1, j + 1),
                    )
                })
                .collect(),
            None => ["y", "z"]
                .iter()
                .map(|d| (format!("b{}_{d}", b + 1), format!("bearing[{}]", i + 1)))
                .collect(),
        };
        for (n, field) in names {
            if seen.contains(&n) {
                return Err(ModelFileError::field(
                    field,
                    format!("channel name \"{n}\" is used twice (probe names and the b<K>_y, b<K>_z of bearings without probes must differ)"),
                ));
            }
            seen.push(n);
        }
    }
    Ok(())
}

/// The `[[bow]]` points, sorted by node (`None` when there are none).
fn shaft_bow(raw: &[RawBow], n_nodes: usize) -> Result<Option<ShaftBow>, ModelFileError> {
    if raw.is_empty() {
        return Ok(None);
    }
    let mut points = Vec::new();
    for (i, p) in raw.iter().enumerate() {
        let f = |k: &str| format!("bow[{}].{k}", i + 1);
        points.push(BowPoint {
            node: node(&f("node"), p.node, n_nodes)?,
            amplitude: finite(&f("amplitude"), p.amplitude)?,
            phase: finite(&f("phase_deg"), p.phase_deg)?.to_radians(),
        });
    }
    points.sort_by_key(|p| p.node);
    Ok(Some(ShaftBow { points }))
}

/// The top-level `probes` key: relative (the default) or absolute.
fn probe_reference(probes: Option<&str>) -> Result<ProbeReference, ModelFileError> {
    match probes {
        None | Some("relative") => Ok(ProbeReference::Relative),
        Some("absolute") => Ok(ProbeReference::Absolute),
        Some(other) => Err(ModelFileError::field(
            "probes",
            format!("expected \"relative\" or \"absolute\", got \"{other}\""),
        )),
    }
}

/// The `[simulate]` section's effects, for a model of `n_bearings`
/// bearings and `n_nodes` nodes.
fn effects(s: &RawSimulate, n_bearings: usize, n_nodes: usize) -> Result<Effects, ModelFileError> {
    let mut effects = Effects::default();
    if let Some(e) = s.e_scale {
        effects.e_scale = plausible(
            "simulate.e_scale",
            e,
            Range {
                lo: 1e-3,
                hi: 1e3,
                unit: "(factor)",
            },
        )?;
    }
    if let Some(l) = &s.bearing_speed_law {
        let rpm_ref = finite_pos("simulate.bearing_speed_law.rpm_ref", l.rpm_ref)?;
        let law = match l.law.as_str() {
            "quadratic" => SpeedLaw::Quadratic,
            "linear" => SpeedLaw::Linear,
            other => {
                return Err(ModelFileError::field(
                    "simulate.bearing_speed_law.law",
                    format!("unknown law `{other}` (quadratic, linear)"),
                ))
            }
        };
        effects.bearing_speed_law = Some(SpeedScaling { rpm_ref, law });
    }
    if let Some(p) = &s.pedestal {
        effects.pedestal = Some(pedestal("simulate.pedestal", p)?);
    }
    for (i, r) in s.runout.iter().enumerate() {
        let f = |k: &str| format!("simulate.runout[{}].{k}", i + 1);
        effects.runout.push(Runout {
            channel: parse_channel(&f("channel"), &r.channel, n_bearings)?,
            amplitude: finite_nonneg(&f("amplitude"), r.amplitude)?,
            phase: finite(&f("phase_deg"), r.phase_deg)?.to_radians(),
        });
    }
    for (i, g) in s.probe_gain.iter().enumerate() {
        let f = |k: &str| format!("simulate.probe_gain[{}].{k}", i + 1);
        effects.probe_gain.push(ProbeGain {
            channel: parse_channel(&f("channel"), &g.channel, n_bearings)?,
            factor: finite_pos(&f("factor"), g.factor)?,
        });
    }
    for (i, u) in s.extra_unbalance.iter().enumerate() {
        effects.extra_unbalance.push(unbalance_entry(
            &format!("simulate.extra_unbalance[{}]", i + 1),
            u,
            n_nodes,
        )?);
    }
    Ok(effects)
}

/// Longest probe name.
const MAX_PROBE_NAME: usize = 32;

/// A bearing's `probes = [{ name, angle_deg }, { name, angle_deg }]`:
/// exactly two, names of 1 to 32 ASCII letters, digits, `_` or `-`,
/// finite angles within +-360 deg whose axes are at least
/// [`ProbePair::MIN_SEPARATION_DEG`] apart (mod 180 deg).
fn probe_pair(field: &str, raw: &[RawProbe]) -> Result<ProbePair, ModelFileError> {
    if raw.len() != 2 {
        return Err(ModelFileError::field(
            field,
            format!(
                "expected 2 probes (two non-parallel axes give y and z), got {}",
                raw.len()
            ),
        ));
    }
    let mut names = [String::new(), String::new()];
    let mut angles = [0.0; 2];
    for (j, p) in raw.iter().enumerate() {
        let f = |k: &str| format!("{field}[{}].{k}", j + 1);
        let ok = !p.name.is_empty()
            && p.name.len() <= MAX_PROBE_NAME
            && p.name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
        if !ok {
            return Err(ModelFileError::field(
                f("name"),
                format!(
                    "\"{}\": 1 to {MAX_PROBE_NAME} ASCII letters, digits, '_' or '-' (it names the file's columns)",
                    crate::io::clip(&p.name)
                ),
            ));
        }
        let a = finite(&f("angle_deg"), p.angle_deg)?;
        if a.abs() > 360.0 {
            return Err(ModelFileError::field(
                f("angle_deg"),
                format!("{a} deg is outside -360..=360"),
            ));
        }
        names[j] = p.name.clone();
        angles[j] = a.to_radians();
    }
    if names[0] == names[1] {
        return Err(ModelFileError::field(
            format!("{field}[2].name"),
            format!("\"{}\" is the name of probes[1] too", names[1]),
        ));
    }
    let pair = ProbePair { names, angles };
    let separation = pair.determinant().abs().asin().to_degrees();
    if separation < ProbePair::MIN_SEPARATION_DEG {
        return Err(ModelFileError::field(
            format!("{field}[2].angle_deg"),
            format!(
                "{} deg is parallel to probes[1] at {} deg within {separation:.2} deg: the axes must be at least {} deg apart to give y and z",
                raw[1].angle_deg,
                raw[0].angle_deg,
                ProbePair::MIN_SEPARATION_DEG
            ),
        ));
    }
    Ok(pair)
}

fn unbalance_entry(
    field: &str,
    u: &RawUnbalance,
    n_nodes: usize,
) -> Result<Unbalance, ModelFileError> {
    Ok(Unbalance {
        node: node(&format!("{field}.node"), u.node, n_nodes)?,
        me: finite_nonneg(&format!("{field}.me"), u.me)?,
        phase: finite(&format!("{field}.phase_deg"), u.phase_deg)?.to_radians(),
    })
}

/// True if the TOML text is a ROSS rotor: a top-level `ross_version` key,
/// or (older ROSS files, saved without it) a top-level `ShaftElement_*`
/// table.
pub fn is_ross(text: &str) -> bool {
    match toml::from_str::<toml::Table>(text) {
        Ok(t) => t.contains_key("ross_version") || t.keys().any(|k| k.starts_with("ShaftElement_")),
        Err(_) => false,
    }
}

/// The table name when the TOML text is a file ROSS wrote for a single
/// element (`element.save(path)`: one top-level table
/// `<ElementClass>_<tag>` holding the element's node `n`), not a rotor.
pub fn ross_element_file(text: &str) -> Option<String> {
    let t = toml::from_str::<toml::Table>(text).ok()?;
    let mut keys = t.iter();
    let (key, value) = keys.next()?;
    let class = key.split('_').next()?;
    let single = keys.next().is_none();
    let element = class.ends_with("Element")
        || ["Seal", "Bearing", "Damper", "Pad", "Disk"]
            .iter()
            .any(|k| class.ends_with(k));
    (single && element && value.as_table().is_some_and(|v| v.contains_key("n")))
        .then(|| key.clone())
}

/// Loads a model file, own format or ROSS (detected by its `ross_version`
/// key), with the `[simulate]` effects (none for ROSS files).
pub fn load_model_file(path: impl AsRef<Path>) -> Result<ModelFile, ModelFileError> {
    let path = path.as_ref();
    let text = std::fs::read_to_string(path).map_err(|source| ModelFileError::Io {
        path: path.display().to_string(),
        source,
    })?;
    if is_ross(&text) {
        Ok(ModelFile::plain(crate::io::ross::parse_ross(&text)?))
    } else if let Some(table) = ross_element_file(&text) {
        Err(ModelFileError::RossElement(table))
    } else {
        parse_model_file(&text)
    }
}

/// Loads a model file (own format or ROSS).
pub fn load_model(path: impl AsRef<Path>) -> Result<RotorModel, ModelFileError> {
    Ok(load_model_file(path)?.model)
}

/// A built-in model by name: `paper` (the method paper's reference rotor) or
/// `paper-speed-dependent` (Eq. 49).
pub fn builtin_model(name: &str) -> Option<RotorModel> {
    match name {
        "paper" => Some(RotorModel::paper()),
        "paper-speed-dependent" => Some(RotorModel::paper_speed_dependent()),
        _ => None,
    }
}

/// The model named `paper` (or another built-in), else the file at that
/// path, with its `[simulate]` effects.
pub fn model_file_by_name_or_path(name_or_path: &str) -> Result<ModelFile, ModelFileError> {
    if let Some(model) = builtin_model(name_or_path) {
        return Ok(ModelFile::plain(model));
    }
    let p = Path::new(name_or_path);
    if !p.exists() {
        // `dir/x`, `x.toml`: meant as a file; a bare word: meant as a name.
        let looks_like_path = p.components().count() > 1 || p.extension().is_some();
        return Err(if looks_like_path {
            ModelFileError::NotFound(name_or_path.to_string())
        } else {
            ModelFileError::UnknownModel(name_or_path.to_string())
        });
    }
    load_model_file(p)
}

/// The model named `paper` (or another built-in), else the file at that path.
pub fn model_by_name_or_path(name_or_path: &str) -> Result<RotorModel, ModelFileError> {
    Ok(model_file_by_name_or_path(name_or_path)?.model)
}

#[cfg(test)]
mod tests {
    use super::*;

    const MINI: &str = r#"
[materials.steel]
e = 200e9
rho = 7800.0
nu = 0.3

[[shaft]]
length = 1.0
outer_diameter = 0.05
elements = 4
material = "steel"

[[bearing]]
node = 1
k = [1e7, 0, 0, 1e7]
c = [100, 0, 0, 100]

[[bearing]]
node = 5
k = [1e7, 0, 0, 1e7]
c = [100, 0, 0, 100]
"#;

    #[test]
    fn minimal_file_loads() {
        let m = parse_model_file(MINI).unwrap().model;
        assert_eq!(m.n_nodes(), 5);
        assert_eq!(m.bearing_nodes(), vec![0, 4]);
        assert_eq!(m.theory, BeamTheory::Timoshenko);
    }

    #[test]
    fn errors_name_the_field() {
        let e = parse_model_file(&MINI.replace("node = 5", "node = 40"))
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "bearing[2].node: node 40 is not on the shaft (nodes 1..=5)"
        );
        let e = parse_model_file(&MINI.replace("node = 5", "nod = 5"))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("bearing[2].nod: unknown field `nod`"), "{e}");
        let e = parse_model_file(&MINI.replace("length = 1.0", "length = -1.0"))
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("shaft[1].length: must be finite and > 0"),
            "{e}"
        );
        let e = parse_model_file(&MINI.replace("node = 5\n", ""))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("bearing[2]: missing field `node`"), "{e}");
    }
}
