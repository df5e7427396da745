//! Vector maps for terrain synthesis: a GeoJSON `FeatureCollection` of
//! coastline polygons, river polylines and peak points (RFC 7946 geometry
//! objects; the CRS member is ignored, coordinates are taken as given).
//!
//! Format (example: `configs/tectonic-map.geojson`):
//! - `Polygon` / `MultiPolygon`: coastlines. Land is the inside of the outer
//!   rings (even-odd over all rings, so rings must not overlap); interior rings
//!   (holes, i.e. lakes) are refused. A ring must be closed (first point =
//!   last), have at least 3 distinct points and must not cross or touch
//!   itself ([`ring_self_intersection`]).
//! - `LineString` / `MultiLineString`: rivers (at least 2 points each).
//! - `Point` / `MultiPoint`: peaks; an optional numeric property `elevation`
//!   (metres) sets the peak's height.
//! - A feature's optional string property `kind` (`coast`, `river`, `peak`)
//!   must agree with its geometry when present.
//!
//! Coordinates are in the output CRS (metres, x east, y north) unless the
//! caller converts them otherwise (the CLI's `--map-units pixels`). Every
//! coordinate must be finite. Limits (checked before allocating): the file at
//! most [`MAX_FILE_BYTES`], at most [`MAX_VERTICES`] vertices in total.

use crate::error::{Error, Result};
use serde_json::Value;
use std::path::{Path, PathBuf};

/// Largest map file read.
pub const MAX_FILE_BYTES: u64 = 256 << 20;
/// Largest total number of vertices.
pub const MAX_VERTICES: usize = 5_000_000;

/// A peak of a vector map.
#[derive(Debug, Clone, PartialEq)]
pub struct MapPeak {
    /// Position (x, y).
    pub pos: [f64; 2],
    /// Elevation (m) if the feature gave one.
    pub elevation: Option<f64>,
}

/// A vector map: coastlines (closed rings, the closing point dropped),
/// rivers (polylines) and peaks.
#[derive(Debug, Clone, Default)]
pub struct VectorMap {
    pub coasts: Vec<Vec<[f64; 2]>>,
    pub rivers: Vec<Vec<[f64; 2]>>,
    pub peaks: Vec<MapPeak>,
    /// The file it came from (for error messages).
    pub path: PathBuf,
}

impl VectorMap {
    /// Read and validate a GeoJSON map file.
    pub fn read(path: &Path) -> Result<VectorMap> {
        let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
        if meta.len() > MAX_FILE_BYTES {
            return Err(Error::too_large(
                path,
                format!(
                    "map file of {} bytes; at most {} MiB are read (simplify the geometry)",
                    meta.len(),
                    MAX_FILE_BYTES >> 20
                ),
            ));
        }
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        Self::parse(&text, path)
    }

