//! River-network terrain, after Génevaux, Galin, Guérin, Peytavie & Beneš
//! (2013), "Terrain generation using procedural models based on hydrology",
//! ACM TOG 32(4) (§4: the river network is grown upstream from river mouths
//! over a set of nodes, then node elevations follow from the water each
//! river carries).
//!
//! Global graph (small: about area / r² nodes):
//! 1. **Land mask** from seeded fBm with a falloff toward the raster edge,
//!    or from coastline polygons ([`LandMask`]).
//! 2. **Nodes**: Poisson-disc samples at spacing r (Bridson 2007, "Fast
//!    Poisson disk sampling in arbitrary dimensions", SIGGRAPH sketches),
//!    seeded; a last pass adds a node wherever a point of the raster is more
//!    than 2r from every node, so every cell is within 2.5r of a node.
//! 3. **Delaunay** triangulation of the nodes (spade).
//! 4. **Base shape draining to the sea**: nodes outside the mask that are
//!    connected (through such nodes) to the raster edge are the sea; every
//!    other node is land (enclosed "lakes" are land). Land nodes next to
//!    the sea are river mouths.
//! 5. **River trees** grow upstream from all mouths at once, in order of a
//!    path cost: claiming node w from v (which flows to u) costs
//!    `|vw| · (1 + inertia · (1 − cos θ)/2) · (1 + jitter · ξ_w)`, θ the turn
//!    between u→v and v→w (directional inertia), ξ_w a seeded hash in 0..1.
//!    A node is claimed once, by the cheapest path, so rivers never re-join
//!    and never split downstream: every land node has exactly one parent.
//! 6. **Water volumes**: each node's drainage area (its share of the land,
//!    raster area / nodes, plus everything upstream).
//! 7. **Heights**: each node is higher than its parent by `|vp| · S`, with
//!    `S = channel_slope · (A / 1 km²)^(−concavity)` (more water, gentler
//!    river: Flint's law) clamped to `min_slope..max_slope` (the cap plays the
//!    role of a talus angle, as in thermal erosion). Heights strictly
//!    increase upstream.
//!
//! **Rasterisation (tileable)**: each tree edge (node → parent, a Delaunay
//! edge) is drawn as an 8-connected digital line whose cells carry heights
//! strictly decreasing downstream (linear along the edge; a cell on several
//! lines keeps the lowest). The terrain is the lower envelope of cones
//! standing on these channel cells, `h(c) = min_n H(n) + s_n · |c − n|` over
//! channel cells within R = ceil(2.5 r) + 1 cells, where the lateral slope
//! `s_n` of an edge is the steepest of the two Delaunay triangles beside it
//! (clamped to `hill_slope..max_slope`): the triangulation sets both the
//! channel heights and the hillslopes. Sea cells (nearest node in the sea)
//! are flat at `−sea_depth`.
//!
//! Why not barycentric interpolation of the triangles: a draining TIN has no
//! continuous pits, but sampled on a grid it does — beside a gently sloping
//! valley edge with steep sides, no D8 neighbour of a valley cell need be
//! lower. The envelope cannot make pits: a cell whose minimising source n is
//! another cell has a D8 neighbour strictly closer to n (step by the signs of
//! n − c: the squared distance drops by at least 1), hence strictly lower; a
//! channel cell that is its own minimiser has a strictly lower next cell on
//! its line; lines end in the sea. So every land cell drains to the sea
//! (tested with the Priority-Flood fill: no cell raised). Each cell is a pure
//! function of the global network, so tiles equal the whole raster bit for
//! bit; a tile gathers the edges near it from a bucket index.

