//! Solar radiation and the diurnal anisotropic heat index.
//!
//! ## Sun position
//! [`sun_position`] implements NOAA's solar calculator formulas (NOAA Global
//! Monitoring Laboratory, "General Solar Position Calculations" and the NOAA
//! solar calculator spreadsheet, after Meeus 1991, *Astronomical Algorithms*,
//! ch. 25 and 28): Julian century, the Sun's apparent longitude, obliquity,
//! declination, equation of time, true solar time, hour angle, zenith and
//! azimuth; accuracy about 0.01° for 1800-2100 (checked in the tests against
//! the published example of Reda & Andreas 2004, NREL/TP-560-34302).
//! [`refraction_deg`] is NOAA's approximate atmospheric refraction.
//!
//! ## Clear-sky irradiance (Campbell & Norman 1998)
//! Campbell & Norman 1998, *An Introduction to Environmental Biophysics*, 2nd
//! ed., ch. 11: beam irradiance normal to the sun `S_b = S0·E0·τ^m`, diffuse on
//! a horizontal surface `S_d = 0.3·(1 − τ^m)·S0·E0·cos z`, with the solar
//! constant S0 = 1361 W/m² (Kopp & Lean 2011), `E0 = 1/r²` the Earth-Sun
//! distance factor (r in AU from the NOAA formulas), the air mass
//! `m = 1/cos z` (sea level) and the atmospheric transmittance τ (parameter
//! `tau`, default 0.7; clear skies are 0.6-0.75).
//!
//! On a cell with unit normal n (Horn 1981 gradient) the direct irradiance is
//! `S_b·max(n·s, 0)` (s the unit vector to the sun: the terrain incidence
//! term) unless the cell is in a cast shadow: the sun's elevation is below
//! the horizon elevation at the sun's azimuth, interpolated linearly in
//! azimuth between the 8 or 16 exact lattice-ray horizons of
//! [`super::horizon`] within the `radius` cutoff (as GRASS r.sun interpolates
//! precomputed horizons: Hofierka & Šúri 2002, "The solar radiation model for
//! Open source GIS", Proc. Open source GIS - GRASS users conference). The
//! diffuse irradiance is isotropic: `S_d` times the sky-view factor of the same
//! horizons (Zakšek et al. 2011). Time is apparent solar time at each cell
//! (hour angle 15°·(hour − 12)); the declination and E0 are those of the day's
//! solar noon (UTC noon at longitude 0).
//!
//! Daily sums integrate from 0 to 24 h with the midpoint rule (`step`
//! minutes) in Wh/m²; one `hour` gives W/m². The annual sum samples every
//! `days`-th day, weights it by the days it stands for (365 in total) and
//! reports kWh/m². The latitude is that of each row on geographic rasters, or
//! the `lat` parameter (required on projected rasters: orogen does not invert
//! map projections). Azimuths assume north-up rasters.
//!
//! ## Heat index
//! Böhner & Antonić 2009, "Land-surface parameters specific to
//! topo-climatology", in Hengl & Reuter (eds.), *Geomorphometry*, ch. 8: the
//! diurnal anisotropic heating `DAH = cos(α_max − α)·atan(β)` with α the
//! aspect, β the slope (radians) and α_max = 202.5° (as SAGA's tool); flat
//! cells are 0.

#![allow(clippy::needless_range_loop)] // index loops over parallel per-cell arrays

use super::horizon::{scan, step_azimuth, HorizonMethod, DIRS};
use super::neighbourhood::{walk_3x3, EdgeMode};
use super::registry::{metric_def, Metric, MetricDef, ScratchClass};
use super::registry::{MetricKind, ParamDef, ParamKind, Resolved};
use super::terrain::horn_gradient;
use super::tile::Tile;
use crate::error::{Error, Result};
use crate::raster::{Grid, RasterInfo, TileView};
use std::f64::consts::PI;

/// Solar constant (W/m²), Kopp & Lean 2011, GRL 38(1).
pub const SOLAR_CONSTANT: f64 = 1361.0;

/// Citation of the solar metrics.
pub const SOLAR_CITE: &str = "sun position: NOAA solar calculator (Meeus 1991); clear sky: Campbell & Norman 1998 ch. 11; shadows from lattice horizons as r.sun (Hofierka & Suri 2002)";