    /// Parse and validate GeoJSON text (`path` names it in errors).
    pub fn parse(text: &str, path: &Path) -> Result<VectorMap> {
        let bad = |m: String| Error::corrupt(path, m);
        let root: Value = serde_json::from_str(text).map_err(|e| {
            bad(format!(
                "not valid JSON ({e}); expected a GeoJSON FeatureCollection"
            ))
        })?;
        let features: Vec<&Value> = match root.get("type").and_then(Value::as_str) {
            Some("FeatureCollection") => root
                .get("features")
                .and_then(Value::as_array)
                .ok_or_else(|| bad("FeatureCollection without a \"features\" array".into()))?
                .iter()
                .collect(),
            Some("Feature") => vec![&root],
            Some(t) => {
                return Err(bad(format!(
                    "top-level type {t:?}; expected a GeoJSON FeatureCollection"
                )))
            }
            None => {
                return Err(bad(
                    "no top-level \"type\"; expected a GeoJSON FeatureCollection".into(),
                ))
            }
        };
        let mut map = VectorMap {
            path: path.to_path_buf(),
            ..Default::default()
        };
        let mut vertices = 0usize;
        for (fi, f) in features.iter().enumerate() {
            let ctx = |m: &str| bad(format!("feature {fi}: {m}"));
            if f.get("type").and_then(Value::as_str) != Some("Feature") {
                return Err(ctx("not a GeoJSON Feature"));
            }
            let geom = f
                .get("geometry")
                .filter(|g| !g.is_null())
                .ok_or_else(|| ctx("has no geometry"))?;
            let gtype = geom
                .get("type")
                .and_then(Value::as_str)
                .ok_or_else(|| ctx("geometry without a \"type\""))?;
            let coords = geom
                .get("coordinates")
                .ok_or_else(|| ctx("geometry without \"coordinates\""))?;
            let props = f.get("properties").filter(|p| p.is_object());
            let kind = props.and_then(|p| p.get("kind")).and_then(Value::as_str);
            let want = match gtype {
                "Polygon" | "MultiPolygon" => "coast",
                "LineString" | "MultiLineString" => "river",
                "Point" | "MultiPoint" => "peak",
                t => {
                    return Err(ctx(&format!(
                        "geometry type {t:?} is not used (Polygon = coastline, LineString = river, Point = peak)"
                    )))
                }
            };
            if let Some(k) = kind {
                if k != want {
                    return Err(ctx(&format!(
                        "property kind {k:?} does not match its {gtype} geometry (a {want})"
                    )));
                }
            }
            let mut count = |n: usize| -> Result<()> {
                vertices += n;
                if vertices > MAX_VERTICES {
                    return Err(Error::too_large(
                        path,
                        format!("more than {MAX_VERTICES} vertices; simplify the map"),
                    ));
                }
                Ok(())
            };
            match gtype {
                "Point" => {
                    count(1)?;
                    map.peaks.push(peak(coords, props).map_err(|m| ctx(&m))?);
                }
                "MultiPoint" => {
                    for c in array(coords).map_err(|m| ctx(&m))? {
                        count(1)?;
                        map.peaks.push(peak(c, props).map_err(|m| ctx(&m))?);
                    }
                }
                "LineString" => {
                    let l = line(coords).map_err(|m| ctx(&m))?;
                    count(l.len())?;
                    map.rivers.push(l);
                }
                "MultiLineString" => {
                    for c in array(coords).map_err(|m| ctx(&m))? {
                        let l = line(c).map_err(|m| ctx(&m))?;
                        count(l.len())?;
                        map.rivers.push(l);
                    }
                }
                "Polygon" => {
                    let r = polygon(coords).map_err(|m| ctx(&m))?;
                    count(r.len())?;
                    map.coasts.push(r);
                }
                _ => {
                    for c in array(coords).map_err(|m| ctx(&m))? {
                        let r = polygon(c).map_err(|m| ctx(&m))?;
                        count(r.len())?;
                        map.coasts.push(r);
                    }
                }
            }
        }
        for (i, ring) in map.coasts.iter().enumerate() {
            if let Some((a, b, p)) = ring_self_intersection(ring) {
                return Err(bad(format!(
                    "coastline {i} crosses itself: edges {a} and {b} meet near ({:.3}, {:.3}); fix the polygon (e.g. with a GIS 'make valid' tool)",
                    p[0], p[1]
                )));
            }
        }
        Ok(map)
    }

    /// Bounding box `[xmin, ymin, xmax, ymax]` of all geometry, `None` if empty.
    pub fn bbox(&self) -> Option<[f64; 4]> {
        let mut b = [
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
        ];
        let pts = self
            .coasts
            .iter()
            .flatten()
            .chain(self.rivers.iter().flatten())
            .chain(self.peaks.iter().map(|p| &p.pos));
        let mut any = false;
        for p in pts {
            any = true;
            b[0] = b[0].min(p[0]);
            b[1] = b[1].min(p[1]);
            b[2] = b[2].max(p[0]);
            b[3] = b[3].max(p[1]);
        }
        any.then_some(b)
    }

