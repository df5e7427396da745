//! Flat regions: maximal 8-connected sets of valid cells of exactly equal
//! height. Every critical point of the orometry code is a region, so plateaus
//! are handled exactly (no epsilon, no perturbation).

use crate::error::{Error, Result};
use crate::raster::Grid;

/// Marker for nodata cells in [`Regions::label`].
pub(crate) const NONE: u32 = u32::MAX;

/// The 8 neighbour offsets (dx, dy) in the row-major order of the 3x3
/// window, north-west first: the order in which the sweeps meet neighbours,
/// so it fixes which of equal candidates comes first (D8 routing uses
/// another, [`crate::raster::neighbours::DX`]).
pub(crate) const N8: [(i64, i64); 8] = {
    let mut n = [(0, 0); 8];
    let mut k = 0;
    while k < 8 {
        // Window positions 0..9 without the centre, 4.
        let i = if k < 4 { k } else { k + 1 } as i64;
        n[k] = (i % 3 - 1, i / 3 - 1);
        k += 1;
    }
    n
};

/// The neighbours of cell `c` of a `w` x `h` grid that lie inside it, as
/// (cell, x, y), in the order of [`N8`].
#[inline]
pub(crate) fn neighbours_in(
    w: usize,
    h: usize,
    c: usize,
) -> impl Iterator<Item = (usize, i64, i64)> {
    let (x, y) = ((c % w) as i64, (c / w) as i64);
    N8.into_iter().filter_map(move |(dx, dy)| {
        let (nx, ny) = (x + dx, y + dy);
        // Lazily: the cell index of an outside position would overflow.
        (nx >= 0 && ny >= 0 && nx < w as i64 && ny < h as i64)
            .then(|| (ny as usize * w + nx as usize, nx, ny))
    })
}

/// Grow a region breadth-first on a grid `w` cells wide: `cells[first..]`
/// holds its seed cells and serves as the queue, so it ends holding the
/// region. `visit((x, y), (nx, ny))` is called for each of the 8 neighbour
/// positions of each cell (in the order of [`N8`], inside the grid or not)
/// and returns the neighbour cell to add, if any.
#[inline]
pub(crate) fn grow(
    cells: &mut Vec<u32>,
    first: usize,
    w: usize,
    mut visit: impl FnMut((i64, i64), (i64, i64)) -> Result<Option<u32>>,
) -> Result<()> {
    let mut head = first;
    while head < cells.len() {
        let c = cells[head] as usize;
        head += 1;
        let (x, y) = ((c % w) as i64, (c / w) as i64);
        for (dx, dy) in N8 {
            if let Some(n) = visit((x, y), (x + dx, y + dy))? {
                cells.push(n);
            }
        }
    }
    Ok(())
}

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
            grow(&mut cells, first, w, |_, (nx, ny)| {
                if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
                    outside = true;
                    return Ok(None);
                }
                let nb = ny as usize * w + nx as usize;
                let nz = data[nb];
                if nz.is_nan() {
                    outside = true;
                } else if nz == z && label[nb] == NONE {
                    label[nb] = r;
                    return Ok(Some(nb as u32));
                }
                Ok(None)
            })?;
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

#[cfg(test)]
mod tests {
    use super::{neighbours_in, N8};

    #[test]
    fn n8_is_the_window_in_row_major_order() {
        // Each offset is a distinct non-zero one of the 3x3 window, and they
        // come north to south, west to east.
        let pos: Vec<i64> = N8.iter().map(|&(dx, dy)| (dy + 1) * 3 + dx + 1).collect();
        assert!(N8.iter().all(|&(dx, dy)| dx.abs() <= 1 && dy.abs() <= 1));
        assert!(pos.windows(2).all(|p| p[0] < p[1]), "{pos:?}");
        assert!(!pos.contains(&4), "{pos:?}");
    }

    #[test]
    fn neighbours_in_keep_the_grid_cells_only() {
        // 4 x 3 grid: a corner has 3 neighbours, an edge cell 5, inside 8.
        let count = |c| neighbours_in(4, 3, c).count();
        assert_eq!((count(0), count(1), count(5), count(11)), (3, 5, 8, 3));
        let n: Vec<usize> = neighbours_in(4, 3, 0).map(|(n, _, _)| n).collect();
        assert_eq!(n, vec![1, 4, 5]);
        assert!(neighbours_in(4, 3, 6).all(|(n, x, y)| n == y as usize * 4 + x as usize));
    }
}