const DAY: ParamDef = ParamDef {
    name: "day",
    kind: ParamKind::Value,
    default: "172",
    range: "day of the year 1..=366",
};
const HOUR: ParamDef = ParamDef {
    name: "hour",
    kind: ParamKind::Value,
    default: "day",
    range: "apparent solar time 0..=24 (W/m2), or day for the daily sum (Wh/m2)",
};
const STEP: ParamDef = ParamDef {
    name: "step",
    kind: ParamKind::Value,
    default: "15",
    range: "time step of the daily sum, minutes, 1..=240",
};
const STEP_ANNUAL: ParamDef = ParamDef {
    name: "step",
    kind: ParamKind::Value,
    default: "30",
    range: "time step of the daily sums, minutes, 1..=240",
};
const DAYS: ParamDef = ParamDef {
    name: "days",
    kind: ParamKind::Value,
    default: "7",
    range: "sample every n-th day of the year, 1..=366",
};
const TAU: ParamDef = ParamDef {
    name: "tau",
    kind: ParamKind::Value,
    default: "0.7",
    range: "clear-sky atmospheric transmittance 0.05..=1",
};
const LAT: ParamDef = ParamDef {
    name: "lat",
    kind: ParamKind::Value,
    default: "auto",
    range: "latitude in degrees -90..=90; auto = each row's (geographic rasters only)",
};
const RADIUS: ParamDef = ParamDef {
    name: "radius",
    kind: ParamKind::Radius,
    default: "10c",
    range: "1c..=2000c, or a length in m/km (> 0); the shadow (horizon) search cutoff",
};
const DIRECTIONS16: ParamDef = ParamDef {
    name: "directions",
    kind: ParamKind::Directions,
    default: "16",
    range: "8 or 16 horizon directions",
};
/// `heat_index`'s azimuth of maximal heating.
pub const ALPHA_MAX: ParamDef = ParamDef {
    name: "alpha_max",
    kind: ParamKind::Value,
    default: "202.5",
    range: "azimuth of maximal heating, degrees 0..=360",
};

/// Units of `solar_direct` and `solar_global`: a daily sum or one hour's irradiance.
const DAY_OR_HOUR_UNITS: &str = "Wh/m2 (day), W/m2 (hour)";
/// Parameters of `solar_direct` and `solar_global`.
pub const SOLAR_PARAMS: &[ParamDef] = &[DAY, HOUR, STEP, TAU, LAT, RADIUS, DIRECTIONS16];
/// Parameters of `solar_annual`.
pub const ANNUAL_PARAMS: &[ParamDef] = &[DAYS, STEP_ANNUAL, TAU, LAT, RADIUS, DIRECTIONS16];

/// Refuse solar metrics without a latitude on projected rasters, and exact
/// visibility indices beyond [`super::visibility::MAX_EXACT_RADIUS`].
pub fn check_resolved(r: &Resolved, info: &RasterInfo) -> Result<()> {
    let max = super::visibility::MAX_EXACT_RADIUS;
    if r.spec.kind == MetricKind::VisibilityIndexExact && r.radius_cells > max {
        return Err(Error::invalid(format!(
            "{}: visibility_index_exact radius is {} cells, above its limit of {max} (O(r^3) per cell): use visibility_index for larger radii",
            info.path.display(),
            r.radius_cells
        )));
    }
    let solar = matches!(
        r.spec.kind,
        MetricKind::SolarDirect | MetricKind::SolarGlobal | MetricKind::SolarAnnual
    );
    let geographic = info.georef.georeferenced && info.georef.crs.geographic;
    if solar && r.spec.value("lat").is_none() && !geographic {
        return Err(Error::invalid(format!(
            "{}: {} needs the latitude of a projected raster: add :lat=DEGREES (e.g. {}:lat=46.5)",
            info.path.display(),
            r.spec.def().name,
            r.spec.def().name
        )));
    }
    Ok(())
}

/// Julian day of a calendar date (Gregorian) at `hour` UTC (Meeus 1991, ch. 7).
pub fn julian_day(year: i32, month: u32, day: u32, hour: f64) -> f64 {
    let (mut y, mut m) = (year as f64, month as f64);
    if month <= 2 {
        y -= 1.0;
        m += 12.0;
    }
    let a = (y / 100.0).floor();
    let b = 2.0 - a + (a / 4.0).floor();
    (365.25 * (y + 4716.0)).floor() + (30.6001 * (m + 1.0)).floor() + day as f64 + b - 1524.5
        + hour / 24.0
}

