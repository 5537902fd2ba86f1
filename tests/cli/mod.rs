//! The `rotorid` command line: the error contract, `simulate` and
//! `campbell`.

mod errors;
mod simulate;
