//! Ridge networks: ridges of the divide tree (steepest-ascent paths from each
//! key saddle to the peaks on both sides), their hierarchy (longest-path
//! levels and Strahler orders), and PPA ridges from the DEM alone.
//!
//! Divide-tree ridges: for every key saddle of a kept peak, the two
//! steepest-ascent paths of [`super::links`] (into the losing and the winning
//! component). An ascent that ends on a peak pruned from the tree is
//! continued through that peak's own key saddle, so kept peaks stay
//! connected. Each merge joins two components that were disjoint, so the
//! network (peaks and saddles as nodes, ascent paths as edges) is a forest.
//!
//! Hierarchy: (1) longest-path levels: in each tree the longest path (by
//! length in metres) is level 1; every branch left hanging from a levelled
//! path gets, along its own longest path from the attachment node, the next
//! level, and so on — the longest-path ordering of ridge networks of Rak et
//! al. 2019 (the ridge analogue of Hack's stream order). (2) Strahler orders
//! (Strahler 1957, "Quantitative analysis of watershed geomorphology") of
//! the tree rooted at its highest peak: leaves 1, a node takes the largest
//! order of its children, +1 when two or more children share it; an edge
//! carries the order of its lower end. This is the topological ordering
//! that Scherler & Schwanghart 2020 ("Drainage divide networks – Part 1",
//! Earth Surface Dynamics 8) apply to divide networks, here without their
//! junction-specific refinements.
//!
//! PPA: Chang, Song & Hsu 1998, "Automatic extraction of ridge and valley
//! axes using the profile recognition and polygon-breaking algorithm",
//! Computers & Geosciences 24(1). A cell is a candidate if, along one of the
//! four profiles through it (E–W, N–S and the diagonals), a lower cell lies
//! within `half_window` cells on both sides. Candidate 8-neighbours are
//! joined by segments weighted by the sum of their elevations; polygon
//! breaking (removing the lowest segment of every closed loop) is done as a
//! maximum spanning forest (Kruskal), the MST formulation of Bangay, de Bruyn
//! & Glass 2010 ("Minimum spanning trees for valley and ridge
//! characterization in digital elevation maps", AFRIGRAPH). Branch reduction:
//! in each tree rooted at one end of its longest path, side branches shorter
//! than `min_branch` cells are removed (recursively, so the main axis is never
//! eroded).

use super::links::Links;
use super::metrics::{check_dims, tree_index, PlanarFrame};
use super::regions::NONE;
use super::tree::DivideTree;
use crate::error::{Error, Result};
use crate::io::geojson::GeoJsonCoords;
use crate::raster::{GeoRef, Grid, UnionFind};
use serde::{Deserialize, Serialize};
use serde_json::{json, Value};
use std::collections::HashMap;
use std::path::Path;

/// A node of the ridge network.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RidgeNode {
    pub col: u32,
    pub row: u32,
    pub elevation: f32,
    /// Index into the tree's peaks for a kept peak; None for saddles and
    /// for pruned peaks the network passes through.
    pub peak: Option<usize>,
    pub is_saddle: bool,
}

/// A ridge segment: steepest ascent from saddle node `a` to peak node `b`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RidgeEdge {
    pub a: usize,
    pub b: usize,
    /// Cells (col, row) from the saddle to the peak; consecutive cells may
    /// be apart across flat regions (draw straight lines between them).
    pub path: Vec<(u32, u32)>,
    pub length_m: f64,
    /// Longest-path level (1 = main ridge).
    pub level: u32,
    /// Strahler order.
    pub order: u32,
}

/// The ridge network of a divide tree.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RidgeNetwork {
    pub width: usize,
    pub height: usize,
    pub nodes: Vec<RidgeNode>,
    pub edges: Vec<RidgeEdge>,
}