/// The Sun seen from the Earth at a Julian day (NOAA formulas).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SunGeometry {
    /// Declination (degrees).
    pub declination: f64,
    /// Equation of time (minutes).
    pub eq_time: f64,
    /// Earth-Sun distance (AU).
    pub distance_au: f64,
}

/// Declination, equation of time and distance at Julian day `jd`.
pub fn sun_geometry(jd: f64) -> SunGeometry {
    let t = (jd - 2_451_545.0) / 36_525.0;
    let l0 = (280.46646 + t * (36000.76983 + t * 0.0003032)).rem_euclid(360.0);
    let m = 357.52911 + t * (35999.05029 - 0.0001537 * t);
    let e = 0.016708634 - t * (0.000042037 + 0.0000001267 * t);
    let mr = m.to_radians();
    let c = mr.sin() * (1.914602 - t * (0.004817 + 0.000014 * t))
        + (2.0 * mr).sin() * (0.019993 - 0.000101 * t)
        + (3.0 * mr).sin() * 0.000289;
    let true_long = l0 + c;
    let anomaly = (m + c).to_radians();
    let distance_au = 1.000001018 * (1.0 - e * e) / (1.0 + e * anomaly.cos());
    let omega = (125.04 - 1934.136 * t).to_radians();
    let lambda = (true_long - 0.00569 - 0.00478 * omega.sin()).to_radians();
    let eps0 = 23.0 + (26.0 + (21.448 - t * (46.815 + t * (0.00059 - t * 0.001813))) / 60.0) / 60.0;
    let eps = (eps0 + 0.00256 * omega.cos()).to_radians();
    let declination = (eps.sin() * lambda.sin()).asin().to_degrees();
    let y = (eps / 2.0).tan().powi(2);
    let l0r = l0.to_radians();
    let eq_time = 4.0
        * (y * (2.0 * l0r).sin() - 2.0 * e * mr.sin() + 4.0 * e * y * mr.sin() * (2.0 * l0r).cos()
            - 0.5 * y * y * (4.0 * l0r).sin()
            - 1.25 * e * e * (2.0 * mr).sin())
        .to_degrees();
    SunGeometry {
        declination,
        eq_time,
        distance_au,
    }
}

/// Zenith and azimuth (degrees; azimuth clockwise from north) of the sun at
/// hour angle `hour_angle` (degrees, 0 at solar noon, positive after) for
/// declination `decl` and latitude `lat` (degrees). Geometric (no refraction).
pub fn zenith_azimuth(lat: f64, decl: f64, hour_angle: f64) -> (f64, f64) {
    let (phi, d, h) = (lat.to_radians(), decl.to_radians(), hour_angle.to_radians());
    let cz = (phi.sin() * d.sin() + phi.cos() * d.cos() * h.cos()).clamp(-1.0, 1.0);
    let z = cz.acos();
    // Azimuth from the east and north components of the sun vector.
    let east = -d.cos() * h.sin();
    let north = phi.cos() * d.sin() - phi.sin() * d.cos() * h.cos();
    let az = east.atan2(north).to_degrees().rem_euclid(360.0);
    (z.to_degrees(), az)
}

/// Sun position for a UTC time: `(zenith, azimuth)` in degrees, geometric
/// (add [`refraction_deg`] to the elevation for the apparent position).
pub fn sun_position(
    year: i32,
    month: u32,
    day: u32,
    hour_utc: f64,
    lat: f64,
    lon: f64,
) -> (f64, f64) {
    let g = sun_geometry(julian_day(year, month, day, hour_utc));
    let tst = (hour_utc * 60.0 + g.eq_time + 4.0 * lon).rem_euclid(1440.0);
    let ha = tst / 4.0 - 180.0;
    zenith_azimuth(lat, g.declination, ha)
}

/// NOAA's approximate atmospheric refraction (degrees) at true elevation `e` (degrees).
pub fn refraction_deg(e: f64) -> f64 {
    let arcsec = if e > 85.0 {
        0.0
    } else if e > 5.0 {
        let t = e.to_radians().tan();
        58.1 / t - 0.07 / t.powi(3) + 0.000086 / t.powi(5)
    } else if e > -0.575 {
        1735.0 + e * (-518.2 + e * (103.4 + e * (-12.79 + e * 0.711)))
    } else {
        -20.774 / e.to_radians().tan()
    };
    arcsec / 3600.0
}

