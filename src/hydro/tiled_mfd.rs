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
//! # The passes (block Jacobi iteration over tiles)
//! Each round is one [`GlobalStep`] run through the [`Engine`] with no
//! output: *map* routes one tile (fractions from the filled DEM with a halo
//! of 1; cells without a lower neighbour take the D8 code of input 1, which
//! must be [`super::d8_directions`] of the same DEM, e.g. from
//! [`super::tiled::TiledD8`]), adds the current estimate of the water its
//! perimeter cells receive from other tiles, accumulates the tile, and
//! reports every share its perimeter cells send into another tile; *reduce*
//! sums those shares into the next estimate of every perimeter cell's
//! inflow. Rounds repeat until the estimate does not change; one last run
//! applies it (its map is skipped).
//!
//! **Exactness and bound.** Call a flow path's *crossings* the number of
//! times it passes from one tile into another, and `L` the largest number of
//! crossings of any path of the DAG. After round `k` the inflow of every
//! perimeter cell whose upstream paths cross at most `k - 1` times is
//! final (induction on `k`: such a cell's inflow depends only on cells of
//! other tiles whose own upstream paths cross at most `k - 2` times). So the
//! estimate is exact after `L + 1` rounds and stops changing: the run costs
//! `L + 2` map passes and one apply pass, and the result is the in-memory
//! one bit for bit (the tile's accumulation with the exact inflows is the
//! unique solution restricted to the tile). A change in round `k` can only
//! happen while `k ≤ L + 1`, so the loop always ends (`L` is finite on a
//! DAG: at most the number of perimeter cells). `L` is small on most
//! terrain but grows when divergent flow runs along a tile seam and
//! crosses it back and forth; the measured rounds are in
//! `docs/notes/mfd.md`. Memory: O(tile × workers + total perimeter).

use super::accum::{fixed_to_f64, weight_to_fixed};
use super::dinf::dinf_cell;
use super::mfd::{
    accumulate_fixed_core, d8_fallback, mfd_cell, mfd_params, overflow, MfdMethod, ONE,
};
use super::tiled::{perimeter_index, perimeter_len};
use super::{code_to_dir, valid, DX, DY, NODATA_DIR};
use crate::error::{Error, Result};
use crate::exec::{Engine, GlobalStep, TileSink};
use crate::raster::{Grid, RasterSource, TileId, TileLayout, TileView};
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

/// Estimate of the water (fixed point) each perimeter cell of each tile
/// receives from other tiles; the solution of one round.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct MultiInflow {
    offsets: Vec<usize>,
    inflow: Vec<i128>,
}

impl MultiInflow {
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
    fn same(&self, o: &MultiInflow) -> bool {
        match (self.inflow.is_empty(), o.inflow.is_empty()) {
            (true, true) => true,
            (true, false) => o.is_zero(),
            (false, true) => self.is_zero(),
            (false, false) => self == o,
        }
    }
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
    pub inflow: Arc<MultiInflow>,
    /// Final run: skip the map work and reduce to `inflow` unchanged.
    pub final_pass: bool,
}

/// Shares sent by one tile's perimeter cells into other tiles:
/// (x, y) in the tile, direction (E..NE order), fixed-point amount.
#[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
pub struct MultiSummary {
    pub w: usize,
    pub h: usize,
    pub out: Vec<(u32, u32, u8, i128)>,
}

/// Result of routing one tile.
struct Solved {
    w: usize,
    h: usize,
    valid: Vec<bool>,
    acc: Vec<i128>,
    out: Vec<(u32, u32, u8, i128)>,
}

fn decode_code(c: f32, gx: i64, gy: i64) -> Result<u8> {
    if c.is_nan() || c == NODATA_DIR as f32 {
        Ok(NODATA_DIR)
    } else if (0.0..=128.0).contains(&c)
        && c.fract() == 0.0
        && (c == 0.0 || code_to_dir(c as u8).is_some())
    {
        Ok(c as u8)
    } else {
        Err(Error::invalid(format!(
            "flow direction {c} at cell ({gx}, {gy}) is not a D8 code (0, 1, 2, 4, …, 128; NaN or 255 for nodata)"
        )))
    }
}

impl TiledMultiAccumulation {
    /// First round of `router` (no inflow yet).
    pub fn new(router: Router, weighted: bool) -> Self {
        TiledMultiAccumulation {
            router,
            weighted,
            inflow: Arc::new(MultiInflow::default()),
            final_pass: false,
        }
    }

