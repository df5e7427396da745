//! The in-process engine: tiles on a rayon pool, results written in tile
//! order by the calling thread, under a memory budget.
//!
//! Pipeline: a dispatcher thread walks the tiles to do in row-major order
//! and spawns one rayon task per tile (read views -> compute -> convert to
//! the sinks' native types); tasks send results on a bounded crossbeam
//! channel to the calling thread, which keeps them in a reorder buffer and
//! writes them to the sinks in increasing tile id order.
//!
//! Memory model: a tile is "in flight" from its dispatch until its result is
//! written (reading, computing, or waiting in the reorder buffer). The
//! dispatcher needs a permit per tile and the writer returns it after the
//! write, so at most `budget / bytes_per_tile` tiles (at least 1) are in
//! flight, where `bytes_per_tile` counts, per input, the view with its halo
//! as read natively plus its typed copies, and per output the typed core
//! plus its native copy (see [`local_tile_bytes`]); independently of the
//! budget, at most `4 x workers + 4` tiles are in flight. Since tiles are
//! dispatched in order, the next tile to write is always in flight, so the
//! bounded pipeline cannot deadlock.

use super::tile_io::{
    apply_tile, check_inputs, check_sinks, finish_all, local_tile, local_tile_bytes, out_meta,
    read_views, roundtrip_summary, tiles_in_flight, todo, write_outputs,
};
use super::{Engine, EngineConfig, GlobalStep, LocalStep, Run};
use crate::error::{Error, Result};
use crate::raster::TileId;
use crossbeam_channel::bounded;
use std::collections::BTreeMap;
use std::sync::atomic::{AtomicBool, Ordering};

/// The in-process engine (rayon pool of `config.threads` workers).
#[derive(Debug, Clone)]
pub struct LocalEngine {
    config: EngineConfig,
}

impl LocalEngine {
    /// New engine; the worker pool is started for each run.
    pub fn new(config: EngineConfig) -> Self {
        LocalEngine { config }
    }

    /// The configuration.
    pub fn config(&self) -> &EngineConfig {
        &self.config
    }

    fn pool(&self) -> Result<rayon::ThreadPool> {
        rayon::ThreadPoolBuilder::new()
            .num_threads(self.config.threads)
            .thread_name(|i| format!("orogen-worker-{i}"))
            .build()
            .map_err(|e| {
                Error::invalid(format!(
                    "cannot start {} worker threads: {e}",
                    self.config.threads
                ))
            })
    }

    /// Tiles allowed in flight for tiles of `bytes_per_tile` (at least 1).
    pub fn tiles_in_flight(&self, bytes_per_tile: u64) -> usize {
        tiles_in_flight(self.config.memory_budget, bytes_per_tile)
    }

    /// Run `compute` for every tile of `ids` (in row-major order) on the
    /// pool and hand each result to `consume` on the calling thread in the
    /// order of `ids`. At most `in_flight` tiles are between dispatch and
    /// `consume`. The first error stops dispatching and is returned with the
    /// tile id and `name`.
    pub fn pipeline<R: Send>(
        &self,
        name: &str,
        ids: &[TileId],
        bytes_per_tile: u64,
        compute: &(dyn Fn(TileId) -> Result<R> + Sync),
        mut consume: impl FnMut(TileId, R) -> Result<()>,
    ) -> Result<()> {
        if ids.is_empty() {
            return Ok(());
        }
        let pool = self.pool()?;
        // Beyond a few tiles per worker a larger window gains nothing, and
        // the channels preallocate one slot per tile in flight.
        let window = 4 * pool.current_num_threads() + 4;
        let in_flight = self
            .tiles_in_flight(bytes_per_tile)
            .min(ids.len())
            .min(window);
        let progress = super::Progress::of_run(name, ids.len(), &self.config);
        let (permit_tx, permit_rx) = bounded::<()>(in_flight);
        for _ in 0..in_flight {
            // Cannot fail: the channel has room for `in_flight` permits.
            let _ = permit_tx.send(());
        }
        let (res_tx, res_rx) = bounded::<(usize, Result<R>)>(in_flight);
        let stop = AtomicBool::new(false);
        let mut failure: Option<Error> = None;
        std::thread::scope(|ts| {
            let stop = &stop;
            let dispatcher = {
                let permit_rx = permit_rx.clone();
                let pool = &pool;
                ts.spawn(move || {
                    pool.in_place_scope(|s| {
                        for (k, &id) in ids.iter().enumerate() {
                            if permit_rx.recv().is_err() || stop.load(Ordering::Acquire) {
                                break;
                            }
                            let tx = res_tx.clone();
                            s.spawn(move |_| {
                                let r = unless_stopped(stop, || compute(id));
                                let _ = tx.send((k, r));
                            });
                        }
                        drop(res_tx);
                    });
                })
            };
            drop(permit_rx);
            let mut pending: BTreeMap<usize, R> = BTreeMap::new();
            let mut next = 0;
            'outer: while next < ids.len() {
                let Ok((k, r)) = res_rx.recv() else {
                    break;
                };
                match r {
                    Ok(v) => {
                        pending.insert(k, v);
                    }
                    Err(e) => {
                        failure = Some(Error::tile(name, ids[k], e));
                        break;
                    }
                }
                while let Some(v) = pending.remove(&next) {
                    let id = ids[next];
                    if let Err(e) = consume(id, v) {
                        failure = Some(Error::tile(name, id, e));
                        break 'outer;
                    }
                    next += 1;
                    if !progress.inc(1) {
                        failure = Some(Error::invalid(format!("{name}: cancelled")));
                        break 'outer;
                    }
                    let _ = permit_tx.send(());
                }
            }
            stop.store(true, Ordering::Release);
            drop(permit_tx);
            drop(res_rx);
            drop(pending);
            if dispatcher.join().is_err() && failure.is_none() {
                failure = Some(Error::invalid(format!("{name}: a worker panicked")));
            }
            if failure.is_none() && next < ids.len() {
                failure = Some(Error::invalid(format!(
                    "{name}: the pipeline stopped early"
                )));
            }
        });
        match failure {
            Some(e) => {
                progress.abandon();
                Err(e)
            }
            None => {
                progress.finish_and_clear();
                Ok(())
            }
        }
    }
}

