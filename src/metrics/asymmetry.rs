//! Hillslope asymmetry (Poulos, Pierce, Flores & Benner 2012, "Hillslope
//! asymmetry maps reveal widespread, multi-scale organization", Geophysical
//! Research Letters 39, L06406): in a window, the base-10 logarithm of the
//! ratio of the typical gradient of slopes facing one direction to that of
//! slopes facing the opposite direction; 0 for symmetric valleys, `log10 2`
//! when one side is twice as steep.
//!
//! As in Poulos et al., cells under 5% gradient are left out and a cell
//! "faces" a direction when its aspect is within a tolerance of it (they use
//! north and south, ±45°). Poulos et al. compare medians ([`asymmetry_index`]);
//! [`hillslope_asymmetry`] uses means, as the code accompanying the Argudo et
//! al. survey does, with exact fixed-point window sums (running column and
//! row sums, O(1) per cell whatever the radius), so that tiled runs equal
//! untiled ones.

use super::directional::gradient_region;
use super::param::{AZIMUTH, RADIUS, TOLERANCE};
use super::registry::{metric_def, Metric, MetricDef, MetricKind, ScratchClass};
use super::spec::Resolved;
use super::tile::{region_cells, Tile};
use super::windowed::{i128_to_f64, pow2, to_fixed, FRAC_BITS, MAX_ABS_VALUE};
use crate::error::{Error, Result};
use crate::raster::RasterInfo;
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
#[allow(clippy::needless_range_loop)] // parallel per-column arrays
pub fn hillslope_asymmetry(
    view: &TileView<f32>,
    r: usize,
    azimuth_deg: f64,
    tolerance_deg: f64,
    path: &str,
    o: &mut Grid<f32>,
) -> Result<()> {
    let (p, q) = gradient_region(view, r);
    let (w, hh) = (view.core.w + 2 * r, view.core.h + 2 * r);
    let (cw, ch) = (view.core.w, view.core.h);
    // Fixed-point gradients by side (0 where the cell faces neither way),
    // so that window sums are exact integers whatever the window's
    // position: the same bits in tiles as in one piece.
    let mut pos = vec![0i64; w * hh];
    let mut neg = vec![0i64; w * hh];
    let mut side = vec![0u8; w * hh];
    for i in 0..p.len() {
        let Some(facing_pos) = facing(p[i], q[i], azimuth_deg, tolerance_deg) else {
            continue;
        };
        let g = (p[i] * p[i] + q[i] * q[i]).sqrt();
        if g > MAX_ABS_VALUE {
            return Err(Error::invalid(format!(
                "{path}: gradient {g} is beyond ±{MAX_ABS_VALUE}, the range of the windowed statistics: rescale the input"
            )));
        }
        let f = to_fixed(g, FRAC_BITS) as i64;
        if facing_pos {
            pos[i] = f;
            side[i] = 1;
        } else {
            neg[i] = f;
            side[i] = 2;
        }
    }
    drop(p);
    drop(q);
    if cw == 0 || ch == 0 {
        return Ok(());
    }
    // Column sums over the window's 2r+1 rows, slid down one row at a
    // time, then a running sum along the row: O(1) per cell, exact (i128).
    let k = 2 * r + 1;
    let mut cs_pos = vec![0i128; w];
    let mut cs_neg = vec![0i128; w];
    let mut cn_pos = vec![0u32; w];
    let mut cn_neg = vec![0u32; w];
    let add_row = |y: usize,
                   sign: i32,
                   cs_pos: &mut [i128],
                   cs_neg: &mut [i128],
                   cn_pos: &mut [u32],
                   cn_neg: &mut [u32]| {
        let row = y * w;
        for x in 0..w {
            let s = side[row + x];
            if s == 0 {
                continue;
            }
            if sign > 0 {
                cs_pos[x] += pos[row + x] as i128;
                cs_neg[x] += neg[row + x] as i128;
                cn_pos[x] += u32::from(s == 1);
                cn_neg[x] += u32::from(s == 2);
            } else {
                cs_pos[x] -= pos[row + x] as i128;
                cs_neg[x] -= neg[row + x] as i128;
                cn_pos[x] -= u32::from(s == 1);
                cn_neg[x] -= u32::from(s == 2);
            }
        }
    };
    for y in 0..k {
        add_row(y, 1, &mut cs_pos, &mut cs_neg, &mut cn_pos, &mut cn_neg);
    }
    let (h, gw) = (view.halo, view.grid.width());
    let data = view.grid.data();
    let scale = pow2(FRAC_BITS);
    for y in 0..ch {
        if y > 0 {
            add_row(
                y - 1,
                -1,
                &mut cs_pos,
                &mut cs_neg,
                &mut cn_pos,
                &mut cn_neg,
            );
            add_row(
                y + 2 * r,
                1,
                &mut cs_pos,
                &mut cs_neg,
                &mut cn_pos,
                &mut cn_neg,
            );
        }
        let (mut sp, mut sn, mut np, mut nn) = (0i128, 0i128, 0u32, 0u32);
        for x in 0..k {
            sp += cs_pos[x];
            sn += cs_neg[x];
            np += cn_pos[x];
            nn += cn_neg[x];
        }
        for x in 0..cw {
            if x > 0 {
                sp += cs_pos[x + 2 * r] - cs_pos[x - 1];
                sn += cs_neg[x + 2 * r] - cs_neg[x - 1];
                np = np + cn_pos[x + 2 * r] - cn_pos[x - 1];
                nn = nn + cn_neg[x + 2 * r] - cn_neg[x - 1];
            }
            let v = if data[(y + h) * gw + x + h].is_nan() || np == 0 || nn == 0 {
                f64::NAN
            } else {
                let mp = i128_to_f64(sp) / scale / np as f64;
                let mn = i128_to_f64(sn) / scale / nn as f64;
                (mp / mn).log10()
            };
            o.set(x, y, v as f32);
        }
    }
    Ok(())
}

