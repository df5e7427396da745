//! `orogen fill-nodata`: fill voids by inverse-distance weighting along 16
//! rays out to a maximum distance, exact across tiles (`ops::fill_nodata`).

use crate::cli::args::{run_one, InOut};
use anyhow::{Context, Result};
use clap::Args;
use orogen::ops::fill_nodata::{self, FillNodataOptions};
use orogen::ops::parse;

/// Arguments of `orogen fill-nodata`.
#[derive(Args)]
#[command(
    after_help = "Method: each void cell takes the inverse-distance-weighted (1/d²) mean of the first\n\
valid cell met on each of 16 rays (the 8 compass directions and the 8 knight moves), out to\n\
--max-distance: the interpolation GDAL's gdal_fillnodata defines, without smoothing passes.\n\
Void cells with no valid cell on any ray within the distance stay nodata; valid cells are\n\
copied unchanged; the output has the input's cell type and nodata value. The input must\n\
declare a nodata value. Exact across tiles (the halo is the maximum distance).\n\n\
Examples:\n  orogen fill-nodata srtm.hgt -o filled.tif\n  \
orogen fill-nodata dem.tif -o filled.tif --max-distance 3km\n  \
orogen fill-nodata dem.tiles -o filled.tiles --max-distance 50 --memory 1GiB"
)]
pub struct FillNodataArgs {
    #[command(flatten)]
    pub(crate) io: InOut,
    /// How far to search for valid cells: cells (100, as gdal_fillnodata -md) or
    /// metres (500m, 3km; with each row's true cell size on geographic grids).
    #[arg(long, default_value = "100")]
    pub max_distance: String,
}

/// Fill the input's voids into the output (`ops::fill_nodata`).
pub fn run(a: FillNodataArgs) -> Result<()> {
    let opts = FillNodataOptions {
        max_distance: parse::reach(&a.max_distance).context("--max-distance")?,
    };
    run_one(&a.io, &opts, fill_nodata::run)
}
