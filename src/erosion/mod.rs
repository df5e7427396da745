//! Erosion models: hydraulic (virtual pipes), thermal, hillslope diffusion,
//! stream power with uplift, and constrained erosion, tiled with halo exchange.
//!
//! The local models (hydraulic, thermal, diffusion) implement [`LocalModel`]:
//! a state of `f64` fields per cell (field 0 is the terrain) advanced by
//! substeps, each of which reads neighbours at most [`LocalModel::radius`]
//! cells away. [`tiled`] runs them over tiles with halo exchange, bit for bit
//! equal to the whole-grid run ([`tiled::run_untiled`]).

pub mod diffusion;
pub mod hydraulic;
pub mod thermal;
pub mod tiled;

pub use diffusion::{Diffusion, DiffusionParams};
pub use hydraulic::{Hydraulic, HydraulicParams};
pub use thermal::{Thermal, ThermalParams};

use crate::error::{Error, Result};
use crate::raster::RasterInfo;
use serde::{Deserialize, Serialize};

/// Cell size in metres along x (columns) and y (rows).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CellSize {
    pub dx: f64,
    pub dy: f64,
}

impl CellSize {
    /// Square cells of `c` metres.
    pub fn square(c: f64) -> Self {
        CellSize { dx: c, dy: c }
    }

    /// The raster's cell size in metres at its middle row (one value for the
    /// whole raster, so every tile uses the same constants). Geographic
    /// rasters get the true size at their middle latitude: the models treat
    /// cells as equal rectangles, an approximation that grows with the
    /// raster's latitude span (documented in `docs/design/erosion.md#local-models-and-the-halo-exchange-driver`).
    pub fn of(info: &RasterInfo) -> Result<Self> {
        let (dx, dy) = info.georef.cell_size_m(info.height as i64 / 2);
        let c = CellSize { dx, dy };
        c.validate().map_err(|_| {
            Error::invalid(format!(
                "{}: cell size {dx} x {dy} m is not usable for erosion; give the cell size with the model's `cell` parameter",
                info.path.display()
            ))
        })?;
        Ok(c)
    }

    /// Both sizes finite and positive.
    pub fn validate(&self) -> Result<()> {
        if self.dx.is_finite() && self.dx > 0.0 && self.dy.is_finite() && self.dy > 0.0 {
            Ok(())
        } else {
            Err(Error::invalid(format!(
                "cell size {} x {} m: both must be positive numbers",
                self.dx, self.dy
            )))
        }
    }
}

/// A rectangle of the raster with the model state of every cell: `fields[f]`
/// is field `f` as a row-major `w x h` array; `(x0, y0)` is the global cell
/// of the patch's first cell (rain and other seeded inputs hash global
/// coordinates, so any patch reproduces them). Patch edges are walls for the
/// models: where a patch edge is not the raster's edge, the cells next to it
/// are wrong after a substep, and the driver discards them (ghost zone).
#[derive(Debug, Clone)]
pub struct Patch {
    pub x0: i64,
    pub y0: i64,
    pub w: usize,
    pub h: usize,
    pub fields: Vec<Vec<f64>>,
    /// Working arrays a model may keep between substeps (each `w x h`).
    pub scratch: Vec<Vec<f64>>,
}

impl Patch {
    /// A patch with `nfields` zeroed fields.
    pub fn new(x0: i64, y0: i64, w: usize, h: usize, nfields: usize) -> Self {
        Patch {
            x0,
            y0,
            w,
            h,
            fields: vec![vec![0.0; w * h]; nfields],
            scratch: Vec::new(),
        }
    }

    /// Make sure `n` scratch arrays of `w x h` exist and return them.
    pub fn scratch(&mut self, n: usize) -> &mut [Vec<f64>] {
        let len = self.w * self.h;
        if self.scratch.len() < n {
            self.scratch.resize_with(n, Vec::new);
        }
        for s in &mut self.scratch[..n] {
            if s.len() != len {
                *s = vec![0.0; len];
            }
        }
        &mut self.scratch[..n]
    }
}

