//! `orogen metric`: terrain descriptors in one pass (`ops::metric`), and
//! `orogen metric list`.

use crate::{engine, open, output_options, wrote, In, InputArgs, OutFmt, Run};
use anyhow::{bail, Result};
use clap::Args;
use orogen::ops::metric::{self, MetricOptions};
use std::path::PathBuf;

/// List the metrics, or compute the requested ones into the output folder.
pub fn run(a: MetricArgs) -> Result<()> {
    if a.input.as_os_str() == "list" {
        print!("{}", orogen::metrics::list());
        return Ok(());
    }
    let Some(spec) = a.metric else {
        bail!("give the metrics to compute with --metric (see `orogen metric list`)");
    };
    let Some(dir) = a.output else {
        bail!("give an output folder with -o DIR");
    };
    let opts = MetricOptions {
        metric: spec,
        format: a.format,
    };
    // Checked before the input is opened (no georeference warning first).
    opts.specs()?;
    let src = open(&In {
        input: a.input.clone(),
        reading: a.reading,
    })?;
    let oo = output_options(&a.out)?;
    let paths = metric::run(src.as_ref(), &dir, &opts, &oo, a.run.tile, &engine(&a.run)?)?;
    for p in &paths {
        wrote(p);
    }
    Ok(())
}

/// Arguments of `orogen metric`.
#[derive(Args)]
#[command(
    after_help = "Examples:\n  orogen metric list\n  orogen metric table [DEM] -o table/   (cost table and correlation matrix; see orogen metric table --help)\n  orogen metric dem.tif --metric slope,aspect,tpi:radius=500m,openness:radius=1km -o out/\n  orogen metric dem.tiles --metric mean_curvature:radius=5c,relief:radius=300m -o out/ --format tiles\nOne file per metric is written into the output folder, named after the metric and its parameters."
)]
pub struct MetricArgs {
    /// Input raster, or `list` to print the metrics and their parameters.
    pub input: PathBuf,
    /// Comma-separated metrics with parameters (`name:param=value:...`).
    #[arg(long, short = 'm')]
    pub metric: Option<String>,
    /// Output folder.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Output format: tif or tiles.
    #[arg(long, default_value = "tif")]
    pub format: String,
    #[command(flatten)]
    pub reading: InputArgs,
    #[command(flatten)]
    pub out: OutFmt,
    #[command(flatten)]
    pub run: Run,
}
