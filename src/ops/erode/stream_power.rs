//! `erode --model stream-power`: stream-power erosion with uplift (Braun &
//! Willett 2013 implicit solver), optional constrained erosion around fixed
//! points (Argudo et al. 2019 §6.3) and coarse-to-fine levels, in memory or
//! tiled out of core (`erosion::stream_power_tiled`, the same bytes).

use super::points::read_fixed_points;
use crate::erosion::constrained::{erode_constrained_f64, ConstrainedParams};
use crate::erosion::multires::{downsample_area, erode_multires};
use crate::erosion::stream_power::{
    stream_power, BaseHeight, Boundary, Depressions, StreamPowerParams, Uplift,
};
use crate::error::{Error, Result};
use crate::exec::output::{below, valid_range};
use crate::exec::EngineConfig;
use crate::io::OutputOptions;
use crate::ops::note::{bail, Note, Notify};
use crate::raster::{read_window, AnyGrid, GeoRef, Grid, MemRaster, RasterSource, Window};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Depression routing (`--depressions`).
#[derive(Copy, Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum DepressionRouting {
    /// Priority-flood filling: lakes drain through their spill point.
    Fill,
    /// Cordonnier, Bovy & Braun (2019) basin graph (minimum spanning tree of passes).
    BasinGraph,
    /// No routing: pits are local base levels.
    None,
}

impl DepressionRouting {
    fn parse(s: &str) -> Option<Self> {
        match s {
            "fill" => Some(Self::Fill),
            "basin-graph" => Some(Self::BasinGraph),
            "none" => Some(Self::None),
            _ => None,
        }
    }
}

/// Height of the base-level cells (`--base-height`).
#[derive(Copy, Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum BaseLevelHeight {
    /// Keep the input elevation of the base-level cells.
    Initial,
    /// Set base-level cells to 0.
    Zero,
}

impl BaseLevelHeight {
    fn parse(s: &str) -> Option<Self> {
        match s {
            "initial" => Some(Self::Initial),
            "zero" => Some(Self::Zero),
            _ => None,
        }
    }
}

/// The stream-power model options (no input or output).
#[derive(Clone, Debug, PartialEq)]
pub struct StreamPowerOptions {
    /// Number of time steps (per level with `levels`).
    pub steps: usize,
    /// Time step in years.
    pub dt: f64,
    /// Erodibility K (for n = 1: m^(1-2m)/yr) [default 1e-5].
    pub k: Option<f64>,
    /// Drainage-area exponent m [default 0.4].
    pub m: Option<f64>,
    /// Slope exponent n [default 1].
    pub n: Option<f64>,
    /// Uniform uplift rate in m/yr [default 0].
    pub uplift: Option<f64>,
    /// Uplift rate map (m/yr), a raster of the DEM's size.
    pub uplift_map: Option<PathBuf>,
    /// Hillslope diffusivity Kd in m^2/yr (0 = none).
    pub diffusion: f64,
    /// Depression routing [default fill].
    pub depressions: Option<DepressionRouting>,
    /// Base-level borders: all, none, or a list of north,south,east,west [default all].
    pub base_level: Option<String>,
    /// Height of the base-level cells [default initial].
    pub base_height: Option<BaseLevelHeight>,
    /// Force the tiled (out-of-core) solve.
    pub tiled: bool,
    /// Scratch folder of the tiled solve.
    pub scratch: Option<PathBuf>,
    /// Fixed points to keep (constrained erosion), CSV or GeoJSON.
    pub fixed_points: Option<PathBuf>,
    /// Radius of the compensating uplift around each fixed point, in metres.
    pub radius: Option<f64>,
    /// Constrained erosion: steps between two compensations.
    pub compensate_every: usize,
    /// Coarse-to-fine cell sizes in metres.
    pub levels: Vec<f64>,
    /// Cell size in metres (default: from the georeference).
    pub cell: Option<f64>,
}

impl Default for StreamPowerOptions {
    fn default() -> Self {
        StreamPowerOptions {
            steps: 100,
            dt: 1000.0,
            k: None,
            m: None,
            n: None,
            uplift: None,
            uplift_map: None,
            diffusion: 0.0,
            depressions: None,
            base_level: None,
            base_height: None,
            tiled: false,
            scratch: None,
            fixed_points: None,
            radius: None,
            compensate_every: 10,
            levels: vec![],
            cell: None,
        }
    }
}

