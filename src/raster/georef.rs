//! Georeferencing: affine transform, CRS, nodata, pixel-is-area/point, and the
//! true cell size in metres (per row for geographic CRSs).

use serde::{Deserialize, Serialize};

/// How a cell's coordinate relates to the cell (GeoTIFF `GTRasterTypeGeoKey`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RasterType {
    /// The transform gives the corner of the cell (GeoTIFF RasterPixelIsArea, GDAL's default).
    #[default]
    Area,
    /// The file said RasterPixelIsPoint: values are samples at cell centres. The
    /// transform is still stored in the area convention (as GDAL reports it); the
    /// flag is kept so writers can round-trip the file.
    Point,
}

/// The raw GeoTIFF GeoKey set, kept so an unmodified CRS round-trips exactly.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct GeoKeys {
    /// GeoKeyDirectoryTag (34735) as read: header + key entries.
    pub directory: Vec<u16>,
    /// GeoDoubleParamsTag (34736).
    pub doubles: Vec<f64>,
    /// GeoAsciiParamsTag (34737).
    pub ascii: String,
}

/// Coordinate reference system as orogen understands it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Crs {
    /// EPSG code of the projected or geographic CRS, when known.
    pub epsg: Option<u32>,
    /// True for a geographic (lat/lon degrees) CRS.
    pub geographic: bool,
    /// Metres per linear unit of a projected CRS (1 for metres, 0.3048 for feet).
    pub linear_unit_m: f64,
    /// The original GeoKeys, if the source was a GeoTIFF.
    pub geokeys: Option<GeoKeys>,
}

impl Default for Crs {
    fn default() -> Self {
        Crs {
            epsg: None,
            geographic: false,
            linear_unit_m: 1.0,
            geokeys: None,
        }
    }
}

impl Crs {
    /// WGS 84 geographic (EPSG:4326).
    pub fn wgs84() -> Self {
        Crs {
            epsg: Some(4326),
            geographic: true,
            linear_unit_m: 1.0,
            geokeys: None,
        }
    }
    /// A projected CRS by EPSG code, in metres.
    pub fn projected(epsg: u32) -> Self {
        Crs {
            epsg: Some(epsg),
            geographic: false,
            linear_unit_m: 1.0,
            geokeys: None,
        }
    }
}

/// Georeferencing of a raster.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GeoRef {
    /// Affine transform in GDAL order: `X = t[0] + col*t[1] + row*t[2]`,
    /// `Y = t[3] + col*t[4] + row*t[5]`, for the corner of cell (col, row).
    pub transform: [f64; 6],
    /// CRS.
    pub crs: Crs,
    /// Nodata value in the raster's native type, if any.
    pub nodata: Option<f64>,
    /// Pixel-is-area or pixel-is-point (as read; the transform is always area).
    pub raster_type: RasterType,
    /// False when the source had no georeferencing: the transform is then the
    /// identity in pixel coordinates (x right, y down) and cell size 1.
    pub georeferenced: bool,
}

impl Default for GeoRef {
    fn default() -> Self {
        GeoRef::pixel()
    }
}

/// WGS 84 semi-major axis (m).
const WGS84_A: f64 = 6_378_137.0;
/// WGS 84 first eccentricity squared.
const WGS84_E2: f64 = 0.006_694_379_990_141_317;

