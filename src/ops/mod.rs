//! Whole operations as the CLI (and later job files) run them: open inputs,
//! pick the tile layout, create sinks by output path, run a step on an engine.

use crate::error::{Error, Result};
use crate::exec::{Engine, EngineConfig, GlobalStep, LocalEngine, LocalStep};
use crate::io::{self, OutputOptions};
use crate::raster::{DType, RasterSource, TileLayout};
use crate::store::Provenance;
use std::path::{Path, PathBuf};

pub mod erode;
pub mod job;
pub mod note;
pub mod synth;

/// Default work-tile size when neither input nor output is a tile store.
pub const DEFAULT_TILE: usize = 1024;

/// The tile layout for a run: an output store's tile size wins, then an input
/// store's (reads stay aligned), then `tile`.
pub fn choose_layout(
    src: &dyn RasterSource,
    outputs: &[PathBuf],
    oo: &OutputOptions,
    tile: Option<usize>,
) -> TileLayout {
    let info = src.info();
    let t = if outputs.iter().any(|p| io::is_store_path(p)) {
        oo.store.tile
    } else {
        choose_tile(src, tile)
    };
    TileLayout::new(info.width, info.height, t.max(1))
}

/// Work-tile size for reading `src`: `tile` if given, an input store's own
/// tile size (aligned reads), else [`DEFAULT_TILE`].
pub fn choose_tile(src: &dyn RasterSource, tile: Option<usize>) -> usize {
    let info = src.info();
    if let Some(t) = tile {
        t
    } else if io::detect(&info.path).ok() == Some(io::Format::Store) {
        info.block.0
    } else {
        DEFAULT_TILE
    }
}

/// Check that all inputs have the first one's size.
fn check_inputs<'a>(inputs: &[&'a dyn RasterSource]) -> Result<&'a dyn RasterSource> {
    let first = *inputs
        .first()
        .ok_or_else(|| Error::invalid("a step needs at least one input"))?;
    let info = first.info();
    for i in &inputs[1..] {
        let o = i.info();
        if (o.width, o.height) != (info.width, info.height) {
            return Err(Error::invalid(format!(
                "{} is {}x{} but {} is {}x{}: inputs of one step must have the same size",
                o.path.display(),
                o.width,
                o.height,
                info.path.display(),
                info.width,
                info.height
            )));
        }
    }
    Ok(first)
}

/// One sink per output path, with the first input's georeference.
fn make_sinks(
    name: String,
    params: serde_json::Value,
    inputs: &[&dyn RasterSource],
    outputs: &[PathBuf],
    out_types: &[(DType, Option<f64>)],
    oo: &OutputOptions,
) -> Result<Vec<Box<dyn crate::exec::TileSink>>> {
    let info = inputs[0].info();
    if out_types.len() != outputs.len() {
        return Err(Error::invalid(format!(
            "{name} writes {} output(s), {} path(s) given",
            out_types.len(),
            outputs.len()
        )));
    }
    let mut sinks = Vec::with_capacity(outputs.len());
    for (p, (dt, nd)) in outputs.iter().zip(out_types) {
        let georef = info.georef.clone().with_nodata(*nd);
        let prov = Provenance::new(
            name.clone(),
            params.clone(),
            inputs
                .iter()
                .map(|i| i.info().path.display().to_string())
                .collect(),
        );
        sinks.push(io::create_sink(
            p,
            info.width,
            info.height,
            *dt,
            &georef,
            oo,
            prov,
        )?);
    }
    Ok(sinks)
}

/// What [`run_local_to_paths`] and [`run_global_to_paths`] share: check the
/// inputs' sizes and that the step (`name`, with `n_out` outputs) gets one
/// path per output, then choose the tile layout and make the sinks.
#[allow(clippy::too_many_arguments)]
fn plan(
    name: String,
    params: serde_json::Value,
    n_out: usize,
    inputs: &[&dyn RasterSource],
    outputs: &[PathBuf],
    out_types: &[(DType, Option<f64>)],
    oo: &OutputOptions,
    tile: Option<usize>,
) -> Result<(TileLayout, Vec<Box<dyn crate::exec::TileSink>>)> {
    let first = check_inputs(inputs)?;
    if outputs.len() != n_out {
        return Err(Error::invalid(format!(
            "{name} writes {n_out} output(s), {} path(s) given",
            outputs.len()
        )));
    }
    let layout = choose_layout(first, outputs, oo, tile);
    let sinks = make_sinks(name, params, inputs, outputs, out_types, oo)?;
    Ok((layout, sinks))
}

