//! 3x3 pointwise descriptors: Evans' quadric coefficients and the curvatures
//! derived from them, the 5-point Laplacian, TRI (Riley; Wilson) and Jenness'
//! rugosity. Windows are `[a b c / d e f / g h i]` = `z1..z9` in row-major
//! order with row 0 to the north (as `walk_3x3` passes them); `ew`, `ns` are
//! the true cell sizes in metres.

/// Partial derivatives of the quadric `z = r x²/2 + t y²/2 + s x y + p x + q y + c`
/// fitted by least squares to a 3x3 window (Evans 1979, "An integrated system
/// of terrain analysis and slope mapping", Final report DA-ERO-591-73-G0040,
/// Univ. Durham; formulas as in Florinsky 2016, *Digital Terrain Analysis in
/// Soil Science and Geology*, 2nd ed., ch. 4, Evans–Young method), generalised to
/// rectangular cells (x east with spacing `ew`, y north with spacing `ns`):
/// `p = (z3+z6+z9−z1−z4−z7)/(6 ew)`, `q = (z1+z2+z3−z7−z8−z9)/(6 ns)`,
/// `r = (z1+z3+z4+z6+z7+z9 − 2(z2+z5+z8))/(3 ew²)`,
/// `t = (z1+z2+z3+z7+z8+z9 − 2(z4+z5+z6))/(3 ns²)`,
/// `s = (z3+z7−z1−z9)/(4 ew ns)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Quadric {
    pub p: f64,
    pub q: f64,
    pub r: f64,
    pub s: f64,
    pub t: f64,
}

impl Quadric {
    /// Fit a 3x3 window.
    #[inline]
    pub fn fit(w: &[f64; 9], ew: f64, ns: f64) -> Quadric {
        let [z1, z2, z3, z4, z5, z6, z7, z8, z9] = *w;
        Quadric {
            p: (z3 + z6 + z9 - z1 - z4 - z7) / (6.0 * ew),
            q: (z1 + z2 + z3 - z7 - z8 - z9) / (6.0 * ns),
            r: (z1 + z3 + z4 + z6 + z7 + z9 - 2.0 * (z2 + z5 + z8)) / (3.0 * ew * ew),
            t: (z1 + z2 + z3 + z7 + z8 + z9 - 2.0 * (z4 + z5 + z6)) / (3.0 * ns * ns),
            s: (z3 + z7 - z1 - z9) / (4.0 * ew * ns),
        }
    }

    /// Mean curvature `H = −((1+q²)r − 2pqs + (1+p²)t) / (2 (1+p²+q²)^{3/2})`
    /// (Florinsky 2016, ch. 2); positive on convex (hill-top) surfaces.
    #[inline]
    pub fn mean(&self) -> f64 {
        let Quadric { p, q, r, s, t } = *self;
        let g = 1.0 + p * p + q * q;
        -((1.0 + q * q) * r - 2.0 * p * q * s + (1.0 + p * p) * t) / (2.0 * g * g.sqrt())
    }

    /// Gaussian curvature `K = (rt − s²)/(1+p²+q²)²` (Florinsky 2016, ch. 2).
    #[inline]
    pub fn gaussian(&self) -> f64 {
        let Quadric { p, q, r, s, t } = *self;
        let g = 1.0 + p * p + q * q;
        (r * t - s * s) / (g * g)
    }

    /// Minimal and maximal curvatures `H ∓ √(H² − K)` (Florinsky 2016, ch. 2);
    /// `H² − K` is clamped at 0 against rounding.
    #[inline]
    pub fn min_max(&self) -> (f64, f64) {
        let h = self.mean();
        let d = (h * h - self.gaussian()).max(0.0).sqrt();
        (h - d, h + d)
    }

    /// Vertical (profile) curvature
    /// `kv = −(p²r + 2pqs + q²t) / ((p²+q²) (1+p²+q²)^{3/2})` (Florinsky
    /// 2016, ch. 2); 0 where the gradient is 0 (undefined there).
    #[inline]
    pub fn profile(&self) -> f64 {
        let Quadric { p, q, r, s, t } = *self;
        let g2 = p * p + q * q;
        if g2 == 0.0 {
            return 0.0;
        }
        let g = 1.0 + g2;
        -(p * p * r + 2.0 * p * q * s + q * q * t) / (g2 * g * g.sqrt())
    }

