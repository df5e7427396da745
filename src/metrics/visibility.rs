//! Visibility: the viewshed of a point (Franklin & Ray 1994's R3 line of
//! sight), cumulative and fuzzy viewsheds of point sets (Fisher 1994), and
//! the visibility index as a tiled registry metric; plus the named numeric
//! parameters ([`parse_value`]) of the visibility and solar metrics.
//!
//! ## Line of sight (R3)
//! Franklin & Ray 1994, "Higher isn't necessarily better: visibility
//! algorithms and experiments", Proc. 6th Int. Symp. on Spatial Data Handling,
//! 751-770, algorithm R3: the terrain between observer and target is known
//! where the segment joining their cell centres crosses the grid lines through
//! cell centres (columns and rows); there it is the linear interpolation of
//! the two cells the crossing lies between. The target is visible unless the
//! terrain at some crossing strictly between the two is strictly above the
//! sight line from the observer's eye (`z + observer height`) to the target
//! (`z + target height`). Nodata cells are transparent (a crossing next to one
//! is skipped). O(r) per target, O(r³) for a viewshed of radius r cells;
//! targets are independent and run in parallel (deterministic).
//!
//! Earth curvature and refraction (optional): every elevation at horizontal
//! distance `D` from the observer is lowered by `(1 − k)·D²/(2R)`, R = 6 371
//! km, refraction coefficient k (0.13 by default; the usual correction, e.g.
//! GRASS r.viewshed and Wang, Robinson & White 2000).
//!
//! ## Fuzzy viewshed
//! Fisher 1994, "Probable and fuzzy models of the viewshed operation", in
//! Worboys (ed.) Innovations in GIS 1, 161-175: a visible target at distance
//! D gets the membership `μ(D) = 1` for `D ≤ b1`, `1/(1 + ((D − b1)/b2)²)`
//! beyond; invisible targets get 0.
//!
//! ## Visibility index (registry metric)
//! The share of targets within the cutoff that the observer sees (Franklin &
//! Ray 1994 estimate it by sampling targets): here the targets are the cells
//! on the 8 or 16 exact lattice rays of the horizon metrics, and a target
//! at step s is visible if its elevation angle from the eye is at least the
//! largest elevation angle of the terrain at steps 1..s−1 on the same ray.
//! Along the axes and diagonals the rays pass through cell centres, so this is
//! exactly R3 for those targets. O(r) per cell and direction; halo = cutoff.

#![allow(clippy::needless_range_loop)] // index loops over parallel per-cell arrays

use super::horizon::{plan as ray_plan, ray_cells, step_azimuth, DIRS};
use super::param::{DIRECTIONS, RADIUS_HORIZON};
use super::registry::{metric_def, Metric, MetricDef, MetricKind};
use super::registry::{ParamDef, ParamKind};
use super::spec::Resolved;
use super::tile::Tile;
use crate::error::{Error, Result};
use crate::raster::RasterInfo;
use crate::raster::{Grid, TileView};
use rayon::prelude::*;

/// Mean Earth radius (m).
pub const EARTH_RADIUS_M: f64 = 6_371_000.0;

/// `horizon`'s direction parameter.
pub const DIR: ParamDef = ParamDef {
    name: "dir",
    kind: ParamKind::Value,
    default: "0",
    range: "azimuth (degrees clockwise from north) of a lattice direction: 0, 45, .., 315, or 26.57, 63.43, 116.57, .. (knight moves)",
};
/// Observer height above the ground (m).
pub const HEIGHT: ParamDef = ParamDef {
    name: "height",
    kind: ParamKind::Value,
    default: "1.7",
    range: "observer height above the cell, metres, 0..=10000",
};
/// Target height above the ground (m).
pub const TARGET: ParamDef = ParamDef {
    name: "target",
    kind: ParamKind::Value,
    default: "0",
    range: "target height above the cell, metres, 0..=10000",
};

/// Largest radius (cells) of `visibility_index_exact` (O(r³) per cell).
pub const MAX_EXACT_RADIUS: usize = 100;
/// `visibility_index_exact`'s radius.
pub const RADIUS_EXACT: ParamDef = ParamDef {
    name: "radius",
    kind: ParamKind::Radius,
    default: "5c",
    range: "1c..=100c, or a length in m/km (> 0); the target disk",
};