/// Run a local step on `inputs` and write output `k` to `outputs[k]` as
/// `(dtype, nodata)` of `out_types[k]`.
pub fn run_local_to_paths<S: LocalStep>(
    step: &S,
    inputs: &[&dyn RasterSource],
    outputs: &[PathBuf],
    out_types: &[(DType, Option<f64>)],
    oo: &OutputOptions,
    tile: Option<usize>,
    cfg: &EngineConfig,
) -> Result<()> {
    let (layout, sinks) = plan(
        step.name(),
        step.params(),
        step.outputs(),
        inputs,
        outputs,
        out_types,
        oo,
        tile,
    )?;
    LocalEngine::new(cfg.clone()).run_local(step, inputs, layout, sinks)
}

/// Run a global step (map, reduce, apply) on `inputs` and write its outputs
/// (the solution is not kept: under MPI only rank 0 reduces, see
/// [`Engine::run_global_apply`]).
pub fn run_global_to_paths<S: GlobalStep>(
    step: &S,
    inputs: &[&dyn RasterSource],
    outputs: &[PathBuf],
    out_types: &[(DType, Option<f64>)],
    oo: &OutputOptions,
    tile: Option<usize>,
    cfg: &EngineConfig,
) -> Result<()> {
    let (layout, sinks) = plan(
        step.name(),
        step.params(),
        step.outputs(),
        inputs,
        outputs,
        out_types,
        oo,
        tile,
    )?;
    LocalEngine::new(cfg.clone()).run_global_apply(step, inputs, layout, sinks)
}

/// [`run_local_to_paths`] for a one-output step on one input.
pub fn run_local_to<S: LocalStep>(
    step: &S,
    src: &dyn RasterSource,
    out: &Path,
    ty: (DType, Option<f64>),
    oo: &OutputOptions,
    tile: Option<usize>,
    cfg: &EngineConfig,
) -> Result<()> {
    run_local_to_paths(step, &[src], &[out.to_path_buf()], &[ty], oo, tile, cfg)
}

/// [`run_global_to_paths`] for a one-output step.
pub fn run_global_to<S: GlobalStep>(
    step: &S,
    inputs: &[&dyn RasterSource],
    out: &Path,
    ty: (DType, Option<f64>),
    oo: &OutputOptions,
    tile: Option<usize>,
    cfg: &EngineConfig,
) -> Result<()> {
    run_global_to_paths(step, inputs, &[out.to_path_buf()], &[ty], oo, tile, cfg)
}

/// Copy any raster (or mosaic) into `out` (a tile store, GeoTIFF, PNG or ASCII
/// file) in its native type, tile by tile.
pub fn convert(
    src: &dyn RasterSource,
    out: &Path,
    oo: &OutputOptions,
    tile: Option<usize>,
    cfg: &EngineConfig,
) -> Result<()> {
    let info = src.info();
    let layout = choose_layout(src, &[out.to_path_buf()], oo, tile);
    let prov = Provenance::new(
        "ingest",
        serde_json::Value::Object(Default::default()),
        vec![info.path.display().to_string()],
    );
    let sink = io::create_sink(
        out,
        info.width,
        info.height,
        info.dtype,
        &info.georef,
        oo,
        prov,
    )?;
    crate::exec::copy(src, sink, layout, &LocalEngine::new(cfg.clone()))
}

/// What `orogen info` reports.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Description {
    pub path: String,
    pub format: String,
    pub width: usize,
    pub height: usize,
    pub dtype: DType,
    pub transform: [f64; 6],
    pub epsg: Option<u32>,
    pub geographic: bool,
    pub nodata: Option<f64>,
    pub raster_type: crate::raster::RasterType,
    pub georeferenced: bool,
    pub block: (usize, usize),
    /// Cell size in metres at the middle row (east-west, north-south).
    pub cell_size_m: (f64, f64),
    pub stats: Option<crate::exec::stats::StatsSummary>,
}

