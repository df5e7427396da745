//! Bucket indices of the map's peaks and segments (nearest peak, distance
//! to the nearest river or coast segment), the clipping of segments to the
//! raster and the peaks' height envelope.

use crate::synth::buckets::for_each_in_ring;

/// Nearest-point queries over a small point set (bucket grid, ring search).
/// Ties go to the smaller index, so the answer is a pure function of the
/// query point.
pub(crate) struct PointIndex {
    pub(super) pts: Vec<[f64; 2]>,
    pub(super) bs: f64,
    pub(super) gw: usize,
    pub(super) gh: usize,
    pub(super) cells: Vec<Vec<u32>>,
}

impl PointIndex {
    pub(crate) fn new(pts: Vec<[f64; 2]>, width: usize, height: usize) -> PointIndex {
        let n = pts.len().max(1) as f64;
        let bs = ((width as f64 * height as f64 / n).sqrt()).max(4.0);
        let gw = ((width as f64 / bs).ceil() as usize).max(1);
        let gh = ((height as f64 / bs).ceil() as usize).max(1);
        let mut cells = vec![Vec::new(); gw * gh];
        for (i, p) in pts.iter().enumerate() {
            let (cx, cy) = Self::cell_of(bs, gw, gh, *p);
            cells[cy * gw + cx].push(i as u32);
        }
        PointIndex {
            pts,
            bs,
            gw,
            gh,
            cells,
        }
    }
    pub(super) fn cell_of(bs: f64, gw: usize, gh: usize, p: [f64; 2]) -> (usize, usize) {
        let cx = ((p[0] / bs).floor().max(0.0) as usize).min(gw - 1);
        let cy = ((p[1] / bs).floor().max(0.0) as usize).min(gh - 1);
        (cx, cy)
    }
    /// Call `f(index, squared distance)` for every point within `rad` of `q`.
    pub(crate) fn for_each_within(&self, q: [f64; 2], rad: f64, mut f: impl FnMut(usize, f64)) {
        let lo = |v: f64, n: usize| (((v - rad) / self.bs).floor().max(0.0) as usize).min(n);
        let hi =
            |v: f64, n: usize| ((((v + rad) / self.bs).floor()).max(-1.0) as i64).min(n as i64 - 1);
        let (x0, x1) = (lo(q[0], self.gw), hi(q[0], self.gw));
        let (y0, y1) = (lo(q[1], self.gh), hi(q[1], self.gh));
        for y in y0 as i64..=y1 {
            for x in x0 as i64..=x1 {
                for &i in &self.cells[y as usize * self.gw + x as usize] {
                    let p = self.pts[i as usize];
                    let d = (p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]);
                    if d <= rad * rad {
                        f(i as usize, d);
                    }
                }
            }
        }
    }

    /// (index, squared distance) of the point nearest to `q`.
    pub(crate) fn nearest(&self, q: [f64; 2]) -> (usize, f64) {
        let (cx, cy) = Self::cell_of(self.bs, self.gw, self.gh, q);
        let mut best = (usize::MAX, f64::INFINITY);
        let maxr = self.gw.max(self.gh);
        for r in 0..=maxr {
            // Any point in ring r is at least (r - 1) * bs away.
            if best.0 != usize::MAX {
                let lb = (r as f64 - 1.0) * self.bs;
                if lb > 0.0 && lb * lb > best.1 {
                    break;
                }
            }
            for_each_in_ring((cx, cy), r, (self.gw, self.gh), |b| {
                for &i in &self.cells[b] {
                    let p = self.pts[i as usize];
                    let d = (p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]);
                    if d < best.1 || (d == best.1 && (i as usize) < best.0) {
                        best = (i as usize, d);
                    }
                }
            });
        }
        best
    }
}

/// Distance to the nearest of a set of segments, capped at `maxd` (bucket
/// grid; each segment is listed in every bucket within `maxd` of it).
pub(crate) struct SegmentIndex {
    pub(super) segs: Vec<[f64; 4]>,
    pub(super) bs: f64,
    pub(super) gw: usize,
    pub(super) gh: usize,
    pub(super) cells: Vec<Vec<u32>>,
    pub(super) maxd: f64,
}

