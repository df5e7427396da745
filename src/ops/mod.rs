//! Whole operations as the CLI (and later job files) run them: open inputs,
//! pick the tile layout, create sinks by output path, run a step on an engine.
//!
//! One module per user operation: an `XxxOptions` struct (the command's
//! parameters, with its names and defaults) and a `run` function that does
//! everything the command does except parsing arguments and printing. Raster
//! outputs are described by a [`Target`] (path, format options, work-tile
//! size); the engine settings by an [`EngineConfig`].

pub mod accumulate;
pub mod aspect;
pub mod basins;
pub mod breach;
#[cfg(feature = "learn")]
pub mod classify;
pub mod compare;
pub mod convert;
pub mod demo;
pub mod fill;
pub mod fill_epsilon;
pub mod fill_nodata;
pub mod flow;
pub mod hillshade;
pub mod hydro_index;
mod hydro_io;
pub mod info;
pub mod metric;
pub mod metric_table;
pub mod orostats;
pub mod parse;
pub mod peaks;
pub mod render;
pub mod ridges;
pub mod slope;
pub mod streams;
mod target;
#[cfg(feature = "archives")]
pub mod tiles;
pub mod viewshed;
pub mod watersheds;

pub use accumulate::{accumulate_multi, FlowMethod, MULTI_FLOW_BYTES_PER_CELL};
pub use convert::convert;
pub use demo::demo;
pub use info::{describe, describe_text, Description};
pub use target::Target;

pub mod erode;
pub mod job;
pub mod note;
pub mod synth;

pub use crate::exec::plan::{
    choose_layout, choose_tile, run_global_to, run_global_to_paths, run_local_to,
    run_local_to_paths, DEFAULT_TILE,
};
