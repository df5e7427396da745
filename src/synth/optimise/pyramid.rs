//! Gaussian pyramids and resampling for the example-based synthesis.
//!
//! One pyramid step is the REDUCE operation of Burt & Adelson (1983), "The
//! Laplacian pyramid as a compact image code", IEEE Trans. Communications
//! 31(4): a separable 5-tap binomial low-pass `[1 4 6 4 1] / 16` followed by
//! keeping every second sample. Coarse cell `j` sits exactly on fine cell
//! `2j`, which is the convention of the correspondence upsampling
//! `C^{k-1}(p) = 2 C^k(⌊p/2⌋) + (p − 2⌊p/2⌋)` (Scott & Dodgson 2022).
//! Edges replicate the border cell. NaN (nodata) propagates to every coarse
//! cell whose filter support touches it, so a coarse cell is valid only if
//! all the fine cells it averages are.

use crate::raster::Grid;

const TAPS: [f32; 5] = [1.0 / 16.0, 4.0 / 16.0, 6.0 / 16.0, 4.0 / 16.0, 1.0 / 16.0];

/// One REDUCE step: blur, then keep even rows and columns. The result is
/// `ceil(w/2) x ceil(h/2)`.
pub fn reduce(g: &Grid<f32>) -> Grid<f32> {
    let (w, h) = (g.width(), g.height());
    let (ow, oh) = (w.div_ceil(2), h.div_ceil(2));
    let d = g.data();
    let clamp = |i: i64, n: usize| i.clamp(0, n as i64 - 1) as usize;
    // Horizontal pass at the kept columns only, for every row.
    let mut horiz = vec![0f32; ow * h];
    for y in 0..h {
        let row = &d[y * w..(y + 1) * w];
        for ox in 0..ow {
            let x = 2 * ox as i64;
            let mut s = 0f32;
            for (t, &k) in TAPS.iter().enumerate() {
                s += k * row[clamp(x + t as i64 - 2, w)];
            }
            horiz[y * ow + ox] = s;
        }
    }
    let mut out = vec![0f32; ow * oh];
    for oy in 0..oh {
        let y = 2 * oy as i64;
        let rows: [usize; 5] = std::array::from_fn(|t| clamp(y + t as i64 - 2, h));
        for ox in 0..ow {
            let mut s = 0f32;
            for (t, &k) in TAPS.iter().enumerate() {
                s += k * horiz[rows[t] * ow + ox];
            }
            out[oy * ow + ox] = s;
        }
    }
    Grid::from_fn(ow, oh, |x, y| out[y * ow + x])
}

/// A Gaussian pyramid: level 0 is `g` itself, level `k` is `reduce` applied
/// `k` times.
pub fn gaussian_pyramid(g: &Grid<f32>, levels: usize) -> Vec<Grid<f32>> {
    let mut out = vec![g.clone()];
    for _ in 0..levels {
        let next = reduce(out.last().unwrap_or(g));
        out.push(next);
    }
    out
}

/// Size of pyramid level `k` of a `w x h` grid (each level halves, rounding up).
pub fn level_size(w: usize, h: usize, k: usize) -> (usize, usize) {
    let mut s = (w, h);
    for _ in 0..k {
        s = (s.0.div_ceil(2), s.1.div_ceil(2));
    }
    s
}

/// Sink masks per level: a coarse cell is a sink when any of the 2x2 fine
/// cells it stands for is one.
pub fn mask_pyramid(m: &Grid<bool>, levels: usize) -> Vec<Grid<bool>> {
    let mut out = vec![m.clone()];
    for _ in 0..levels {
        let f = out.last().unwrap_or(m);
        let (w, h) = (f.width(), f.height());
        let c = Grid::from_fn(w.div_ceil(2), h.div_ceil(2), |x, y| {
            let mut any = false;
            for yy in 2 * y..(2 * y + 2).min(h) {
                for xx in 2 * x..(2 * x + 2).min(w) {
                    any |= f.get(xx, yy);
                }
            }
            any
        });
        out.push(c);
    }
    out
}

/// Bilinear resampling of `g` to `w x h` over the same extent (cell centres
/// map as `u = (x + 0.5)·gw/w − 0.5`, clamped to the grid). Used to bring the
/// guide to the output size.
pub fn resize_bilinear(g: &Grid<f32>, w: usize, h: usize) -> Grid<f32> {
    let (gw, gh) = (g.width(), g.height());
    let d = g.data();
    let coord = |x: usize, n: usize, gn: usize| -> (usize, usize, f32) {
        let u = ((x as f64 + 0.5) * gn as f64 / n as f64 - 0.5).clamp(0.0, (gn - 1) as f64);
        let x0 = (u.floor() as usize).min(gn - 1);
        let x1 = (x0 + 1).min(gn - 1);
        (x0, x1, (u - x0 as f64) as f32)
    };
    let cols: Vec<(usize, usize, f32)> = (0..w).map(|x| coord(x, w, gw)).collect();
    let rows: Vec<(usize, usize, f32)> = (0..h).map(|y| coord(y, h, gh)).collect();
    gather_bilinear(d, gw, &cols, &rows)
}

