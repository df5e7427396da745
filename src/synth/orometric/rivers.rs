//! River network as the dual of the divide tree (Argudo, Galin, Peytavie,
//! Paris, Gain & Guérin 2019, "Orometry-based terrain analysis and
//! synthesis", ACM TOG 38(6), §6).
//!
//! 1. The ridges of the tree (peak → saddle → peak) are refined into
//!    polylines with vertices every λ and planar jitter; peaks and saddles
//!    sit at the centres of their cells so a raster reads them exactly.
//! 2. A constrained Delaunay triangulation (spade) of the ridge vertices and
//!    a frame of border points keeps the ridge segments as edges. Its dual
//!    (one node per triangle, the discrete Voronoi vertices of the ridge
//!    points) with the dual edges that cross ridges removed is the river
//!    graph: a ridge tree never encloses a region, so every triangle reaches
//!    the border. Drainage directions are the shortest-path tree (Dijkstra)
//!    from the triangles that touch the border (the outlets).
//! 3. Drainage area A: the triangle areas accumulated downstream (the
//!    outlets together drain exactly the domain).
//! 4. Elevations: each river node gets an upper bound: the margin below
//!    the lowest ridge vertex of its triangle and below the pass height on
//!    the tree of each pair of ridge vertices its river separates (the two
//!    ends of each non-ridge edge, [`super::minimax`]), so no path across a
//!    river can make a pass higher than the tree's saddles (the river graph
//!    is the dual of the ridge triangulation minus the ridges, a spanning
//!    forest of the faces: every non-ridge edge between ridge vertices is
//!    crossed by a river); from the outlets upward the elevation grows with the
//!    equilibrium channel slope S = s₁ · (A / 1 km²)^−0.45 (Flint 1974,
//!    "Stream gradient as a function of order, magnitude, and discharge",
//!    Water Resour. Res. 10(5)) capped by the bound; a final downstream pass
//!    makes every river non-increasing to its outlet.
//! 5. Rivers are polylines triangle incentre → middle of the shared edge →
//!    downstream incentre (they stay inside the two triangles, so
//!    they never cross a ridge), refined to λ.

use super::minimax::{PassHeights, RidgeAnchor};
use super::tree_synth::SynthTree;
use crate::error::{Error, Result};
use crate::oro::stats::SplitMix64;
use spade::{ConstrainedDelaunayTriangulation, Point2, Triangulation};
use std::cmp::Reverse;
use std::collections::{BinaryHeap, HashMap};

/// Most vertices the triangulations may hold (memory: ~200 B each).
pub const MAX_VERTICES: f64 = 40e6;

/// Options of the river network.
#[derive(Debug, Clone)]
pub struct RiverOptions {
    /// Refinement spacing λ of ridges and rivers, metres.
    pub spacing_m: f64,
    /// Planar jitter of refined ridge vertices, fraction of λ.
    pub jitter: f64,
    /// Outlet elevation (the domain border).
    pub floor: f64,
    /// A river node lies at least this far below the ridge vertices of its triangle (m).
    pub margin: f64,
    /// Channel slope at 1 km² of drainage area (m/m).
    pub river_slope: f64,
}

/// Refined ridges: vertices (x, y, z in metres, x east and y south from the
/// top-left corner) and segments. Peaks come first (index = peak index),
/// then saddles (index = peaks + saddle index), then the refinement.
#[derive(Debug, Clone, Default)]
pub struct Ridges {
    pub pts: Vec<[f64; 3]>,
    pub segs: Vec<[u32; 2]>,
    /// Where each point lies on the tree (parallel to `pts`).
    pub anchor: Vec<RidgeAnchor>,
    /// The saddle of the ridge each segment belongs to (parallel to `segs`).
    pub seg_saddle: Vec<u32>,
}

/// A vertex of the refined river network.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RiverNode {
    pub x: f64,
    pub y: f64,
    pub z: f64,
    /// Drainage area through this point, m².
    pub area_m2: f64,
    /// Next node downstream (None: an outlet on the border, or a sink).
    pub down: Option<u32>,
}

/// The river network of a divide tree (see the module doc).
#[derive(Debug, Clone)]
pub struct RiverNetwork {
    pub ridges: Ridges,
    pub nodes: Vec<RiverNode>,
    /// Border frame points (x, y, z = floor).
    pub frame: Vec<[f64; 3]>,
    /// Ridge segments the triangulation could not keep (they crossed another).
    pub dropped_ridges: usize,
    /// Whether each ridge segment is a constraint of the triangulations
    /// (parallel to `ridges.segs`; false for the dropped ones, so every
    /// triangulation of the terrain, global or per super-tile, sees the same
    /// non-crossing constraints and does not depend on insertion order).
    pub ridge_constrained: Vec<bool>,
    /// Triangles that could not reach the border (should be 0).
    pub sinks: usize,
}

