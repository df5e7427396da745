//! Exact flat resolution across tiles: D8 directions ([`TiledD8`]) and the
//! epsilon surface ([`TiledEpsilon`]), both built on one tiled solver of
//! the geodesic distances of Barnes, Lehman & Mulla (2014).
//!
//! Barnes, R., Lehman, C., Mulla, D. (2014). "An efficient assignment of
//! drainage direction over flat surfaces in raster digital elevation
//! models". Computers & Geosciences 62, 128–135: a flat's cells get a
//! breadth-first distance *towards lower terrain* (from the flat's draining
//! edge) and one *away from higher terrain*. Both are multi-source shortest
//! paths with unit steps over the 8-connected NO_FLOW cells (cells without a
//! lower neighbour that are not outlet cells; two adjacent NO_FLOW cells
//! always have the same height, so NO_FLOW components are the flats).
//! Each source is a local fact (a NO_FLOW cell next to a draining cell of
//! the same height starts at 2, one next to higher ground at 1), so the
//! distances cross tiles only through the tiles' perimeter NO_FLOW cells,
//! the *portals*.
//!
//! # The tiled solver
//! - *map* (O(tile area)): steepest descent, the two local distance fields
//!   by one multi-source breadth-first search each, and a summary holding
//!   the portals' local distances and the **shape** of every flat component
//!   of the tile that holds at least two portals, run-length encoded
//!   (row-major runs of cells). A component with one portal cannot carry a
//!   shortest path through the tile and is left out.
//! - *reduce*: a label-correcting search at tile granularity. Tiles wait in
//!   a priority queue keyed by their smallest improved portal distance; a
//!   popped tile runs one multi-source breadth-first search over its
//!   decoded runs, seeded by the current distances of all its portals, which
//!   gives the exact in-tile transit; improved portals relax the unit edges
//!   to adjacent portals of neighbouring tiles, which re-queues those tiles.
//!   It stops when no distance improves; the fixed point is the exact global
//!   shortest distance of every portal (Bellman–Ford at tile granularity,
//!   with the Dijkstra-like order keeping re-runs rare).
//! - *apply*: the tile's own search seeded with its portals' global
//!   distances, plus the distances of the ring of cells around the tile
//!   from the slice, gives every cell's exact global distances.
//!
//! The previous design stored every in-tile portal-to-portal distance:
//! O(perimeter²) summaries and one search per portal, O(portals × flat area)
//! per tile, which did not finish in 5 minutes on the Poland mosaic at tile
//! 1024 (the Baltic is one flat across many tiles). Runs are O(perimeter)
//! for compact flats (seas, lakes: a few runs per row) and never more than
//! half the tile's cells; map time is linear in the tile's area.

use super::fill::{neighbours, next_up_n};
use super::tiled::check_summaries;
use super::{valid, D8_CODES, DX, DY, NODATA_DIR, NO_FLOW};
use crate::error::{Error, Result};
use crate::exec::output::{NodataRule, OutputSpec};
use crate::exec::GlobalStep;
use crate::raster::neighbours::CellGeometry;
use crate::raster::{perimeter_cells, perimeter_index, perimeter_len};
use crate::raster::{DType, Grid, TileId, TileLayout, TileView};
use serde::{Deserialize, Serialize};
use std::borrow::Cow;
use std::cmp::Reverse;
use std::collections::BinaryHeap;

const FAR: u32 = u32::MAX;

/// D8 flow directions with flats resolved exactly across tiles (equal to
/// [`super::d8_directions`] bit for bit). Input: a filled DEM (f32, NaN =
/// nodata), halo 2, and optionally the declared sinks (input 1, non-zero =
/// sink; the DEM is routed lowered there, see `dem_view`), whose cells get
/// [`NO_FLOW`]; output: ESRI codes (u8, [`NODATA_DIR`] for
/// nodata).
///
/// Steepest descent is local (halo 1, plus 1 to know the halo cells' own
/// codes); flats use the tiled distance solver of this module. Within a flat
/// only differences of the combined mask of the paper matter, so its
/// per-flat "flat height" term (a global maximum) cancels: cells compare
/// `2·towards − away`, and a cell next to a low edge drains to its first
/// low edge, exactly as [`super::d8_directions`] decides.
#[derive(Debug, Clone, Copy, Default)]
pub struct TiledD8;

