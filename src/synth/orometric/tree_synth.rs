//! Divide-tree synthesis (Argudo et al. 2019, "Orometry-based terrain
//! analysis and synthesis", ACM TOG 38(6), §5).
//!
//! 1. Peak count from the profile's density (or given); elevations are
//!    stratified samples of the elevation histogram, placed in decreasing
//!    order (user-fixed peaks first, where the user put them).
//! 2. Dart throwing: a candidate for a peak of elevation h is accepted with
//!    probability C_P(p) · n(C_H(p) − h) · p(isolation) · p(direction), with
//!    the user maps C_P (density) and C_H (coarse elevation), n a Gaussian of
//!    σ = 1/20 of C_H's range. Isolation and its direction are matched by
//!    proposing candidates at a target isolation distance (a stratified
//!    sample of the profile's isolation histogram, larger for higher peaks)
//!    in a target direction (stratified from the direction histogram) from a
//!    random higher peak, accepted when no higher peak is much closer; after
//!    a bounded number of failures the best of a few uniform darts is taken.
//! 3. Ridges: the Delaunay triangulation of the peaks (spade) and its
//!    minimum spanning tree (Kruskal) with weights ‖Pi − Pj‖ / min(h_i, h_j)^ρ.
//! 4. One saddle per ridge at a random split point (t ∈ [0.35, 0.65]) moved
//!    sideways by up to 10 % of the ridge length; saddle elevations by
//!    optimal assignment ([`super::assign`]).
//!
//! 5. Multi-pass placement by prominence bins ([`TreeOptions::passes`]):
//!    bins of 1 : 2 : 4 : … parts, the most prominent placed first; before
//!    each later pass the ridges (Delaunay MST) of the peaks placed so far
//!    are rasterised, diffused and multiplied into C_P, so less prominent
//!    peaks gather along the ridges of the prominent ones.
//! 6. Authoring: fixed peaks, ridges kept verbatim between them (a pasted
//!    real fragment, [`super::fragment`]), keep-out rectangles, and a type
//!    map C_T giving each region its own profile ([`super::typemap`]): the
//!    peak count, elevations, isolation and saddle targets of a peak come
//!    from the profile of the region it is placed in.

use super::assign::{
    assign_saddles_grouped, prominences, refine_histograms, GroupTargets, SaddleProblem,
    PROMINENCE_MARGIN,
};
use super::clearance::{clear_ridges, Node};
use super::profile::SynthProfile;
use super::typemap::TypeMap;
use crate::error::{Error, Result};
use crate::oro::stats::SplitMix64;
use crate::raster::{Grid, UnionFind};
use serde::{Deserialize, Serialize};
use spade::{DelaunayTriangulation, HasPosition, Point2, Triangulation};
use std::path::Path;

/// A peak of a synthesised divide tree. Coordinates are metres from the
/// top-left corner of the domain, x east, y south (down the rows).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SynthPeak {
    pub x: f64,
    pub y: f64,
    pub elevation: f64,
    /// Placed by the user (kept by edits and re-synthesis).
    #[serde(default)]
    pub fixed: bool,
}

/// A saddle on the ridge between two peaks.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SynthSaddle {
    pub x: f64,
    pub y: f64,
    pub elevation: f64,
    /// Indices into [`SynthTree::peaks`] of the ridge's two ends.
    pub peaks: [usize; 2],
}

/// A synthesised (or edited) divide tree on a rectangular domain: JSON,
/// editable; [`SynthTree::validate`] checks an edited tree.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SynthTree {
    /// Always "orogen-synthtree".
    pub format: String,
    pub version: u32,
    /// Domain in cells and cell size in metres.
    pub width: usize,
    pub height: usize,
    pub cell: f64,
    /// Seed of the synthesis; terrain generation derives its own from it.
    pub seed: u64,
    /// Prominence threshold of the profile it was made from (m).
    pub min_prominence: f64,
    pub peaks: Vec<SynthPeak>,
    pub saddles: Vec<SynthSaddle>,
}

/// Options of [`synthesize_tree`].
#[derive(Debug, Clone)]
pub struct TreeOptions {
    pub width: usize,
    pub height: usize,
    /// Cell size, metres.
    pub cell: f64,
    pub seed: u64,
    /// Number of peaks; None: profile density × area.
    pub n_peaks: Option<usize>,
    /// MST weight exponent ρ ∈ {0, 1, 2}.
    pub rho: u8,
    /// Density map C_P (any size, stretched over the domain; ≥ 0).
    pub density_map: Option<Grid<f32>>,
    /// Coarse elevation map C_H (any size, stretched over the domain; m).
    pub elevation_map: Option<Grid<f32>>,
    /// Peaks the user placed (kept where they are; `fixed` is set).
    pub fixed_peaks: Vec<SynthPeak>,
    /// Prominence/dominance alternations of the saddle assignment.
    pub iterations: usize,
    /// Without an elevation map, use a coherent random one (see
    /// [`coherent_elevation_map`]); false: elevations are placed anywhere.
    pub coherent: bool,
    /// Isolation proposals are made at this multiple of the target distance
    /// (the terrain's nearest higher ground lies on the higher peak's ridges,
    /// closer than its summit). Default 1.2 ([`DEFAULT_ISOLATION_STRETCH`]),
    /// calibrated on the TIN terrain of the Mont Blanc and Dallas profiles
    /// over six seeds each once the render kept exactly the tree's peaks
    /// (1.1 suits the Alps best, 1.3 Dallas; 1.3 was the default while
    /// knolls of the render stood near many peaks; see
    /// docs/design/orometric-synthesis.md#placement).
    pub isolation_stretch: f64,
    /// Placement passes by prominence bins (§5): the most prominent bin
    /// first, each next bin about twice as many peaks, earlier peaks fixed.
    /// 1: one pass in decreasing elevation.
    pub passes: usize,
    /// Weight in [0, 1] of the diffused ridges of earlier passes in the
    /// acceptance (1 − a + a · ridges): 0 leaves C_P alone.
    pub ridge_attraction: f64,
    /// Ridges kept verbatim between fixed peaks (a pasted real fragment).
    pub fixed_ridges: Vec<FixedRidge>,
    /// Rectangles [x0, y0, x1, y1] (m, the tree's frame) where no free peak
    /// is placed (a pasted fragment's footprint).
    pub keep_out: Vec<[f64; 4]>,
    /// Type map C_T: a profile per region label ([`TypeMap`]).
    pub type_map: Option<TypeMap>,
    /// After the assignment, a local search on the saddle heights that
    /// lowers the prominence and dominance histogram distances directly
    /// ([`super::assign::refine_histograms`]). Default true; false gives the
    /// trees of the assignment alone.
    pub refine: bool,
    /// Least relief contrast C ≥ 1 of the ridge weights: the MST uses
    /// ‖Pi − Pj‖ / (min(h_i, h_j) − b)^ρ with the base b ≥ 0 the smallest
    /// that makes (highest − b) / (lowest − b) ≥ C (b ≤ lowest − threshold).
    /// A departure from Argudo et al. 2019 §5 (which weighs absolute
    /// elevations), default [`DEFAULT_RIDGE_CONTRAST`] = 5: on a low-relief
    /// region (Dallas: peaks 165–298 m, contrast 1.8) min(h)^2 barely tells
    /// high peaks from low ones, so the MST routed high peaks to higher
    /// ground through much lower peaks whose saddles capped their
    /// prominence (tree dominance error 2.4–5.4 %, measured; 0.0–1.2 % with
    /// C = 5). Profiles already that contrasted (Mont Blanc: 876–4810 m,
    /// 5.5) get b = 0 from this rule (but see [`TreeOptions::ridge_base`]).
    /// 1 with `ridge_base` 0: the paper's weights.
    pub ridge_contrast: f64,
    /// Least base of the ridge weights as a fraction β ∈ [0, 1) of the
    /// lowest peak: b = max(b_C, β · lowest) with b_C the base of
    /// [`TreeOptions::ridge_contrast`]. Default [`DEFAULT_RIDGE_BASE`]. On
    /// Mont Blanc (876–4810 m, contrast 5.5, so b_C = 0) the paper's
    /// weights joined high peaks through much lower ones, whose h_max caps
    /// the saddles on the way: the tree kept 4–7 peaks of prominence over
    /// 3000 m where the profile has 1 and too many of 800–1500 m (tree
    /// prominence error 1.6–3.2 %, rendered 2.0–3.5 %, seeds 1–6); with
    /// β = 0.72 (contrast ≈ 17) 1.2–2.3 % and 1.4–2.6 % (docs/design/orometric-synthesis.md#ridges).
    /// On Dallas b_C (contrast 5: 132 m = 0.8 · 165 m) is larger, so its
    /// trees do not change. 0: the contrast alone.
    pub ridge_base: f64,
    /// Width (m) of the band over which the type map's region profiles are
    /// blended at their borders (see [`super::typemap`]). Default
    /// [`DEFAULT_TYPE_BLEND_M`] = 0: sharp borders.
    pub type_blend_m: f64,
}

