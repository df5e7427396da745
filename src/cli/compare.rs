//! `orogen compare A B -o DIR`: realism report of two terrains (see
//! `orogen::ops::compare`).

use crate::distance;
use anyhow::Result;
use clap::Args;
use orogen::ops::compare::{self, CompareOptions};
use std::path::PathBuf;

/// Arguments of `orogen compare`.
#[derive(Args)]
#[command(
    after_help = "Examples:\n  orogen compare synth.tif ../shared/data/srtm3_S33W071.tif -o cmp/\n  orogen compare a.tif b.tif -o cmp/ --min-prominence 50 --radius 5km --channel-area 0.5\nBoth terrains are read into memory (limit: --memory). Densities are per km²,\ndistributions are fractions on common bins; every distance is 0 for identical terrains."
)]
pub struct CompareArgs {
    /// First terrain (e.g. the synthetic one): any raster orogen reads.
    pub a: PathBuf,
    /// Second terrain (e.g. the real exemplar).
    pub b: PathBuf,
    /// Output folder: compare.json, compare.html, chart PNGs, thumbnails.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Peaks with at least this prominence (m).
    #[arg(long, default_value_t = 30.0)]
    pub min_prominence: f64,
    /// Disk radius of the orometric statistics, e.g. 5km (default: 10 km, or a
    /// quarter of the shorter side of the smaller terrain).
    #[arg(short = 'R', long)]
    pub radius: Option<String>,
    /// Channels start where the drainage area reaches this many km².
    #[arg(long, default_value_t = 1.0)]
    pub channel_area: f64,
    /// Seed of the blue-noise disk placement.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Name of the first terrain in the report (default: its file name).
    #[arg(long)]
    pub label_a: Option<String>,
    /// Name of the second terrain in the report (default: its file name).
    #[arg(long)]
    pub label_b: Option<String>,
    #[command(flatten)]
    pub run: crate::Run,
}

/// Compare the two terrains into the output folder (`ops::compare`).
pub fn run(a: CompareArgs) -> Result<()> {
    let cfg = crate::engine(&a.run)?;
    let opts = CompareOptions {
        min_prominence: a.min_prominence,
        radius: a
            .radius
            .as_deref()
            .map(|r| distance("--radius", r))
            .transpose()?,
        channel_area: a.channel_area,
        seed: a.seed,
        label_a: a.label_a.clone(),
        label_b: a.label_b.clone(),
    };
    let mut notify = super::erode::printer(a.run.quiet);
    compare::run_noted(&a.a, &a.b, &a.output, &opts, &cfg, &mut notify)?;
    Ok(())
}
