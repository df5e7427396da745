//! Exact global hydrology passes across tiles, as [`GlobalStep`]s.
//!
//! - [`TiledFill`]: depression filling after Barnes, R. (2016). "Parallel
//!   priority-flood depression filling for trillion cell digital elevation
//!   models on desktops or clusters". Computers & Geosciences 96, 56–68.
//!   *map*: each tile is flooded alone (Improved Priority-Flood) from seeds
//!   that are its perimeter cells (one label each) and its true outlet cells
//!   (label 1, the "ocean": cells next to nodata or the raster's edge, seen
//!   through a halo of 1); the summary is the perimeter's labels and
//!   elevations plus the in-tile spill graph (label pairs with the lowest
//!   elevation at which one spills into the other). *reduce*: the tile graphs
//!   are joined by edges between adjacent perimeter cells of neighbouring
//!   tiles (spill elevation = the higher of the two cells) and a minimax
//!   Dijkstra (a priority-flood over labels) from the ocean gives each label
//!   its water level. *apply*: the tile is flooded again (not stored) and each
//!   cell becomes `max(locally filled elevation, level of its label)`. The
//!   result equals [`super::fill()`] bit for bit (tested for many tile sizes).
//! - [`TiledAccumulation`]: D8 accumulation after Barnes, R. (2017).
//!   "Parallel non-divergent flow accumulation for trillion cell digital
//!   elevation models on desktops or clusters". Environmental Modelling &
//!   Software 92, 202–212. *map*: accumulation inside the tile and, for every
//!   perimeter cell, its link: the next perimeter cell downstream inside the
//!   tile, or the cell of another tile its flow enters, or none. *reduce*: the
//!   perimeter graph is accumulated in topological order, giving the flow each
//!   perimeter cell receives from other tiles. *apply*: the tile is
//!   accumulated again with those inflows added at its perimeter. Sums are
//!   exact integers (see [`super::accum`]), so the result equals
//!   [`super::accumulate`] / [`super::accumulate_weighted`] bit for bit.
//!
//! - [`TiledD8`]: D8 directions with flats resolved exactly across tiles
//!   (Barnes, Lehman & Mulla 2014 gradients as shortest distances over
//!   perimeter "portals"; see its docs). Equal to [`super::d8_directions`].
//!
//! All read their inputs as f32 (NaN = nodata), with a halo of 1 (fill,
//! accumulation) or 2 (D8).
//!
//! Not (yet) tiled: epsilon filling and watershed labels. Epsilon fill's
//! values depend on the order in which the in-memory flood reaches each cell
//! of a flat, which a per-tile flood cannot reproduce; an exact tiled form
//! needs the epsilon surface redefined as `next_up^k(fill level)` with `k`
//! a geodesic distance inside each flat (computable with the portal
//! machinery of [`TiledD8`]) and the in-memory version changed to match.

use super::accum::{accumulate_core, bad_code, fixed_to_f64, receiver, weight_to_fixed};
use super::fill::{flood_labelled, UNLABELLED};
use super::{order_key, valid, DX, DY, NODATA_DIR};
use crate::error::{Error, Result};
use crate::exec::GlobalStep;
use crate::raster::{Grid, TileId, TileLayout, TileView};
use serde::{Deserialize, Serialize};
use std::cmp::Reverse;
use std::collections::{BinaryHeap, HashMap};

/// Number of perimeter cells of a `w` x `h` tile.
pub fn perimeter_len(w: usize, h: usize) -> usize {
    if w == 0 || h == 0 {
        0
    } else if h == 1 {
        w
    } else {
        2 * w + (h - 2) * if w == 1 { 1 } else { 2 }
    }
}

/// Position of (x, y) in the row-major enumeration of a tile's perimeter
/// cells, or `None` for an interior cell.
pub fn perimeter_index(w: usize, h: usize, x: usize, y: usize) -> Option<usize> {
    let k = if w == 1 { 1 } else { 2 };
    if y == 0 {
        Some(x)
    } else if y + 1 == h {
        Some(w + (h - 2) * k + x)
    } else if x == 0 {
        Some(w + (y - 1) * k)
    } else if x + 1 == w {
        Some(w + (y - 1) * k + 1)
    } else {
        None
    }
}

/// The perimeter cells of a `w` x `h` tile in row-major order.
pub fn perimeter_cells(w: usize, h: usize) -> impl Iterator<Item = (usize, usize)> {
    (0..h).flat_map(move |y| {
        let edge_row = y == 0 || y + 1 == h;
        (0..w)
            .filter(move |&x| edge_row || x == 0 || x + 1 == w)
            .map(move |x| (x, y))
    })
}

fn need_halo<T>(v: &TileView<T>, step: &str) -> Result<()> {
    if v.halo < 1 {
        return Err(Error::invalid(format!(
            "{step}: tile views need a halo of at least 1"
        )));
    }
    Ok(())
}

// ---------------------------------------------------------------- fill ----

/// Global depression filling across tiles (Barnes 2016); see the module docs.
#[derive(Debug, Clone, Copy, Default)]
pub struct TiledFill;

/// Per-tile summary of [`TiledFill`]: O(perimeter).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct FillSummary {
    /// Core size.
    pub w: usize,
    pub h: usize,
    /// Local labels are `0..labels`: 0 = nodata, 1 = ocean, 2.. = one per
    /// non-outlet perimeter cell.
    pub labels: u32,
    /// (label, elevation) of each perimeter cell, row-major perimeter order
    /// (label 0 and elevation 0 for nodata).
    pub perimeter: Vec<(u32, f32)>,
    /// In-tile spill graph: (a, b, e) with a < b, `e` the lowest elevation
    /// at which label a's and label b's regions touch; sorted.
    pub spill: Vec<(u32, u32, f32)>,
}

/// Reduced solution of [`TiledFill`]: the water level of every label.
#[derive(Debug, Clone)]
pub struct FillSolution {
    /// First global label of each tile's local label 2.
    offsets: Vec<usize>,
    /// Local label counts per tile.
    counts: Vec<u32>,
    /// Level per global label (0 = ocean, `f32::MIN`).
    level: Vec<f32>,
}

