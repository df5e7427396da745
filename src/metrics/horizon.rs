//! Horizon-based descriptors with a radius cutoff: positive and negative
//! openness (Yokoyama, Shirasawa & Pike 2002, "Visualizing topography by
//! openness", PE&RS 68(3), 257-265) and the sky-view factor (Zakšek, Oštir &
//! Kokalj 2011, "Sky-view factor as a relief visualization technique",
//! Remote Sensing 3(2), 398-415).
//!
//! Rays leave the cell along 8 directions (the grid axes and diagonals) or
//! 16 (plus the knight-move directions (±1, ±2), (±2, ±1)). Each ray visits
//! exactly the cells at integer multiples of its step, so no interpolation
//! is involved and the result within the cutoff is exact: every cell whose
//! centre lies within `cutoff_m` metres along the ray is examined (the halo,
//! `ceil(cutoff / smallest cell size)`, covers all of them). Distances use
//! the centre row's true cell sizes. Nodata cells and cells beyond the raster
//! are skipped; a direction without any valid cell within the cutoff is left
//! out of the mean; a cell without any is nodata.
//!
//! Per direction D with elevation angles `θ_k = atan((z_k − z_0)/d_k)`:
//! positive openness `φ_D = 90° − max θ_k`, negative openness
//! `ψ_D = 90° + min θ_k` (Yokoyama et al. 2002; means over D);
//! sky-view factor `1 − mean_D sin(max(max θ_k, 0))` (Zakšek et al. 2011,
//! with the horizon clamped at the horizontal: terrain below it hides
//! no sky).

use crate::raster::{Grid, TileView};

/// The 16 ray steps (dx east, dy south in rows); the first 8 are the axes and diagonals.
const DIRS: [(i64, i64); 16] = [
    (0, -1),
    (1, -1),
    (1, 0),
    (1, 1),
    (0, 1),
    (-1, 1),
    (-1, 0),
    (-1, -1),
    (1, -2),
    (2, -1),
    (2, 1),
    (1, 2),
    (-1, 2),
    (-2, 1),
    (-2, -1),
    (-1, -2),
];

/// Which horizon outputs to fill.
pub struct HorizonOut<'a> {
    pub positive: Option<&'a mut Grid<f32>>,
    pub negative: Option<&'a mut Grid<f32>>,
    pub sky_view: Option<&'a mut Grid<f32>>,
}

/// Compute the requested horizon descriptors for every core cell of `view`
/// with rays of at most `steps` cells per axis (≤ the view's halo) and a
/// cutoff of `cutoff_m` metres; `directions` is 8 or 16.
pub fn horizon(
    view: &TileView<f32>,
    steps: usize,
    cutoff_m: f64,
    directions: usize,
    mut out: HorizonOut<'_>,
) {
    assert!(steps <= view.halo, "horizon rays must stay inside the halo");
    let h = view.halo;
    let gw = view.grid.width();
    let data = view.grid.data();
    let dirs = &DIRS[..directions.min(16)];
    let limit = cutoff_m * (1.0 + 1e-12);
    for y in 0..view.core.h {
        let (ew, ns) = view.georef.cell_size_m(view.core.y + y as i64);
        // Per direction: step distance and the number of steps within the cutoff.
        let mut plan = [(0isize, 0.0f64, 0usize); 16];
        for (p, &(dx, dy)) in plan.iter_mut().zip(dirs) {
            let d = ((dx as f64 * ew).powi(2) + (dy as f64 * ns).powi(2)).sqrt();
            let axis = dx.unsigned_abs().max(dy.unsigned_abs()) as usize;
            let mut k = steps / axis;
            while k > 0 && k as f64 * d > limit {
                k -= 1;
            }
            *p = (dy as isize * gw as isize + dx as isize, d, k);
        }
        for x in 0..view.core.w {
            let c = (y + h) * gw + x + h;
            let z0 = data[c] as f64;
            let (mut pos, mut neg, mut svf, mut nd) = (0.0, 0.0, 0.0, 0usize);
            if !z0.is_nan() {
                for &(off, d, k) in &plan[..dirs.len()] {
                    let (mut hi, mut lo) = (f64::NEG_INFINITY, f64::INFINITY);
                    let mut i = c as isize;
                    for s in 1..=k {
                        i += off;
                        let z = data[i as usize] as f64;
                        if !z.is_nan() {
                            let t = (z - z0) / (s as f64 * d);
                            hi = hi.max(t);
                            lo = lo.min(t);
                        }
                    }
                    if hi == f64::NEG_INFINITY {
                        continue;
                    }
                    let (up, down) = (hi.atan(), lo.atan());
                    pos += 90.0 - up.to_degrees();
                    neg += 90.0 + down.to_degrees();
                    svf += up.max(0.0).sin();
                    nd += 1;
                }
            }
            let n = nd as f64;
            let (p, q, s) = if nd == 0 {
                (f32::NAN, f32::NAN, f32::NAN)
            } else {
                ((pos / n) as f32, (neg / n) as f32, (1.0 - svf / n) as f32)
            };
            if let Some(g) = out.positive.as_deref_mut() {
                g.set(x, y, p);
            }
            if let Some(g) = out.negative.as_deref_mut() {
                g.set(x, y, q);
            }
            if let Some(g) = out.sky_view.as_deref_mut() {
                g.set(x, y, s);
            }
        }
    }
}
