//! The order tracker's per-sample entry point for the firmware (the source
//! is `push.rs`, which the host check `examples/firmware_host.rs` includes
//! as a module: both run the same code).
#![no_std]

mod push;
pub use push::*;
