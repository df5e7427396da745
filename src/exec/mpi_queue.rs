//! The MPI engine's work queue: ranks draw the tiles they compute from rank
//! 0 while they run, so a rank that drew cheap tiles (nodata, flat sea)
//! takes more of them and all ranks finish together.
//!
//! Protocol (tags [`TAG_REQ`], [`TAG_GRANT`], and the engine's tile tag):
//! - a rank other than 0 sends rank 0 a request (`want: u64`, the tiles it
//!   keeps in flight) when no granted tile waits in its own queue any more
//!   (its pool still has up to one tile per worker plus one), and has at
//!   most one request out; rank 0 takes its own share the same way;
//! - rank 0 answers with a grant ([`super::mpi_codec::encode_grant`]):
//!   positions in the tile list every rank holds (runs of consecutive
//!   positions) plus an optional payload (the slices of those tiles, when
//!   rank 0 alone holds the solution); a grant of nothing means "no more";
//! - results that travel (tiles, receipts) go to rank 0 as they finish, in
//!   any order; rank 0 puts them in order itself.
//!
//! Rank 0 both serves and works. MPI is started with thread level
//! "funneled" (only the main thread calls MPI), and rank 0's main thread
//! polls: between its own tiles it waits at most [`POLL`] for a result of
//! its worker pool, then checks for requests and tile messages with
//! `MPI_Iprobe`. A service thread would need `MPI_THREAD_MULTIPLE`, and a
//! blocking receive in Open MPI (and MPICH) spins its core while it waits,
//! which would take a core from rank 0's own workers; a poll costs a few
//! microseconds, so rank 0 keeps working at full rate and answers a request
//! within about a millisecond (tiles take tens of milliseconds or more).
//!
//! Deadlock freedom: ranks other than 0 use blocking sends, but only to
//! rank 0, which never blocks on a receive: it probes, and while its own
//! grant to rank `r` is in flight (a non-blocking send that may be large,
//! with slices) it keeps draining tile messages. A rank other than 0 never
//! blocks on a receive either (it probes for its grant). With a window
//! ([`super::mpi_codec::Queue`]) the first unwritten position is always
//! grantable and its rank always computes it: its earlier tiles were all
//! received, so nothing it sends waits for anything later.

use super::local::unless_stopped;
use super::mpi::fail;
use super::mpi_codec::{decode_grant, encode_grant, Queue};
use crate::error::{Error, Result};
use crate::raster::TileId;
use crossbeam_channel::{unbounded, Receiver, Sender};
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// Tag of work requests (rank -> rank 0).
pub(super) const TAG_REQ: i32 = 13;
/// Tag of grants (rank 0 -> rank).
pub(super) const TAG_GRANT: i32 = 14;
/// Longest wait for a local result before rank 0 (or a rank waiting for a
/// grant) looks at MPI again.
const POLL: Duration = Duration::from_millis(1);

/// What one rank did in one queue run (for `OROGEN_MPI_STATS`).
#[derive(Debug, Default, Clone, Copy)]
pub(super) struct Work {
    /// Tiles this rank computed.
    pub tiles: u64,
    /// Summed compute time of those tiles (all worker threads), seconds.
    pub busy: f64,
    /// When this rank's last tile finished, seconds after the run started.
    pub last: f64,
    /// Queue messages (requests and grants without payload) this rank sent
    /// or (rank 0) answered, bytes.
    pub queue_bytes: u64,
    /// Grant payloads (slices) sent by rank 0, bytes.
    pub payload_bytes: u64,
}

/// Rank 0's side of a queue run.
pub(super) trait Serve<R> {
    /// The payload of a grant of positions `ks` to another rank.
    fn payload(&mut self, ks: &[usize]) -> Result<Vec<u8>>;
    /// Positions `ks` were granted to rank `r` (0 included).
    fn granted(&mut self, r: usize, ks: &[usize], q: &Queue);
    /// A result rank 0 computed itself (position `k`).
    fn own(&mut self, k: usize, r: R, q: &Queue) -> Result<()>;
    /// A tile message from rank `from`.
    fn remote(&mut self, from: usize, msg: Vec<u8>, q: &Queue) -> Result<()>;
    /// Consume (write) at most one result that is due; true if it did. Rank
    /// 0 serves the queue between two of these, so a burst of writes never
    /// leaves a rank waiting for its next grant longer than one write.
    fn write_one(&mut self, q: &Queue) -> Result<bool>;
    /// First position not yet consumed (the window's frontier).
    fn frontier(&self) -> usize;
    /// Every result consumed.
    fn complete(&self) -> bool;
}

