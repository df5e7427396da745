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

mod fbm;
pub use fbm::{Fbm, FbmSource};

use crate::error::{Error, Result};
use crate::raster::{AnyGrid, Crs, DType, GeoRef, Grid, RasterInfo, RasterSource, Window};
use crate::synth::source_info;
use serde::{Deserialize, Serialize};
use std::ops::Bound::{Excluded, Included};

/// SplitMix64 finaliser (Steele, Lea & Flood 2014): a bijective 64-bit mixer
/// used as a counter-based hash of lattice coordinates and seeds.
#[inline]
pub(crate) fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// 32 unit gradient directions, evenly spaced.
pub(crate) const GRADS: [(f64, f64); 32] = {
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

/// Hash of a 2-D lattice point and a seed (two SplitMix64 rounds).
#[inline]
pub(crate) fn hash2(ix: i64, iy: i64, seed: u64) -> u64 {
    mix(mix((ix as u64) ^ seed) ^ (iy as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15))
}

/// Unit gradient of lattice point (ix, iy) (one of [`GRADS`], chosen by hash).
#[inline]
pub(crate) fn lattice_grad(ix: i64, iy: i64, seed: u64) -> (f64, f64) {
    GRADS[(hash2(ix, iy, seed) >> 59) as usize]
}

/// An approximately standard-normal number from the 64 bits of `h`: the sum
/// of four 16-bit uniforms (Irwin–Hall, variance scaled to 1).
#[inline]
pub(crate) fn gauss_from_hash(h: u64) -> f64 {
    let s = (h & 0xffff) + ((h >> 16) & 0xffff) + ((h >> 32) & 0xffff) + (h >> 48);
    (s as f64 / 65535.0 - 2.0) * 3f64.sqrt()
}

/// The kinds of noise terrain. All are seeded and tileable: each cell is a
/// pure function of its global coordinates and the parameters.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum NoiseKind {
    /// Fractional Brownian motion of gradient noise (Musgrave 2003, §16).
    Fbm,
    /// Ridged multifractal (Musgrave 2003, §16: offset, squared, weighted by
    /// the previous octave).
    Ridged,
    /// "Billow" / turbulence: fBm of |noise| (Perlin 1985), each octave
    /// rescaled to 2|n| - 1 (in [-1, 1], mean about -0.5: rounded hills,
    /// sharp creased valleys).
    Billow,
    /// fBm of 2-D simplex noise (Perlin 2001; Gustavson 2005).
    Simplex,
    /// Domain-warped ridged multifractal blended with fBm (Quilez 2002,
    /// "domain warping": f(p + w·q(p)) with q a 2-D fBm).
    Warped,
    /// Diamond-square midpoint displacement (Fournier, Fussell & Carpenter
    /// 1982) on the infinite plane, random numbers hashed from lattice points.
    DiamondSquare,
    /// Power-law spectral synthesis, power ∝ f^-β (Voss 1985; Saupe 1988),
    /// by octave bands of FFT patches blended with a partition of unity.
    Spectral,
}

impl NoiseKind {
    /// The name used on the command line.
    pub fn name(self) -> &'static str {
        match self {
            NoiseKind::Fbm => "fbm",
            NoiseKind::Ridged => "ridged",
            NoiseKind::Billow => "billow",
            NoiseKind::Simplex => "simplex",
            NoiseKind::Warped => "warped",
            NoiseKind::DiamondSquare => "diamond-square",
            NoiseKind::Spectral => "spectral",
        }
    }
    /// A one-line description (the command line's help for the kind).
    pub fn about(self) -> &'static str {
        match self {
            NoiseKind::Fbm => "fBm of gradient noise",
            NoiseKind::Ridged => "Ridged multifractal (sharp crests)",
            NoiseKind::Billow => "fBm of |noise| (rounded hills, creased valleys)",
            NoiseKind::Simplex => "fBm of simplex noise",
            NoiseKind::Warped => "Domain-warped ridged multifractal blended with fBm",
            NoiseKind::DiamondSquare => "Diamond-square midpoint displacement",
            NoiseKind::Spectral => "Power-law spectral synthesis (power ∝ f^-beta)",
        }
    }
    /// Every kind.
    pub const ALL: [NoiseKind; 7] = [
        NoiseKind::Fbm,
        NoiseKind::Ridged,
        NoiseKind::Billow,
        NoiseKind::Simplex,
        NoiseKind::Warped,
        NoiseKind::DiamondSquare,
        NoiseKind::Spectral,
    ];
}

