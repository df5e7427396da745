//! Divergent (MFD and D∞) flow accumulation across tiles, equal bit for bit
//! to the in-memory [`super::mfd::accumulate_fixed`] /
//! [`super::mfd::accumulate_cells`] / [`super::mfd::accumulate_fractions`].
//!
//! # Why the D8 scheme does not carry over
//! Barnes (2017, "Parallel non-divergent flow accumulation for trillion cell
//! digital elevation models on desktops or clusters", EMS 92) sends each
//! perimeter cell's flow along one path, so a tile's effect on its
//! perimeter is a list of links. With divergent flow a perimeter inflow
//! spreads over many cells and reaches many perimeter cells; the exact
//! transfer is a dense perimeter × perimeter matrix of products of
//! fractions, which is only exact in unbounded-precision arithmetic, and
//! O(perimeter²) in size.
//!
//! # Definition that makes tiles possible
//! Accumulation is exact fixed point with a per-cell deterministic split
//! ([`super::mfd::split_fixed`]): the water a cell passes on is a function
//! of its total only, and totals are integer sums, which do not depend on
//! the order of addition. So the result is the unique solution of
//! `A(c) = own(c) + Σ share(A(u) → c)` over the flow DAG, whatever order
//! evaluates it.
//!
//! # The passes (iteration over tiles, exact band solve in the reduce)
//! Each round is one [`GlobalStep`] run through the [`Engine`] with no
//! output. *map* routes one tile (fractions from the filled DEM with a halo
//! of 1; cells without a lower neighbour take the D8 code of input 1, which
//! must be [`super::d8_directions`] of the same DEM, e.g. from
//! [`super::tiled::TiledD8`]), adds the current estimate of the water its
//! perimeter cells receive from other tiles, accumulates the tile, and
//! reports for every perimeter cell its fractions and its *base*: own
//! contribution plus what it receives from the tile's interior cells.
//! *reduce* joins all perimeter cells of all tiles into one *band* graph
//! (a sub-graph of the flow DAG: edges between perimeter cells of the same
//! or of neighbouring tiles) and accumulates it exactly in topological
//! order, starting from the bases; the shares that cross between tiles are
//! the next inflow estimate. Rounds repeat until the estimate does not
//! change; one last run applies it (its map is skipped).
//!
//! **Exactness and bound.** The band solve is exact given exact bases, and
//! a base depends on other tiles only through a path that leaves the band
//! into a tile's interior after having crossed from another tile. Call `L`
//! the largest number of such *interior re-entries* along any flow path.
//! After round `k` the inflow of every perimeter cell whose upstream paths
//! have at most `k - 1` re-entries is final (induction on `k`), so the
//! estimate is exact after `L + 1` rounds and the next round confirms it:
//! `L + 2` map passes and one apply pass, and the result equals the
//! in-memory one bit for bit (it is the unique solution of the equations
//! above). The loop always ends (`L` is finite on a DAG). Flow that runs
//! along a seam and crosses it back and forth stays in the band and costs
//! no extra round; flow that wanders a few cells away from a seam and back
//! does. Measured rounds are in `docs/design/hydrology.md#divergent-accumulation-d-mfd-and-the-d8-kernel`. Memory:
//! O(tile × workers) for map/apply, O(total perimeter) for the reduce
//! (≈ 120 bytes per perimeter cell, about twice that while the summaries
//! are decoded).

use super::accum::fixed_to_f64;
use super::dinf::dinf_cell;
use super::mfd::{
    accumulate_fixed_core, d8_fallback, mfd_cell, mfd_params, overflow, split_fixed, MfdMethod, ONE,
};
use super::tiled::{
    check_summaries, decode_code, perimeter_cells, perimeter_index, perimeter_len,
    weighted_amounts, PerimeterInflow,
};
use super::{valid, ACCUMULATION_NODATA, DX, DY};
use crate::error::{Error, Result};
use crate::exec::output::OutputSpec;
use crate::exec::{Engine, GlobalStep, Run, TileSink};
use crate::raster::neighbours::CellGeometry;
use crate::raster::{DType, Grid, RasterSource, TileId, TileLayout, TileView};
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// Divergent router of a tiled accumulation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Router {
    /// Multiple flow directions ([`super::mfd::mfd_flow`]).
    Mfd(MfdMethod),
    /// D-infinity (Tarboton 1997, [`super::dinf::dinf`]).
    Dinf,
}

