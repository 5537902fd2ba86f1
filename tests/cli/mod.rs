//! The `rotorid` command line: the error contract, `simulate` and
//! `campbell`, outputs, degenerate data and limits.

mod campbell;
mod errors;
mod front_door;
mod responses;
mod robust;
mod simulate;
mod vectors;
