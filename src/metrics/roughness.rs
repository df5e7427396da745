//! Roughness: the terrain ruggedness indices of Riley et al. and Wilson et
//! al., Jenness's rugosity (3x3 windows), and the spherical standard
//! deviation of the unit normals over square windows (Lindsay et al.).
//!
//! Sources: Riley, DeGloria & Elliot 1999, Intermountain J. Sci. 5; Wilson
//! et al. 2007, Marine Geodesy 30; Jenness 2004, Wildlife Society Bulletin
//! 32(3); Lindsay, Newman & Francioni 2019, Geosciences 9(7) 322.

use super::neighbourhood::{walk_3x3, window, EdgeMode};
use super::param::RADIUS;
use super::quadric::{rugosity, tri_riley, tri_wilson};
use super::registry::{metric_def, Metric, MetricDef, MetricKind, Needs, ScratchClass};
use super::spec::Resolved;
use super::terrain::horn_gradient;
use super::tile::{region_cells, Tile};
use super::MAX_RADIUS_CELLS;
use crate::error::Result;
use crate::raster::{Grid, TileView};

/// Fractional bits of the fixed-point unit normals summed for roughness.
const NORMAL_FRAC: u32 = 60;

/// A roughness index on the 3x3 window.
pub struct Ruggedness(MetricDef);

impl Metric for Ruggedness {
    fn def(&self) -> &MetricDef {
        &self.0
    }
    fn run(&self, t: &mut Tile<'_>, _m: &Resolved, o: &mut Grid<f32>) -> Result<()> {
        let (view, nan) = (t.view, f32::NAN);
        match self.0.kind {
            MetricKind::TriRiley => walk_3x3(view, o, EdgeMode::Nodata, nan, |w, _, _| {
                tri_riley(w) as f32
            }),
            MetricKind::TriWilson => walk_3x3(view, o, EdgeMode::Nodata, nan, |w, _, _| {
                tri_wilson(w) as f32
            }),
            _ => walk_3x3(view, o, EdgeMode::Nodata, nan, |w, ew, ns| {
                rugosity(w, ew, ns) as f32
            }),
        }
        Ok(())
    }
}

/// The spherical standard deviation of the normals in the square window.
pub struct Roughness(MetricDef);

impl Metric for Roughness {
    fn def(&self) -> &MetricDef {
        &self.0
    }
    fn halo(&self, m: &Resolved) -> usize {
        // Normals need one more ring.
        m.radius_cells + 1
    }
    fn needs(&self, m: &Resolved) -> Needs {
        Needs {
            normals: Some(m.radius_cells),
            ..Needs::default()
        }
    }
    fn scratch(&self, m: &Resolved, tile: usize) -> Option<(ScratchClass, u64)> {
        // fixed-point normals: six i32 limbs + an i32 count per cell
        Some((("normals", 0), region_cells(tile, m.radius_cells) * (7 * 4)))
    }
    fn run(&self, t: &mut Tile<'_>, m: &Resolved, o: &mut Grid<f32>) -> Result<()> {
        let (big, field) = t.normals()?;
        roughness(t.view, field, big, m.radius_cells, o);
        Ok(())
    }
}

/// `tri_riley`: sqrt of the sum of squared differences to the 8 neighbours.
///
/// Source: Riley, DeGloria & Elliot 1999, Intermountain J. Sci. 5.
pub static TRI_RILEY: Ruggedness = Ruggedness(metric_def!(
    TriRiley,
    "tri_riley",
    &[],
    "z",
    "sqrt of the sum of squared differences to the 8 neighbours",
    "Riley, DeGloria & Elliot 1999, Intermountain J. Sci. 5"
));

/// `tri`: mean absolute difference to the 8 neighbours (gdaldem TRI -alg Wilson).
///
/// Source: Wilson et al. 2007, Marine Geodesy 30.
pub static TRI_WILSON: Ruggedness = Ruggedness(metric_def!(
    TriWilson,
    "tri",
    &[],
    "z",
    "mean absolute difference to the 8 neighbours (gdaldem TRI -alg Wilson)",
    "Wilson et al. 2007, Marine Geodesy 30"
));

