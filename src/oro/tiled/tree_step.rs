//! Pass 2 of the tiled divide tree ([`TreeStep`], halo 1): each tile's
//! descending sweep contracted to a join tree of its open pieces (final
//! peaks go straight into the summary), and the reduce that joins the tile
//! graphs by region id and sweeps them once more.

use super::super::regions::{grow, neighbours_in};
use super::super::tree::DivideTree;
use super::super::tree::EdgeConvention;
use super::assemble;
use super::bits;
use super::check_finite;
use super::first_view;
use super::key;
use super::plateau::PlateauSolution;
use super::NONE;
use super::SEA_ID;
use crate::error::Error;
use crate::error::Result;
use crate::exec::GlobalStep;
use crate::raster::perimeter_index;
use crate::raster::Adjacency;
use crate::raster::Grid;
use crate::raster::TileId;
use crate::raster::TileLayout;
use crate::raster::TileView;
use crate::raster::UnionFind;
use serde::Deserialize;
use serde::Serialize;
use std::collections::HashMap;

/// A node of a tile's contracted join tree.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct TreeNode {
    /// Region id: global index of the region's first cell, or [`SEA_ID`].
    pub id: u64,
    #[serde(with = "bits::f32s")]
    pub z: f32,
    /// Lowest elevation of the cells this node stands for (`Unknown`
    /// convention: the drop below the component's top).
    #[serde(with = "bits::f32s")]
    pub low: f32,
    /// The region touches the DEM edge or nodata.
    pub outside: bool,
    /// The region has a valid neighbour of another elevation.
    pub any_valid: bool,
    /// The region has a higher valid neighbour (in any tile): a region
    /// without one is a peak even when the sea is all it joins.
    #[serde(default)]
    pub higher: bool,
}

/// A peak whose key saddle, parent and prominence are known.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct FinalPeak {
    pub id: u64,
    #[serde(with = "bits::f32s")]
    pub z: f32,
    #[serde(with = "bits::f64s")]
    pub prominence: f64,
    /// (region id, elevation) of the key saddle.
    #[serde(with = "bits::saddle")]
    pub saddle: Option<(u64, f32)>,
    /// Region id of the prominence parent.
    pub parent: Option<u64>,
    pub on_edge: bool,
}

/// Per-tile summary of [`TreeStep`]: final peaks plus the contracted join
/// tree of the part still open (O(perimeter + open peaks)).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq, Default)]
pub struct TreeSummary {
    pub nodes: Vec<TreeNode>,
    /// Undirected edges between node region ids (tile-internal links and
    /// links across seams).
    pub edges: Vec<(u64, u64)>,
    pub peaks: Vec<FinalPeak>,
}

/// Pass 2: the divide tree across tiles (see the module docs). Holds the
/// plateau solution of pass 1, which gives open pieces their global ids.
pub struct TreeStep<'a> {
    pub convention: EdgeConvention,
    /// Drop final peaks below this prominence in the map when no peak at or
    /// above it can descend from them (see [`TreeStep::droppable`]); the
    /// result is then only right after [`DivideTree::pruned`] at the same
    /// threshold. None keeps the whole tree.
    pub min_prominence: Option<f64>,
    pub layout: TileLayout,
    pub plateaus: &'a PlateauSolution,
}

/// Component state of the per-tile sweep.
pub(super) const SEA_TOP: u32 = u32::MAX;

pub(super) const OPEN_TOP: u32 = u32::MAX - 1;

pub(super) const NO_TOP: u32 = u32::MAX - 2;

pub(super) struct Comp {
    pub(super) closed: bool,
    /// Local peak index (closed components), or SEA_TOP / OPEN_TOP / NO_TOP.
    pub(super) top: u32,
    pub(super) lowest: f32,
    /// Last node of the contracted tree in this component (open ones).
    pub(super) last: u32,
    /// Highest sweep key in the component (the sea's is above all).
    pub(super) hi: (u32, u64),
}

pub(super) struct Piece {
    pub(super) z: f32,
    pub(super) id: u64,
    pub(super) open: bool,
    pub(super) outside: bool,
    pub(super) any_valid: bool,
    /// A higher valid neighbour (core or halo).
    pub(super) higher: bool,
}

