//! rotorid-core's integration tests, one binary (`cargo test -p
//! rotorid-core --test lib`; add `--features baseline` for the comparisons
//! with the reference filters), one module per theme.

mod common;

mod ordertrack;
mod qrdrls;
