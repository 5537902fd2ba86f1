//! Estimation of the bearing coefficients and unbalance from measured
//! responses: the equation-error QRD/RLS driver on the desktop ([`rls`]).

pub mod rls;

pub use rls::*;
