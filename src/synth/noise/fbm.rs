//! Fractional Brownian motion of gradient noise with an optional domain
//! warp ([`Fbm`], Musgrave 2003, §16; Quilez 2002), and the same field as a
//! [`RasterSource`] ([`FbmSource`]).

use super::gradient_noise;
use crate::error::Error;
use crate::error::Result;
use crate::raster::AnyGrid;
use crate::raster::Crs;
use crate::raster::DType;
use crate::raster::GeoRef;
use crate::raster::Grid;
use crate::raster::RasterInfo;
use crate::raster::RasterSource;
use crate::raster::Window;
use crate::synth::source_info;
use serde::Deserialize;
use serde::Serialize;

/// fBm parameters. Elevation = `base + amplitude * (fbm + ridge_mix * ridged)`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Fbm {
    pub seed: u64,
    /// Octaves (1..=24).
    pub octaves: u32,
    /// Frequency multiplier between octaves.
    pub lacunarity: f64,
    /// Amplitude multiplier between octaves (persistence).
    pub gain: f64,
    /// Wavelength of the first octave in cells.
    pub wavelength: f64,
    /// Mean elevation (m).
    pub base: f64,
    /// Amplitude (m).
    pub amplitude: f64,
    /// Domain-warp strength in cells (0 = none): samples at p + w·(n1(p), n2(p)).
    pub warp: f64,
}

impl Default for Fbm {
    fn default() -> Self {
        Fbm {
            seed: 42,
            octaves: 10,
            lacunarity: 2.0,
            gain: 0.5,
            wavelength: 512.0,
            base: 1200.0,
            amplitude: 1400.0,
            warp: 60.0,
        }
    }
}

impl Fbm {
    /// Check parameters.
    pub fn validate(&self) -> Result<()> {
        if !(1..=24).contains(&self.octaves) {
            return Err(Error::invalid("fBm octaves must be between 1 and 24"));
        }
        if !(self.wavelength.is_finite() && self.wavelength > 0.0) {
            return Err(Error::invalid(
                "fBm wavelength must be a positive number of cells",
            ));
        }
        if !(self.lacunarity.is_finite() && self.lacunarity > 1.0) {
            return Err(Error::invalid("fBm lacunarity must be > 1"));
        }
        if !(self.gain.is_finite() && self.gain > 0.0 && self.gain < 1.0) {
            return Err(Error::invalid("fBm gain must be in (0, 1)"));
        }
        Ok(())
    }

    /// fBm value at cell centre (col, row), normalised to about [-1, 1].
    pub fn sample(&self, col: f64, row: f64) -> f64 {
        let f0 = 1.0 / self.wavelength;
        let (mut x, mut y) = (col * f0, row * f0);
        if self.warp != 0.0 {
            let s = self.seed.wrapping_add(0x51ed);
            let wx = gradient_noise(x * 2.0, y * 2.0, s);
            let wy = gradient_noise(x * 2.0 + 5.2, y * 2.0 + 1.3, s ^ 0xabcd);
            x += self.warp * f0 * wx;
            y += self.warp * f0 * wy;
        }
        let mut sum = 0.0;
        let mut amp = 1.0;
        let mut norm = 0.0;
        for o in 0..self.octaves {
            let n = gradient_noise(x, y, self.seed.wrapping_add(o as u64 * 0x1f3d));
            // Ridged octaves after the second give sharp crests (Musgrave's ridged multifractal, simplified).
            let v = if o >= 2 { 1.0 - 2.0 * n.abs() } else { n };
            sum += amp * v;
            norm += amp;
            amp *= self.gain;
            x *= self.lacunarity;
            y *= self.lacunarity;
        }
        sum / norm
    }

    /// Elevation at cell (col, row).
    pub fn elevation(&self, col: usize, row: usize) -> f32 {
        (self.base + self.amplitude * self.sample(col as f64 + 0.5, row as f64 + 0.5)) as f32
    }
}

/// A procedural raster source: any window is generated on demand, so it can be
/// streamed into a tile store of any size in bounded memory.
pub struct FbmSource {
    pub(super) fbm: Fbm,
    pub(super) info: RasterInfo,
}

impl FbmSource {
    /// A `width` x `height` fBm DEM with square cells of `cell` metres in a local
    /// (unnamed, metric) CRS.
    pub fn new(fbm: Fbm, width: usize, height: usize, cell: f64) -> Result<Self> {
        fbm.validate()?;
        if width == 0 || height == 0 || !(cell.is_finite() && cell > 0.0) {
            return Err(Error::invalid(
                "synthetic DEM needs a positive size and cell size",
            ));
        }
        let georef = GeoRef::north_up(0.0, height as f64 * cell, cell, Crs::default());
        Ok(FbmSource {
            fbm,
            info: source_info(width, height, DType::F32, georef, "<fbm>"),
        })
    }
}

impl RasterSource for FbmSource {
    fn info(&self) -> &RasterInfo {
        &self.info
    }
    fn read_native(&self, win: Window) -> Result<AnyGrid> {
        let (x0, y0) = (win.x as usize, win.y as usize);
        Ok(AnyGrid::F32(Grid::from_fn(win.w, win.h, |x, y| {
            self.fbm.elevation(x0 + x, y0 + y)
        })))
    }
}
