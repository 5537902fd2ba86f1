//! ROSS rotor files: the shipped paper rotor in ROSS format loads to the
//! built-in rotor, and unsupported content is refused naming the element.

use crate::common::{example, tmp};
use rotorid::io::model_file::{load_model, ModelFileError};
use rotorid::io::ross::{parse_ross, RossError};
use rotorid::model::{BearingLaw, RotorModel, TableInterpolation};

#[test]
fn paper_ross_equals_builtin_paper_field_by_field() {
    let r = load_model(example("paper_ross.toml")).unwrap();
    let p = RotorModel::paper();
    assert_eq!(r.theory, p.theory);
    assert_eq!(r.shaft.len(), 26);
    for (a, b) in r.shaft.iter().zip(&p.shaft) {
        assert_eq!(a.length, b.length);
        assert_eq!(a.outer_diameter, b.outer_diameter);
        assert_eq!(a.inner_diameter, b.inner_diameter);
        assert_eq!(a.material.e, b.material.e);
        assert_eq!(a.material.g, b.material.g);
        assert_eq!(a.material.rho, b.material.rho);
    }
    assert_eq!(r.disks.len(), 3);
    for (a, b) in r.disks.iter().zip(&p.disks) {
        assert_eq!((a.node, a.mass, a.id, a.ip), (b.node, b.mass, b.id, b.ip));
    }
    assert_eq!(r.bearings.len(), 2);
    for (a, b) in r.bearings.iter().zip(&p.bearings) {
        assert_eq!(a.node, b.node);
        assert_eq!(a.law, b.law);
        assert_eq!(a.pedestal, b.pedestal);
    }
    // Planes default to the disk nodes: the paper's 5, 11, 21.
    assert_eq!(r.planes, vec![4, 10, 20]);
    assert!(r.unbalance.is_empty());
}

fn paper_ross() -> String {
    std::fs::read_to_string(example("paper_ross.toml")).unwrap()
}

fn refuse(text: &str) -> String {
    let e = parse_ross(text).unwrap_err();
    let s = e.to_string();
    assert!(!s.contains('\n'), "{s}");
    s
}

#[test]
fn ross_axes_map_to_ours() {
    // kxy (ROSS x -> y) is our kyz; kyx is our kzy.
    let text = paper_ross().replacen("kxy = [5000000.0]", "kxy = [1234.0]", 1);
    let m = parse_ross(&text).unwrap();
    let BearingLaw::Constant(c) = &m.bearings[0].law else {
        panic!("constant law expected")
    };
    assert_eq!(c.k, [5e7, 1234.0, 1e7, 7e7]);
}

#[test]
fn speed_table_becomes_bearing_table() {
    let text = paper_ross().replacen(
        "kxx = [50000000.0]\nkxy = [5000000.0]",
        "kxx = [1e7, 5e7]\nfrequency = [0.0, 1570.8]\nkxy = [5000000.0, 5000000.0]",
        1,
    );
    let m = parse_ross(&text).unwrap();
    let BearingLaw::Table {
        speeds,
        coefficients,
        interpolation,
    } = &m.bearings[0].law
    else {
        panic!("table expected")
    };
    assert_eq!(speeds, &vec![0.0, 1570.8]);
    // No `interpolation` key (ROSS 2.x): linear, held beyond the table.
    assert_eq!(*interpolation, TableInterpolation::LinearHold);
    assert_eq!(coefficients[0].k[0], 1e7);
    assert_eq!(coefficients[1].k[0], 5e7);
    assert_eq!(coefficients[1].k[3], 7e7);
    // Mismatched array length is an error naming the element.
    let bad = paper_ross().replacen(
        "kxx = [50000000.0]",
        "kxx = [1e7, 5e7, 6e7]\nfrequency = [0.0, 10.0]",
        1,
    );
    let e = refuse(&bad);
    assert!(e.starts_with("BearingElement_Bearing 0: "), "{e}");
}

#[test]
fn pedestal_pattern_is_read() {
    let extra = r#"
["PointMass_P0"]
n = 27
m = 25.0
tag = "P0"

["BearingElement_Support"]
n = 27
kxx = 2e8
kyy = 3e8
cxx = 1000.0
cyy = 1500.0
"#;
    let text = paper_ross().replacen("n = 0\nkxx", "n = 0\nn_link = 27\nkxx", 1) + extra;
    let m = parse_ross(&text).unwrap();
    let p = m.bearings[0].pedestal.unwrap();
    assert_eq!(p.mass, [25.0, 25.0]);
    assert_eq!(p.k, [2e8, 3e8]);
    assert_eq!(p.c, [1000.0, 1500.0]);
    assert!(m.bearings[1].pedestal.is_none());
    // A mass per direction (ROSS mx, my = our y, z); mz is axial, unused.
    let two = text.replacen(
        "m = 25.0\ntag = \"P0\"",
        "mx = 25.0\nmy = 40.0\nmz = 1.0\ntag = \"P0\"",
        1,
    );
    let p = parse_ross(&two).unwrap().bearings[0].pedestal.unwrap();
    assert_eq!(p.mass, [25.0, 40.0]);
    // Written back as mx, my, and read back the same.
    let back = parse_ross(&rotorid::io::ross::to_ross_toml(&parse_ross(&two).unwrap()).unwrap());
    assert_eq!(back.unwrap().bearings[0].pedestal.unwrap(), p);
    // mx without my is not a point mass ROSS builds.
    let half = text.replacen("m = 25.0\ntag = \"P0\"", "mx = 25.0\ntag = \"P0\"", 1);
    let e = parse_ross(&half).unwrap_err().to_string();
    assert!(
        e.starts_with("PointMass_P0: ") && e.contains("mx and my"),
        "{e}"
    );
    // A point mass with no support to ground is refused.
    let lonely = paper_ross().replacen("n = 0\nkxx", "n = 0\nn_link = 27\nkxx", 1)
        + "[\"PointMass_P0\"]\nn = 27\nm = 25.0\n";
    assert!(refuse(&lonely).contains("PointMass_P0: not supported"));
    // Cross-coupled support refused.
    let cross = text.replacen("cyy = 1500.0", "cyy = 1500.0\nkxy = 1e6", 1);
    assert!(refuse(&cross).starts_with("BearingElement_Support: not supported"));
}