impl TreeOptions {
    pub fn new(width: usize, height: usize, cell: f64, seed: u64) -> TreeOptions {
        TreeOptions {
            width,
            height,
            cell,
            seed,
            n_peaks: None,
            rho: 2,
            density_map: None,
            elevation_map: None,
            fixed_peaks: Vec::new(),
            iterations: 3,
            coherent: true,
            isolation_stretch: DEFAULT_ISOLATION_STRETCH,
            passes: DEFAULT_PASSES,
            ridge_attraction: DEFAULT_RIDGE_ATTRACTION,
            fixed_ridges: Vec::new(),
            keep_out: Vec::new(),
            type_map: None,
            refine: true,
            ridge_contrast: DEFAULT_RIDGE_CONTRAST,
            ridge_base: DEFAULT_RIDGE_BASE,
            type_blend_m: DEFAULT_TYPE_BLEND_M,
        }
    }
}

/// Default [`TreeOptions::ridge_contrast`] (the Mont Blanc profile's own
/// contrast, rounded down: it keeps the paper's weights there).
pub const DEFAULT_RIDGE_CONTRAST: f64 = 5.0;
/// Default [`TreeOptions::ridge_base`], calibrated on Mont Blanc, seeds
/// 1–6 (see the field). The sweep (docs/design/orometric-synthesis.md#ridges) put every seed
/// within the paper's figures at bases ≈ 0.72 and 0.81 of the lowest peak,
/// but ≈ 0.76 and 0.79 each missed on one seed by 0.1–0.2 points: the
/// margin is of the order of the seed-to-seed noise. Kept below 0.8 so the
/// Dallas trees (contrast base 0.8 · lowest) do not change.
pub const DEFAULT_RIDGE_BASE: f64 = 0.72;
/// Default [`TreeOptions::type_blend_m`]: 0, sharp borders (as before the
/// blend existed; the CLI has no flag for it yet). A band of about 6 km,
/// two to three peak spacings of the shipped profiles (Mont Blanc 0.16,
/// Dallas 0.18 peaks per km²), mixes a few peaks of each side at a border
/// instead of a step; wider bands ramp more slowly.
pub const DEFAULT_TYPE_BLEND_M: f64 = 0.0;
/// Default isolation stretch ([`TreeOptions::isolation_stretch`]).
pub const DEFAULT_ISOLATION_STRETCH: f64 = 1.2;
/// Default number of placement passes (see `docs/design/orometric-synthesis.md#authoring`).
pub const DEFAULT_PASSES: usize = 4;
/// Default ridge attraction of the multi-pass placement.
pub const DEFAULT_RIDGE_ATTRACTION: f64 = 0.8;

/// Largest number of peaks a synthesis accepts (memory and the O(n log n)
/// steps stay small; 4 M peaks ≈ a continent at 0.01 peaks/km²·…).
pub const MAX_PEAKS: usize = 4_000_000;
/// Largest domain side in cells.
pub const MAX_SIDE: usize = 1 << 21;

/// A map stretched over the domain, sampled by nearest cell.
struct DomainMap<'a> {
    g: &'a Grid<f32>,
    sx: f64,
    sy: f64,
}

impl DomainMap<'_> {
    fn at(&self, x: f64, y: f64) -> f64 {
        let c = ((x * self.sx) as usize).min(self.g.width() - 1);
        let r = ((y * self.sy) as usize).min(self.g.height() - 1);
        self.g.get(c, r) as f64
    }
}

/// Uniform grid of placed peaks for nearest-higher queries.
struct PeakGrid {
    cell: f64,
    nx: usize,
    ny: usize,
    buckets: Vec<Vec<u32>>,
}

impl PeakGrid {
    fn new(wm: f64, hm: f64, cell: f64) -> PeakGrid {
        let nx = ((wm / cell).ceil() as usize).max(1);
        let ny = ((hm / cell).ceil() as usize).max(1);
        PeakGrid {
            cell,
            nx,
            ny,
            buckets: vec![Vec::new(); nx * ny],
        }
    }
    fn key(&self, x: f64, y: f64) -> (usize, usize) {
        (
            ((x / self.cell).max(0.0) as usize).min(self.nx - 1),
            ((y / self.cell).max(0.0) as usize).min(self.ny - 1),
        )
    }
    fn insert(&mut self, i: usize, x: f64, y: f64) {
        let (bx, by) = self.key(x, y);
        self.buckets[by * self.nx + bx].push(i as u32);
    }
    /// Distance to the nearest peak with elevation ≥ h, searched up to `max_d`
    /// (returns `max_d` if none is closer).
    fn nearest_higher(&self, peaks: &[SynthPeak], x: f64, y: f64, h: f64, max_d: f64) -> f64 {
        let (bx, by) = self.key(x, y);
        let mut best = max_d;
        let rings = ((max_d / self.cell).ceil() as usize + 1).min(self.nx.max(self.ny));
        for ring in 0..=rings {
            // Every point in ring r is at least (r − 1) · cell away.
            if ring >= 1 && (ring as f64 - 1.0) * self.cell > best {
                break;
            }
            let (x0, x1) = (bx as i64 - ring as i64, bx as i64 + ring as i64);
            let (y0, y1) = (by as i64 - ring as i64, by as i64 + ring as i64);
            for yy in y0..=y1 {
                if yy < 0 || yy >= self.ny as i64 {
                    continue;
                }
                let edge_row = yy == y0 || yy == y1;
                let mut xx = x0;
                while xx <= x1 {
                    if xx >= 0 && xx < self.nx as i64 {
                        for &i in &self.buckets[yy as usize * self.nx + xx as usize] {
                            let p = &peaks[i as usize];
                            if p.elevation >= h {
                                best = best.min((p.x - x).hypot(p.y - y));
                            }
                        }
                    }
                    xx += if edge_row || xx == x1 { 1 } else { x1 - x0 };
                }
            }
        }
        best
    }
}