/// Declination (degrees) and distance factor `E0 = 1/r²` at solar noon
/// (UTC noon, longitude 0) of day-of-year `day` (counted in 2001).
pub fn day_geometry(day: f64) -> (f64, f64) {
    let jd = julian_day(2001, 1, 1, 12.0) + (day - 1.0);
    let g = sun_geometry(jd);
    (g.declination, 1.0 / (g.distance_au * g.distance_au))
}

/// One time step of one row: sun vector, beam and diffuse irradiance, and
/// the bracketing horizon directions.
struct Instant {
    s: [f64; 3],
    /// Sun elevation (radians).
    elev: f64,
    beam: f64,
    diffuse: f64,
    /// Horizon interpolation: slots (into the cell's direction list) and weight of the second.
    h0: usize,
    h1: usize,
    w: f64,
    /// Weight (hours) of this step in the sum.
    dt: f64,
}

/// Clear-sky beam (normal) and horizontal diffuse irradiance for zenith `z`
/// (radians), transmittance `tau`, distance factor `e0` (Campbell & Norman 1998).
pub fn clear_sky(z: f64, tau: f64, e0: f64) -> (f64, f64) {
    let cz = z.cos();
    if cz <= 0.0 {
        return (0.0, 0.0);
    }
    let t = tau.powf(1.0 / cz);
    let s0 = SOLAR_CONSTANT * e0;
    (s0 * t, 0.3 * (1.0 - t) * s0 * cz)
}

