//! Where a tiled run writes its output tiles: the [`TileSink`] trait every
//! output implements (tile stores, GeoTIFFs, whole-file formats, memory),
//! the in-memory sink [`MemSink`] and the outputs kept in memory by path
//! ([`MemoryOutputs`]), and the rank of this process among the
//! processes that run a step together (set by the engine that runs them).
//!
//! It sits in `store` (below `exec`) so the readers and writers of `io` and
//! `store` implement it without naming the engine; `exec` re-exports it.

use super::{DelegatedTiles, TileEntry};
use crate::error::{Error, Result};
use crate::raster::{AnyGrid, Cell, DType, GeoRef, Grid, TileId, TileLayout, Window};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};

/// Where an engine writes output tiles. The engine calls `write` from one
/// thread, in increasing tile id order, so sinks need no reordering of their
/// own beyond their own block layout.
pub trait TileSink: Send {
    /// Native type of the output.
    fn dtype(&self) -> DType;
    /// Nodata value written for NaN cells.
    fn nodata(&self) -> Option<f64>;
    /// The tile layout the sink is bound to, if any (a tile store's); the
    /// engine refuses to run with a different layout.
    fn layout(&self) -> Option<TileLayout> {
        None
    }
    /// True if the tile is already finished (resume): the engine skips it.
    fn is_done(&self, _id: TileId) -> bool {
        false
    }
    /// Write one finished tile whose core is `core`.
    fn write(&mut self, id: TileId, core: Window, data: AnyGrid) -> Result<()>;
    /// If other processes may write this sink's tiles themselves (a tile
    /// store on a filesystem they share), what they need to do so; `None`
    /// (the default) means every tile must come to this sink's `write`.
    /// Used by the MPI engine: rank 0 owns the sink (and its lock) and
    /// delegates the tile files of the other ranks' tiles to them.
    fn delegate(&self) -> Option<DelegatedTiles> {
        None
    }
    /// Record tile `id`, written by another process through
    /// [`TileSink::delegate`] as `entry` (checksum and size): from then on
    /// the tile counts as finished, exactly as after `write`. Called in the
    /// same order and from the same thread as `write`.
    fn record_delegated(&mut self, id: TileId, _entry: TileEntry) -> Result<()> {
        Err(Error::invalid(format!(
            "tile {id}: this output cannot record tiles written by another process"
        )))
    }
    /// Finish the output (flush, write directories/manifest, rename into place).
    fn finish(self: Box<Self>) -> Result<()>;
}

/// Convert a step's typed output tile into the sink's native type.
pub fn to_sink_type<T: Cell>(g: &Grid<T>, sink: &dyn TileSink) -> AnyGrid {
    AnyGrid::from_typed(g, sink.dtype(), sink.nodata())
}

/// A sink that assembles the whole raster in memory (tests, small outputs).
/// Its result is taken from the [`MemSinkHandle`] after `finish`.
#[derive(Debug)]
pub struct MemSink {
    grid: AnyGrid,
    nodata: Option<f64>,
    cells_written: usize,
    out: Arc<Mutex<Option<AnyGrid>>>,
}

/// Where a finished [`MemSink`] leaves its grid.
#[derive(Debug, Clone)]
pub struct MemSinkHandle(Arc<Mutex<Option<AnyGrid>>>);

impl MemSinkHandle {
    /// The assembled grid, once the sink finished (`None` before, or if the
    /// run failed).
    pub fn take(&self) -> Option<AnyGrid> {
        self.0.lock().ok()?.take()
    }
}

impl MemSink {
    /// A `width` x `height` sink of `dtype` with `nodata`.
    pub fn new(
        width: usize,
        height: usize,
        dtype: DType,
        nodata: Option<f64>,
    ) -> (MemSink, MemSinkHandle) {
        let out = Arc::new(Mutex::new(None));
        let sink = MemSink {
            grid: AnyGrid::filled(dtype, width, height, nodata.unwrap_or(0.0)),
            nodata,
            cells_written: 0,
            out: out.clone(),
        };
        (sink, MemSinkHandle(out))
    }
}