    /// The same map with every coordinate transformed by `f`.
    pub fn transformed(&self, f: impl Fn([f64; 2]) -> [f64; 2]) -> VectorMap {
        VectorMap {
            coasts: self
                .coasts
                .iter()
                .map(|r| r.iter().map(|&p| f(p)).collect())
                .collect(),
            rivers: self
                .rivers
                .iter()
                .map(|r| r.iter().map(|&p| f(p)).collect())
                .collect(),
            peaks: self
                .peaks
                .iter()
                .map(|p| MapPeak {
                    pos: f(p.pos),
                    elevation: p.elevation,
                })
                .collect(),
            path: self.path.clone(),
        }
    }
}

fn array(v: &Value) -> std::result::Result<&Vec<Value>, String> {
    v.as_array()
        .ok_or_else(|| "coordinates are not an array".to_string())
}

fn position(v: &Value) -> std::result::Result<[f64; 2], String> {
    let a = array(v)?;
    if a.len() < 2 {
        return Err("a position needs two numbers [x, y]".into());
    }
    let x = a[0].as_f64();
    let y = a[1].as_f64();
    match (x, y) {
        (Some(x), Some(y)) if x.is_finite() && y.is_finite() => Ok([x, y]),
        _ => Err(format!("position {v} is not two finite numbers")),
    }
}

fn peak(v: &Value, props: Option<&Value>) -> std::result::Result<MapPeak, String> {
    let pos = position(v)?;
    let elevation = match props.and_then(|p| p.get("elevation")) {
        None | Some(Value::Null) => None,
        Some(e) => match e.as_f64() {
            Some(z) if z.is_finite() && z.abs() < 1e5 => Some(z),
            _ => return Err(format!("peak elevation {e} is not a number of metres")),
        },
    };
    Ok(MapPeak { pos, elevation })
}

fn line(v: &Value) -> std::result::Result<Vec<[f64; 2]>, String> {
    let pts = array(v)?
        .iter()
        .map(position)
        .collect::<std::result::Result<Vec<_>, _>>()?;
    if pts.len() < 2 {
        return Err("a river needs at least 2 points".into());
    }
    Ok(pts)
}

fn polygon(v: &Value) -> std::result::Result<Vec<[f64; 2]>, String> {
    let rings = array(v)?;
    if rings.is_empty() {
        return Err("a polygon needs an outer ring".into());
    }
    if rings.len() > 1 {
        return Err(
            "coastline polygons with holes (lakes) are not supported; give the outer ring only"
                .into(),
        );
    }
    let mut r = array(&rings[0])?
        .iter()
        .map(position)
        .collect::<std::result::Result<Vec<_>, _>>()?;
    if r.len() < 4 || r.first() != r.last() {
        return Err(
            "a coastline ring must be closed (first point = last) with at least 3 distinct points"
                .into(),
        );
    }
    r.pop();
    r.dedup();
    if r.len() < 3 {
        return Err("a coastline ring needs at least 3 distinct points".into());
    }
    Ok(r)
}

/// Sign of the cross product (b − a) × (c − a).
fn orient(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

fn on_segment(a: [f64; 2], b: [f64; 2], p: [f64; 2]) -> bool {
    p[0] >= a[0].min(b[0])
        && p[0] <= a[0].max(b[0])
        && p[1] >= a[1].min(b[1])
        && p[1] <= a[1].max(b[1])
}

/// True if closed segments ab and cd share a point (standard orientation test,
/// Cormen et al., *Introduction to Algorithms*, §33.1).
pub fn segments_intersect(a: [f64; 2], b: [f64; 2], c: [f64; 2], d: [f64; 2]) -> bool {
    let d1 = orient(c, d, a);
    let d2 = orient(c, d, b);
    let d3 = orient(a, b, c);
    let d4 = orient(a, b, d);
    if ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0))
        && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0))
    {
        return true;
    }
    (d1 == 0.0 && on_segment(c, d, a))
        || (d2 == 0.0 && on_segment(c, d, b))
        || (d3 == 0.0 && on_segment(a, b, c))
        || (d4 == 0.0 && on_segment(a, b, d))
}

