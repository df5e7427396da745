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

use super::tree::Isolation;
use crate::raster::{GeoRef, Grid};

const B: usize = 16;
const R_EARTH: f64 = 6_371_008.8;

/// Precomputed block maxima and distance geometry for one DEM.
pub struct IsolationIndex<'a> {
    dem: &'a Grid<f32>,
    georef: GeoRef,
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

impl<'a> IsolationIndex<'a> {
    /// Index `dem` (NaN = nodata) with its georeference.
    pub fn new(dem: &'a Grid<f32>, georef: &GeoRef) -> Self {
        let (w, h) = (dem.width(), dem.height());
        let (bw, bh) = (w.div_ceil(B), h.div_ceil(B));
        let mut bmax = vec![f32::NEG_INFINITY; bw * bh];
        for y in 0..h {
            let row = dem.row(y);
            let brow = &mut bmax[(y / B) * bw..(y / B + 1) * bw];
            for (x, &z) in row.iter().enumerate() {
                // NaN never wins `max` against a number.
                let m = &mut brow[x / B];
                *m = m.max(z);
            }
        }
        let geographic = georef.georeferenced && georef.crs.geographic;
        let (cx, cy) = georef.cell_size_units();
        let t = georef.transform;
        let mut idx = IsolationIndex {
            dem,
            georef: georef.clone(),
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
            idx.cos_max_lat = m.to_radians().cos();
            // Wrap-around longitudes would break the bound: fall back to a full search.
            if w as f64 * cx > 180.0 {
                idx.bounded = false;
            }
        } else {
            idx.min_cell = cx.min(cy) * idx.planar_unit;
        }
        idx
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

    /// Distance (m) and bearing (degrees from north) between two cells.
    pub fn distance_bearing(&self, c0: usize, r0: usize, c1: usize, r1: usize) -> (f64, f64) {
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

    /// Nearest cell strictly higher than `elevation`, from cell (col, row).
    /// Ties in distance go to the first cell in row-major order. None if the
    /// DEM has no higher cell.
    pub fn nearest_higher(&self, col: usize, row: usize, elevation: f32) -> Option<Isolation> {
        let (w, h) = (self.dem.width(), self.dem.height());
        let data = self.dem.data();
        let (bx0, by0) = ((col / B) as i64, (row / B) as i64);
        let max_ring = self.bw.max(self.bh) as i64;
        let mut best: Option<(f64, usize)> = None;
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
                            for y in byu * B..((byu + 1) * B).min(h) {
                                for x in bxu * B..((bxu + 1) * B).min(w) {
                                    let i = y * w + x;
                                    if data[i] > elevation {
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
        best.map(|(_, i)| {
            let (x, y) = (i % w, i / w);
            let (d, b) = self.distance_bearing(col, row, x, y);
            Isolation {
                distance_m: d,
                col: x as u32,
                row: y as u32,
                bearing_deg: b,
            }
        })
    }
}