/// Describe a raster (and compute its statistics with a global pass if asked).
pub fn describe(src: &dyn RasterSource, stats: bool, cfg: &EngineConfig) -> Result<Description> {
    let info = src.info();
    let g = &info.georef;
    let stats = if stats {
        let step = crate::exec::stats::Stats::new(-1e300, 1e300, 1)?;
        let info = src.info();
        let layout = TileLayout::new(info.width, info.height, choose_tile(src, None));
        Some(LocalEngine::new(cfg.clone()).run_global(&step, &[src], layout, Vec::new())?)
    } else {
        None
    };
    Ok(Description {
        path: info.path.display().to_string(),
        format: format!("{:?}", io::detect(&info.path).ok()),
        width: info.width,
        height: info.height,
        dtype: info.dtype,
        transform: g.transform,
        epsg: g.crs.epsg,
        geographic: g.crs.geographic,
        nodata: g.nodata,
        raster_type: g.raster_type,
        georeferenced: g.georeferenced,
        block: info.block,
        cell_size_m: g.cell_size_m(info.height as i64 / 2),
        stats,
    })
}

/// Human-readable form of a [`Description`].
pub fn describe_text(d: &Description) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let _ = writeln!(s, "{}", d.path);
    let _ = writeln!(
        s,
        "  size        {} x {} cells, {}",
        d.width, d.height, d.dtype
    );
    let _ = writeln!(s, "  block       {} x {}", d.block.0, d.block.1);
    if d.georeferenced {
        let crs = match d.epsg {
            Some(e) => format!("EPSG:{e}"),
            None => "unknown CRS".into(),
        };
        let _ = writeln!(
            s,
            "  crs         {crs}{}",
            if d.geographic { " (geographic)" } else { "" }
        );
        let t = d.transform;
        let _ = writeln!(s, "  origin      ({}, {})", t[0], t[3]);
        let _ = writeln!(
            s,
            "  pixel size  ({}, {}), rotation ({}, {})",
            t[1], t[5], t[2], t[4]
        );
        let _ = writeln!(
            s,
            "  cell (m)    {:.3} x {:.3} at the middle row",
            d.cell_size_m.0, d.cell_size_m.1
        );
        let _ = writeln!(s, "  raster type {:?}", d.raster_type);
    } else {
        let _ = writeln!(s, "  no georeferencing (pixel coordinates)");
    }
    match d.nodata {
        Some(v) => {
            let _ = writeln!(s, "  nodata      {v}");
        }
        None => {
            let _ = writeln!(s, "  nodata      none");
        }
    }
    if let Some(st) = &d.stats {
        match (st.min, st.max, st.mean()) {
            (Some(lo), Some(hi), Some(m)) => {
                let _ = writeln!(
                    s,
                    "  stats       min {lo}, max {hi}, mean {m:.6}, {} valid cells, {} nodata",
                    st.count, st.nodata
                );
            }
            _ => {
                let _ = writeln!(s, "  stats       no valid cells ({} nodata)", st.nodata);
            }
        }
    }
    s
}