/// The epsilon-filled surface across tiles (equal to
/// [`super::fill_epsilon`] bit for bit): input a **filled** DEM (the output
/// of [`super::tiled::TiledFill`] or [`super::fill()`]), halo 2; output f32.
/// Each cell becomes `next_up^k(level)` with `k` its geodesic distance inside
/// its flat to the flat's draining edge (see [`super::fill::epsilon_surface`]
/// for the definition, the strictness check and where it differs from
/// RichDEM). `k` is the towards-lower distance of the D8 flats minus one,
/// computed by the same tiled solver.
#[derive(Debug, Clone, Copy, Default)]
pub struct TiledEpsilon;

/// Per-tile summary of [`TiledD8`] / [`TiledEpsilon`].
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct FlatSummary {
    pub w: usize,
    pub h: usize,
    /// (perimeter index, local towards distance, local away distance) of each
    /// perimeter NO_FLOW cell; `u32::MAX` = not reached inside the tile.
    pub portals: Vec<(u32, u32, u32)>,
    /// The cells of the flat components holding two portals or more, as
    /// (start, length) runs of row-major core indices, increasing and
    /// disjoint.
    pub runs: Vec<(u32, u32)>,
}

/// Former name of [`FlatSummary`].
pub type D8Summary = FlatSummary;

/// Reduced solution: global distances of every portal.
#[derive(Debug, Clone)]
pub struct FlatSolution {
    layout: TileLayout,
    /// Per tile, per perimeter index: portal node or `u32::MAX`.
    node_of: Vec<Vec<u32>>,
    towards: Vec<u32>,
    away: Vec<u32>,
}

/// Former name of [`FlatSolution`].
pub type D8Solution = FlatSolution;

/// What one tile needs: (towards, away) of its own perimeter cells and of the
/// ring of cells around it (perimeter order of the box grown by 1).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct FlatSlice {
    pub own: Vec<(u32, u32)>,
    pub ring: Vec<(u32, u32)>,
}

/// Former name of [`FlatSlice`].
pub type D8Slice = FlatSlice;

/// Multi-source breadth-first distances with unit steps over the cells of a
/// `w` x `h` grid where `pass` is true. `seeds` are (start distance, cell) in
/// any order, on pass cells; `dist` must be `FAR` on every pass cell. Each
/// pass cell ends with the minimum over seeds of start + steps (`FAR` if
/// unreachable). Level-synchronous: seeds join the frontier when the search
/// reaches their start distance, so the cost is linear plus a sort of the
/// seeds.
pub(crate) fn level_bfs(
    pass: &[bool],
    w: usize,
    h: usize,
    seeds: &mut [(u32, u32)],
    dist: &mut [u32],
) {
    seeds.sort_unstable();
    let mut cur: Vec<u32> = Vec::new();
    let mut nxt: Vec<u32> = Vec::new();
    let mut si = 0;
    let mut level = 0u32;
    let mut nb = [0usize; 8];
    loop {
        if cur.is_empty() {
            match seeds.get(si) {
                Some(&(d, _)) => level = d,
                None => break,
            }
        }
        while si < seeds.len() && seeds[si].0 == level {
            let c = seeds[si].1 as usize;
            if level < dist[c] {
                dist[c] = level;
                cur.push(c as u32);
            }
            si += 1;
        }
        let nl = level.saturating_add(1);
        for &c in &cur {
            let n = neighbours(c as usize, w, h, &mut nb);
            for &m in &nb[..n] {
                if pass[m] && nl < dist[m] {
                    dist[m] = nl;
                    nxt.push(m as u32);
                }
            }
        }
        std::mem::swap(&mut cur, &mut nxt);
        nxt.clear();
        level = nl;
    }
}

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
    /// (distance, core cell) seeds: towards (2 next to a draining cell of the
    /// same height) and away (1 next to a higher cell; empty unless asked)
    seed_t: Vec<(u32, u32)>,
    seed_a: Vec<(u32, u32)>,
}