/// Parameters of a noise terrain. Elevation = `base + amplitude * v`, where
/// `v` is the kind's field, normalised to about [-1, 1]. As keys (serde)
/// the fields are kebab-case and each missing one takes its default.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields, default)]
pub struct Noise {
    pub kind: NoiseKind,
    pub seed: u64,
    /// Octaves (1..=24; diamond-square and spectral derive their levels from
    /// `wavelength` instead).
    pub octaves: u32,
    /// Frequency multiplier between octaves (must be 2 for diamond-square and
    /// spectral, whose levels are octaves).
    pub lacunarity: f64,
    /// Amplitude multiplier between octaves, in (0, 1) (diamond-square: the
    /// displacement multiplier between levels, 2^-H).
    pub gain: f64,
    /// Wavelength of the first (coarsest) octave in cells; diamond-square: the
    /// coarse lattice spacing (rounded up to a power of two); spectral: the
    /// longest wavelength present (rounded up to an octave band).
    pub wavelength: f64,
    /// Mean elevation (m).
    pub base: f64,
    /// Amplitude (m).
    pub amplitude: f64,
    /// Ridged multifractal offset (Musgrave's `offset`, 1.0).
    pub ridge_offset: f64,
    /// Ridged multifractal weight gain (Musgrave's `gain`, 2.0).
    pub ridge_gain: f64,
    /// Warped: displacement of the domain warp in cells.
    pub warp: f64,
    /// Warped: share of the ridged multifractal in the blend with fBm (0..=1).
    pub blend: f64,
    /// Spectral: exponent β of the radially averaged power spectrum f^-β.
    pub beta: f64,
}

impl Default for Noise {
    fn default() -> Self {
        Noise {
            kind: NoiseKind::Fbm,
            seed: 42,
            octaves: 8,
            lacunarity: 2.0,
            gain: 0.5,
            wavelength: 512.0,
            base: 1200.0,
            amplitude: 1400.0,
            ridge_offset: 1.0,
            ridge_gain: 2.0,
            warp: 80.0,
            blend: 0.7,
            beta: 3.0,
        }
    }
}

/// `Ok` if `ok`, else the error "noise (KIND): RULE (got VALUE)".
fn check(ok: bool, kind: &str, rule: &str, got: impl std::fmt::Display) -> Result<()> {
    if ok {
        Ok(())
    } else {
        Err(Error::invalid(format!(
            "noise ({kind}): {rule} (got {got})"
        )))
    }
}

/// [`check`] that `v` lies in `range`: "NAME must be ALLOWED".
fn in_range(
    kind: &str,
    name: &str,
    v: f64,
    range: impl std::ops::RangeBounds<f64>,
    allowed: &str,
) -> Result<()> {
    check(
        range.contains(&v),
        kind,
        &format!("{name} must be {allowed}"),
        v,
    )
}

/// Octaves of the warp field of [`NoiseKind::Warped`].
const WARP_OCTAVES: u32 = 4;

