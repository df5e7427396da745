//! Orometry in memory: peaks, saddles, the divide tree, prominence, isolation.
//!
//! Entry points: [`peaks`] (the whole pipeline: tree, prune, isolation),
//! [`divide_tree`] (the unpruned tree), [`critical_points`], and the writers
//! [`write_peaks_csv`], [`write_peaks_geojson`], [`write_saddles_geojson`],
//! [`write_divide_tree_geojson`]; [`DivideTree::save_json`]/`load_json`.
//! Input: a `Grid<f32>` with NaN as nodata. Definitions follow Kirmse & de
//! Ferranti 2017 (prominence, key saddle, prominence parent, isolation); see
//! `tree.rs` for the sweep and the tie rules, [`EdgeConvention`] for the edge.
//!
//! Checked against akirmse/mountains (the tool of Kirmse & de Ferranti) on two
//! SRTM3 tiles (`tests/oro/reference.rs`): identical peak lists, elevations
//! and prominences at ≥ 30 m.
//!
//! Out of core: [`peaks_tiled`] / [`divide_tree_tiled`] build the same tree
//! tile by tile on an [`Engine`] (see `tiled.rs`: per-tile sweeps emit the
//! final peaks and a contracted join tree of the part still open; one sweep
//! over the joined graphs finishes it) and compute isolation with
//! [`TiledIsolationIndex`] (block maxima in memory, cells read on demand).

#[cfg(feature = "learn")]
pub mod classify;
mod isolation;
mod links;
pub mod metrics;
pub(crate) mod regions;
pub mod ridges;
pub mod stats;
pub mod tiled;
mod tree;
mod write;

pub use isolation::{IsolationIndex, TiledIsolationIndex};
pub use tiled::{divide_tree_tiled, pruned_tree_tiled};
pub use tree::{CriticalPoints, DivideTree, EdgeConvention, Isolation, Peak, Saddle};
pub use write::{
    write_divide_tree_geojson, write_peaks_csv, write_peaks_geojson, write_saddles_geojson,
};
pub use write::{write_peaks_csv_with, write_peaks_geojson_with, EXTRA_COLUMNS};

use crate::error::{Error, Result};
use crate::exec::Engine;
use crate::io::geojson::GeoJsonCoords;
use crate::raster::{GeoRef, Grid, RasterSource};
use std::path::{Path, PathBuf};

/// Options of [`peaks`].
#[derive(Debug, Clone, PartialEq)]
pub struct PeakOptions {
    /// Keep peaks with prominence ≥ this (metres, or DEM units).
    pub min_prominence: f64,
    /// Edge and nodata convention.
    pub convention: EdgeConvention,
    /// Compute isolation of the kept peaks.
    pub isolation: bool,
}

impl Default for PeakOptions {
    fn default() -> Self {
        PeakOptions {
            min_prominence: 30.0,
            convention: EdgeConvention::SeaLevel,
            isolation: true,
        }
    }
}

/// Peaks with prominence ≥ the threshold, as a pruned divide tree (peaks in
/// decreasing elevation, each with key saddle and parent among kept peaks).
#[derive(Debug, Clone, PartialEq)]
pub struct PeakList {
    pub tree: DivideTree,
    pub georef: GeoRef,
}

impl PeakList {
    /// Write `peaks.csv`, `peaks.geojson`, `saddles.geojson`,
    /// `divide_tree.geojson` and `divide_tree.json` into `dir` (created if
    /// missing); returns the paths written. Each file is written atomically
    /// (temporary, then rename), so none is ever seen half-written.
    /// GeoJSON coordinates as `coords` says (see [`crate::io::geojson`]).
    pub fn write_all(&self, dir: &Path, coords: &GeoJsonCoords) -> Result<Vec<PathBuf>> {
        let m = metrics::peak_metrics_tree_only(&self.tree, &self.georef);
        self.write_files(dir, &m, coords)
    }

