//! Model files: the shipped examples load to the built-in rotor, and bad
//! files give an error naming the field.

use crate::common::example;
use rotorid::io::model_file::{
    load_model, model_by_name_or_path, parse_model_file, ModelFileError,
};
use rotorid::model::RotorModel;

#[test]
fn paper_toml_equals_builtin_paper() {
    let m = load_model(example("paper.toml")).unwrap();
    assert_eq!(m, RotorModel::paper());
}

#[test]
fn paper_by_name_and_by_path() {
    assert_eq!(model_by_name_or_path("paper").unwrap(), RotorModel::paper());
    let p = example("paper.toml");
    assert_eq!(
        model_by_name_or_path(p.to_str().unwrap()).unwrap(),
        RotorModel::paper()
    );
    let e = model_by_name_or_path("no-such-model").unwrap_err();
    assert!(matches!(e, ModelFileError::UnknownModel(_)), "{e}");
}

fn paper_text() -> String {
    std::fs::read_to_string(example("paper.toml")).unwrap()
}

/// Replaces exactly one occurrence (so a test edits what it means to).
fn edit(text: &str, from: &str, to: &str) -> String {
    assert_eq!(text.matches(from).count(), 1, "{from:?} must occur once");
    text.replace(from, to)
}

fn err(text: &str) -> String {
    let e = parse_model_file(text).unwrap_err().to_string();
    assert!(!e.contains('\n'), "one-line message: {e}");
    e
}

#[test]
fn bearing_off_the_shaft() {
    let e = err(&edit(&paper_text(), "node = 27\n", "node = 40\n"));
    assert_eq!(
        e,
        "bearing[2].node: node 40 is not on the shaft (nodes 1..=27)"
    );
    let e = err(&edit(&paper_text(), "node = 1\n", "node = 0\n"));
    assert_eq!(
        e,
        "bearing[1].node: node 0 is not on the shaft (nodes 1..=27)"
    );
}

#[test]
fn unknown_node_in_disk_plane_unbalance() {
    let e = err(&paper_text().replacen("node = 11\n", "node = 99\n", 1));
    assert!(e.starts_with("disk[2].node: node 99"), "{e}");
    let e = err(&edit(
        &paper_text(),
        "planes = [5, 11, 21]",
        "planes = [5, 11, 28]",
    ));
    assert!(e.starts_with("planes[3]: node 28"), "{e}");
    let e = err(&edit(
        &paper_text(),
        "node = 21\nme = 0.0073",
        "node = 0\nme = 0.0073",
    ));
    assert!(
        e.starts_with("unbalance[3].node: node 0 is not on the shaft"),
        "{e}"
    );
}

#[test]
fn negative_length_and_diameters() {
    let e = err(&edit(&paper_text(), "length = 1.3", "length = -1.3"));
    assert!(
        e.starts_with("shaft[1].length: must be finite and > 0, got -1.3"),
        "{e}"
    );
    let e = err(&edit(
        &paper_text(),
        "outer_diameter = 0.1\n",
        "outer_diameter = 0.0\n",
    ));
    assert!(e.starts_with("shaft[1].outer_diameter"), "{e}");
    let e = err(&edit(
        &paper_text(),
        "inner_diameter = 0.0\n",
        "inner_diameter = 0.2\n",
    ));
    assert!(e.starts_with("shaft[1].inner_diameter"), "{e}");
    let e = err(&edit(&paper_text(), "elements = 26", "elements = 0"));
    assert!(e.starts_with("shaft[1].elements"), "{e}");
}

#[test]
fn missing_fields() {
    let e = err(&edit(
        &paper_text(),
        "c = [500.0, 100.0, 50.0, 700.0]\n",
        "",
    ));
    assert!(e.starts_with("bearing[2].c: missing"), "{e}");
    let e = err(&edit(&paper_text(), "rho = 7800.0 ", "#"));
    assert!(e.starts_with("materials.steel: missing field `rho`"), "{e}");
    let e = err(&edit(&paper_text(), "length = 1.3\n", ""));
    assert!(e.starts_with("shaft[1]: missing field `length`"), "{e}");
    let e = err(&paper_text().replacen("thickness = 0.05\n", "", 1));
    assert!(e.starts_with("disk[1].thickness: missing"), "{e}");
}

