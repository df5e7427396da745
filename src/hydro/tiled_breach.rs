//! Breaching and Rho8 across tiles.
//!
//! - [`TiledLeastCostBreach`]: least-cost breaching
//!   ([`super::BreachMethod::LeastCost`]) as a [`LocalStep`] with a halo of
//!   `2·dist + 1`, on two inputs: the DEM and its filled DEM (from
//!   [`super::tiled::TiledFill`], exact across tiles). Each pit is carved
//!   independently on the input, inside the `(2·dist+1)²` window centred on
//!   it, and the result is the pointwise minimum of all carves; so a core
//!   cell is changed only by pits within `dist` of it, whose searches read
//!   cells within `dist` of the pit (and their neighbours, for the outlet
//!   test): everything a core cell depends on lies within `2·dist + 1` of
//!   it. The tiled result therefore equals [`super::breach()`] with the same
//!   method bit for bit, for every tile size — the bound "breach paths no
//!   longer than the halo" holds by construction, since no path leaves its
//!   window. `fill_remaining` is a further [`super::tiled::TiledFill`] pass
//!   over the carved DEM (the CLI chains the three passes).
//! - Flood-order breaching and the selective hybrid are *not* tiled: the
//!   channel they carve is the priority-flood's path back towards the
//!   outlet, whose shape depends on the flood order over the whole DEM
//!   (a carve can run back across any number of tiles). They run in memory.
//! - [`TiledRho8`]: Rho8 directions across tiles. Rho8 differs from D8 only
//!   on cells that have a lower neighbour (a seeded, tiling-independent
//!   variate per global cell), and both leave the same cells NO_FLOW, so the
//!   flats are resolved by [`super::tiled::TiledD8`]'s map/reduce unchanged
//!   and `apply` replaces the steepest-descent codes by Rho8's. Equal to
//!   [`super::rho8_directions`] bit for bit.

use super::breach::least_cost_carve;
use super::rho8::{rho8_cell, rho8_random};
use super::tiled::{D8Slice, D8Solution, D8Summary, TiledD8};
use super::{outlet_cells, valid, BreachOptions, NODATA_DIR, NO_FLOW};
use crate::error::{Error, Result};
use crate::exec::output::OutputSpec;
use crate::exec::{GlobalStep, LocalStep};
use crate::raster::{DType, Grid, TileId, TileLayout, TileView};

/// Least-cost breaching across tiles; see the module docs. Inputs: the DEM
/// and its filled DEM (f32, NaN = nodata); output: the carved DEM (f32, NaN
/// on nodata).
#[derive(Debug, Clone, Copy)]
pub struct TiledLeastCostBreach {
    /// Search distance in cells (1..=[`super::breach::MAX_BREACH_DIST`]).
    pub dist: usize,
    /// Carve strictly descending channels (one f32 step per cell).
    pub epsilon: bool,
}

impl TiledLeastCostBreach {
    /// The step for `opts` (least-cost method only; `fill_remaining` is a
    /// separate fill pass and is ignored here).
    pub fn from_options(opts: &BreachOptions) -> Result<Self> {
        opts.validate()?;
        match opts.method {
            super::BreachMethod::LeastCost { dist } => Ok(TiledLeastCostBreach {
                dist,
                epsilon: opts.epsilon,
            }),
            m => Err(Error::invalid(format!(
                "breach: {m:?} runs in memory only; across tiles use least-cost breaching"
            ))),
        }
    }
}

impl LocalStep for TiledLeastCostBreach {
    type In = f32;
    type Out = f32;

    fn name(&self) -> String {
        "breach".into()
    }
    fn params(&self) -> serde_json::Value {
        serde_json::json!({
            "algorithm": "least-cost breaching (Lindsay & Dhun 2015), independent pits, pointwise minimum",
            "dist": self.dist,
            "epsilon": self.epsilon,
        })
    }
    fn halo(&self) -> usize {
        2 * self.dist + 1
    }
    fn scratch_bytes(&self, tile: usize) -> u64 {
        let side = (tile + 2 * self.halo()) as u64;
        // out, stamps, closed, cost, prev, outlet
        side * side * (4 + 4 + 4 + 8 + 4 + 1)
    }

