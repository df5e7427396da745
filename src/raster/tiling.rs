//! Tile layouts and tile views: the unit of work of every tiled step.

use super::georef::GeoRef;
use super::grid::Grid;
use super::window::Window;
use serde::{Deserialize, Serialize};

/// Index of a tile in row-major order of the layout.
pub type TileId = usize;

/// A raster of `width` x `height` cut into square tiles of `tile` cells
/// (the last column and row of tiles may be smaller).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct TileLayout {
    pub width: usize,
    pub height: usize,
    pub tile: usize,
}

impl TileLayout {
    /// New layout (`tile` must be >= 1).
    pub fn new(width: usize, height: usize, tile: usize) -> Self {
        assert!(tile >= 1, "tile size must be at least 1");
        TileLayout {
            width,
            height,
            tile,
        }
    }
    /// Tiles per row.
    pub fn tiles_x(&self) -> usize {
        self.width.div_ceil(self.tile)
    }
    /// Tiles per column.
    pub fn tiles_y(&self) -> usize {
        self.height.div_ceil(self.tile)
    }
    /// Total tiles.
    pub fn count(&self) -> usize {
        self.tiles_x() * self.tiles_y()
    }
    /// (tx, ty) of a tile id.
    pub fn coords(&self, id: TileId) -> (usize, usize) {
        (id % self.tiles_x(), id / self.tiles_x())
    }
    /// Tile id of (tx, ty).
    pub fn id(&self, tx: usize, ty: usize) -> TileId {
        ty * self.tiles_x() + tx
    }
    /// The core window of a tile, clipped to the raster.
    pub fn window(&self, id: TileId) -> Window {
        let (tx, ty) = self.coords(id);
        let x = tx * self.tile;
        let y = ty * self.tile;
        Window::new(
            x as i64,
            y as i64,
            self.tile.min(self.width - x),
            self.tile.min(self.height - y),
        )
    }
    /// Ids of the tiles intersecting `win` (row-major).
    pub fn tiles_in(&self, win: &Window) -> Vec<TileId> {
        let Some(w) = win.intersect(&Window::full(self.width, self.height)) else {
            return Vec::new();
        };
        let tx0 = w.x as usize / self.tile;
        let ty0 = w.y as usize / self.tile;
        let tx1 = (w.x_end() as usize - 1) / self.tile;
        let ty1 = (w.y_end() as usize - 1) / self.tile;
        let mut v = Vec::with_capacity((tx1 - tx0 + 1) * (ty1 - ty0 + 1));
        for ty in ty0..=ty1 {
            for tx in tx0..=tx1 {
                v.push(self.id(tx, ty));
            }
        }
        v
    }
}

/// A tile's core plus a halo of `halo` cells on every side, read from a
/// source, with cells beyond the raster's edge set to nodata (NaN for floats).
#[derive(Debug, Clone)]
pub struct TileView<T> {
    /// Tile id in the layout it was cut from.
    pub id: TileId,
    /// The core window in global cell coordinates.
    pub core: Window,
    /// Halo width in cells.
    pub halo: usize,
    /// Core + halo: `(core.w + 2 halo) x (core.h + 2 halo)` cells.
    pub grid: Grid<T>,
    /// Georeference of the whole raster (use `core` to locate cells).
    pub georef: GeoRef,
    /// Size of the whole raster.
    pub raster_width: usize,
    /// Size of the whole raster.
    pub raster_height: usize,
}

impl<T: Copy> TileView<T> {
    /// Value at core-relative (x, y); x, y may range over `-halo..core+halo`.
    #[inline]
    pub fn at(&self, x: i64, y: i64) -> T {
        let h = self.halo as i64;
        self.grid.get((x + h) as usize, (y + h) as usize)
    }
    /// The window covered by `grid`, in global coordinates.
    pub fn extent(&self) -> Window {
        self.core.expand(self.halo)
    }
    /// Copy of the core cells only.
    pub fn core_grid(&self) -> Grid<T> {
        self.grid.crop(Window::new(
            self.halo as i64,
            self.halo as i64,
            self.core.w,
            self.core.h,
        ))
    }
}

/// Calls `f(tile_a, (xa, ya), tile_b, (xb, yb))` for every pair of
/// 8-adjacent cells that lie in different tiles (tile-local coordinates),
/// each pair once.
pub fn cross_tile_pairs(
    layout: &TileLayout,
    mut f: impl FnMut(usize, (usize, usize), usize, (usize, usize)),
) {
    let (ntx, nty) = (layout.tiles_x(), layout.tiles_y());
    for ty in 0..nty {
        for tx in 0..ntx {
            let a = layout.id(tx, ty);
            let wa = layout.window(a).w;
            let ha = layout.window(a).h;
            if tx + 1 < ntx {
                let b = layout.id(tx + 1, ty);
                for y in 0..ha {
                    for yb in y.saturating_sub(1)..(y + 2).min(ha) {
                        f(a, (wa - 1, y), b, (0, yb));
                    }
                }
            }
            if ty + 1 < nty {
                let b = layout.id(tx, ty + 1);
                for x in 0..wa {
                    for xb in x.saturating_sub(1)..(x + 2).min(wa) {
                        f(a, (x, ha - 1), b, (xb, 0));
                    }
                }
                if tx + 1 < ntx {
                    f(a, (wa - 1, ha - 1), layout.id(tx + 1, ty + 1), (0, 0));
                }
                if tx > 0 {
                    let b = layout.id(tx - 1, ty + 1);
                    f(a, (0, ha - 1), b, (layout.window(b).w - 1, 0));
                }
            }
        }
    }
}

/// Number of perimeter cells of a `w` x `h` tile.
pub fn perimeter_len(w: usize, h: usize) -> usize {
    if w == 0 || h == 0 {
        0
    } else if h == 1 {
        w
    } else {
        2 * w + (h - 2) * if w == 1 { 1 } else { 2 }
    }
}

/// Position of (x, y) in the row-major enumeration of a tile's perimeter
/// cells, or `None` for an interior cell.
pub fn perimeter_index(w: usize, h: usize, x: usize, y: usize) -> Option<usize> {
    let k = if w == 1 { 1 } else { 2 };
    if y == 0 {
        Some(x)
    } else if y + 1 == h {
        Some(w + (h - 2) * k + x)
    } else if x == 0 {
        Some(w + (y - 1) * k)
    } else if x + 1 == w {
        Some(w + (y - 1) * k + 1)
    } else {
        None
    }
}

/// The perimeter cells of a `w` x `h` tile in row-major order.
pub fn perimeter_cells(w: usize, h: usize) -> impl Iterator<Item = (usize, usize)> {
    (0..h).flat_map(move |y| {
        let edge_row = y == 0 || y + 1 == h;
        (0..w)
            .filter(move |&x| edge_row || x == 0 || x + 1 == w)
            .map(move |x| (x, y))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn perimeter_enumeration_matches_index() {
        for w in 1..6 {
            for h in 1..6 {
                let cells: Vec<_> = perimeter_cells(w, h).collect();
                assert_eq!(cells.len(), perimeter_len(w, h), "{w}x{h}");
                for (k, &(x, y)) in cells.iter().enumerate() {
                    assert_eq!(perimeter_index(w, h, x, y), Some(k), "{w}x{h} ({x},{y})");
                }
                for y in 0..h {
                    for x in 0..w {
                        let on = x == 0 || y == 0 || x + 1 == w || y + 1 == h;
                        assert_eq!(perimeter_index(w, h, x, y).is_some(), on);
                    }
                }
            }
        }
    }
}
