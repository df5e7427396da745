//! Slope, aspect and hillshade from Horn's 3x3 gradient, as `gdaldem` defines
//! them (GDAL documentation, `gdaldem`: slope, aspect, hillshade).
//!
//! Source: Horn, B.K.P. (1981), "Hill shading and the reflectance map",
//! Proc. IEEE 69(1), 14-47, eq. for the 3x3 weighted gradient:
//! `dz/dx = ((c + 2f + i) - (a + 2d + g)) / (8 Δx)`,
//! `dz/dy = ((a + 2b + c) - (g + 2h + i)) / (8 Δy)` (y pointing north).
//! Unlike gdaldem, cell sizes are the true metric sizes of each row (so slopes
//! on geographic DEMs need no `-s` scale) and aspect uses them too (gdaldem's
//! aspect assumes square cells; for square cells both agree).

use super::neighbourhood::{walk_3x3, EdgeMode};
use crate::error::Result;
use crate::exec::output::{OutputKind, OutputSpec};
use crate::exec::LocalStep;
use crate::raster::{DType, Grid, TileView};
use serde::{Deserialize, Serialize};
use serde_json::json;

pub use crate::raster::neighbours::horn_gradient;

/// Arctangent of `x >= 0` (NaN propagates), max error 7e-9 rad (4e-7°):
/// an odd degree-17 polynomial fitted by least squares at Chebyshev nodes on
/// [0, 1] (near-minimax; J.-M. Muller, *Elementary Functions*, 3rd ed. 2016,
/// ch. 3), with `atan x = π/2 − atan(1/x)` above 1. Branch-light and about
/// twice as fast as libm's `atan`, which dominated slope's run time.
#[inline]
pub fn atan_nonneg(x: f64) -> f64 {
    const C: [f64; 9] = [
        0.99999990554571,
        -0.33332657852597425,
        0.19986537489167466,
        -0.14164333375291085,
        0.10507319787676575,
        -0.07247950663674324,
        0.03989956005716888,
        -0.014458697078641336,
        0.0024682466275341847,
    ];
    let inv = x > 1.0;
    let t = if inv { 1.0 / x } else { x };
    // Estrin's scheme: shorter dependency chains than Horner's.
    let t2 = t * t;
    let t4 = t2 * t2;
    let t8 = t4 * t4;
    let p01 = C[0] + C[1] * t2;
    let p23 = C[2] + C[3] * t2;
    let p45 = C[4] + C[5] * t2;
    let p67 = C[6] + C[7] * t2;
    let p = (p01 + p23 * t4) + (p45 + p67 * t4) * t8 + C[8] * (t8 * t8);
    let a = p * t;
    if inv {
        std::f64::consts::FRAC_PI_2 - a
    } else {
        a
    }
}

/// Slope units.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SlopeUnits {
    /// Degrees from horizontal.
    #[default]
    Degrees,
    /// Percent rise (100 tan θ).
    Percent,
}

/// Nodata written by slope and aspect (gdaldem's value).
pub const SLOPE_NODATA: f64 = -9999.0;

/// Slope (Horn 1981) as a local step: f32 output, NaN = nodata.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Slope {
    pub units: SlopeUnits,
    /// Vertical exaggeration (gdaldem `-s` is a horizontal scale; here cell sizes are already metres).
    pub z_factor: f64,
    pub edge: EdgeMode,
}

impl Default for Slope {
    fn default() -> Self {
        Slope {
            units: SlopeUnits::Degrees,
            z_factor: 1.0,
            edge: EdgeMode::Nodata,
        }
    }
}

impl LocalStep for Slope {
    type In = f32;
    type Out = f32;
    fn name(&self) -> String {
        "slope".into()
    }
    fn params(&self) -> serde_json::Value {
        json!(self)
    }
    fn halo(&self) -> usize {
        1
    }
    fn outputs(&self) -> Vec<OutputSpec> {
        vec![OutputSpec::continuous(DType::F32, SLOPE_NODATA)]
    }
    fn run(&self, inputs: &[TileView<f32>], out: &mut [Grid<f32>]) -> Result<()> {
        let z = self.z_factor;
        let pct = self.units == SlopeUnits::Percent;
        // Gradient magnitude first, then one branch-free pass of arctangents
        // that the compiler vectorises (a scalar atan per cell dominated).
        walk_3x3(&inputs[0], &mut out[0], self.edge, f32::NAN, |w, ew, ns| {
            let (dx, dy) = horn_gradient(w, ew, ns);
            let g = z * (dx * dx + dy * dy).sqrt();
            (if pct { 100.0 * g } else { g }) as f32
        });
        if !pct {
            for v in out[0].data_mut() {
                *v = atan_nonneg(*v as f64).to_degrees() as f32;
            }
        }
        Ok(())
    }
}

/// Aspect (Horn 1981): azimuth of the downslope direction, degrees clockwise
/// from north in [0, 360). Flat cells (zero gradient) are nodata, or 0 with
/// `zero_for_flat` (gdaldem `-zero_for_flat`).
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct Aspect {
    pub edge: EdgeMode,
    pub zero_for_flat: bool,
}

