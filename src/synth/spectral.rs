//! Power-law ("1/f^β") spectral synthesis, tileable at any size.
//!
//! Sources: R.F. Voss, "Random fractal forgeries", in *Fundamental Algorithms
//! for Computer Graphics*, 1985, and D. Saupe, "Algorithms for random
//! fractals", in *The Science of Fractal Images*, 1988, ch. 2 (§2.4.3,
//! spectral synthesis: Fourier coefficients of amplitude ∝ f^-β/2, random
//! phases, inverse FFT); the variance-preserving blend of independent patches
//! under a partition of unity follows the "texture tiling and blending"
//! practice (e.g. Heitz & Neyret, "High-performance by-example noise using a
//! histogram-preserving blending operator", HPG 2018: divide by √Σw²).
//!
//! A single FFT over 100000² cells is not bounded-memory, so the spectrum is
//! cut into octave bands, each synthesised locally:
//! - Band 0 covers 0.125..0.5 cycles/cell, sampled at the cells themselves;
//!   band b ≥ 1 covers [0.125, 0.25) / 2^b cycles/cell, sampled every 2^b
//!   cells (twice oversampled) and interpolated to cells with Catmull-Rom
//!   splines. Bands continue until the longest wavelength is covered.
//! - Each band is a sum of patches: the plane of band samples is covered by
//!   M x M patches (M = 64) on a grid of step M/2; a patch is an inverse FFT
//!   of coefficients on the band's annulus, Gaussian with amplitude
//!   ν^-β/2 / s (ν the frequency in cycles/cell, s the band's sample spacing,
//!   so the power per unit of frequency area is ν^-β in every band), hashed
//!   from (seed, band, patch coordinates, bin): a counter-based RNG.
//! - Patches are blended with w = sin²(πt/M) in x and y (the weights of the
//!   two patches covering a sample sum to 1) and the blend is divided by
//!   √Σw², which keeps the variance constant. The smooth window widens each
//!   spectral line by only ~1/M of the band's sample rate, well inside the
//!   band, so the power law holds across bands (the test measures the slope of
//!   the radially averaged power spectrum). Every band has the same shape on
//!   a log-frequency axis, so the interpolation's small roll-off repeats each
//!   octave and does not tilt the slope.
//!
//! Every band sample is a fixed sum over the same patches in the same order,
//! so any window equals the same cells of a whole-grid run, bit for bit.
//! Cost per tile: about ((T/32 + 2)² patches of a 64² FFT in band 0, a
//! quarter of that per further band (bounded below by a few patches), plus
//! 8 multiply-adds per cell per interpolated band.

use super::noise::{gauss_from_hash, mix, Noise};
use crate::raster::Window;
use rustfft::num_complex::Complex;
use rustfft::{Fft, FftPlanner};
use std::sync::Arc;

/// Patch size in band samples.
const M: usize = 64;
/// Patch grid step (half overlap).
const HALF: i64 = (M / 2) as i64;

/// Work buffers of one patch: FFT buffer, transposed buffer, FFT scratch,
/// real output.
struct PatchBufs {
    buf: Vec<Complex<f64>>,
    tmp: Vec<Complex<f64>>,
    scratch: Vec<Complex<f64>>,
    out: Vec<f64>,
}

struct Band {
    /// Sample spacing in cells (a power of two).
    spacing: i64,
    /// Non-zero coefficients: bin index (v·M + u) and amplitude.
    bins: Vec<(usize, f64)>,
}

/// A prepared spectral synthesiser (bands, FFT plan, window table).
pub(crate) struct Spectral {
    seed: u64,
    fft: Arc<dyn Fft<f64>>,
    bands: Vec<Band>,
    wtab: [f64; M],
    scale: f64,
}

