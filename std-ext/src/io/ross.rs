//! Reading (and writing) rotors in the TOML format of ROSS, the Python
//! rotordynamics package (`Rotor.save`, formats 2.x and 3.x: a top-level
//! `ross_version` key, a `[parameters]` table and one table per element
//! named `"<Class>_<tag>"`, holding the arguments of the element's
//! constructor; older files without `ross_version` are recognised by their
//! `ShaftElement_*` tables). Every key ROSS writes is either honoured,
//! ignored because it has no effect here (`tag`, `color`, `scale_factor`,
//! axial `kzz`, `czz`, `mz`, `default_damping_ratio`, `min_w`, `max_w`,
//! `rated_w`), or refused with the element's name and a reason.
//!
//! # Mapping
//!
//! - **Axes.** ROSS's rotor axis is z, with transverse axes x and y; ours is
//!   x with transverse y and z. The map is the cyclic permutation
//!   `ROSS (x, y, z) -> ours (y, z, x)`, which keeps the frame right-handed
//!   and the sense of rotation: ROSS `kxx, kxy, kyx, kyy` are our
//!   `kyy, kyz, kzy, kzz` (same for damping). Phasors are the same
//!   (`x(t) = Re{X e^(j Omega t)}`), so ROSS's response `X`, `Y` at a node
//!   are our `Y`, `Z`.
//! - **Nodes.** ROSS numbers nodes from 0, as our code does internally
//!   (our files and reports show them + 1). ROSS shaft element `n` joins
//!   nodes `n` and `n + 1`; element `n` becomes our shaft element `n`.
//! - **Shaft elements** (`ShaftElement_*`: `L`, `idl`, `odl`, `idr`, `odr`,
//!   `n`, `material = {name, rho, E, G_s, Poisson, color}`, `shear_effects`,
//!   `rotary_inertia`, `gyroscopic`, `shear_method_calc`, `alpha`, `beta`,
//!   `axial_force`, `torque`): `shear_effects = true` -> Timoshenko (with
//!   Cowper's shear coefficient, ROSS's `"cowper"`), `false` ->
//!   Euler-Bernoulli; all elements must agree. Several elements with the
//!   same `n` are coaxial layers: the innermost is the element, the others
//!   [`ShaftLayer`]s whose matrices are added to it (as ROSS sums them; any
//!   materials). **Refused**: tapered elements (`idl != idr` or
//!   `odl != odr`; split them into uniform elements in ROSS first),
//!   per-element damping (`alpha`, `beta` non-zero), axial force, torque,
//!   `rotary_inertia = false`, `gyroscopic = false`, a shear method other
//!   than Cowper's.
//! - **Rotor damping** (`[parameters] alpha` (1/s), `beta` (s)): ROSS's
//!   `C0 = alpha M0 + beta K0` over shaft, disks and point masses becomes
//!   [`RotorModel::rotor_damping`] (shaft and disks) plus `alpha m` added
//!   to the damping to ground of each pedestal mass. The response and
//!   Campbell analyses include it; the reduction used for identification
//!   refuses it. `modal_damping_ratio` is refused.
//! - **Disks** (`DiskElement_*`: `n`, `m`, `Id`, `Ip`): as given; `Id = Ip
//!   = 0` is a mass without rotary inertia (ROSS's compressor example has
//!   one).
//! - **Bearings** (`BearingElement_*`: `n`, `kxx`, `kxy`, `kyx`, `kyy`,
//!   `cxx`, ... as arrays (length 1: constant) over `speed` (rotor speed,
//!   rad/s; ROSS 3), `frequency` (whirl frequency in ROSS 3, speed in ROSS
//!   2) or `w`, `interpolation`, `n_link`, and the mass coefficients `mxx`,
//!   ...): one value -> [`BearingLaw::Constant`]; arrays -> a
//!   [`BearingLaw::Table`] evaluated at the rotor speed. Every analysis here
//!   is synchronous (whirl frequency = speed), where ROSS's `speed` and
//!   `frequency` tables give the same numbers; a table on both axes is
//!   refused. `interpolation = "pchip"` -> [`TableInterpolation::Pchip`]
//!   (ROSS 3's default: PCHIP inside, linear extrapolation with the end
//!   slopes beyond), `"linear"` -> [`TableInterpolation::LinearExtrapolate`],
//!   no key (ROSS 2.x) -> [`TableInterpolation::LinearHold`].
//!   `kyy`/`cyy` default to `kxx`/`cxx` as in ROSS. Non-zero bearing mass
//!   coefficients are refused. Magnetic bearings, which ROSS saves as
//!   `BearingElement_*` with controller keys (`ag`, `g0`, `i0`, `k_amp`,
//!   `kp_pid`, ...), are refused by those keys.
//! - **Pedestals.** The ROSS pattern "bearing at shaft node s with
//!   `n_link = p`, a `PointMass` at node p, and a bearing at node p (no
//!   link) to ground" becomes a bearing at s on a [`Pedestal`] (masses
//!   `[mx, my]` in our y, z, or `m` in both when only `m` is given, as
//!   ROSS's `PointMass` reads its arguments; the axial `mz` is ignored;
//!   stiffness `[kxx, kyy]` and damping `[cxx, cyy]` of the ground
//!   bearing, which must be constant with no cross-coupling). Any other
//!   use of `n_link` or `PointMass` is refused.
//! - **Unbalance planes.** A ROSS rotor carries none; the disk nodes are
//!   taken as the planes to identify.
//! - Every other class (seals, magnetic, ball/roller, fluid-film bearings,
//!   couplings, gears, 6-DOF elements, ...) is refused with an error that
//!   names the element.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use serde::Deserialize;
use thiserror::Error;

