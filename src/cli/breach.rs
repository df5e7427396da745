//! `orogen breach`: depression breaching (flood-order, selective hybrid,
//! least-cost). Least-cost runs across tiles (exact: fill, carve, and an
//! optional final fill, each a tiled pass); the flood-order methods follow
//! the priority-flood over the whole DEM and run in memory.

use anyhow::{bail, Context, Result};
use clap::{Args, ValueEnum};
use orogen::exec::LocalStep;
use orogen::hydro::tiled::TiledFill;
use orogen::hydro::tiled_breach::TiledLeastCostBreach;
use orogen::hydro::{BreachMethod, BreachOptions};
use orogen::io::{self, OpenOptions};
use orogen::ops;
use orogen::raster::{read_window, DType, MemRaster, RasterSource, Window};
use std::path::{Path, PathBuf};

#[derive(Copy, Clone, PartialEq, Eq, ValueEnum)]
pub enum Method {
    /// Flood-order breaching: every depression is carved (in memory).
    Breach,
    /// Lindsay (2016) selective breaching: carve within --max-depth/--max-length, else fill (in memory).
    Hybrid,
    /// Least-cost breaching within --dist cells of each pit (across tiles).
    LeastCost,
}

#[derive(Args)]
pub struct BreachArgs {
    #[command(flatten)]
    pub input: crate::In,
    /// Breaching method.
    #[arg(long, value_enum, default_value_t = Method::Breach)]
    pub method: Method,
    /// Hybrid: deepest cut allowed below the input elevation (DEM units); deeper depressions are filled.
    #[arg(long)]
    pub max_depth: Option<f32>,
    /// Hybrid: most cells one carve may lower; longer channels are filled instead.
    #[arg(long)]
    pub max_length: Option<usize>,
    /// Least-cost: search distance around each pit, in cells (halo = 2·dist+1 across tiles).
    #[arg(long, default_value_t = 50)]
    pub dist: usize,
    /// Least-cost: fill the pits no channel within --dist could drain.
    #[arg(long)]
    pub fill_remaining: bool,
    /// Carve strictly descending channels (one f32 step per cell) and epsilon-fill.
    #[arg(long)]
    pub epsilon: bool,
    #[command(flatten)]
    pub out: crate::Out,
    #[command(flatten)]
    pub run: crate::Run,
}

/// Bytes per cell the in-memory methods need (input, result, links, flags,
/// queue), used against --memory.
const BYTES_PER_CELL: u64 = 32;

pub fn run(a: BreachArgs) -> Result<()> {
    let method = match a.method {
        Method::Breach => BreachMethod::Breach,
        Method::Hybrid => {
            if a.max_depth.is_none() && a.max_length.is_none() {
                bail!("--method hybrid needs --max-depth and/or --max-length (e.g. --max-depth 2 --max-length 50)");
            }
            BreachMethod::Hybrid {
                max_depth: a.max_depth.unwrap_or(f32::INFINITY),
                max_length: a.max_length.unwrap_or(usize::MAX),
            }
        }
        Method::LeastCost => BreachMethod::LeastCost { dist: a.dist },
    };
    if a.method != Method::Hybrid && (a.max_depth.is_some() || a.max_length.is_some()) {
        bail!("--max-depth and --max-length apply to --method hybrid only");
    }
    if a.method != Method::LeastCost && a.fill_remaining {
        bail!("--fill-remaining applies to --method least-cost only (breach and hybrid leave no depression)");
    }
    let opts = BreachOptions {
        method,
        epsilon: a.epsilon,
        fill_remaining: a.fill_remaining,
    };
    opts.validate()?;
    let cfg = crate::engine(&a.run)?;
    let src = crate::open(&a.input)?;
    let oo = crate::output_options(&a.out.fmt)?;
    if a.method == Method::LeastCost && !(a.epsilon && a.fill_remaining) {
        tiled_least_cost(src.as_ref(), &opts, &a, &oo, &cfg)?;
    } else {
        let info = src.info().clone();
        let need = info.width as u64 * info.height as u64 * BYTES_PER_CELL;
        if need > cfg.memory_budget {
            bail!(
                "{}: this breaching method runs in memory and needs about {:.1} GiB for {}x{} cells; \
                 raise --memory (e.g. --memory {}GiB) or use --method least-cost, which runs across tiles",
                a.input.input.display(),
                need as f64 / (1u64 << 30) as f64,
                info.width,
                info.height,
                need.div_ceil(1 << 30)
            );
        }
        let dem = read_window::<f32>(src.as_ref(), Window::full(info.width, info.height))?;
        let nd = orogen::hydro::out_nodata::elevation_nodata(src.as_ref())?;
        let out = orogen::hydro::breach(&dem, &opts)?;
        let out = out.map(|v| if v.is_nan() { nd as f32 } else { v });
        let mem = MemRaster::new(
            orogen::raster::AnyGrid::F32(out),
            info.georef.clone().with_nodata(Some(nd)),
            info.path.clone(),
        );
        ops::convert(&mem, &a.out.output, &oo, a.run.tile, &cfg)?;
    }
    crate::wrote(&a.out.output);
    Ok(())
}