/// `atan2(y, x)` in radians from [`atan_nonneg`] by octant reduction
/// (max error 7e-9 rad; `atan2(0, 0)` = 0). Branch-light, so loops using it
/// vectorise, unlike libm's `atan2`.
#[inline]
pub fn atan2_fast(y: f64, x: f64) -> f64 {
    use std::f64::consts::{FRAC_PI_2, PI};
    let (ax, ay) = (x.abs(), y.abs());
    let (lo, hi) = if ay > ax { (ax, ay) } else { (ay, ax) };
    let t = if hi == 0.0 { 0.0 } else { lo / hi };
    let mut a = atan_nonneg(t);
    if ay > ax {
        a = FRAC_PI_2 - a;
    }
    if x < 0.0 {
        a = PI - a;
    }
    if y < 0.0 {
        -a
    } else {
        a
    }
}

/// Azimuth of steepest descent for a gradient (east, north components).
#[inline]
pub fn aspect_deg(dzdx: f64, dzdy: f64) -> f64 {
    let a = atan2_fast(-dzdx, -dzdy).to_degrees();
    let a = if a < 0.0 { a + 360.0 } else { a };
    if a >= 360.0 {
        0.0
    } else {
        a
    }
}

impl LocalStep for Aspect {
    type In = f32;
    type Out = f32;
    fn name(&self) -> String {
        "aspect".into()
    }
    fn params(&self) -> serde_json::Value {
        json!(self)
    }
    fn halo(&self) -> usize {
        1
    }
    fn outputs(&self) -> Vec<OutputSpec> {
        vec![OutputSpec::continuous(DType::F32, SLOPE_NODATA).with_kind(OutputKind::Angle)]
    }
    fn run(&self, inputs: &[TileView<f32>], out: &mut [Grid<f32>]) -> Result<()> {
        let zf = self.zero_for_flat;
        walk_3x3(&inputs[0], &mut out[0], self.edge, f32::NAN, |w, ew, ns| {
            let (dx, dy) = horn_gradient(w, ew, ns);
            if dx == 0.0 && dy == 0.0 {
                if zf {
                    0.0
                } else {
                    f32::NAN
                }
            } else {
                aspect_deg(dx, dy) as f32
            }
        });
        Ok(())
    }
}

/// Hillshade (Horn gradient, Lambertian reflectance for a light at `azimuth`
/// degrees clockwise from north and `altitude` degrees above the horizon), on
/// gdaldem's scale: `1 + 254·cos(i)` rounded, 1 where the cell faces away from
/// the light, 0 = nodata. `cos(i) = (sin alt − z·p·sin az·cos alt −
/// z·q·cos az·cos alt) / √(1 + z²(p² + q²))` with p, q = dz/dx (east), dz/dy (north).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Hillshade {
    pub azimuth: f64,
    pub altitude: f64,
    pub z_factor: f64,
    pub edge: EdgeMode,
}

impl Default for Hillshade {
    fn default() -> Self {
        Hillshade {
            azimuth: 315.0,
            altitude: 45.0,
            z_factor: 1.0,
            edge: EdgeMode::Nodata,
        }
    }
}

impl Hillshade {
    /// Light constants: (sin alt, z·sin az·cos alt, z·cos az·cos alt, z²).
    #[inline]
    fn light(&self) -> [f64; 4] {
        let z = self.z_factor;
        let (sa, ca) = self.altitude.to_radians().sin_cos();
        let (sz, cz) = self.azimuth.to_radians().sin_cos();
        [sa, z * sz * ca, z * cz * ca, z * z]
    }

    /// Shade value of one 3x3 window (1..=255), gdaldem's scale.
    #[inline]
    pub fn shade(&self, w: &[f64; 9], ew: f64, ns: f64) -> u8 {
        shade_with(&self.light(), w, ew, ns)
    }
}

#[inline]
fn shade_with(l: &[f64; 4], w: &[f64; 9], ew: f64, ns: f64) -> u8 {
    let (p, q) = horn_gradient(w, ew, ns);
    let c = (l[0] - p * l[1] - q * l[2]) / (1.0 + l[3] * (p * p + q * q)).sqrt();
    if c <= 0.0 {
        1
    } else {
        // Round half up (as GDAL converts to bytes); `as` saturates at 255.
        (1.5 + 254.0 * c) as u8
    }
}

impl LocalStep for Hillshade {
    type In = f32;
    type Out = u8;
    fn name(&self) -> String {
        "hillshade".into()
    }
    fn params(&self) -> serde_json::Value {
        json!(self)
    }
    fn halo(&self) -> usize {
        1
    }
    fn outputs(&self) -> Vec<OutputSpec> {
        vec![OutputSpec::continuous(DType::U8, 0.0)]
    }
    fn run(&self, inputs: &[TileView<f32>], out: &mut [Grid<u8>]) -> Result<()> {
        let l = self.light();
        walk_3x3(&inputs[0], &mut out[0], self.edge, 0u8, |w, ew, ns| {
            shade_with(&l, w, ew, ns)
        });
        Ok(())
    }
}

/// Hillshade of a whole in-memory grid (previews): same definition as [`Hillshade`].
pub fn hillshade_grid(
    grid: &Grid<f32>,
    georef: &crate::raster::GeoRef,
    hs: &Hillshade,
) -> Grid<u8> {
    let view = TileView {
        id: 0,
        core: crate::raster::Window::full(grid.width(), grid.height()),
        halo: 1,
        grid: {
            let mut g = Grid::new(grid.width() + 2, grid.height() + 2, f32::NAN);
            g.paste(grid, 1, 1);
            g
        },
        georef: georef.clone(),
        raster_width: grid.width(),
        raster_height: grid.height(),
    };
    let mut out = Grid::new(grid.width(), grid.height(), 0u8);
    walk_3x3(&view, &mut out, hs.edge, 0u8, |w, ew, ns| {
        hs.shade(w, ew, ns)
    });
    out
}
