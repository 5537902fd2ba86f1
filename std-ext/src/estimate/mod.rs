//! Estimation of the bearing coefficients and unbalance from measured
//! responses.
//!
//! * [`parametrization`]: what the unknowns are (the core's description
//!   bound to a rotor's nodes and a scaling); every reading of weights
//!   goes through it.
//! * [`rls`]: the equation-error QRD/RLS driver (the paper's method, the
//!   firmware's kernel on `Vec` buffers).
//! * [`uncertainty`]: covariance of the weights and standard deviations.
//! * [`results`]: typed results in physical units (`serde::Serialize`).

pub mod parametrization;
pub mod results;
pub mod rls;
pub mod uncertainty;

pub use parametrization::Parametrization;
pub use results::IdentifyResult;
pub use rls::*;
pub use uncertainty::StdSet;
