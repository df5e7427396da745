//! Descriptors of Horn's 3x3 gradient: its components, slope and aspect (as
//! `gdaldem`), northness and eastness, the unit surface normal and the sky
//! view of a tilted plane. Nodata where a neighbour of the 3x3 window is
//! nodata or beyond the raster (gdaldem's default).
//!
//! Source: Horn, B.K.P. (1981), "Hill shading and the reflectance map",
//! Proc. IEEE 69(1), 14-47 (the 3x3 weighted gradient, see [`super::terrain`]);
//! the sky view of a plane of slope β, `(1 + cos β)/2`, is Liu & Jordan's
//! isotropic sky (1963, Solar Energy 7(2)).

use super::neighbourhood::{walk_3x3, EdgeMode};
use super::param::UNITS;
use super::registry::{metric_def, Metric, MetricDef, MetricKind};
use super::spec::Resolved;
use super::terrain::horn_gradient;
use super::tile::Tile;
use crate::error::Result;
use crate::exec::LocalStep;
use crate::raster::Grid;

/// Citation of the gradient metrics.
pub const HORN: &str = "Horn 1981, Proc. IEEE 69(1) (3x3 weighted gradient)";

/// A descriptor of Horn's gradient on the 3x3 window.
pub struct Gradient(MetricDef);

impl Metric for Gradient {
    fn def(&self) -> &MetricDef {
        &self.0
    }
    fn run(&self, t: &mut Tile<'_>, m: &Resolved, o: &mut Grid<f32>) -> Result<()> {
        let (view, nan) = (t.view, f32::NAN);
        use MetricKind::*;
        match self.0.kind {
            Dzdx => walk_3x3(view, o, EdgeMode::Nodata, nan, |w, ew, ns| {
                horn_gradient(w, ew, ns).0 as f32
            }),
            Dzdy => walk_3x3(view, o, EdgeMode::Nodata, nan, |w, ew, ns| {
                horn_gradient(w, ew, ns).1 as f32
            }),
            Slope => {
                let s = super::terrain::Slope {
                    units: m.spec.units,
                    ..super::terrain::Slope::default()
                };
                s.run(t.inputs, std::slice::from_mut(o))?;
            }
            Aspect => {
                super::terrain::Aspect::default().run(t.inputs, std::slice::from_mut(o))?;
            }
            // cos(aspect)·sin(slope) = −q/√(1+p²+q²) (aspect = atan2(−p, −q)).
            Northness | NormalY => walk_3x3(view, o, EdgeMode::Nodata, nan, |w, ew, ns| {
                let (p, q) = horn_gradient(w, ew, ns);
                (-q / (1.0 + p * p + q * q).sqrt()) as f32
            }),
            Eastness | NormalX => walk_3x3(view, o, EdgeMode::Nodata, nan, |w, ew, ns| {
                let (p, q) = horn_gradient(w, ew, ns);
                (-p / (1.0 + p * p + q * q).sqrt()) as f32
            }),
            NormalZ => walk_3x3(view, o, EdgeMode::Nodata, nan, |w, ew, ns| {
                let (p, q) = horn_gradient(w, ew, ns);
                (1.0 / (1.0 + p * p + q * q).sqrt()) as f32
            }),
            _ => walk_3x3(view, o, EdgeMode::Nodata, nan, |w, ew, ns| {
                // Sky view of the plane: cos β = 1/√(1+p²+q²).
                let (p, q) = horn_gradient(w, ew, ns);
                ((1.0 + 1.0 / (1.0 + p * p + q * q).sqrt()) / 2.0) as f32
            }),
        }
        Ok(())
    }
}

/// `dzdx`: gradient component east (dz/dx).
///
/// Source: [`HORN`].
pub static DZDX: Gradient = Gradient(metric_def!(
    Dzdx,
    "dzdx",
    &[],
    "z/m",
    "gradient component east (dz/dx)",
    HORN
));

