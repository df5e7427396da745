//! `orogen ingest` and `orogen export`: copy rasters into a tile store or a
//! file format (`ops::convert`).

use crate::cli::args::InOut;
use crate::{engine, open, target, warn_georef, wrote, InputArgs, Out, Run};
use anyhow::Result;
use clap::Args;
use orogen::raster::RasterSource;
use std::path::PathBuf;

/// Ingest the inputs (one mosaic) into the output.
pub fn run_ingest(a: IngestArgs) -> Result<()> {
    let src = orogen::io::open_inputs(&a.inputs, &a.reading.open_options())?;
    warn_georef(src.as_ref());
    orogen::ops::note::note_band(src.as_ref(), &mut crate::cli::erode::printer(false));
    convert(src.as_ref(), &a.out, &a.run)
}

/// Export the input into the output.
pub fn run_export(a: ExportArgs) -> Result<()> {
    let src = open(&a.io.input)?;
    convert(src.as_ref(), &a.io.out, &a.io.run)
}

fn convert(src: &dyn RasterSource, out: &Out, run: &Run) -> Result<()> {
    let t = target(out, run)?;
    orogen::ops::convert::run(
        src,
        &t,
        &engine(run)?,
        &mut crate::cli::erode::printer(false),
    )?;
    wrote(&out.output);
    Ok(())
}

/// Arguments of `orogen ingest`.
#[derive(Args)]
#[command(
    after_help = "Examples:\n  orogen ingest ../shared/data/poland_N49-55_E014-025.tif -o poland.tiles --memory 256MiB\n  orogen ingest N43E006.hgt N43E007.hgt -o alps.tiles --store-tile 512\n  orogen ingest srtm_folder/ -o mosaic.tiles\nRerunning an interrupted ingest resumes it."
)]
pub struct IngestArgs {
    /// Input rasters or folders (several = one mosaic).
    #[arg(required = true)]
    pub inputs: Vec<PathBuf>,
    #[command(flatten)]
    pub reading: InputArgs,
    #[command(flatten)]
    pub out: Out,
    #[command(flatten)]
    pub run: Run,
}

/// Arguments of `orogen export`.
#[derive(Args)]
#[command(
    after_help = "Example:\n  orogen export dem.tiles -o dem.tif --compress zstd --predictor 2"
)]
pub struct ExportArgs {
    #[command(flatten)]
    pub(crate) io: InOut,
}