/// Asymmetry index in Poulos et al.'s own form (2012, sec. 2): the base-10
/// logarithm of the ratio of the *median* gradient of the cells facing
/// `azimuth_deg` (± `tolerance_deg`) to the median gradient of the cells
/// facing the opposite direction, over the square window of half-side `r`;
/// cells under [`MIN_GRADIENT`] are left out, as in [`hillslope_asymmetry`].
/// It differs from [`hillslope_asymmetry`] (means, the survey code's choice)
/// wherever the gradient distributions are skewed: one cliff band in a
/// window moves the mean a lot and the median little. The median of an even
/// count is the mean of the two middle values. Nodata where the centre is
/// nodata or either side is empty. Needs a halo ≥ r + 1.
///
/// Exact medians of every window in O(r log n) per cell (instead of the
/// O(r²) of selecting in each window): the gradients of the region are
/// ranked once, the window walks the core in a boustrophedon (each step adds
/// and removes one row or column of 2r + 1 cells), and one Fenwick tree per
/// side counts the ranks present (Fenwick 1994, "A new data structure for
/// cumulative frequency tables", Software P&E 24(3)); the k-th smallest rank
/// is found by descending the tree. The result depends only on the values in
/// the window, so tiled runs equal untiled ones.
pub fn asymmetry_index(
    view: &TileView<f32>,
    r: usize,
    azimuth_deg: f64,
    tolerance_deg: f64,
    o: &mut Grid<f32>,
) {
    let (p, q) = gradient_region(view, r);
    let w = view.core.w + 2 * r;
    // Side of each region cell (0 none, 1 facing azimuth, 2 opposite) and
    // its gradient; ranks of the sided cells by gradient (ties by index).
    let mut side = vec![0u8; p.len()];
    let mut grad = vec![0.0f64; p.len()];
    let mut order: Vec<u32> = Vec::new();
    for i in 0..p.len() {
        if let Some(pos) = facing(p[i], q[i], azimuth_deg, tolerance_deg) {
            side[i] = if pos { 1 } else { 2 };
            grad[i] = (p[i] * p[i] + q[i] * q[i]).sqrt();
            order.push(i as u32);
        }
    }
    order.sort_unstable_by(|&a, &b| {
        grad[a as usize]
            .total_cmp(&grad[b as usize])
            .then(a.cmp(&b))
    });
    let n = order.len();
    let mut rank = vec![0u32; p.len()];
    let mut value = Vec::with_capacity(n);
    for (k, &i) in order.iter().enumerate() {
        rank[i as usize] = k as u32;
        value.push(grad[i as usize]);
    }
    drop(order);
    drop(grad);
    let mut trees = [Fenwick::new(n), Fenwick::new(n)];
    let update = |x: usize, y: usize, d: i32, trees: &mut [Fenwick; 2]| {
        let i = y * w + x;
        match side[i] {
            1 => trees[0].add(rank[i] as usize, d),
            2 => trees[1].add(rank[i] as usize, d),
            _ => {}
        }
    };
    let side_len = 2 * r + 1;
    let (h, gw) = (view.halo, view.grid.width());
    let data = view.grid.data();
    let (cw, ch) = (view.core.w, view.core.h);
    if cw == 0 || ch == 0 {
        return;
    }
    // Window of core cell (x, y): region columns x..x+2r, rows y..y+2r.
    for yy in 0..side_len {
        for xx in 0..side_len {
            update(xx, yy, 1, &mut trees);
        }
    }
    let mut x = 0usize;
    for y in 0..ch {
        if y > 0 {
            for xx in x..x + side_len {
                update(xx, y - 1, -1, &mut trees);
                update(xx, y + 2 * r, 1, &mut trees);
            }
        }
        let rightwards = y % 2 == 0;
        for step in 0..cw {
            if step > 0 {
                if rightwards {
                    for yy in y..y + side_len {
                        update(x, yy, -1, &mut trees);
                        update(x + side_len, yy, 1, &mut trees);
                    }
                    x += 1;
                } else {
                    for yy in y..y + side_len {
                        update(x + 2 * r, yy, -1, &mut trees);
                        update(x - 1, yy, 1, &mut trees);
                    }
                    x -= 1;
                }
            }
            let v = if data[(y + h) * gw + x + h].is_nan() {
                f64::NAN
            } else {
                match (trees[0].median(&value), trees[1].median(&value)) {
                    (Some(a), Some(b)) => (a / b).log10(),
                    _ => f64::NAN,
                }
            };
            o.set(x, y, v as f32);
        }
    }
}

