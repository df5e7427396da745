//! `RasterSource`: anything a step can read windows from (a tile store, a
//! GeoTIFF read block by block, an in-memory grid, a mosaic of files).

use super::dtype::{Cell, DType};
use super::georef::GeoRef;
use super::grid::{AnyGrid, Grid, IntoAny};
use super::tiling::{TileId, TileLayout, TileView};
use super::window::Window;
use crate::error::Result;
use std::path::PathBuf;

/// What every raster source describes about itself.
#[derive(Debug, Clone, PartialEq)]
pub struct RasterInfo {
    pub width: usize,
    pub height: usize,
    pub dtype: DType,
    pub georef: GeoRef,
    /// Natural block size (width, height) for efficient reads (a TIFF's strip
    /// or tile, a store's tile); readers should prefer windows aligned to it.
    pub block: (usize, usize),
    /// The file or directory the data comes from (for error messages).
    pub path: PathBuf,
}

/// A readable raster. Implementations only read windows that lie fully inside
/// the raster, in the native data type; [`read_window`] adds padding and
/// conversion on top, once for all sources.
pub trait RasterSource: Send + Sync {
    /// Size, type, georeference.
    fn info(&self) -> &RasterInfo;
    /// Read `win` (inside the raster) in the native type.
    fn read_native(&self, win: Window) -> Result<AnyGrid>;
    /// The band read (1-based) and the number of bands of the source: a
    /// multi-band file is read one band at a time.
    fn band(&self) -> (usize, usize) {
        (1, 1)
    }
    /// What of the file's georeferencing is not used (ground control
    /// points, RPC coefficients), said when it is opened; `None` when
    /// nothing is left out.
    fn unused_georef(&self) -> Option<&str> {
        None
    }
    /// The scale and offset applied to the file's raw cells on read
    /// (`raw * scale + offset`, GDAL's band Scale/Offset); `None` when the
    /// cells are read as stored.
    fn scaling(&self) -> Option<Scaling> {
        None
    }
}

/// A band's scale and offset: a cell means `raw * scale + offset`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Scaling {
    pub scale: f64,
    pub offset: f64,
}

impl Scaling {
    /// True when applying it changes nothing (scale 1, offset 0).
    pub fn is_identity(&self) -> bool {
        self.scale == 1.0 && self.offset == 0.0
    }
}

/// Read any window of `src` converted to `T`. Cells outside the raster are
/// nodata: NaN for float `T`; for integer `T`, the source's nodata value (or 0).
/// For float `T`, cells equal to the source's nodata value become NaN.
pub fn read_window<T: Cell>(src: &dyn RasterSource, win: Window) -> Result<Grid<T>> {
    let info = src.info();
    let nodata = info.georef.nodata;
    let outside = if T::DTYPE.is_float() {
        T::from_f64(f64::NAN)
    } else {
        T::from_f64(nodata.unwrap_or(0.0))
    };
    let full = Window::full(info.width, info.height);
    match win.intersect(&full) {
        Some(inner) if inner == win => Ok(src.read_native(win)?.to_typed(nodata)),
        Some(inner) => {
            let mut out = Grid::new(win.w, win.h, outside);
            let part: Grid<T> = src.read_native(inner)?.to_typed(nodata);
            out.paste(&part, inner.x - win.x, inner.y - win.y);
            Ok(out)
        }
        None => Ok(Grid::new(win.w, win.h, outside)),
    }
}

/// Read the native window with padding outside the raster (padding = the
/// nodata value, or 0 when there is none).
pub fn read_window_native(src: &dyn RasterSource, win: Window) -> Result<AnyGrid> {
    let info = src.info();
    let full = Window::full(info.width, info.height);
    match win.intersect(&full) {
        Some(inner) if inner == win => src.read_native(win),
        inner => {
            let fill = info.georef.nodata.unwrap_or(0.0);
            let mut out = AnyGrid::filled(info.dtype, win.w, win.h, fill);
            if let Some(inner) = inner {
                let part = src.read_native(inner)?;
                out.paste(&part, inner.x - win.x, inner.y - win.y);
            }
            Ok(out)
        }
    }
}

