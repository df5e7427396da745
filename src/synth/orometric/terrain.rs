//! Terrain from a divide tree, rasterised at any resolution, tile by tile.
//!
//! Ridges: each ridge peak–saddle–peak is refined into a polyline with
//! vertices every λ (default 200 m) and random planar jitter (Argudo et al.
//! 2019, §6.2), its elevation falling linearly from each peak to the saddle.
//! The surface is the upper envelope of sloped "tents" over the ridge
//! segments, h(x) = max(floor, max_s max_u [z_s(u) − σ_s·√((u − u_x)² + (d⊥ − w)₊²)]),
//! maximised over the position u along each segment in closed form (the
//! function is concave in u). σ_s is the flank slope (at least 1.25 × the
//! segment's own gradient, so a tent never rises above its ridge), w a crest
//! half-width of about half a cell, so every 8-connected digital path along a
//! ridge reads the ridge's own elevation: the peaks are the maxima, the
//! saddles the minimax points of the tree, at their cells and elevations.
//! Valleys form where tents of neighbouring ridges meet.
//!
//! This "tents" model stands in for the paper's river network, Poisson-disk
//! samples and constrained TIN (§6), which [`super::terrain_tin`] builds (the
//! default model, chosen by [`TerrainOptions::model`] and [`build_terrain`]):
//! it keeps the tree at a fraction of the cost, but valleys are V-shaped
//! rather than fluvial.
//! Multifractal noise (fBm with ridged octaves, [`crate::synth::Fbm`]) of
//! amplitude below the prominence threshold is added away from the crests.
//!
//! Rasterisation: segments are bucketed on a coarse grid; each 32 x 32 block
//! of cells takes a lower bound of the surface at its centre (the tents are
//! σ-Lipschitz) and keeps only segments whose upper bound over the block
//! beats it, sorted so each cell stops early. Any window can be computed
//! alone: [`OroTerrain`] is a [`RasterSource`], so terrains of any size
//! stream to a tile store in memory bounded by the tree.

use super::terrain_tin::TinTerrain;
use super::tree_synth::SynthTree;
use crate::error::{Error, Result};
use crate::oro::stats::SplitMix64;
use crate::raster::{AnyGrid, Crs, DType, GeoRef, Grid, RasterInfo, RasterSource, Window};
use crate::synth::source_info;
use crate::synth::Fbm;
use rayon::prelude::*;

/// Options of terrain generation.
#[derive(Debug, Clone)]
pub struct TerrainOptions {
    /// Flank slope (m per m) away from the ridges.
    pub slope: f64,
    /// Ridge refinement spacing λ, metres.
    pub spacing_m: f64,
    /// Planar jitter of refined ridge vertices, fraction of λ.
    pub jitter: f64,
    /// Noise amplitude, m (None: 0.3 × the tree's prominence threshold).
    pub noise_amplitude: Option<f64>,
    /// Noise wavelength, cells.
    pub noise_wavelength: f64,
    /// Lowest elevation (None: the lowest saddle − the prominence threshold, ≥ 0).
    pub floor: Option<f64>,
    /// Which terrain model renders the tree.
    pub model: TerrainModel,
    /// TIN model: valley floor width (m) at 1 km² of drainage area (w ∝ A^0.4).
    pub valley_width: f64,
    /// TIN model: river channel slope (m/m) at 1 km² of drainage area.
    pub river_slope: f64,
}

/// Terrain model of [`build_terrain`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum TerrainModel {
    /// The paper's model (§6): river network dual of the tree, valley-width
    /// interpolation and a constrained TIN ([`TinTerrain`]).
    #[default]
    Tin,
    /// Upper envelope of tents over the ridges ([`OroTerrain`]).
    Tents,
}

/// The terrain of `tree` with the model `opts.model`, as a raster source.
pub fn build_terrain(tree: &SynthTree, opts: &TerrainOptions) -> Result<Box<dyn RasterSource>> {
    Ok(match opts.model {
        TerrainModel::Tin => Box::new(TinTerrain::new(tree, opts)?),
        TerrainModel::Tents => Box::new(OroTerrain::new(tree, opts)?),
    })
}

impl Default for TerrainOptions {
    fn default() -> Self {
        TerrainOptions {
            slope: 0.6,
            spacing_m: 200.0,
            jitter: 0.25,
            noise_amplitude: None,
            noise_wavelength: 24.0,
            floor: None,
            model: TerrainModel::default(),
            valley_width: 100.0,
            river_slope: 0.2,
        }
    }
}

