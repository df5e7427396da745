//! `orogen metric`: several terrain descriptors in one pass over the tiles
//! (see [`crate::metrics`] for the registry and each metric's source), one
//! file per metric in an output folder.

use crate::error::{Error, Result};
use crate::exec::EngineConfig;
use crate::io::OutputOptions;
use crate::metrics::MetricSpec;
use crate::raster::RasterSource;
use std::path::{Path, PathBuf};

/// Options of `orogen metric`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MetricOptions {
    /// Comma-separated metrics with parameters (`name:param=value:...`).
    pub metric: String,
    /// Output format: tif or tiles.
    pub format: String,
}

impl Default for MetricOptions {
    fn default() -> Self {
        MetricOptions {
            metric: String::new(),
            format: "tif".into(),
        }
    }
}

impl MetricOptions {
    /// Check the format and parse the metric list.
    pub fn specs(&self) -> Result<Vec<MetricSpec>> {
        let format = &self.format;
        if format != "tif" && format != "tiles" {
            return Err(Error::invalid(format!(
                "--format {format:?}: use tif or tiles"
            )));
        }
        crate::metrics::parse_specs(&self.metric)
    }
}

/// Compute the metrics of `opts` on `dem` into the folder `dir` (created if
/// needed), one file per metric named after it and its parameters; returns
/// the files written.
pub fn run(
    dem: &dyn RasterSource,
    dir: &Path,
    opts: &MetricOptions,
    oo: &OutputOptions,
    tile: Option<usize>,
    cfg: &EngineConfig,
) -> Result<Vec<PathBuf>> {
    let specs = opts.specs()?;
    std::fs::create_dir_all(dir).map_err(|e| {
        Error::invalid(format!(
            "{}: cannot create the output folder: {e}",
            dir.display()
        ))
    })?;
    let paths = crate::metrics::output_paths(&specs, dir, &opts.format)?;
    crate::metrics::compute(dem, &specs, &paths, oo, tile, cfg)?;
    Ok(paths)
}

/// The files [`run`] writes into `dir` for `opts`, one per metric, in the
/// order of `opts.metric` (nothing is created).
pub fn output_paths(dir: &Path, opts: &MetricOptions) -> Result<Vec<PathBuf>> {
    crate::metrics::output_paths(&opts.specs()?, dir, &opts.format)
}