/// Ridges of `tree` (built from `dem`, possibly pruned): see the module doc.
pub fn divide_tree_ridges(
    tree: &DivideTree,
    dem: &Grid<f32>,
    georef: &GeoRef,
) -> Result<RidgeNetwork> {
    let links = Links::new(dem)?;
    check_dims(tree, links.reg.width, links.reg.height)?;
    let idx = tree_index(tree, &links);
    let w = links.reg.width as u32;
    let frame = PlanarFrame::new(georef, links.reg.height);
    let mut nodes: Vec<RidgeNode> = Vec::new();
    let mut peak_node: HashMap<u32, usize> = HashMap::new();
    let mut edges: Vec<RidgeEdge> = Vec::new();
    let mut queue: Vec<u32> = Vec::new();
    let mut queued = vec![false; links.events.len()];
    for p in &tree.peaks {
        if p.key_saddle.is_none() {
            continue;
        }
        let r = links.region_of(p.row * w + p.col);
        if r == NONE {
            continue;
        }
        let e = links.lost_at[r as usize];
        if e != NONE && !queued[e as usize] {
            queued[e as usize] = true;
            queue.push(e);
        }
    }
    let cell = |c: u32| (c % w, c / w);
    let mut qi = 0;
    while qi < queue.len() {
        let ev = links.events[queue[qi] as usize];
        qi += 1;
        let srep = links.reg.rep(ev.saddle as usize);
        let (sc, sr) = cell(srep);
        let sn = nodes.len();
        nodes.push(RidgeNode {
            col: sc,
            row: sr,
            elevation: links.reg.elev[ev.saddle as usize],
            peak: None,
            is_saddle: true,
        });
        for entry in [ev.loser_entry, ev.winner_entry] {
            let (cells, pr) = links.ascent_path(entry);
            let pn = *peak_node.entry(pr).or_insert_with(|| {
                let (c, r) = cell(links.reg.rep(pr as usize));
                nodes.push(RidgeNode {
                    col: c,
                    row: r,
                    elevation: links.reg.elev[pr as usize],
                    peak: (idx[pr as usize] != NONE).then(|| idx[pr as usize] as usize),
                    is_saddle: false,
                });
                nodes.len() - 1
            });
            if idx[pr as usize] == NONE {
                let e = links.lost_at[pr as usize];
                if e != NONE && !queued[e as usize] {
                    queued[e as usize] = true;
                    queue.push(e);
                }
            }
            let mut path = vec![(sc, sr)];
            path.extend(cells.iter().map(|&c| cell(c)));
            path.dedup();
            let mut length_m = 0.0;
            for pair in path.windows(2) {
                let (x0, y0) = frame.xy(pair[0].0 as f64, pair[0].1 as f64);
                let (x1, y1) = frame.xy(pair[1].0 as f64, pair[1].1 as f64);
                length_m += (x1 - x0).hypot(y1 - y0);
            }
            edges.push(RidgeEdge {
                a: sn,
                b: pn,
                path,
                length_m,
                level: 0,
                order: 0,
            });
        }
    }
    let pairs: Vec<(usize, usize, f64)> = edges.iter().map(|e| (e.a, e.b, e.length_m)).collect();
    let levels = longest_path_levels(nodes.len(), &pairs)?;
    // Strahler: root each tree at its highest node.
    let elev: Vec<f64> = nodes.iter().map(|n| n.elevation as f64).collect();
    let orders = strahler_orders(nodes.len(), &pairs, &elev)?;
    for (e, (l, o)) in edges.iter_mut().zip(levels.into_iter().zip(orders)) {
        e.level = l;
        e.order = o;
    }
    Ok(RidgeNetwork {
        width: links.reg.width,
        height: links.reg.height,
        nodes,
        edges,
    })
}

/// Adjacency lists of an undirected graph; errors if it has a cycle.
fn forest(n: usize, edges: &[(usize, usize, f64)]) -> Result<Vec<Vec<(usize, usize)>>> {
    let mut adj = vec![Vec::new(); n];
    let mut uf = UnionFind::<usize>::new(n);
    for (i, &(a, b, _)) in edges.iter().enumerate() {
        if a >= n || b >= n {
            return Err(Error::invalid(format!(
                "ridge edge {i} names node {} of {n}",
                a.max(b)
            )));
        }
        if !uf.join(a, b) {
            return Err(Error::invalid(format!(
                "ridge edges form a cycle at edge {i}"
            )));
        }
        adj[a].push((b, i));
        adj[b].push((a, i));
    }
    Ok(adj)
}