/// Bilinear upsampling from a pyramid level to the next finer one
/// (`w x h`, about twice the size): fine cell `i` lies at coarse position
/// `i/2`, the convention of [`reduce`].
pub fn expand(g: &Grid<f32>, w: usize, h: usize) -> Grid<f32> {
    let (gw, gh) = (g.width(), g.height());
    let d = g.data();
    let coord = |x: usize, gn: usize| -> (usize, usize, f32) {
        let u = (x as f32 * 0.5).min((gn - 1) as f32);
        let x0 = u as usize;
        let x1 = (x0 + 1).min(gn - 1);
        (x0, x1, u - x0 as f32)
    };
    let cols: Vec<(usize, usize, f32)> = (0..w).map(|x| coord(x, gw)).collect();
    let rows: Vec<(usize, usize, f32)> = (0..h).map(|y| coord(y, gh)).collect();
    gather_bilinear(d, gw, &cols, &rows)
}

/// Bilinear interpolation of the row-major grid `d` (width `gw`) at the
/// separable positions `cols` × `rows`, each `(lower index, upper index,
/// fraction)`.
fn gather_bilinear(
    d: &[f32],
    gw: usize,
    cols: &[(usize, usize, f32)],
    rows: &[(usize, usize, f32)],
) -> Grid<f32> {
    Grid::from_fn(cols.len(), rows.len(), |x, y| {
        let (x0, x1, fx) = cols[x];
        let (y0, y1, fy) = rows[y];
        let a = d[y0 * gw + x0];
        let b = d[y0 * gw + x1];
        let c = d[y1 * gw + x0];
        let e = d[y1 * gw + x1];
        let top = a + fx * (b - a);
        let bot = c + fx * (e - c);
        top + fy * (bot - top)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reduce_keeps_planes_and_sizes() {
        // The binomial filter reproduces linear functions away from the edges
        // and sums to one: a plane z = 3x + 5y stays 3(2j) + 5(2i) inside.
        let g = Grid::from_fn(21, 14, |x, y| 3.0 * x as f32 + 5.0 * y as f32);
        let r = reduce(&g);
        assert_eq!((r.width(), r.height()), (11, 7));
        for y in 1..6 {
            for x in 1..10 {
                let want = 3.0 * (2 * x) as f32 + 5.0 * (2 * y) as f32;
                assert!((r.get(x, y) - want).abs() < 1e-4, "{x},{y}");
            }
        }
        assert_eq!(level_size(21, 14, 2), (6, 4));
    }

    #[test]
    fn reduce_propagates_nan_locally() {
        let mut g = Grid::new(16, 16, 1.0f32);
        g.set(8, 8, f32::NAN);
        let r = reduce(&g);
        // fine 8 is reached from coarse 3 (taps 4..8), 4 (6..10), 5 (8..12)
        for y in 0..8 {
            for x in 0..8 {
                let near = (3..=5).contains(&x) && (3..=5).contains(&y);
                assert_eq!(r.get(x, y).is_nan(), near, "{x},{y}");
            }
        }
    }

    #[test]
    fn expand_interpolates_halfway() {
        let g = Grid::from_fn(4, 3, |x, y| (10 * x + y) as f32);
        let e = expand(&g, 7, 5);
        assert_eq!(e.get(2, 2), g.get(1, 1));
        assert!((e.get(3, 1) - (15.0 + 0.5)).abs() < 1e-6);
        assert_eq!(e.get(6, 4), g.get(3, 2));
    }

    #[test]
    fn bilinear_resize_of_a_plane() {
        let g = Grid::from_fn(10, 10, |x, y| x as f32 + 2.0 * y as f32);
        let r = resize_bilinear(&g, 40, 40);
        // interior: u = (x+0.5)/4 - 0.5
        for &(x, y) in &[(5usize, 7usize), (20, 20), (33, 9)] {
            let u = (x as f32 + 0.5) / 4.0 - 0.5;
            let v = (y as f32 + 0.5) / 4.0 - 0.5;
            assert!((r.get(x, y) - (u + 2.0 * v)).abs() < 1e-4);
        }
    }
}