impl Noise {
    /// Check parameters; the error says which one is wrong and what is allowed.
    pub fn validate(&self) -> Result<()> {
        let k = self.kind.name();
        check(
            (1..=24).contains(&self.octaves),
            k,
            "octaves must be between 1 and 24",
            self.octaves,
        )?;
        in_range(
            k,
            "gain",
            self.gain,
            (Excluded(0.0), Excluded(1.0)),
            "in (0, 1)",
        )?;
        in_range(
            k,
            "lacunarity",
            self.lacunarity,
            (Excluded(1.0), Included(16.0)),
            "in (1, 16]",
        )?;
        in_range(
            k,
            "wavelength",
            self.wavelength,
            2.0..=(1u64 << 30) as f64,
            "between 2 and 2^30 cells",
        )?;
        if !(self.base.is_finite() && self.amplitude.is_finite()) {
            return Err(Error::invalid(format!(
                "noise ({k}): base and amplitude must be finite numbers"
            )));
        }
        match self.kind {
            NoiseKind::DiamondSquare | NoiseKind::Spectral => {
                check(
                    self.lacunarity == 2.0,
                    k,
                    "levels are octaves, so lacunarity must be 2",
                    self.lacunarity,
                )?;
            }
            _ => {
                // The finest octave must stay above half a cell: finer octaves
                // only alias, and they would make the lattice of a tile huge.
                let finest = self.wavelength / self.lacunarity.powi(self.octaves as i32 - 1);
                if finest < 0.5 {
                    return Err(Error::invalid(format!(
                        "noise ({k}): the finest octave's wavelength would be {finest:.3} cells; \
                         use fewer octaves, a smaller lacunarity or a longer wavelength \
                         (at least 0.5 cells)"
                    )));
                }
            }
        }
        if self.kind == NoiseKind::Ridged || self.kind == NoiseKind::Warped {
            check(
                self.ridge_offset.is_finite()
                    && self.ridge_offset > 0.0
                    && self.ridge_offset <= 2.0,
                k,
                "ridge offset must be in (0, 2]",
                self.ridge_offset,
            )?;
            in_range(
                k,
                "ridge gain",
                self.ridge_gain,
                (Excluded(0.0), Included(100.0)),
                "in (0, 100]",
            )?;
        }
        if self.kind == NoiseKind::Warped {
            in_range(k, "warp", self.warp, 0.0..=1e6, "between 0 and 1e6 cells")?;
            in_range(k, "blend", self.blend, 0.0..=1.0, "between 0 and 1")?;
        }
        if self.kind == NoiseKind::Spectral {
            in_range(k, "beta", self.beta, 0.0..=6.0, "between 0 and 6")?;
            check(
                self.wavelength <= (1u64 << 24) as f64,
                k,
                "wavelength must be at most 2^24 cells",
                self.wavelength,
            )?;
        }
        Ok(())
    }

    /// The octaves of the lattice-noise kinds (fbm, ridged, billow, simplex,
    /// warped): each octave's frequency (cycles per cell), lattice offset and
    /// seed, with its amplitude. Public so that tests can rebuild the sums
    /// point by point.
    pub fn octaves(&self) -> Vec<(Octave, f64)> {
        self.octave_list(self.seed, self.octaves)
    }

    fn octave_list(&self, seed: u64, octaves: u32) -> Vec<(Octave, f64)> {
        let mut f = 1.0 / self.wavelength;
        let mut amp = 1.0;
        (0..octaves)
            .map(|o| {
                let s = mix(seed ^ mix(o as u64 + 1));
                let oct = Octave {
                    freq: f,
                    ox: (s & 0xffff) as f64 / 256.0,
                    oy: ((s >> 16) & 0xffff) as f64 / 256.0,
                    seed: mix(s),
                };
                let r = (oct, amp);
                f *= self.lacunarity;
                amp *= self.gain;
                r
            })
            .collect()
    }

    /// Fill `out` (row-major, `win.w` x `win.h`) with the normalised field
    /// `v` (about [-1, 1]) of the cells of `win` (global cell coordinates;
    /// any window, also outside a raster: the plane is infinite).
    pub fn field(&self, win: Window, out: &mut [f64]) {
        debug_assert_eq!(out.len(), win.len());
        if win.is_empty() {
            return;
        }
        match self.kind {
            NoiseKind::Fbm | NoiseKind::Billow | NoiseKind::Ridged => self.lattice_field(win, out),
            NoiseKind::Simplex => {
                super::simplex::fbm_field(&self.octave_list(self.seed, self.octaves), win, out)
            }
            NoiseKind::Warped => self.warped_field(win, out),
            NoiseKind::DiamondSquare => super::diamond_square::field(self, win, out),
            NoiseKind::Spectral => super::spectral::Spectral::new(self).field(win, out),
        }
    }