/// The result of one tile's local flood.
struct TileFlood {
    z: Vec<f32>,
    labels: Vec<u32>,
    count: u32,
    w: usize,
    h: usize,
}

/// Flood one tile from its perimeter and true outlets; spill pairs go to
/// `on_spill`.
fn flood_tile(v: &TileView<f32>, on_spill: impl FnMut(u32, u32, f32)) -> Result<TileFlood> {
    need_halo(v, "fill")?;
    let (w, h) = (v.core.w, v.core.h);
    if w.checked_mul(h).is_none_or(|n| n > super::fill::MAX_CELLS) {
        return Err(Error::invalid(format!(
            "fill: a tile of {w}x{h} cells is too large (at most 2^32 cells)"
        )));
    }
    let mut z = Vec::with_capacity(w * h);
    for y in 0..h {
        for x in 0..w {
            z.push(v.at(x as i64, y as i64));
        }
    }
    let mut labels = vec![UNLABELLED; w * h];
    let mut seeds = Vec::new();
    let mut next: u32 = 2;
    for y in 0..h {
        let edge_row = y == 0 || y + 1 == h;
        for x in 0..w {
            let i = y * w + x;
            if !valid(z[i]) {
                continue;
            }
            let perim = edge_row || x == 0 || x + 1 == w;
            let outlet = (0..8).any(|d| !valid(v.at(x as i64 + DX[d], y as i64 + DY[d])));
            if outlet {
                labels[i] = 1;
                seeds.push(i);
            } else if perim {
                labels[i] = next;
                next = next
                    .checked_add(1)
                    .ok_or_else(|| Error::invalid("fill: tile has more than 2^32 labels"))?;
                seeds.push(i);
            }
        }
    }
    flood_labelled(&mut z, w, h, &mut labels, &seeds, on_spill);
    Ok(TileFlood {
        z,
        labels,
        count: next,
        w,
        h,
    })
}

impl GlobalStep for TiledFill {
    type In = f32;
    type Out = f32;
    type Summary = FillSummary;
    type Solution = FillSolution;
    type Slice = Vec<f32>;

    fn name(&self) -> String {
        "fill".into()
    }
    fn params(&self) -> serde_json::Value {
        serde_json::json!({"algorithm": "priority-flood (Barnes 2014, 2016)"})
    }
    fn halo(&self) -> usize {
        1
    }

    fn map(&self, inputs: &[TileView<f32>]) -> Result<FillSummary> {
        let v = inputs
            .first()
            .ok_or_else(|| Error::invalid("fill needs one input (the DEM)"))?;
        let mut spill: HashMap<(u32, u32), f32> = HashMap::new();
        let f = flood_tile(v, |a, b, e| {
            let key = if a < b { (a, b) } else { (b, a) };
            spill
                .entry(key)
                .and_modify(|old| {
                    if e < *old {
                        *old = e
                    }
                })
                .or_insert(e);
        })?;
        let perimeter = perimeter_cells(f.w, f.h)
            .map(|(x, y)| {
                let i = y * f.w + x;
                if f.labels[i] == UNLABELLED {
                    (0, 0.0)
                } else {
                    (f.labels[i], f.z[i])
                }
            })
            .collect();
        let mut spill: Vec<(u32, u32, f32)> =
            spill.into_iter().map(|((a, b), e)| (a, b, e)).collect();
        spill.sort_by_key(|p| (p.0, p.1));
        Ok(FillSummary {
            w: f.w,
            h: f.h,
            labels: f.count,
            perimeter,
            spill,
        })
    }

    fn reduce(&self, layout: &TileLayout, summaries: Vec<FillSummary>) -> Result<FillSolution> {
        if summaries.len() != layout.count() {
            return Err(Error::invalid(format!(
                "fill reduce: {} summaries for {} tiles",
                summaries.len(),
                layout.count()
            )));
        }
        let mut offsets = Vec::with_capacity(summaries.len());
        let mut counts = Vec::with_capacity(summaries.len());
        let mut total = 1usize;
        for (t, s) in summaries.iter().enumerate() {
            let win = layout.window(t);
            if s.w != win.w
                || s.h != win.h
                || s.perimeter.len() != perimeter_len(s.w, s.h)
                || s.labels < 2
                || s.perimeter.iter().any(|&(l, _)| l >= s.labels)
            {
                return Err(Error::invalid(format!(
                    "fill reduce: summary of tile {t} does not match the layout"
                )));
            }
            offsets.push(total);
            counts.push(s.labels);
            total += (s.labels - 2) as usize;
        }
        let global = |t: usize, l: u32| -> usize {
            if l == 1 {
                0
            } else {
                offsets[t] + (l - 2) as usize
            }
        };
        let mut edges: Vec<(usize, usize, f32)> = Vec::new();
        for (t, s) in summaries.iter().enumerate() {
            for &(a, b, e) in &s.spill {
                if a == 0 || b == 0 || a >= s.labels || b >= s.labels {
                    return Err(Error::invalid(format!(
                        "fill reduce: bad label in tile {t}'s spill graph"
                    )));
                }
                edges.push((global(t, a), global(t, b), e));
            }
        }
        // Edges between adjacent perimeter cells of neighbouring tiles.
        cross_tile_pairs(layout, |ta, (xa, ya), tb, (xb, yb)| {
            let cell = |t: usize, x: usize, y: usize| -> (u32, f32) {
                let s = &summaries[t];
                match perimeter_index(s.w, s.h, x, y) {
                    Some(k) => s.perimeter[k],
                    None => (0, 0.0),
                }
            };
            let (la, za) = cell(ta, xa, ya);
            let (lb, zb) = cell(tb, xb, yb);
            if la != 0 && lb != 0 {
                edges.push((
                    global(ta, la),
                    global(tb, lb),
                    if za > zb { za } else { zb },
                ));
            }
        });
        // CSR adjacency (undirected).
        let mut start = vec![0usize; total + 1];
        for &(a, b, _) in &edges {
            start[a + 1] += 1;
            start[b + 1] += 1;
        }
        for i in 0..total {
            start[i + 1] += start[i];
        }
        let mut fill_at = start.clone();
        let mut adj = vec![(0usize, 0f32); start[total]];
        for &(a, b, e) in &edges {
            adj[fill_at[a]] = (b, e);
            fill_at[a] += 1;
            adj[fill_at[b]] = (a, e);
            fill_at[b] += 1;
        }
        drop(edges);
        // Minimax Dijkstra from the ocean: a priority-flood over labels.
        let mut level = vec![f32::INFINITY; total];
        let mut done = vec![false; total];
        let mut heap = BinaryHeap::new();
        level[0] = f32::MIN;
        heap.push(Reverse((order_key(f32::MIN), 0usize)));
        while let Some(Reverse((_, u))) = heap.pop() {
            if done[u] {
                continue;
            }
            done[u] = true;
            let lu = level[u];
            for &(v, e) in &adj[start[u]..start[u + 1]] {
                let cand = if e > lu { e } else { lu };
                if cand < level[v] {
                    level[v] = cand;
                    heap.push(Reverse((order_key(cand), v)));
                }
            }
        }
        if let Some(u) = done.iter().position(|&d| !d) {
            return Err(Error::invalid(format!(
                "fill reduce: label {u} has no path to an outlet (inconsistent summaries)"
            )));
        }
        Ok(FillSolution {
            offsets,
            counts,
            level,
        })
    }

