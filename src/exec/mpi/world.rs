//! The MPI process: start and end MPI, this rank and the rank count, the
//! abort that ends every rank, and byte strings of any length sent point to
//! point, broadcast from rank 0 or from every rank to every rank (MPI
//! counts are 32-bit, so long strings travel in pieces).

use super::last_words;
use crate::error::{Error, Result};
use mpi::environment::Universe;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;

/// MPI state of the process: the universe (dropping it finalises MPI) and
/// the thread that initialised it (the only one that may call MPI).
pub(super) struct State {
    pub(super) universe: Universe,
    pub(super) thread: std::thread::ThreadId,
}

pub(super) static STATE: Mutex<Option<State>> = Mutex::new(None);
static ACTIVE: AtomicBool = AtomicBool::new(false);

/// Message tag of tile messages (rank -> rank 0).
pub(in crate::exec) const TAG_TILE: i32 = 11;
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

pub(super) fn world() -> SimpleCommunicator {
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
pub(in crate::exec) fn fail(e: Error) -> ! {
    abort(&e.to_string())
}

/// Send `bytes` to rank `to`: its length (`u64`), then pieces of at most
/// [`CHUNK`] bytes (MPI counts are 32-bit).
pub(super) fn send_bytes(comm: &SimpleCommunicator, to: usize, bytes: &[u8]) {
    let p = comm.process_at_rank(to as i32);
    p.send_with_tag(&(bytes.len() as u64), TAG_BYTES);
    for piece in bytes.chunks(CHUNK) {
        p.send_with_tag(piece, TAG_BYTES);
    }
}

/// Receive what [`send_bytes`] sent from rank `from`. Memory grows with the
/// pieces actually received, never by the announced length alone.
pub(super) fn recv_bytes(comm: &SimpleCommunicator, from: usize) -> Result<Vec<u8>> {
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
pub(super) fn broadcast_bytes(comm: &SimpleCommunicator, mut bytes: Vec<u8>) -> Vec<u8> {
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

/// Send every rank's `mine` bytes to every rank (one broadcast per
/// rank, in pieces of at most [`CHUNK`] bytes). Returns the lists by rank.
pub(super) fn all_to_all(comm: &SimpleCommunicator, mine: Vec<u8>) -> Vec<Vec<u8>> {
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
