//! `orogen aspect`: aspect (Horn 1981, as gdaldem aspect), the azimuth of
//! downslope in degrees from north.

use super::Target;
use crate::error::Result;
use crate::exec::EngineConfig;
use crate::metrics::{Aspect, EdgeMode};
use crate::raster::RasterSource;

/// Options of `orogen aspect`.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AspectOptions {
    /// Flat cells get 0 instead of nodata.
    pub zero_for_flat: bool,
    /// Compute edge cells with missing neighbours (gdaldem -compute_edges).
    pub compute_edges: bool,
}

impl AspectOptions {
    /// The local step these options describe.
    pub fn step(&self) -> Aspect {
        Aspect {
            edge: EdgeMode::from_compute_edges(self.compute_edges),
            zero_for_flat: self.zero_for_flat,
        }
    }
}

/// Aspect of `dem` into `target` (f32, nodata
/// [`crate::metrics::terrain::SLOPE_NODATA`]), tile by tile.
pub fn run(
    dem: &dyn RasterSource,
    opts: &AspectOptions,
    target: &Target,
    cfg: &EngineConfig,
) -> Result<()> {
    target.run_local(&opts.step(), &[dem], cfg)
}
