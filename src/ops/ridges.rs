//! `orogen ridges`: ridge networks ([`crate::oro::ridges`]): divide-tree
//! ridges (steepest-ascent paths saddle -> peak, with longest-path level and
//! Strahler order) and PPA ridges (Chang et al. 1998 profile recognition +
//! maximum spanning tree), in memory.

use super::convert;
use super::orostats::read_dem;
use crate::error::{Error, Result};
use crate::exec::EngineConfig;
use crate::io::OutputOptions;
use crate::ops::note::{Note, Notify};
use crate::ops::parse::GeoJsonCrs;
use crate::oro::EdgeConvention;
use crate::raster::{GeoRef, Grid, RasterSource};
use std::path::{Path, PathBuf};

/// Options of `orogen ridges`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RidgesOptions {
    /// Ridges of peaks with at least this prominence.
    pub min_prominence: f64,
    /// Edge and nodata convention of the divide tree (`sea-level` or
    /// `unknown`).
    #[serde(with = "super::peaks::edge_text")]
    pub edge: EdgeConvention,
    /// PPA profile half-length, cells.
    pub half_window: usize,
    /// PPA: remove side branches shorter than this many cells.
    pub min_branch: usize,
    /// Skip the PPA ridges.
    pub no_ppa: bool,
    /// Coordinates of the GeoJSON outputs: `wgs84` (longitude/latitude,
    /// RFC 7946) or `native` (the raster's CRS, named in a `crs` member);
    /// see [`crate::io::geojson`].
    pub geojson_crs: GeoJsonCrs,
}

impl Default for RidgesOptions {
    fn default() -> Self {
        RidgesOptions {
            min_prominence: 30.0,
            edge: EdgeConvention::SeaLevel,
            half_window: 3,
            min_branch: 10,
            no_ppa: false,
            geojson_crs: GeoJsonCrs::Wgs84,
        }
    }
}

impl RidgesOptions {
    /// Check the parameters (the minimum prominence).
    pub fn validate(&self) -> Result<()> {
        if !(self.min_prominence.is_finite() && self.min_prominence >= 0.0) {
            return Err(Error::invalid(format!(
                "--min-prominence {}: give a prominence of 0 or more",
                self.min_prominence
            )));
        }
        Ok(())
    }
}

/// What [`run`] found and wrote.
#[derive(Debug, Clone)]
pub struct RidgesOutcome {
    /// Peaks of the divide tree.
    pub peaks: usize,
    /// Ridge segments.
    pub segments: usize,
    /// Highest hierarchy level.
    pub levels: u32,
    /// Files written, in order.
    pub files: Vec<PathBuf>,
}

fn write_u8(
    grid: Grid<u8>,
    georef: &GeoRef,
    path: &Path,
    oo: &OutputOptions,
    cfg: &EngineConfig,
) -> Result<()> {
    let g = georef.clone().with_nodata(None);
    let mem = crate::raster::MemRaster::new(crate::raster::AnyGrid::U8(grid), g, path);
    convert(&mem, path, oo, None, cfg)
}

/// Write ridges.geojson, ridge_levels.tif, ridge_orders.tif (0 = no ridge)
/// and, unless `no_ppa`, ppa_ridges.tif (1 = ridge) of `dem` into `dir`.
pub fn run(
    dem: &dyn RasterSource,
    dir: &Path,
    opts: &RidgesOptions,
    oo: &OutputOptions,
    cfg: &EngineConfig,
) -> Result<RidgesOutcome> {
    run_with(dem, dir, opts, oo, cfg, &mut |_| {})
}

/// [`run`], the warning of a raster without a known CRS told to `notify`.
fn run_with(
    dem: &dyn RasterSource,
    dir: &Path,
    opts: &RidgesOptions,
    oo: &OutputOptions,
    cfg: &EngineConfig,
    notify: Notify<'_>,
) -> Result<RidgesOutcome> {
    opts.validate()?;
    let coords = crate::ops::note::geojson_coords(opts.geojson_crs, dem, notify)?;
    let per_cell = if opts.no_ppa {
        40
    } else {
        40 + crate::oro::ridges::PPA_BYTES_PER_CELL
    };
    let (grid, georef) = read_dem(dem, per_cell, cfg)?;
    std::fs::create_dir_all(dir).map_err(|e| {
        Error::invalid(format!(
            "{}: cannot create the output folder: {e}",
            dir.display()
        ))
    })?;
    let popts = crate::oro::PeakOptions {
        min_prominence: opts.min_prominence,
        convention: opts.edge,
        isolation: false,
    };
    let list = crate::oro::peaks(&grid, &georef, &popts)?;
    let net = crate::oro::ridges::divide_tree_ridges(&list.tree, &grid, &georef)?;
    let gj = dir.join("ridges.geojson");
    net.write_geojson(&gj, &coords)?;
    let mut files = vec![gj];
    let levels = dir.join("ridge_levels.tif");
    write_u8(net.rasterise_levels(), &georef, &levels, oo, cfg)?;
    files.push(levels);
    let orders = dir.join("ridge_orders.tif");
    write_u8(net.rasterise_orders(), &georef, &orders, oo, cfg)?;
    files.push(orders);
    if !opts.no_ppa {
        let ppa = crate::oro::ridges::ppa_ridges(
            &grid,
            &crate::oro::ridges::PpaOptions {
                half_window: opts.half_window,
                min_branch: opts.min_branch,
            },
        )?;
        let p = dir.join("ppa_ridges.tif");
        write_u8(ppa, &georef, &p, oo, cfg)?;
        files.push(p);
    }
    Ok(RidgesOutcome {
        peaks: list.tree.peaks.len(),
        segments: net.edges.len(),
        levels: net.edges.iter().map(|e| e.level).max().unwrap_or(0),
        files,
    })
}

/// [`run`], noting each file written and then the summary line (peaks,
/// ridge segments, levels).
pub fn run_noted(
    dem: &dyn RasterSource,
    dir: &Path,
    opts: &RidgesOptions,
    oo: &OutputOptions,
    cfg: &EngineConfig,
    notify: Notify<'_>,
) -> Result<RidgesOutcome> {
    let done = run_with(dem, dir, opts, oo, cfg, notify)?;
    for f in &done.files {
        notify(Note::Wrote(f.clone()));
    }
    notify(Note::Info(format!(
        "{} peaks (prominence >= {}), {} ridge segments, {} levels",
        done.peaks, opts.min_prominence, done.segments, done.levels
    )));
    Ok(done)
}
