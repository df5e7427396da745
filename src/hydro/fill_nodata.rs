//! Void filling (`orogen fill-nodata`): every nodata cell that sees a valid
//! cell within the maximum distance along one of 16 fixed rays gets the
//! inverse-distance-weighted mean of the first valid cell met on each ray;
//! valid cells are copied unchanged. A local step whose halo is the maximum
//! distance, so a tiled run equals an untiled one bit for bit.
//!
//! # Method
//!
//! The interpolation of GDAL's `GDALFillNodata` as its documentation defines
//! it (GDAL documentation, `gdal_fillnodata` (https://gdal.org/gdal_fillnodata.html)
//! and the `GDALFillNodata()` entry of the algorithms API, `gdal_alg.h`: each
//! nodata pixel takes the inverse-distance-weighted value of the valid pixels
//! found by a conic search in four directions, out to the maximum distance
//! `-md` in pixels, default 100; then zero or more 3x3 smoothing passes over
//! the filled pixels, default none), with the four cones replaced by a fixed
//! set of rays so that the result is a function of the cells within the
//! maximum distance only, and written here from that definition, not from
//! GDAL's code:
//!
//! - From a void cell `c`, walk each of the 16 rays with integer steps
//!   `s` = E, ENE (2,1), NE, NNE (1,2), N, … (the 8 compass directions and
//!   the 8 knight moves, in [`RAYS`]' order), visiting `c + k s` for
//!   `k = 1, 2, …` while the distance `d_k = k |s|` is at most the maximum
//!   distance `D` and the cell lies inside the raster; the first valid cell
//!   met is that ray's sample `(z_i, d_i)`. Knight-move rays skip the cells
//!   between their lattice points.
//! - The fill value is `Σ z_i / d_i² / Σ 1 / d_i²` over the rays that met a
//!   valid cell (Shepard's inverse-distance weighting with power 2:
//!   Shepard, D. (1968), "A two-dimensional interpolation function for
//!   irregularly-spaced data", Proc. 23rd ACM National Conference, 517–524),
//!   computed in f64 in [`RAYS`]' order.
//! - A void cell whose 16 rays meet no valid cell within `D` stays nodata.
//!   So every void cell farther than `D` from all valid cells stays nodata;
//!   a few nearer ones whose nearby valid cells all lie between the rays
//!   stay nodata too.
//! - No smoothing passes (GDAL's `-si`, default 0) are done.
//!
//! Distances are in cells (`|s|` = 1, √2 or √5) or, for a maximum distance in
//! metres, in metres with the metric cell size of the void cell's own row
//! (`GeoRef::cell_size_m(row)`: on geographic grids a cell is narrower
//! towards the poles, so a ray reaches more columns there); the halo is then
//! `D` over the smallest cell side of any row.
//!
//! Only the raster's valid cells are used as samples (never filled ones), so
//! the result does not depend on the order in which cells are visited. The
//! value is a convex combination of valid cells: it lies within their range,
//! and a plane is reproduced only where the samples are symmetric (see the
//! tests' stated bound). Integer outputs round the value to the nearest
//! integer (the sink's conversion).

use crate::error::{Error, Result};
use crate::exec::output::{NodataRule, OutputSpec};
use crate::exec::LocalStep;
use crate::raster::{DType, GeoRef, Grid, TileView};
use serde::{Deserialize, Serialize};
use serde_json::json;

/// The 16 ray steps `(dx, dy)` (x east, y south), counter-clockwise from
/// east as seen on a map: the compass directions and the knight moves.
pub const RAYS: [(i64, i64); 16] = [
    (1, 0),
    (2, -1),
    (1, -1),
    (1, -2),
    (0, -1),
    (-1, -2),
    (-1, -1),
    (-2, -1),
    (-1, 0),
    (-2, 1),
    (-1, 1),
    (-1, 2),
    (0, 1),
    (1, 2),
    (1, 1),
    (2, 1),
];

/// Largest halo (cells) fill-nodata accepts before even sizing the tiles
/// against the memory budget: beyond it the view's side would not fit an
/// address computation, let alone memory.
pub const MAX_HALO: f64 = 1e7;

/// The maximum search distance: cells, or metres (per-row cell sizes).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Reach {
    /// Distance in cells (GDAL's `-md`).
    Cells(f64),
    /// Distance in metres, with each row's metric cell size.
    Metres(f64),
}

impl std::fmt::Display for Reach {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Reach::Cells(c) => write!(f, "{c} cells"),
            Reach::Metres(m) if *m >= 1000.0 => write!(f, "{} km", m / 1000.0),
            Reach::Metres(m) => write!(f, "{m} m"),
        }
    }
}