/// Scratch for repeated BFS over the components of one forest: visit
/// stamps instead of clearing, so each component costs only its own size.
struct Walk {
    stamp: Vec<u32>,
    cur: u32,
    /// Position of each node in the order of the latest BFS that reached it.
    pos: Vec<usize>,
}

impl Walk {
    fn new(n: usize) -> Walk {
        Walk {
            stamp: vec![0; n],
            cur: 0,
            pos: vec![0; n],
        }
    }

    /// BFS order from `root` with each node's (parent, edge) (usize::MAX for root).
    fn bfs(
        &mut self,
        adj: &[Vec<(usize, usize)>],
        root: usize,
    ) -> (Vec<usize>, Vec<(usize, usize)>) {
        self.cur += 1;
        let mut order = vec![root];
        let mut parents = vec![(usize::MAX, usize::MAX)];
        self.stamp[root] = self.cur;
        self.pos[root] = 0;
        let mut i = 0;
        while i < order.len() {
            let u = order[i];
            i += 1;
            for &(v, e) in &adj[u] {
                if self.stamp[v] != self.cur {
                    self.stamp[v] = self.cur;
                    self.pos[v] = order.len();
                    order.push(v);
                    parents.push((u, e));
                }
            }
        }
        (order, parents)
    }
}

/// Longest-path level of every edge of a forest (edges `(a, b, length)`):
/// level 1 along the longest path of each tree, then level k + 1 along the
/// longest path of each branch hanging from a level-k path (see module doc).
/// Ties go to the smaller node or edge index. Errors on cycles.
pub fn longest_path_levels(n: usize, edges: &[(usize, usize, f64)]) -> Result<Vec<u32>> {
    let farthest_end = |walk: &mut Walk, adj: &[Vec<(usize, usize)>], start: usize| {
        // One end of the longest path: the farthest node from `start`.
        let (order, parents) = walk.bfs(adj, start);
        let mut dist = vec![0.0f64; order.len()];
        let mut best = (0.0, start);
        for (k, &v) in order.iter().enumerate().skip(1) {
            let (p, e) = parents[k];
            let d = dist[walk.pos[p]] + edges[e].2;
            dist[k] = d;
            if d > best.0 || (d == best.0 && v < best.1) {
                best = (d, v);
            }
        }
        best.1
    };
    label_trees(n, edges, farthest_end, |order, parents, pos, level| {
        // Rooted at that end; height = longest path down to a leaf.
        let mut height = vec![0.0f64; order.len()];
        let mut best_child = vec![usize::MAX; order.len()]; // position of child on the longest path
        for k in (1..order.len()).rev() {
            let (p, e) = parents[k];
            let pk = pos[p];
            let hk = height[k] + edges[e].2;
            let bc = best_child[pk];
            if bc == usize::MAX || hk > height[pk] || (hk == height[pk] && order[k] < order[bc]) {
                height[pk] = hk;
                best_child[pk] = k;
            }
        }
        // Top-down: the best child continues its parent's level; others start level + 1.
        let mut node_level = vec![1u32; order.len()];
        for k in 1..order.len() {
            let (p, e) = parents[k];
            let pk = pos[p];
            let l = if best_child[pk] == k {
                node_level[pk]
            } else {
                node_level[pk] + 1
            };
            // A root's first child is level 1; a branch from a level-l node starts at l + 1.
            node_level[k] = l;
            level[e] = l;
        }
    })
}

/// Strahler order of every edge of a forest, each tree rooted at its node of
/// highest `elev` (ties: smallest index). Errors on cycles.
pub fn strahler_orders(n: usize, edges: &[(usize, usize, f64)], elev: &[f64]) -> Result<Vec<u32>> {
    let highest = |walk: &mut Walk, adj: &[Vec<(usize, usize)>], start: usize| {
        let (comp, _) = walk.bfs(adj, start);
        *comp
            .iter()
            .max_by(|&&a, &&b| elev[a].total_cmp(&elev[b]).then(b.cmp(&a)))
            .expect("non-empty")
    };
    label_trees(n, edges, highest, |order, parents, pos, order_e| {
        let mut max_child = vec![0u32; order.len()];
        let mut count_max = vec![0u32; order.len()];
        let mut node_order = vec![0u32; order.len()];
        for k in (0..order.len()).rev() {
            node_order[k] = if max_child[k] == 0 {
                1
            } else if count_max[k] >= 2 {
                max_child[k] + 1
            } else {
                max_child[k]
            };
            if k > 0 {
                let (p, e) = parents[k];
                order_e[e] = node_order[k];
                let pk = pos[p];
                if node_order[k] > max_child[pk] {
                    max_child[pk] = node_order[k];
                    count_max[pk] = 1;
                } else if node_order[k] == max_child[pk] {
                    count_max[pk] += 1;
                }
            }
        }
    })
}