/// The `[stream-power]` table of a parameter file (every key optional).
#[derive(serde::Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct SpTable {
    k: Option<f64>,
    m: Option<f64>,
    n: Option<f64>,
    dt: Option<f64>,
    diffusivity: Option<f64>,
    uplift: Option<f64>,
    uplift_map: Option<PathBuf>,
    depressions: Option<String>,
    base_level: Option<String>,
    base_height: Option<String>,
    cell: Option<f64>,
    tiled: Option<bool>,
}

/// Bytes per cell the in-memory solver needs (heights, receivers, distances,
/// stack, area, donors, levels, flags, queue), checked against the memory budget.
const BYTES_PER_CELL: u64 = 96;

impl StreamPowerOptions {
    /// The library parameters (validated).
    pub fn params(&self) -> Result<StreamPowerParams> {
        let p = StreamPowerParams {
            k: self.k.unwrap_or(1e-5),
            m: self.m.unwrap_or(0.4),
            n: self.n.unwrap_or(1.0),
            dt: self.dt,
            kd: self.diffusion,
            depressions: match self.depressions.unwrap_or(DepressionRouting::Fill) {
                DepressionRouting::Fill => Depressions::Fill,
                DepressionRouting::BasinGraph => Depressions::BasinGraph,
                DepressionRouting::None => Depressions::None,
            },
            boundary: Boundary::parse(self.base_level.as_deref().unwrap_or("all"))
                .map_err(|e| Error::invalid(format!("--base-level: {e}")))?,
            base_height: match self.base_height.unwrap_or(BaseLevelHeight::Initial) {
                BaseLevelHeight::Initial => BaseHeight::Initial,
                BaseLevelHeight::Zero => BaseHeight::Zero,
            },
        };
        p.validate()?;
        if self.steps == 0 {
            bail!("--steps 0: give at least one time step");
        }
        if !self.uplift_rate().is_finite() {
            bail!(
                "--uplift {}: give a finite rate in m/yr",
                self.uplift_rate()
            );
        }
        if self.fixed_points.is_some() != self.radius.is_some() {
            bail!("--fixed-points and --radius go together (radius in metres, e.g. 10 cells)");
        }
        if self.compensate_every == 0 {
            bail!("--compensate-every 0: give at least 1 step");
        }
        Ok(p)
    }

    /// The uniform uplift rate (m/yr), 0 unless given.
    pub fn uplift_rate(&self) -> f64 {
        self.uplift.unwrap_or(0.0)
    }

    /// Fill the options not given from a `[stream-power]` parameter table
    /// (file, then `--set`, then `--dt`/`--diffusivity`, as merged by
    /// [`super::run`]); `from` names the table's sources in errors. Unknown
    /// keys are refused with the valid ones.
    pub fn merge_table(&mut self, table: toml::Table, from: &str) -> Result<()> {
        let f: SpTable = toml::Value::Table(table).try_into().map_err(|e| {
            Error::invalid(format!(
                "stream-power parameters ({from}): {}",
                e.to_string().trim_end()
            ))
        })?;
        let pick = |v: Option<String>, key: &str| -> Option<String> {
            v.map(|s| s.trim().to_ascii_lowercase()).map(|s| {
                if key == "depressions" {
                    s.replace('_', "-")
                } else {
                    s
                }
            })
        };
        self.k = self.k.or(f.k);
        self.m = self.m.or(f.m);
        self.n = self.n.or(f.n);
        if self.uplift.is_none() && self.uplift_map.is_none() {
            match (f.uplift, f.uplift_map) {
                (Some(_), Some(_)) => {
                    bail!("stream-power parameters ({from}): give uplift or uplift_map, not both")
                }
                (u, m) => {
                    self.uplift = u;
                    self.uplift_map = m;
                }
            }
        }
        if let Some(dt) = f.dt {
            self.dt = dt;
        }
        if let Some(kd) = f.diffusivity {
            self.diffusion = kd;
        }
        if self.depressions.is_none() {
            if let Some(d) = pick(f.depressions, "depressions") {
                let Some(v) = DepressionRouting::parse(&d) else {
                    bail!("stream-power parameters ({from}): depressions = {d:?}; use fill, basin-graph or none");
                };
                self.depressions = Some(v);
            }
        }
        if self.base_height.is_none() {
            if let Some(d) = pick(f.base_height, "base_height") {
                let Some(v) = BaseLevelHeight::parse(&d) else {
                    bail!("stream-power parameters ({from}): base_height = {d:?}; use initial or zero");
                };
                self.base_height = Some(v);
            }
        }
        self.base_level = self.base_level.take().or(f.base_level);
        self.cell = self.cell.or(f.cell);
        self.tiled |= f.tiled.unwrap_or(false);
        Ok(())
    }

