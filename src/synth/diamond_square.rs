//! Diamond-square midpoint displacement on the infinite plane, tileable.
//!
//! Source: A. Fournier, D. Fussell & L. Carpenter, "Computer rendering of
//! stochastic models", CACM 25(6), 1982 (recursive subdivision: each new
//! point is the mean of its parents plus a random displacement whose scale
//! shrinks by 2^-H per level); the square ("diamond") and edge ("square")
//! steps as popularised by G. Miller, "The definition and rendering of
//! terrain maps", SIGGRAPH 1986.
//!
//! Tileable design: the coarse lattice has spacing S = 2^L cells (the
//! wavelength rounded up to a power of two) and covers the whole plane; its
//! values, and the displacement of every point created at level l, are
//! Gaussian numbers hashed from (seed, level, global coordinates) — a
//! counter-based RNG, no state. A point's value is then a pure function of
//! its ancestors, and level l only needs level l-1 on its own window grown by
//! two cells of that level. So a tile is computed by walking up from the tile
//! to the coarse lattice (window at level l-1 = window at level l halved and
//! grown by 1..2 points), generating that small coarse window, and refining
//! it down level by level. Cost per tile of T x T cells: Σ_l (T/2^l + 5)²
//! ≈ 4/3 T² + O(T + L) point updates; memory: two level grids of about
//! (T + 5)² f64. Any tile thus equals the same window of a whole-grid run,
//! bit for bit, and there are no edges to the plane (no boundary artefacts
//! at tile or raster borders).

use super::noise::{gauss_from_hash, mix, Noise};
use crate::raster::Window;

/// One level's grid: values at lattice indices [i0, i0 + w) x [j0, j0 + h)
/// of that level's spacing.
struct Level {
    i0: i64,
    j0: i64,
    w: usize,
    h: usize,
    v: Vec<f64>,
}

impl Level {
    /// The sub-grid of indices [a0, a1] x [b0, b1] (inclusive, inside).
    fn crop(&self, a0: i64, a1: i64, b0: i64, b1: i64) -> Level {
        let (w, h) = ((a1 - a0 + 1) as usize, (b1 - b0 + 1) as usize);
        let mut v = Vec::with_capacity(w * h);
        for j in b0..=b1 {
            let s = (j - self.j0) as usize * self.w + (a0 - self.i0) as usize;
            v.extend_from_slice(&self.v[s..s + w]);
        }
        Level {
            i0: a0,
            j0: b0,
            w,
            h,
            v,
        }
    }
    #[inline]
    fn at(&self, i: i64, j: i64) -> f64 {
        self.v[(j - self.j0) as usize * self.w + (i - self.i0) as usize]
    }
}

/// The counter-based random numbers of diamond-square: the N(0, 1)
/// displacement (before scaling by gain^level) of the point created at
/// `level` (0 = the coarse lattice) at global cell coordinates (gx, gy), for
/// the noise seed `seed`. Public so that tests can rebuild the field with
/// an independent implementation.
pub fn displacement(seed: u64, level: u32, gx: i64, gy: i64) -> f64 {
    rnd(mix(seed ^ 0x4453_0000), level, gx, gy)
}

#[inline]
fn rnd(seed: u64, level: u32, gx: i64, gy: i64) -> f64 {
    let h =
        mix(mix(mix(seed ^ level as u64) ^ gx as u64)
            ^ (gy as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15));
    gauss_from_hash(h)
}

/// The number of levels L: the coarse lattice spacing S = 2^L is the
/// smallest power of two >= `wavelength` (at least 2).
pub fn levels(wavelength: f64) -> u32 {
    let mut l = 1;
    while ((1u64 << l) as f64) < wavelength {
        l += 1;
    }
    l
}

