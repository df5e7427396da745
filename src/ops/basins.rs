//! `orogen basins`: basin labels of every outlet, or watersheds of pour
//! points, exact across tiles ([`crate::hydro::basins`]), optionally with
//! per-basin metrics ([`crate::hydro::basin_metrics`]: area, perimeter,
//! circularity, hypsometry, ...) and outlines, in memory.

use super::hydro_io::{full, guard, open_path, read_dirs, same_size};
use super::Target;
use crate::error::{Error, Result};
use crate::exec::EngineConfig;
use crate::hydro::basin_metrics;
use crate::hydro::basins::{self, Seeds, TiledDownstream};
use crate::io::geojson::GeoJsonCoords;
use crate::ops::parse::GeoJsonCrs;
use crate::raster::{read_window, Grid, RasterSource};
use std::path::PathBuf;

/// Options of `orogen basins`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BasinsOptions {
    /// Pour points (CSV with x,y or lon,lat columns, or GeoJSON Points) in
    /// the rasters' CRS: delineate their watersheds instead of every outlet's basin.
    pub points: Option<PathBuf>,
    /// Snap each pour point to the cell of largest accumulation within this many cells.
    pub snap: usize,
    /// Flow accumulation (for `snap`).
    pub acc: Option<PathBuf>,
    /// Also write per-basin metrics to this CSV and, beside it (.geojson),
    /// the basins' outlines; needs `dem`.
    pub metrics: Option<PathBuf>,
    /// DEM (filled) for `metrics`.
    pub dem: Option<PathBuf>,
    /// Only basins with at least this many cells in `metrics`.
    pub min_cells: u64,
    /// Samples on the hypsometric curve in `metrics`.
    pub hyp_samples: usize,
    /// Coordinates of the GeoJSON outputs: `wgs84` (longitude/latitude,
    /// RFC 7946) or `native` (the raster's CRS, named in a `crs` member);
    /// see [`crate::io::geojson`].
    pub geojson_crs: GeoJsonCrs,
}

impl Default for BasinsOptions {
    fn default() -> Self {
        BasinsOptions {
            points: None,
            snap: 0,
            acc: None,
            metrics: None,
            dem: None,
            min_cells: 1,
            hyp_samples: 21,
            geojson_crs: GeoJsonCrs::Wgs84,
        }
    }
}

/// The labels [`write_labels`] wrote: the pour points' cells (`None`:
/// every outlet's basin), for [`write_metrics`].
#[derive(Debug, Clone)]
pub struct Labels {
    /// Cells (column, row) of the located pour points.
    pub cells: Option<Vec<(usize, usize)>>,
    /// How the outlines GeoJSON of `metrics` is written (checked before the
    /// labels are: an unprojectable CRS writes nothing).
    pub coords: GeoJsonCoords,
}

impl Labels {
    /// The warning of a raster without a known CRS, when `metrics` writes
    /// GeoJSON (see [`crate::io::geojson`]).
    pub fn warning(&self, opts: &BasinsOptions) -> Option<&str> {
        opts.metrics.as_ref().and(self.coords.warning())
    }
}

/// Label the basins of the D8 directions `dirs` into `target` (u32, or f64
/// for more than 2³² cells; 0 = none/nodata), then write the metrics if
/// asked ([`write_labels`], then [`write_metrics`]). Returns the files
/// written, in order.
pub fn run(
    dirs: &dyn RasterSource,
    opts: &BasinsOptions,
    target: &Target,
    cfg: &EngineConfig,
) -> Result<Vec<PathBuf>> {
    let labels = write_labels(dirs, opts, target, cfg)?;
    let mut files = vec![target.path.clone()];
    files.extend(write_metrics(dirs, opts, &labels, cfg)?);
    Ok(files)
}

/// The label raster of [`run`].
pub fn write_labels(
    dirs: &dyn RasterSource,
    opts: &BasinsOptions,
    target: &Target,
    cfg: &EngineConfig,
) -> Result<Labels> {
    let a = opts;
    let info = dirs.info().clone();
    let coords = match &a.metrics {
        Some(_) => a.geojson_crs.coords(&info.georef, &info.path)?,
        None => GeoJsonCoords::native(&info.georef),
    };
    let mut cells = None;
    let seeds = match &a.points {
        None => Seeds::Outlets,
        Some(p) => {
            let pts = basins::read_points_in(p, &info.georef)?;
            let acc = match &a.acc {
                Some(ap) => {
                    let s = open_path(ap)?;
                    same_size(dirs, s.as_ref())?;
                    Some(s)
                }
                None => None,
            };
            if a.snap > 0 && acc.is_none() {
                return Err(Error::invalid(
                    "--snap needs the flow accumulation: add --acc acc.tif",
                ));
            }
            let c = basins::locate_points(dirs, &pts, acc.as_deref(), a.snap)?;
            let s = basins::point_seeds(&c, info.width);
            cells = Some(c);
            s
        }
    };
    let step = TiledDownstream {
        seeds,
        labels: TiledDownstream::label_type(info.width, info.height),
    };
    target.run_global(&step, &[dirs], cfg)?;
    Ok(Labels { cells, coords })
}

/// The per-basin metrics CSV and outlines GeoJSON of [`run`] (none without
/// `opts.metrics`); returns the files written.
pub fn write_metrics(
    dirs: &dyn RasterSource,
    opts: &BasinsOptions,
    labels: &Labels,
    cfg: &EngineConfig,
) -> Result<Vec<PathBuf>> {
    let a = opts;
    let info = dirs.info();
    let labels_in = labels;
    let cells = &labels.cells;
    let mut files = Vec::new();
    if let Some(mp) = &a.metrics {
        let Some(dp) = &a.dem else {
            return Err(Error::invalid(
                "--metrics needs the DEM: add --dem filled.tif",
            ));
        };
        let dem = open_path(dp)?;
        same_size(dirs, dem.as_ref())?;
        guard(
            dirs,
            basin_metrics::BASIN_METRICS_BYTES_PER_CELL,
            "basin metrics",
            cfg,
        )?;
        let d = read_dirs(dirs)?;
        let labels: Grid<u64> = match cells {
            None => crate::hydro::basin_labels(&d)?,
            Some(c) => {
                let g = crate::hydro::watersheds(&d, c)?;
                g.map(|v| v as u64)
            }
        };
        let z = read_window::<f32>(dem.as_ref(), full(dem.as_ref()))?;
        let m = basin_metrics::basin_metrics(
            &labels,
            &z,
            &d,
            &info.georef,
            a.hyp_samples,
            a.min_cells,
        )?;
        basin_metrics::write_csv(mp, &info.georef, &m)?;
        files.push(mp.clone());
        let gj = mp.with_extension("geojson");
        let outlines = basin_metrics::basin_outlines(&labels)?;
        basin_metrics::write_geojson(&gj, &info.georef, &labels_in.coords, &m, Some(&outlines))?;
        files.push(gj);
    }
    Ok(files)
}