    fn outputs(&self) -> Vec<OutputSpec> {
        vec![OutputSpec::elevation()]
    }
    fn run(&self, inputs: &[TileView<f32>], out: &mut [Grid<f32>]) -> Result<()> {
        let (Some(dem), Some(filled)) = (inputs.first(), inputs.get(1)) else {
            return Err(Error::invalid(
                "breach needs two inputs: the DEM and its filled DEM",
            ));
        };
        let hl = self.halo();
        if dem.halo < hl || filled.halo != dem.halo || filled.core != dem.core {
            return Err(Error::invalid(format!(
                "breach: tile views need a halo of {hl} on both inputs"
            )));
        }
        let (gw, gh) = (dem.grid.width(), dem.grid.height());
        if gw.checked_mul(gh).is_none_or(|n| n >= u32::MAX as usize) {
            return Err(Error::invalid(
                "breach: a tile with its halo exceeds 2^32 cells; use a smaller --tile",
            ));
        }
        let z = dem.grid.data();
        let outlet = outlet_cells(z, gw, gh);
        let (cw, ch) = (dem.core.w, dem.core.h);
        let off = dem.halo;
        let d = self.dist;
        let region = (off - d, off - d, off + cw + d, off + ch + d);
        let carved = least_cost_carve(
            z,
            filled.grid.data(),
            &outlet,
            gw,
            gh,
            d,
            self.epsilon,
            region,
        )?;
        let o = out
            .first_mut()
            .ok_or_else(|| Error::invalid("breach: no output grid"))?;
        for y in 0..ch {
            for x in 0..cw {
                let v = carved[(y + off) * gw + x + off];
                o.set(x, y, if valid(v) { v } else { f32::NAN });
            }
        }
        Ok(())
    }
}

/// Rho8 flow directions across tiles (input: a filled DEM, f32; halo 2;
/// output: ESRI codes); see the module docs.
#[derive(Debug, Clone, Copy, Default)]
pub struct TiledRho8 {
    pub seed: u64,
}

impl GlobalStep for TiledRho8 {
    type In = f32;
    type Out = u8;
    type Summary = D8Summary;
    type Solution = D8Solution;
    type Slice = D8Slice;

    fn name(&self) -> String {
        "rho8".into()
    }
    fn params(&self) -> serde_json::Value {
        serde_json::json!({
            "algorithm": "Rho8 (Fairfield & Leymarie 1991), flats after Barnes, Lehman & Mulla 2014",
            "seed": self.seed,
        })
    }
    fn halo(&self) -> usize {
        TiledD8.halo()
    }
    fn outputs(&self) -> Vec<OutputSpec> {
        vec![OutputSpec::categorical(DType::U8, NODATA_DIR as f64)]
    }
    fn map(&self, inputs: &[TileView<f32>]) -> Result<D8Summary> {
        TiledD8.map(inputs)
    }
    fn reduce(&self, layout: &TileLayout, summaries: Vec<D8Summary>) -> Result<D8Solution> {
        TiledD8.reduce(layout, summaries)
    }
    fn slice(&self, sol: &D8Solution, id: TileId) -> D8Slice {
        TiledD8.slice(sol, id)
    }
    fn apply(&self, inputs: &[TileView<f32>], slice: &D8Slice, out: &mut [Grid<u8>]) -> Result<()> {
        TiledD8.apply(inputs, slice, out)?;
        let v = inputs
            .first()
            .ok_or_else(|| Error::invalid("rho8 needs one input (the filled DEM)"))?;
        let o = out
            .first_mut()
            .ok_or_else(|| Error::invalid("rho8 apply: no output grid"))?;
        let (gw, gh, hl) = (v.grid.width(), v.grid.height(), v.halo);
        let z = v.grid.data();
        for y in 0..v.core.h {
            for x in 0..v.core.w {
                let gx = (v.core.x + x as i64) as u64;
                let gy = (v.core.y + y as i64) as u64;
                let code = rho8_cell(z, gw, gh, x + hl, y + hl, rho8_random(self.seed, gx, gy));
                if code != NO_FLOW {
                    o.set(x, y, code);
                }
            }
        }
        Ok(())
    }
}
