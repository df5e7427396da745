//! The MPI engine (`--features mpi`, `--engine mpi`): the same steps as the
//! in-process engine, spread over the ranks of `mpirun`, writing the same
//! bytes.
//!
//! Every rank runs the same command (SPMD), so every rank reaches the same
//! engine call with the same step, inputs and layout; the engine then splits
//! the tiles between the ranks:
//! - tiles to do are listed by rank 0 (resume) and broadcast; the ranks
//!   draw them from a work queue rank 0 serves ([`super::mpi_queue`]:
//!   guided chunks on request, so ranks whose tiles are cheap take more);
//!   each rank runs what it drew on its own thread pool. Which rank does
//!   which tile changes from run to run; the output does not;
//! - local steps and the apply phase of global steps: each rank computes its
//!   tiles, converts them to the sinks' native types and sends them to rank
//!   0 as they finish, which puts them back in order and writes every tile
//!   in increasing id order to its sinks, exactly as the in-process engine
//!   does (so the bytes are the same; see [`MpiEngine::distribute`] for the
//!   bounded reorder window). Tile-store outputs are written by the rank
//!   that computed the tile; rank 0 records them, in tile order too. The
//!   sinks of the other ranks are dropped unwritten. Cost: every GeoTIFF
//!   output cell crosses the network once, to rank 0;
//! - global steps (Barnes 2016, "Parallel priority-flood depression filling
//!   for trillion cell digital elevation models on desktops or clusters",
//!   Computers & Geosciences 96; Barnes 2017, "Parallel non-divergent flow
//!   accumulation for trillion cell digital elevation models on desktops or
//!   clusters", Environmental Modelling & Software 92): each rank maps its
//!   tiles; the summaries (serde, sent as JSON, which a debug build of the
//!   in-process engine already round-trips) go to every rank, every rank
//!   reduces them to the same solution (`reduce` is deterministic), and
//!   takes its tiles' slices from it. The trait returns the solution to the
//!   caller on every rank and solutions are not serialisable, so this
//!   replaces Barnes's "rank 0 reduces and sends each rank its slice"; the
//!   price is that each rank receives all summaries instead of its slices.
//!   `run_global_apply` (no solution returned) follows Barnes: rank 0
//!   reduces and sends each grant of the apply phase with its tiles' slices.
//!
//! MPI calls are made only from the thread that started MPI (thread level
//! "funneled"): the worker pools hand results to the calling thread, and
//! rank 0 serves the queue by polling between its own tiles.
//!
//! Failure: an error on any rank once the ranks communicate prints the rank,
//! host and the error (which names the step and tile) and calls MPI_Abort,
//! which ends every rank; a rank that dies is reported by `mpirun`, which
//! ends the others. Nothing is left looking finished: GeoTIFF outputs are
//! renamed into place only by a successful `finish`.

use super::mpi_codec::{
    decode_records, decode_tile_written, encode_tile_written, perimeter_cells, push_record, Queue,
    Schedule, TileParts,
};
use super::mpi_queue::{self, Work};
use super::tile_io::{
    blank_outputs, check_inputs, check_sinks, convert_outputs, finish_all, read_views, todo,
    write_outputs,
};
use super::{Engine, GlobalStep, LocalEngine, LocalStep, TileSink};
use crate::error::{Error, Result};
use crate::raster::{AnyGrid, DType, RasterSource, TileId, TileLayout};
use crate::store::{DelegatedTiles, TileEntry, TileState};
use mpi::environment::Universe;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;
use std::time::Instant;

/// MPI state of the process: the universe (dropping it finalises MPI) and
/// the thread that initialised it (the only one that may call MPI).
struct State {
    universe: Universe,
    thread: std::thread::ThreadId,
}

static STATE: Mutex<Option<State>> = Mutex::new(None);
static ACTIVE: AtomicBool = AtomicBool::new(false);

/// Message tag of tile messages (rank -> rank 0).
pub(super) const TAG_TILE: i32 = 11;
/// Message tag of byte strings sent point to point ([`send_bytes`]).
const TAG_BYTES: i32 = 12;
/// Largest piece of one broadcast (MPI counts are 32-bit).
const CHUNK: usize = 1 << 30;

/// Initialise MPI (once per process) and route every engine run to the
/// ranks. Started without `mpirun`, MPI runs as a single rank.
pub fn init() -> Result<()> {
    let mut st = STATE
        .lock()
        .map_err(|_| Error::invalid("MPI engine: state lock poisoned"))?;
    if st.is_some() {
        return Ok(());
    }
    let (universe, level) = mpi::initialize_with_threading(mpi::Threading::Funneled)
        .ok_or_else(|| {
            Error::invalid(
                "--engine mpi: MPI was already initialised or finalised in this process; run each orogen command in its own process",
            )
        })?;
    if level == mpi::Threading::Single {
        return Err(Error::invalid(
            "--engine mpi: the MPI library supports only single-threaded processes (MPI_THREAD_SINGLE); orogen needs MPI_THREAD_FUNNELED (Open MPI and MPICH provide it)",
        ));
    }
    if universe.world().rank() == 0 {
        last_words::install();
    }
    *st = Some(State {
        universe,
        thread: std::thread::current().id(),
    });
    ACTIVE.store(true, Ordering::Release);
    let (rank, ranks) = rank_size();
    crate::store::sink::set_process_rank(rank, ranks);
    Ok(())
}

/// True once [`init`] succeeded and until [`finalize`].
pub fn active() -> bool {
    ACTIVE.load(Ordering::Acquire)
}

/// Finalise MPI (after a barrier, so no rank leaves while another still
/// writes). No effect if MPI was not started.
pub fn finalize() {
    if !ACTIVE.swap(false, Ordering::AcqRel) {
        return;
    }
    crate::store::sink::set_process_rank(0, 1);
    if let Ok(mut st) = STATE.lock() {
        if let Some(s) = st.take() {
            s.universe.world().barrier();
            drop(s);
        }
    }
}

fn world() -> SimpleCommunicator {
    SimpleCommunicator::world()
}

/// Barrier over all ranks (no-op if MPI is not running).
pub fn barrier() {
    if active() {
        world().barrier();
    }
}

/// `(rank, ranks)` of this process; `(0, 1)` if MPI is not running.
pub fn rank_size() -> (usize, usize) {
    if !active() {
        return (0, 1);
    }
    let w = world();
    (w.rank().max(0) as usize, w.size().max(1) as usize)
}

fn host() -> String {
    mpi::environment::processor_name().unwrap_or_else(|_| "?".into())
}

/// Print `msg` naming this rank and end every rank (MPI_Abort).
pub fn abort(msg: &str) -> ! {
    let (r, n) = rank_size();
    eprintln!(
        "error: MPI rank {r} of {n} (host {}, pid {}): {msg}\nerror: ending the job on all ranks (MPI_Abort); rerun to resume from finished tile-store tiles",
        host(),
        std::process::id()
    );
    world().abort(1)
}

