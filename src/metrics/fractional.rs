//! The fractional Laplacian `(−Δ)^s` of the elevation in its integral
//! (singular-integral) form with a radius cutoff (Di Nezza, Palatucci &
//! Valdinoci 2012, "Hitchhiker's guide to the fractional Sobolev spaces",
//! Bull. Sci. Math. 136(5), eq. (3.1)-(3.2); used as a multi-scale terrain
//! descriptor in the survey of Argudo et al., sec. 3.2):
//!
//! `(−Δ)^s z(x) ≈ C(s) Σ_{0<|y|≤R} (z(x) − z(x+y)) / |y|^{2+2s} · ΔA`,
//!
//! summed over the cells `y` of the disk of radius `R` metres (distances in
//! true metres, `ΔA` the cell area), with the constant for dimension n = 2
//! `C(s) = s 4^s Γ(1+s) / (π Γ(1−s))` (their `4^s Γ(n/2+s) / (π^{n/2} |Γ(−s)|)`
//! with `|Γ(−s)| = Γ(1−s)/s`). Nodata neighbours are left out of the sum.
//!
//! Properties (tested): a plane gives 0 (the disk is symmetric); for the
//! paraboloid `a(x²+y²)` the value is the same at every cell,
//! `−a C(s) ΔA Σ |y|^{−2s}`. Limit s → 1: `C(s) ≈ 4(1−s)/π → 0` while the
//! lattice sum stays bounded, so the truncated *discrete* sum tends to 0, not
//! to `−Δz`; the continuous integral recovers `−Δz` only through the
//! singular part near `y = 0` that a grid does not sample. Use s well inside
//! (0, 1); s → 0 weights all distances alike (`C → 0` too).

use super::param::{EXPONENT, RADIUS_CUTOFF};
use super::registry::{metric_def, Metric, MetricDef};
use super::spec::Resolved;
use super::tile::Tile;
use crate::error::Result;
use crate::raster::{Grid, TileView};

/// Γ(x) for x > 0 by Lanczos' approximation (Lanczos 1964, "A precision
/// approximation of the gamma function", SIAM J. Numer. Anal. B 1; the
/// published g = 7, n = 9 coefficients), relative error ~1e-15.
pub fn gamma(x: f64) -> f64 {
    const G: f64 = 7.0;
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // Reflection: Γ(x) Γ(1−x) = π / sin(πx).
        return std::f64::consts::PI / ((std::f64::consts::PI * x).sin() * gamma(1.0 - x));
    }
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + G + 0.5;
    for (i, c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    (2.0 * std::f64::consts::PI).sqrt() * t.powf(x + 0.5) * (-t).exp() * a
}

/// The normalising constant `C(2, s)` of the fractional Laplacian in the plane.
pub fn frac_constant(s: f64) -> f64 {
    s * 4f64.powf(s) * gamma(1.0 + s) / (std::f64::consts::PI * gamma(1.0 - s))
}

/// Offsets (flat, in the view's grid) and distances in metres of the cells
/// of the disk `0 < d ≤ radius_m` around a cell of global row `row`, within
/// `rc` cells on each axis; distances use that row's true cell sizes.
pub fn disk_offsets(
    view: &TileView<f32>,
    rc: usize,
    radius_m: f64,
    row: i64,
) -> (Vec<isize>, Vec<f64>) {
    let (ew, ns) = view.georef.cell_size_m(row);
    let gw = view.grid.width() as isize;
    let rc = rc as isize;
    let (mut off, mut dist) = (Vec::new(), Vec::new());
    for dy in -rc..=rc {
        for dx in -rc..=rc {
            if dx == 0 && dy == 0 {
                continue;
            }
            let d = ((dx as f64 * ew).powi(2) + (dy as f64 * ns).powi(2)).sqrt();
            // A small relative slack so that a radius given in cells keeps
            // the cells exactly at that distance.
            if d <= radius_m * (1.0 + 1e-12) {
                off.push(dy * gw + dx);
                dist.push(d);
            }
        }
    }
    (off, dist)
}

/// Fractional Laplacian of every core cell (cutoff `radius_m`, at most `rc`
/// cells per axis, `rc ≤` the view's halo), exponent `s` in (0, 1).
pub fn fractional_laplacian(
    view: &TileView<f32>,
    rc: usize,
    radius_m: f64,
    s: f64,
    o: &mut Grid<f32>,
) {
    let c = frac_constant(s);
    let (h, gw) = (view.halo, view.grid.width());
    let data = view.grid.data();
    let mut weights = Vec::new();
    for y in 0..view.core.h {
        let row = view.core.y + y as i64;
        let (off, dist) = disk_offsets(view, rc, radius_m, row);
        let (ew, ns) = view.georef.cell_size_m(row);
        weights.clear();
        weights.extend(dist.iter().map(|d| c * ew * ns / d.powf(2.0 + 2.0 * s)));
        for x in 0..view.core.w {
            let ci = (y + h) * gw + x + h;
            let z = data[ci] as f64;
            if z.is_nan() {
                o.set(x, y, f32::NAN);
                continue;
            }
            let mut acc = 0.0;
            for (&k, &wgt) in off.iter().zip(&weights) {
                let v = data[(ci as isize + k) as usize] as f64;
                if !v.is_nan() {
                    acc += (z - v) * wgt;
                }
            }
            o.set(x, y, acc as f32);
        }
    }
}

/// The fractional Laplacian with a disk cutoff.
pub struct FractionalLaplacian(MetricDef);

impl Metric for FractionalLaplacian {
    fn def(&self) -> &MetricDef {
        &self.0
    }
    fn halo(&self, m: &Resolved) -> usize {
        m.radius_cells
    }
    fn run(&self, t: &mut Tile<'_>, m: &Resolved, o: &mut Grid<f32>) -> Result<()> {
        fractional_laplacian(
            t.view,
            m.radius_cells,
            m.radius_m,
            m.spec.exponent.unwrap_or(0.5),
            o,
        );
        Ok(())
    }
}

/// `fractional_laplacian`: (-Laplacian)^s z = C(s) sum over 0<|y|<=R of (z(x)-z(x+y))/|y|^(2+2s) * cell area (disk cutoff).
///
/// Source: integral form, Di Nezza, Palatucci & Valdinoci 2012, Bull. Sci. Math. 136(5), eq. 3.1; C(s) of their eq. 3.2 for n = 2.
pub static FRACTIONAL_LAPLACIAN: FractionalLaplacian = FractionalLaplacian(metric_def!(
        FractionalLaplacian,
        "fractional_laplacian",
        &[RADIUS_CUTOFF, EXPONENT],
        "z/m^2s",
        "(-Laplacian)^s z = C(s) sum over 0<|y|<=R of (z(x)-z(x+y))/|y|^(2+2s) * cell area (disk cutoff)",
        "integral form, Di Nezza, Palatucci & Valdinoci 2012, Bull. Sci. Math. 136(5), eq. 3.1; C(s) of their eq. 3.2 for n = 2"
    ));