impl TileSink for MemSink {
    fn dtype(&self) -> DType {
        self.grid.dtype()
    }
    fn nodata(&self) -> Option<f64> {
        self.nodata
    }
    fn write(&mut self, _id: TileId, core: Window, data: AnyGrid) -> Result<()> {
        let full = Window::full(self.grid.width(), self.grid.height());
        if data.dtype() != self.grid.dtype()
            || (data.width(), data.height()) != (core.w, core.h)
            || core.intersect(&full) != Some(core)
        {
            return Err(Error::invalid(format!(
                "memory sink: a {}x{} {} tile at {core:?} does not fit a {}x{} {} raster",
                data.width(),
                data.height(),
                data.dtype(),
                full.w,
                full.h,
                self.grid.dtype()
            )));
        }
        self.grid.paste(&data, core.x, core.y);
        self.cells_written += core.len();
        Ok(())
    }
    fn finish(self: Box<Self>) -> Result<()> {
        let total = self.grid.width() * self.grid.height();
        if self.cells_written != total {
            return Err(Error::invalid(format!(
                "memory sink: {} of {total} cells written",
                self.cells_written
            )));
        }
        let mut slot = self
            .out
            .lock()
            .map_err(|_| Error::invalid("memory sink: result slot poisoned"))?;
        *slot = Some(self.grid);
        Ok(())
    }
}

/// Outputs a run leaves in memory instead of writing them: every path
/// claimed here gets a [`MemSink`] from [`crate::io::create_sink`] (so
/// every writer of an operation, tiled or whole-raster, is served without
/// knowing it), and the assembled raster with its georeference is taken
/// back by path after the run. Paths not claimed (an operation's
/// intermediate stores) are written as usual. Clones share the claims.
#[derive(Debug, Clone, Default)]
pub struct MemoryOutputs(Arc<Mutex<Vec<MemoryClaim>>>);

/// One claimed path and, once its sink is made, where its result lands.
#[derive(Debug)]
struct MemoryClaim {
    path: PathBuf,
    result: Option<(MemSinkHandle, GeoRef)>,
}

impl MemoryOutputs {
    /// Keep the output written to `path` in memory.
    pub fn claim(&self, path: impl Into<PathBuf>) {
        if let Ok(mut claims) = self.0.lock() {
            claims.push(MemoryClaim {
                path: path.into(),
                result: None,
            });
        }
    }

    /// The in-memory sink for `path` if it is claimed (`None`: write the
    /// path as usual). The sink's nodata is `georef`'s.
    pub fn sink(
        &self,
        path: &Path,
        width: usize,
        height: usize,
        dtype: DType,
        georef: &GeoRef,
    ) -> Option<Box<dyn TileSink>> {
        let mut claims = self.0.lock().ok()?;
        let claim = claims.iter_mut().find(|c| c.path == path)?;
        let (sink, handle) = MemSink::new(width, height, dtype, georef.nodata);
        claim.result = Some((handle, georef.clone()));
        Some(Box::new(sink))
    }

    /// The raster written to the claimed `path` and its georeference
    /// (`None` if nothing was written there, or the run failed).
    pub fn take(&self, path: &Path) -> Option<(AnyGrid, GeoRef)> {
        let claims = self.0.lock().ok()?;
        let (handle, georef) = claims.iter().find(|c| c.path == path)?.result.as_ref()?;
        Some((handle.take()?, georef.clone()))
    }
}

static RANK: AtomicUsize = AtomicUsize::new(0);
static RANKS: AtomicUsize = AtomicUsize::new(1);

/// Record that this process is rank `rank` of `ranks` processes running the
/// steps together (the MPI engine calls it when it starts, and with `(0, 1)`
/// when it ends).
pub fn set_process_rank(rank: usize, ranks: usize) {
    RANK.store(rank, Ordering::Release);
    RANKS.store(ranks.max(1), Ordering::Release);
}

/// `(rank, ranks)` of this process as recorded by [`set_process_rank`]:
/// `(0, 1)` unless a distributed engine runs.
pub fn process_rank() -> (usize, usize) {
    (RANK.load(Ordering::Acquire), RANKS.load(Ordering::Acquire))
}