/// A coherent coarse elevation map C_H for a domain of `w` x `h` cells: seeded
/// low-frequency fBm (about two massifs across), each value replaced by the
/// profile's peak-elevation quantile of its rank, so its histogram is the
/// profile's elevation histogram (a rank transform, as in histogram
/// matching, Gonzalez & Woods, "Digital Image Processing", §3.3).
pub fn coherent_elevation_map(profile: &SynthProfile, w: usize, h: usize, seed: u64) -> Grid<f32> {
    coherent_map_with(w, h, seed, |u, _, _| profile.elevation.quantile(u))
}

/// [`coherent_elevation_map`] with the quantile function chosen per cell:
/// `q(u, fx, fy)` maps the rank fraction u of the fBm value at the domain
/// fraction (fx, fy) to an elevation (the type map C_T uses the profile of
/// the region there).
fn coherent_map_with(w: usize, h: usize, seed: u64, q: impl Fn(f64, f64, f64) -> f64) -> Grid<f32> {
    let side = 128usize;
    let (gw, gh) = if w >= h {
        (side, ((side * h) / w).max(8))
    } else {
        (((side * w) / h).max(8), side)
    };
    let fbm = crate::synth::Fbm {
        seed: seed ^ 0x0063_686d_6170,
        octaves: 4,
        lacunarity: 2.0,
        gain: 0.5,
        wavelength: side as f64 / 2.0,
        base: 0.0,
        amplitude: 1.0,
        warp: 0.0,
    };
    let vals: Vec<f64> = (0..gw * gh)
        .map(|i| fbm.sample((i % gw) as f64 + 0.5, (i / gw) as f64 + 0.5))
        .collect();
    let mut order: Vec<usize> = (0..vals.len()).collect();
    order.sort_by(|&a, &b| vals[a].total_cmp(&vals[b]).then(a.cmp(&b)));
    let mut out = vec![0f32; vals.len()];
    let n = vals.len() as f64;
    for (rank, &i) in order.iter().enumerate() {
        let (fx, fy) = (
            ((i % gw) as f64 + 0.5) / gw as f64,
            ((i / gw) as f64 + 0.5) / gh as f64,
        );
        out[i] = q((rank as f64 + 0.5) / n, fx, fy) as f32;
    }
    Grid::from_vec(gw, gh, out).unwrap_or_else(|_| Grid::new(gw, gh, 0.0))
}

struct Vtx {
    p: Point2<f64>,
    id: usize,
}

impl HasPosition for Vtx {
    type Scalar = f64;
    fn position(&self) -> Point2<f64> {
        self.p
    }
}

/// Ridges: Delaunay triangulation of the peaks, then its minimum spanning
/// tree with weights ‖Pi − Pj‖ / min(h_i, h_j)^ρ (Kruskal; ties by indices).
pub fn ridge_tree(peaks: &[SynthPeak], rho: u8) -> Result<Vec<(usize, usize)>> {
    ridge_tree_with(peaks, rho, &[], &[])
}

/// [`ridge_tree`] keeping the ridges `forced` (they come first in the
/// result, in their order; e.g. a pasted real fragment or the ridges an
/// edit left alone) and never using a pair in `forbidden` (a ridge the user
/// deleted). Errors when the forced ridges close a loop or when the
/// Delaunay edges left cannot connect every peak.
pub fn ridge_tree_with(
    peaks: &[SynthPeak],
    rho: u8,
    forced: &[(usize, usize)],
    forbidden: &[(usize, usize)],
) -> Result<Vec<(usize, usize)>> {
    if peaks.len() < 2 {
        return Ok(Vec::new());
    }
    let verts: Vec<Vtx> = peaks
        .iter()
        .enumerate()
        .map(|(id, p)| Vtx {
            p: Point2::new(p.x, p.y),
            id,
        })
        .collect();
    let tri: DelaunayTriangulation<Vtx> = DelaunayTriangulation::bulk_load(verts).map_err(|e| {
        Error::invalid(format!("Delaunay triangulation of the peaks failed: {e:?}"))
    })?;
    if tri.num_vertices() != peaks.len() {
        return Err(Error::invalid(
            "two peaks share a position; move one (each peak needs its own place)",
        ));
    }
    let mut edges: Vec<(f64, usize, usize)> = tri
        .undirected_edges()
        .map(|e| {
            let [a, b] = e.vertices();
            let (i, j) = (a.data().id.min(b.data().id), a.data().id.max(b.data().id));
            let d = (peaks[i].x - peaks[j].x).hypot(peaks[i].y - peaks[j].y);
            let hmin = peaks[i].elevation.min(peaks[j].elevation).max(1.0);
            (d / hmin.powi(rho as i32), i, j)
        })
        .collect();
    edges.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
    let mut uf = UnionFind::<usize>::new(peaks.len());
    let mut out = Vec::with_capacity(peaks.len() - 1);
    for &(i, j) in forced {
        if i >= peaks.len() || j >= peaks.len() || i == j {
            return Err(Error::invalid(format!(
                "a kept ridge joins peaks {i} and {j}; it needs two different existing peaks"
            )));
        }
        if !uf.join(i, j) {
            return Err(Error::invalid(format!(
                "the kept ridges close a loop at peaks {i} and {j}; a divide tree has none"
            )));
        }
        out.push((i, j));
    }
    let banned = |i: usize, j: usize| {
        forbidden
            .iter()
            .any(|&(a, b)| (a == i && b == j) || (a == j && b == i))
    };
    for (_, i, j) in edges {
        if !forbidden.is_empty() && banned(i, j) {
            continue;
        }
        if uf.join(i, j) {
            out.push((i, j));
        }
    }
    if out.len() + 1 != peaks.len() {
        return Err(Error::invalid(
            "the peaks cannot be joined into one divide tree without a deleted ridge: delete fewer ridges or add a peak between the parts",
        ));
    }
    Ok(out)
}

/// A ridge of a pasted real divide-tree fragment, kept verbatim: its two
/// peaks (indices into [`TreeOptions::fixed_peaks`]) and its saddle.
#[derive(Debug, Clone, PartialEq)]
pub struct FixedRidge {
    pub peaks: [usize; 2],
    pub x: f64,
    pub y: f64,
    pub elevation: f64,
}

/// Pass (0 = the most prominent bin) of the peak of rank `r` among `n` when
/// the bins hold 1 : 2 : 4 : … parts, the least prominent the largest
/// (Argudo et al. 2019, §5: each less prominent bin about twice as many).
pub fn pass_of_rank(r: usize, n: usize, passes: usize) -> usize {
    if passes <= 1 || n == 0 {
        return 0;
    }
    let total = ((1u64 << passes.min(40)) - 1) as f64;
    let mut bound = 0.0;
    for k in 0..passes {
        bound += (1u64 << k.min(40)) as f64;
        if (r as f64) < n as f64 * bound / total {
            return k;
        }
    }
    passes - 1
}

