//! `orogen watersheds`: watershed labels from D8 directions, exact across
//! tiles ([`crate::hydro::tiled::TiledLabels`]).

use super::Target;
use crate::error::Result;
use crate::exec::EngineConfig;
use crate::raster::RasterSource;

/// Options of `orogen watersheds` (none yet).
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct WatershedsOptions {}

/// Label every cell of the D8 directions `dirs` with the row-major index + 1
/// of the cell where its D8 path leaves the DEM (u32, 0 = nodata), into `target`.
pub fn run(
    dirs: &dyn RasterSource,
    _opts: &WatershedsOptions,
    target: &Target,
    cfg: &EngineConfig,
) -> Result<()> {
    target.run_global(&crate::hydro::tiled::TiledLabels, &[dirs], cfg)
}