#[test]
fn unknown_fields() {
    let e = err(&edit(
        &paper_text(),
        "node = 27\n",
        "node = 27\nstiffness = 3\n",
    ));
    assert!(
        e.starts_with("bearing[2].stiffness: unknown field `stiffness`"),
        "{e}"
    );
    let e = err(&edit(&paper_text(), "name = \"paper\"", "nam = \"paper\""));
    assert!(e.starts_with("nam: unknown field `nam`"), "{e}");
    let e = err(&edit(&paper_text(), "nu = 0.3 ", "poisson = 0.3 "));
    assert!(
        e.starts_with("materials.steel.poisson: unknown field"),
        "{e}"
    );
}

#[test]
fn wrong_types_and_values() {
    let e = err(&edit(&paper_text(), "node = 27\n", "node = \"last\"\n"));
    assert!(e.starts_with("bearing[2].node: invalid type"), "{e}");
    let e = err(&edit(
        &paper_text(),
        "k = [5e7, 1e7, 0.5e7, 7e7]",
        "k = [5e7, 1e7, 7e7]",
    ));
    assert!(e.starts_with("bearing[2].k"), "{e}");
    let e = err(&edit(
        &paper_text(),
        "theory = \"timoshenko\"",
        "theory = \"rayleigh\"",
    ));
    assert!(e.starts_with("theory: unknown beam theory"), "{e}");
    let e = err(&edit(
        &paper_text(),
        "material = \"steel\"\n\n# Rigid",
        "material = \"iron\"\n\n# Rigid",
    ));
    assert!(
        e.starts_with("shaft[1].material: unknown material `iron`"),
        "{e}"
    );
    let e = err(&edit(&paper_text(), "nu = 0.3 ", "nu = 0.7 "));
    assert!(e.starts_with("materials.steel.nu"), "{e}");
    // Two bearings on one node.
    let e = err(&edit(&paper_text(), "node = 27\n", "node = 1\n"));
    assert!(e.contains("bearing[2].node"), "{e}");
    // Syntax error: line number.
    let e = err(&edit(&paper_text(), "elements = 26", "elements = = 26"));
    assert!(e.starts_with("line 20:"), "{e}");
}

