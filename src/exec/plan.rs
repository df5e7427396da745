//! Planning a tiled run whose outputs are files: check the inputs, choose
//! the tile layout (an output or input tile store's tile size wins), create
//! one sink per output path by its extension, written as the step's
//! [`OutputSpec`]s declare (nodata rules resolved on input 0), and run a
//! local or global step on the engine.

use super::output::{resolve_nodata, OutputSpec};
use super::{engine, Engine, EngineConfig, GlobalStep, LocalStep, Run, TileSink};
use crate::error::{Error, Result};
use crate::io::{self, OutputOptions};
use crate::raster::{RasterSource, TileLayout};
use crate::store::Provenance;
use std::path::{Path, PathBuf};

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
pub fn check_inputs<'a>(inputs: &[&'a dyn RasterSource]) -> Result<&'a dyn RasterSource> {
    let first = *inputs
        .first()
        .ok_or_else(|| Error::invalid("a step needs at least one input"))?;
    for i in &inputs[1..] {
        check_same_size(first, *i, "inputs of one step must have the same size")?;
    }
    Ok(first)
}

/// Check that `b` has the size of `a`; the error names both and ends with
/// `why`.
pub fn check_same_size(a: &dyn RasterSource, b: &dyn RasterSource, why: &str) -> Result<()> {
    let (ia, ib) = (a.info(), b.info());
    if (ia.width, ia.height) != (ib.width, ib.height) {
        return Err(Error::invalid(format!(
            "{} is {}x{} but {} is {}x{}: {why}",
            ib.path.display(),
            ib.width,
            ib.height,
            ia.path.display(),
            ia.width,
            ia.height
        )));
    }
    Ok(())
}

/// One sink per output path, with the first input's georeference: output
/// `k` written as `specs[k]` (its nodata rule resolved on input 0, its kind
/// recorded in the provenance, which picks a COG's overview resampling
/// unless the options fix it).
pub fn make_sinks(
    name: String,
    params: serde_json::Value,
    inputs: &[&dyn RasterSource],
    outputs: &[PathBuf],
    specs: &[OutputSpec],
    oo: &OutputOptions,
) -> Result<Vec<Box<dyn TileSink>>> {
    let info = inputs[0].info();
    if specs.len() != outputs.len() {
        return Err(Error::invalid(format!(
            "{name} writes {} output(s), {} path(s) given",
            specs.len(),
            outputs.len()
        )));
    }
    let nodata = resolve_nodata(specs, inputs[0])?;
    let mut sinks = Vec::with_capacity(outputs.len());
    for ((p, spec), nd) in outputs.iter().zip(specs).zip(nodata) {
        let georef = info.georef.clone().with_nodata(nd);
        let prov = Provenance::new(
            name.clone(),
            params.clone(),
            inputs
                .iter()
                .map(|i| i.info().path.display().to_string())
                .collect(),
        )
        .with_kind(spec.kind);
        sinks.push(io::create_sink(
            p,
            info.width,
            info.height,
            spec.dtype,
            &georef,
            oo,
            prov,
        )?);
    }
    Ok(sinks)
}

/// A run of a step (`name`, `params`, output `specs`) whose outputs are
/// the files `outputs`: check the inputs' sizes, choose the tile layout and
/// make one sink per output (their number must match).
pub fn plan_run<'a>(
    name: String,
    params: serde_json::Value,
    specs: &[OutputSpec],
    inputs: &'a [&'a dyn RasterSource],
    outputs: &[PathBuf],
    oo: &OutputOptions,
    tile: Option<usize>,
) -> Result<Run<'a>> {
    let first = check_inputs(inputs)?;
    let layout = choose_layout(first, outputs, oo, tile);
    let sinks = make_sinks(name, params, inputs, outputs, specs, oo)?;
    Ok(Run::new(inputs, layout, sinks))
}

/// Run a local step on `inputs` and write output `k` to `outputs[k]`, as
/// the step's `outputs()[k]` declares.
pub fn run_local_to_paths<S: LocalStep>(
    step: &S,
    inputs: &[&dyn RasterSource],
    outputs: &[PathBuf],
    oo: &OutputOptions,
    tile: Option<usize>,
    cfg: &EngineConfig,
) -> Result<()> {
    let run = plan_run(
        step.name(),
        step.params(),
        &step.outputs(),
        inputs,
        outputs,
        oo,
        tile,
    )?;
    engine(cfg)?.run_local(step, run)
}

/// Run a global step (map, reduce, apply) on `inputs` and write its outputs
/// as [`run_local_to_paths`] does (the solution is not kept: under MPI only
/// rank 0 reduces, see [`Engine::run_global_apply`]).
pub fn run_global_to_paths<S: GlobalStep>(
    step: &S,
    inputs: &[&dyn RasterSource],
    outputs: &[PathBuf],
    oo: &OutputOptions,
    tile: Option<usize>,
    cfg: &EngineConfig,
) -> Result<()> {
    let run = plan_run(
        step.name(),
        step.params(),
        &step.outputs(),
        inputs,
        outputs,
        oo,
        tile,
    )?;
    engine(cfg)?.run_global_apply(step, run)
}

/// [`run_local_to_paths`] for a one-output step on one input.
pub fn run_local_to<S: LocalStep>(
    step: &S,
    src: &dyn RasterSource,
    out: &Path,
    oo: &OutputOptions,
    tile: Option<usize>,
    cfg: &EngineConfig,
) -> Result<()> {
    run_local_to_paths(step, &[src], &[out.to_path_buf()], oo, tile, cfg)
}

/// [`run_global_to_paths`] for a one-output step.
pub fn run_global_to<S: GlobalStep>(
    step: &S,
    inputs: &[&dyn RasterSource],
    out: &Path,
    oo: &OutputOptions,
    tile: Option<usize>,
    cfg: &EngineConfig,
) -> Result<()> {
    run_global_to_paths(step, inputs, &[out.to_path_buf()], oo, tile, cfg)
}