/// `dzdy`: gradient component north (dz/dy).
///
/// Source: [`HORN`].
pub static DZDY: Gradient = Gradient(metric_def!(
    Dzdy,
    "dzdy",
    &[],
    "z/m",
    "gradient component north (dz/dy)",
    HORN
));

/// `slope`: slope angle (as the `slope` command).
///
/// Source: [`HORN`].
pub static SLOPE: Gradient = Gradient(metric_def!(
    Slope,
    "slope",
    &[UNITS],
    "degrees|percent",
    "slope angle (as the `slope` command)",
    HORN
));

/// `aspect`: azimuth of steepest descent, clockwise from north; flat = nodata.
///
/// Source: [`HORN`].
pub static ASPECT: Gradient = Gradient(metric_def!(
        Aspect,
        "aspect",
        &[],
        "degrees",
        "azimuth of steepest descent, clockwise from north; flat = nodata",
        HORN;
    Angle
));

/// `northness`: cos(aspect)*sin(slope), slope-weighted so flat cells are 0 (= normal_y).
///
/// Source: aspect and slope of Horn 1981; slope-weighted form chosen here (plain cos(aspect) is undefined on flats).
pub static NORTHNESS: Gradient = Gradient(metric_def!(
        Northness,
        "northness",
        &[],
        "-1..1",
        "cos(aspect)*sin(slope), slope-weighted so flat cells are 0 (= normal_y)",
        "aspect and slope of Horn 1981; slope-weighted form chosen here (plain cos(aspect) is undefined on flats)"
    ));

/// `eastness`: sin(aspect)*sin(slope), slope-weighted so flat cells are 0 (= normal_x).
///
/// Source: aspect and slope of Horn 1981; slope-weighted form chosen here (plain sin(aspect) is undefined on flats).
pub static EASTNESS: Gradient = Gradient(metric_def!(
        Eastness,
        "eastness",
        &[],
        "-1..1",
        "sin(aspect)*sin(slope), slope-weighted so flat cells are 0 (= normal_x)",
        "aspect and slope of Horn 1981; slope-weighted form chosen here (plain sin(aspect) is undefined on flats)"
    ));

/// `normal_x`: unit surface normal, east component -p/sqrt(1+p^2+q^2).
///
/// Source: [`HORN`].
pub static NORMAL_X: Gradient = Gradient(metric_def!(
    NormalX,
    "normal_x",
    &[],
    "-1..1",
    "unit surface normal, east component -p/sqrt(1+p^2+q^2)",
    HORN
));

/// `normal_y`: unit surface normal, north component -q/sqrt(1+p^2+q^2).
///
/// Source: [`HORN`].
pub static NORMAL_Y: Gradient = Gradient(metric_def!(
    NormalY,
    "normal_y",
    &[],
    "-1..1",
    "unit surface normal, north component -q/sqrt(1+p^2+q^2)",
    HORN
));

/// `normal_z`: unit surface normal, up component 1/sqrt(1+p^2+q^2).
///
/// Source: [`HORN`].
pub static NORMAL_Z: Gradient = Gradient(metric_def!(
    NormalZ,
    "normal_z",
    &[],
    "0..1",
    "unit surface normal, up component 1/sqrt(1+p^2+q^2)",
    HORN
));

/// `sky_view_approx`: (1 + cos slope)/2: the sky view of an infinite plane of that slope.
///
/// Source: isotropic sky view of a tilted plane (Liu & Jordan 1963, Solar Energy 7(2)); Horn slope.
pub static SKY_VIEW_APPROX: Gradient = Gradient(metric_def!(
    SkyViewApprox,
    "sky_view_approx",
    &[],
    "0..1",
    "(1 + cos slope)/2: the sky view of an infinite plane of that slope",
    "isotropic sky view of a tilted plane (Liu & Jordan 1963, Solar Energy 7(2)); Horn slope"
));
