//! The 3x3 neighbourhood walk, written once for every 3x3 metric.

use crate::raster::{Grid, TileView};

/// What a 3x3 metric does where a neighbour is nodata or beyond the edge.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum EdgeMode {
    /// The cell is nodata (gdaldem's default: the outermost ring is nodata).
    #[default]
    Nodata,
    /// Missing neighbours take the centre cell's value (gdaldem `-compute_edges`).
    Compute,
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
    let mut win = [0f64; 9];
    for y in 0..view.core.h {
        let (ew, ns) = view.georef.cell_size_m(view.core.y + y as i64);
        let orow = out.row_mut(y);
        let base = (y + h) * gw + h;
        for (x, o) in orow.iter_mut().enumerate() {
            let c = base + x;
            let centre = data[c];
            if centre.is_nan() {
                *o = nodata;
                continue;
            }
            let mut missing = false;
            let mut k = 0;
            for r in [c - gw, c, c + gw] {
                for v in &data[r - 1..=r + 1] {
                    if v.is_nan() {
                        missing = true;
                        win[k] = centre as f64;
                    } else {
                        win[k] = *v as f64;
                    }
                    k += 1;
                }
            }
            *o = if missing && edge == EdgeMode::Nodata {
                nodata
            } else {
                f(&win, ew, ns)
            };
        }
    }
}
