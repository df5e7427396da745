//! Points from vector files: a GeoJSON FeatureCollection of Points (or a
//! single Feature or Point geometry), or a CSV table whose header names the
//! coordinate columns. One reader for every operation that takes points
//! (pour points, observers, fixed points…); the caller names what the points
//! are, and the errors say it.
//!
//! CSV: the first non-blank line is the header; the separator is `;` when
//! the header holds `;` and no `,`, else `,`; names are trimmed, unquoted and
//! compared case-insensitively. `x` is the first of `x`, `lon`, `lng`,
//! `longitude`, `easting`; `y` the first of `y`, `lat`, `latitude`,
//! `northing`; an optional `id` or `name` column names each point. Blank
//! lines are skipped; every other line must hold finite numbers in both
//! coordinate columns. Line numbers in errors count the header as line 1.
//!
//! GeoJSON: every feature must be a Point with at least two numeric
//! coordinates; the `id` (else `name`) property names it. Coordinates are in
//! the raster's CRS unless the file has a `crs` member: [`read_points_in`]
//! then reads longitude/latitude (CRS84, EPSG:4326) through the raster's
//! projection and refuses another CRS ([`crate::io::geojson::input_crs`]);
//! so the `--geojson-crs native` outputs of orogen read back as they are.

use crate::error::{Error, Result};
use crate::raster::GeoRef;
use std::path::Path;

/// A point read from a CSV or GeoJSON file, in map coordinates.
#[derive(Debug, Clone, PartialEq)]
pub struct MapPoint {
    pub x: f64,
    pub y: f64,
    /// Name or id from the file (`id`/`name` column or property), if any.
    pub name: Option<String>,
}

/// Upper bound on points read from a file (they are held in memory).
pub const MAX_POINTS: usize = 10_000_000;

/// Largest point file read (bytes).
pub const MAX_POINT_FILE_BYTES: u64 = 1 << 30;

/// What the points of a file are, for the error messages: `one` in the
/// singular ("pour point"), `many` in the plural ("pour points").
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PointNoun<'a> {
    pub one: &'a str,
    pub many: &'a str,
}

/// Read points: a `.geojson`/`.json` file (see the module doc), else a CSV.
/// Errors name the file and what is wrong; an empty result is an error.
/// Coordinates as in the file (a GeoJSON `crs` member is not looked at; see
/// [`read_points_in`]).
pub fn read_points(path: &Path, noun: PointNoun) -> Result<Vec<MapPoint>> {
    read_points_with(path, noun, None)
}

/// [`read_points`] in the map coordinates of a raster with `georef`: a
/// GeoJSON file's `crs` member is honoured (see the module doc).
pub fn read_points_in(path: &Path, noun: PointNoun, georef: &GeoRef) -> Result<Vec<MapPoint>> {
    read_points_with(path, noun, Some(georef))
}

fn read_points_with(
    path: &Path,
    noun: PointNoun,
    georef: Option<&GeoRef>,
) -> Result<Vec<MapPoint>> {
    let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    if meta.len() > MAX_POINT_FILE_BYTES {
        return Err(Error::too_large(
            path,
            format!(
                "{} file larger than 1 GiB; give fewer points",
                noun.one.replace(' ', "-")
            ),
        ));
    }
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    let pts = if ext == "geojson" || ext == "json" {
        let v = parse_geojson(path, &text)?;
        let mut pts = points_of(path, &v, noun)?;
        if let Some(g) = georef {
            let crs = crate::io::geojson::input_crs(&v, path)?;
            let to_map = crate::io::geojson::input_to_map(crs, g, path)?;
            for p in &mut pts {
                (p.x, p.y) = to_map(p.x, p.y);
            }
        }
        pts
    } else {
        points_csv(path, &text, noun)?
    };
    if pts.is_empty() {
        return Err(Error::invalid(format!(
            "{}: no {} found",
            path.display(),
            noun.many
        )));
    }
    Ok(pts)
}

fn too_many(path: &Path, noun: PointNoun) -> Error {
    Error::too_large(path, format!("more than 10 million {}", noun.many))
}

fn parse_geojson(path: &Path, text: &str) -> Result<serde_json::Value> {
    serde_json::from_str(text).map_err(|e| Error::corrupt(path, format!("not valid GeoJSON: {e}")))
}

