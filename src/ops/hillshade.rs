//! `orogen hillshade`: hillshade (Horn 1981, as gdaldem hillshade), byte
//! values 1-255, 0 = nodata.

use super::Target;
use crate::error::{Error, Result};
use crate::exec::EngineConfig;
use crate::metrics::{EdgeMode, Hillshade};
use crate::raster::RasterSource;

/// Options of `orogen hillshade`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct HillshadeOptions {
    /// Azimuth of the light, degrees clockwise from north.
    pub azimuth: f64,
    /// Altitude of the light above the horizon, degrees (0 to 90).
    pub altitude: f64,
    /// Vertical exaggeration.
    pub z_factor: f64,
    /// Compute edge cells with missing neighbours (gdaldem -compute_edges).
    pub compute_edges: bool,
}

impl Default for HillshadeOptions {
    fn default() -> Self {
        HillshadeOptions {
            azimuth: 315.0,
            altitude: 45.0,
            z_factor: 1.0,
            compute_edges: false,
        }
    }
}

impl HillshadeOptions {
    /// Check the parameters (the sun's altitude).
    pub fn validate(&self) -> Result<()> {
        let altitude = self.altitude;
        if !(0.0..=90.0).contains(&altitude) {
            return Err(Error::invalid(format!(
                "--altitude {altitude}: the sun's altitude must be between 0 and 90 degrees"
            )));
        }
        Ok(())
    }

    /// The local step these options describe.
    pub fn step(&self) -> Hillshade {
        Hillshade {
            azimuth: self.azimuth,
            altitude: self.altitude,
            z_factor: self.z_factor,
            edge: EdgeMode::from_compute_edges(self.compute_edges),
        }
    }
}

/// Hillshade of `dem` into `target` (u8, nodata 0), tile by tile.
pub fn run(
    dem: &dyn RasterSource,
    opts: &HillshadeOptions,
    target: &Target,
    cfg: &EngineConfig,
) -> Result<()> {
    opts.validate()?;
    target.run_local(&opts.step(), &[dem], cfg)
}