/// End the job on every rank with `e` (see [`abort`]).
pub(super) fn fail(e: Error) -> ! {
    abort(&e.to_string())
}

/// Send `bytes` to rank `to`: its length (`u64`), then pieces of at most
/// [`CHUNK`] bytes (MPI counts are 32-bit).
fn send_bytes(comm: &SimpleCommunicator, to: usize, bytes: &[u8]) {
    let p = comm.process_at_rank(to as i32);
    p.send_with_tag(&(bytes.len() as u64), TAG_BYTES);
    for piece in bytes.chunks(CHUNK) {
        p.send_with_tag(piece, TAG_BYTES);
    }
}

/// Receive what [`send_bytes`] sent from rank `from`. Memory grows with the
/// pieces actually received, never by the announced length alone.
fn recv_bytes(comm: &SimpleCommunicator, from: usize) -> Result<Vec<u8>> {
    let p = comm.process_at_rank(from as i32);
    let (len, _) = p.receive_with_tag::<u64>(TAG_BYTES);
    let mut out = Vec::new();
    while (out.len() as u64) < len {
        let (piece, _) = p.receive_vec_with_tag::<u8>(TAG_BYTES);
        if piece.is_empty() || out.len() as u64 + piece.len() as u64 > len {
            return Err(Error::invalid(format!(
                "MPI engine: rank {from} announced {len} bytes and sent a piece of {} after {}",
                piece.len(),
                out.len()
            )));
        }
        out.extend_from_slice(&piece);
    }
    Ok(out)
}

/// Send rank 0's `bytes` to every rank (length, then pieces of at most
/// [`CHUNK`] bytes); other ranks pass anything and get rank 0's bytes.
fn broadcast_bytes(comm: &SimpleCommunicator, mut bytes: Vec<u8>) -> Vec<u8> {
    let root = comm.process_at_rank(0);
    let mut len = bytes.len() as u64;
    root.broadcast_into(&mut len);
    if comm.rank() != 0 {
        // A length from rank 0 of the same job (small: a few sink descriptions).
        let n = usize::try_from(len)
            .unwrap_or_else(|_| fail(Error::invalid(format!("rank 0 broadcasts {len} bytes"))));
        bytes = vec![0u8; n];
    }
    for piece in bytes.chunks_mut(CHUNK) {
        root.broadcast_into(piece);
    }
    bytes
}

/// What rank 0 is waiting for, printed to stderr if the process is ended
/// by SIGTERM, which is how `mpirun` (and Slurm) end the surviving ranks
/// after one rank died: with `mpirun`'s own "process rank R exited on
/// signal 9", it names the dead rank's unfinished tiles. The message lives
/// in a fixed static buffer of atomics and the handler only copies it and
/// calls `write(2)` and `_exit(2)`, both async-signal-safe (POSIX.1-2017,
/// "Signal Concepts", 2.4.3).
mod last_words {
    use std::sync::atomic::{AtomicU8, AtomicUsize, Ordering};

    const CAP: usize = 2048;
    static BUF: [AtomicU8; CAP] = [const { AtomicU8::new(0) }; CAP];
    static LEN: AtomicUsize = AtomicUsize::new(0);

    /// Replace the message (truncated to the buffer).
    pub(super) fn set(msg: &str) {
        LEN.store(0, Ordering::Release);
        let b = msg.as_bytes();
        let n = b.len().min(CAP);
        for (slot, &byte) in BUF.iter().zip(&b[..n]) {
            slot.store(byte, Ordering::Relaxed);
        }
        LEN.store(n, Ordering::Release);
    }

    /// No message (the handler then just exits).
    pub(super) fn clear() {
        LEN.store(0, Ordering::Release);
    }

    extern "C" fn on_term(sig: libc::c_int) {
        let n = LEN.load(Ordering::Acquire).min(CAP);
        let mut local = [0u8; CAP];
        for (dst, src) in local.iter_mut().zip(BUF.iter()).take(n) {
            *dst = src.load(Ordering::Relaxed);
        }
        // SAFETY: `local` is a live stack buffer of at least `n` bytes;
        // write(2) and _exit(2) are async-signal-safe.
        unsafe {
            if n > 0 {
                libc::write(2, local.as_ptr().cast(), n);
            }
            libc::_exit(128 + sig);
        }
    }

    /// Install the SIGTERM handler (rank 0, once).
    pub(super) fn install() {
        let handler: extern "C" fn(libc::c_int) = on_term;
        // SAFETY: the handler only touches atomics and calls
        // async-signal-safe functions.
        unsafe {
            libc::signal(libc::SIGTERM, handler as libc::sighandler_t);
        }
    }
}

/// Rank 0's last words while tiles are still out: for each rank other
/// than 0, how many tiles it was granted and has not delivered (`left`),
/// naming the first few of them found in `ids[frontier..]` (a bounded
/// look-ahead, so a refresh costs O(ranks), not O(tiles)); `got[k]` says
/// position `k` arrived.
fn note_pending(
    step: &str,
    ids: &[TileId],
    q: &Queue,
    got: &[bool],
    frontier: usize,
    left: &[usize],
) {
    let ranks = left.len();
    let mut first: Vec<Vec<String>> = vec![Vec::new(); ranks];
    for k in (frontier..ids.len()).take(64 * ranks.max(1)) {
        if got[k] {
            continue;
        }
        if let Some(f) = q
            .owner(k)
            .and_then(|o| first.get_mut(o))
            .filter(|f| f.len() < 6)
        {
            f.push(ids[k].to_string());
        }
    }
    let mut lines = String::new();
    for r in 1..ranks {
        let n = left[r];
        if n > 0 {
            lines.push_str(&format!(
                "\n  rank {r}: {n} tile(s) granted and not received: {}{}",
                first[r].join(", "),
                if n > first[r].len() { ", ..." } else { "" }
            ));
        }
    }
    let msg = format!(
        "error: MPI rank 0 ended (SIGTERM) during {step}; {}{lines}\nerror: a rank died or the job was cancelled (mpirun names the rank); rerun the same command to resume from the finished tiles of tile-store outputs\n",
        if lines.is_empty() {
            "every other rank had delivered the tiles granted to it"
        } else {
            "still missing from the other ranks:"
        }
    );
    last_words::set(&msg);
}

/// The work-queue schedule chosen on rank 0 (`OROGEN_MPI_SCHEDULE`:
/// `queue`, the default, or `round-robin` to compare against).
fn schedule() -> Schedule {
    let v = std::env::var("OROGEN_MPI_SCHEDULE").unwrap_or_default();
    Schedule::parse(&v).unwrap_or_else(|e| fail(e))
}

