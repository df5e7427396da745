//! What both engines do to one tile of a run: check the inputs and sinks,
//! list the tiles still to do, read a tile's views, make blank outputs,
//! convert them to the sinks' types and write them; the memory estimate of
//! a tile in flight; one tile of a local step or of a global step's apply
//! ([`local_tile`], [`apply_tile`]); the serde round trip of global-step
//! summaries.

use super::{GlobalStep, LocalStep, TileSink};
use crate::error::{Error, Result};
use crate::raster::{
    read_view, AnyGrid, Cell, DType, Grid, IntoAny, RasterSource, TileId, TileLayout, TileView,
};

/// Tiles allowed in flight under `budget` bytes for tiles of
/// `bytes_per_tile` bytes: `budget / bytes_per_tile`, at least 1.
pub fn tiles_in_flight(budget: u64, bytes_per_tile: u64) -> usize {
    (budget / bytes_per_tile.max(1)).clamp(1, usize::MAX as u64) as usize
}

/// Estimated bytes of one tile in flight: per input, the halo-extended view
/// in the native type and twice in `in_size` (conversion, and padding at the
/// raster edge); per output, the core in `out_size` and in the sink's type.
pub fn local_tile_bytes(
    layout: &TileLayout,
    halo: usize,
    inputs: &[&dyn RasterSource],
    in_size: usize,
    out_size: usize,
    sink_sizes: &[usize],
) -> u64 {
    let cw = layout.tile.min(layout.width) as u64;
    let ch = layout.tile.min(layout.height) as u64;
    let h = halo as u64;
    let view = (cw + 2 * h) * (ch + 2 * h);
    let core = cw * ch;
    let ins: u64 = inputs
        .iter()
        .map(|s| view * (s.info().dtype.size() as u64 + 2 * in_size as u64))
        .sum();
    let outs: u64 = sink_sizes
        .iter()
        .map(|&s| core * (out_size as u64 + s as u64))
        .sum();
    ins + outs
}

pub(super) fn check_inputs(
    name: &str,
    inputs: &[&dyn RasterSource],
    layout: &TileLayout,
) -> Result<()> {
    for src in inputs {
        let i = src.info();
        if (i.width, i.height) != (layout.width, layout.height) {
            return Err(Error::invalid(format!(
                "{name}: input {} is {}x{} but the run covers {}x{}",
                i.path.display(),
                i.width,
                i.height,
                layout.width,
                layout.height
            )));
        }
    }
    Ok(())
}

pub(super) fn check_sinks(
    name: &str,
    sinks: &[Box<dyn TileSink>],
    outputs: usize,
    layout: &TileLayout,
) -> Result<()> {
    if sinks.len() != outputs {
        return Err(Error::invalid(format!(
            "{name}: the step has {outputs} outputs but {} sinks were given",
            sinks.len()
        )));
    }
    for s in sinks {
        if let Some(l) = s.layout() {
            if l != *layout {
                return Err(Error::invalid(format!(
                    "{name}: a sink is laid out as {}x{} in tiles of {}, the run as {}x{} in tiles of {}; run with the sink's layout",
                    l.width, l.height, l.tile, layout.width, layout.height, layout.tile
                )));
            }
        }
    }
    Ok(())
}

/// Tiles not yet finished in every sink (all tiles when there are none).
pub(super) fn todo(layout: &TileLayout, sinks: &[Box<dyn TileSink>]) -> Vec<TileId> {
    (0..layout.count())
        .filter(|&id| sinks.is_empty() || !sinks.iter().all(|s| s.is_done(id)))
        .collect()
}

pub(super) fn read_views<T: Cell>(
    inputs: &[&dyn RasterSource],
    layout: &TileLayout,
    id: TileId,
    halo: usize,
) -> Result<Vec<TileView<T>>> {
    inputs
        .iter()
        .map(|src| read_view::<T>(*src, layout, id, halo))
        .collect()
}

pub(super) fn blank_outputs<T: IntoAny>(n: usize, layout: &TileLayout, id: TileId) -> Vec<Grid<T>> {
    let core = layout.window(id);
    (0..n)
        .map(|_| Grid::new(core.w, core.h, T::from_f64(f64::NAN)))
        .collect()
}

