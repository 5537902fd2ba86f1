//! The vector QRD/RLS: against batch least squares, input safety, long-run
//! stability in f32, tracking.

mod batch;
mod safety;
mod stability;
mod tracking;