/// Points of a GeoJSON text (see the module doc), coordinates as in the file.
pub fn points_geojson(path: &Path, text: &str, noun: PointNoun) -> Result<Vec<MapPoint>> {
    points_of(path, &parse_geojson(path, text)?, noun)
}

fn points_of(path: &Path, v: &serde_json::Value, noun: PointNoun) -> Result<Vec<MapPoint>> {
    let feats: Vec<&serde_json::Value> = match v.get("features").and_then(|f| f.as_array()) {
        Some(a) => a.iter().collect(),
        None => vec![&v],
    };
    let mut out = Vec::new();
    for (i, f) in feats.iter().enumerate() {
        let geom = f.get("geometry").unwrap_or(f);
        if geom.get("type").and_then(|t| t.as_str()) != Some("Point") {
            return Err(Error::corrupt(
                path,
                format!(
                    "feature {i} is not a Point; {} must be GeoJSON Points",
                    noun.many
                ),
            ));
        }
        let c = geom
            .get("coordinates")
            .and_then(|c| c.as_array())
            .filter(|c| c.len() >= 2)
            .ok_or_else(|| Error::corrupt(path, format!("feature {i} has no coordinates")))?;
        let (x, y) = (c[0].as_f64(), c[1].as_f64());
        let (Some(x), Some(y)) = (x, y) else {
            return Err(Error::corrupt(
                path,
                format!("feature {i}: coordinates are not numbers"),
            ));
        };
        let props = f.get("properties");
        let name = props
            .and_then(|p| p.get("id").or_else(|| p.get("name")))
            .map(|n| match n {
                serde_json::Value::String(s) => s.clone(),
                o => o.to_string(),
            });
        out.push(MapPoint { x, y, name });
        if out.len() > MAX_POINTS {
            return Err(too_many(path, noun));
        }
    }
    Ok(out)
}