    /// Route and accumulate one tile with `inflow` at its perimeter.
    fn solve(&self, inputs: &[TileView<f32>], inflow: &[i128]) -> Result<Solved> {
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
        for y in 0..h {
            for x in 0..w {
                let (vx, vy) = (x + hl, y + hl);
                if !valid(z[vy * gw + vx]) {
                    continue;
                }
                let c = y * w + x;
                valid_core[c] = true;
                let mut f = [0.0f64; 8];
                let routed = match params {
                    Some(p) => mfd_cell(z, gw, gh, vx, vy, p, &mut f),
                    None => dinf_cell(z, gw, gh, vx, vy, &mut f).is_some(),
                };
                if !routed {
                    let code = decode_code(
                        d8.grid.data()[vy * gw + vx],
                        dem.core.x + x as i64,
                        dem.core.y + y as i64,
                    )?;
                    f = d8_fallback(code);
                }
                frac[c] = f;
            }
        }
        let mut acc = Vec::with_capacity(w * h);
        if self.weighted {
            let wt = inputs.get(2).ok_or_else(|| {
                Error::invalid("weighted divergent accumulation needs the weights as input 2")
            })?;
            if wt.core != dem.core {
                return Err(Error::invalid(
                    "divergent accumulation: weights and DEM tiles differ",
                ));
            }
            for y in 0..h {
                for x in 0..w {
                    acc.push(if valid_core[y * w + x] {
                        weight_to_fixed(wt.at(x as i64, y as i64))?
                    } else {
                        0
                    });
                }
            }
        } else {
            acc.extend(valid_core.iter().map(|&v| if v { ONE } else { 0 }));
        }
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
        let mut out = Vec::new();
        accumulate_fixed_core(&frac, w, h, &mut acc, |c, d, v| {
            let Some(d) = d else { return Ok(()) };
            if v == 0 {
                return Ok(());
            }
            let (x, y) = (c % w, c / w);
            let vx = (x + hl) as i64 + DX[d];
            let vy = (y + hl) as i64 + DY[d];
            // beyond the core (or into core nodata): another tile's valid cell?
            let inside = (0..w as i64).contains(&(vx - hl as i64))
                && (0..h as i64).contains(&(vy - hl as i64));
            if !inside && valid(z[vy as usize * gw + vx as usize]) {
                out.push((x as u32, y as u32, d as u8, v));
            }
            Ok(())
        })?;
        Ok(Solved {
            w,
            h,
            valid: valid_core,
            acc,
            out,
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
        let x = if j % side == 0 { 0 } else { w - 1 };
        (x, y)
    } else {
        (k - w - mid, h - 1)
    }
}

impl GlobalStep for TiledMultiAccumulation {
    type In = f32;
    type Out = f64;
    type Summary = MultiSummary;
    type Solution = MultiInflow;
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
        })
    }
    fn halo(&self) -> usize {
        1
    }

    fn map(&self, inputs: &[TileView<f32>]) -> Result<MultiSummary> {
        if self.final_pass {
            return Ok(MultiSummary::default());
        }
        let id = inputs.first().map(|v| v.id).unwrap_or(0);
        let s = self.solve(inputs, self.inflow.tile(id))?;
        Ok(MultiSummary {
            w: s.w,
            h: s.h,
            out: s.out,
        })
    }

    fn reduce(&self, layout: &TileLayout, summaries: Vec<MultiSummary>) -> Result<MultiInflow> {
        if self.final_pass {
            return Ok((*self.inflow).clone());
        }
        if summaries.len() != layout.count() {
            return Err(Error::invalid(format!(
                "divergent accumulation reduce: {} summaries for {} tiles",
                summaries.len(),
                layout.count()
            )));
        }
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
        let mut inflow = vec![0i128; total];
        for (t, s) in summaries.iter().enumerate() {
            let win = layout.window(t);
            let corrupt = || {
                Error::invalid(format!(
                    "divergent accumulation reduce: bad share in tile {t}'s summary"
                ))
            };
            for &(x, y, d, v) in &s.out {
                let d = d as usize;
                if d >= 8 || x as usize >= win.w || y as usize >= win.h {
                    return Err(corrupt());
                }
                let gx = win.x + x as i64 + DX[d];
                let gy = win.y + y as i64 + DY[d];
                if gx < 0 || gy < 0 || gx as usize >= layout.width || gy as usize >= layout.height {
                    return Err(corrupt());
                }
                let (gx, gy) = (gx as usize, gy as usize);
                let tb = layout.id(gx / layout.tile, gy / layout.tile);
                if tb == t {
                    return Err(corrupt());
                }
                let wb = layout.window(tb);
                let (lx, ly) = (gx - wb.x as usize, gy - wb.y as usize);
                let k = perimeter_index(wb.w, wb.h, lx, ly).ok_or_else(corrupt)?;
                let u = offsets[tb] + k;
                inflow[u] = inflow[u].checked_add(v).ok_or_else(overflow)?;
            }
        }
        Ok(MultiInflow { offsets, inflow })
    }

    fn slice(&self, sol: &MultiInflow, id: TileId) -> Vec<i128> {
        sol.tile(id).to_vec()
    }

    fn apply(
        &self,
        inputs: &[TileView<f32>],
        slice: &Vec<i128>,
        out: &mut [Grid<f64>],
    ) -> Result<()> {
        let s = self.solve(inputs, slice)?;
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
    let mut step = TiledMultiAccumulation::new(router, weighted);
    let mut rounds = 0usize;
    loop {
        let next = engine.run_global(&step, inputs, layout, Vec::new())?;
        rounds += 1;
        if next.same(&step.inflow) {
            break;
        }
        step.inflow = Arc::new(next);
    }
    step.final_pass = true;
    engine.run_global(&step, inputs, layout, sinks)?;
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