    fn slice(&self, sol: &FillSolution, id: TileId) -> Vec<f32> {
        let n = sol.counts[id] as usize;
        let mut s = vec![0.0f32; n];
        if n > 1 {
            s[1] = f32::MIN;
        }
        for (l, v) in s.iter_mut().enumerate().skip(2) {
            *v = sol.level[sol.offsets[id] + l - 2];
        }
        s
    }

    fn apply(
        &self,
        inputs: &[TileView<f32>],
        slice: &Vec<f32>,
        out: &mut [Grid<f32>],
    ) -> Result<()> {
        let v = inputs
            .first()
            .ok_or_else(|| Error::invalid("fill needs one input (the DEM)"))?;
        let f = flood_tile(v, |_, _, _| {})?;
        if f.count as usize != slice.len() {
            return Err(Error::invalid(
                "fill apply: slice does not belong to this tile",
            ));
        }
        let o = out
            .first_mut()
            .ok_or_else(|| Error::invalid("fill apply: no output grid"))?;
        for (i, cell) in o.data_mut().iter_mut().enumerate() {
            let l = f.labels[i];
            *cell = if l == UNLABELLED {
                f32::NAN
            } else {
                let lv = slice[l as usize];
                if lv > f.z[i] {
                    lv
                } else {
                    f.z[i]
                }
            };
        }
        Ok(())
    }
}

// ------------------------------------------------------- accumulation ----

/// Global D8 flow accumulation across tiles (Barnes 2017); see the module
/// docs. Input 0: D8 directions read as f32 (ESRI codes, NaN or 255 =
/// nodata); input 1 (when `weighted`): weights. Output: f64 accumulation
/// (cell counts, or sums of weights), NaN on nodata.
#[derive(Debug, Clone, Copy, Default)]
pub struct TiledAccumulation {
    /// Sum weights (input 1) instead of counting cells.
    pub weighted: bool,
}

/// Where the flow of a perimeter cell goes next, seen from its tile.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq)]
pub enum Link {
    /// It ends inside the tile (no-flow cell, nodata, off the raster).
    End,
    /// It reaches this perimeter cell (index) of the same tile.
    Perim(u32),
    /// It enters the cell (x, y) (global coordinates) of another tile.
    Cross(u64, u64),
}

/// Per-tile summary of [`TiledAccumulation`]: one entry per perimeter cell.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct AccumSummary {
    pub w: usize,
    pub h: usize,
    /// Local accumulation (fixed point for weights) and link of each
    /// perimeter cell, row-major perimeter order.
    pub perimeter: Vec<(i128, Link)>,
}

/// Reduced solution: the inflow each perimeter cell receives from other tiles.
#[derive(Debug, Clone)]
pub struct AccumSolution {
    offsets: Vec<usize>,
    inflow: Vec<i128>,
}

/// Direction codes of a whole view, codes and own contributions of the core
/// cells, core width and height.
type AccumTile = (Vec<u8>, Vec<u8>, Vec<i128>, usize, usize);

impl TiledAccumulation {
    /// Decode the direction view (core + halo) into codes.
    fn codes(&self, v: &TileView<f32>) -> Result<Vec<u8>> {
        need_halo(v, "accumulation")?;
        let mut out = Vec::with_capacity(v.grid.len());
        let gw = v.grid.width();
        let h = v.halo as i64;
        for (i, &c) in v.grid.data().iter().enumerate() {
            let code = if c.is_nan() || c == NODATA_DIR as f32 {
                NODATA_DIR
            } else if (0.0..=128.0).contains(&c)
                && c.fract() == 0.0
                && (c == 0.0 || super::code_to_dir(c as u8).is_some())
            {
                c as u8
            } else {
                let gx = v.core.x + (i % gw) as i64 - h;
                let gy = v.core.y + (i / gw) as i64 - h;
                return Err(Error::invalid(format!(
                    "flow direction {c} at cell ({gx}, {gy}) is not a D8 code (0, 1, 2, 4, …, 128; NaN or 255 for nodata)"
                )));
            };
            out.push(code);
        }
        Ok(out)
    }