/// Centre of the cell holding coordinate `v` (clamped into `n` cells).
fn snap(v: f64, cell: f64, n: usize) -> f64 {
    ((v / cell).floor().clamp(0.0, (n - 1) as f64) + 0.5) * cell
}

/// Refine the ridges of `tree` to spacing `lambda` with planar jitter.
pub fn refine_ridges(tree: &SynthTree, lambda: f64, jitter: f64) -> Result<Ridges> {
    let cell = tree.cell;
    let lambda = lambda.max(cell);
    let total = tree.ridge_length();
    if total / lambda + 2.0 * tree.saddles.len() as f64 > MAX_VERTICES {
        return Err(Error::invalid(
            "terrain: the ridges would need over 40 M vertices; give a larger --spacing",
        ));
    }
    let mut pts: Vec<[f64; 3]> = Vec::new();
    let mut anchor: Vec<RidgeAnchor> = Vec::new();
    let snapped =
        |x: f64, y: f64, z: f64| [snap(x, cell, tree.width), snap(y, cell, tree.height), z];
    for (i, p) in tree.peaks.iter().enumerate() {
        anchor.push(RidgeAnchor::Peak(i as u32));
        pts.push(snapped(p.x, p.y, p.elevation));
    }
    for (k, s) in tree.saddles.iter().enumerate() {
        anchor.push(RidgeAnchor::Saddle(k as u32));
        pts.push(snapped(s.x, s.y, s.elevation));
    }
    let (lo, hx, hy) = (
        0.5 * cell,
        (tree.width as f64 - 0.5) * cell,
        (tree.height as f64 - 0.5) * cell,
    );
    let np = tree.peaks.len();
    let mut rng = SplitMix64(tree.seed ^ 0x7269_7665_7273_0001);
    let mut segs = Vec::new();
    let mut seg_saddle = Vec::new();
    for (k, s) in tree.saddles.iter().enumerate() {
        let sv = (np + k) as u32;
        for &pi in &s.peaks {
            let [ax, ay, az] = pts[pi];
            let [bx, by, bz] = pts[sv as usize];
            let (dx, dy) = (bx - ax, by - ay);
            let l = dx.hypot(dy);
            let m = ((l / lambda).ceil() as usize).max(1);
            let amp = jitter * (l / m as f64);
            let (nx, ny) = if l > 0.0 {
                (-dy / l, dx / l)
            } else {
                (0.0, 0.0)
            };
            let mut prev = pi as u32;
            for i in 1..m {
                let t = i as f64 / m as f64;
                let off = (rng.unit() - 0.5) * 2.0 * amp;
                pts.push([
                    (ax + t * dx + off * nx).clamp(lo, hx),
                    (ay + t * dy + off * ny).clamp(lo, hy),
                    az + t * (bz - az),
                ]);
                anchor.push(RidgeAnchor::Half(pi as u32, k as u32));
                let cur = (pts.len() - 1) as u32;
                segs.push([prev, cur]);
                seg_saddle.push(k as u32);
                prev = cur;
            }
            segs.push([prev, sv]);
            seg_saddle.push(k as u32);
        }
    }
    Ok(Ridges {
        pts,
        segs,
        anchor,
        seg_saddle,
    })
}

/// Border frame: points every ≈ λ along the four sides, corners included.
pub fn frame_points(wm: f64, hm: f64, lambda: f64, z: f64) -> Vec<[f64; 3]> {
    let nx = ((wm / lambda).ceil() as usize).max(1);
    let ny = ((hm / lambda).ceil() as usize).max(1);
    let mut f = Vec::with_capacity(2 * (nx + ny));
    for i in 0..nx {
        f.push([wm * i as f64 / nx as f64, 0.0, z]);
        f.push([wm * (nx - i) as f64 / nx as f64, hm, z]);
    }
    for j in 0..ny {
        f.push([wm, hm * j as f64 / ny as f64, z]);
        f.push([0.0, hm * (ny - j) as f64 / ny as f64, z]);
    }
    f
}