/// Catmull-Rom weights of the four samples around fraction t.
#[inline]
fn catmull_rom(t: f64) -> [f64; 4] {
    let t2 = t * t;
    let t3 = t2 * t;
    [
        0.5 * (-t3 + 2.0 * t2 - t),
        0.5 * (3.0 * t3 - 5.0 * t2 + 2.0),
        0.5 * (-3.0 * t3 + 4.0 * t2 + t),
        0.5 * (t3 - t2),
    ]
}

impl Spectral {
    /// Bands for `p.wavelength` and `p.beta` (parameters already validated).
    pub(crate) fn new(p: &Noise) -> Spectral {
        let mut nb = 1usize;
        while (8.0 * (1u64 << (nb - 1)) as f64) < p.wavelength {
            nb += 1;
        }
        let mut bands = Vec::with_capacity(nb);
        let mut var = 0.0;
        for b in 0..nb {
            let spacing = 1i64 << b;
            let (rmin, rmax) = if b == 0 {
                (M as f64 / 8.0, M as f64 / 2.0)
            } else {
                (M as f64 / 8.0, M as f64 / 4.0)
            };
            let mut bins = Vec::new();
            for vi in 0..M {
                let v = if vi <= M / 2 {
                    vi as f64
                } else {
                    vi as f64 - M as f64
                };
                for ui in 0..M {
                    let u = if ui <= M / 2 {
                        ui as f64
                    } else {
                        ui as f64 - M as f64
                    };
                    let r = (u * u + v * v).sqrt();
                    if r >= rmin && r < rmax {
                        let nu = r / (M as f64 * spacing as f64);
                        let a = nu.powf(-p.beta / 2.0) / spacing as f64;
                        var += a * a;
                        bins.push((vi * M + ui, a));
                    }
                }
            }
            bands.push(Band { spacing, bins });
        }
        let mut wtab = [0.0; M];
        for (t, w) in wtab.iter_mut().enumerate() {
            let s = (std::f64::consts::PI * t as f64 / M as f64).sin();
            *w = s * s;
        }
        Spectral {
            seed: mix(p.seed ^ 0x5350_4543),
            fft: FftPlanner::new().plan_fft_inverse(M),
            bands,
            wtab,
            scale: 1.0 / (3.0 * var.sqrt()),
        }
    }

    /// One patch of band `b` at patch coordinates (px, py): M x M real
    /// samples, `out[x * M + y]`.
    fn patch(&self, b: usize, px: i64, py: i64, bufs: &mut PatchBufs) {
        let PatchBufs {
            buf,
            tmp,
            scratch,
            out,
        } = bufs;
        let ps = mix(mix(mix(self.seed ^ b as u64) ^ px as u64)
            ^ (py as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15));
        buf.fill(Complex::new(0.0, 0.0));
        for &(i, a) in &self.bands[b].bins {
            let h = mix(ps ^ (i as u64 + 1).wrapping_mul(0xd1b5_4a32_d192_ed03));
            let h2 = mix(h);
            buf[i] = Complex::new(a * gauss_from_hash(h), a * gauss_from_hash(h2));
        }
        // Rows, transpose, rows again: tmp[u * M + y] holds column u after the
        // first pass; the second pass transforms along y.
        self.fft.process_with_scratch(buf, scratch);
        for y in 0..M {
            for x in 0..M {
                tmp[x * M + y] = buf[y * M + x];
            }
        }
        self.fft.process_with_scratch(tmp, scratch);
        for (o, c) in out.iter_mut().zip(tmp.iter()) {
            *o = c.re;
        }
    }

