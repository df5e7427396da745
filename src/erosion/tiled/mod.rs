//! Halo-exchange driver for the local erosion models.
//!
//! The state (all of a model's fields, `f64`) is kept per tile core. One
//! *round* advances every tile by `k` substeps: the tile's core is expanded
//! by a ghost zone of `g = k·r` cells (`r` = the model's radius, clipped to
//! the raster), the patch is assembled from the previous round's states of
//! the tiles it overlaps, the model runs `k` substeps on the whole patch
//! (patch edges act as walls), and the core is kept. A cell `j` cells inside
//! the patch edge is exact after `⌊j / r⌋` substeps, so the core (`g` cells
//! inside, or on the raster's true edge) is exact after `k` substeps — the
//! same bits as the whole-grid run, which is one patch covering the raster
//! (a ghost-zone scheme, as in e.g. Ding & He, "A ghost cell expansion method
//! for reducing communications in solving PDE problems", SC 2001).
//!
//! The rounds are run by the engine's round driver, the one tiled stream
//! power uses (`exec::iterate::Rounds`, its ghost-zone rounds
//! `Rounds::ghost_rounds`): tiles of a round run in parallel (rayon); each
//! reads only the previous round's states, so the result does not depend on
//! thread count or order. States live in memory ([`Backend::Memory`], two
//! copies of the whole state) or in a scratch directory of one raw file per
//! tile ([`Backend::Disk`]), where memory is O(threads × patch) and the
//! raster may exceed memory. This module keeps what is erosion's: the ghost
//! depth from the model's radius and the exchange interval, the memory
//! check, the substeps on each patch, the finish and the final gather.
//!
//! The tile loop does not know where the neighbours live: [`run_ranked`]
//! takes a [`HaloTransport`]. [`Single`] (one process, what [`run`] uses)
//! has every tile local; under the MPI engine (`--engine mpi`,
//! `exec::mpi_halo::MpiHalo`) the tiles are split between the ranks in
//! contiguous ranges, each rank keeps only its tiles' states, and before
//! every round the ghost-zone cells of other ranks' tiles arrive point to
//! point from their owners (`exec::mpi_halo`; not the board all-gather of
//! the fixed-point rounds, which would send whole tile states to every
//! rank: see `exec/iterate/ghost.rs`); the finished tiles go to rank 0,
//! which writes them. Same bits for any number of ranks.

use super::{LocalModel, Patch};
use crate::error::{Error, Result};
use crate::exec::iterate::{GhostPatch, GhostRun, Rounds};
use crate::exec::mpi_halo::{partition, patch_window, HaloTransport, Single};
use crate::exec::{to_sink_type, EngineConfig, MemoryFit, TileSink};
use crate::raster::{read_window, DType, Grid, RasterSource, TileId, TileLayout, Window};
use crate::store::scratch::{hidden_beside, ScratchDir};
use std::path::{Path, PathBuf};

/// Where tile states are kept between rounds.
#[derive(Debug, Clone, PartialEq)]
pub enum Backend {
    /// In memory: two copies of the whole state.
    Memory,
    /// One raw little-endian `f64` file per tile and round parity in this
    /// directory (created if needed; the caller removes it).
    Disk(PathBuf),
}

/// What a run did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RunStats {
    /// Halo exchanges (rounds).
    pub rounds: u64,
    /// Substeps in total.
    pub substeps: u64,
    /// Ghost-zone depth in cells.
    pub ghost: usize,
}

/// One tiled run: the model, its input, the tile layout, the exchange
/// interval (substeps per round), where the states live and the engine
/// settings.
pub struct Tiled<'a, M> {
    pub model: &'a M,
    pub src: &'a dyn RasterSource,
    pub layout: TileLayout,
    pub exchange: usize,
    pub backend: &'a Backend,
    pub cfg: &'a EngineConfig,
}