/// Runs every step in this process; the MPI engine is another value
/// ([`super::Engines`], chosen by [`EngineConfig::engine`]).
impl Engine for LocalEngine {
    fn run_local<S: LocalStep>(&self, step: &S, run: Run<'_>) -> Result<()> {
        let Run {
            inputs,
            layout,
            mut sinks,
        } = run;
        let name = step.name();
        check_inputs(&name, inputs, &layout)?;
        check_sinks(&name, &sinks, step.outputs().len(), &layout)?;
        let halo = step.halo();
        let (meta, bytes) = out_meta::<S::In, S::Out>(&layout, halo, inputs, &sinks);
        let bytes = bytes + step.scratch_bytes(layout.tile);
        let ids = todo(&layout, &sinks);
        let compute = |id: TileId| local_tile(step, &name, inputs, &layout, id, &meta);
        self.pipeline(&name, &ids, bytes, &compute, |id, grids| {
            write_outputs(&mut sinks, &layout, id, grids)
        })?;
        finish_all(sinks)
    }

    fn run_global<S: GlobalStep>(&self, step: &S, run: Run<'_>) -> Result<S::Solution> {
        let Run {
            inputs,
            layout,
            mut sinks,
        } = run;
        let name = step.name();
        check_inputs(&name, inputs, &layout)?;
        if !sinks.is_empty() {
            check_sinks(&name, &sinks, step.outputs().len(), &layout)?;
        }
        let halo = step.halo();
        let in_size = std::mem::size_of::<S::In>();
        // Map: every tile, summaries kept by tile id.
        let all: Vec<TileId> = (0..layout.count()).collect();
        let map_bytes = local_tile_bytes(&layout, halo, inputs, in_size, 0, &[]);
        let map_name = format!("{name} (map)");
        let mut summaries: Vec<Option<S::Summary>> = (0..layout.count()).map(|_| None).collect();
        let map = |id: TileId| -> Result<S::Summary> {
            let views = read_views::<S::In>(inputs, &layout, id, halo)?;
            let s = step.map(&views)?;
            if cfg!(debug_assertions) {
                roundtrip_summary(&name, &s)
            } else {
                Ok(s)
            }
        };
        self.pipeline(&map_name, &all, map_bytes, &map, |id, s| {
            summaries[id] = Some(s);
            Ok(())
        })?;
        let summaries: Vec<S::Summary> = summaries
            .into_iter()
            .enumerate()
            .map(|(id, s)| {
                s.ok_or_else(|| Error::invalid(format!("{name}: tile {id} has no summary")))
            })
            .collect::<Result<_>>()?;
        let solution = step.reduce(&layout, summaries)?;
        if sinks.is_empty() {
            return Ok(solution);
        }
        // Apply: like a local step, with each tile's slice of the solution.
        let (meta, bytes) = out_meta::<S::In, S::Out>(&layout, halo, inputs, &sinks);
        let ids = todo(&layout, &sinks);
        let apply_name = format!("{name} (apply)");
        let solution_ref = &solution;
        let apply = |id: TileId| {
            let slice = step.slice(solution_ref, id);
            apply_tile(step, &name, inputs, &layout, id, &slice, &meta)
        };
        self.pipeline(&apply_name, &ids, bytes, &apply, |id, grids| {
            write_outputs(&mut sinks, &layout, id, grids)
        })?;
        finish_all(sinks)?;
        Ok(solution)
    }
}

/// `compute()`, unless the run was stopped (another tile failed): then the
/// error `cancelled`, which is never reported (the first failure is). A
/// panic in `compute` becomes the tile's error.
#[inline]
pub(super) fn unless_stopped<R>(
    stop: &AtomicBool,
    compute: impl FnOnce() -> Result<R>,
) -> Result<R> {
    if stop.load(Ordering::Acquire) {
        return Err(Error::invalid("cancelled"));
    }
    // A panic in a tile's work must reach the consumer as this tile's
    // result: unwinding past the worker would drop its result without a
    // send, and the consumer, which takes results in tile order and returns
    // the permits that let new tiles start, would wait for it for ever.
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(compute)).unwrap_or_else(|p| {
        let msg = p
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| p.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "unknown cause".into());
        Err(Error::invalid(format!(
            "internal error (a bug: please report it): the tile's work panicked: {msg}"
        )))
    })
}
