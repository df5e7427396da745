//! `orogen accumulate`: flow accumulation, D8 from flow directions (exact
//! across tiles, Barnes 2017) or D-infinity / MFD from a filled DEM.

use super::{choose_layout, convert, Target};
use crate::error::{Error, Result};
use crate::exec::plan::{check_inputs, make_sinks};
use crate::exec::MemoryFit;
use crate::exec::{Engine, EngineConfig, GlobalStep, Run};
pub use crate::hydro::areas::AreaUnits;
use crate::hydro::areas::CellAreas;
use crate::io::{self, OutputOptions};
use crate::raster::{DType, RasterSource};
use crate::store::scratch::ScratchDir;
use std::path::{Path, PathBuf};

/// Routing of `orogen accumulate --method`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum AccumulateMethod {
    /// D8 directions from `orogen flow`, exact across tiles.
    #[default]
    D8,
    /// D-infinity (Tarboton 1997) from a filled DEM.
    Dinf,
    /// MFD, Quinn et al. 1991.
    Quinn,
    /// MFD, Holmgren 1994 (with [`AccumulateOptions::exponent`]).
    Holmgren,
    /// MFD, Freeman 1991.
    Freeman,
}

impl std::str::FromStr for AccumulateMethod {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        Ok(match s {
            "d8" => AccumulateMethod::D8,
            "dinf" => AccumulateMethod::Dinf,
            "quinn" => AccumulateMethod::Quinn,
            "holmgren" => AccumulateMethod::Holmgren,
            "freeman" => AccumulateMethod::Freeman,
            m => {
                return Err(Error::invalid(format!(
                    "--method {m:?}: use d8, dinf, quinn, holmgren or freeman"
                )))
            }
        })
    }
}

/// Options of `orogen accumulate`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AccumulateOptions {
    /// Routing.
    pub method: AccumulateMethod,
    /// Holmgren's exponent.
    pub exponent: f64,
    /// Weights raster (same size): accumulate its values instead of cells.
    pub weights: Option<PathBuf>,
    /// Units: cell counts, or true areas (m², km², or the specific
    /// catchment area in m²/m), per row on geographic grids
    /// ([`crate::hydro::areas`]); with `weights`, area × weight.
    pub units: AreaUnits,
}

impl Default for AccumulateOptions {
    fn default() -> Self {
        AccumulateOptions {
            method: AccumulateMethod::D8,
            exponent: 4.0,
            weights: None,
            units: AreaUnits::Cells,
        }
    }
}

impl AccumulateOptions {
    /// The multiple-flow routing, `None` for D8.
    pub fn flow_method(&self) -> Option<FlowMethod> {
        use crate::hydro::mfd::MfdMethod;
        match self.method {
            AccumulateMethod::D8 => None,
            AccumulateMethod::Dinf => Some(FlowMethod::Dinf),
            AccumulateMethod::Quinn => Some(FlowMethod::Mfd(MfdMethod::Quinn)),
            AccumulateMethod::Holmgren => Some(FlowMethod::Mfd(MfdMethod::Holmgren(self.exponent))),
            AccumulateMethod::Freeman => Some(FlowMethod::Mfd(MfdMethod::Freeman)),
        }
    }
}

/// What [`run`] did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AccumulateOutcome {
    /// Map rounds over tiles of a D∞/MFD accumulation (0: in memory, or D8).
    pub rounds: usize,
}

