//! `orogen tiles`: web-map pyramids (z/x/y folder, MBTiles, PMTiles).

use anyhow::Result;
use clap::Args;
use orogen::ops::tiles::{self, TilesOptions};
use std::path::PathBuf;

/// Arguments of `orogen tiles`.
#[derive(Args, Clone)]
#[command(
    after_help = "Examples:\n  orogen tiles dem.tif -o dem.pmtiles\n  orogen tiles dem.tiles -o tiles/ -o dem.mbtiles --encoding terrarium --max-zoom 12\n  orogen tiles shade.tif -o shade.pmtiles --encoding color --ramp grey --range 0,255\nInputs: geographic, UTM (WGS 84 / ETRS89) or EPSG:3857 rasters. Nodata is transparent."
)]
pub struct TilesArgs {
    #[command(flatten)]
    pub input: crate::In,
    /// Output: a folder (z/x/y.png; a name with a dot ends with /), FILE.mbtiles or FILE.pmtiles; repeat -o for several.
    #[arg(short, long, required = true)]
    pub output: Vec<PathBuf>,
    /// Tile encoding: terrain-rgb, terrarium (elevation) or color (any raster, with --ramp).
    #[arg(long, default_value = "terrain-rgb")]
    pub encoding: String,
    /// Colour ramp for --encoding color: terrain, viridis, grey, magma.
    #[arg(long, default_value = "viridis")]
    pub ramp: String,
    /// Value range mapped onto the ramp, "lo,hi" (default: the data's min and max).
    #[arg(long)]
    pub range: Option<String>,
    /// Shallowest zoom (default: where the raster fits in about one tile).
    #[arg(long)]
    pub min_zoom: Option<u8>,
    /// Deepest zoom (default: the first whose pixels are no larger than the raster's cells).
    #[arg(long)]
    pub max_zoom: Option<u8>,
    /// Resampling: bilinear (continuous data) or nearest (classes).
    #[arg(long, default_value = "bilinear")]
    pub resampling: String,
    #[command(flatten)]
    pub run: crate::Run,
}

/// Cut the input into a pyramid and write every output (`ops::tiles`).
pub fn run(a: TilesArgs) -> Result<()> {
    let src = crate::open(&a.input)?;
    let cfg = crate::engine(&a.run)?;
    let opts = TilesOptions {
        encoding: a.encoding.clone(),
        ramp: a.ramp.clone(),
        range: a.range.as_deref().map(tiles::parse_range).transpose()?,
        min_zoom: a.min_zoom,
        max_zoom: a.max_zoom,
        resampling: a.resampling.clone(),
    };
    let info = tiles::run(src.as_ref(), &a.output, &opts, &cfg)?;
    if !a.run.quiet {
        eprintln!("{}", tiles::summary(&info));
    }
    for o in &a.output {
        crate::wrote(o);
    }
    Ok(())
}
