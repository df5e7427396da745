//! The paper's terrain model (Argudo et al. 2019, §6): river network dual
//! of the divide tree ([`super::rivers`]), Poisson-disk samples whose
//! elevation interpolates between the nearest ridge and river points with a
//! valley width growing as A^0.4, a constrained Delaunay TIN keeping the
//! ridge and river segments, rasterised at any resolution, window by window.
//!
//! Samples: Poisson-disk dart throwing on a background grid of side r/√2
//! (one point per grid cell at most; the grid as in Bridson 2007, "Fast
//! Poisson disk sampling in arbitrary dimensions", SIGGRAPH sketches),
//! r = λ, kept 0.4 λ away from ridge and river vertices. A sample's flank
//! elevation z_l is the barycentric value of the skeleton TIN (ridge, river
//! and border vertices, ridge and river segments kept): it descends from
//! the ridges to the rivers and has no interior extremum, so it adds no
//! peak and no pit (a first version interpolated between the *nearest*
//! ridge and river points and made plateaus, hence spurious peaks, in the
//! large triangles between sparse ridges). Near a river of drainage area A
//! the flank eases to the river's elevation z_r over the valley half-width
//! w = w₁ · (A / 1 km²)^0.4 (the A^0.4 law of the issue, after the
//! hydraulic-geometry exponents of Leopold & Maddock 1953):
//! z = z_r + (z_l − z_r) · s(d_r / w), s the smoothstep 3u² − 2u³ clamped
//! at 1 (our profile; the paper's curve is not reproduced). Then no sample
//! may be a local maximum or minimum of the final TIN (such a sample is set
//! to the middle of its neighbours' range) and no sample next to a peak may
//! reach it, so the only maxima are the tree's peaks.
//!
//! Raster: barycentric interpolation in the TIN ([`super::tin::Tin`]);
//! cells within 0.71 cell of a river segment read at most the river's
//! elevation (a 4-connected channel no 8-path can hop over) and cells
//! within 0.55 cell of a ridge at least the ridge's (an 8-connected crest); multifractal
//! noise below the prominence threshold fades in over 4 cells away from
//! both. Every cell is a pure function of its position.

use super::rivers::{cdt, dedup, RiverNetwork, RiverOptions, MAX_VERTICES};
use super::terrain::TerrainOptions;
use super::tin::Tin;
use super::tree_synth::SynthTree;
use crate::error::{Error, Result};
use crate::oro::stats::SplitMix64;
use crate::raster::{AnyGrid, Crs, DType, GeoRef, Grid, RasterInfo, RasterSource, Window};
use crate::synth::Fbm;
use rayon::prelude::*;
use spade::Triangulation;

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
}

/// Poisson-disk samples of radius `r` over [0, wm) x [0, hm), away from the
/// points of `avoid` by `r_avoid`. Deterministic for a seed.
fn poisson(wm: f64, hm: f64, r: f64, seed: u64, avoid: &PointGrid, r_avoid: f64) -> Vec<[f64; 2]> {
    let gs = r / std::f64::consts::SQRT_2;
    let gw = ((wm / gs).ceil() as usize).max(1);
    let gh = ((hm / gs).ceil() as usize).max(1);
    let mut grid = vec![u32::MAX; gw * gh];
    let mut out: Vec<[f64; 2]> = Vec::new();
    let mut rng = SplitMix64(seed ^ 0x706f_6973_736f_6e00);
    for gy in 0..gh {
        for gx in 0..gw {
            for _ in 0..4 {
                let x = (gx as f64 + rng.unit()) * gs;
                let y = (gy as f64 + rng.unit()) * gs;
                if x >= wm || y >= hm {
                    continue;
                }
                let mut ok = true;
                'n: for yy in gy.saturating_sub(2)..(gy + 3).min(gh) {
                    for xx in gx.saturating_sub(2)..(gx + 3).min(gw) {
                        let j = grid[yy * gw + xx];
                        if j != u32::MAX {
                            let q = out[j as usize];
                            if (q[0] - x).hypot(q[1] - y) < r {
                                ok = false;
                                break 'n;
                            }
                        }
                    }
                }
                if ok && !avoid.any_within(x, y, r_avoid) {
                    grid[gy * gw + gx] = out.len() as u32;
                    out.push([x, y]);
                    break;
                }
            }
        }
    }
    out
}