/// Compute a solar metric (`r.spec.kind` is `solar_direct`, `solar_global`
/// or `solar_annual`) for the core cells of `view`.
pub fn solar(view: &TileView<f32>, r: &Resolved, out: &mut Grid<f32>) -> Result<()> {
    let kind = r.spec.kind;
    let spec = &r.spec;
    let tau = spec.value("tau").unwrap_or(0.7);
    let dirs = spec.directions.min(16);
    let (cw, ch) = (view.core.w, view.core.h);
    let n = cw * ch;
    // Horizon elevation angles (radians; −π/2 if none) per cell and direction.
    let mut hor = vec![0f32; n * dirs];
    let mut svf = vec![0.0f64; n];
    let mut nsv = vec![0u32; n];
    let steps = r.radius_cells.max(1).min(view.halo);
    let cutoff = if r.radius_m > 0.0 {
        r.radius_m
    } else {
        f64::INFINITY
    };
    scan(
        view,
        steps,
        cutoff,
        dirs,
        false,
        HorizonMethod::Sweep,
        |d, up, _| {
            for i in 0..n {
                let t = up[i];
                let a = if t.is_nan() || t == f64::NEG_INFINITY {
                    -PI / 2.0
                } else {
                    nsv[i] += 1;
                    let a = t.atan();
                    svf[i] += a.max(0.0).sin();
                    a
                };
                hor[i * dirs + d] = a as f32;
            }
        },
    );
    // Days and their weights.
    let days: Vec<(f64, f64)> = match kind {
        MetricKind::SolarAnnual => {
            let every = spec.value("days").unwrap_or(7.0).round().max(1.0);
            let mut v = Vec::new();
            let mut d = 1.0;
            while d <= 365.0 {
                v.push((d, every.min(366.0 - d)));
                d += every;
            }
            v
        }
        _ => vec![(spec.value("day").unwrap_or(172.0), 1.0)],
    };
    let hour = if kind == MetricKind::SolarAnnual {
        None
    } else {
        spec.value("hour")
    };
    let step_h = spec.value("step").unwrap_or(15.0) / 60.0;
    let global = kind != MetricKind::SolarDirect;
    let h = view.halo;
    let gw = view.grid.width();
    let data = view.grid.data();
    let mut inst: Vec<Instant> = Vec::new();
    for y in 0..ch {
        let row = view.core.y + y as i64;
        let (ew, ns) = view.georef.cell_size_m(row);
        let lat = match spec.value("lat") {
            Some(l) => l,
            None => view.georef.pixel_to_map(0.5, row as f64 + 0.5).1,
        };
        if !lat.is_finite() {
            return Err(Error::invalid("solar: the row's latitude is not finite"));
        }
        // Lattice directions sorted by azimuth on this row.
        let mut order: Vec<(f64, usize)> = (0..dirs)
            .map(|d| (step_azimuth(DIRS[d].0, DIRS[d].1, ew, ns), d))
            .collect();
        order.sort_by(|a, b| a.0.total_cmp(&b.0));
        inst.clear();
        for &(day, weight) in &days {
            let (decl, e0) = day_geometry(day);
            let times: Vec<(f64, f64)> = match hour {
                Some(t) => vec![(t, 1.0)],
                None => {
                    let k = (24.0 / step_h).round().max(1.0) as usize;
                    let dt = 24.0 / k as f64;
                    (0..k).map(|i| ((i as f64 + 0.5) * dt, dt)).collect()
                }
            };
            for (t, dt) in times {
                let (zd, az) = zenith_azimuth(lat, decl, 15.0 * (t - 12.0));
                let z = zd.to_radians();
                if z.cos() <= 0.0 {
                    continue;
                }
                let (beam, diffuse) = clear_sky(z, tau, e0);
                let a = az.to_radians();
                let s = [z.sin() * a.sin(), z.sin() * a.cos(), z.cos()];
                // Bracketing directions in azimuth (cyclic).
                let m = order.len();
                let j = order.iter().position(|o| o.0 > az).unwrap_or(m);
                let (lo, hi) = ((j + m - 1) % m, j % m);
                let (alo, mut ahi) = (order[lo].0, order[hi].0);
                if ahi <= alo {
                    ahi += 360.0;
                }
                let mut x = az;
                if x < alo {
                    x += 360.0;
                }
                let w = ((x - alo) / (ahi - alo)).clamp(0.0, 1.0);
                inst.push(Instant {
                    s,
                    elev: PI / 2.0 - z,
                    beam,
                    diffuse,
                    h0: order[lo].1,
                    h1: order[hi].1,
                    w,
                    dt: dt * weight,
                });
            }
        }
        for x in 0..cw {
            let c = (y + h) * gw + x + h;
            let mut win = [0.0; 9];
            for (k, v) in win.iter_mut().enumerate() {
                *v = data[c + (k / 3) * gw + k % 3 - gw - 1] as f64;
            }
            let i = y * cw + x;
            if win.iter().any(|v| v.is_nan()) {
                out.set(x, y, f32::NAN);
                continue;
            }
            let (p, q) = horn_gradient(&win, ew, ns);
            let norm = (1.0 + p * p + q * q).sqrt();
            let nv = [-p / norm, -q / norm, 1.0 / norm];
            let sky = if nsv[i] > 0 {
                1.0 - svf[i] / nsv[i] as f64
            } else {
                1.0
            };
            let hz = &hor[i * dirs..(i + 1) * dirs];
            let mut sum = 0.0;
            for it in &inst {
                let horizon = (1.0 - it.w) * hz[it.h0] as f64 + it.w * hz[it.h1] as f64;
                let mut e = 0.0;
                if it.elev > horizon {
                    let cosi = nv[0] * it.s[0] + nv[1] * it.s[1] + nv[2] * it.s[2];
                    e += it.beam * cosi.max(0.0);
                }
                if global {
                    e += it.diffuse * sky;
                }
                sum += e * it.dt;
            }
            if kind == MetricKind::SolarAnnual {
                sum /= 1000.0;
            }
            out.set(x, y, sum as f32);
        }
    }
    Ok(())
}

/// Diurnal anisotropic heating of a 3x3 window (see the module doc).
#[inline]
pub fn heat_index(w: &[f64; 9], ew: f64, ns: f64, alpha_max_deg: f64) -> f64 {
    let (p, q) = horn_gradient(w, ew, ns);
    if p == 0.0 && q == 0.0 {
        return 0.0;
    }
    let g = (p * p + q * q).sqrt();
    let slope = g.atan();
    // cos(alpha_max − aspect) with aspect = atan2(−p, −q), expanded so that
    // no atan2/cos is evaluated per cell: (sin a, cos a) = (−p, −q)/g.
    let am = alpha_max_deg.to_radians();
    ((-q) * am.cos() + (-p) * am.sin()) / g * slope.atan()
}

/// Clear-sky irradiation (direct, global, annual).
pub struct Solar(MetricDef);