pub(super) fn convert_outputs<T: IntoAny>(
    name: &str,
    out: &[Grid<T>],
    layout: &TileLayout,
    id: TileId,
    meta: &[(DType, Option<f64>)],
) -> Result<Vec<AnyGrid>> {
    let core = layout.window(id);
    out.iter()
        .zip(meta)
        .map(|(g, &(dt, nd))| {
            if (g.width(), g.height()) != (core.w, core.h) {
                return Err(Error::invalid(format!(
                    "{name} produced a {}x{} output for a {}x{} tile",
                    g.width(),
                    g.height(),
                    core.w,
                    core.h
                )));
            }
            Ok(AnyGrid::from_typed(g, dt, nd))
        })
        .collect()
}

/// The sinks' cell types and nodata, and the memory of one tile of a step
/// reading `inputs` as `I` with `halo` cells and writing the sinks from
/// outputs of `O` (`local_tile_bytes`).
pub(super) fn out_meta<I, O>(
    layout: &TileLayout,
    halo: usize,
    inputs: &[&dyn RasterSource],
    sinks: &[Box<dyn TileSink>],
) -> (Vec<(DType, Option<f64>)>, u64) {
    let meta: Vec<(DType, Option<f64>)> = sinks.iter().map(|s| (s.dtype(), s.nodata())).collect();
    let sizes: Vec<usize> = meta.iter().map(|m| m.0.size()).collect();
    let bytes = local_tile_bytes(
        layout,
        halo,
        inputs,
        std::mem::size_of::<I>(),
        std::mem::size_of::<O>(),
        &sizes,
    );
    (meta, bytes)
}

/// One tile of a local step: read the views, run the step, convert the
/// outputs to the sinks' types `meta` (one per output).
pub(super) fn local_tile<S: LocalStep>(
    step: &S,
    name: &str,
    inputs: &[&dyn RasterSource],
    layout: &TileLayout,
    id: TileId,
    meta: &[(DType, Option<f64>)],
) -> Result<Vec<AnyGrid>> {
    let views = read_views::<S::In>(inputs, layout, id, step.halo())?;
    let mut out = blank_outputs::<S::Out>(meta.len(), layout, id);
    step.run(&views, &mut out)?;
    convert_outputs(name, &out, layout, id, meta)
}

/// One tile of a global step's apply phase with its `slice`, as
/// [`local_tile`].
pub(super) fn apply_tile<S: GlobalStep>(
    step: &S,
    name: &str,
    inputs: &[&dyn RasterSource],
    layout: &TileLayout,
    id: TileId,
    slice: &S::Slice,
    meta: &[(DType, Option<f64>)],
) -> Result<Vec<AnyGrid>> {
    let views = read_views::<S::In>(inputs, layout, id, step.halo())?;
    let mut out = blank_outputs::<S::Out>(meta.len(), layout, id);
    step.apply(&views, slice, &mut out)?;
    convert_outputs(name, &out, layout, id, meta)
}

pub(super) fn write_outputs(
    sinks: &mut [Box<dyn TileSink>],
    layout: &TileLayout,
    id: TileId,
    grids: Vec<AnyGrid>,
) -> Result<()> {
    let core = layout.window(id);
    for (s, g) in sinks.iter_mut().zip(grids) {
        if !s.is_done(id) {
            s.write(id, core, g)?;
        }
    }
    Ok(())
}

pub(super) fn finish_all(sinks: Vec<Box<dyn TileSink>>) -> Result<()> {
    for s in sinks {
        s.finish()?;
    }
    Ok(())
}

/// Serialise a summary with serde_json and read it back, proving it can be
/// shipped between processes (used on every summary in debug builds).
pub fn roundtrip_summary<T: serde::Serialize + serde::de::DeserializeOwned>(
    step: &str,
    s: &T,
) -> Result<T> {
    let bytes = serde_json::to_vec(s)
        .map_err(|e| Error::invalid(format!("{step}: a tile summary does not serialise: {e}")))?;
    serde_json::from_slice(&bytes).map_err(|e| {
        Error::invalid(format!(
            "{step}: a tile summary does not survive a serde_json round trip (NaN or infinity in an f64 field?): {e}"
        ))
    })
}