    /// Core codes and each core cell's own contribution.
    fn core(&self, inputs: &[TileView<f32>]) -> Result<AccumTile> {
        let d = inputs
            .first()
            .ok_or_else(|| Error::invalid("accumulation needs the flow directions as input 0"))?;
        let all = self.codes(d)?;
        let (w, h) = (d.core.w, d.core.h);
        let gw = d.grid.width();
        let hl = d.halo;
        let mut core = Vec::with_capacity(w * h);
        for y in 0..h {
            core.extend_from_slice(&all[(y + hl) * gw + hl..(y + hl) * gw + hl + w]);
        }
        let mut own = Vec::with_capacity(w * h);
        if self.weighted {
            let wt = inputs.get(1).ok_or_else(|| {
                Error::invalid("weighted accumulation needs the weights as input 1")
            })?;
            if wt.core != d.core {
                return Err(Error::invalid(
                    "accumulation: weights and directions tiles differ",
                ));
            }
            for y in 0..h {
                for x in 0..w {
                    let c = core[y * w + x];
                    own.push(if c == NODATA_DIR {
                        0
                    } else {
                        weight_to_fixed(wt.at(x as i64, y as i64))?
                    });
                }
            }
        } else {
            own.extend(core.iter().map(|&c| if c == NODATA_DIR { 0 } else { 1 }));
        }
        Ok((all, core, own, w, h))
    }
}

impl GlobalStep for TiledAccumulation {
    type In = f32;
    type Out = f64;
    type Summary = AccumSummary;
    type Solution = AccumSolution;
    type Slice = Vec<i128>;

    fn name(&self) -> String {
        "accumulate".into()
    }
    fn params(&self) -> serde_json::Value {
        serde_json::json!({"algorithm": "D8 accumulation (Barnes 2017)", "weighted": self.weighted})
    }
    fn halo(&self) -> usize {
        1
    }

    fn map(&self, inputs: &[TileView<f32>]) -> Result<AccumSummary> {
        let (all, core, mut acc, w, h) = self.core(inputs)?;
        let v = &inputs[0];
        let order = accumulate_core(&core, w, h, &mut acc)?;
        // Next perimeter cell downstream of every cell, downstream first.
        const END: u32 = u32::MAX;
        const OUT: u32 = u32::MAX - 1;
        let mut down = vec![END; w * h];
        let gw = v.grid.width();
        let hl = v.halo;
        for &c in order.iter().rev() {
            let c = c as usize;
            let (x, y) = (c % w, c / w);
            let code = core[c];
            down[c] = match receiver(x, y, code, w, h) {
                Err(()) => return Err(bad_code(code, x, y)),
                Ok(Some(r)) => {
                    if core[r] == NODATA_DIR {
                        END
                    } else if let Some(k) = perimeter_index(w, h, r % w, r / w) {
                        k as u32
                    } else {
                        down[r]
                    }
                }
                Ok(None) => {
                    match super::code_to_dir(code) {
                        // points beyond the core: valid target in the halo?
                        Some(d) => {
                            let hx = (x as i64 + DX[d] + hl as i64) as usize;
                            let hy = (y as i64 + DY[d] + hl as i64) as usize;
                            if all[hy * gw + hx] != NODATA_DIR {
                                OUT
                            } else {
                                END
                            }
                        }
                        None => END,
                    }
                }
            };
        }
        let perimeter = perimeter_cells(w, h)
            .map(|(x, y)| {
                let c = y * w + x;
                let link = match down[c] {
                    END => Link::End,
                    OUT => {
                        let d = super::code_to_dir(core[c]).expect("OUT only for codes");
                        Link::Cross(
                            (v.core.x + x as i64 + DX[d]) as u64,
                            (v.core.y + y as i64 + DY[d]) as u64,
                        )
                    }
                    k => Link::Perim(k),
                };
                (acc[c], link)
            })
            .collect();
        Ok(AccumSummary { w, h, perimeter })
    }

    fn reduce(&self, layout: &TileLayout, summaries: Vec<AccumSummary>) -> Result<AccumSolution> {
        if summaries.len() != layout.count() {
            return Err(Error::invalid(format!(
                "accumulation reduce: {} summaries for {} tiles",
                summaries.len(),
                layout.count()
            )));
        }
        let mut offsets = Vec::with_capacity(summaries.len());
        let mut total = 0usize;
        for (t, s) in summaries.iter().enumerate() {
            let win = layout.window(t);
            if s.w != win.w || s.h != win.h || s.perimeter.len() != perimeter_len(s.w, s.h) {
                return Err(Error::invalid(format!(
                    "accumulation reduce: summary of tile {t} does not match the layout"
                )));
            }
            offsets.push(total);
            total += s.perimeter.len();
        }
        let corrupt = |t: usize| {
            Error::invalid(format!(
                "accumulation reduce: bad link in tile {t}'s summary"
            ))
        };
        // Downstream node of every perimeter node; `cross` marks links to
        // another tile (they carry the whole accumulation, not just inflow).
        let mut next = vec![usize::MAX; total];
        let mut cross = vec![false; total];
        let mut own = vec![0i128; total];
        for (t, s) in summaries.iter().enumerate() {
            for (k, &(a, link)) in s.perimeter.iter().enumerate() {
                let u = offsets[t] + k;
                own[u] = a;
                match link {
                    Link::End => {}
                    Link::Perim(j) => {
                        if j as usize >= s.perimeter.len() || j as usize == k {
                            return Err(corrupt(t));
                        }
                        next[u] = offsets[t] + j as usize;
                    }
                    Link::Cross(gx, gy) => {
                        if gx as usize >= layout.width || gy as usize >= layout.height {
                            return Err(corrupt(t));
                        }
                        let (gx, gy) = (gx as usize, gy as usize);
                        let tb = layout.id(gx / layout.tile, gy / layout.tile);
                        let win = layout.window(tb);
                        let (lx, ly) = (gx - win.x as usize, gy - win.y as usize);
                        let j = perimeter_index(win.w, win.h, lx, ly).ok_or_else(|| corrupt(t))?;
                        if tb == t {
                            return Err(corrupt(t));
                        }
                        next[u] = offsets[tb] + j;
                        cross[u] = true;
                    }
                }
            }
        }
        // in-degrees: up to 3 from other tiles plus any number of perimeter
        // cells of the same tile whose paths join here
        let mut indeg = vec![0u32; total];
        for &v in &next {
            if v != usize::MAX {
                indeg[v] += 1;
            }
        }
        let mut extra = vec![0i128; total];
        let mut inflow = vec![0i128; total];
        let mut queue: Vec<usize> = (0..total).filter(|&u| indeg[u] == 0).collect();
        let mut head = 0;
        let overflow = || Error::invalid("flow accumulation overflowed 2^127");
        while head < queue.len() {
            let u = queue[head];
            head += 1;
            let v = next[u];
            if v == usize::MAX {
                continue;
            }
            if cross[u] {
                let a = own[u].checked_add(extra[u]).ok_or_else(overflow)?;
                extra[v] = extra[v].checked_add(a).ok_or_else(overflow)?;
                inflow[v] = inflow[v].checked_add(a).ok_or_else(overflow)?;
            } else {
                extra[v] = extra[v].checked_add(extra[u]).ok_or_else(overflow)?;
            }
            indeg[v] -= 1;
            if indeg[v] == 0 {
                queue.push(v);
            }
        }
        if queue.len() != total {
            return Err(Error::invalid(
                "flow directions contain a cycle across tiles; directions must come from a D8 routing of one DEM",
            ));
        }
        Ok(AccumSolution { offsets, inflow })
    }

