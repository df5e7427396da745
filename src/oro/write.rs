//! Writers: peaks.csv and GeoJSON for peaks, saddles and the divide tree.
//! Coordinates are cell centres. peaks.csv has them in the DEM's CRS
//! (longitude/latitude for geographic CRSs; projected x/y otherwise); the
//! GeoJSON files as a [`GeoJsonCoords`] says: WGS 84 longitude/latitude
//! (RFC 7946 §4) by default, or the DEM's CRS named in a `crs` member (see
//! [`crate::io::geojson`]). Properties are the same either way.

use super::metrics::{peak_metrics, peak_metrics_tree_only, PeakMetrics};
use super::tree::{DivideTree, Peak, Saddle};
use super::PeakList;
use crate::error::{Error, Result};
use crate::io::geojson::GeoJsonCoords;
use crate::raster::{GeoRef, Grid};
use serde_json::{json, Value};
use std::path::{Path, PathBuf};

fn centre(g: &GeoRef, col: u32, row: u32) -> (f64, f64) {
    g.pixel_to_map(col as f64 + 0.5, row as f64 + 0.5)
}

fn opt(v: Option<f64>) -> String {
    v.map(|x| format!("{x}")).unwrap_or_default()
}

/// peaks.csv: one line per peak, in the tree's order (decreasing elevation).
/// Columns `lat,lon,elevation,prominence,saddle_lat,saddle_lon,saddle_elevation,
/// isolation_km,dominance,col,row,parent` (`y,x,...,saddle_y,saddle_x` for
/// projected CRSs); empty fields where there is no key saddle, isolation,
/// dominance or parent. `parent` is the 0-based line number of the parent.
/// Then the columns of [`PeakMetrics`] ([`EXTRA_COLUMNS`]): those that need the
/// DEM (`line_parent`, `normalised_elevation`, `relevance`) are empty here;
/// [`write_peaks_csv_with`] fills them.
pub fn write_peaks_csv(path: &Path, tree: &DivideTree, georef: &GeoRef) -> Result<()> {
    write_peaks_csv_with(path, tree, georef, &peak_metrics_tree_only(tree, georef))
}

/// Columns appended to peaks.csv after `parent`: line parent (0-based line
/// number), Jurgalski dominance group (0 = D2 ... 7 = A1), key-saddle distance
/// (km) and bearing (degrees from north), isolation bearing, normalised
/// elevation, relative prominence, relevance (see [`super::metrics`]).
pub const EXTRA_COLUMNS: &str = "line_parent,dominance_group,key_saddle_km,key_saddle_bearing,isolation_bearing,normalised_elevation,relative_prominence,relevance";

/// peaks.csv with the metrics `m` (one per peak, from [`peak_metrics`]).
pub fn write_peaks_csv_with(
    path: &Path,
    tree: &DivideTree,
    georef: &GeoRef,
    m: &[PeakMetrics],
) -> Result<()> {
    write(path, peaks_csv_text(tree, georef, m)?.as_bytes())
}

