//! Windowed statistics whose cost does not depend on the radius:
//! summed-area tables (Crow 1984, "Summed-area tables for texture mapping",
//! SIGGRAPH '84) for counts, sums and sums of squares, and the van Herk /
//! Gil-Werman running max/min (van Herk 1992, Pattern Recognition Letters
//! 13(7); Gil & Werman 1993, IEEE PAMI 15(5)) for local relief.
//!
//! Windows are squares of side `2r+1` cells centred on the cell by default
//! (the survey of Argudo et al. uses disks; a square of half-side r contains
//! the disk of radius r and has 4/π ≈ 1.27 times its area, so square
//! statistics smooth slightly more). Disks (`shape=disk`: cells with
//! dx² + dy² ≤ r², in cells) are summed as one SAT row segment per row,
//! O(r) per cell. Nodata (NaN) cells are excluded from every window.
//!
//! **Exact, tile-independent sums.** A floating-point SAT gives results that
//! depend on where the table starts (its rounding depends on the prefix),
//! so a tiled run would differ from an untiled one in the last bits. Values
//! are therefore converted once per cell to 128-bit fixed point with
//! [`FRAC_BITS`] fractional bits (exact for every f32 with |z| ≥ 0.5; smaller
//! non-integers are rounded to 2⁻²⁴ ≈ 6e-8) and summed in wrapping integer
//! arithmetic: inclusion–exclusion over a wrapping SAT yields the exact window
//! sum whenever that sum itself fits, which [`MAX_ABS_VALUE`] and the radius
//! limit guarantee. Variances are formed exactly in integers too. Square
//! windows of the mean and TPI skip the tables: the same integers are summed
//! by running column and row sums in i64 limbs (`metrics::multi::box_stat`).

use crate::error::{Error, Result};

/// Fractional bits of the fixed-point values.
pub const FRAC_BITS: u32 = 24;
/// Largest |z| accepted by the windowed statistics: with windows of at most
/// (2·2000+1)² < 2²⁴ cells and |q| ≤ 5e7·2²⁴ < 2^49.6, every window's
/// Σ(q − a)² (|q − a| ≤ 2 max|q|) stays below 2²⁴·4·2^99.2 < 2¹²⁷.
pub const MAX_ABS_VALUE: f64 = 5e7;

/// Fixed-point value of `z` with `frac` fractional bits (|z| small enough).
#[inline]
pub fn to_fixed(z: f64, frac: u32) -> i128 {
    let v = z * pow2(frac);
    // Through the hardware i64 conversion when the value fits (always for
    // FRAC_BITS and |z| ≤ MAX_ABS_VALUE); `as i128` and `f64::round` (a
    // libm call without SSE4.1) are slow. `t = trunc(v)` is exact, and so is
    // the fraction `v − t` (|v| < 2⁶³: for |v| ≥ 2⁵² v is integral and the
    // fraction is 0), so rounding half away from zero from it is `v.round()`.
    if v.abs() < 9.0e18 {
        let t = v as i64;
        let f = v - t as f64;
        (if f >= 0.5 {
            t + 1
        } else if f <= -0.5 {
            t - 1
        } else {
            t
        }) as i128
    } else {
        v.round() as i128
    }
}

/// `v as f64` (round to nearest) without the slow software i128 routine in
/// the common cases: through the hardware i64 conversion when `v` fits in
/// an i64 (window sums of elevations), else as `hi·2³² + lo` with `hi =
/// v >> 32` exact in f64 (|v| < 2⁸⁵: sums of fixed-point normals) — both
/// terms are exact, so their f64 sum is rounded once, like `v as f64`.
#[inline]
pub fn i128_to_f64(v: i128) -> f64 {
    let s = v as i64;
    if s as i128 == v {
        return s as f64;
    }
    let hi = (v >> 32) as i64;
    if hi.unsigned_abs() < 1u64 << 53 && (hi as i128) == (v >> 32) {
        hi as f64 * 4_294_967_296.0 + (v as u64 & 0xffff_ffff) as f64
    } else {
        v as f64
    }
}

/// Summed-area tables over a `w x h` region: valid-cell counts, fixed-point
/// sums and sums of squares (wrapping), each `(w+1) x (h+1)` with a zero
/// first row and column.
pub struct Sat {
    w1: usize,
    frac: u32,
    count: Vec<u32>,
    sum: Vec<i128>,
    sumsq: Option<Vec<i128>>,
}