use super::noise::Fbm;
use super::tectonic::PointIndex;
use crate::error::{Error, Result};
use crate::raster::{AnyGrid, Crs, DType, GeoRef, Grid, RasterInfo, RasterSource, Window};
use spade::{DelaunayTriangulation, Point2, Triangulation};
use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// Where the land is.
#[derive(Debug, Clone)]
pub enum LandMask {
    /// Land where `fbm.sample(p) + falloff(p) > threshold`; the falloff
    /// (0 inside, down to −1.5 at the raster edge over the outer 15 %) keeps
    /// the edge in the sea.
    Noise { fbm: Fbm, threshold: f64 },
    /// Land inside these rings (pixel coordinates; even-odd).
    Rings(Vec<Vec<[f64; 2]>>),
}

/// Parameters (lengths in cells, slopes in metres per metre).
#[derive(Debug, Clone)]
pub struct RiverParams {
    pub seed: u64,
    /// Poisson-disc spacing of the nodes (cells, >= 2).
    pub radius: f64,
    pub mask: LandMask,
    /// Directional inertia (0 = none).
    pub inertia: f64,
    /// Random perturbation of the growth costs (0..1).
    pub jitter: f64,
    /// River slope at a drainage area of 1 km².
    pub channel_slope: f64,
    /// Exponent θ of the slope–area law.
    pub concavity: f64,
    /// Smallest river slope (keeps heights strictly increasing upstream).
    pub min_slope: f64,
    /// Largest slope (river and hillslope cap).
    pub max_slope: f64,
    /// Smallest hillslope beside a river.
    pub hill_slope: f64,
    /// Sea floor (m below 0).
    pub sea_depth: f64,
}

impl Default for RiverParams {
    fn default() -> Self {
        RiverParams {
            seed: 42,
            radius: 12.0,
            mask: LandMask::Noise {
                fbm: Fbm {
                    seed: 42,
                    octaves: 6,
                    wavelength: 600.0,
                    warp: 0.0,
                    ..Fbm::default()
                },
                threshold: -0.1,
            },
            inertia: 1.0,
            jitter: 0.5,
            channel_slope: 0.05,
            concavity: 0.45,
            min_slope: 0.0005,
            max_slope: 0.7,
            hill_slope: 0.05,
            sea_depth: 20.0,
        }
    }
}

/// Marker for "no parent" (sea nodes).
pub const NO_PARENT: u32 = u32::MAX;

/// The global river graph.
#[derive(Debug, Clone)]
pub struct RiverNetwork {
    /// Node positions (pixel coordinates).
    pub nodes: Vec<[f64; 2]>,
    /// True for sea nodes.
    pub sea: Vec<bool>,
    /// Downstream node of each land node (a land node or, at a mouth, a sea
    /// node); [`NO_PARENT`] for sea nodes.
    pub parent: Vec<u32>,
    /// Drainage area of each node (m²; 0 for sea nodes).
    pub area: Vec<f64>,
    /// Node heights (m; `−sea_depth` for sea nodes).
    pub height: Vec<f64>,
    /// Lateral slope beside each node's edge to its parent (m/m).
    pub lateral: Vec<f64>,
    /// Delaunay neighbours (sorted) of each node.
    pub neighbours: Vec<Vec<u32>>,
}

struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        // SplitMix64 (Steele, Lea & Flood 2014).
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        hash(self.0)
    }
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn hash(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// Most nodes a network may have.
pub const MAX_NODES: usize = 4_000_000;

/// Poisson-disc samples in [0, w) x [0, h) with spacing r (Bridson 2007,
/// 30 candidates per active sample), then gap filling so that every point
/// of the rectangle is within 2.5 r of a sample.
pub fn poisson_disc(w: f64, h: f64, r: f64, seed: u64) -> Vec<[f64; 2]> {
    let cs = r / std::f64::consts::SQRT_2;
    let gw = (w / cs).ceil() as usize;
    let gh = (h / cs).ceil() as usize;
    let mut grid = vec![u32::MAX; gw * gh];
    let mut pts: Vec<[f64; 2]> = Vec::new();
    let mut rng = Rng(seed ^ 0x005e_ed0f_d15c);
    let cell =
        |p: [f64; 2]| ((p[0] / cs) as usize).min(gw - 1) + ((p[1] / cs) as usize).min(gh - 1) * gw;
    let free = |pts: &[[f64; 2]], grid: &[u32], p: [f64; 2], rr: f64| -> bool {
        let (cx, cy) = ((p[0] / cs) as i64, (p[1] / cs) as i64);
        let reach = (rr / cs).ceil() as i64;
        for y in (cy - reach).max(0)..=(cy + reach).min(gh as i64 - 1) {
            for x in (cx - reach).max(0)..=(cx + reach).min(gw as i64 - 1) {
                let i = grid[y as usize * gw + x as usize];
                if i != u32::MAX {
                    let q = pts[i as usize];
                    if (q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2) < rr * rr {
                        return false;
                    }
                }
            }
        }
        true
    };
    let first = [rng.unit() * w, rng.unit() * h];
    grid[cell(first)] = 0;
    pts.push(first);
    let mut active = vec![0u32];
    while !active.is_empty() {
        let k = (rng.next() % active.len() as u64) as usize;
        let base = pts[active[k] as usize];
        let mut found = false;
        for _ in 0..30 {
            let a = rng.unit() * std::f64::consts::TAU;
            let d = r * (1.0 + rng.unit());
            let q = [base[0] + d * a.cos(), base[1] + d * a.sin()];
            if q[0] >= 0.0 && q[1] >= 0.0 && q[0] < w && q[1] < h && free(&pts, &grid, q, r) {
                grid[cell(q)] = pts.len() as u32;
                active.push(pts.len() as u32);
                pts.push(q);
                found = true;
                break;
            }
        }
        if !found {
            active.swap_remove(k);
        }
    }
    // Gap filling: a grid-cell centre with no sample within 2r gets one (it is
    // then more than r from all others). Grid cells have half-diagonal r/2.
    for gy in 0..gh {
        for gx in 0..gw {
            let c = [
                ((gx as f64 + 0.5) * cs).min(w * 0.999_999),
                ((gy as f64 + 0.5) * cs).min(h * 0.999_999),
            ];
            if grid[cell(c)] == u32::MAX && free(&pts, &grid, c, 2.0 * r) {
                grid[cell(c)] = pts.len() as u32;
                pts.push(c);
            }
        }
    }
    pts
}

#[derive(PartialEq)]
struct Cand(f64, u32, u32);
impl Eq for Cand {}
impl PartialOrd for Cand {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Cand {
    // Min-heap on (cost, node, from).
    fn cmp(&self, o: &Self) -> Ordering {
        o.0.total_cmp(&self.0)
            .then(o.1.cmp(&self.1))
            .then(o.2.cmp(&self.2))
    }
}

impl RiverNetwork {
    /// Build the network of a `width x height` raster with cells of `cell_m`
    /// metres.
    pub fn build(
        width: usize,
        height: usize,
        cell_m: f64,
        p: &RiverParams,
    ) -> Result<RiverNetwork> {
        if !(p.radius.is_finite() && p.radius >= 2.0 && p.radius <= 4096.0) {
            return Err(Error::invalid(
                "river node spacing (--radius) must be 2..4096 cells",
            ));
        }
        if width == 0 || height == 0 || width > 1 << 30 || height > 1 << 30 {
            return Err(Error::invalid(
                "river terrain size must be 1..2^30 cells a side",
            ));
        }
        if !(cell_m.is_finite() && cell_m > 0.0) {
            return Err(Error::invalid(
                "cell size must be a positive number of metres",
            ));
        }
        let est = width as f64 * height as f64 / (p.radius * p.radius);
        if est > MAX_NODES as f64 / 2.0 {
            return Err(Error::invalid(format!(
                "about {est:.0} river nodes: too many for the global graph (at most {}); increase --radius",
                MAX_NODES / 2
            )));
        }
        let finite = |v: f64| v.is_finite();
        let ok = finite(p.inertia)
            && p.inertia >= 0.0
            && (0.0..=1.0).contains(&p.jitter)
            && finite(p.channel_slope)
            && p.channel_slope > 0.0
            && finite(p.concavity)
            && (0.0..=2.0).contains(&p.concavity)
            && finite(p.min_slope)
            && p.min_slope > 0.0
            && finite(p.max_slope)
            && p.max_slope >= p.min_slope
            && p.max_slope <= 10.0
            && finite(p.hill_slope)
            && p.hill_slope > 0.0
            && finite(p.sea_depth)
            && (0.0..1e5).contains(&p.sea_depth);
        if !ok {
            return Err(Error::invalid(
                "river parameters out of range: inertia >= 0, jitter 0..1, slopes > 0 with min <= max <= 10, concavity 0..2, sea depth 0..1e5",
            ));
        }
        if p.min_slope * cell_m < 1e-3 {
            return Err(Error::invalid(
                "min slope x cell size must be at least 1 mm per cell (heights are stored as f32)",
            ));
        }
        if let LandMask::Noise { fbm, threshold } = &p.mask {
            fbm.validate()?;
            if !threshold.is_finite() {
                return Err(Error::invalid("land threshold must be finite"));
            }
        }
        let (w, h) = (width as f64, height as f64);
        let nodes = poisson_disc(w, h, p.radius, p.seed);
        let n = nodes.len();
        let mut tri: DelaunayTriangulation<Point2<f64>> = DelaunayTriangulation::new();
        for (i, q) in nodes.iter().enumerate() {
            let hnd = tri
                .insert(Point2::new(q[0], q[1]))
                .map_err(|e| Error::invalid(format!("Delaunay insertion failed: {e:?}")))?;
            if hnd.index() != i {
                return Err(Error::invalid(
                    "Delaunay triangulation merged two river nodes",
                ));
            }
        }
        let mut neighbours = vec![Vec::new(); n];
        for e in tri.undirected_edges() {
            let [a, b] = e.vertices();
            let (a, b) = (a.fix().index(), b.fix().index());
            neighbours[a].push(b as u32);
            neighbours[b].push(a as u32);
        }
        for nb in neighbours.iter_mut() {
            nb.sort_unstable();
        }

        // Land mask at the nodes; sea = off-mask nodes connected to the edge.
        let on_land: Vec<bool> = match &p.mask {
            LandMask::Noise { fbm, threshold } => nodes
                .iter()
                .map(|q| {
                    let e =
                        (q[0].min(w - q[0]).min(q[1]).min(h - q[1]) / (0.15 * w.min(h))).min(1.0);
                    fbm.sample(q[0], q[1]) + 1.5 * (e - 1.0) > *threshold
                })
                .collect(),
            LandMask::Rings(r) => nodes
                .iter()
                .map(|&q| super::vector::inside_rings(r, q))
                .collect(),
        };
        let index = PointIndex::new(nodes.clone(), width, height);
        let mut sea = vec![false; n];
        let mut queue = Vec::new();
        let border = (0..width)
            .flat_map(|x| [[x as f64 + 0.5, 0.5], [x as f64 + 0.5, h - 0.5]])
            .chain((0..height).flat_map(|y| [[0.5, y as f64 + 0.5], [w - 0.5, y as f64 + 0.5]]));
        for c in border {
            let i = index.nearest(c).0;
            if !on_land[i] && !sea[i] {
                sea[i] = true;
                queue.push(i);
            }
        }
        if queue.is_empty() {
            return Err(Error::invalid(
                "the land mask leaves no sea at the raster edge; rivers need a sea to drain to (raise the land threshold or give a smaller coastline)",
            ));
        }
        while let Some(i) = queue.pop() {
            for &j in &neighbours[i] {
                let j = j as usize;
                if !on_land[j] && !sea[j] {
                    sea[j] = true;
                    queue.push(j);
                }
            }
        }
        if sea.iter().all(|&s| s) {
            return Err(Error::invalid(
                "the land mask has no land (lower the land threshold or check the coastline)",
            ));
        }

        // River trees grown upstream from the mouths.
        let dist = |a: usize, b: usize| {
            ((nodes[a][0] - nodes[b][0]).powi(2) + (nodes[a][1] - nodes[b][1]).powi(2)).sqrt()
        };
        let mut parent = vec![NO_PARENT; n];
        let mut order: Vec<u32> = Vec::new();
        let mut heap = BinaryHeap::new();
        for m in 0..n {
            if sea[m] {
                continue;
            }
            // The nearest sea neighbour is the mouth's outlet.
            let best = neighbours[m]
                .iter()
                .filter(|&&j| sea[j as usize])
                .map(|&j| (dist(m, j as usize), j))
                .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            if let Some((d, j)) = best {
                heap.push(Cand(d, m as u32, j));
            }
        }
        let jitter =
            |i: usize| (hash(p.seed ^ hash(i as u64 ^ 0x71e7)) >> 11) as f64 / (1u64 << 53) as f64;
        let mut cost = vec![0.0; n];
        while let Some(Cand(c, v, from)) = heap.pop() {
            let v = v as usize;
            if parent[v] != NO_PARENT {
                continue;
            }
            parent[v] = from;
            cost[v] = c;
            order.push(v as u32);
            let u = from as usize;
            let dir = [nodes[v][0] - nodes[u][0], nodes[v][1] - nodes[u][1]];
            let dl = (dir[0] * dir[0] + dir[1] * dir[1]).sqrt();
            for &wn in &neighbours[v] {
                let wi = wn as usize;
                if sea[wi] || parent[wi] != NO_PARENT {
                    continue;
                }
                let step = [nodes[wi][0] - nodes[v][0], nodes[wi][1] - nodes[v][1]];
                let sl = (step[0] * step[0] + step[1] * step[1]).sqrt();
                let cos = (dir[0] * step[0] + dir[1] * step[1]) / (dl * sl);
                let k = sl * (1.0 + p.inertia * (1.0 - cos) / 2.0) * (1.0 + p.jitter * jitter(wi));
                heap.push(Cand(c + k, wn, v as u32));
            }
        }
        // Every land component touches the sea (the graph is connected), so
        // every land node has been claimed.
        if let Some(v) = (0..n).find(|&v| !sea[v] && parent[v] == NO_PARENT) {
            return Err(Error::invalid(format!(
                "river node {v} was not reached (internal error)"
            )));
        }

        // Volumes (drainage areas): children are claimed after their parents.
        let share = w * h * cell_m * cell_m / n as f64;
        let mut area = vec![0.0; n];
        for &v in order.iter().rev() {
            let v = v as usize;
            area[v] += share;
            let u = parent[v] as usize;
            if !sea[u] {
                area[u] += area[v];
            }
        }
        // Heights: parents before children.
        let mut height_m = vec![-p.sea_depth; n];
        for &v in &order {
            let v = v as usize;
            let u = parent[v] as usize;
            let s = (p.channel_slope * (area[v] / 1e6).powf(-p.concavity))
                .clamp(p.min_slope, p.max_slope);
            let base = if sea[u] { 0.0 } else { height_m[u] };
            height_m[v] = base + dist(v, u) * cell_m * s;
        }
        // Lateral slopes from the triangles beside each tree edge.
        let mut lateral = vec![0.0f64; n];
        for f in tri.inner_faces() {
            let vs = f.vertices().map(|v| v.fix().index());
            let pt = |i: usize| [nodes[i][0] * cell_m, nodes[i][1] * cell_m, height_m[i]];
            let (a, b, c) = (pt(vs[0]), pt(vs[1]), pt(vs[2]));
            let (ux, uy, uz) = (b[0] - a[0], b[1] - a[1], b[2] - a[2]);
            let (vx, vy, vz) = (c[0] - a[0], c[1] - a[1], c[2] - a[2]);
            let (nx, ny, nz) = (uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx);
            if nz == 0.0 {
                continue;
            }
            let g = (nx * nx + ny * ny).sqrt() / nz.abs();
            for (i, j) in [(0, 1), (1, 2), (2, 0)] {
                let (x, y) = (vs[i], vs[j]);
                for (child, par) in [(x, y), (y, x)] {
                    if parent[child] == par as u32 {
                        lateral[child] = lateral[child].max(g);
                    }
                }
            }
        }
        for l in lateral.iter_mut() {
            *l = l.clamp(p.hill_slope, p.max_slope);
        }
        Ok(RiverNetwork {
            nodes,
            sea,
            parent,
            area,
            height: height_m,
            lateral,
            neighbours,
        })
    }
}

/// The river trees as a GeoJSON FeatureCollection: one LineString per tree
/// edge (node → downstream node) in the CRS of `georef`, with the node's
/// drainage area (km²) and the two heights (m).
pub fn network_geojson(net: &RiverNetwork, georef: &GeoRef) -> serde_json::Value {
    let xy = |q: [f64; 2]| {
        let (x, y) = georef.pixel_to_map(q[0], q[1]);
        serde_json::json!([x, y])
    };
    let features: Vec<serde_json::Value> = (0..net.nodes.len())
        .filter(|&v| !net.sea[v])
        .map(|v| {
            let u = net.parent[v] as usize;
            serde_json::json!({
                "type": "Feature",
                "properties": {
                    "kind": "river",
                    "node": v,
                    "area_km2": net.area[v] / 1e6,
                    "height": net.height[v],
                    "downstream_height": net.height[u],
                },
                "geometry": {"type": "LineString", "coordinates": [xy(net.nodes[v]), xy(net.nodes[u])]},
            })
        })
        .collect();
    serde_json::json!({"type": "FeatureCollection", "features": features})
}

/// A channel source: a digital line from `a` to `b` (cells) with heights
/// `ha` → `hb` and cone slope `s` (metres per cell).
#[derive(Debug, Clone, Copy)]
struct Channel {
    a: [i64; 2],
    b: [i64; 2],
    ha: f64,
    hb: f64,
    s: f64,
}

impl Channel {
    fn steps(&self) -> i64 {
        (self.b[0] - self.a[0])
            .abs()
            .max((self.b[1] - self.a[1]).abs())
    }
    /// Cell i (0..=steps) and its height; integer rounding keeps every
    /// step 8-connected.
    #[inline]
    fn cell(&self, i: i64, k: i64) -> ([i64; 2], f64) {
        if k == 0 {
            return (self.a, self.ha.min(self.hb));
        }
        let (dx, dy) = (self.b[0] - self.a[0], self.b[1] - self.a[1]);
        let x = self.a[0] + (2 * i * dx + k).div_euclid(2 * k);
        let y = self.a[1] + (2 * i * dy + k).div_euclid(2 * k);
        let t = i as f64 / k as f64;
        ([x, y], self.ha + (self.hb - self.ha) * t)
    }
}

/// River-network terrain as a tileable raster source (f32 metres).
pub struct RiverTerrain {
    net: RiverNetwork,
    channels: Vec<Channel>,
    /// Channel ids per bucket of `bs` cells (listed where within R).
    buckets: Vec<Vec<u32>>,
    bs: i64,
    gw: usize,
    reach: i64,
    /// Distances 0..=reach: `dist[dy * (reach+1) + dx]`.
    dist: Vec<f64>,
    nearest: PointIndex,
    sea_depth: f64,
    info: RasterInfo,
}

impl RiverTerrain {
    /// Rasteriser of `net` on a `width x height` raster with `cell_m` metre
    /// cells, georeferenced by `georef` (a local metric CRS if `None`).
    pub fn new(
        net: RiverNetwork,
        width: usize,
        height: usize,
        cell_m: f64,
        radius: f64,
        sea_depth: f64,
        georef: Option<GeoRef>,
    ) -> Result<Self> {
        let reach = (2.5 * radius).ceil() as i64 + 1;
        let cellpos = |q: [f64; 2]| {
            [
                (q[0].floor() as i64).clamp(0, width as i64 - 1),
                (q[1].floor() as i64).clamp(0, height as i64 - 1),
            ]
        };
        let mut channels = Vec::new();
        for v in 0..net.nodes.len() {
            if net.sea[v] {
                let c = cellpos(net.nodes[v]);
                channels.push(Channel {
                    a: c,
                    b: c,
                    ha: -sea_depth,
                    hb: -sea_depth,
                    s: net.lateral[v].max(1e-3) * cell_m,
                });
            } else {
                let u = net.parent[v] as usize;
                channels.push(Channel {
                    a: cellpos(net.nodes[v]),
                    b: cellpos(net.nodes[u]),
                    ha: net.height[v],
                    hb: net.height[u],
                    s: net.lateral[v] * cell_m,
                });
            }
        }
        let bs = (reach * 2).max(32);
        let gw = (width as i64 + bs - 1) / bs;
        let gh = (height as i64 + bs - 1) / bs;
        let mut buckets = vec![Vec::new(); (gw * gh) as usize];
        for (id, c) in channels.iter().enumerate() {
            let x0 = ((c.a[0].min(c.b[0]) - reach).div_euclid(bs)).max(0);
            let x1 = ((c.a[0].max(c.b[0]) + reach).div_euclid(bs)).min(gw - 1);
            let y0 = ((c.a[1].min(c.b[1]) - reach).div_euclid(bs)).max(0);
            let y1 = ((c.a[1].max(c.b[1]) + reach).div_euclid(bs)).min(gh - 1);
            for y in y0..=y1 {
                for x in x0..=x1 {
                    buckets[(y * gw + x) as usize].push(id as u32);
                }
            }
        }
        let r1 = (reach + 1) as usize;
        let dist = (0..r1 * r1)
            .map(|i| (((i / r1) * (i / r1) + (i % r1) * (i % r1)) as f64).sqrt())
            .collect();
        let georef = georef.unwrap_or_else(|| {
            GeoRef::north_up(0.0, height as f64 * cell_m, cell_m, Crs::default())
        });
        let nearest = PointIndex::new(net.nodes.clone(), width, height);
        Ok(RiverTerrain {
            net,
            channels,
            buckets,
            bs,
            gw: gw as usize,
            reach,
            dist,
            nearest,
            sea_depth,
            info: RasterInfo {
                width,
                height,
                dtype: DType::F32,
                georef,
                block: (256, 256),
                path: "<rivers>".into(),
            },
        })
    }

    /// The network it rasterises.
    pub fn network(&self) -> &RiverNetwork {
        &self.net
    }

    /// True if cell (x, y) is sea (its nearest node is a sea node).
    pub fn is_sea(&self, x: usize, y: usize) -> bool {
        self.net.sea[self.nearest.nearest([x as f64 + 0.5, y as f64 + 0.5]).0]
    }

    fn render(&self, win: Window) -> Vec<f32> {
        let (wx, wy, ww, wh) = (win.x, win.y, win.w as i64, win.h as i64);
        let r = self.reach;
        let mut best = vec![f64::INFINITY; (ww * wh) as usize];
        let gh = self.buckets.len() / self.gw;
        let bx0 = (wx.div_euclid(self.bs)).max(0) as usize;
        let bx1 = ((wx + ww - 1).div_euclid(self.bs) as usize).min(self.gw - 1);
        let by0 = (wy.div_euclid(self.bs)).max(0) as usize;
        let by1 = ((wy + wh - 1).div_euclid(self.bs) as usize).min(gh - 1);
        let mut ids: Vec<u32> = Vec::new();
        for by in by0..=by1 {
            for bx in bx0..=bx1 {
                ids.extend_from_slice(&self.buckets[by * self.gw + bx]);
            }
        }
        ids.sort_unstable();
        ids.dedup();
        let r1 = (r + 1) as usize;
        for &id in &ids {
            let ch = self.channels[id as usize];
            let k = ch.steps();
            for i in 0..=k {
                let (c, hc) = ch.cell(i, k);
                // Rows of the window within reach of this cell.
                let ya = (c[1] - r).max(wy);
                let yb = (c[1] + r).min(wy + wh - 1);
                if ya > yb || c[0] + r < wx || c[0] - r > wx + ww - 1 {
                    continue;
                }
                for y in ya..=yb {
                    let dy = (y - c[1]).unsigned_abs() as usize;
                    // Columns with dx² + dy² <= r².
                    let mut span = (((r * r) as f64 - (dy * dy) as f64).sqrt()) as i64;
                    while (span + 1) * (span + 1) + (dy * dy) as i64 <= r * r {
                        span += 1;
                    }
                    while span >= 0 && span * span + (dy * dy) as i64 > r * r {
                        span -= 1;
                    }
                    let xa = (c[0] - span).max(wx);
                    let xb = (c[0] + span).min(wx + ww - 1);
                    if xa > xb {
                        continue;
                    }
                    let row = ((y - wy) * ww) as usize;
                    let drow = &self.dist[dy * r1..dy * r1 + r1];
                    for x in xa..=xb {
                        let dx = (x - c[0]).unsigned_abs() as usize;
                        let v = hc + ch.s * drow[dx];
                        let o = &mut best[row + (x - wx) as usize];
                        if v < *o {
                            *o = v;
                        }
                    }
                }
            }
        }
        let mut out = vec![0f32; best.len()];
        for y in 0..wh {
            for x in 0..ww {
                let i = (y * ww + x) as usize;
                out[i] = if self.is_sea((wx + x) as usize, (wy + y) as usize) {
                    -self.sea_depth as f32
                } else {
                    best[i] as f32
                };
            }
        }
        out
    }
}

impl RasterSource for RiverTerrain {
    fn info(&self) -> &RasterInfo {
        &self.info
    }
    fn read_native(&self, win: Window) -> Result<AnyGrid> {
        Ok(AnyGrid::F32(Grid::from_vec(
            win.w,
            win.h,
            self.render(win),
        )?))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn poisson_disc_spacing_and_coverage() {
        let (w, h, r) = (300.0, 200.0, 9.0);
        let pts = poisson_disc(w, h, r, 3);
        for (i, a) in pts.iter().enumerate() {
            assert!(a[0] >= 0.0 && a[1] >= 0.0 && a[0] < w && a[1] < h);
            for b in &pts[i + 1..] {
                assert!((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) >= r * r);
            }
        }
        // Brute-force coverage on a fine lattice: within 2.5 r of a node.
        for y in 0..100 {
            for x in 0..150 {
                let q = [x as f64 * 2.0 + 0.5, y as f64 * 2.0 + 0.5];
                let d = pts
                    .iter()
                    .map(|p| (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2))
                    .fold(f64::INFINITY, f64::min);
                assert!(d.sqrt() <= 2.5 * r, "{q:?} {}", d.sqrt());
            }
        }
        assert_eq!(pts, poisson_disc(w, h, r, 3));
    }

    #[test]
    fn digital_lines_are_8_connected() {
        for (a, b) in [
            ([0, 0], [7, 3]),
            ([5, 9], [1, 0]),
            ([3, 3], [3, 10]),
            ([10, 2], [0, 2]),
            ([4, 4], [-3, 11]),
        ] {
            let ch = Channel {
                a,
                b,
                ha: 10.0,
                hb: 1.0,
                s: 1.0,
            };
            let k = ch.steps();
            let mut prev = ch.cell(0, k);
            assert_eq!(prev.0, a);
            for i in 1..=k {
                let c = ch.cell(i, k);
                assert!((c.0[0] - prev.0[0]).abs() <= 1 && (c.0[1] - prev.0[1]).abs() <= 1);
                assert!(c.1 < prev.1);
                prev = c;
            }
            assert_eq!(prev.0, b);
        }
    }
}