#[test]
fn bearing_table_polynomial_and_pedestal_forms() {
    let text = edit(
        &paper_text(),
        "k = [5e7, 1e7, 0.5e7, 7e7]\nc = [500.0, 100.0, 50.0, 700.0]\n",
        "table = { rpm = [0.0, 6000.0, 15000.0], k = [[1e7, 0, 0, 1e7], [3e7, 0, 0, 3e7], [5e7, 1e7, 0.5e7, 7e7]], c = [[500, 0, 0, 500], [500, 0, 0, 500], [500, 100, 50, 700]] }\npedestal = { mass = 40.0, k = [2e8, 3e8], c = [1e3, 2e3] }\n",
    );
    let m = parse_model_file(&text).unwrap().model;
    let b = &m.bearings[1];
    let w = rotorid::units::rpm_to_rad_s(3000.0);
    assert!((b.law.at(w).k[0] - 2e7).abs() < 1e-6);
    assert_eq!(b.pedestal.unwrap().k, [2e8, 3e8]);
    assert_eq!(b.pedestal.unwrap().mass, [40.0, 40.0]);
    // A pedestal mass per direction, [m_y, m_z].
    let two = text.replace("mass = 40.0", "mass = [40.0, 65.0]");
    let m = parse_model_file(&two).unwrap().model;
    assert_eq!(m.bearings[1].pedestal.unwrap().mass, [40.0, 65.0]);
    let e = err(&text.replace("mass = 40.0", "mass = [40.0, -65.0]"));
    assert!(e.starts_with("bearing[2].pedestal.mass[2]: "), "{e}");
    let e = err(&text.replace("mass = 40.0", "mass = [40.0, 1e300]"));
    assert!(e.starts_with("bearing[2].pedestal.mass[2]: "), "{e}");
    let e = err(&text.replace("mass = 40.0", "mass = [40.0, 65.0, 1.0]"));
    assert!(
        e.contains("bearing[2].pedestal.mass") && e.contains("[m_y, m_z]"),
        "{e}"
    );
    let text = edit(
        &paper_text(),
        "k = [5e7, 1e7, 0.5e7, 7e7]\nc = [500.0, 100.0, 50.0, 700.0]\n",
        "polynomial = { k = [[1e7, 0, 0, 1e7], [1e4, 0, 0, 1e4]], c = [[500, 0, 0, 500]] }\n",
    );
    let m = parse_model_file(&text).unwrap().model;
    assert!((m.bearings[1].law.at(100.0).k[3] - 1.1e7).abs() < 1e-6);
    // Both forms at once is an error.
    let text = edit(
        &paper_text(),
        "c = [500.0, 100.0, 50.0, 700.0]\n",
        "c = [500.0, 100.0, 50.0, 700.0]\npolynomial = { k = [[1, 0, 0, 1]], c = [] }\n",
    );
    assert!(err(&text).starts_with("bearing[2].table: give exactly one"));
    let text = edit(
        &paper_text(),
        "k = [5e7, 1e7, 0.5e7, 7e7]\nc = [500.0, 100.0, 50.0, 700.0]\n",
        "table = { rpm = [0.0, 0.0], k = [[1e7, 0, 0, 1e7], [3e7, 0, 0, 3e7]], c = [[500, 0, 0, 500], [500, 0, 0, 500]] }\n",
    );
    assert!(err(&text).starts_with("bearing[2].table.rpm[2]"));
}

#[test]
fn disk_from_inertia_and_simulate_section() {
    let text = format!(
        "{}\n[simulate]\ne_scale = 1.02\nbearing_speed_law = {{ rpm_ref = 15000.0, law = \"linear\" }}\nrunout = [{{ channel = \"b2_z\", amplitude = 1e-6, phase_deg = 90.0 }}]\nextra_unbalance = [{{ node = 14, me = 0.001, phase_deg = 45.0 }}]\npedestal = {{ mass = 50.0, k = [1e8, 1e8], c = [1e3, 1e3] }}\n",
        paper_text().replacen(
            "material = \"steel\"\nouter_diameter = 0.12\ninner_diameter = 0.1\nthickness = 0.05",
            "mass = 2.0\nid = 0.01\nip = 0.02",
            1
        )
    );
    let f = parse_model_file(&text).unwrap();
    assert_eq!(f.model.disks[0].mass, 2.0);
    assert_eq!(f.effects.e_scale, 1.02);
    assert_eq!(f.effects.runout[0].channel.index(), 3);
    assert_eq!(f.effects.extra_unbalance[0].node, 13);
    assert!(f.effects.pedestal.is_some());
    assert!(f.effects.bearing_speed_law.is_some());
    let bad = text.replace("b2_z", "b3_z");
    assert!(err(&bad).starts_with("simulate.runout[1].channel: bad channel"));
    let bad = text.replace("e_scale = 1.02", "e_scale = 1.02\ncolour = 1");
    assert!(err(&bad).starts_with("simulate.colour: unknown field"));
}