/// Rank 0's payload of a grant: the packed slices of the granted tiles.
type SlicesOut<'a> = &'a (dyn Fn(&[TileId]) -> Result<Vec<u8>> + Sync);
/// A rank's intake of a grant's payload (granted tiles, packed slices).
type SlicesIn<'a> = &'a (dyn Fn(&[TileId], &[u8]) -> Result<()> + Sync);

/// How a tile arrived at rank 0 before its turn to be written.
enum Arrived {
    /// Computed on rank 0 (the sinks' native types).
    Own(Vec<AnyGrid>),
    /// A tile message from another rank.
    Remote(Vec<u8>),
}

/// Rank 0's side of [`MpiEngine::distribute`]: puts tiles arriving in any
/// order back into tile order and writes them (or records the receipts of
/// delegated writes) exactly as the in-process engine does.
struct Writer<'a> {
    name: &'a str,
    layout: &'a TileLayout,
    ids: &'a [TileId],
    meta: &'a [(DType, Option<f64>)],
    sinks: Vec<Box<dyn TileSink>>,
    delegated: &'a [Option<DelegatedTiles>],
    slices: Option<SlicesOut<'a>>,
    /// Positions that arrived and wait for an earlier one (at most the
    /// queue's window when cells travel; receipts only otherwise).
    buffer: std::collections::BTreeMap<usize, Arrived>,
    got: Vec<bool>,
    left: Vec<usize>,
    frontier: usize,
    moved: u64,
}

impl Writer<'_> {
    fn shapes_of(&self, id: TileId) -> Vec<(DType, usize, usize)> {
        let core = self.layout.window(id);
        self.meta
            .iter()
            .zip(self.delegated)
            .filter(|(_, d)| d.is_none())
            .map(|(m, _)| (m.0, core.w, core.h))
            .collect()
    }

    /// Write the tile at the frontier if it is there (one tile, so the
    /// queue is served between writes); true if one was written.
    fn write_next(&mut self, q: &Queue) -> Result<bool> {
        let Some(a) = self.buffer.remove(&self.frontier) else {
            return Ok(false);
        };
        let id = self.ids[self.frontier];
        match a {
            Arrived::Own(grids) => write_outputs(&mut self.sinks, self.layout, id, grids)
                .map_err(|e| Error::tile(self.name, id, e))?,
            Arrived::Remote(msg) => self
                .write_remote(id, &msg)
                .map_err(|e| Error::tile(self.name, id, e))?,
        }
        self.frontier += 1;
        note_pending(self.name, self.ids, q, &self.got, self.frontier, &self.left);
        Ok(true)
    }

    fn write_remote(&mut self, id: TileId, msg: &[u8]) -> Result<()> {
        let n_written = self.delegated.iter().filter(|d| d.is_some()).count();
        let (cells, written) = decode_tile_written(msg, id, &self.shapes_of(id), n_written)?;
        let core = self.layout.window(id);
        let mut cells = cells.into_iter();
        let mut written = written.into_iter();
        for (s, d) in self.sinks.iter_mut().zip(self.delegated) {
            let done = s.is_done(id);
            if d.is_some() {
                let Some((crc32, bytes)) = written.next() else {
                    break;
                };
                if !done {
                    s.record_delegated(
                        id,
                        TileEntry {
                            state: TileState::Done,
                            crc32,
                            bytes,
                        },
                    )?;
                }
            } else {
                let Some(g) = cells.next() else { break };
                if !done {
                    s.write(id, core, g)?;
                }
            }
        }
        Ok(())
    }

    fn arrive(&mut self, k: usize, from: usize, q: &Queue) -> Result<()> {
        if q.owner(k) != Some(from) || self.got[k] {
            return Err(Error::invalid(format!(
                "{}: rank {from} delivered tile {}, which it was not granted or which came twice",
                self.name, self.ids[k]
            )));
        }
        self.got[k] = true;
        if let Some(l) = self.left.get_mut(from) {
            *l = l.saturating_sub(1);
        }
        Ok(())
    }
}

impl mpi_queue::Serve<Vec<AnyGrid>> for Writer<'_> {
    fn payload(&mut self, ks: &[usize]) -> Result<Vec<u8>> {
        match self.slices {
            Some(f) => f(&ks.iter().map(|&k| self.ids[k]).collect::<Vec<_>>()),
            None => Ok(Vec::new()),
        }
    }
    fn granted(&mut self, r: usize, ks: &[usize], q: &Queue) {
        if let Some(l) = self.left.get_mut(r) {
            *l += ks.len();
        }
        note_pending(self.name, self.ids, q, &self.got, self.frontier, &self.left);
    }
    fn own(&mut self, k: usize, grids: Vec<AnyGrid>, q: &Queue) -> Result<()> {
        self.arrive(k, 0, q)?;
        self.buffer.insert(k, Arrived::Own(grids));
        note_pending(self.name, self.ids, q, &self.got, self.frontier, &self.left);
        Ok(())
    }
    fn remote(&mut self, from: usize, msg: Vec<u8>, q: &Queue) -> Result<()> {
        let id = msg
            .get(..8)
            .map(|b| {
                let mut a = [0u8; 8];
                a.copy_from_slice(b);
                u64::from_le_bytes(a)
            })
            .ok_or_else(|| {
                Error::invalid(format!(
                    "{}: a tile message from rank {from} is shorter than its header",
                    self.name
                ))
            })?;
        let k = usize::try_from(id)
            .ok()
            .and_then(|id| self.ids.binary_search(&id).ok())
            .ok_or_else(|| {
                Error::invalid(format!(
                    "{}: rank {from} sent tile {id}, which is not to do",
                    self.name
                ))
            })?;
        self.arrive(k, from, q)?;
        self.moved += msg.len() as u64;
        self.buffer.insert(k, Arrived::Remote(msg));
        note_pending(self.name, self.ids, q, &self.got, self.frontier, &self.left);
        Ok(())
    }
    fn write_one(&mut self, q: &Queue) -> Result<bool> {
        self.write_next(q)
    }
    fn frontier(&self) -> usize {
        self.frontier
    }
    fn complete(&self) -> bool {
        self.frontier >= self.ids.len()
    }
}

/// A rank's side of [`MpiEngine::distribute`]: tiles (and receipts) to
/// rank 0 as they finish; slices that come with grants to `slices`.
struct Sender<'a> {
    ids: &'a [TileId],
    slices: Option<SlicesIn<'a>>,
    moved: u64,
}

impl mpi_queue::Draw<TileParts> for Sender<'_> {
    fn payload(&mut self, ks: &[usize], bytes: &[u8]) -> Result<()> {
        match self.slices {
            Some(f) => f(&ks.iter().map(|&k| self.ids[k]).collect::<Vec<_>>(), bytes),
            None => Ok(()),
        }
    }
    fn result(&mut self, k: usize, (cells, written): TileParts) -> Result<Option<Vec<u8>>> {
        let msg = encode_tile_written(self.ids[k], &cells, &written);
        self.moved += msg.len() as u64;
        Ok(Some(msg))
    }
}

