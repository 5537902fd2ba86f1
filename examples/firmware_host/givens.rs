//! The firmware's run (`examples/firmware/src/run.rs`, the same source)
//! with the Givens block filter, as the firmware's `givens` feature builds
//! it.

/// The identifier with the Givens block filter.
type FwId = rotorid_core::identify::PhysicalGivensIdentifier<
    f32,
    { super::table::NQ },
    { super::table::NP },
    { super::table::M },
    { super::table::N },
    { super::table::W },
    { super::table::S },
>;

// The same source a second time on purpose: a second copy of the run, bound
// to this module's `FwId`.
#[allow(clippy::duplicate_mod)]
#[path = "../firmware/src/run.rs"]
pub mod run;