/// Points of a CSV text (see the module doc).
pub fn points_csv(path: &Path, text: &str, noun: PointNoun) -> Result<Vec<MapPoint>> {
    let mut lines = text.lines().filter(|l| !l.trim().is_empty());
    let header = lines
        .next()
        .ok_or_else(|| Error::corrupt(path, "empty CSV file"))?;
    let sep = if header.contains(';') && !header.contains(',') {
        ';'
    } else {
        ','
    };
    let cols: Vec<String> = header
        .split(sep)
        .map(|c| c.trim().trim_matches('"').to_ascii_lowercase())
        .collect();
    let find = |names: &[&str]| cols.iter().position(|c| names.contains(&c.as_str()));
    let (Some(ix), Some(iy)) = (
        find(&["x", "lon", "lng", "longitude", "easting"]),
        find(&["y", "lat", "latitude", "northing"]),
    ) else {
        return Err(Error::corrupt(
            path,
            "the CSV header must name x and y (or lon and lat) columns",
        ));
    };
    let iname = find(&["id", "name"]);
    let mut out = Vec::new();
    for (ln, line) in lines.enumerate() {
        let f: Vec<&str> = line
            .split(sep)
            .map(|s| s.trim().trim_matches('"'))
            .collect();
        let num = |i: usize| -> Result<f64> {
            f.get(i)
                .and_then(|s| s.parse::<f64>().ok())
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    Error::corrupt(
                        path,
                        format!("line {}: column {} is not a number", ln + 2, i + 1),
                    )
                })
        };
        out.push(MapPoint {
            x: num(ix)?,
            y: num(iy)?,
            name: iname.and_then(|i| f.get(i)).map(|s| s.to_string()),
        });
        if out.len() > MAX_POINTS {
            return Err(too_many(path, noun));
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    const OBS: PointNoun = PointNoun {
        one: "observer point",
        many: "observers",
    };

    fn write(dir: &Path, name: &str, text: &str) -> std::path::PathBuf {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    #[test]
    fn csv_columns_by_name_with_either_separator() {
        let d = tempfile::tempdir().unwrap();
        let p = write(
            d.path(),
            "a.csv",
            "Name,\"LON\",elev,lat\nsummit, 7.5 ,1200,46.25\n\n\"hut\",8,900,-1e2\n",
        );
        let v = read_points(&p, OBS).unwrap();
        assert_eq!(
            v,
            vec![
                MapPoint {
                    x: 7.5,
                    y: 46.25,
                    name: Some("summit".into())
                },
                MapPoint {
                    x: 8.0,
                    y: -100.0,
                    name: Some("hut".into())
                },
            ]
        );
        let p = write(d.path(), "b.txt", "easting;northing\n350120;4590210\n");
        assert_eq!(
            read_points(&p, OBS).unwrap(),
            vec![MapPoint {
                x: 350120.0,
                y: 4590210.0,
                name: None
            }]
        );
    }

    #[test]
    fn csv_errors_name_the_file_and_the_line() {
        let d = tempfile::tempdir().unwrap();
        let p = write(d.path(), "h.csv", "a,b\n1,2\n");
        let e = read_points(&p, OBS).unwrap_err().to_string();
        assert_eq!(
            e,
            format!(
                "{}: the CSV header must name x and y (or lon and lat) columns",
                p.display()
            )
        );
        let p = write(d.path(), "n.csv", "x,y\n1,2\n3,inf\n");
        let e = read_points(&p, OBS).unwrap_err().to_string();
        assert_eq!(
            e,
            format!("{}: line 3: column 2 is not a number", p.display())
        );
        let p = write(d.path(), "e.csv", "x,y\n\n");
        let e = read_points(&p, OBS).unwrap_err().to_string();
        assert_eq!(e, format!("{}: no observers found", p.display()));
        let p = write(d.path(), "z.csv", "  \n");
        let e = read_points(&p, OBS).unwrap_err().to_string();
        assert_eq!(e, format!("{}: empty CSV file", p.display()));
    }

    #[test]
    fn geojson_points_and_their_names() {
        let d = tempfile::tempdir().unwrap();
        let p = write(
            d.path(),
            "p.geojson",
            r#"{"type":"FeatureCollection","features":[
              {"type":"Feature","geometry":{"type":"Point","coordinates":[5,6,100]},"properties":{"id":7,"name":"a"}},
              {"type":"Feature","geometry":{"type":"Point","coordinates":[-1.5,2]},"properties":{"name":"b"}},
              {"type":"Feature","geometry":{"type":"Point","coordinates":[0,0]}}]}"#,
        );
        let v = read_points(&p, OBS).unwrap();
        assert_eq!(v.len(), 3);
        assert_eq!(
            (v[0].x, v[0].y, v[0].name.as_deref()),
            (5.0, 6.0, Some("7"))
        );
        assert_eq!(
            (v[1].x, v[1].y, v[1].name.as_deref()),
            (-1.5, 2.0, Some("b"))
        );
        assert_eq!(v[2].name, None);
        // A bare geometry is one point.
        let p = write(
            d.path(),
            "g.json",
            r#"{"type":"Point","coordinates":[1,2]}"#,
        );
        assert_eq!(read_points(&p, OBS).unwrap()[0].y, 2.0);
    }

    #[test]
    fn geojson_errors_say_what_the_points_are() {
        let d = tempfile::tempdir().unwrap();
        let p = write(
            d.path(),
            "l.geojson",
            r#"{"type":"FeatureCollection","features":[{"type":"Feature","geometry":{"type":"LineString","coordinates":[[0,0],[1,1]]}}]}"#,
        );
        let e = read_points(&p, OBS).unwrap_err().to_string();
        assert_eq!(
            e,
            format!(
                "{}: feature 0 is not a Point; observers must be GeoJSON Points",
                p.display()
            )
        );
        let p = write(
            d.path(),
            "s.geojson",
            r#"{"type":"Point","coordinates":["a",1]}"#,
        );
        let e = read_points(&p, OBS).unwrap_err().to_string();
        assert_eq!(
            e,
            format!("{}: feature 0: coordinates are not numbers", p.display())
        );
        let p = write(
            d.path(),
            "c.geojson",
            r#"{"type":"Point","coordinates":[1]}"#,
        );
        let e = read_points(&p, OBS).unwrap_err().to_string();
        assert_eq!(e, format!("{}: feature 0 has no coordinates", p.display()));
        let p = write(d.path(), "j.geojson", "{");
        let e = read_points(&p, OBS).unwrap_err().to_string();
        assert!(e.contains("not valid GeoJSON"), "{e}");
        let missing = d.path().join("none.csv");
        assert!(read_points(&missing, OBS).is_err());
    }
}
