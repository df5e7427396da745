//! `orogen peaks`: peaks with prominence, key saddles, parents, isolation and
//! the divide tree (Kirmse & de Ferranti 2017), in memory when the DEM fits
//! the memory budget, else tile by tile with the same results.

use crate::error::{Error, Result};
use crate::exec::EngineConfig;
use crate::exec::MemoryFit;
use crate::io::geojson::GeoJsonCoords;
use crate::ops::note::{Note, Notify};
use crate::ops::parse::GeoJsonCrs;
use crate::oro::EdgeConvention;
use crate::raster::RasterSource;
use std::path::{Path, PathBuf};

/// Bytes per cell of the in-memory peak search.
pub const PEAKS_BYTES_PER_CELL: u64 = 28;

/// Options of `orogen peaks`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PeaksOptions {
    /// Keep peaks with at least this prominence (DEM units, usually metres).
    pub min_prominence: f64,
    /// Edge and nodata convention (`sea-level` or `unknown`; see
    /// [`EdgeConvention`] for the rule below sea level).
    #[serde(with = "edge_text")]
    pub edge: EdgeConvention,
    /// Skip isolation (distance to higher ground).
    pub no_isolation: bool,
    /// Work tile by tile even if the DEM fits the memory budget.
    pub tiled: bool,
    /// Also write line parents, relevance and normalised elevation (needs the
    /// whole DEM in memory; not with `tiled`).
    pub line_parents: bool,
    /// Work-tile size of a tiled run (`None`: the input store's, else the default).
    pub tile: Option<usize>,
    /// Coordinates of the GeoJSON outputs: `wgs84` (longitude/latitude,
    /// RFC 7946) or `native` (the raster's CRS, named in a `crs` member);
    /// see [`crate::io::geojson`].
    pub geojson_crs: GeoJsonCrs,
}

impl Default for PeaksOptions {
    fn default() -> Self {
        PeaksOptions {
            min_prominence: 30.0,
            edge: EdgeConvention::SeaLevel,
            no_isolation: false,
            tiled: false,
            line_parents: false,
            tile: None,
            geojson_crs: GeoJsonCrs::Wgs84,
        }
    }
}

/// `--edge` of `orogen peaks`: `sea-level` or `unknown`.
pub fn parse_edge(s: &str) -> Result<EdgeConvention> {
    match s {
        "sea-level" => Ok(EdgeConvention::SeaLevel),
        "unknown" => Ok(EdgeConvention::Unknown),
        e => Err(Error::invalid(format!(
            "--edge {e:?}: use sea-level or unknown"
        ))),
    }
}

/// Serde form of an [`EdgeConvention`]: the text of `--edge`
/// ([`parse_edge`]).
pub mod edge_text {
    use crate::oro::EdgeConvention;
    use serde::{Deserialize, Deserializer, Serializer};

    pub fn serialize<S: Serializer>(e: &EdgeConvention, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(match e {
            EdgeConvention::SeaLevel => "sea-level",
            EdgeConvention::Unknown => "unknown",
        })
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<EdgeConvention, D::Error> {
        super::parse_edge(&String::deserialize(d)?).map_err(serde::de::Error::custom)
    }
}

impl PeaksOptions {
    /// Check the parameters (the minimum prominence).
    pub fn validate(&self) -> Result<()> {
        let min_prominence = self.min_prominence;
        if !(min_prominence.is_finite() && min_prominence >= 0.0) {
            return Err(Error::invalid(format!(
                "--min-prominence {min_prominence}: give a prominence of 0 or more"
            )));
        }
        Ok(())
    }

    fn peak_options(&self) -> crate::oro::PeakOptions {
        crate::oro::PeakOptions {
            min_prominence: self.min_prominence,
            convention: self.edge,
            isolation: !self.no_isolation,
        }
    }
}

/// How [`run`] works on a DEM.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PeaksMode {
    /// The whole DEM in memory.
    InMemory,
    /// Tile by tile, with this tile size.
    Tiled {
        /// Work-tile size in cells.
        tile: usize,
    },
}

/// The memory rule: in memory ([`PEAKS_BYTES_PER_CELL`] per cell) when it
/// fits `cfg.memory_budget` and `opts.tiled` is off, else tile by tile;
/// an error for line parents when the DEM does not fit.
pub fn mode(src: &dyn RasterSource, opts: &PeaksOptions, cfg: &EngineConfig) -> Result<PeaksMode> {
    let info = src.info();
    let fit = MemoryFit::raster(info, PEAKS_BYTES_PER_CELL, cfg.memory_budget);
    let need = fit.need;
    let go_tiled = opts.tiled || !fit.fits();
    if opts.line_parents && go_tiled {
        return Err(Error::over_budget(format!(
            "--line-parents needs the whole DEM in memory (about {} MiB); raise --memory and drop --tiled",
            need >> 20
        )));
    }
    Ok(if go_tiled {
        PeaksMode::Tiled {
            tile: super::choose_tile(src, opts.tile),
        }
    } else {
        PeaksMode::InMemory
    })
}

