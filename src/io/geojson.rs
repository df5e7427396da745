//! The coordinates of the GeoJSON files the analysis commands write (peaks,
//! saddles and divide tree of `peaks`, `ridges`, stream links and nodes of
//! `streams`, basin outlines of `basins --metrics`), and the `crs` member of
//! GeoJSON files read as input.
//!
//! GeoJSON is WGS 84 longitude/latitude in decimal degrees (RFC 7946, "The
//! GeoJSON Format", Butler et al. 2016, §4), and RFC 7946 removed the `crs`
//! member of the 2008 specification: a GIS reads a file without one as
//! lon/lat. So, with [`GeoJsonCrs::Wgs84`] (the default):
//!
//! - a geographic raster (any geographic CRS, taken as WGS 84, as
//!   [`SourceCrs::Geographic`] does): coordinates as they are, no `crs`;
//! - UTM on WGS 84 (EPSG:326zz/327zz), ETRS89 / UTM (EPSG:25828-25838) and
//!   Web Mercator (EPSG:3857): map coordinates projected to lon/lat by
//!   [`SourceCrs::to_lonlat`] (Karney 2011's Krüger series, see
//!   [`crate::raster::proj`]), no `crs`;
//! - any other EPSG code: an error naming the raster and the fix
//!   (`--geojson-crs native`), raised before anything is written;
//! - no CRS at all (not georeferenced: pixel coordinates; a local or
//!   user-defined CRS without EPSG code): the raster's own coordinates, no
//!   `crs`, and a [warning](GeoJsonCoords::warning) saying so — there is no
//!   place on Earth to put them, and refusing would break the use of such
//!   rasters that worked before.
//!
//! With [`GeoJsonCrs::Native`] coordinates stay the raster's map coordinates
//! and a projected raster with an EPSG code gets the 2008 named-CRS member
//! `"crs": {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::32632"}}`,
//! which GDAL/OGR still honours. Only geometry changes: properties that are
//! measures (lengths, areas, distances) are metric whatever the choice, and
//! properties holding map coordinates (`outlet_x`/`outlet_y` of basins) stay
//! in the raster's CRS, as in the CSV outputs.
//!
//! Inputs (point files, [`input_crs`]): a GeoJSON file given by a user is in
//! the raster's CRS, as documented before, unless it has a `crs` member; a
//! member naming CRS84 or EPSG:4326 means lon/lat (projected to the raster's
//! CRS), one naming the raster's own EPSG code means map coordinates.

use crate::error::{Error, Result};
use crate::raster::proj::SourceCrs;
use crate::raster::GeoRef;
use serde_json::{json, Value};
use std::path::Path;

/// The coordinates GeoJSON outputs are written in (`--geojson-crs`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum GeoJsonCrs {
    /// WGS 84 longitude/latitude (RFC 7946), projected from the raster's CRS.
    #[default]
    Wgs84,
    /// The raster's own coordinates, with a `crs` member naming its EPSG code.
    Native,
}

impl GeoJsonCrs {
    /// `wgs84` or `native` (the text of `--geojson-crs`).
    pub fn parse(s: &str) -> Result<GeoJsonCrs> {
        match s.trim().to_ascii_lowercase().as_str() {
            "wgs84" => Ok(GeoJsonCrs::Wgs84),
            "native" => Ok(GeoJsonCrs::Native),
            o => Err(Error::invalid(format!(
                "--geojson-crs {o:?}: use wgs84 (longitude/latitude, RFC 7946) or native (the raster's CRS)"
            ))),
        }
    }

    /// How GeoJSON outputs of a raster with `georef` (read from `what`, named
    /// in the error) are written; an error for an EPSG code orogen cannot
    /// project when `self` is [`GeoJsonCrs::Wgs84`] (see the module doc).
    pub fn coords(self, georef: &GeoRef, what: &Path) -> Result<GeoJsonCoords> {
        let crs = &georef.crs;
        let unknown = !georef.georeferenced || (crs.epsg.is_none() && !crs.geographic);
        let warning = unknown.then(|| {
            format!(
                "{}: the raster has no known coordinate reference system; its GeoJSON outputs are in the raster's own coordinates{}, not longitude/latitude (RFC 7946), and name no CRS",
                what.display(),
                if georef.georeferenced { "" } else { " (pixels)" }
            )
        });
        let mut out = GeoJsonCoords {
            georef: georef.clone(),
            to_lonlat: None,
            crs_name: None,
            warning,
        };
        if unknown || crs.geographic {
            return Ok(out);
        }
        match self {
            GeoJsonCrs::Native => {
                out.crs_name = crs.epsg.map(|e| format!("urn:ogc:def:crs:EPSG::{e}"));
            }
            GeoJsonCrs::Wgs84 => match SourceCrs::known(georef) {
                Some(p) => out.to_lonlat = Some(p),
                None => {
                    let e = crs.epsg.unwrap_or_default();
                    return Err(Error::unsupported(
                        what,
                        format!(
                            "its CRS EPSG:{e} cannot be projected to the longitude/latitude GeoJSON needs (RFC 7946); orogen projects geographic, UTM (EPSG:326zz/327zz/258zz) and Web Mercator (EPSG:3857) rasters. Add --geojson-crs native to write EPSG:{e} coordinates with a \"crs\" member naming it, or reproject the DEM first (gdalwarp -t_srs EPSG:4326)"
                        ),
                    ));
                }
            },
        }
        Ok(out)
    }
}