/// Azimuths (square cells) of the 16 lattice directions, in `DIRS` order.
fn lattice_azimuths() -> [f64; 16] {
    let mut a = [0.0; 16];
    for (a, &(dx, dy)) in a.iter_mut().zip(DIRS.iter()) {
        *a = step_azimuth(dx, dy, 1.0, 1.0);
    }
    a
}

/// The lattice direction (index into `DIRS`) of azimuth `deg`, if `deg` is
/// within 0.01° of one (square cells).
pub fn lattice_dir(deg: f64) -> Option<usize> {
    let d = deg.rem_euclid(360.0);
    lattice_azimuths().iter().position(|&a| {
        let e = (a - d).abs();
        e.min(360.0 - e) < 0.01
    })
}

/// Parse the value of a [`ParamKind::Value`] parameter named `name`
/// (`auto` = unset where allowed), checking its range.
pub fn parse_value(name: &str, value: &str) -> std::result::Result<Option<f64>, String> {
    let value = value.trim();
    if value == "auto" && matches!(name, "lat" | "hour") {
        return Ok(None);
    }
    if value == "day" && name == "hour" {
        return Ok(None);
    }
    // Xu's measures are planar unless a planet radius is given.
    if matches!(value, "none" | "flat") && name == "planet" {
        return Ok(None);
    }
    let v: f64 = value
        .parse()
        .map_err(|_| format!("'{value}' is not a number"))?;
    let (lo, hi) = match name {
        "dir" => {
            if !v.is_finite() || lattice_dir(v).is_none() {
                return Err(format!(
                    "'{value}' is not the azimuth of a lattice direction"
                ));
            }
            return Ok(Some(v));
        }
        "height" | "target" => (0.0, 10_000.0),
        "day" => (1.0, 366.0),
        "hour" => (0.0, 24.0),
        "step" => (1.0, 240.0),
        "days" => (1.0, 366.0),
        "tau" => (0.05, 1.0),
        "lat" => (-90.0, 90.0),
        "alpha_max" => (0.0, 360.0),
        "planet" => (1.0, 1.0e6),
        _ => (f64::NEG_INFINITY, f64::INFINITY),
    };
    if !(v.is_finite() && v >= lo && v <= hi) {
        return Err(format!("'{value}' is outside {lo}..={hi}"));
    }
    Ok(Some(v))
}

/// Options of a point viewshed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViewshedOptions {
    /// Eye height above the observer's cell (m).
    pub observer_height: f64,
    /// Target height above each target cell (m).
    pub target_height: f64,
    /// Largest horizontal distance from the observer (m).
    pub radius_m: f64,
    /// Refraction coefficient if earth curvature is applied.
    pub curvature: Option<f64>,
}

impl Default for ViewshedOptions {
    fn default() -> Self {
        ViewshedOptions {
            observer_height: 1.7,
            target_height: 0.0,
            radius_m: 10_000.0,
            curvature: None,
        }
    }
}

/// Check viewshed options (finite, non-negative, radius > 0).
pub fn check_options(o: &ViewshedOptions) -> Result<()> {
    if !(o.radius_m.is_finite() && o.radius_m > 0.0) {
        return Err(Error::invalid(format!(
            "viewshed radius {} m: give a positive distance (e.g. 10km)",
            o.radius_m
        )));
    }
    for (what, v) in [
        ("observer height", o.observer_height),
        ("target height", o.target_height),
    ] {
        if !(v.is_finite() && (0.0..=10_000.0).contains(&v)) {
            return Err(Error::invalid(format!(
                "{what} {v} m: give a height between 0 and 10000 m"
            )));
        }
    }
    if let Some(k) = o.curvature {
        if !(k.is_finite() && (0.0..1.0).contains(&k)) {
            return Err(Error::invalid(format!(
                "refraction coefficient {k}: use 0 <= k < 1 (0.13 is usual)"
            )));
        }
    }
    Ok(())
}

/// Fisher's fuzzy membership `μ(D)` (see the module doc).
pub fn fuzzy_membership(d: f64, b1: f64, b2: f64) -> f64 {
    if d <= b1 {
        1.0
    } else {
        let t = (d - b1) / b2;
        1.0 / (1.0 + t * t)
    }
}

