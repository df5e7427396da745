//! orogen: an out-of-core engine for digital elevation models.
//!
//! Large DEMs are cut into tiles (`store`), steps run over tiles (`exec`):
//! local steps with halos, global steps as map/reduce/apply over small
//! per-tile summaries. See `ARCHITECTURE.md` for the map of the crate.
//!
//! # Using the library
//!
//! Every user operation (what an `orogen` command does) is a function in
//! [`ops`]: `ops::<operation>::run` with that operation's `XxxOptions`
//! (serde, the command's names and defaults), an input ([`RasterSource`],
//! opened with [`open_raster`] or held in memory as a [`MemRaster`] over a
//! [`Grid`]), an output [`Target`] and an [`EngineConfig`] (threads, memory
//! budget, [`EngineKind`]: in this process or MPI). What a library user
//! needs is re-exported here (`ops::flow`, `ops::compare`, `ops::tiles` and
//! `ops::synth` stay under [`ops`]: their names are the algorithm modules'
//! [`flow`], [`compare`], [`tiles`], [`synth`]); the modules hold the
//! algorithms behind them.
//! The batch-job runner [`ops::job`] runs the typed commands of a job file
//! (fill, flow, accumulate, slope, metric, peaks, ...: see
//! [`ops::job::COMMANDS`]) by calling these operations; the others still need
//! the caller's step runner (`orogen run` parses them as command lines).
//!
//! ```
//! use orogen::{fill, Grid, MemRaster, GeoRef, Target, EngineConfig};
//! // A 4 x 3 plateau at 5 with a pit of 1: filling raises the pit to 5.
//! let dem = MemRaster::from_grid(Grid::from_fn(4, 3, |x, y| if (x, y) == (1, 1) { 1.0f32 } else { 5.0 }), GeoRef::pixel());
//! let out = std::env::temp_dir().join(format!("orogen-doc-lib-{}.tif", std::process::id()));
//! fill::run(&dem, &Default::default(), &Target::new(&out), &EngineConfig::default())?;
//! let filled = orogen::open_raster(&out, &Default::default())?;
//! let g = orogen::raster::read_window::<f32>(filled.as_ref(), orogen::raster::Window::full(4, 3))?;
//! assert_eq!(g.data(), &[5.0f32; 12][..]);
//! # std::fs::remove_file(&out)?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! # Features
//!
//! All on by default (the binary and the tests use them); a library user
//! may turn off what pulls in heavy dependencies:
//! `cli` (clap, anyhow: the `orogen` binary; implies `progress`),
//! `progress` (indicatif progress bars, [`exec::Progress`]), `archives`
//! (rusqlite with a bundled SQLite, pmtiles: MBTiles/PMTiles in
//! `tiles::archive`/`tiles::reader` and `ops::tiles`), `learn` (smartcore:
//! `oro::classify`, `ops::classify`); `mpi` (off by default) adds the MPI
//! engine. `cargo build --lib --no-default-features` builds the engine,
//! I/O and every other algorithm.

#[cfg(not(target_endian = "little"))]
compile_error!(
    "orogen stores tiles as little-endian raw arrays and builds only on little-endian targets"
);

pub mod compare;
pub mod erosion;
pub mod error;
pub mod exec;
pub mod flow;
pub mod hydro;
pub mod io;
pub mod metrics;
pub mod ops;
pub mod oro;
pub mod raster;
pub mod report;
pub mod store;
pub mod synth;
pub mod tiles;

pub use error::{Error, Result};
pub use exec::{engine, Engine, EngineConfig, EngineKind, Engines, LocalEngine};
pub use io::{open_raster, OpenOptions, OutputOptions};
pub use ops::{
    accumulate, aspect, basins, breach, fill, fill_epsilon, hillshade, hydro_index, info, metric,
    orostats, peaks, render, ridges, slope, streams, viewshed, watersheds, Target,
};
pub use raster::{DType, GeoRef, Grid, MemRaster, RasterSource, Window};
