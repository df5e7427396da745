//! Slope along a direction and the average slope over a window (Argudo,
//! Guérin, Schott & Galin, "Terrain descriptors for landscape synthesis,
//! analysis and simulation", sec. 3.1: gradient, directional and average
//! slope), on Horn's 3x3 gradient (Horn 1981, "Hill shading and the
//! reflectance map", Proc. IEEE 69(1)).
//!
//! Also the gradient field over a tile's core plus a margin, shared with the
//! hillslope asymmetry (`asymmetry`).

use super::neighbourhood::{walk_3x3, EdgeMode};
use super::param::{AZIMUTH, RADIUS};
use super::registry::{metric_def, Metric, MetricDef, ScratchClass};
use super::spec::Resolved;
use super::terrain::horn_gradient;
use super::tile::{region_cells, Tile};
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

/// The slope along an azimuth (3x3 window).
pub struct DirectionalSlope(MetricDef);

impl Metric for DirectionalSlope {
    fn def(&self) -> &MetricDef {
        &self.0
    }
    fn run(&self, t: &mut Tile<'_>, m: &Resolved, o: &mut Grid<f32>) -> Result<()> {
        let a = m.spec.azimuth.unwrap_or(0.0);
        walk_3x3(t.view, o, EdgeMode::Nodata, f32::NAN, |w, ew, ns| {
            let (p, q) = horn_gradient(w, ew, ns);
            directional_slope(p, q, a) as f32
        });
        Ok(())
    }
}

/// The mean slope angle in the square window.
pub struct AverageSlope(MetricDef);

/// Scratch of the windows of gradients: gradients, slopes and two tables
/// (shared with `hillslope_asymmetry`).
pub fn gradient_window_scratch(r: usize, tile: usize) -> (ScratchClass, u64) {
    (
        ("gradient_window", 0),
        region_cells(tile, r) * (4 * 8 + 2 * (4 + 16)),
    )
}

impl Metric for AverageSlope {
    fn def(&self) -> &MetricDef {
        &self.0
    }
    fn halo(&self, m: &Resolved) -> usize {
        m.radius_cells + 1
    }
    fn scratch(&self, m: &Resolved, tile: usize) -> Option<(ScratchClass, u64)> {
        Some(gradient_window_scratch(m.radius_cells, tile))
    }
    fn run(&self, t: &mut Tile<'_>, m: &Resolved, o: &mut Grid<f32>) -> Result<()> {
        average_slope(t.view, m.radius_cells, t.path, o)
    }
}

/// `directional_slope`: slope along an azimuth: grad z . (sin a, cos a), positive uphill (Horn gradient).
///
/// Source: directional derivative (Argudo et al. survey sec. 3.1); Horn 1981 gradient.
pub static DIRECTIONAL_SLOPE: DirectionalSlope = DirectionalSlope(metric_def!(
    DirectionalSlope,
    "directional_slope",
    &[AZIMUTH],
    "z/m",
    "slope along an azimuth: grad z . (sin a, cos a), positive uphill (Horn gradient)",
    "directional derivative (Argudo et al. survey sec. 3.1); Horn 1981 gradient"
));

/// `average_slope`: mean Horn slope angle of the valid cells of the square window (exact SAT).
///
/// Source: average slope (Argudo et al. survey sec. 3.1); summed-area tables, Crow 1984.
pub static AVERAGE_SLOPE: AverageSlope = AverageSlope(metric_def!(
    AverageSlope,
    "average_slope",
    &[RADIUS],
    "degrees",
    "mean Horn slope angle of the valid cells of the square window (exact SAT)",
    "average slope (Argudo et al. survey sec. 3.1); summed-area tables, Crow 1984"
));
