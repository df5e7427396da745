//! The output target of an operation.

use crate::error::Result;
use crate::exec::plan::{run_global_to, run_local_to_paths};
use crate::exec::{EngineConfig, GlobalStep, LocalStep};
use crate::io::OutputOptions;
use crate::raster::RasterSource;
use std::path::PathBuf;

/// Where and how an operation writes its raster output: the path (its
/// extension picks the format: `.tif`, `.tiles`, `.png`, `.asc`; a folder for
/// operations that write several files), the format options, and the
/// work-tile size (`None`: an input store's own, else [`super::DEFAULT_TILE`]).
#[derive(Debug, Clone)]
pub struct Target {
    /// Output path.
    pub path: PathBuf,
    /// GeoTIFF / tile-store / COG settings.
    pub options: OutputOptions,
    /// Work-tile size in cells.
    pub tile: Option<usize>,
}

impl Target {
    /// `path` with the default output options and work tiles.
    pub fn new(path: impl Into<PathBuf>) -> Self {
        Target {
            path: path.into(),
            options: OutputOptions::default(),
            tile: None,
        }
    }

    /// Run a one-output local step on `inputs` into this target, written
    /// as the step's output spec declares.
    pub fn run_local<S: LocalStep>(
        &self,
        step: &S,
        inputs: &[&dyn RasterSource],
        cfg: &EngineConfig,
    ) -> Result<()> {
        let out = std::slice::from_ref(&self.path);
        run_local_to_paths(step, inputs, out, &self.options, self.tile, cfg)
    }

    /// Run a one-output global step (map, reduce, apply) on `inputs` into
    /// this target, written as the step's output spec declares.
    pub fn run_global<S: GlobalStep>(
        &self,
        step: &S,
        inputs: &[&dyn RasterSource],
        cfg: &EngineConfig,
    ) -> Result<()> {
        run_global_to(step, inputs, &self.path, &self.options, self.tile, cfg)
    }
}
