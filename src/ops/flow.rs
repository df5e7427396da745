//! `orogen flow`: D8 flow directions of a filled DEM (ESRI codes 1..128,
//! 0 = no flow, 255 = nodata), flats drained per Barnes, Lehman & Mulla 2014,
//! exact across tiles; or Rho8 (Fairfield & Leymarie 1991, seeded).

use super::Target;
use crate::error::{Error, Result};
use crate::exec::EngineConfig;
use crate::raster::RasterSource;

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
    /// Declared sinks (as for [`crate::ops::fill::FillOptions::sinks`]: give
    /// the fill's): their cells get no flow (0) and the flats the fill left
    /// around them drain into them. D8 only.
    pub sinks: Option<std::path::PathBuf>,
}

/// Flow directions of the filled `dem` into `target` (u8, nodata
/// [`crate::hydro::NODATA_DIR`]), exact across tiles.
///
/// D8 then accumulation ([`crate::ops::accumulate::run`]) on a 5 x 5 plane
/// rising 1 m per cell eastwards and 10 m per cell southwards: below the top
/// row every cell drains north (ESRI code 64; 10 m down beats 1 m west and
/// 11/√2 m north-west), and the top row drains west (code 16) to the lowest
/// corner. Counting each cell itself, the middle column holds 1..4 from the
/// bottom up, and its top cell also collects the two columns east of it.
///
/// ```
/// use orogen::ops::{accumulate, flow, Target};
/// use orogen::raster::{read_window, GeoRef, Grid, MemRaster, Window};
/// let dem = MemRaster::from_grid(Grid::from_fn(5, 5, |x, y| (x + 10 * y) as f32), GeoRef::pixel());
/// let dir = std::env::temp_dir().join(format!("orogen-doc-flow-{}", std::process::id()));
/// std::fs::create_dir_all(&dir)?;
/// let cfg = Default::default();
/// flow::run(&dem, &flow::FlowOptions::default(), &Target::new(dir.join("d8.tif")), &cfg)?;
/// let d8 = orogen::io::open_raster(&dir.join("d8.tif"), &Default::default())?;
/// assert_eq!(read_window::<u8>(d8.as_ref(), Window::new(2, 2, 1, 1))?.get(0, 0), 64);
/// assert_eq!(read_window::<u8>(d8.as_ref(), Window::new(2, 0, 1, 1))?.get(0, 0), 16);
/// accumulate::run(d8.as_ref(), &Default::default(), &Target::new(dir.join("acc.tif")), &cfg)?;
/// let acc = orogen::io::open_raster(&dir.join("acc.tif"), &Default::default())?;
/// let column: Vec<f64> = (0..5)
///     .map(|y| read_window::<f64>(acc.as_ref(), Window::new(2, y, 1, 1)).map(|g| g.get(0, 0)))
///     .collect::<Result<_, _>>()?;
/// assert_eq!(column, [15.0, 4.0, 3.0, 2.0, 1.0]);
/// # std::fs::remove_dir_all(&dir)?;
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn run(
    dem: &dyn RasterSource,
    opts: &FlowOptions,
    target: &Target,
    cfg: &EngineConfig,
) -> Result<()> {
    if let Some(p) = &opts.sinks {
        if opts.method != FlowRouting::D8 {
            return Err(Error::invalid(format!(
                "{}: declared sinks are routed by D8 only; drop --sinks or use --method d8",
                p.display()
            )));
        }
        let sinks = crate::io::sinks::open_sinks(p, dem.info())?;
        return target.run_global(&crate::hydro::tiled::TiledD8, &[dem, sinks.as_ref()], cfg);
    }
    match opts.method {
        FlowRouting::D8 => target.run_global(&crate::hydro::tiled::TiledD8, &[dem], cfg),
        FlowRouting::Rho8 => {
            let step = crate::hydro::tiled_breach::TiledRho8 { seed: opts.seed };
            target.run_global(&step, &[dem], cfg)
        }
    }
}