    /// Horizontal (tangential) curvature
    /// `kh = −(q²r − 2pqs + p²t) / ((p²+q²) √(1+p²+q²))` (Florinsky 2016,
    /// ch. 2); 0 where the gradient is 0.
    #[inline]
    pub fn tangential(&self) -> f64 {
        let Quadric { p, q, r, s, t } = *self;
        let g2 = p * p + q * q;
        if g2 == 0.0 {
            return 0.0;
        }
        -(q * q * r - 2.0 * p * q * s + p * p * t) / (g2 * (1.0 + g2).sqrt())
    }

    /// Plan (contour) curvature, the curvature of the contour line in the
    /// horizontal plane: `kp = −(q²r − 2pqs + p²t) / (p²+q²)^{3/2}`
    /// (Florinsky 2016, ch. 2); 0 where the gradient is 0.
    #[inline]
    pub fn plan(&self) -> f64 {
        let Quadric { p, q, r, s, t } = *self;
        let g2 = p * p + q * q;
        if g2 == 0.0 {
            return 0.0;
        }
        -(q * q * r - 2.0 * p * q * s + p * p * t) / (g2 * g2.sqrt())
    }
}

/// 5-point Laplacian `(z4 + z6 − 2 z5)/ew² + (z2 + z8 − 2 z5)/ns²`.
#[inline]
pub fn laplacian(w: &[f64; 9], ew: f64, ns: f64) -> f64 {
    (w[3] + w[5] - 2.0 * w[4]) / (ew * ew) + (w[1] + w[7] - 2.0 * w[4]) / (ns * ns)
}

/// Terrain ruggedness index of Riley, DeGloria & Elliot (1999):
/// `√Σ (z_i − z5)²` over the 8 neighbours.
#[inline]
pub fn tri_riley(w: &[f64; 9]) -> f64 {
    let c = w[4];
    w.iter().map(|z| (z - c) * (z - c)).sum::<f64>().sqrt()
}

/// Terrain ruggedness index of Wilson et al. (2007, Marine Geodesy 30, 3-35):
/// mean absolute difference to the 8 neighbours (gdaldem TRI -alg Wilson;
/// GDAL 3.6's default TRI is Riley's).
#[inline]
pub fn tri_wilson(w: &[f64; 9]) -> f64 {
    let c = w[4];
    w.iter().map(|z| (z - c).abs()).sum::<f64>() / 8.0
}

/// Rugosity (surface-area ratio) of Jenness (2004, "Calculating landscape
/// surface area from digital elevation models", Wildlife Society Bulletin
/// 32(3), 829-839): the 3D triangles joining the centre to each pair of
/// adjacent neighbours among the 8, clipped to the cell (every edge halved,
/// so each triangle is similar to the full one with factor ½ and a quarter of
/// its area), summed and divided by the cell's planimetric area `ew·ns`.
/// Triangle areas as half the norm of the cross product of the two spokes
/// (the same areas as Jenness's Heron formula on the edge lengths, with one
/// square root per triangle instead of four).
#[inline]
pub fn rugosity(w: &[f64; 9], ew: f64, ns: f64) -> f64 {
    // Neighbours in ring order around the centre (clockwise from north-west),
    // with their (dx, dy) offsets in cells.
    const RING: [(usize, f64, f64); 8] = [
        (0, -1.0, 1.0),
        (1, 0.0, 1.0),
        (2, 1.0, 1.0),
        (5, 1.0, 0.0),
        (8, 1.0, -1.0),
        (7, 0.0, -1.0),
        (6, -1.0, -1.0),
        (3, -1.0, 0.0),
    ];
    let c = w[4];
    // Spokes clipped to the cell (halved): (dx, dy, dz) in metres.
    let mut sx = [0.0; 8];
    let mut sy = [0.0; 8];
    let mut sz = [0.0; 8];
    for k in 0..8 {
        let (i, dx, dy) = RING[k];
        sx[k] = 0.5 * dx * ew;
        sy[k] = 0.5 * dy * ns;
        sz[k] = 0.5 * (w[i] - c);
    }
    let mut area = 0.0;
    for k in 0..8 {
        let j = (k + 1) % 8;
        let cx = sy[k] * sz[j] - sz[k] * sy[j];
        let cy = sz[k] * sx[j] - sx[k] * sz[j];
        let cz = sx[k] * sy[j] - sy[k] * sx[j];
        area += 0.5 * (cx * cx + cy * cy + cz * cz).sqrt();
    }
    area / (ew * ns)
}