    /// fBm, billow and ridged: octave by octave over the window with
    /// [`octave_rows`], combined per cell.
    fn lattice_field(&self, win: Window, out: &mut [f64]) {
        let octs = self.octave_list(self.seed, self.octaves);
        let w = win.w;
        out.fill(0.0);
        let mut scratch = OctScratch::default();
        let mut norm = 0.0;
        match self.kind {
            // fBm sums the octaves; billow sums their folds 2|n| - 1.
            NoiseKind::Fbm => sum_octaves(&octs, win, out, &mut scratch, |v| v),
            NoiseKind::Billow => {
                sum_octaves(&octs, win, out, &mut scratch, |v| 2.0 * v.abs() - 1.0)
            }
            _ => {
                // Musgrave's ridged multifractal: signal = (offset - |n|)²,
                // weighted by the previous octave's signal x gain (clamped to
                // [0, 1]); the first octave has weight 1.
                let (off, g) = (self.ridge_offset, self.ridge_gain);
                let mut weight = vec![1.0f64; out.len()];
                for (oct, amp) in &octs {
                    octave_rows(oct, win, &mut scratch, |r, n| {
                        let rows = r * w..(r + 1) * w;
                        for ((o, wt), &v) in
                            out[rows.clone()].iter_mut().zip(&mut weight[rows]).zip(n)
                        {
                            let s = off - v.abs();
                            let s = s * s * *wt;
                            *wt = (s * g).clamp(0.0, 1.0);
                            *o += amp * s;
                        }
                    });
                    norm += amp;
                }
                let k = 2.0 / (norm * off * off);
                out.iter_mut().for_each(|v| *v = *v * k - 1.0);
            }
        }
    }

    /// Domain warping after Quilez: q = (fbm_a(p), fbm_b(p)) (4 octaves at
    /// the base wavelength), then ridged and fBm sums of the same octaves of
    /// gradient noise at p + warp·q, blended `blend : 1 - blend`.
    fn warped_field(&self, win: Window, out: &mut [f64]) {
        let n = win.len();
        let mut qx = vec![0.0; n];
        let mut qy = vec![0.0; n];
        let warp_kind = Noise {
            kind: NoiseKind::Fbm,
            octaves: WARP_OCTAVES,
            lacunarity: 2.0,
            gain: 0.5,
            ..self.clone()
        };
        Noise {
            seed: mix(self.seed ^ 0x5741_5250_0000_0001),
            ..warp_kind.clone()
        }
        .lattice_field(win, &mut qx);
        Noise {
            seed: mix(self.seed ^ 0x5741_5250_0000_0002),
            ..warp_kind
        }
        .lattice_field(win, &mut qy);
        let octs = self.octave_list(self.seed, self.octaves);
        let norm: f64 = octs.iter().map(|o| o.1).sum();
        let (off, g, warp, blend) = (self.ridge_offset, self.ridge_gain, self.warp, self.blend);
        let kr = 2.0 / (norm * off * off);
        for r in 0..win.h {
            let y = (win.y + r as i64) as f64 + 0.5;
            for c in 0..win.w {
                let i = r * win.w + c;
                let x = (win.x + c as i64) as f64 + 0.5;
                let (px, py) = (x + warp * qx[i], y + warp * qy[i]);
                let (mut fbm, mut ridged, mut wt) = (0.0, 0.0, 1.0f64);
                for (oct, amp) in &octs {
                    let v = lattice_noise(px * oct.freq + oct.ox, py * oct.freq + oct.oy, oct.seed);
                    fbm += amp * v;
                    let s = off - v.abs();
                    let s = s * s * wt;
                    wt = (s * g).clamp(0.0, 1.0);
                    ridged += amp * s;
                }
                out[i] = blend * (ridged * kr - 1.0) + (1.0 - blend) * (fbm / norm);
            }
        }
    }
}

/// One octave of lattice noise: frequency in cycles per cell, lattice offset
/// (decorrelates the octaves' lattices), hash seed.
#[derive(Debug, Clone, Copy)]
pub struct Octave {
    pub freq: f64,
    pub ox: f64,
    pub oy: f64,
    pub seed: u64,
}