impl TreeStep<'_> {
    /// A final peak below the threshold can go at once if it has a key
    /// saddle, or under `Unknown`: then every peak below it in the tree
    /// (joined to it at a saddle at least as high as its own key saddle, or
    /// above the lowest cell of its area) has a prominence no larger, so none
    /// is kept and pruning never needs it. Peaks that merged into the sea
    /// stay: a sub-sea-level saddle below them can give a descendant more
    /// prominence than they have.
    pub(super) fn droppable(&self, p: &FinalPeak) -> bool {
        match self.min_prominence {
            Some(m) => {
                p.prominence < m
                    && (p.saddle.is_some() || self.convention == EdgeConvention::Unknown)
            }
            None => false,
        }
    }

    /// Global region id of the cell at global (gx, gy), which must be a
    /// perimeter cell of its tile.
    pub(super) fn perimeter_id(&self, gx: i64, gy: i64) -> Option<u64> {
        let t = self.layout.tile as i64;
        let tid = self.layout.id((gx / t) as usize, (gy / t) as usize);
        let win = self.layout.window(tid);
        let k = perimeter_index(win.w, win.h, (gx - win.x) as usize, (gy - win.y) as usize)?;
        let id = *self.plateaus.perimeter_id.get(tid)?.get(k)?;
        (id != u64::MAX).then_some(id)
    }

    pub(super) fn missing(&self, gx: i64, gy: i64) -> Error {
        Error::invalid(format!(
            "divide tree: no plateau id for perimeter cell ({gx}, {gy}); run the plateau pass on the same layout"
        ))
    }
}

