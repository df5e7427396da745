//! Rectangular windows in global cell coordinates.

use serde::{Deserialize, Serialize};

/// A rectangle of cells: column `x`, row `y` of its top-left cell (may be
/// negative or beyond the raster for halos), and its size.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Window {
    pub x: i64,
    pub y: i64,
    pub w: usize,
    pub h: usize,
}

impl Window {
    /// New window.
    pub fn new(x: i64, y: i64, w: usize, h: usize) -> Self {
        Window { x, y, w, h }
    }
    /// The whole raster of size `w` x `h`.
    pub fn full(w: usize, h: usize) -> Self {
        Window { x: 0, y: 0, w, h }
    }
    /// Cell count.
    pub fn len(&self) -> usize {
        self.w * self.h
    }
    /// True when empty.
    pub fn is_empty(&self) -> bool {
        self.w == 0 || self.h == 0
    }
    /// Exclusive right column.
    pub fn x_end(&self) -> i64 {
        self.x + self.w as i64
    }
    /// Exclusive bottom row.
    pub fn y_end(&self) -> i64 {
        self.y + self.h as i64
    }
    /// Grown by `m` cells on every side.
    pub fn expand(&self, m: usize) -> Window {
        Window {
            x: self.x - m as i64,
            y: self.y - m as i64,
            w: self.w + 2 * m,
            h: self.h + 2 * m,
        }
    }
    /// Intersection (None if disjoint).
    pub fn intersect(&self, o: &Window) -> Option<Window> {
        let x0 = self.x.max(o.x);
        let y0 = self.y.max(o.y);
        let x1 = self.x_end().min(o.x_end());
        let y1 = self.y_end().min(o.y_end());
        if x1 <= x0 || y1 <= y0 {
            None
        } else {
            Some(Window::new(x0, y0, (x1 - x0) as usize, (y1 - y0) as usize))
        }
    }
    /// True if the cell (x, y) lies inside.
    pub fn contains(&self, x: i64, y: i64) -> bool {
        x >= self.x && y >= self.y && x < self.x_end() && y < self.y_end()
    }
}