/// First pair of non-adjacent edges of a closed ring (edge i joins vertex i
/// to vertex i+1 mod n) that touch or cross, with a point near the contact;
/// adjacent edges that fold back onto each other count too. Edges are
/// bucketed in a uniform grid of about n cells, so typical rings cost
/// O(n) tests rather than O(n²).
pub fn ring_self_intersection(ring: &[[f64; 2]]) -> Option<(usize, usize, [f64; 2])> {
    let n = ring.len();
    if n < 3 {
        return None;
    }
    let seg = |i: usize| (ring[i], ring[(i + 1) % n]);
    let mut bb = [
        f64::INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NEG_INFINITY,
    ];
    for p in ring {
        bb[0] = bb[0].min(p[0]);
        bb[1] = bb[1].min(p[1]);
        bb[2] = bb[2].max(p[0]);
        bb[3] = bb[3].max(p[1]);
    }
    let side = ((n as f64).sqrt().ceil() as usize).clamp(1, 1024);
    let sx = ((bb[2] - bb[0]) / side as f64).max(f64::MIN_POSITIVE);
    let sy = ((bb[3] - bb[1]) / side as f64).max(f64::MIN_POSITIVE);
    let cell = |x: f64, y: f64| {
        let cx = (((x - bb[0]) / sx) as usize).min(side - 1);
        let cy = (((y - bb[1]) / sy) as usize).min(side - 1);
        (cx, cy)
    };
    let mut buckets: Vec<Vec<u32>> = vec![Vec::new(); side * side];
    for i in 0..n {
        let (a, b) = seg(i);
        let (x0, y0) = cell(a[0].min(b[0]), a[1].min(b[1]));
        let (x1, y1) = cell(a[0].max(b[0]), a[1].max(b[1]));
        for cy in y0..=y1 {
            for cx in x0..=x1 {
                buckets[cy * side + cx].push(i as u32);
            }
        }
    }
    let mut best: Option<(usize, usize)> = None;
    for b in &buckets {
        for (k, &i) in b.iter().enumerate() {
            for &j in &b[k + 1..] {
                let (i, j) = (i as usize, j as usize);
                let (a1, b1) = seg(i);
                let (a2, b2) = seg(j);
                let adjacent = (i + 1) % n == j || (j + 1) % n == i;
                let hit = if adjacent {
                    // Adjacent edges share one vertex; they are bad only if
                    // they are collinear and overlap (the ring folds back).
                    let (p, q, r) = if (i + 1) % n == j {
                        (a1, b1, b2)
                    } else {
                        (a2, b2, b1)
                    };
                    orient(p, q, r) == 0.0
                        && ((r[0] - q[0]) * (p[0] - q[0]) + (r[1] - q[1]) * (p[1] - q[1])) > 0.0
                } else {
                    segments_intersect(a1, b1, a2, b2)
                };
                if hit {
                    let pair = (i.min(j), i.max(j));
                    if best.is_none_or(|b| pair < b) {
                        best = Some(pair);
                    }
                }
            }
        }
    }
    best.map(|(i, j)| {
        let (a, b) = seg(i);
        let (c, d) = seg(j);
        let p = [
            (a[0] + b[0] + c[0] + d[0]) / 4.0,
            (a[1] + b[1] + c[1] + d[1]) / 4.0,
        ];
        (i, j, p)
    })
}

/// Even-odd point-in-polygon test over a set of rings (crossing number,
/// half-open rule so vertices on the ray count once).
pub fn inside_rings(rings: &[Vec<[f64; 2]>], p: [f64; 2]) -> bool {
    let mut inside = false;
    for r in rings {
        let n = r.len();
        for i in 0..n {
            let a = r[i];
            let b = r[(i + 1) % n];
            if (a[1] <= p[1]) != (b[1] <= p[1]) {
                let x = a[0] + (p[1] - a[1]) / (b[1] - a[1]) * (b[0] - a[0]);
                if x < p[0] {
                    inside = !inside;
                }
            }
        }
    }
    inside
}