/// `orogen demo`: generate a seeded noise terrain (warped ridged fBm), ingest it into a tile store,
/// export it, derive slope, aspect and hillshade, fill depressions, route D8
/// flow and accumulate it (global passes across tiles), render a preview.
/// Returns the files written with a description of each.
pub fn demo(
    dir: &Path,
    size: usize,
    seed: u64,
    cfg: &EngineConfig,
) -> Result<Vec<(PathBuf, &'static str)>> {
    if !(64..=65536).contains(&size) {
        return Err(Error::invalid(
            "demo --size must be between 64 and 65536 cells",
        ));
    }
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    // A domain-warped ridged multifractal blended with fBm: sharp, sinuous
    // crests over rolling ground (see `synth::noise`).
    let wavelength = (size as f64 / 2.0).max(64.0);
    let noise = crate::synth::Noise {
        kind: crate::synth::NoiseKind::Warped,
        seed,
        wavelength,
        octaves: (wavelength.log2().floor() as u32 + 1).min(10),
        warp: 0.15 * wavelength,
        ..Default::default()
    };
    let src = crate::synth::NoiseSource::new(noise, size, size, 30.0)?;
    let mut oo = OutputOptions::default();
    oo.store.tile = 256.min(size);
    oo.store.overwrite = true;
    let mut files = Vec::new();
    let store = dir.join("terrain.tiles");
    convert(&src, &store, &oo, None, cfg)?;
    files.push((store.clone(), "tile store of the terrain (f32, 30 m cells)"));
    let dem = io::open_raster(&store, &io::OpenOptions::default())?;
    let tif = dir.join("terrain.tif");
    convert(dem.as_ref(), &tif, &oo, None, cfg)?;
    files.push((tif, "the terrain as a GeoTIFF (DEFLATE, tiled)"));
    let slope = dir.join("slope.tif");
    let f32_nd = (DType::F32, Some(crate::metrics::terrain::SLOPE_NODATA));
    run_local_to(
        &crate::metrics::Slope::default(),
        dem.as_ref(),
        &slope,
        f32_nd,
        &oo,
        None,
        cfg,
    )?;
    files.push((slope, "slope in degrees (Horn)"));
    let aspect = dir.join("aspect.tif");
    run_local_to(
        &crate::metrics::Aspect::default(),
        dem.as_ref(),
        &aspect,
        f32_nd,
        &oo,
        None,
        cfg,
    )?;
    files.push((aspect, "aspect, degrees clockwise from north"));
    let shade = dir.join("hillshade.tif");
    run_local_to(
        &crate::metrics::Hillshade::default(),
        dem.as_ref(),
        &shade,
        (DType::U8, Some(0.0)),
        &oo,
        None,
        cfg,
    )?;
    files.push((shade, "hillshade, light from 315 degrees at 45 degrees"));
    let filled = dir.join("filled.tif");
    run_global_to(
        &crate::hydro::tiled::TiledFill,
        &[dem.as_ref()],
        &filled,
        (DType::F32, Some(crate::hydro::FILL_NODATA)),
        &oo,
        None,
        cfg,
    )?;
    files.push((
        filled.clone(),
        "depressions filled (Priority-Flood, exact across tiles)",
    ));
    let filled_src = io::open_raster(&filled, &io::OpenOptions::default())?;
    let d8 = dir.join("flow_d8.tif");
    run_global_to(
        &crate::hydro::tiled::TiledD8,
        &[filled_src.as_ref()],
        &d8,
        (DType::U8, Some(crate::hydro::NODATA_DIR as f64)),
        &oo,
        Some(oo.store.tile),
        cfg,
    )?;
    files.push((d8.clone(), "D8 flow directions (ESRI codes), flats drained"));
    let d8_src = io::open_raster(&d8, &io::OpenOptions::default())?;
    let acc = dir.join("accumulation.tif");
    run_global_to(
        &crate::hydro::tiled::TiledAccumulation { weighted: false },
        &[d8_src.as_ref()],
        &acc,
        (DType::F64, Some(-1.0)),
        &oo,
        Some(oo.store.tile),
        cfg,
    )?;
    files.push((acc, "D8 flow accumulation (cells)"));
    let preview = dir.join("preview.png");
    let ropts = io::render::RenderOptions {
        legend: true,
        ..Default::default()
    };
    io::render::render_preview(dem.as_ref(), &preview, &ropts)?;
    files.push((
        preview,
        "preview: hillshade over a hypsometric tint, with legend",
    ));
    Ok(files)
}

/// Multiple-flow routing for `orogen accumulate --method`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FlowMethod {
    /// D-infinity (Tarboton 1997).
    Dinf,
    /// MFD (Quinn et al. 1991, Holmgren 1994, Freeman 1991).
    Mfd(crate::hydro::mfd::MfdMethod),
}

/// Bytes per cell the in-memory D∞/MFD accumulation needs (fractions, DEM,
/// D8 codes, weights, fixed-point result, f64 result).
pub const MULTI_FLOW_BYTES_PER_CELL: u64 = 104;