/// Drop exact duplicate positions, keeping the first; returns the unique
/// points and the map old index → unique index.
pub fn dedup(pts: &[[f64; 3]]) -> (Vec<[f64; 3]>, Vec<u32>) {
    let mut seen: HashMap<(u64, u64), u32> = HashMap::with_capacity(pts.len());
    let mut uniq = Vec::with_capacity(pts.len());
    let mut map = Vec::with_capacity(pts.len());
    for p in pts {
        let key = (p[0].to_bits(), p[1].to_bits());
        let id = *seen.entry(key).or_insert_with(|| {
            uniq.push(*p);
            (uniq.len() - 1) as u32
        });
        map.push(id);
    }
    (uniq, map)
}

/// Constrained Delaunay triangulation of `pts` keeping `edges` (pairs of
/// indices into `pts`, already deduplicated); returns it and the number of
/// edges it had to drop because they crossed an earlier one.
pub fn cdt(
    pts: &[[f64; 3]],
    edges: &[[u32; 2]],
) -> Result<(ConstrainedDelaunayTriangulation<Point2<f64>>, usize)> {
    let (t, dropped) = cdt_dropping(pts, edges)?;
    Ok((t, dropped.len()))
}

/// The constrained Delaunay triangulation of the terrain's points.
pub type Cdt = ConstrainedDelaunayTriangulation<Point2<f64>>;

/// As [`cdt`], returning the edges dropped (index pairs into `pts`).
pub fn cdt_dropping(pts: &[[f64; 3]], edges: &[[u32; 2]]) -> Result<(Cdt, Vec<[usize; 2]>)> {
    let verts: Vec<Point2<f64>> = pts.iter().map(|p| Point2::new(p[0], p[1])).collect();
    let e: Vec<[usize; 2]> = edges
        .iter()
        .filter(|e| e[0] != e[1])
        .map(|e| [e[0] as usize, e[1] as usize])
        .collect();
    let mut dropped = Vec::new();
    let t = ConstrainedDelaunayTriangulation::<Point2<f64>>::try_bulk_load_cdt(verts, e, |d| {
        dropped.push(d)
    })
    .map_err(|e| Error::invalid(format!("terrain: triangulation failed ({e:?})")))?;
    if t.num_vertices() != pts.len() {
        return Err(Error::invalid(
            "terrain: duplicate vertices reached the triangulation",
        ));
    }
    Ok((t, dropped))
}

/// Ordered key of a non-negative distance.
fn key(d: f64) -> u64 {
    d.max(0.0).to_bits()
}

/// One triangle of the ridge triangulation seen as a river node.
struct Face {
    c: [f64; 2],
    area: f64,
    bound: f64,
    /// Nearest frame vertex (unique index) if the triangle touches the border.
    outlet: Option<u32>,
    /// Neighbours across non-ridge edges: (face slot, edge midpoint).
    nb: Vec<(usize, [f64; 2])>,
}

