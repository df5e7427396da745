//! Per-peak orometric metrics beyond prominence and isolation: line parent,
//! key-saddle distance and direction, dominance groups, normalised elevation,
//! relative prominence and relevance; anti-prominence of pits; the Nearest
//! Neighbor Index of a point set.
//!
//! Everything is computed from a [`DivideTree`] (however it was built) plus,
//! where needed, the DEM it was built from.

use super::links::Links;
use super::regions::NONE;
use super::tree::{DivideTree, EdgeConvention};
use super::IsolationIndex;
use crate::error::{Error, Result};
use crate::raster::{GeoRef, Grid};
use serde::{Deserialize, Serialize};

/// Lower bounds (dominance in %) of Jurgalski's classes for "mountains, peaks
/// and points", from D2 (minor notable point) to A1 (supreme mountain):
/// E. Jurgalski, "Dominance" (8000ers.com; first published in
/// *Wissenschaftliche Alpenvereinshefte* 39, 2004), elevation unit chart (b).
pub const JURGALSKI_BOUNDS_PCT: [f64; 8] = [0.0, 0.35, 0.7, 1.4, 2.1, 4.2, 7.0, 10.5];

/// Names of the classes of [`JURGALSKI_BOUNDS_PCT`], same order.
pub const JURGALSKI_NAMES: [&str; 8] = [
    "D2 minor notable point",
    "D1 major notable point",
    "C2 minor sub-peak",
    "C1 major sub-peak",
    "B2 minor main peak",
    "B1 major main peak",
    "A2 mountain",
    "A1 supreme mountain",
];

/// Jurgalski dominance group (0 = D2 ... 7 = A1) of a dominance given as a
/// fraction (prominence / elevation); None for NaN or negative values.
pub fn dominance_group(dominance: f64) -> Option<u8> {
    if dominance.is_nan() || dominance < 0.0 {
        return None;
    }
    let pct = dominance * 100.0;
    let g = JURGALSKI_BOUNDS_PCT.iter().rposition(|&b| pct >= b)?;
    Some(g as u8)
}

