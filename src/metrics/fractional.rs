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

/// The disk around one valid core cell, as [`disk_map`] hands it to a kernel.
#[derive(Clone, Copy)]
pub struct Disk<'a> {
    data: &'a [f32],
    centre: usize,
    off: &'a [isize],
    per: &'a [f64],
}

impl<'a> Disk<'a> {
    /// Every cell of the disk: its value (NaN = nodata) and its per-offset
    /// number (the distance in metres, or what the row's closure made of it).
    #[inline(always)]
    pub fn cells(self) -> impl Iterator<Item = (f64, f64)> + 'a {
        let (data, c) = (self.data, self.centre as isize);
        self.off
            .iter()
            .zip(self.per)
            .map(move |(&k, &p)| (data[(c + k) as usize] as f64, p))
    }
}

/// The driver of the disk kernels (fractional Laplacian, ORS/jut/rut, Xu's
/// spherical forms): for every core row, the disk of [`disk_offsets`] with
/// its distances, which `per_row(row, distances)` may turn in place into
/// per-offset weights and from which it returns the row's constant; for
/// every core cell, nodata at a nodata centre, else
/// `cell(row constant, z, disk)`. Monomorphic: no per-cell dispatch.
#[inline(always)]
pub fn disk_map<R: Copy>(
    view: &TileView<f32>,
    rc: usize,
    radius_m: f64,
    o: &mut Grid<f32>,
    mut per_row: impl FnMut(i64, &mut [f64]) -> R,
    mut cell: impl FnMut(R, f64, Disk<'_>) -> f64,
) {
    let (h, gw) = (view.halo, view.grid.width());
    let data = view.grid.data();
    for y in 0..view.core.h {
        let row = view.core.y + y as i64;
        let (off, mut per) = disk_offsets(view, rc, radius_m, row);
        let r = per_row(row, &mut per);
        for x in 0..view.core.w {
            let centre = (y + h) * gw + x + h;
            let z = data[centre] as f64;
            if z.is_nan() {
                o.set(x, y, f32::NAN);
                continue;
            }
            let disk = Disk {
                data,
                centre,
                off: &off,
                per: &per,
            };
            o.set(x, y, cell(r, z, disk) as f32);
        }
    }
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
    let weigh = |row: i64, dist: &mut [f64]| {
        let (ew, ns) = view.georef.cell_size_m(row);
        for d in dist.iter_mut() {
            *d = c * ew * ns / d.powf(2.0 + 2.0 * s);
        }
    };
    disk_map(view, rc, radius_m, o, weigh, |(), z, disk| {
        let mut acc = 0.0;
        for (v, wgt) in disk.cells() {
            if !v.is_nan() {
                acc += (z - v) * wgt;
            }
        }
        acc
    });
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
