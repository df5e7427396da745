//! Map projections needed to cut web-map pyramids without GDAL: Web Mercator
//! (EPSG:3857, spherical formulas on the WGS 84 semi-major axis, as the EPSG
//! guidance note 7-2 defines "Popular Visualisation Pseudo-Mercator") and UTM
//! on WGS 84 / GRS 80 (EPSG:326zz, 327zz, 258zz) by the Krüger series to
//! sixth order in n (Karney 2011, "Transverse Mercator with an accuracy of a
//! few nanometers", J. Geodesy 85, eqs. 35-36 and the coefficient series
//! given there), accurate to well under a millimetre within a UTM zone.

use super::GeoRef;
use crate::error::{Error, Result};

/// WGS 84 semi-major axis (m).
pub const A_WGS84: f64 = 6_378_137.0;
/// WGS 84 flattening.
pub const F_WGS84: f64 = 1.0 / 298.257_223_563;

/// Web Mercator x, y (m) of a longitude/latitude (degrees).
pub fn lonlat_to_merc(lon: f64, lat: f64) -> (f64, f64) {
    let lat = lat.clamp(-85.051_128_779_806_6, 85.051_128_779_806_6);
    (
        A_WGS84 * lon.to_radians(),
        A_WGS84
            * (std::f64::consts::FRAC_PI_4 + lat.to_radians() / 2.0)
                .tan()
                .ln(),
    )
}

/// Longitude/latitude (degrees) of a Web Mercator point.
pub fn merc_to_lonlat(x: f64, y: f64) -> (f64, f64) {
    (
        (x / A_WGS84).to_degrees(),
        (2.0 * (y / A_WGS84).exp().atan() - std::f64::consts::FRAC_PI_2).to_degrees(),
    )
}

/// A transverse Mercator projection on an ellipsoid (UTM parameters).
#[derive(Debug, Clone, Copy)]
pub struct TransverseMercator {
    lon0: f64,
    k0: f64,
    e0: f64,
    n0: f64,
    a_rect: f64,
    alpha: [f64; 6],
    beta: [f64; 6],
    delta: [f64; 6],
    /// 2√n/(1+n) = e (first eccentricity).
    e: f64,
}

impl TransverseMercator {
    /// UTM zone `zone` (1..=60), north or south, on WGS 84.
    pub fn utm(zone: u32, north: bool) -> TransverseMercator {
        let lon0 = -183.0 + 6.0 * zone as f64;
        TransverseMercator::new(
            A_WGS84,
            F_WGS84,
            lon0,
            0.9996,
            500_000.0,
            if north { 0.0 } else { 10_000_000.0 },
        )
    }

    /// A transverse Mercator with semi-major axis `a`, flattening `f`,
    /// central meridian `lon0` (degrees), scale `k0`, false easting/northing.
    pub fn new(a: f64, f: f64, lon0: f64, k0: f64, e0: f64, n0: f64) -> TransverseMercator {
        let n = f / (2.0 - f);
        let (n2, n3) = (n * n, n * n * n);
        let (n4, n5, n6) = (n2 * n2, n2 * n3, n3 * n3);
        let a_rect = a / (1.0 + n) * (1.0 + n2 / 4.0 + n4 / 64.0 + n6 / 256.0);
        let alpha = [
            n / 2.0 - 2.0 * n2 / 3.0 + 5.0 * n3 / 16.0 + 41.0 * n4 / 180.0 - 127.0 * n5 / 288.0
                + 7891.0 * n6 / 37800.0,
            13.0 * n2 / 48.0 - 3.0 * n3 / 5.0 + 557.0 * n4 / 1440.0 + 281.0 * n5 / 630.0
                - 1983433.0 * n6 / 1935360.0,
            61.0 * n3 / 240.0 - 103.0 * n4 / 140.0
                + 15061.0 * n5 / 26880.0
                + 167603.0 * n6 / 181440.0,
            49561.0 * n4 / 161280.0 - 179.0 * n5 / 168.0 + 6601661.0 * n6 / 7257600.0,
            34729.0 * n5 / 80640.0 - 3418889.0 * n6 / 1995840.0,
            212378941.0 * n6 / 319334400.0,
        ];
        let beta = [
            n / 2.0 - 2.0 * n2 / 3.0 + 37.0 * n3 / 96.0 - n4 / 360.0 - 81.0 * n5 / 512.0
                + 96199.0 * n6 / 604800.0,
            n2 / 48.0 + n3 / 15.0 - 437.0 * n4 / 1440.0 + 46.0 * n5 / 105.0
                - 1118711.0 * n6 / 3870720.0,
            17.0 * n3 / 480.0 - 37.0 * n4 / 840.0 - 209.0 * n5 / 4480.0 + 5569.0 * n6 / 90720.0,
            4397.0 * n4 / 161280.0 - 11.0 * n5 / 504.0 - 830251.0 * n6 / 7257600.0,
            4583.0 * n5 / 161280.0 - 108847.0 * n6 / 3991680.0,
            20648693.0 * n6 / 638668800.0,
        ];
        let delta = [
            2.0 * n - 2.0 * n2 / 3.0 - 2.0 * n3 + 116.0 * n4 / 45.0 + 26.0 * n5 / 45.0
                - 2854.0 * n6 / 675.0,
            7.0 * n2 / 3.0 - 8.0 * n3 / 5.0 - 227.0 * n4 / 45.0
                + 2704.0 * n5 / 315.0
                + 2323.0 * n6 / 945.0,
            56.0 * n3 / 15.0 - 136.0 * n4 / 35.0 - 1262.0 * n5 / 105.0 + 73814.0 * n6 / 2835.0,
            4279.0 * n4 / 630.0 - 332.0 * n5 / 35.0 - 399572.0 * n6 / 14175.0,
            4174.0 * n5 / 315.0 - 144838.0 * n6 / 6237.0,
            601676.0 * n6 / 22275.0,
        ];
        TransverseMercator {
            lon0,
            k0,
            e0,
            n0,
            a_rect,
            alpha,
            beta,
            delta,
            e: 2.0 * n.sqrt() / (1.0 + n),
        }
    }