impl D8Prep {
    fn new(v: &TileView<f32>, away: bool) -> Result<D8Prep> {
        if v.halo < 2 {
            return Err(Error::invalid(
                "flats: tile views need a halo of at least 2",
            ));
        }
        let (w, h) = (v.core.w, v.core.h);
        if w.checked_mul(h).is_none_or(|n| n >= FAR as usize) {
            return Err(Error::invalid(format!(
                "flats: a tile of {w}x{h} cells is too large (fewer than 2^32 cells)"
            )));
        }
        let gw = v.grid.width();
        let gh = v.grid.height();
        let hl = v.halo;
        let z = v.grid.data();
        let geo = CellGeometry::of_rows(&v.georef, v.core.y - hl as i64, gh);
        let codes = super::flow::steepest_descent(z, gw, gh, &geo);
        let mut nf = vec![false; w * h];
        let mut seed_t = Vec::new();
        let mut seed_a = Vec::new();
        for y in 0..h {
            for x in 0..w {
                let vi = (y + hl) * gw + x + hl;
                if codes[vi] != NO_FLOW {
                    continue;
                }
                let c = y * w + x;
                nf[c] = true;
                let (mut st, mut sa) = (false, false);
                for d in 0..8 {
                    let n = ((y + hl) as i64 + DY[d]) as usize * gw
                        + ((x + hl) as i64 + DX[d]) as usize;
                    let cn = codes[n];
                    if cn == NODATA_DIR {
                        continue;
                    }
                    if cn != NO_FLOW && z[n] == z[vi] {
                        st = true;
                    }
                    if z[n] > z[vi] {
                        sa = true;
                    }
                }
                if st {
                    seed_t.push((2, c as u32));
                }
                if sa && away {
                    seed_a.push((1, c as u32));
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

    /// Distances over the core's NO_FLOW cells from `seeds`.
    fn distances(&self, seeds: &mut [(u32, u32)]) -> Vec<u32> {
        let mut dist = vec![FAR; self.w * self.h];
        level_bfs(&self.nf, self.w, self.h, seeds, &mut dist);
        dist
    }

    /// Summary: portals with their local distances, runs of the flat
    /// components holding two portals or more.
    fn summary(&self) -> FlatSummary {
        let (w, h) = (self.w, self.h);
        let lt = self.distances(&mut self.seed_t.clone());
        let la = if self.seed_a.is_empty() {
            None
        } else {
            Some(self.distances(&mut self.seed_a.clone()))
        };
        let mut portals = Vec::new();
        let mut cells = Vec::new();
        for (k, (x, y)) in perimeter_cells(w, h).enumerate() {
            let c = y * w + x;
            if self.nf[c] {
                portals.push((k as u32, lt[c], la.as_ref().map_or(FAR, |a| a[c])));
                cells.push(c);
            }
        }
        drop(lt);
        drop(la);
        // flat components reached from the portals, with their portal counts
        let mut comp = vec![0u32; w * h];
        let mut count: Vec<u32> = vec![0];
        let mut stack = Vec::new();
        let mut nb = [0usize; 8];
        for &s in &cells {
            if comp[s] == 0 {
                let id = count.len() as u32;
                count.push(0);
                comp[s] = id;
                stack.push(s);
                while let Some(c) = stack.pop() {
                    let n = neighbours(c, w, h, &mut nb);
                    for &m in &nb[..n] {
                        if self.nf[m] && comp[m] == 0 {
                            comp[m] = id;
                            stack.push(m);
                        }
                    }
                }
            }
            count[comp[s] as usize] += 1;
        }
        let mut runs: Vec<(u32, u32)> = Vec::new();
        let mut open: Option<usize> = None;
        for (c, &id) in comp.iter().enumerate() {
            let keep = id != 0 && count[id as usize] >= 2;
            match (keep, open) {
                (true, None) => open = Some(c),
                (false, Some(s)) => {
                    runs.push((s as u32, (c - s) as u32));
                    open = None;
                }
                _ => {}
            }
        }
        if let Some(s) = open {
            runs.push((s as u32, (w * h - s) as u32));
        }
        FlatSummary {
            w,
            h,
            portals,
            runs,
        }
    }

    /// Global (towards, away) distances of every core cell, from the local
    /// seeds and the slice's portal distances.
    fn global(&self, slice: &FlatSlice, away: bool) -> Result<(Vec<u32>, Vec<u32>)> {
        let (w, h) = (self.w, self.h);
        if slice.own.len() != perimeter_len(w, h) || slice.ring.len() != perimeter_len(w + 2, h + 2)
        {
            return Err(Error::invalid(
                "flats apply: slice does not belong to this tile",
            ));
        }
        let mut st = self.seed_t.clone();
        let mut sa = self.seed_a.clone();
        for ((x, y), &(dt, da)) in perimeter_cells(w, h).zip(&slice.own) {
            let c = y * w + x;
            if !self.nf[c] {
                continue;
            }
            if dt != FAR {
                st.push((dt, c as u32));
            }
            if away && da != FAR {
                sa.push((da, c as u32));
            }
        }
        let t = self.distances(&mut st);
        let a = if away {
            self.distances(&mut sa)
        } else {
            Vec::new()
        };
        Ok((t, a))
    }
}

/// Input view of a flats step.
/// The filled DEM a flats step routes on: input 0, or, when input 1 holds
/// declared sinks ([`crate::io::sinks`], non-zero = sink), a copy with every
/// valid sink cell lowered to the next f32 below its elevation. A sink is
/// then lower than the flat its fill left around it, so that flat drains
/// into it (its cells are low edges), while steepest descent elsewhere is
/// unchanged but for exact ties; halo cells are lowered alike, so every
/// tile sees the same surface.
fn dem_view<'a>(inputs: &'a [TileView<f32>], what: &str) -> Result<Cow<'a, TileView<f32>>> {
    let v = inputs
        .first()
        .ok_or_else(|| Error::invalid(format!("{what} needs one input (the filled DEM)")))?;
    let Some(sinks) = inputs.get(1) else {
        return Ok(Cow::Borrowed(v));
    };
    let mut low = v.clone();
    for (z, &k) in low.grid.data_mut().iter_mut().zip(sinks.grid.data()) {
        if super::tiled::is_sink(k) && z.is_finite() {
            *z = z.next_down();
        }
    }
    Ok(Cow::Owned(low))
}

/// The reduce shared by both steps.
fn reduce_flats(layout: &TileLayout, summaries: Vec<FlatSummary>) -> Result<FlatSolution> {
    check_summaries("flats reduce", summaries.len(), layout)?;
    let mut node_of = Vec::with_capacity(summaries.len());
    let mut first = Vec::with_capacity(summaries.len() + 1);
    let mut init_t = Vec::new();
    let mut init_a = Vec::new();
    let mut node_cell: Vec<u32> = Vec::new();
    let mut node_tile: Vec<u32> = Vec::new();
    for (t, s) in summaries.iter().enumerate() {
        let win = layout.window(t);
        let bad = || Error::invalid(format!("flats reduce: bad summary for tile {t}"));
        if s.w != win.w || s.h != win.h {
            return Err(Error::invalid(format!(
                "flats reduce: summary of tile {t} does not match the layout"
            )));
        }
        let plen = perimeter_len(win.w, win.h);
        let cells: Vec<(usize, usize)> = perimeter_cells(win.w, win.h).collect();
        let mut map = vec![FAR; plen];
        first.push(init_t.len());
        for &(k, dt, da) in &s.portals {
            if k as usize >= plen || map[k as usize] != FAR {
                return Err(bad());
            }
            map[k as usize] = init_t.len() as u32;
            let (x, y) = cells[k as usize];
            node_cell.push((y * win.w + x) as u32);
            node_tile.push(t as u32);
            init_t.push(dt);
            init_a.push(da);
        }
        let mut end = 0u64;
        for &(a, l) in &s.runs {
            if l == 0 || (a as u64) < end || a as u64 + l as u64 > (win.w * win.h) as u64 {
                return Err(bad());
            }
            end = a as u64 + l as u64;
        }
        node_of.push(map);
    }
    first.push(init_t.len());
    let total = init_t.len();
    // unit edges between adjacent portals of neighbouring tiles (CSR)
    let mut edges: Vec<(u32, u32)> = Vec::new();
    let win_of: Vec<_> = (0..layout.count()).map(|t| layout.window(t)).collect();
    crate::raster::cross_tile_pairs(layout, |ta, (xa, ya), tb, (xb, yb)| {
        let ka = perimeter_index(win_of[ta].w, win_of[ta].h, xa, ya);
        let kb = perimeter_index(win_of[tb].w, win_of[tb].h, xb, yb);
        if let (Some(ka), Some(kb)) = (ka, kb) {
            let (na, nb) = (node_of[ta][ka], node_of[tb][kb]);
            if na != FAR && nb != FAR {
                edges.push((na, nb));
            }
        }
    });
    let graph = crate::raster::Adjacency::undirected(total, &edges);
    drop(edges);
    let max_cells = win_of.iter().map(|w| w.w * w.h).max().unwrap_or(0);
    let mut pass = vec![false; max_cells];
    let mut sdist = vec![FAR; max_cells];
    let mut seeds: Vec<(u32, u32)> = Vec::new();
    let mut solve = |init: Vec<u32>| -> Vec<u32> {
        let mut dist = init;
        let mut sent = vec![FAR; total];
        let mut key = vec![FAR; summaries.len()];
        let mut heap = BinaryHeap::new();
        for t in 0..summaries.len() {
            let m = dist[first[t]..first[t + 1]]
                .iter()
                .copied()
                .min()
                .unwrap_or(FAR);
            if m != FAR {
                key[t] = m;
                heap.push(Reverse((m, t)));
            }
        }
        while let Some(Reverse((k, t))) = heap.pop() {
            if k != key[t] {
                continue;
            }
            key[t] = FAR;
            let s = &summaries[t];
            let (f, e) = (first[t], first[t + 1]);
            if !s.runs.is_empty() {
                for &(a, l) in &s.runs {
                    pass[a as usize..(a + l) as usize].fill(true);
                }
                seeds.clear();
                for u in f..e {
                    let c = node_cell[u];
                    if dist[u] != FAR && pass[c as usize] {
                        seeds.push((dist[u], c));
                    }
                }
                level_bfs(&pass, s.w, s.h, &mut seeds, &mut sdist);
                for u in f..e {
                    let c = node_cell[u] as usize;
                    if pass[c] && sdist[c] < dist[u] {
                        dist[u] = sdist[c];
                    }
                }
                for &(a, l) in &s.runs {
                    pass[a as usize..(a + l) as usize].fill(false);
                    sdist[a as usize..(a + l) as usize].fill(FAR);
                }
            }
            for u in f..e {
                let du = dist[u];
                if du >= sent[u] {
                    continue;
                }
                sent[u] = du;
                let nd = du.saturating_add(1);
                for &v in graph.neighbours(u) {
                    let v = v as usize;
                    if nd < dist[v] {
                        dist[v] = nd;
                        let tv = node_tile[v] as usize;
                        if nd < key[tv] {
                            key[tv] = nd;
                            heap.push(Reverse((nd, tv)));
                        }
                    }
                }
            }
        }
        dist
    };
    let towards = solve(init_t);
    let away = solve(init_a);
    Ok(FlatSolution {
        layout: *layout,
        node_of,
        towards,
        away,
    })
}

/// The slice shared by both steps.
fn slice_flats(sol: &FlatSolution, id: TileId) -> FlatSlice {
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
    FlatSlice { own, ring }
}

/// (towards, away) of a cell of the tile's box grown by 1 (box coordinates).
#[inline]
fn dist_at(
    t: &[u32],
    a: &[u32],
    ring: &[(u32, u32)],
    w: usize,
    h: usize,
    ex: usize,
    ey: usize,
) -> (u32, u32) {
    if ex >= 1 && ey >= 1 && ex <= w && ey <= h {
        let c = (ey - 1) * w + ex - 1;
        (t[c], a.get(c).copied().unwrap_or(FAR))
    } else {
        match perimeter_index(w + 2, h + 2, ex, ey) {
            Some(k) => ring[k],
            None => (FAR, FAR),
        }
    }
}

/// What [`TiledD8`] and [`TiledEpsilon`] share as global steps: f32 in,
/// halo 2, the map (flat distances from each tile's own edges, towards
/// lower terrain and, for D8, `away` from higher terrain), the reduce
/// ([`reduce_flats`]) and the slice ([`slice_flats`]); only the output type
/// and the apply differ.
macro_rules! flat_passes {
    ($name:literal, $away:literal) => {
        type In = f32;
        type Summary = FlatSummary;
        type Solution = FlatSolution;
        type Slice = FlatSlice;

        fn name(&self) -> String {
            $name.into()
        }
        fn halo(&self) -> usize {
            2
        }

        fn map(&self, inputs: &[TileView<f32>]) -> Result<FlatSummary> {
            Ok(D8Prep::new(&*dem_view(inputs, $name)?, $away)?.summary())
        }

        fn reduce(&self, layout: &TileLayout, summaries: Vec<FlatSummary>) -> Result<FlatSolution> {
            reduce_flats(layout, summaries)
        }

        fn slice(&self, sol: &FlatSolution, id: TileId) -> FlatSlice {
            slice_flats(sol, id)
        }
    };
}

impl GlobalStep for TiledD8 {
    type Out = u8;
    flat_passes!("d8", true);

    fn params(&self) -> serde_json::Value {
        serde_json::json!({"algorithm": "D8 steepest descent, flats after Barnes, Lehman & Mulla 2014"})
    }

    fn outputs(&self) -> Vec<OutputSpec> {
        vec![OutputSpec::categorical(DType::U8, NODATA_DIR as f64)]
    }
    fn apply(
        &self,
        inputs: &[TileView<f32>],
        slice: &FlatSlice,
        out: &mut [Grid<u8>],
    ) -> Result<()> {
        let v = dem_view(inputs, "d8")?;
        let p = D8Prep::new(&v, true)?;
        let (w, h, gw, hl) = (p.w, p.h, p.gw, p.hl);
        let (t, a) = p.global(slice, true)?;
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
                if code == NO_FLOW && t[c] != FAR {
                    let nb = |d: usize| -> usize {
                        ((y + hl) as i64 + DY[d]) as usize * gw + ((x + hl) as i64 + DX[d]) as usize
                    };
                    // a low edge next to the cell wins (mask 2, the minimum)
                    let low = (0..8).find(|&d| {
                        let n = nb(d);
                        let cn = p.codes[n];
                        cn != NODATA_DIR && cn != NO_FLOW && z[n] == z[vi]
                    });
                    if let Some(d) = low {
                        code = D8_CODES[d];
                    } else {
                        let mut best = mask((t[c], a[c]));
                        for d in 0..8 {
                            if p.codes[nb(d)] != NO_FLOW {
                                continue;
                            }
                            let ex = (x as i64 + 1 + DX[d]) as usize;
                            let ey = (y as i64 + 1 + DY[d]) as usize;
                            let dn = dist_at(&t, &a, &slice.ring, w, h, ex, ey);
                            if dn.0 == FAR {
                                continue;
                            }
                            let m = mask(dn);
                            if m < best {
                                best = m;
                                code = D8_CODES[d];
                            }
                        }
                    }
                }
                // A declared sink (input 1, lowered by `dem_view`) ends its flow.
                if code != NODATA_DIR
                    && inputs
                        .get(1)
                        .is_some_and(|s| super::tiled::is_sink(s.at(x as i64, y as i64)))
                {
                    code = NO_FLOW;
                }
                o.set(x, y, code);
            }
        }
        Ok(())
    }
}

