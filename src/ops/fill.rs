//! `orogen fill`: fill depressions (Priority-Flood, Barnes, Lehman & Mulla
//! 2014; exact across tiles after Barnes 2016). Nodata cells, the DEM's
//! edge and declared sinks (`sinks`, [`crate::io::sinks`]) are outlets.

use super::Target;
use crate::error::Result;
use crate::exec::EngineConfig;
use crate::raster::RasterSource;

/// Options of `orogen fill`.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FillOptions {
    /// Declared sinks: a raster on the DEM's grid (non-zero = sink) or a
    /// points file (CSV, GeoJSON), outlets like the edge: an endorheic
    /// basin drains into its sink instead of filling to its spill point.
    pub sinks: Option<std::path::PathBuf>,
}

/// Fill the depressions of `dem` into `target` (f32; nodata from
/// [`crate::exec::output::elevation_nodata`]), exact across tiles.
///
/// ```
/// use orogen::ops::{fill, Target};
/// use orogen::raster::{read_window, GeoRef, Grid, MemRaster, Window};
/// // A 5 x 5 plateau at 10 with a pit of 2 in the middle: the pit fills to 10.
/// let dem = MemRaster::from_grid(Grid::from_fn(5, 5, |x, y| if (x, y) == (2, 2) { 2.0f32 } else { 10.0 }), GeoRef::pixel());
/// let out = std::env::temp_dir().join(format!("orogen-doc-fill-{}.tif", std::process::id()));
/// fill::run(&dem, &fill::FillOptions::default(), &Target::new(&out), &Default::default())?;
/// let f = orogen::io::open_raster(&out, &Default::default())?;
/// assert_eq!(read_window::<f32>(f.as_ref(), Window::new(2, 2, 1, 1))?.get(0, 0), 10.0);
/// # std::fs::remove_file(&out)?;
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn run(
    dem: &dyn RasterSource,
    opts: &FillOptions,
    target: &Target,
    cfg: &EngineConfig,
) -> Result<()> {
    match &opts.sinks {
        None => target.run_global(&crate::hydro::tiled::TiledFill, &[dem], cfg),
        Some(p) => {
            let sinks = crate::io::sinks::open_sinks(p, dem.info())?;
            target.run_global(&crate::hydro::tiled::TiledFill, &[dem, sinks.as_ref()], cfg)
        }
    }
}