impl SegmentIndex {
    pub(crate) fn new(
        lines: &[Vec<[f64; 2]>],
        width: usize,
        height: usize,
        maxd: f64,
    ) -> SegmentIndex {
        // At most 512 buckets a side, whatever the raster size.
        let bs = maxd.max(8.0).max(width.max(height) as f64 / 512.0);
        let gw = ((width as f64 / bs).ceil() as usize).max(1);
        let gh = ((height as f64 / bs).ceil() as usize).max(1);
        let mut cells = vec![Vec::new(); gw * gh];
        let mut segs = Vec::new();
        for l in lines {
            for w in l.windows(2) {
                let s = [w[0][0], w[0][1], w[1][0], w[1][1]];
                let lo = |a: f64, b: f64, n: usize| {
                    (((a.min(b) - maxd) / bs).floor().max(0.0) as usize).min(n)
                };
                let hi = |a: f64, b: f64, n: usize| {
                    ((((a.max(b) + maxd) / bs).floor()).max(-1.0) as i64).min(n as i64 - 1)
                };
                let (x0, x1) = (lo(s[0], s[2], gw), hi(s[0], s[2], gw));
                let (y0, y1) = (lo(s[1], s[3], gh), hi(s[1], s[3], gh));
                let id = segs.len() as u32;
                segs.push(s);
                for y in y0 as i64..=y1 {
                    for x in x0 as i64..=x1 {
                        cells[y as usize * gw + x as usize].push(id);
                    }
                }
            }
        }
        SegmentIndex {
            segs,
            bs,
            gw,
            gh,
            cells,
            maxd,
        }
    }

    pub(crate) fn is_empty(&self) -> bool {
        self.segs.is_empty()
    }

    /// Distance from `q` to the nearest segment, at most `maxd`.
    pub(crate) fn distance(&self, q: [f64; 2]) -> f64 {
        let cx = ((q[0] / self.bs).floor().max(0.0) as usize).min(self.gw - 1);
        let cy = ((q[1] / self.bs).floor().max(0.0) as usize).min(self.gh - 1);
        let mut best = self.maxd * self.maxd;
        for &i in &self.cells[cy * self.gw + cx] {
            let s = self.segs[i as usize];
            let (dx, dy) = (s[2] - s[0], s[3] - s[1]);
            let l2 = dx * dx + dy * dy;
            let t = if l2 > 0.0 {
                (((q[0] - s[0]) * dx + (q[1] - s[1]) * dy) / l2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let (ex, ey) = (s[0] + t * dx - q[0], s[1] + t * dy - q[1]);
            best = best.min(ex * ex + ey * ey);
        }
        best.sqrt()
    }
}

/// The part of segment ab inside [0, w] x [0, h] (Liang & Barsky 1984).
pub(super) fn clip(a: [f64; 2], b: [f64; 2], w: f64, h: f64) -> Option<([f64; 2], [f64; 2])> {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (p, q) in [(-dx, a[0]), (dx, w - a[0]), (-dy, a[1]), (dy, h - a[1])] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
        } else {
            let r = q / p;
            if p < 0.0 {
                t0 = t0.max(r);
            } else {
                t1 = t1.min(r);
            }
        }
    }
    (t0 <= t1 && t0.is_finite() && t1.is_finite()).then(|| {
        (
            [a[0] + t0 * dx, a[1] + t0 * dy],
            [a[0] + t1 * dx, a[1] + t1 * dy],
        )
    })
}

pub(super) fn envelope(peaks: &PointIndex, height: &[f64], r: f64, p: [f64; 2], unit: bool) -> f64 {
    let floor = (-8.0f64).exp();
    let mut best = 0.0f64;
    peaks.for_each_within(p, 4.0 * r, |i, d2| {
        let a = ((-0.5 * d2 / (r * r)).exp() - floor).max(0.0);
        let w = if unit { 1.0 } else { height[i] };
        best = best.max(w * a);
    });
    best
}