impl TerrainOptions {
    /// The render's lowest elevation and noise amplitude for `tree` (defaults:
    /// the lowest saddle − the prominence threshold, ≥ 0, and 0.3 × the
    /// threshold), checked: an amplitude of half the threshold or more could
    /// raise peaks the tree does not have.
    pub(crate) fn floor_and_amplitude(&self, tree: &SynthTree) -> Result<(f64, f64)> {
        let thr = tree.min_prominence;
        let min_saddle = tree
            .saddles
            .iter()
            .map(|s| s.elevation)
            .fold(f64::INFINITY, f64::min);
        let floor = match self.floor {
            Some(f) => f,
            None if min_saddle.is_finite() => (min_saddle - thr).max(0.0),
            None => 0.0,
        };
        let amp = self.noise_amplitude.unwrap_or(0.3 * thr);
        if !(amp.is_finite() && amp >= 0.0 && floor.is_finite()) {
            return Err(Error::invalid(
                "terrain: noise amplitude and floor must be finite, amplitude ≥ 0",
            ));
        }
        if amp >= 0.5 * thr {
            return Err(Error::invalid(format!(
                "terrain: a noise amplitude of {amp} m could make peaks of prominence ≥ the threshold {thr} m; keep it below half the threshold"
            )));
        }
        Ok((floor, amp))
    }

    /// The unit fBm (five octaves, seeded from the tree) the render adds
    /// scaled by `amp`; `None` when `amp` is 0.
    pub(crate) fn noise(&self, tree: &SynthTree, amp: f64) -> Option<(Fbm, f64)> {
        (amp > 0.0).then(|| {
            (
                Fbm {
                    seed: tree.seed ^ 0x006e_6f69_7365,
                    octaves: 5,
                    lacunarity: 2.0,
                    gain: 0.5,
                    wavelength: self.noise_wavelength.max(2.0),
                    base: 0.0,
                    amplitude: 1.0,
                    warp: 0.0,
                },
                amp,
            )
        })
    }
}

#[derive(Debug, Clone, Copy)]
struct Seg {
    ax: f64,
    ay: f64,
    az: f64,
    ux: f64,
    uy: f64,
    len: f64,
    /// Elevation gradient along the segment.
    g: f64,
    /// Flank slope.
    s: f64,
    /// |g| / √(s² − g²): where the tent's maximum lies along the segment.
    k: f64,
    zmax: f64,
    bbox: [f64; 4],
    /// The peak at the top of this ridge half.
    peak: u32,
}

impl Seg {
    fn new(a: (f64, f64, f64), b: (f64, f64, f64), slope: f64) -> Option<Seg> {
        let (dx, dy) = (b.0 - a.0, b.1 - a.1);
        let len = dx.hypot(dy);
        if len.is_nan() || len <= 1e-9 {
            return None;
        }
        let g = (b.2 - a.2) / len;
        let s = slope.max(1.25 * g.abs());
        Some(Seg {
            ax: a.0,
            ay: a.1,
            az: a.2,
            ux: dx / len,
            uy: dy / len,
            len,
            g,
            s,
            k: g.abs() / (s * s - g * g).sqrt(),
            zmax: a.2.max(b.2),
            bbox: [a.0.min(b.0), a.1.min(b.1), a.0.max(b.0), a.1.max(b.1)],
            peak: 0,
        })
    }

    /// Tent value at (x, y) with crest half-width `w`.
    #[inline]
    fn eval(&self, x: f64, y: f64, w: f64) -> f64 {
        let (px, py) = (x - self.ax, y - self.ay);
        let u = px * self.ux + py * self.uy;
        // Offset beyond the crest band; inside it a point reads the ridge at
        // its projection (no gain along the ridge, so saddles stay exact).
        let v = ((px * self.uy - py * self.ux).abs() - w).max(0.0);
        let us = (u + v * self.k * self.g.signum()).clamp(0.0, self.len);
        let r = (us - u).hypot(v);
        self.az + self.g * us - self.s * r
    }

    /// Distance from (x, y) to the segment.
    #[inline]
    fn dist(&self, x: f64, y: f64) -> f64 {
        let (px, py) = (x - self.ax, y - self.ay);
        let u = (px * self.ux + py * self.uy).clamp(0.0, self.len);
        (px - u * self.ux).hypot(py - u * self.uy)
    }
}

