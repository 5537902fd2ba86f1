//! The finite-element rotor model: element matrices ([`shaft`], [`disk`],
//! [`bearing`]), the complex band LU ([`banded`]), global assembly and
//! forcing ([`assembly`]), the 1X response ([`response`]) and the damped
//! eigenvalue analysis ([`campbell`]), and the time integration through a
//! speed ramp ([`transient`]).

pub mod assembly;
pub mod banded;
pub mod bearing;
pub mod campbell;
pub mod disk;
pub mod response;
pub mod shaft;
pub mod transient;