impl RiverNetwork {
    /// Build the river network of `tree` (validated by the caller).
    pub fn new(tree: &SynthTree, o: &RiverOptions) -> Result<RiverNetwork> {
        if !(o.spacing_m.is_finite() && o.spacing_m > 0.0) {
            return Err(Error::invalid("terrain: the spacing λ must be positive"));
        }
        if !(o.river_slope.is_finite() && o.river_slope >= 0.0 && o.river_slope <= 1.0) {
            return Err(Error::invalid(
                "terrain: the river slope at 1 km² must be in [0, 1]",
            ));
        }
        if !(o.margin.is_finite() && o.margin >= 0.0 && o.floor.is_finite()) {
            return Err(Error::invalid(
                "terrain: river margin and floor must be finite, margin ≥ 0",
            ));
        }
        let cell = tree.cell;
        let lambda = o.spacing_m.max(cell);
        let (wm, hm) = (tree.width as f64 * cell, tree.height as f64 * cell);
        let ridges = refine_ridges(tree, lambda, o.jitter)?;
        let frame = frame_points(wm, hm, lambda, o.floor);
        let n_ridge = ridges.pts.len();
        let mut all = ridges.pts.clone();
        all.extend_from_slice(&frame);
        let (uniq, map) = dedup(&all);
        let is_frame: Vec<bool> = {
            let mut f = vec![true; uniq.len()];
            for &m in &map[..n_ridge] {
                f[m as usize] = false;
            }
            f
        };
        let edges: Vec<[u32; 2]> = ridges
            .segs
            .iter()
            .map(|s| [map[s[0] as usize], map[s[1] as usize]])
            .collect();
        let (t, dropped_edges) = cdt_dropping(&uniq, &edges)?;
        let dropped = dropped_edges.len();
        let mut ridge_constrained = vec![true; edges.len()];
        if dropped > 0 {
            let mut of_pair: HashMap<(u32, u32), Vec<usize>> = HashMap::new();
            for (k, e) in edges.iter().enumerate() {
                of_pair
                    .entry((e[0].min(e[1]), e[0].max(e[1])))
                    .or_default()
                    .push(k);
            }
            for d in &dropped_edges {
                let (a, b) = (d[0] as u32, d[1] as u32);
                if let Some(ks) = of_pair.get(&(a.min(b), a.max(b))) {
                    for &k in ks {
                        ridge_constrained[k] = false;
                    }
                }
            }
        }
        // Where each unique ridge vertex lies on the tree (None: frame).
        let mut anchor: Vec<Option<RidgeAnchor>> = vec![None; uniq.len()];
        for (i, &m) in map[..n_ridge].iter().enumerate().rev() {
            anchor[m as usize] = Some(ridges.anchor[i]);
        }
        let passes = PassHeights::new(tree);
        let pass = |a: usize, b: usize| match (anchor[a], anchor[b]) {
            (Some(x), Some(y)) => passes.between(x, uniq[a][2], y, uniq[b][2]),
            _ => f64::INFINITY,
        };

        // Faces of the triangulation as river nodes.
        let nf_all = t.num_all_faces();
        let mut slot = vec![usize::MAX; nf_all];
        let mut faces: Vec<Face> = Vec::with_capacity(t.num_inner_faces());
        for f in t.inner_faces() {
            slot[f.fix().index()] = faces.len();
            let vs = f.vertices().map(|v| v.fix().index());
            let ps = vs.map(|v| uniq[v]);
            // Incentre: the point farthest from the three sides (at least
            // as far as the centroid from each), so a river keeps away
            // from the ridges it runs between.
            let side = |i: usize, j: usize| (ps[i][0] - ps[j][0]).hypot(ps[i][1] - ps[j][1]);
            let (la, lb, lc) = (side(1, 2), side(2, 0), side(0, 1));
            let per = la + lb + lc;
            let c = if per > 0.0 {
                [
                    (la * ps[0][0] + lb * ps[1][0] + lc * ps[2][0]) / per,
                    (la * ps[0][1] + lb * ps[1][1] + lc * ps[2][1]) / per,
                ]
            } else {
                [ps[0][0], ps[0][1]]
            };
            let area = 0.5
                * ((ps[1][0] - ps[0][0]) * (ps[2][1] - ps[0][1])
                    - (ps[2][0] - ps[0][0]) * (ps[1][1] - ps[0][1]))
                    .abs();
            let zmin = vs
                .iter()
                .filter(|&&v| !is_frame[v])
                .map(|&v| uniq[v][2])
                .fold(f64::INFINITY, f64::min);
            let bound = if zmin.is_finite() {
                o.floor.max(zmin - o.margin)
            } else {
                o.floor
            };
            let outlet = vs
                .iter()
                .filter(|&&v| is_frame[v])
                .map(|&v| {
                    let d = (uniq[v][0] - c[0]).hypot(uniq[v][1] - c[1]);
                    (key(d), v as u32)
                })
                .min()
                .map(|(_, v)| v);
            faces.push(Face {
                c,
                area,
                bound,
                outlet,
                nb: Vec::new(),
            });
        }
        for f in t.inner_faces() {
            let s = slot[f.fix().index()];
            for e in f.adjacent_edges() {
                if e.as_undirected().is_constraint_edge() {
                    continue;
                }
                // The river here separates the edge's two ridge vertices:
                // it stays below their pass height on the tree.
                let (va, vb) = (e.from().fix().index(), e.to().fix().index());
                let p = pass(va, vb) - o.margin;
                faces[s].bound = faces[s].bound.min(p.max(o.floor));
                if let Some(g) = e.rev().face().as_inner() {
                    let [a, b] = e.positions();
                    let m = [0.5 * (a.x + b.x), 0.5 * (a.y + b.y)];
                    faces[s].nb.push((slot[g.fix().index()], m));
                }
            }
        }
        drop(t);
        let nf = faces.len();

        // Drainage directions: shortest paths to the border (Dijkstra).
        const NONE: usize = usize::MAX;
        let mut dist = vec![f64::INFINITY; nf];
        let mut parent = vec![(NONE, [0.0; 2]); nf];
        let mut heap = BinaryHeap::new();
        for (i, f) in faces.iter().enumerate() {
            if let Some(v) = f.outlet {
                let p = uniq[v as usize];
                dist[i] = (p[0] - f.c[0]).hypot(p[1] - f.c[1]);
                heap.push(Reverse((key(dist[i]), i)));
            }
        }
        let mut order = Vec::with_capacity(nf);
        let mut done = vec![false; nf];
        while let Some(Reverse((_, i))) = heap.pop() {
            if done[i] {
                continue;
            }
            done[i] = true;
            order.push(i);
            let ci = faces[i].c;
            for &(g, m) in &faces[i].nb {
                if done[g] {
                    continue;
                }
                let cg = faces[g].c;
                let d = dist[i]
                    + (ci[0] - m[0]).hypot(ci[1] - m[1])
                    + (m[0] - cg[0]).hypot(m[1] - cg[1]);
                if d < dist[g] {
                    dist[g] = d;
                    parent[g] = (i, m);
                    heap.push(Reverse((key(d), g)));
                }
            }
        }
        let sinks = nf - order.len();
        for (i, d) in done.iter().enumerate() {
            if !d {
                order.push(i);
            }
        }

        // Drainage area, downstream.
        let mut area: Vec<f64> = faces.iter().map(|f| f.area).collect();
        for &i in order.iter().rev() {
            let p = parent[i].0;
            if p != NONE {
                area[p] += area[i];
            }
        }
        // Elevations: up from the outlets along the channel slope, capped by
        // the bounds; then non-increasing downstream.
        let slope = |a: f64| (o.river_slope * (a.max(1.0) / 1e6).powf(-0.45)).min(0.5);
        let mut z = vec![o.floor; nf];
        for &i in &order {
            let f = &faces[i];
            let (p, _) = parent[i];
            let (zd, d) = if p != NONE {
                (z[p], dist[i] - dist[p])
            } else if f.outlet.is_some() {
                (o.floor, dist[i])
            } else {
                (f.bound, 0.0)
            };
            z[i] = f.bound.min(zd + slope(area[i]) * d.max(0.0));
        }
        for &i in order.iter().rev() {
            let p = parent[i].0;
            if p != NONE && z[p] > z[i] {
                z[p] = z[i];
            }
        }

        // Polylines, refined to λ.
        let mut nodes: Vec<RiverNode> = faces
            .iter()
            .enumerate()
            .map(|(i, f)| RiverNode {
                x: f.c[0],
                y: f.c[1],
                z: z[i],
                area_m2: area[i],
                down: None,
            })
            .collect();
        let mut outlet_node: HashMap<u32, u32> = HashMap::new();
        for &i in &order {
            let (p, m) = parent[i];
            let (zi, ai) = (z[i], area[i]);
            // Waypoints (x, y) and the end's elevation and node.
            let (way, zend, end): (Vec<[f64; 2]>, f64, u32) = if p != NONE {
                (vec![faces[i].c, m, faces[p].c], z[p], p as u32)
            } else if let Some(v) = faces[i].outlet {
                let q = uniq[v as usize];
                let id = *outlet_node.entry(v).or_insert_with(|| {
                    nodes.push(RiverNode {
                        x: q[0],
                        y: q[1],
                        z: o.floor.min(zi),
                        area_m2: 0.0,
                        down: None,
                    });
                    (nodes.len() - 1) as u32
                });
                nodes[id as usize].z = nodes[id as usize].z.min(zi);
                nodes[id as usize].area_m2 += ai;
                (vec![faces[i].c, [q[0], q[1]]], nodes[id as usize].z, id)
            } else {
                continue;
            };
            let lens: Vec<f64> = way
                .windows(2)
                .map(|w| (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]))
                .collect();
            let total: f64 = lens.iter().sum();
            let mut prev = i as u32;
            let mut run = 0.0;
            for (k, w) in way.windows(2).enumerate() {
                let n = ((lens[k] / lambda).ceil() as usize).max(1);
                let last = k + 2 == way.len();
                for j in 1..=n {
                    if last && j == n {
                        break;
                    }
                    let t = j as f64 / n as f64;
                    let s = run + t * lens[k];
                    let frac = if total > 0.0 { s / total } else { 1.0 };
                    nodes.push(RiverNode {
                        x: w[0][0] + t * (w[1][0] - w[0][0]),
                        y: w[0][1] + t * (w[1][1] - w[0][1]),
                        z: zi + frac * (zend - zi),
                        area_m2: ai,
                        down: None,
                    });
                    let cur = (nodes.len() - 1) as u32;
                    nodes[prev as usize].down = Some(cur);
                    prev = cur;
                }
                run += lens[k];
            }
            nodes[prev as usize].down = Some(end);
        }
        Ok(RiverNetwork {
            ridges,
            nodes,
            frame,
            dropped_ridges: dropped,
            ridge_constrained,
            sinks,
        })
    }
}