impl<'a, M> Tiled<'a, M> {
    /// The run of `model` on `src` over `layout`, a halo exchange every
    /// `exchange` substeps, states in `backend`.
    pub fn new(
        model: &'a M,
        src: &'a dyn RasterSource,
        layout: TileLayout,
        exchange: usize,
        backend: &'a Backend,
        cfg: &'a EngineConfig,
    ) -> Self {
        Tiled {
            model,
            src,
            layout,
            exchange,
            backend,
            cfg,
        }
    }
}

/// Bytes of state of a `width x height` raster for `fields` fields.
pub fn state_bytes(width: usize, height: usize, fields: usize) -> u64 {
    (width as u64)
        .saturating_mul(height as u64)
        .saturating_mul(fields as u64)
        .saturating_mul(8)
}

/// The whole-grid run: one patch covering `dem`, every substep, then
/// `finish`. Returns the final fields (field 0 = terrain). This is the
/// reference the tiled run equals bit for bit.
pub fn run_untiled<M: LocalModel>(model: &M, dem: &Grid<f64>) -> Vec<Grid<f64>> {
    let (w, h) = (dem.width(), dem.height());
    let nf = model.field_names().len();
    let mut p = Patch::new(0, 0, w, h, nf);
    p.fields[0].copy_from_slice(dem.data());
    for n in 0..model.substeps() {
        model.substep(&mut p, n);
    }
    model.finish(&mut p);
    p.fields
        .into_iter()
        .map(|f| Grid::from_vec(w, h, f).unwrap_or_else(|_| Grid::new(w, h, f64::NAN)))
        .collect()
}

/// Run `model` on `src` over `layout` with a halo exchange every `exchange`
/// substeps, and hand each finished tile (after [`LocalModel::finish`]) to
/// `emit` in increasing tile id order, as a patch holding exactly the core.
pub fn run<M: LocalModel>(
    job: &Tiled<'_, M>,
    emit: impl FnMut(TileId, Window, &Patch) -> Result<()>,
) -> Result<RunStats> {
    run_ranked(job, &mut Single, None, false, emit)
}