/// R3 viewshed of the observer at cell `(ox, oy)` of `dem` (NaN = nodata),
/// cells of `ew` x `ns` metres: per row (in parallel, collected in order),
/// `f(visible, distance_m)` for every valid target cell within the radius
/// (the observer's own cell is visible) and `none` elsewhere.
fn r3_rows<T: Send + Sync + Copy>(
    dem: &Grid<f32>,
    (ew, ns): (f64, f64),
    (ox, oy): (usize, usize),
    o: &ViewshedOptions,
    none: T,
    f: impl Fn(bool, f64) -> T + Sync,
) -> Vec<Vec<T>> {
    let (w, h) = (dem.width(), dem.height());
    let data = dem.data();
    let z0 = data[oy * w + ox] as f64;
    let curv = o.curvature.map(|k| (1.0 - k) / (2.0 * EARTH_RADIUS_M));
    let drop = |dx: f64, dy: f64| match curv {
        Some(c) => c * ((dx * ew).powi(2) + (dy * ns).powi(2)),
        None => 0.0,
    };
    let eye = z0 + o.observer_height;
    let r2 = o.radius_m * o.radius_m * (1.0 + 1e-12);
    (0..h)
        .into_par_iter()
        .map(|ty| {
            let mut row = vec![none; w];
            if z0.is_nan() {
                return row;
            }
            for (tx, cell) in row.iter_mut().enumerate() {
                let (dx, dy) = (tx as f64 - ox as f64, ty as f64 - oy as f64);
                let d2 = (dx * ew).powi(2) + (dy * ns).powi(2);
                let zt = data[ty * w + tx] as f64;
                if d2 > r2 || zt.is_nan() {
                    continue;
                }
                let target = zt + o.target_height - drop(dx, dy);
                let visible = r3_visible(data, w, (ox, oy), (tx, ty), eye, target, &drop);
                *cell = f(visible, d2.sqrt());
            }
            row
        })
        .collect()
}

/// R3 line of sight on a row-major grid of width `w`: is the target at cell
/// `t` with (curvature-corrected) elevation `target` visible from the eye at
/// elevation `eye` above cell `o`? `drop(dx, dy)` lowers the terrain at an
/// offset of (dx, dy) cells from the observer (0 without curvature).
#[inline]
fn r3_visible(
    data: &[f32],
    w: usize,
    (ox, oy): (usize, usize),
    (tx, ty): (usize, usize),
    eye: f64,
    target: f64,
    drop: &impl Fn(f64, f64) -> f64,
) -> bool {
    let (dx, dy) = (tx as f64 - ox as f64, ty as f64 - oy as f64);
    let rise = target - eye;
    // Terrain at fraction t along the segment vs the sight line.
    let blocks =
        |t: f64, z: f64| -> bool { !z.is_nan() && z - drop(t * dx, t * dy) > eye + t * rise };
    // Crossings of columns strictly between.
    for c in ox.min(tx) + 1..ox.max(tx) {
        let t = (c as f64 - ox as f64) / dx;
        if blocks(t, interp(data, w, c, oy as f64 + t * dy, true)) {
            return false;
        }
    }
    // Crossings of rows strictly between.
    for r in oy.min(ty) + 1..oy.max(ty) {
        let t = (r as f64 - oy as f64) / dy;
        if blocks(t, interp(data, w, r, ox as f64 + t * dx, false)) {
            return false;
        }
    }
    true
}

/// Elevation at the crossing of column `line` at fractional row `at`
/// (`column`), or of row `line` at fractional column `at`: linear
/// interpolation of the two cells around it (one if `at` is integral).
#[inline]
fn interp(data: &[f32], w: usize, line: usize, at: f64, column: bool) -> f64 {
    let a = at.floor();
    let f = at - a;
    let a = a as usize;
    let cell = |k: usize| -> f64 {
        if column {
            data[k * w + line] as f64
        } else {
            data[line * w + k] as f64
        }
    };
    let za = cell(a);
    if f == 0.0 {
        za
    } else {
        za + f * (cell(a + 1) - za)
    }
}

fn check_observer(dem: &Grid<f32>, (ox, oy): (usize, usize)) -> Result<()> {
    if ox >= dem.width() || oy >= dem.height() {
        return Err(Error::invalid(format!(
            "observer cell ({ox}, {oy}) is outside the {}x{} grid: give a point inside the DEM",
            dem.width(),
            dem.height()
        )));
    }
    if dem.get(ox, oy).is_nan() {
        return Err(Error::invalid(format!(
            "observer cell ({ox}, {oy}) is nodata: move the observer onto valid terrain"
        )));
    }
    Ok(())
}

