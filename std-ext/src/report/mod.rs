//! Human-facing output: SVG plot primitives ([`plot`]) and the
//! identification report ([`identify`]: text table and plots), the
//! diagnosis report ([`diagnose`]: text, JSON, plots), the simulated
//! sweep's Bode and polar plots ([`simulate`]).

pub mod diagnose;
pub mod identify;
pub mod plot;
pub mod simulate;