#[test]
fn shipped_variants_load() {
    let m = load_model(example("paper_pedestal.toml")).unwrap();
    let mut p = RotorModel::paper();
    for b in &mut p.bearings {
        b.pedestal = Some(rotorid::model::Pedestal {
            mass: [40.0, 40.0],
            k: [1e8, 1.5e8],
            c: [2e3, 2e3],
        });
    }
    p.name = "paper-pedestal".into();
    assert_eq!(m, p);
    let f = rotorid::io::model_file::load_model_file(example("paper_effects.toml")).unwrap();
    let mut p = RotorModel::paper();
    p.name = "paper-effects".into();
    assert_eq!(f.model, p);
    assert_eq!(f.effects.e_scale, 1.04);
    assert_eq!(f.effects.runout.len(), 1);
    assert_eq!(f.effects.extra_unbalance[0].node, 13);
}

/// Probe declarations (`bearing.probes`): two named probes at angles from
/// +y toward +z; every bad declaration is refused naming its field.
#[test]
fn angled_probe_declarations() {
    let with = |decl: &str| {
        edit(
            &paper_text(),
            "node = 27\n",
            &format!("node = 27\nprobes = [{decl}]\n"),
        )
    };
    let good = with("{ name = \"2X\", angle_deg = 45.0 }, { name = \"2Y\", angle_deg = -45.0 }");
    let f = parse_model_file(&good).unwrap();
    assert_eq!(f.probes.len(), 2);
    assert!(f.probes[0].is_none());
    let p = f.probes[1].as_ref().unwrap();
    assert_eq!(p.names, ["2X".to_string(), "2Y".to_string()]);
    assert_eq!(p.angles, [45f64.to_radians(), (-45f64).to_radians()]);
    // y, z back from the readings.
    let (y, z) = (
        num_complex::Complex64::new(1e-6, -2e-6),
        num_complex::Complex64::new(-3e-7, 4e-6),
    );
    let back = p.to_yz(p.readings(y, z));
    assert!((back[0] - y).norm() < 1e-15 * y.norm() && (back[1] - z).norm() < 1e-15 * z.norm());
    for (decl, field, needle) in [
        ("{ name = \"2X\", angle_deg = 45.0 }", "bearing[2].probes: ", "expected 2 probes"),
        (
            "{ name = \"A\", angle_deg = 0.0 }, { name = \"B\", angle_deg = 90.0 }, { name = \"C\", angle_deg = 45.0 }",
            "bearing[2].probes: ",
            "got 3",
        ),
        (
            "{ name = \"2X\", angle_deg = 45.0 }, { name = \"2Y\", angle_deg = 225.0 }",
            "bearing[2].probes[2].angle_deg: ",
            "parallel",
        ),
        (
            "{ name = \"2X\", angle_deg = 45.0 }, { name = \"2Y\", angle_deg = 48.0 }",
            "bearing[2].probes[2].angle_deg: ",
            "at least 5 deg apart",
        ),
        (
            "{ name = \"2 X\", angle_deg = 45.0 }, { name = \"2Y\", angle_deg = -45.0 }",
            "bearing[2].probes[1].name: ",
            "letters, digits",
        ),
        (
            "{ name = \"2X\", angle_deg = 45.0 }, { name = \"2X\", angle_deg = -45.0 }",
            "bearing[2].probes[2].name: ",
            "probes[1] too",
        ),
        (
            "{ name = \"b1_y\", angle_deg = 45.0 }, { name = \"2Y\", angle_deg = -45.0 }",
            "bearing[2].probes[1].name: ",
            "used twice",
        ),
        (
            "{ name = \"2X\", angle_deg = nan }, { name = \"2Y\", angle_deg = -45.0 }",
            "bearing[2].probes[1].angle_deg: ",
            "",
        ),
        (
            "{ name = \"2X\", angle_deg = 400.0 }, { name = \"2Y\", angle_deg = -45.0 }",
            "bearing[2].probes[1].angle_deg: ",
            "outside -360..=360",
        ),
        (
            "{ name = \"2X\", angle = 45.0 }, { name = \"2Y\", angle_deg = -45.0 }",
            "bearing[2].probes[1].angle: ",
            "unknown field",
        ),
    ] {
        let e = err(&with(decl));
        assert!(e.starts_with(field) && e.contains(needle), "{decl}: {e}");
    }
}