/// Rank 0's side of the map phase: its own summaries into a record list;
/// the last words name each rank's latest grant (summaries travel only at
/// the end of the phase).
struct MapServe<'a> {
    name: &'a str,
    records: Vec<u8>,
    last: Vec<String>,
}

impl mpi_queue::Serve<Vec<u8>> for MapServe<'_> {
    fn payload(&mut self, _ks: &[usize]) -> Result<Vec<u8>> {
        Ok(Vec::new())
    }
    fn granted(&mut self, r: usize, ks: &[usize], _q: &Queue) {
        if let (Some(slot), Some(a), Some(b)) = (self.last.get_mut(r), ks.first(), ks.last()) {
            *slot = format!("tiles {a}..={b}");
        }
        let mut lines = String::new();
        for (r, l) in self.last.iter().enumerate().skip(1) {
            if !l.is_empty() {
                lines.push_str(&format!("\n  rank {r}: last granted {l}"));
            }
        }
        last_words::set(&format!(
            "error: MPI rank 0 ended (SIGTERM) during {}, map phase (summaries travel at its end);{lines}\nerror: a rank died or the job was cancelled (mpirun names the rank); rerun the same command to resume from the finished tiles of tile-store outputs\n",
            self.name
        ));
    }
    fn own(&mut self, k: usize, b: Vec<u8>, _q: &Queue) -> Result<()> {
        push_record(&mut self.records, k, &b);
        Ok(())
    }
    fn remote(&mut self, from: usize, _msg: Vec<u8>, _q: &Queue) -> Result<()> {
        Err(Error::invalid(format!(
            "{}: rank {from} sent a tile message during the map phase",
            self.name
        )))
    }
    fn write_one(&mut self, _q: &Queue) -> Result<bool> {
        Ok(false)
    }
    fn frontier(&self) -> usize {
        0
    }
    fn complete(&self) -> bool {
        true
    }
}

/// A rank's side of the map phase: summaries into a record list.
struct MapDraw {
    records: Vec<u8>,
}

impl mpi_queue::Draw<Vec<u8>> for MapDraw {
    fn payload(&mut self, _ks: &[usize], _bytes: &[u8]) -> Result<()> {
        Ok(())
    }
    fn result(&mut self, k: usize, b: Vec<u8>) -> Result<Option<Vec<u8>>> {
        push_record(&mut self.records, k, &b);
        Ok(None)
    }
}

/// The MPI engine: an [`Engine`] over the ranks of `MPI_COMM_WORLD`, each
/// computing with the thread pool and memory budget of `local`.
#[derive(Debug, Clone)]
pub struct MpiEngine {
    local: LocalEngine,
}

/// What one phase moved, summed over the ranks (for `OROGEN_MPI_STATS`).
struct Phase<'a> {
    step: &'a str,
    phase: &'static str,
    tiles: usize,
    perimeter: u64,
    /// Bytes sent (summaries: compressed).
    up: u64,
    /// Bytes received by ranks other than the sender.
    down: u64,
    /// Bytes before compression.
    raw: u64,
    t0: Instant,
    /// What this rank did in the phase's work queue (none: zero).
    work: Work,
}

/// Compress a record list for the wire: raw length (`u64`), then zstd
/// (level 3) of the JSON records, which are mostly decimal numbers.
fn pack(records: &[u8]) -> Result<Vec<u8>> {
    let z = zstd::bulk::compress(records, 3)
        .map_err(|e| Error::invalid(format!("MPI engine: compressing summaries: {e}")))?;
    let mut out = Vec::with_capacity(8 + z.len());
    out.extend_from_slice(&(records.len() as u64).to_le_bytes());
    out.extend_from_slice(&z);
    Ok(out)
}

/// Undo [`pack`]; the declared size is checked against zstd's own frame
/// header before anything that large is allocated.
fn unpack(msg: &[u8]) -> Result<Vec<u8>> {
    if msg.len() < 8 {
        return Err(Error::invalid(
            "a summary message is shorter than its header",
        ));
    }
    let mut a = [0u8; 8];
    a.copy_from_slice(&msg[..8]);
    let n = u64::from_le_bytes(a);
    let frame = zstd::zstd_safe::get_frame_content_size(&msg[8..])
        .ok()
        .flatten();
    if frame != Some(n) {
        return Err(Error::invalid(format!(
            "a summary message declares {n} bytes but its zstd frame {frame:?}"
        )));
    }
    let n = usize::try_from(n)
        .map_err(|_| Error::invalid(format!("a summary message declares {n} bytes")))?;
    zstd::bulk::decompress(&msg[8..], n)
        .map_err(|e| Error::invalid(format!("decompressing summaries: {e}")))
}

impl MpiEngine {
    /// An MPI engine whose ranks compute as `local` does. Call [`init`] first.
    pub fn new(local: LocalEngine) -> Self {
        MpiEngine { local }
    }

    fn check_thread(&self, name: &str) -> Result<()> {
        let st = STATE
            .lock()
            .map_err(|_| Error::invalid("MPI engine: state lock poisoned"))?;
        match st.as_ref() {
            Some(s) if s.thread == std::thread::current().id() => Ok(()),
            Some(_) => Err(Error::invalid(format!(
                "{name}: the MPI engine was called from a thread other than the one that started MPI"
            ))),
            None => Err(Error::invalid(format!(
                "{name}: the MPI engine runs only after MPI is started (--engine mpi)"
            ))),
        }
    }

    /// Rank 0's list of tiles to do (it owns the sinks that know which are
    /// finished), sent to every rank.
    fn shared_todo(
        comm: &SimpleCommunicator,
        layout: &TileLayout,
        sinks: &[Box<dyn TileSink>],
    ) -> Vec<TileId> {
        let root = comm.process_at_rank(0);
        let mut ids: Vec<u64> = if comm.rank() == 0 {
            todo(layout, sinks).into_iter().map(|i| i as u64).collect()
        } else {
            Vec::new()
        };
        let mut n = ids.len() as u64;
        root.broadcast_into(&mut n);
        if n > layout.count() as u64 {
            fail(Error::invalid(format!(
                "rank 0 lists {n} tiles to do, the layout has {}",
                layout.count()
            )));
        }
        ids.resize(n as usize, 0);
        if n > 0 {
            root.broadcast_into(&mut ids[..]);
        }
        ids.into_iter().map(|i| i as TileId).collect()
    }