#[test]
fn unsupported_content_is_refused_naming_the_element() {
    let tapered = paper_ross().replacen("odr = 0.1\nn = 3\n", "odr = 0.11\nn = 3\n", 1);
    assert!(refuse(&tapered).starts_with("ShaftElement_ShaftElement 3: not supported: tapered"));
    let seal = paper_ross() + "[\"SealElement_S\"]\nn = 3\nkxx = 1e6\ncxx = 10.0\n";
    assert!(refuse(&seal).starts_with("SealElement_S: not supported"));
    let mag = paper_ross() + "[\"MagneticBearingElement_M\"]\nn = 3\n";
    assert!(refuse(&mag).starts_with("MagneticBearingElement_M: not supported"));
    // ROSS 3 saves magnetic bearings as BearingElement with controller keys.
    let amb = paper_ross().replacen("n = 0\nkxx", "n = 0\nag = 0.0001\nkp_pid = 1e5\nkxx", 1);
    let e = refuse(&amb);
    assert!(
        e.starts_with("BearingElement_Bearing 0: ")
            && e.contains("magnetic bearings are not supported")
            && e.contains("ag, kp_pid"),
        "{e}"
    );
    let modal = paper_ross().replacen(
        "[parameters]\n",
        "[parameters]\nmodal_damping_ratio = 0.1\n",
        1,
    );
    assert!(refuse(&modal).starts_with("parameters: not supported: modal_damping_ratio"));
    let bad_interp =
        paper_ross().replacen("n = 0\nkxx", "n = 0\ninterpolation = \"cubic\"\nkxx", 1);
    assert!(refuse(&bad_interp).contains("interpolation = \"cubic\""));
    let other = paper_ross() + "[\"GearElement_G\"]\nn = 3\n";
    assert!(refuse(&other).contains("GearElement"));
    let mass = paper_ross().replacen("mxx = [0.0]", "mxx = [3.0]", 1);
    assert!(refuse(&mass).starts_with("BearingElement_Bearing 0: not supported: bearing mass"));
    let damped = paper_ross().replacen("alpha = 0.0\n", "alpha = 0.1\n", 1);
    assert!(refuse(&damped).starts_with("ShaftElement_ShaftElement 0: not supported: alpha"));
    let unknown_key = paper_ross().replacen("scale_factor = 1\n", "scale_factor = 1\nfoo = 2\n", 1);
    assert!(refuse(&unknown_key).contains("unknown field `foo`"));
    let gap = paper_ross().replacen("n = 5\naxial_force", "n = 50\naxial_force", 1);
    assert!(refuse(&gap).contains("without gaps"));
    let missing = paper_ross().replacen("m = ", "mass = ", 1);
    assert!(refuse(&missing).starts_with("DiskElement_Disk 0: "));
}

#[test]
fn coaxial_layers_become_shaft_layers() {
    let layer = r#"
["ShaftElement_Sleeve 2"]
L = 0.05
idl = 0.1
odl = 0.14
idr = 0.1
odr = 0.14
n = 2

["ShaftElement_Sleeve 2".material]
name = "aluminium"
rho = 2700.0
E = 70000000000.0
G_s = 26000000000.0
"#;
    let m = parse_ross(&(paper_ross() + layer)).unwrap();
    assert_eq!(m.shaft, RotorModel::paper().shaft);
    assert_eq!(m.shaft_layers.len(), 1);
    let l = &m.shaft_layers[0];
    assert_eq!(l.element, 2);
    assert_eq!(
        (l.section.inner_diameter, l.section.outer_diameter),
        (0.1, 0.14)
    );
    assert_eq!(l.section.material.e, 70e9);
    let longer = (paper_ross() + layer).replacen("L = 0.05\nidl = 0.1", "L = 0.06\nidl = 0.1", 1);
    assert!(refuse(&longer).contains("coaxial layer of element n = 2 with length"));
}

#[test]
fn ross_detection_by_key() {
    let p = tmp("r.toml");
    std::fs::write(&p, paper_ross().replace("[\"SealElement", "")).unwrap();
    assert_eq!(load_model(&p).unwrap().shaft, RotorModel::paper().shaft);
    std::fs::write(
        &p,
        paper_ross() + "[\"SealElement_S\"]\nn = 3\nkxx = 1e6\ncxx = 10.0\n",
    )
    .unwrap();
    let e = load_model(&p).unwrap_err();
    assert!(
        matches!(e, ModelFileError::Ross(RossError::Unsupported { .. })),
        "{e}"
    );
    std::fs::remove_file(&p).ok();
}

#[test]
fn older_ross_files_without_version_key_are_detected() {
    let old = paper_ross().replace("ross_version = \"3.1.0\"\n", "");
    assert!(rotorid::io::model_file::is_ross(&old));
    assert_eq!(parse_ross(&old).unwrap().shaft, RotorModel::paper().shaft);
    assert!(!rotorid::io::model_file::is_ross(
        "name = \"x\"\n[[shaft]]\nlength = 1.0\n"
    ));
}
