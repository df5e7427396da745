//! Isolation: distance from a peak to the nearest cell strictly higher.
//!
//! Branch and bound over a grid of 16 x 16 block maxima: blocks are visited
//! in growing square rings around the peak; a block is scanned only if its
//! maximum exceeds the peak; the search stops when the ring's lower bound on
//! distance exceeds the best distance found. Distances are great-circle
//! (haversine on the sphere of mean radius 6 371 008.8 m, Moritz 2000,
//! "Geodetic Reference System 1980") for geographic CRSs, Euclidean in metres
//! for projected ones, in cells without georeferencing. Kirmse & de Ferranti
//! 2017 define isolation the same way (distance to the nearest higher ground).
//!
//! [`IsolationIndex`] searches a grid in memory; [`TiledIsolationIndex`]
//! keeps only the block maxima (4 bytes per 256 cells) and reads the blocks
//! it must scan from the raster source through a small cache of 256 x 256
//! windows, so isolation of a mosaic needs O(W·H/256) memory. Both run the
//! same search and give the same answers.

use super::tree::{DivideTree, Isolation, Peak};
use crate::error::Result;
use crate::raster::{read_window, GeoRef, Grid, RasterSource, Window};
use std::cell::RefCell;
use std::collections::HashMap;

const B: usize = 16;
const R_EARTH: f64 = 6_371_008.8;

/// Block maxima and distance geometry of one DEM: everything the search
/// needs except the cells themselves.
struct Geometry {
    georef: GeoRef,
    w: usize,
    h: usize,
    bw: usize,
    bh: usize,
    bmax: Vec<f32>,
    geographic: bool,
    planar_unit: f64,
    /// Lower bound on distance (m) for a Chebyshev cell distance k: `lb_a * k`
    /// capped by the longitude term (see `lower_bound`).
    dlat_rad: f64,
    dlon_rad: f64,
    cos_max_lat: f64,
    min_cell: f64,
    bounded: bool,
}

impl Geometry {
    fn new(w: usize, h: usize, bmax: Vec<f32>, georef: &GeoRef) -> Self {
        let (bw, bh) = (w.div_ceil(B), h.div_ceil(B));
        let geographic = georef.georeferenced && georef.crs.geographic;
        let (cx, cy) = georef.cell_size_units();
        let t = georef.transform;
        let mut g = Geometry {
            georef: georef.clone(),
            w,
            h,
            bw,
            bh,
            bmax,
            geographic,
            planar_unit: if georef.georeferenced {
                georef.crs.linear_unit_m
            } else {
                1.0
            },
            dlat_rad: cy.to_radians(),
            dlon_rad: cx.to_radians(),
            cos_max_lat: 1.0,
            min_cell: 0.0,
            bounded: georef.is_north_up(),
        };
        if geographic {
            let lat_a = t[3];
            let lat_b = t[3] + h as f64 * t[5];
            let m = lat_a.abs().max(lat_b.abs()).min(90.0);
            g.cos_max_lat = m.to_radians().cos();
            // Wrap-around longitudes would break the bound: fall back to a full search.
            if w as f64 * cx > 180.0 {
                g.bounded = false;
            }
        } else {
            g.min_cell = cx.min(cy) * g.planar_unit;
        }
        g
    }

    /// Fold rows `y0..` of cells (`rows` holds whole rows of width `w`
    /// starting at column `x0`) into the block maxima.
    fn fold_max(bmax: &mut [f32], bw: usize, x0: usize, y0: usize, win: &Grid<f32>) {
        for y in 0..win.height() {
            let row = win.row(y);
            let by = (y0 + y) / B;
            for (x, &z) in row.iter().enumerate() {
                // NaN never wins `max` against a number.
                let m = &mut bmax[by * bw + (x0 + x) / B];
                *m = m.max(z);
            }
        }
    }

    /// Lower bound on the distance between two cells `k` apart (Chebyshev).
    fn lower_bound(&self, k: usize) -> f64 {
        if !self.bounded || k == 0 {
            return 0.0;
        }
        let k = k as f64;
        if self.geographic {
            // |Δφ| ≥ k·Δφcell gives d ≥ R|Δφ|; |Δλ| ≥ k·Δλcell gives, from the
            // haversine formula, sin(d/2R) ≥ cos φmax · sin(Δλ/2).
            let a = R_EARTH * k * self.dlat_rad;
            let half = (k * self.dlon_rad / 2.0).min(std::f64::consts::FRAC_PI_2);
            let b = 2.0 * R_EARTH * (self.cos_max_lat * half.sin()).min(1.0).asin();
            a.min(b)
        } else {
            k * self.min_cell
        }
    }

    fn centre(&self, col: usize, row: usize) -> (f64, f64) {
        self.georef.pixel_to_map(col as f64 + 0.5, row as f64 + 0.5)
    }