    /// Send every rank's `mine` bytes to every rank (one broadcast per
    /// rank, in pieces of at most [`CHUNK`] bytes). Returns the lists by rank.
    fn all_to_all(comm: &SimpleCommunicator, mine: Vec<u8>) -> Vec<Vec<u8>> {
        let n = comm.size() as usize;
        let me = comm.rank() as usize;
        let mut mine = Some(mine);
        let mut out = Vec::with_capacity(n);
        for r in 0..n {
            let root = comm.process_at_rank(r as i32);
            let mut buf = if r == me {
                mine.take().unwrap_or_default()
            } else {
                Vec::new()
            };
            let mut len = buf.len() as u64;
            root.broadcast_into(&mut len);
            if r != me {
                // The length comes from a rank of the same job; the bytes
                // are checked when decoded.
                buf = vec![
                    0u8;
                    usize::try_from(len).unwrap_or_else(|_| {
                        fail(Error::too_large(
                            std::path::Path::new("<MPI>"),
                            format!("rank {r} sends {len} bytes of summaries"),
                        ))
                    })
                ];
            }
            for piece in buf.chunks_mut(CHUNK) {
                root.broadcast_into(piece);
            }
            out.push(buf);
        }
        out
    }

    /// Sum `up`/`down` over the ranks and, on rank 0 with
    /// `OROGEN_MPI_STATS` set, print one JSON line for the phase, with each
    /// rank's tiles, busy seconds (summed over its workers) and the time its
    /// last tile finished, and the work queue's own message bytes.
    fn report(comm: &SimpleCommunicator, p: Phase) {
        const F: usize = 7;
        let n = comm.size() as usize;
        let w = p.work;
        let mine = [
            p.up,
            p.down,
            p.raw,
            w.tiles,
            (w.busy * 1e6) as u64,
            (w.last * 1e6) as u64,
            w.queue_bytes,
        ];
        let mut all = vec![0u64; F * n];
        comm.all_gather_into(&mine[..], &mut all[..]);
        if comm.rank() != 0 || std::env::var_os("OROGEN_MPI_STATS").is_none() {
            return;
        }
        let col = |i: usize| all.iter().skip(i).step_by(F).copied().collect::<Vec<u64>>();
        let up: u64 = col(0).iter().sum();
        let down: u64 = col(1).iter().sum();
        let raw: u64 = col(2).iter().sum();
        let tiles_done = col(3);
        let secs = |v: Vec<u64>| v.into_iter().map(|x| x as f64 * 1e-6).collect::<Vec<f64>>();
        let queue: u64 = col(6).iter().sum();
        let done: u64 = tiles_done.iter().sum();
        let per = |b: u64| {
            if p.perimeter == 0 {
                0.0
            } else {
                b as f64 / p.perimeter as f64
            }
        };
        eprintln!(
            "{}",
            serde_json::json!({
                "mpi_stats": p.step,
                "phase": p.phase,
                "ranks": n,
                "tiles": p.tiles,
                "perimeter_cells": p.perimeter,
                "bytes_up": up,
                "bytes_up_uncompressed": raw,
                "bytes_up_uncompressed_per_perimeter_cell": per(raw),
                "bytes_down": down,
                "bytes_up_per_perimeter_cell": per(up),
                "bytes_down_per_perimeter_cell": per(down),
                "seconds": p.t0.elapsed().as_secs_f64(),
                "schedule": format!("{:?}", schedule()),
                "tiles_per_rank": tiles_done,
                "busy_s_per_rank": secs(col(4)),
                "last_tile_s_per_rank": secs(col(5)),
                "queue_bytes": queue,
                "queue_bytes_per_tile": if done == 0 { 0.0 } else { queue as f64 / done as f64 },
            })
        );
    }

    /// Tiles in flight on one rank for tiles of `bytes` (the in-process
    /// pipeline's rule: the budget, at most `4 x workers + 4`).
    fn cap(&self, bytes: u64) -> usize {
        let threads = self.local.config().threads.max(1);
        self.local.tiles_in_flight(bytes).min(4 * threads + 4)
    }

    /// Compute the tiles `ids` spread over the ranks by the work queue
    /// ([`mpi_queue`]) and write them on rank 0 in increasing id order.
    /// `compute` gives a tile's outputs in the sinks' native types. Outputs
    /// whose sink on rank 0 can delegate its writes (a tile store:
    /// [`TileSink::delegate`]) are written by the rank that computed the
    /// tile, which sends rank 0 only the tile's checksum and size to record;
    /// the others travel to rank 0. Rank 0 writes (and records) in tile
    /// order whatever the order of arrival, so neither the output nor a
    /// store's journal depends on which rank did which tile.
    ///
    /// Memory on rank 0: its own tiles in flight (`d = min(cap, threads +
    /// 1)`, see `mpi_queue::depth`) plus the tiles that arrived before an
    /// earlier one was written. When cells travel, the queue grants nothing
    /// beyond a window of `W` positions past the first unwritten one, `W =
    /// max(2 x ranks, min(ranks x cap, budget / bytes_per_tile - d))`, so
    /// rank 0 holds at most `d + W` tiles: within its `--memory` budget
    /// unless that is under `2 x ranks + d` tiles. Receipts alone (12 bytes
    /// per delegated output) are not windowed. Other ranks hold at most `d`
    /// tiles, and each message buffer is one of those tiles.
    ///
    /// `slices_out` (rank 0) gives the payload of a grant (the slices of
    /// its tiles, when only rank 0 holds the solution); `slices_in` (other
    /// ranks) takes it. Returns the bytes sent to rank 0 (tiles, receipts)
    /// and this rank's work. Errors end the job (MPI_Abort).
    #[allow(clippy::too_many_arguments)]
    fn distribute(
        &self,
        comm: &SimpleCommunicator,
        name: &str,
        layout: &TileLayout,
        ids: &[TileId],
        meta: &[(DType, Option<f64>)],
        bytes: u64,
        sinks: Vec<Box<dyn TileSink>>,
        compute: &(dyn Fn(TileId) -> Result<Vec<AnyGrid>> + Sync),
        slices_out: Option<SlicesOut<'_>>,
        slices_in: Option<SlicesIn<'_>>,
    ) -> (u64, Work) {
        let me = comm.rank() as usize;
        let ranks = comm.size() as usize;
        let threads = self.local.config().threads.max(1);
        let cap = self.cap(bytes);
        let delegated = Self::shared_delegation(comm, &sinks, meta, layout);
        let (moved, work) = if me == 0 {
            let travels = delegated.iter().any(|d| d.is_none());
            // The reorder window and rank 0's own tiles in flight share its
            // memory budget (at least two tiles per rank, so every rank can
            // work while the next one travels).
            let own = mpi_queue::depth(cap, threads);
            let window = travels.then(|| {
                (ranks * cap)
                    .min(self.local.tiles_in_flight(bytes).saturating_sub(own))
                    .max(2 * ranks)
            });
            let max_chunk = if slices_out.is_some() {
                4 * cap
            } else {
                usize::MAX
            };
            let mut q = Queue::new(ids.len(), ranks, schedule(), window, max_chunk)
                .unwrap_or_else(|e| fail(e));
            let mut w = Writer {
                name,
                layout,
                ids,
                meta,
                sinks,
                delegated: &delegated,
                slices: slices_out,
                buffer: Default::default(),
                got: vec![false; ids.len()],
                left: vec![0; ranks],
                frontier: 0,
                moved: 0,
            };
            let work = mpi_queue::serve(comm, name, threads, cap, ids, &mut q, compute, &mut w);
            last_words::clear();
            if let Err(e) = finish_all(w.sinks) {
                fail(e);
            }
            (w.moved, work)
        } else {
            drop(sinks);
            // Compute, then write the delegated outputs here (on the
            // workers, in parallel): what travels is the rest plus receipts.
            let delegated = &delegated;
            let work = |id: TileId| -> Result<TileParts> {
                let grids = compute(id)?;
                let mut cells = Vec::new();
                let mut written = Vec::new();
                for (g, d) in grids.into_iter().zip(delegated) {
                    match d {
                        Some(d) => {
                            let e = d.write_tile(id, &g)?;
                            written.push((e.crc32, e.bytes));
                        }
                        None => cells.push(g),
                    }
                }
                Ok((cells, written))
            };
            let mut s = Sender {
                ids,
                slices: slices_in,
                moved: 0,
            };
            let work = mpi_queue::draw(comm, name, threads, cap, ids, &work, &mut s);
            (s.moved, work)
        };
        // Nobody goes on (and reads the output) before rank 0 finished it.
        comm.barrier();
        (moved, work)
    }