/// Window sums of one cell.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WindowSums {
    pub n: u32,
    /// Σ q (fixed point).
    pub sum: i128,
    /// Σ q² (fixed point squared), 0 if squares were not tabulated.
    pub sumsq: i128,
    /// Fractional bits of q.
    pub frac: u32,
}

impl Sat {
    /// Tables of `vals` (`w x h`, row-major, NaN = excluded) with
    /// [`FRAC_BITS`]. Errors if a valid value is beyond ±[`MAX_ABS_VALUE`]
    /// (`what` names the input).
    pub fn new(vals: &[f64], w: usize, h: usize, squares: bool, what: &str) -> Result<Sat> {
        Self::with_frac(vals, w, h, squares, FRAC_BITS, MAX_ABS_VALUE, what)
    }

    /// Tables with `frac` fractional bits for values within ±`max_abs`
    /// (the caller guarantees that window sums fit in i128).
    pub fn with_frac(
        vals: &[f64],
        w: usize,
        h: usize,
        squares: bool,
        frac: u32,
        max_abs: f64,
        what: &str,
    ) -> Result<Sat> {
        let w1 = w + 1;
        let n = w1 * (h + 1);
        let mut count = vec![0u32; n];
        let mut sum = vec![0i128; n];
        let mut sumsq = if squares { Some(vec![0i128; n]) } else { None };
        for y in 0..h {
            let (mut rc, mut rs, mut rq) = (0u32, 0i128, 0i128);
            let row = &vals[y * w..(y + 1) * w];
            for (x, &z) in row.iter().enumerate() {
                if !z.is_nan() {
                    if z.abs() > max_abs {
                        return Err(Error::invalid(format!(
                            "{what}: value {z} is beyond ±{max_abs}, the range of the windowed statistics: rescale the input"
                        )));
                    }
                    let q = to_fixed(z, frac);
                    rc += 1;
                    rs = rs.wrapping_add(q);
                    rq = rq.wrapping_add(q.wrapping_mul(q));
                }
                let i = (y + 1) * w1 + x + 1;
                let up = y * w1 + x + 1;
                count[i] = count[up] + rc;
                sum[i] = sum[up].wrapping_add(rs);
                if let Some(sq) = sumsq.as_mut() {
                    sq[i] = sq[up].wrapping_add(rq);
                }
            }
        }
        Ok(Sat {
            w1,
            frac,
            count,
            sum,
            sumsq,
        })
    }

    /// Sums over the region cells `x0..x1`, `y0..y1` (exclusive ends).
    #[inline]
    pub fn window(&self, x0: usize, y0: usize, x1: usize, y1: usize) -> WindowSums {
        let w1 = self.w1;
        let (a, b, c, d) = (y0 * w1 + x0, y0 * w1 + x1, y1 * w1 + x0, y1 * w1 + x1);
        let n = self.count[d] + self.count[a] - self.count[b] - self.count[c];
        let s = |t: &[i128]| {
            t[d].wrapping_sub(t[b])
                .wrapping_sub(t[c])
                .wrapping_add(t[a])
        };
        WindowSums {
            n,
            sum: s(&self.sum),
            sumsq: self.sumsq.as_deref().map_or(0, s),
            frac: self.frac,
        }
    }
}

impl WindowSums {
    /// Sums of two disjoint windows (wrapping, exact when the total fits).
    #[inline]
    pub fn plus(&self, o: &WindowSums) -> WindowSums {
        WindowSums {
            n: self.n + o.n,
            sum: self.sum.wrapping_add(o.sum),
            sumsq: self.sumsq.wrapping_add(o.sumsq),
            frac: self.frac,
        }
    }

    /// Mean in value units (NaN if empty).
    #[inline]
    pub fn mean(&self) -> f64 {
        if self.n == 0 {
            return f64::NAN;
        }
        fixed_to_f64(self.sum, self.frac) / self.n as f64
    }