/// One label per edge of a forest (`edges` over `n` nodes; errors on
/// cycles), tree by tree: `root_of(walk, adjacency, any node of the tree)`
/// picks the tree's root, then `label(order, parents, pos, labels)` sets the
/// labels of its edges from the BFS from that root (`order`, each position's
/// (parent, edge), each node's position in `order`).
fn label_trees(
    n: usize,
    edges: &[(usize, usize, f64)],
    mut root_of: impl FnMut(&mut Walk, &[Vec<(usize, usize)>], usize) -> usize,
    mut label: impl FnMut(&[usize], &[(usize, usize)], &[usize], &mut [u32]),
) -> Result<Vec<u32>> {
    let adj = forest(n, edges)?;
    let mut labels = vec![0u32; edges.len()];
    let mut seen = vec![false; n];
    let mut walk = Walk::new(n);
    for start in 0..n {
        if seen[start] || adj[start].is_empty() {
            continue;
        }
        let root = root_of(&mut walk, &adj, start);
        let (order, parents) = walk.bfs(&adj, root);
        for &v in &order {
            seen[v] = true;
        }
        label(&order, &parents, &walk.pos, &mut labels);
    }
    Ok(labels)
}

/// Draw the cells of a path (straight 8-connected lines between points).
fn draw(path: &[(u32, u32)], mut f: impl FnMut(usize, usize)) {
    if let Some(&(x, y)) = path.first() {
        f(x as usize, y as usize);
    }
    for pair in path.windows(2) {
        let (x0, y0) = (pair[0].0 as i64, pair[0].1 as i64);
        let (x1, y1) = (pair[1].0 as i64, pair[1].1 as i64);
        let n = (x1 - x0).abs().max((y1 - y0).abs());
        for s in 1..=n {
            let t = s as f64 / n as f64;
            let x = x0 + ((x1 - x0) as f64 * t).round() as i64;
            let y = y0 + ((y1 - y0) as f64 * t).round() as i64;
            f(x as usize, y as usize);
        }
    }
}

impl RidgeNetwork {
    /// Raster of ridge cells: the lowest longest-path level crossing each
    /// cell (1 = main ridge, capped at 254), 0 elsewhere.
    pub fn rasterise_levels(&self) -> Grid<u8> {
        self.rasterise(|e| e.level)
    }

    /// Raster of the highest Strahler order crossing each cell, 0 elsewhere.
    pub fn rasterise_orders(&self) -> Grid<u8> {
        let mut g = Grid::new(self.width, self.height, 0u8);
        for e in &self.edges {
            let v = e.order.min(254) as u8;
            draw(&e.path, |x, y| {
                if x < self.width && y < self.height && g.get(x, y) < v {
                    g.set(x, y, v);
                }
            });
        }
        g
    }

    fn rasterise(&self, key: impl Fn(&RidgeEdge) -> u32) -> Grid<u8> {
        let mut g = Grid::new(self.width, self.height, 0u8);
        for e in &self.edges {
            let v = key(e).clamp(1, 254) as u8;
            draw(&e.path, |x, y| {
                if x < self.width && y < self.height {
                    let c = g.get(x, y);
                    if c == 0 || v < c {
                        g.set(x, y, v);
                    }
                }
            });
        }
        g
    }

