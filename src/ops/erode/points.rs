//! Fixed points of constrained erosion (`--fixed-points`): cells read from a
//! CSV (`col,row` cells, as in orogen's peaks.csv with its key saddles, or
//! `x,y` / `lon,lat` map coordinates) or a GeoJSON file (Point, MultiPoint,
//! LineString vertices; in the DEM's CRS unless the file has a `crs` member,
//! see [`crate::io::geojson::input_crs`], so the `--geojson-crs native`
//! outputs of `orogen peaks` read back as they are).

use crate::error::{Error, Result};
use crate::ops::note::{bail, Note, Notify};
use crate::raster::{GeoRef, Grid};
use std::path::Path;

/// Most fixed points accepted from a file (the compensation is per point).
const MAX_FIXED_POINTS: usize = 1_000_000;
/// Largest fixed-point file read.
const MAX_FIXED_FILE: u64 = 256 << 20;

/// Read fixed points from CSV or GeoJSON as (column, row) cells of `h`; points
/// outside the DEM or on nodata are skipped with a warning count.
pub fn read_fixed_points(
    path: &Path,
    georef: &GeoRef,
    h: &Grid<f64>,
    notify: Notify<'_>,
) -> Result<Vec<(usize, usize)>> {
    let unreadable = |e: std::io::Error| {
        Error::invalid(format!(
            "{}: cannot read the fixed points: {e}",
            path.display()
        ))
    };
    let len = std::fs::metadata(path).map_err(unreadable)?.len();
    if len > MAX_FIXED_FILE {
        bail!(
            "{}: {} bytes is too large for a fixed-point file (limit {} MiB)",
            path.display(),
            len,
            MAX_FIXED_FILE >> 20
        );
    }
    let text = std::fs::read_to_string(path).map_err(unreadable)?;
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    // Points as fractional (col, row) pixel coordinates.
    let mut px: Vec<(f64, f64)> = Vec::new();
    let to_px = |x: f64, y: f64| -> Result<(f64, f64)> {
        georef.map_to_pixel(x, y).ok_or_else(|| {
            Error::invalid(format!(
                "{}: the DEM's georeference cannot place map coordinates",
                path.display()
            ))
        })
    };
    if ext == "geojson" || ext == "json" {
        let v: serde_json::Value = serde_json::from_str(&text)
            .map_err(|e| Error::invalid(format!("{}: not valid JSON: {e}", path.display())))?;
        // In the DEM's CRS unless a `crs` member says otherwise.
        let crs = crate::io::geojson::input_crs(&v, path)?;
        let to_map = crate::io::geojson::input_to_map(crs, georef, path)?;
        let mut coords = Vec::new();
        collect_geojson(&v, &mut coords, 0);
        for (x, y) in coords {
            let (x, y) = to_map(x, y);
            px.push(to_px(x, y)?);
        }
    } else if ext == "csv" {
        let mut lines = text.lines();
        let header: Vec<String> = lines
            .next()
            .ok_or_else(|| Error::invalid(format!("{}: empty CSV", path.display())))?
            .split(',')
            .map(|s| s.trim().to_ascii_lowercase())
            .collect();
        let col = |n: &str| header.iter().position(|h| h == n);
        let pairs: Vec<(usize, usize, bool)> = if let (Some(c), Some(r)) = (col("col"), col("row"))
        {
            let mut v = vec![(c, r, true)];
            for (sx, sy) in [("saddle_x", "saddle_y"), ("saddle_lon", "saddle_lat")] {
                if let (Some(a), Some(b)) = (col(sx), col(sy)) {
                    v.push((a, b, false));
                }
            }
            v
        } else if let (Some(a), Some(b)) = (col("x"), col("y")) {
            vec![(a, b, false)]
        } else if let (Some(a), Some(b)) = (col("lon"), col("lat")) {
            vec![(a, b, false)]
        } else {
            bail!(
                "{}: the CSV needs col,row columns (0-based cells) or x,y (or lon,lat) map coordinates",
                path.display()
            );
        };
        for (ln, line) in lines.enumerate() {
            if line.trim().is_empty() {
                continue;
            }
            let f: Vec<&str> = line.split(',').collect();
            for &(a, b, cells) in &pairs {
                let (sa, sb) = (
                    f.get(a).map(|s| s.trim()).unwrap_or(""),
                    f.get(b).map(|s| s.trim()).unwrap_or(""),
                );
                if sa.is_empty() && sb.is_empty() && !cells {
                    continue; // a peak without key saddle
                }
                let parse = |s: &str| -> Result<f64> {
                    s.parse::<f64>().map_err(|e| {
                        Error::invalid(format!(
                            "{} line {}: {s:?} is not a number: {e}",
                            path.display(),
                            ln + 2
                        ))
                    })
                };
                let (va, vb) = (parse(sa)?, parse(sb)?);
                if cells {
                    px.push((va + 0.5, vb + 0.5));
                } else {
                    px.push(to_px(va, vb)?);
                }
            }
            if px.len() > MAX_FIXED_POINTS {
                bail!(
                    "{}: more than {MAX_FIXED_POINTS} fixed points",
                    path.display()
                );
            }
        }
    } else {
        bail!(
            "{}: fixed points must be a .csv or .geojson file",
            path.display()
        );
    }
    let mut out = Vec::new();
    let mut skipped = 0usize;
    for (fx, fy) in px {
        if !(fx.is_finite() && fy.is_finite()) || fx < 0.0 || fy < 0.0 {
            skipped += 1;
            continue;
        }
        let (x, y) = (fx.floor() as usize, fy.floor() as usize);
        if x >= h.width() || y >= h.height() || !h.get(x, y).is_finite() {
            skipped += 1;
            continue;
        }
        out.push((x, y));
    }
    if out.len() > MAX_FIXED_POINTS {
        bail!(
            "{}: more than {MAX_FIXED_POINTS} fixed points",
            path.display()
        );
    }
    out.sort_unstable();
    out.dedup();
    if skipped > 0 {
        notify(Note::Warning(format!(
            "{}: {skipped} fixed point(s) outside the DEM or on nodata were skipped",
            path.display()
        )));
    }
    if out.is_empty() {
        bail!("{}: no fixed point falls on the DEM", path.display());
    }
    Ok(out)
}

/// Gather every coordinate pair of Points, MultiPoints and LineStrings.
fn collect_geojson(v: &serde_json::Value, out: &mut Vec<(f64, f64)>, depth: usize) {
    if depth > 8 || out.len() > MAX_FIXED_POINTS {
        return;
    }
    let pair = |c: &serde_json::Value| -> Option<(f64, f64)> {
        let a = c.as_array()?;
        Some((a.first()?.as_f64()?, a.get(1)?.as_f64()?))
    };
    match v.get("type").and_then(|t| t.as_str()) {
        Some("FeatureCollection") => {
            if let Some(fs) = v.get("features").and_then(|f| f.as_array()) {
                for f in fs {
                    collect_geojson(f, out, depth + 1);
                }
            }
        }
        Some("Feature") => {
            if let Some(g) = v.get("geometry") {
                collect_geojson(g, out, depth + 1);
            }
        }
        Some("Point") => {
            if let Some(p) = v.get("coordinates").and_then(pair) {
                out.push(p);
            }
        }
        Some("MultiPoint") | Some("LineString") => {
            if let Some(cs) = v.get("coordinates").and_then(|c| c.as_array()) {
                out.extend(cs.iter().filter_map(pair));
            }
        }
        _ => {}
    }
}