    fn slice(&self, sol: &AccumSolution, id: TileId) -> Vec<i128> {
        let end = sol.offsets.get(id + 1).copied().unwrap_or(sol.inflow.len());
        sol.inflow[sol.offsets[id]..end].to_vec()
    }

    fn apply(
        &self,
        inputs: &[TileView<f32>],
        slice: &Vec<i128>,
        out: &mut [Grid<f64>],
    ) -> Result<()> {
        let (_, core, mut acc, w, h) = self.core(inputs)?;
        if slice.len() != perimeter_len(w, h) {
            return Err(Error::invalid(
                "accumulation apply: slice does not belong to this tile",
            ));
        }
        for ((x, y), &inc) in perimeter_cells(w, h).zip(slice) {
            let c = y * w + x;
            acc[c] = acc[c]
                .checked_add(inc)
                .ok_or_else(|| Error::invalid("flow accumulation overflowed 2^127"))?;
        }
        accumulate_core(&core, w, h, &mut acc)?;
        let o = out
            .first_mut()
            .ok_or_else(|| Error::invalid("accumulation apply: no output grid"))?;
        for (i, cell) in o.data_mut().iter_mut().enumerate() {
            *cell = if core[i] == NODATA_DIR {
                f64::NAN
            } else if self.weighted {
                fixed_to_f64(acc[i])
            } else {
                acc[i] as f64
            };
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn perimeter_enumeration_matches_index() {
        for w in 1..6 {
            for h in 1..6 {
                let cells: Vec<_> = perimeter_cells(w, h).collect();
                assert_eq!(cells.len(), perimeter_len(w, h), "{w}x{h}");
                for (k, &(x, y)) in cells.iter().enumerate() {
                    assert_eq!(perimeter_index(w, h, x, y), Some(k), "{w}x{h} ({x},{y})");
                }
                for y in 0..h {
                    for x in 0..w {
                        let on = x == 0 || y == 0 || x + 1 == w || y + 1 == h;
                        assert_eq!(perimeter_index(w, h, x, y).is_some(), on);
                    }
                }
            }
        }
    }

    #[test]
    fn summaries_round_trip_through_json() {
        let s = AccumSummary {
            w: 2,
            h: 1,
            perimeter: vec![(1i128 << 100, Link::Cross(3, 4)), (-5, Link::Perim(0))],
        };
        let j = serde_json::to_string(&s).unwrap();
        let back: AccumSummary = serde_json::from_str(&j).unwrap();
        assert_eq!(back, s);
    }
}

// ------------------------------------------------------ D8 directions ----

/// Calls `f(tile_a, (xa, ya), tile_b, (xb, yb))` for every pair of
/// 8-adjacent cells that lie in different tiles (tile-local coordinates),
/// each pair once.
fn cross_tile_pairs(
    layout: &TileLayout,
    mut f: impl FnMut(usize, (usize, usize), usize, (usize, usize)),
) {
    let (ntx, nty) = (layout.tiles_x(), layout.tiles_y());
    for ty in 0..nty {
        for tx in 0..ntx {
            let a = layout.id(tx, ty);
            let wa = layout.window(a).w;
            let ha = layout.window(a).h;
            if tx + 1 < ntx {
                let b = layout.id(tx + 1, ty);
                for y in 0..ha {
                    for yb in y.saturating_sub(1)..(y + 2).min(ha) {
                        f(a, (wa - 1, y), b, (0, yb));
                    }
                }
            }
            if ty + 1 < nty {
                let b = layout.id(tx, ty + 1);
                for x in 0..wa {
                    for xb in x.saturating_sub(1)..(x + 2).min(wa) {
                        f(a, (x, ha - 1), b, (xb, 0));
                    }
                }
                if tx + 1 < ntx {
                    f(a, (wa - 1, ha - 1), layout.id(tx + 1, ty + 1), (0, 0));
                }
                if tx > 0 {
                    let b = layout.id(tx - 1, ty + 1);
                    f(a, (0, ha - 1), b, (layout.window(b).w - 1, 0));
                }
            }
        }
    }
}

/// D8 flow directions with flats resolved exactly across tiles (equal to
/// [`super::d8_directions`] bit for bit). Input: a filled DEM (f32, NaN =
/// nodata), halo 2; output: ESRI codes (u8, [`NODATA_DIR`] for nodata).
///
/// Steepest descent is local (halo 1, plus 1 to know the halo cells' own
/// codes). Flats need the two breadth-first distances of Barnes, Lehman &
/// Mulla (2014) — towards lower terrain and away from higher terrain — which
/// are geodesic distances through the flat's NO_FLOW cells and so cross
/// tiles. Each source distance is a local fact (a NO_FLOW cell next to a
/// draining cell of the same height starts at 2, one next to higher ground at
/// 1), so the distances are a multi-source shortest-path problem, solved as a
/// global step: *map* computes, per tile, the local distances of the
/// perimeter NO_FLOW cells ("portals") and the geodesic distance inside the
/// tile between every two portals of the same flat; *reduce* runs Dijkstra
/// over portals (in-tile portal pairs plus unit edges between adjacent
/// portals of neighbouring tiles); *apply* seeds a tile's search with its
/// portals' global distances, reads the distances of the ring of cells
/// around the tile from the slice, and picks directions exactly as the
/// in-memory algorithm does. Within a flat only differences of the combined
/// mask matter, so the flat's height term of the paper (a per-flat maximum,
/// global) cancels and is not needed: cells compare `2·towards − away`, and
/// a cell next to a low edge drains to its first low edge.
///
/// Cost: the portal-pair distances take one search per portal over its flat
/// inside the tile, and the summary holds one entry per pair of portals of
/// the same flat: O(perimeter) for tiles that flats do not cross, but up to
/// O(perimeter²) for a tile covered by one flat (a filled lake). Keep tiles
/// moderate (≤ 512) on DEMs with very large flats.
#[derive(Debug, Clone, Copy, Default)]
pub struct TiledD8;

/// Per-tile summary of [`TiledD8`].
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct D8Summary {
    pub w: usize,
    pub h: usize,
    /// (perimeter index, local towards distance, local away distance) of each
    /// perimeter NO_FLOW cell; `u32::MAX` = not reached inside the tile.
    pub portals: Vec<(u32, u32, u32)>,
    /// (i, j, d): portals i < j (indices into `portals`) are `d` steps apart
    /// through the tile's NO_FLOW cells.
    pub pairs: Vec<(u32, u32, u32)>,
    /// The whole tile is NO_FLOW (a flat covers it: sea, a filled lake):
    /// `pairs` is left empty, every two portals are their Chebyshev distance
    /// apart (an obstacle-free rectangle), and the reduce relaxes them
    /// directly instead of storing O(perimeter²) pairs.
    pub open: bool,
}

/// Reduced solution of [`TiledD8`]: global distances of every portal.
#[derive(Debug, Clone)]
pub struct D8Solution {
    layout: TileLayout,
    /// Per tile, per perimeter index: portal node or `u32::MAX`.
    node_of: Vec<Vec<u32>>,
    towards: Vec<u32>,
    away: Vec<u32>,
}

/// What one tile needs: (towards, away) of its own perimeter cells and of the
/// ring of cells around it (perimeter order of the box grown by 1).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct D8Slice {
    pub own: Vec<(u32, u32)>,
    pub ring: Vec<(u32, u32)>,
}

const FAR: u32 = u32::MAX;

/// Steepest-descent codes over a tile view plus which core cells are NO_FLOW
/// and their local seed distances.
struct D8Prep {
    w: usize,
    h: usize,
    gw: usize,
    hl: usize,
    codes: Vec<u8>,
    /// core-indexed: NO_FLOW
    nf: Vec<bool>,
    /// core-indexed seed distances (towards: 2 next to a draining cell of the
    /// same height; away: 1 next to a higher cell), FAR otherwise
    seed_t: Vec<u32>,
    seed_a: Vec<u32>,
}

impl D8Prep {
    fn new(v: &TileView<f32>) -> Result<D8Prep> {
        if v.halo < 2 {
            return Err(Error::invalid("d8: tile views need a halo of at least 2"));
        }
        let (w, h) = (v.core.w, v.core.h);
        let gw = v.grid.width();
        let gh = v.grid.height();
        let hl = v.halo;
        let z = v.grid.data();
        let codes = super::flow::steepest_descent(z, gw, gh);
        let mut nf = vec![false; w * h];
        let mut seed_t = vec![FAR; w * h];
        let mut seed_a = vec![FAR; w * h];
        for y in 0..h {
            for x in 0..w {
                let vi = (y + hl) * gw + x + hl;
                if codes[vi] != super::NO_FLOW {
                    continue;
                }
                let c = y * w + x;
                nf[c] = true;
                for d in 0..8 {
                    let n = ((y + hl) as i64 + DY[d]) as usize * gw
                        + ((x + hl) as i64 + DX[d]) as usize;
                    let cn = codes[n];
                    if cn == NODATA_DIR {
                        continue;
                    }
                    if cn != super::NO_FLOW && z[n] == z[vi] {
                        seed_t[c] = 2;
                    }
                    if z[n] > z[vi] {
                        seed_a[c] = 1;
                    }
                }
            }
        }
        Ok(D8Prep {
            w,
            h,
            gw,
            hl,
            codes,
            nf,
            seed_t,
            seed_a,
        })
    }

