//! Tiled execution: the step traits (local and global), the `Engine` trait
//! that runs steps over tiles (tile sinks are `store::sink`'s, re-exported
//! here), what each output is ([`output::OutputSpec`]: cell type, nodata
//! rule, kind, declared by the step) and runs planned from paths
//! ([`plan`], which turns the specs into sinks). Steps never know which engine runs them; an engine never
//! knows what a step computes.
//!
//! The engine is a value: [`engine`] turns an [`EngineConfig`] (whose
//! `engine` field is an [`EngineKind`]) into an [`Engines`], the in-process
//! [`LocalEngine`] or, with the `mpi` feature, the MPI engine; both
//! implement [`Engine`]. [`select_engine`] only starts MPI at process
//! start-up.

use crate::error::Result;
use crate::raster::{Cell, Grid, IntoAny, RasterSource, TileId, TileLayout, TileView};
use output::OutputSpec;
use serde::{de::DeserializeOwned, Serialize};

/// A local step: `tile + halo -> tile`, for every tile independently.
/// With the declared halo, the result must equal the in-memory computation
/// on the whole grid, cell for cell.
pub trait LocalStep: Sync {
    /// Cell type the inputs are read as (NaN = nodata for floats).
    type In: Cell;
    /// Cell type of the outputs.
    type Out: IntoAny;
    /// Short name (provenance, progress bar).
    fn name(&self) -> String;
    /// Parameters, recorded as provenance in the output's manifest.
    fn params(&self) -> serde_json::Value;
    /// Halo in cells the step needs around each tile.
    fn halo(&self) -> usize;
    /// The output rasters (all of the core's size), one spec each: cell
    /// type written, nodata rule, kind. Their number is the length.
    fn outputs(&self) -> Vec<OutputSpec>;
    /// Extra working memory `run` allocates for one tile of side `tile`
    /// (summed-area tables, horizon buffers…), counted in the memory budget.
    fn scratch_bytes(&self, _tile: usize) -> u64 {
        0
    }
    /// Compute one tile. `inputs[i]` is input `i`'s view (core + halo);
    /// `out[k]` is output `k`'s core, pre-filled with nodata (NaN or 0).
    fn run(&self, inputs: &[TileView<Self::In>], out: &mut [Grid<Self::Out>]) -> Result<()>;
}

/// A global step in three phases (Barnes 2016, 2017; DESIGN.md): `map` solves
/// each tile alone into a small serialisable summary; `reduce` joins all
/// summaries into a solution; `apply` rewrites each tile with its slice of the
/// solution. Summaries and slices are serde types so another engine (MPI) can
/// ship them between processes.
pub trait GlobalStep: Sync {
    /// Cell type the inputs are read as.
    type In: Cell;
    /// Cell type of the outputs written by `apply`.
    type Out: IntoAny;
    /// Per-tile summary (should be O(perimeter)).
    type Summary: Serialize + DeserializeOwned + Send;
    /// The reduced global solution.
    type Solution: Send + Sync;
    /// What `apply` needs of the solution for one tile.
    type Slice: Serialize + DeserializeOwned + Send + Sync;
    /// Short name.
    fn name(&self) -> String;
    /// Parameters (provenance).
    fn params(&self) -> serde_json::Value;
    /// Halo for the views given to `map` and `apply`.
    fn halo(&self) -> usize {
        0
    }
    /// The outputs of `apply`, as in [`LocalStep::outputs`] (empty for a
    /// step run for its solution only).
    fn outputs(&self) -> Vec<OutputSpec>;
    /// Solve one tile alone.
    fn map(&self, inputs: &[TileView<Self::In>]) -> Result<Self::Summary>;
    /// Join the summaries (`summaries[id]` belongs to tile `id`).
    fn reduce(&self, layout: &TileLayout, summaries: Vec<Self::Summary>) -> Result<Self::Solution>;
    /// The part of the solution tile `id` needs.
    fn slice(&self, solution: &Self::Solution, id: TileId) -> Self::Slice;
    /// Rewrite one tile with its slice; `out` as in [`LocalStep::run`].
    fn apply(
        &self,
        inputs: &[TileView<Self::In>],
        slice: &Self::Slice,
        out: &mut [Grid<Self::Out>],
    ) -> Result<()>;
}

/// Engine settings shared by all engines.
#[derive(Debug, Clone)]
pub struct EngineConfig {
    /// Worker threads (0 = all cores).
    pub threads: usize,
    /// Memory budget in bytes for tiles in flight (inputs + outputs + buffers).
    pub memory_budget: u64,
    /// Show a progress bar on stderr.
    pub progress: bool,
    /// Told of every tile (or round) done, and may stop the run.
    pub observer: Option<Observer>,
    /// Which engine runs the steps ([`engine`] builds it): in this process
    /// or over the ranks of `mpirun`.
    pub engine: EngineKind,
}

impl Default for EngineConfig {
    fn default() -> Self {
        EngineConfig {
            threads: 0,
            memory_budget: 1 << 30,
            progress: false,
            observer: None,
            engine: EngineKind::Local,
        }
    }
}

/// One run of a step on an engine: the inputs (all of the layout's size),
/// the tile layout, and one sink per output of the step (none: a global
/// step run for its solution only).
pub struct Run<'a> {
    /// The step's inputs, input 0 first.
    pub inputs: &'a [&'a dyn RasterSource],
    /// The tiles.
    pub layout: TileLayout,
    /// Output `k` is written to `sinks[k]`.
    pub sinks: Vec<Box<dyn TileSink>>,
}