/// Gradient noise with [`lattice_grad`] gradients at (x, y) in lattice
/// units, in [-1, 1]. The same formula as [`octave_rows`], point by point
/// (different rounding: the two are not mixed within one kind).
#[inline]
pub fn lattice_noise(x: f64, y: f64, seed: u64) -> f64 {
    let (xf, yf) = (x.floor(), y.floor());
    let (ix, iy) = (xf as i64, yf as i64);
    let (fx, fy) = (x - xf, y - yf);
    let g00 = lattice_grad(ix, iy, seed);
    let g10 = lattice_grad(ix + 1, iy, seed);
    let g01 = lattice_grad(ix, iy + 1, seed);
    let g11 = lattice_grad(ix + 1, iy + 1, seed);
    let n00 = g00.0 * fx + g00.1 * fy;
    let n10 = g10.0 * (fx - 1.0) + g10.1 * fy;
    let n01 = g01.0 * fx + g01.1 * (fy - 1.0);
    let n11 = g11.0 * (fx - 1.0) + g11.1 * (fy - 1.0);
    let (u, v) = (fade(fx), fade(fy));
    let a = n00 + u * (n10 - n00);
    let b = n01 + u * (n11 - n01);
    std::f64::consts::SQRT_2 * (a + v * (b - a))
}

/// Reusable buffers of [`octave_rows`].
#[derive(Default)]
struct OctScratch {
    fx: Vec<f64>,
    u: Vec<f64>,
    runs: Vec<(usize, usize)>,
    g: [Vec<(f64, f64)>; 2],
    a: Vec<f64>,
    b: Vec<f64>,
    row: Vec<f64>,
}

/// Gradient noise (Perlin 2002: gradients dotted with the offsets, quintic
/// fade) of one octave on a window, row by row, handing each row to `each`.
///
/// Written for speed, evaluating whole rows: per column, the lattice column,
/// fraction and fade are computed once per window; per row, gradients are
/// hashed once per lattice point (and kept while the lattice row does not
/// change), and each lattice column's two edge functions are folded into
/// `A·fx + B` (the v-interpolation of the two gradients' dot products, which
/// is linear in fx). A cell then costs two multiply-adds per edge and one
/// lerp, over contiguous runs of cells sharing a lattice cell. Every cell's
/// value is a fixed sequence of operations on its own global coordinates, so
/// any window gives the same bits for the same cell.
/// `out` (zeroed, `win`'s cells) = the amplitude-weighted mean over `octs`
/// of `shape(n)`, `n` each octave's noise ([`octave_rows`]).
#[inline]
fn sum_octaves(
    octs: &[(Octave, f64)],
    win: Window,
    out: &mut [f64],
    scratch: &mut OctScratch,
    shape: impl Fn(f64) -> f64,
) {
    let w = win.w;
    let mut norm = 0.0;
    for (oct, amp) in octs {
        octave_rows(oct, win, scratch, |r, n| {
            for (o, &v) in out[r * w..(r + 1) * w].iter_mut().zip(n) {
                *o += amp * shape(v);
            }
        });
        norm += amp;
    }
    let inv = 1.0 / norm;
    out.iter_mut().for_each(|v| *v *= inv);
}

