//! Tectonic folds from a vector map (issue 7, part 2; the pipeline is the
//! tectonic-folds method as the issue describes it, step by step):
//!
//! 1. **Sub-plates**: the Voronoi cells of the map's peaks. The velocity of a
//!    sub-plate is the vector from its centre of mass to its peak.
//! 2. **Merging**: adjacent plates are merged while some pair qualifies: the
//!    normalised velocities agree (`v̂a·v̂b ≥ T1`) and the plates are of
//!    comparable size (`min(Aa, Ab) / max(Aa, Ab) ≥ T2`, so one plate cannot
//!    snowball over all its neighbours). Each round merges the qualifying
//!    pair with the largest dot product (ties: smallest plate ids); the
//!    merged velocity is the area-weighted mean. See [`merge_plates`].
//! 3. **Velocity map**: each cell takes its plate's velocity; the map is
//!    blurred with a Gaussian (σ = `blur` cells).
//! 4. **Folds**: fBm warped by the velocity map, `I′(p) = I(p + s·V(p))`
//!    (the warp compresses the noise where plates converge and stretches it
//!    where they part), attenuated by the distance to the nearest peak,
//!    `a(d) = exp(−d² / 2R²)` (shifted to reach 0 at 4R), and scaled by the
//!    peaks' heights: `fold(p) = E(p) · ((1 − k) + k · I′01(p))`, with the
//!    envelope `E(p) = max_i H_i · a(d_i)` (continuous, unlike the nearest
//!    peak's term alone), I′01 = I′ mapped to 0..1, k = `noise_share`.
//! 5. **Watershed map** g: sea cells are 0 next to land and `−sea_depth`
//!    further out; land heights grow from the coast along least-cost paths
//!    (Dijkstra), with a small slope on river cells and a larger one
//!    elsewhere, both multiplied by `1 + gain · a(d)` so slopes steepen near
//!    peaks. Heights thus run up the rivers from the sea first and spread
//!    outward from them.
//! 6. **Blend**: `h = g(1 − m) + f m`, m = distance to the nearest river /
//!    `river_width`, clamped to 0..1 (1 everywhere without rivers). Here the
//!    folded terrain is `f = g + fold`: the folds sit on the watershed map so
//!    that, far from rivers, the terrain keeps the regional rise from the
//!    coast (a documented reading of the description), hence
//!    `h = g + m · fold` on land; sea cells get `min(g, 0) − 1`.
//! 7. Hydraulic erosion finishes the terrain: that is `orogen erode`'s job,
//!    chained after this source (see the CLI).
//!
//! **Tileability.** Plates, their merging, the velocity map and the watershed
//! map are global but coarse: they are computed once on a coarse grid of at
//! most `coarse` cells along the longer side (default 512, i.e. one coarse
//! cell per 2x2 output cells at 1024², per 8x8 at 4096²; the velocity map is
//! blurred anyway and the watershed map is smooth, so this loses no visible
//! detail) and sampled bilinearly. Plate labels, peak distances, river
//! distances, the land mask and the noise are pure functions of the cell
//! position. So every output cell is a pure function of its position: any
//! window generated alone equals the same window of the whole raster, bit
//! for bit.

use super::noise::Fbm;
use super::vector::{RingMask, VectorMap};
use crate::error::{Error, Result};
use crate::raster::{AnyGrid, DType, GeoRef, Grid, RasterInfo, RasterSource, UnionFind, Window};
use serde::{Deserialize, Serialize};
use std::cmp::Ordering;
use std::collections::BinaryHeap;
use std::sync::Arc;

