//! The 3x3 neighbourhood walk, written once for every 3x3 metric.

use crate::raster::{Grid, TileView};

/// What a 3x3 metric does where a neighbour is nodata or beyond the edge.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum EdgeMode {
    /// The cell is nodata (gdaldem's default: the outermost ring is nodata).
    #[default]
    Nodata,
    /// Compute every valid cell (gdaldem `-compute_edges`): neighbours beyond
    /// the raster's edge are extrapolated linearly across the edge
    /// (`2·middle − opposite`, rows first, then columns), as gdaldem does;
    /// remaining missing neighbours (nodata inside the raster) take the centre
    /// cell's value, as gdaldem does. gdaldem's four corner cells follow a rule
    /// of their own and differ (documented; tested on every other edge cell).
    Compute,
}

impl EdgeMode {
    /// [`EdgeMode::Compute`] when `compute_edges` (gdaldem's
    /// `-compute_edges`), else [`EdgeMode::Nodata`].
    pub fn from_compute_edges(compute_edges: bool) -> Self {
        if compute_edges {
            EdgeMode::Compute
        } else {
            EdgeMode::Nodata
        }
    }
}

/// Call `f(window, ew_m, ns_m)` for every core cell of `view` whose centre is
/// valid, writing the result into `out` (core-sized). `window` is the 3x3
/// neighbourhood in row-major order `[a b c / d e f / g h i]` (row 0 = north
/// for north-up rasters); `ew_m`, `ns_m` are the true cell sizes in metres of
/// the cell's row. Cells whose centre is nodata, or (in `Nodata` mode) with a
/// nodata neighbour, get `nodata`. Needs a halo of at least 1.
pub fn walk_3x3<O: Copy>(
    view: &TileView<f32>,
    out: &mut Grid<O>,
    edge: EdgeMode,
    nodata: O,
    f: impl Fn(&[f64; 9], f64, f64) -> O,
) {
    assert!(view.halo >= 1, "3x3 metrics need a halo of at least 1");
    let h = view.halo;
    let gw = view.grid.width();
    let data = view.grid.data();
    for y in 0..view.core.h {
        let (ew, ns) = view.georef.cell_size_m(view.core.y + y as i64);
        let orow = out.row_mut(y);
        let r0 = (y + h - 1) * gw + h - 1;
        // Three rows of the window, each starting one cell left of the core.
        let up = &data[r0..r0 + orow.len() + 2];
        let mid = &data[r0 + gw..r0 + gw + orow.len() + 2];
        let dn = &data[r0 + 2 * gw..r0 + 2 * gw + orow.len() + 2];
        // Branch-free pass (vectorisable when `f` is): every cell is computed,
        // cells whose window holds a NaN or ±inf get `nodata` (±inf is
        // nodata, as in the hydrology steps; found by tests/hardening/numerics.rs).
        let mut any_bad = false;
        for (x, o) in orow.iter_mut().enumerate() {
            let win = window(up, mid, dn, x);
            // A NaN or ±inf anywhere makes the sum non-finite (f32 values
            // cannot overflow an f64 sum of nine).
            let bad = !win.iter().sum::<f64>().is_finite();
            let v = f(&win, ew, ns);
            *o = if bad { nodata } else { v };
            any_bad |= bad;
        }
        if any_bad && edge == EdgeMode::Compute {
            for (x, o) in orow.iter_mut().enumerate() {
                let win = window(up, mid, dn, x);
                if !win.iter().sum::<f64>().is_finite() {
                    *o = slow_cell(view, &win, x, y, edge, nodata, &f, ew, ns);
                }
            }
        }
    }
}

/// The 3x3 window at column `x` of three row slices that start one cell left.
#[inline(always)]
pub(crate) fn window(up: &[f32], mid: &[f32], dn: &[f32], x: usize) -> [f64; 9] {
    [
        up[x] as f64,
        up[x + 1] as f64,
        up[x + 2] as f64,
        mid[x] as f64,
        mid[x + 1] as f64,
        mid[x + 2] as f64,
        dn[x] as f64,
        dn[x + 1] as f64,
        dn[x + 2] as f64,
    ]
}

/// A cell whose window holds nodata: nodata, or (Compute mode) the metric
/// of the window with its missing cells filled.
#[allow(clippy::too_many_arguments)]
#[inline(never)]
fn slow_cell<O: Copy>(
    view: &TileView<f32>,
    win: &[f64; 9],
    x: usize,
    y: usize,
    edge: EdgeMode,
    nodata: O,
    f: &impl Fn(&[f64; 9], f64, f64) -> O,
    ew: f64,
    ns: f64,
) -> O {
    let centre = win[4];
    if !centre.is_finite() || edge == EdgeMode::Nodata {
        return nodata;
    }
    let mut filled = *win;
    for v in filled.iter_mut() {
        if !v.is_finite() {
            *v = centre;
        }
    }
    let h = view.halo;
    let c = (y + h) * view.grid.width() + h + x;
    let gx = view.core.x + x as i64;
    let gy = view.core.y + y as i64;
    fill_missing(
        &mut filled,
        view.grid.data(),
        c,
        view.grid.width(),
        gx,
        gy,
        view.raster_width,
        view.raster_height,
    );
    f(&filled, ew, ns)
}

/// Fill the missing neighbours of a 3x3 window in `Compute` mode: beyond the
/// raster edge by linear extrapolation (rows, then columns), otherwise with
/// the centre value (already there from the walk).
#[allow(clippy::too_many_arguments)]
#[inline(never)]
fn fill_missing(
    win: &mut [f64; 9],
    data: &[f32],
    c: usize,
    gw: usize,
    gx: i64,
    gy: i64,
    w: usize,
    h: usize,
) {
    let mut v = [f64::NAN; 9];
    let mut k = 0;
    for r in [c - gw, c, c + gw] {
        for d in &data[r - 1..=r + 1] {
            v[k] = *d as f64;
            k += 1;
        }
    }
    let outside = |dx: i64, dy: i64| {
        let (x, y) = (gx + dx, gy + dy);
        x < 0 || y < 0 || x >= w as i64 || y >= h as i64
    };
    // Rows beyond the top/bottom edge: 2 * middle row - opposite row.
    for col in 0..3 {
        for (row, opp) in [(0usize, 2usize), (2, 0)] {
            let i = row * 3 + col;
            if v[i].is_nan() && outside(col as i64 - 1, row as i64 - 1) {
                v[i] = 2.0 * v[3 + col] - v[opp * 3 + col];
            }
        }
    }
    // Columns beyond the left/right edge: 2 * middle column - opposite column.
    for row in 0..3 {
        for (col, opp) in [(0usize, 2usize), (2, 0)] {
            let i = row * 3 + col;
            if v[i].is_nan() && outside(col as i64 - 1, row as i64 - 1) {
                v[i] = 2.0 * v[row * 3 + 1] - v[row * 3 + opp];
            }
        }
    }
    for (o, x) in win.iter_mut().zip(v) {
        if !x.is_nan() {
            *o = x;
        }
    }
}
