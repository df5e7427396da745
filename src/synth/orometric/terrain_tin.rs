//! The paper's terrain model (Argudo et al. 2019, §6): river network dual
//! of the divide tree ([`super::rivers`]), Poisson-disk samples whose
//! elevation interpolates between the ridges and rivers with a valley width
//! growing as A^0.4, a constrained Delaunay TIN keeping the ridge and river
//! segments, rasterised at any resolution, window by window, in memory
//! bounded by the tree (not by the raster).
//!
//! **Skeleton (global, O(tree))**: ridges, rivers (refined to λ, so no
//! constrained segment is longer than [`MAX_SEG`] λ), the border frame, a
//! skeleton TIN of them and the line index of the crest/channel bands.
//!
//! **Samples (a pure function of position)**: one background grid of side
//! r/√2 over the domain (r = λ); each cell draws up to 4 candidates from a
//! hash of (seed, cell, try) and keeps the first one at least r from the
//! samples already accepted and 0.4 λ from ridge and river vertices. Cells
//! are visited in 9 phases by (x mod 3, y mod 3) (the phase-group parallel
//! dart throwing of Wei 2008, "Parallel Poisson disk sampling", SIGGRAPH):
//! cells of one phase are too far apart to conflict, so a cell depends only
//! on cells within 2 × 8 = 16 cells, and any region is sampled exactly from
//! the region grown by 17 cells. A sample's flank elevation z_l is the
//! barycentric value of the skeleton TIN (it descends from the ridges to
//! the rivers and has no interior extremum). Near a river of drainage area
//! A the flank eases to the river's elevation z_r over the valley
//! half-width w = w₁ · (A / 1 km²)^0.4 (the A^0.4 law of the issue, after
//! the hydraulic-geometry exponents of Leopold & Maddock 1953):
//! z = z_r + (z_l − z_r) · s(d_r / w), s the smoothstep 3u² − 2u³ clamped
//! at 1 (our profile; the paper's curve is not reproduced).
//!
//! **Final TIN, per super-tile**: the model is the constrained Delaunay
//! triangulation of all skeleton vertices and samples, followed by
//! [`REPAIR_ROUNDS`] Jacobi rounds of repair (a sample that is a local
//! extremum goes to the middle of its neighbours' range; a river source
//! that is a maximum is lowered, not below its downstream node; a sample
//! next to a peak stays below it), so the only maxima are the tree's peaks.
//! It is never built whole: the raster is cut into square super-tiles (a
//! grid of its own, independent of the engine's tiles) and each one
//! triangulates the vertices within a margin around it. Exactness is
//! *certified*, not assumed: a local triangle whose circumdisk (clipped to
//! the domain) lies at least one constrained-segment length inside the
//! local rectangle is a triangle of the global triangulation (every vertex
//! and constraint that could see into the disk is local; Delaunay
//! triangulations in general position are unique), a vertex whose incident
//! triangles are all certified has its global neighbours, and a repaired
//! value is exact if the vertices within [`REPAIR_ROUNDS`] hops were. A
//! super-tile whose covering triangles are not all exact is rebuilt with a
//! doubled margin. So every cell equals the cell of a single global TIN,
//! whatever the super-tile size: no seams, and tiles == whole render bit for
//! bit. Triangles are kept in a canonical order (by vertex positions) so
//! even the choice between two triangles sharing an edge is global.
//! Super-tiles are built on demand (one builder each, other threads wait)
//! and cached, least recently used dropped beyond 128 MB, so memory does
//! not grow with the raster: the skeleton is the floor.
//!
//! **Raster**: barycentric interpolation in the TIN ([`super::tin::Tin`]);
//! cells within 0.71 cell of a river segment read at most the river's
//! elevation (a 4-connected channel no 8-path can hop over) and cells
//! within 0.55 cell of a ridge at least the ridge's (an 8-connected
//! crest); the 8 cells around a saddle's cell read at most the saddle
//! (a *pinch*: where a ridge bends at its saddle the crest cells on either
//! side touch diagonally, and the raster's pass would bypass the saddle
//! cell; cells on another ridge's crest and tree peaks are left alone).
//! Then, block by block of a fixed 512-cell grid with a 32-cell halo, a
//! grey-scale reconstruction from the crest and pinch cells cuts every
//! knoll that no path joins to a ridge above its col down to that col
//! ([`TinTerrain::build_block`]): the TIN leaves such knolls between river
//! channels and samples closer than a cell or two apart, and they would be
//! peaks the tree does not have. Last, multifractal noise below the
//! prominence threshold fades in over 4 cells away from ridges and rivers.
//! Every cell is a pure function of its position (and of the fixed block
//! grid, which does not depend on the super-tile size or the window).

use super::reconstruct::reconstruct;
use super::rivers::{cdt, dedup, RiverNetwork, RiverOptions};
use super::terrain::TerrainOptions;
use super::tin::Tin;
use super::tree_synth::SynthTree;
use crate::error::{Error, Result};
use crate::oro::regions::N8;
use crate::raster::{AnyGrid, Crs, DType, GeoRef, Grid, RasterInfo, RasterSource, Window};
use crate::synth::Fbm;
use rayon::prelude::*;
use spade::Triangulation;
use std::collections::HashMap;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, OnceLock};
/// Points in a uniform bucket grid, for nearest-point queries.
struct PointGrid {
    g: f64,
    nx: usize,
    ny: usize,
    start: Vec<u32>,
    ids: Vec<u32>,
    pts: Vec<[f64; 2]>,
}

impl PointGrid {
    fn new(pts: Vec<[f64; 2]>, g: f64, wm: f64, hm: f64) -> PointGrid {
        let nx = ((wm / g).ceil() as usize).max(1);
        let ny = ((hm / g).ceil() as usize).max(1);
        let cell = |p: &[f64; 2]| {
            let cx = ((p[0] / g).floor().max(0.0) as usize).min(nx - 1);
            let cy = ((p[1] / g).floor().max(0.0) as usize).min(ny - 1);
            cy * nx + cx
        };
        let mut start = vec![0u32; nx * ny + 1];
        for p in &pts {
            start[cell(p) + 1] += 1;
        }
        for i in 1..start.len() {
            start[i] += start[i - 1];
        }
        let mut fill = start.clone();
        let mut ids = vec![0u32; pts.len()];
        for (i, p) in pts.iter().enumerate() {
            let c = cell(p);
            ids[fill[c] as usize] = i as u32;
            fill[c] += 1;
        }
        PointGrid {
            g,
            nx,
            ny,
            start,
            ids,
            pts,
        }
    }

    /// Nearest point within `max_r` of (x, y): (index, distance).
    fn nearest(&self, x: f64, y: f64, max_r: f64) -> Option<(usize, f64)> {
        let cx = ((x / self.g).floor().max(0.0) as usize).min(self.nx - 1) as isize;
        let cy = ((y / self.g).floor().max(0.0) as usize).min(self.ny - 1) as isize;
        let mut best: Option<(usize, f64)> = None;
        let kmax = (max_r / self.g).ceil() as isize + 1;
        for k in 0..=kmax {
            for yy in cy - k..=cy + k {
                if yy < 0 || yy >= self.ny as isize {
                    continue;
                }
                let edge_row = yy == cy - k || yy == cy + k;
                let mut xx = cx - k;
                while xx <= cx + k {
                    if xx >= 0 && xx < self.nx as isize {
                        let b = yy as usize * self.nx + xx as usize;
                        for &i in &self.ids[self.start[b] as usize..self.start[b + 1] as usize] {
                            let p = self.pts[i as usize];
                            let d = (p[0] - x).hypot(p[1] - y);
                            if d <= max_r
                                && best
                                    .is_none_or(|(bi, bd)| d < bd || (d == bd && (i as usize) < bi))
                            {
                                best = Some((i as usize, d));
                            }
                        }
                    }
                    xx += if edge_row || k == 0 { 1 } else { 2 * k };
                }
            }
            if let Some((_, bd)) = best {
                if bd <= k as f64 * self.g {
                    break;
                }
            }
        }
        best
    }

