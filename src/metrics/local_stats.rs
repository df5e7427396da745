//! Statistics of the elevations in a window around each cell: mean,
//! standard deviation, variance, TPI and NTPI (square or disk windows), and
//! the elevation percentile. Nodata cells and cells beyond the raster are
//! excluded from the windows; a nodata centre is nodata.
//!
//! Sources: summed-area tables, Crow 1984 (SIGGRAPH), built once per tile
//! for every windowed statistic of the pass ([`super::tile::Tile::sat`]);
//! TPI, Weiss 2001 (TPI poster, ESRI UC); NTPI, De Reu et al. 2013
//! (Geomorphology, DEV); the percentile, Argudo et al. survey sec. 3 (local
//! statistics).

use super::param::{RADIUS, SHAPE};
use super::registry::{metric_def, Metric, MetricDef, MetricKind, Needs, ScratchClass};
use super::spec::Resolved;
use super::tile::{region_cells, Tile};
use super::windowed::{to_fixed, Sat, WindowSums, FRAC_BITS, MAX_ABS_VALUE};
use super::MAX_RADIUS_CELLS;
use crate::error::{Error, Result};
use crate::raster::{Grid, TileView};

/// Mean, standard deviation, variance, TPI or NTPI of the window.
pub struct WindowStat(MetricDef);

impl WindowStat {
    /// Square-window mean and TPI: running sums ([`box_stat`]), no SAT.
    fn is_box(&self, m: &Resolved) -> bool {
        matches!(self.0.kind, MetricKind::Mean | MetricKind::Tpi) && !m.spec.disk
    }
}

impl Metric for WindowStat {
    fn def(&self) -> &MetricDef {
        &self.0
    }
    fn halo(&self, m: &Resolved) -> usize {
        m.radius_cells
    }
    fn needs(&self, m: &Resolved) -> Needs {
        if self.is_box(m) {
            return Needs::default();
        }
        let squares = !matches!(self.0.kind, MetricKind::Mean | MetricKind::Tpi);
        Needs {
            sat: Some((m.radius_cells, squares)),
            ..Needs::default()
        }
    }
    fn scratch(&self, m: &Resolved, tile: usize) -> Option<(ScratchClass, u64)> {
        // values (f64) + count (u32) + two i128 tables
        Some((
            ("sat", 0),
            region_cells(tile, m.radius_cells) * (8 + 4 + 16 + 16),
        ))
    }
    fn run(&self, t: &mut Tile<'_>, m: &Resolved, o: &mut Grid<f32>) -> Result<()> {
        if self.is_box(m) {
            return box_stat(t.view, m.radius_cells, self.0.kind, t.path, o);
        }
        let (big, sat) = t.sat()?;
        windowed_stat(
            t.view,
            sat,
            big,
            m.radius_cells,
            m.spec.disk,
            self.0.kind,
            o,
        );
        Ok(())
    }
}

/// The elevation percentile in the square window.
pub struct Percentile(MetricDef);

impl Metric for Percentile {
    fn def(&self) -> &MetricDef {
        &self.0
    }
    fn halo(&self, m: &Resolved) -> usize {
        m.radius_cells
    }
    fn run(&self, t: &mut Tile<'_>, m: &Resolved, o: &mut Grid<f32>) -> Result<()> {
        percentile(t.view, m.radius_cells, o);
        Ok(())
    }
}

/// `mean`: mean of valid cells in the square window of side 2r+1.
///
/// Source: summed-area tables, Crow 1984 (SIGGRAPH).
pub static MEAN: WindowStat = WindowStat(metric_def!(
    Mean,
    "mean",
    &[RADIUS, SHAPE],
    "z",
    "mean of valid cells in the square window of side 2r+1",
    "summed-area tables, Crow 1984 (SIGGRAPH)"
));

/// `stdev`: population standard deviation of valid cells in the square window.
///
/// Source: summed-area tables, Crow 1984.
pub static STDEV: WindowStat = WindowStat(metric_def!(
    Stdev,
    "stdev",
    &[RADIUS, SHAPE],
    "z",
    "population standard deviation of valid cells in the square window",
    "summed-area tables, Crow 1984"
));

/// `variance`: population variance of valid cells in the square window.
///
/// Source: summed-area tables, Crow 1984.
pub static VARIANCE: WindowStat = WindowStat(metric_def!(
    Variance,
    "variance",
    &[RADIUS, SHAPE],
    "z^2",
    "population variance of valid cells in the square window",
    "summed-area tables, Crow 1984"
));

/// `tpi`: z minus the mean of the other valid cells of the square window.
///
/// Source: Weiss 2001 (TPI poster, ESRI UC); square window, centre excluded.
pub static TPI: WindowStat = WindowStat(metric_def!(
    Tpi,
    "tpi",
    &[RADIUS, SHAPE],
    "z",
    "z minus the mean of the other valid cells of the square window",
    "Weiss 2001 (TPI poster, ESRI UC); square window, centre excluded"
));