use crate::model::plausible::{
    check, check_inertia, Range, DENSITY, DIAMETER, LENGTH, MASS, SHEAR, YOUNG,
};
use crate::model::{
    BeamTheory, Bearing, BearingCoefficients, BearingLaw, Disk, Material, ModelError, Pedestal,
    ProportionalDamping, RotorModel, ShaftElement, ShaftLayer, TableInterpolation,
};

/// Error reading a ROSS rotor file, naming the element.
#[derive(Debug, Error)]
pub enum RossError {
    /// Not valid TOML, or not a ROSS rotor.
    #[error("{0}")]
    Format(String),
    /// An element with a missing or ill-typed field.
    #[error("{element}: {reason}")]
    Field {
        /// The element's table name, e.g. `BearingElement_Bearing 0`.
        element: String,
        /// What is wrong.
        reason: String,
    },
    /// An element that rotorid does not model.
    #[error("{element}: not supported: {reason}")]
    Unsupported {
        /// The element's table name.
        element: String,
        /// Why.
        reason: String,
    },
    /// The assembled model is inconsistent.
    #[error("{0}")]
    Model(#[from] ModelError),
}

fn unsupported(element: &str, reason: impl Into<String>) -> RossError {
    RossError::Unsupported {
        element: element.to_string(),
        reason: reason.into(),
    }
}

/// A coefficient: a number or an array of numbers.
#[derive(Debug, Clone, Deserialize)]
#[serde(untagged)]
enum OneOrMany {
    One(f64),
    Many(Vec<f64>),
}

impl OneOrMany {
    fn values(&self) -> Vec<f64> {
        match self {
            OneOrMany::One(v) => vec![*v],
            OneOrMany::Many(v) => v.clone(),
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(non_snake_case, dead_code)]
struct RossShaft {
    L: f64,
    idl: f64,
    odl: f64,
    idr: Option<f64>,
    odr: Option<f64>,
    n: usize,
    material: RossMaterial,
    axial_force: Option<f64>,
    torque: Option<f64>,
    shear_effects: Option<bool>,
    rotary_inertia: Option<bool>,
    gyroscopic: Option<bool>,
    shear_method_calc: Option<String>,
    tag: Option<String>,
    alpha: Option<f64>,
    beta: Option<f64>,
}

#[derive(Debug, Clone, Deserialize)]
#[allow(non_snake_case)]
struct RossMaterial {
    name: Option<String>,
    rho: f64,
    E: f64,
    G_s: Option<f64>,
    Poisson: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(non_snake_case, dead_code)]
struct RossDisk {
    n: usize,
    m: f64,
    Id: f64,
    Ip: f64,
    tag: Option<String>,
    scale_factor: Option<f64>,
    color: Option<String>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(dead_code)]
struct RossBearing {
    n: usize,
    kxx: OneOrMany,
    cxx: OneOrMany,
    kyy: Option<OneOrMany>,
    cyy: Option<OneOrMany>,
    kxy: Option<OneOrMany>,
    kyx: Option<OneOrMany>,
    cxy: Option<OneOrMany>,
    cyx: Option<OneOrMany>,
    kzz: Option<OneOrMany>,
    czz: Option<OneOrMany>,
    mxx: Option<OneOrMany>,
    mxy: Option<OneOrMany>,
    myx: Option<OneOrMany>,
    myy: Option<OneOrMany>,
    mzz: Option<OneOrMany>,
    frequency: Option<Vec<f64>>,
    speed: Option<Vec<f64>>,
    w: Option<Vec<f64>>,
    n_link: Option<usize>,
    tag: Option<String>,
    scale_factor: Option<f64>,
    color: Option<String>,
    interpolation: Option<String>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(dead_code)]
struct RossPointMass {
    n: usize,
    m: Option<f64>,
    mx: Option<f64>,
    my: Option<f64>,
    mz: Option<f64>,
    tag: Option<String>,
    scale_factor: Option<f64>,
    color: Option<String>,
}

/// The rotor-level `[parameters]` table of ROSS 3 files.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(dead_code)]
struct RossParameters {
    default_damping_ratio: Option<f64>,
    modal_damping_ratio: Option<toml::Value>,
    alpha: Option<f64>,
    beta: Option<f64>,
    min_w: Option<f64>,
    max_w: Option<f64>,
    rated_w: Option<f64>,
}

/// Keys that ROSS's `MagneticBearingElement` adds to the bearing table it
/// saves under the `BearingElement_*` class name.
const MAGNETIC_KEYS: [&str; 13] = [
    "ag",
    "g0",
    "i0",
    "nw",
    "k_amp",
    "k_sense",
    "kp_pid",
    "ki_pid",
    "kd_pid",
    "n_f",
    "sensor_node",
    "sensors_axis_rotation",
    "alpha",
];

fn element<T: serde::de::DeserializeOwned>(name: &str, v: &toml::Value) -> Result<T, RossError> {
    serde_path_to_error::deserialize(v.clone()).map_err(|e| {
        let path = e.path().to_string();
        let msg = e.inner().message().trim().replace('\n', " ");
        RossError::Field {
            element: name.to_string(),
            reason: if path == "." {
                msg
            } else {
                format!("{path}: {msg}")
            },
        }
    })
}

/// A bearing's law from ROSS coefficients, in our axes.
fn bearing_law(name: &str, b: &RossBearing) -> Result<BearingLaw, RossError> {
    for (key, m) in [
        ("mxx", &b.mxx),
        ("mxy", &b.mxy),
        ("myx", &b.myx),
        ("myy", &b.myy),
    ] {
        if let Some(m) = m {
            if m.values().iter().any(|v| *v != 0.0) {
                return Err(unsupported(
                    name,
                    format!("bearing mass coefficients ({key} non-zero)"),
                ));
            }
        }
    }
    let kxx = b.kxx.values();
    let cxx = b.cxx.values();
    let get = |v: &Option<OneOrMany>, default: &[f64]| -> Vec<f64> {
        match v {
            Some(x) => x.values(),
            None => default.to_vec(),
        }
    };
    let zeros = vec![0.0; kxx.len().max(1)];
    // ROSS order xx, xy, yx, yy == ours yy, yz, zy, zz.
    let k = [
        kxx.clone(),
        get(&b.kxy, &zeros),
        get(&b.kyx, &zeros),
        get(&b.kyy, &kxx),
    ];
    let c = [
        cxx.clone(),
        get(&b.cxy, &zeros),
        get(&b.cyx, &zeros),
        get(&b.cyy, &cxx),
    ];
    let speeds = match (&b.frequency, &b.speed, &b.w) {
        (Some(f), None, None) | (None, Some(f), None) | (None, None, Some(f)) => Some(f.clone()),
        (None, None, None) => None,
        _ => {
            return Err(RossError::Field {
                element: name.into(),
                reason: "give only one of frequency, speed, w".into(),
            })
        }
    };
    let interpolation = match b.interpolation.as_deref() {
        // ROSS 2.x files carry no key: rotorid's linear table, held beyond.
        None => TableInterpolation::LinearHold,
        Some("pchip") => TableInterpolation::Pchip,
        Some("linear") => TableInterpolation::LinearExtrapolate,
        Some(other) => {
            return Err(RossError::Field {
                element: name.into(),
                reason: format!("interpolation = \"{other}\" (expected \"pchip\" or \"linear\")"),
            })
        }
    };
    // Length of each coefficient array: 1 (constant) or the table length.
    let n = match &speeds {
        Some(s) => s.len(),
        None => 1,
    };
    let expand = |v: &Vec<f64>, key: &str| -> Result<Vec<f64>, RossError> {
        if v.len() == n {
            Ok(v.clone())
        } else if v.len() == 1 {
            Ok(vec![v[0]; n])
        } else {
            Err(RossError::Field {
                element: name.into(),
                reason: format!(
                    "{key} has {} values, expected 1 or {n} (the length of frequency)",
                    v.len()
                ),
            })
        }
    };
    let keys_k = ["kxx", "kxy", "kyx", "kyy"];
    let keys_c = ["cxx", "cxy", "cyx", "cyy"];
    let mut kk = Vec::new();
    let mut cc = Vec::new();
    for j in 0..4 {
        kk.push(expand(&k[j], keys_k[j])?);
        cc.push(expand(&c[j], keys_c[j])?);
    }
    let at = |i: usize| BearingCoefficients {
        k: [kk[0][i], kk[1][i], kk[2][i], kk[3][i]],
        c: [cc[0][i], cc[1][i], cc[2][i], cc[3][i]],
    };
    if n == 0 {
        return Err(RossError::Field {
            element: name.into(),
            reason: "empty coefficient arrays".into(),
        });
    }
    match speeds {
        None => Ok(BearingLaw::Constant(at(0))),
        Some(s) if s.len() == 1 => Ok(BearingLaw::Constant(at(0))),
        Some(s) => {
            if s.iter().any(|x| !x.is_finite() || *x < 0.0) {
                return Err(RossError::Field {
                    element: name.into(),
                    reason: "frequency values must be finite and >= 0".into(),
                });
            }
            let mut pairs: Vec<(f64, BearingCoefficients)> =
                s.iter().enumerate().map(|(i, &w)| (w, at(i))).collect();
            pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
            if pairs.windows(2).any(|p| p[0].0 == p[1].0) {
                return Err(RossError::Field {
                    element: name.into(),
                    reason: "repeated frequency value".into(),
                });
            }
            // Constant tables become constant laws.
            if pairs.iter().all(|p| p.1 == pairs[0].1) {
                return Ok(BearingLaw::Constant(pairs[0].1));
            }
            Ok(BearingLaw::Table {
                speeds: pairs.iter().map(|p| p.0).collect(),
                coefficients: pairs.iter().map(|p| p.1).collect(),
                interpolation,
            })
        }
    }
}

fn material(name: &str, m: &RossMaterial) -> Result<Material, RossError> {
    let label = m.name.clone().unwrap_or_else(|| "material".into());
    let g = match (m.G_s, m.Poisson) {
        (Some(g), _) => g,
        (None, Some(nu)) => m.E / (2.0 * (1.0 + nu)),
        (None, None) => {
            return Err(RossError::Field {
                element: name.into(),
                reason: "material needs G_s or Poisson".into(),
            })
        }
    };
    let e = plausible(name, "material.E", m.E, YOUNG)?;
    let g = plausible(name, "material.G_s", g, SHEAR)?;
    let rho = plausible(name, "material.rho", m.rho, DENSITY)?;
    Ok(Material {
        name: label,
        e,
        g,
        rho,
    })
}

/// A disk's `Id` or `Ip`: 0 (a mass without rotary inertia) or plausible.
fn inertia(name: &str, key: &str, v: f64) -> Result<f64, RossError> {
    check_inertia(v).map_err(|reason| RossError::Field {
        element: name.into(),
        reason: format!("{key}: {reason}"),
    })
}

/// `v` (key `key` of element `name`) inside a physically plausible range
/// ([`crate::model::plausible`]).
fn plausible(name: &str, key: &str, v: f64, range: Range) -> Result<f64, RossError> {
    check(v, range).map_err(|reason| RossError::Field {
        element: name.into(),
        reason: format!("{key}: {reason}"),
    })
}

/// Parses the text of a ROSS rotor file (see the module docs for the mapping).
pub fn parse_ross(text: &str) -> Result<RotorModel, RossError> {
    let table: toml::Table = toml::from_str(text)
        .map_err(|e| RossError::Format(format!("not valid TOML: {}", e.message().trim())))?;
    if !table.contains_key("ross_version") && !table.keys().any(|k| k.starts_with("ShaftElement_"))
    {
        return Err(RossError::Format(
            "neither a `ross_version` key nor a ShaftElement table: not a ROSS rotor file".into(),
        ));
    }
    let rotor_damping = rotor_damping(&table)?;
    let elements = RossElements::sort(&table)?;
    if elements.shafts.is_empty() {
        return Err(RossError::Format("no ShaftElement in the file".into()));
    }

    // Shaft: group by n, merge coaxial layers, check contiguity.
    let (theory, by_n) = shaft_by_n(&elements.shafts)?;
    let (shaft, shaft_layers) = merge_layers(by_n)?;
    let n_nodes = shaft.len() + 1;

    let out_disks = disks(&elements.disks, n_nodes)?;
    let out_bearings = bearings(&elements, n_nodes, &rotor_damping)?;
    let planes = out_disks.iter().map(|d| d.node).collect::<Vec<_>>();
    let mut planes_dedup = planes.clone();
    planes_dedup.dedup();
    let model = RotorModel {
        name: "ross".into(),
        theory: theory.map(|t| t.0).unwrap_or_default(),
        shaft,
        disks: out_disks,
        bearings: out_bearings,
        planes: planes_dedup,
        unbalance: Vec::new(),
        bow: None,
        probes: crate::model::ProbeReference::Relative,
        rotor_damping,
        shaft_layers,
    };
    model.validate()?;
    Ok(model)
}

/// The rotor damping of the `[parameters]` table (alpha M + beta K; none
/// when the table is absent). Modal damping is refused.
fn rotor_damping(table: &toml::Table) -> Result<ProportionalDamping, RossError> {
    let parameters: RossParameters = match table.get("parameters") {
        Some(v) => element("parameters", v)?,
        None => RossParameters::default(),
    };
    if parameters.modal_damping_ratio.is_some() {
        return Err(unsupported(
            "parameters",
            "modal_damping_ratio (modal damping of the rotor)",
        ));
    }
    let rotor_damping = ProportionalDamping {
        alpha: parameters.alpha.unwrap_or(0.0),
        beta: parameters.beta.unwrap_or(0.0),
    };
    if !(rotor_damping.alpha.is_finite() && rotor_damping.beta.is_finite()) {
        return Err(RossError::Field {
            element: "parameters".into(),
            reason: "alpha and beta must be finite".into(),
        });
    }
    Ok(rotor_damping)
}

/// A ROSS file's element tables by class, each with its table name, in
/// file (key) order.
struct RossElements {
    shafts: Vec<(String, RossShaft)>,
    disks: Vec<(String, RossDisk)>,
    bearings: Vec<(String, RossBearing)>,
    masses: Vec<(String, RossPointMass)>,
}

impl RossElements {
    /// Reads every element table of `table` by the class its name starts
    /// with; seals, magnetic bearings and other classes are refused.
    fn sort(table: &toml::Table) -> Result<Self, RossError> {
        let mut elements = RossElements {
            shafts: Vec::new(),
            disks: Vec::new(),
            bearings: Vec::new(),
            masses: Vec::new(),
        };
        for (key, value) in table {
            if key == "ross_version" || key == "parameters" {
                continue;
            }
            let class = key.split('_').next().unwrap_or("");
            if !value.is_table() {
                return Err(unsupported(
                    key,
                    "top-level key that is not an element table",
                ));
            }
            match class {
                "ShaftElement" => elements.shafts.push((key.clone(), element(key, value)?)),
                "DiskElement" => elements.disks.push((key.clone(), element(key, value)?)),
                "BearingElement" => {
                    not_magnetic(key, value)?;
                    elements.bearings.push((key.clone(), element(key, value)?))
                }
                "PointMass" => elements.masses.push((key.clone(), element(key, value)?)),
                "SealElement" | "LabyrinthSeal" | "HoleePatternSeal" | "HolePatternSeal" => {
                    return Err(unsupported(
                        key,
                        "seal elements (rotorid's bearings are the measured supports)",
                    ))
                }
                "MagneticBearingElement" => {
                    return Err(unsupported(
                        key,
                        "magnetic bearings are not supported (controller dynamics)",
                    ))
                }
                other => {
                    return Err(unsupported(
                        key,
                        format!(
                            "element class `{other}` (supported: ShaftElement, DiskElement, BearingElement, PointMass)"
                        ),
                    ))
                }
            }
        }
        Ok(elements)
    }
}

/// Refuses a `BearingElement_*` table that carries the controller keys of a
/// `MagneticBearingElement` (which ROSS saves under the bearing class name).
fn not_magnetic(key: &str, value: &toml::Value) -> Result<(), RossError> {
    let magnetic: Vec<&str> = MAGNETIC_KEYS
        .iter()
        .copied()
        .filter(|k| value.get(*k).is_some())
        .collect();
    if !magnetic.is_empty() {
        let more = if magnetic.len() > 3 { ", ..." } else { "" };
        return Err(unsupported(
            key,
            format!(
                "magnetic bearings are not supported (a MagneticBearingElement, saved with its controller keys {}{more})",
                magnetic[..magnetic.len().min(3)].join(", ")
            ),
        ));
    }
    Ok(())
}

/// The shaft elements by their `n` (coaxial layers share one), with the
/// beam theory and the first element that set it.
#[allow(clippy::type_complexity)]
fn shaft_by_n(
    shafts: &[(String, RossShaft)],
) -> Result<
    (
        Option<(BeamTheory, String)>,
        BTreeMap<usize, Vec<(String, ShaftElement)>>,
    ),
    RossError,
> {
    let mut theory: Option<(BeamTheory, String)> = None;
    let mut by_n: BTreeMap<usize, Vec<(String, ShaftElement)>> = BTreeMap::new();
    for (name, s) in shafts {
        let t = shaft_theory(name, s)?;
        match &theory {
            None => theory = Some((t, name.clone())),
            Some((t0, first)) if *t0 != t => {
                return Err(unsupported(
                    name,
                    format!("shear_effects differs from {first}: mixed beam theories"),
                ))
            }
            _ => {}
        }
        plausible(name, "L", s.L, LENGTH)?;
        plausible(name, "odl", s.odl, DIAMETER)?;
        if !(s.idl >= 0.0 && s.idl < s.odl) {
            return Err(RossError::Field {
                element: name.clone(),
                reason: format!("idl: must be in [0, odl), got {:e}", s.idl),
            });
        }
        by_n.entry(s.n).or_default().push((
            name.clone(),
            ShaftElement {
                length: s.L,
                outer_diameter: s.odl,
                inner_diameter: s.idl,
                material: material(name, &s.material)?,
            },
        ));
    }
    Ok((theory, by_n))
}

/// Checks that a shaft element is one rotorid models (uniform, no axial
/// force or torque, rotary inertia and gyroscopic terms on) and returns its
/// beam theory.
fn shaft_theory(name: &str, s: &RossShaft) -> Result<BeamTheory, RossError> {
    let idr = s.idr.unwrap_or(s.idl);
    let odr = s.odr.unwrap_or(s.odl);
    if idr != s.idl || odr != s.odl {
        return Err(unsupported(
            name,
            format!(
                "tapered element (idl {} idr {}, odl {} odr {}); split it into uniform elements",
                s.idl, idr, s.odl, odr
            ),
        ));
    }
    for (key, v) in [
        ("alpha", s.alpha),
        ("beta", s.beta),
        ("axial_force", s.axial_force),
        ("torque", s.torque),
    ] {
        if let Some(v) = v {
            if v != 0.0 {
                return Err(unsupported(name, format!("{key} = {v} (must be 0)")));
            }
        }
    }
    if s.rotary_inertia == Some(false) {
        return Err(unsupported(name, "rotary_inertia = false"));
    }
    if s.gyroscopic == Some(false) {
        return Err(unsupported(name, "gyroscopic = false"));
    }
    Ok(if s.shear_effects.unwrap_or(true) {
        if let Some(m) = &s.shear_method_calc {
            if m != "cowper" {
                return Err(unsupported(
                    name,
                    format!("shear_method_calc = \"{m}\" (rotorid uses Cowper's coefficient)"),
                ));
            }
        }
        BeamTheory::Timoshenko
    } else {
        BeamTheory::EulerBernoulli
    })
}

/// The shaft elements (numbered 0, 1, 2, ... without gaps) and the coaxial
/// layers added to them.
fn merge_layers(
    by_n: BTreeMap<usize, Vec<(String, ShaftElement)>>,
) -> Result<(Vec<ShaftElement>, Vec<ShaftLayer>), RossError> {
    let mut shaft = Vec::new();
    let mut shaft_layers = Vec::new();
    for (expect, (n, mut layers)) in by_n.into_iter().enumerate() {
        let first = layers[0].0.clone();
        if n != expect {
            return Err(RossError::Field {
                element: first,
                reason: format!("n = {n}: shaft elements must be numbered 0, 1, 2, ... without gaps (expected {expect})"),
            });
        }
        // The innermost section is the element; the others are layers whose
        // matrices are added to it (ROSS sums the matrices of elements that
        // share an `n`).
        layers.sort_by(|a, b| a.1.inner_diameter.total_cmp(&b.1.inner_diameter));
        let base = layers[0].1.clone();
        for (name, l) in &layers[1..] {
            if l.length != base.length {
                return Err(unsupported(
                    name,
                    format!(
                        "coaxial layer of element n = {n} with length {} != {}",
                        l.length, base.length
                    ),
                ));
            }
            shaft_layers.push(ShaftLayer {
                element: n,
                section: l.clone(),
            });
        }
        shaft.push(base);
    }
    Ok((shaft, shaft_layers))
}

/// The disks, on shaft nodes, sorted by node.
fn disks(disks: &[(String, RossDisk)], n_nodes: usize) -> Result<Vec<Disk>, RossError> {
    let mut out_disks = Vec::new();
    for (name, d) in disks {
        if d.n >= n_nodes {
            return Err(RossError::Field {
                element: name.clone(),
                reason: format!("n = {} is not a shaft node (0..={})", d.n, n_nodes - 1),
            });
        }
        out_disks.push(Disk {
            node: d.n,
            mass: plausible(name, "m", d.m, MASS)?,
            id: inertia(name, "Id", d.Id)?,
            ip: inertia(name, "Ip", d.Ip)?,
        });
    }
    out_disks.sort_by_key(|d| d.node);
    Ok(out_disks)
}

/// The shaft bearings, sorted by node, with the pedestals made of a point
/// mass linked to a bearing and held to ground by another.
fn bearings(
    elements: &RossElements,
    n_nodes: usize,
    rotor_damping: &ProportionalDamping,
) -> Result<Vec<Bearing>, RossError> {
    // Point masses are pedestal nodes; index them by node.
    let mut pm_by_node: BTreeMap<usize, &(String, RossPointMass)> = BTreeMap::new();
    for pm in &elements.masses {
        if pm.1.n < n_nodes {
            return Err(unsupported(
                &pm.0,
                "point mass on a shaft node (only pedestal point masses linked to a bearing are read)",
            ));
        }
        if pm_by_node.insert(pm.1.n, pm).is_some() {
            return Err(unsupported(&pm.0, "two point masses on one node"));
        }
    }
    let mut ground: BTreeMap<usize, &(String, RossBearing)> = BTreeMap::new();
    let mut shaft_bearings = Vec::new();
    for b in &elements.bearings {
        if b.1.n < n_nodes {
            shaft_bearings.push(b);
        } else if pm_by_node.contains_key(&b.1.n) {
            if b.1.n_link.is_some() {
                return Err(unsupported(
                    &b.0,
                    "bearing linking a point mass to another node (only point mass to ground)",
                ));
            }
            if ground.insert(b.1.n, b).is_some() {
                return Err(unsupported(
                    &b.0,
                    "two bearings from one point mass to ground",
                ));
            }
        } else {
            return Err(RossError::Field {
                element: b.0.clone(),
                reason: format!("n = {} is neither a shaft node nor a point mass", b.1.n),
            });
        }
    }
    let mut used_pm = std::collections::BTreeSet::new();
    let mut out_bearings = Vec::new();
    for (name, b) in shaft_bearings {
        let law = bearing_law(name, b)?;
        let pedestal = match b.n_link {
            None => None,
            Some(p) => {
                let Some((pm_name, pm)) = pm_by_node.get(&p).map(|x| (&x.0, &x.1)) else {
                    return Err(unsupported(
                        name,
                        format!("n_link = {p} is not a point mass node"),
                    ));
                };
                let Some((g_name, g)) = ground.get(&p).map(|x| (&x.0, &x.1)) else {
                    return Err(unsupported(
                        pm_name,
                        "point mass without a bearing to ground",
                    ));
                };
                if !used_pm.insert(p) {
                    return Err(unsupported(pm_name, "point mass linked to two bearings"));
                }
                Some(pedestal(pm_name, pm, g_name, g, rotor_damping)?)
            }
        };
        out_bearings.push(Bearing {
            node: b.n,
            law,
            pedestal,
        });
    }
    for (p, (name, _)) in pm_by_node.iter().map(|(p, x)| (p, (&x.0, &x.1))) {
        if !used_pm.contains(p) {
            return Err(unsupported(
                name,
                "point mass not linked to a shaft bearing",
            ));
        }
    }
    out_bearings.sort_by_key(|b| b.node);
    Ok(out_bearings)
}

/// The pedestal of point mass `pm` held to ground by bearing `g`: its
/// masses, and the ground support's direct stiffness and damping (plus the
/// rotor's alpha m).
fn pedestal(
    pm_name: &str,
    pm: &RossPointMass,
    g_name: &str,
    g: &RossBearing,
    rotor_damping: &ProportionalDamping,
) -> Result<Pedestal, RossError> {
    // `mz` (axial) acts on a DOF the lateral model does not have.
    // As ROSS's PointMass: `m` alone is the mass in every
    // direction; once `mx`, `my` or `mz` is given, `mx`, `my`
    // are the masses (ROSS x, y = our y, z) and `m` is unused.
    let mass = match (pm.m, pm.mx, pm.my, pm.mz) {
        (Some(m), None, None, None) => [m, m],
        (_, Some(mx), Some(my), _) => [mx, my],
        _ => {
            return Err(RossError::Field {
                element: pm_name.to_string(),
                reason: "point mass needs m, or both mx and my".into(),
            })
        }
    };
    let mass = [
        plausible(pm_name, "mx", mass[0], MASS)?,
        plausible(pm_name, "my", mass[1], MASS)?,
    ];
    let gl = bearing_law(g_name, g)?;
    let BearingLaw::Constant(gc) = gl else {
        return Err(unsupported(g_name, "speed-dependent pedestal support"));
    };
    if gc.k[1] != 0.0 || gc.k[2] != 0.0 || gc.c[1] != 0.0 || gc.c[2] != 0.0 {
        return Err(unsupported(
            g_name,
            "cross-coupled pedestal support (kxy, kyx, cxy, cyx must be 0)",
        ));
    }
    // ROSS's rotor damping alpha M0 covers the point masses too:
    // alpha m of viscous damping to ground on each direction.
    Ok(Pedestal {
        mass,
        k: [gc.k[0], gc.k[3]],
        c: [
            gc.c[0] + rotor_damping.alpha * mass[0],
            gc.c[3] + rotor_damping.alpha * mass[1],
        ],
    })
}

/// Float in a form TOML reads back exactly (Rust's shortest round-trip
/// representation).
fn f(v: f64) -> String {
    let s = format!("{v:?}");
    if s.contains('.') || s.contains('e') || s.contains("inf") || s.contains("NaN") {
        s
    } else {
        format!("{s}.0")
    }
}

fn arr(v: &[f64]) -> String {
    format!(
        "[{}]",
        v.iter().map(|x| f(*x)).collect::<Vec<_>>().join(", ")
    )
}

/// Writes a model as a ROSS rotor file (format 3.x, `ross_version = "3.1.0"`), the inverse of
/// [`parse_ross`]: shaft elements and their coaxial layers, disks,
/// bearings (constant, or tables over ROSS 3's `speed` axis, the rotor
/// speed in rad/s, at which rotorid evaluates every table; with
/// `interpolation` for PCHIP and extrapolated linear tables), pedestals as a linked
/// `PointMass` with a bearing to ground, rotor damping in `[parameters]`.
/// Polynomial and dynamic-stiffness bearing laws have no ROSS equivalent
/// and are refused ([`tabulate_for_ross`] turns them into tables first);
/// unbalance, bow and the unbalance planes are not written (a ROSS rotor
/// file carries none; the reader takes the disk nodes as planes).
pub fn to_ross_toml(model: &RotorModel) -> Result<String, RossError> {
    model.validate()?;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# ROSS rotor file (format 3.x) written by rotorid: {}",
        model.name
    );
    let _ = writeln!(s, "ross_version = \"3.1.0\"\n\n[parameters]");
    let damping = model.rotor_damping;
    if !damping.is_zero() {
        let _ = writeln!(
            s,
            "alpha = {}\nbeta = {}",
            f(damping.alpha),
            f(damping.beta)
        );
    }
    let _ = writeln!(s);
    write_shaft_elements(&mut s, model);
    for (i, d) in model.disks.iter().enumerate() {
        let _ = writeln!(
            s,
            "[\"DiskElement_Disk {i}\"]\nn = {}\nm = {}\nId = {}\nIp = {}\ntag = \"Disk {i}\"\nscale_factor = 1.0\n",
            d.node,
            f(d.mass),
            f(d.id),
            f(d.ip)
        );
    }
    write_bearings(&mut s, model)?;
    Ok(s)
}

/// [`to_ross_toml`]'s `ShaftElement` tables: the shaft elements, then
/// their coaxial layers (on the same `n`), each with its material.
fn write_shaft_elements(s: &mut String, model: &RotorModel) {
    let shear = model.theory == BeamTheory::Timoshenko;
    let sections = model
        .shaft
        .iter()
        .enumerate()
        .map(|(i, e)| (i, e, format!("ShaftElement {i}")));
    let layers = model.shaft_layers.iter().enumerate().map(|(j, l)| {
        (
            l.element,
            &l.section,
            format!("ShaftElement {} layer {j}", l.element),
        )
    });
    for (i, e, tag) in sections.chain(layers) {
        let key = format!("ShaftElement_{tag}");
        let _ = writeln!(
            s,
            "[\"{key}\"]\nL = {}\nidl = {}\nodl = {}\nidr = {}\nodr = {}\nn = {i}\naxial_force = 0\ntorque = 0\nshear_effects = {shear}\nrotary_inertia = true\ngyroscopic = true\nshear_method_calc = \"cowper\"\ntag = \"{tag}\"\nalpha = 0.0\nbeta = 0.0\n",
            f(e.length),
            f(e.inner_diameter),
            f(e.outer_diameter),
            f(e.inner_diameter),
            f(e.outer_diameter),
        );
        let _ = writeln!(
            s,
            "[\"{key}\".material]\nname = \"{}\"\nrho = {}\nE = {}\nG_s = {}\n",
            e.material.name.replace('"', "'"),
            f(e.material.rho),
            f(e.material.e),
            f(e.material.g),
        );
    }
}

/// [`to_ross_toml`]'s bearings, each pedestal after its bearing as a
/// `PointMass` on a new node past the shaft with a bearing to ground.
/// Polynomial and dynamic-stiffness laws are refused.
fn write_bearings(s: &mut String, model: &RotorModel) -> Result<(), RossError> {
    let damping = model.rotor_damping;
    let mut next_node = model.n_nodes();
    for (i, b) in model.bearings.iter().enumerate() {
        type Axis<'a> = Option<(&'a [f64], TableInterpolation)>;
        let (speeds, co): (Axis, Vec<BearingCoefficients>) = match &b.law {
            BearingLaw::Constant(c) => (None, vec![*c]),
            BearingLaw::Table {
                speeds,
                coefficients,
                interpolation,
            } => (
                Some((speeds.as_slice(), *interpolation)),
                coefficients.clone(),
            ),
            BearingLaw::Polynomial { .. } | BearingLaw::DynamicStiffness { .. } => {
                return Err(unsupported(
                    &format!("bearing {}", i + 1),
                    "polynomial bearing laws have no ROSS equivalent",
                ))
            }
        };
        let link = b.pedestal.map(|_| {
            next_node += 1;
            next_node - 1
        });
        write_bearing_element(s, &format!("Bearing {i}"), b.node, link, speeds, &co);
        if let (Some(p), Some(ped)) = (link, b.pedestal) {
            // `m` for one mass; `mx`, `my` (and `mz`, axial, unused here:
            // equal to `my`) for two, as ROSS writes a PointMass.
            let masses = if ped.mass[0] == ped.mass[1] {
                format!("m = {}", f(ped.mass[0]))
            } else {
                format!(
                    "mx = {}\nmy = {}\nmz = {}",
                    f(ped.mass[0]),
                    f(ped.mass[1]),
                    f(ped.mass[1])
                )
            };
            let _ = writeln!(
                s,
                "[\"PointMass_Pedestal {i}\"]\nn = {p}\n{masses}\ntag = \"Pedestal {i}\"\n",
            );
            // The reader adds the rotor damping alpha m of the point mass.
            let g = BearingCoefficients {
                k: [ped.k[0], 0.0, 0.0, ped.k[1]],
                c: [
                    ped.c[0] - damping.alpha * ped.mass[0],
                    0.0,
                    0.0,
                    ped.c[1] - damping.alpha * ped.mass[1],
                ],
            };
            write_bearing_element(s, &format!("Support {i}"), p, None, None, &[g]);
        }
    }
    Ok(())
}

/// One `BearingElement` table: on node `n` (linked to node `link`), the
/// coefficients `co`, one set or one per speed of `speeds` with its
/// interpolation.
fn write_bearing_element(
    s: &mut String,
    tag: &str,
    n: usize,
    link: Option<usize>,
    speeds: Option<(&[f64], TableInterpolation)>,
    co: &[BearingCoefficients],
) {
    let _ = writeln!(s, "[\"BearingElement_{tag}\"]\nn = {n}");
    if let Some(p) = link {
        let _ = writeln!(s, "n_link = {p}");
    }
    let names_k = ["kxx", "kxy", "kyx", "kyy"];
    let names_c = ["cxx", "cxy", "cyx", "cyy"];
    for (j, name) in names_k.iter().enumerate() {
        let v: Vec<f64> = co.iter().map(|c| c.k[j]).collect();
        let _ = writeln!(s, "{name} = {}", arr(&v));
    }
    for (j, name) in names_c.iter().enumerate() {
        let v: Vec<f64> = co.iter().map(|c| c.c[j]).collect();
        let _ = writeln!(s, "{name} = {}", arr(&v));
    }
    // Axial and mass coefficients, zero (as ROSS 2.x writes them).
    let zeros = vec![0.0; co.len()];
    for key in ["kzz", "czz", "mxx", "mxy", "myx", "myy", "mzz"] {
        let _ = writeln!(s, "{key} = {}", arr(&zeros));
    }
    if let Some((w, kind)) = speeds {
        let _ = writeln!(s, "speed = {}", arr(w));
        match kind {
            TableInterpolation::LinearHold => {}
            TableInterpolation::LinearExtrapolate => {
                let _ = writeln!(s, "interpolation = \"linear\"");
            }
            TableInterpolation::Pchip => {
                let _ = writeln!(s, "interpolation = \"pchip\"");
            }
        }
    }
    let _ = writeln!(s, "tag = \"{tag}\"\nscale_factor = 1\n");
}

/// Speeds of the table that [`tabulate_for_ross`] writes for a bearing law
/// that changes with speed (ROSS warns below 5).
pub const ROSS_TABLE_POINTS: usize = 31;

/// `model` with every bearing law that a ROSS file cannot hold
/// ([`BearingLaw::Polynomial`], [`BearingLaw::DynamicStiffness`]) replaced
/// by a PCHIP table ([`TableInterpolation::Pchip`], ROSS's own) of `points`
/// speeds spaced evenly over `omega_min..=omega_max` (rad/s), holding the
/// law's `K(Omega)` (N/m) and `C(Omega)` (N s/m) at each, so that
/// [`to_ross_toml`] can write it. A law that is the same at every speed of
/// the range (e.g. a polynomial whose higher terms are zero) becomes
/// [`BearingLaw::Constant`]; constant laws and tables are kept. Between the
/// points the table is the PCHIP interpolant of the law, beyond them the
/// straight line with the end slope (ROSS's extrapolation), not the law.
/// Refused (`RossError::Format`): a range that is not finite, negative or
/// empty (`omega_max <= omega_min`) when a law needs a table, or fewer than
/// 2 points.
pub fn tabulate_for_ross(
    model: &RotorModel,
    omega_min: f64,
    omega_max: f64,
    points: usize,
) -> Result<RotorModel, RossError> {
    let mut out = model.clone();
    for (i, b) in out.bearings.iter_mut().enumerate() {
        if !matches!(
            b.law,
            BearingLaw::Polynomial { .. } | BearingLaw::DynamicStiffness { .. }
        ) {
            continue;
        }
        if !(omega_min.is_finite() && omega_max.is_finite() && omega_min >= 0.0)
            || omega_max <= omega_min
            || points < 2
        {
            return Err(RossError::Format(format!(
                "bearing {}: its law changes with speed and a ROSS file holds it only as a table over a speed range; got {omega_min}..={omega_max} rad/s with {points} points (need 0 <= min < max, at least 2 points)",
                i + 1
            )));
        }
        let speeds: Vec<f64> = (0..points)
            .map(|j| {
                if j + 1 == points {
                    omega_max
                } else {
                    omega_min + (omega_max - omega_min) * j as f64 / (points - 1) as f64
                }
            })
            .collect();
        let coefficients: Vec<BearingCoefficients> = speeds.iter().map(|&w| b.law.at(w)).collect();
        b.law = if coefficients.iter().all(|c| *c == coefficients[0]) {
            BearingLaw::Constant(coefficients[0])
        } else {
            BearingLaw::Table {
                speeds,
                coefficients,
                interpolation: TableInterpolation::Pchip,
            }
        };
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_round_trips_through_ross() {
        let m = RotorModel::paper();
        let text = to_ross_toml(&m).unwrap();
        let r = parse_ross(&text).unwrap();
        assert_eq!(r.shaft, m.shaft);
        assert_eq!(r.disks, m.disks);
        assert_eq!(r.bearings, m.bearings);
        assert_eq!(r.planes, m.planes);
        assert_eq!(r.theory, m.theory);
    }

    #[test]
    fn pedestal_and_table_round_trip() {
        let mut m = RotorModel::paper();
        m.bearings[0].pedestal = Some(Pedestal {
            mass: [30.0, 45.0],
            k: [1e8, 2e8],
            c: [1e3, 2e3],
        });
        let c0 = m.bearings[1].law.at(0.0);
        let mut c1 = c0;
        c1.k[0] *= 2.0;
        m.bearings[1].law = BearingLaw::Table {
            speeds: vec![0.0, 1000.0],
            coefficients: vec![c0, c1],
            interpolation: TableInterpolation::LinearHold,
        };
        let r = parse_ross(&to_ross_toml(&m).unwrap()).unwrap();
        assert_eq!(r.bearings, m.bearings);
    }
}