/// The text of peaks.csv with the metrics `m` (one per peak, from
/// [`peak_metrics`]): a header line, then one line per peak.
pub fn peaks_csv_text(tree: &DivideTree, georef: &GeoRef, m: &[PeakMetrics]) -> Result<String> {
    check_len(tree, m)?;
    let geo = georef.georeferenced && georef.crs.geographic;
    let mut out = String::new();
    out.push_str(if geo {
        "lat,lon,elevation,prominence,saddle_lat,saddle_lon,saddle_elevation,isolation_km,dominance,col,row,parent,"
    } else {
        "y,x,elevation,prominence,saddle_y,saddle_x,saddle_elevation,isolation_km,dominance,col,row,parent,"
    });
    out.push_str(EXTRA_COLUMNS);
    out.push('\n');
    for (p, pm) in tree.peaks.iter().zip(m) {
        let (x, y) = centre(georef, p.col, p.row);
        let (sy, sx, se) = match p.key_saddle.and_then(|s| tree.saddles.get(s)) {
            Some(s) => {
                let (sx, sy) = centre(georef, s.col, s.row);
                (format!("{sy}"), format!("{sx}"), format!("{}", s.elevation))
            }
            None => (String::new(), String::new(), String::new()),
        };
        out.push_str(&format!(
            "{y},{x},{},{},{sy},{sx},{se},{},{},{},{},{},{},{},{},{},{},{},{},{}\n",
            p.elevation,
            p.prominence,
            opt(p.isolation.map(|i| i.distance_m / 1000.0)),
            opt(p.dominance()),
            p.col,
            p.row,
            p.parent.map(|q| q.to_string()).unwrap_or_default(),
            pm.line_parent.map(|q| q.to_string()).unwrap_or_default(),
            pm.dominance_group
                .map(|q| q.to_string())
                .unwrap_or_default(),
            opt(pm.key_saddle_distance_m.map(|d| d / 1000.0)),
            opt(pm.key_saddle_bearing_deg),
            opt(p.isolation.map(|i| i.bearing_deg)),
            opt(pm.normalised_elevation),
            pm.relative_prominence,
            opt(pm.relevance),
        ));
    }
    Ok(out)
}

fn check_len(tree: &DivideTree, m: &[PeakMetrics]) -> Result<()> {
    if m.len() != tree.peaks.len() {
        return Err(Error::invalid(format!(
            "peak metrics: {} values for {} peaks; compute them from this tree",
            m.len(),
            tree.peaks.len()
        )));
    }
    Ok(())
}

impl PeakList {
    /// Like [`PeakList::write_all`], with the DEM the list was computed from,
    /// so that peaks.csv and peaks.geojson also carry line parents,
    /// normalised elevation and relevance.
    pub fn write_all_with_dem(
        &self,
        dir: &Path,
        dem: &Grid<f32>,
        coords: &GeoJsonCoords,
    ) -> Result<Vec<PathBuf>> {
        let m = peak_metrics(&self.tree, dem, &self.georef)?;
        self.write_files(dir, &m, coords)
    }

    /// The text of peaks.csv, as [`PeakList::write_all`] (`dem` `None`) or
    /// [`PeakList::write_all_with_dem`] writes it.
    pub fn csv_text(&self, dem: Option<&Grid<f32>>) -> Result<String> {
        let m = match dem {
            Some(g) => peak_metrics(&self.tree, g, &self.georef)?,
            None => super::metrics::peak_metrics_tree_only(&self.tree, &self.georef),
        };
        peaks_csv_text(&self.tree, &self.georef, &m)
    }
}

/// Every output of this module is written atomically (temporary, then rename).
fn write(path: &Path, bytes: &[u8]) -> Result<()> {
    crate::io::atomic::write_file_atomic(path, bytes)
}

fn collection(coords: &GeoJsonCoords, features: Vec<Value>) -> Vec<u8> {
    serde_json::to_vec(&coords.collection(features)).expect("GeoJSON of finite numbers serialises")
}

/// The GeoJSON coordinates of the centre of cell (`col`, `row`).
fn point(coords: &GeoJsonCoords, col: u32, row: u32) -> Value {
    let [x, y] = coords.pixel(col as f64 + 0.5, row as f64 + 0.5);
    json!([num(x), num(y)])
}

/// A FeatureCollection with `feature(i, peak, key saddle)` for each peak of
/// `tree` that has a key saddle (and for which it returns one), written to `path`.
fn write_key_saddle_features(
    path: &Path,
    tree: &DivideTree,
    coords: &GeoJsonCoords,
    feature: impl Fn(usize, &Peak, &Saddle) -> Option<Value>,
) -> Result<()> {
    let feats = tree
        .peaks
        .iter()
        .enumerate()
        .filter_map(|(i, p)| feature(i, p, tree.saddles.get(p.key_saddle?)?))
        .collect();
    write(path, &collection(coords, feats))
}

