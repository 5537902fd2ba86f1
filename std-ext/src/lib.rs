//! # rotorid
//!
//! The desktop half of rotorid: the finite-element rotor model, the
//! bearing-level tables it precomputes for firmware, simulation,
//! identification, diagnosis, file formats, plots and the `rotorid` binary.
//! The firmware half (filter, table reader, identifier) is
//! [`rotorid_core`], re-exported as [`core`].
//!
//! Conventions (see the README): SI units inside (m, kg, s, N, rad/s; rpm
//! only at the edges), rotation about x, node DOFs `(y, z, phi_y, phi_z)`,
//! nodes 0-based in code and 1-based in files, reports and the CLI, phasors
//! `y(t) = Re{ Y exp(j Omega t) }`, bearing coefficients in the order
//! `yy, yz, zy, zz`.

pub use rotorid_core as core;

/// Physical description of a rotor (material, shaft, disks, bearings,
/// pedestals, unbalance, bow): what a model file says.
pub mod model;

// Finite-element model.
pub mod assembly;
pub mod banded;
pub mod bearing;
pub mod campbell;
pub mod disk;
pub mod response;
pub mod shaft;

// Bearing-level tables for firmware.
pub mod grid;
pub mod reduction;
pub mod tables;

// Files, simulation, identification, plots.
pub mod identify;
pub mod measurement;
pub mod model_file;
pub mod plot;
pub mod ross;
pub mod simulate;
pub mod units;

/// The command line (`rotorid`): argument parsing, model loading, errors.
pub mod cli;
