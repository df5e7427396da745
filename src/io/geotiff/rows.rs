//! Reassembling full-width rows from the engine's tiles (any tile size,
//! increasing tile id order), shared by the GeoTIFF and COG writers.

use crate::error::{Error, Result};
use crate::raster::{AnyGrid, DType, Window};
use std::collections::VecDeque;
use std::path::Path;

/// Rows `y0..y0 + fill.len()` at full width, with the number of cells
/// received so far in each.
#[derive(Debug, Default)]
pub(super) struct RowBuffer {
    pub width: usize,
    pub height: usize,
    pub dtype: Option<DType>,
    /// Row bytes, row after row.
    pub buf: Vec<u8>,
    /// Global row of `buf`'s first row.
    pub y0: usize,
    /// Cells received per buffered row.
    pub fill: VecDeque<usize>,
}

impl RowBuffer {
    pub fn new(width: usize, height: usize, dtype: DType) -> RowBuffer {
        RowBuffer {
            width,
            height,
            dtype: Some(dtype),
            ..Default::default()
        }
    }

    fn row_bytes(&self) -> usize {
        self.width * self.dtype.map_or(1, |d| d.size())
    }

    /// Check tile `core` (its cells in `data`) against the raster and copy it
    /// into the buffered rows. `path` names the output in errors.
    pub fn put(&mut self, path: &Path, core: Window, data: &AnyGrid) -> Result<()> {
        let p = path.display();
        let dtype = self.dtype.unwrap_or(DType::U8);
        if data.dtype() != dtype || data.width() != core.w || data.height() != core.h {
            return Err(Error::invalid(format!(
                "{p}: tile {core:?} holds {}x{} {} cells, expected {}x{} {dtype}",
                data.width(),
                data.height(),
                data.dtype(),
                core.w,
                core.h,
            )));
        }
        if core.x < 0
            || core.x_end() > self.width as i64
            || core.y_end() > self.height as i64
            || core.y < self.y0 as i64
        {
            return Err(Error::invalid(format!(
                "{p}: tile {core:?} is outside the {}x{} raster or its rows were already written",
                self.width, self.height
            )));
        }
        if core.is_empty() {
            return Ok(());
        }
        let size = dtype.size();
        let row_bytes = self.row_bytes();
        let need = core.y_end() as usize - self.y0;
        if self.fill.len() < need {
            self.fill.resize(need, 0);
            self.buf.resize(need * row_bytes, 0);
        }
        let src = data.as_le_bytes();
        let n = core.w * size;
        for r in 0..core.h {
            let ly = core.y as usize - self.y0 + r;
            let d = ly * row_bytes + core.x as usize * size;
            self.buf[d..d + n].copy_from_slice(&src[r * n..(r + 1) * n]);
            self.fill[ly] += core.w;
        }
        Ok(())
    }

    /// Number of complete rows at the front of the buffer.
    pub fn complete(&self) -> usize {
        self.fill.iter().take_while(|&&f| f == self.width).count()
    }

    /// Drop the first `n` buffered rows (after they were written out).
    pub fn consume(&mut self, n: usize) {
        let row_bytes = self.row_bytes();
        self.buf.drain(..n * row_bytes);
        self.fill.drain(..n);
        self.y0 += n;
    }
}
