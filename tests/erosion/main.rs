//! Erosion: the local models (hydraulic, thermal, diffusion), stream power in
//! memory and tiled, and `orogen erode` from the command line.

#[path = "../common/mod.rs"]
mod common;

mod cli;
mod cli_stream_power_tiled;
mod engine_choice;
mod local_models;
mod stream_power;
mod stream_power_tiled;
