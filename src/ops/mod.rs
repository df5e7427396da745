//! Whole operations as the CLI (and later job files) run them: open inputs,
//! pick the tile layout, create sinks by output path, run a step on an engine.
//!
//! One module per user operation: an `XxxOptions` struct (the command's
//! parameters, with its names and defaults) and a `run` function that does
//! everything the command does except parsing arguments and printing. Raster
//! outputs are described by a [`Target`] (path, format options, work-tile
//! size); the engine settings by an [`EngineConfig`].

pub mod accumulate;
pub mod aspect;
pub mod basins;
pub mod breach;
pub mod classify;
pub mod compare;
pub mod convert;
pub mod demo;
pub mod fill;
pub mod fill_epsilon;
pub mod flow;
pub mod hillshade;
pub mod hydro_index;
mod hydro_io;
pub mod info;
pub mod metric;
pub mod metric_table;
pub mod orostats;
pub mod peaks;
pub mod render;
pub mod ridges;
pub mod slope;
pub mod streams;
mod target;
pub mod tiles;
pub mod viewshed;
pub mod watersheds;

pub use accumulate::{accumulate_multi, FlowMethod, MULTI_FLOW_BYTES_PER_CELL};
pub use convert::convert;
pub use demo::demo;
pub use info::{describe, describe_text, Description};
pub use target::Target;

use crate::error::{Error, Result};
use crate::exec::{Engine, EngineConfig, GlobalStep, LocalEngine, LocalStep};
use crate::io::{self, OutputOptions};
use crate::raster::{DType, RasterSource, TileLayout};
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
