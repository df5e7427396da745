//! Coarse-to-fine (multi-resolution) erosion: erode a coarse version of the
//! DEM, upsample the result, put back the detail the coarse level lacked,
//! erode again at the next level (the cascade Argudo et al. 2019 and
//! FastScape users apply to reach large drainage areas cheaply: e.g.
//! 100 m → 50 m → 30 m).
//!
//! For levels with cell sizes `L_1 > L_2 > … > L_k` (metres, each ≥ the DEM's
//! cell size `c`):
//! - `D_j` = the input averaged down to level `j` (exact area-weighted box
//!   average, so every input cell counts by the fraction of it each coarse cell
//!   covers), size `round(W·c/L_j) x round(H·c/L_j)`;
//! - `E_1` = erode(`D_1`);
//! - `E_j` = erode(`up(E_{j−1}) + D_j − up(D_{j−1})`): the eroded coarse
//!   terrain, upsampled by **bilinear** interpolation between cell centres
//!   (edges clamped), plus the fine-level detail difference;
//! - the output, at the input's size: `E_k` itself when `L_k` equals `c`, else
//!   `up(E_k) + input − up(D_k)` (no erosion at the native resolution).
//!
//! A level's cell size is the mean of its x and y cell sizes (they differ by
//! the rounding of the level's dimensions only).

use crate::error::{Error, Result};
use crate::raster::Grid;

/// Run `erode(grid, cell_m, level_index)` coarse to fine over `levels_m` (see
/// the module doc) and return the result at the input's size. The input must
/// have no nodata (non-finite) cells.
pub fn erode_multires(
    h: &Grid<f64>,
    cell: f64,
    levels_m: &[f64],
    mut erode: impl FnMut(&mut Grid<f64>, f64, usize) -> Result<()>,
) -> Result<Grid<f64>> {
    let (w, ht) = (h.width(), h.height());
    if levels_m.is_empty() {
        return Err(Error::invalid("multi-resolution: no level given"));
    }
    if !(cell.is_finite() && cell > 0.0) {
        return Err(Error::invalid(format!(
            "multi-resolution: cell size {cell} m is invalid"
        )));
    }
    for (k, &l) in levels_m.iter().enumerate() {
        if !(l.is_finite() && l >= cell * (1.0 - 1e-9)) {
            return Err(Error::invalid(format!(
                "multi-resolution: level {l} m is finer than the DEM's {cell} m cells; \
                 levels must be cell sizes >= the DEM's (e.g. 100,50,{cell})"
            )));
        }
        if k > 0 && l >= levels_m[k - 1] {
            return Err(Error::invalid(format!(
                "multi-resolution: levels must go from coarse to fine (got {} then {l} m)",
                levels_m[k - 1]
            )));
        }
    }
    if h.data().iter().any(|v| !v.is_finite()) {
        return Err(Error::invalid(
            "multi-resolution: the DEM has nodata cells; fill or crop them first",
        ));
    }
    let dims = |l: f64| -> (usize, usize) {
        let f = cell / l;
        (
            ((w as f64 * f).round() as usize).max(1),
            ((ht as f64 * f).round() as usize).max(1),
        )
    };
    let level_cell = |lw: usize, lh: usize| -> f64 {
        0.5 * (w as f64 * cell / lw as f64 + ht as f64 * cell / lh as f64)
    };
    let mut prev_d: Option<Grid<f64>> = None;
    let mut prev_e: Option<Grid<f64>> = None;
    for (k, &l) in levels_m.iter().enumerate() {
        let (lw, lh) = dims(l);
        let d = downsample_area(h, lw, lh)?;
        let mut start = match (&prev_e, &prev_d) {
            (Some(e), Some(pd)) => {
                let ue = upsample_bilinear(e, lw, lh)?;
                let ud = upsample_bilinear(pd, lw, lh)?;
                let mut s = ue;
                for ((v, a), b) in s.data_mut().iter_mut().zip(d.data()).zip(ud.data()) {
                    *v += a - b;
                }
                s
            }
            _ => d.clone(),
        };
        erode(&mut start, level_cell(lw, lh), k)?;
        prev_e = Some(start);
        prev_d = Some(d);
    }
    let (e, d) = match (prev_e, prev_d) {
        (Some(e), Some(d)) => (e, d),
        _ => return Err(Error::invalid("multi-resolution: no level given")),
    };
    if e.width() == w && e.height() == ht {
        return Ok(e);
    }
    let mut out = upsample_bilinear(&e, w, ht)?;
    let ud = upsample_bilinear(&d, w, ht)?;
    for ((v, a), b) in out.data_mut().iter_mut().zip(h.data()).zip(ud.data()) {
        *v += a - b;
    }
    Ok(out)
}