/// A ridge or river segment for the crest / channel bands and the noise fade.
#[derive(Debug, Clone, Copy)]
struct Line {
    a: [f64; 3],
    b: [f64; 3],
    ridge: bool,
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

/// Bucket side of the raster indices, cells.
const BUCKET_CELLS: f64 = 8.0;

/// The paper's terrain model of a divide tree: a [`RasterSource`] (f32).
pub struct TinTerrain {
    info: RasterInfo,
    cell: f64,
    tin: Tin,
    rivers: RiverNetwork,
    lines: Vec<Line>,
    lb: f64,
    lnx: usize,
    lny: usize,
    lstart: Vec<u32>,
    lids: Vec<u32>,
    band: f64,
    noise: Option<(Fbm, f64)>,
    n_samples: usize,
    dropped: usize,
}

impl TinTerrain {
    /// Build rivers, samples and the TIN of `tree`.
    pub fn new(tree: &SynthTree, opts: &TerrainOptions) -> Result<TinTerrain> {
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
        let n_est = wm * hm / (lambda * lambda) * 0.9;
        if n_est > MAX_VERTICES {
            return Err(Error::invalid(format!(
                "terrain: about {:.0} M samples at spacing λ = {lambda} m is too many; give a larger --spacing or --terrain tents",
                n_est / 1e6
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
        let ridges = rivers.ridges.clone();
        let ridges = &ridges;
        let np = tree.peaks.len();

        // Samples and their elevations.
        let river_grid = PointGrid::new(
            rivers.nodes.iter().map(|n| [n.x, n.y]).collect(),
            lambda,
            wm,
            hm,
        );
        let mut occupied: Vec<[f64; 2]> = ridges.pts.iter().map(|p| [p[0], p[1]]).collect();
        occupied.extend_from_slice(&river_grid.pts);
        let occ = PointGrid::new(occupied, lambda, wm, hm);
        let samples = poisson(wm, hm, lambda, tree.seed, &occ, 0.4 * lambda);
        drop(occ);
        // Skeleton TIN of ridges, rivers and frame: its barycentric value is
        // the flank between them (no interior extremum by construction).
        let n_ridge = ridges.pts.len();
        let mut all: Vec<[f64; 3]> = ridges.pts.clone();
        all.extend(rivers.nodes.iter().map(|n| [n.x, n.y, n.z]));
        all.extend_from_slice(&rivers.frame);
        let s0 = all.len();
        let mut edges: Vec<[u32; 2]> = ridges.segs.clone();
        for (i, n) in rivers.nodes.iter().enumerate() {
            if let Some(d) = n.down {
                edges.push([(n_ridge + i) as u32, n_ridge as u32 + d]);
            }
        }
        let skeleton = {
            let (uniq, map) = dedup(&all);
            let e: Vec<[u32; 2]> = edges
                .iter()
                .map(|e| [map[e[0] as usize], map[e[1] as usize]])
                .collect();
            let (t, _) = cdt(&uniq, &e)?;
            let tris: Vec<[u32; 3]> = t
                .inner_faces()
                .map(|f| f.vertices().map(|v| v.fix().index() as u32))
                .collect();
            drop(t);
            Tin::new(
                uniq.iter().map(|p| [p[0], p[1]]).collect(),
                uniq.iter().map(|p| p[2]).collect(),
                tris,
                [0.0, 0.0, wm, hm],
                BUCKET_CELLS * cell,
            )?
        };
        // Valley floors: within w = w₁ (A / 1 km²)^0.4 of a river the flank
        // eases down to the river's elevation.
        let far = 50.0 * lambda;
        let sample_z: Vec<f64> = samples
            .par_iter()
            .map(|s| {
                let zl = skeleton.value(s[0], s[1]);
                let zl = if zl.is_finite() { zl } else { floor };
                let Some((i, dr)) = river_grid.nearest(s[0], s[1], far) else {
                    return zl;
                };
                let n = &rivers.nodes[i];
                let w = opts.valley_width * (n.area_m2.max(0.0) / 1e6).powf(0.4);
                let u = if w > 0.0 { (dr / w).min(1.0) } else { 1.0 };
                let f = u * u * (3.0 - 2.0 * u);
                if zl > n.z {
                    n.z + (zl - n.z) * f
                } else {
                    zl
                }
            })
            .collect();
        drop(skeleton);

        // Final TIN: ridges (peaks first), rivers, frame, samples.
        all.extend(samples.iter().zip(&sample_z).map(|(s, &z)| [s[0], s[1], z]));
        let (uniq, map) = dedup(&all);
        // Kind of each unique vertex: 0 peak, 1 other ridge, 2 river/frame, 3 sample.
        let mut kind = vec![3u8; uniq.len()];
        for (i, &m) in map.iter().enumerate().rev() {
            kind[m as usize] = if i < np {
                0
            } else if i < n_ridge {
                1
            } else if i < s0 {
                2
            } else {
                3
            };
        }
        let edges: Vec<[u32; 2]> = edges
            .iter()
            .map(|e| [map[e[0] as usize], map[e[1] as usize]])
            .collect();
        let (t, dropped) = cdt(&uniq, &edges)?;
        let nv = uniq.len();
        // Vertex adjacency (CSR) for the sample fixes.
        let mut nb_start = vec![0u32; nv + 1];
        let mut nb: Vec<u32> = Vec::with_capacity(6 * nv);
        for v in t.vertices() {
            for e in v.out_edges() {
                nb.push(e.to().fix().index() as u32);
            }
            nb_start[v.fix().index() + 1] = nb.len() as u32;
        }
        let tris: Vec<[u32; 3]> = t
            .inner_faces()
            .map(|f| f.vertices().map(|v| v.fix().index() as u32))
            .collect();
        drop(t);
        let mut z: Vec<f64> = uniq.iter().map(|p| p[2]).collect();
        let nbs = |v: usize| &nb[nb_start[v] as usize..nb_start[v + 1] as usize];
        let nn = rivers.nodes.len();
        let mut has_up = vec![false; nn];
        for n in &rivers.nodes {
            if let Some(d) = n.down {
                has_up[d as usize] = true;
            }
        }
        let range = |z: &[f64], v: usize| {
            let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
            for &u in nbs(v) {
                lo = lo.min(z[u as usize]);
                hi = hi.max(z[u as usize]);
            }
            (lo, hi)
        };
        for round in 0..8 {
            if round < 7 {
                // No sample is an extremum of the TIN.
                for v in 0..nv {
                    if kind[v] != 3 {
                        continue;
                    }
                    let (lo, hi) = range(&z, v);
                    if hi > lo && (z[v] >= hi || z[v] <= lo) {
                        z[v] = 0.5 * (lo + hi);
                    }
                }
                // No river source is a maximum: lower it (a river may only
                // go down: its bound holds) and keep its river non-increasing.
                for i in 0..nn {
                    if has_up[i] || rivers.nodes[i].down.is_none() {
                        continue;
                    }
                    let v = map[n_ridge + i] as usize;
                    let (lo, hi) = range(&z, v);
                    if hi > lo && z[v] >= hi {
                        z[v] = 0.5 * (lo + hi);
                        let mut j = i;
                        while let Some(d) = rivers.nodes[j].down {
                            let (a, b) = (
                                map[n_ridge + j] as usize,
                                map[n_ridge + d as usize] as usize,
                            );
                            if z[b] <= z[a] {
                                break;
                            }
                            z[b] = z[a];
                            j = d as usize;
                        }
                    }
                }
            }
            // No sample next to a peak reaches it.
            for v in 0..nv {
                if kind[v] != 0 {
                    continue;
                }
                let zp = z[v];
                for &u in nbs(v) {
                    let u = u as usize;
                    if kind[u] == 3 && z[u] >= zp {
                        z[u] = zp - 0.5 * thr.max(1.0);
                    }
                }
            }
        }
        for (i, n) in rivers.nodes.iter_mut().enumerate() {
            n.z = z[map[n_ridge + i] as usize];
        }

        let xy: Vec<[f64; 2]> = uniq.iter().map(|p| [p[0], p[1]]).collect();
        let lb = BUCKET_CELLS * cell;
        let tin = Tin::new(xy, z, tris, [0.0, 0.0, wm, hm], lb)?;

        // Ridge and river lines, bucketed with the fade reach.
        let mut lines: Vec<Line> = ridges
            .segs
            .iter()
            .map(|s| Line {
                a: ridges.pts[s[0] as usize],
                b: ridges.pts[s[1] as usize],
                ridge: true,
            })
            .collect();
        for n in &rivers.nodes {
            if let Some(d) = n.down {
                let m = &rivers.nodes[d as usize];
                lines.push(Line {
                    a: [n.x, n.y, n.z],
                    b: [m.x, m.y, m.z],
                    ridge: false,
                });
            }
        }
        let band = 0.55 * cell;
        let reach = CHANNEL_BAND.max(0.55) * cell + 4.0 * cell;
        let lnx = ((wm / lb).ceil() as usize).max(1);
        let lny = ((hm / lb).ceil() as usize).max(1);
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
        let georef = GeoRef::north_up(0.0, hm, cell, Crs::default());
        let dropped = dropped + rivers.dropped_ridges;
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
            tin,
            rivers,
            lines,
            lb,
            lnx,
            lny,
            lstart,
            lids,
            band,
            noise,
            n_samples: samples.len(),
            dropped,
        })
    }

    /// The river network (vector) the terrain was built on.
    pub fn rivers(&self) -> &RiverNetwork {
        &self.rivers
    }

    /// The TIN (vertices, elevations, triangles).
    pub fn tin(&self) -> &Tin {
        &self.tin
    }

    /// Number of Poisson-disk samples.
    pub fn n_samples(&self) -> usize {
        self.n_samples
    }

    /// Ridge or river segments the triangulations could not keep (crossings).
    pub fn dropped_constraints(&self) -> usize {
        self.dropped
    }

    /// Elevation of the cell centre (col + ½, row + ½).
    #[inline]
    fn cell_value(&self, col: usize, row: usize) -> f64 {
        let c = self.cell;
        let (x, y) = ((col as f64 + 0.5) * c, (row as f64 + 0.5) * c);
        let mut v = self.tin.value(x, y);
        let bx = ((x / self.lb) as usize).min(self.lnx - 1);
        let by = ((y / self.lb) as usize).min(self.lny - 1);
        let b = by * self.lnx + bx;
        let (mut crest, mut chan, mut dmin) = (f64::NEG_INFINITY, f64::INFINITY, f64::INFINITY);
        for &i in &self.lids[self.lstart[b] as usize..self.lstart[b + 1] as usize] {
            let l = &self.lines[i as usize];
            let (d, zl) = l.probe(x, y);
            dmin = dmin.min(d);
            if l.ridge {
                if d <= self.band {
                    crest = crest.max(zl);
                }
            } else if d <= CHANNEL_BAND * c {
                chan = chan.min(zl);
            }
        }
        v = v.min(chan).max(crest);
        if let Some((fbm, amp)) = &self.noise {
            let t = ((dmin - self.band) / (4.0 * c)).clamp(0.0, 1.0);
            let wgt = t * t * (3.0 - 2.0 * t);
            if wgt > 0.0 {
                v += amp * wgt * fbm.sample(col as f64 + 0.5, row as f64 + 0.5);
            }
        }
        v
    }

    /// The window (x0, y0, w, h) in cells, row-major.
    pub fn fill_window(&self, x0: usize, y0: usize, w: usize, h: usize) -> Vec<f32> {
        let mut out = Vec::with_capacity(w * h);
        for r in y0..y0 + h {
            for c in x0..x0 + w {
                out.push(self.cell_value(c, r) as f32);
            }
        }
        out
    }

    /// The whole terrain in memory (rows computed in parallel).
    pub fn render(&self) -> Grid<f32> {
        let (w, h) = (self.info.width, self.info.height);
        let rows: Vec<Vec<f32>> = (0..h)
            .into_par_iter()
            .map(|r| self.fill_window(0, r, w, 1))
            .collect();
        let data: Vec<f32> = rows.into_iter().flatten().collect();
        Grid::from_vec(w, h, data).unwrap_or_else(|_| Grid::new(w, h, 0.0))
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
        let data = self.fill_window(x0, y0, win.w, win.h);
        Ok(AnyGrid::F32(Grid::from_vec(win.w, win.h, data)?))
    }
}