    /// Easting, northing (m) of a longitude/latitude (degrees).
    pub fn forward(&self, lon: f64, lat: f64) -> (f64, f64) {
        let phi = lat.to_radians();
        let lam = (lon - self.lon0).to_radians();
        let s = phi.sin();
        let t = (s.atanh() - self.e * (self.e * s).atanh()).sinh();
        let xi_p = t.atan2(lam.cos());
        let eta_p = (lam.sin() / (1.0 + t * t).sqrt()).atanh();
        let (mut xi, mut eta) = (xi_p, eta_p);
        for (j, a) in self.alpha.iter().enumerate() {
            let k = 2.0 * (j + 1) as f64;
            xi += a * (k * xi_p).sin() * (k * eta_p).cosh();
            eta += a * (k * xi_p).cos() * (k * eta_p).sinh();
        }
        (
            self.e0 + self.k0 * self.a_rect * eta,
            self.n0 + self.k0 * self.a_rect * xi,
        )
    }

    /// Longitude/latitude (degrees) of an easting, northing (m).
    pub fn inverse(&self, x: f64, y: f64) -> (f64, f64) {
        let xi = (y - self.n0) / (self.k0 * self.a_rect);
        let eta = (x - self.e0) / (self.k0 * self.a_rect);
        let (mut xi_p, mut eta_p) = (xi, eta);
        for (j, b) in self.beta.iter().enumerate() {
            let k = 2.0 * (j + 1) as f64;
            xi_p -= b * (k * xi).sin() * (k * eta).cosh();
            eta_p -= b * (k * xi).cos() * (k * eta).sinh();
        }
        let chi = (xi_p.sin() / eta_p.cosh()).asin();
        let mut phi = chi;
        for (j, d) in self.delta.iter().enumerate() {
            phi += d * (2.0 * (j + 1) as f64 * chi).sin();
        }
        let lam = eta_p.sinh().atan2(xi_p.cos());
        (self.lon0 + lam.to_degrees(), phi.to_degrees())
    }
}

/// How a raster's map coordinates relate to longitude/latitude.
#[derive(Debug, Clone, Copy)]
pub enum SourceCrs {
    /// Longitude/latitude in degrees (any geographic CRS, taken as WGS 84).
    Geographic,
    /// Web Mercator metres.
    WebMercator,
    /// UTM metres.
    Utm(TransverseMercator),
}

impl SourceCrs {
    /// The CRS of `georef` when it is one of those above (geographic, UTM
    /// on WGS 84 / ETRS89, Web Mercator), else `None`.
    pub fn known(georef: &GeoRef) -> Option<SourceCrs> {
        let crs = &georef.crs;
        if !georef.georeferenced {
            return None;
        }
        if crs.geographic {
            return Some(SourceCrs::Geographic);
        }
        match crs.epsg? {
            3857 | 900913 => Some(SourceCrs::WebMercator),
            e @ 32601..=32660 => Some(SourceCrs::Utm(TransverseMercator::utm(e - 32600, true))),
            e @ 32701..=32760 => Some(SourceCrs::Utm(TransverseMercator::utm(e - 32700, false))),
            // ETRS89 / UTM zones 28N-38N: GRS 80 differs from WGS 84 by < 0.1 mm here.
            e @ 25828..=25838 => Some(SourceCrs::Utm(TransverseMercator::utm(e - 25800, true))),
            _ => None,
        }
    }

    /// The CRS of `georef`, or an error naming what is supported.
    pub fn of(georef: &GeoRef, what: &std::path::Path) -> Result<SourceCrs> {
        let crs = &georef.crs;
        if !georef.georeferenced || (crs.epsg.is_none() && !crs.geographic) {
            return Err(Error::unsupported(
                what,
                "the raster has no coordinate reference system; web-map tiles need one (geographic, UTM or EPSG:3857)",
            ));
        }
        if let Some(known) = SourceCrs::known(georef) {
            return Ok(known);
        }
        Err(Error::unsupported(
            what,
            format!(
                "coordinate reference system {} is not supported for web-map tiles: use a geographic CRS, UTM (EPSG:326zz/327zz/258zz) or EPSG:3857 (reproject with gdalwarp first)",
                crs.epsg.map(|e| format!("EPSG:{e}")).unwrap_or_else(|| "without EPSG code".into())
            ),
        ))
    }

    /// Map coordinates of a longitude/latitude.
    pub fn from_lonlat(&self, lon: f64, lat: f64) -> (f64, f64) {
        match self {
            SourceCrs::Geographic => (lon, lat),
            SourceCrs::WebMercator => lonlat_to_merc(lon, lat),
            SourceCrs::Utm(tm) => tm.forward(lon, lat),
        }
    }

    /// Longitude/latitude of map coordinates.
    pub fn to_lonlat(&self, x: f64, y: f64) -> (f64, f64) {
        match self {
            SourceCrs::Geographic => (x, y),
            SourceCrs::WebMercator => merc_to_lonlat(x, y),
            SourceCrs::Utm(tm) => tm.inverse(x, y),
        }
    }
}