/// Parameters of the tectonic pipeline (lengths in output cells, heights in
/// metres, slopes in metres per metre).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct TectonicParams {
    /// The fold noise (seed, octaves, wavelength...; `base` and `amplitude`
    /// are not used: the peaks set the heights).
    pub fbm: Fbm,
    /// Merge threshold on the dot product of normalised velocities (-1..1).
    pub t1: f64,
    /// Merge threshold on the area ratio smaller/larger (0..1).
    pub t2: f64,
    /// Gaussian σ of the velocity-map blur (cells).
    pub blur: f64,
    /// Warp strength: the noise is sampled at p + strength · V(p).
    pub fold_strength: f64,
    /// Height of peaks without an `elevation` (m).
    pub relief: f64,
    /// Attenuation radius R of the folds around peaks (cells).
    pub peak_radius: f64,
    /// Share of the noise in the folds (0 = smooth bumps, 1 = pure noise).
    pub noise_share: f64,
    /// Slope along rivers in the watershed map.
    pub river_slope: f64,
    /// Slope away from rivers in the watershed map.
    pub hill_slope: f64,
    /// Slopes are multiplied by 1 + gain · a(d) (steeper near peaks).
    pub peak_slope_gain: f64,
    /// Distance to a river (cells) beyond which the folds apply fully.
    pub river_width: f64,
    /// Depth of the open sea in the watershed map (m).
    pub sea_depth: f64,
    /// Longest side of the coarse grid for plates, velocity and watershed map.
    pub coarse: usize,
}

impl Default for TectonicParams {
    fn default() -> Self {
        TectonicParams {
            fbm: Fbm {
                seed: 42,
                octaves: 8,
                wavelength: 256.0,
                warp: 20.0,
                ..Fbm::default()
            },
            t1: 0.8,
            t2: 0.25,
            blur: 24.0,
            fold_strength: 1.0,
            relief: 2000.0,
            peak_radius: 120.0,
            noise_share: 0.6,
            river_slope: 0.003,
            hill_slope: 0.03,
            peak_slope_gain: 2.0,
            river_width: 40.0,
            sea_depth: 60.0,
            coarse: 512,
        }
    }
}

impl TectonicParams {
    /// Check ranges.
    pub fn validate(&self) -> Result<()> {
        self.fbm.validate()?;
        let pos = |v: f64| v.is_finite() && v > 0.0;
        let nonneg = |v: f64| v.is_finite() && v >= 0.0;
        if !(self.t1.is_finite() && (-1.0..=1.0).contains(&self.t1)) {
            return Err(Error::invalid("tectonic t1 must be in -1..1"));
        }
        if !(self.t2.is_finite() && (0.0..=1.0).contains(&self.t2)) {
            return Err(Error::invalid("tectonic t2 must be in 0..1"));
        }
        if !(nonneg(self.blur) && self.blur <= 1e5) {
            return Err(Error::invalid("tectonic blur must be 0..100000 cells"));
        }
        if !(self.fold_strength.is_finite() && self.fold_strength.abs() <= 1e4) {
            return Err(Error::invalid(
                "tectonic fold strength must be a finite number up to 1e4",
            ));
        }
        if !(nonneg(self.relief) && self.relief < 1e5) {
            return Err(Error::invalid("tectonic relief must be 0..100000 m"));
        }
        if !(pos(self.peak_radius) && pos(self.river_width)) {
            return Err(Error::invalid(
                "tectonic peak radius and river width must be positive",
            ));
        }
        if !(nonneg(self.noise_share) && self.noise_share <= 1.0) {
            return Err(Error::invalid("tectonic noise share must be in 0..1"));
        }
        if !(nonneg(self.river_slope) && nonneg(self.hill_slope) && nonneg(self.peak_slope_gain))
            || self.river_slope > 10.0
            || self.hill_slope > 10.0
        {
            return Err(Error::invalid(
                "tectonic slopes must be in 0..10 and the gain >= 0",
            ));
        }
        if !(nonneg(self.sea_depth) && self.sea_depth < 1e5) {
            return Err(Error::invalid("tectonic sea depth must be 0..100000 m"));
        }
        if !(8..=8192).contains(&self.coarse) {
            return Err(Error::invalid("tectonic coarse grid must be 8..8192 cells"));
        }
        Ok(())
    }
}