impl Metric for Solar {
    fn def(&self) -> &MetricDef {
        &self.0
    }
    fn halo(&self, m: &Resolved) -> usize {
        m.radius_cells.max(1)
    }
    fn scratch(&self, _m: &Resolved, tile: usize) -> Option<(ScratchClass, u64)> {
        Some(super::openness::horizon_scratch(tile))
    }
    fn bind(&self, r: &mut Resolved, info: &RasterInfo) -> Result<()> {
        // On a projected raster whose CRS orogen can invert (UTM, Web
        // Mercator) the latitude defaults to that of the raster's centre.
        let spec = &mut r.spec;
        if spec.value("lat").is_none() && info.georef.georeferenced && !info.georef.crs.geographic {
            if let Ok(crs) = crate::raster::proj::SourceCrs::of(&info.georef, &info.path) {
                let t = info.georef.transform;
                let (c, r) = (info.width as f64 / 2.0, info.height as f64 / 2.0);
                let (x, y) = (t[0] + c * t[1] + r * t[2], t[3] + c * t[4] + r * t[5]);
                let (_, lat) = crs.to_lonlat(x, y);
                if lat.is_finite() {
                    spec.values.insert("lat".to_string(), lat);
                }
            }
        }
        check_resolved(r, info)
    }
    fn run(&self, t: &mut Tile<'_>, m: &Resolved, o: &mut Grid<f32>) -> Result<()> {
        solar(t.view, m, o)
    }
}

/// Böhner & Antonić's diurnal anisotropic heating on the 3x3 window.
pub struct HeatIndex(MetricDef);

impl Metric for HeatIndex {
    fn def(&self) -> &MetricDef {
        &self.0
    }
    fn run(&self, t: &mut Tile<'_>, m: &Resolved, o: &mut Grid<f32>) -> Result<()> {
        let amax = m.spec.value("alpha_max").unwrap_or(202.5);
        walk_3x3(t.view, o, EdgeMode::Nodata, f32::NAN, |w, ew, ns| {
            heat_index(w, ew, ns, amax) as f32
        });
        Ok(())
    }
}

/// `solar_direct`: clear-sky direct (beam) irradiation on the slope with cast shadows, for one solar hour or the whole day.
///
/// Source: [`SOLAR_CITE`].
pub static SOLAR_DIRECT: Solar = Solar(metric_def!(
        SolarDirect,
        "solar_direct",
        SOLAR_PARAMS,
        DAY_OR_HOUR_UNITS,
        "clear-sky direct (beam) irradiation on the slope with cast shadows, for one solar hour or the whole day",
        SOLAR_CITE
    ));

/// `solar_global`: clear-sky direct + isotropic diffuse (x sky-view factor) irradiation, one solar hour or the whole day.
///
/// Source: [`SOLAR_CITE`].
pub static SOLAR_GLOBAL: Solar = Solar(metric_def!(
        SolarGlobal,
        "solar_global",
        SOLAR_PARAMS,
        DAY_OR_HOUR_UNITS,
        "clear-sky direct + isotropic diffuse (x sky-view factor) irradiation, one solar hour or the whole day",
        SOLAR_CITE
    ));

/// `solar_annual`: clear-sky direct + isotropic diffuse irradiation over a year (sampled days, scaled to 365).
///
/// Source: [`SOLAR_CITE`].
pub static SOLAR_ANNUAL: Solar = Solar(metric_def!(
    SolarAnnual,
    "solar_annual",
    ANNUAL_PARAMS,
    "kWh/m2",
    "clear-sky direct + isotropic diffuse irradiation over a year (sampled days, scaled to 365)",
    SOLAR_CITE
));

/// `heat_index`: diurnal anisotropic heating cos(alpha_max - aspect) * atan(slope in radians); flat = 0.
///
/// Source: Böhner & Antonić 2009 (in Hengl & Reuter, Geomorphometry, ch. 8), as SAGA.
pub static HEAT_INDEX: HeatIndex = HeatIndex(metric_def!(
    HeatIndex,
    "heat_index",
    &[ALPHA_MAX],
    "-1.57..1.57",
    "diurnal anisotropic heating cos(alpha_max - aspect) * atan(slope in radians); flat = 0",
    "Böhner & Antonić 2009 (in Hengl & Reuter, Geomorphometry, ch. 8), as SAGA"
));
