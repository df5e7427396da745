//! The coarse grid of the global maps (plates, velocity, watershed) sampled
//! bilinearly, its Gaussian blur, and the queue item of the watershed
//! map's least-cost paths (Dijkstra).

use std::cmp::Ordering;

/// A coarse grid: `k` output cells per coarse cell.
#[derive(Debug, Clone)]
pub(super) struct Coarse {
    pub(super) k: f64,
    pub(super) w: usize,
    pub(super) h: usize,
}

impl Coarse {
    pub(super) fn centre(&self, i: usize, j: usize) -> [f64; 2] {
        [(i as f64 + 0.5) * self.k, (j as f64 + 0.5) * self.k]
    }
    /// Bilinear sample of a coarse field at output position p (clamped).
    #[inline]
    pub(super) fn sample(&self, f: &[f64], p: [f64; 2]) -> f64 {
        let u = (p[0] / self.k - 0.5).clamp(0.0, (self.w - 1) as f64);
        let v = (p[1] / self.k - 0.5).clamp(0.0, (self.h - 1) as f64);
        let (i0, j0) = (u.floor() as usize, v.floor() as usize);
        let (i1, j1) = ((i0 + 1).min(self.w - 1), (j0 + 1).min(self.h - 1));
        let (fx, fy) = (u - i0 as f64, v - j0 as f64);
        let a = f[j0 * self.w + i0] * (1.0 - fx) + f[j0 * self.w + i1] * fx;
        let b = f[j1 * self.w + i0] * (1.0 - fx) + f[j1 * self.w + i1] * fx;
        a * (1.0 - fy) + b * fy
    }
}

/// Separable Gaussian blur of a `w x h` field with clamped edges.
pub(super) fn gaussian_blur(f: &mut [f64], w: usize, h: usize, sigma: f64) {
    if sigma < 0.3 {
        return;
    }
    let r = (3.0 * sigma).ceil() as i64;
    let kern: Vec<f64> = (-r..=r)
        .map(|d| (-(d * d) as f64 / (2.0 * sigma * sigma)).exp())
        .collect();
    let norm: f64 = kern.iter().sum();
    let mut tmp = vec![0.0; f.len()];
    blur_pass::<true>(f, &mut tmp, w, h, &kern, norm);
    blur_pass::<false>(&tmp, f, w, h, &kern, norm);
}

/// One pass of [`gaussian_blur`]: `dst` = `src` convolved with `kern`
/// (odd length, centred) along rows (`ALONG_X`) or columns, divided by `norm`.
fn blur_pass<const ALONG_X: bool>(
    src: &[f64],
    dst: &mut [f64],
    w: usize,
    h: usize,
    kern: &[f64],
    norm: f64,
) {
    let r = (kern.len() / 2) as i64;
    for y in 0..h {
        for x in 0..w {
            let mut s = 0.0;
            for (k, &c) in kern.iter().enumerate() {
                let i = if ALONG_X {
                    y * w + (x as i64 + k as i64 - r).clamp(0, w as i64 - 1) as usize
                } else {
                    (y as i64 + k as i64 - r).clamp(0, h as i64 - 1) as usize * w + x
                };
                s += c * src[i];
            }
            dst[y * w + x] = s / norm;
        }
    }
}

#[derive(PartialEq)]
pub(super) struct Item(pub(super) f64, pub(super) u32);

impl Eq for Item {}

impl PartialOrd for Item {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}

impl Ord for Item {
    // Min-heap on (height, index).
    fn cmp(&self, o: &Self) -> Ordering {
        o.0.total_cmp(&self.0).then(o.1.cmp(&self.1))
    }
}