    /// Rank 0 decides, per output, whether the ranks write their tiles
    /// themselves (its sink can delegate, and `OROGEN_MPI_DELEGATE` is not
    /// `0`) and sends every rank the delegation (JSON), so all ranks agree.
    fn shared_delegation(
        comm: &SimpleCommunicator,
        sinks: &[Box<dyn TileSink>],
        meta: &[(DType, Option<f64>)],
        layout: &TileLayout,
    ) -> Vec<Option<DelegatedTiles>> {
        let mine: Vec<Option<DelegatedTiles>> = if comm.rank() == 0 {
            let on = std::env::var("OROGEN_MPI_DELEGATE").as_deref() != Ok("0");
            sinks
                .iter()
                .map(|s| if on { s.delegate() } else { None })
                .collect()
        } else {
            Vec::new()
        };
        let bytes = if comm.rank() == 0 {
            serde_json::to_vec(&mine).unwrap_or_else(|e| {
                fail(Error::invalid(format!(
                    "MPI engine: a tile-store delegation does not serialise: {e}"
                )))
            })
        } else {
            Vec::new()
        };
        let bytes = broadcast_bytes(comm, bytes);
        let got: Vec<Option<DelegatedTiles>> = serde_json::from_slice(&bytes)
            .unwrap_or_else(|e| fail(Error::invalid(format!("MPI engine: rank 0's tile-store delegation does not parse (ranks of different orogen builds?): {e}"))));
        if got.len() != meta.len() {
            fail(Error::invalid(format!(
                "MPI engine: rank 0 delegates {} outputs, this rank has {}",
                got.len(),
                meta.len()
            )));
        }
        for (d, m) in got.iter().zip(meta) {
            if let Some(d) = d {
                if d.dtype != m.0 || d.layout().ok() != Some(*layout) {
                    fail(Error::invalid(format!(
                        "MPI engine: rank 0's store {} is {} in tiles of {}, this rank computes {} in tiles of {}",
                        d.dir.display(),
                        d.dtype,
                        d.tile,
                        m.0,
                        layout.tile
                    )));
                }
            }
        }
        got
    }

    /// On rank 0, say how many tiles a resumed output had finished already
    /// (one line on stderr, even when quiet: under MPI a resume follows a
    /// failed job, and the line shows the rerun did not start over).
    fn note_resume(
        &self,
        comm: &SimpleCommunicator,
        name: &str,
        ids: &[TileId],
        layout: &TileLayout,
    ) {
        if comm.rank() == 0 && ids.len() < layout.count() {
            eprintln!(
                "{name}: resuming: {} of {} tiles already finished (skipped), {} to do",
                layout.count() - ids.len(),
                layout.count(),
                ids.len()
            );
        }
    }

    /// Map phase of a global step: the ranks map all tiles, drawn from the
    /// work queue; returns (rank 0) the queue, which records who mapped
    /// which tile, this rank's summaries as a record list of JSON, and this
    /// rank's work. Errors end the job.
    fn map_mine<S: GlobalStep>(
        &self,
        comm: &SimpleCommunicator,
        step: &S,
        inputs: &[&dyn RasterSource],
        layout: &TileLayout,
    ) -> (Option<Queue>, Vec<u8>, Work) {
        let name = step.name();
        let halo = step.halo();
        let all: Vec<TileId> = (0..layout.count()).collect();
        let map_bytes =
            super::local_tile_bytes(layout, halo, inputs, std::mem::size_of::<S::In>(), 0, &[]);
        let map_name = format!("{name} (map)");
        let map = |id: TileId| -> Result<Vec<u8>> {
            let views = read_views::<S::In>(inputs, layout, id, halo)?;
            let s = step.map(&views)?;
            serde_json::to_vec(&s).map_err(|e| {
                Error::invalid(format!("{name}: a tile summary does not serialise: {e}"))
            })
        };
        let threads = self.local.config().threads.max(1);
        let cap = self.cap(map_bytes);
        if comm.rank() == 0 {
            let mut q = Queue::new(
                all.len(),
                comm.size() as usize,
                schedule(),
                None,
                usize::MAX,
            )
            .unwrap_or_else(|e| fail(e));
            let mut h = MapServe {
                name: &map_name,
                records: Vec::new(),
                last: vec![String::new(); comm.size().max(1) as usize],
            };
            let work = mpi_queue::serve(comm, &map_name, threads, cap, &all, &mut q, &map, &mut h);
            last_words::clear();
            (Some(q), h.records, work)
        } else {
            let mut h = MapDraw {
                records: Vec::new(),
            };
            let work = mpi_queue::draw(comm, &map_name, threads, cap, &all, &map, &mut h);
            (None, h.records, work)
        }
    }

