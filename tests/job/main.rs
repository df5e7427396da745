//! Job files (`orogen run job.toml`): steps equal the commands run by hand,
//! resume after kill, group commands as steps, clear errors; jobs run from
//! the library with the bytes of the operations called directly.

#[path = "../common/mod.rs"]
mod common;
mod group_steps;
mod library;
mod report_previews;
mod run_file;
mod step_paths;