/// `roughness`: spherical standard deviation of unit normals in the square window.
///
/// Source: Lindsay, Newman & Francioni 2019, Geosciences 9(7) 322.
pub static ROUGHNESS: Roughness = Roughness(metric_def!(
    Roughness,
    "roughness",
    &[RADIUS],
    "degrees",
    "spherical standard deviation of unit normals in the square window",
    "Lindsay, Newman & Francioni 2019, Geosciences 9(7) 322"
));

/// `rugosity`: surface area / planimetric area of the cell (8 triangles).
///
/// Source: Jenness 2004, Wildlife Society Bulletin 32(3).
pub static RUGOSITY: Ruggedness = Ruggedness(metric_def!(
    Rugosity,
    "rugosity",
    &[],
    ">=1",
    "surface area / planimetric area of the cell (8 triangles)",
    "Jenness 2004, Wildlife Society Bulletin 32(3)"
));

/// Fixed-point unit normals (Horn gradient, [`NORMAL_FRAC`] fractional
/// bits, |component| ≤ 2⁶⁰) of the core plus `r` cells on each side,
/// row-major, each component split into 30-bit limbs `v = hi·2³⁰ + lo`
/// (`0 ≤ lo < 2³⁰`, `|hi| ≤ 2³⁰`: both fit i32), with a 0/1 validity count
/// (cells whose 3x3 window holds nodata or lies beyond the raster have zero
/// limbs and count 0).
pub struct NormalField {
    /// `hi[j]`, `lo[j]`: limbs of component j (x, y, z).
    hi: [Vec<i32>; 3],
    lo: [Vec<i32>; 3],
    count: Vec<i32>,
}

#[allow(clippy::needless_range_loop)] // parallel per-column arrays
pub fn normal_field(view: &TileView<f32>, r: usize) -> NormalField {
    const _: () = assert!(NORMAL_FRAC == 60);
    let h = view.halo;
    let gw = view.grid.width();
    let data = view.grid.data();
    let (w, hh) = (view.core.w + 2 * r, view.core.h + 2 * r);
    let zero = || vec![0i32; w * hh];
    let mut f = NormalField {
        hi: [zero(), zero(), zero()],
        lo: [zero(), zero(), zero()],
        count: zero(),
    };
    let fix = |v: f64| super::windowed::to_fixed(v, NORMAL_FRAC) as i64;
    let mut nb = [vec![0.0f64; w], vec![0.0f64; w], vec![0.0f64; w]];
    let mut ok = vec![false; w];
    for y in 0..hh {
        let vy = y + h - r;
        let (ew, ns) = view.georef.cell_size_m(view.core.y + vy as i64 - h as i64);
        // Rows above, at and below, from the column left of region column 0.
        let row = |yy: usize| &data[yy * gw + h - r - 1..yy * gw + h - r + w + 1];
        let (a, b, c) = (row(vy - 1), row(vy), row(vy + 1));
        // Two passes per row: the floating-point normals (branch-free, so
        // the divisions and square roots vectorise), then their fixed point.
        for x in 0..w {
            let win = window(a, b, c, x);
            ok[x] = !win.iter().sum::<f64>().is_nan();
            let (p, q) = horn_gradient(&win, ew, ns);
            let d = (1.0 + p * p + q * q).sqrt();
            nb[0][x] = -p / d;
            nb[1][x] = -q / d;
            nb[2][x] = 1.0 / d;
        }
        let i0 = y * w;
        for x in 0..w {
            if !ok[x] {
                continue;
            }
            for j in 0..3 {
                let v = fix(nb[j][x]);
                f.hi[j][i0 + x] = (v >> 30) as i32;
                f.lo[j][i0 + x] = (v & ((1 << 30) - 1)) as i32;
            }
            f.count[i0 + x] = 1;
        }
    }
    f
}

