//! The desktop crate's integration tests, one binary (`cargo test --test
//! lib`), one module per theme; filter by module path, e.g.
//! `cargo test --test lib fe::` or `cargo test --test lib identify::paper`.
//!
//! - [`architecture`]: the layering of `std-ext/src`;
//! - [`cli`]: the command line's contract (exit status, one-line errors);
//! - [`fe`]: the finite-element model against closed forms and dense solves;
//! - [`files`]: model files, ROSS files, the measurement CSV, the simulator;
//! - [`tables`]: the reduction, the table blob and source, speed grids;
//! - [`identify`]: the identification on the paper's cases and beyond;
//! - [`transient`]: the time-domain check of the steady-state simulator;
//! - [`common`]: helpers shared by all of them.

mod common;

mod diagnose;

mod architecture;
mod cli;
mod docs;
mod fe;
mod files;
mod identify;
mod tables;
mod transient;