impl Quadric {
    /// All coefficients NaN (nodata).
    pub const NAN: Quadric = Quadric {
        p: f64::NAN,
        q: f64::NAN,
        r: f64::NAN,
        s: f64::NAN,
        t: f64::NAN,
    };
}

/// Solve the 6x6 system `m · x = v` by Gaussian elimination with partial
/// pivoting; `None` if (numerically) singular.
fn solve6(mut m: [[f64; 6]; 6], mut v: [f64; 6]) -> Option<[f64; 6]> {
    let scale = m.iter().flatten().fold(0.0f64, |a, b| a.max(b.abs()));
    if scale == 0.0 || !scale.is_finite() {
        return None;
    }
    for col in 0..6 {
        let piv = (col..6).max_by(|&a, &b| m[a][col].abs().total_cmp(&m[b][col].abs()))?;
        if m[piv][col].abs() <= 1e-12 * scale {
            return None;
        }
        m.swap(col, piv);
        v.swap(col, piv);
        let pivot_row = m[col];
        for row in col + 1..6 {
            let f = m[row][col] / pivot_row[col];
            for (a, b) in m[row][col..].iter_mut().zip(&pivot_row[col..]) {
                *a -= f * b;
            }
            v[row] -= f * v[col];
        }
    }
    let mut x = [0.0; 6];
    for row in (0..6).rev() {
        let mut s = v[row];
        for k in row + 1..6 {
            s -= m[row][k] * x[k];
        }
        x[row] = s / m[row][row];
    }
    Some(x)
}

/// Basis of the quadric at offset (i east, j north) in cells.
#[inline(always)]
fn basis(i: f64, j: f64) -> [f64; 6] {
    [i * i, j * j, i * j, i, j, 1.0]
}