/// [`run`] spread over the ranks of `x` (every rank calls it with the same
/// arguments): the tiles are split by [`partition`], each rank keeps only
/// its tiles' states, and before every round the ghost-zone cells owned by
/// other ranks arrive through `x` ([`HaloPlan`]); tiles of the same rank
/// are read in memory. Finished tiles go to rank 0, which alone calls
/// `emit`, in increasing tile id order; remote tiles carry only the fields
/// in `keep` (all if `None`; the others are empty). The result is the same
/// bits for any number of ranks and threads. With [`Single`] this is
/// [`run`], with no copy or message added. With `narrow`, remote tiles
/// travel as `f32` (half the bytes): their kept fields reach `emit` rounded
/// to `f32`, which gives the same bytes when every kept field is written
/// as `f32` (an `f32` widened to `f64` converts back to itself).
pub fn run_ranked<M: LocalModel, X: HaloTransport>(
    job: &Tiled<'_, M>,
    x: &mut X,
    keep: Option<&[usize]>,
    narrow: bool,
    mut emit: impl FnMut(TileId, Window, &Patch) -> Result<()>,
) -> Result<RunStats> {
    let (model, src, layout) = (job.model, job.src, job.layout);
    let (exchange, backend, cfg) = (job.exchange, job.backend, job.cfg);
    let info = src.info();
    if (layout.width, layout.height) != (info.width, info.height) {
        return Err(Error::invalid(format!(
            "erosion: layout {}x{} does not match {} ({}x{})",
            layout.width,
            layout.height,
            info.path.display(),
            info.width,
            info.height
        )));
    }
    if !(1..=100_000).contains(&exchange) {
        return Err(Error::invalid(format!(
            "erosion: exchange every {exchange} substeps: give 1 to 100000"
        )));
    }
    let nf = model.field_names().len();
    let keep: Vec<usize> = match keep {
        Some(k) => {
            if let Some(f) = k.iter().find(|&&f| f >= nf) {
                return Err(Error::invalid(format!(
                    "erosion: {} has {nf} fields, field {f} requested",
                    model.name()
                )));
            }
            k.to_vec()
        }
        None => (0..nf).collect(),
    };
    let total = model.substeps();
    let k = (exchange as u64).min(total.max(1));
    let ghost = (k as usize).saturating_mul(model.radius());
    // Patch memory per tile in flight (fields + the models' scratch, at most
    // 9 arrays), checked before anything is allocated.
    let side = |n: usize| (layout.tile.saturating_add(2 * ghost)).min(n) as u64;
    let patch_bytes = side(info.width)
        .saturating_mul(side(info.height))
        .saturating_mul((nf + 9) as u64 * 8);
    MemoryFit::bytes(patch_bytes, cfg.memory_budget).check(|fit| {
        Error::over_budget(format!(
            "erosion: one {}-cell tile with a {ghost}-cell ghost zone needs {} MiB, more than the memory budget ({} MiB); use a smaller --tile or --exchange, or a larger --memory",
            layout.tile,
            fit.need_mib(),
            fit.budget_mib()
        ))
    })?;
    let (me, ranks) = x.rank();
    let rounds = total.div_ceil(k);
    let pb = if cfg.progress && me == 0 {
        let pb = crate::exec::Progress::new(rounds);
        pb.set_message(model.name());
        pb
    } else {
        crate::exec::Progress::hidden()
    };
    // The observer hears of every exchange round (it cannot stop one).
    let pb = if me == 0 {
        pb.observed(model.name(), rounds, cfg)
    } else {
        pb
    };
    let disk = match backend {
        Backend::Memory => None,
        Backend::Disk(d) => Some(d.as_path()),
    };
    let mut driver = Rounds::new(layout, cfg.threads, x, |_| 0)?;
    let GhostRun {
        states: cur,
        plan,
        exchange_time,
    } = driver.ghost_rounds(
        ghost,
        nf,
        rounds,
        disk,
        // Round 0: the initial state (terrain from the source, other fields 0).
        |id| {
            let core = layout.window(id);
            let dem = read_window::<f64>(src, core)?;
            let mut v = vec![0.0; core.len() * nf];
            // Cells the f32 output cannot hold (±inf, beyond ±f32::MAX)
            // are nodata, as in the other steps (tests/hardening/numerics.rs).
            for (o, &z) in v[..core.len()].iter_mut().zip(dem.data()) {
                *o = if (z as f32).is_finite() { z } else { f64::NAN };
            }
            Ok(v)
        },
        |round, _, gp| {
            let s0 = round * k;
            let s1 = (s0 + k).min(total);
            let pw = gp.win;
            let mut patch = Patch::new(pw.x, pw.y, pw.w, pw.h, 0);
            patch.fields = gp.fields;
            for n in s0..s1 {
                model.substep(&mut patch, n);
            }
            Ok(GhostPatch {
                win: pw,
                fields: patch.fields,
                scratch: patch.scratch,
            })
        },
        || {
            pb.inc(1);
        },
    )?;
    drop(driver);
    let mine = &plan.mine;
    let owner = &plan.owner;
    pb.finish_and_clear();
    // Finish; rank 0 emits in tile id order, receiving the other ranks'
    // tiles (each sends its own in increasing order).
    let t_final = std::time::Instant::now();
    let finished = |id: TileId| -> Result<Patch> {
        let core = layout.window(id);
        let data = cur.get(id, core.len() * nf)?;
        let mut patch = Patch::new(core.x, core.y, core.w, core.h, 0);
        patch.fields = data.chunks_exact(core.len()).map(|c| c.to_vec()).collect();
        model.finish(&mut patch);
        Ok(patch)
    };
    let mut final_bytes = 0u64;
    if me == 0 {
        let mut buf = Vec::new();
        let mut buf32: Vec<f32> = Vec::new();
        for (id, &from) in owner.iter().enumerate() {
            let core = layout.window(id);
            let patch = if from == 0 {
                finished(id).map_err(|e| x.fail(e))?
            } else {
                let n = core.len() * keep.len();
                let mut patch = Patch::new(core.x, core.y, core.w, core.h, 0);
                patch.fields = vec![Vec::new(); nf];
                if narrow {
                    buf32.resize(n, 0.0);
                    x.recv_from_f32(from, &mut buf32).map_err(|e| x.fail(e))?;
                    for (&f, c) in keep.iter().zip(buf32.chunks_exact(core.len())) {
                        patch.fields[f] = c.iter().map(|&v| f64::from(v)).collect();
                    }
                } else {
                    buf.resize(n, 0.0);
                    x.recv_from(from, &mut buf).map_err(|e| x.fail(e))?;
                    for (&f, c) in keep.iter().zip(buf.chunks_exact(core.len())) {
                        patch.fields[f] = c.to_vec();
                    }
                }
                patch
            };
            emit(id, core, &patch).map_err(|e| x.fail(e))?;
        }
    } else {
        let mut buf = Vec::new();
        let mut buf32: Vec<f32> = Vec::new();
        for &id in mine {
            let patch = finished(id).map_err(|e| x.fail(e))?;
            if narrow {
                buf32.clear();
                for &f in &keep {
                    buf32.extend(patch.fields[f].iter().map(|&v| v as f32));
                }
                final_bytes += buf32.len() as u64 * 4;
                x.send_to_root_f32(&buf32).map_err(|e| x.fail(e))?;
            } else {
                buf.clear();
                for &f in &keep {
                    buf.extend_from_slice(&patch.fields[f]);
                }
                final_bytes += buf.len() as u64 * 8;
                x.send_to_root(&buf).map_err(|e| x.fail(e))?;
            }
        }
    }
    if x.distributed() {
        let ghost_cells: u64 = mine
            .iter()
            .map(|&id| (patch_window(&layout, id, ghost).len() - layout.window(id).len()) as u64)
            .sum();
        let received: u64 = plan.recv_len.iter().map(|&n| n as u64).sum();
        let mine_stats = [
            received * 8,
            received / nf.max(1) as u64,
            ghost_cells,
            final_bytes,
            exchange_time.as_nanos() as u64,
            t_final.elapsed().as_nanos() as u64,
        ];
        let s = x.sum(&mine_stats).map_err(|e| x.fail(e))?;
        if me == 0 && std::env::var_os("OROGEN_MPI_STATS").is_some() {
            print_stats(model.name(), &layout, ranks, rounds, ghost, nf, &s);
        }
    }
    Ok(RunStats {
        rounds,
        substeps: total,
        ghost,
    })
}

