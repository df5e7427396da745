//! The MPI engine (`--features mpi`, `--engine mpi`): the same steps as the
//! in-process engine, spread over the ranks of `mpirun`, writing the same
//! bytes.
//!
//! Every rank runs the same command (SPMD), so every rank reaches the same
//! engine call with the same step, inputs and layout; the engine then splits
//! the tiles between the ranks:
//! - tiles to do are listed by rank 0 (resume) and broadcast; the `k`-th goes
//!   to rank `k mod ranks` ([`super::mpi_codec::owners`]); each rank runs its
//!   tiles on its own thread pool ([`LocalEngine::pipeline`]);
//! - local steps and the apply phase of global steps: each rank computes its
//!   tiles, converts them to the sinks' native types and sends them to rank
//!   0, which writes every tile in increasing id order to its sinks, exactly
//!   as the in-process engine does (so the bytes are the same). The sinks of
//!   the other ranks are dropped unwritten. Cost: every output cell crosses
//!   the network once, to rank 0, and rank 0's disk writes everything;
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
//!
//! MPI calls are made only from the thread that started MPI (thread level
//! "funneled"): the pipeline hands results to the calling thread.
//!
//! Failure: an error on any rank once the ranks communicate prints the rank,
//! host and the error (which names the step and tile) and calls MPI_Abort,
//! which ends every rank; a rank that dies is reported by `mpirun`, which
//! ends the others. Nothing is left looking finished: GeoTIFF outputs are
//! renamed into place only by a successful `finish`.

use super::local::{
    blank_outputs, check_inputs, check_sinks, convert_outputs, finish_all, read_views, todo,
    write_outputs,
};
use super::mpi_codec::{decode_records, decode_tile, encode_tile, owners, perimeter_cells};
use super::{Engine, GlobalStep, LocalEngine, LocalStep, TileSink};
use crate::error::{Error, Result};
use crate::raster::{AnyGrid, DType, RasterSource, TileId, TileLayout};
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
const TAG_TILE: i32 = 11;
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
    *st = Some(State {
        universe,
        thread: std::thread::current().id(),
    });
    ACTIVE.store(true, Ordering::Release);
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