/// Steepest flank slope [`steepen`] gives a segment.
const MAX_SLOPE: f64 = 8.0;

/// Lowest saddle on the tree path between two peaks, by binary lifting
/// (Bender & Farach-Colton 2000, "The LCA problem revisited": ancestor
/// tables of 2^k steps, here carrying the path minimum).
struct PathMin {
    depth: Vec<u32>,
    up: Vec<Vec<u32>>,
    mn: Vec<Vec<f64>>,
}

impl PathMin {
    fn new(tree: &SynthTree) -> PathMin {
        let n = tree.peaks.len();
        let mut adj = vec![Vec::new(); n];
        for s in &tree.saddles {
            adj[s.peaks[0]].push((s.peaks[1], s.elevation));
            adj[s.peaks[1]].push((s.peaks[0], s.elevation));
        }
        let mut depth = vec![u32::MAX; n];
        let mut par = vec![0u32; n];
        let mut pmin = vec![f64::INFINITY; n];
        depth[0] = 0;
        let mut stack = vec![0usize];
        while let Some(a) = stack.pop() {
            for &(b, z) in &adj[a] {
                if depth[b] == u32::MAX {
                    depth[b] = depth[a] + 1;
                    par[b] = a as u32;
                    pmin[b] = z;
                    stack.push(b);
                }
            }
        }
        let levels = (usize::BITS - n.leading_zeros()).max(1) as usize;
        let mut up = vec![par];
        let mut mn = vec![pmin];
        for k in 1..levels {
            let (pu, pm) = (&up[k - 1], &mn[k - 1]);
            let nu: Vec<u32> = (0..n).map(|v| pu[pu[v] as usize]).collect();
            let nm: Vec<f64> = (0..n).map(|v| pm[v].min(pm[pu[v] as usize])).collect();
            up.push(nu);
            mn.push(nm);
        }
        PathMin { depth, up, mn }
    }

    fn query(&self, a: usize, b: usize) -> f64 {
        let (mut a, mut b) = (a, b);
        let mut m = f64::INFINITY;
        if self.depth[a] < self.depth[b] {
            std::mem::swap(&mut a, &mut b);
        }
        let mut diff = self.depth[a] - self.depth[b];
        let mut k = 0;
        while diff > 0 {
            if diff & 1 == 1 {
                m = m.min(self.mn[k][a]);
                a = self.up[k][a] as usize;
            }
            diff >>= 1;
            k += 1;
        }
        if a == b {
            return m;
        }
        for k in (0..self.up.len()).rev() {
            if self.up[k][a] != self.up[k][b] {
                m = m.min(self.mn[k][a]).min(self.mn[k][b]);
                a = self.up[k][a] as usize;
                b = self.up[k][b] as usize;
            }
        }
        m.min(self.mn[0][a]).min(self.mn[0][b])
    }
}

