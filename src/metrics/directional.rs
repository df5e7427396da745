//! Slope along a direction and the average slope over a window (Argudo,
//! Guérin, Schott & Galin, "Terrain descriptors for landscape synthesis,
//! analysis and simulation", sec. 3.1: gradient, directional and average
//! slope), on Horn's 3x3 gradient (Horn 1981, "Hill shading and the
//! reflectance map", Proc. IEEE 69(1)).
//!
//! Also the gradient field over a tile's core plus a margin, shared with the
//! hillslope asymmetry (`asymmetry`).

use super::terrain::horn_gradient;
use super::windowed::Sat;
use crate::error::Result;
use crate::raster::{Grid, TileView};

/// Directional slope `∇z · u` with `u = (sin a, cos a)` (east, north) for an
/// azimuth `a` in degrees clockwise from north: the rise per metre when
/// walking towards `a` (positive uphill). `p`, `q` are dz/dx (east) and
/// dz/dy (north).
#[inline]
pub fn directional_slope(p: f64, q: f64, azimuth_deg: f64) -> f64 {
    let a = azimuth_deg.to_radians();
    p * a.sin() + q * a.cos()
}

/// Horn gradient `(p, q)` of every cell of the core plus `r` cells on each
/// side (row-major, `(core.w + 2r) x (core.h + 2r)`), NaN where the cell's
/// 3x3 window holds nodata or lies beyond the raster. Needs a halo ≥ r + 1.
pub fn gradient_region(view: &TileView<f32>, r: usize) -> (Vec<f64>, Vec<f64>) {
    let h = view.halo;
    debug_assert!(h > r);
    let gw = view.grid.width();
    let data = view.grid.data();
    let (w, hh) = (view.core.w + 2 * r, view.core.h + 2 * r);
    let mut p = vec![f64::NAN; w * hh];
    let mut q = vec![f64::NAN; w * hh];
    for y in 0..hh {
        let vy = y + h - r;
        let (ew, ns) = view.georef.cell_size_m(view.core.y + vy as i64 - h as i64);
        for x in 0..w {
            let vx = x + h - r;
            let mut win = [0.0; 9];
            let mut k = 0;
            for yy in vy - 1..=vy + 1 {
                for xx in vx - 1..=vx + 1 {
                    win[k] = data[yy * gw + xx] as f64;
                    k += 1;
                }
            }
            if win.iter().sum::<f64>().is_nan() {
                continue;
            }
            let (a, b) = horn_gradient(&win, ew, ns);
            p[y * w + x] = a;
            q[y * w + x] = b;
        }
    }
    (p, q)
}

/// Average slope: the mean Horn slope angle (degrees) of the valid cells of
/// the square window of half-side `r` around each core cell, by an exact
/// fixed-point summed-area table (Crow 1984), so tiled and untiled runs give
/// the same bits. A nodata centre is nodata; cells whose slope is undefined
/// (nodata in their 3x3 window, beyond the raster) are left out.
pub fn average_slope(view: &TileView<f32>, r: usize, path: &str, o: &mut Grid<f32>) -> Result<()> {
    let (p, q) = gradient_region(view, r);
    let slope: Vec<f64> = p
        .iter()
        .zip(&q)
        .map(|(a, b)| (a * a + b * b).sqrt().atan().to_degrees())
        .collect();
    let w = view.core.w + 2 * r;
    let sat = Sat::new(&slope, w, view.core.h + 2 * r, false, path)?;
    let (h, gw) = (view.halo, view.grid.width());
    let data = view.grid.data();
    for y in 0..view.core.h {
        for x in 0..view.core.w {
            let v = if data[(y + h) * gw + x + h].is_nan() {
                f32::NAN
            } else {
                sat.window(x, y, x + 2 * r + 1, y + 2 * r + 1).mean() as f32
            };
            o.set(x, y, v);
        }
    }
    Ok(())
}