    /// Erode `h` (f64, NaN = nodata) in memory with these options; `georef`
    /// places the fixed points given as map coordinates, `cell` is the cell
    /// size in metres.
    pub fn erode(
        &self,
        h: &Grid<f64>,
        cell: f64,
        georef: &GeoRef,
        notify: Notify<'_>,
    ) -> Result<Grid<f64>> {
        let p = self.params()?;
        let uplift_map = match &self.uplift_map {
            Some(path) => {
                let src = crate::io::open_raster(path, &Default::default())?;
                let info = src.info().clone();
                if info.width != h.width() || info.height != h.height() {
                    bail!(
                        "{}: the uplift map is {}x{} but the DEM is {}x{}",
                        path.display(),
                        info.width,
                        info.height,
                        h.width(),
                        h.height()
                    );
                }
                Some(read_window::<f64>(
                    src.as_ref(),
                    Window::full(info.width, info.height),
                )?)
            }
            None => None,
        };
        let fixed = match (&self.fixed_points, self.radius) {
            (Some(f), Some(r)) => Some((read_fixed_points(f, georef, h, &mut *notify)?, r)),
            _ => None,
        };
        let (w, ht) = (h.width(), h.height());
        let run_level = |g: &mut Grid<f64>, c: f64| -> Result<()> {
            let up_level;
            let up = match &uplift_map {
                Some(m) if m.width() == g.width() && m.height() == g.height() => Uplift::Map(m),
                Some(m) => {
                    up_level = downsample_area(m, g.width(), g.height())?;
                    Uplift::Map(&up_level)
                }
                None => Uplift::Uniform(self.uplift_rate()),
            };
            match &fixed {
                None => stream_power(g, c, &p, &up, self.steps)?,
                Some((pts, r)) => {
                    if uplift_map.is_some() {
                        bail!("--fixed-points works with a uniform --uplift, not --uplift-map");
                    }
                    let pts: Vec<(usize, usize)> = scale_points(pts, w, ht, g.width(), g.height());
                    let every = self.compensate_every.min(self.steps);
                    let cp = ConstrainedParams {
                        stream: p.clone(),
                        uplift: self.uplift_rate(),
                        iterations: self.steps.div_ceil(every),
                        steps_per_iteration: every,
                        ..Default::default()
                    };
                    erode_constrained_f64(g, c, &pts, *r, &cp)?;
                }
            }
            Ok(())
        };
        if self.levels.is_empty() {
            let mut g = h.clone();
            run_level(&mut g, cell)?;
            Ok(g)
        } else {
            erode_multires(h, cell, &self.levels, |g, c, _| run_level(g, c))
        }
    }
}

/// Fixed points scaled from a `w x h` grid to a `w2 x h2` one (cell containing
/// the point's centre), duplicates removed.
fn scale_points(
    pts: &[(usize, usize)],
    w: usize,
    h: usize,
    w2: usize,
    h2: usize,
) -> Vec<(usize, usize)> {
    let mut v: Vec<(usize, usize)> = pts
        .iter()
        .map(|&(x, y)| {
            let sx = (((x as f64 + 0.5) * w2 as f64 / w as f64) as usize).min(w2 - 1);
            let sy = (((y as f64 + 0.5) * h2 as f64 / h as f64) as usize).min(h2 - 1);
            (sx, sy)
        })
        .collect();
    v.sort_unstable();
    v.dedup();
    v
}