/// Adaptive flanks: raise each segment's slope until (1) its tent stays
/// below every other segment's crest and (2) where its tent meets another
/// segment's tent, the valley between them lies below the lowest saddle on
/// the tree path joining the two ridges (else the valley would be a new,
/// higher pass and change prominences). Checked at the other segment's ends
/// and middle against the nearest point of this segment; the meeting level of
/// two tents of slopes s_a, s_b over a gap D is (s_b z_a + s_a z_b −
/// s_a s_b D)/(s_a + s_b). Run a few rounds (the other slope changes too).
/// Capped at [`MAX_SLOPE`]; crests closer than the crest width cannot be
/// separated.
#[allow(clippy::too_many_arguments)]
fn steepen(
    segs: &mut [Seg],
    start: &[u32],
    ids: &[u32],
    bucket: f64,
    nbx: usize,
    nby: usize,
    crest: f64,
    paths: &PathMin,
) {
    let bidx = |v: f64, n: usize| ((v / bucket).floor().max(0.0) as usize).min(n - 1);
    let new_s: Vec<f64> = (0..segs.len())
        .into_par_iter()
        .map(|a| {
            let sa = &segs[a];
            let mut s = sa.s;
            // Reach of this tent above the lowest crest it could bury.
            let reach = (sa.zmax / s).min(64.0 * bucket) + crest;
            let (x0, x1) = (bidx(sa.bbox[0] - reach, nbx), bidx(sa.bbox[2] + reach, nbx));
            let (y0, y1) = (bidx(sa.bbox[1] - reach, nby), bidx(sa.bbox[3] + reach, nby));
            for by in y0..=y1 {
                for bx in x0..=x1 {
                    let b = by * nbx + bx;
                    for &j in &ids[start[b] as usize..start[b + 1] as usize] {
                        if j as usize == a {
                            continue;
                        }
                        let sb = &segs[j as usize];
                        for t in [0.0, 0.5, 1.0] {
                            let u = t * sb.len;
                            let (px, py) = (sb.ax + u * sb.ux, sb.ay + u * sb.uy);
                            let zb = sb.az + sb.g * u;
                            // Nearest point of segment a.
                            let (qx, qy) = (px - sa.ax, py - sa.ay);
                            let ua = (qx * sa.ux + qy * sa.uy).clamp(0.0, sa.len);
                            let d = (qx - ua * sa.ux).hypot(qy - ua * sa.uy) - crest;
                            if d <= 0.0 {
                                continue;
                            }
                            let za = sa.az + sa.g * ua;
                            if za > zb {
                                s = s.max(1.05 * (za - zb) / d);
                            }
                            // Valley between the two crests vs the tree's pass.
                            let lvl = paths.query(sa.peak as usize, sb.peak as usize);
                            let l = lvl.min(za).min(zb) - 1.0;
                            if lvl < za.min(zb) && d > 0.0 {
                                let sbv = sb.s;
                                let den = l + sbv * d - zb;
                                // (den ≤ 0: b's tent alone reaches above the
                                // pass; b's own round steepens it.)
                                if den > 0.0 {
                                    s = s.max(1.02 * sbv * (za - l) / den);
                                }
                            }
                        }
                    }
                }
            }
            s.min(MAX_SLOPE.max(sa.s))
        })
        .collect();
    for (sg, s) in segs.iter_mut().zip(new_s) {
        if s > sg.s {
            sg.s = s;
            sg.k = sg.g.abs() / (s * s - sg.g * sg.g).sqrt();
        }
    }
}

/// A terrain generated from a divide tree: a [`RasterSource`] (f32).
pub struct OroTerrain {
    info: RasterInfo,
    cell: f64,
    segs: Vec<Seg>,
    bucket: f64,
    nbx: usize,
    nby: usize,
    /// Segment ids per bucket (CSR).
    start: Vec<u32>,
    ids: Vec<u32>,
    zmax_all: f64,
    s_min: f64,
    crest: f64,
    floor: f64,
    noise: Option<(Fbm, f64)>,
}

/// Block side (cells) of the culling.
const BLK: usize = 32;