    /// Apply phase of a global step: like a local step, each tile with its
    /// slice. The tiles to apply are drawn from the work queue again (apply
    /// costs need not follow map costs, and a resumed output applies fewer
    /// tiles than were mapped). `solution` is there on every rank (the
    /// replicated reduce) or on rank 0 only (`shipped`, Barnes): then rank 0 sends
    /// the slices of the tiles of each grant along with it. Errors end the
    /// job.
    #[allow(clippy::too_many_arguments)]
    fn apply_phase<S: GlobalStep>(
        &self,
        comm: &SimpleCommunicator,
        step: &S,
        inputs: &[&dyn RasterSource],
        layout: &TileLayout,
        sinks: Vec<Box<dyn TileSink>>,
        solution: Option<&S::Solution>,
        shipped: bool,
        t_reduce: Instant,
    ) {
        let name = step.name();
        let t1 = Instant::now();
        let me = comm.rank() as usize;
        let count = layout.count();
        let halo = step.halo();
        let meta: Vec<(DType, Option<f64>)> =
            sinks.iter().map(|s| (s.dtype(), s.nodata())).collect();
        let sizes: Vec<usize> = meta.iter().map(|m| m.0.size()).collect();
        let bytes = super::local_tile_bytes(
            layout,
            halo,
            inputs,
            std::mem::size_of::<S::In>(),
            std::mem::size_of::<S::Out>(),
            &sizes,
        );
        let ids = Self::shared_todo(comm, layout, &sinks);
        self.note_resume(comm, &name, &ids, layout);
        Self::report(
            comm,
            Phase {
                step: &name,
                phase: "global: reduce",
                tiles: count,
                perimeter: perimeter_cells(layout),
                up: 0,
                down: 0,
                raw: 0,
                t0: t_reduce,
                work: Work::default(),
            },
        );
        // Slices that came with grants (ranks other than 0, Barnes).
        let received: Mutex<std::collections::HashMap<TileId, S::Slice>> =
            Mutex::new(Default::default());
        let slice_of = |id: TileId| -> Result<S::Slice> {
            match solution {
                Some(sol) => Ok(step.slice(sol, id)),
                None => received
                    .lock()
                    .map_err(|_| Error::invalid("MPI engine: slice table lock poisoned"))?
                    .remove(&id)
                    .ok_or_else(|| {
                        Error::invalid(format!("rank 0 sent no slice of tile {id} to this rank"))
                    }),
            }
        };
        let slices_out = |grant: &[TileId]| -> Result<Vec<u8>> {
            let Some(sol) = solution else {
                return Ok(Vec::new());
            };
            let mut list = Vec::new();
            for &id in grant {
                let b = serde_json::to_vec(&step.slice(sol, id)).map_err(|e| {
                    Error::invalid(format!(
                        "{name}: the slice of tile {id} does not serialise: {e}"
                    ))
                })?;
                push_record(&mut list, id, &b);
            }
            pack(&list)
        };
        let slices_in = |grant: &[TileId], bytes: &[u8]| -> Result<()> {
            let list = unpack(bytes)
                .map_err(|e| Error::invalid(format!("{name}: the slices sent by rank 0: {e}")))?;
            let mut got = received
                .lock()
                .map_err(|_| Error::invalid("MPI engine: slice table lock poisoned"))?;
            let mut n = 0;
            for (id, b) in decode_records(&list, count)? {
                if grant.binary_search(&id).is_err() || got.contains_key(&id) {
                    return Err(Error::invalid(format!(
                        "{name}: rank 0 sent the slice of tile {id}, which this rank was not granted or already has"
                    )));
                }
                let v: S::Slice = serde_json::from_slice(b).map_err(|e| {
                    Error::tile(
                        &name,
                        id,
                        Error::invalid(format!(
                            "its slice does not survive a serde_json round trip (NaN or infinity in an f64 field?): {e}"
                        )),
                    )
                })?;
                got.insert(id, v);
                n += 1;
            }
            if n != grant.len() {
                return Err(Error::invalid(format!(
                    "{name}: rank 0 granted {} tiles with {n} slices",
                    grant.len()
                )));
            }
            Ok(())
        };
        let n_out = step.outputs();
        let apply_name = format!("{name} (apply)");
        let apply = |id: TileId| -> Result<Vec<AnyGrid>> {
            let views = read_views::<S::In>(inputs, layout, id, halo)?;
            let slice = slice_of(id)?;
            let mut out = blank_outputs::<S::Out>(n_out, layout, id);
            step.apply(&views, &slice, &mut out)?;
            convert_outputs(&name, &out, layout, id, &meta)
        };
        let (out, inn): (Option<SlicesOut<'_>>, Option<SlicesIn<'_>>) = match (shipped, me) {
            (false, _) => (None, None),
            (true, 0) => (Some(&slices_out), None),
            (true, _) => (None, Some(&slices_in)),
        };
        let (moved, work) = self.distribute(
            comm,
            &apply_name,
            layout,
            &ids,
            &meta,
            bytes,
            sinks,
            &apply,
            out,
            inn,
        );
        Self::report(
            comm,
            Phase {
                step: &name,
                phase: if shipped {
                    "global: apply (queue; slices with the grants), tiles (or receipts) to rank 0"
                } else {
                    "global: apply (queue), tiles (or receipts) to rank 0"
                },
                tiles: ids.len(),
                perimeter: perimeter_cells(layout),
                up: moved,
                down: work.payload_bytes,
                raw: moved,
                t0: t1,
                work,
            },
        );
    }
}

impl Engine for MpiEngine {
    fn run_local<S: LocalStep>(
        &self,
        step: &S,
        inputs: &[&dyn RasterSource],
        layout: TileLayout,
        sinks: Vec<Box<dyn TileSink>>,
    ) -> Result<()> {
        let name = step.name();
        self.check_thread(&name)?;
        check_inputs(&name, inputs, &layout)?;
        check_sinks(&name, &sinks, step.outputs(), &layout)?;
        let comm = world();
        let t0 = Instant::now();
        let halo = step.halo();
        let meta: Vec<(DType, Option<f64>)> =
            sinks.iter().map(|s| (s.dtype(), s.nodata())).collect();
        let sizes: Vec<usize> = meta.iter().map(|m| m.0.size()).collect();
        let bytes = super::local_tile_bytes(
            &layout,
            halo,
            inputs,
            std::mem::size_of::<S::In>(),
            std::mem::size_of::<S::Out>(),
            &sizes,
        ) + step.scratch_bytes(layout.tile);
        let ids = Self::shared_todo(&comm, &layout, &sinks);
        self.note_resume(&comm, &name, &ids, &layout);
        let n_out = step.outputs();
        let compute = |id: TileId| -> Result<Vec<AnyGrid>> {
            let views = read_views::<S::In>(inputs, &layout, id, halo)?;
            let mut out = blank_outputs::<S::Out>(n_out, &layout, id);
            step.run(&views, &mut out)?;
            convert_outputs(&name, &out, &layout, id, &meta)
        };
        let (moved, work) = self.distribute(
            &comm, &name, &layout, &ids, &meta, bytes, sinks, &compute, None, None,
        );
        Self::report(
            &comm,
            Phase {
                step: &name,
                phase: "local (queue): tiles (or receipts) to rank 0",
                tiles: ids.len(),
                perimeter: perimeter_cells(&layout),
                up: moved,
                down: 0,
                raw: moved,
                t0,
                work,
            },
        );
        Ok(())
    }

