//! orogen: an out-of-core engine for digital elevation models.
//!
//! Large DEMs are cut into tiles (`store`), steps run over tiles (`exec`):
//! local steps with halos, global steps as map/reduce/apply over small
//! per-tile summaries. See `ARCHITECTURE.md` for the map of the crate.

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
