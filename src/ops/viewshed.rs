//! `orogen viewshed`: the R3 viewshed of one observer (u8: 1 visible, 0 not,
//! 255 beyond the radius or nodata), the cumulative viewshed of several
//! (u16 count of observers seeing each cell), or Fisher's fuzzy viewshed
//! (f32 sum of distance-decay memberships); see [`crate::metrics::visibility`]
//! (line of sight after Franklin & Ray 1994).
//!
//! Only the window around the observers (their radius, clipped to the DEM)
//! is read and written, so the output covers that window, georeferenced.

use super::{convert, Target};
use crate::error::{Error, Result};
use crate::exec::EngineConfig;
use crate::exec::MemoryFit;
use crate::metrics::registry::{parse_length, Length};
use crate::metrics::visibility::{self, accumulate_viewshed, viewshed};
use crate::raster::{read_window, DType, Grid, MemRaster, RasterInfo, RasterSource, Window};
use std::path::{Path, PathBuf};

/// Options of `orogen viewshed`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ViewshedOptions {
    /// Observers in the DEM's CRS (or col,row with `pixel`); read from
    /// `"X,Y"`, a list of them or a list of `[x, y]` ([`pair_text`]).
    #[serde(deserialize_with = "pair_text::list")]
    pub at: Vec<(f64, f64)>,
    /// More observers from a CSV (x,y or lon,lat columns) or GeoJSON Points file.
    pub points: Option<PathBuf>,
    /// `at` holds pixel coordinates (col,row), not map coordinates.
    pub pixel: bool,
    /// Observer height above the ground (DEM units).
    pub observer_height: f64,
    /// Target height above the ground (DEM units).
    pub target_height: f64,
    /// Radius: a length such as `10km`, `500m` or `200c` (cells).
    pub radius: String,
    /// Correct for the earth's curvature and refraction.
    pub curvature: bool,
    /// Refraction coefficient (with `curvature`).
    pub refraction: f64,
    /// Fisher's fuzzy viewshed with distance-decay breakpoints (B1, B2);
    /// read from `"B1,B2"` or `[b1, b2]`.
    #[serde(deserialize_with = "pair_text::option")]
    pub fuzzy: Option<(f64, f64)>,
}

impl Default for ViewshedOptions {
    fn default() -> Self {
        ViewshedOptions {
            at: Vec::new(),
            points: None,
            pixel: false,
            observer_height: 1.7,
            target_height: 0.0,
            radius: "10km".into(),
            curvature: false,
            refraction: 0.13,
            fuzzy: None,
        }
    }
}

/// `msg: e`, as the CLI prints a context over an error.
fn ctx(msg: String, e: impl std::fmt::Display) -> Error {
    Error::invalid(format!("{msg}: {e}"))
}

/// An `X,Y` pair of `--at` or `--fuzzy` (`what` names the option in errors).
pub fn parse_pair(s: &str, what: &str) -> Result<(f64, f64)> {
    let mut it = s.split(',').map(|v| v.trim().parse::<f64>());
    match (it.next(), it.next(), it.next()) {
        (Some(Ok(a)), Some(Ok(b)), None) if a.is_finite() && b.is_finite() => Ok((a, b)),
        _ => Err(Error::invalid(format!(
            "{what} {s:?}: expected two numbers separated by a comma, e.g. 350120,4590210"
        ))),
    }
}

/// Serde forms of the `X,Y` pairs of [`ViewshedOptions`]: the text of
/// `--at` / `--fuzzy` ([`parse_pair`]) or two numbers.
pub mod pair_text {
    use serde::{Deserialize, Deserializer};

    #[derive(Deserialize)]
    #[serde(untagged)]
    enum Pair {
        Text(String),
        Numbers((f64, f64)),
    }

    impl Pair {
        fn pair<E: serde::de::Error>(self, what: &str) -> Result<(f64, f64), E> {
            match self {
                Pair::Text(t) => super::parse_pair(&t, what).map_err(E::custom),
                Pair::Numbers(p) => Ok(p),
            }
        }
    }