    /// [`PeakList::write_all`] with the per-peak metrics `m`: every file
    /// is written once, so a kill between two writes never leaves a peaks
    /// file that is complete but lacks the DEM's metrics.
    fn write_files(
        &self,
        dir: &Path,
        m: &[metrics::PeakMetrics],
        coords: &GeoJsonCoords,
    ) -> Result<Vec<PathBuf>> {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        let p = |n: &str| dir.join(n);
        write::write_peaks_csv_with(&p("peaks.csv"), &self.tree, &self.georef, m)?;
        write::write_peaks_geojson_with(&p("peaks.geojson"), &self.tree, coords, m)?;
        write_saddles_geojson(&p("saddles.geojson"), &self.tree, coords)?;
        write_divide_tree_geojson(&p("divide_tree.geojson"), &self.tree, coords)?;
        self.tree.save_json(&p("divide_tree.json"))?;
        Ok([
            "peaks.csv",
            "peaks.geojson",
            "saddles.geojson",
            "divide_tree.geojson",
            "divide_tree.json",
        ]
        .iter()
        .map(|n| p(n))
        .collect())
    }
}

/// The unpruned divide tree of `dem` (NaN = nodata).
pub fn divide_tree(dem: &Grid<f32>, convention: EdgeConvention) -> Result<DivideTree> {
    Ok(tree::build(dem, convention)?.0)
}

/// Peaks, join saddles and pits of `dem` (see [`CriticalPoints`]).
pub fn critical_points(dem: &Grid<f32>, convention: EdgeConvention) -> Result<CriticalPoints> {
    Ok(tree::build(dem, convention)?.1)
}

/// The whole pipeline: divide tree, pruning at `opts.min_prominence`,
/// isolation of the kept peaks.
pub fn peaks(dem: &Grid<f32>, georef: &GeoRef, opts: &PeakOptions) -> Result<PeakList> {
    if !opts.min_prominence.is_finite() {
        return Err(Error::invalid(format!(
            "peaks: minimum prominence must be a finite number, got {}",
            opts.min_prominence
        )));
    }
    let mut tree = divide_tree(dem, opts.convention)?.pruned(opts.min_prominence);
    if opts.isolation {
        compute_isolation(&mut tree, dem, georef);
    }
    Ok(PeakList {
        tree,
        georef: georef.clone(),
    })
}

/// Fill [`Peak::isolation`] for every peak of `tree` (built from `dem`).
pub fn compute_isolation(tree: &mut DivideTree, dem: &Grid<f32>, georef: &GeoRef) {
    let idx = IsolationIndex::new(dem, georef);
    for p in tree.peaks.iter_mut() {
        p.isolation = idx.nearest_higher(p.col as usize, p.row as usize, p.elevation);
    }
}

/// [`peaks`] for a DEM read tile by tile from `src` (f32, nodata = NaN) on
/// `engine` with tiles of `tile` cells: the same [`PeakList`]. Isolation
/// keeps block maxima (W·H/64 bytes) and at most `cache_bytes` of cells.
pub fn peaks_tiled<E: Engine>(
    src: &dyn RasterSource,
    opts: &PeakOptions,
    tile: usize,
    engine: &E,
    cache_bytes: u64,
) -> Result<PeakList> {
    if !opts.min_prominence.is_finite() {
        return Err(Error::invalid(format!(
            "peaks: minimum prominence must be a finite number, got {}",
            opts.min_prominence
        )));
    }
    let mut tree = pruned_tree_tiled(src, opts.convention, opts.min_prominence, tile, engine)?;
    if opts.isolation {
        let idx = TiledIsolationIndex::new(src, cache_bytes)?;
        // Visit peaks window by window so the cache is reused.
        let mut order: Vec<usize> = (0..tree.peaks.len()).collect();
        order.sort_by_key(|&i| {
            let p = &tree.peaks[i];
            (p.row / 256, p.col / 256, i)
        });
        for i in order {
            let p = &tree.peaks[i];
            let iso = idx.nearest_higher(p.col as usize, p.row as usize, p.elevation)?;
            tree.peaks[i].isolation = iso;
        }
    }
    Ok(PeakList {
        tree,
        georef: src.info().georef.clone(),
    })
}