/// One round (or the final apply) of the tiled divergent accumulation; see
/// the module docs. Inputs (f32, halo 1): 0 the filled DEM (NaN = nodata),
/// 1 its D8 directions (ESRI codes; NaN or 255 = nodata), 2 the weights when
/// `weighted`. Output: f64 accumulation (cells or weight sums), NaN on
/// nodata. Use [`run_multi_accumulation`] to run all rounds.
#[derive(Debug, Clone)]
pub struct TiledMultiAccumulation {
    /// The router.
    pub router: Router,
    /// Sum the weights (input 2) instead of counting cells.
    pub weighted: bool,
    /// The inflow estimate this round starts from.
    pub inflow: Arc<PerimeterInflow>,
    /// Final run: skip the map work and reduce to `inflow` unchanged.
    pub final_pass: bool,
    /// Divide the result by each row's contour width (specific catchment
    /// area when the weights are cell areas in m², [`super::areas`]).
    pub sca: bool,
}

/// Per-tile summary of one round: for each perimeter cell (row-major
/// perimeter order) its *base* — own contribution plus the water it
/// receives from the tile's interior cells, given the round's inflow
/// estimate — and its flow fractions as f64 bit patterns (so that they
/// survive any serialisation exactly; NaN for nodata). O(perimeter).
#[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
pub struct MultiSummary {
    pub w: usize,
    pub h: usize,
    pub nodes: Vec<(i128, [u64; 8])>,
}

/// Result of routing one tile.
struct Solved {
    w: usize,
    h: usize,
    valid: Vec<bool>,
    acc: Vec<i128>,
    /// Perimeter nodes for the summary (map only).
    nodes: Vec<(i128, [u64; 8])>,
}

impl TiledMultiAccumulation {
    /// First round of `router` (no inflow yet).
    pub fn new(router: Router, weighted: bool) -> Self {
        TiledMultiAccumulation {
            router,
            weighted,
            inflow: Arc::new(PerimeterInflow::default()),
            final_pass: false,
            sca: false,
        }
    }