/// The side of a rank other than 0.
pub(super) trait Draw<R> {
    /// The payload of a grant of positions `ks`.
    fn payload(&mut self, ks: &[usize], bytes: &[u8]) -> Result<()>;
    /// A result computed here (position `k`): the message to send to rank 0
    /// (tile tag), if any.
    fn result(&mut self, k: usize, r: R) -> Result<Option<Vec<u8>>>;
}

/// A worker pool fed one tile at a time from the calling thread; results
/// come back in completion order.
struct Lanes<R> {
    tx: Option<Sender<(usize, TileId)>>,
    rx: Receiver<(usize, Result<R>)>,
    outstanding: usize,
}

impl<R> Lanes<R> {
    fn push(&mut self, k: usize, id: TileId) {
        if let Some(tx) = &self.tx {
            if tx.send((k, id)).is_ok() {
                self.outstanding += 1;
            }
        }
    }

    /// Next result, waiting at most `wait`.
    fn poll(&mut self, wait: Duration) -> Option<(usize, Result<R>)> {
        if self.outstanding == 0 {
            std::thread::sleep(wait);
            return None;
        }
        let got = self.rx.recv_timeout(wait).ok();
        if got.is_some() {
            self.outstanding -= 1;
        }
        got
    }
}

/// Run `drive` with a pool of `threads` workers computing `compute(id)`
/// for what `drive` pushes. Busy time and tile count are added to `work`.
fn with_lanes<R: Send, T>(
    threads: usize,
    compute: &(dyn Fn(TileId) -> Result<R> + Sync),
    work: &mut Work,
    drive: impl FnOnce(&mut Lanes<R>) -> T,
) -> Result<T> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .thread_name(|i| format!("orogen-worker-{i}"))
        .build()
        .map_err(|e| Error::invalid(format!("cannot start {threads} worker threads: {e}")))?;
    let (id_tx, id_rx) = unbounded::<(usize, TileId)>();
    let (res_tx, res_rx) = unbounded::<(usize, Result<R>)>();
    let stop = AtomicBool::new(false);
    let busy_ns = AtomicU64::new(0);
    let tiles = AtomicU64::new(0);
    let out = std::thread::scope(|ts| {
        let (stop, busy_ns, tiles, pool) = (&stop, &busy_ns, &tiles, &pool);
        let dispatcher = ts.spawn(move || {
            pool.in_place_scope(|s| {
                while let Ok((k, id)) = id_rx.recv() {
                    if stop.load(Ordering::Acquire) {
                        break;
                    }
                    let tx = res_tx.clone();
                    s.spawn(move |_| {
                        let r = unless_stopped(stop, || {
                            let t = Instant::now();
                            let r = compute(id);
                            busy_ns.fetch_add(t.elapsed().as_nanos() as u64, Ordering::Relaxed);
                            tiles.fetch_add(1, Ordering::Relaxed);
                            r
                        });
                        let _ = tx.send((k, r));
                    });
                }
                drop(res_tx);
            });
        });
        let mut lanes = Lanes {
            tx: Some(id_tx),
            rx: res_rx,
            outstanding: 0,
        };
        let out = drive(&mut lanes);
        stop.store(true, Ordering::Release);
        lanes.tx = None;
        let ok = dispatcher.join().is_ok();
        (out, ok)
    });
    work.busy += busy_ns.load(Ordering::Relaxed) as f64 * 1e-9;
    work.tiles += tiles.load(Ordering::Relaxed);
    match out {
        (out, true) => Ok(out),
        (_, false) => Err(Error::invalid("a worker thread panicked")),
    }
}

/// Tiles a rank hands its pool at once: one per worker plus one waiting,
/// which hides the latency of the next grant (about a millisecond), never
/// more than the memory budget allows (`cap`). Results are taken in
/// completion order, so a deeper pipeline would only hoard tiles another
/// rank could be computing.
pub(super) fn depth(cap: usize, threads: usize) -> usize {
    cap.min(threads.max(1) + 1).max(1)
}