/// A land mask from coastline rings, evaluated a row at a time: the crossings
/// of each row's centre line with the ring edges are found through a band
/// index, so a cell's state depends only on its position (tileable).
pub struct RingMask {
    /// Edges (ax, ay, bx, by).
    edges: Vec<[f64; 4]>,
    /// Edge ids per band of `band` rows.
    bands: Vec<Vec<u32>>,
    band: f64,
    y0: f64,
}

impl RingMask {
    /// Index `rings` (pixel coordinates, y down) for rows in `0..height`.
    pub fn new(rings: &[Vec<[f64; 2]>], height: usize) -> RingMask {
        let mut edges = Vec::new();
        for r in rings {
            let n = r.len();
            for i in 0..n {
                let (a, b) = (r[i], r[(i + 1) % n]);
                if a[1] != b[1] {
                    edges.push([a[0], a[1], b[0], b[1]]);
                }
            }
        }
        // At most 65536 bands, whatever the raster height.
        let band = (height as f64 / 65536.0).max(16.0);
        let nb = (height as f64 / band).ceil().max(1.0) as usize;
        let mut bands = vec![Vec::new(); nb];
        for (i, e) in edges.iter().enumerate() {
            let lo = e[1].min(e[3]);
            let hi = e[1].max(e[3]);
            if hi < 0.0 || lo > height as f64 {
                continue;
            }
            let b0 = ((lo.max(0.0)) / band) as usize;
            let b1 = (((hi.min(height as f64)) / band) as usize).min(nb - 1);
            for b in bands.iter_mut().take(b1 + 1).skip(b0.min(nb - 1)) {
                b.push(i as u32);
            }
        }
        RingMask {
            edges,
            bands,
            band,
            y0: 0.0,
        }
    }

    /// Land flags of cells `x0..x0+out.len()` of row `row` (cell centres),
    /// using `xs` as scratch.
    pub fn row(&self, row: usize, x0: usize, out: &mut [bool], xs: &mut Vec<f64>) {
        let y = row as f64 + 0.5 - self.y0;
        xs.clear();
        let b = ((y / self.band) as usize).min(self.bands.len() - 1);
        for &i in &self.bands[b] {
            let e = self.edges[i as usize];
            if (e[1] <= y) != (e[3] <= y) {
                xs.push(e[0] + (y - e[1]) / (e[3] - e[1]) * (e[2] - e[0]));
            }
        }
        xs.sort_by(|a, b| a.total_cmp(b));
        let mut k = 0;
        for (i, o) in out.iter_mut().enumerate() {
            let x = (x0 + i) as f64 + 0.5;
            while k < xs.len() && xs[k] < x {
                k += 1;
            }
            *o = k % 2 == 1;
        }
    }

    /// Land flag of one point (pixel coordinates).
    pub fn at(&self, x: f64, y: f64) -> bool {
        if y < 0.0 {
            return false;
        }
        let b = ((y / self.band) as usize).min(self.bands.len() - 1);
        let mut inside = false;
        for &i in &self.bands[b] {
            let e = self.edges[i as usize];
            if (e[1] <= y) != (e[3] <= y) {
                let xc = e[0] + (y - e[1]) / (e[3] - e[1]) * (e[2] - e[0]);
                if xc < x {
                    inside = !inside;
                }
            }
        }
        inside
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p() -> &'static Path {
        Path::new("m.geojson")
    }