    #[derive(Deserialize)]
    #[serde(untagged)]
    enum Pairs {
        One(Pair),
        Many(Vec<Pair>),
    }

    /// `"X,Y"`, `[x, y]` or a list of either.
    pub fn list<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<(f64, f64)>, D::Error> {
        match Pairs::deserialize(d)? {
            Pairs::One(p) => Ok(vec![p.pair("--at")?]),
            Pairs::Many(v) => v.into_iter().map(|p| p.pair("--at")).collect(),
        }
    }

    /// `"B1,B2"` or `[b1, b2]`.
    pub fn option<'de, D: Deserializer<'de>>(d: D) -> Result<Option<(f64, f64)>, D::Error> {
        Option::<Pair>::deserialize(d)?
            .map(|p| p.pair("--fuzzy"))
            .transpose()
    }
}

impl ViewshedOptions {
    /// Check what can be checked without the DEM (the radius).
    pub fn validate(&self) -> Result<()> {
        parse_length(&self.radius).map_err(|e| ctx("--radius".into(), e))?;
        Ok(())
    }
}

/// The observers of a point file in the map coordinates of a DEM with
/// `georef`: GeoJSON Points (in the DEM's CRS unless the file has a `crs`
/// member), or a CSV with x,y (lon,lat, easting,northing) columns, read by
/// [`crate::io::vector::read_points_in`].
pub fn read_points(path: &Path, georef: &crate::raster::GeoRef) -> Result<Vec<(f64, f64)>> {
    let pts = crate::io::vector::read_points_in(path, OBSERVERS, georef)?;
    Ok(pts.into_iter().map(|p| (p.x, p.y)).collect())
}

/// What the points of `--points` are, in the point reader's errors.
const OBSERVERS: crate::io::vector::PointNoun<'static> = crate::io::vector::PointNoun {
    one: "observer point",
    many: "observer points",
};

/// Cell of a point, or an error naming the point and the DEM's extent.
fn to_cell(info: &RasterInfo, p: (f64, f64), pixel: bool) -> Result<(usize, usize)> {
    let (c, r) = if pixel {
        p
    } else {
        info.georef.map_to_pixel(p.0, p.1).ok_or_else(|| {
            Error::invalid(format!("{}: singular geotransform", info.path.display()))
        })?
    };
    let (c, r) = (c.floor(), r.floor());
    if !(c >= 0.0 && r >= 0.0 && c < info.width as f64 && r < info.height as f64) {
        let (x0, y0) = info.georef.pixel_to_map(0.0, 0.0);
        let (x1, y1) = info
            .georef
            .pixel_to_map(info.width as f64, info.height as f64);
        return Err(Error::invalid(format!(
            "observer {},{} is outside {} (cell {c},{r} of {}x{}; the DEM spans x {x0}..{x1}, y {y1}..{y0}): give a point inside the DEM",
            p.0,
            p.1,
            info.path.display(),
            info.width,
            info.height
        )));
    }
    Ok((c as usize, r as usize))
}

