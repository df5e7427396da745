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
//! Tiles of a round run in parallel (rayon); each reads only the previous
//! round's states, so the result does not depend on thread count or order.
//! States live in memory ([`Backend::Memory`], two copies of the whole state)
//! or in a scratch directory of one raw file per tile ([`Backend::Disk`]),
//! where memory is O(threads × patch) and the raster may exceed memory.

use super::{LocalModel, Patch};
use crate::error::{Error, Result};
use crate::exec::{to_sink_type, EngineConfig, TileSink};
use crate::raster::{read_window, Grid, RasterSource, TileId, TileLayout, Window};
use rayon::prelude::*;
use std::borrow::Cow;
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

/// Tile states of one round.
enum States {
    Memory(Vec<Vec<f64>>),
    Disk(PathBuf),
}

fn tile_file(dir: &Path, id: TileId) -> PathBuf {
    dir.join(format!("t{id}.f64"))
}

impl States {
    fn get(&self, id: TileId, expect: usize) -> Result<Cow<'_, [f64]>> {
        match self {
            States::Memory(v) => Ok(Cow::Borrowed(&v[id])),
            States::Disk(dir) => {
                let path = tile_file(dir, id);
                let bytes = std::fs::read(&path).map_err(|e| Error::io(&path, e))?;
                if bytes.len() != expect * 8 {
                    return Err(Error::corrupt(
                        &path,
                        format!(
                            "erosion scratch tile has {} bytes, expected {}; was the scratch folder changed during the run?",
                            bytes.len(),
                            expect * 8
                        ),
                    ));
                }
                Ok(Cow::Owned(
                    bytes
                        .chunks_exact(8)
                        .map(|c| {
                            f64::from_le_bytes([c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]])
                        })
                        .collect(),
                ))
            }
        }
    }
}