/// A tile's error with the step's name and the tile id.
fn tile_err(name: &str, id: TileId, e: Error) -> Error {
    Error::tile(name, id, e)
}

/// Rank 0: serve the queue `q` over `ids` to the other ranks and compute
/// its own grants with `threads` workers, at most `cap` in flight. Errors
/// end the job (MPI_Abort), since other ranks wait for rank 0.
#[allow(clippy::too_many_arguments)]
pub(super) fn serve<R: Send, H: Serve<R>>(
    comm: &SimpleCommunicator,
    name: &str,
    threads: usize,
    cap: usize,
    ids: &[TileId],
    q: &mut Queue,
    compute: &(dyn Fn(TileId) -> Result<R> + Sync),
    hooks: &mut H,
) -> Work {
    let ranks = comm.size().max(1) as usize;
    let cap = depth(cap, threads);
    let t0 = Instant::now();
    let mut work = Work::default();
    let mut queue_bytes = 0u64;
    let mut payload_bytes = 0u64;
    let mut last = 0f64;
    let r = with_lanes(threads, compute, &mut work, |lanes| -> Result<()> {
        let mut waiting: VecDeque<(usize, usize)> = VecDeque::new();
        let mut ended = vec![false; ranks];
        ended[0] = true;
        let mut local: VecDeque<usize> = VecDeque::new();
        loop {
            // Requests.
            while let Some(st) = comm.any_process().immediate_probe_with_tag(TAG_REQ) {
                let from = st.source_rank();
                let (want, _) = comm.process_at_rank(from).receive_with_tag::<u64>(TAG_REQ);
                let from = usize::try_from(from).unwrap_or(0);
                if from == 0 || from >= ranks || ended[from] {
                    return Err(Error::invalid(format!(
                        "{name}: an unexpected work request from rank {from}"
                    )));
                }
                queue_bytes += 8;
                waiting.push_back((from, usize::try_from(want).unwrap_or(usize::MAX).max(1)));
            }
            // Tiles that arrived.
            drain_tiles(comm, q, hooks)?;
            // Grants: to the waiting ranks, then to this rank.
            let mut still = VecDeque::new();
            while let Some((r, want)) = waiting.pop_front() {
                let ks = q.grant(r, want, hooks.frontier());
                if ks.is_empty() && !q.exhausted(r) {
                    still.push_back((r, want));
                    continue;
                }
                let payload = if ks.is_empty() {
                    Vec::new()
                } else {
                    hooks.payload(&ks)?
                };
                let msg = encode_grant(&ks, &payload);
                queue_bytes += (msg.len() - payload.len()) as u64;
                payload_bytes += payload.len() as u64;
                send_serving(comm, r, &msg, q, hooks)?;
                ended[r] |= ks.is_empty();
                if !ks.is_empty() {
                    hooks.granted(r, &ks, q);
                }
            }
            waiting = still;
            if local.is_empty() && !q.exhausted(0) {
                let ks = q.grant(0, cap, hooks.frontier());
                if !ks.is_empty() {
                    hooks.granted(0, &ks, q);
                    local.extend(ks);
                }
            }
            while lanes.outstanding < cap {
                let Some(k) = local.pop_front() else { break };
                lanes.push(k, ids[k]);
            }
            // Write one due tile; wait for a result only when there was none.
            let wrote = hooks.write_one(q)?;
            let wait = if wrote { Duration::ZERO } else { POLL };
            if let Some((k, res)) = lanes.poll(wait) {
                let v = res.map_err(|e| tile_err(name, ids[k], e))?;
                last = t0.elapsed().as_secs_f64();
                hooks.own(k, v, q)?;
            }
            if ended.iter().all(|&e| e)
                && q.exhausted(0)
                && local.is_empty()
                && lanes.outstanding == 0
                && hooks.complete()
            {
                return Ok(());
            }
        }
    });
    if let Err(e) = r.and_then(|r| r) {
        fail(e);
    }
    work.last = last;
    work.queue_bytes = queue_bytes;
    work.payload_bytes = payload_bytes;
    work
}