/// Merge adjacent plates (see the module doc, step 2). `area[i]` and `vel[i]`
/// describe plate i, `adjacent` lists pairs of touching plates. Returns each
/// plate's merged label, numbered 0.. in the order of each group's smallest
/// plate id, and the merged velocities (area-weighted means).
pub fn merge_plates(
    area: &[f64],
    vel: &[[f64; 2]],
    adjacent: &[(u32, u32)],
    t1: f64,
    t2: f64,
) -> (Vec<u32>, Vec<[f64; 2]>) {
    let n = area.len();
    let mut root = UnionFind::<u32>::new(n);
    let mut a: Vec<f64> = area.to_vec();
    let mut mom: Vec<[f64; 2]> = (0..n)
        .map(|i| [vel[i][0] * area[i], vel[i][1] * area[i]])
        .collect();
    let unit = |m: [f64; 2], a: f64| -> Option<[f64; 2]> {
        if a <= 0.0 {
            return None;
        }
        let (x, y) = (m[0] / a, m[1] / a);
        let l = (x * x + y * y).sqrt();
        (l > 0.0 && l.is_finite()).then(|| [x / l, y / l])
    };
    let mut pairs: Vec<(u32, u32)> = adjacent
        .iter()
        .filter(|(i, j)| i != j && (*i as usize) < n && (*j as usize) < n)
        .map(|&(i, j)| (i.min(j), i.max(j)))
        .collect();
    loop {
        for p in pairs.iter_mut() {
            let (i, j) = (root.find(p.0), root.find(p.1));
            *p = (i.min(j), i.max(j));
        }
        pairs.retain(|p| p.0 != p.1);
        pairs.sort_unstable();
        pairs.dedup();
        let mut best: Option<(f64, (u32, u32))> = None;
        for &(i, j) in &pairs {
            let (ai, aj) = (a[i as usize], a[j as usize]);
            let (Some(ui), Some(uj)) = (unit(mom[i as usize], ai), unit(mom[j as usize], aj))
            else {
                continue;
            };
            let dot = ui[0] * uj[0] + ui[1] * uj[1];
            let ratio = ai.min(aj) / ai.max(aj);
            if dot >= t1 && ratio >= t2 && best.is_none_or(|(d, _)| dot > d) {
                best = Some((dot, (i, j)));
            }
        }
        let Some((_, (i, j))) = best else { break };
        // Merge j into i (i < j: the group keeps its smallest id as root).
        root.union_into(i, j);
        a[i as usize] += a[j as usize];
        mom[i as usize][0] += mom[j as usize][0];
        mom[i as usize][1] += mom[j as usize][1];
    }
    let mut label = vec![u32::MAX; n];
    let mut out_vel = Vec::new();
    let mut group = vec![0u32; n];
    for (i, gi) in group.iter_mut().enumerate() {
        let r = root.find(i as u32) as usize;
        if label[r] == u32::MAX {
            label[r] = out_vel.len() as u32;
            out_vel.push(if a[r] > 0.0 {
                [mom[r][0] / a[r], mom[r][1] / a[r]]
            } else {
                [0.0, 0.0]
            });
        }
        *gi = label[r];
    }
    (group, out_vel)
}

/// Nearest-point queries over a small point set (bucket grid, ring search).
/// Ties go to the smaller index, so the answer is a pure function of the
/// query point.
pub(crate) struct PointIndex {
    pts: Vec<[f64; 2]>,
    bs: f64,
    gw: usize,
    gh: usize,
    cells: Vec<Vec<u32>>,
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
    fn cell_of(bs: f64, gw: usize, gh: usize, p: [f64; 2]) -> (usize, usize) {
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
            let (x0, x1) = (cx as i64 - r as i64, cx as i64 + r as i64);
            let (y0, y1) = (cy as i64 - r as i64, cy as i64 + r as i64);
            for y in y0..=y1 {
                if y < 0 || y >= self.gh as i64 {
                    continue;
                }
                let edge_row = y == y0 || y == y1;
                let mut x = x0;
                while x <= x1 {
                    if x >= 0 && x < self.gw as i64 {
                        for &i in &self.cells[y as usize * self.gw + x as usize] {
                            let p = self.pts[i as usize];
                            let d = (p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]);
                            if d < best.1 || (d == best.1 && (i as usize) < best.0) {
                                best = (i as usize, d);
                            }
                        }
                    }
                    x = if edge_row || x == x1 { x + 1 } else { x1 };
                }
            }
        }
        best
    }
}