/// Fenwick (binary indexed) tree of counts over ranks `0..n`, with the
/// k-th smallest present rank by binary descent.
struct Fenwick {
    t: Vec<i32>,
    total: i32,
    /// Largest power of two ≤ n (descent start).
    top: usize,
}

impl Fenwick {
    fn new(n: usize) -> Fenwick {
        let mut top = 1;
        while top * 2 <= n {
            top *= 2;
        }
        Fenwick {
            t: vec![0; n + 1],
            total: 0,
            top,
        }
    }

    #[inline]
    fn add(&mut self, rank: usize, d: i32) {
        self.total += d;
        let mut i = rank + 1;
        while i < self.t.len() {
            self.t[i] += d;
            i += i & i.wrapping_neg();
        }
    }

    /// The rank of the k-th (0-based) smallest present element; k < total.
    #[inline]
    fn kth(&self, k: i32) -> usize {
        let (mut pos, mut rem, mut step) = (0usize, k, self.top);
        while step > 0 {
            let nxt = pos + step;
            if nxt < self.t.len() && self.t[nxt] <= rem {
                pos = nxt;
                rem -= self.t[nxt];
            }
            step /= 2;
        }
        pos // 1-based index pos + 1  ->  rank pos
    }

    /// Median of the present values (`value[rank]`), None when empty.
    fn median(&self, value: &[f64]) -> Option<f64> {
        let n = self.total;
        if n <= 0 {
            return None;
        }
        if n % 2 == 1 {
            Some(value[self.kth(n / 2)])
        } else {
            Some(0.5 * (value[self.kth(n / 2 - 1)] + value[self.kth(n / 2)]))
        }
    }
}

