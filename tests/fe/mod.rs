//! The finite-element model: beams against closed forms, the Campbell
//! diagram, the unbalance and bow response.

mod beams;
mod campbell;
mod response;
