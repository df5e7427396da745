//! `orogen fill-nodata`: fill voids (nodata cells) by inverse-distance
//! weighting of the first valid cell on each of 16 rays, out to a maximum
//! distance (the interpolation GDAL's `gdal_fillnodata` defines, without its
//! smoothing passes; [`crate::hydro::fill_nodata`] states the method and its
//! sources). Exact across tiles: the step's halo is the maximum distance.
//! Void cells with no valid cell on any ray within the distance stay nodata;
//! valid cells are copied unchanged; the output has the input's cell type
//! and nodata value.

use super::parse::{serde_reach, Reach};
use super::Target;
use crate::error::{Error, Result};
use crate::exec::plan::choose_layout;
use crate::exec::{local_tile_bytes, EngineConfig, MemoryFit};
use crate::hydro::fill_nodata::FillNodata;
use crate::raster::{DType, RasterSource};

/// Options of `orogen fill-nodata`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FillNodataOptions {
    /// How far to search for valid cells: cells (`100`, gdal_fillnodata's
    /// `-md`) or metres (`500m`, `3km`, with each row's cell size).
    #[serde(with = "serde_reach")]
    pub max_distance: Reach,
}

/// gdal_fillnodata's default `-md`: 100 cells.
pub const DEFAULT_MAX_DISTANCE: Reach = Reach::Cells(100.0);

impl Default for FillNodataOptions {
    fn default() -> Self {
        FillNodataOptions {
            max_distance: DEFAULT_MAX_DISTANCE,
        }
    }
}

/// The step filling `dem` with `opts`: errors when `dem` is of an integer
/// type and declares no nodata value (there is nothing to fill; a float
/// input without one has its NaN cells as voids, and its output keeps NaN)
/// or the distance is absurd.
pub fn step(dem: &dyn RasterSource, opts: &FillNodataOptions) -> Result<FillNodata> {
    let info = dem.info();
    let nodata = info.georef.nodata;
    if nodata.is_none() && !matches!(info.dtype, DType::F32 | DType::F64) {
        return Err(Error::invalid(format!(
            "{}: declares no nodata value, so fill-nodata has no voids to fill \
             (if some value marks voids, declare it first, e.g. gdal_edit.py -a_nodata -32768 FILE)",
            info.path.display()
        )));
    }
    FillNodata::new(
        opts.max_distance,
        &info.georef,
        info.height,
        info.dtype,
        nodata,
    )
}

/// Fill the voids of `dem` into `target` (the input's cell type and
/// nodata), tile by tile. Before anything is written, refuses a DEM without
/// a nodata value and a maximum distance whose halo makes one tile larger
/// than the memory budget (the error names the fix).
///
/// ```
/// use orogen::ops::{fill_nodata, Target};
/// use orogen::raster::{read_window, GeoRef, Grid, MemRaster, Window};
/// // A plane z = x with a one-cell void in the middle: filled back to 4
/// // (the rays are symmetric about the void, so the plane is exact there).
/// let g = Grid::from_fn(9, 9, |x, y| if (x, y) == (4, 4) { -9999.0f32 } else { x as f32 });
/// let dem = MemRaster::from_grid(g, GeoRef::pixel().with_nodata(Some(-9999.0)));
/// let out = std::env::temp_dir().join(format!("orogen-doc-fill-nodata-{}.tif", std::process::id()));
/// fill_nodata::run(&dem, &Default::default(), &Target::new(&out), &Default::default())?;
/// let f = orogen::io::open_raster(&out, &Default::default())?;
/// assert_eq!(read_window::<f32>(f.as_ref(), Window::new(4, 4, 1, 1))?.get(0, 0), 4.0);
/// # std::fs::remove_file(&out)?;
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn run(
    dem: &dyn RasterSource,
    opts: &FillNodataOptions,
    target: &Target,
    cfg: &EngineConfig,
) -> Result<()> {
    let step = step(dem, opts)?;
    check_memory(dem, &step, target, cfg)?;
    target.run_local(&step, &[dem], cfg)
}

/// One tile with its halo (the step reads and writes f64) against the
/// budget: the engine runs at least one tile whatever the budget, so an
/// absurd halo is refused here, before any output exists.
fn check_memory(
    dem: &dyn RasterSource,
    step: &FillNodata,
    target: &Target,
    cfg: &EngineConfig,
) -> Result<()> {
    use crate::exec::LocalStep;
    let layout = choose_layout(
        dem,
        std::slice::from_ref(&target.path),
        &target.options,
        target.tile,
    );
    let need = local_tile_bytes(&layout, step.halo(), &[dem], 8, 8, &[step.dtype.size()]);
    MemoryFit::bytes(need, cfg.memory_budget).check(|f| {
        Error::over_budget(format!(
            "fill-nodata: --max-distance {} reaches {} cells beyond every {}-cell tile, so one \
             tile needs {:.2} GiB, more than the --memory budget of {} MiB; give a smaller \
             --max-distance or raise --memory to at least {}GiB",
            step.max_distance,
            step.halo(),
            layout.tile,
            f.need_gib(),
            f.budget_mib(),
            f.suggested_gib()
        ))
    })
}
