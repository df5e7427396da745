//! 2-D simplex noise and its fBm, seeded and tileable.
//!
//! Source: K. Perlin, "Noise hardware", SIGGRAPH 2001 course notes (simplex
//! noise: a skewed triangular lattice, radially symmetric kernels
//! (r² - d²)⁴ around each of the three corners); the 2-D skew constants and
//! kernel radius r² = 0.5 follow S. Gustavson, "Simplex noise demystified"
//! (2005). Corner gradients are hashed from the lattice point and the seed
//! ([`super::noise::lattice_grad`]) instead of a permutation table, so the
//! noise has no period and every cell is a pure function of its coordinates.

use super::noise::{lattice_grad, Octave};
use crate::raster::Window;

/// Skew factor (√3 − 1)/2 of the 2-D simplex lattice.
const F2: f64 = 0.366_025_403_784_438_6;
/// Unskew factor (3 − √3)/6.
const G2: f64 = 0.211_324_865_405_187_1;
/// Scales the sum of the three kernels to [-1, 1] for unit gradients (the
/// maximum of the raw sum, found numerically, is just under 1/99.2).
const SCALE: f64 = 99.2;

/// Simplex noise at (x, y) in lattice units, in about [-1, 1].
#[inline]
pub fn simplex_noise(x: f64, y: f64, seed: u64) -> f64 {
    let s = (x + y) * F2;
    let (i, j) = ((x + s).floor(), (y + s).floor());
    let t = (i + j) * G2;
    let (x0, y0) = (x - (i - t), y - (j - t));
    let (i, j) = (i as i64, j as i64);
    let (i1, j1) = if x0 > y0 { (1, 0) } else { (0, 1) };
    let (x1, y1) = (x0 - i1 as f64 + G2, y0 - j1 as f64 + G2);
    let (x2, y2) = (x0 - 1.0 + 2.0 * G2, y0 - 1.0 + 2.0 * G2);
    let corner = |gx: i64, gy: i64, dx: f64, dy: f64| {
        let t = 0.5 - dx * dx - dy * dy;
        if t <= 0.0 {
            0.0
        } else {
            let (a, b) = lattice_grad(gx, gy, seed);
            let t2 = t * t;
            t2 * t2 * (a * dx + b * dy)
        }
    };
    let n = corner(i, j, x0, y0) + corner(i + i1, j + j1, x1, y1) + corner(i + 1, j + 1, x2, y2);
    SCALE * n
}

/// fBm of simplex noise over `win`: Σ amp·noise(p·freq + offset) / Σ amp,
/// p the cell centre.
pub(crate) fn fbm_field(octs: &[(Octave, f64)], win: Window, out: &mut [f64]) {
    let norm: f64 = octs.iter().map(|o| o.1).sum();
    let inv = 1.0 / norm;
    for r in 0..win.h {
        let y = (win.y + r as i64) as f64 + 0.5;
        let row = &mut out[r * win.w..(r + 1) * win.w];
        for (c, o) in row.iter_mut().enumerate() {
            let x = (win.x + c as i64) as f64 + 0.5;
            let mut sum = 0.0;
            for (oct, amp) in octs {
                sum += amp * simplex_noise(x * oct.freq + oct.ox, y * oct.freq + oct.oy, oct.seed);
            }
            *o = sum * inv;
        }
    }
}