impl OroTerrain {
    /// Refine the ridges of `tree` and index them.
    pub fn new(tree: &SynthTree, opts: &TerrainOptions) -> Result<OroTerrain> {
        tree.validate()?;
        if !(opts.slope.is_finite() && opts.slope > 0.0 && opts.slope <= 100.0) {
            return Err(Error::invalid(
                "terrain: the flank slope must be in (0, 100]",
            ));
        }
        if !(opts.spacing_m.is_finite() && opts.spacing_m > 0.0) {
            return Err(Error::invalid(
                "terrain: the ridge spacing λ must be positive",
            ));
        }
        if !(opts.jitter.is_finite() && (0.0..=0.5).contains(&opts.jitter)) {
            return Err(Error::invalid(
                "terrain: the ridge jitter must be in [0, 0.5]",
            ));
        }
        let cell = tree.cell;
        let (wm, hm) = (tree.width as f64 * cell, tree.height as f64 * cell);
        let lambda = opts.spacing_m.max(cell);
        let mut rng = SplitMix64(tree.seed ^ 0x7465_7272_6169_6e00);
        let mut segs = Vec::new();
        // Bound the refinement: at most 64 M segments.
        let total_len = tree.ridge_length();
        if total_len / lambda + 2.0 * tree.saddles.len() as f64 > 64e6 {
            return Err(Error::invalid(
                "terrain: the ridges would need over 64 M segments; give a larger --spacing",
            ));
        }
        for s in &tree.saddles {
            for &pi in &s.peaks {
                let p = &tree.peaks[pi];
                let (dx, dy) = (s.x - p.x, s.y - p.y);
                let l = dx.hypot(dy);
                let m = ((l / lambda).ceil() as usize).max(1);
                let amp = opts.jitter * (l / m as f64);
                let (nx, ny) = if l > 0.0 {
                    (-dy / l, dx / l)
                } else {
                    (0.0, 0.0)
                };
                let mut prev = (p.x, p.y, p.elevation);
                for i in 1..=m {
                    let t = i as f64 / m as f64;
                    let off = if i < m {
                        (rng.unit() - 0.5) * 2.0 * amp
                    } else {
                        0.0
                    };
                    let cur = (
                        p.x + t * dx + off * nx,
                        p.y + t * dy + off * ny,
                        p.elevation + t * (s.elevation - p.elevation),
                    );
                    if let Some(mut seg) = Seg::new(prev, cur, opts.slope) {
                        seg.peak = pi as u32;
                        segs.push(seg);
                    }
                    prev = cur;
                }
            }
        }
        let bucket = BLK as f64 * cell;
        let crest = 0.55 * cell;
        let nbx = ((wm / bucket).ceil() as usize).max(1);
        let nby = ((hm / bucket).ceil() as usize).max(1);
        let bidx = |v: f64, n: usize| ((v / bucket).floor().max(0.0) as usize).min(n - 1);
        let mut counts = vec![0u32; nbx * nby + 1];
        for sg in &segs {
            for by in bidx(sg.bbox[1], nby)..=bidx(sg.bbox[3], nby) {
                for bx in bidx(sg.bbox[0], nbx)..=bidx(sg.bbox[2], nbx) {
                    counts[by * nbx + bx + 1] += 1;
                }
            }
        }
        for i in 1..counts.len() {
            counts[i] += counts[i - 1];
        }
        let mut fillp = counts.clone();
        let mut ids = vec![0u32; counts[nbx * nby] as usize];
        for (i, sg) in segs.iter().enumerate() {
            for by in bidx(sg.bbox[1], nby)..=bidx(sg.bbox[3], nby) {
                for bx in bidx(sg.bbox[0], nbx)..=bidx(sg.bbox[2], nbx) {
                    let b = by * nbx + bx;
                    ids[fillp[b] as usize] = i as u32;
                    fillp[b] += 1;
                }
            }
        }
        let paths = PathMin::new(tree);
        for _ in 0..3 {
            steepen(&mut segs, &counts, &ids, bucket, nbx, nby, crest, &paths);
        }
        let zmax_all = segs.iter().map(|s| s.zmax).fold(0.0, f64::max);
        let s_min = segs.iter().map(|s| s.s).fold(f64::INFINITY, f64::min);
        let (floor, amp) = opts.floor_and_amplitude(tree)?;
        let noise = opts.noise(tree, amp);
        let georef = GeoRef::north_up(0.0, hm, cell, Crs::default());
        Ok(OroTerrain {
            info: source_info(tree.width, tree.height, DType::F32, georef, "<orometric>"),
            cell,
            segs,
            bucket,
            nbx,
            nby,
            start: counts,
            ids,
            zmax_all,
            s_min: if s_min.is_finite() { s_min } else { opts.slope },
            crest,
            floor,
            noise,
        })
    }

    /// Number of refined ridge segments.
    pub fn n_segments(&self) -> usize {
        self.segs.len()
    }