impl<'a> Run<'a> {
    /// A run of `inputs` over `layout` writing to `sinks`.
    pub fn new(
        inputs: &'a [&'a dyn RasterSource],
        layout: TileLayout,
        sinks: Vec<Box<dyn TileSink>>,
    ) -> Run<'a> {
        Run {
            inputs,
            layout,
            sinks,
        }
    }

    /// A run of `inputs` over `layout` that writes nothing (a global step's
    /// solution only).
    pub fn solution_only(inputs: &'a [&'a dyn RasterSource], layout: TileLayout) -> Run<'a> {
        Run::new(inputs, layout, Vec::new())
    }
}

/// Runs steps over tiles. Implemented by the in-process engine (rayon) and
/// the distributed one (MPI); steps are written once against this trait.
pub trait Engine {
    /// Run a local step over every tile of `run.layout`, reading
    /// `run.inputs` and writing output `k` to `run.sinks[k]`.
    fn run_local<S: LocalStep>(&self, step: &S, run: Run<'_>) -> Result<()>;

    /// Run a global step: map every tile, reduce, then (if `run.sinks` is
    /// not empty) apply every tile and write it. Returns the solution.
    fn run_global<S: GlobalStep>(&self, step: &S, run: Run<'_>) -> Result<S::Solution>;

    /// Run a global step whose caller needs only the written outputs, not
    /// the solution: map, reduce, apply and write, like [`Engine::run_global`].
    /// The default runs `run_global` and drops the solution; a distributed
    /// engine may instead reduce on one process and send each other process
    /// only the slices of its tiles (Barnes 2016, 2017), since no process
    /// but the reducing one needs the whole solution.
    fn run_global_apply<S: GlobalStep>(&self, step: &S, run: Run<'_>) -> Result<()> {
        self.run_global(step, run).map(|_| ())
    }
}

/// Start the engine `kind` for this process (at start-up, before the first
/// step): `Mpi` initialises MPI once (call [`finish_engine`] before the
/// process exits; [`EngineKind::current`] is `Mpi` from then on); it is an
/// error in a build without the `mpi` feature. `Local` needs no start.
/// Which engine runs a step is the [`EngineConfig::engine`] value given to
/// [`engine`], never this process state.
pub fn select_engine(kind: EngineKind) -> Result<()> {
    match kind {
        EngineKind::Local => Ok(()),
        #[cfg(feature = "mpi")]
        EngineKind::Mpi => mpi::init(),
        #[cfg(not(feature = "mpi"))]
        EngineKind::Mpi => Err(mpi_missing()),
    }
}

/// The error of `--engine mpi` in a build without the `mpi` feature.
#[cfg(not(feature = "mpi"))]
pub(crate) fn mpi_missing() -> crate::error::Error {
    crate::error::Error::invalid(
        "--engine mpi: this orogen was built without MPI (feature `mpi`); rebuild with `cargo build --release --features mpi` (tools/install_mpi.sh installs Open MPI and libclang) and start it with mpirun",
    )
}

/// True when the MPI engine runs this process's steps.
pub fn distributed() -> bool {
    #[cfg(feature = "mpi")]
    {
        mpi::active()
    }
    #[cfg(not(feature = "mpi"))]
    {
        false
    }
}

/// `(rank, ranks)` of this process: `(0, 1)` unless the MPI engine runs.
pub fn rank() -> (usize, usize) {
    #[cfg(feature = "mpi")]
    {
        mpi::rank_size()
    }
    #[cfg(not(feature = "mpi"))]
    {
        (0, 1)
    }
}

/// Wait until every rank gets here (no-op unless the MPI engine runs): used
/// after work that bypasses the engine's own barriers, such as an ingest,
/// so no rank reads an output before rank 0 has finished writing it.
pub fn barrier() {
    #[cfg(feature = "mpi")]
    mpi::barrier();
}

/// End the engine of this process (finalises MPI if it was started); call
/// once, last, on every exit path that did not fail.
pub fn finish_engine() {
    #[cfg(feature = "mpi")]
    mpi::finalize();
}

/// End the job on every rank after `msg` (an error) on this one: MPI_Abort
/// under the MPI engine, else a plain exit with status 1.
pub fn abort_engine(msg: &str) -> ! {
    #[cfg(feature = "mpi")]
    if mpi::active() {
        mpi::abort(msg)
    }
    eprintln!("error: {msg}");
    std::process::exit(1)
}

mod copy;
mod engines;
pub mod iterate;
mod local;
mod memory_fit;
#[cfg(feature = "mpi")]
pub mod mpi;
pub mod mpi_codec;
pub mod mpi_halo;
#[cfg(feature = "mpi")]
mod mpi_queue;
pub mod output;
pub mod plan;
mod progress;
pub mod stats;
mod tile_io;

pub use crate::store::sink::{to_sink_type, MemSink, MemSinkHandle, TileSink};
pub use copy::{copy, ingest, run_local_to_memory};
pub use engines::{engine, EngineKind, Engines};
pub use local::LocalEngine;
pub use memory_fit::MemoryFit;
pub use progress::{Observer, Progress};
pub use tile_io::{local_tile_bytes, roundtrip_summary, tiles_in_flight};
