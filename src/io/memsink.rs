//! A sink that assembles tiles into one in-memory grid and hands it to a
//! whole-file writer at the end (for formats that cannot be streamed: PNG, ASCII).

use crate::error::{Error, Result};
use crate::exec::TileSink;
use crate::raster::{AnyGrid, DType, GeoRef, TileId, Window};

/// Largest raster written through a whole-file format (cells).
pub const MAX_MEM_CELLS: usize = 1 << 28;

type Finisher = Box<dyn FnOnce(AnyGrid, &GeoRef) -> Result<()> + Send>;

/// Collects tiles, then calls `finisher(grid, georef)`.
pub struct MemSink {
    grid: AnyGrid,
    georef: GeoRef,
    finisher: Finisher,
}

impl MemSink {
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
        let fill = georef
            .nodata
            .unwrap_or(if dtype.is_float() { f64::NAN } else { 0.0 });
        Ok(MemSink {
            grid: AnyGrid::filled(dtype, width, height, fill),
            georef,
            finisher,
        })
    }
}

impl TileSink for MemSink {
    fn dtype(&self) -> DType {
        self.grid.dtype()
    }
    fn nodata(&self) -> Option<f64> {
        self.georef.nodata
    }
    fn write(&mut self, _id: TileId, core: Window, data: AnyGrid) -> Result<()> {
        self.grid.paste(&data, core.x, core.y);
        Ok(())
    }
    fn finish(self: Box<Self>) -> Result<()> {
        let s = *self;
        (s.finisher)(s.grid, &s.georef)
    }
}