/// `ntpi`: TPI / standard deviation of the window (0 where the window is flat).
///
/// Source: Weiss 2001; De Reu et al. 2013 (DEV).
pub static NTPI: WindowStat = WindowStat(metric_def!(
    Ntpi,
    "ntpi",
    &[RADIUS, SHAPE],
    "-",
    "TPI / standard deviation of the window (0 where the window is flat)",
    "Weiss 2001; De Reu et al. 2013 (DEV)"
));

/// `percentile`: share of the other valid cells of the square window lower than the cell (O(r^2) per cell).
///
/// Source: elevation percentile (Argudo et al. survey sec. 3, local statistics).
pub static PERCENTILE: Percentile = Percentile(metric_def!(
    Percentile,
    "percentile",
    &[RADIUS],
    "%",
    "share of the other valid cells of the square window lower than the cell (O(r^2) per cell)",
    "elevation percentile (Argudo et al. survey sec. 3, local statistics)"
));

/// Mean, stdev, variance, TPI or NTPI of every core cell from the SAT built
/// over core + `big` cells; window half-side `r ≤ big`.
///
/// With `disk`, the window is the disk of cells with `dx² + dy² ≤ r²` (in
/// cells), summed as one SAT row segment per row: O(r) per cell, exact.
#[allow(clippy::too_many_arguments)]
pub(crate) fn windowed_stat(
    view: &TileView<f32>,
    sat: &Sat,
    big: usize,
    r: usize,
    disk: bool,
    kind: MetricKind,
    o: &mut Grid<f32>,
) {
    let h = view.halo;
    let gw = view.grid.width();
    let data = view.grid.data();
    // Half-widths of the disk's rows (exact integer test dx² ≤ r² − dy²).
    let half: Vec<usize> = (0..=r)
        .map(|dy| {
            let mut hw = 0;
            while (hw + 1) * (hw + 1) + dy * dy <= r * r {
                hw += 1;
            }
            hw
        })
        .collect();
    for y in 0..view.core.h {
        let (y0, y1) = (y + big - r, y + big + r + 1);
        for x in 0..view.core.w {
            let z = data[(y + h) * gw + x + h];
            if z.is_nan() {
                o.set(x, y, f32::NAN);
                continue;
            }
            let ws = if disk {
                let cx = x + big;
                let mut acc = sat.window(cx - half[0], y + big, cx + half[0] + 1, y + big + 1);
                for (dy, &hw) in half.iter().enumerate().skip(1) {
                    for yy in [y + big - dy, y + big + dy] {
                        acc = acc.plus(&sat.window(cx - hw, yy, cx + hw + 1, yy + 1));
                    }
                }
                acc
            } else {
                sat.window(x + big - r, y0, x + big + r + 1, y1)
            };
            o.set(x, y, stat_value(ws, z, kind) as f32);
        }
    }
}

/// Mean, variance, stdev, TPI or NTPI of a valid centre `z` from its
/// window's exact sums.
#[inline]
fn stat_value(ws: WindowSums, z: f32, kind: MetricKind) -> f64 {
    match kind {
        MetricKind::Mean => ws.mean(),
        MetricKind::Variance => ws.variance(),
        MetricKind::Stdev => ws.variance().sqrt(),
        _ => {
            // The window without its centre.
            let mut others = ws;
            others.n -= 1;
            others.sum = others
                .sum
                .wrapping_sub(super::windowed::to_fixed(z as f64, ws.frac));
            let tpi = z as f64 - others.mean();
            if kind == MetricKind::Tpi {
                tpi
            } else {
                let sd = ws.variance().sqrt();
                if tpi.is_nan() {
                    f64::NAN
                } else if sd == 0.0 {
                    0.0
                } else {
                    tpi / sd
                }
            }
        }
    }
}