    /// Population variance in value units², computed exactly in integers:
    /// for any integer `a` near the mean and `b = Σq − n·a`,
    /// `Σ(q − Σq/n)² = Σq² − 2aΣq + n a² − b²/n`; the first three terms are
    /// exact (wrapping, the true value fits), the last is small and taken in
    /// f64. `a` comes from one f64 division (no 128-bit division).
    #[inline]
    pub fn variance(&self) -> f64 {
        if self.n == 0 {
            return f64::NAN;
        }
        let n = self.n as i128;
        let a = (i128_to_f64(self.sum) / self.n as f64).round() as i64 as i128;
        let b = self.sum.wrapping_sub(n.wrapping_mul(a));
        let d = self
            .sumsq
            .wrapping_sub(2i128.wrapping_mul(a).wrapping_mul(self.sum))
            .wrapping_add(n.wrapping_mul(a).wrapping_mul(a));
        let bf = i128_to_f64(b);
        let v = (i128_to_f64(d) - bf * bf / self.n as f64) / self.n as f64;
        v.max(0.0) / pow2(2 * self.frac)
    }
}

/// Fixed point back to f64.
#[inline]
pub fn fixed_to_f64(q: i128, frac: u32) -> f64 {
    i128_to_f64(q) / pow2(frac)
}

/// `2^k` as f64, exactly (`(1u128 << k) as f64` without the software u128
/// conversion; k ≤ 127).
#[inline]
pub fn pow2(k: u32) -> f64 {
    f64::from_bits((1023 + k as u64) << 52)
}

/// Running maximum over windows of `2r+1` (clipped at the ends) of `a`,
/// written to `out` (same length), in O(1) per element whatever `r` (van
/// Herk 1992; Gil & Werman 1993): the padded line is cut into blocks of
/// `k = 2r+1`; `g` holds prefix maxima within each block, `hs` suffix maxima,
/// and the window `[j, j+k)` straddles at most two blocks:
/// `max = max(hs[j], g[j+k−1])`. NaN must be mapped to −∞ by the caller.
/// `g` and `hs` are scratch buffers (resized here).
pub fn running_max(a: &[f64], r: usize, out: &mut [f64], g: &mut Vec<f64>, hs: &mut Vec<f64>) {
    let n = a.len();
    let k = 2 * r + 1;
    let m = n + 2 * r;
    g.clear();
    g.resize(m, f64::NEG_INFINITY);
    hs.clear();
    hs.resize(m, f64::NEG_INFINITY);
    let at = |i: usize| {
        if i >= r && i - r < n {
            a[i - r]
        } else {
            f64::NEG_INFINITY
        }
    };
    for i in 0..m {
        let v = at(i);
        g[i] = if i % k == 0 { v } else { g[i - 1].max(v) };
    }
    for i in (0..m).rev() {
        let v = at(i);
        hs[i] = if i % k == k - 1 || i == m - 1 {
            v
        } else {
            hs[i + 1].max(v)
        };
    }
    for (j, o) in out.iter_mut().enumerate().take(n) {
        *o = hs[j].max(g[j + k - 1]);
    }
}

/// Maximum over the square window of half-side `r` for every cell of the
/// inner `(w−2r) x (h−2r)` part of a `w x h` region (row-major), by two
/// separable [`running_max`] passes: O(1) per cell whatever `r`. NaN cells
/// are excluded; a window without valid cells gives −∞.
pub fn box_max(vals: &[f64], w: usize, h: usize, r: usize) -> Vec<f64> {
    let (ow, oh) = (w - 2 * r, h - 2 * r);
    let (mut g1, mut g2) = (Vec::new(), Vec::new());
    let mut horiz = vec![0.0; h * ow];
    let mut line = vec![0.0; w];
    let mut res = vec![0.0; w];
    for y in 0..h {
        for (l, &z) in line.iter_mut().zip(&vals[y * w..(y + 1) * w]) {
            *l = if z.is_nan() { f64::NEG_INFINITY } else { z };
        }
        running_max(&line, r, &mut res, &mut g1, &mut g2);
        horiz[y * ow..(y + 1) * ow].copy_from_slice(&res[r..r + ow]);
    }
    let mut out = vec![0.0; ow * oh];
    let mut col = vec![0.0; h];
    let mut cres = vec![0.0; h];
    for x in 0..ow {
        for (y, c) in col.iter_mut().enumerate() {
            *c = horiz[y * ow + x];
        }
        running_max(&col, r, &mut cres, &mut g1, &mut g2);
        for y in 0..oh {
            out[y * ow + x] = cres[y + r];
        }
    }
    out
}