    /// Shortest distances over NO_FLOW core cells from seeds (unit steps).
    fn distances(&self, seeds: &[u32]) -> Vec<u32> {
        let mut dist = seeds.to_vec();
        let mut heap: BinaryHeap<Reverse<(u32, usize)>> = seeds
            .iter()
            .enumerate()
            .filter(|(_, &d)| d != FAR)
            .map(|(i, &d)| Reverse((d, i)))
            .collect();
        while let Some(Reverse((d, c))) = heap.pop() {
            if d != dist[c] {
                continue;
            }
            self.for_nf_neighbours(c, |n| {
                if d + 1 < dist[n] {
                    dist[n] = d + 1;
                    heap.push(Reverse((d + 1, n)));
                }
            });
        }
        dist
    }

    #[inline]
    fn for_nf_neighbours(&self, c: usize, mut f: impl FnMut(usize)) {
        let (x, y) = ((c % self.w) as i64, (c / self.w) as i64);
        for d in 0..8 {
            let nx = x + DX[d];
            let ny = y + DY[d];
            if nx >= 0 && ny >= 0 && nx < self.w as i64 && ny < self.h as i64 {
                let n = ny as usize * self.w + nx as usize;
                if self.nf[n] {
                    f(n);
                }
            }
        }
    }
}

impl GlobalStep for TiledD8 {
    type In = f32;
    type Out = u8;
    type Summary = D8Summary;
    type Solution = D8Solution;
    type Slice = D8Slice;