    fn run_global<S: GlobalStep>(
        &self,
        step: &S,
        inputs: &[&dyn RasterSource],
        layout: TileLayout,
        sinks: Vec<Box<dyn TileSink>>,
    ) -> Result<S::Solution> {
        let name = step.name();
        self.check_thread(&name)?;
        check_inputs(&name, inputs, &layout)?;
        if !sinks.is_empty() {
            check_sinks(&name, &sinks, step.outputs(), &layout)?;
        }
        let comm = world();
        let me = comm.rank() as usize;
        let count = layout.count();

        // Map, then every rank's summaries to every rank.
        let t0 = Instant::now();
        let (queue, records, work) = self.map_mine(&comm, step, inputs, &layout);
        let raw = records.len() as u64;
        let packed = pack(&records).unwrap_or_else(|e| fail(e));
        drop(records);
        let up = packed.len() as u64;
        let lists = Self::all_to_all(&comm, packed);
        let down: u64 = lists
            .iter()
            .enumerate()
            .filter(|(r, _)| *r != me)
            .map(|(_, l)| l.len() as u64)
            .sum();
        let summaries = decode_summaries::<S>(&name, &lists, queue.as_ref(), count);
        drop(lists);
        Self::report(
            &comm,
            Phase {
                step: &name,
                phase: "global: map (queue) + summaries to every rank",
                tiles: count,
                perimeter: perimeter_cells(&layout),
                up,
                down,
                raw,
                t0,
                work,
            },
        );
        // Reduce: the same on every rank (same summaries, deterministic step).
        let t1 = Instant::now();
        let solution = step.reduce(&layout, summaries)?;
        if sinks.is_empty() {
            return Ok(solution);
        }
        self.apply_phase(
            &comm,
            step,
            inputs,
            &layout,
            sinks,
            Some(&solution),
            false,
            t1,
        );
        Ok(solution)
    }

    /// Barnes's scheme (2016, 2017): the summaries go to rank 0 only, rank 0
    /// reduces and sends each rank only the slices of the tiles it applies
    /// (with the work-queue grants of those tiles); no other rank ever holds
    /// the solution or all summaries.
    fn run_global_apply<S: GlobalStep>(
        &self,
        step: &S,
        inputs: &[&dyn RasterSource],
        layout: TileLayout,
        sinks: Vec<Box<dyn TileSink>>,
    ) -> Result<()> {
        let name = step.name();
        self.check_thread(&name)?;
        check_inputs(&name, inputs, &layout)?;
        if !sinks.is_empty() {
            check_sinks(&name, &sinks, step.outputs(), &layout)?;
        }
        let comm = world();
        let me = comm.rank() as usize;
        let ranks = comm.size() as usize;
        let count = layout.count();
        let perimeter = perimeter_cells(&layout);

        // Map, then the summaries to rank 0 (rank 0's own are packed too,
        // so the figure counts every tile's summary whatever the rank count).
        let t0 = Instant::now();
        let (queue, records, work) = self.map_mine(&comm, step, inputs, &layout);
        let raw = records.len() as u64;
        let packed = pack(&records).unwrap_or_else(|e| fail(e));
        drop(records);
        let up = packed.len() as u64;
        let summaries = if me == 0 {
            let mut lists = Vec::with_capacity(ranks);
            lists.push(packed);
            for r in 1..ranks {
                last_words::set(&format!(
                    "error: MPI rank 0 ended (SIGTERM) while receiving the summaries of rank {r} ({name}, map phase; ranks {r}..{} had not delivered theirs)\nerror: a rank died or the job was cancelled (mpirun names the rank); rerun the same command to resume from the finished tiles of tile-store outputs\n",
                    ranks - 1
                ));
                lists.push(recv_bytes(&comm, r).unwrap_or_else(|e| fail(e)));
            }
            last_words::clear();
            Some(decode_summaries::<S>(&name, &lists, queue.as_ref(), count))
        } else {
            send_bytes(&comm, 0, &packed);
            drop(packed);
            None
        };
        Self::report(
            &comm,
            Phase {
                step: &name,
                phase: "global: map (queue) + summaries to rank 0",
                tiles: count,
                perimeter,
                up,
                down: 0,
                raw,
                t0,
                work,
            },
        );
        let t1 = Instant::now();
        let solution = summaries.map(|s| step.reduce(&layout, s).unwrap_or_else(|e| fail(e)));
        if sinks.is_empty() {
            // Nothing to apply: the reduce ran for its errors only.
            comm.barrier();
            return Ok(());
        }
        self.apply_phase(
            &comm,
            step,
            inputs,
            &layout,
            sinks,
            solution.as_ref(),
            ranks > 1,
            t1,
        );
        Ok(())
    }
}

/// Decode the records of `list` (tile id + serde_json) into `slots`,
/// ending the job when `refused(id)` gives a reason, a tile comes twice or a
/// record does not decode. `what` names the record ("summary", "slice") in
/// the error, attached to tile `id` of step `step`.
fn decode_into<T: serde::de::DeserializeOwned>(
    slots: &mut [Option<T>],
    list: &[u8],
    step: &str,
    what: &str,
    refused: impl Fn(TileId) -> Option<String>,
) {
    for (id, b) in decode_records(list, slots.len()).unwrap_or_else(|e| fail(e)) {
        let why = refused(id).or_else(|| {
            slots[id]
                .is_some()
                .then(|| format!("{step}: the {what} of tile {id} came twice"))
        });
        if let Some(why) = why {
            fail(Error::invalid(why));
        }
        let v: T = serde_json::from_slice(b).unwrap_or_else(|e| {
            fail(Error::tile(
                step,
                id,
                Error::invalid(format!(
                    "its {what} does not survive a serde_json round trip (NaN or infinity in an f64 field?): {e}"
                )),
            ))
        });
        slots[id] = Some(v);
    }
}

/// Every tile's summary from the packed record lists by rank (`lists[r]`
/// from rank `r`), checking each tile comes exactly once and (on rank 0,
/// which holds the `queue`) from the rank that was granted it.
/// Errors end the job.
fn decode_summaries<S: GlobalStep>(
    name: &str,
    lists: &[Vec<u8>],
    queue: Option<&Queue>,
    count: usize,
) -> Vec<S::Summary> {
    let map_name = format!("{name} (map)");
    let mut summaries: Vec<Option<S::Summary>> = (0..count).map(|_| None).collect();
    for (r, packed) in lists.iter().enumerate() {
        let list = unpack(packed).unwrap_or_else(|e| {
            fail(Error::invalid(format!(
                "{name}: the summaries of rank {r}: {e}"
            )))
        });
        decode_into(&mut summaries, &list, &map_name, "summary", |id| {
            queue.filter(|q| q.owner(id) != Some(r)).map(|_| {
                format!("{name}: rank {r} sent a summary of tile {id}, which it was not granted")
            })
        });
    }
    summaries
        .into_iter()
        .enumerate()
        .map(|(id, s)| {
            s.unwrap_or_else(|| fail(Error::invalid(format!("{name}: tile {id} has no summary"))))
        })
        .collect()
}
