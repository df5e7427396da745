//! `orogen fill-epsilon`: depression filling to a strictly draining epsilon
//! surface, exact across tiles: each flat cell rises k ULPs above its fill
//! level, k = its distance to the flat's exit (two global passes:
//! `TiledFill` into a temporary tile store next to the output, then
//! `TiledEpsilon`; see [`crate::hydro::tiled`]).

use super::{choose_tile, run_global_to, Target};
use crate::error::Result;
use crate::exec::EngineConfig;
use crate::raster::RasterSource;
use crate::store::scratch::ScratchDir;

/// Options of `orogen fill-epsilon` (none yet: the surface is parameter-free).
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FillEpsilonOptions {}

/// Fill, then raise every flat cell of `dem` by k ULPs (k = its distance to
/// the flat's exit) into `target`; the temporary filled store is removed
/// afterwards. Errors (instead of raising terrain) where a flat is too wide
/// for f32 steps.
pub fn run(
    dem: &dyn RasterSource,
    _opts: &FillEpsilonOptions,
    target: &Target,
    cfg: &EngineConfig,
) -> Result<()> {
    let out = &target.path;
    let mut name = out.file_name().unwrap_or_default().to_os_string();
    name.push(".fill-tmp.tiles");
    let tmp = out.with_file_name(name);
    // Under MPI only rank 0 created the store; the others removing it too would race.
    let scratch = ScratchDir::new(&tmp).owned(crate::exec::rank().0 == 0);
    let mut too = crate::io::OutputOptions::default();
    too.store.overwrite = true;
    too.store.sync = false;
    too.store.tile = choose_tile(dem, target.tile);
    let result = (|| -> Result<()> {
        let fill = crate::hydro::tiled::TiledFill;
        run_global_to(&fill, &[dem], &tmp, &too, target.tile, cfg)?;
        let filled = crate::io::open_raster(&tmp, &crate::io::OpenOptions::default())?;
        let epsilon = crate::hydro::tiled::TiledEpsilon;
        target.run_global(&epsilon, &[filled.as_ref()], cfg)?;
        Ok(())
    })();
    scratch.remove()?;
    result
}