    /// Band `b`'s blended samples on sample indices [sx0, sx0+nx) x [sy0, sy0+ny).
    fn band_samples(&self, b: usize, sx0: i64, sy0: i64, nx: usize, ny: usize) -> Vec<f64> {
        let mut acc = vec![0.0; nx * ny];
        let zero = Complex::new(0.0, 0.0);
        let mut bufs = PatchBufs {
            buf: vec![zero; M * M],
            tmp: vec![zero; M * M],
            scratch: vec![zero; self.fft.get_inplace_scratch_len()],
            out: vec![0.0; M * M],
        };
        let (sx1, sy1) = (sx0 + nx as i64 - 1, sy0 + ny as i64 - 1);
        for py in sy0.div_euclid(HALF) - 1..=sy1.div_euclid(HALF) {
            for px in sx0.div_euclid(HALF) - 1..=sx1.div_euclid(HALF) {
                self.patch(b, px, py, &mut bufs);
                let vals = &bufs.out;
                let (ox, oy) = (px * HALF, py * HALF);
                let (xa, xb) = (sx0.max(ox), sx1.min(ox + M as i64 - 1));
                let (ya, yb) = (sy0.max(oy), sy1.min(oy + M as i64 - 1));
                for y in ya..=yb {
                    let ty = (y - oy) as usize;
                    let wy = self.wtab[ty];
                    let row = (y - sy0) as usize * nx;
                    for x in xa..=xb {
                        let tx = (x - ox) as usize;
                        acc[row + (x - sx0) as usize] += self.wtab[tx] * wy * vals[tx * M + ty];
                    }
                }
            }
        }
        // Variance-preserving normalisation: divide by √Σw².
        let w2 = |s: i64| {
            let t = s.rem_euclid(HALF) as usize;
            let (a, b) = (self.wtab[t], self.wtab[t + M / 2]);
            a * a + b * b
        };
        for j in 0..ny {
            let wy = w2(sy0 + j as i64);
            for i in 0..nx {
                acc[j * nx + i] /= (w2(sx0 + i as i64) * wy).sqrt();
            }
        }
        acc
    }

    /// The field of `win` (about [-1, 1]: three standard deviations).
    pub(crate) fn field(&self, win: Window, out: &mut [f64]) {
        out.fill(0.0);
        let (w, h) = (win.w, win.h);
        let mut tmp = Vec::new();
        for (b, band) in self.bands.iter().enumerate() {
            let s = band.spacing;
            if s == 1 {
                let smp = self.band_samples(b, win.x, win.y, w, h);
                for (o, v) in out.iter_mut().zip(&smp) {
                    *o += v;
                }
                continue;
            }
            let sx0 = win.x.div_euclid(s) - 1;
            let sy0 = win.y.div_euclid(s) - 1;
            let nx = ((win.x_end() - 1).div_euclid(s) + 2 - sx0 + 1) as usize;
            let ny = ((win.y_end() - 1).div_euclid(s) + 2 - sy0 + 1) as usize;
            let smp = self.band_samples(b, sx0, sy0, nx, ny);
            let inv = 1.0 / s as f64;
            let cols: Vec<(usize, [f64; 4])> = (0..w)
                .map(|c| {
                    let x = win.x + c as i64;
                    let j = x.div_euclid(s);
                    (
                        (j - 1 - sx0) as usize,
                        catmull_rom((x - j * s) as f64 * inv),
                    )
                })
                .collect();
            tmp.resize(nx, 0.0);
            for r in 0..h {
                let y = win.y + r as i64;
                let j = y.div_euclid(s);
                let wy = catmull_rom((y - j * s) as f64 * inv);
                let j0 = (j - 1 - sy0) as usize;
                for (i, t) in tmp.iter_mut().enumerate() {
                    *t = wy[0] * smp[j0 * nx + i]
                        + wy[1] * smp[(j0 + 1) * nx + i]
                        + wy[2] * smp[(j0 + 2) * nx + i]
                        + wy[3] * smp[(j0 + 3) * nx + i];
                }
                for (o, (i, wx)) in out[r * w..(r + 1) * w].iter_mut().zip(&cols) {
                    *o += wx[0] * tmp[*i]
                        + wx[1] * tmp[i + 1]
                        + wx[2] * tmp[i + 2]
                        + wx[3] * tmp[i + 3];
                }
            }
        }
        out.iter_mut().for_each(|v| *v *= self.scale);
    }
}
