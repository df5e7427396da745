//! Flat regions: maximal 8-connected sets of valid cells of exactly equal
//! height. Every critical point of the orometry code is a region, so plateaus
//! are handled exactly (no epsilon, no perturbation).

use crate::error::{Error, Result};
use crate::raster::Grid;

/// Marker for nodata cells in [`Regions::label`].
pub(crate) const NONE: u32 = u32::MAX;

/// The 8 neighbour offsets (dx, dy), in a fixed order.
pub(crate) const N8: [(i64, i64); 8] = [
    (-1, -1),
    (0, -1),
    (1, -1),
    (-1, 0),
    (1, 0),
    (-1, 1),
    (0, 1),
    (1, 1),
];

/// Flat-region labelling of a DEM, with each region's cells stored
/// contiguously (CSR layout) for the sweep.
pub(crate) struct Regions {
    pub width: usize,
    pub height: usize,
    /// Region id of each cell, `NONE` for NaN.
    pub label: Vec<u32>,
    /// `cells[off[r]..off[r+1]]` are the cells of region `r`; the first is the
    /// representative (the region's first cell in row-major order).
    pub off: Vec<u32>,
    pub cells: Vec<u32>,
    /// Elevation of each region.
    pub elev: Vec<f32>,
    /// Whether the region has a cell on the DEM edge or next to a NaN cell.
    pub touches_outside: Vec<bool>,
}

impl Regions {
    /// Label the flat regions of `dem` (NaN = nodata). Region ids are assigned
    /// in row-major order of their first cell, which is also the region's
    /// representative cell: the deterministic rule used everywhere in `oro`.
    pub fn new(dem: &Grid<f32>) -> Result<Regions> {
        let (w, h) = (dem.width(), dem.height());
        let n = w * h;
        if n >= NONE as usize {
            return Err(Error::invalid(format!(
                "orometry: a {w} x {h} grid has too many cells for the in-memory divide tree \
                 (limit {}); cut it into tiles",
                NONE - 1
            )));
        }
        let data = dem.data();
        let mut label = vec![NONE; n];
        let mut off: Vec<u32> = vec![0];
        let mut cells: Vec<u32> = Vec::with_capacity(n);
        let mut elev = Vec::new();
        let mut touches = Vec::new();
        for start in 0..n {
            let z = data[start];
            if z.is_nan() || label[start] != NONE {
                continue;
            }
            if z.is_infinite() {
                return Err(Error::invalid(format!(
                    "orometry: cell ({}, {}) is {z}; elevations must be finite (use NaN for nodata)",
                    start % w,
                    start / w
                )));
            }
            let r = elev.len() as u32;
            let first = cells.len();
            label[start] = r;
            cells.push(start as u32);
            let mut outside = false;
            // The region's cell list doubles as the BFS queue.
            let mut head = first;
            while head < cells.len() {
                let c = cells[head] as usize;
                head += 1;
                let (x, y) = ((c % w) as i64, (c / w) as i64);
                for (dx, dy) in N8 {
                    let (nx, ny) = (x + dx, y + dy);
                    if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
                        outside = true;
                        continue;
                    }
                    let nb = ny as usize * w + nx as usize;
                    let nz = data[nb];
                    if nz.is_nan() {
                        outside = true;
                    } else if nz == z && label[nb] == NONE {
                        label[nb] = r;
                        cells.push(nb as u32);
                    }
                }
            }
            off.push(cells.len() as u32);
            elev.push(z);
            touches.push(outside);
        }
        Ok(Regions {
            width: w,
            height: h,
            label,
            off,
            cells,
            elev,
            touches_outside: touches,
        })
    }

    /// Number of regions.
    pub fn len(&self) -> usize {
        self.elev.len()
    }

    /// Cells of region `r`.
    pub fn cells_of(&self, r: usize) -> &[u32] {
        &self.cells[self.off[r] as usize..self.off[r + 1] as usize]
    }

    /// Representative cell (first in row-major order) of region `r`.
    pub fn rep(&self, r: usize) -> u32 {
        self.cells[self.off[r] as usize]
    }
}