/// Relevance of a peak within a domain (Argudo et al. 2019, "Orometry-based
/// terrain analysis and synthesis", ACM TOG 38(6), §4: the geometric mean of
/// relative prominence and relative elevation). Normalisation used here:
/// relative prominence = prominence / the largest prominence of the peaks in
/// the domain; relative elevation = (h − zmin) / (zmax − zmin) with zmin, zmax
/// the lowest and highest valid DEM cell of the domain. Both are clamped to
/// [0, 1]; a domain with no relief (zmax = zmin) or no prominence gives 0.
pub fn relevance(
    prominence: f64,
    max_prominence: f64,
    elevation: f64,
    zmin: f64,
    zmax: f64,
) -> f64 {
    let rp = if max_prominence > 0.0 {
        (prominence / max_prominence).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let re = normalised_elevation(elevation, zmin, zmax);
    (rp * re).sqrt()
}

/// (h − zmin) / (zmax − zmin), clamped to [0, 1]; 0 when zmax ≤ zmin.
pub fn normalised_elevation(elevation: f64, zmin: f64, zmax: f64) -> f64 {
    if zmax > zmin {
        ((elevation - zmin) / (zmax - zmin)).clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// Metrics of one peak of a tree (same index as `tree.peaks`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PeakMetrics {
    /// Index of the line parent (see [`line_parents`]).
    pub line_parent: Option<usize>,
    /// Distance (m) and bearing (degrees from north) from the peak to its key saddle.
    pub key_saddle_distance_m: Option<f64>,
    pub key_saddle_bearing_deg: Option<f64>,
    /// Jurgalski dominance group (see [`dominance_group`]).
    pub dominance_group: Option<u8>,
    /// See [`normalised_elevation`], over the whole DEM.
    pub normalised_elevation: Option<f64>,
    /// Prominence / the largest prominence of the tree.
    pub relative_prominence: f64,
    /// See [`relevance`], over the whole DEM.
    pub relevance: Option<f64>,
}

/// Line parents of every peak of `tree`, which must have been built from `dem`
/// (possibly pruned): the first peak at least as high as the peak met when
/// walking the divide tree from the peak through its key saddle (Kirmse &
/// de Ferranti 2017; the rule of their `compute_parents`: elevation ≥ the
/// peak's). The walk uses the ridge-adjacent divide tree recovered from the
/// DEM ([`Links`]): from a peak, cross its key saddle and climb by steepest
/// ascent to the peak on the far side; repeat from there. Peaks missing from
/// `tree` (pruned) are walked through, as pruning a peak from a divide tree
/// removes it from the path without changing the order of the others.
/// Peaks without key saddle have no line parent.
pub fn line_parents(tree: &DivideTree, dem: &Grid<f32>) -> Result<Vec<Option<usize>>> {
    let links = Links::new(dem)?;
    line_parents_with(tree, &links)
}

pub(crate) fn check_dims(tree: &DivideTree, w: usize, h: usize) -> Result<()> {
    if tree.width != w || tree.height != h {
        return Err(Error::invalid(format!(
            "divide tree is for a {} x {} grid but the DEM is {w} x {h}; give the DEM the tree was built from",
            tree.width, tree.height
        )));
    }
    Ok(())
}

/// Map from peak region to tree index (NONE if the region is not a tree peak).
pub(crate) fn tree_index(tree: &DivideTree, links: &Links) -> Vec<u32> {
    let w = links.reg.width;
    let mut idx = vec![NONE; links.reg.len()];
    for (i, p) in tree.peaks.iter().enumerate() {
        let r = links.region_of(p.row * w as u32 + p.col);
        if r != NONE {
            idx[r as usize] = i as u32;
        }
    }
    idx
}

pub(crate) fn line_parents_with(tree: &DivideTree, links: &Links) -> Result<Vec<Option<usize>>> {
    check_dims(tree, links.reg.width, links.reg.height)?;
    let idx = tree_index(tree, links);
    let w = links.reg.width as u32;
    let mut out = vec![None; tree.peaks.len()];
    for (i, p) in tree.peaks.iter().enumerate() {
        if p.key_saddle.is_none() {
            continue;
        }
        let start = links.region_of(p.row * w + p.col);
        if start == NONE {
            continue;
        }
        let mut cur = start;
        // Each step crosses a strictly earlier merge, so at most one step per event.
        for _ in 0..=links.events.len() {
            let Some(q) = links.ridge_next(cur) else {
                break;
            };
            let qi = idx[q as usize];
            if qi != NONE && links.reg.elev[q as usize] >= p.elevation && qi as usize != i {
                out[i] = Some(qi as usize);
                break;
            }
            cur = q;
        }
    }
    Ok(out)
}

/// All metrics of [`PeakMetrics`] for `tree`, built from `dem` with `georef`.
pub fn peak_metrics(
    tree: &DivideTree,
    dem: &Grid<f32>,
    georef: &GeoRef,
) -> Result<Vec<PeakMetrics>> {
    let links = Links::new(dem)?;
    let lp = line_parents_with(tree, &links)?;
    let (zmin, zmax) = dem_range(dem);
    let mut m = peak_metrics_without_dem(tree, georef, dem);
    let maxp = max_prominence(tree);
    for (i, pm) in m.iter_mut().enumerate() {
        pm.line_parent = lp[i];
        if let (Some(a), Some(b)) = (zmin, zmax) {
            let p = &tree.peaks[i];
            pm.normalised_elevation = Some(normalised_elevation(p.elevation as f64, a, b));
            pm.relevance = Some(relevance(p.prominence, maxp, p.elevation as f64, a, b));
        }
    }
    Ok(m)
}

fn max_prominence(tree: &DivideTree) -> f64 {
    tree.peaks
        .iter()
        .map(|p| p.prominence)
        .filter(|v| v.is_finite())
        .fold(0.0, f64::max)
}

/// Lowest and highest valid cell of a DEM (None if all nodata).
pub fn dem_range(dem: &Grid<f32>) -> (Option<f64>, Option<f64>) {
    let mut lo = f32::INFINITY;
    let mut hi = f32::NEG_INFINITY;
    for &z in dem.data() {
        if z.is_finite() {
            lo = lo.min(z);
            hi = hi.max(z);
        }
    }
    if lo > hi {
        (None, None)
    } else {
        (Some(lo as f64), Some(hi as f64))
    }
}

/// The metrics that need only the tree and the georeference (line parent and
/// relevance stay None). `dem` is used only for distance geometry.
fn peak_metrics_without_dem(
    tree: &DivideTree,
    georef: &GeoRef,
    dem: &Grid<f32>,
) -> Vec<PeakMetrics> {
    let geo = IsolationIndex::new(dem, georef);
    let maxp = max_prominence(tree);
    tree.peaks
        .iter()
        .map(|p| {
            let ks = geo.to_key_saddle(tree, p);
            PeakMetrics {
                line_parent: None,
                key_saddle_distance_m: ks.map(|k| k.0),
                key_saddle_bearing_deg: ks.map(|k| k.1),
                dominance_group: p.dominance().and_then(dominance_group),
                normalised_elevation: None,
                relative_prominence: if maxp > 0.0 { p.prominence / maxp } else { 0.0 },
                relevance: None,
            }
        })
        .collect()
}

/// Metrics computable without the DEM's cells (line parent, normalised
/// elevation and relevance stay None): for writers that only have the tree.
pub fn peak_metrics_tree_only(tree: &DivideTree, georef: &GeoRef) -> Vec<PeakMetrics> {
    // Distances need only the georeference; a 1 x 1 grid carries no cells.
    let tiny = Grid::new(1, 1, f32::NAN);
    peak_metrics_without_dem(tree, georef, &tiny)
}

/// A pit with its anti-prominence (prominence of the pit on the negated DEM).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Pit {
    pub col: u32,
    pub row: u32,
    /// Elevation of the pit floor.
    pub elevation: f32,
    /// Depth below its key saddle (the lowest rim over which it overflows
    /// into a deeper pit).
    pub anti_prominence: f64,
    /// Key saddle (col, row, elevation), None for the deepest pit of a connected area.
    pub key_saddle: Option<(u32, u32, f32)>,
}

/// Pits with anti-prominence ≥ `min_anti_prominence`, deepest first: the
/// divide tree of −h (Argudo et al. 2019 §4 mention anti-prominence; the
/// construction is the prominence of the negated surface). The outside of
/// the DEM is unknown ([`EdgeConvention::Unknown`]): on −h sea level has no
/// meaning, so the deepest pit of each area gets anti-prominence = the
/// area's relief (highest − lowest cell).
pub fn anti_prominence(dem: &Grid<f32>, min_anti_prominence: f64) -> Result<Vec<Pit>> {
    if !min_anti_prominence.is_finite() {
        return Err(Error::invalid(format!(
            "anti-prominence: the threshold must be finite, got {min_anti_prominence}"
        )));
    }
    let neg = dem.map(|z| -z);
    let t = super::divide_tree(&neg, EdgeConvention::Unknown)?.pruned(min_anti_prominence);
    Ok(t.peaks
        .iter()
        .map(|p| Pit {
            col: p.col,
            row: p.row,
            elevation: -p.elevation,
            anti_prominence: p.prominence,
            key_saddle: p
                .key_saddle
                .and_then(|s| t.saddles.get(s))
                .map(|s| (s.col, s.row, -s.elevation)),
        })
        .collect())
}

/// Nearest Neighbor Index of a point set (Clark & Evans 1954, "Distance to
/// nearest neighbor as a measure of spatial relationships in populations",
/// Ecology 35(4)).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Nni {
    pub n: usize,
    /// Mean distance to the nearest other point.
    pub mean_nn: f64,
    /// Expected mean for a Poisson process of the same density, 0.5 / √(n/A).
    pub expected: f64,
    /// mean_nn / expected: 1 random, < 1 clustered, 2 square lattice, 2.1491
    /// hexagonal lattice (the maximum).
    pub ratio: f64,
    /// Expected mean with Donnelly's edge correction (Donnelly 1978, in
    /// Hodder (ed.), *Simulation Methods in Archaeology*, pp. 91-95):
    /// 0.5 √(A/n) + (0.0514 + 0.041/√n) · P/n, P the domain's perimeter.
    pub expected_corrected: f64,
    /// mean_nn / expected_corrected.
    pub ratio_corrected: f64,
}