/// Wood's quadric fit (Wood 1996, *The geomorphological characterisation of
/// digital elevation models*, PhD thesis, Univ. Leicester, ch. 4): the
/// unweighted least-squares quadric `z = a x² + b y² + c xy + d x + e y + f`
/// over the valid cells of the `(2r+1)²` window, so that curvatures describe
/// the terrain at the scale of the window (for r = 1 it is Evans' fit).
/// Offsets are in cells, heights relative to the centre (conditioning);
/// derivatives are then scaled by the row's true cell sizes:
/// `p = d/ew, q = e/ns, r = 2a/ew², t = 2b/ns², s = c/(ew·ns)`.
/// Windows without nodata share one precomputed inverse normal matrix (6
/// sums per window cell); windows with holes solve their own 6x6 system.
/// Cost O(r²) per cell. Cells whose centre is nodata, or whose valid cells
/// do not determine the quadric, get [`Quadric::NAN`]. Needs `r ≤ halo`.
pub fn wood_fit(
    view: &crate::raster::TileView<f32>,
    r: usize,
    out: &mut crate::raster::Grid<Quadric>,
) {
    assert!(r >= 1 && r <= view.halo, "Wood's fit needs 1 <= r <= halo");
    let h = view.halo;
    let gw = view.grid.width();
    let data = view.grid.data();
    let ri = r as i64;
    let side = 2 * r + 1;
    // The full window's normal matrix and its inverse (columns of M⁻¹).
    let mut full = [[0.0; 6]; 6];
    for dy in -ri..=ri {
        for dx in -ri..=ri {
            let b = basis(dx as f64, -dy as f64);
            for (a, ba) in full.iter_mut().zip(&b) {
                for (m, bb) in a.iter_mut().zip(&b) {
                    *m += ba * bb;
                }
            }
        }
    }
    let mut inv = [[0.0; 6]; 6];
    for k in 0..6 {
        let mut e = [0.0; 6];
        e[k] = 1.0;
        // The full window of r >= 1 always determines the quadric.
        let col = solve6(full, e).unwrap_or([f64::NAN; 6]);
        for (row, c) in inv.iter_mut().zip(col) {
            row[k] = c;
        }
    }
    for y in 0..view.core.h {
        let (ew, ns) = view.georef.cell_size_m(view.core.y + y as i64);
        for x in 0..view.core.w {
            let c = (y + h) * gw + x + h;
            let z0 = data[c] as f64;
            if z0.is_nan() {
                out.set(x, y, Quadric::NAN);
                continue;
            }
            let mut v = [0.0; 6];
            let mut n = 0usize;
            for (row, dy) in (-ri..=ri).enumerate() {
                let start = c - r * gw + row * gw - r;
                let line = &data[start..start + side];
                for (col, &z) in line.iter().enumerate() {
                    if z.is_nan() {
                        continue;
                    }
                    let dz = z as f64 - z0;
                    let b = basis(col as f64 - r as f64, -dy as f64);
                    for (vk, bk) in v.iter_mut().zip(&b) {
                        *vk += bk * dz;
                    }
                    n += 1;
                }
            }
            let beta = if n == side * side {
                let mut bt = [0.0; 6];
                for (o, row) in bt.iter_mut().zip(&inv) {
                    *o = row.iter().zip(&v).map(|(a, b)| a * b).sum();
                }
                Some(bt)
            } else {
                let mut m = [[0.0; 6]; 6];
                for (row, dy) in (-ri..=ri).enumerate() {
                    let start = c - r * gw + row * gw - r;
                    for (col, &z) in data[start..start + side].iter().enumerate() {
                        if z.is_nan() {
                            continue;
                        }
                        let b = basis(col as f64 - r as f64, -dy as f64);
                        for (a, ba) in m.iter_mut().zip(&b) {
                            for (mm, bb) in a.iter_mut().zip(&b) {
                                *mm += ba * bb;
                            }
                        }
                    }
                }
                solve6(m, v)
            };
            out.set(
                x,
                y,
                match beta {
                    Some(b) => Quadric {
                        p: b[3] / ew,
                        q: b[4] / ns,
                        r: 2.0 * b[0] / (ew * ew),
                        t: 2.0 * b[1] / (ns * ns),
                        s: b[2] / (ew * ns),
                    },
                    None => Quadric::NAN,
                },
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raster::{Crs, GeoRef, Grid, TileView, Window};

    #[test]
    fn wood_radius_one_is_evans() {
        let data: Vec<f32> = (0..25).map(|i| ((i * 37) % 11) as f32 * 1.5).collect();
        let view = TileView {
            id: 0,
            core: Window::new(1, 1, 3, 3),
            halo: 1,
            grid: Grid::from_vec(5, 5, data.clone()).unwrap(),
            georef: GeoRef::north_up(0.0, 0.0, 10.0, Crs::projected(32611)),
            raster_width: 5,
            raster_height: 5,
        };
        let mut out = Grid::new(3, 3, Quadric::NAN);
        wood_fit(&view, 1, &mut out);
        for y in 0..3 {
            for x in 0..3 {
                let mut w = [0.0; 9];
                for k in 0..9 {
                    w[k] = data[(y + k / 3) * 5 + x + k % 3] as f64;
                }
                let e = Quadric::fit(&w, 10.0, 10.0);
                let g = out.get(x, y);
                for (a, b) in [(g.p, e.p), (g.q, e.q), (g.r, e.r), (g.s, e.s), (g.t, e.t)] {
                    assert!((a - b).abs() < 1e-12, "({x},{y}) {g:?} vs {e:?}");
                }
            }
        }
    }
}