/// One JSON line per phase on stderr (rank 0, `OROGEN_MPI_STATS`), like
/// the MPI engine's. `s` = sums over the ranks of [bytes received per round,
/// remote ghost cells per round, ghost cells per round, bytes of finished
/// tiles to rank 0, ns exchanging, ns of the final gather].
fn print_stats(
    name: &str,
    layout: &TileLayout,
    ranks: usize,
    rounds: u64,
    ghost: usize,
    nf: usize,
    s: &[u64],
) {
    let [bytes, remote, ghost_cells, final_bytes, ns_x, ns_f] = s[..] else {
        return;
    };
    let div = |a: u64, b: u64| if b == 0 { 0.0 } else { a as f64 / b as f64 };
    let perimeter = crate::exec::mpi_codec::perimeter_cells(layout);
    eprintln!(
        "{}",
        serde_json::json!({
            "mpi_stats": format!("erode {name}"),
            "phase": "erosion: halo exchange, point to point",
            "ranks": ranks,
            "tiles": layout.count(),
            "rounds": rounds,
            "ghost_depth": ghost,
            "fields": nf,
            "bytes_per_round": bytes,
            "bytes_total": bytes.saturating_mul(rounds),
            "remote_ghost_cells_per_round": remote,
            "ghost_cells_per_round": ghost_cells,
            "bytes_per_remote_ghost_cell": div(bytes, remote),
            "bytes_per_ghost_cell": div(bytes, ghost_cells),
            "perimeter_cells": perimeter,
            "bytes_per_perimeter_cell_per_round": div(bytes, perimeter),
            "seconds_summed_over_ranks": ns_x as f64 * 1e-9,
        })
    );
    eprintln!(
        "{}",
        serde_json::json!({
            "mpi_stats": format!("erode {name}"),
            "phase": "erosion: finished tiles to rank 0",
            "ranks": ranks,
            "tiles": layout.count(),
            "bytes_up": final_bytes,
            "cells": layout.width as u64 * layout.height as u64,
            "bytes_up_per_perimeter_cell": div(final_bytes, perimeter),
            "seconds_summed_over_ranks": ns_f as f64 * 1e-9,
        })
    );
}

