//! `orogen render`: a preview PNG (`ops::render`).

use crate::{open, wrote, In, Run};
use anyhow::Result;
use clap::Args;
use orogen::ops::render::{self, RenderOptions};
use std::path::PathBuf;

/// Render the input into the output PNG.
pub fn run(a: RenderArgs) -> Result<()> {
    let src = open(&a.input)?;
    let opts = RenderOptions {
        max_size: a.max_size,
        legend: a.legend,
        grey: a.grey,
    };
    render::run(src.as_ref(), &a.output, &opts)?;
    wrote(&a.output);
    Ok(())
}

/// Arguments of `orogen render`.
#[derive(Args)]
#[command(
    after_help = "Example:\n  orogen render dem.tiles -o preview.png --legend\n  orogen render slope.tif -o slope.png --grey"
)]
pub struct RenderArgs {
    #[command(flatten)]
    pub input: In,
    #[arg(short, long)]
    pub output: PathBuf,
    /// Longest side of the preview in pixels.
    #[arg(long, default_value_t = 2048)]
    pub max_size: usize,
    /// Draw a colour legend.
    #[arg(long)]
    pub legend: bool,
    /// Greyscale, no hillshade (for non-elevation rasters).
    #[arg(long)]
    pub grey: bool,
    #[command(flatten)]
    pub run: Run,
}