/// D∞ or MFD accumulation of a (filled) DEM. When the whole raster's working
/// set ([`MULTI_FLOW_BYTES_PER_CELL`]) fits `cfg.memory_budget` it runs in
/// memory in one pass (returns 0 rounds); otherwise across tiles. Both give
/// the same bytes (exact fixed point, see [`crate::hydro::tiled_mfd`]).
/// Across tiles: D8 directions of the DEM (for cells without a
/// lower neighbour, [`crate::hydro::tiled::TiledD8`]) go to a temporary tile
/// store next to `out` (removed afterwards), then
/// [`crate::hydro::tiled_mfd::run_multi_accumulation`] accumulates cells, or
/// the weights' values, and writes `out` (f64, nodata -1). Memory is
/// O(tile × workers + total perimeter), independent of the raster size.
/// Returns the number of map rounds the accumulation needed.
pub fn accumulate_multi(
    dem: &dyn RasterSource,
    weights: Option<&dyn RasterSource>,
    method: FlowMethod,
    out: &Path,
    oo: &OutputOptions,
    tile: Option<usize>,
    cfg: &EngineConfig,
) -> Result<usize> {
    use crate::hydro::tiled_mfd::{run_multi_accumulation, Router};
    let mut inputs: Vec<&dyn RasterSource> = vec![dem];
    if let Some(w) = weights {
        inputs.push(w);
    }
    check_inputs(&inputs)?;
    let info = dem.info();
    let need = (info.width as u64)
        .saturating_mul(info.height as u64)
        .saturating_mul(MULTI_FLOW_BYTES_PER_CELL);
    if need <= cfg.memory_budget && (info.width as u64) * (info.height as u64) <= u32::MAX as u64 {
        let full = crate::raster::Window::full(info.width, info.height);
        let z = crate::raster::read_window::<f32>(dem, full)?;
        let flow = match method {
            FlowMethod::Dinf => crate::hydro::dinf::dinf(&z)?.flow,
            FlowMethod::Mfd(m) => crate::hydro::mfd::mfd_flow(&z, m)?,
        };
        drop(z);
        let acc = match weights {
            Some(w) => {
                let wg = crate::raster::read_window::<f32>(w, full)?;
                crate::hydro::mfd::accumulate_fractions(&flow, &wg)?
            }
            None => crate::hydro::mfd::accumulate_cells(&flow)?,
        };
        drop(flow);
        let acc = acc.map(|v| if v.is_nan() { -1.0 } else { v });
        let georef = info.georef.clone().with_nodata(Some(-1.0));
        let mem = crate::raster::MemRaster::new(
            crate::raster::AnyGrid::F64(acc),
            georef,
            info.path.clone(),
        );
        convert(&mem, out, oo, None, cfg)?;
        return Ok(0);
    }
    let layout = choose_layout(dem, &[out.to_path_buf()], oo, tile);
    let engine = LocalEngine::new(cfg.clone());
    let name = out
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "accumulation".into());
    let tmp = out.with_file_name(format!(".{name}.d8-tmp.tiles"));
    let mut tmp_oo = oo.clone();
    tmp_oo.store.tile = layout.tile;
    tmp_oo.store.overwrite = true;
    tmp_oo.store.sync = false;
    let d8_step = crate::hydro::tiled::TiledD8;
    let result = (|| -> Result<usize> {
        let sinks = make_sinks(
            d8_step.name(),
            d8_step.params(),
            &[dem],
            std::slice::from_ref(&tmp),
            &[(DType::U8, Some(crate::hydro::NODATA_DIR as f64))],
            &tmp_oo,
        )?;
        engine.run_global_apply(&d8_step, &[dem], layout, sinks)?;
        let d8 = io::open_raster(&tmp, &io::OpenOptions::default())?;
        let mut acc_inputs: Vec<&dyn RasterSource> = vec![dem, d8.as_ref()];
        if let Some(w) = weights {
            acc_inputs.push(w);
        }
        let router = match method {
            FlowMethod::Dinf => Router::Dinf,
            FlowMethod::Mfd(m) => Router::Mfd(m),
        };
        let probe = crate::hydro::tiled_mfd::TiledMultiAccumulation::new(router, weights.is_some());
        let sinks = make_sinks(
            probe.name(),
            probe.params(),
            &acc_inputs,
            &[out.to_path_buf()],
            &[(DType::F64, Some(-1.0))],
            oo,
        )?;
        let run = run_multi_accumulation(
            &engine,
            router,
            weights.is_some(),
            &acc_inputs,
            layout,
            sinks,
        )?;
        Ok(run.rounds)
    })();
    // Under MPI only rank 0 created the store (and every rank is past the
    // engine's closing barrier): several ranks removing it would race.
    let cleanup = if crate::exec::rank().0 == 0 {
        std::fs::remove_dir_all(&tmp)
    } else {
        Ok(())
    };
    let rounds = result?;
    if let Err(e) = cleanup {
        if e.kind() != std::io::ErrorKind::NotFound {
            return Err(Error::io(&tmp, e));
        }
    }
    Ok(rounds)
}
