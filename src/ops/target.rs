//! The output target of an operation.

use crate::io::OutputOptions;
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
}