/// Ridges of the placed peaks (their Delaunay MST) rasterised on a coarse
/// grid of `gc`-metre cells and diffused by three box blurs of radius one
/// cell (≈ a Gaussian of σ ≈ 1.4 cells; Wells 1986, "Efficient synthesis of
/// Gaussian filters by cascaded uniform filters", IEEE PAMI 8(2)),
/// normalised to a maximum of 1: the attraction of the ridges of earlier
/// passes added to C_P (Argudo et al. 2019, §5).
fn ridge_density(peaks: &[SynthPeak], rho: u8, wm: f64, hm: f64, gc: f64) -> Result<Grid<f32>> {
    let nx = ((wm / gc).ceil() as usize).clamp(1, 4096);
    let ny = ((hm / gc).ceil() as usize).clamp(1, 4096);
    let (sx, sy) = (nx as f64 / wm, ny as f64 / hm);
    let mut g = vec![0f32; nx * ny];
    for (i, j) in ridge_tree(peaks, rho)? {
        let (a, b) = (&peaks[i], &peaks[j]);
        let len = ((b.x - a.x) * sx).hypot((b.y - a.y) * sy);
        let steps = (2.0 * len).ceil().max(1.0) as usize;
        for s in 0..=steps {
            let t = s as f64 / steps as f64;
            let c = (((a.x + t * (b.x - a.x)) * sx) as usize).min(nx - 1);
            let r = (((a.y + t * (b.y - a.y)) * sy) as usize).min(ny - 1);
            g[r * nx + c] = 1.0;
        }
    }
    let mut tmp = vec![0f32; nx * ny];
    for _ in 0..3 {
        // Horizontal then vertical box of radius 1 (edges clamped).
        for r in 0..ny {
            for c in 0..nx {
                let (l, rr) = (c.saturating_sub(1), (c + 1).min(nx - 1));
                tmp[r * nx + c] = (g[r * nx + l] + g[r * nx + c] + g[r * nx + rr]) / 3.0;
            }
        }
        for r in 0..ny {
            let (u, d) = (r.saturating_sub(1), (r + 1).min(ny - 1));
            for c in 0..nx {
                g[r * nx + c] = (tmp[u * nx + c] + tmp[r * nx + c] + tmp[d * nx + c]) / 3.0;
            }
        }
    }
    let max = g.iter().fold(0f32, |a, &b| a.max(b));
    if max > 0.0 {
        g.iter_mut().for_each(|v| *v /= max);
    }
    Grid::from_vec(nx, ny, g)
}

/// A peak still to place: its targets and region, and its pass.
struct Job {
    elev: f64,
    iso: f64,
    dir: f64,
    region: usize,
    pass: usize,
}