fn write_tile(dir: &Path, id: TileId, data: &[f64]) -> Result<()> {
    let path = tile_file(dir, id);
    let mut bytes = Vec::with_capacity(data.len() * 8);
    for v in data {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    std::fs::write(&path, bytes).map_err(|e| Error::io(&path, e))
}

/// Copy the core `core` (inside `p`) of every field into one flat vector.
fn extract(p: &Patch, core: Window) -> Vec<f64> {
    let (ox, oy) = ((core.x - p.x0) as usize, (core.y - p.y0) as usize);
    let mut out = Vec::with_capacity(core.len() * p.fields.len());
    for f in &p.fields {
        for y in 0..core.h {
            let s = (oy + y) * p.w + ox;
            out.extend_from_slice(&f[s..s + core.w]);
        }
    }
    out
}

/// Run `model` on `src` over `layout` with a halo exchange every `exchange`
/// substeps, and hand each finished tile (after [`LocalModel::finish`]) to
/// `emit` in increasing tile id order, as a patch holding exactly the core.
pub fn run<M: LocalModel>(
    model: &M,
    src: &dyn RasterSource,
    layout: TileLayout,
    exchange: usize,
    backend: &Backend,
    cfg: &EngineConfig,
    mut emit: impl FnMut(TileId, Window, &Patch) -> Result<()>,
) -> Result<RunStats> {
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
    let total = model.substeps();
    let k = (exchange as u64).min(total.max(1));
    let ghost = (k as usize).saturating_mul(model.radius());
    let full = Window::full(info.width, info.height);
    // Patch memory per tile in flight (fields + the models' scratch, at most
    // 9 arrays), checked before anything is allocated.
    let side = |n: usize| (layout.tile.saturating_add(2 * ghost)).min(n) as u64;
    let patch_bytes = side(info.width)
        .saturating_mul(side(info.height))
        .saturating_mul((nf + 9) as u64 * 8);
    if patch_bytes > cfg.memory_budget {
        return Err(Error::invalid(format!(
            "erosion: one {}-cell tile with a {ghost}-cell ghost zone needs {} MiB, more than the memory budget ({} MiB); use a smaller --tile or --exchange, or a larger --memory",
            layout.tile,
            patch_bytes >> 20,
            cfg.memory_budget >> 20
        )));
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(cfg.threads)
        .build()
        .map_err(|e| Error::invalid(format!("erosion: cannot start worker threads: {e}")))?;
    let ids: Vec<TileId> = (0..layout.count()).collect();
    let disk_dir = |parity: u64| -> Option<PathBuf> {
        match backend {
            Backend::Memory => None,
            Backend::Disk(d) => Some(d.join(format!("r{parity}"))),
        }
    };
    let store = |parity: u64, results: Vec<(TileId, Vec<f64>)>| -> Result<States> {
        match disk_dir(parity) {
            None => Ok(States::Memory(
                results.into_iter().map(|(_, v)| v).collect(),
            )),
            Some(dir) => Ok(States::Disk(dir)),
        }
    };
    for p in 0..2 {
        if let Some(d) = disk_dir(p) {
            std::fs::create_dir_all(&d).map_err(|e| Error::io(&d, e))?;
        }
    }
    let rounds = total.div_ceil(k);
    let pb = if cfg.progress {
        let pb = indicatif::ProgressBar::new(rounds);
        pb.set_message(model.name());
        pb
    } else {
        indicatif::ProgressBar::hidden()
    };
    // Round 0: the initial state (terrain from the source, other fields 0).
    let init = pool.install(|| {
        ids.par_iter()
            .map(|&id| -> Result<(TileId, Vec<f64>)> {
                let core = layout.window(id);
                let dem = read_window::<f64>(src, core)?;
                let mut v = vec![0.0; core.len() * nf];
                // Cells the f32 output cannot hold (±inf, beyond ±f32::MAX)
                // are nodata, as in the other steps (tests/numerics.rs).
                for (o, &z) in v[..core.len()].iter_mut().zip(dem.data()) {
                    *o = if (z as f32).is_finite() { z } else { f64::NAN };
                }
                if let Some(dir) = disk_dir(0) {
                    write_tile(&dir, id, &v)?;
                    return Ok((id, Vec::new()));
                }
                Ok((id, v))
            })
            .collect::<Result<Vec<_>>>()
    })?;
    let mut cur = store(0, init)?;
    for round in 0..rounds {
        let s0 = round * k;
        let s1 = (s0 + k).min(total);
        let next_parity = (round + 1) % 2;
        let prev = &cur;
        let results = pool.install(|| {
            ids.par_iter()
                .map(|&id| -> Result<(TileId, Vec<f64>)> {
                    let core = layout.window(id);
                    let pw = core.expand(ghost).intersect(&full).unwrap_or(core);
                    let mut patch = Patch::new(pw.x, pw.y, pw.w, pw.h, nf);
                    for tid in layout.tiles_in(&pw) {
                        let tw = layout.window(tid);
                        let Some(iw) = tw.intersect(&pw) else {
                            continue;
                        };
                        let data = prev.get(tid, tw.len() * nf)?;
                        for (f, field) in patch.fields.iter_mut().enumerate() {
                            let base = f * tw.len();
                            for y in iw.y..iw.y_end() {
                                let s = base + (y - tw.y) as usize * tw.w + (iw.x - tw.x) as usize;
                                let d = (y - pw.y) as usize * pw.w + (iw.x - pw.x) as usize;
                                field[d..d + iw.w].copy_from_slice(&data[s..s + iw.w]);
                            }
                        }
                    }
                    for n in s0..s1 {
                        model.substep(&mut patch, n);
                    }
                    let v = extract(&patch, core);
                    if let Some(dir) = disk_dir(next_parity) {
                        write_tile(&dir, id, &v)?;
                        return Ok((id, Vec::new()));
                    }
                    Ok((id, v))
                })
                .collect::<Result<Vec<_>>>()
        })?;
        cur = store(next_parity, results)?;
        pb.inc(1);
    }
    pb.finish_and_clear();
    // Finish and emit in tile id order.
    for &id in &ids {
        let core = layout.window(id);
        let data = cur.get(id, core.len() * nf)?;
        let mut patch = Patch::new(core.x, core.y, core.w, core.h, 0);
        patch.fields = data.chunks_exact(core.len()).map(|c| c.to_vec()).collect();
        model.finish(&mut patch);
        emit(id, core, &patch)?;
    }
    Ok(RunStats {
        rounds,
        substeps: total,
        ghost,
    })
}

/// [`run`], writing field `f` of every tile to the sink paired with it.
/// Sinks are finished only when every tile was written.
pub fn run_to_sinks<M: LocalModel>(
    model: &M,
    src: &dyn RasterSource,
    layout: TileLayout,
    exchange: usize,
    backend: &Backend,
    cfg: &EngineConfig,
    mut sinks: Vec<(usize, Box<dyn TileSink>)>,
) -> Result<RunStats> {
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
    let stats = run(model, src, layout, exchange, backend, cfg, |id, core, p| {
        for (f, sink) in sinks.iter_mut() {
            let g = Grid::from_vec(core.w, core.h, p.fields[*f].clone())?;
            let any = to_sink_type(&g, sink.as_ref());
            sink.write(id, core, any)?;
        }
        Ok(())
    })?;
    for (_, s) in sinks {
        s.finish()?;
    }
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
    let stats = run(model, src, layout, exchange, backend, cfg, |_, core, p| {
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
    let layout = crate::ops::choose_layout(src, &paths, oo, tile);
    let nodata = info.georef.nodata;
    let georef = info.georef.clone().with_nodata(nodata);
    let mut sinks = Vec::with_capacity(outputs.len());
    for (f, p) in outputs {
        let prov = crate::store::Provenance::new(
            format!("erode-{}", model.name()),
            model.params_json(),
            vec![info.path.display().to_string()],
        );
        let sink = crate::io::create_sink(
            p,
            info.width,
            info.height,
            crate::raster::DType::F32,
            &georef,
            oo,
            prov,
        )?;
        sinks.push((*f, sink));
    }
    let nf = model.field_names().len();
    let in_memory = scratch.is_none()
        && state_bytes(info.width, info.height, nf).saturating_mul(2) <= cfg.memory_budget / 2;
    if in_memory {
        let stats = run_to_sinks(model, src, layout, exchange, &Backend::Memory, cfg, sinks)?;
        return Ok((stats, layout));
    }
    let dir = match scratch {
        Some(d) => d.join("orogen-erosion-scratch"),
        None => {
            let name = first
                .1
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_else(|| "erosion".into());
            first.1.with_file_name(format!(".{name}.erosion-scratch"))
        }
    };
    let result = run_to_sinks(
        model,
        src,
        layout,
        exchange,
        &Backend::Disk(dir.clone()),
        cfg,
        sinks,
    );
    let cleanup = std::fs::remove_dir_all(&dir);
    let stats = result?;
    if let Err(e) = cleanup {
        if e.kind() != std::io::ErrorKind::NotFound {
            return Err(Error::io(&dir, e));
        }
    }
    Ok((stats, layout))
}
