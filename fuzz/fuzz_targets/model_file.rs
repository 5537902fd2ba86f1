//! Untrusted input: any text as a model file (rotorid's own TOML format or a
//! ROSS rotor file). Either an error naming the field, or a model that
//! passes validation and from which the FE model is built (so that a value
//! that breaks the assembly is caught at load, with its field's name).
//! Round trip: a model that has a ROSS form is written as ROSS, read back
//! and compared (shaft, disks, bearings, beam theory).
#![no_main]

use libfuzzer_sys::fuzz_target;
use rotorid::model::RotorModel;

/// The parts of a model that the ROSS form carries (names aside).
fn rotor_part(m: &RotorModel) -> RotorModel {
    let mut m = m.clone();
    m.name.clear();
    for e in &mut m.shaft {
        e.material.name.clear();
    }
    m.planes.clear();
    m.unbalance.clear();
    m.bow = None;
    m
}

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let model = if rotorid::io::model_file::is_ross(text) {
        match rotorid::io::ross::parse_ross(text) {
            Ok(m) => m,
            Err(_) => return,
        }
    } else {
        match rotorid::io::model_file::parse_model_file(text) {
            Ok(f) => f.model,
            Err(_) => return,
        }
    };
    assert!(model.validate().is_ok());
    // Small models only: the fuzzer's time goes to parsing, not assembly
    // or writing.
    if model.shaft.len() > 64 {
        return;
    }
    if let Err(e) = rotorid::fe::assembly::FeModel::new(&model) {
        panic!("loaded model does not assemble: {e}");
    }
    let rotor = rotor_part(&model);
    if let Ok(ross) = rotorid::io::ross::to_ross_toml(&rotor) {
        let back = rotorid::io::ross::parse_ross(&ross).expect("written ROSS file reads back");
        assert_eq!(
            rotor_part(&back),
            rotor,
            "ROSS round trip changed the rotor"
        );
    }
});
