//! Estimation of the bearing coefficients and unbalance from measured
//! responses.
//!
//! * [`unknowns`]: what the unknowns are (the core's
//!   [`rotorid_core::parametrization`] bound to a rotor's nodes and a
//!   scaling, [`Parametrization`]); every reading of weights goes through it.
//! * [`sweep`]: the identification of a speed sweep: the equation-error
//!   QRD/RLS pass (the paper's method, the firmware's kernel on `Vec`
//!   buffers), the runout handling and, by default, the output-error fit
//!   after it ([`identify`], [`Options`], [`Identification`]).
//! * [`uncertainty`]: covariance of the weights and standard deviations.
//! * [`predictor`], [`output_error`], [`noise`]: the output-error
//!   (maximum-likelihood) fit of the predicted bearing responses to the
//!   measured ones, its Fisher information, and the model-free noise level;
//!   [`refine`] runs it after the QRD/RLS and checks the fit; [`design`]
//!   reads the Fisher information as a design of the test.
//! * [`results`]: the reported [`Estimate`] in physical units
//!   (`serde::Serialize`).

pub mod design;
pub mod noise;
pub mod output_error;
pub mod predictor;
pub mod refine;
pub mod results;
pub mod sweep;
pub mod uncertainty;
pub mod unknowns;

pub use results::Estimate;
pub use sweep::*;
pub use uncertainty::StdSet;
pub use unknowns::Parametrization;
