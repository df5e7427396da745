//! The tile engine: local and global steps through `LocalEngine`,
//! `run_global_apply` with delegated store writes, and the choice of engine
//! from the command line and job files.

#[path = "../common/mod.rs"]
mod common;

mod cli;
mod global;
mod global_apply;
mod local;
