//! The diagnosis on generated hidden-effect cases: the right effect named,
//! its size recovered, the gain measured.

mod cases;
mod cli;
mod pedestal_grid;
mod ross_cases;
mod sensitivity;
mod three_bearing;