/// Synthesise a divide tree matching `profile` on the domain of `opts`
/// (with a type map C_T, `profile` holds wherever the map's label has no
/// profile of its own).
pub fn synthesize_tree(profile: &SynthProfile, opts: &TreeOptions) -> Result<SynthTree> {
    profile.validate()?;
    let (w, h, cell) = (opts.width, opts.height, opts.cell);
    if w == 0 || h == 0 || w > MAX_SIDE || h > MAX_SIDE {
        return Err(Error::invalid(format!(
            "synthesis domain {w}x{h} cells: each side must be 1..{MAX_SIDE}"
        )));
    }
    if !(cell.is_finite() && cell > 0.0) {
        return Err(Error::invalid(
            "the cell size must be a positive number of metres",
        ));
    }
    if opts.rho > 2 {
        return Err(Error::invalid(
            "rho (the ridge weight exponent) must be 0, 1 or 2",
        ));
    }
    if !(opts.isolation_stretch.is_finite() && opts.isolation_stretch > 0.0) {
        return Err(Error::invalid(
            "isolation_stretch must be a positive number",
        ));
    }
    if !(opts.type_blend_m.is_finite() && opts.type_blend_m >= 0.0) {
        return Err(Error::invalid(
            "type_blend_m (the blend band at type-map borders) must be a number ≥ 0 m",
        ));
    }
    if opts.passes == 0 || opts.passes > 16 {
        return Err(Error::invalid(
            "passes (prominence bins placed one after the other) must be 1..16",
        ));
    }
    if !(0.0..=1.0).contains(&opts.ridge_attraction) {
        return Err(Error::invalid(
            "ridge_attraction must lie in [0, 1] (0: ridges of earlier passes do not attract peaks)",
        ));
    }
    let (wm, hm) = (w as f64 * cell, h as f64 * cell);
    let area_km2 = wm * hm / 1e6;
    // Regions: 0 = `profile`, then the type map's labelled profiles.
    let tm = opts.type_map.as_ref();
    let mut profiles: Vec<&SynthProfile> = vec![profile];
    if let Some(t) = tm {
        profiles.extend(t.regions.iter().map(|r| &r.1));
    }
    let nreg = profiles.len();
    let region_at = |x: f64, y: f64| -> Option<usize> {
        match tm {
            None => Some(0),
            Some(t) => t.region_at(x / wm, y / hm),
        }
    };
    let frac = match tm {
        None => vec![1.0],
        Some(t) => t.fractions(),
    };
    // Peaks wanted per region: density × area (or `n_peaks` shared in
    // proportion to it, largest remainders).
    let mut want: Vec<usize> = (0..nreg)
        .map(|r| (profiles[r].peak_density_per_km2 * area_km2 * frac[r]).round() as usize)
        .collect();
    if let Some(total) = opts.n_peaks {
        if nreg == 1 {
            want[0] = total;
        } else {
            let wts: Vec<f64> = (0..nreg)
                .map(|r| profiles[r].peak_density_per_km2 * frac[r])
                .collect();
            let sw: f64 = wts.iter().sum();
            if sw <= 0.0 {
                return Err(Error::invalid("the type map leaves no region with peaks"));
            }
            let raw: Vec<f64> = wts.iter().map(|v| v / sw * total as f64).collect();
            want = raw.iter().map(|v| v.floor() as usize).collect();
            let mut rest: Vec<usize> = (0..nreg).collect();
            rest.sort_by(|&a, &b| {
                (raw[b] - raw[b].floor())
                    .total_cmp(&(raw[a] - raw[a].floor()))
                    .then(a.cmp(&b))
            });
            let short = total - want.iter().sum::<usize>();
            for &r in rest.iter().take(short) {
                want[r] += 1;
            }
        }
    }
    let n_wanted: usize = want.iter().sum();
    if n_wanted.max(opts.fixed_peaks.len()) > MAX_PEAKS {
        return Err(Error::invalid(format!(
            "{} peaks requested; at most {MAX_PEAKS} per synthesis (use a smaller domain or density)",
            n_wanted.max(opts.fixed_peaks.len())
        )));
    }
    for f in &opts.fixed_peaks {
        if !(f.x.is_finite() && f.y.is_finite() && f.elevation.is_finite()) {
            return Err(Error::invalid(
                "a fixed peak has a non-finite coordinate or elevation",
            ));
        }
        if f.x < 0.0 || f.y < 0.0 || f.x >= wm || f.y >= hm {
            return Err(Error::invalid(format!(
                "fixed peak at ({:.0}, {:.0}) m lies outside the {wm:.0} x {hm:.0} m domain",
                f.x, f.y
            )));
        }
        if f.elevation <= 0.0 {
            return Err(Error::invalid("a fixed peak must be above 0 m"));
        }
    }
    // Free peaks per region: what is wanted less the fixed peaks there.
    let mut fixed_in = vec![0usize; nreg];
    for f in &opts.fixed_peaks {
        fixed_in[region_at(f.x, f.y).unwrap_or(0)] += 1;
    }
    let mut n_free: Vec<usize> = (0..nreg)
        .map(|r| want[r].saturating_sub(fixed_in[r]))
        .collect();
    if opts.fixed_peaks.is_empty() && n_free.iter().all(|&k| k == 0) {
        let big = (0..nreg)
            .max_by(|&a, &b| frac[a].total_cmp(&frac[b]).then(b.cmp(&a)))
            .unwrap_or(0);
        n_free[big] = 1;
    }
    let n = opts.fixed_peaks.len() + n_free.iter().sum::<usize>();
    // Peaks need distinct cells with room around them.
    if n as f64 * 4.0 > (w as f64) * (h as f64) {
        return Err(Error::invalid(format!(
            "{n} peaks do not fit in {w}x{h} cells (at most one per 4 cells); give a larger domain or a coarser cell"
        )));
    }
    let cp = match &opts.density_map {
        Some(g) => {
            let max = g
                .data()
                .iter()
                .filter(|v| v.is_finite())
                .fold(0.0f32, |a, &b| a.max(b));
            if g.data().iter().any(|v| v.is_finite() && *v < 0.0) {
                return Err(Error::invalid(
                    "the density map has negative values; densities must be ≥ 0",
                ));
            }
            if max <= 0.0 {
                return Err(Error::invalid(
                    "the density map is zero (or nodata) everywhere: no place may hold a peak",
                ));
            }
            Some((
                DomainMap {
                    g,
                    sx: g.width() as f64 / wm,
                    sy: g.height() as f64 / hm,
                },
                max as f64,
            ))
        }
        None => None,
    };
    // Without a user C_H, a coherent one: low-frequency fBm whose values are
    // mapped through the profile's peak-elevation quantiles, so high peaks
    // gather in massifs as in real ranges instead of landing next to low ones
    // (with a type map: the quantiles of the region's profile).
    // With a type map, the coherent map holds the fBm's rank fraction u and
    // a peak of region r reads r's quantile q_r(u) with r's σ (1/20 of its
    // elevation range): in a blend band each region's peaks keep their own
    // elevations (a blended elevation would suit neither side).
    let auto_ch;
    let mut rank_map = None;
    let ch_src = match &opts.elevation_map {
        Some(g) => Some(g),
        None if opts.coherent => match tm {
            None => {
                auto_ch = coherent_elevation_map(profile, w, h, opts.seed);
                Some(&auto_ch)
            }
            Some(_) => {
                rank_map = Some(coherent_map_with(w, h, opts.seed, |u, _, _| u));
                None
            }
        },
        None => None,
    };
    let rank_map = rank_map.as_ref().map(|g| DomainMap {
        g,
        sx: g.width() as f64 / wm,
        sy: g.height() as f64 / hm,
    });
    let region_sigma: Vec<f64> = profiles
        .iter()
        .map(|p| ((p.elevation.quantile(1.0) - p.elevation.quantile(0.0)) / 20.0).max(1.0))
        .collect();
    let (blend_fx, blend_fy) = (opts.type_blend_m / wm, opts.type_blend_m / hm);
    let ch = match ch_src {
        Some(g) => {
            let (lo, hi) = g
                .data()
                .iter()
                .filter(|v| v.is_finite())
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                    (a.min(v as f64), b.max(v as f64))
                });
            if !lo.is_finite() {
                return Err(Error::invalid("the elevation map has no valid cells"));
            }
            let sigma = ((hi - lo) / 20.0).max(1.0);
            Some((
                DomainMap {
                    g,
                    sx: g.width() as f64 / wm,
                    sy: g.height() as f64 / hm,
                },
                sigma,
            ))
        }
        None => None,
    };
    let mut rng = SplitMix64(opts.seed ^ 0x6f72_6f73_796e_7468);
    let snap =
        |v: f64, nmax: usize| ((v / cell).floor().clamp(0.0, nmax as f64 - 1.0) + 0.5) * cell;

    // Per region: elevations stratified, decreasing; isolation targets
    // (m) stratified, larger for higher peaks with a random rank jitter
    // (real isolation correlates with elevation rank, not perfectly);
    // directions stratified sectors, shuffled.
    let mut jobs: Vec<Job> = Vec::with_capacity(n);
    for (r, prof) in profiles.iter().enumerate() {
        let nf = n_free[r];
        if nf == 0 {
            continue;
        }
        let mut elev = prof.elevation.stratified(nf);
        elev.reverse();
        let mut iso: Vec<f64> = prof
            .isolation_km
            .stratified(nf)
            .into_iter()
            .map(|d| d * 1000.0 * opts.isolation_stretch)
            .collect();
        let keys: Vec<f64> = (0..nf)
            .map(|i| i as f64 + (rng.unit() - 0.5) * 0.5 * nf as f64)
            .collect();
        let mut idx: Vec<usize> = (0..nf).collect();
        idx.sort_by(|&a, &b| keys[a].total_cmp(&keys[b]).then(a.cmp(&b)));
        iso.sort_by(|a, b| b.total_cmp(a));
        let mut iso_of = vec![0.0; nf];
        for (rank, &i) in idx.iter().enumerate() {
            iso_of[i] = iso[rank];
        }
        let mut dirs = prof.isolation_dir.stratified(nf);
        for i in (1..dirs.len()).rev() {
            let j = rng.below(i as u64 + 1) as usize;
            dirs.swap(i, j);
        }
        // Prominence bins: the prominence rank of a peak is its elevation
        // rank with a random jitter (prominent peaks are mostly high ones;
        // the saddle assignment sets the prominences later).
        let mut pass = vec![0usize; nf];
        if opts.passes > 1 {
            let pk: Vec<f64> = (0..nf)
                .map(|i| i as f64 + (rng.unit() - 0.5) * 0.5 * nf as f64)
                .collect();
            let mut pidx: Vec<usize> = (0..nf).collect();
            pidx.sort_by(|&a, &b| pk[a].total_cmp(&pk[b]).then(a.cmp(&b)));
            for (rank, &i) in pidx.iter().enumerate() {
                pass[i] = pass_of_rank(rank, nf, opts.passes);
            }
        }
        for i in 0..nf {
            jobs.push(Job {
                elev: elev[i],
                iso: iso_of[i],
                dir: dirs[i],
                region: r,
                pass: pass[i],
            });
        }
    }
    // Placement order: pass by pass, each in decreasing elevation.
    jobs.sort_by(|a, b| a.pass.cmp(&b.pass).then(b.elev.total_cmp(&a.elev)));

    let min_sep = 2.0 * cell;
    let typical = (wm * hm / n as f64).sqrt().max(min_sep);
    let mut grid = PeakGrid::new(wm, hm, typical);
    let mut peaks: Vec<SynthPeak> = Vec::with_capacity(n);
    let mut group_of_peak: Vec<usize> = Vec::with_capacity(n);
    for f in &opts.fixed_peaks {
        let (x, y) = (snap(f.x, w), snap(f.y, h));
        if grid.nearest_higher(&peaks, x, y, f64::NEG_INFINITY, min_sep) < min_sep {
            return Err(Error::invalid(format!(
                "fixed peaks at ({:.0}, {:.0}) m are closer than two cells to another fixed peak",
                f.x, f.y
            )));
        }
        grid.insert(peaks.len(), x, y);
        peaks.push(SynthPeak {
            x,
            y,
            elevation: f.elevation,
            fixed: true,
        });
        group_of_peak.push(region_at(x, y).unwrap_or(0));
    }
    let n_fixed = peaks.len();
    let kept_out = |x: f64, y: f64| {
        opts.keep_out
            .iter()
            .any(|k| x >= k[0] && x <= k[2] && y >= k[1] && y <= k[3])
    };
    let accept_maps = |rng: &mut SplitMix64,
                       x: f64,
                       y: f64,
                       hh: f64,
                       region: usize,
                       ridges: Option<&DomainMap>|
     -> bool {
        if let Some(t) = tm {
            if t.region_blended(x / wm, y / hm, blend_fx, blend_fy, opts.seed) != Some(region) {
                return false;
            }
        }
        if kept_out(x, y) {
            return false;
        }
        if let Some((m, max)) = &cp {
            let v = m.at(x, y);
            if !(v.is_finite() && rng.unit() * max < v) {
                return false;
            }
        }
        if let Some((m, sigma)) = &ch {
            let v = m.at(x, y);
            if !v.is_finite() {
                return false;
            }
            let z = (v - hh) / sigma;
            if rng.unit() >= (-0.5 * z * z).exp() {
                return false;
            }
        }
        if let Some(m) = &rank_map {
            let v = profiles[region].elevation.quantile(m.at(x, y));
            let z = (v - hh) / region_sigma[region];
            if rng.unit() >= (-0.5 * z * z).exp() {
                return false;
            }
        }
        if let Some(m) = ridges {
            let a = opts.ridge_attraction;
            if rng.unit() >= (1.0 - a) + a * m.at(x, y) {
                return false;
            }
        }
        true
    };
    let margin = cell;
    let mut max_placed = peaks
        .iter()
        .map(|p| p.elevation)
        .fold(f64::NEG_INFINITY, f64::max);
    let mut ridge_grid: Option<Grid<f32>> = None;
    let mut cur_pass = 0usize;
    for job in &jobs {
        if job.pass != cur_pass {
            cur_pass = job.pass;
            // The ridges of the peaks placed so far attract the next bins.
            ridge_grid = if opts.ridge_attraction > 0.0 && peaks.len() >= 2 {
                Some(ridge_density(&peaks, opts.rho, wm, hm, typical)?)
            } else {
                None
            };
        }
        let rmap = ridge_grid.as_ref().map(|g| DomainMap {
            g,
            sx: g.width() as f64 / wm,
            sy: g.height() as f64 / hm,
        });
        let hh = job.elev;
        let d = job.iso.max(min_sep);
        let mut placed = None;
        // Proposals from a random higher peak at the target distance and
        // direction (some placed peak is at least as high iff the highest
        // placed one is).
        let have_higher = max_placed >= hh;
        if have_higher {
            for _ in 0..64 {
                // Random placed peak that is at least as high.
                let mut q = rng.below(peaks.len() as u64) as usize;
                let mut guard = 0;
                while peaks[q].elevation < hh && guard < 8 {
                    q = rng.below(peaks.len() as u64) as usize;
                    guard += 1;
                }
                if peaks[q].elevation < hh {
                    continue;
                }
                let theta = ((job.dir.floor() * 45.0) + (rng.unit() - 0.5) * 45.0).to_radians();
                // Vector from the new peak to q points along bearing theta.
                let x = peaks[q].x - d * theta.sin();
                let y = peaks[q].y + d * theta.cos();
                if x < margin || y < margin || x > wm - margin || y > hm - margin {
                    continue;
                }
                let (x, y) = (snap(x, w), snap(y, h));
                let dn = grid.nearest_higher(&peaks, x, y, hh, d * 1.5);
                let dall = grid.nearest_higher(&peaks, x, y, f64::NEG_INFINITY, min_sep * 2.0);
                if dn >= 0.85 * d
                    && dall >= min_sep
                    && accept_maps(&mut rng, x, y, hh, job.region, rmap.as_ref())
                {
                    placed = Some((x, y));
                    break;
                }
            }
        }
        if placed.is_none() {
            // Uniform darts: the best isolation match among a few accepted ones.
            let mut best: Option<(f64, f64, f64)> = None;
            for _ in 0..256 {
                let x = snap(margin + rng.unit() * (wm - 2.0 * margin), w);
                let y = snap(margin + rng.unit() * (hm - 2.0 * margin), h);
                let dall = grid.nearest_higher(&peaks, x, y, f64::NEG_INFINITY, min_sep * 2.0);
                if dall < min_sep || !accept_maps(&mut rng, x, y, hh, job.region, rmap.as_ref()) {
                    continue;
                }
                let dn = if have_higher {
                    grid.nearest_higher(&peaks, x, y, hh, d * 4.0)
                } else {
                    d
                };
                let score = (dn / d).ln().abs();
                if best.is_none_or(|b| score < b.2) {
                    best = Some((x, y, score));
                }
                if score < 0.1 {
                    break;
                }
            }
            placed = best.map(|b| (b.0, b.1));
        }
        if let Some((x, y)) = placed {
            max_placed = max_placed.max(hh);
            grid.insert(peaks.len(), x, y);
            peaks.push(SynthPeak {
                x,
                y,
                elevation: hh,
                fixed: false,
            });
            group_of_peak.push(job.region);
        }
    }
    if peaks.is_empty() {
        return Err(Error::invalid(
            "no peak could be placed (the density map leaves no room?)",
        ));
    }
    // Ridges (the pasted fragment's first, verbatim) and saddles.
    let mut forced = Vec::with_capacity(opts.fixed_ridges.len());
    for (k, fr) in opts.fixed_ridges.iter().enumerate() {
        let [a, b] = fr.peaks;
        if a >= n_fixed || b >= n_fixed {
            return Err(Error::invalid(format!(
                "kept ridge {k} joins fixed peaks {a} and {b}, but there are {n_fixed} fixed peaks"
            )));
        }
        let lo = peaks[a].elevation.min(peaks[b].elevation);
        let ok = fr.elevation.is_finite()
            && fr.elevation >= 0.0
            && fr.elevation < lo
            && fr.x.is_finite()
            && fr.y.is_finite();
        if !ok || fr.x < 0.0 || fr.y < 0.0 || fr.x >= wm || fr.y >= hm {
            return Err(Error::invalid(format!(
                "kept ridge {k}: its saddle must lie in the domain, between 0 m and its lower peak ({lo} m)"
            )));
        }
        forced.push((a, b));
    }
    if !(opts.ridge_contrast.is_finite() && opts.ridge_contrast >= 1.0) {
        return Err(Error::invalid(
            "ridge_contrast must be a number ≥ 1 (1: ridge weights on absolute elevations)",
        ));
    }
    if !(opts.ridge_base.is_finite() && (0.0..1.0).contains(&opts.ridge_base)) {
        return Err(Error::invalid(
            "ridge_base must be a fraction in [0, 1) of the lowest peak (0: the contrast alone)",
        ));
    }
    let edges = {
        // Ridge weights on the relief above a common base (see
        // `TreeOptions::ridge_contrast`); `ridge_tree_with` floors it at 1 m.
        let (lowest, highest) = peaks
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                (a.min(p.elevation), b.max(p.elevation))
            });
        let thr = profiles
            .iter()
            .map(|p| p.min_prominence)
            .fold(0.0f64, f64::max);
        let c = opts.ridge_contrast;
        let by_contrast = if c > 1.0 {
            (c * lowest - highest) / (c - 1.0)
        } else {
            0.0
        };
        let base = by_contrast
            .max(opts.ridge_base * lowest)
            .clamp(0.0, (lowest - thr).max(0.0));
        if base > 0.0 {
            let rel: Vec<SynthPeak> = peaks
                .iter()
                .map(|p| SynthPeak {
                    elevation: p.elevation - base,
                    ..p.clone()
                })
                .collect();
            ridge_tree_with(&rel, opts.rho, &forced, &[])?
        } else {
            ridge_tree_with(&peaks, opts.rho, &forced, &[])?
        }
    };
    let mut saddles = Vec::with_capacity(edges.len());
    let mut hmax = Vec::with_capacity(edges.len());
    let mut pinned = Vec::with_capacity(edges.len());
    for (e, &(i, j)) in edges.iter().enumerate() {
        let (a, b) = (&peaks[i], &peaks[j]);
        let lo = a.elevation.min(b.elevation);
        if let Some(fr) = opts.fixed_ridges.get(e) {
            // `ridge_tree_with` puts the forced ridges first, in order.
            saddles.push(SynthSaddle {
                x: snap(fr.x, w),
                y: snap(fr.y, h),
                elevation: fr.elevation,
                peaks: [i, j],
            });
            hmax.push(fr.elevation);
            pinned.push(true);
            continue;
        }
        let t = 0.35 + 0.3 * rng.unit();
        let off = (rng.unit() - 0.5) * 0.2;
        let (dx, dy) = (b.x - a.x, b.y - a.y);
        let mut x = a.x + t * dx - off * dy;
        let mut y = a.y + t * dy + off * dx;
        x = snap(x.clamp(0.0, wm - 1e-9), w);
        y = snap(y.clamp(0.0, hm - 1e-9), h);
        // A saddle must not share a peak's cell.
        if (x == a.x && y == a.y) || (x == b.x && y == b.y) {
            x = snap(a.x + 0.5 * dx, w);
            y = snap(a.y + 0.5 * dy, h);
        }
        saddles.push(SynthSaddle {
            x,
            y,
            elevation: 0.0,
            peaks: [i, j],
        });
        // Saddles stay at least 1 m (or 1 %) below both ends.
        hmax.push(lo - (0.01 * lo).clamp(0.0, 1.0).max(0.01));
        pinned.push(false);
    }
    let hp: Vec<f64> = peaks.iter().map(|p| p.elevation).collect();
    let ns = edges.len();
    let thr_of: Vec<f64> = profiles.iter().map(|p| p.min_prominence).collect();
    if ns > 0 {
        let groups: Vec<GroupTargets> = profiles
            .iter()
            .map(|p| GroupTargets {
                prominence: &p.prominence,
                dominance: &p.dominance,
            })
            .collect();
        // Start: each saddle a random prominence (of the profile of its
        // lower end) below its lower end.
        let mut hs: Vec<f64> = (0..ns)
            .map(|e| {
                if pinned[e] {
                    return saddles[e].elevation;
                }
                let (i, j) = edges[e];
                let low = if hp[i] <= hp[j] { i } else { j };
                let k = rng.below(ns as u64) as usize;
                let t = profiles[group_of_peak[low]]
                    .prominence
                    .quantile((k as f64 + 0.5) / ns as f64);
                (hmax[e] - t).clamp(0.0, hmax[e].max(0.0))
            })
            .collect();
        let problem = SaddleProblem {
            h: &hp,
            edges: &edges,
            hmax: &hmax,
            floor: 0.0,
            group_of_peak: &group_of_peak,
            groups: &groups,
            thresholds: &thr_of,
            pinned: &pinned,
        };
        assign_saddles_grouped(&problem, &mut hs, opts.iterations)?;
        // Repair: a peak whose prominence fell below its profile's threshold
        // (owners change as saddles move) gets its key saddle lowered to the
        // threshold. Lowering saddles never lowers another peak's
        // prominence, so this converges. Pasted saddles stay as they are.
        for _ in 0..32 {
            let own = super::assign::owners(&hp, &edges, &hs);
            let mut changed = false;
            for (e, &o) in own.iter().enumerate() {
                let thr = thr_of[group_of_peak[o]];
                if !pinned[e]
                    && hp[o] - hs[e] < thr * PROMINENCE_MARGIN * (1.0 - 1e-9)
                    && hs[e] > 0.0
                {
                    hs[e] = (hp[o] - thr * PROMINENCE_MARGIN).max(0.0);
                    changed = true;
                }
            }
            if !changed {
                break;
            }
        }
        if opts.refine {
            refine_histograms(&problem, &mut hs, opts.seed)?;
        }
        for (s, v) in saddles.iter_mut().zip(hs) {
            s.elevation = v;
        }
    }
    let home: Vec<(f64, f64)> = peaks.iter().map(|p| (p.x, p.y)).collect();
    let mut tree = SynthTree {
        format: "orogen-synthtree".into(),
        version: 1,
        width: w,
        height: h,
        cell,
        seed: opts.seed,
        min_prominence: thr_of.iter().copied().fold(f64::INFINITY, f64::min),
        peaks,
        saddles,
    };
    // Peaks and saddles keep clear of ridges joined to them only lower
    // down; a moved peak stays in its region, outside kept-out ground and
    // where the density map allows peaks.
    let tol = RIDGE_CLEARANCE_TOL * tree.min_prominence;
    clear_ridges(
        &mut tree,
        RIDGE_CLEARANCE_CELLS * cell + RIDGE_CLEARANCE_M,
        tol,
        &mut |node, x, y| match node {
            Node::Peak(i) => {
                let (x0, y0) = home[i];
                region_at(x, y) == region_at(x0, y0)
                    && !kept_out(x, y)
                    && cp.as_ref().is_none_or(|(m, _)| {
                        let v = m.at(x, y);
                        v.is_finite() && v > 0.0
                    })
            }
            // A pasted fragment's saddles stay where they were measured.
            Node::Saddle(k) => !pinned[k],
        },
    );
    tree.validate()?;
    Ok(tree)
}