/// The fill-nodata local step; see the module documentation.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct FillNodata {
    /// Maximum search distance.
    pub max_distance: Reach,
    /// Output cell type (the input's).
    pub dtype: DType,
    /// Output nodata (the input's; `None` for a float input whose voids
    /// are NaN cells without a declared value).
    pub nodata: Option<f64>,
    /// Halo in cells: the farthest row or column offset a ray may reach.
    pub halo: usize,
}

impl FillNodata {
    /// The step for a raster of `height` rows with `georef`, writing
    /// `dtype` with `nodata`. Errors when the distance reaches more than
    /// [`MAX_HALO`] cells.
    pub fn new(
        max_distance: Reach,
        georef: &GeoRef,
        height: usize,
        dtype: DType,
        nodata: Option<f64>,
    ) -> Result<FillNodata> {
        let halo = halo_cells(max_distance, georef, height);
        if !(halo.is_finite() && halo <= MAX_HALO) {
            return Err(Error::over_budget(format!(
                "fill-nodata: --max-distance {max_distance} reaches {halo:.3e} cells around every \
                 tile, far more than memory holds; give a smaller --max-distance (in cells, \
                 such as 100, or with a unit, such as 3km)"
            )));
        }
        Ok(FillNodata {
            max_distance,
            dtype,
            nodata,
            halo: halo as usize,
        })
    }
}

/// The farthest row or column offset (cells, not yet rounded to an
/// integer but floored) a ray may reach for `reach` on a raster of `height`
/// rows: `D` in cells, or `D` over the smallest metric cell side of any row.
pub fn halo_cells(reach: Reach, georef: &GeoRef, height: usize) -> f64 {
    match reach {
        Reach::Cells(c) => c.floor(),
        Reach::Metres(m) => {
            let mut side = f64::INFINITY;
            for row in 0..height.max(1) {
                let (ew, ns) = georef.cell_size_m(row as i64);
                side = side.min(ew).min(ns);
            }
            if side > 0.0 {
                (m / side).floor()
            } else {
                f64::INFINITY
            }
        }
    }
}

/// The length of each ray's step for the void cells of one row: in cells,
/// or in metres with that row's cell size `(ew, ns)`.
fn step_lengths(reach: Reach, cell: (f64, f64)) -> [f64; 16] {
    let (ew, ns) = match reach {
        Reach::Cells(_) => (1.0, 1.0),
        Reach::Metres(_) => cell,
    };
    RAYS.map(|(dx, dy)| ((dx as f64 * ew).powi(2) + (dy as f64 * ns).powi(2)).sqrt())
}

impl LocalStep for FillNodata {
    type In = f64;
    type Out = f64;
    fn name(&self) -> String {
        "fill-nodata".into()
    }
    fn params(&self) -> serde_json::Value {
        json!({ "max_distance": self.max_distance, "method": "idw2-16-rays" })
    }
    fn halo(&self) -> usize {
        self.halo
    }
    fn outputs(&self) -> Vec<OutputSpec> {
        let spec = OutputSpec::continuous(self.dtype, 0.0);
        vec![match self.nodata {
            Some(v) => spec.with_nodata(NodataRule::Value(v)),
            None => spec.with_nodata(NodataRule::None),
        }]
    }
    fn run(&self, inputs: &[TileView<f64>], out: &mut [Grid<f64>]) -> Result<()> {
        let v = &inputs[0];
        let out = &mut out[0];
        let max = match self.max_distance {
            Reach::Cells(c) | Reach::Metres(c) => c,
        };
        let (rw, rh) = (v.raster_width as i64, v.raster_height as i64);
        let h = v.halo as i64;
        for y in 0..v.core.h {
            let gy = v.core.y + y as i64;
            let lengths = step_lengths(self.max_distance, v.georef.cell_size_m(gy));
            for x in 0..v.core.w {
                let z = v.at(x as i64, y as i64);
                if z.is_finite() {
                    out.set(x, y, z);
                    continue;
                }
                let gx = v.core.x + x as i64;
                let (mut num, mut den) = (0.0f64, 0.0f64);
                for (&(dx, dy), &len) in RAYS.iter().zip(&lengths) {
                    let mut k = 1i64;
                    loop {
                        let d = k as f64 * len;
                        let (cx, cy) = (gx + k * dx, gy + k * dy);
                        // The halo test only guards against rounding in
                        // `d`: `k |dx|, k |dy| <= halo` whenever `d <= max`.
                        let beyond = k * dx.abs() > h || k * dy.abs() > h;
                        if d > max || beyond || cx < 0 || cy < 0 || cx >= rw || cy >= rh {
                            break;
                        }
                        let s = v.at(cx - v.core.x, cy - v.core.y);
                        if s.is_finite() {
                            let w = 1.0 / (d * d);
                            num += w * s;
                            den += w;
                            break;
                        }
                        k += 1;
                    }
                }
                out.set(x, y, if den > 0.0 { num / den } else { f64::NAN });
            }
        }
        Ok(())
    }
}