/// What [`run`] found and wrote.
#[derive(Debug, Clone)]
pub struct PeaksOutcome {
    /// Peaks kept (prominence at least the minimum).
    pub peaks: usize,
    /// Files written into the output folder.
    pub files: Vec<PathBuf>,
}

/// Find the peaks of `dem` and write `peaks.csv`, `peaks.geojson`,
/// `saddles.geojson`, `divide_tree.geojson` and `divide_tree.json` into `dir`,
/// working as [`mode`] chooses.
///
/// ```
/// use orogen::ops::peaks;
/// use orogen::raster::{GeoRef, Grid, MemRaster};
/// // One cone 100 high on flat ground at 0: one peak, prominence 100.
/// let dem = MemRaster::from_grid(Grid::from_fn(21, 21, |x, y| (100.0 - 10.0 * (x.abs_diff(10).max(y.abs_diff(10)) as f32)).max(0.0)), GeoRef::pixel());
/// let dir = std::env::temp_dir().join(format!("orogen-doc-peaks-{}", std::process::id()));
/// let found = peaks::run(&dem, &dir, &peaks::PeaksOptions::default(), &Default::default())?;
/// assert_eq!(found.peaks, 1);
/// # std::fs::remove_dir_all(&dir)?;
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn run(
    dem: &dyn RasterSource,
    dir: &Path,
    opts: &PeaksOptions,
    cfg: &EngineConfig,
) -> Result<PeaksOutcome> {
    opts.validate()?;
    let coords = crate::ops::note::geojson_coords(opts.geojson_crs, dem, &mut |_| {})?;
    let m = mode(dem, opts, cfg)?;
    run_in(dem, dir, opts, m, &coords, cfg)
}

/// [`run`], telling `notify` how it runs (tile by tile), how many peaks it
/// found and the files it wrote.
pub fn run_noted(
    dem: &dyn RasterSource,
    dir: &Path,
    opts: &PeaksOptions,
    cfg: &EngineConfig,
    notify: Notify<'_>,
) -> Result<PeaksOutcome> {
    opts.validate()?;
    let coords = crate::ops::note::geojson_coords(opts.geojson_crs, dem, notify)?;
    let m = mode(dem, opts, cfg)?;
    if let PeaksMode::Tiled { tile } = m {
        let info = dem.info();
        notify(Note::Info(format!(
            "peaks: {}x{} cells, tile by tile ({tile}-cell tiles)",
            info.width, info.height
        )));
    }
    let found = run_in(dem, dir, opts, m, &coords, cfg)?;
    notify(Note::Info(format!(
        "{} peaks with prominence >= {}",
        found.peaks, opts.min_prominence
    )));
    for f in &found.files {
        notify(Note::Wrote(f.clone()));
    }
    Ok(found)
}

/// [`run`] in the given mode (from [`mode`]), GeoJSON coordinates as
/// `coords` says (from `opts.geojson_crs`, [`crate::ops::note::geojson_coords`]).
pub fn run_in(
    dem: &dyn RasterSource,
    dir: &Path,
    opts: &PeaksOptions,
    mode: PeaksMode,
    coords: &GeoJsonCoords,
    cfg: &EngineConfig,
) -> Result<PeaksOutcome> {
    let (list, grid) = find(dem, opts, mode, cfg)?;
    // Line parents, relevance and normalised elevation need the DEM in
    // memory (line_parents); otherwise those columns are empty, so the
    // files are the same bytes tiled and untiled.
    let files = match &grid {
        Some(g) if opts.line_parents => list.write_all_with_dem(dir, g, coords)?,
        _ => list.write_all(dir, coords)?,
    };
    Ok(PeaksOutcome {
        peaks: list.tree.peaks.len(),
        files,
    })
}

/// The peaks of `dem` (and the DEM read whole, when `mode` is in memory).
fn find(
    dem: &dyn RasterSource,
    opts: &PeaksOptions,
    mode: PeaksMode,
    cfg: &EngineConfig,
) -> Result<(crate::oro::PeakList, Option<crate::raster::Grid<f32>>)> {
    let info = dem.info();
    let popts = opts.peak_options();
    Ok(match mode {
        PeaksMode::Tiled { tile } => {
            // A quarter of the budget caches cells for the isolation search.
            let cache = cfg.memory_budget / 4;
            let eng = crate::exec::engine(cfg)?;
            (
                crate::oro::peaks_tiled(dem, &popts, tile, &eng, cache)?,
                None,
            )
        }
        PeaksMode::InMemory => {
            let g = crate::raster::read_window::<f32>(
                dem,
                crate::raster::Window::full(info.width, info.height),
            )?;
            (crate::oro::peaks(&g, &info.georef, &popts)?, Some(g))
        }
    })
}

/// The peaks table of `dem` in memory: the text of the `peaks.csv`
/// [`run`] writes (same columns, same values), nothing written.
pub fn table(dem: &dyn RasterSource, opts: &PeaksOptions, cfg: &EngineConfig) -> Result<String> {
    opts.validate()?;
    let m = mode(dem, opts, cfg)?;
    let (list, grid) = find(dem, opts, m, cfg)?;
    list.csv_text(grid.as_ref().filter(|_| opts.line_parents))
}