/// Distance to the nearest of a set of segments, capped at `maxd` (bucket
/// grid; each segment is listed in every bucket within `maxd` of it).
pub(crate) struct SegmentIndex {
    segs: Vec<[f64; 4]>,
    bs: f64,
    gw: usize,
    gh: usize,
    cells: Vec<Vec<u32>>,
    maxd: f64,
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
fn clip(a: [f64; 2], b: [f64; 2], w: f64, h: f64) -> Option<([f64; 2], [f64; 2])> {
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

fn envelope(peaks: &PointIndex, height: &[f64], r: f64, p: [f64; 2], unit: bool) -> f64 {
    let floor = (-8.0f64).exp();
    let mut best = 0.0f64;
    peaks.for_each_within(p, 4.0 * r, |i, d2| {
        let a = ((-0.5 * d2 / (r * r)).exp() - floor).max(0.0);
        let w = if unit { 1.0 } else { height[i] };
        best = best.max(w * a);
    });
    best
}

/// A coarse grid: `k` output cells per coarse cell.
#[derive(Debug, Clone)]
struct Coarse {
    k: f64,
    w: usize,
    h: usize,
}

impl Coarse {
    fn centre(&self, i: usize, j: usize) -> [f64; 2] {
        [(i as f64 + 0.5) * self.k, (j as f64 + 0.5) * self.k]
    }
    /// Bilinear sample of a coarse field at output position p (clamped).
    #[inline]
    fn sample(&self, f: &[f64], p: [f64; 2]) -> f64 {
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
fn gaussian_blur(f: &mut [f64], w: usize, h: usize, sigma: f64) {
    if sigma < 0.3 {
        return;
    }
    let r = (3.0 * sigma).ceil() as i64;
    let kern: Vec<f64> = (-r..=r)
        .map(|d| (-(d * d) as f64 / (2.0 * sigma * sigma)).exp())
        .collect();
    let norm: f64 = kern.iter().sum();
    let mut tmp = vec![0.0; f.len()];
    for y in 0..h {
        for x in 0..w {
            let mut s = 0.0;
            for (k, &c) in kern.iter().enumerate() {
                let xx = (x as i64 + k as i64 - r).clamp(0, w as i64 - 1) as usize;
                s += c * f[y * w + xx];
            }
            tmp[y * w + x] = s / norm;
        }
    }
    for y in 0..h {
        for x in 0..w {
            let mut s = 0.0;
            for (k, &c) in kern.iter().enumerate() {
                let yy = (y as i64 + k as i64 - r).clamp(0, h as i64 - 1) as usize;
                s += c * tmp[yy * w + x];
            }
            f[y * w + x] = s / norm;
        }
    }
}

#[derive(PartialEq)]
struct Item(f64, u32);
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

/// The global (coarse) part of the tectonic pipeline; every layer is sampled
/// from it by [`TectonicSource`].
pub struct TectonicModel {
    params: TectonicParams,
    width: usize,
    height: usize,
    peaks: PointIndex,
    peak_height: Vec<f64>,
    /// Merged plate of each peak's sub-plate.
    plate_of: Vec<u32>,
    plate_vel: Vec<[f64; 2]>,
    coarse: Coarse,
    vx: Vec<f64>,
    vy: Vec<f64>,
    water: Vec<f64>,
    land: Option<RingMask>,
    rivers: SegmentIndex,
}

/// Which raster a [`TectonicSource`] yields.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TectonicLayer {
    /// The final terrain before erosion (f32, m).
    Terrain,
    /// Merged plate labels (i32, 0..).
    Plates,
    /// Velocity magnitude after the blur (f32, cells).
    VelocityMagnitude,
    /// Velocity direction (f32, degrees clockwise from north).
    VelocityDirection,
    /// The attenuated folds, `fold(p)` (f32, m).
    Folds,
    /// The watershed map g (f32, m).
    Watershed,
}

impl TectonicLayer {
    /// All layers with their file stems for `--intermediates`.
    pub const INTERMEDIATES: [(TectonicLayer, &'static str); 5] = [
        (TectonicLayer::Plates, "plates"),
        (TectonicLayer::VelocityMagnitude, "velocity_magnitude"),
        (TectonicLayer::VelocityDirection, "velocity_direction"),
        (TectonicLayer::Folds, "folds"),
        (TectonicLayer::Watershed, "watershed"),
    ];
}

impl TectonicModel {
    /// Build the model of a `width x height` raster with cells of `cell_m`
    /// metres from `map` in pixel coordinates (x right, y down, cell (c, r)
    /// covers [c, c+1) x [r, r+1)). Errors: no peaks, a peak outside the
    /// raster, bad parameters, a raster beyond 2^31 cells a side.
    pub fn new(
        map: &VectorMap,
        width: usize,
        height: usize,
        cell_m: f64,
        params: TectonicParams,
    ) -> Result<Self> {
        params.validate()?;
        let p = &map.path;
        if width == 0 || height == 0 || width > 1 << 31 || height > 1 << 31 {
            return Err(Error::invalid(
                "tectonic raster size must be 1..2^31 cells a side",
            ));
        }
        if !(cell_m.is_finite() && cell_m > 0.0) {
            return Err(Error::invalid(
                "cell size must be a positive number of metres",
            ));
        }
        if map.peaks.is_empty() {
            return Err(Error::corrupt(
                p,
                "the map has no peaks (Point features); the tectonic pipeline needs at least one",
            ));
        }
        if map.peaks.len() > 1_000_000 {
            return Err(Error::too_large(p, "more than 1 000 000 peaks"));
        }
        for (i, pk) in map.peaks.iter().enumerate() {
            let [x, y] = pk.pos;
            if !(x >= 0.0 && y >= 0.0 && x <= width as f64 && y <= height as f64) {
                return Err(Error::corrupt(
                    p,
                    format!(
                        "peak {i} lies outside the {width} x {height} raster (column {x:.1}, row {y:.1}); enlarge the domain (--size/--origin) or remove the peak"
                    ),
                ));
            }
        }
        let peaks = PointIndex::new(map.peaks.iter().map(|k| k.pos).collect(), width, height);
        let peak_height: Vec<f64> = map
            .peaks
            .iter()
            .map(|k| k.elevation.unwrap_or(params.relief))
            .collect();
        let k = (width.max(height) as f64 / params.coarse as f64)
            .ceil()
            .max(1.0);
        let coarse = Coarse {
            k,
            w: ((width as f64 / k).ceil() as usize).max(1),
            h: ((height as f64 / k).ceil() as usize).max(1),
        };
        let (cw, ch) = (coarse.w, coarse.h);
        let n = map.peaks.len();

        // 1. Sub-plates on the coarse grid: labels, areas, centres of mass.
        let mut label = vec![0u32; cw * ch];
        let mut area = vec![0.0; n];
        let mut sum = vec![[0.0f64; 2]; n];
        let mut att = vec![0.0; cw * ch];
        for j in 0..ch {
            for i in 0..cw {
                let c = coarse.centre(i, j);
                let pi = peaks.nearest(c).0;
                label[j * cw + i] = pi as u32;
                area[pi] += 1.0;
                sum[pi][0] += c[0];
                sum[pi][1] += c[1];
                att[j * cw + i] = envelope(&peaks, &peak_height, params.peak_radius, c, true);
            }
        }
        let vel: Vec<[f64; 2]> = (0..n)
            .map(|i| {
                if area[i] > 0.0 {
                    let pk = map.peaks[i].pos;
                    [pk[0] - sum[i][0] / area[i], pk[1] - sum[i][1] / area[i]]
                } else {
                    [0.0, 0.0]
                }
            })
            .collect();
        let mut adj = Vec::new();
        for j in 0..ch {
            for i in 0..cw {
                let a = label[j * cw + i];
                if i + 1 < cw && label[j * cw + i + 1] != a {
                    adj.push((a, label[j * cw + i + 1]));
                }
                if j + 1 < ch && label[(j + 1) * cw + i] != a {
                    adj.push((a, label[(j + 1) * cw + i]));
                }
            }
        }
        // 2. Merging.
        let (plate_of, plate_vel) = merge_plates(&area, &vel, &adj, params.t1, params.t2);
        // 3. Velocity map, blurred.
        let mut vx: Vec<f64> = label
            .iter()
            .map(|&l| plate_vel[plate_of[l as usize] as usize][0])
            .collect();
        let mut vy: Vec<f64> = label
            .iter()
            .map(|&l| plate_vel[plate_of[l as usize] as usize][1])
            .collect();
        gaussian_blur(&mut vx, cw, ch, params.blur / k);
        gaussian_blur(&mut vy, cw, ch, params.blur / k);

        // 5. Watershed map on the coarse grid.
        let land = (!map.coasts.is_empty()).then(|| RingMask::new(&map.coasts, height));
        let is_land: Vec<bool> = (0..cw * ch)
            .map(|ix| {
                let c = coarse.centre(ix % cw, ix / cw);
                land.as_ref().is_none_or(|m| m.at(c[0], c[1]))
            })
            .collect();
        if !is_land.iter().any(|&l| l) {
            return Err(Error::corrupt(
                p,
                "the coastlines enclose no land inside the raster (check the coordinates and --map-units)",
            ));
        }
        let mut river = vec![false; cw * ch];
        for l in &map.rivers {
            for w in l.windows(2) {
                let Some((a, b)) = clip(w[0], w[1], width as f64, height as f64) else {
                    continue;
                };
                let len = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
                let steps = ((4.0 * len / k).ceil() as usize).clamp(1, 1 << 24);
                for s in 0..=steps {
                    let t = s as f64 / steps as f64;
                    let (x, y) = (a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]));
                    if x >= 0.0 && y >= 0.0 {
                        let (i, j) = ((x / k) as usize, (y / k) as usize);
                        if i < cw && j < ch {
                            river[j * cw + i] = true;
                        }
                    }
                }
            }
        }
        let nb8 = |ix: usize| {
            let (i, j) = ((ix % cw) as i64, (ix / cw) as i64);
            (0..9).filter(|&d| d != 4).filter_map(move |d| {
                let (ni, nj) = (i + d % 3 - 1, j + d / 3 - 1);
                (ni >= 0 && nj >= 0 && ni < cw as i64 && nj < ch as i64)
                    .then(|| (nj as usize * cw + ni as usize, d % 3 != 1 && d / 3 != 1))
            })
        };
        let mut water = vec![f64::INFINITY; cw * ch];
        let mut heap = BinaryHeap::new();
        for ix in 0..cw * ch {
            if !is_land[ix] {
                let coast = nb8(ix).any(|(n, _)| is_land[n]);
                water[ix] = if coast { 0.0 } else { -params.sea_depth };
                continue;
            }
            let (i, j) = (ix % cw, ix / cw);
            let seed = if land.is_some() {
                nb8(ix).any(|(n, _)| !is_land[n])
            } else {
                i == 0 || j == 0 || i == cw - 1 || j == ch - 1
            };
            if seed {
                water[ix] = 0.0;
                heap.push(Item(0.0, ix as u32));
            }
        }
        if heap.is_empty() {
            // Coastlines cover the whole raster: its edge is the outlet.
            for (ix, wv) in water.iter_mut().enumerate() {
                let (i, j) = (ix % cw, ix / cw);
                if i == 0 || j == 0 || i == cw - 1 || j == ch - 1 {
                    *wv = 0.0;
                    heap.push(Item(0.0, ix as u32));
                }
            }
        }
        let slope = |ix: usize| {
            let s = if river[ix] {
                params.river_slope
            } else {
                params.hill_slope
            };
            s * (1.0 + params.peak_slope_gain * att[ix])
        };
        let step = k * cell_m;
        while let Some(Item(hv, ix)) = heap.pop() {
            let ix = ix as usize;
            if hv > water[ix] {
                continue;
            }
            for (nx, diag) in nb8(ix) {
                if !is_land[nx] {
                    continue;
                }
                let len = if diag { std::f64::consts::SQRT_2 } else { 1.0 } * step;
                let nh = hv + len * 0.5 * (slope(ix) + slope(nx));
                if nh < water[nx] {
                    water[nx] = nh;
                    heap.push(Item(nh, nx as u32));
                }
            }
        }
        for w in water.iter_mut() {
            if !w.is_finite() {
                *w = 0.0;
            }
        }
        let rivers = SegmentIndex::new(&map.rivers, width, height, params.river_width);
        Ok(TectonicModel {
            params,
            width,
            height,
            peaks,
            peak_height,
            plate_of,
            plate_vel,
            coarse,
            vx,
            vy,
            water,
            land,
            rivers,
        })
    }

    /// Raster size.
    pub fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// Merged plate of each peak (indices into [`Self::plate_velocities`]).
    pub fn plate_of_peaks(&self) -> &[u32] {
        &self.plate_of
    }

    /// Velocity of each merged plate before the blur (cells).
    pub fn plate_velocities(&self) -> &[[f64; 2]] {
        &self.plate_vel
    }

    /// Compute `layer` over `win` (inside the raster), as f64 per cell.
    fn fill(&self, layer: TectonicLayer, win: Window, out: &mut [f64]) {
        let pr = &self.params;
        let mut land_row = vec![true; win.w];
        let mut xs = Vec::new();
        for y in 0..win.h {
            let gy = win.y as usize + y;
            if layer == TectonicLayer::Terrain {
                if let Some(m) = &self.land {
                    m.row(gy, win.x as usize, &mut land_row, &mut xs);
                }
            }
            for x in 0..win.w {
                let gx = win.x as usize + x;
                let p = [gx as f64 + 0.5, gy as f64 + 0.5];
                let o = &mut out[y * win.w + x];
                *o = match layer {
                    TectonicLayer::Plates => self.plate_of[self.peaks.nearest(p).0] as f64,
                    TectonicLayer::VelocityMagnitude => {
                        let (vx, vy) = (
                            self.coarse.sample(&self.vx, p),
                            self.coarse.sample(&self.vy, p),
                        );
                        (vx * vx + vy * vy).sqrt()
                    }
                    TectonicLayer::VelocityDirection => {
                        let (vx, vy) = (
                            self.coarse.sample(&self.vx, p),
                            self.coarse.sample(&self.vy, p),
                        );
                        // Rows grow southward: north is -y.
                        vx.atan2(-vy).to_degrees().rem_euclid(360.0)
                    }
                    TectonicLayer::Watershed => self.coarse.sample(&self.water, p),
                    TectonicLayer::Folds => self.fold(p),
                    TectonicLayer::Terrain => {
                        let g = self.coarse.sample(&self.water, p);
                        if land_row[x] {
                            let m = if self.rivers.is_empty() {
                                1.0
                            } else {
                                self.rivers.distance(p) / pr.river_width
                            };
                            g + m.clamp(0.0, 1.0) * self.fold(p)
                        } else {
                            g.min(0.0) - 1.0
                        }
                    }
                };
            }
        }
    }

    /// Peak envelope `max_i w_i · a(d_i)` over peaks within 4R, with
    /// `a(d) = exp(−d²/2R²) − exp(−8)` (zero at 4R, so the envelope is
    /// continuous; the nearest peak alone would jump where peak heights
    /// differ). `w_i` = the peak's height, or 1 with `unit`.
    #[inline]
    fn envelope(&self, p: [f64; 2], unit: bool) -> f64 {
        envelope(
            &self.peaks,
            &self.peak_height,
            self.params.peak_radius,
            p,
            unit,
        )
    }

    /// Attenuated, warped fold relief at p.
    #[inline]
    fn fold(&self, p: [f64; 2]) -> f64 {
        let pr = &self.params;
        let s = pr.fold_strength;
        let (vx, vy) = (
            self.coarse.sample(&self.vx, p),
            self.coarse.sample(&self.vy, p),
        );
        let n = pr.fbm.sample(p[0] + s * vx, p[1] + s * vy);
        let n01 = (0.5 * (n + 1.0)).clamp(0.0, 1.0);
        self.envelope(p, false) * ((1.0 - pr.noise_share) + pr.noise_share * n01)
    }
}

/// One layer of a [`TectonicModel`] as a tileable raster source.
pub struct TectonicSource {
    model: Arc<TectonicModel>,
    layer: TectonicLayer,
    info: RasterInfo,
}

impl TectonicSource {
    /// `layer` of `model`, georeferenced by `georef`.
    pub fn new(model: Arc<TectonicModel>, layer: TectonicLayer, georef: GeoRef) -> Self {
        let dtype = if layer == TectonicLayer::Plates {
            DType::I32
        } else {
            DType::F32
        };
        let info = RasterInfo {
            width: model.width,
            height: model.height,
            dtype,
            georef,
            block: (256, 256),
            path: "<tectonic>".into(),
        };
        TectonicSource { model, layer, info }
    }
}

impl RasterSource for TectonicSource {
    fn info(&self) -> &RasterInfo {
        &self.info
    }
    fn read_native(&self, win: Window) -> Result<AnyGrid> {
        let mut v = vec![0.0; win.w * win.h];
        self.model.fill(self.layer, win, &mut v);
        Ok(if self.layer == TectonicLayer::Plates {
            AnyGrid::I32(Grid::from_vec(
                win.w,
                win.h,
                v.iter().map(|&x| x as i32).collect(),
            )?)
        } else {
            AnyGrid::F32(Grid::from_vec(
                win.w,
                win.h,
                v.iter().map(|&x| x as f32).collect(),
            )?)
        })
    }
}

/// Convert a map from CRS coordinates to pixel coordinates of `georef`
/// (north-up or rotated; errors on a singular transform).
pub fn map_to_pixels(map: &VectorMap, georef: &GeoRef) -> Result<VectorMap> {
    if georef.map_to_pixel(0.0, 0.0).is_none() {
        return Err(Error::invalid(
            "the output georeference has a singular transform",
        ));
    }
    Ok(map.transformed(|p| {
        let (c, r) = georef
            .map_to_pixel(p[0], p[1])
            .unwrap_or((f64::NAN, f64::NAN));
        [c, r]
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn merge_rules_on_hand_made_plates() {
        // Four plates in a row 0-1-2-3. 0 and 1 move east together (cos 1),
        // 1 and 2 at 90° (cos 0), 2 and 3 nearly together (cos ≈ 0.995) but 3
        // is tiny (ratio 0.05).
        let area = [100.0, 80.0, 100.0, 5.0];
        let vel = [[1.0, 0.0], [2.0, 0.0], [0.0, 1.0], [0.1, 1.0]];
        let adj = [(0, 1), (1, 2), (2, 3)];
        let (g, v) = merge_plates(&area, &vel, &adj, 0.8, 0.25);
        assert_eq!(g, vec![0, 0, 1, 2]);
        // Area-weighted velocity of {0, 1}: (100·1 + 80·2) / 180.
        assert!((v[0][0] - 260.0 / 180.0).abs() < 1e-12 && v[0][1] == 0.0);
        assert_eq!(v[1], [0.0, 1.0]);
        // Without the area rule the tiny plate joins plate 2.
        let (g, _) = merge_plates(&area, &vel, &adj, 0.8, 0.0);
        assert_eq!(g, vec![0, 0, 1, 1]);
        // A strict direction rule merges nothing but the identical directions.
        let (g, _) = merge_plates(&area, &vel, &adj, 0.999, 0.0);
        assert_eq!(g, vec![0, 0, 1, 2]);
        // Non-adjacent plates never merge: 0 and 2 have the same direction here.
        let vel2 = [[1.0, 0.0], [0.0, 1.0], [1.0, 0.0], [0.0, -1.0]];
        let (g, _) = merge_plates(&area, &vel2, &adj, 0.5, 0.0);
        assert_eq!(g, vec![0, 1, 2, 3]);
    }

    #[test]
    fn merge_is_greedy_on_best_dot() {
        // 1 is adjacent to 0 (cos 0.9) and 2 (cos 0.95): it joins 2 first; the
        // merged {1,2} then has direction between them and may join 0.
        let a = 0.9f64.acos();
        let b = 0.95f64.acos();
        let vel = [[a.cos(), a.sin()], [1.0, 0.0], [b.cos(), -b.sin()]];
        let (g, _) = merge_plates(&[1.0, 1.0, 1.0], &vel, &[(0, 1), (1, 2)], 0.93, 0.0);
        assert_eq!(g, vec![0, 1, 1]);
    }

    #[test]
    fn point_index_matches_brute_force() {
        let pts: Vec<[f64; 2]> = (0..57)
            .map(|i| {
                let h = super::super::noise::gradient_noise(i as f64 * 0.37, 0.5, 9);
                [
                    ((i * 7919) % 300) as f64 + h,
                    ((i * 104_729) % 170) as f64 * 1.1,
                ]
            })
            .collect();
        let idx = PointIndex::new(pts.clone(), 300, 200);
        for qy in 0..40 {
            for qx in 0..60 {
                let q = [qx as f64 * 5.1, qy as f64 * 5.3];
                let mut best = (0, f64::INFINITY);
                for (i, p) in pts.iter().enumerate() {
                    let d = (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2);
                    if d < best.1 {
                        best = (i, d);
                    }
                }
                assert_eq!(idx.nearest(q), best, "{q:?}");
            }
        }
    }
}