/// Least distance from a peak to a ridge the tree joins to it only below
/// both ([`clear_ridges`]): cells (a raster joins crest points with one cell
/// between them), plus metres for part of the terrain's ridge jitter. Three
/// cells plus 50 m moved 45 % of the Alps profile's peaks and doubled the
/// isolation error; this moves about 4 % (docs/design/orometric-synthesis.md#ridge-clearance-clearancers).
pub const RIDGE_CLEARANCE_CELLS: f64 = 2.0;
/// See [`RIDGE_CLEARANCE_CELLS`].
pub const RIDGE_CLEARANCE_M: f64 = 25.0;
/// A join counts as offending when it stands more than this fraction of the
/// prominence threshold above the tree's pass height: the terrain noise's
/// bound (below half the threshold), within which the issue's check accepts
/// elevations anyway.
pub const RIDGE_CLEARANCE_TOL: f64 = 0.5;

impl SynthTree {
    /// Check an edited or loaded tree: sizes, finite values inside the
    /// domain, n − 1 saddles forming one tree over the peaks, each saddle
    /// between 0 and the lower of its two peaks. Errors name the element.
    pub fn validate(&self) -> Result<()> {
        if self.format != "orogen-synthtree" || self.version != 1 {
            return Err(Error::invalid(format!(
                "divide tree format {:?} version {}; expected orogen-synthtree 1 (made by `orogen synth divide-tree`)",
                self.format, self.version
            )));
        }
        if self.width == 0 || self.height == 0 || self.width > MAX_SIDE || self.height > MAX_SIDE {
            return Err(Error::invalid("divide tree: domain size out of range"));
        }
        if !(self.cell.is_finite() && self.cell > 0.0) {
            return Err(Error::invalid(
                "divide tree: the cell size must be positive",
            ));
        }
        if self.peaks.is_empty() {
            return Err(Error::invalid("divide tree: it has no peak"));
        }
        if self.peaks.len() > MAX_PEAKS {
            return Err(Error::invalid("divide tree: too many peaks"));
        }
        let (wm, hm) = (
            self.width as f64 * self.cell,
            self.height as f64 * self.cell,
        );
        let inside = |x: f64, y: f64| {
            x.is_finite() && y.is_finite() && x >= 0.0 && y >= 0.0 && x < wm && y < hm
        };
        for (i, p) in self.peaks.iter().enumerate() {
            if !inside(p.x, p.y) || !p.elevation.is_finite() || p.elevation <= 0.0 {
                return Err(Error::invalid(format!(
                    "divide tree: peak {i} at ({}, {}) m, {} m is outside the {wm} x {hm} m domain or not above 0 m",
                    p.x, p.y, p.elevation
                )));
            }
        }
        if self.saddles.len() + 1 != self.peaks.len() {
            return Err(Error::invalid(format!(
                "divide tree: {} peaks need {} saddles (one per ridge), found {}: the edit disconnected the tree or added a loop",
                self.peaks.len(),
                self.peaks.len() - 1,
                self.saddles.len()
            )));
        }
        let mut uf = UnionFind::<usize>::new(self.peaks.len());
        for (k, s) in self.saddles.iter().enumerate() {
            let [a, b] = s.peaks;
            if a >= self.peaks.len() || b >= self.peaks.len() || a == b {
                return Err(Error::invalid(format!(
                    "divide tree: saddle {k} joins peaks {a} and {b}; it needs two different existing peaks"
                )));
            }
            if !inside(s.x, s.y) || !s.elevation.is_finite() {
                return Err(Error::invalid(format!(
                    "divide tree: saddle {k} lies outside the domain or has no elevation"
                )));
            }
            let lo = self.peaks[a].elevation.min(self.peaks[b].elevation);
            if s.elevation < 0.0 || s.elevation >= lo {
                return Err(Error::invalid(format!(
                    "divide tree: saddle {k} at {} m must lie between 0 m and its lower peak ({lo} m)",
                    s.elevation
                )));
            }
            if !uf.join(a, b) {
                return Err(Error::invalid(format!(
                    "divide tree: saddle {k} closes a loop (peaks {a} and {b} are already joined); the edit disconnected the tree elsewhere"
                )));
            }
        }
        Ok(())
    }

