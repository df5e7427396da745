//! Native-type copies between sources and sinks (ingest, export) and runs
//! of a local step into memory.

use super::{local::LocalEngine, EngineConfig, MemSink, TileSink};
use crate::error::{Error, Result};
use crate::raster::{AnyGrid, DType, RasterSource, TileId, TileLayout};
use crate::store::{Provenance, StoreOptions, StoreWriter};
use std::path::Path;

/// Copy `src` into `sink` tile by tile in the native type (exact bytes, no
/// nodata conversion), running on `engine`'s pool under its memory budget.
/// Tiles the sink reports done are skipped; the sink is finished at the end.
pub fn copy(
    src: &dyn RasterSource,
    mut sink: Box<dyn TileSink>,
    layout: TileLayout,
    engine: &LocalEngine,
) -> Result<()> {
    let info = src.info();
    if (info.width, info.height) != (layout.width, layout.height) {
        return Err(Error::invalid(format!(
            "copy: {} is {}x{} but the layout is {}x{}",
            info.path.display(),
            info.width,
            info.height,
            layout.width,
            layout.height
        )));
    }
    if sink.dtype() != info.dtype {
        return Err(Error::invalid(format!(
            "copy: {} holds {} cells but the destination holds {}",
            info.path.display(),
            info.dtype,
            sink.dtype()
        )));
    }
    if let Some(l) = sink.layout() {
        if l != layout {
            return Err(Error::invalid(format!(
                "copy: the destination is laid out in tiles of {}, the copy in tiles of {}",
                l.tile, layout.tile
            )));
        }
    }
    let ids: Vec<TileId> = (0..layout.count())
        .filter(|&id| !sink.is_done(id))
        .collect();
    // One native tile read, and the same tile waiting to be written.
    let cells = (layout.tile.min(layout.width) * layout.tile.min(layout.height)) as u64;
    let bytes = 2 * cells * info.dtype.size() as u64;
    let compute = |id: TileId| src.read_native(layout.window(id));
    engine.pipeline("copy", &ids, bytes, &compute, |id, g| {
        sink.write(id, layout.window(id), g)
    })?;
    sink.finish()
}

/// Ingest `src` into the tile store `out_path` with `opts`: a native copy
/// with the store's layout. Rerunning after an interruption resumes: tiles
/// already finished (and verified) are not read again.
pub fn ingest(
    src: &dyn RasterSource,
    out_path: &Path,
    opts: StoreOptions,
    config: &EngineConfig,
) -> Result<()> {
    let info = src.info();
    let provenance = Provenance::new(
        "ingest",
        serde_json::Value::Object(Default::default()),
        vec![info.path.display().to_string()],
    );
    let (sink, layout): (Box<dyn TileSink>, TileLayout) =
        if crate::io::memsink::RemoteRankSink::applies() {
            // Under MPI only rank 0 creates (and locks) the store; the others compute.
            let layout = TileLayout::new(info.width, info.height, opts.tile.max(1));
            let nodata = info.georef.nodata.filter(|v| !v.is_nan());
            let sink = crate::io::memsink::RemoteRankSink::new(info.dtype, nodata, Some(layout));
            (Box::new(sink), layout)
        } else {
            let writer = StoreWriter::create(
                out_path,
                info.width,
                info.height,
                info.dtype,
                &info.georef,
                opts,
                provenance,
            )?;
            let layout = writer.layout();
            (Box::new(writer), layout)
        };
    copy(src, sink, layout, &LocalEngine::new(config.clone()))?;
    super::barrier();
    Ok(())
}

/// Run a local step over `layout` and return its outputs assembled in memory,
/// output `k` as `out_types[k]` (dtype, nodata). For small rasters and tests;
/// big outputs go to a file or store sink instead.
pub fn run_local_to_memory<S: super::LocalStep>(
    engine: &LocalEngine,
    step: &S,
    inputs: &[&dyn RasterSource],
    layout: TileLayout,
    out_types: &[(DType, Option<f64>)],
) -> Result<Vec<AnyGrid>> {
    use super::Engine;
    let mut sinks: Vec<Box<dyn TileSink>> = Vec::with_capacity(out_types.len());
    let mut handles = Vec::with_capacity(out_types.len());
    for &(dtype, nodata) in out_types {
        let (s, h) = MemSink::new(layout.width, layout.height, dtype, nodata);
        sinks.push(Box::new(s));
        handles.push(h);
    }
    engine.run_local(step, super::Run::new(inputs, layout, sinks))?;
    handles
        .iter()
        .map(|h| {
            h.take()
                .ok_or_else(|| Error::invalid("internal: in-memory sink finished without a grid"))
        })
        .collect()
}