/// How one raster's GeoJSON outputs are written: map coordinates to file
/// coordinates and the `crs` member (from [`GeoJsonCrs::coords`]).
#[derive(Debug, Clone)]
pub struct GeoJsonCoords {
    georef: GeoRef,
    to_lonlat: Option<SourceCrs>,
    crs_name: Option<String>,
    warning: Option<String>,
}

impl GeoJsonCoords {
    /// The raster's own coordinates, with a `crs` member when it is projected
    /// with an EPSG code ([`GeoJsonCrs::Native`], which never fails).
    pub fn native(georef: &GeoRef) -> GeoJsonCoords {
        GeoJsonCrs::Native
            .coords(georef, Path::new(""))
            .expect("native coordinates need no projection")
    }

    /// Whether coordinates are written as longitude/latitude.
    pub fn is_lonlat(&self) -> bool {
        self.to_lonlat.is_some() || (self.georef.georeferenced && self.georef.crs.geographic)
    }

    /// The warning for a raster without a known CRS (see the module doc).
    pub fn warning(&self) -> Option<&str> {
        self.warning.as_deref()
    }

    /// The file coordinates of map coordinates `(x, y)`.
    pub fn map(&self, x: f64, y: f64) -> [f64; 2] {
        match &self.to_lonlat {
            Some(p) => {
                let (lon, lat) = p.to_lonlat(x, y);
                [lon, lat]
            }
            None => [x, y],
        }
    }

    /// The file coordinates of the pixel position `(col, row)` (cell centres
    /// are at `+ 0.5`).
    pub fn pixel(&self, col: f64, row: f64) -> [f64; 2] {
        let (x, y) = self.georef.pixel_to_map(col, row);
        self.map(x, y)
    }

    /// The `crs` member, when one is written.
    pub fn crs_member(&self) -> Option<Value> {
        self.crs_name
            .as_ref()
            .map(|n| json!({"type": "name", "properties": {"name": n}}))
    }

    /// A FeatureCollection of `features`, with the `crs` member if any.
    pub fn collection(&self, features: Vec<Value>) -> Value {
        let mut v = json!({"type": "FeatureCollection", "features": features});
        if let Some(c) = self.crs_member() {
            v["crs"] = c;
        }
        v
    }

    /// The text of a FeatureCollection up to its first feature
    /// (`{"type":"FeatureCollection",["crs":...,]"features":[`), for writers
    /// that stream their features; close it with `]}`.
    pub fn collection_head(&self) -> String {
        match self.crs_member() {
            Some(c) => format!("{{\"type\":\"FeatureCollection\",\"crs\":{c},\"features\":["),
            None => "{\"type\":\"FeatureCollection\",\"features\":[".to_string(),
        }
    }
}

/// What the `crs` member of an input GeoJSON file says.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InputCrs {
    /// No `crs` member: the raster's CRS (as documented for every input).
    Raster,
    /// CRS84 or EPSG:4326: longitude/latitude.
    LonLat,
    /// Another EPSG code.
    Epsg(u32),
}

/// The CRS named by the `crs` member of the GeoJSON value `v` read from
/// `path`: `urn:ogc:def:crs:OGC:1.3:CRS84`, `urn:ogc:def:crs:EPSG::N`,
/// `EPSG:N`; an error for a member naming anything else.
pub fn input_crs(v: &Value, path: &Path) -> Result<InputCrs> {
    let Some(c) = v.get("crs").filter(|c| !c.is_null()) else {
        return Ok(InputCrs::Raster);
    };
    let name = c
        .get("properties")
        .and_then(|p| p.get("name"))
        .and_then(|n| n.as_str())
        .unwrap_or("");
    let n = name.trim().to_ascii_uppercase();
    if n.ends_with("CRS84") {
        return Ok(InputCrs::LonLat);
    }
    let code = n
        .strip_prefix("URN:OGC:DEF:CRS:EPSG:")
        .map(|r| r.rsplit(':').next().unwrap_or(""))
        .or_else(|| n.strip_prefix("EPSG:"))
        .and_then(|d| d.parse::<u32>().ok());
    match code {
        Some(4326) => Ok(InputCrs::LonLat),
        Some(e) => Ok(InputCrs::Epsg(e)),
        None => Err(Error::corrupt(
            path,
            format!("its \"crs\" member {name:?} is not understood: name urn:ogc:def:crs:EPSG::N or CRS84, or remove it (coordinates are then in the raster's CRS)"),
        )),
    }
}

