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
//! Not done (see `docs/notes/orometric.md`): the multi-pass placement by
//! prominence bins and the diffusion of ridges into C_P; one pass places
//! every peak.

use super::assign::{assign_saddles, prominences};
use super::profile::SynthProfile;
use crate::error::{Error, Result};
use crate::oro::stats::SplitMix64;
use crate::raster::Grid;
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
    /// closer than its summit). Default 1.2, calibrated on the Mont Blanc
    /// and Dallas profiles (see docs/notes/orometric.md).
    pub isolation_stretch: f64,
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
            isolation_stretch: 1.2,
        }
    }
}

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
        out[i] = profile.elevation.quantile((rank as f64 + 0.5) / n) as f32;
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
    let mut parent: Vec<usize> = (0..peaks.len()).collect();
    fn find(p: &mut [usize], mut x: usize) -> usize {
        while p[x] != x {
            p[x] = p[p[x]];
            x = p[x];
        }
        x
    }
    let mut out = Vec::with_capacity(peaks.len() - 1);
    for (_, i, j) in edges {
        let (ri, rj) = (find(&mut parent, i), find(&mut parent, j));
        if ri != rj {
            parent[ri] = rj;
            out.push((i, j));
        }
    }
    Ok(out)
}

/// Synthesise a divide tree matching `profile` on the domain of `opts`.
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
    let (wm, hm) = (w as f64 * cell, h as f64 * cell);
    let area_km2 = wm * hm / 1e6;
    let n_wanted = match opts.n_peaks {
        Some(n) => n,
        None => (profile.peak_density_per_km2 * area_km2).round() as usize,
    };
    let n = n_wanted.max(opts.fixed_peaks.len()).max(1);
    if n > MAX_PEAKS {
        return Err(Error::invalid(format!(
            "{n} peaks requested; at most {MAX_PEAKS} per synthesis (use a smaller domain or density)"
        )));
    }
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
    // gather in massifs as in real ranges instead of landing next to low ones.
    let auto_ch;
    let ch_src = match &opts.elevation_map {
        Some(g) => Some(g),
        None if opts.coherent => {
            auto_ch = coherent_elevation_map(profile, w, h, opts.seed);
            Some(&auto_ch)
        }
        None => None,
    };
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

    // Elevations: stratified, decreasing; fixed peaks come first.
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
    let n_free = n - opts.fixed_peaks.len();
    let mut elev = profile.elevation.stratified(n_free);
    elev.reverse();
    // Isolation targets (m): stratified, larger for higher peaks with a
    // random rank jitter (real isolation correlates with elevation rank, not
    // perfectly); directions: stratified sectors, shuffled.
    let mut iso: Vec<f64> = profile
        .isolation_km
        .stratified(n_free)
        .into_iter()
        .map(|d| d * 1000.0 * opts.isolation_stretch)
        .collect();
    let keys: Vec<f64> = (0..n_free)
        .map(|i| i as f64 + (rng.unit() - 0.5) * 0.5 * n_free as f64)
        .collect();
    let mut idx: Vec<usize> = (0..n_free).collect();
    idx.sort_by(|&a, &b| keys[a].total_cmp(&keys[b]).then(a.cmp(&b)));
    iso.sort_by(|a, b| b.total_cmp(a));
    let mut iso_of = vec![0.0; n_free];
    for (rank, &i) in idx.iter().enumerate() {
        iso_of[i] = iso[rank];
    }
    let mut dirs = profile.isolation_dir.stratified(n_free);
    for i in (1..dirs.len()).rev() {
        let j = rng.below(i as u64 + 1) as usize;
        dirs.swap(i, j);
    }

    let min_sep = 2.0 * cell;
    let typical = (wm * hm / n as f64).sqrt().max(min_sep);
    let mut grid = PeakGrid::new(wm, hm, typical);
    let mut peaks: Vec<SynthPeak> = Vec::with_capacity(n);
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
    }
    let accept_maps = |rng: &mut SplitMix64, x: f64, y: f64, hh: f64| -> bool {
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
        true
    };
    let margin = cell;
    let mut max_placed = peaks
        .iter()
        .map(|p| p.elevation)
        .fold(f64::NEG_INFINITY, f64::max);
    for k in 0..n_free {
        let hh = elev[k];
        let d = iso_of[k].max(min_sep);
        let mut placed = None;
        // Proposals from a random higher peak at the target distance and
        // direction (free peaks come in decreasing elevation, so some placed
        // peak is at least as high iff the highest placed one is).
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
                let theta = ((dirs[k].floor() * 45.0) + (rng.unit() - 0.5) * 45.0).to_radians();
                // Vector from the new peak to q points along bearing theta.
                let x = peaks[q].x - d * theta.sin();
                let y = peaks[q].y + d * theta.cos();
                if x < margin || y < margin || x > wm - margin || y > hm - margin {
                    continue;
                }
                let (x, y) = (snap(x, w), snap(y, h));
                let dn = grid.nearest_higher(&peaks, x, y, hh, d * 1.5);
                let dall = grid.nearest_higher(&peaks, x, y, f64::NEG_INFINITY, min_sep * 2.0);
                if dn >= 0.85 * d && dall >= min_sep && accept_maps(&mut rng, x, y, hh) {
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
                if dall < min_sep || !accept_maps(&mut rng, x, y, hh) {
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
        }
    }
    if peaks.is_empty() {
        return Err(Error::invalid(
            "no peak could be placed (the density map leaves no room?)",
        ));
    }
    // Ridges and saddles.
    let edges = ridge_tree(&peaks, opts.rho)?;
    let mut saddles = Vec::with_capacity(edges.len());
    let mut hmax = Vec::with_capacity(edges.len());
    for &(i, j) in &edges {
        let (a, b) = (&peaks[i], &peaks[j]);
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
        let lo = a.elevation.min(b.elevation);
        hmax.push(lo - (0.01 * lo).clamp(0.0, 1.0).max(0.01));
    }
    let hp: Vec<f64> = peaks.iter().map(|p| p.elevation).collect();
    let ns = edges.len();
    if ns > 0 {
        let prom_t = profile.prominence.stratified(ns);
        let dom_t = profile.dominance.stratified(ns);
        // Start: each saddle a random prominence below its lower end.
        let mut hs: Vec<f64> = (0..ns)
            .map(|e| {
                let k = rng.below(ns as u64) as usize;
                (hmax[e] - prom_t[k]).clamp(0.0, hmax[e].max(0.0))
            })
            .collect();
        assign_saddles(
            &hp,
            &edges,
            &hmax,
            0.0,
            &mut hs,
            &prom_t,
            &dom_t,
            opts.iterations,
        )?;
        // Repair: a peak whose prominence fell below the profile's threshold
        // (owners change as saddles move) gets its key saddle lowered to the
        // threshold. Lowering saddles never lowers another peak's
        // prominence, so this converges.
        let thr = profile.min_prominence;
        for _ in 0..32 {
            let own = super::assign::owners(&hp, &edges, &hs);
            let mut changed = false;
            for (e, &o) in own.iter().enumerate() {
                if hp[o] - hs[e] < thr && hs[e] > 0.0 {
                    hs[e] = (hp[o] - thr * 1.001).max(0.0);
                    changed = true;
                }
            }
            if !changed {
                break;
            }
        }
        for (s, v) in saddles.iter_mut().zip(hs) {
            s.elevation = v;
        }
    }
    let tree = SynthTree {
        format: "orogen-synthtree".into(),
        version: 1,
        width: w,
        height: h,
        cell,
        seed: opts.seed,
        min_prominence: profile.min_prominence,
        peaks,
        saddles,
    };
    tree.validate()?;
    Ok(tree)
}

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
        let mut parent: Vec<usize> = (0..self.peaks.len()).collect();
        fn find(p: &mut [usize], mut x: usize) -> usize {
            while p[x] != x {
                p[x] = p[p[x]];
                x = p[x];
            }
            x
        }
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
            let (ra, rb) = (find(&mut parent, a), find(&mut parent, b));
            if ra == rb {
                return Err(Error::invalid(format!(
                    "divide tree: saddle {k} closes a loop (peaks {a} and {b} are already joined); the edit disconnected the tree elsewhere"
                )));
            }
            parent[ra] = rb;
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
        std::fs::write(path, self.to_json()).map_err(|e| Error::io(path, e))
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
