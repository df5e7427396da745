//! Hillslope asymmetry (Poulos, Pierce, Flores & Benner 2012, "Hillslope
//! asymmetry maps reveal widespread, multi-scale organization", Geophysical
//! Research Letters 39, L06406): in a window, the base-10 logarithm of the
//! ratio of the typical gradient of slopes facing one direction to that of
//! slopes facing the opposite direction; 0 for symmetric valleys, `log10 2`
//! when one side is twice as steep.
//!
//! As in Poulos et al., cells under 5% gradient are left out and a cell
//! "faces" a direction when its aspect is within a tolerance of it (they use
//! north and south, ±45°). Poulos et al. compare medians; this uses means,
//! as the code accompanying the Argudo et al. survey does, so that the
//! window sums come from exact summed-area tables (Crow 1984) whatever the
//! radius, and tiled runs equal untiled ones.

use super::directional::gradient_region;
use super::windowed::Sat;
use crate::error::Result;
use crate::raster::{Grid, TileView};

/// Gradient (rise over run) below which a cell is treated as flat and left out.
pub const MIN_GRADIENT: f64 = 0.05;

/// Which side a gradient `(p, q)` faces: `Some(true)` if its aspect (the
/// azimuth of steepest descent, clockwise from north) is within
/// `tolerance_deg` (strictly) of `azimuth_deg`, `Some(false)` if within it of
/// the opposite azimuth, `None` otherwise or when flatter than [`MIN_GRADIENT`].
#[inline]
pub fn facing(p: f64, q: f64, azimuth_deg: f64, tolerance_deg: f64) -> Option<bool> {
    let g = (p * p + q * q).sqrt();
    if g.is_nan() || g <= MIN_GRADIENT {
        return None;
    }
    let aspect = (-p).atan2(-q).to_degrees();
    let diff = |target: f64| {
        let d = (aspect - target).rem_euclid(360.0);
        if d > 180.0 {
            360.0 - d
        } else {
            d
        }
    };
    if diff(azimuth_deg) < tolerance_deg {
        Some(true)
    } else if diff(azimuth_deg + 180.0) < tolerance_deg {
        Some(false)
    } else {
        None
    }
}

/// Hillslope asymmetry of every core cell over the square window of
/// half-side `r`: `log10(mean gradient facing azimuth / mean gradient facing
/// azimuth + 180°)`; nodata where the centre is nodata or either side has no
/// cell in the window (e.g. on a plane). Needs a halo ≥ r + 1.
pub fn hillslope_asymmetry(
    view: &TileView<f32>,
    r: usize,
    azimuth_deg: f64,
    tolerance_deg: f64,
    path: &str,
    o: &mut Grid<f32>,
) -> Result<()> {
    let (p, q) = gradient_region(view, r);
    let mut pos = vec![f64::NAN; p.len()];
    let mut neg = vec![f64::NAN; p.len()];
    for i in 0..p.len() {
        match facing(p[i], q[i], azimuth_deg, tolerance_deg) {
            Some(true) => pos[i] = (p[i] * p[i] + q[i] * q[i]).sqrt(),
            Some(false) => neg[i] = (p[i] * p[i] + q[i] * q[i]).sqrt(),
            None => {}
        }
    }
    let (w, hh) = (view.core.w + 2 * r, view.core.h + 2 * r);
    let sp = Sat::new(&pos, w, hh, false, path)?;
    let sn = Sat::new(&neg, w, hh, false, path)?;
    let (h, gw) = (view.halo, view.grid.width());
    let data = view.grid.data();
    for y in 0..view.core.h {
        for x in 0..view.core.w {
            let v = if data[(y + h) * gw + x + h].is_nan() {
                f64::NAN
            } else {
                let a = sp.window(x, y, x + 2 * r + 1, y + 2 * r + 1);
                let b = sn.window(x, y, x + 2 * r + 1, y + 2 * r + 1);
                if a.n == 0 || b.n == 0 {
                    f64::NAN
                } else {
                    (a.mean() / b.mean()).log10()
                }
            };
            o.set(x, y, v as f32);
        }
    }
    Ok(())
}