/// Assemble the [`TileView`] of tile `id` of `layout` with `halo` cells.
pub fn read_view<T: Cell>(
    src: &dyn RasterSource,
    layout: &TileLayout,
    id: TileId,
    halo: usize,
) -> Result<TileView<T>> {
    let core = layout.window(id);
    let grid = read_window::<T>(src, core.expand(halo))?;
    let info = src.info();
    Ok(TileView {
        id,
        core,
        halo,
        grid,
        georef: info.georef.clone(),
        raster_width: info.width,
        raster_height: info.height,
    })
}

/// A raster held in memory (small files: .hgt, .asc, PNG; tests).
pub struct MemRaster {
    info: RasterInfo,
    data: AnyGrid,
}

impl MemRaster {
    /// Wrap a native grid with its georeference.
    pub fn new(data: AnyGrid, georef: GeoRef, path: impl Into<PathBuf>) -> Self {
        let info = RasterInfo {
            width: data.width(),
            height: data.height(),
            dtype: data.dtype(),
            georef,
            block: (data.width(), data.height().min(256)),
            path: path.into(),
        };
        MemRaster { info, data }
    }
    /// Wrap a typed grid.
    pub fn from_grid<T: IntoAny>(g: Grid<T>, georef: GeoRef) -> Self {
        MemRaster::new(T::wrap(g), georef, "<memory>")
    }
    /// The native grid.
    pub fn grid(&self) -> &AnyGrid {
        &self.data
    }
}

impl RasterSource for MemRaster {
    fn info(&self) -> &RasterInfo {
        &self.info
    }
    fn read_native(&self, win: Window) -> Result<AnyGrid> {
        Ok(self.data.crop(win))
    }
}

/// A raster over cells it borrows (row-major, `width` x `height`): an
/// array owned by someone else (a numpy array in the Python package) is
/// read in place, window by window, without a copy of the whole.
pub struct SliceRaster<'a, T> {
    info: RasterInfo,
    data: &'a [T],
}

impl<'a, T: IntoAny> SliceRaster<'a, T> {
    /// Borrow `data` as a `width` x `height` raster; refused unless
    /// `data` holds exactly that many cells.
    pub fn new(
        data: &'a [T],
        width: usize,
        height: usize,
        georef: GeoRef,
        path: impl Into<PathBuf>,
    ) -> Result<Self> {
        if width.checked_mul(height) != Some(data.len()) {
            return Err(crate::error::Error::invalid(format!(
                "{width} x {height} cells need {} values, not {}",
                width.saturating_mul(height),
                data.len()
            )));
        }
        let info = RasterInfo {
            width,
            height,
            dtype: T::DTYPE,
            georef,
            block: (width, height.min(256)),
            path: path.into(),
        };
        Ok(SliceRaster { info, data })
    }
}

impl<T: IntoAny> RasterSource for SliceRaster<'_, T> {
    fn info(&self) -> &RasterInfo {
        &self.info
    }
    fn read_native(&self, win: Window) -> Result<AnyGrid> {
        let w = self.info.width;
        let mut out = Vec::with_capacity(win.len());
        for y in win.y as usize..win.y_end() as usize {
            let row = y * w;
            out.extend_from_slice(&self.data[row + win.x as usize..row + win.x_end() as usize]);
        }
        Ok(T::wrap(Grid::from_vec(win.w, win.h, out)?))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_slice_raster_reads_the_windows_of_the_grid_it_borrows() {
        let cells: Vec<i16> = (0..35).map(|v| v * 3 - 40).collect();
        let borrowed = SliceRaster::new(&cells, 7, 5, GeoRef::pixel(), "<slice>").unwrap();
        let owned = MemRaster::new(
            AnyGrid::I16(Grid::from_vec(7, 5, cells.clone()).unwrap()),
            GeoRef::pixel(),
            "<mem>",
        );
        for win in [
            Window::new(0, 0, 7, 5),
            Window::new(2, 1, 3, 4),
            Window::new(6, 4, 1, 1),
        ] {
            let a = borrowed.read_native(win).unwrap();
            let b = owned.read_native(win).unwrap();
            assert_eq!(a, b, "{win:?}");
        }
        // Row 2, columns 2..5 by hand: cell k = 3k - 40.
        let AnyGrid::I16(g) = borrowed.read_native(Window::new(2, 2, 3, 1)).unwrap() else {
            panic!("not i16");
        };
        assert_eq!(g.data(), &[8, 11, 14]);
        assert!(SliceRaster::new(&cells, 6, 6, GeoRef::pixel(), "<slice>").is_err());
    }
}