/// A function from the coordinates of an input file whose `crs` member
/// says `crs` to the map coordinates of a raster with `georef`; an error
/// naming `path` when they cannot be converted.
pub fn input_to_map(
    crs: InputCrs,
    georef: &GeoRef,
    path: &Path,
) -> Result<impl Fn(f64, f64) -> (f64, f64)> {
    let raster_epsg = georef.crs.epsg;
    let proj = match crs {
        InputCrs::Raster => None,
        InputCrs::Epsg(e) if Some(e) == raster_epsg => None,
        InputCrs::LonLat if georef.georeferenced && georef.crs.geographic => None,
        InputCrs::LonLat => match SourceCrs::known(georef) {
            Some(p) => Some(p),
            None => {
                return Err(Error::unsupported(
                    path,
                    "its coordinates are longitude/latitude (\"crs\" member) but the raster's CRS cannot be projected by orogen (geographic, UTM and Web Mercator can): give the points in the raster's CRS",
                ))
            }
        },
        InputCrs::Epsg(e) => {
            return Err(Error::unsupported(
                path,
                format!(
                    "its \"crs\" member names EPSG:{e}, the raster's CRS is {}: give the points in the raster's CRS or in longitude/latitude (e.g. ogr2ogr -t_srs EPSG:4326)",
                    raster_epsg
                        .map(|r| format!("EPSG:{r}"))
                        .unwrap_or_else(|| "without EPSG code".into())
                ),
            ))
        }
    };
    Ok(move |x: f64, y: f64| match &proj {
        Some(p) => p.from_lonlat(x, y),
        None => (x, y),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raster::Crs;

    fn utm(epsg: u32) -> GeoRef {
        GeoRef::north_up(380_000.0, 3_800_000.0, 30.0, Crs::projected(epsg))
    }

    #[test]
    fn native_names_the_epsg_code_and_keeps_coordinates() {
        let c = GeoJsonCrs::Native
            .coords(&utm(32611), Path::new("d.tif"))
            .unwrap();
        assert_eq!(c.pixel(0.0, 0.0), [380_000.0, 3_800_000.0]);
        assert_eq!(
            c.collection_head(),
            r#"{"type":"FeatureCollection","crs":{"properties":{"name":"urn:ogc:def:crs:EPSG::32611"},"type":"name"},"features":["#
        );
        assert!(!c.is_lonlat() && c.warning().is_none());
    }

    #[test]
    fn unprojectable_epsg_is_an_error_naming_the_fix() {
        let e = GeoJsonCrs::Wgs84
            .coords(&utm(2056), Path::new("swiss.tif"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("swiss.tif") && e.contains("EPSG:2056"), "{e}");
        assert!(e.contains("--geojson-crs native"), "{e}");
        assert!(GeoJsonCrs::Native
            .coords(&utm(2056), Path::new("s"))
            .is_ok());
    }

    #[test]
    fn rasters_without_crs_stay_native_with_a_warning() {
        let c = GeoJsonCrs::Wgs84
            .coords(&GeoRef::pixel(), Path::new("p.tif"))
            .unwrap();
        assert_eq!(c.pixel(2.5, 3.5), [2.5, 3.5]);
        assert!(c.crs_member().is_none());
        assert!(c.warning().unwrap().contains("p.tif"));
    }

    #[test]
    fn input_crs_members_are_read() {
        let p = Path::new("i.geojson");
        let v = |n: &str| json!({"crs": {"type": "name", "properties": {"name": n}}});
        assert_eq!(input_crs(&json!({}), p).unwrap(), InputCrs::Raster);
        assert_eq!(
            input_crs(&v("urn:ogc:def:crs:OGC:1.3:CRS84"), p).unwrap(),
            InputCrs::LonLat
        );
        assert_eq!(
            input_crs(&v("urn:ogc:def:crs:EPSG::4326"), p).unwrap(),
            InputCrs::LonLat
        );
        assert_eq!(
            input_crs(&v("EPSG:32611"), p).unwrap(),
            InputCrs::Epsg(32611)
        );
        assert!(input_crs(&v("local"), p).is_err());
        let g = utm(32611);
        let same = input_to_map(InputCrs::Epsg(32611), &g, p).unwrap();
        assert_eq!(same(1.0, 2.0), (1.0, 2.0));
        assert!(input_to_map(InputCrs::Epsg(32632), &g, p).is_err());
        // lon/lat -118, 34.3 -> UTM 11N and back through the module's projection
        let f = input_to_map(InputCrs::LonLat, &g, p).unwrap();
        let (x, y) = f(-118.0, 34.3);
        let back = GeoJsonCrs::Wgs84.coords(&g, p).unwrap().map(x, y);
        assert!((back[0] + 118.0).abs() < 1e-9 && (back[1] - 34.3).abs() < 1e-9);
    }
}