impl GlobalStep for TreeStep<'_> {
    type In = f32;
    type Out = f32;
    type Summary = TreeSummary;
    type Solution = DivideTree;
    type Slice = ();

    fn name(&self) -> String {
        "divide tree".into()
    }
    fn params(&self) -> serde_json::Value {
        serde_json::json!({"convention": format!("{:?}", self.convention)})
    }
    fn halo(&self) -> usize {
        1
    }
    fn outputs(&self) -> Vec<crate::exec::output::OutputSpec> {
        Vec::new()
    }

    fn map(&self, inputs: &[TileView<f32>]) -> Result<TreeSummary> {
        let v = first_view(inputs, "divide tree")?;
        if v.halo < 1 {
            return Err(Error::invalid(
                "divide tree: tile views need a halo of at least 1",
            ));
        }
        let (w, h) = (v.core.w, v.core.h);
        if w * h >= NONE as usize - 1 {
            return Err(Error::invalid(format!(
                "divide tree: a {w} x {h} tile has too many cells; use a smaller --tile"
            )));
        }
        let (cx0, cy0) = (v.core.x, v.core.y);
        let rw = v.raster_width as u64;
        let inside = |gx: i64, gy: i64| {
            gx >= 0 && gy >= 0 && gx < v.raster_width as i64 && gy < v.raster_height as i64
        };
        // Flat pieces of the core (CSR), with their attributes.
        let mut label = vec![NONE; w * h];
        let mut off: Vec<u32> = vec![0];
        let mut cells: Vec<u32> = Vec::with_capacity(w * h);
        let mut pieces: Vec<Piece> = Vec::new();
        let mut edges: Vec<(u64, u64)> = Vec::new();
        // Seam edges found while labelling: (piece, neighbour region id).
        let mut seam: Vec<(u32, u64)> = Vec::new();
        for start in 0..w * h {
            let (sx, sy) = ((start % w) as i64, (start / w) as i64);
            let z = v.at(sx, sy);
            if z.is_nan() || label[start] != NONE {
                continue;
            }
            check_finite(z, cx0 + sx, cy0 + sy)?;
            let r = pieces.len() as u32;
            label[start] = r;
            let first = cells.len();
            cells.push(start as u32);
            let mut p = Piece {
                z,
                id: (cy0 + sy) as u64 * rw + (cx0 + sx) as u64,
                open: false,
                outside: false,
                any_valid: false,
                higher: false,
            };
            let mut open_id: Option<u64> = None;
            grow(&mut cells, first, w, |(x, y), (nx, ny)| {
                let nz = v.at(nx, ny);
                let in_core = nx >= 0 && ny >= 0 && nx < w as i64 && ny < h as i64;
                if nz.is_nan() {
                    p.outside = true;
                    return Ok(None);
                }
                if nz != z {
                    p.any_valid = true;
                }
                if nz > z {
                    p.higher = true;
                }
                if in_core {
                    let nb = ny as usize * w + nx as usize;
                    if nz == z && label[nb] == NONE {
                        label[nb] = r;
                        return Ok(Some(nb as u32));
                    }
                } else if inside(cx0 + nx, cy0 + ny) {
                    // A valid neighbour in another tile: the piece is open.
                    if !p.open {
                        p.open = true;
                        open_id = Some(
                            self.perimeter_id(cx0 + x, cy0 + y)
                                .ok_or_else(|| self.missing(cx0 + x, cy0 + y))?,
                        );
                    }
                    if nz < z {
                        let nid = self
                            .perimeter_id(cx0 + nx, cy0 + ny)
                            .ok_or_else(|| self.missing(cx0 + nx, cy0 + ny))?;
                        seam.push((r, nid));
                    }
                }
                Ok(None)
            })?;
            if let Some(id) = open_id {
                p.id = id;
            }
            off.push(cells.len() as u32);
            pieces.push(p);
        }
        for &(r, nid) in &seam {
            edges.push((pieces[r as usize].id, nid));
        }
        drop(seam);
        let np = pieces.len();
        // Sweep order: (elevation, id) decreasing.
        let mut order: Vec<u32> = (0..np as u32).collect();
        order.sort_unstable_by_key(|&i| {
            let p = &pieces[i as usize];
            std::cmp::Reverse(key(p.z, p.id))
        });
        let sea = np as u32;
        let mut uf = UnionFind::<u32>::new(np + 1);
        let mut comp: Vec<Comp> = (0..=np)
            .map(|_| Comp {
                closed: true,
                top: NO_TOP,
                lowest: f32::INFINITY,
                last: NONE,
                hi: (0, 0),
            })
            .collect();
        // Local peaks (piece index) and the summary being built.
        let mut local_peaks: Vec<u32> = Vec::new();
        let mut out = TreeSummary::default();
        let node_of = |p: &Piece, out: &mut TreeSummary| -> u32 {
            out.nodes.push(TreeNode {
                id: p.id,
                z: p.z,
                low: p.z,
                outside: p.outside,
                any_valid: p.any_valid,
                higher: p.higher,
            });
            (out.nodes.len() - 1) as u32
        };
        let finalize = |peak_piece: &Piece,
                        prominence: f64,
                        saddle: Option<(u64, f32)>,
                        parent: Option<u64>,
                        out: &mut TreeSummary| {
            out.peaks.push(FinalPeak {
                id: peak_piece.id,
                z: peak_piece.z,
                prominence,
                saddle,
                parent,
                on_edge: peak_piece.outside,
            });
        };
        let conv = self.convention;
        let mut sea_done = conv == EdgeConvention::Unknown;
        let mut roots: Vec<u32> = Vec::with_capacity(8);
        let mut relevant: Vec<u32> = Vec::with_capacity(8);

        // The sea node joins (SeaLevel): every processed piece touching the
        // outside (exactly those above 0) joins its component.
        let sea_event = |uf: &mut UnionFind<u32>,
                         comp: &mut Vec<Comp>,
                         out: &mut TreeSummary,
                         local_peaks: &[u32]| {
            out.nodes.push(TreeNode {
                id: SEA_ID,
                z: 0.0,
                low: 0.0,
                outside: false,
                any_valid: false,
                higher: false,
            });
            let sea_node = (out.nodes.len() - 1) as u32;
            let mut rs: Vec<u32> = Vec::new();
            for (i, p) in pieces.iter().enumerate() {
                if p.z > 0.0 && p.outside {
                    let r = uf.find(i as u32);
                    if !rs.contains(&r) {
                        rs.push(r);
                    }
                }
            }
            let mut low = 0.0f32;
            for &r in &rs {
                let c = &comp[r as usize];
                low = low.min(c.lowest);
                if c.closed {
                    if c.top < NO_TOP {
                        let pk = &pieces[local_peaks[c.top as usize] as usize];
                        finalize(pk, pk.z as f64, None, None, out);
                    }
                } else {
                    out.edges.push((SEA_ID, out.nodes[c.last as usize].id));
                }
                uf.union_into(sea, r);
            }
            comp[sea as usize] = Comp {
                closed: false,
                top: SEA_TOP,
                lowest: low,
                last: sea_node,
                hi: (u32::MAX, u64::MAX),
            };
        };

        for &x in &order {
            let xi = x as usize;
            let px = &pieces[xi];
            let z = px.z;
            if !sea_done && z <= 0.0 {
                sea_done = true;
                sea_event(&mut uf, &mut comp, &mut out, &local_peaks);
            }
            roots.clear();
            for &c in &cells[off[xi] as usize..off[xi + 1] as usize] {
                for (nb, nx, ny) in neighbours_in(w, h, c as usize) {
                    if label[nb] == NONE {
                        continue;
                    }
                    if v.at(nx, ny) > z {
                        let r = uf.find(label[nb]);
                        if !roots.contains(&r) {
                            roots.push(r);
                        }
                    }
                }
            }
            if sea_done && conv == EdgeConvention::SeaLevel && px.outside {
                let s = uf.find(sea);
                if !roots.contains(&s) {
                    roots.push(s);
                }
            }
            if roots.is_empty() {
                comp[xi] = if px.open {
                    let n = node_of(px, &mut out);
                    Comp {
                        closed: false,
                        top: OPEN_TOP,
                        lowest: z,
                        last: n,
                        hi: key(z, px.id),
                    }
                } else if conv == EdgeConvention::Unknown && !px.any_valid {
                    Comp {
                        closed: true,
                        top: NO_TOP,
                        lowest: z,
                        last: NONE,
                        hi: key(z, px.id),
                    }
                } else {
                    local_peaks.push(x);
                    Comp {
                        closed: true,
                        top: (local_peaks.len() - 1) as u32,
                        lowest: z,
                        last: NONE,
                        hi: key(z, px.id),
                    }
                };
                continue;
            }
            let mut low = z;
            let mut hi = key(z, px.id);
            for &r in &roots {
                low = low.min(comp[r as usize].lowest);
                hi = hi.max(comp[r as usize].hi);
            }
            let all_closed = !px.open && roots.iter().all(|&r| comp[r as usize].closed);
            let (closed, top, last);
            if all_closed {
                // Everything is inside the tile: the in-memory merge rule.
                let win = *roots
                    .iter()
                    .min_by_key(|&&r| comp[r as usize].top)
                    .expect("roots is not empty");
                let wtop = comp[win as usize].top;
                for &r in &roots {
                    let t = comp[r as usize].top;
                    if r == win || t >= NO_TOP {
                        continue;
                    }
                    let pk = &pieces[local_peaks[t as usize] as usize];
                    let wp = &pieces[local_peaks[wtop as usize] as usize];
                    finalize(
                        pk,
                        pk.z as f64 - z as f64,
                        Some((px.id, z)),
                        Some(wp.id),
                        &mut out,
                    );
                }
                closed = true;
                top = wtop;
                last = NONE;
            } else {
                let sea_in = roots.iter().any(|&r| comp[r as usize].top == SEA_TOP);
                if sea_in && !px.open && !px.higher && px.any_valid {
                    // A summit at or below 0 touching the outside, all in
                    // this tile: a peak of prominence 0 (as in `tree.rs`).
                    finalize(px, 0.0, None, None, &mut out);
                }
                relevant.clear();
                for &r in &roots {
                    let c = &comp[r as usize];
                    if c.closed {
                        if c.top >= NO_TOP {
                            continue;
                        }
                        let pk = &pieces[local_peaks[c.top as usize] as usize];
                        // Another root already holds higher ground, so this
                        // top loses here: its key saddle and prominence are
                        // final (unless the sea may win, at or below 0), only
                        // its parent is not; below the threshold it can go.
                        let beaten = (z > 0.0 || conv == EdgeConvention::Unknown)
                            && roots.iter().any(|&o| o != r && comp[o as usize].hi > c.hi);
                        let small = self
                            .min_prominence
                            .is_some_and(|m| (pk.z as f64 - z as f64) < m);
                        if sea_in {
                            // Meets the sea at this level (≤ 0).
                            finalize(pk, pk.z as f64 - z as f64, None, None, &mut out);
                        } else if !(beaten && small) {
                            relevant.push(node_of(pk, &mut out));
                        }
                    } else {
                        relevant.push(c.last);
                    }
                }
                last = if px.open || relevant.len() >= 2 {
                    let n = node_of(px, &mut out);
                    for &rel in &relevant {
                        out.edges.push((px.id, out.nodes[rel as usize].id));
                    }
                    n
                } else {
                    relevant[0]
                };
                closed = false;
                top = if sea_in { SEA_TOP } else { OPEN_TOP };
            }
            // Union: x (fresh) becomes the root; `find(sea)` names the
            // sea's component wherever its root is.
            for &r in &roots {
                uf.union_into(x, r);
            }
            comp[xi] = Comp {
                closed,
                top,
                lowest: low,
                last,
                hi,
            };
        }
        if !sea_done {
            sea_event(&mut uf, &mut comp, &mut out, &local_peaks);
        }
        // Components still alive at the end.
        for r in 0..=np as u32 {
            if uf.find(r) != r {
                continue;
            }
            if r == sea && conv == EdgeConvention::Unknown {
                continue;
            }
            let c = &comp[r as usize];
            if c.closed {
                if c.top < NO_TOP {
                    let pk = &pieces[local_peaks[c.top as usize] as usize];
                    let prom = match conv {
                        EdgeConvention::SeaLevel => pk.z as f64,
                        EdgeConvention::Unknown => pk.z as f64 - c.lowest as f64,
                    };
                    finalize(pk, prom, None, None, &mut out);
                }
            } else if c.last != NONE {
                let n = &mut out.nodes[c.last as usize];
                n.low = n.low.min(c.lowest);
            }
        }
        out.edges.extend(edges);
        for e in out.edges.iter_mut() {
            if e.0 > e.1 {
                *e = (e.1, e.0);
            }
        }
        out.edges.sort_unstable();
        out.edges.dedup();
        if self.min_prominence.is_some() {
            let peaks = std::mem::take(&mut out.peaks);
            out.peaks = peaks.into_iter().filter(|p| !self.droppable(p)).collect();
        }
        Ok(out)
    }

    fn reduce(&self, layout: &TileLayout, summaries: Vec<TreeSummary>) -> Result<DivideTree> {
        if summaries.len() != layout.count() {
            return Err(Error::invalid(format!(
                "divide tree: {} summaries for {} tiles",
                summaries.len(),
                layout.count()
            )));
        }
        let mut final_peaks: Vec<FinalPeak> = Vec::new();
        let mut nodes: Vec<TreeNode> = Vec::new();
        let mut index: HashMap<u64, u32> = HashMap::new();
        let mut summaries = summaries;
        for s in summaries.iter_mut() {
            for n in std::mem::take(&mut s.nodes) {
                match index.get(&n.id) {
                    Some(&i) => {
                        let m = &mut nodes[i as usize];
                        if m.z != n.z {
                            return Err(Error::invalid(format!(
                                "divide tree: region {} has two elevations ({} and {}) in the tile summaries",
                                n.id, m.z, n.z
                            )));
                        }
                        m.low = m.low.min(n.low);
                        m.outside |= n.outside;
                        m.any_valid |= n.any_valid;
                        m.higher |= n.higher;
                    }
                    None => {
                        index.insert(n.id, nodes.len() as u32);
                        nodes.push(n);
                    }
                }
            }
            final_peaks.append(&mut s.peaks);
        }
        let mut edges: Vec<(u32, u32)> = Vec::new();
        for s in &summaries {
            for &(a, b) in &s.edges {
                let (Some(&ia), Some(&ib)) = (index.get(&a), index.get(&b)) else {
                    return Err(Error::invalid(format!(
                        "divide tree: an edge names region {a} or {b}, which no tile summary holds"
                    )));
                };
                edges.push((ia, ib));
            }
        }
        drop(summaries);
        drop(index);
        let n = nodes.len();
        for e in edges.iter_mut() {
            if e.0 > e.1 {
                *e = (e.1, e.0);
            }
        }
        edges.sort_unstable();
        edges.dedup();
        let graph = Adjacency::undirected(n, &edges);
        drop(edges);
        let mut order: Vec<u32> = (0..n as u32).collect();
        order.sort_unstable_by_key(|&i| {
            let m = &nodes[i as usize];
            std::cmp::Reverse(key(m.z, m.id))
        });
        let conv = self.convention;
        // Global sweep over the joined graph: the rules of `tree::build`.
        let mut uf = UnionFind::<u32>::new(n);
        let mut top = vec![NO_TOP; n];
        let mut lowest = vec![f32::INFINITY; n];
        let mut done = vec![false; n];
        let mut peaks: Vec<FinalPeak> = Vec::new();
        let mut roots: Vec<u32> = Vec::with_capacity(8);
        let rank = |t: u32| -> u64 {
            match t {
                SEA_TOP => 0,
                NO_TOP => u64::MAX,
                p => p as u64 + 1,
            }
        };
        for &x in &order {
            let xi = x as usize;
            let m = &nodes[xi];
            roots.clear();
            for &nb in graph.neighbours(xi) {
                if done[nb as usize] {
                    let r = uf.find(nb);
                    if !roots.contains(&r) {
                        roots.push(r);
                    }
                }
            }
            done[xi] = true;
            let is_sea = m.id == SEA_ID;
            if is_sea && conv == EdgeConvention::Unknown {
                return Err(Error::invalid(
                    "divide tree: a sea node in a tree built with the Unknown convention",
                ));
            }
            let own_low = m.low.min(m.z);
            if roots.is_empty() {
                lowest[xi] = own_low;
                top[xi] = if is_sea {
                    SEA_TOP
                } else if conv == EdgeConvention::Unknown && !m.any_valid {
                    NO_TOP
                } else {
                    peaks.push(FinalPeak {
                        id: m.id,
                        z: m.z,
                        prominence: f64::NAN,
                        saddle: None,
                        parent: None,
                        on_edge: m.outside,
                    });
                    (peaks.len() - 1) as u32
                };
                continue;
            }
            if !is_sea && conv == EdgeConvention::SeaLevel && !m.higher && m.any_valid {
                // Joins only the sea (at or below 0) and has no higher
                // neighbour: a summit of prominence 0 (as in `tree.rs`).
                peaks.push(FinalPeak {
                    id: m.id,
                    z: m.z,
                    prominence: 0.0,
                    saddle: None,
                    parent: None,
                    on_edge: m.outside,
                });
            }
            let wtop = if is_sea {
                SEA_TOP
            } else {
                roots
                    .iter()
                    .map(|&r| top[r as usize])
                    .min_by_key(|&t| rank(t))
                    .expect("roots is not empty")
            };
            let mut low = own_low;
            for &r in &roots {
                low = low.min(lowest[r as usize]);
                let t = top[r as usize];
                if t == wtop || t == SEA_TOP || t == NO_TOP {
                    continue;
                }
                let (pz, wid) = (
                    peaks[t as usize].z,
                    (wtop != SEA_TOP).then(|| peaks[wtop as usize].id),
                );
                let p = &mut peaks[t as usize];
                match wid {
                    // The sea wins at the sea node (z = 0) or below it.
                    None => p.prominence = pz as f64 - m.z as f64,
                    Some(wid) => {
                        p.prominence = pz as f64 - m.z as f64;
                        p.saddle = Some((m.id, m.z));
                        p.parent = Some(wid);
                    }
                }
            }
            for &r in &roots {
                uf.union_into(x, r);
            }
            top[xi] = wtop;
            lowest[xi] = low;
        }
        for r in 0..n {
            if uf.find(r as u32) != r as u32 {
                continue;
            }
            let t = top[r];
            if t == SEA_TOP || t == NO_TOP {
                continue;
            }
            let p = &mut peaks[t as usize];
            if p.prominence.is_nan() {
                p.prominence = match conv {
                    EdgeConvention::SeaLevel => p.z as f64,
                    EdgeConvention::Unknown => p.z as f64 - lowest[r] as f64,
                };
            }
        }
        final_peaks.extend(peaks);
        assemble(
            layout.width,
            layout.height,
            conv,
            final_peaks,
            self.min_prominence,
        )
    }

    fn slice(&self, _: &DivideTree, _: TileId) {}

    fn apply(&self, _: &[TileView<f32>], _: &(), _: &mut [Grid<f32>]) -> Result<()> {
        Err(Error::invalid(
            "divide tree writes no raster; run it without outputs",
        ))
    }
}
