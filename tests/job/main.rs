//! Job files (`orogen run job.toml`): steps equal the commands run by hand,
//! resume after kill, group commands as steps, clear errors.

mod group_steps;
mod run_file;
