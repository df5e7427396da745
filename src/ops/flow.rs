//! `orogen flow`: D8 flow directions of a filled DEM (ESRI codes 1..128,
//! 0 = no flow, 255 = nodata), flats drained per Barnes, Lehman & Mulla 2014,
//! exact across tiles; or Rho8 (Fairfield & Leymarie 1991, seeded).

use super::{run_global_to, Target};
use crate::error::{Error, Result};
use crate::exec::EngineConfig;
use crate::raster::{DType, RasterSource};

/// Routing of `orogen flow --method`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FlowRouting {
    /// Steepest descent.
    #[default]
    D8,
    /// Fairfield & Leymarie 1991, stochastic, seeded.
    Rho8,
}

impl std::str::FromStr for FlowRouting {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "d8" => Ok(FlowRouting::D8),
            "rho8" => Ok(FlowRouting::Rho8),
            m => Err(Error::invalid(format!("--method {m:?}: use d8 or rho8"))),
        }
    }
}

/// Options of `orogen flow`.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FlowOptions {
    /// Routing.
    pub method: FlowRouting,
    /// Rho8 seed (same seed, same directions, whatever the tiling).
    pub seed: u64,
}

/// Flow directions of the filled `dem` into `target` (u8, nodata
/// [`crate::hydro::NODATA_DIR`]), exact across tiles.
pub fn run(
    dem: &dyn RasterSource,
    opts: &FlowOptions,
    target: &Target,
    cfg: &EngineConfig,
) -> Result<()> {
    let ty = (DType::U8, Some(crate::hydro::NODATA_DIR as f64));
    let (path, oo, tile) = (&target.path, &target.options, target.tile);
    match opts.method {
        FlowRouting::D8 => run_global_to(
            &crate::hydro::tiled::TiledD8,
            &[dem],
            path,
            ty,
            oo,
            tile,
            cfg,
        ),
        FlowRouting::Rho8 => run_global_to(
            &crate::hydro::tiled_breach::TiledRho8 { seed: opts.seed },
            &[dem],
            path,
            ty,
            oo,
            tile,
            cfg,
        ),
    }
}