/// Read `src` (the raster at `input`), erode it and write `output`: in
/// memory when it fits `cfg.memory_budget` (and `tiled` is off), else tile by
/// tile with the same bytes.
#[allow(clippy::too_many_arguments)]
pub fn run(
    input: &Path,
    src: &dyn RasterSource,
    model: &StreamPowerOptions,
    output: &Path,
    oo: &OutputOptions,
    tile: Option<usize>,
    cfg: &EngineConfig,
    notify: Notify<'_>,
) -> Result<()> {
    let info = src.info().clone();
    let need = info.width as u64 * info.height as u64 * BYTES_PER_CELL;
    let tiled = model.tiled || need > cfg.memory_budget;
    if tiled {
        if !model.levels.is_empty() || model.fixed_points.is_some() {
            bail!(
                "{}: --levels and --fixed-points run in memory only ({}); raise --memory (about {:.1} GiB) or drop them",
                input.display(),
                if model.tiled { "--tiled was given" } else { "the DEM does not fit in --memory" },
                need as f64 / (1u64 << 30) as f64
            );
        }
        if model.depressions == Some(DepressionRouting::BasinGraph) {
            bail!(
                "{}: --depressions basin-graph runs in memory only ({}); use --depressions fill or none, or raise --memory (about {:.1} GiB)",
                input.display(),
                if model.tiled { "--tiled was given" } else { "the DEM does not fit in --memory" },
                need as f64 / (1u64 << 30) as f64
            );
        }
    } else if model.scratch.is_some() {
        bail!("--scratch applies to the tiled stream-power solve only (give --tiled, or a DEM larger than --memory)");
    }
    let cell = match model.cell {
        Some(c) => {
            if !(c.is_finite() && c > 0.0) {
                bail!("--cell {c}: give a cell size in metres > 0");
            }
            c
        }
        None => {
            let (cx, cy) = info.georef.cell_size_m(info.height as i64 / 2);
            if (cx - cy).abs() > 0.01 * cx.max(cy) {
                notify(Note::Warning(format!(
                    "{}: cells are {cx:.2} x {cy:.2} m; the solver uses square cells of {:.2} m (pass --cell to choose)",
                    input.display(),
                    0.5 * (cx + cy)
                )));
            }
            0.5 * (cx + cy)
        }
    };
    if tiled {
        return run_tiled(model, src, cell, output, tile, oo, cfg, &mut *notify);
    }
    let dem = read_window::<f64>(src, Window::full(info.width, info.height))?;
    let out = model
        .erode(&dem, cell, &info.georef, &mut *notify)
        .map_err(|e| Error::invalid(format!("{}: {e}", input.display())))?;
    // Output nodata: −9999 unless the eroded surface may reach it
    // (bathymetry), then a customary value below it (`exec::output`'s
    // rule, on the bound the tiled solve uses, so both write the same bytes;
    // the actual minimum too, should the bound ever fail).
    let out = out.map(|v| v as f32);
    let lowest = |d: &[f32]| {
        d.iter()
            .copied()
            .filter(|v| v.is_finite())
            .fold(None, |m: Option<f32>, v| Some(m.map_or(v, |m| m.min(v))))
    };
    let input_min = dem
        .data()
        .iter()
        .map(|&v| v as f32)
        .filter(|v| v.is_finite())
        .fold(None, |m: Option<f32>, v| Some(m.map_or(v, |m| m.min(v))));
    let bound = sp_lower_bound(input_min, None, model, model.params()?.dt)?;
    let nd = match (bound, lowest(out.data())) {
        (Some(b), Some(o)) => below(Some(b.min(o))),
        (b, o) => below(b.or(o)),
    }
    .unwrap_or(f64::NAN);
    let out = out.map(|v| if v.is_finite() { v } else { nd as f32 });
    let mem = MemRaster::new(
        AnyGrid::F32(out),
        info.georef.clone().with_nodata(Some(nd)),
        info.path.clone(),
    );
    crate::ops::convert(&mem, output, oo, tile, cfg)?;
    notify(Note::Wrote(output.to_path_buf()));
    Ok(())
}