/// The diamond-square field of `win` (about [-1, 1]) into `out`.
pub(crate) fn field(p: &Noise, win: Window, out: &mut [f64]) {
    let big_l = levels(p.wavelength);
    let seed = mix(p.seed ^ 0x4453_0000);
    // Index ranges (inclusive) needed at each level, finest first.
    let mut ranges = vec![(0i64, 0i64, 0i64, 0i64); big_l as usize + 1];
    ranges[big_l as usize] = (win.x, win.x_end() - 1, win.y, win.y_end() - 1);
    for l in (1..=big_l as usize).rev() {
        let (a0, a1, b0, b1) = ranges[l];
        ranges[l - 1] = (
            (a0 - 2).div_euclid(2),
            (a1 + 3).div_euclid(2),
            (b0 - 2).div_euclid(2),
            (b1 + 3).div_euclid(2),
        );
    }
    // Level 0: the coarse lattice, spacing S.
    let (i0, i1, j0, j1) = ranges[0];
    let s_big = 1i64 << big_l;
    let (w, h) = ((i1 - i0 + 1) as usize, (j1 - j0 + 1) as usize);
    let mut v = Vec::with_capacity(w * h);
    for j in j0..=j1 {
        for i in i0..=i1 {
            v.push(rnd(seed, 0, i * s_big, j * s_big));
        }
    }
    let mut cur = Level { i0, j0, w, h, v };
    let mut sigma = 1.0;
    let mut var = 1.0;
    for l in 1..=big_l {
        sigma *= p.gain;
        var += sigma * sigma;
        let step = 1i64 << (big_l - l); // spacing of this level's points
                                        // The fine grid spans the coarse one at twice the resolution.
        let fi0 = 2 * cur.i0;
        let fj0 = 2 * cur.j0;
        let fw = 2 * cur.w - 1;
        let fh = 2 * cur.h - 1;
        let mut fine = Level {
            i0: fi0,
            j0: fj0,
            w: fw,
            h: fh,
            v: vec![0.0; fw * fh],
        };
        // Corners: the coarse points.
        for cj in 0..cur.h {
            for ci in 0..cur.w {
                fine.v[2 * cj * fw + 2 * ci] = cur.v[cj * cur.w + ci];
            }
        }
        // Square step: centres of coarse squares (odd, odd).
        for y in (1..fh).step_by(2) {
            for x in (1..fw).step_by(2) {
                let m = (fine.v[(y - 1) * fw + x - 1]
                    + fine.v[(y - 1) * fw + x + 1]
                    + fine.v[(y + 1) * fw + x - 1]
                    + fine.v[(y + 1) * fw + x + 1])
                    * 0.25;
                let (gx, gy) = ((fi0 + x as i64) * step, (fj0 + y as i64) * step);
                fine.v[y * fw + x] = m + sigma * rnd(seed, l, gx, gy);
            }
        }
        // Diamond step: edge midpoints (exactly one odd index) whose four
        // neighbours lie inside the grid.
        for y in 1..fh.saturating_sub(1) {
            let x_first = if y % 2 == 0 { 1 } else { 2 };
            for x in (x_first..fw - 1).step_by(2) {
                let m = (fine.v[y * fw + x - 1]
                    + fine.v[y * fw + x + 1]
                    + fine.v[(y - 1) * fw + x]
                    + fine.v[(y + 1) * fw + x])
                    * 0.25;
                let (gx, gy) = ((fi0 + x as i64) * step, (fj0 + y as i64) * step);
                fine.v[y * fw + x] = m + sigma * rnd(seed, l, gx, gy);
            }
        }
        // Keep only what the next level needs (the border of `fine` is
        // incomplete, and an uncropped grid would double its margin per level).
        let (a0, a1, b0, b1) = ranges[l as usize];
        cur = fine.crop(a0, a1, b0, b1);
    }
    // About [-1, 1]: 2.5 standard deviations of the summed displacements.
    let k = 1.0 / (2.5 * var.sqrt());
    for r in 0..win.h {
        for c in 0..win.w {
            out[r * win.w + c] = cur.at(win.x + c as i64, win.y + r as i64) * k;
        }
    }
}