/// [`run`], writing field `f` of every tile to the sink paired with it.
/// Sinks are finished only when every tile was written.
pub fn run_to_sinks<M: LocalModel>(
    job: &Tiled<'_, M>,
    sinks: Vec<(usize, Box<dyn TileSink>)>,
) -> Result<RunStats> {
    run_to_sinks_ranked(job, &mut Single, sinks)
}

/// [`run_to_sinks`] over the ranks of `x` ([`run_ranked`]): only rank 0
/// writes (the other ranks' sinks are dropped unwritten); only the sinks'
/// fields travel to rank 0; every rank returns once the outputs are
/// finished.
pub fn run_to_sinks_ranked<M: LocalModel, X: HaloTransport>(
    job: &Tiled<'_, M>,
    x: &mut X,
    mut sinks: Vec<(usize, Box<dyn TileSink>)>,
) -> Result<RunStats> {
    let (model, layout) = (job.model, job.layout);
    let nf = model.field_names().len();
    if let Some((f, _)) = sinks.iter().find(|(f, _)| *f >= nf) {
        return Err(Error::invalid(format!(
            "erosion: {} has {nf} fields, output field {f} requested",
            model.name()
        )));
    }
    for (_, s) in &sinks {
        if let Some(l) = s.layout() {
            if l != layout {
                return Err(Error::invalid(
                    "erosion: an output tile store has another tile layout than the run",
                ));
            }
        }
    }
    let mut keep: Vec<usize> = sinks.iter().map(|(f, _)| *f).collect();
    keep.sort_unstable();
    keep.dedup();
    // Every output f32 (the same on every rank: the other ranks' sinks
    // report the real sinks' types): tiles travel as f32.
    let narrow = !sinks.is_empty() && sinks.iter().all(|(_, s)| s.dtype() == DType::F32);
    let stats = run_ranked(job, x, Some(&keep), narrow, |id, core, p| {
        for (f, sink) in sinks.iter_mut() {
            let g = Grid::from_vec(core.w, core.h, p.fields[*f].clone())?;
            let any = to_sink_type(&g, sink.as_ref());
            sink.write(id, core, any)?;
        }
        Ok(())
    })?;
    let (me, _) = x.rank();
    if me == 0 {
        for (_, s) in sinks {
            s.finish().map_err(|e| x.fail(e))?;
        }
    } else {
        drop(sinks);
    }
    // Nobody goes on (and reads an output) before rank 0 finished it.
    x.barrier();
    Ok(stats)
}

/// [`run`] with every field assembled into whole grids (tests, small rasters).
pub fn run_to_grids<M: LocalModel>(
    model: &M,
    src: &dyn RasterSource,
    tile: usize,
    exchange: usize,
    backend: &Backend,
    cfg: &EngineConfig,
) -> Result<(Vec<Grid<f64>>, RunStats)> {
    let info = src.info();
    let (w, h) = (info.width, info.height);
    let nf = model.field_names().len();
    let mut grids: Vec<Grid<f64>> = (0..nf).map(|_| Grid::new(w, h, 0.0)).collect();
    let layout = TileLayout::new(w, h, tile.max(1));
    let job = Tiled::new(model, src, layout, exchange, backend, cfg);
    let stats = run(&job, |_, core, p| {
        for (g, f) in grids.iter_mut().zip(&p.fields) {
            let t = Grid::from_vec(core.w, core.h, f.clone())?;
            g.paste(&t, core.x, core.y);
        }
        Ok(())
    })?;
    Ok((grids, stats))
}