/// The tiled (out-of-core) solve, written tile by tile to the output.
#[allow(clippy::too_many_arguments)]
fn run_tiled(
    model: &StreamPowerOptions,
    src: &dyn RasterSource,
    cell: f64,
    output: &Path,
    tile: Option<usize>,
    oo: &OutputOptions,
    cfg: &EngineConfig,
    notify: Notify<'_>,
) -> Result<()> {
    use crate::erosion::stream_power_tiled::{
        SpBackend, SpTiling, TiledUplift, TILE_BYTES_PER_CELL,
    };
    let p = model.params()?;
    let info = src.info().clone();
    let t0 = std::time::Instant::now();
    let layout = crate::ops::choose_layout(src, &[output.to_path_buf()], oo, tile);
    let map_src = match &model.uplift_map {
        Some(path) => Some(crate::io::open_raster(path, &Default::default())?),
        None => None,
    };
    let uplift = match &map_src {
        Some(m) => TiledUplift::Map(m.as_ref()),
        None => TiledUplift::Uniform(model.uplift_rate()),
    };
    // Under MPI each rank keeps its own tiles (about 1/ranks of them),
    // in a scratch folder of its own (ranks may share a filesystem).
    let (me, ranks) = crate::exec::rank();
    let cells = (info.width as u64 * info.height as u64).div_ceil(ranks as u64);
    let rank_tag = if ranks > 1 {
        format!("-rank{me}")
    } else {
        String::new()
    };
    let (backend, cleanup) = match &model.scratch {
        None if cells.saturating_mul(TILE_BYTES_PER_CELL) <= cfg.memory_budget / 2 => {
            (SpBackend::Memory, None)
        }
        Some(d) => {
            let dir = d.join(format!("orogen-sp-scratch{rank_tag}"));
            (SpBackend::Disk(dir.clone()), Some(dir))
        }
        None => {
            let name = output
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_else(|| "erosion".into());
            let dir = output.with_file_name(format!(".{name}.sp-scratch{rank_tag}"));
            (SpBackend::Disk(dir.clone()), Some(dir))
        }
    };
    let nd = tiled_nodata(src, map_src.as_deref(), model, p.dt)?;
    let georef = info.georef.clone().with_nodata(Some(nd));
    let prov = crate::store::Provenance::new(
        "erode-stream-power",
        serde_json::json!({
            "model": "stream-power", "k": p.k, "m": p.m, "n": p.n, "dt": p.dt, "kd": p.kd,
            "steps": model.steps, "uplift": model.uplift_rate(),
            "uplift_map": model.uplift_map.as_ref().map(|p| p.display().to_string()),
            "depressions": format!("{:?}", p.depressions), "cell": cell,
        }),
        vec![info.path.display().to_string()],
    );
    let mut sink =
        crate::io::create_sink_like(output, &info, crate::raster::DType::F32, &georef, oo, prov)?;
    let tiling = SpTiling {
        tile: layout.tile,
        backend,
        threads: cfg.threads,
    };
    let write = |id, win, g: &Grid<f64>| {
        let low = g
            .data()
            .iter()
            .map(|&v| v as f32)
            .filter(|v| v.is_finite())
            .fold(f32::INFINITY, f32::min);
        let g = g.map(|v| {
            let v = v as f32;
            if v.is_finite() {
                v
            } else {
                nd as f32
            }
        });
        if low as f64 <= nd {
            // Out of the bound `tiled_nodata` derived: refuse rather
            // than write a cell that reads back as nodata.
            return Err(Error::invalid(format!(
                    "tile {id}: an eroded elevation ({low}) reaches the output nodata ({nd}) chosen from the input's minimum; this is a bug, please report it"
                )));
        }
        sink.write(id, win, AnyGrid::F32(g))
    };
    let result = dispatch_tiled(cfg, src, cell, &p, &uplift, model.steps, &tiling, write);
    if let Some(dir) = &cleanup {
        if let Err(e) = std::fs::remove_dir_all(dir) {
            if e.kind() != std::io::ErrorKind::NotFound {
                notify(Note::Warning(format!(
                    "{}: cannot remove the scratch folder: {e}",
                    dir.display()
                )));
            }
        }
    }
    let stats = result.map_err(|e| Error::invalid(format!("{}: {e}", info.path.display())))?;
    sink.finish()?;
    // Nobody goes on (and reads the output) before rank 0 finished it.
    crate::exec::barrier();
    notify(Note::Info(format!(
        "erode: stream power (tiled, {}-cell tiles, {}) on {}x{} cells, {} steps, {} tile passes (longest round {}), {:.1} s",
        layout.tile,
        if cleanup.is_some() { "scratch files" } else { "in memory" },
        info.width,
        info.height,
        model.steps,
        stats.passes,
        stats.max_round,
        t0.elapsed().as_secs_f64()
    )));
    notify(Note::Wrote(output.to_path_buf()));
    Ok(())
}