/// Run `orogen viewshed`.
/// The viewshed of the observers of `opts` on `dem` into `target`.
pub fn run(
    dem: &dyn RasterSource,
    opts: &ViewshedOptions,
    target: &Target,
    cfg: &EngineConfig,
) -> Result<()> {
    let a = opts;
    let info = dem.info().clone();
    let mut pts: Vec<(f64, f64)> = a.at.clone();
    let n_at = pts.len();
    if let Some(p) = &a.points {
        pts.extend(read_points(p, &info.georef)?);
    }
    if pts.is_empty() {
        return Err(Error::invalid(
            "give an observer with --at X,Y (or --points FILE)",
        ));
    }
    // --pixel applies to --at only; point files hold coordinates.
    let cells: Vec<(usize, usize)> = pts
        .iter()
        .enumerate()
        .map(|(i, &p)| to_cell(&info, p, a.pixel && i < n_at))
        .collect::<Result<_>>()?;
    let min_cell = crate::metrics::registry::min_cell_size_m(&info);
    let radius_m = match parse_length(&a.radius).map_err(|e| ctx("--radius".into(), e))? {
        Length::Metres(m) => m,
        Length::Cells(c) => c as f64 * min_cell,
    };
    let fuzzy = a.fuzzy;
    let opts = visibility::ViewshedOptions {
        observer_height: a.observer_height,
        target_height: a.target_height,
        radius_m,
        curvature: a.curvature.then_some(a.refraction),
    };
    visibility::check_options(&opts)?;
    // The window: every observer's radius, clipped to the DEM.
    let reach = (radius_m / min_cell).ceil();
    if !(reach.is_finite()) {
        return Err(Error::invalid(format!(
            "--radius {}: not a usable distance",
            a.radius
        )));
    }
    let reach = reach.min(1e9) as i64;
    let (mut x0, mut y0, mut x1, mut y1) = (i64::MAX, i64::MAX, i64::MIN, i64::MIN);
    for &(c, r) in &cells {
        x0 = x0.min(c as i64 - reach);
        y0 = y0.min(r as i64 - reach);
        x1 = x1.max(c as i64 + reach + 1);
        y1 = y1.max(r as i64 + reach + 1);
    }
    let (x0, y0) = (x0.max(0), y0.max(0));
    let (x1, y1) = (x1.min(info.width as i64), y1.min(info.height as i64));
    let win = Window::new(x0, y0, (x1 - x0) as usize, (y1 - y0) as usize);
    MemoryFit::cells(win.w, win.h, 8, cfg.memory_budget).check(|f| {
        Error::over_budget(format!(
            "{}: the viewshed window is {}x{} cells ({:.1} GiB in memory); use a smaller --radius or raise --memory",
            info.path.display(),
            win.w,
            win.h,
            f.need_gib()
        ))
    })?;
    let grid = read_window::<f32>(dem, win)?;
    let georef = info.georef.shifted(win.x, win.y);
    let local: Vec<(usize, usize)> = cells
        .iter()
        .map(|&(c, r)| (c - win.x as usize, r - win.y as usize))
        .collect();
    let cell_m = |row: usize| info.georef.cell_size_m(row as i64);
    let mem = if local.len() == 1 && fuzzy.is_none() {
        let (c, r) = local[0];
        let v = viewshed(&grid, cell_m(r + win.y as usize), (c, r), &opts)
            .map_err(|e| ctx(format!("observer {},{}", pts[0].0, pts[0].1), e))?;
        MemRaster::from_grid(v, georef.with_nodata(Some(255.0)))
    } else {
        let mut acc = Grid::new(win.w, win.h, 0f32);
        for (k, &(c, r)) in local.iter().enumerate() {
            accumulate_viewshed(
                &grid,
                cell_m(r + win.y as usize),
                (c, r),
                &opts,
                fuzzy,
                &mut acc,
            )
            .map_err(|e| ctx(format!("observer {},{}", pts[k].0, pts[k].1), e))?;
        }
        if fuzzy.is_some() {
            for (a, z) in acc.data_mut().iter_mut().zip(grid.data()) {
                if z.is_nan() {
                    *a = crate::metrics::METRIC_NODATA as f32;
                }
            }
            MemRaster::from_grid(acc, georef.with_nodata(Some(crate::metrics::METRIC_NODATA)))
        } else {
            if local.len() > 65_534 {
                return Err(Error::invalid(format!(
                    "{} observers: at most 65534 for a u16 count",
                    local.len()
                )));
            }
            let counts: Vec<u16> = acc
                .data()
                .iter()
                .zip(grid.data())
                .map(|(&n, z)| if z.is_nan() { u16::MAX } else { n as u16 })
                .collect();
            MemRaster::from_grid(
                Grid::from_vec(win.w, win.h, counts)?,
                georef.with_nodata(Some(u16::MAX as f64)),
            )
        }
    };
    debug_assert!(matches!(
        mem.grid().dtype(),
        DType::U8 | DType::U16 | DType::F32
    ));
    convert(&mem, &target.path, &target.options, target.tile, cfg)
}
