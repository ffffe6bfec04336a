//! The `raycaster` command's own layer over the library: argument parsing ([`cli`]), the
//! choice of renderer ([`backend`]), one command line's work and batches ([`job`]), and
//! `raycaster bench` ([`bench`]). Nothing here is part of the library's API.

pub mod backend;
pub mod bench;
pub mod cli;
pub mod job;
pub mod output;
pub mod split;