/// Rank 0: hand every tile message already there to `hooks`.
fn drain_tiles<R, H: Serve<R>>(comm: &SimpleCommunicator, q: &Queue, hooks: &mut H) -> Result<()> {
    while let Some(st) = comm
        .any_process()
        .immediate_probe_with_tag(super::mpi::TAG_TILE)
    {
        let from = st.source_rank();
        let (msg, _) = comm
            .process_at_rank(from)
            .receive_vec_with_tag::<u8>(super::mpi::TAG_TILE);
        hooks.remote(usize::try_from(from).unwrap_or(0), msg, q)?;
    }
    Ok(())
}

/// Rank 0: send `msg` to rank `to` without blocking on it, draining tile
/// messages meanwhile (rank `to` may itself be blocked sending a tile).
/// An error ends the job here: the pending send cannot be abandoned.
fn send_serving<R, H: Serve<R>>(
    comm: &SimpleCommunicator,
    to: usize,
    msg: &[u8],
    q: &Queue,
    hooks: &mut H,
) -> Result<()> {
    if msg.len() > i32::MAX as usize {
        return Err(Error::invalid(format!(
            "a work-queue grant of {} bytes is over MPI's 2 GiB message limit; use larger tiles",
            msg.len()
        )));
    }
    mpi::request::scope(|sc| {
        let mut req = comm
            .process_at_rank(to as i32)
            .immediate_send_with_tag(sc, msg, TAG_GRANT);
        loop {
            match req.test() {
                Ok(_) => return,
                Err(pending) => {
                    req = pending;
                    if let Err(e) = drain_tiles(comm, q, hooks) {
                        fail(e);
                    }
                    std::thread::yield_now();
                }
            }
        }
    });
    Ok(())
}

/// A rank other than 0: draw positions of `ids` from rank 0 until it says
/// there are no more, compute them with `threads` workers (at most `cap`
/// in flight) and send what `hooks.result` returns to rank 0. Errors end
/// the job (MPI_Abort).
pub(super) fn draw<R: Send, H: Draw<R>>(
    comm: &SimpleCommunicator,
    name: &str,
    threads: usize,
    cap: usize,
    ids: &[TileId],
    compute: &(dyn Fn(TileId) -> Result<R> + Sync),
    hooks: &mut H,
) -> Work {
    let cap = depth(cap, threads);
    let t0 = Instant::now();
    let mut work = Work::default();
    let mut queue_bytes = 0u64;
    let mut last = 0f64;
    let root = comm.process_at_rank(0);
    let r = with_lanes(threads, compute, &mut work, |lanes| -> Result<()> {
        let mut local: VecDeque<usize> = VecDeque::new();
        let mut asked = false;
        let mut ended = false;
        loop {
            if !ended && !asked && local.is_empty() {
                root.send_with_tag(&(cap as u64), TAG_REQ);
                queue_bytes += 8;
                asked = true;
            }
            if asked && root.immediate_probe_with_tag(TAG_GRANT).is_some() {
                let (msg, _) = root.receive_vec_with_tag::<u8>(TAG_GRANT);
                let (ks, payload) = decode_grant(&msg, ids.len())?;
                queue_bytes += (msg.len() - payload.len()) as u64;
                asked = false;
                if ks.is_empty() {
                    ended = true;
                } else {
                    hooks.payload(&ks, payload)?;
                    local.extend(ks);
                }
            }
            while lanes.outstanding < cap {
                let Some(k) = local.pop_front() else { break };
                lanes.push(k, ids[k]);
            }
            if let Some((k, res)) = lanes.poll(POLL) {
                let v = res.map_err(|e| tile_err(name, ids[k], e))?;
                last = t0.elapsed().as_secs_f64();
                if let Some(msg) = hooks.result(k, v)? {
                    if msg.len() > i32::MAX as usize {
                        return Err(Error::invalid(format!(
                            "tile {} is {} bytes, over MPI's 2 GiB message limit; use smaller tiles (--tile)",
                            ids[k],
                            msg.len()
                        )));
                    }
                    root.send_with_tag(&msg[..], super::mpi::TAG_TILE);
                }
            }
            if ended && local.is_empty() && lanes.outstanding == 0 {
                return Ok(());
            }
        }
    });
    if let Err(e) = r.and_then(|r| r) {
        fail(e);
    }
    work.last = last;
    work.queue_bytes = queue_bytes;
    work
}