    /// Route and accumulate one tile with `inflow` at its perimeter.
    fn solve(&self, inputs: &[TileView<f32>], inflow: &[i128], want_nodes: bool) -> Result<Solved> {
        let (dem, d8) =
            match inputs {
                [a, b, ..] => (a, b),
                _ => return Err(Error::invalid(
                    "divergent accumulation needs the filled DEM and its D8 directions as inputs",
                )),
            };
        if dem.halo < 1 || d8.halo != dem.halo || d8.core != dem.core {
            return Err(Error::invalid(
                "divergent accumulation: inputs need the same tiles with a halo of at least 1",
            ));
        }
        let params = match self.router {
            Router::Mfd(m) => Some(mfd_params(m)?),
            Router::Dinf => None,
        };
        let (w, h) = (dem.core.w, dem.core.h);
        let hl = dem.halo;
        let gw = dem.grid.width();
        let gh = dem.grid.height();
        let z = dem.grid.data();
        let mut frac = vec![[f64::NAN; 8]; w * h];
        let mut valid_core = vec![false; w * h];
        let geo = CellGeometry::of_rows(&dem.georef, dem.core.y, h);
        for y in 0..h {
            let g = geo.row(y);
            for x in 0..w {
                let (vx, vy) = (x + hl, y + hl);
                if !valid(z[vy * gw + vx]) {
                    continue;
                }
                let c = y * w + x;
                valid_core[c] = true;
                let mut f = [0.0f64; 8];
                let routed = match params {
                    Some(p) => mfd_cell(z, gw, gh, vx, vy, p, g, &mut f),
                    None => dinf_cell(z, gw, gh, vx, vy, g, &mut f).is_some(),
                };
                if !routed {
                    let code = decode_code(d8.grid.data()[vy * gw + vx], || {
                        (dem.core.x + x as i64, dem.core.y + y as i64)
                    })?;
                    f = d8_fallback(code);
                }
                frac[c] = f;
            }
        }
        let mut acc = if self.weighted {
            weighted_amounts(inputs, 2, dem, "divergent accumulation", "DEM", |i| {
                valid_core[i]
            })?
        } else {
            valid_core
                .iter()
                .map(|&v| if v { ONE } else { 0 })
                .collect()
        };
        if !inflow.is_empty() {
            if inflow.len() != perimeter_len(w, h) {
                return Err(Error::invalid(
                    "divergent accumulation: inflow estimate does not belong to this tile",
                ));
            }
            for (k, &v) in inflow.iter().enumerate() {
                if v == 0 {
                    continue;
                }
                let (x, y) = perimeter_xy(w, h, k);
                let c = y * w + x;
                acc[c] = acc[c].checked_add(v).ok_or_else(overflow)?;
            }
        }
        let own: Vec<i128> = if want_nodes {
            perimeter_cells(w, h).map(|(x, y)| acc[y * w + x]).collect()
        } else {
            Vec::new()
        };
        accumulate_fixed_core(&frac, w, h, &mut acc, |_, _, _| Ok(()))?;
        let mut nodes = Vec::new();
        if want_nodes {
            // base = final accumulation − water from perimeter cells of this
            // tile − inflow from other tiles (own + interior inflow remains)
            let np = perimeter_len(w, h);
            let mut from_perim = vec![0i128; np];
            let mut share = [0i128; 8];
            for (x, y) in perimeter_cells(w, h) {
                let c = y * w + x;
                if !valid_core[c] {
                    continue;
                }
                split_fixed(acc[c], &frac[c], &mut share)?;
                for d in 0..8 {
                    if share[d] == 0 {
                        continue;
                    }
                    let nx = x as i64 + DX[d];
                    let ny = y as i64 + DY[d];
                    if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
                        continue;
                    }
                    let (nx, ny) = (nx as usize, ny as usize);
                    if let Some(j) = perimeter_index(w, h, nx, ny) {
                        if valid_core[ny * w + nx] {
                            from_perim[j] =
                                from_perim[j].checked_add(share[d]).ok_or_else(overflow)?;
                        }
                    }
                }
            }
            nodes.reserve(np);
            for (k, (x, y)) in perimeter_cells(w, h).enumerate() {
                let c = y * w + x;
                if !valid_core[c] {
                    nodes.push((0, [f64::NAN.to_bits(); 8]));
                    continue;
                }
                let inf = inflow.get(k).copied().unwrap_or(0);
                let interior = acc[c] - own[k] - inf - from_perim[k];
                nodes.push((own[k] + interior, frac[c].map(f64::to_bits)));
            }
        }
        Ok(Solved {
            w,
            h,
            valid: valid_core,
            acc,
            nodes,
        })
    }
}

/// (x, y) of perimeter cell `k` of a `w` x `h` tile (inverse of
/// [`perimeter_index`]).
fn perimeter_xy(w: usize, h: usize, k: usize) -> (usize, usize) {
    if k < w {
        return (k, 0);
    }
    let side = if w == 1 { 1 } else { 2 };
    let mid = (h.saturating_sub(2)) * side;
    if k < w + mid {
        let j = k - w;
        let y = 1 + j / side;
        let x = if j.is_multiple_of(side) { 0 } else { w - 1 };
        (x, y)
    } else {
        (k - w - mid, h - 1)
    }
}

impl GlobalStep for TiledMultiAccumulation {
    type In = f32;
    type Out = f64;
    type Summary = MultiSummary;
    type Solution = PerimeterInflow;
    type Slice = Vec<i128>;

    fn name(&self) -> String {
        "accumulate-multi".into()
    }
    fn params(&self) -> serde_json::Value {
        let router = match self.router {
            Router::Dinf => "D-infinity (Tarboton 1997)".to_string(),
            Router::Mfd(MfdMethod::Quinn) => "MFD Quinn et al. 1991".into(),
            Router::Mfd(MfdMethod::Freeman) => "MFD Freeman 1991".into(),
            Router::Mfd(MfdMethod::Holmgren(p)) => format!("MFD Holmgren 1994, exponent {p}"),
        };
        serde_json::json!({
            "algorithm": "divergent accumulation, exact fixed point, block-Jacobi rounds over tiles",
            "router": router,
            "weighted": self.weighted,
            "sca": self.sca,
        })
    }
    fn halo(&self) -> usize {
        1
    }

