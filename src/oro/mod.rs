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
//! SRTM3 tiles (`tests/oro_reference.rs`): identical peak lists, elevations
//! and prominences at ≥ 30 m.
//!
//! Not tiled yet. The plan for out-of-core DEMs: each tile runs this sweep
//! with its boundary ring as extra tree nodes and emits (1) the peaks whose
//! key saddle was found before their component reached the tile boundary
//! (final: no terrain outside can change them), (2) a contracted join tree
//! over the remaining peaks, the saddles joining them and the boundary cells
//! ("runoffs" in Kirmse's terms), each node with its elevation and position.
//! Neighbouring summaries are merged by connecting boundary cells adjacent
//! across the seam at level min(a, b) and re-running the same descending
//! Kruskal sweep on the small contracted graph; seams that become interior are
//! then contracted away, so summaries stay O(boundary + open peaks).

mod isolation;
mod regions;
pub mod tiled;
mod tree;
mod write;

pub use isolation::IsolationIndex;
pub use tiled::divide_tree_tiled;
pub use tree::{CriticalPoints, DivideTree, EdgeConvention, Isolation, Peak, Saddle};
pub use write::{
    write_divide_tree_geojson, write_peaks_csv, write_peaks_geojson, write_saddles_geojson,
};

use crate::error::{Error, Result};
use crate::raster::{GeoRef, Grid};
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
    /// missing); returns the paths written.
    pub fn write_all(&self, dir: &Path) -> Result<Vec<PathBuf>> {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        let p = |n: &str| dir.join(n);
        write_peaks_csv(&p("peaks.csv"), &self.tree, &self.georef)?;
        write_peaks_geojson(&p("peaks.geojson"), &self.tree, &self.georef)?;
        write_saddles_geojson(&p("saddles.geojson"), &self.tree, &self.georef)?;
        write_divide_tree_geojson(&p("divide_tree.geojson"), &self.tree, &self.georef)?;
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
