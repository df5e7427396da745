//! `orogen breach`: depression breaching (flood-order, Lindsay's 2016
//! selective hybrid, least-cost; see [`crate::hydro::breach`]). Least-cost
//! runs across tiles (exact: fill, carve, and an optional final fill, each a
//! tiled pass); the flood-order methods follow the priority-flood over the
//! whole DEM and run in memory.

use super::{choose_tile, convert, run_global_to, run_local_to_paths, Target};
use crate::error::{Error, Result};
use crate::exec::MemoryFit;
use crate::exec::{EngineConfig, LocalStep};
use crate::hydro::tiled::TiledFill;
use crate::hydro::tiled_breach::TiledLeastCostBreach;
use crate::hydro::BreachMethod;
use crate::io::{self, OpenOptions, OutputOptions};
use crate::raster::{read_window, MemRaster, RasterSource, Window};
use crate::store::scratch::ScratchDir;
use std::path::Path;

/// Breaching method of `orogen breach --method`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// Flood-order breaching: every depression is carved (in memory).
    #[default]
    Breach,
    /// Lindsay (2016) selective breaching: carve within `max_depth` /
    /// `max_length`, else fill (in memory).
    Hybrid,
    /// Least-cost breaching within `dist` cells of each pit (across tiles).
    LeastCost,
}

/// Options of `orogen breach`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BreachOptions {
    /// Breaching method.
    pub method: Method,
    /// Hybrid: deepest cut allowed below the input elevation (DEM units).
    pub max_depth: Option<f32>,
    /// Hybrid: most cells one carve may lower.
    pub max_length: Option<usize>,
    /// Least-cost: search distance around each pit, in cells.
    pub dist: usize,
    /// Least-cost: fill the pits no channel within `dist` could drain.
    pub fill_remaining: bool,
    /// Carve strictly descending channels (one f32 step per cell) and epsilon-fill.
    pub epsilon: bool,
}

impl Default for BreachOptions {
    fn default() -> Self {
        BreachOptions {
            method: Method::Breach,
            max_depth: None,
            max_length: None,
            dist: 50,
            fill_remaining: false,
            epsilon: false,
        }
    }
}

/// Bytes per cell the in-memory methods need (input, result, links, flags,
/// queue), used against the memory budget.
pub const BREACH_BYTES_PER_CELL: u64 = 32;

impl BreachOptions {
    /// Check the combination of parameters and build the library's options.
    pub fn resolve(&self) -> Result<crate::hydro::BreachOptions> {
        let method = match self.method {
            Method::Breach => BreachMethod::Breach,
            Method::Hybrid => {
                if self.max_depth.is_none() && self.max_length.is_none() {
                    return Err(Error::invalid("--method hybrid needs --max-depth and/or --max-length (e.g. --max-depth 2 --max-length 50)"));
                }
                BreachMethod::Hybrid {
                    max_depth: self.max_depth.unwrap_or(f32::INFINITY),
                    max_length: self.max_length.unwrap_or(usize::MAX),
                }
            }
            Method::LeastCost => BreachMethod::LeastCost { dist: self.dist },
        };
        if self.method != Method::Hybrid && (self.max_depth.is_some() || self.max_length.is_some())
        {
            return Err(Error::invalid(
                "--max-depth and --max-length apply to --method hybrid only",
            ));
        }
        if self.method != Method::LeastCost && self.fill_remaining {
            return Err(Error::invalid("--fill-remaining applies to --method least-cost only (breach and hybrid leave no depression)"));
        }
        let opts = crate::hydro::BreachOptions {
            method,
            epsilon: self.epsilon,
            fill_remaining: self.fill_remaining,
        };
        opts.validate()?;
        Ok(opts)
    }
}

