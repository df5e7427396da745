//! Writers: peaks.csv and GeoJSON for peaks, saddles and the divide tree.
//! Coordinates are cell centres in the DEM's CRS (longitude/latitude for
//! geographic CRSs, as RFC 7946 GeoJSON expects; projected x/y otherwise).

use super::tree::DivideTree;
use crate::error::{Error, Result};
use crate::raster::GeoRef;
use serde_json::{json, Value};
use std::io::Write;
use std::path::Path;

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
pub fn write_peaks_csv(path: &Path, tree: &DivideTree, georef: &GeoRef) -> Result<()> {
    let geo = georef.georeferenced && georef.crs.geographic;
    let mut out = String::new();
    out.push_str(if geo {
        "lat,lon,elevation,prominence,saddle_lat,saddle_lon,saddle_elevation,isolation_km,dominance,col,row,parent\n"
    } else {
        "y,x,elevation,prominence,saddle_y,saddle_x,saddle_elevation,isolation_km,dominance,col,row,parent\n"
    });
    for p in &tree.peaks {
        let (x, y) = centre(georef, p.col, p.row);
        let (sy, sx, se) = match p.key_saddle.and_then(|s| tree.saddles.get(s)) {
            Some(s) => {
                let (sx, sy) = centre(georef, s.col, s.row);
                (format!("{sy}"), format!("{sx}"), format!("{}", s.elevation))
            }
            None => (String::new(), String::new(), String::new()),
        };
        out.push_str(&format!(
            "{y},{x},{},{},{sy},{sx},{se},{},{},{},{},{}\n",
            p.elevation,
            p.prominence,
            opt(p.isolation.map(|i| i.distance_m / 1000.0)),
            opt(p.dominance()),
            p.col,
            p.row,
            p.parent.map(|q| q.to_string()).unwrap_or_default()
        ));
    }
    write(path, out.as_bytes())
}

fn write(path: &Path, bytes: &[u8]) -> Result<()> {
    let mut f = std::fs::File::create(path).map_err(|e| Error::io(path, e))?;
    f.write_all(bytes).map_err(|e| Error::io(path, e))?;
    f.flush().map_err(|e| Error::io(path, e))
}

fn collection(features: Vec<Value>) -> Vec<u8> {
    serde_json::to_vec(&json!({"type": "FeatureCollection", "features": features}))
        .expect("GeoJSON of finite numbers serialises")
}

/// Finite numbers only in JSON: NaN/inf become null.
fn num(v: f64) -> Value {
    serde_json::Number::from_f64(v)
        .map(Value::Number)
        .unwrap_or(Value::Null)
}

/// peaks.geojson: Points with elevation, prominence, key saddle elevation,
/// isolation (km), dominance, parent index.
pub fn write_peaks_geojson(path: &Path, tree: &DivideTree, georef: &GeoRef) -> Result<()> {
    let feats = tree
        .peaks
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let (x, y) = centre(georef, p.col, p.row);
            json!({
                "type": "Feature",
                "geometry": {"type": "Point", "coordinates": [num(x), num(y)]},
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
                }
            })
        })
        .collect();
    write(path, &collection(feats))
}

/// saddles.geojson: Points of the key saddles, with the peak they are the key
/// saddle of and its parent.
pub fn write_saddles_geojson(path: &Path, tree: &DivideTree, georef: &GeoRef) -> Result<()> {
    let feats = tree
        .peaks
        .iter()
        .enumerate()
        .filter_map(|(i, p)| {
            let s = tree.saddles.get(p.key_saddle?)?;
            let (x, y) = centre(georef, s.col, s.row);
            Some(json!({
                "type": "Feature",
                "geometry": {"type": "Point", "coordinates": [num(x), num(y)]},
                "properties": {
                    "elevation": num(s.elevation as f64),
                    "peak": i,
                    "parent": p.parent,
                    "col": s.col,
                    "row": s.row,
                }
            }))
        })
        .collect();
    write(path, &collection(feats))
}

/// divide_tree.geojson: one LineString peak → key saddle → parent per edge.
pub fn write_divide_tree_geojson(path: &Path, tree: &DivideTree, georef: &GeoRef) -> Result<()> {
    let feats = tree
        .peaks
        .iter()
        .enumerate()
        .filter_map(|(i, p)| {
            let s = tree.saddles.get(p.key_saddle?)?;
            let q = tree.peaks.get(p.parent?)?;
            let pts: Vec<Value> = [(p.col, p.row), (s.col, s.row), (q.col, q.row)]
                .iter()
                .map(|&(c, r)| {
                    let (x, y) = centre(georef, c, r);
                    json!([num(x), num(y)])
                })
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
        .collect();
    write(path, &collection(feats))
}