    fn outputs(&self) -> Vec<OutputSpec> {
        vec![OutputSpec::continuous(DType::F64, ACCUMULATION_NODATA)]
    }
    fn map(&self, inputs: &[TileView<f32>]) -> Result<MultiSummary> {
        if self.final_pass {
            return Ok(MultiSummary::default());
        }
        let id = inputs.first().map(|v| v.id).unwrap_or(0);
        let s = self.solve(inputs, self.inflow.tile(id), true)?;
        Ok(MultiSummary {
            w: s.w,
            h: s.h,
            nodes: s.nodes,
        })
    }

    fn reduce(&self, layout: &TileLayout, summaries: Vec<MultiSummary>) -> Result<PerimeterInflow> {
        if self.final_pass {
            return Ok((*self.inflow).clone());
        }
        check_summaries("divergent accumulation reduce", summaries.len(), layout)?;
        let mut offsets = Vec::with_capacity(summaries.len());
        let mut total = 0usize;
        for (t, s) in summaries.iter().enumerate() {
            let win = layout.window(t);
            if s.w != win.w || s.h != win.h {
                return Err(Error::invalid(format!(
                    "divergent accumulation reduce: summary of tile {t} does not match the layout"
                )));
            }
            offsets.push(total);
            total += perimeter_len(win.w, win.h);
        }
        for (t, s) in summaries.iter().enumerate() {
            if s.nodes.len() != perimeter_len(s.w, s.h) {
                return Err(Error::invalid(format!(
                    "divergent accumulation reduce: summary of tile {t} has {} perimeter cells, expected {}",
                    s.nodes.len(),
                    perimeter_len(s.w, s.h)
                )));
            }
        }
        // node id -> (tile, perimeter index); base and fractions per node
        let mut owner = Vec::with_capacity(total);
        let mut nodes: Vec<(i128, [f64; 8])> = Vec::with_capacity(total);
        for (t, s) in summaries.iter().enumerate() {
            owner.extend((0..s.nodes.len()).map(|k| (t as u32, k as u32)));
            nodes.extend(s.nodes.iter().map(|(b, f)| (*b, f.map(f64::from_bits))));
        }
        drop(summaries);
        let node = |u: usize| &nodes[u];
        // Band neighbour of node u in direction d: another perimeter node
        // (same tile or another), with whether the edge crosses tiles.
        let band_neighbour = |u: usize, d: usize| -> Option<(usize, bool)> {
            let (t, k) = (owner[u].0 as usize, owner[u].1 as usize);
            let win = layout.window(t);
            let (x, y) = perimeter_xy(win.w, win.h, k);
            let gx = win.x + x as i64 + DX[d];
            let gy = win.y + y as i64 + DY[d];
            if gx < 0 || gy < 0 || gx as usize >= layout.width || gy as usize >= layout.height {
                return None;
            }
            let (gx, gy) = (gx as usize, gy as usize);
            let tb = layout.id(gx / layout.tile, gy / layout.tile);
            let wb = layout.window(tb);
            let j = perimeter_index(wb.w, wb.h, gx - wb.x as usize, gy - wb.y as usize)?;
            let v = offsets[tb] + j;
            if node(v).1[0].is_nan() {
                None
            } else {
                Some((v, tb != t))
            }
        };
        // Kahn's order over the band of perimeter cells (a sub-graph of
        // the flow DAG), accumulating exactly as inside a tile.
        let mut indeg = vec![0u8; total];
        let mut acc = vec![0i128; total];
        let mut valid_nodes = 0usize;
        for (u, a) in acc.iter_mut().enumerate() {
            let (base, f) = node(u);
            if f[0].is_nan() {
                continue;
            }
            valid_nodes += 1;
            *a = *base;
            for (d, &fd) in f.iter().enumerate() {
                if fd > 0.0 {
                    if let Some((v, _)) = band_neighbour(u, d) {
                        indeg[v] += 1;
                    }
                }
            }
        }
        let mut stack: Vec<usize> = (0..total)
            .rev()
            .filter(|&u| !node(u).1[0].is_nan() && indeg[u] == 0)
            .collect();
        let mut inflow = vec![0i128; total];
        let mut share = [0i128; 8];
        let mut done = 0usize;
        while let Some(u) = stack.pop() {
            done += 1;
            let f = &node(u).1;
            split_fixed(acc[u], f, &mut share)?;
            for d in 0..8 {
                if f[d] <= 0.0 {
                    continue;
                }
                if let Some((v, cross)) = band_neighbour(u, d) {
                    acc[v] = acc[v].checked_add(share[d]).ok_or_else(overflow)?;
                    if cross {
                        inflow[v] = inflow[v].checked_add(share[d]).ok_or_else(overflow)?;
                    }
                    indeg[v] -= 1;
                    if indeg[v] == 0 {
                        stack.push(v);
                    }
                }
            }
        }
        if done != valid_nodes {
            return Err(Error::invalid(
                "divergent accumulation reduce: the flow between tiles has a cycle; inputs must be a filled DEM and its own D8 directions",
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
        let s = self.solve(inputs, slice, false)?;
        let o = out
            .first_mut()
            .ok_or_else(|| Error::invalid("divergent accumulation apply: no output grid"))?;
        for (i, cell) in o.data_mut().iter_mut().enumerate() {
            *cell = if s.valid[i] {
                fixed_to_f64(s.acc[i])
            } else {
                f64::NAN
            };
        }
        if self.sca {
            super::areas::divide_by_contour_width(o, &inputs[0].georef, inputs[0].core.y);
        }
        Ok(())
    }
}

/// What a tiled divergent accumulation did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MultiRun {
    /// Map rounds run (the last one confirmed the fixed point).
    pub rounds: usize,
}

/// Run [`TiledMultiAccumulation`] to its fixed point on `engine` and write
/// the accumulation to `sinks` (one f64 output). `inputs`: filled DEM, its
/// D8 directions, and the weights when `weighted`.
pub fn run_multi_accumulation<E: Engine>(
    engine: &E,
    router: Router,
    weighted: bool,
    inputs: &[&dyn RasterSource],
    layout: TileLayout,
    sinks: Vec<Box<dyn TileSink>>,
) -> Result<MultiRun> {
    run_multi(
        engine,
        TiledMultiAccumulation::new(router, weighted),
        inputs,
        layout,
        sinks,
    )
}

/// [`run_multi_accumulation`] of a step set up by the caller (e.g. with
/// [`TiledMultiAccumulation::sca`]); `step` must be a first round.
pub fn run_multi<E: Engine>(
    engine: &E,
    mut step: TiledMultiAccumulation,
    inputs: &[&dyn RasterSource],
    layout: TileLayout,
    sinks: Vec<Box<dyn TileSink>>,
) -> Result<MultiRun> {
    // L + 2 rounds suffice and L < the number of perimeter cells (module
    // docs); more means the inputs are not one DEM and its own directions
    let limit = (0..layout.count())
        .map(|t| {
            let w = layout.window(t);
            perimeter_len(w.w, w.h)
        })
        .sum::<usize>()
        + 2;
    let mut rounds = 0usize;
    loop {
        let next = engine.run_global(&step, Run::solution_only(inputs, layout))?;
        rounds += 1;
        if next.same(&step.inflow) {
            break;
        }
        if rounds >= limit {
            return Err(Error::invalid(format!(
                "divergent accumulation across tiles did not settle after {rounds} rounds; \
                 the inputs must be a DEM and its own D8 directions"
            )));
        }
        step.inflow = Arc::new(next);
    }
    step.final_pass = true;
    engine.run_global_apply(&step, Run::new(inputs, layout, sinks))?;
    Ok(MultiRun { rounds })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn perimeter_xy_inverts_perimeter_index() {
        for w in 1..7 {
            for h in 1..7 {
                for k in 0..perimeter_len(w, h) {
                    let (x, y) = perimeter_xy(w, h, k);
                    assert_eq!(perimeter_index(w, h, x, y), Some(k), "{w}x{h} k={k}");
                }
            }
        }
    }
}
