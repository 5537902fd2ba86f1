//! The identification: the paper's section 4, noise, reported standard
//! deviations, steady running, the firmware path and its table grid, the
//! identified rotor's natural frequencies, `rotorid identify`.

mod campbell;
mod cli;
mod coastdown;
mod firmware;
mod noise;
pub(crate) mod output_error;
mod paper;
mod phase_reference;
mod precision;
mod prefilter;
pub(crate) mod real_noise;
mod std_dev;
mod steady;
mod table_grid;