/// Breach the depressions of `dem` into `target` (f32; nodata from
/// [`crate::exec::output::elevation_nodata`]).
pub fn run(
    dem: &dyn RasterSource,
    opts: &BreachOptions,
    target: &Target,
    cfg: &EngineConfig,
) -> Result<()> {
    let hopts = opts.resolve()?;
    let oo = &target.options;
    if opts.method == Method::LeastCost && !(opts.epsilon && opts.fill_remaining) {
        return tiled_least_cost(dem, &hopts, opts.dist, target, cfg);
    }
    let info = dem.info().clone();
    MemoryFit::raster(&info, BREACH_BYTES_PER_CELL, cfg.memory_budget).check_in_memory(
        &info.path,
        "this breaching method",
        " or use --method least-cost, which runs across tiles",
    )?;
    let grid = read_window::<f32>(dem, Window::full(info.width, info.height))?;
    let nd = crate::exec::output::elevation_nodata(dem)?;
    let out = crate::hydro::breach(&grid, &hopts)?;
    let out = out.map(|v| if v.is_nan() { nd as f32 } else { v });
    let mem = MemRaster::new(
        crate::raster::AnyGrid::F32(out),
        info.georef.clone().with_nodata(Some(nd)),
        info.path.clone(),
    );
    convert(&mem, &target.path, oo, target.tile, cfg)
}

/// Fill (tiled) -> carve (local step, halo 2·dist+1) -> optional fill, with
/// the intermediate rasters in a temporary folder beside the output.
fn tiled_least_cost(
    src: &dyn RasterSource,
    opts: &crate::hydro::BreachOptions,
    dist: usize,
    target: &Target,
    cfg: &EngineConfig,
) -> Result<()> {
    // Removed when dropped, whatever `chain` returns.
    let tmp = ScratchDir::new(format!("{}.breach-tmp", target.path.display())).create()?;
    chain(src, opts, dist, target, cfg, tmp.path())
}

fn chain(
    src: &dyn RasterSource,
    opts: &crate::hydro::BreachOptions,
    dist: usize,
    target: &Target,
    cfg: &EngineConfig,
    tmp: &Path,
) -> Result<()> {
    let oo: &OutputOptions = &target.options;
    let tile = choose_tile(src, target.tile);
    let mut tmp_oo = oo.clone();
    tmp_oo.store.tile = tile;
    tmp_oo.store.overwrite = true;
    tmp_oo.store.sync = false;
    let step = TiledLeastCostBreach::from_options(opts)?;
    // One tile in flight holds two halo-extended views (native + f32 copies)
    // and the search scratch: refuse before allocating what the budget forbids.
    let side = tile as u64 + 2 * step.halo() as u64;
    let need = side * side * 2 * 12 + step.scratch_bytes(tile);
    MemoryFit::bytes(need, cfg.memory_budget).check(|f| {
        Error::over_budget(format!(
            "least-cost breaching with --dist {dist} on {tile}-cell tiles needs about {} MiB per tile \
             (halo 2*dist+1 = {} cells); lower --dist or --tile, or raise --memory",
            f.need_mib(),
            step.halo()
        ))
    })?;
    let filled_path = tmp.join("filled.tiles");
    run_global_to(&TiledFill, &[src], &filled_path, &tmp_oo, Some(tile), cfg)?;
    let filled = io::open_raster(&filled_path, &OpenOptions::default())?;
    let inputs: [&dyn RasterSource; 2] = [src, filled.as_ref()];
    if opts.fill_remaining {
        let carved_path = tmp.join("carved.tiles");
        let carved_out = std::slice::from_ref(&carved_path);
        run_local_to_paths(&step, &inputs, carved_out, &tmp_oo, Some(tile), cfg)?;
        let carved = io::open_raster(&carved_path, &OpenOptions::default())?;
        run_global_to(
            &TiledFill,
            &[carved.as_ref()],
            &target.path,
            oo,
            Some(tile),
            cfg,
        )?;
    } else {
        let out = std::slice::from_ref(&target.path);
        run_local_to_paths(&step, &inputs, out, oo, Some(tile), cfg)?;
    }
    Ok(())
}
