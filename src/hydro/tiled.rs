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
//! - [`TiledD8`] and [`TiledEpsilon`] (in [`super::tiled_flats`]): D8
//!   directions with flats resolved exactly across tiles, and the epsilon
//!   surface of a filled DEM (Barnes, Lehman & Mulla 2014 distances solved
//!   over perimeter "portals" and run-length encoded flat shapes). Equal to
//!   [`super::d8_directions`] and [`super::fill_epsilon`].
//! - [`TiledLabels`] (in [`super::tiled_labels`]): watershed labels from D8
//!   directions, equal to [`super::flow::outlet_labels`] (and so to
//!   [`super::watershed_labels`] on the directions of the filled DEM).
//!
//! All read their inputs as f32 (NaN = nodata), with a halo of 1 (fill,
//! accumulation, labels) or 2 (D8, epsilon).
//!
//! Epsilon filling across tiles is two passes: [`TiledFill`] then
//! [`TiledEpsilon`] on its output (the epsilon surface is defined from the
//! fill levels and distances inside flats, see
//! [`super::fill::epsilon_surface`]).

pub use super::tiled_flats::{
    D8Slice, D8Solution, D8Summary, FlatSlice, FlatSolution, FlatSummary, TiledD8, TiledEpsilon,
};
pub use super::tiled_labels::TiledLabels;

use super::accum::{accumulate_core, bad_code, fixed_to_f64, receiver, weight_to_fixed};
use super::fill::{flood_labelled, UNLABELLED};
use super::{order_key, valid, ACCUMULATION_NODATA, DX, DY, NODATA_DIR};
use crate::error::{Error, Result};
use crate::exec::output::OutputSpec;
use crate::exec::GlobalStep;
use crate::raster::{cross_tile_pairs, DType, Grid, TileId, TileLayout, TileView};
use serde::{Deserialize, Serialize};
use std::cmp::Reverse;
use std::collections::{BinaryHeap, HashMap};

pub use crate::raster::{perimeter_cells, perimeter_index, perimeter_len};

/// Every `reduce` of this folder first checks that it got one summary per
/// tile of `layout`; `what` names the reduce in the error.
pub(crate) fn check_summaries(what: &str, n: usize, layout: &TileLayout) -> Result<()> {
    if n != layout.count() {
        return Err(Error::invalid(format!(
            "{what}: {n} summaries for {} tiles",
            layout.count()
        )));
    }
    Ok(())
}