    #[test]
    fn parses_all_kinds() {
        let t = r#"{"type":"FeatureCollection","features":[
          {"type":"Feature","properties":{"kind":"coast"},"geometry":{"type":"Polygon","coordinates":[[[0,0],[10,0],[10,10],[0,10],[0,0]]]}},
          {"type":"Feature","properties":{},"geometry":{"type":"LineString","coordinates":[[1,1],[5,5]]}},
          {"type":"Feature","properties":{"elevation":1234.5},"geometry":{"type":"Point","coordinates":[3,4]}}]}"#;
        let m = VectorMap::parse(t, p()).unwrap();
        assert_eq!(
            m.coasts,
            vec![vec![[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]]]
        );
        assert_eq!(m.rivers.len(), 1);
        assert_eq!(
            m.peaks,
            vec![MapPeak {
                pos: [3.0, 4.0],
                elevation: Some(1234.5)
            }]
        );
        assert_eq!(m.bbox(), Some([0.0, 0.0, 10.0, 10.0]));
    }

    #[test]
    fn rejects_bad_input() {
        let e = VectorMap::parse("{not json", p()).unwrap_err().to_string();
        assert!(
            e.contains("m.geojson") && e.contains("not valid JSON"),
            "{e}"
        );
        let bowtie = r#"{"type":"FeatureCollection","features":[{"type":"Feature","properties":{},"geometry":{"type":"Polygon","coordinates":[[[0,0],[10,10],[10,0],[0,10],[0,0]]]}}]}"#;
        let e = VectorMap::parse(bowtie, p()).unwrap_err().to_string();
        assert!(e.contains("crosses itself"), "{e}");
        let open = r#"{"type":"FeatureCollection","features":[{"type":"Feature","properties":{},"geometry":{"type":"Polygon","coordinates":[[[0,0],[10,10],[10,0]]]}}]}"#;
        assert!(VectorMap::parse(open, p())
            .unwrap_err()
            .to_string()
            .contains("closed"));
        let nan = r#"{"type":"FeatureCollection","features":[{"type":"Feature","properties":{},"geometry":{"type":"Point","coordinates":["a",1]}}]}"#;
        assert!(VectorMap::parse(nan, p())
            .unwrap_err()
            .to_string()
            .contains("finite"));
        let kind = r#"{"type":"FeatureCollection","features":[{"type":"Feature","properties":{"kind":"river"},"geometry":{"type":"Point","coordinates":[1,1]}}]}"#;
        assert!(VectorMap::parse(kind, p())
            .unwrap_err()
            .to_string()
            .contains("does not match"));
    }

    /// Brute-force oracle: every pair of non-adjacent edges.
    fn brute(ring: &[[f64; 2]]) -> bool {
        let n = ring.len();
        for i in 0..n {
            for j in i + 2..n {
                if i == 0 && j == n - 1 {
                    continue;
                }
                if segments_intersect(ring[i], ring[(i + 1) % n], ring[j], ring[(j + 1) % n]) {
                    return true;
                }
            }
        }
        false
    }

    #[test]
    fn self_intersection_matches_brute_force() {
        // Star polygons: {n/1} is simple, {n/2} crosses itself.
        for n in [5usize, 7, 11, 40] {
            for step in [1usize, 2] {
                let ring: Vec<[f64; 2]> = (0..n)
                    .map(|k| {
                        let a = std::f64::consts::TAU * (k * step % n) as f64 / n as f64;
                        let r = if k % 2 == 0 { 10.0 } else { 9.0 };
                        [r * a.cos(), r * a.sin()]
                    })
                    .collect();
                assert_eq!(
                    ring_self_intersection(&ring).is_some(),
                    brute(&ring),
                    "n={n} step={step}"
                );
                assert_eq!(brute(&ring), step == 2);
            }
        }
    }

    #[test]
    fn ring_mask_matches_point_in_polygon() {
        let ring = vec![
            [2.3, 1.1],
            [30.7, 4.2],
            [25.0, 28.9],
            [12.5, 14.0],
            [3.3, 26.1],
        ];
        let rings = vec![ring];
        let m = RingMask::new(&rings, 32);
        let mut row = vec![false; 32];
        let mut xs = Vec::new();
        for y in 0..32 {
            m.row(y, 0, &mut row, &mut xs);
            for (x, &v) in row.iter().enumerate() {
                let p = [x as f64 + 0.5, y as f64 + 0.5];
                assert_eq!(v, inside_rings(&rings, p));
                assert_eq!(m.at(p[0], p[1]), v);
            }
        }
    }
}