    fn name(&self) -> String {
        "d8".into()
    }
    fn params(&self) -> serde_json::Value {
        serde_json::json!({"algorithm": "D8 steepest descent, flats after Barnes, Lehman & Mulla 2014"})
    }
    fn halo(&self) -> usize {
        2
    }

    fn map(&self, inputs: &[TileView<f32>]) -> Result<D8Summary> {
        let v = inputs
            .first()
            .ok_or_else(|| Error::invalid("d8 needs one input (the filled DEM)"))?;
        let p = D8Prep::new(v)?;
        let (w, h) = (p.w, p.h);
        let lt = p.distances(&p.seed_t);
        let la = p.distances(&p.seed_a);
        let mut portals = Vec::new();
        let mut cells = Vec::new();
        for (k, (x, y)) in perimeter_cells(w, h).enumerate() {
            let c = y * w + x;
            if p.nf[c] {
                portals.push((k as u32, lt[c], la[c]));
                cells.push(c);
            }
        }
        let open = p.nf.iter().all(|&b| b);
        if open {
            return Ok(D8Summary {
                w,
                h,
                portals,
                pairs: Vec::new(),
                open,
            });
        }
        // portal-pair distances: one BFS per portal, reusing the buffers
        let mut portal_at = vec![FAR; w * h];
        for (i, &c) in cells.iter().enumerate() {
            portal_at[c] = i as u32;
        }
        let mut dist = vec![FAR; w * h];
        let mut touched: Vec<usize> = Vec::new();
        let mut pairs = Vec::new();
        for (i, &start) in cells.iter().enumerate() {
            for &t in &touched {
                dist[t] = FAR;
            }
            touched.clear();
            dist[start] = 0;
            touched.push(start);
            let mut head = 0;
            while head < touched.len() {
                let c = touched[head];
                head += 1;
                let dc = dist[c];
                p.for_nf_neighbours(c, |n| {
                    if dist[n] == FAR {
                        dist[n] = dc + 1;
                        touched.push(n);
                    }
                });
            }
            for &c in &touched {
                let j = portal_at[c];
                if j != FAR && j as usize > i {
                    pairs.push((i as u32, j, dist[c]));
                }
            }
        }
        pairs.sort_unstable();
        Ok(D8Summary {
            w,
            h,
            portals,
            pairs,
            open,
        })
    }

    fn reduce(&self, layout: &TileLayout, summaries: Vec<D8Summary>) -> Result<D8Solution> {
        if summaries.len() != layout.count() {
            return Err(Error::invalid(format!(
                "d8 reduce: {} summaries for {} tiles",
                summaries.len(),
                layout.count()
            )));
        }
        let mut node_of = Vec::with_capacity(summaries.len());
        let mut first = Vec::with_capacity(summaries.len());
        let mut init_t = Vec::new();
        let mut init_a = Vec::new();
        // tile and (x, y) of every node, for the Chebyshev relaxation of open tiles
        let mut node_pos: Vec<(u32, u32, u32)> = Vec::new();
        for (t, s) in summaries.iter().enumerate() {
            let win = layout.window(t);
            let plen = perimeter_len(win.w, win.h);
            if s.w != win.w || s.h != win.h {
                return Err(Error::invalid(format!(
                    "d8 reduce: summary of tile {t} does not match the layout"
                )));
            }
            let mut map = vec![FAR; plen];
            first.push(init_t.len());
            let cells: Vec<(usize, usize)> = perimeter_cells(win.w, win.h).collect();
            if s.open && s.portals.len() != plen {
                return Err(Error::invalid(format!(
                    "d8 reduce: open tile {t} without all its portals"
                )));
            }
            for &(k, dt, da) in &s.portals {
                if k as usize >= plen || map[k as usize] != FAR {
                    return Err(Error::invalid(format!("d8 reduce: bad portal in tile {t}")));
                }
                map[k as usize] = init_t.len() as u32;
                let (x, y) = cells[k as usize];
                node_pos.push((t as u32, x as u32, y as u32));
                init_t.push(dt);
                init_a.push(da);
            }
            node_of.push(map);
        }
        let total = init_t.len();
        let mut edges: Vec<(usize, usize, u32)> = Vec::new();
        for (t, s) in summaries.iter().enumerate() {
            for &(i, j, d) in &s.pairs {
                if i as usize >= s.portals.len() || j as usize >= s.portals.len() {
                    return Err(Error::invalid(format!(
                        "d8 reduce: bad portal pair in tile {t}"
                    )));
                }
                edges.push((first[t] + i as usize, first[t] + j as usize, d));
            }
        }
        let win_of: Vec<_> = (0..layout.count()).map(|t| layout.window(t)).collect();
        cross_tile_pairs(layout, |ta, (xa, ya), tb, (xb, yb)| {
            let ka = perimeter_index(win_of[ta].w, win_of[ta].h, xa, ya);
            let kb = perimeter_index(win_of[tb].w, win_of[tb].h, xb, yb);
            if let (Some(ka), Some(kb)) = (ka, kb) {
                let (na, nb) = (node_of[ta][ka], node_of[tb][kb]);
                if na != FAR && nb != FAR {
                    edges.push((na as usize, nb as usize, 1));
                }
            }
        });
        let mut start = vec![0usize; total + 1];
        for &(a, b, _) in &edges {
            start[a + 1] += 1;
            start[b + 1] += 1;
        }
        for i in 0..total {
            start[i + 1] += start[i];
        }
        let mut at = start.clone();
        let mut adj = vec![(0usize, 0u32); start[total]];
        for &(a, b, d) in &edges {
            adj[at[a]] = (b, d);
            at[a] += 1;
            adj[at[b]] = (a, d);
            at[b] += 1;
        }
        drop(edges);
        let dijkstra = |init: Vec<u32>| -> Vec<u32> {
            let mut dist = init;
            let mut heap: BinaryHeap<Reverse<(u32, usize)>> = dist
                .iter()
                .enumerate()
                .filter(|(_, &d)| d != FAR)
                .map(|(i, &d)| Reverse((d, i)))
                .collect();
            while let Some(Reverse((d, u))) = heap.pop() {
                if d != dist[u] {
                    continue;
                }
                for &(v, e) in &adj[start[u]..start[u + 1]] {
                    let nd = d.saturating_add(e);
                    if nd < dist[v] {
                        dist[v] = nd;
                        heap.push(Reverse((nd, v)));
                    }
                }
                let (t, ux, uy) = node_pos[u];
                let s = &summaries[t as usize];
                if s.open {
                    let f = first[t as usize];
                    for v in f..f + s.portals.len() {
                        let (_, vx, vy) = node_pos[v];
                        let nd = d.saturating_add(ux.abs_diff(vx).max(uy.abs_diff(vy)));
                        if nd < dist[v] {
                            dist[v] = nd;
                            heap.push(Reverse((nd, v)));
                        }
                    }
                }
            }
            dist
        };
        let towards = dijkstra(init_t);
        let away = dijkstra(init_a);
        Ok(D8Solution {
            layout: *layout,
            node_of,
            towards,
            away,
        })
    }