/// The tiled solve over the ranks of the MPI engine when the config names
/// it ([`EngineConfig::engine`], `--engine mpi`), else in this process alone.
#[allow(clippy::too_many_arguments)]
fn dispatch_tiled(
    cfg: &EngineConfig,
    src: &dyn RasterSource,
    cell: f64,
    p: &StreamPowerParams,
    uplift: &crate::erosion::stream_power_tiled::TiledUplift,
    steps: usize,
    tiling: &crate::erosion::stream_power_tiled::SpTiling,
    write: impl FnMut(crate::raster::TileId, Window, &Grid<f64>) -> Result<()>,
) -> Result<crate::erosion::stream_power_tiled::SpTiledStats> {
    use crate::erosion::stream_power_tiled::stream_power_tiled_ranked;
    #[cfg(feature = "mpi")]
    if cfg.engine == crate::exec::EngineKind::Mpi {
        let mut x = crate::exec::mpi_halo::MpiHalo::new()?;
        return stream_power_tiled_ranked(src, cell, p, uplift, steps, tiling, &mut x, write);
    }
    #[cfg(not(feature = "mpi"))]
    if cfg.engine == crate::exec::EngineKind::Mpi {
        return Err(crate::exec::mpi_missing());
    }
    let mut x = crate::exec::mpi_halo::Single;
    stream_power_tiled_ranked(src, cell, p, uplift, steps, tiling, &mut x, write)
}

/// Output nodata of the tiled solve, fixed before the first tile is written:
/// the rule of `exec::output` (−9999 unless the data come within 1 m of
/// it, then a customary value below them) applied to [`sp_lower_bound`].
/// One read pass over the input (and the uplift map).
fn tiled_nodata(
    src: &dyn RasterSource,
    map: Option<&dyn RasterSource>,
    model: &StreamPowerOptions,
    dt: f64,
) -> Result<f64> {
    let input_min = valid_range(src)?.map(|r| r.0);
    let bound = sp_lower_bound(input_min, map, model, dt)?;
    Ok(below(bound).unwrap_or(f64::NAN))
}

/// A lower bound of the eroded surface: Braun & Willett's (2013) implicit
/// update makes each new height a weighted mean of the uplifted old height
/// and its receiver's new height, and stable explicit hillslope diffusion
/// averages neighbours, so no cell goes below the input minimum plus the
/// most negative uplift over the run, `steps · levels · dt · min(0, U)`
/// (U: the uniform uplift, or the minimum of the uplift map, opened here
/// unless `map` is given). None without valid input cells.
fn sp_lower_bound(
    input_min: Option<f32>,
    map: Option<&dyn RasterSource>,
    model: &StreamPowerOptions,
    dt: f64,
) -> Result<Option<f32>> {
    let Some(lo) = input_min else {
        return Ok(None);
    };
    let u_min = match (map, &model.uplift_map) {
        (Some(m), _) => valid_range(m)?.map_or(0.0, |r| r.0 as f64),
        (None, Some(path)) => {
            let m = crate::io::open_raster(path, &Default::default())?;
            valid_range(m.as_ref())?.map_or(0.0, |r| r.0 as f64)
        }
        (None, None) => model.uplift_rate(),
    };
    let steps = model.steps as f64 * model.levels.len().max(1) as f64;
    Ok(Some((lo as f64 + steps * dt * u_min.min(0.0)) as f32))
}