/// The own amounts of the core cells of a weighted accumulation: each valid
/// cell (`valid(i)`, row-major core index) its weight from input `k` in fixed
/// point, the others 0. The weights must cover the same tile as `base`;
/// `what` names the step and `base_name` that input in the errors.
pub(crate) fn weighted_amounts(
    inputs: &[TileView<f32>],
    k: usize,
    base: &TileView<f32>,
    what: &str,
    base_name: &str,
    valid: impl Fn(usize) -> bool,
) -> Result<Vec<i128>> {
    let wt = inputs
        .get(k)
        .ok_or_else(|| Error::invalid(format!("weighted {what} needs the weights as input {k}")))?;
    if wt.core != base.core {
        return Err(Error::invalid(format!(
            "{what}: weights and {base_name} tiles differ"
        )));
    }
    let (w, h) = (base.core.w, base.core.h);
    let mut own = Vec::with_capacity(w * h);
    for y in 0..h {
        for x in 0..w {
            own.push(if valid(y * w + x) {
                weight_to_fixed(wt.at(x as i64, y as i64))?
            } else {
                0
            });
        }
    }
    Ok(own)
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

/// Global depression filling across tiles (Barnes 2016); see the module
/// docs. Input 0: the DEM; input 1 (optional): declared sinks (non-zero =
/// sink, [`crate::io::sinks`]), outlets like the DEM's edge: seeds of the
/// flood at their own elevation, never raised.
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

/// A declared sink's cell in a sink raster read as f32 ([`crate::io::sinks`]).
pub(crate) fn is_sink(v: f32) -> bool {
    v != 0.0 && !v.is_nan()
}

/// Flood one tile from its perimeter and true outlets (and the declared
/// sinks of `sinks`, non-zero cells); spill pairs go to `on_spill`.
fn flood_tile(
    v: &TileView<f32>,
    sinks: Option<&TileView<f32>>,
    on_spill: impl FnMut(u32, u32, f32),
) -> Result<TileFlood> {
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
            let outlet = (0..8).any(|d| !valid(v.at(x as i64 + DX[d], y as i64 + DY[d])))
                || sinks.is_some_and(|s| is_sink(s.at(x as i64, y as i64)));
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

    fn outputs(&self) -> Vec<OutputSpec> {
        vec![OutputSpec::elevation()]
    }
    fn map(&self, inputs: &[TileView<f32>]) -> Result<FillSummary> {
        let v = inputs
            .first()
            .ok_or_else(|| Error::invalid("fill needs one input (the DEM)"))?;
        let mut spill: HashMap<(u32, u32), f32> = HashMap::new();
        let f = flood_tile(v, inputs.get(1), |a, b, e| {
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
        check_summaries("fill reduce", summaries.len(), layout)?;
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
        let f = flood_tile(v, inputs.get(1), |_, _, _| {})?;
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
    /// Divide the result by each row's contour width
    /// ([`super::areas::contour_width`]): specific catchment area when the
    /// weights are cell areas in m² ([`super::areas::CellAreas`]).
    pub sca: bool,
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

/// The water (fixed point) each perimeter cell of each tile receives from
/// other tiles, tile after tile: the reduced solution of the tiled D8
/// accumulation, and the estimate of one round of the divergent one
/// ([`super::tiled_mfd`]).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct PerimeterInflow {
    pub(super) offsets: Vec<usize>,
    pub(super) inflow: Vec<i128>,
}

impl PerimeterInflow {
    /// Inflows of tile `id`'s perimeter cells (row-major perimeter order);
    /// empty before the first round (= all zero).
    pub fn tile(&self, id: TileId) -> &[i128] {
        match self.offsets.get(id) {
            Some(&a) => {
                let b = self
                    .offsets
                    .get(id + 1)
                    .copied()
                    .unwrap_or(self.inflow.len());
                &self.inflow[a..b]
            }
            None => &[],
        }
    }
    fn is_zero(&self) -> bool {
        self.inflow.iter().all(|&v| v == 0)
    }
    /// Same estimate (an empty one equals all zeros).
    pub(super) fn same(&self, o: &PerimeterInflow) -> bool {
        match (self.inflow.is_empty(), o.inflow.is_empty()) {
            (true, true) => true,
            (true, false) => o.is_zero(),
            (false, true) => self.is_zero(),
            (false, false) => self == o,
        }
    }
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
            out.push(decode_code(c, || {
                (
                    v.core.x + (i % gw) as i64 - h,
                    v.core.y + (i / gw) as i64 - h,
                )
            })?);
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
        let own = if self.weighted {
            weighted_amounts(inputs, 1, d, "accumulation", "directions", |i| {
                core[i] != NODATA_DIR
            })?
        } else {
            core.iter()
                .map(|&c| if c == NODATA_DIR { 0 } else { 1 })
                .collect()
        };
        Ok((all, core, own, w, h))
    }
}

impl GlobalStep for TiledAccumulation {
    type In = f32;
    type Out = f64;
    type Summary = AccumSummary;
    type Solution = PerimeterInflow;
    type Slice = Vec<i128>;

    fn name(&self) -> String {
        "accumulate".into()
    }
    fn params(&self) -> serde_json::Value {
        serde_json::json!({"algorithm": "D8 accumulation (Barnes 2017)", "weighted": self.weighted, "sca": self.sca})
    }
    fn halo(&self) -> usize {
        1
    }

    fn outputs(&self) -> Vec<OutputSpec> {
        vec![OutputSpec::continuous(DType::F64, ACCUMULATION_NODATA)]
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

    fn reduce(&self, layout: &TileLayout, summaries: Vec<AccumSummary>) -> Result<PerimeterInflow> {
        check_summaries("accumulation reduce", summaries.len(), layout)?;
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
        Ok(PerimeterInflow { offsets, inflow })
    }

    fn slice(&self, sol: &PerimeterInflow, id: TileId) -> Vec<i128> {
        sol.tile(id).to_vec()
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
        if self.sca {
            super::areas::divide_by_contour_width(o, &inputs[0].georef, inputs[0].core.y);
        }
        Ok(())
    }
}

// ---------------------------------------------------- cross-tile pairs ----

/// The D8 code of a direction cell read as `f32` (NaN or 255 are nodata);
/// `at()` gives the cell's raster position for the error, computed only
/// when the value is not a code.
#[inline]
pub(super) fn decode_code(c: f32, at: impl FnOnce() -> (i64, i64)) -> Result<u8> {
    if c.is_nan() || c == NODATA_DIR as f32 {
        Ok(NODATA_DIR)
    } else if (0.0..=128.0).contains(&c)
        && c.fract() == 0.0
        && (c == 0.0 || super::code_to_dir(c as u8).is_some())
    {
        Ok(c as u8)
    } else {
        let (gx, gy) = at();
        Err(Error::invalid(format!(
            "flow direction {c} at cell ({gx}, {gy}) is not a D8 code (0, 1, 2, 4, …, 128; NaN or 255 for nodata)"
        )))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
