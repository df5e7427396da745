//! The output target of an operation.

use crate::error::Result;
use crate::exec::plan::{run_global_to, run_local_to_paths};
use crate::exec::{EngineConfig, GlobalStep, LocalStep};
use crate::io::OutputOptions;
use crate::raster::{AnyGrid, GeoRef, RasterSource};
use std::path::{Path, PathBuf};

/// Where and how an operation writes its raster output: the path (its
/// extension picks the format: `.tif`, `.tiles`, `.png`, `.asc`; a folder for
/// operations that write several files), the format options, and the
/// work-tile size (`None`: an input store's own, else [`super::DEFAULT_TILE`]).
/// [`Target::memory`] keeps the output in memory instead of writing it.
#[derive(Debug, Clone)]
pub struct Target {
    /// Output path.
    pub path: PathBuf,
    /// GeoTIFF / tile-store / COG settings.
    pub options: OutputOptions,
    /// Work-tile size in cells.
    pub tile: Option<usize>,
}

impl Target {
    /// `path` with the default output options and work tiles.
    pub fn new(path: impl Into<PathBuf>) -> Self {
        Target {
            path: path.into(),
            options: OutputOptions::default(),
            tile: None,
        }
    }

    /// A target whose raster output stays in memory, taken back with
    /// [`Target::take_memory`] after the run: the output is claimed at
    /// `output.tif` in `dir`, an existing folder where the operation's
    /// intermediate stores (if any) are written as usual.
    ///
    /// ```
    /// use orogen::ops::{fill, Target};
    /// use orogen::raster::{AnyGrid, GeoRef, Grid, MemRaster};
    /// // A 5 x 5 plateau at 10 with a pit of 2 in the middle: the pit fills to 10.
    /// let dem = MemRaster::from_grid(Grid::from_fn(5, 5, |x, y| if (x, y) == (2, 2) { 2.0f32 } else { 10.0 }), GeoRef::pixel());
    /// let target = Target::memory(&std::env::temp_dir());
    /// fill::run(&dem, &fill::FillOptions::default(), &target, &Default::default())?;
    /// let (out, _georef) = target.take_memory().expect("the fill left its output");
    /// let AnyGrid::F32(g) = out else { panic!("fill writes f32") };
    /// assert_eq!((g.get(2, 2), g.get(0, 0)), (10.0, 10.0));
    /// assert!(!target.path.exists());
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn memory(dir: &Path) -> Self {
        let mut t = Target::new(dir.join("output.tif"));
        let memory = crate::store::sink::MemoryOutputs::default();
        memory.claim(&t.path);
        t.options.memory = Some(memory);
        t
    }

    /// The raster an operation left in this [`Target::memory`] target and
    /// its georeference (`None` for a path target, or before a run).
    pub fn take_memory(&self) -> Option<(AnyGrid, GeoRef)> {
        self.options.memory.as_ref()?.take(&self.path)
    }

    /// Run a one-output local step on `inputs` into this target, written
    /// as the step's output spec declares.
    pub fn run_local<S: LocalStep>(
        &self,
        step: &S,
        inputs: &[&dyn RasterSource],
        cfg: &EngineConfig,
    ) -> Result<()> {
        let out = std::slice::from_ref(&self.path);
        run_local_to_paths(step, inputs, out, &self.options, self.tile, cfg)
    }

    /// Run a one-output global step (map, reduce, apply) on `inputs` into
    /// this target, written as the step's output spec declares.
    pub fn run_global<S: GlobalStep>(
        &self,
        step: &S,
        inputs: &[&dyn RasterSource],
        cfg: &EngineConfig,
    ) -> Result<()> {
        run_global_to(step, inputs, &self.path, &self.options, self.tile, cfg)
    }
}
