//! Human-facing output: SVG plot primitives ([`plot`]) and the
//! identification report ([`identify`]: text table and plots).

pub mod identify;
pub mod plot;