    fn distance_bearing(&self, c0: usize, r0: usize, c1: usize, r1: usize) -> (f64, f64) {
        let (x0, y0) = self.centre(c0, r0);
        let (x1, y1) = self.centre(c1, r1);
        if self.geographic {
            let (p0, p1) = (y0.to_radians(), y1.to_radians());
            let dl = (x1 - x0).to_radians();
            let hav =
                ((p1 - p0) / 2.0).sin().powi(2) + p0.cos() * p1.cos() * (dl / 2.0).sin().powi(2);
            let d = 2.0 * R_EARTH * hav.sqrt().min(1.0).asin();
            let by = dl.sin() * p1.cos();
            let bx = p0.cos() * p1.sin() - p0.sin() * p1.cos() * dl.cos();
            (d, by.atan2(bx).to_degrees().rem_euclid(360.0))
        } else {
            let dx = (x1 - x0) * self.planar_unit;
            let mut dy = (y1 - y0) * self.planar_unit;
            if !self.georef.georeferenced {
                // Pixel space: y grows downwards; "north" is up.
                dy = -dy;
            }
            (dx.hypot(dy), dx.atan2(dy).to_degrees().rem_euclid(360.0))
        }
    }

    /// The branch-and-bound search; `block(bx, by, buf)` fills `buf` with
    /// the cells of block (bx, by), row-major, `B` per row.
    fn nearest_higher(
        &self,
        col: usize,
        row: usize,
        elevation: f32,
        mut block: impl FnMut(usize, usize, &mut [f32]) -> Result<()>,
    ) -> Result<Option<Isolation>> {
        let (w, h) = (self.w, self.h);
        let (bx0, by0) = ((col / B) as i64, (row / B) as i64);
        let max_ring = self.bw.max(self.bh) as i64;
        let mut best: Option<(f64, usize)> = None;
        let mut buf = [f32::NAN; B * B];
        for k in 0..=max_ring {
            if let Some((d, _)) = best {
                // Cells in ring k are at least (k-1)·B+1 cells away.
                let kc = if k == 0 { 0 } else { (k as usize - 1) * B + 1 };
                if self.lower_bound(kc) > d {
                    break;
                }
            }
            for by in (by0 - k)..=(by0 + k) {
                if by < 0 || by >= self.bh as i64 {
                    continue;
                }
                let edge_row = by == by0 - k || by == by0 + k;
                let step = if edge_row { 1 } else { (2 * k).max(1) };
                let mut bx = bx0 - k;
                while bx <= bx0 + k {
                    if bx >= 0 && bx < self.bw as i64 {
                        let (bxu, byu) = (bx as usize, by as usize);
                        if self.bmax[byu * self.bw + bxu] > elevation {
                            block(bxu, byu, &mut buf)?;
                            for y in byu * B..((byu + 1) * B).min(h) {
                                for x in bxu * B..((bxu + 1) * B).min(w) {
                                    let i = y * w + x;
                                    if buf[(y - byu * B) * B + (x - bxu * B)] > elevation {
                                        let (d, _) = self.distance_bearing(col, row, x, y);
                                        let better = match best {
                                            None => true,
                                            Some((bd, bi)) => d < bd || (d == bd && i < bi),
                                        };
                                        if better {
                                            best = Some((d, i));
                                        }
                                    }
                                }
                            }
                        }
                    }
                    bx += step;
                }
            }
        }
        Ok(best.map(|(_, i)| {
            let (x, y) = (i % w, i / w);
            let (d, b) = self.distance_bearing(col, row, x, y);
            Isolation {
                distance_m: d,
                col: x as u32,
                row: y as u32,
                bearing_deg: b,
            }
        }))
    }
}

/// Precomputed block maxima and distance geometry for one DEM in memory.
pub struct IsolationIndex<'a> {
    dem: &'a Grid<f32>,
    geo: Geometry,
}

impl<'a> IsolationIndex<'a> {
    /// Index `dem` (NaN = nodata) with its georeference.
    pub fn new(dem: &'a Grid<f32>, georef: &GeoRef) -> Self {
        let (w, h) = (dem.width(), dem.height());
        let mut bmax = vec![f32::NEG_INFINITY; w.div_ceil(B) * h.div_ceil(B)];
        Geometry::fold_max(&mut bmax, w.div_ceil(B), 0, 0, dem);
        IsolationIndex {
            dem,
            geo: Geometry::new(w, h, bmax, georef),
        }
    }

    /// Distance (m) and bearing (degrees from north) between two cells.
    pub fn distance_bearing(&self, c0: usize, r0: usize, c1: usize, r1: usize) -> (f64, f64) {
        self.geo.distance_bearing(c0, r0, c1, r1)
    }

    /// Distance (m) and bearing (degrees from north) from peak `p` of `tree`
    /// to its key saddle; `None` if it has none.
    pub fn to_key_saddle(&self, tree: &DivideTree, p: &Peak) -> Option<(f64, f64)> {
        let s = tree.saddles.get(p.key_saddle?)?;
        Some(self.distance_bearing(
            p.col as usize,
            p.row as usize,
            s.col as usize,
            s.row as usize,
        ))
    }

