//! `orogen peaks`: peaks, saddles and the divide tree (`ops::peaks`).

use crate::{engine, open, In, Run};
use anyhow::Result;
use clap::Args;
use orogen::ops::peaks::{self, PeaksOptions};
use std::path::PathBuf;

/// Find the peaks of the input and write them into the output folder.
pub fn run(a: PeaksArgs) -> Result<()> {
    let opts = PeaksOptions {
        min_prominence: a.min_prominence,
        edge: peaks::parse_edge(&a.edge)?,
        no_isolation: a.no_isolation,
        tiled: a.tiled,
        line_parents: a.line_parents,
        tile: a.run.tile,
        geojson_crs: a.geojson.crs,
    };
    opts.validate()?;
    let cfg = engine(&a.run)?;
    let src = open(&a.input)?;
    let mut notify = super::erode::printer(a.run.quiet);
    peaks::run_noted(src.as_ref(), &a.output, &opts, &cfg, &mut notify)?;
    Ok(())
}

/// Arguments of `orogen peaks`.
#[derive(Args)]
#[command(
    after_help = "Example:\n  orogen peaks ../shared/data/srtm3_S33W071.tif --min-prominence 30 -o out/\nWrites peaks.csv, peaks.geojson, saddles.geojson, divide_tree.geojson and divide_tree.json.\nThe GeoJSON files are WGS 84 longitude/latitude (RFC 7946) unless --geojson-crs native;\npeaks.csv keeps the DEM's coordinates. Keep projected coordinates (with a \"crs\" member):\n  orogen peaks utm.tif --geojson-crs native -o out/\nConventions (Kirmse & de Ferranti 2017): with --edge sea-level (default) the DEM's edge and\nnodata are sea at 0, higher than any peak: an island top's prominence is its height above\nmin(0, L), L the highest level at which its land touches the edge or nodata (below sea level,\ne.g. the Dead Sea, the sea is met at L, so prominence stays >= 0); with --edge unknown the\noutside is ignored and prominences do not change when all elevations are shifted.\nRuns in memory (about 28 bytes per cell) when --memory allows it, else tile by tile with the\nsame results (--tiled forces it):\n  orogen peaks poland.tif --memory 512MiB -o out/"
)]
pub struct PeaksArgs {
    #[command(flatten)]
    pub input: In,
    /// Keep peaks with at least this prominence (DEM units, usually metres).
    #[arg(long, default_value_t = 30.0)]
    pub min_prominence: f64,
    /// Edge and nodata convention: sea-level (the edge and nodata are sea at 0;
    /// land below 0 that reaches them meets the sea at its own level, so island
    /// tops below sea level keep a prominence >= 0) or unknown (the outside is
    /// ignored; shift-invariant).
    #[arg(long, default_value = "sea-level")]
    pub edge: String,
    /// Skip isolation (distance to higher ground).
    #[arg(long)]
    pub no_isolation: bool,
    /// Work tile by tile even if the DEM fits the memory budget.
    #[arg(long)]
    pub tiled: bool,
    /// Also write line parents, relevance and normalised elevation (needs the
    /// whole DEM in memory; not with --tiled).
    #[arg(long)]
    pub line_parents: bool,
    /// Output folder.
    #[arg(short, long)]
    pub output: PathBuf,
    #[command(flatten)]
    pub geojson: crate::GeoJsonArg,
    #[command(flatten)]
    pub run: Run,
}
