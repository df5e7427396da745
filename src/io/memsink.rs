//! A sink for whole-file formats (PNG, ASCII): tiles are assembled in memory
//! by [`crate::store::sink::MemSink`], then written by a finisher at the end.

use crate::error::{Error, Result};
use crate::raster::{AnyGrid, DType, GeoRef, TileId, Window};
use crate::store::sink::{process_rank, MemSink, MemSinkHandle, TileSink};

/// Largest raster written through a whole-file format (cells).
pub const MAX_MEM_CELLS: usize = 1 << 28;

type Finisher = Box<dyn FnOnce(AnyGrid, &GeoRef) -> Result<()> + Send>;

/// Collects tiles, then calls `finisher(grid, georef)`.
pub struct WholeFileSink {
    inner: MemSink,
    handle: MemSinkHandle,
    georef: GeoRef,
    finisher: Finisher,
}

impl WholeFileSink {
    /// A sink for a `width` x `height` raster of `dtype`.
    pub fn new(
        width: usize,
        height: usize,
        dtype: DType,
        georef: GeoRef,
        finisher: Finisher,
    ) -> Result<Self> {
        if width.saturating_mul(height) > MAX_MEM_CELLS {
            return Err(Error::invalid(format!(
                "a {width}x{height} output is too large for a whole-file format (PNG/ASCII); write a GeoTIFF (.tif) or a tile store (.tiles) instead"
            )));
        }
        let (inner, handle) = MemSink::new(width, height, dtype, georef.nodata);
        Ok(WholeFileSink {
            inner,
            handle,
            georef,
            finisher,
        })
    }
}

impl TileSink for WholeFileSink {
    fn dtype(&self) -> DType {
        self.inner.dtype()
    }
    fn nodata(&self) -> Option<f64> {
        self.inner.nodata()
    }
    fn write(&mut self, id: TileId, core: Window, data: AnyGrid) -> Result<()> {
        self.inner.write(id, core, data)
    }
    fn finish(self: Box<Self>) -> Result<()> {
        let s = *self;
        Box::new(s.inner).finish()?;
        let grid = s
            .handle
            .take()
            .ok_or_else(|| Error::invalid("internal: in-memory sink finished without a grid"))?;
        (s.finisher)(grid, &s.georef)
    }
}

/// The sink of an output on an MPI rank other than 0: rank 0 writes every
/// tile (in tile-id order, as the local engine does), the other ranks only
/// compute, so their sink neither creates nor locks the output (a tile
/// store's writer lock would refuse every rank but one). It reports the
/// output's layout so the engine's layout check is the same on every rank;
/// the list of tiles to do comes from rank 0's sinks.
#[derive(Debug)]
pub struct RemoteRankSink {
    dtype: DType,
    nodata: Option<f64>,
    layout: Option<crate::raster::TileLayout>,
}

impl RemoteRankSink {
    /// A sink for an output of `dtype`/`nodata`, laid out as `layout` if
    /// the real output has a fixed layout (a tile store).
    pub fn new(
        dtype: DType,
        nodata: Option<f64>,
        layout: Option<crate::raster::TileLayout>,
    ) -> Self {
        RemoteRankSink {
            dtype,
            nodata,
            layout,
        }
    }

    /// True when this process is an MPI rank other than 0 (the outputs are
    /// rank 0's to write).
    pub fn applies() -> bool {
        process_rank().0 != 0
    }
}

impl TileSink for RemoteRankSink {
    fn dtype(&self) -> DType {
        self.dtype
    }
    fn nodata(&self) -> Option<f64> {
        self.nodata
    }
    fn layout(&self) -> Option<crate::raster::TileLayout> {
        self.layout
    }
    fn write(&mut self, _id: TileId, _core: Window, _data: AnyGrid) -> Result<()> {
        Ok(())
    }
    fn finish(self: Box<Self>) -> Result<()> {
        Ok(())
    }
}
