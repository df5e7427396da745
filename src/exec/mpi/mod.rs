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

mod distribute;
mod global;
mod last_words;
mod world;

pub use world::{abort, active, barrier, finalize, init, rank_size};
pub(super) use world::{fail, TAG_TILE};

use super::mpi_codec::{perimeter_cells, Schedule};
use super::mpi_queue::Work;
use super::tile_io::{check_inputs, check_sinks, local_tile, out_meta, todo};
use super::{Engine, GlobalStep, LocalEngine, LocalStep, Run, TileSink};
use crate::error::{Error, Result};
use crate::raster::{TileId, TileLayout};
use global::decode_summaries;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use std::time::Instant;
use world::{all_to_all, recv_bytes, send_bytes, world, STATE};

/// The work-queue schedule chosen on rank 0 (`OROGEN_MPI_SCHEDULE`:
/// `queue`, the default, or `round-robin` to compare against).
fn schedule() -> Schedule {
    let v = std::env::var("OROGEN_MPI_SCHEDULE").unwrap_or_default();
    Schedule::parse(&v).unwrap_or_else(|e| fail(e))
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

impl MpiEngine {
    /// An MPI engine whose ranks compute as `local` does. Call [`init`] first.
    pub fn new(local: LocalEngine) -> Self {
        MpiEngine { local }
    }

    /// What every engine call checks first (the calling thread, the
    /// inputs, and the sinks against the step's `n_out` outputs: always for
    /// local steps, when there are any for global ones); returns the
    /// communicator of all ranks with the run.
    fn start<'a>(
        &self,
        name: &str,
        run: Run<'a>,
        n_out: usize,
        sinks_required: bool,
    ) -> Result<(SimpleCommunicator, Run<'a>)> {
        self.check_thread(name)?;
        check_inputs(name, run.inputs, &run.layout)?;
        if sinks_required || !run.sinks.is_empty() {
            check_sinks(name, &run.sinks, n_out, &run.layout)?;
        }
        Ok((world(), run))
    }

    /// [`MpiEngine::start`] for a global step (sinks optional), with the
    /// step's name.
    fn start_global<'a, S: GlobalStep>(
        &self,
        step: &S,
        run: Run<'a>,
    ) -> Result<(SimpleCommunicator, String, Run<'a>)> {
        let name = step.name();
        let (comm, run) = self.start(&name, run, step.outputs().len(), false)?;
        Ok((comm, name, run))
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
}

impl Engine for MpiEngine {
    fn run_local<S: LocalStep>(&self, step: &S, run: Run<'_>) -> Result<()> {
        let name = step.name();
        let (
            comm,
            Run {
                inputs,
                layout,
                sinks,
            },
        ) = self.start(&name, run, step.outputs().len(), true)?;
        let t0 = Instant::now();
        let (meta, bytes) = out_meta::<S::In, S::Out>(&layout, step.halo(), inputs, &sinks);
        let bytes = bytes + step.scratch_bytes(layout.tile);
        let ids = Self::shared_todo(&comm, &layout, &sinks);
        self.note_resume(&comm, &name, &ids, &layout);
        let compute = |id: TileId| local_tile(step, &name, inputs, &layout, id, &meta);
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

    fn run_global<S: GlobalStep>(&self, step: &S, run: Run<'_>) -> Result<S::Solution> {
        let (
            comm,
            name,
            Run {
                inputs,
                layout,
                sinks,
            },
        ) = self.start_global(step, run)?;
        let me = comm.rank() as usize;
        let count = layout.count();

        // Map, then every rank's summaries to every rank.
        let t0 = Instant::now();
        let (queue, packed, raw, work) = self.map_mine(&comm, step, inputs, &layout);
        let up = packed.len() as u64;
        let lists = all_to_all(&comm, packed);
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
    fn run_global_apply<S: GlobalStep>(&self, step: &S, run: Run<'_>) -> Result<()> {
        let (
            comm,
            name,
            Run {
                inputs,
                layout,
                sinks,
            },
        ) = self.start_global(step, run)?;
        let me = comm.rank() as usize;
        let ranks = comm.size() as usize;
        let count = layout.count();
        let perimeter = perimeter_cells(&layout);

        // Map, then the summaries to rank 0 (rank 0's own are packed too,
        // so the figure counts every tile's summary whatever the rank count).
        let t0 = Instant::now();
        let (queue, packed, raw, work) = self.map_mine(&comm, step, inputs, &layout);
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