/// [`Nni`] of `points` (planar coordinates, metres) in a domain of `area`
/// and `perimeter`. Points at identical positions are nearest neighbours at
/// distance 0. None with fewer than 2 points or a non-positive area.
pub fn nearest_neighbor_index(points: &[(f64, f64)], area: f64, perimeter: f64) -> Option<Nni> {
    let n = points.len();
    let usable = area > 0.0 && area.is_finite();
    if n < 2 || !usable {
        return None;
    }
    let nn = nearest_distances(points);
    let mean_nn = nn.iter().sum::<f64>() / n as f64;
    let nf = n as f64;
    let expected = 0.5 * (area / nf).sqrt();
    let expected_corrected = expected + (0.0514 + 0.041 / nf.sqrt()) * perimeter.max(0.0) / nf;
    Some(Nni {
        n,
        mean_nn,
        expected,
        ratio: mean_nn / expected,
        expected_corrected,
        ratio_corrected: mean_nn / expected_corrected,
    })
}

/// Distance from each point to its nearest other point, by a uniform bucket
/// grid searched in growing rings (exact).
pub fn nearest_distances(points: &[(f64, f64)]) -> Vec<f64> {
    let n = points.len();
    if n < 2 {
        return vec![f64::INFINITY; n];
    }
    let (mut x0, mut y0, mut x1, mut y1) = (f64::MAX, f64::MAX, f64::MIN, f64::MIN);
    for &(x, y) in points {
        x0 = x0.min(x);
        y0 = y0.min(y);
        x1 = x1.max(x);
        y1 = y1.max(y);
    }
    let span = (x1 - x0).max(y1 - y0).max(1e-12);
    // About one point per bucket, at most 4096 buckets a side.
    let side = ((n as f64).sqrt().ceil() as usize).clamp(1, 4096);
    let cs = span / side as f64;
    let key = |v: f64, o: f64| (((v - o) / cs) as usize).min(side - 1);
    let mut start = vec![0u32; side * side + 1];
    for &(x, y) in points {
        start[key(y, y0) * side + key(x, x0) + 1] += 1;
    }
    for i in 0..side * side {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut items = vec![0u32; n];
    for (i, &(x, y)) in points.iter().enumerate() {
        let b = key(y, y0) * side + key(x, x0);
        items[fill[b] as usize] = i as u32;
        fill[b] += 1;
    }
    points
        .iter()
        .enumerate()
        .map(|(i, &(x, y))| {
            let (bx, by) = (key(x, x0) as i64, key(y, y0) as i64);
            let mut best = f64::INFINITY;
            for k in 0..=side as i64 {
                // Points in ring k are at least (k − 1)·cs away.
                if k >= 1 && (k - 1) as f64 * cs > best {
                    break;
                }
                for gy in (by - k)..=(by + k) {
                    if gy < 0 || gy >= side as i64 {
                        continue;
                    }
                    let edge = gy == by - k || gy == by + k;
                    let step = if edge { 1 } else { (2 * k).max(1) };
                    let mut gx = bx - k;
                    while gx <= bx + k {
                        if gx >= 0 && gx < side as i64 {
                            let b = gy as usize * side + gx as usize;
                            for &j in &items[start[b] as usize..start[b + 1] as usize] {
                                if j as usize != i {
                                    let (u, v) = points[j as usize];
                                    best = best.min((u - x).hypot(v - y));
                                }
                            }
                        }
                        gx += step;
                    }
                }
            }
            best
        })
        .collect()
}

/// Planar coordinates in metres for distances inside one DEM: projected CRSs
/// use map units × the linear unit; geographic CRSs an equirectangular
/// projection about the DEM's central latitude (sphere of mean radius
/// 6 371 008.8 m; the error over a 1° tile is below 1 %); without
/// georeferencing, cell units with y up.
#[derive(Debug, Clone)]
pub struct PlanarFrame {
    georef: GeoRef,
    kx: f64,
    ky: f64,
}

impl PlanarFrame {
    pub fn new(georef: &GeoRef, height: usize) -> PlanarFrame {
        let (kx, ky) = if !georef.georeferenced {
            (1.0, 1.0)
        } else if georef.crs.geographic {
            let (_, lat) = georef.pixel_to_map(0.0, height as f64 / 2.0);
            let r = 6_371_008.8f64.to_radians();
            (r * lat.to_radians().cos(), r)
        } else {
            (georef.crs.linear_unit_m, georef.crs.linear_unit_m)
        };
        PlanarFrame {
            georef: georef.clone(),
            kx,
            ky,
        }
    }

    /// Position of the centre of cell (col, row), metres.
    pub fn xy(&self, col: f64, row: f64) -> (f64, f64) {
        if !self.georef.georeferenced {
            return (col + 0.5, -(row + 0.5));
        }
        let (x, y) = self.georef.pixel_to_map(col + 0.5, row + 0.5);
        (x * self.kx, y * self.ky)
    }

    /// Fractional (col, row) of the cell whose centre is at planar (x, y).
    pub fn to_pixel(&self, x: f64, y: f64) -> Option<(f64, f64)> {
        if !self.georef.georeferenced {
            return Some((x - 0.5, -y - 0.5));
        }
        let (c, r) = self.georef.map_to_pixel(x / self.kx, y / self.ky)?;
        Some((c - 0.5, r - 0.5))
    }

    /// Planar size (m) of one cell step along columns and rows at `row`.
    pub fn cell_size_m(&self, row: f64) -> (f64, f64) {
        let (a, b) = self.xy(0.0, row);
        let (c, d) = self.xy(1.0, row);
        let (e, f) = self.xy(0.0, row + 1.0);
        ((c - a).hypot(d - b), (e - a).hypot(f - b))
    }
}
