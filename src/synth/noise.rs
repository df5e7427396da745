//! Seeded gradient noise and fractional Brownian motion (fBm), tileable by
//! construction: every sample is a pure function of its global coordinates and
//! the seed, so any window generated alone equals the same window of a whole
//! generation.
//!
//! Sources: K. Perlin, "Improving Noise", SIGGRAPH 2002 (gradient noise with
//! the quintic fade 6t⁵ − 15t⁴ + 10t³); F.K. Musgrave in Ebert et al.,
//! *Texturing & Modeling: A Procedural Approach*, 3rd ed. 2003, ch. 16 (fBm as a
//! sum of octaves with lacunarity and gain). Lattice gradients come from a
//! counter-based hash (SplitMix64 finaliser, Steele et al. 2014) of the lattice
//! point and the seed instead of Perlin's permutation table, which removes the
//! 256-cell period and makes tiles independent.

use crate::error::{Error, Result};
use crate::raster::{AnyGrid, Crs, DType, GeoRef, Grid, RasterInfo, RasterSource, Window};
use serde::{Deserialize, Serialize};

#[inline]
fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// 32 unit gradient directions, evenly spaced.
const GRADS: [(f64, f64); 32] = {
    let mut g = [(0.0, 0.0); 32];
    // cos/sin are not const: a table of the 32 directions, k * 11.25 degrees.
    let c = [
        1.0,
        0.980_785_280_403_230_4,
        0.923_879_532_511_286_7,
        0.831_469_612_302_545_2,
        0.707_106_781_186_547_5,
        0.555_570_233_019_602_2,
        0.382_683_432_365_089_8,
        0.195_090_322_016_128_3,
    ];
    let mut k = 0;
    while k < 32 {
        let q = k / 8;
        let r = k % 8;
        // direction angle = q*90° + r*11.25°
        let (x, y) = (c[r], if r == 0 { 0.0 } else { c[8 - r] });
        g[k] = match q {
            0 => (x, y),
            1 => (-y, x),
            2 => (-x, -y),
            _ => (y, -x),
        };
        k += 1;
    }
    g
};

#[inline]
fn grad(ix: i64, iy: i64, seed: u64) -> (f64, f64) {
    let h = mix(seed ^ mix((ix as u64) ^ mix(iy as u64 ^ 0x9e37_79b9_7f4a_7c15)));
    GRADS[(h >> 59) as usize]
}

#[inline]
fn fade(t: f64) -> f64 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

/// 2-D gradient noise at (x, y), roughly in [-1, 1].
#[inline]
pub fn gradient_noise(x: f64, y: f64, seed: u64) -> f64 {
    let x0 = x.floor();
    let y0 = y.floor();
    let (fx, fy) = (x - x0, y - y0);
    let (ix, iy) = (x0 as i64, y0 as i64);
    let d = |gx: i64, gy: i64, dx: f64, dy: f64| {
        let (a, b) = grad(ix + gx, iy + gy, seed);
        a * dx + b * dy
    };
    let n00 = d(0, 0, fx, fy);
    let n10 = d(1, 0, fx - 1.0, fy);
    let n01 = d(0, 1, fx, fy - 1.0);
    let n11 = d(1, 1, fx - 1.0, fy - 1.0);
    let (u, v) = (fade(fx), fade(fy));
    let a = n00 + u * (n10 - n00);
    let b = n01 + u * (n11 - n01);
    // sqrt(2) scales the 2-D gradient-noise range to about [-1, 1].
    std::f64::consts::SQRT_2 * (a + v * (b - a))
}

/// fBm parameters. Elevation = `base + amplitude * (fbm + ridge_mix * ridged)`.
#[derive(Debug, Clone, Serialize, Deserialize)]
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
    fbm: Fbm,
    info: RasterInfo,
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
            info: RasterInfo {
                width,
                height,
                dtype: DType::F32,
                georef,
                block: (256, 256),
                path: "<fbm>".into(),
            },
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