/// Binary R3 viewshed: 1 visible, 0 not, 255 beyond the radius or nodata.
pub fn viewshed(
    dem: &Grid<f32>,
    cell_m: (f64, f64),
    observer: (usize, usize),
    o: &ViewshedOptions,
) -> Result<Grid<u8>> {
    check_options(o)?;
    check_observer(dem, observer)?;
    let rows = r3_rows(dem, cell_m, observer, o, 255u8, |v, _| u8::from(v));
    Grid::from_vec(dem.width(), dem.height(), rows.concat())
}

/// Add one observer's viewshed to `acc`: `+1` per visible cell, or `+μ(D)`
/// with `fuzzy = Some((b1, b2))` (Fisher's fuzzy viewshed). Cells never
/// reached stay as they are.
pub fn accumulate_viewshed(
    dem: &Grid<f32>,
    cell_m: (f64, f64),
    observer: (usize, usize),
    o: &ViewshedOptions,
    fuzzy: Option<(f64, f64)>,
    acc: &mut Grid<f32>,
) -> Result<()> {
    check_options(o)?;
    check_observer(dem, observer)?;
    if let Some((b1, b2)) = fuzzy {
        if !(b1.is_finite() && b1 >= 0.0 && b2.is_finite() && b2 > 0.0) {
            return Err(Error::invalid(format!(
                "fuzzy viewshed b1={b1}, b2={b2}: give b1 >= 0 and b2 > 0 metres"
            )));
        }
    }
    let rows = r3_rows(dem, cell_m, observer, o, 0.0f32, |v, d| {
        if !v {
            0.0
        } else if let Some((b1, b2)) = fuzzy {
            fuzzy_membership(d, b1, b2) as f32
        } else {
            1.0
        }
    });
    for (a, v) in acc.data_mut().iter_mut().zip(rows.concat()) {
        *a += v;
    }
    Ok(())
}

/// Visibility index of every core cell of `view` (see the module doc):
/// rays of at most `steps` cells per axis and `cutoff_m` metres, `directions`
/// 8 or 16, eye `height` above the cell, targets `target` above theirs.
/// Nodata where the centre is nodata or no target is valid.
pub fn visibility_index(
    view: &TileView<f32>,
    steps: usize,
    cutoff_m: f64,
    directions: usize,
    height: f64,
    target: f64,
    out: &mut Grid<f32>,
) {
    assert!(
        steps <= view.halo,
        "visibility rays must stay inside the halo"
    );
    let h = view.halo;
    let gw = view.grid.width();
    let data = view.grid.data();
    let dirs = &DIRS[..directions.min(16)];
    for y in 0..view.core.h {
        let (ew, ns) = view.georef.cell_size_m(view.core.y + y as i64);
        let mut plan = [(0isize, 0.0f64, 0usize); 16];
        for (j, (p, &(dx, dy))) in plan.iter_mut().zip(dirs).enumerate() {
            let (d, k) = ray_plan(j, ew, ns, steps, cutoff_m);
            *p = (dy as isize * gw as isize + dx as isize, d, k);
        }
        for x in 0..view.core.w {
            let c = (y + h) * gw + x + h;
            let z0 = data[c] as f64;
            if z0.is_nan() {
                out.set(x, y, f32::NAN);
                continue;
            }
            let eye = z0 + height;
            let (mut seen, mut n) = (0u32, 0u32);
            for &(off, d, k) in &plan[..dirs.len()] {
                let mut block = f64::NEG_INFINITY;
                for (s, z) in ray_cells(data, c, off, k) {
                    let dist = s as f64 * d;
                    n += 1;
                    if (z + target - eye) / dist >= block {
                        seen += 1;
                    }
                    block = block.max((z - eye) / dist);
                }
            }
            out.set(
                x,
                y,
                if n == 0 {
                    f32::NAN
                } else {
                    (seen as f64 / n as f64) as f32
                },
            );
        }
    }
}

