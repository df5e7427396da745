//! `orogen ingest` and `orogen export`: copy a raster (or a mosaic) into
//! another format, tile by tile, in its native type.

use super::{choose_layout, Target};
use crate::error::Result;
use crate::exec::{EngineConfig, LocalEngine};
use crate::io::{self, OutputOptions};
use crate::raster::RasterSource;
use crate::store::Provenance;
use std::path::Path;

/// Copy `src` to `target` (`orogen ingest`, `orogen export`).
pub fn run(src: &dyn RasterSource, target: &Target, cfg: &EngineConfig) -> Result<()> {
    convert(src, &target.path, &target.options, target.tile, cfg)
}

/// Copy any raster (or mosaic) into `out` (a tile store, GeoTIFF, PNG or ASCII
/// file) in its native type, tile by tile.
pub fn convert(
    src: &dyn RasterSource,
    out: &Path,
    oo: &OutputOptions,
    tile: Option<usize>,
    cfg: &EngineConfig,
) -> Result<()> {
    let info = src.info();
    let layout = choose_layout(src, &[out.to_path_buf()], oo, tile);
    let prov = Provenance::new(
        "ingest",
        serde_json::Value::Object(Default::default()),
        vec![info.path.display().to_string()],
    );
    let sink = io::create_sink_like(out, info, info.dtype, &info.georef, oo, prov)?;
    crate::exec::copy(src, sink, layout, &LocalEngine::new(cfg.clone()))
}
