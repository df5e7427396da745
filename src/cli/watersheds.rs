//! `orogen watersheds`: watershed labels from D8 directions, exact across
//! tiles (`orogen::ops::watersheds`).

use crate::{engine, open, target, wrote, In, Out, Run};
use anyhow::Result;
use clap::Args;
use orogen::ops::watersheds::{self, WatershedsOptions};

/// Arguments of `orogen watersheds`.
#[derive(Args)]
#[command(
    after_help = "Example:\n  orogen fill dem.tif -o f.tif && orogen flow f.tif -o d8.tif\n  orogen watersheds d8.tif -o basins.tif"
)]
pub struct WatershedsArgs {
    /// D8 directions from `orogen flow`.
    #[command(flatten)]
    pub input: In,
    #[command(flatten)]
    pub out: Out,
    #[command(flatten)]
    pub run: Run,
}

/// Watershed labels of the input's D8 directions into the output (`ops::watersheds`).
pub fn run(a: WatershedsArgs) -> Result<()> {
    let src = open(&a.input)?;
    let t = target(&a.out, &a.run)?;
    watersheds::run(
        src.as_ref(),
        &WatershedsOptions::default(),
        &t,
        &engine(&a.run)?,
    )?;
    wrote(&a.out.output);
    Ok(())
}