    /// Whether any point lies within `r` of (x, y).
    fn any_within(&self, x: f64, y: f64, r: f64) -> bool {
        let k = (r / self.g).ceil() as isize;
        let cx = ((x / self.g).floor().max(0.0) as usize).min(self.nx - 1) as isize;
        let cy = ((y / self.g).floor().max(0.0) as usize).min(self.ny - 1) as isize;
        for yy in (cy - k).max(0)..=(cy + k).min(self.ny as isize - 1) {
            for xx in (cx - k).max(0)..=(cx + k).min(self.nx as isize - 1) {
                let b = yy as usize * self.nx + xx as usize;
                for &i in &self.ids[self.start[b] as usize..self.start[b + 1] as usize] {
                    let p = self.pts[i as usize];
                    if (p[0] - x).hypot(p[1] - y) < r {
                        return true;
                    }
                }
            }
        }
        false
    }

    /// Indices of the points in [x0, x1) x [y0, y1), ascending.
    fn in_rect(&self, x0: f64, y0: f64, x1: f64, y1: f64) -> Vec<u32> {
        let b = |v: f64, n: usize| ((v / self.g).floor().max(0.0) as usize).min(n - 1);
        let mut out = Vec::new();
        for by in b(y0, self.ny)..=b(y1, self.ny) {
            for bx in b(x0, self.nx)..=b(x1, self.nx) {
                let k = by * self.nx + bx;
                for &i in &self.ids[self.start[k] as usize..self.start[k + 1] as usize] {
                    let p = self.pts[i as usize];
                    if p[0] >= x0 && p[0] < x1 && p[1] >= y0 && p[1] < y1 {
                        out.push(i);
                    }
                }
            }
        }
        out.sort_unstable();
        out
    }
}

