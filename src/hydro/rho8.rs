//! Rho8: stochastic D8 flow directions.
//!
//! Fairfield, J., Leymarie, P. (1991). "Drainage networks from grid digital
//! elevation models". Water Resources Research 27(5), 709–717. D8 picks the
//! steepest of the 8 neighbours with diagonal distance √2, which biases flow
//! paths towards the 8 directions; Rho8 instead scales the drop towards a
//! diagonal neighbour by `ρ = 1/(2 − r)`, `r` uniform in [0, 1) drawn once
//! per cell (the mean of ρ is ln 2 ≈ 1/√2), so that, on average over many cells, flow
//! directions follow the true aspect.
//!
//! Determinism: `r` comes from a hash of the seed and the cell's *global*
//! (column, row) (SplitMix64 finaliser, Steele, Lea & Flood 2014, "Fast
//! splittable pseudorandom number generators", OOPSLA), so the same seed
//! gives the same directions whatever the tiling or thread count.
//!
//! Cells without a lower neighbour are handled as [`super::d8_directions`]
//! does (outlet cells point off the DEM; flats are drained per Barnes,
//! Lehman & Mulla 2014, with the same result as D8 on flats), which is what
//! lets the tiled version reuse [`super::tiled::TiledD8`]'s flat machinery.

use super::{valid, D8_CODES, DX, DY, NODATA_DIR, NO_FLOW};
use crate::raster::Grid;

/// SplitMix64 finaliser (Steele, Lea & Flood 2014).
#[inline]
fn mix64(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^ (x >> 31)
}

/// The uniform variate `r` in [0, 1) of global cell (`gx`, `gy`) for `seed`.
#[inline]
pub fn rho8_random(seed: u64, gx: u64, gy: u64) -> f64 {
    let h = mix64(mix64(seed) ^ mix64((gy << 32) ^ gx));
    (h >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// Rho8 code of cell (x, y) of a `w` x `h` array, with variate `r`: the
/// neighbour of largest `drop` (cardinal) or `drop / (2 − r)` (diagonal),
/// first in E..NE order on ties; without a lower neighbour, the first
/// nodata/off-array neighbour, else [`NO_FLOW`].
#[inline]
pub(crate) fn rho8_cell(z: &[f32], w: usize, h: usize, x: usize, y: usize, r: f64) -> u8 {
    let zc = z[y * w + x];
    if !valid(zc) {
        return NODATA_DIR;
    }
    let inv = 1.0 / (2.0 - r);
    let mut best = 0.0f64;
    let mut best_d = usize::MAX;
    let mut exit_d = usize::MAX;
    for d in 0..8 {
        let nx = x as i64 + DX[d];
        let ny = y as i64 + DY[d];
        let zn = if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
            f32::NAN
        } else {
            z[ny as usize * w + nx as usize]
        };
        if !valid(zn) {
            if exit_d == usize::MAX {
                exit_d = d;
            }
            continue;
        }
        let drop = zc as f64 - zn as f64;
        let s = if d % 2 == 1 { drop * inv } else { drop };
        if s > best {
            best = s;
            best_d = d;
        }
    }
    if best_d != usize::MAX {
        D8_CODES[best_d]
    } else if exit_d != usize::MAX {
        D8_CODES[exit_d]
    } else {
        NO_FLOW
    }
}

/// Rho8 flow directions of `dem` (normally a filled or breached DEM) with
/// `seed`; ESRI codes as [`super::d8_directions`], flats resolved as there.
/// The grid's (0, 0) is taken as global cell (0, 0).
pub fn rho8_directions(dem: &Grid<f32>, seed: u64) -> Grid<u8> {
    let (w, h) = (dem.width(), dem.height());
    let z = dem.data();
    let mut dir = vec![NODATA_DIR; z.len()];
    for y in 0..h {
        for x in 0..w {
            let r = rho8_random(seed, x as u64, y as u64);
            dir[y * w + x] = rho8_cell(z, w, h, x, y, r);
        }
    }
    super::flow::resolve_flats(z, w, h, &mut dir);
    Grid::from_vec(w, h, dir).expect("same size as the input")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn variates_are_uniform_enough_and_seeded() {
        let mut sum = 0.0;
        let n = 10_000u64;
        for i in 0..n {
            let r = rho8_random(7, i % 100, i / 100);
            assert!((0.0..1.0).contains(&r));
            sum += r;
        }
        assert!((sum / n as f64 - 0.5).abs() < 0.02);
        assert_ne!(rho8_random(1, 3, 4), rho8_random(2, 3, 4));
        assert_eq!(rho8_random(1, 3, 4), rho8_random(1, 3, 4));
    }
}
