//! Files and the simulator: the measurement CSV, rotorid and ROSS model
//! files, mutated (untrusted) input, the simulated sweep.

mod conventions;
mod measurement;
mod model;
mod robustness;
mod ross;
pub(crate) mod ross_fixtures;
pub mod signals;
mod simulate;
