//! `orogen watersheds`: watershed labels from D8 directions, exact across
//! tiles (`orogen::ops::watersheds`).

use crate::cli::args::{run_one, InOut};
use anyhow::Result;
use clap::Args;
use orogen::ops::watersheds::{self, WatershedsOptions};

/// Arguments of `orogen watersheds`.
#[derive(Args)]
#[command(
    after_help = "Example:\n  orogen fill dem.tif -o f.tif && orogen flow f.tif -o d8.tif\n  orogen watersheds d8.tif -o basins.tif"
)]
pub struct WatershedsArgs {
    /// The input: D8 directions from `orogen flow`.
    #[command(flatten)]
    pub(crate) io: InOut,
}

/// Watershed labels of the input's D8 directions into the output (`ops::watersheds`).
pub fn run(a: WatershedsArgs) -> Result<()> {
    let opts = WatershedsOptions::default();
    run_one(&a.io, &opts, watersheds::run)
}