/// Grey-level opening (erosion then dilation, square window of half-side
/// `r`) or closing (dilation then erosion) of the inner `(w−4r) x (h−4r)`
/// cells of a region (Serra 1982, *Image Analysis and Mathematical
/// Morphology*; here nodata cells take part in neither pass: the first
/// pass is evaluated on valid cells only and the second takes its extremum
/// over those). The white top-hat is `z − opening`, the black top-hat
/// `closing − z`.
pub fn open_close(vals: &[f64], w: usize, h: usize, r: usize, closing: bool) -> Vec<f64> {
    let neg = |v: &[f64]| v.iter().map(|x| -x).collect::<Vec<f64>>();
    let (w1, h1) = (w - 2 * r, h - 2 * r);
    // First pass over core + r: dilation (closing) or erosion (opening).
    let mut first = if closing {
        box_max(vals, w, h, r)
    } else {
        neg(&box_max(&neg(vals), w, h, r))
    };
    for y in 0..h1 {
        for x in 0..w1 {
            if vals[(y + r) * w + x + r].is_nan() {
                first[y * w1 + x] = f64::NAN;
            }
        }
    }
    // Second pass over the core: erosion of the dilation, or dilation of the erosion.
    if closing {
        neg(&box_max(&neg(&first), w1, h1, r))
    } else {
        box_max(&first, w1, h1, r)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn running_max_matches_naive() {
        let a: Vec<f64> = (0..37).map(|i| ((i * 7919) % 23) as f64 - 11.0).collect();
        let (mut g, mut h) = (Vec::new(), Vec::new());
        for r in 0..40 {
            let mut out = vec![0.0; a.len()];
            running_max(&a, r, &mut out, &mut g, &mut h);
            for (j, o) in out.iter().enumerate() {
                let lo = j.saturating_sub(r);
                let hi = (j + r).min(a.len() - 1);
                let m = a[lo..=hi].iter().cloned().fold(f64::NEG_INFINITY, f64::max);
                assert_eq!(*o, m, "r {r} j {j}");
            }
        }
    }

    #[test]
    fn i128_to_f64_rounds_like_as() {
        let mut x: u64 = 0x1234_5678_9abc_def1;
        for k in 0..20_000u32 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            // Magnitudes from 2^0 to 2^126, both signs.
            let shift = k % 127;
            let v = ((x as i128) << 64 | (x.rotate_left(29) as i128)) >> (127 - shift);
            for v in [v, -v, v + 1, v - 1] {
                assert_eq!(i128_to_f64(v).to_bits(), (v as f64).to_bits(), "{v}");
            }
        }
    }

    #[test]
    fn pow2_is_exact() {
        for k in 0..=127u32 {
            assert_eq!(pow2(k), (1u128 << k) as f64, "{k}");
        }
    }

    #[test]
    fn to_fixed_matches_i128_cast() {
        for z in [0.0, 1.5, -2.25, 8848.86, -4.9e7, 4.9e7, 1e-9, -0.3] {
            let want = (z * (1u128 << FRAC_BITS) as f64).round() as i128;
            assert_eq!(to_fixed(z, FRAC_BITS), want);
        }
        // Ties (half away from zero like f64::round), tiny and huge values.
        let mut x = 0x2545_f491_4f6c_dd1du64;
        for i in 0..20_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let z = match i % 4 {
                0 => (x % 2001) as f64 / 2.0 - 500.0,
                1 => f64::from_bits(x >> 2) * if x & 1 == 0 { 1.0 } else { -1.0 },
                2 => (x % 1_000_000) as f64 * 1e-7 - 0.05,
                _ => (x as i64 as f64) * 2f64.powi(-((x % 70) as i32)),
            };
            for frac in [0u32, 24, 60] {
                let v = z * pow2(frac);
                if !v.is_finite() || v.abs() >= 1.6e38 {
                    continue;
                }
                assert_eq!(to_fixed(z, frac), v.round() as i128, "{z} {frac}");
            }
        }
    }

    #[test]
    fn variance_exact_on_large_offsets() {
        // Values near 1e6 with a tiny spread: f64 naive Σz² − (Σz)²/n loses it.
        let vals = [1e6 + 0.5, 1e6 + 1.0, 1e6 + 1.5, f64::NAN];
        let sat = Sat::new(&vals, 2, 2, true, "t").unwrap();
        let ws = sat.window(0, 0, 2, 2);
        assert_eq!(ws.n, 3);
        assert_eq!(ws.mean(), 1e6 + 1.0);
        assert!((ws.variance() - 1.0 / 6.0).abs() < 1e-15);
    }
}
