//! `orogen fill`: fill depressions, exact across tiles (`ops::fill`).

use crate::{engine, open, target, wrote, In, Out, Run};
use anyhow::Result;
use clap::Args;
use orogen::ops::fill::{self, FillOptions};

/// Fill the input's depressions into the output.
pub fn run(a: FillArgs) -> Result<()> {
    let src = open(&a.input)?;
    let t = target(&a.out, &a.run)?;
    fill::run(src.as_ref(), &FillOptions::default(), &t, &engine(&a.run)?)?;
    wrote(&a.out.output);
    Ok(())
}

/// Arguments of `orogen fill`.
#[derive(Args)]
#[command(
    after_help = "Example:\n  orogen fill dem.tif -o filled.tif\n  orogen fill poland.tiles -o filled.tiles --memory 512MiB\nNodata cells and the DEM's edge are outlets."
)]
pub struct FillArgs {
    #[command(flatten)]
    pub input: In,
    #[command(flatten)]
    pub out: Out,
    #[command(flatten)]
    pub run: Run,
}
