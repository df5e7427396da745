//! What the in-memory hydrology operations (`basins --metrics`, `streams`,
//! `hydro-index`) share: opening side inputs, the memory guard, reading D8
//! directions with their codes checked, size checks, and writing a grid held
//! in memory.

use super::convert;
use crate::error::{Error, Result};
use crate::exec::EngineConfig;
use crate::exec::MemoryFit;
use crate::hydro::{NODATA_DIR, NO_FLOW};
use crate::io::{self, OpenOptions, OutputOptions};
use crate::raster::{read_window, DType, Grid, MemRaster, RasterSource, Window};
use std::path::Path;

/// Open a side input (default open options).
pub(crate) fn open_path(p: &Path) -> Result<Box<dyn RasterSource>> {
    io::open_raster(p, &OpenOptions::default())
}

/// Refuse an in-memory step whose working set exceeds the memory budget.
pub(crate) fn guard(
    src: &dyn RasterSource,
    per_cell: u64,
    what: &str,
    cfg: &EngineConfig,
) -> Result<()> {
    let info = src.info();
    MemoryFit::raster(info, per_cell, cfg.memory_budget).check_in_memory(&info.path, what, "")
}

/// The whole raster as a window.
pub(crate) fn full(src: &dyn RasterSource) -> Window {
    let i = src.info();
    Window::full(i.width, i.height)
}

/// Read D8 directions (any numeric type; NaN/nodata/255 -> 255), checking codes.
pub(crate) fn read_dirs(src: &dyn RasterSource) -> Result<Grid<u8>> {
    let g = read_window::<f64>(src, full(src))?;
    let w = g.width();
    let bad = |v: f64, i: usize| {
        Error::invalid(format!(
            "{}: value {v} at cell ({}, {}) is not a D8 code; give directions from `orogen flow`",
            src.info().path.display(),
            i % w,
            i / w
        ))
    };
    let mut out = Vec::with_capacity(g.len());
    for (i, &v) in g.data().iter().enumerate() {
        let c = if v.is_nan() || v == NODATA_DIR as f64 {
            NODATA_DIR
        } else if (0.0..=128.0).contains(&v) && v.fract() == 0.0 {
            let c = v as u8;
            if c != NO_FLOW && crate::hydro::code_to_dir(c).is_none() {
                return Err(bad(v, i));
            }
            c
        } else {
            return Err(bad(v, i));
        };
        out.push(c);
    }
    Grid::from_vec(g.width(), g.height(), out)
}

/// Check that `b` has the size of `a`.
pub(crate) fn same_size(a: &dyn RasterSource, b: &dyn RasterSource) -> Result<()> {
    crate::exec::plan::check_same_size(a, b, "the rasters must have the same size")
}

/// Write the in-memory raster `mem` to `p` with nodata `ty.1`.
pub(crate) fn write_mem(
    mem: MemRaster,
    p: &Path,
    oo: &OutputOptions,
    tile: Option<usize>,
    cfg: &EngineConfig,
    ty: (DType, Option<f64>),
) -> Result<()> {
    let mem = MemRaster::new(
        mem.grid().clone(),
        mem.info().georef.clone().with_nodata(ty.1),
        mem.info().path.clone(),
    );
    convert(&mem, p, oo, tile, cfg)
}