impl GlobalStep for TiledEpsilon {
    type Out = f32;
    flat_passes!("fill-epsilon", false);

    fn params(&self) -> serde_json::Value {
        serde_json::json!({"algorithm": "epsilon surface next_up^k(fill level), k = geodesic distance to the flat's draining edge"})
    }

    /// Input 0 is the filled DEM, whose nodata was chosen below the
    /// original DEM's data; the epsilon surface only raises flat cells, so
    /// it keeps that value (the same nodata as `fill`).
    fn outputs(&self) -> Vec<OutputSpec> {
        vec![OutputSpec::elevation().with_nodata(NodataRule::OfRaisedInput)]
    }
    fn apply(
        &self,
        inputs: &[TileView<f32>],
        slice: &FlatSlice,
        out: &mut [Grid<f32>],
    ) -> Result<()> {
        let v = dem_view(inputs, "fill-epsilon")?;
        let p = D8Prep::new(&v, false)?;
        let (w, h, gw, hl) = (p.w, p.h, p.gw, p.hl);
        let (t, _) = p.global(slice, false)?;
        let z = v.grid.data();
        let at = |x: usize, y: usize| -> (i64, i64) { (v.core.x + x as i64, v.core.y + y as i64) };
        // epsilon value of a cell from its level, code and towards distance
        let eps = |zz: f32, code: u8, dt: u32| -> Option<f32> {
            if code == NO_FLOW {
                if dt == FAR {
                    None
                } else {
                    Some(next_up_n(zz, dt - 1))
                }
            } else {
                Some(zz)
            }
        };
        let o = out
            .first_mut()
            .ok_or_else(|| Error::invalid("fill-epsilon apply: no output grid"))?;
        for y in 0..h {
            for x in 0..w {
                let vi = (y + hl) * gw + x + hl;
                let c = y * w + x;
                let zc = z[vi];
                if !valid(zc) {
                    o.set(x, y, f32::NAN);
                    continue;
                }
                let code = p.codes[vi];
                let Some(e) = eps(zc, code, t[c]) else {
                    return Err(super::fill::not_filled(at(x, y)));
                };
                if e == f32::INFINITY {
                    return Err(super::fill::eps_overflow(at(x, y)));
                }
                if code != NO_FLOW {
                    // a cell that keeps its level must still have a strictly
                    // lower neighbour unless it is an outlet cell
                    let nb = |d: usize| -> usize {
                        ((y + hl) as i64 + DY[d]) as usize * gw + ((x + hl) as i64 + DX[d]) as usize
                    };
                    let outlet = (0..8).any(|d| !valid(z[nb(d)]));
                    if !outlet {
                        let lower = (0..8).any(|d| {
                            let n = nb(d);
                            let ex = (x as i64 + 1 + DX[d]) as usize;
                            let ey = (y as i64 + 1 + DY[d]) as usize;
                            let dn = dist_at(&t, &[], &slice.ring, w, h, ex, ey).0;
                            eps(z[n], p.codes[n], dn).is_some_and(|en| en < zc)
                        });
                        if !lower {
                            return Err(super::fill::eps_too_wide(at(x, y), zc));
                        }
                    }
                }
                o.set(x, y, e);
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests;