    /// Ridges as (peak, peak) pairs, saddle by saddle.
    pub fn edges(&self) -> Vec<(usize, usize)> {
        self.saddles
            .iter()
            .map(|s| (s.peaks[0], s.peaks[1]))
            .collect()
    }

    /// Prominence of every peak (the highest: its elevation).
    pub fn prominences(&self) -> Vec<f64> {
        let h: Vec<f64> = self.peaks.iter().map(|p| p.elevation).collect();
        let hs: Vec<f64> = self.saddles.iter().map(|s| s.elevation).collect();
        prominences(&h, &self.edges(), &hs)
    }

    /// Edit: delete peak `i` and reconnect its ridge neighbours to the
    /// highest of them through the saddles they had (the deleted peak's
    /// saddles are kept, moved to the new ridges' ends). Saddles above a new
    /// ridge's lower end are lowered just below it.
    pub fn delete_peak(&mut self, i: usize) -> Result<()> {
        if i >= self.peaks.len() || self.peaks.len() < 2 {
            return Err(Error::invalid(format!(
                "delete peak {i}: no such peak, or it is the only one"
            )));
        }
        let nbrs: Vec<(usize, usize)> = self
            .saddles
            .iter()
            .enumerate()
            .filter_map(|(k, s)| {
                if s.peaks[0] == i {
                    Some((k, s.peaks[1]))
                } else if s.peaks[1] == i {
                    Some((k, s.peaks[0]))
                } else {
                    None
                }
            })
            .collect();
        let Some(&(k0, hub)) = nbrs.iter().max_by(|a, b| {
            self.peaks[a.1]
                .elevation
                .total_cmp(&self.peaks[b.1].elevation)
                .then(b.1.cmp(&a.1))
        }) else {
            return Err(Error::invalid(format!("delete peak {i}: it has no ridge")));
        };
        for &(k, nb) in &nbrs {
            if k != k0 {
                let lo = self.peaks[nb].elevation.min(self.peaks[hub].elevation);
                let s = &mut self.saddles[k];
                s.peaks = [nb, hub];
                s.elevation = s.elevation.min(lo - 1.0).max(0.0);
            }
        }
        self.saddles.remove(k0);
        self.peaks.remove(i);
        for s in &mut self.saddles {
            for p in &mut s.peaks {
                if *p > i {
                    *p -= 1;
                }
            }
        }
        self.validate()
    }

