//! `orogen info`: describe a raster (`ops::info`).

use crate::{engine, open, In, Run};
use anyhow::Result;
use clap::Args;
use orogen::ops::info::{self, InfoOptions};

/// Print the description of the input, as text or JSON.
pub fn run(a: InfoArgs) -> Result<()> {
    let src = open(&a.input)?;
    let cfg = engine(&a.run)?;
    let opts = InfoOptions {
        stats: a.stats,
        json: a.json,
    };
    let report = info::run(src.as_ref(), &opts, &cfg)?;
    print!("{}", info::report_text(&report, &opts)?);
    Ok(())
}

/// Arguments of `orogen info`.
#[derive(Args)]
#[command(
    after_help = "Example:\n  orogen info ../shared/data/srtm3_N46E008.tif\n  orogen info dem.tiles --json"
)]
pub struct InfoArgs {
    #[command(flatten)]
    pub input: In,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
    /// Also compute min/max/mean (reads every cell).
    #[arg(long)]
    pub stats: bool,
    #[command(flatten)]
    pub run: Run,
}