fn octave_rows(oct: &Octave, win: Window, s: &mut OctScratch, mut each: impl FnMut(usize, &[f64])) {
    let w = win.w;
    s.fx.clear();
    s.u.clear();
    s.runs.clear();
    let mut kmin = 0i64;
    let mut last = i64::MIN;
    for c in 0..w {
        let x = ((win.x + c as i64) as f64 + 0.5) * oct.freq + oct.ox;
        let xf = x.floor();
        let ix = xf as i64;
        if c == 0 {
            kmin = ix;
        }
        if ix != last {
            s.runs.push((c, (ix - kmin) as usize));
            last = ix;
        }
        let fx = x - xf;
        s.fx.push(fx);
        s.u.push(fade(fx));
    }
    s.runs.push((w, 0));
    let nk = (last - kmin) as usize + 2;
    for g in &mut s.g {
        g.clear();
        g.resize(nk, (0.0, 0.0));
    }
    s.a.resize(nk, 0.0);
    s.b.resize(nk, 0.0);
    s.row.resize(w, 0.0);
    let fill = |g: &mut Vec<(f64, f64)>, iy: i64| {
        for (k, v) in g.iter_mut().enumerate() {
            *v = lattice_grad(kmin + k as i64, iy, oct.seed);
        }
    };
    let mut cur: Option<i64> = None;
    for r in 0..win.h {
        let y = ((win.y + r as i64) as f64 + 0.5) * oct.freq + oct.oy;
        let yf = y.floor();
        let iy = yf as i64;
        let fy = y - yf;
        let v = fade(fy);
        if cur != Some(iy) {
            if cur == Some(iy - 1) {
                s.g.swap(0, 1);
                fill(&mut s.g[1], iy + 1);
            } else {
                let [g0, g1] = &mut s.g;
                fill(g0, iy);
                fill(g1, iy + 1);
            }
            cur = Some(iy);
        }
        let fy1 = fy - 1.0;
        let [g0, g1] = &s.g;
        for k in 0..nk {
            let (p, q) = (g0[k], g1[k]);
            s.a[k] = p.0 + v * (q.0 - p.0);
            let b0 = p.1 * fy;
            s.b[k] = b0 + v * (q.1 * fy1 - b0);
        }
        for j in 0..s.runs.len() - 1 {
            let (c0, k) = s.runs[j];
            let c1 = s.runs[j + 1].0;
            let (a0, b0, a1, b1) = (s.a[k], s.b[k], s.a[k + 1], s.b[k + 1]);
            for ((o, &fx), &u) in s.row[c0..c1]
                .iter_mut()
                .zip(&s.fx[c0..c1])
                .zip(&s.u[c0..c1])
            {
                let el = a0 * fx + b0;
                let er = a1 * (fx - 1.0) + b1;
                *o = std::f64::consts::SQRT_2 * (el + u * (er - el));
            }
        }
        each(r, &s.row);
    }
}

/// Any [`Noise`] as a raster source (f32 elevations in a local metric CRS):
/// every window is generated on demand, so `ops::convert` streams a noise
/// terrain of any size to any output in bounded memory.
pub struct NoiseSource {
    noise: Noise,
    info: RasterInfo,
}

impl NoiseSource {
    /// A `width` x `height` terrain with square cells of `cell` metres.
    pub fn new(noise: Noise, width: usize, height: usize, cell: f64) -> Result<Self> {
        noise.validate()?;
        const MAX: usize = 1 << 31;
        if width == 0 || height == 0 || width > MAX || height > MAX {
            return Err(Error::invalid(format!(
                "noise terrain size must be between 1 and 2^31 cells per side (got {width}x{height})"
            )));
        }
        if !(cell.is_finite() && cell > 0.0) {
            return Err(Error::invalid(format!(
                "noise terrain cell size must be a positive number of metres (got {cell})"
            )));
        }
        let georef = GeoRef::north_up(0.0, height as f64 * cell, cell, Crs::default());
        Ok(NoiseSource {
            info: source_info(
                width,
                height,
                DType::F32,
                georef,
                format!("<noise:{}>", noise.kind.name()),
            ),
            noise,
        })
    }

    /// The parameters.
    pub fn noise(&self) -> &Noise {
        &self.noise
    }
}

impl RasterSource for NoiseSource {
    fn info(&self) -> &RasterInfo {
        &self.info
    }
    fn read_native(&self, win: Window) -> Result<AnyGrid> {
        let mut v = vec![0.0f64; win.len()];
        self.noise.field(win, &mut v);
        let (b, a) = (self.noise.base, self.noise.amplitude);
        let data: Vec<f32> = v.iter().map(|&x| (b + a * x) as f32).collect();
        Ok(AnyGrid::F32(Grid::from_vec(win.w, win.h, data)?))
    }
}
