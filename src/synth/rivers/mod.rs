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

mod poisson;
mod terrain;
pub use poisson::poisson_disc;
pub use terrain::RiverTerrain;

use super::noise::Fbm;
use super::tectonic::PointIndex;
use crate::error::{Error, Result};
use crate::raster::GeoRef;
use serde::{Deserialize, Serialize};
use spade::{DelaunayTriangulation, Point2, Triangulation};
use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// Where the land is.
#[derive(Debug, Clone, PartialEq)]
pub enum LandMask {
    /// Land where `fbm.sample(p) + falloff(p) > threshold`; the falloff
    /// (0 inside, down to −1.5 at the raster edge over the outer 15 %) keeps
    /// the edge in the sea.
    Noise { fbm: Fbm, threshold: f64 },
    /// Land inside these rings (pixel coordinates; even-odd).
    Rings(Vec<Vec<[f64; 2]>>),
}

/// Parameters (lengths in cells, slopes in metres per metre). As keys
/// (serde) the fields are kebab-case, each missing one takes its default,
/// and the land mask is no key (a caller builds it, from a map or noise).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields, default)]
pub struct RiverParams {
    /// Seed of the nodes and the growth jitter.
    pub seed: u64,
    /// Poisson-disc spacing of the nodes (cells, >= 2).
    pub radius: f64,
    #[serde(skip)]
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

#[cfg(test)]
mod tests {
    use super::terrain::Channel;
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
