//! The bearing-level tables: the reduction, the blob and Rust-source
//! formats, speed grids, `rotorid tables`.

mod blob;
mod cli;
mod grid;
mod modal;
mod reduction;
mod source;