    fn slice(&self, sol: &D8Solution, id: TileId) -> D8Slice {
        let get = |t: usize, k: usize| -> (u32, u32) {
            match sol.node_of[t][k] {
                FAR => (FAR, FAR),
                n => (sol.towards[n as usize], sol.away[n as usize]),
            }
        };
        let own = (0..sol.node_of[id].len()).map(|k| get(id, k)).collect();
        let core = sol.layout.window(id);
        let (lw, lh) = (sol.layout.width as i64, sol.layout.height as i64);
        let ring = perimeter_cells(core.w + 2, core.h + 2)
            .map(|(ex, ey)| {
                let gx = core.x - 1 + ex as i64;
                let gy = core.y - 1 + ey as i64;
                if gx < 0 || gy < 0 || gx >= lw || gy >= lh {
                    return (FAR, FAR);
                }
                let (gx, gy) = (gx as usize, gy as usize);
                let t = sol.layout.id(gx / sol.layout.tile, gy / sol.layout.tile);
                let win = sol.layout.window(t);
                match perimeter_index(win.w, win.h, gx - win.x as usize, gy - win.y as usize) {
                    Some(k) => get(t, k),
                    None => (FAR, FAR),
                }
            })
            .collect();
        D8Slice { own, ring }
    }

    fn apply(&self, inputs: &[TileView<f32>], slice: &D8Slice, out: &mut [Grid<u8>]) -> Result<()> {
        let v = inputs
            .first()
            .ok_or_else(|| Error::invalid("d8 needs one input (the filled DEM)"))?;
        let p = D8Prep::new(v)?;
        let (w, h, gw, hl) = (p.w, p.h, p.gw, p.hl);
        if slice.own.len() != perimeter_len(w, h) || slice.ring.len() != perimeter_len(w + 2, h + 2)
        {
            return Err(Error::invalid(
                "d8 apply: slice does not belong to this tile",
            ));
        }
        let mut seed_t = p.seed_t.clone();
        let mut seed_a = p.seed_a.clone();
        for ((x, y), &(dt, da)) in perimeter_cells(w, h).zip(&slice.own) {
            let c = y * w + x;
            seed_t[c] = seed_t[c].min(dt);
            seed_a[c] = seed_a[c].min(da);
        }
        let t = p.distances(&seed_t);
        let a = p.distances(&seed_a);
        // (towards, away) of a cell of the box grown by 1, box coordinates
        let dist_at = |ex: usize, ey: usize| -> (u32, u32) {
            if ex >= 1 && ey >= 1 && ex <= w && ey <= h {
                let c = (ey - 1) * w + ex - 1;
                (t[c], a[c])
            } else {
                match perimeter_index(w + 2, h + 2, ex, ey) {
                    Some(k) => slice.ring[k],
                    None => (FAR, FAR),
                }
            }
        };
        let mask =
            |(dt, da): (u32, u32)| -> i64 { 2 * dt as i64 - if da == FAR { 0 } else { da as i64 } };
        let z = v.grid.data();
        let o = out
            .first_mut()
            .ok_or_else(|| Error::invalid("d8 apply: no output grid"))?;
        for y in 0..h {
            for x in 0..w {
                let vi = (y + hl) * gw + x + hl;
                let c = y * w + x;
                let mut code = p.codes[vi];
                if code == super::NO_FLOW && t[c] != FAR {
                    let nb = |d: usize| -> usize {
                        ((y + hl) as i64 + DY[d]) as usize * gw + ((x + hl) as i64 + DX[d]) as usize
                    };
                    // a low edge next to the cell wins (mask 2, the minimum)
                    let low = (0..8).find(|&d| {
                        let n = nb(d);
                        let cn = p.codes[n];
                        cn != NODATA_DIR && cn != super::NO_FLOW && z[n] == z[vi]
                    });
                    if let Some(d) = low {
                        code = super::D8_CODES[d];
                    } else {
                        let mut best = mask((t[c], a[c]));
                        for d in 0..8 {
                            if p.codes[nb(d)] != super::NO_FLOW {
                                continue;
                            }
                            let ex = (x as i64 + 1 + DX[d]) as usize;
                            let ey = (y as i64 + 1 + DY[d]) as usize;
                            let dn = dist_at(ex, ey);
                            if dn.0 == FAR {
                                continue;
                            }
                            let m = mask(dn);
                            if m < best {
                                best = m;
                                code = super::D8_CODES[d];
                            }
                        }
                    }
                }
                o.set(x, y, code);
            }
        }
        Ok(())
    }
}