/// A local erosion model: state fields per cell, advanced by substeps whose
/// stencil reaches `radius()` cells. Implementations must compute each cell
/// of a substep from the cell's and its neighbours' values only (plus global
/// coordinates and the substep number), with the same arithmetic wherever
/// the cell lies in the patch: that is what makes tiled runs exact.
pub trait LocalModel: Sync {
    /// Short name (`hydraulic`, `thermal`, `diffusion`).
    fn name(&self) -> &'static str;
    /// Parameters as JSON (provenance).
    fn params_json(&self) -> serde_json::Value;
    /// Names of the state fields; field 0 is the terrain. Default: the
    /// terrain alone.
    fn field_names(&self) -> &'static [&'static str] {
        &["terrain"]
    }
    /// Ghost cells one substep consumes (its stencil reach).
    fn radius(&self) -> usize;
    /// Substeps of the whole run.
    fn substeps(&self) -> u64;
    /// Advance `patch` by substep number `n` (0-based, global).
    fn substep(&self, patch: &mut Patch, n: u64);
    /// Turn a final core state into the output (e.g. settle suspended
    /// sediment); must be cell-local. Default: nothing.
    fn finish(&self, _patch: &mut Patch) {}
}

/// Check a run's step count and choose its cell size: the parameters' square
/// cell `cell_param` (metres) where given, else the raster's `raster`.
pub(crate) fn run_cell(steps: u64, cell_param: Option<f64>, raster: CellSize) -> Result<CellSize> {
    check_steps(steps)?;
    let cell = cell_param.map(CellSize::square).unwrap_or(raster);
    cell.validate()?;
    Ok(cell)
}

/// The provenance of a local model run: the model's name, its steps, the
/// cell size and its parameters.
pub(crate) fn model_json(
    name: &str,
    steps: u64,
    cell: CellSize,
    params: &impl serde::Serialize,
) -> serde_json::Value {
    serde_json::json!({
        "model": name,
        "steps": steps,
        "cell": [cell.dx, cell.dy],
        "params": params,
    })
}

/// SplitMix64 finaliser (Steele, Lea & Flood, "Fast splittable pseudorandom
/// number generators", OOPSLA 2014): a counter-based hash, so a value depends
/// only on its key.
#[inline]
pub(crate) fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// A uniform number in [0, 1) from (seed, substep, global col, global row):
/// the same in any tile.
#[inline]
pub fn hash_unit(seed: u64, n: u64, gx: i64, gy: i64) -> f64 {
    let k =
        mix64(seed ^ mix64(n ^ mix64((gy as u64) ^ mix64((gx as u64) ^ 0x9e37_79b9_7f4a_7c15))));
    (k >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// Check that `v` is finite and within `[lo, hi]`; the error names the
/// parameter, its unit and the valid range.
pub(crate) fn check_range(name: &str, v: f64, lo: f64, hi: f64, unit: &str) -> Result<()> {
    if v.is_finite() && v >= lo && v <= hi {
        Ok(())
    } else {
        Err(Error::invalid(format!(
            "erosion parameter {name} = {v}{unit}: must be between {lo} and {hi}{unit}"
        )))
    }
}

/// Check a model's optional `cell` parameter (metres, at most 10 000 km).
pub(crate) fn check_cell(cell: Option<f64>) -> Result<()> {
    match cell {
        Some(c) => check_positive("cell", c, 1e7, " m"),
        None => Ok(()),
    }
}

/// Check that `v` is finite and > 0 (and <= `hi`).
pub(crate) fn check_positive(name: &str, v: f64, hi: f64, unit: &str) -> Result<()> {
    if v.is_finite() && v > 0.0 && v <= hi {
        Ok(())
    } else {
        Err(Error::invalid(format!(
            "erosion parameter {name} = {v}{unit}: must be greater than 0{}",
            if hi.is_finite() {
                format!(" and at most {hi}{unit}")
            } else {
                String::new()
            }
        )))
    }
}

/// Check the number of steps (at least 1, at most 10^8).
pub fn check_steps(steps: u64) -> Result<()> {
    if steps == 0 {
        Err(Error::invalid(
            "erosion steps = 0: give at least one step (e.g. --steps 100)",
        ))
    } else if steps > 100_000_000 {
        Err(Error::invalid(format!(
            "erosion steps = {steps}: at most 100000000"
        )))
    } else {
        Ok(())
    }
}

/// True for a cell with data (nodata is NaN in the models' state; ±inf is
/// nodata too, as in the hydrology and terrain steps: an infinite cell would
/// otherwise spread infinities to its neighbours; found by tests/hardening/numerics.rs).
#[inline]
pub(crate) fn valid(v: f64) -> bool {
    v.is_finite()
}

pub mod constrained;
pub mod multires;
pub mod stream_power;
pub mod stream_power_tiled;