    /// Nearest cell strictly higher than `elevation`, from cell (col, row).
    /// Ties in distance go to the first cell in row-major order. None if the
    /// DEM has no higher cell.
    pub fn nearest_higher(&self, col: usize, row: usize, elevation: f32) -> Option<Isolation> {
        let (w, h) = (self.dem.width(), self.dem.height());
        let data = self.dem.data();
        let fill = |bx: usize, by: usize, buf: &mut [f32]| -> Result<()> {
            for y in by * B..((by + 1) * B).min(h) {
                for x in bx * B..((bx + 1) * B).min(w) {
                    buf[(y - by * B) * B + (x - bx * B)] = data[y * w + x];
                }
            }
            Ok(())
        };
        // Reading from memory cannot fail.
        self.geo
            .nearest_higher(col, row, elevation, fill)
            .unwrap_or(None)
    }
}

/// Side of the windows [`TiledIsolationIndex`] reads and caches (a multiple
/// of the block side, so a block lies in one window).
const CACHE_TILE: usize = 16 * B;

/// Isolation for a DEM read through a [`RasterSource`]: block maxima in
/// memory (one pass over the raster), cells read on demand into a bounded
/// cache of `CACHE_TILE`-square windows. Same answers as [`IsolationIndex`].
pub struct TiledIsolationIndex<'a> {
    src: &'a dyn RasterSource,
    geo: Geometry,
    cache: RefCell<Cache>,
}

struct Cache {
    tiles: HashMap<(usize, usize), (u64, Grid<f32>)>,
    clock: u64,
    capacity: usize,
    reads: u64,
}

impl<'a> TiledIsolationIndex<'a> {
    /// Index `src` (read as f32, nodata = NaN), keeping at most about
    /// `cache_bytes` of cells in memory (at least one window).
    pub fn new(src: &'a dyn RasterSource, cache_bytes: u64) -> Result<Self> {
        let info = src.info();
        let (w, h) = (info.width, info.height);
        let bw = w.div_ceil(B);
        let mut bmax = vec![f32::NEG_INFINITY; bw * h.div_ceil(B)];
        // Strips of CACHE_TILE rows, at most 4096 columns at a time.
        let chunk = 4096usize;
        for y0 in (0..h).step_by(CACHE_TILE) {
            for x0 in (0..w).step_by(chunk) {
                let win = Window::new(
                    x0 as i64,
                    y0 as i64,
                    chunk.min(w - x0),
                    CACHE_TILE.min(h - y0),
                );
                let g = read_window::<f32>(src, win)?;
                Geometry::fold_max(&mut bmax, bw, x0, y0, &g);
            }
        }
        let per = (CACHE_TILE * CACHE_TILE * 4) as u64;
        Ok(TiledIsolationIndex {
            src,
            geo: Geometry::new(w, h, bmax, &info.georef),
            cache: RefCell::new(Cache {
                tiles: HashMap::new(),
                clock: 0,
                capacity: (cache_bytes / per).max(1) as usize,
                reads: 0,
            }),
        })
    }

    /// Number of windows read from the source so far (cache misses).
    pub fn reads(&self) -> u64 {
        self.cache.borrow().reads
    }

    /// As [`IsolationIndex::nearest_higher`].
    pub fn nearest_higher(
        &self,
        col: usize,
        row: usize,
        elevation: f32,
    ) -> Result<Option<Isolation>> {
        let (w, h) = (self.geo.w, self.geo.h);
        let fill = |bx: usize, by: usize, buf: &mut [f32]| -> Result<()> {
            let (tx, ty) = (bx * B / CACHE_TILE, by * B / CACHE_TILE);
            let mut c = self.cache.borrow_mut();
            c.clock += 1;
            let now = c.clock;
            if let Some(e) = c.tiles.get_mut(&(tx, ty)) {
                e.0 = now;
            } else {
                if c.tiles.len() >= c.capacity {
                    // Evict the least recently used window.
                    if let Some(old) = c.tiles.iter().min_by_key(|e| e.1 .0).map(|e| *e.0) {
                        c.tiles.remove(&old);
                    }
                }
                let (x0, y0) = (tx * CACHE_TILE, ty * CACHE_TILE);
                let win = Window::new(
                    x0 as i64,
                    y0 as i64,
                    CACHE_TILE.min(w - x0),
                    CACHE_TILE.min(h - y0),
                );
                let g = read_window::<f32>(self.src, win)?;
                c.reads += 1;
                c.tiles.insert((tx, ty), (now, g));
            }
            let g = &c.tiles[&(tx, ty)].1;
            let (x0, y0) = (tx * CACHE_TILE, ty * CACHE_TILE);
            for y in by * B..((by + 1) * B).min(h) {
                let r = g.row(y - y0);
                for x in bx * B..((bx + 1) * B).min(w) {
                    buf[(y - by * B) * B + (x - bx * B)] = r[x - x0];
                }
            }
            Ok(())
        };
        self.geo.nearest_higher(col, row, elevation, fill)
    }
}
