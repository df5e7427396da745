//! `orogen fill`: fill depressions, exact across tiles (`ops::fill`).

use crate::cli::args::{run_one, InOut};
use anyhow::Result;
use clap::Args;
use orogen::ops::fill::{self, FillOptions};

/// Fill the input's depressions into the output.
pub fn run(a: FillArgs) -> Result<()> {
    let opts = FillOptions {
        sinks: a.sinks.clone(),
    };
    run_one(&a.io, &opts, fill::run)
}

/// Arguments of `orogen fill`.
#[derive(Args)]
#[command(
    after_help = "Example:\n  orogen fill dem.tif -o filled.tif\n  orogen fill poland.tiles -o filled.tiles --memory 512MiB\n  orogen fill dem.tif --sinks sinks.csv -o filled.tif   (endorheic basins drain to their sinks)\nNodata cells, the DEM's edge and declared sinks are outlets."
)]
pub struct FillArgs {
    #[command(flatten)]
    pub(crate) io: InOut,
    /// Declared sinks: a raster on the DEM's grid (non-zero = sink) or
    /// points (CSV x,y or lon,lat; GeoJSON Points), each the cell it falls
    /// in. They are outlets like the edge: an endorheic basin drains into
    /// its sink instead of filling up to its spill point. Give the same
    /// file to `orogen flow --sinks`.
    #[arg(long, value_name = "FILE")]
    pub(crate) sinks: Option<std::path::PathBuf>,
}