/// Accumulate flow over `src` (D8 directions for [`AccumulateMethod::D8`],
/// else a filled DEM) into `target` (f64, nodata -1).
pub fn run(
    src: &dyn RasterSource,
    opts: &AccumulateOptions,
    target: &Target,
    cfg: &EngineConfig,
) -> Result<AccumulateOutcome> {
    let open_weights = || -> Result<Option<Box<dyn RasterSource>>> {
        Ok(match &opts.weights {
            Some(p) => Some(io::open_raster(p, &io::OpenOptions::default())?),
            None => None,
        })
    };
    let sca = opts.units == AreaUnits::Sca;
    if let Some(m) = opts.flow_method() {
        let w = open_weights()?;
        let areas = CellAreas::new(src.info(), w.as_deref(), opts.units)?;
        let weights: Option<&dyn RasterSource> = match &areas {
            Some(a) => Some(a),
            None => w.as_deref(),
        };
        let rounds = accumulate_multi_in(
            src,
            weights,
            m,
            sca,
            &target.path,
            &target.options,
            target.tile,
            cfg,
        )?;
        return Ok(AccumulateOutcome { rounds });
    }
    if src.info().dtype != DType::U8 {
        return Err(Error::invalid(format!(
            "{}: expected D8 directions (a byte raster from `orogen flow`), found {} cells",
            src.info().path.display(),
            src.info().dtype
        )));
    }
    let w = open_weights()?;
    let areas = CellAreas::new(src.info(), w.as_deref(), opts.units)?;
    let mut inputs: Vec<&dyn RasterSource> = vec![src];
    if let Some(a) = &areas {
        inputs.push(a);
    } else if let Some(w) = &w {
        inputs.push(w.as_ref());
    }
    let step = crate::hydro::tiled::TiledAccumulation {
        weighted: inputs.len() > 1,
        sca,
    };
    target.run_global(&step, &inputs, cfg)?;
    Ok(AccumulateOutcome { rounds: 0 })
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
    accumulate_multi_in(dem, weights, method, false, out, oo, tile, cfg)
}

/// [`accumulate_multi`], the result divided by each row's contour width
/// when `sca` (the weights then are cell areas in m²,
/// [`crate::hydro::areas::CellAreas`]).
#[allow(clippy::too_many_arguments)]
pub fn accumulate_multi_in(
    dem: &dyn RasterSource,
    weights: Option<&dyn RasterSource>,
    method: FlowMethod,
    sca: bool,
    out: &Path,
    oo: &OutputOptions,
    tile: Option<usize>,
    cfg: &EngineConfig,
) -> Result<usize> {
    use crate::hydro::tiled_mfd::{run_multi, Router};
    let mut inputs: Vec<&dyn RasterSource> = vec![dem];
    if let Some(w) = weights {
        inputs.push(w);
    }
    check_inputs(&inputs)?;
    let info = dem.info();
    let fit = MemoryFit::raster(info, MULTI_FLOW_BYTES_PER_CELL, cfg.memory_budget);
    if fit.fits() && (info.width as u64) * (info.height as u64) <= u32::MAX as u64 {
        let full = crate::raster::Window::full(info.width, info.height);
        let z = crate::raster::read_window::<f32>(dem, full)?;
        let geo = crate::raster::neighbours::CellGeometry::of_rows(&info.georef, 0, info.height);
        let flow = match method {
            FlowMethod::Dinf => crate::hydro::dinf::dinf_on(&z, &geo)?.flow,
            FlowMethod::Mfd(m) => crate::hydro::mfd::mfd_flow_on(&z, m, &geo)?,
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
        let mut acc = acc;
        if sca {
            crate::hydro::areas::divide_by_contour_width(&mut acc, &info.georef, 0);
        }
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
    let engine = crate::exec::engine(cfg)?;
    let name = out
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "accumulation".into());
    let tmp = out.with_file_name(format!(".{name}.d8-tmp.tiles"));
    // Under MPI only rank 0 created the store (and every rank is past the
    // engine's closing barrier): several ranks removing it would race.
    let scratch = ScratchDir::new(&tmp).owned(crate::exec::rank().0 == 0);
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
            &d8_step.outputs(),
            &tmp_oo,
        )?;
        engine.run_global_apply(&d8_step, Run::new(&[dem], layout, sinks))?;
        let d8 = io::open_raster(&tmp, &io::OpenOptions::default())?;
        let mut acc_inputs: Vec<&dyn RasterSource> = vec![dem, d8.as_ref()];
        if let Some(w) = weights {
            acc_inputs.push(w);
        }
        let router = match method {
            FlowMethod::Dinf => Router::Dinf,
            FlowMethod::Mfd(m) => Router::Mfd(m),
        };
        let mut probe =
            crate::hydro::tiled_mfd::TiledMultiAccumulation::new(router, weights.is_some());
        probe.sca = sca;
        let sinks = make_sinks(
            probe.name(),
            probe.params(),
            &acc_inputs,
            &[out.to_path_buf()],
            &probe.outputs(),
            oo,
        )?;
        let run = run_multi(&engine, probe, &acc_inputs, layout, sinks)?;
        Ok(run.rounds)
    })();
    let rounds = result?;
    scratch.remove()?;
    Ok(rounds)
}
