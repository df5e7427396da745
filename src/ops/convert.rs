//! `orogen ingest` and `orogen export`: copy a raster (or a mosaic) into
//! another format, tile by tile, in its native type.

use super::note::{Note, Notify};
use super::{choose_layout, Target};
use crate::error::Result;
use crate::exec::{EngineConfig, LocalEngine};
use crate::io::{self, OutputOptions};
use crate::raster::RasterSource;
use crate::store::Provenance;
use std::path::Path;

/// Copy `src` to `target` (`orogen ingest`, `orogen export`); a warning
/// when its nodata cannot be stored in its type (see [`convert`]).
pub fn run(
    src: &dyn RasterSource,
    target: &Target,
    cfg: &EngineConfig,
    notify: Notify<'_>,
) -> Result<()> {
    let info = src.info();
    if let Some(v) = info.georef.nodata.filter(|&v| !info.dtype.represents(v)) {
        notify(Note::Warning(format!(
            "{}: nodata {v} cannot be stored in {} and no cell holds it; {} is written without nodata (every cell is data, as GDAL reads it)",
            info.path.display(),
            info.dtype,
            target.path.display()
        )));
    }
    convert(src, &target.path, &target.options, target.tile, cfg)
}

/// Copy any raster (or mosaic) into `out` (a tile store, GeoTIFF, PNG or ASCII
/// file) in its native type, tile by tile. A declared nodata the type
/// cannot hold (256 on u8: GDAL accepts it, and no cell equals it) is
/// dropped: no cell was nodata, and none is.
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
    let mut georef = info.georef.clone();
    georef.nodata = georef.nodata.filter(|&v| info.dtype.represents(v));
    let sink = io::create_sink_like(out, info, info.dtype, &georef, oo, prov)?;
    crate::exec::copy(src, sink, layout, &LocalEngine::new(cfg.clone()))
}
