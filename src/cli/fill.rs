//! `orogen fill`: fill depressions, exact across tiles (`ops::fill`).

use crate::cli::args::{run_one, InOut};
use anyhow::Result;
use clap::Args;
use orogen::ops::fill::{self, FillOptions};

/// Fill the input's depressions into the output.
pub fn run(a: FillArgs) -> Result<()> {
    run_one(&a.io, &FillOptions::default(), fill::run)
}

/// Arguments of `orogen fill`.
#[derive(Args)]
#[command(
    after_help = "Example:\n  orogen fill dem.tif -o filled.tif\n  orogen fill poland.tiles -o filled.tiles --memory 512MiB\nNodata cells and the DEM's edge are outlets."
)]
pub struct FillArgs {
    #[command(flatten)]
    pub(crate) io: InOut,
}