/// Mean or TPI over square windows of half-side `r` by exact running sums
/// (no summed-area table): each value's fixed-point `q` ([`FRAC_BITS`]) is
/// split into limbs `q = hi·2²⁴ + lo`, `0 ≤ lo < 2²⁴`, `|hi| ≤ 5·10⁷ < 2²⁶`
/// ([`MAX_ABS_VALUE`]); column sums of the `2r+1` rows are slid down the
/// rows and row sums along them. With at most (2·2000+1)² < 2²⁴ cells per
/// window ([`MAX_RADIUS_CELLS`]), |Σhi| < 2⁵⁰ and Σlo < 2⁴⁸: both limbs sum
/// in i64 without overflow, the row loops are plain i64 adds the compiler
/// vectorises, and `Σq = Σhi·2²⁴ + Σlo` is the same integer the SAT gave
/// (same bits, whatever the tiling). Nodata cells add zero limbs and no
/// count. `what` names the input in the range error.
fn box_stat(
    view: &TileView<f32>,
    r: usize,
    kind: MetricKind,
    what: &str,
    o: &mut Grid<f32>,
) -> Result<()> {
    const _: () = assert!(FRAC_BITS == 24 && MAX_ABS_VALUE <= 67_108_864.0);
    const _: () = assert!(MAX_RADIUS_CELLS <= 2000);
    let (cw, ch) = (view.core.w, view.core.h);
    if cw == 0 || ch == 0 {
        return Ok(());
    }
    let h = view.halo;
    let gw = view.grid.width();
    let data = view.grid.data();
    let (cols, rows, k) = (cw + 2 * r, ch + 2 * r, 2 * r + 1);
    let mut hi = vec![0i32; cols * rows];
    let mut lo = vec![0i32; cols * rows];
    let mut cnt = vec![0i32; cols * rows];
    for y in 0..rows {
        let start = (y + h - r) * gw + h - r;
        let row = &data[start..start + cols];
        for (x, &z) in row.iter().enumerate() {
            if z.is_nan() {
                continue;
            }
            let z = z as f64;
            if z.abs() > MAX_ABS_VALUE {
                return Err(Error::invalid(format!(
                    "{what}: value {z} is beyond ±{MAX_ABS_VALUE}, the range of the windowed statistics: rescale the input"
                )));
            }
            let q = to_fixed(z, FRAC_BITS) as i64;
            let i = y * cols + x;
            hi[i] = (q >> FRAC_BITS) as i32;
            lo[i] = (q & ((1 << FRAC_BITS) - 1)) as i32;
            cnt[i] = 1;
        }
    }
    let (mut chi, mut clo, mut cc) = (vec![0i64; cols], vec![0i64; cols], vec![0i32; cols]);
    for y in 0..k {
        let b = y * cols;
        for c in 0..cols {
            chi[c] += hi[b + c] as i64;
            clo[c] += lo[b + c] as i64;
            cc[c] += cnt[b + c];
        }
    }
    for y in 0..ch {
        if y > 0 {
            let (a, b) = ((y + k - 1) * cols, (y - 1) * cols);
            let (ha, hb) = (&hi[a..a + cols], &hi[b..b + cols]);
            let (la, lb) = (&lo[a..a + cols], &lo[b..b + cols]);
            let (na, nb) = (&cnt[a..a + cols], &cnt[b..b + cols]);
            for c in 0..cols {
                chi[c] += ha[c] as i64 - hb[c] as i64;
                clo[c] += la[c] as i64 - lb[c] as i64;
                cc[c] += na[c] - nb[c];
            }
        }
        let (mut sh, mut sl, mut n) = (0i64, 0i64, 0i32);
        for c in 0..k {
            sh += chi[c];
            sl += clo[c];
            n += cc[c];
        }
        let zrow = &data[(y + h) * gw + h..(y + h) * gw + h + cw];
        for (x, &z) in zrow.iter().enumerate() {
            if x > 0 {
                sh += chi[x + k - 1] - chi[x - 1];
                sl += clo[x + k - 1] - clo[x - 1];
                n += cc[x + k - 1] - cc[x - 1];
            }
            if z.is_nan() {
                o.set(x, y, f32::NAN);
                continue;
            }
            let ws = WindowSums {
                n: n as u32,
                sum: ((sh as i128) << FRAC_BITS) + sl as i128,
                sumsq: 0,
                frac: FRAC_BITS,
            };
            o.set(x, y, stat_value(ws, z, kind) as f32);
        }
    }
    Ok(())
}

/// Elevation percentile: 100 · (number of the other valid cells of the
/// square window strictly lower than the centre) / (number of the other
/// valid cells); nodata if there are none. Exact counting, O(r²) per cell.
fn percentile(view: &TileView<f32>, r: usize, o: &mut Grid<f32>) {
    let h = view.halo;
    let gw = view.grid.width();
    let data = view.grid.data();
    let side = 2 * r + 1;
    for y in 0..view.core.h {
        for x in 0..view.core.w {
            let c = (y + h) * gw + x + h;
            let z = data[c];
            if z.is_nan() {
                o.set(x, y, f32::NAN);
                continue;
            }
            let (mut lower, mut n) = (0u32, 0u32);
            for row in 0..side {
                let start = c + row * gw - r * gw - r;
                for &v in &data[start..start + side] {
                    // NaN compares false: neither counted nor lower.
                    n += u32::from(!v.is_nan());
                    lower += u32::from(v < z);
                }
            }
            let others = n - 1;
            o.set(
                x,
                y,
                if others == 0 {
                    f32::NAN
                } else {
                    (100.0 * lower as f64 / others as f64) as f32
                },
            );
        }
    }
}