/// Spherical standard deviation of the unit normals in the window (Lindsay
/// et al. 2019): `s = √(−2 ln R̄)` in degrees, with `R̄ = |Σ n| / N` the mean
/// resultant length. Normals are those of the unsmoothed DEM (Lindsay et al.
/// smooth first; smooth the input for their multiscale variant). The sums
/// are exact integers (fixed-point normals) kept as running column sums
/// slid down the rows and running row sums along them: O(1) per cell, no
/// tables, and the same bits whatever the tiling. They are kept per 30-bit
/// limb ([`NormalField`]) in i64: with at most (2·2000+1)² < 2²⁴ cells per
/// window ([`MAX_RADIUS_CELLS`]), |Σhi| ≤ 2⁵⁴ and Σlo < 2⁵⁴, so nothing
/// overflows, the row loops are plain i64 adds (vectorised), and
/// `Σv = Σhi·2³⁰ + Σlo` is formed in i128 once per cell. `field` covers the
/// core plus `big ≥ r` cells on each side.
#[allow(clippy::needless_range_loop)] // parallel per-column arrays
fn roughness(view: &TileView<f32>, field: &NormalField, big: usize, r: usize, o: &mut Grid<f32>) {
    const _: () = assert!(MAX_RADIUS_CELLS <= 2000);
    let h = view.halo;
    let gw = view.grid.width();
    let data = view.grid.data();
    let (cw, ch) = (view.core.w, view.core.h);
    if cw == 0 || ch == 0 {
        return;
    }
    let w = cw + 2 * big;
    let off = big - r;
    let k = 2 * r + 1;
    let cols = cw + 2 * r;
    // Column c of the sums is region column off + c. Seven running column
    // sums: hi and lo limbs of x, y, z, and the count.
    let mut cs: [Vec<i64>; 7] = std::array::from_fn(|_| vec![0i64; cols]);
    let lane = |j: usize| -> &[i32] {
        match j {
            0..=2 => &field.hi[j],
            3..=5 => &field.lo[j - 3],
            _ => &field.count,
        }
    };
    for ry in off..off + k {
        let base = ry * w + off;
        for (j, c) in cs.iter_mut().enumerate() {
            let src = &lane(j)[base..base + cols];
            for (c, &v) in c.iter_mut().zip(src) {
                *c += v as i64;
            }
        }
    }
    let f = |s: i128| super::windowed::fixed_to_f64(s, NORMAL_FRAC);
    let (mut len2, mut cnt) = (vec![0.0f64; cw], vec![0.0f64; cw]);
    for y in 0..ch {
        if y > 0 {
            let (a, b) = ((off + y + k - 1) * w + off, (off + y - 1) * w + off);
            for (j, c) in cs.iter_mut().enumerate() {
                let l = lane(j);
                let (na, ob) = (&l[a..a + cols], &l[b..b + cols]);
                for ((c, &p), &m) in c.iter_mut().zip(na).zip(ob) {
                    *c += p as i64 - m as i64;
                }
            }
        }
        let mut s = [0i64; 7];
        for c in 0..k {
            for j in 0..7 {
                s[j] += cs[j][c];
            }
        }
        // Three passes per row: the exact sums as f64 (|Σn|², N), then R̄
        // (vectorised square roots and divisions), its logarithm (libm) and
        // the degrees; empty windows and nodata centres are NaN.
        let zrow = &data[(y + h) * gw + h..(y + h) * gw + h + cw];
        for x in 0..cw {
            if x > 0 {
                for j in 0..7 {
                    s[j] += cs[j][x + k - 1] - cs[j][x - 1];
                }
            }
            let sum = |j: usize| f(((s[j] as i128) << 30) + s[j + 3] as i128);
            let (sx, sy, sz) = (sum(0), sum(1), sum(2));
            len2[x] = sx * sx + sy * sy + sz * sz;
            cnt[x] = if zrow[x].is_nan() || s[6] == 0 {
                f64::NAN
            } else {
                s[6] as f64
            };
        }
        for x in 0..cw {
            // Not `min`: a NaN (no value) must stay NaN.
            let v = len2[x].sqrt() / cnt[x];
            len2[x] = if v > 1.0 { 1.0 } else { v };
        }
        for v in len2.iter_mut() {
            *v = v.ln();
        }
        let orow = &mut o.data_mut()[y * cw..(y + 1) * cw];
        for (o, &l) in orow.iter_mut().zip(&len2) {
            *o = if l.is_nan() {
                f32::NAN
            } else {
                (-2.0 * l).max(0.0).sqrt().to_degrees() as f32
            };
        }
    }
}
