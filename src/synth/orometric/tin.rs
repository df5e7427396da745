//! A triangulated irregular network (TIN) sampled at any point by
//! barycentric interpolation, with a uniform bucket grid over the triangles
//! so a query only tests the few triangles of its bucket.
//!
//! A query is a pure function of its position (the first containing
//! triangle in increasing id order wins; a point in no triangle, which only
//! rounding can cause, takes the triangle it is least outside of), so any
//! window computed alone equals the same cells of a whole render.

use crate::error::{Error, Result};

/// A TIN with a bucket index (see the module doc).
#[derive(Debug, Clone)]
pub struct Tin {
    xy: Vec<[f64; 2]>,
    z: Vec<f64>,
    tris: Vec<[u32; 3]>,
    x0: f64,
    y0: f64,
    bucket: f64,
    nbx: usize,
    nby: usize,
    start: Vec<u32>,
    ids: Vec<u32>,
}

/// Largest number of (triangle, bucket) pairs indexed.
const MAX_REFS: usize = 1 << 31;

impl Tin {
    /// Index the triangles `tris` (vertex ids) of vertices `xy` with
    /// elevations `z` over the rectangle [x0, x0 + w] x [y0, y0 + h],
    /// with square buckets of side `bucket`.
    pub fn new(
        xy: Vec<[f64; 2]>,
        z: Vec<f64>,
        tris: Vec<[u32; 3]>,
        rect: [f64; 4],
        bucket: f64,
    ) -> Result<Tin> {
        let [x0, y0, w, h] = rect;
        if xy.len() != z.len()
            || tris
                .iter()
                .any(|t| t.iter().any(|&v| v as usize >= xy.len()))
        {
            return Err(Error::invalid("TIN: a triangle names a missing vertex"));
        }
        if !(bucket > 0.0 && w > 0.0 && h > 0.0 && bucket.is_finite()) {
            return Err(Error::invalid("TIN: empty extent or bucket"));
        }
        let nbx = ((w / bucket).ceil() as usize).max(1);
        let nby = ((h / bucket).ceil() as usize).max(1);
        if nbx.saturating_mul(nby) > 1 << 28 {
            return Err(Error::invalid("TIN: too many buckets; use larger buckets"));
        }
        let bi =
            |v: f64, o: f64, n: usize| (((v - o) / bucket).floor().max(0.0) as usize).min(n - 1);
        let range = |t: &[u32; 3]| {
            let (mut a, mut b, mut c, mut d) = (
                f64::INFINITY,
                f64::INFINITY,
                f64::NEG_INFINITY,
                f64::NEG_INFINITY,
            );
            for &v in t {
                let p = xy[v as usize];
                a = a.min(p[0]);
                b = b.min(p[1]);
                c = c.max(p[0]);
                d = d.max(p[1]);
            }
            (
                bi(a, x0, nbx),
                bi(b, y0, nby),
                bi(c, x0, nbx),
                bi(d, y0, nby),
            )
        };
        let mut counts = vec![0u32; nbx * nby + 1];
        let mut total = 0usize;
        for t in &tris {
            let (bx0, by0, bx1, by1) = range(t);
            total += (bx1 - bx0 + 1) * (by1 - by0 + 1);
            if total > MAX_REFS {
                return Err(Error::invalid("TIN: the bucket index would be too large"));
            }
            for by in by0..=by1 {
                for bx in bx0..=bx1 {
                    counts[by * nbx + bx + 1] += 1;
                }
            }
        }
        for i in 1..counts.len() {
            counts[i] += counts[i - 1];
        }
        let mut fill = counts.clone();
        let mut ids = vec![0u32; total];
        for (i, t) in tris.iter().enumerate() {
            let (bx0, by0, bx1, by1) = range(t);
            for by in by0..=by1 {
                for bx in bx0..=bx1 {
                    let b = by * nbx + bx;
                    ids[fill[b] as usize] = i as u32;
                    fill[b] += 1;
                }
            }
        }
        Ok(Tin {
            xy,
            z,
            tris,
            x0,
            y0,
            bucket,
            nbx,
            nby,
            start: counts,
            ids,
        })
    }

    /// Bytes held on the heap (vertices, triangles, bucket index).
    pub fn heap_bytes(&self) -> usize {
        self.xy.len() * 16
            + self.z.len() * 8
            + self.tris.len() * 12
            + (self.start.len() + self.ids.len()) * 4
    }

    /// Number of triangles.
    pub fn n_triangles(&self) -> usize {
        self.tris.len()
    }

    /// Vertex positions.
    pub fn vertices(&self) -> &[[f64; 2]] {
        &self.xy
    }

    /// Vertex elevations.
    pub fn elevations(&self) -> &[f64] {
        &self.z
    }

    /// Triangles (vertex ids).
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.tris
    }

    /// Barycentric weights of (x, y) in triangle `t`.
    #[inline]
    fn bary(&self, t: usize, x: f64, y: f64) -> [f64; 3] {
        let [a, b, c] = self.tris[t];
        let (pa, pb, pc) = (
            self.xy[a as usize],
            self.xy[b as usize],
            self.xy[c as usize],
        );
        let (e1x, e1y) = (pb[0] - pa[0], pb[1] - pa[1]);
        let (e2x, e2y) = (pc[0] - pa[0], pc[1] - pa[1]);
        let den = e1x * e2y - e2x * e1y;
        if den == 0.0 {
            return [f64::NEG_INFINITY; 3];
        }
        let (qx, qy) = (x - pa[0], y - pa[1]);
        let wb = (qx * e2y - e2x * qy) / den;
        let wc = (e1x * qy - qx * e1y) / den;
        [1.0 - wb - wc, wb, wc]
    }

    /// Elevation at (x, y) (NaN if no triangle is indexed near it).
    pub fn value(&self, x: f64, y: f64) -> f64 {
        let bx = (((x - self.x0) / self.bucket).floor().max(0.0) as usize).min(self.nbx - 1);
        let by = (((y - self.y0) / self.bucket).floor().max(0.0) as usize).min(self.nby - 1);
        let b = by * self.nbx + bx;
        let mut best = (f64::NEG_INFINITY, [0.0; 3], usize::MAX);
        for &t in &self.ids[self.start[b] as usize..self.start[b + 1] as usize] {
            let w = self.bary(t as usize, x, y);
            let m = w[0].min(w[1]).min(w[2]);
            if m > best.0 {
                best = (m, w, t as usize);
                if m >= -1e-12 {
                    break;
                }
            }
        }
        if best.2 == usize::MAX {
            return f64::NAN;
        }
        let [a, b2, c] = self.tris[best.2];
        let w = best.1;
        w[0] * self.z[a as usize] + w[1] * self.z[b2 as usize] + w[2] * self.z[c as usize]
    }
}