/// One axis of an area-weighted resampling: for each output cell, the input
/// cells it covers and the fraction of the output cell each one fills.
fn box_weights(n_in: usize, n_out: usize) -> Vec<Vec<(usize, f64)>> {
    let scale = n_in as f64 / n_out as f64;
    (0..n_out)
        .map(|o| {
            let a = o as f64 * scale;
            let b = (o + 1) as f64 * scale;
            let mut v = Vec::new();
            let mut i = a.floor() as usize;
            while (i as f64) < b && i < n_in {
                let lo = a.max(i as f64);
                let hi = b.min((i + 1) as f64);
                if hi > lo {
                    v.push((i, (hi - lo) / scale));
                }
                i += 1;
            }
            v
        })
        .collect()
}

/// Area-weighted average of `g` onto a `w2 x h2` grid covering the same extent
/// (exact box filter; `w2 <= width`, `h2 <= height`).
pub fn downsample_area(g: &Grid<f64>, w2: usize, h2: usize) -> Result<Grid<f64>> {
    if w2 == 0 || h2 == 0 || w2 > g.width() || h2 > g.height() {
        return Err(Error::invalid(format!(
            "downsample {}x{} to {w2}x{h2}: the target must be non-empty and not larger",
            g.width(),
            g.height()
        )));
    }
    let wx = box_weights(g.width(), w2);
    let wy = box_weights(g.height(), h2);
    // Rows first (width w2), then columns.
    let mut tmp = Grid::new(w2, g.height(), 0.0);
    for y in 0..g.height() {
        let src = g.row(y);
        let dst = tmp.row_mut(y);
        for (o, ws) in wx.iter().enumerate() {
            dst[o] = ws.iter().map(|&(i, f)| src[i] * f).sum();
        }
    }
    let mut out = Grid::new(w2, h2, 0.0);
    for (o, ws) in wy.iter().enumerate() {
        let dst = out.row_mut(o);
        for &(i, f) in ws {
            for (d, s) in dst.iter_mut().zip(tmp.row(i)) {
                *d += s * f;
            }
        }
    }
    Ok(out)
}

/// One axis of bilinear interpolation between cell centres: for output cell
/// `o`, the two input cells and the weight of the second.
fn lin_weights(n_in: usize, n_out: usize) -> Vec<(usize, usize, f64)> {
    let scale = n_in as f64 / n_out as f64;
    (0..n_out)
        .map(|o| {
            let s = ((o as f64 + 0.5) * scale - 0.5).clamp(0.0, (n_in - 1) as f64);
            let i0 = s.floor() as usize;
            let i1 = (i0 + 1).min(n_in - 1);
            (i0, i1, s - i0 as f64)
        })
        .collect()
}

/// Bilinear interpolation of `g` between cell centres onto a `w2 x h2` grid
/// covering the same extent (positions beyond the outer centres are clamped).
pub fn upsample_bilinear(g: &Grid<f64>, w2: usize, h2: usize) -> Result<Grid<f64>> {
    if w2 == 0 || h2 == 0 || g.is_empty() {
        return Err(Error::invalid(format!(
            "upsample {}x{} to {w2}x{h2}: both grids must be non-empty",
            g.width(),
            g.height()
        )));
    }
    let wx = lin_weights(g.width(), w2);
    let wy = lin_weights(g.height(), h2);
    let mut tmp = Grid::new(w2, g.height(), 0.0);
    for y in 0..g.height() {
        let src = g.row(y);
        let dst = tmp.row_mut(y);
        for (d, &(a, b, t)) in dst.iter_mut().zip(&wx) {
            *d = src[a] * (1.0 - t) + src[b] * t;
        }
    }
    let mut out = Grid::new(w2, h2, 0.0);
    for (o, &(a, b, t)) in wy.iter().enumerate() {
        let dst = out.row_mut(o);
        let (ra, rb) = (tmp.row(a), tmp.row(b));
        for ((d, &p), &q) in dst.iter_mut().zip(ra).zip(rb) {
            *d = p * (1.0 - t) + q * t;
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn downsample_keeps_the_mean_and_planes() {
        // A plane z = 2x + 3y sampled at cell centres; whole-cell boxes (3x2)
        // average to the plane at the coarse centres.
        let plane = |x: f64, y: f64| 2.0 * x + 3.0 * y;
        let g = Grid::from_fn(9, 6, |x, y| plane(x as f64 + 0.5, y as f64 + 0.5));
        let d = downsample_area(&g, 3, 3).unwrap();
        for y in 0..3 {
            for x in 0..3 {
                let (cx, cy) = ((x as f64 + 0.5) * 3.0, (y as f64 + 0.5) * 2.0);
                assert!((d.get(x, y) - plane(cx, cy)).abs() < 1e-9);
            }
        }
        // Fractional boxes: equal-area coarse cells, so the mean is kept.
        let f = downsample_area(&g, 4, 4).unwrap();
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
        assert!((mean(f.data()) - mean(g.data())).abs() < 1e-9);
        // Bilinear between coarse centres reproduces the plane inside their hull.
        let up = upsample_bilinear(&d, 9, 6).unwrap();
        for y in 1..5 {
            for x in 2..7 {
                let v = plane(x as f64 + 0.5, y as f64 + 0.5);
                assert!(
                    (up.get(x, y) - v).abs() < 1e-9,
                    "{x},{y}: {} vs {v}",
                    up.get(x, y)
                );
            }
        }
    }
}