/// Run `model` on `src` and write field `f` to `path` for each `(f, path)`
/// of `outputs` (as f32, nodata = the input's), choosing the tile layout like
/// the other operations (`ops::choose_layout`). States stay in memory when
/// two copies fit in half the memory budget; otherwise (or with `scratch`)
/// they go to a scratch folder — `scratch`, or a hidden folder next to the
/// first output — removed at the end.
#[allow(clippy::too_many_arguments)]
pub fn erode_to_paths<M: LocalModel>(
    model: &M,
    src: &dyn RasterSource,
    outputs: &[(usize, PathBuf)],
    oo: &crate::io::OutputOptions,
    tile: Option<usize>,
    exchange: usize,
    scratch: Option<&Path>,
    cfg: &EngineConfig,
) -> Result<(RunStats, TileLayout)> {
    let info = src.info();
    let first = outputs
        .first()
        .ok_or_else(|| Error::invalid("erosion: no output given"))?;
    let paths: Vec<PathBuf> = outputs.iter().map(|(_, p)| p.clone()).collect();
    let layout = crate::exec::plan::choose_layout(src, &paths, oo, tile);
    let nodata = info.georef.nodata;
    let georef = info.georef.clone().with_nodata(nodata);
    let mut sinks = Vec::with_capacity(outputs.len());
    for (f, p) in outputs {
        let prov = crate::store::Provenance::new(
            format!("erode-{}", model.name()),
            model.params_json(),
            vec![info.path.display().to_string()],
        );
        let sink =
            crate::io::create_sink_like(p, info, crate::raster::DType::F32, &georef, oo, prov)?;
        sinks.push((*f, sink));
    }
    let nf = model.field_names().len();
    // Under MPI each rank holds the states of its own tiles only.
    let (me, ranks) = crate::exec::rank();
    let owner = partition(&layout, ranks);
    let my_cells: u64 = (0..layout.count())
        .filter(|&id| owner[id] == me)
        .map(|id| layout.window(id).len() as u64)
        .sum();
    let in_memory = scratch.is_none()
        && MemoryFit::bytes(
            my_cells.saturating_mul(nf as u64 * 8).saturating_mul(2),
            cfg.memory_budget / 2,
        )
        .fits();
    let job = |backend| Tiled::new(model, src, layout, exchange, backend, cfg);
    if in_memory {
        let stats = dispatch(&job(&Backend::Memory), sinks)?;
        return Ok((stats, layout));
    }
    // One scratch folder per rank (ranks may share a filesystem).
    let rank_tag = if ranks > 1 {
        format!("-rank{me}")
    } else {
        String::new()
    };
    let dir = ScratchDir::new(match scratch {
        Some(d) => d.join(format!("orogen-erosion-scratch{rank_tag}")),
        None => hidden_beside(&first.1, &format!("erosion-scratch{rank_tag}"), "erosion"),
    });
    let result = dispatch(&job(&Backend::Disk(dir.path().to_path_buf())), sinks);
    let cleanup = dir.remove();
    let stats = result?;
    cleanup?;
    Ok((stats, layout))
}

/// [`run_to_sinks_ranked`] over the ranks of the MPI engine when the config
/// names it ([`EngineConfig::engine`], `--engine mpi`), else in this
/// process alone.
fn dispatch<M: LocalModel>(
    job: &Tiled<'_, M>,
    sinks: Vec<(usize, Box<dyn TileSink>)>,
) -> Result<RunStats> {
    #[cfg(feature = "mpi")]
    if job.cfg.engine == crate::exec::EngineKind::Mpi {
        let mut x = crate::exec::mpi_halo::MpiHalo::new()?;
        return run_to_sinks_ranked(job, &mut x, sinks);
    }
    #[cfg(not(feature = "mpi"))]
    if job.cfg.engine == crate::exec::EngineKind::Mpi {
        return Err(crate::exec::mpi_missing());
    }
    run_to_sinks(job, sinks)
}

#[cfg(test)]
mod tests;