/// Finite numbers only in JSON: NaN/inf become null.
fn num(v: f64) -> Value {
    serde_json::Number::from_f64(v)
        .map(Value::Number)
        .unwrap_or(Value::Null)
}

/// peaks.geojson: Points with elevation, prominence, key saddle elevation,
/// isolation (km), dominance, parent index, and the tree-only metrics of
/// [`EXTRA_COLUMNS`] (see [`write_peaks_geojson_with`] for all of them).
pub fn write_peaks_geojson(
    path: &Path,
    tree: &DivideTree,
    georef: &GeoRef,
    coords: &GeoJsonCoords,
) -> Result<()> {
    write_peaks_geojson_with(path, tree, coords, &peak_metrics_tree_only(tree, georef))
}

/// peaks.geojson with the metrics `m` (one per peak) as extra properties.
pub fn write_peaks_geojson_with(
    path: &Path,
    tree: &DivideTree,
    coords: &GeoJsonCoords,
    m: &[PeakMetrics],
) -> Result<()> {
    check_len(tree, m)?;
    let feats = tree
        .peaks
        .iter()
        .zip(m)
        .enumerate()
        .map(|(i, (p, pm))| {
            json!({
                "type": "Feature",
                "geometry": {"type": "Point", "coordinates": point(coords, p.col, p.row)},
                "properties": {
                    "id": i,
                    "elevation": num(p.elevation as f64),
                    "prominence": num(p.prominence),
                    "saddle_elevation": p.key_saddle.and_then(|s| tree.saddles.get(s)).map(|s| num(s.elevation as f64)),
                    "isolation_km": p.isolation.map(|s| num(s.distance_m / 1000.0)),
                    "dominance": p.dominance().map(num),
                    "parent": p.parent,
                    "col": p.col,
                    "row": p.row,
                    "line_parent": pm.line_parent,
                    "dominance_group": pm.dominance_group,
                    "key_saddle_km": pm.key_saddle_distance_m.map(|d| num(d / 1000.0)),
                    "key_saddle_bearing": pm.key_saddle_bearing_deg.map(num),
                    "isolation_bearing": p.isolation.map(|s| num(s.bearing_deg)),
                    "normalised_elevation": pm.normalised_elevation.map(num),
                    "relative_prominence": num(pm.relative_prominence),
                    "relevance": pm.relevance.map(num),
                }
            })
        })
        .collect();
    write(path, &collection(coords, feats))
}

/// saddles.geojson: Points of the key saddles, with the peak they are the key
/// saddle of and its parent.
pub fn write_saddles_geojson(path: &Path, tree: &DivideTree, coords: &GeoJsonCoords) -> Result<()> {
    write_key_saddle_features(path, tree, coords, |i, p, s| {
        Some(json!({
            "type": "Feature",
            "geometry": {"type": "Point", "coordinates": point(coords, s.col, s.row)},
            "properties": {
                "elevation": num(s.elevation as f64),
                "peak": i,
                "parent": p.parent,
                "col": s.col,
                "row": s.row,
            }
        }))
    })
}

/// divide_tree.geojson: one LineString peak → key saddle → parent per edge.
pub fn write_divide_tree_geojson(
    path: &Path,
    tree: &DivideTree,
    coords: &GeoJsonCoords,
) -> Result<()> {
    write_key_saddle_features(path, tree, coords, |i, p, s| {
        let q = tree.peaks.get(p.parent?)?;
        let pts: Vec<Value> = [(p.col, p.row), (s.col, s.row), (q.col, q.row)]
            .iter()
            .map(|&(c, r)| point(coords, c, r))
            .collect();
        Some(json!({
            "type": "Feature",
            "geometry": {"type": "LineString", "coordinates": pts},
            "properties": {
                "peak": i,
                "parent": p.parent,
                "peak_elevation": num(p.elevation as f64),
                "saddle_elevation": num(s.elevation as f64),
                "prominence": num(p.prominence),
            }
        }))
    })
}
