//! # rotorid
//!
//! The desktop half of rotorid: the finite-element rotor model, the
//! bearing-level tables it precomputes for firmware, simulation,
//! identification, diagnosis, file formats, plots and the `rotorid` binary.
//! The firmware half (filter, table reader, identifier) is
//! [`rotorid_core`], re-exported as [`core`].
//!
//! # Data flow and layering
//!
//! ```text
//! model -> fe -> reduce -> tables -> estimate -> (diagnose) -> report -> cli
//!   ^ io (model files, ROSS files, measurement CSV)    simulate (fe + model::extension)
//!                                                       campbell (fe)
//! ```
//!
//! The top-level modules form layers, lowest first: [`units`], [`model`],
//! [`io`], [`fe`], [`reduce`], [`tables`], [`mod@campbell`], [`mod@simulate`], [`estimate`],
//! [`mod@diagnose`], [`report`], [`cli`]. A module may use the ones before it, never one
//! after it (`tests/architecture.rs` checks this on the source), so there
//! are no import cycles and each stage can be read and tested on its own.
//!
//! Conventions (see the README): SI units inside (m, kg, s, N, rad/s; rpm
//! only at the edges), rotation about x, node DOFs `(y, z, phi_y, phi_z)`,
//! nodes 0-based in code and 1-based in files, reports and the CLI, phasors
//! `y(t) = Re{ Y exp(j Omega t) }`, bearing coefficients in the order
//! `yy, yz, zy, zz`.
//!
//! # The front door
//!
//! The jobs of the `rotorid` command, each a function of the model, the
//! measurements and an options struct whose `Default` is the command's
//! default: [`identify`] ([`IdentifyOptions`]), [`diagnose()`]
//! ([`DiagnoseOptions`]), [`simulate()`] ([`SimOptions`]); and of the model
//! alone, [`campbell()`] ([`CampbellOptions`]). A measurement file is read
//! for its model by [`read_for_model`].
//!
//! ```no_run
//! let file = rotorid::io::model_file::model_file_by_name_or_path("paper")?;
//! let read = rotorid::read_for_model("sweep.csv".as_ref(), &file)?;
//! let id = rotorid::identify(&file.model, &read.measurements, &Default::default())?;
//! println!("{}", serde_json::to_string_pretty(&id.result())?);
//! let d = rotorid::diagnose(&file.model, &read.measurements, &Default::default())?;
//! println!("{}", d.effect.name());
//! let c = rotorid::campbell(&file.model, &Default::default())?;
//! println!("{}", rotorid::report::campbell::CampbellReport::new("paper", &c).text());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! `examples/library.rs` runs it on the built-in reference rotor.
#![warn(missing_docs)]

pub use rotorid_core as core;

pub use campbell::{campbell, CampbellAnalysis, CampbellOptions};
pub use diagnose::{diagnose, DiagnoseOptions, Diagnosis};
pub use estimate::{identify, Identification, IdentifyError, Options as IdentifyOptions, Progress};
pub use io::measurement::{read_for_model, Measurements, ModelMeasurements};
pub use model::RotorModel;
pub use simulate::{simulate, SimOptions};

pub mod units;

/// Physical description of a rotor (material, shaft, disks, bearings,
/// pedestals, unbalance, bow) and the physical effects a nominal model may
/// lack ([`model::extension`]): what a model file says.
pub mod model;

pub mod io;

pub mod fe;

pub mod reduce;

pub mod tables;

pub mod campbell;

pub mod simulate;

pub mod signals;

pub mod estimate;

pub mod diagnose;

pub mod report;

pub mod cli;
