//! `orogen render`: a preview PNG, hillshade blended with a hypsometric
//! colour ramp (or greyscale), see [`crate::tiles::render`].

use crate::error::Result;
use crate::raster::RasterSource;
use crate::tiles::render::{
    render_preview, RenderInfo, RenderKind, RenderOptions as PreviewOptions,
};
use std::path::Path;

/// Options of `orogen render`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RenderOptions {
    /// Longest side of the preview in pixels.
    pub max_size: usize,
    /// Draw a colour legend.
    pub legend: bool,
    /// Greyscale, no hillshade (for non-elevation rasters).
    pub grey: bool,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            max_size: 2048,
            legend: false,
            grey: false,
        }
    }
}

/// Render `src` into the PNG `output`; returns what was drawn (size, value range).
pub fn run(src: &dyn RasterSource, output: &Path, opts: &RenderOptions) -> Result<RenderInfo> {
    let p = PreviewOptions {
        max_size: opts.max_size,
        legend: opts.legend,
        kind: if opts.grey {
            RenderKind::Grey
        } else {
            RenderKind::Elevation
        },
        ..Default::default()
    };
    render_preview(src, output, &p)
}