/// Fill (tiled) -> carve (local step, halo 2·dist+1) -> optional fill, with
/// the intermediate rasters in a temporary folder beside the output.
fn tiled_least_cost(
    src: &dyn RasterSource,
    opts: &BreachOptions,
    a: &BreachArgs,
    oo: &io::OutputOptions,
    cfg: &orogen::exec::EngineConfig,
) -> Result<()> {
    let tmp = PathBuf::from(format!("{}.breach-tmp", a.out.output.display()));
    std::fs::create_dir_all(&tmp)
        .with_context(|| format!("{}: cannot create a temporary folder", tmp.display()))?;
    let res = chain(src, opts, a, oo, cfg, &tmp);
    let _ = std::fs::remove_dir_all(&tmp);
    res
}

fn chain(
    src: &dyn RasterSource,
    opts: &BreachOptions,
    a: &BreachArgs,
    oo: &io::OutputOptions,
    cfg: &orogen::exec::EngineConfig,
    tmp: &Path,
) -> Result<()> {
    let ty = (
        DType::F32,
        Some(orogen::hydro::out_nodata::elevation_nodata(src)?),
    );
    let tile = ops::choose_tile(src, a.run.tile);
    let mut tmp_oo = oo.clone();
    tmp_oo.store.tile = tile;
    tmp_oo.store.overwrite = true;
    tmp_oo.store.sync = false;
    let step = TiledLeastCostBreach::from_options(opts)?;
    // One tile in flight holds two halo-extended views (native + f32 copies)
    // and the search scratch: refuse before allocating what --memory forbids.
    let side = tile as u64 + 2 * step.halo() as u64;
    let need = side * side * 2 * 12 + step.scratch_bytes(tile);
    if need > cfg.memory_budget {
        bail!(
            "least-cost breaching with --dist {} on {tile}-cell tiles needs about {} MiB per tile \
             (halo 2*dist+1 = {} cells); lower --dist or --tile, or raise --memory",
            a.dist,
            need >> 20,
            step.halo()
        );
    }
    let filled_path = tmp.join("filled.tiles");
    ops::run_global_to(
        &TiledFill,
        &[src],
        &filled_path,
        ty,
        &tmp_oo,
        Some(tile),
        cfg,
    )?;
    let filled = io::open_raster(&filled_path, &OpenOptions::default())?;
    let inputs: [&dyn RasterSource; 2] = [src, filled.as_ref()];
    if opts.fill_remaining {
        let carved_path = tmp.join("carved.tiles");
        ops::run_local_to_paths(
            &step,
            &inputs,
            std::slice::from_ref(&carved_path),
            &[ty],
            &tmp_oo,
            Some(tile),
            cfg,
        )?;
        let carved = io::open_raster(&carved_path, &OpenOptions::default())?;
        ops::run_global_to(
            &TiledFill,
            &[carved.as_ref()],
            &a.out.output,
            ty,
            oo,
            Some(tile),
            cfg,
        )?;
    } else {
        ops::run_local_to_paths(
            &step,
            &inputs,
            std::slice::from_ref(&a.out.output),
            &[ty],
            oo,
            Some(tile),
            cfg,
        )?;
    }
    Ok(())
}