    /// GeoJSON: one LineString per edge (cell centres, in the coordinates
    /// `coords` says: WGS 84 lon/lat by default, RFC 7946; see
    /// [`crate::io::geojson`]) with saddle and peak elevations, length
    /// (metres), level and order.
    pub fn write_geojson(&self, path: &Path, coords: &GeoJsonCoords) -> Result<()> {
        let num = |v: f64| {
            serde_json::Number::from_f64(v)
                .map(Value::Number)
                .unwrap_or(Value::Null)
        };
        let feats: Vec<Value> = self
            .edges
            .iter()
            .map(|e| {
                let coords: Vec<Value> = e
                    .path
                    .iter()
                    .map(|&(c, r)| {
                        let [x, y] = coords.pixel(c as f64 + 0.5, r as f64 + 0.5);
                        json!([num(x), num(y)])
                    })
                    .collect();
                let (a, b) = (&self.nodes[e.a], &self.nodes[e.b]);
                json!({
                    "type": "Feature",
                    "geometry": {"type": "LineString", "coordinates": coords},
                    "properties": {
                        "saddle_elevation": num(a.elevation as f64),
                        "peak_elevation": num(b.elevation as f64),
                        "peak": b.peak,
                        "length_m": num(e.length_m),
                        "level": e.level,
                        "order": e.order,
                    }
                })
            })
            .collect();
        let v = coords.collection(feats);
        let bytes = serde_json::to_vec(&v)
            .map_err(|e| Error::invalid(format!("ridges do not serialise: {e}")))?;
        crate::io::atomic::write_file_atomic(path, &bytes)
    }
}

/// Options of [`ppa_ridges`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PpaOptions {
    /// Profile half-length in cells (profiles span 2·half_window + 1 cells).
    pub half_window: usize,
    /// Side branches shorter than this (cells) are removed.
    pub min_branch: usize,
}

impl Default for PpaOptions {
    fn default() -> Self {
        PpaOptions {
            half_window: 3,
            min_branch: 10,
        }
    }
}

/// Bytes of working memory per cell of [`ppa_ridges`] (edge list and forest).
pub const PPA_BYTES_PER_CELL: u64 = 100;

/// PPA ridge cells of `dem` (NaN = nodata): 1 ridge, 0 not (see module doc).
pub fn ppa_ridges(dem: &Grid<f32>, opts: &PpaOptions) -> Result<Grid<u8>> {
    if opts.half_window == 0 || opts.half_window > 1000 {
        return Err(Error::invalid(format!(
            "PPA: the profile half-window must be 1..=1000 cells, got {}",
            opts.half_window
        )));
    }
    let (w, h) = (dem.width(), dem.height());
    let n = w * h;
    if n >= u32::MAX as usize {
        return Err(Error::invalid(format!(
            "PPA: a {w} x {h} grid is too large for the in-memory ridge extraction"
        )));
    }
    let z = dem.data();
    let k = opts.half_window as i64;
    let at = |x: i64, y: i64| -> f32 {
        if x < 0 || y < 0 || x >= w as i64 || y >= h as i64 {
            f32::NAN
        } else {
            z[y as usize * w + x as usize]
        }
    };
    // 1. Profile recognition.
    let mut cand = vec![false; n];
    for y in 0..h as i64 {
        for x in 0..w as i64 {
            let zc = at(x, y);
            if zc.is_nan() {
                continue;
            }
            for (dx, dy) in [(1i64, 0i64), (0, 1), (1, 1), (1, -1)] {
                let lower = |s: i64| (1..=k).any(|t| at(x + s * t * dx, y + s * t * dy) < zc);
                if lower(1) && lower(-1) {
                    cand[y as usize * w + x as usize] = true;
                    break;
                }
            }
        }
    }
    // 2. Segments between candidate neighbours (E, S, SE, SW), heaviest first.
    let mut segs: Vec<(f64, u32, u32)> = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let a = y * w + x;
            if !cand[a] {
                continue;
            }
            for (dx, dy) in [(1i64, 0i64), (0, 1), (1, 1), (-1, 1)] {
                let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                if nx < 0 || nx >= w as i64 || ny >= h as i64 {
                    continue;
                }
                let b = ny as usize * w + nx as usize;
                if cand[b] {
                    segs.push((z[a] as f64 + z[b] as f64, a as u32, b as u32));
                }
            }
        }
    }
    segs.sort_by(|p, q| q.0.total_cmp(&p.0).then(p.1.cmp(&q.1)).then(p.2.cmp(&q.2)));
    // 3. Polygon breaking = maximum spanning forest.
    let mut uf = UnionFind::<u32>::new(n);
    let mut tree_edges: Vec<(usize, usize, f64)> = Vec::new();
    // Node id of each candidate cell in the forest (u32::MAX: not in it).
    let mut id: Vec<u32> = vec![u32::MAX; n];
    let mut cells: Vec<u32> = Vec::new();
    for &(_, a, b) in &segs {
        if !uf.join(a, b) {
            continue;
        }
        for c in [a, b] {
            if id[c as usize] == u32::MAX {
                id[c as usize] = cells.len() as u32;
                cells.push(c);
            }
        }
        tree_edges.push((id[a as usize] as usize, id[b as usize] as usize, 1.0));
    }
    drop(segs);
    drop(uf);
    drop(id);
    // 4. Branch reduction on each tree rooted at an end of its longest path.
    let levels = longest_path_levels(cells.len(), &tree_edges)?;
    let mut keep_edge = vec![true; tree_edges.len()];
    prune_branches(
        cells.len(),
        &tree_edges,
        &levels,
        opts.min_branch,
        &mut keep_edge,
    )?;
    let mut out = Grid::new(w, h, 0u8);
    for (e, &(a, b, _)) in tree_edges.iter().enumerate() {
        if keep_edge[e] {
            for c in [cells[a], cells[b]] {
                out.data_mut()[c as usize] = 1;
            }
        }
    }
    Ok(out)
}

