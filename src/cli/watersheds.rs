//! `orogen watersheds`: watershed labels from D8 directions, exact across
//! tiles (`hydro::tiled::TiledLabels`).

use crate::{global1, open, In, Out, Run};
use anyhow::Result;
use clap::Args;
use orogen::raster::DType;

/// Arguments of `orogen watersheds`.
#[derive(Args)]
pub struct WatershedsArgs {
    /// D8 directions from `orogen flow`.
    #[command(flatten)]
    pub input: In,
    #[command(flatten)]
    pub out: Out,
    #[command(flatten)]
    pub run: Run,
}

/// Label every cell with the row-major index + 1 of the cell where its D8
/// path leaves the DEM (u32, 0 = nodata).
pub fn run(a: WatershedsArgs) -> Result<()> {
    let src = open(&a.input)?;
    global1(
        &orogen::hydro::tiled::TiledLabels,
        &[src.as_ref()],
        &a.out,
        &a.run,
        (DType::U32, Some(0.0)),
    )
}