/// Hillslope asymmetry (means) or the asymmetry index (medians).
pub struct Asymmetry(MetricDef);

impl Metric for Asymmetry {
    fn def(&self) -> &MetricDef {
        &self.0
    }
    fn halo(&self, m: &Resolved) -> usize {
        m.radius_cells + 1
    }
    fn scratch(&self, m: &Resolved, tile: usize) -> Option<(ScratchClass, u64)> {
        if self.0.kind == MetricKind::HillslopeAsymmetry {
            return Some(super::directional::gradient_window_scratch(
                m.radius_cells,
                tile,
            ));
        }
        // gradients, side, rank, value, order and two Fenwick trees
        Some((
            ("asymmetry_index", 0),
            region_cells(tile, m.radius_cells) * (2 * 8 + 1 + 4 + 8 + 8 + 4 + 2 * 4),
        ))
    }
    fn bind(&self, r: &mut Resolved, _info: &RasterInfo) -> Result<()> {
        let t = r.spec.threshold.unwrap_or(45.0);
        if !(t > 0.0 && t <= 90.0) {
            return Err(Error::invalid(format!(
                "{}:tolerance={t} is out of range: use 0 < tolerance <= 90 (degrees)",
                self.0.name
            )));
        }
        Ok(())
    }
    fn run(&self, t: &mut Tile<'_>, m: &Resolved, o: &mut Grid<f32>) -> Result<()> {
        let azimuth = m.spec.azimuth.unwrap_or(0.0);
        let tolerance = m.spec.threshold.unwrap_or(45.0);
        if self.0.kind == MetricKind::HillslopeAsymmetry {
            hillslope_asymmetry(t.view, m.radius_cells, azimuth, tolerance, t.path, o)
        } else {
            asymmetry_index(t.view, m.radius_cells, azimuth, tolerance, o);
            Ok(())
        }
    }
}

/// `hillslope_asymmetry`: log10(mean gradient of cells facing azimuth / mean gradient of cells facing azimuth+180) in the square window; cells under 5% gradient left out.
///
/// Source: Poulos, Pierce, Flores & Benner 2012, GRL 39 L06406 (medians there; means as in the Argudo et al. survey code).
pub static HILLSLOPE_ASYMMETRY: Asymmetry = Asymmetry(metric_def!(
        HillslopeAsymmetry,
        "hillslope_asymmetry",
        &[RADIUS, AZIMUTH, TOLERANCE],
        "log10 ratio",
        "log10(mean gradient of cells facing azimuth / mean gradient of cells facing azimuth+180) in the square window; cells under 5% gradient left out",
        "Poulos, Pierce, Flores & Benner 2012, GRL 39 L06406 (medians there; means as in the Argudo et al. survey code)"
    ));

/// `asymmetry_index`: log10(median gradient of cells facing azimuth / median gradient of cells facing azimuth+180) in the square window; cells under 5% gradient left out.
///
/// Source: Poulos, Pierce, Flores & Benner 2012, GRL 39 L06406, sec. 2 (medians, as published; hillslope_asymmetry uses means).
pub static ASYMMETRY_INDEX: Asymmetry = Asymmetry(metric_def!(
        AsymmetryIndex,
        "asymmetry_index",
        &[RADIUS, AZIMUTH, TOLERANCE],
        "log10 ratio",
        "log10(median gradient of cells facing azimuth / median gradient of cells facing azimuth+180) in the square window; cells under 5% gradient left out",
        "Poulos, Pierce, Flores & Benner 2012, GRL 39 L06406, sec. 2 (medians, as published; hillslope_asymmetry uses means)"
    ));