    /// JSON text (pretty).
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).unwrap_or_default()
    }

    /// Save as JSON.
    pub fn save(&self, path: &Path) -> Result<()> {
        crate::io::atomic::write_file_atomic(path, self.to_json().as_bytes())
    }

    /// Load and validate (size-checked before reading).
    pub fn load(path: &Path) -> Result<SynthTree> {
        let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
        if meta.len() > 1 << 30 {
            return Err(Error::too_large(path, "a divide tree file over 1 GiB"));
        }
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        let t: SynthTree = serde_json::from_str(&text).map_err(|e| {
            Error::corrupt(
                path,
                format!("not a divide tree written by `orogen synth divide-tree`: {e}"),
            )
        })?;
        t.validate()
            .map_err(|e| Error::corrupt(path, e.to_string()))?;
        Ok(t)
    }

    /// GeoJSON (local metric CRS, y up as in the rasters orogen writes):
    /// peaks and saddles as points, ridges as two-segment lines.
    pub fn to_geojson(&self) -> String {
        let hm = self.height as f64 * self.cell;
        let prom = self.prominences();
        let mut f = Vec::new();
        for (i, p) in self.peaks.iter().enumerate() {
            f.push(format!(
                r#"{{"type":"Feature","geometry":{{"type":"Point","coordinates":[{},{}]}},"properties":{{"kind":"peak","id":{i},"elevation":{},"prominence":{},"fixed":{}}}}}"#,
                p.x, hm - p.y, p.elevation, prom[i], p.fixed
            ));
        }
        for (k, s) in self.saddles.iter().enumerate() {
            f.push(format!(
                r#"{{"type":"Feature","geometry":{{"type":"Point","coordinates":[{},{}]}},"properties":{{"kind":"saddle","id":{k},"elevation":{},"peaks":[{},{}]}}}}"#,
                s.x, hm - s.y, s.elevation, s.peaks[0], s.peaks[1]
            ));
            let (a, b) = (&self.peaks[s.peaks[0]], &self.peaks[s.peaks[1]]);
            f.push(format!(
                r#"{{"type":"Feature","geometry":{{"type":"LineString","coordinates":[[{},{}],[{},{}],[{},{}]]}},"properties":{{"kind":"ridge","saddle":{k}}}}}"#,
                a.x, hm - a.y, s.x, hm - s.y, b.x, hm - b.y
            ));
        }
        format!(
            "{{\"type\":\"FeatureCollection\",\"features\":[\n{}\n]}}\n",
            f.join(",\n")
        )
    }
}