/// A ridge or river segment for the crest / channel bands, the noise fade
/// and the samples' clearance.
#[derive(Debug, Clone, Copy)]
struct Line {
    a: [f64; 3],
    b: [f64; 3],
    kind: LineKind,
    /// The tree saddle of a ridge segment's ridge (u32::MAX otherwise).
    saddle: u32,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum LineKind {
    /// Crest band (cells read at least the ridge).
    Ridge,
    /// Channel band (cells read at most the river).
    Channel,
}

impl Line {
    /// (distance, elevation at the projection) of (x, y).
    #[inline]
    fn probe(&self, x: f64, y: f64) -> (f64, f64) {
        let (dx, dy) = (self.b[0] - self.a[0], self.b[1] - self.a[1]);
        let l2 = dx * dx + dy * dy;
        let t = if l2 > 0.0 {
            (((x - self.a[0]) * dx + (y - self.a[1]) * dy) / l2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let (px, py) = (self.a[0] + t * dx, self.a[1] + t * dy);
        (
            (x - px).hypot(y - py),
            self.a[2] + t * (self.b[2] - self.a[2]),
        )
    }
}

/// Half-width of the channel band, cells: cells whose centres lie within
/// (|cos θ| + |sin θ|)/2 ≤ √2/2 cell of a line form a 4-connected chain,
/// which no 8-connected path can cross without touching (a 0.55-cell band
/// is only 8-connected: a diagonal step could hop over the river and make
/// a pass higher than the tree's saddle).
const CHANNEL_BAND: f64 = 0.71;

/// Whether segments p–q and a–b cross or touch.
fn crosses(p: [f64; 2], q: [f64; 2], a: [f64; 2], b: [f64; 2]) -> bool {
    let side = |u: [f64; 2], v: [f64; 2], w: [f64; 2]| {
        ((v[0] - u[0]) * (w[1] - u[1]) - (v[1] - u[1]) * (w[0] - u[0])).signum()
    };
    side(p, q, a) * side(p, q, b) <= 0.0 && side(a, b, p) * side(a, b, q) <= 0.0
}

/// Side of the reconstruction blocks, cells: a fixed grid (part of the
/// model, unlike the super-tiles, so the terrain does not depend on the
/// super-tile size; see [`TinTerrain::build_block`]).
const BLOCK_SIDE: usize = 512;

/// Cells around a tree peak (Chebyshev) where the noise cannot lift a cell
/// to within half the threshold of the summit. 16 let the noise make a
/// higher point 17 cells along a gentle Dallas ridge (600² round trip, seed
/// 10; docs/design/orometric-synthesis.md#ridge-clearance-clearancers).
const PEAK_CALM: usize = 24;

/// Halo of the reconstruction blocks, cells.
const BLOCK_HALO: usize = 32;

/// Bucket side of the raster indices, cells.
const BUCKET_CELLS: f64 = 8.0;

/// Longest constrained segment (ridge, river, frame), in λ: ridge pieces are
/// at most λ long with ±0.25 λ of jitter at each end (√(1 + 0.5²) ≈ 1.118),
/// river pieces and frame steps at most λ.
pub const MAX_SEG: f64 = 1.2;

/// Jacobi rounds of the TIN repair (each reads only the previous round, so
/// a value depends on the vertices within this many edges).
pub const REPAIR_ROUNDS: usize = 6;

/// Default super-tile side, in λ (rounded up to whole buckets of cells).
pub const SUPERTILE_LAMBDA: f64 = 64.0;

/// First margin around a super-tile, in λ (doubled until certified).
pub const MARGIN_LAMBDA: f64 = 16.0;

/// Bytes of super-tiles kept in the cache (least recently used dropped).
const CACHE_BYTES: usize = 128 << 20;

/// Background cells around a region sampled with it: 8 earlier phases, each
/// reaching 2 cells, plus one.
const SAMPLE_PAD: i64 = 17;

/// Items at cells (`pos`), listed per bucket (side `b` cells, `lnx` x `lny`
/// buckets) for every bucket within Chebyshev distance `radius` of their
/// cell: (start per bucket, items).
fn bucket_cells<T: Copy>(
    items: &[T],
    pos: impl Fn(&T) -> (u32, u32),
    radius: u32,
    b: usize,
    lnx: usize,
    lny: usize,
) -> (Vec<u32>, Vec<T>) {
    let span = |v: u32, n: usize| {
        let lo = (v.saturating_sub(radius) as usize / b).min(n - 1);
        (lo, ((v + radius) as usize / b).min(n - 1))
    };
    let mut start = vec![0u32; lnx * lny + 1];
    for it in items {
        let (c, r) = pos(it);
        let ((x0, x1), (y0, y1)) = (span(c, lnx), span(r, lny));
        for by in y0..=y1 {
            for bx in x0..=x1 {
                start[by * lnx + bx + 1] += 1;
            }
        }
    }
    for i in 1..start.len() {
        start[i] += start[i - 1];
    }
    let mut fill = start.clone();
    let mut out = Vec::with_capacity(start[lnx * lny] as usize);
    // Placed by bucket: fill positions in a second pass.
    let mut slots: Vec<Option<T>> = vec![None; start[lnx * lny] as usize];
    for it in items {
        let (c, r) = pos(it);
        let ((x0, x1), (y0, y1)) = (span(c, lnx), span(r, lny));
        for by in y0..=y1 {
            for bx in x0..=x1 {
                let k = by * lnx + bx;
                slots[fill[k] as usize] = Some(*it);
                fill[k] += 1;
            }
        }
    }
    out.extend(slots.into_iter().flatten());
    (start, out)
}

/// Grey-scale reconstruction on the skeleton triangulation (Vincent 1993,
/// on a graph): every river or frame vertex becomes min(its elevation, the
/// highest level at which a path of triangle edges joins it to a ridge
/// vertex), by a priority flood from the ridge vertices (`kind` 0 or 1),
/// highest first. Rivers far from the ridges can otherwise stand as hills
/// of the skeleton (a stretch of river above every river around it), too
/// wide for the per-block reconstruction of the raster. A river stays
/// non-increasing downstream: a node joined to the ridges at level L passes
/// at least min(z, L) to its downstream node, which was at most z.
fn reconstruct_skeleton(sk: &mut [[f64; 3]], kind: &[u8], tris: &[[u32; 3]]) {
    let n = sk.len();
    let mut start = vec![0u32; n + 1];
    for t in tris {
        for &v in t {
            start[v as usize + 1] += 2;
        }
    }
    for i in 1..=n {
        start[i] += start[i - 1];
    }
    let mut fill = start.clone();
    let mut adj = vec![0u32; start[n] as usize];
    for t in tris {
        for k in 0..3 {
            let (a, b, c) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
            for u in [b, c] {
                adj[fill[a as usize] as usize] = u;
                fill[a as usize] += 1;
            }
        }
    }
    drop(fill);
    let val: Vec<f64> = sk.iter().map(|p| p[2]).collect();
    let marker: Vec<bool> = kind.iter().map(|&k| k <= 1).collect();
    let level = reconstruct(&val, &marker, |v, buf| {
        buf.extend(
            adj[start[v] as usize..start[v + 1] as usize]
                .iter()
                .map(|&u| u as usize),
        )
    });
    for (p, l) in sk.iter_mut().zip(level) {
        p[2] = l;
    }
}

/// SplitMix64 finaliser (Steele, Lea & Flood 2014, "Fast splittable
/// pseudorandom number generators", OOPSLA): a hash of a 64-bit word.
#[inline]
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

#[inline]
fn unit(h: u64) -> f64 {
    (h >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// The final TIN of one super-tile: the global triangles touching it.
struct Super {
    tin: Tin,
    n_samples: usize,
    bytes: usize,
}

/// The finished cells of one super-tile (see [`TinTerrain::build_block`]).
struct Block {
    cells: Vec<f32>,
}

/// Something kept in a [`Cache`], with its heap size.
trait Cached {
    fn bytes(&self) -> usize;
}

impl Cached for Super {
    fn bytes(&self) -> usize {
        self.bytes
    }
}

impl Cached for Block {
    fn bytes(&self) -> usize {
        self.cells.len() * 4 + std::mem::size_of::<Block>()
    }
}

type Slot<T> = Arc<OnceLock<std::result::Result<Arc<T>, String>>>;

/// LRU cache of super-tiles or blocks: (key, last use, slot).
struct Cache<T> {
    tick: u64,
    slots: Vec<(u64, u64, Slot<T>)>,
}

impl<T: Cached> Cache<T> {
    fn new() -> Mutex<Cache<T>> {
        Mutex::new(Cache {
            tick: 0,
            slots: Vec::new(),
        })
    }
}

/// The value cached under `key` in `cache`, built by `build` if absent
/// (one builder per key, other threads wait); least recently used entries
/// are dropped beyond [`CACHE_BYTES`] (an entry in use elsewhere lives on
/// through its Arc).
fn cached<T: Cached>(
    cache: &Mutex<Cache<T>>,
    key: u64,
    build: impl FnOnce() -> Result<T>,
) -> Result<Arc<T>> {
    let slot = {
        let mut c = cache.lock().unwrap_or_else(|e| e.into_inner());
        c.tick += 1;
        let tick = c.tick;
        if let Some(s) = c.slots.iter_mut().find(|s| s.0 == key) {
            s.1 = tick;
            s.2.clone()
        } else {
            let s: Slot<T> = Arc::new(OnceLock::new());
            c.slots.push((key, tick, s.clone()));
            let min_keep = 8 + 4 * rayon::current_num_threads();
            loop {
                let bytes: usize = c
                    .slots
                    .iter()
                    .filter_map(|s| match s.2.get() {
                        Some(Ok(t)) => Some(t.bytes()),
                        _ => None,
                    })
                    .sum();
                if bytes <= CACHE_BYTES || c.slots.len() <= min_keep {
                    break;
                }
                let Some(old) = c
                    .slots
                    .iter()
                    .enumerate()
                    .filter(|(_, s)| s.0 != key)
                    .min_by_key(|(_, s)| s.1)
                    .map(|(i, _)| i)
                else {
                    break;
                };
                c.slots.swap_remove(old);
            }
            s
        }
    };
    match slot.get_or_init(|| build().map(Arc::new).map_err(|e| e.to_string())) {
        Ok(t) => Ok(t.clone()),
        Err(m) => Err(Error::invalid(m.clone())),
    }
}

/// Counters of the super-tiles built so far.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SuperTileStats {
    /// Side of a super-tile, cells.
    pub side: usize,
    /// Super-tiles built (a super-tile evicted and needed again counts twice).
    pub built: usize,
    /// Builds that needed a larger margin to be certified exact.
    pub retried: usize,
    /// Poisson-disk samples inside the built super-tiles.
    pub samples: usize,
}

/// The paper's terrain model of a divide tree: a [`RasterSource`] (f32).
pub struct TinTerrain {
    info: RasterInfo,
    cell: f64,
    wm: f64,
    hm: f64,
    lambda: f64,
    thr: f64,
    seed: u64,
    floor: f64,
    valley_width: f64,
    rivers: RiverNetwork,
    /// Skeleton vertices (ridges, rivers, frame; deduplicated), x y z.
    sk: Vec<[f64; 3]>,
    /// 0 peak, 1 other ridge vertex, 2 river or frame vertex.
    sk_kind: Vec<u8>,
    /// Elevation of the downstream node of a river source (NaN otherwise).
    sk_down: Vec<f64>,
    sk_edges: Vec<[u32; 2]>,
    sk_adj_start: Vec<u32>,
    sk_adj: Vec<u32>,
    sk_grid: PointGrid,
    avoid: PointGrid,
    skeleton: Tin,
    river_grid: PointGrid,
    lines: Vec<Line>,
    lb: f64,
    lnx: usize,
    lny: usize,
    lstart: Vec<u32>,
    lids: Vec<u32>,
    /// Saddle pinches per bucket of the line index: (col, row, elevation)
    /// of the saddle cells whose 3 x 3 block touches the bucket.
    pstart: Vec<u32>,
    pinch: Vec<(u32, u32, f64, u32)>,
    /// Tree peaks (col, row, elevation) per bucket of the line index, for
    /// the buckets within [`PEAK_CALM`] cells of them (also: the cells a
    /// pinch leaves alone).
    kstart: Vec<u32>,
    calm: Vec<(u32, u32, f64)>,
    band: f64,
    noise: Option<(Fbm, f64)>,
    side: usize,
    nsx: usize,
    cache: Mutex<Cache<Super>>,
    blocks: Mutex<Cache<Block>>,
    built: AtomicUsize,
    retried: AtomicUsize,
    samples: AtomicUsize,
    dropped: usize,
}

impl TinTerrain {
    /// Build the skeleton (rivers, ridges, indices) of `tree`; the final
    /// TIN is built per super-tile on demand (default side 64 λ).
    pub fn new(tree: &SynthTree, opts: &TerrainOptions) -> Result<TinTerrain> {
        TinTerrain::with_supertile(tree, opts, 0)
    }

    /// As [`TinTerrain::new`] with super-tiles of `side_cells` cells
    /// (rounded up to a multiple of 8; 0: the default 64 λ). The terrain
    /// does not depend on it (see the module doc).
    pub fn with_supertile(
        tree: &SynthTree,
        opts: &TerrainOptions,
        side_cells: usize,
    ) -> Result<TinTerrain> {
        tree.validate()?;
        if !(opts.spacing_m.is_finite() && opts.spacing_m > 0.0) {
            return Err(Error::invalid("terrain: the spacing λ must be positive"));
        }
        if !(opts.jitter.is_finite() && (0.0..=0.5).contains(&opts.jitter)) {
            return Err(Error::invalid(
                "terrain: the ridge jitter must be in [0, 0.5]",
            ));
        }
        if !(opts.valley_width.is_finite() && opts.valley_width >= 0.0) {
            return Err(Error::invalid(
                "terrain: the valley width at 1 km² must be ≥ 0 m",
            ));
        }
        let cell = tree.cell;
        let (wm, hm) = (tree.width as f64 * cell, tree.height as f64 * cell);
        let lambda = opts.spacing_m.max(cell);
        let lb = BUCKET_CELLS * cell;
        let (lnx, lny) = (
            ((wm / lb).ceil() as usize).max(1),
            ((hm / lb).ceil() as usize).max(1),
        );
        if lnx.saturating_mul(lny) > 1 << 28 {
            return Err(Error::invalid(format!(
                "terrain: {} x {} cells is too large (at most 2^28 blocks of 8 x 8 cells); render it in parts",
                tree.width, tree.height
            )));
        }
        let thr = tree.min_prominence;
        let min_saddle = tree
            .saddles
            .iter()
            .map(|s| s.elevation)
            .fold(f64::INFINITY, f64::min);
        let floor = match opts.floor {
            Some(f) => f,
            None if min_saddle.is_finite() => (min_saddle - thr).max(0.0),
            None => 0.0,
        };
        let amp = opts.noise_amplitude.unwrap_or(0.3 * thr);
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
        let mut rivers = RiverNetwork::new(
            tree,
            &RiverOptions {
                spacing_m: lambda,
                jitter: opts.jitter,
                floor,
                margin: thr.max(2.0 * amp),
                river_slope: opts.river_slope,
            },
        )?;
        let mut nodes = std::mem::take(&mut rivers.nodes);
        let ridges = &rivers.ridges;
        let np = tree.peaks.len();
        let nn = nodes.len();

        // Skeleton: ridges (peaks first), river nodes, frame; deduplicated.
        let n_ridge = ridges.pts.len();
        let mut all: Vec<[f64; 3]> = ridges.pts.clone();
        all.extend(nodes.iter().map(|n| [n.x, n.y, n.z]));
        let s0 = all.len();
        all.extend_from_slice(&rivers.frame);
        let (mut sk, map) = dedup(&all);
        drop(all);
        let mut first = vec![u32::MAX; sk.len()];
        for (i, &m) in map.iter().enumerate() {
            if first[m as usize] == u32::MAX {
                first[m as usize] = i as u32;
            }
        }
        let mut has_up = vec![false; nn];
        for n in &nodes {
            if let Some(d) = n.down {
                has_up[d as usize] = true;
            }
        }
        let mut sk_kind = vec![2u8; sk.len()];
        // River sources: (skeleton vertex, downstream node).
        let mut sources: Vec<(usize, usize)> = Vec::new();
        for (v, &f) in first.iter().enumerate() {
            let f = f as usize;
            sk_kind[v] = if f < np {
                0
            } else if f < n_ridge {
                1
            } else {
                2
            };
            if (n_ridge..s0).contains(&f) {
                let i = f - n_ridge;
                if let (false, Some(d)) = (has_up[i], nodes[i].down) {
                    sources.push((v, d as usize));
                }
            }
        }
        drop(first);
        let mut sk_edges: Vec<[u32; 2]> = ridges
            .segs
            .iter()
            .zip(&rivers.ridge_constrained)
            .filter(|(_, &c)| c)
            .map(|(s, _)| [map[s[0] as usize], map[s[1] as usize]])
            .collect();
        for (i, n) in nodes.iter().enumerate() {
            if let Some(d) = n.down {
                sk_edges.push([map[n_ridge + i], map[n_ridge + d as usize]]);
            }
        }
        sk_edges.retain(|e| e[0] != e[1]);
        let node_sk: Vec<u32> = map[n_ridge..s0].to_vec();
        drop(map);
        let mut sk_adj_start = vec![0u32; sk.len() + 1];
        for e in &sk_edges {
            sk_adj_start[e[0] as usize + 1] += 1;
            sk_adj_start[e[1] as usize + 1] += 1;
        }
        for i in 1..sk_adj_start.len() {
            sk_adj_start[i] += sk_adj_start[i - 1];
        }
        let mut fill = sk_adj_start.clone();
        let mut sk_adj = vec![0u32; 2 * sk_edges.len()];
        for (k, e) in sk_edges.iter().enumerate() {
            for &v in e {
                sk_adj[fill[v as usize] as usize] = k as u32;
                fill[v as usize] += 1;
            }
        }
        drop(fill);

        // Skeleton TIN of ridges, rivers and frame: its barycentric value is
        // the flank between them (no interior extremum by construction).
        let (skeleton, dropped) = {
            let (t, dropped) = cdt(&sk, &sk_edges)?;
            let tris: Vec<[u32; 3]> = t
                .inner_faces()
                .map(|f| f.vertices().map(|v| v.fix().index() as u32))
                .collect();
            drop(t);
            reconstruct_skeleton(&mut sk, &sk_kind, &tris);
            for (n, &v) in nodes.iter_mut().zip(&node_sk) {
                n.z = sk[v as usize][2];
            }
            let tin = Tin::new(
                sk.iter().map(|p| [p[0], p[1]]).collect(),
                sk.iter().map(|p| p[2]).collect(),
                tris,
                [0.0, 0.0, wm, hm],
                4.0 * lambda,
            )?;
            (tin, dropped)
        };
        let mut sk_down = vec![f64::NAN; sk.len()];
        for &(v, d) in &sources {
            sk_down[v] = nodes[d].z;
        }
        drop(sources);
        let sk_grid = PointGrid::new(
            sk.iter().map(|p| [p[0], p[1]]).collect(),
            2.0 * lambda,
            wm,
            hm,
        );
        let avoid = PointGrid::new(
            ridges
                .pts
                .iter()
                .map(|p| [p[0], p[1]])
                .chain(nodes.iter().map(|n| [n.x, n.y]))
                .collect(),
            2.0 * lambda,
            wm,
            hm,
        );
        let river_grid = PointGrid::new(
            nodes.iter().map(|n| [n.x, n.y]).collect(),
            4.0 * lambda,
            wm,
            hm,
        );

        // Ridge and river lines, bucketed with the fade reach.
        let mut lines: Vec<Line> = ridges
            .segs
            .iter()
            .zip(&ridges.seg_saddle)
            .map(|(s, &k)| Line {
                a: ridges.pts[s[0] as usize],
                b: ridges.pts[s[1] as usize],
                kind: LineKind::Ridge,
                saddle: k,
            })
            .collect();
        for n in &nodes {
            if let Some(d) = n.down {
                let m = &nodes[d as usize];
                lines.push(Line {
                    a: [n.x, n.y, n.z],
                    b: [m.x, m.y, m.z],
                    kind: LineKind::Channel,
                    saddle: u32::MAX,
                });
            }
        }
        let band = 0.55 * cell;
        let reach = CHANNEL_BAND.max(0.55) * cell + 4.0 * cell;
        let bi = |v: f64, n: usize| ((v / lb).floor().max(0.0) as usize).min(n - 1);
        let span = |l: &Line| {
            (
                bi(l.a[0].min(l.b[0]) - reach, lnx),
                bi(l.a[1].min(l.b[1]) - reach, lny),
                bi(l.a[0].max(l.b[0]) + reach, lnx),
                bi(l.a[1].max(l.b[1]) + reach, lny),
            )
        };
        let mut lstart = vec![0u32; lnx * lny + 1];
        let mut total = 0usize;
        for l in &lines {
            let (x0, y0, x1, y1) = span(l);
            total += (x1 - x0 + 1) * (y1 - y0 + 1);
            for by in y0..=y1 {
                for bx in x0..=x1 {
                    lstart[by * lnx + bx + 1] += 1;
                }
            }
        }
        if total > u32::MAX as usize {
            return Err(Error::invalid(
                "terrain: the line index would be too large; give a larger --spacing",
            ));
        }
        for i in 1..lstart.len() {
            lstart[i] += lstart[i - 1];
        }
        let mut fill = lstart.clone();
        let mut lids = vec![0u32; total];
        for (i, l) in lines.iter().enumerate() {
            let (x0, y0, x1, y1) = span(l);
            for by in y0..=y1 {
                for bx in x0..=x1 {
                    let b = by * lnx + bx;
                    lids[fill[b] as usize] = i as u32;
                    fill[b] += 1;
                }
            }
        }
        drop(fill);
        let noise = (amp > 0.0).then(|| {
            (
                Fbm {
                    seed: tree.seed ^ 0x006e_6f69_7365,
                    octaves: 5,
                    lacunarity: 2.0,
                    gain: 0.5,
                    wavelength: opts.noise_wavelength.max(2.0),
                    base: 0.0,
                    amplitude: 1.0,
                    warp: 0.0,
                },
                amp,
            )
        });
        let b = BUCKET_CELLS as usize;
        let side = if side_cells > 0 {
            side_cells
        } else {
            (SUPERTILE_LAMBDA * lambda / cell).ceil() as usize
        };
        let side = side.div_ceil(b).max(1) * b;
        let nsx = tree.width.div_ceil(side);
        let georef = GeoRef::north_up(0.0, hm, cell, Crs::default());
        let dropped = dropped + rivers.dropped_ridges;
        // Saddle pinches: the crest band keeps a ridge 8-connected, so
        // where it bends at a saddle the two crest cells beside the saddle
        // cell can touch diagonally and bypass it (a pass above the tree's
        // saddle). The cells around a saddle cell read at most the saddle.
        let cell_of = |x: f64, y: f64| {
            (
                ((x / cell).floor().clamp(0.0, (tree.width - 1) as f64)) as u32,
                ((y / cell).floor().clamp(0.0, (tree.height - 1) as f64)) as u32,
            )
        };
        let saddle_cells: Vec<(u32, u32, f64, u32)> = tree
            .saddles
            .iter()
            .enumerate()
            .map(|(k, s)| {
                let (c, r) = cell_of(s.x, s.y);
                (c, r, s.elevation, k as u32)
            })
            .collect();
        let (pstart, pinch) = bucket_cells(&saddle_cells, |p| (p.0, p.1), 1, b, lnx, lny);
        let peak_list: Vec<(u32, u32, f64)> = tree
            .peaks
            .iter()
            .map(|p| {
                let (c, r) = cell_of(p.x, p.y);
                (c, r, p.elevation)
            })
            .collect();
        let (kstart, calm) =
            bucket_cells(&peak_list, |p| (p.0, p.1), PEAK_CALM as u32, b, lnx, lny);
        rivers.nodes = nodes;
        Ok(TinTerrain {
            info: RasterInfo {
                width: tree.width,
                height: tree.height,
                dtype: DType::F32,
                georef,
                block: (256, 256),
                path: "<orometric-tin>".into(),
            },
            cell,
            wm,
            hm,
            lambda,
            thr,
            seed: tree.seed,
            floor,
            valley_width: opts.valley_width,
            rivers,
            sk,
            sk_kind,
            sk_down,
            sk_edges,
            sk_adj_start,
            sk_adj,
            sk_grid,
            avoid,
            skeleton,
            river_grid,
            lines,
            lb,
            lnx,
            lny,
            lstart,
            lids,
            pstart,
            pinch,
            kstart,
            calm,
            band,
            noise,
            side,
            nsx,
            cache: Cache::new(),
            blocks: Cache::new(),
            built: AtomicUsize::new(0),
            retried: AtomicUsize::new(0),
            samples: AtomicUsize::new(0),
            dropped,
        })
    }

    /// The river network (vector) the terrain was built on.
    pub fn rivers(&self) -> &RiverNetwork {
        &self.rivers
    }

    /// Counters of the super-tiles built so far.
    pub fn supertile_stats(&self) -> SuperTileStats {
        SuperTileStats {
            side: self.side,
            built: self.built.load(Ordering::Relaxed),
            retried: self.retried.load(Ordering::Relaxed),
            samples: self.samples.load(Ordering::Relaxed),
        }
    }

    /// Number of skeleton vertices (ridges, rivers, frame): the part of the
    /// model held for the whole raster.
    pub fn skeleton_vertices(&self) -> usize {
        self.sk.len()
    }

    /// Ridge or river segments the triangulations could not keep (crossings).
    pub fn dropped_constraints(&self) -> usize {
        self.dropped
    }

    /// Poisson-disk samples in [x0, x1) x [y0, y1) (metres), exactly those
    /// of the whole domain there (see the module doc).
    fn samples_in(&self, r: [f64; 4]) -> Vec<[f64; 2]> {
        let lam = self.lambda;
        let gs = lam / std::f64::consts::SQRT_2;
        let gw = ((self.wm / gs).ceil() as i64).max(1);
        let gh = ((self.hm / gs).ceil() as i64).max(1);
        let gx0 = ((r[0] / gs).floor() as i64 - SAMPLE_PAD).max(0);
        let gy0 = ((r[1] / gs).floor() as i64 - SAMPLE_PAD).max(0);
        let gx1 = ((r[2] / gs).ceil() as i64 + SAMPLE_PAD).min(gw);
        let gy1 = ((r[3] / gs).ceil() as i64 + SAMPLE_PAD).min(gh);
        if gx1 <= gx0 || gy1 <= gy0 {
            return Vec::new();
        }
        let (lw, lh) = ((gx1 - gx0) as usize, (gy1 - gy0) as usize);
        let mut slot = vec![u32::MAX; lw * lh];
        let mut acc: Vec<[f64; 2]> = Vec::new();
        let h0 = mix(self.seed ^ 0x706f_6973_736f_6e00);
        // Away from ridge and river segments too (no sliver triangle along
        // a constraint, whose circumdisk would be huge).
        let seg_avoid = (0.25 * lam).min(4.0 * self.cell);
        for phase in 0..9i64 {
            let (px, py) = (phase % 3, phase / 3);
            let mut gy = gy0 + (py - gy0).rem_euclid(3);
            while gy < gy1 {
                let mut gx = gx0 + (px - gx0).rem_euclid(3);
                while gx < gx1 {
                    let (lx, ly) = ((gx - gx0) as usize, (gy - gy0) as usize);
                    let hc = mix(mix(h0 ^ gx as u64) ^ gy as u64);
                    for t in 0..4u64 {
                        let h = mix(hc ^ t);
                        let x = (gx as f64 + unit(h)) * gs;
                        let y = (gy as f64 + unit(mix(h))) * gs;
                        if x <= 0.0 || y <= 0.0 || x >= self.wm || y >= self.hm {
                            continue;
                        }
                        let mut ok = true;
                        'n: for yy in ly.saturating_sub(2)..(ly + 3).min(lh) {
                            for xx in lx.saturating_sub(2)..(lx + 3).min(lw) {
                                let j = slot[yy * lw + xx];
                                if j != u32::MAX {
                                    let q = acc[j as usize];
                                    if (q[0] - x).hypot(q[1] - y) < lam {
                                        ok = false;
                                        break 'n;
                                    }
                                }
                            }
                        }
                        if ok
                            && !self.avoid.any_within(x, y, 0.4 * lam)
                            && !self.near_line(x, y, seg_avoid)
                        {
                            slot[ly * lw + lx] = acc.len() as u32;
                            acc.push([x, y]);
                            break;
                        }
                    }
                    gx += 3;
                }
                gy += 3;
            }
        }
        acc.retain(|p| p[0] >= r[0] && p[0] < r[2] && p[1] >= r[1] && p[1] < r[3]);
        acc.sort_by(|a, b| a[1].total_cmp(&b[1]).then(a[0].total_cmp(&b[0])));
        acc
    }

    /// Whether a ridge or river segment passes within `d` (≤ 4.7 cells) of (x, y).
    fn near_line(&self, x: f64, y: f64, d: f64) -> bool {
        let bx = ((x / self.lb) as usize).min(self.lnx - 1);
        let by = ((y / self.lb) as usize).min(self.lny - 1);
        let b = by * self.lnx + bx;
        self.lids[self.lstart[b] as usize..self.lstart[b + 1] as usize]
            .iter()
            .any(|&i| self.lines[i as usize].probe(x, y).0 < d)
    }

    /// Elevation of a sample: the skeleton flank, eased to the nearest
    /// river within its valley half-width.
    fn sample_z(&self, s: [f64; 2]) -> f64 {
        let zl = self.skeleton.value(s[0], s[1]);
        let zl = if zl.is_finite() { zl } else { self.floor };
        let Some((i, dr)) = self.river_grid.nearest(s[0], s[1], 50.0 * self.lambda) else {
            return zl;
        };
        let n = &self.rivers.nodes[i];
        let w = self.valley_width * (n.area_m2.max(0.0) / 1e6).powf(0.4);
        let u = if w > 0.0 { (dr / w).min(1.0) } else { 1.0 };
        let f = u * u * (3.0 - 2.0 * u);
        if zl > n.z {
            n.z + (zl - n.z) * f
        } else {
            zl
        }
    }

    /// The super-tile (sx, sy), from the cache or built.
    fn supertile(&self, sx: usize, sy: usize) -> Result<Arc<Super>> {
        cached(&self.cache, (sy * self.nsx + sx) as u64, || {
            self.build_supertile(sx, sy)
        })
    }

    fn build_supertile(&self, sx: usize, sy: usize) -> Result<Super> {
        let mut margin = MARGIN_LAMBDA * self.lambda;
        for attempt in 0..6 {
            if attempt == 5 {
                // Last resort: the whole domain (always certified).
                margin = self.wm + self.hm;
            }
            if let Some(s) = self.try_supertile(sx, sy, margin)? {
                self.built.fetch_add(1, Ordering::Relaxed);
                if attempt > 0 {
                    self.retried.fetch_add(1, Ordering::Relaxed);
                }
                self.samples.fetch_add(s.n_samples, Ordering::Relaxed);
                return Ok(s);
            }
            margin *= 2.0;
        }
        Err(Error::invalid(format!(
            "terrain: super-tile ({sx}, {sy}) could not be certified exact with a margin of {margin} m (a bug: please report it with the tree)"
        )))
    }

    /// The final TIN of super-tile (sx, sy) from the vertices within
    /// `margin` of it, or None if its triangles cannot be certified global.
    fn try_supertile(&self, sx: usize, sy: usize, margin: f64) -> Result<Option<Super>> {
        let c = self.cell;
        let (c0, r0) = (sx * self.side, sy * self.side);
        let (c1, r1) = (
            (c0 + self.side).min(self.info.width),
            (r0 + self.side).min(self.info.height),
        );
        let core = [c0 as f64 * c, r0 as f64 * c, c1 as f64 * c, r1 as f64 * c];
        let rr = [
            core[0] - margin,
            core[1] - margin,
            core[2] + margin,
            core[3] + margin,
        ];
        // Skeleton vertices and the constraints between them.
        let ids = self.sk_grid.in_rect(rr[0], rr[1], rr[2], rr[3]);
        let mut local: HashMap<u32, u32> = HashMap::with_capacity(ids.len());
        let mut pts: Vec<[f64; 3]> = Vec::with_capacity(2 * ids.len());
        let mut kind: Vec<u8> = Vec::with_capacity(2 * ids.len());
        let mut down: Vec<f64> = Vec::with_capacity(2 * ids.len());
        for (k, &g) in ids.iter().enumerate() {
            local.insert(g, k as u32);
            pts.push(self.sk[g as usize]);
            kind.push(self.sk_kind[g as usize]);
            down.push(self.sk_down[g as usize]);
        }
        let mut eids: Vec<u32> = Vec::new();
        for &g in &ids {
            let g = g as usize;
            for &e in &self.sk_adj[self.sk_adj_start[g] as usize..self.sk_adj_start[g + 1] as usize]
            {
                let [a, b] = self.sk_edges[e as usize];
                if local.contains_key(&a) && local.contains_key(&b) {
                    eids.push(e);
                }
            }
        }
        eids.sort_unstable();
        eids.dedup();
        let edges: Vec<[u32; 2]> = eids
            .iter()
            .map(|&e| {
                let [a, b] = self.sk_edges[e as usize];
                [local[&a], local[&b]]
            })
            .collect();
        drop(local);
        let samples = self.samples_in(rr);
        let n_samples = samples
            .iter()
            .filter(|p| p[0] >= core[0] && p[0] < core[2] && p[1] >= core[1] && p[1] < core[3])
            .count();
        for s in &samples {
            pts.push([s[0], s[1], self.sample_z(*s)]);
            kind.push(3);
            down.push(f64::NAN);
        }
        drop(samples);
        let (t, _) = cdt(&pts, &edges)?;
        let nv = pts.len();

        // Certificate of each face: its circumdisk, clipped to the domain,
        // lies at least one constrained-segment length inside `rr` on every
        // side where `rr` does not reach past the domain.
        let lmax = MAX_SEG * self.lambda;
        let (wm, hm) = (self.wm, self.hm);
        let whole = rr[0] <= 0.0 && rr[1] <= 0.0 && rr[2] >= wm && rr[3] >= hm;
        let certified = |p: [[f64; 3]; 3]| -> bool {
            if whole {
                return true;
            }
            let (ax, ay) = (p[0][0], p[0][1]);
            let (bx, by) = (p[1][0] - ax, p[1][1] - ay);
            let (cx, cy) = (p[2][0] - ax, p[2][1] - ay);
            let d = 2.0 * (bx * cy - by * cx);
            if d == 0.0 {
                return false;
            }
            let (b2, c2) = (bx * bx + by * by, cx * cx + cy * cy);
            let ux = (cy * b2 - by * c2) / d;
            let uy = (bx * c2 - cx * b2) / d;
            let rad = ux.hypot(uy) * (1.0 + 1e-9) + 1e-9 * (wm + hm);
            let (ox, oy) = (ax + ux, ay + uy);
            if !(ox.is_finite() && oy.is_finite() && rad.is_finite()) {
                return false;
            }
            // The disk misses the part of the domain outside rr shrunk by
            // lmax (a strip per side that does not reach past the domain).
            let clear = |x0: f64, y0: f64, x1: f64, y1: f64| {
                let dx = (x0 - ox).max(ox - x1).max(0.0);
                let dy = (y0 - oy).max(oy - y1).max(0.0);
                dx.hypot(dy) > rad
            };
            (rr[0] <= 0.0 || clear(0.0, 0.0, rr[0] + lmax, hm))
                && (rr[1] <= 0.0 || clear(0.0, 0.0, wm, rr[1] + lmax))
                && (rr[2] >= wm || clear(rr[2] - lmax, 0.0, wm, hm))
                && (rr[3] >= hm || clear(0.0, rr[3] - lmax, wm, hm))
        };
        let mut face_ok = vec![false; t.num_all_faces()];
        for f in t.inner_faces() {
            let v = f.vertices().map(|v| pts[v.fix().index()]);
            face_ok[f.fix().index()] = certified(v);
        }
        let on_side = |p: [f64; 3], q: [f64; 3]| {
            (p[0] == 0.0 && q[0] == 0.0)
                || (p[0] == wm && q[0] == wm)
                || (p[1] == 0.0 && q[1] == 0.0)
                || (p[1] == hm && q[1] == hm)
        };
        // Vertex adjacency (CSR) and whether a vertex has its global
        // neighbours (every incident face certified, or the domain border).
        let mut nb_start = vec![0u32; nv + 1];
        let mut nb: Vec<u32> = Vec::with_capacity(6 * nv);
        let mut vok = vec![true; nv];
        for v in t.vertices() {
            let i = v.fix().index();
            for e in v.out_edges() {
                let to = e.to().fix().index();
                nb.push(to as u32);
                match e.face().as_inner() {
                    Some(f) => {
                        if !face_ok[f.fix().index()] {
                            vok[i] = false;
                        }
                    }
                    None => {
                        if !on_side(pts[i], pts[to]) {
                            vok[i] = false;
                        }
                    }
                }
            }
            nb_start[i + 1] = nb.len() as u32;
        }
        for i in 0..nv {
            nb_start[i + 1] = nb_start[i + 1].max(nb_start[i]);
        }
        let faces: Vec<([u32; 3], bool)> = t
            .inner_faces()
            .map(|f| {
                (
                    f.vertices().map(|v| v.fix().index() as u32),
                    face_ok[f.fix().index()],
                )
            })
            .collect();
        drop(t);
        drop(face_ok);

        // Repair, Jacobi rounds; `exact` follows which values are global.
        let nbs = |v: usize| &nb[nb_start[v] as usize..nb_start[v + 1] as usize];
        let mut z: Vec<f64> = pts.iter().map(|p| p[2]).collect();
        let mutable: Vec<bool> = (0..nv).map(|v| kind[v] == 3 || !down[v].is_nan()).collect();
        let mut exact = vec![true; nv];
        let drop_below = 0.5 * self.thr.max(1.0);
        for _ in 0..REPAIR_ROUNDS {
            let mut nz = z.clone();
            let mut nex = exact.clone();
            for v in 0..nv {
                if !mutable[v] {
                    continue;
                }
                nex[v] = exact[v] && vok[v] && nbs(v).iter().all(|&u| exact[u as usize]);
                let (mut lo, mut hi, mut peak) = (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY);
                for &u in nbs(v) {
                    let zu = z[u as usize];
                    lo = lo.min(zu);
                    hi = hi.max(zu);
                    if kind[u as usize] == 0 {
                        peak = peak.min(zu);
                    }
                }
                if kind[v] == 3 {
                    if hi > lo && (z[v] >= hi || z[v] <= lo) {
                        nz[v] = 0.5 * (lo + hi);
                    }
                    if nz[v] >= peak {
                        nz[v] = peak - drop_below;
                    }
                } else if hi > lo && z[v] >= hi {
                    // A river source that is a maximum: lowered, its river
                    // kept non-increasing.
                    nz[v] = (0.5 * (lo + hi)).max(down[v]);
                }
            }
            z = nz;
            exact = nex;
        }

        // The triangles touching the core: all must be global and exact.
        let mut keep: Vec<[u32; 3]> = Vec::new();
        for (f, ok) in faces {
            let p = f.map(|v| pts[v as usize]);
            let bx0 = p[0][0].min(p[1][0]).min(p[2][0]);
            let by0 = p[0][1].min(p[1][1]).min(p[2][1]);
            let bx1 = p[0][0].max(p[1][0]).max(p[2][0]);
            let by1 = p[0][1].max(p[1][1]).max(p[2][1]);
            if bx1 < core[0] || bx0 > core[2] || by1 < core[1] || by0 > core[3] {
                continue;
            }
            if !(ok && f.iter().all(|&v| exact[v as usize])) {
                return Ok(None);
            }
            // Canonical rotation: the lexicographically smallest vertex first.
            let lo = (0..3)
                .min_by(|&a, &b| {
                    p[a][0]
                        .total_cmp(&p[b][0])
                        .then(p[a][1].total_cmp(&p[b][1]))
                })
                .unwrap_or(0);
            keep.push([f[lo], f[(lo + 1) % 3], f[(lo + 2) % 3]]);
        }
        let key = |t: &[u32; 3]| t.map(|v| [pts[v as usize][0], pts[v as usize][1]]);
        keep.sort_by(|a, b| {
            let (ka, kb) = (key(a), key(b));
            let mut o = std::cmp::Ordering::Equal;
            for i in 0..3 {
                o = o
                    .then(ka[i][0].total_cmp(&kb[i][0]))
                    .then(ka[i][1].total_cmp(&kb[i][1]));
            }
            o
        });
        // Keep only the vertices used.
        let mut remap = vec![u32::MAX; nv];
        let mut xy: Vec<[f64; 2]> = Vec::new();
        let mut zz: Vec<f64> = Vec::new();
        for t in keep.iter_mut() {
            for v in t.iter_mut() {
                let o = *v as usize;
                if remap[o] == u32::MAX {
                    remap[o] = xy.len() as u32;
                    xy.push([pts[o][0], pts[o][1]]);
                    zz.push(z[o]);
                }
                *v = remap[o];
            }
        }
        let tin = Tin::new(
            xy,
            zz,
            keep,
            [core[0], core[1], core[2] - core[0], core[3] - core[1]],
            BUCKET_CELLS * c,
        )?;
        let bytes = tin.heap_bytes() + std::mem::size_of::<Super>();
        Ok(Some(Super {
            tin,
            n_samples,
            bytes,
        }))
    }

    /// Elevation of the cell centre (col + ½, row + ½) in super-tile `st`.
    #[inline]
    /// (surface, whether the cell is a crest or pinch cell, noise).
    fn cell_value(&self, st: &Super, col: usize, row: usize) -> (f64, bool, f64) {
        let c = self.cell;
        let (x, y) = ((col as f64 + 0.5) * c, (row as f64 + 0.5) * c);
        let mut v = st.tin.value(x, y);
        let bx = ((x / self.lb) as usize).min(self.lnx - 1);
        let by = ((y / self.lb) as usize).min(self.lny - 1);
        let b = by * self.lnx + bx;
        let (mut crest, mut chan, mut dmin) = (f64::NEG_INFINITY, f64::INFINITY, f64::INFINITY);
        let (mut dridge, mut dchan) = (f64::INFINITY, f64::INFINITY);
        for &i in &self.lids[self.lstart[b] as usize..self.lstart[b + 1] as usize] {
            let l = &self.lines[i as usize];
            let (d, zl) = l.probe(x, y);
            dmin = dmin.min(d);
            if l.kind == LineKind::Ridge {
                dridge = dridge.min(d);
                if d <= self.band {
                    crest = crest.max(zl);
                }
            } else {
                dchan = dchan.min(d);
                if d <= CHANNEL_BAND * c {
                    chan = chan.min(zl);
                }
            }
        }
        v = v.min(chan).max(crest);
        // A crest cell among the 8 neighbours needs a ridge within the
        // band of a neighbour's centre, √2 cells away at most.
        if crest == f64::NEG_INFINITY && dchan <= 1.5 * c && dridge <= self.band + 1.5 * c {
            v = v.min(self.across_crest(b, x, y));
        }
        let mut keep = crest.is_finite();
        for &(sc, sr, sz, k) in &self.pinch[self.pstart[b] as usize..self.pstart[b + 1] as usize] {
            let (dc, dr) = (sc.abs_diff(col as u32), sr.abs_diff(row as u32));
            if dc <= 1
                && dr <= 1
                && (dc, dr) != (0, 0)
                && v > sz
                && !self.calm[self.kstart[b] as usize..self.kstart[b + 1] as usize]
                    .iter()
                    .any(|p| (p.0, p.1) == (col as u32, row as u32))
                && !self.on_other_crest(b, x, y, k)
            {
                v = sz;
                keep = true;
            }
        }
        let mut noise = 0.0;
        if let Some((fbm, amp)) = &self.noise {
            let t = ((dmin - self.band) / (4.0 * c)).clamp(0.0, 1.0);
            let wgt = t * t * (3.0 - 2.0 * t);
            if wgt > 0.0 {
                noise = amp * wgt * fbm.sample(col as f64 + 0.5, row as f64 + 0.5);
            }
            // Near a tree peak, noise lifts no cell above half the
            // threshold under the summit: on a broad summit it could
            // otherwise make a higher cell a few cells off the peak.
            if noise > 0.0 {
                let k = &self.calm[self.kstart[b] as usize..self.kstart[b + 1] as usize];
                for &(pc, pr, pz) in k {
                    if pc.abs_diff(col as u32) <= PEAK_CALM as u32
                        && pr.abs_diff(row as u32) <= PEAK_CALM as u32
                    {
                        noise = noise.min((pz - 0.5 * self.thr - v).max(0.0));
                    }
                }
            }
        }
        (v, keep, noise)
    }

    /// The lowest river level across which a crest cell is an 8-neighbour
    /// of the cell at (x, y) (+∞ if none). The channel band blocks every
    /// 8-step across a river by a cell within √2/2 cell of it, unless that
    /// cell is a crest cell: the crest band wins there (a ridge running
    /// beside a river), and a diagonal step from the crest to the flank
    /// across the river would join two hills above the tree's pass (Alps
    /// seed 3, Dallas seed 2 at 600²; docs/design/orometric-synthesis.md#ridge-clearance-clearancers). So the cell on
    /// the far side takes the block: it reads at most the river.
    fn across_crest(&self, b: usize, x: f64, y: f64) -> f64 {
        let c = self.cell;
        let lines = &self.lids[self.lstart[b] as usize..self.lstart[b + 1] as usize];
        let mut level = f64::INFINITY;
        for &i in lines {
            let l = &self.lines[i as usize];
            if l.kind != LineKind::Channel {
                continue;
            }
            let (d, zl) = l.probe(x, y);
            if d > 1.5 * c || zl >= level {
                continue;
            }
            for (dx, dy) in N8 {
                let (nx, ny) = (x + dx as f64 * c, y + dy as f64 * c);
                if !crosses([x, y], [nx, ny], [l.a[0], l.a[1]], [l.b[0], l.b[1]]) {
                    continue;
                }
                let crest = lines.iter().any(|&j| {
                    let r = &self.lines[j as usize];
                    r.kind == LineKind::Ridge && r.probe(nx, ny).0 <= self.band
                });
                if crest {
                    level = zl;
                    break;
                }
            }
        }
        level
    }

    /// Whether (x, y) lies in the crest band of a ridge other than saddle
    /// `k`'s (a pinch must not cut another ridge passing by).
    fn on_other_crest(&self, b: usize, x: f64, y: f64, k: u32) -> bool {
        self.lids[self.lstart[b] as usize..self.lstart[b + 1] as usize]
            .iter()
            .map(|&i| &self.lines[i as usize])
            .any(|l| l.kind == LineKind::Ridge && l.saddle != k && l.probe(x, y).0 <= self.band)
    }

    /// The window (x0, y0, w, h) in cells (inside the raster), row-major.
    pub fn fill_window(&self, x0: usize, y0: usize, w: usize, h: usize) -> Result<Vec<f32>> {
        let mut out = vec![0f32; w * h];
        if w == 0 || h == 0 {
            return Ok(out);
        }
        if x0 + w > self.info.width || y0 + h > self.info.height {
            return Err(Error::invalid("terrain: window outside the raster"));
        }
        let s = BLOCK_SIDE;
        let nbx = self.info.width.div_ceil(s);
        for sy in y0 / s..=(y0 + h - 1) / s {
            for sx in x0 / s..=(x0 + w - 1) / s {
                let bl = cached(&self.blocks, (sy * nbx + sx) as u64, || {
                    self.build_block(sx, sy)
                })?;
                let bw = s.min(self.info.width - sx * s);
                let (ca, cb) = ((sx * s).max(x0), ((sx + 1) * s).min(x0 + w));
                let (ra, rb) = ((sy * s).max(y0), ((sy + 1) * s).min(y0 + h));
                for r in ra..rb {
                    let o = (r - y0) * w;
                    let bo = (r - sy * s) * bw;
                    out[o + ca - x0..o + cb - x0]
                        .copy_from_slice(&bl.cells[bo + ca - sx * s..bo + cb - sx * s]);
                }
            }
        }
        Ok(out)
    }

    /// The finished cells of block (bx, by) of the fixed [`BLOCK_SIDE`]
    /// grid: the cell values of the block grown by [`BLOCK_HALO`] cells,
    /// reconstructed from the crest and pinch cells, then the noise.
    ///
    /// Grey-scale reconstruction by dilation (Vincent 1993, "Morphological
    /// grayscale reconstruction in image analysis", IEEE TIP 2(2)) under the
    /// surface from the marker "crest and pinch cells, and the halo's outer
    /// ring where the raster goes on": each cell becomes min(its value, the
    /// highest level at which an 8-path joins it to a marker), computed by
    /// a priority flood from the markers, highest first (Barnes, Lehman &
    /// Mulla 2014, turned upside down). Knolls the TIN leaves between river
    /// channels, which no path joins to a ridge above their col, are cut to
    /// that col: the raster's peaks are the tree's. Cells joined to a ridge
    /// (or to the ring) at their own height keep it, so only such knolls
    /// change. A knoll that reaches the ring stays (the halo bounds what a
    /// block sees); every cell depends only on its position and the fixed
    /// block grid, so windows equal the whole render.
    fn build_block(&self, bx: usize, by: usize) -> Result<Block> {
        let s = self.side;
        let (w, h) = (self.info.width, self.info.height);
        let (c0, r0) = (bx * BLOCK_SIDE, by * BLOCK_SIDE);
        let (c1, r1) = ((c0 + BLOCK_SIDE).min(w), (r0 + BLOCK_SIDE).min(h));
        let (ex0, ey0) = (c0.saturating_sub(BLOCK_HALO), r0.saturating_sub(BLOCK_HALO));
        let (ex1, ey1) = ((c1 + BLOCK_HALO).min(w), (r1 + BLOCK_HALO).min(h));
        let (ew, eh) = (ex1 - ex0, ey1 - ey0);
        let n = ew * eh;
        let mut val = vec![0f64; n];
        let mut marker = vec![false; n];
        let mut noise = vec![0f64; n];
        for ty in ey0 / s..=(ey1 - 1) / s {
            for tx in ex0 / s..=(ex1 - 1) / s {
                let st = self.supertile(tx, ty)?;
                let (ca, cb) = ((tx * s).max(ex0), ((tx + 1) * s).min(ex1));
                let (ra, rb) = ((ty * s).max(ey0), ((ty + 1) * s).min(ey1));
                for r in ra..rb {
                    let o = (r - ey0) * ew;
                    for col in ca..cb {
                        let (v, k, z) = self.cell_value(&st, col, r);
                        val[o + col - ex0] = v;
                        marker[o + col - ex0] = k;
                        noise[o + col - ex0] = z;
                    }
                }
            }
        }
        // The outer ring, where the raster goes on beyond the halo.
        for r in 0..eh {
            for c in 0..ew {
                let (gc, gr) = (c + ex0, r + ey0);
                if (c == 0 && gc > 0)
                    || (r == 0 && gr > 0)
                    || (c + 1 == ew && gc + 1 < w)
                    || (r + 1 == eh && gr + 1 < h)
                {
                    marker[r * ew + c] = true;
                }
            }
        }
        let level = reconstruct(&val, &marker, |i, buf| {
            let (c, r) = (i % ew, i / ew);
            for rr in r.saturating_sub(1)..(r + 2).min(eh) {
                for cc in c.saturating_sub(1)..(c + 2).min(ew) {
                    if (cc, rr) != (c, r) {
                        buf.push(rr * ew + cc);
                    }
                }
            }
        });
        let bw = c1 - c0;
        let mut cells = vec![0f32; bw * (r1 - r0)];
        for r in r0..r1 {
            for c in c0..c1 {
                let i = (r - ey0) * ew + c - ex0;
                // A cut knoll is flat at its col: noise only roughens it
                // downwards, so it cannot rise above the col (next to a
                // summit, the col can be within the noise of the peak).
                let (v, z) = if level[i] < val[i] {
                    (level[i], noise[i].min(0.0))
                } else {
                    (val[i], noise[i])
                };
                cells[(r - r0) * bw + c - c0] = (v + z) as f32;
            }
        }
        Ok(Block { cells })
    }

    /// The whole terrain in memory (super-tiles computed in parallel).
    pub fn render(&self) -> Result<Grid<f32>> {
        let (w, h, s) = (self.info.width, self.info.height, self.side);
        let tiles: Vec<(usize, usize)> = (0..h.div_ceil(s))
            .flat_map(|sy| (0..w.div_ceil(s)).map(move |sx| (sx, sy)))
            .collect();
        let parts: Vec<Result<(usize, usize, Vec<f32>)>> = tiles
            .par_iter()
            .map(|&(sx, sy)| {
                let (x0, y0) = (sx * s, sy * s);
                let (tw, th) = (s.min(w - x0), s.min(h - y0));
                Ok((x0, y0, self.fill_window(x0, y0, tw, th)?))
            })
            .collect();
        let mut g = Grid::new(w, h, 0f32);
        for p in parts {
            let (x0, y0, data) = p?;
            let tw = s.min(w - x0);
            for (k, row) in data.chunks(tw).enumerate() {
                for (j, &v) in row.iter().enumerate() {
                    g.set(x0 + j, y0 + k, v);
                }
            }
        }
        Ok(g)
    }

    /// Georeference (local metric CRS, origin top-left at (0, H·cell)).
    pub fn georef(&self) -> &GeoRef {
        &self.info.georef
    }
}

impl RasterSource for TinTerrain {
    fn info(&self) -> &RasterInfo {
        &self.info
    }
    fn read_native(&self, win: Window) -> Result<AnyGrid> {
        let (x0, y0) = (win.x.max(0) as usize, win.y.max(0) as usize);
        let data = self.fill_window(x0, y0, win.w, win.h)?;
        Ok(AnyGrid::F32(Grid::from_vec(win.w, win.h, data)?))
    }
}
