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

mod block;
mod cache;
mod index;
mod lines;
mod samples;
mod skeleton;
mod supertile;

use super::rivers::RiverNetwork;
use super::terrain::TerrainOptions;
use super::tin::Tin;
use super::tree_synth::SynthTree;
use crate::error::{Error, Result};
use crate::raster::{AnyGrid, GeoRef, Grid, RasterInfo, RasterSource, Window};
use crate::synth::Fbm;
use cache::cached;
use cache::Block;
use cache::Cache;
use cache::Super;
use index::PointGrid;
use lines::Line;
use rayon::prelude::*;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

/// Half-width of the channel band, cells: cells whose centres lie within
/// (|cos θ| + |sin θ|)/2 ≤ √2/2 cell of a line form a 4-connected chain,
/// which no 8-connected path can cross without touching (a 0.55-cell band
/// is only 8-connected: a diagonal step could hop over the river and make
/// a pass higher than the tree's saddle).
const CHANNEL_BAND: f64 = 0.71;

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