/// Exact visibility index of every core cell of `view`: the share of the
/// valid cells `t ≠ o` with `dx² + dy²` (metres) within `cutoff_m` (and at
/// most `steps` cells per axis, ≤ the halo) that are visible by R3 line of
/// sight from the eye `height` above the cell, targets `target` above
/// theirs; no curvature. O(r³) per cell: for small radii and DEMs.
pub fn visibility_index_exact(
    view: &TileView<f32>,
    steps: usize,
    cutoff_m: f64,
    height: f64,
    target: f64,
    out: &mut Grid<f32>,
) {
    assert!(
        steps <= view.halo,
        "visibility targets must stay inside the halo"
    );
    let h = view.halo;
    let gw = view.grid.width();
    let data = view.grid.data();
    let limit = cutoff_m * cutoff_m * (1.0 + 1e-12);
    let flat = |_: f64, _: f64| 0.0;
    let r = steps as i64;
    for y in 0..view.core.h {
        let (ew, ns) = view.georef.cell_size_m(view.core.y + y as i64);
        // Target offsets within the cutoff, in a fixed order.
        let offs: Vec<(i64, i64)> = (-r..=r)
            .flat_map(|dy| (-r..=r).map(move |dx| (dx, dy)))
            .filter(|&(dx, dy)| {
                (dx, dy) != (0, 0) && (dx as f64 * ew).powi(2) + (dy as f64 * ns).powi(2) <= limit
            })
            .collect();
        for x in 0..view.core.w {
            let (ox, oy) = (x + h, y + h);
            let z0 = data[oy * gw + ox] as f64;
            if z0.is_nan() {
                out.set(x, y, f32::NAN);
                continue;
            }
            let eye = z0 + height;
            let (mut seen, mut n) = (0u32, 0u32);
            for &(dx, dy) in &offs {
                let (tx, ty) = ((ox as i64 + dx) as usize, (oy as i64 + dy) as usize);
                let zt = data[ty * gw + tx] as f64;
                if zt.is_nan() {
                    continue;
                }
                n += 1;
                seen += u32::from(r3_visible(
                    data,
                    gw,
                    (ox, oy),
                    (tx, ty),
                    eye,
                    zt + target,
                    &flat,
                ));
            }
            out.set(
                x,
                y,
                if n == 0 {
                    f32::NAN
                } else {
                    (seen as f64 / n as f64) as f32
                },
            );
        }
    }
}

/// The visibility index along the lattice rays, or over the whole disk
/// (R3 line of sight).
pub struct VisibilityIndex(MetricDef);

impl Metric for VisibilityIndex {
    fn def(&self) -> &MetricDef {
        &self.0
    }
    fn halo(&self, m: &Resolved) -> usize {
        m.radius_cells.max(1)
    }
    fn bind(&self, r: &mut Resolved, info: &RasterInfo) -> Result<()> {
        super::solar::check_resolved(r, info)
    }
    fn run(&self, t: &mut Tile<'_>, m: &Resolved, o: &mut Grid<f32>) -> Result<()> {
        let height = m.spec.value("height").unwrap_or(1.7);
        let target = m.spec.value("target").unwrap_or(0.0);
        if self.0.kind == MetricKind::VisibilityIndexExact {
            visibility_index_exact(t.view, m.radius_cells, m.radius_m, height, target, o);
        } else {
            visibility_index(
                t.view,
                m.radius_cells,
                m.radius_m,
                m.spec.directions,
                height,
                target,
                o,
            );
        }
        Ok(())
    }
}

/// `visibility_index`: share of the cells on the lattice rays within the cutoff that the observer (height above the cell) sees.
///
/// Source: Franklin & Ray 1994 (Proc. Spatial Data Handling) visibility index, targets sampled along 8/16 exact rays.
pub static VISIBILITY_INDEX: VisibilityIndex = VisibilityIndex(metric_def!(
        VisibilityIndex,
        "visibility_index",
        &[
            RADIUS_HORIZON,
            DIRECTIONS,
            HEIGHT,
            TARGET
        ],
        "0..1",
        "share of the cells on the lattice rays within the cutoff that the observer (height above the cell) sees",
        "Franklin & Ray 1994 (Proc. Spatial Data Handling) visibility index, targets sampled along 8/16 exact rays"
    ));

/// `visibility_index_exact`: share of all cells within the cutoff disk visible (R3 line of sight) from the observer; O(r^3) per cell.
///
/// Source: Franklin & Ray 1994 (Proc. Spatial Data Handling) visibility index, R3 line of sight to every target.
pub static VISIBILITY_INDEX_EXACT: VisibilityIndex = VisibilityIndex(metric_def!(
        VisibilityIndexExact,
        "visibility_index_exact",
        &[
            RADIUS_EXACT,
            HEIGHT,
            TARGET
        ],
        "0..1",
        "share of all cells within the cutoff disk visible (R3 line of sight) from the observer; O(r^3) per cell",
        "Franklin & Ray 1994 (Proc. Spatial Data Handling) visibility index, R3 line of sight to every target"
    ));
