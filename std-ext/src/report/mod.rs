//! Human-facing output: SVG plot primitives ([`plot`]) and the
//! identification report ([`identify`]: text table and plots), the
//! diagnosis report ([`diagnose`]: text, JSON, plots), the Campbell
//! diagram report ([`campbell`]: text, JSON, CSV, plot), the simulated
//! sweep's Bode and polar plots ([`simulate`]), the extracted vectors'
//! Bode plots with error bars and polar plot ([`vectors`]).

pub mod campbell;
pub mod diagnose;
pub mod identify;
pub mod plot;
pub mod simulate;
pub mod vectors;
