//! The `raycaster` command's own layer over the library: argument parsing ([`cli`]), the
//! choice of renderer ([`backend`]), one command line's work and batches ([`job`]),
//! `raycaster bench` ([`bench`]), the progress bar of long work ([`progress`]), how the
//! command ends ([`exit`]) and interrupts ([`signals`]). Nothing here is part of the
//! library's API.

pub mod backend;
pub mod bench;
pub mod cli;
pub mod exit;
pub mod job;
pub mod output;
pub mod progress;
pub mod signals;
pub mod split;
