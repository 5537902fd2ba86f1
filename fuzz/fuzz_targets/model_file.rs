//! Untrusted input: any text as a model file (rotorid's own TOML format or a
//! ROSS rotor file). Either an error naming the field, or a model that
//! passes validation; never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if rotorid::io::model_file::is_ross(text) {
        if let Ok(model) = rotorid::io::ross::parse_ross(text) {
            assert!(model.validate().is_ok());
        }
    } else if let Ok(file) = rotorid::io::model_file::parse_model_file(text) {
        assert!(file.model.validate().is_ok());
    }
});