    /// The window (x0, y0, w, h) in cells, row-major.
    pub fn fill_window(&self, x0: usize, y0: usize, w: usize, h: usize) -> Vec<f32> {
        let mut out = vec![0f32; w * h];
        let mut stamp = vec![u32::MAX; self.segs.len()];
        let mut cands: Vec<(f64, u32)> = Vec::new();
        let mut tick = 0u32;
        let c = self.cell;
        for by in (0..h).step_by(BLK) {
            for bx in (0..w).step_by(BLK) {
                let (bw, bh) = (BLK.min(w - bx), BLK.min(h - by));
                let (cx0, cy0) = (x0 + bx, y0 + by);
                // Block rectangle of cell centres, metres.
                let rx0 = (cx0 as f64 + 0.5) * c;
                let ry0 = (cy0 as f64 + 0.5) * c;
                let rx1 = rx0 + (bw - 1) as f64 * c;
                let ry1 = ry0 + (bh - 1) as f64 * c;
                let (mx, my) = (0.5 * (rx0 + rx1), 0.5 * (ry0 + ry1));
                let hd = 0.5 * (rx1 - rx0).hypot(ry1 - ry0);
                let bxi = |v: f64| ((v / self.bucket).floor().max(0.0) as usize).min(self.nbx - 1);
                let byi = |v: f64| ((v / self.bucket).floor().max(0.0) as usize).min(self.nby - 1);
                // Lower bound from the segments of the nearby buckets.
                let mut lb = self.floor;
                for yy in byi(ry0 - self.bucket)..=byi(ry1 + self.bucket) {
                    for xx in bxi(rx0 - self.bucket)..=bxi(rx1 + self.bucket) {
                        let b = yy * self.nbx + xx;
                        for &i in &self.ids[self.start[b] as usize..self.start[b + 1] as usize] {
                            let sg = &self.segs[i as usize];
                            lb = lb.max(sg.eval(mx, my, self.crest) - sg.s * hd);
                        }
                    }
                }
                let reach = (self.zmax_all - lb).max(0.0) / self.s_min + self.crest + hd;
                tick = tick.wrapping_add(1);
                if tick == u32::MAX {
                    stamp.iter_mut().for_each(|s| *s = u32::MAX);
                    tick = 0;
                }
                cands.clear();
                for yy in byi(my - reach)..=byi(my + reach) {
                    for xx in bxi(mx - reach)..=bxi(mx + reach) {
                        let b = yy * self.nbx + xx;
                        for &i in &self.ids[self.start[b] as usize..self.start[b + 1] as usize] {
                            if stamp[i as usize] == tick {
                                continue;
                            }
                            stamp[i as usize] = tick;
                            let sg = &self.segs[i as usize];
                            let ddx = (sg.bbox[0] - rx1).max(rx0 - sg.bbox[2]).max(0.0);
                            let ddy = (sg.bbox[1] - ry1).max(ry0 - sg.bbox[3]).max(0.0);
                            let ub = sg.zmax - sg.s * (ddx.hypot(ddy) - self.crest).max(0.0);
                            if ub > lb {
                                cands.push((ub, i));
                            }
                        }
                    }
                }
                cands.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
                for j in 0..bh {
                    let y = ry0 + j as f64 * c;
                    let row = &mut out[(by + j) * w + bx..(by + j) * w + bx + bw];
                    for (i, o) in row.iter_mut().enumerate() {
                        let x = rx0 + i as f64 * c;
                        let mut best = self.floor;
                        let mut win = u32::MAX;
                        for &(ub, s) in &cands {
                            if ub <= best {
                                break;
                            }
                            let v = self.segs[s as usize].eval(x, y, self.crest);
                            if v > best {
                                best = v;
                                win = s;
                            }
                        }
                        if let Some((fbm, amp)) = &self.noise {
                            // Noise fades in over 4 cells from the crest.
                            let d = if win == u32::MAX {
                                f64::INFINITY
                            } else {
                                self.segs[win as usize].dist(x, y)
                            };
                            let t = ((d - self.crest) / (4.0 * c)).clamp(0.0, 1.0);
                            let wgt = t * t * (3.0 - 2.0 * t);
                            if wgt > 0.0 {
                                let (col, rw) = ((cx0 + i) as f64 + 0.5, (cy0 + j) as f64 + 0.5);
                                best += amp * wgt * fbm.sample(col, rw);
                            }
                        }
                        *o = best as f32;
                    }
                }
            }
        }
        out
    }

    /// The whole terrain in memory (rows computed in parallel).
    pub fn render(&self) -> Grid<f32> {
        let (w, h) = (self.info.width, self.info.height);
        let strips: Vec<Vec<f32>> = (0..h.div_ceil(BLK))
            .into_par_iter()
            .map(|s| {
                let y0 = s * BLK;
                self.fill_window(0, y0, w, BLK.min(h - y0))
            })
            .collect();
        let data: Vec<f32> = strips.into_iter().flatten().collect();
        Grid::from_vec(w, h, data).unwrap_or_else(|_| Grid::new(w, h, 0.0))
    }

    /// Georeference of the terrain (local metric CRS, origin top-left at (0, H·cell)).
    pub fn georef(&self) -> &GeoRef {
        &self.info.georef
    }
}

impl RasterSource for OroTerrain {
    fn info(&self) -> &RasterInfo {
        &self.info
    }
    fn read_native(&self, win: Window) -> Result<AnyGrid> {
        let (x0, y0) = (win.x.max(0) as usize, win.y.max(0) as usize);
        let data = self.fill_window(x0, y0, win.w, win.h);
        Ok(AnyGrid::F32(Grid::from_vec(win.w, win.h, data)?))
    }
}
