//! Files: rotorid's TOML model files ([`model_file`]), rotors saved by ROSS
//! ([`ross`]) and the measurement CSV ([`measurement`]).

pub mod measurement;
pub mod model_file;
pub mod ross;