/// Remove side branches shorter than `min_len` edges: the edges of one
/// longest-path level that hang from a kept path form a branch whose length
/// is its longest path; a branch shorter than `min_len` goes with everything
/// hanging from it. Level-1 paths (each tree's longest path) are kept whole
/// when at least `min_len` long, else the whole tree goes.
fn prune_branches(
    n: usize,
    edges: &[(usize, usize, f64)],
    levels: &[u32],
    min_len: usize,
    keep: &mut [bool],
) -> Result<()> {
    let adj = forest(n, edges)?;
    let mut seen = vec![false; n];
    let mut walk = Walk::new(n);
    for start in 0..n {
        if seen[start] || adj[start].is_empty() {
            continue;
        }
        // Root at a node on a level-1 edge that is a path end (degree 1 in level-1 edges).
        let (comp, _) = walk.bfs(&adj, start);
        let root = comp
            .iter()
            .copied()
            .find(|&v| adj[v].iter().filter(|&&(_, e)| levels[e] == 1).count() == 1)
            .unwrap_or(start);
        let (order, parents) = walk.bfs(&adj, root);
        for &v in &order {
            seen[v] = true;
        }
        let pos = &walk.pos;
        // Branch length: the run of same-level edges starting below a level change.
        // Compute for each node the longest same-level chain below it.
        let mut chain = vec![0usize; order.len()];
        for k in (1..order.len()).rev() {
            let (p, e) = parents[k];
            let pk = pos[p];
            // Continue a chain only along edges of the same level as the parent's incoming edge.
            let below = chain[k] + 1;
            let pe_level = if pk == 0 { 1 } else { levels[parents[pk].1] };
            if levels[e] == pe_level && below > chain[pk] {
                chain[pk] = below;
            }
        }
        // Top-down: an edge that starts a new level (branch start) is kept
        // if the branch it starts is long enough and its parent is kept.
        let mut node_kept = vec![true; order.len()];
        let total: usize = chain[0];
        if total < min_len {
            for &v in &order {
                for &(_, e) in &adj[v] {
                    keep[e] = false;
                }
            }
            continue;
        }
        for k in 1..order.len() {
            let (p, e) = parents[k];
            let pk = pos[p];
            let pe_level = if pk == 0 { 1 } else { levels[parents[pk].1] };
            let starts_branch = levels[e] != pe_level;
            let ok = node_kept[pk] && (!starts_branch || chain[k] + 1 >= min_len);
            node_kept[k] = ok;
            keep[e] = ok;
        }
    }
    Ok(())
}