impl GeoRef {
    /// No georeferencing: pixel coordinates, unit cells.
    pub fn pixel() -> Self {
        GeoRef {
            transform: [0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
            crs: Crs::default(),
            nodata: None,
            raster_type: RasterType::Area,
            georeferenced: false,
        }
    }
    /// A north-up transform with top-left corner (x0, y0) and square cells of `cell`.
    pub fn north_up(x0: f64, y0: f64, cell: f64, crs: Crs) -> Self {
        GeoRef {
            transform: [x0, cell, 0.0, y0, 0.0, -cell],
            crs,
            nodata: None,
            raster_type: RasterType::Area,
            georeferenced: true,
        }
    }
    /// Same georeference with a nodata value.
    pub fn with_nodata(mut self, nodata: Option<f64>) -> Self {
        self.nodata = nodata;
        self
    }
    /// Map coordinates of the corner of cell (col, row) (fractional allowed).
    pub fn pixel_to_map(&self, col: f64, row: f64) -> (f64, f64) {
        let t = &self.transform;
        (
            t[0] + col * t[1] + row * t[2],
            t[3] + col * t[4] + row * t[5],
        )
    }
    /// Fractional (col, row) of a map coordinate; None if the transform is singular.
    pub fn map_to_pixel(&self, x: f64, y: f64) -> Option<(f64, f64)> {
        let t = &self.transform;
        let det = t[1] * t[5] - t[2] * t[4];
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let dx = x - t[0];
        let dy = y - t[3];
        Some(((dx * t[5] - dy * t[2]) / det, (dy * t[1] - dx * t[4]) / det))
    }
    /// The cell (col, row) of a `width` x `height` raster whose area holds
    /// the map point (x, y) (the floor of its pixel coordinates); None when
    /// it lies outside the raster or the transform is singular.
    pub fn cell_at(&self, x: f64, y: f64, width: usize, height: usize) -> Option<(usize, usize)> {
        let (c, r) = self.map_to_pixel(x, y)?;
        let (c, r) = (c.floor(), r.floor());
        (c >= 0.0 && r >= 0.0 && c < width as f64 && r < height as f64)
            .then_some((c as usize, r as usize))
    }
    /// The georeference of a window whose top-left cell is (x, y) of this raster.
    pub fn shifted(&self, x: i64, y: i64) -> GeoRef {
        let (x0, y0) = self.pixel_to_map(x as f64, y as f64);
        let mut g = self.clone();
        g.transform[0] = x0;
        g.transform[3] = y0;
        g
    }
    /// True if the transform has no rotation terms.
    pub fn is_north_up(&self) -> bool {
        self.transform[2] == 0.0 && self.transform[4] == 0.0
    }
    /// Cell size in CRS units along columns and rows (lengths of the transform's column vectors).
    pub fn cell_size_units(&self) -> (f64, f64) {
        let t = &self.transform;
        (t[1].hypot(t[4]), t[2].hypot(t[5]))
    }
    /// True cell size in metres (east-west, north-south) for cells on `row`.
    ///
    /// Projected CRSs: the transform's cell size times the linear unit. Geographic
    /// CRSs: the WGS 84 ellipsoid's radii of curvature at the latitude of the
    /// row's centre — east-west `N(φ)·cos φ·Δλ`, north-south `M(φ)·Δφ` with
    /// `N = a/√(1−e²sin²φ)`, `M = a(1−e²)/(1−e²sin²φ)^{3/2}` (standard geodesy,
    /// e.g. Snyder 1987, *Map Projections — A Working Manual*, eqs. 4-18, 4-20).
    /// Without georeferencing: 1 x 1.
    pub fn cell_size_m(&self, row: i64) -> (f64, f64) {
        self.cell_size_m_at(row as f64 + 0.5)
    }
    /// [`GeoRef::cell_size_m`] at the pixel-space line `pixel_y` (`row + 0.5`
    /// is a row's centre, `row` the edge between `row − 1` and `row`): on
    /// geographic grids the east-west spacing of cells along that latitude
    /// and the north-south spacing of rows across it.
    pub fn cell_size_m_at(&self, pixel_y: f64) -> (f64, f64) {
        let (cx, cy) = self.cell_size_units();
        if !self.georeferenced {
            return (cx, cy);
        }
        if !self.crs.geographic {
            let u = self.crs.linear_unit_m;
            return (cx * u, cy * u);
        }
        let (_, lat) = self.pixel_to_map(0.5, pixel_y);
        let phi = lat.clamp(-90.0, 90.0).to_radians();
        let s2 = phi.sin() * phi.sin();
        let w = (1.0 - WGS84_E2 * s2).sqrt();
        let n = WGS84_A / w;
        let m = WGS84_A * (1.0 - WGS84_E2) / (w * w * w);
        let rad = std::f64::consts::PI / 180.0;
        ((n * phi.cos() * cx * rad).abs(), (m * cy * rad).abs())
    }
    /// True area in m² of a cell on `row`, or `None` without georeferencing.
    ///
    /// Projected CRSs: |det| of the transform times the linear unit squared.
    /// Geographic CRSs: the exact area of the cell's quadrangle on the WGS 84
    /// ellipsoid, `A = (a²(1−e²)/2)·Δλ·[q(φ)]` between the row's edge
    /// latitudes, with `q(φ) = sin φ/(1−e² sin²φ) + (1/2e)·ln((1+e sin φ)/(1−e sin φ))`
    /// (the authalic-latitude function, Snyder 1987, eq. 3-12; summed over
    /// the globe it gives the ellipsoid's area, 5.10066e14 m²). Assumes a
    /// north-up grid (no rotation terms) on geographic CRSs.
    pub fn cell_area_m2(&self, row: i64) -> Option<f64> {
        if !self.georeferenced {
            return None;
        }
        let t = &self.transform;
        if !self.crs.geographic {
            let u = self.crs.linear_unit_m;
            return Some((t[1] * t[5] - t[2] * t[4]).abs() * u * u);
        }
        let e = WGS84_E2.sqrt();
        let q = |lat: f64| {
            let s = lat.clamp(-90.0, 90.0).to_radians().sin();
            s / (1.0 - WGS84_E2 * s * s) + ((1.0 + e * s) / (1.0 - e * s)).ln() / (2.0 * e)
        };
        let (_, lat0) = self.pixel_to_map(0.5, row as f64);
        let (_, lat1) = self.pixel_to_map(0.5, row as f64 + 1.0);
        let dlon = self.cell_size_units().0.to_radians();
        Some(WGS84_A * WGS84_A * (1.0 - WGS84_E2) / 2.0 * dlon * (q(lat0) - q(lat1)).abs())
    }
}
