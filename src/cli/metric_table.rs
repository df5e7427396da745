//! `orogen metric table [DEM] -o DIR`: the survey's cost table (time of
//! every metric relative to slope at several radii) and correlation matrix
//! (CSV + PNG heat map), see `orogen::ops::metric_table`.

use anyhow::{Context, Result};
use clap::Parser;
use orogen::ops::metric_table::{self, MetricTableOptions};
use std::path::PathBuf;

/// Default DEM: the survey's own terrain (Mont Blanc, 647 x 647 cells of ~92.7 m).
pub const DEFAULT_DEM: &str = "../shared/data/terraindescriptors_alps_montblanc.tif";

/// Arguments of `orogen metric table`.
#[derive(Parser, Debug)]
#[command(
    name = "orogen metric table",
    about = "Cost table (time of each metric relative to slope, single-threaded) and Pearson correlation matrix of the metrics, as in the terrain-descriptors survey (Tables 1-2, Fig. 52)",
    after_help = "Example:\n  orogen metric table ../shared/data/terraindescriptors_alps_montblanc.tif -o table/\nWrites cost.csv, cost.md, correlation.csv, correlation.png (rows and columns labelled by index) and correlation_legend.csv.\nRuns in memory on the whole raster; use a release build for meaningful times."
)]
pub struct MetricTableArgs {
    /// Input DEM (default: the survey's Mont Blanc terrain).
    #[arg(default_value = DEFAULT_DEM)]
    pub input: PathBuf,
    /// Output folder.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Radii for the metrics with a radius, comma separated (m, km or c).
    #[arg(long, default_value = "100m,500m,1500m,5000m")]
    pub radii: String,
    /// Radius of the metrics in the correlation matrix.
    #[arg(long, default_value = "500m")]
    pub corr_radius: String,
    /// Timing runs per metric (the best is kept).
    #[arg(long, default_value_t = 1)]
    pub repeats: usize,
    /// Only these metrics in the cost table (comma-separated names).
    #[arg(long)]
    pub only: Option<String>,
    /// Skip the cost table (correlation only).
    #[arg(long)]
    pub no_cost: bool,
    /// Largest raster (cells) accepted; the table runs in memory.
    #[arg(long, default_value_t = 16_000_000)]
    pub max_cells: usize,
    /// Print no progress.
    #[arg(long, short)]
    pub quiet: bool,
}

/// Write the cost table and correlation matrix (`ops::metric_table`).
pub fn run(a: MetricTableArgs) -> Result<()> {
    let src = orogen::io::open_raster(&a.input, &Default::default())
        .with_context(|| format!("{}: cannot open the DEM", a.input.display()))?;
    let opts = MetricTableOptions {
        radii: a.radii.clone(),
        corr_radius: a.corr_radius.clone(),
        repeats: a.repeats,
        only: a.only.clone(),
        no_cost: a.no_cost,
        max_cells: a.max_cells,
    };
    let quiet = a.quiet;
    let done = metric_table::run(src.as_ref(), &a.output, &opts, |r| {
        if !quiet {
            eprintln!(
                "{:<22} r={:>8} {:>8.4} s  x{:.2}{}",
                r.name,
                r.radius_m
                    .map(|m| format!("{m}m"))
                    .unwrap_or_else(|| "-".into()),
                r.seconds,
                r.relative,
                if r.skipped.is_some() {
                    "  (skipped)"
                } else {
                    ""
                }
            );
        }
    })?;
    if !quiet {
        for f in &done.files {
            eprintln!("wrote {}", f.display());
        }
        if let Some(md) = &done.cost_markdown {
            print!("{md}");
        }
    }
    Ok(())
}
