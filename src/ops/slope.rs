//! `orogen slope`: slope (Horn 1981, as gdaldem slope), in degrees or percent.

use super::Target;
use crate::error::Result;
use crate::exec::EngineConfig;
use crate::metrics::{EdgeMode, Slope, SlopeUnits};
use crate::raster::RasterSource;

/// Options of `orogen slope`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SlopeOptions {
    /// Degrees or percent.
    pub units: SlopeUnits,
    /// Vertical exaggeration.
    pub z_factor: f64,
    /// Compute edge cells with missing neighbours (gdaldem -compute_edges).
    pub compute_edges: bool,
}

impl Default for SlopeOptions {
    fn default() -> Self {
        SlopeOptions {
            units: SlopeUnits::Degrees,
            z_factor: 1.0,
            compute_edges: false,
        }
    }
}

impl SlopeOptions {
    /// The local step these options describe.
    pub fn step(&self) -> Slope {
        Slope {
            units: self.units,
            z_factor: self.z_factor,
            edge: EdgeMode::from_compute_edges(self.compute_edges),
        }
    }
}

/// Slope of `dem` into `target` (f32, nodata
/// [`crate::metrics::terrain::SLOPE_NODATA`]), tile by tile.
///
/// ```
/// use orogen::ops::{slope, Target};
/// use orogen::raster::{read_window, GeoRef, Grid, MemRaster, Window};
/// // A plane rising 1 unit per cell eastwards, 1 x 1 cells: 45 degrees.
/// let dem = MemRaster::from_grid(Grid::from_fn(8, 8, |x, _| x as f32), GeoRef::pixel());
/// let out = std::env::temp_dir().join(format!("orogen-doc-slope-{}.tif", std::process::id()));
/// slope::run(&dem, &slope::SlopeOptions::default(), &Target::new(&out), &Default::default())?;
/// let s = orogen::io::open_raster(&out, &Default::default())?;
/// let g = read_window::<f32>(s.as_ref(), Window::new(4, 4, 1, 1))?;
/// assert!((g.get(0, 0) - 45.0).abs() < 1e-4);
/// # std::fs::remove_file(&out)?;
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn run(
    dem: &dyn RasterSource,
    opts: &SlopeOptions,
    target: &Target,
    cfg: &EngineConfig,
) -> Result<()> {
    target.run_local(&opts.step(), &[dem], cfg)
}