fn fail(e: Error) -> ! {
    abort(&e.to_string())
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
    /// `OROGEN_MPI_STATS` set, print one JSON line for the phase.
    fn report(comm: &SimpleCommunicator, p: Phase) {
        let n = comm.size() as usize;
        let mine = [p.up, p.down, p.raw];
        let mut all = vec![0u64; 3 * n];
        comm.all_gather_into(&mine[..], &mut all[..]);
        if comm.rank() != 0 || std::env::var_os("OROGEN_MPI_STATS").is_none() {
            return;
        }
        let up: u64 = all.iter().step_by(3).sum();
        let down: u64 = all.iter().skip(1).step_by(3).sum();
        let raw: u64 = all.iter().skip(2).step_by(3).sum();
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
            })
        );
    }

    /// Compute the tiles `ids` spread over the ranks and write them on rank
    /// 0 in increasing id order. `compute` gives a tile's outputs in the
    /// sinks' native types. Errors end the job (MPI_Abort).
    #[allow(clippy::too_many_arguments)]
    fn distribute(
        &self,
        comm: &SimpleCommunicator,
        name: &str,
        layout: &TileLayout,
        ids: &[TileId],
        meta: &[(DType, Option<f64>)],
        bytes: u64,
        mut sinks: Vec<Box<dyn TileSink>>,
        compute: &(dyn Fn(TileId) -> Result<Vec<AnyGrid>> + Sync),
    ) -> u64 {
        let me = comm.rank() as usize;
        let owner = owners(ids, comm.size() as usize);
        let mut owner_of = vec![0usize; layout.count()];
        for (k, &id) in ids.iter().enumerate() {
            owner_of[id] = owner[k];
        }
        let mut moved = 0u64;
        if me == 0 {
            let c0 = |id: TileId| -> Result<Option<Vec<AnyGrid>>> {
                if owner_of[id] == 0 {
                    compute(id).map(Some)
                } else {
                    Ok(None)
                }
            };
            let r = self.local.pipeline(name, ids, bytes, &c0, |id, got| {
                let grids = match got {
                    Some(g) => g,
                    None => {
                        let from = owner_of[id];
                        let (msg, _) = comm
                            .process_at_rank(from as i32)
                            .receive_vec_with_tag::<u8>(TAG_TILE);
                        moved += msg.len() as u64;
                        let core = layout.window(id);
                        let shapes: Vec<(DType, usize, usize)> =
                            meta.iter().map(|m| (m.0, core.w, core.h)).collect();
                        decode_tile(&msg, id, &shapes)?
                    }
                };
                write_outputs(&mut sinks, layout, id, grids)
            });
            if let Err(e) = r.and_then(|_| finish_all(sinks)) {
                fail(e);
            }
        } else {
            drop(sinks);
            let mine: Vec<TileId> = ids
                .iter()
                .zip(&owner)
                .filter(|(_, &o)| o == me)
                .map(|(&id, _)| id)
                .collect();
            let r = self.local.pipeline(name, &mine, bytes, compute, |id, grids| {
                let msg = encode_tile(id, &grids);
                if msg.len() > i32::MAX as usize {
                    return Err(Error::invalid(format!(
                        "tile {id} is {} bytes, over MPI's 2 GiB message limit; use smaller tiles (--tile)",
                        msg.len()
                    )));
                }
                moved += msg.len() as u64;
                comm.process_at_rank(0).send_with_tag(&msg[..], TAG_TILE);
                Ok(())
            });
            if let Err(e) = r {
                fail(e);
            }
        }
        // Nobody goes on (and reads the output) before rank 0 finished it.
        comm.barrier();
        moved
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
        let n_out = step.outputs();
        let compute = |id: TileId| -> Result<Vec<AnyGrid>> {
            let views = read_views::<S::In>(inputs, &layout, id, halo)?;
            let mut out = blank_outputs::<S::Out>(n_out, &layout, id);
            step.run(&views, &mut out)?;
            convert_outputs(&name, &out, &layout, id, &meta)
        };
        let moved = self.distribute(&comm, &name, &layout, &ids, &meta, bytes, sinks, &compute);
        Self::report(
            &comm,
            Phase {
                step: &name,
                phase: "local: tiles to rank 0",
                tiles: ids.len(),
                perimeter: perimeter_cells(&layout),
                up: moved,
                down: 0,
                raw: moved,
                t0,
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
        let halo = step.halo();
        let in_size = std::mem::size_of::<S::In>();
        let count = layout.count();
        let perimeter = perimeter_cells(&layout);

        // Map: every rank its share of all tiles; summaries as records.
        let t0 = Instant::now();
        let all: Vec<TileId> = (0..count).collect();
        let owner = owners(&all, comm.size() as usize);
        let mine: Vec<TileId> = all.iter().copied().filter(|&id| owner[id] == me).collect();
        let map_bytes = super::local_tile_bytes(&layout, halo, inputs, in_size, 0, &[]);
        let map_name = format!("{name} (map)");
        let map = |id: TileId| -> Result<Vec<u8>> {
            let views = read_views::<S::In>(inputs, &layout, id, halo)?;
            let s = step.map(&views)?;
            serde_json::to_vec(&s).map_err(|e| {
                Error::invalid(format!("{name}: a tile summary does not serialise: {e}"))
            })
        };
        let mut records = Vec::new();
        let r = self
            .local
            .pipeline(&map_name, &mine, map_bytes, &map, |id, b| {
                super::mpi_codec::push_record(&mut records, id, &b);
                Ok(())
            });
        if let Err(e) = r {
            fail(e);
        }
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
        let lists: Vec<Vec<u8>> = lists
            .iter()
            .enumerate()
            .map(|(r, l)| {
                unpack(l).unwrap_or_else(|e| {
                    fail(Error::invalid(format!(
                        "{name}: the summaries of rank {r}: {e}"
                    )))
                })
            })
            .collect();
        let mut summaries: Vec<Option<S::Summary>> = (0..count).map(|_| None).collect();
        for (r, list) in lists.iter().enumerate() {
            let recs = decode_records(list, count).unwrap_or_else(|e| fail(e));
            for (id, b) in recs {
                if owner[id] != r || summaries[id].is_some() {
                    fail(Error::invalid(format!(
                        "{name}: rank {r} sent a summary of tile {id}, which it does not own or was sent twice"
                    )));
                }
                let s: S::Summary = serde_json::from_slice(b).unwrap_or_else(|e| {
                    fail(Error::tile(
                        &map_name,
                        id,
                        Error::invalid(format!(
                            "its summary does not survive a serde_json round trip (NaN or infinity in an f64 field?): {e}"
                        )),
                    ))
                });
                summaries[id] = Some(s);
            }
        }
        drop(lists);
        let summaries: Vec<S::Summary> = summaries
            .into_iter()
            .enumerate()
            .map(|(id, s)| {
                s.unwrap_or_else(|| {
                    fail(Error::invalid(format!("{name}: tile {id} has no summary")))
                })
            })
            .collect();
        Self::report(
            &comm,
            Phase {
                step: &name,
                phase: "global: map + summaries to every rank",
                tiles: count,
                perimeter,
                up,
                down,
                raw,
                t0,
            },
        );
        // Reduce: the same on every rank (same summaries, deterministic step).
        let solution = step.reduce(&layout, summaries)?;
        if sinks.is_empty() {
            return Ok(solution);
        }

        // Apply: like a local step, with each tile's slice of the solution.
        let t1 = Instant::now();
        let meta: Vec<(DType, Option<f64>)> =
            sinks.iter().map(|s| (s.dtype(), s.nodata())).collect();
        let sizes: Vec<usize> = meta.iter().map(|m| m.0.size()).collect();
        let bytes = super::local_tile_bytes(
            &layout,
            halo,
            inputs,
            in_size,
            std::mem::size_of::<S::Out>(),
            &sizes,
        );
        let ids = Self::shared_todo(&comm, &layout, &sinks);
        let n_out = step.outputs();
        let apply_name = format!("{name} (apply)");
        let solution_ref = &solution;
        let apply = |id: TileId| -> Result<Vec<AnyGrid>> {
            let views = read_views::<S::In>(inputs, &layout, id, halo)?;
            let slice = step.slice(solution_ref, id);
            let mut out = blank_outputs::<S::Out>(n_out, &layout, id);
            step.apply(&views, &slice, &mut out)?;
            convert_outputs(&name, &out, &layout, id, &meta)
        };
        let moved = self.distribute(
            &comm,
            &apply_name,
            &layout,
            &ids,
            &meta,
            bytes,
            sinks,
            &apply,
        );
        Self::report(
            &comm,
            Phase {
                step: &name,
                phase: "global: apply, tiles to rank 0",
                tiles: ids.len(),
                perimeter,
                up: moved,
                down: 0,
                raw: moved,
                t0: t1,
            },
        );
        Ok(solution)
    }
}
