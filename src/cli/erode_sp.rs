//! `orogen erode-sp` (temporary name; meant to become `orogen erode --model
//! stream-power`): stream-power erosion with uplift (Braun & Willett 2013),
//! optional constrained erosion around fixed points (Argudo et al. 2019 §6.3)
//! and coarse-to-fine levels. Runs in memory (see `orogen::erosion`).
//!
//! [`StreamPowerArgs`] holds every model option and no input/output option,
//! so it can be `#[command(flatten)]`ed into another command as it is.

use anyhow::{bail, Context, Result};
use clap::{Args, ValueEnum};
use orogen::erosion::constrained::{erode_constrained_f64, ConstrainedParams};
use orogen::erosion::multires::{downsample_area, erode_multires};
use orogen::erosion::stream_power::{
    stream_power, BaseHeight, Boundary, Depressions, StreamPowerParams, Uplift,
};
use orogen::hydro::out_nodata::{below, valid_range};
use orogen::raster::{read_window, AnyGrid, GeoRef, Grid, MemRaster, Window};
use std::path::{Path, PathBuf};

/// Depression routing choices.
#[derive(Copy, Clone, PartialEq, Eq, ValueEnum)]
pub enum DepressionsArg {
    /// Priority-flood filling: lakes drain through their spill point.
    Fill,
    /// Cordonnier, Bovy & Braun (2019) basin graph (minimum spanning tree of passes).
    BasinGraph,
    /// No routing: pits are local base levels.
    None,
}

/// Base-level height choices.
#[derive(Copy, Clone, PartialEq, Eq, ValueEnum)]
pub enum BaseHeightArg {
    /// Keep the input elevation of the base-level cells.
    Initial,
    /// Set base-level cells to 0.
    Zero,
}

/// The stream-power model options (no input or output: flatten it anywhere).
#[derive(Args, Clone)]
pub struct StreamPowerArgs {
    /// Number of time steps (per level with --levels): `orogen erode --steps`.
    #[arg(skip = 100usize)]
    pub steps: usize,
    /// Time step in years: `orogen erode --dt` (default 1000).
    #[arg(skip = 1000.0)]
    pub dt: f64,
    /// Erodibility K (for n = 1: m^(1-2m)/yr) [default 1e-5].
    #[arg(long = "k")]
    pub k: Option<f64>,
    /// Drainage-area exponent m [default 0.4].
    #[arg(long = "m")]
    pub m: Option<f64>,
    /// Slope exponent n (n != 1 is solved by Newton iteration) [default 1].
    #[arg(long = "n")]
    pub n: Option<f64>,
    /// Uniform uplift rate in m/yr [default 0].
    #[arg(long, conflicts_with = "uplift_map")]
    pub uplift: Option<f64>,
    /// Uplift rate map (m/yr), a raster of the DEM's size.
    #[arg(long)]
    pub uplift_map: Option<PathBuf>,
    /// Hillslope diffusivity Kd in m^2/yr (0 = none): `orogen erode --diffusivity`.
    #[arg(skip = 0.0)]
    pub diffusion: f64,
    /// Depression routing [default fill].
    #[arg(long, value_enum)]
    pub depressions: Option<DepressionsArg>,
    /// Base-level borders: all, none, or a list of north,south,east,west
    /// [default all]. Cells next to nodata are always base levels.
    #[arg(long)]
    pub base_level: Option<String>,
    /// Height of the base-level cells [default initial].
    #[arg(long, value_enum)]
    pub base_height: Option<BaseHeightArg>,
    /// Force the tiled (out-of-core) solve, which is otherwise chosen when the
    /// DEM does not fit in --memory; same result bit for bit.
    #[arg(long)]
    pub tiled: bool,
    /// Scratch folder of the tiled solve (set by `orogen erode --scratch`).
    #[arg(skip)]
    pub scratch: Option<PathBuf>,
    /// Fixed points to keep (constrained erosion): CSV with col,row columns
    /// (orogen's peaks.csv; its saddle_x/saddle_y columns are kept too) or x,y
    /// map coordinates, or GeoJSON (Point, MultiPoint, LineString vertices).
    #[arg(long)]
    pub fixed_points: Option<PathBuf>,
    /// Radius of the compensating uplift around each fixed point, in metres.
    #[arg(long)]
    pub radius: Option<f64>,
    /// Constrained erosion: steps between two compensations.
    #[arg(long, default_value_t = 10)]
    pub compensate_every: usize,
    /// Coarse-to-fine cell sizes in metres, e.g. 100,50,30.
    #[arg(long, value_delimiter = ',')]
    pub levels: Vec<f64>,
    /// Cell size in metres (default: from the georeference).
    #[arg(long)]
    pub cell: Option<f64>,
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
/// stack, area, donors, levels, flags, queue), checked against --memory.
const BYTES_PER_CELL: u64 = 96;

impl StreamPowerArgs {
    /// The library parameters (validated).
    pub fn params(&self) -> Result<StreamPowerParams> {
        let p = StreamPowerParams {
            k: self.k.unwrap_or(1e-5),
            m: self.m.unwrap_or(0.4),
            n: self.n.unwrap_or(1.0),
            dt: self.dt,
            kd: self.diffusion,
            depressions: match self.depressions.unwrap_or(DepressionsArg::Fill) {
                DepressionsArg::Fill => Depressions::Fill,
                DepressionsArg::BasinGraph => Depressions::BasinGraph,
                DepressionsArg::None => Depressions::None,
            },
            boundary: Boundary::parse(self.base_level.as_deref().unwrap_or("all"))
                .context("--base-level")?,
            base_height: match self.base_height.unwrap_or(BaseHeightArg::Initial) {
                BaseHeightArg::Initial => BaseHeight::Initial,
                BaseHeightArg::Zero => BaseHeight::Zero,
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

    /// Fill the options not given on the command line from a `[stream-power]`
    /// parameter table (file, then `--set`, then `--dt`/`--diffusivity`, as
    /// merged by `orogen erode`). Unknown keys are refused with the valid ones.
    pub fn merge_table(&mut self, table: toml::Table, from: &str) -> Result<()> {
        let f: SpTable = toml::Value::Table(table).try_into().map_err(|e| {
            anyhow::anyhow!(
                "stream-power parameters ({from}): {}",
                e.to_string().trim_end()
            )
        })?;
        let pick = |v: Option<String>, key: &str| -> Result<Option<String>> {
            Ok(v.map(|s| s.trim().to_ascii_lowercase()).map(|s| {
                if key == "depressions" {
                    s.replace('_', "-")
                } else {
                    s
                }
            }))
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
            if let Some(d) = pick(f.depressions, "depressions")? {
                self.depressions = Some(DepressionsArg::from_str(&d, true).map_err(|_| {
                    anyhow::anyhow!(
                        "stream-power parameters ({from}): depressions = {d:?}; use fill, basin-graph or none"
                    )
                })?);
            }
        }
        if self.base_height.is_none() {
            if let Some(d) = pick(f.base_height, "base_height")? {
                self.base_height = Some(BaseHeightArg::from_str(&d, true).map_err(|_| {
                    anyhow::anyhow!(
                        "stream-power parameters ({from}): base_height = {d:?}; use initial or zero"
                    )
                })?);
            }
        }
        self.base_level = self.base_level.take().or(f.base_level);
        self.cell = self.cell.or(f.cell);
        self.tiled |= f.tiled.unwrap_or(false);
        Ok(())
    }

    /// Erode `h` (f64, NaN = nodata) with these options; `georef` places the
    /// fixed points given as map coordinates, `cell` is the cell size in metres.
    pub fn erode(&self, h: &Grid<f64>, cell: f64, georef: &GeoRef) -> Result<Grid<f64>> {
        let p = self.params()?;
        let uplift_map = match &self.uplift_map {
            Some(path) => {
                let src = orogen::io::open_raster(path, &Default::default())?;
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
            (Some(f), Some(r)) => Some((read_fixed_points(f, georef, h)?, r)),
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
            Ok(erode_multires(h, cell, &self.levels, |g, c, _| {
                run_level(g, c).map_err(|e| orogen::Error::invalid(format!("{e:#}")))
            })?)
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

/// Most fixed points accepted from a file (the compensation is per point).
const MAX_FIXED_POINTS: usize = 1_000_000;
/// Largest fixed-point file read.
const MAX_FIXED_FILE: u64 = 256 << 20;

/// Read fixed points from CSV or GeoJSON as (column, row) cells of `h`; points
/// outside the DEM or on nodata are skipped with a warning count.
pub fn read_fixed_points(
    path: &Path,
    georef: &GeoRef,
    h: &Grid<f64>,
) -> Result<Vec<(usize, usize)>> {
    let len = std::fs::metadata(path)
        .with_context(|| format!("{}: cannot read the fixed points", path.display()))?
        .len();
    if len > MAX_FIXED_FILE {
        bail!(
            "{}: {} bytes is too large for a fixed-point file (limit {} MiB)",
            path.display(),
            len,
            MAX_FIXED_FILE >> 20
        );
    }
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("{}: cannot read the fixed points", path.display()))?;
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    // Points as fractional (col, row) pixel coordinates.
    let mut px: Vec<(f64, f64)> = Vec::new();
    let to_px = |x: f64, y: f64| -> Result<(f64, f64)> {
        georef.map_to_pixel(x, y).with_context(|| {
            format!(
                "{}: the DEM's georeference cannot place map coordinates",
                path.display()
            )
        })
    };
    if ext == "geojson" || ext == "json" {
        let v: serde_json::Value = serde_json::from_str(&text)
            .with_context(|| format!("{}: not valid JSON", path.display()))?;
        let mut coords = Vec::new();
        collect_geojson(&v, &mut coords, 0);
        for (x, y) in coords {
            px.push(to_px(x, y)?);
        }
    } else if ext == "csv" {
        let mut lines = text.lines();
        let header: Vec<String> = lines
            .next()
            .with_context(|| format!("{}: empty CSV", path.display()))?
            .split(',')
            .map(|s| s.trim().to_ascii_lowercase())
            .collect();
        let col = |n: &str| header.iter().position(|h| h == n);
        let pairs: Vec<(usize, usize, bool)> = if let (Some(c), Some(r)) = (col("col"), col("row"))
        {
            let mut v = vec![(c, r, true)];
            for (sx, sy) in [("saddle_x", "saddle_y"), ("saddle_lon", "saddle_lat")] {
                if let (Some(a), Some(b)) = (col(sx), col(sy)) {
                    v.push((a, b, false));
                }
            }
            v
        } else if let (Some(a), Some(b)) = (col("x"), col("y")) {
            vec![(a, b, false)]
        } else if let (Some(a), Some(b)) = (col("lon"), col("lat")) {
            vec![(a, b, false)]
        } else {
            bail!(
                "{}: the CSV needs col,row columns (0-based cells) or x,y (or lon,lat) map coordinates",
                path.display()
            );
        };
        for (ln, line) in lines.enumerate() {
            if line.trim().is_empty() {
                continue;
            }
            let f: Vec<&str> = line.split(',').collect();
            for &(a, b, cells) in &pairs {
                let (sa, sb) = (
                    f.get(a).map(|s| s.trim()).unwrap_or(""),
                    f.get(b).map(|s| s.trim()).unwrap_or(""),
                );
                if sa.is_empty() && sb.is_empty() && !cells {
                    continue; // a peak without key saddle
                }
                let parse = |s: &str| -> Result<f64> {
                    s.parse::<f64>().with_context(|| {
                        format!("{} line {}: {s:?} is not a number", path.display(), ln + 2)
                    })
                };
                let (va, vb) = (parse(sa)?, parse(sb)?);
                if cells {
                    px.push((va + 0.5, vb + 0.5));
                } else {
                    px.push(to_px(va, vb)?);
                }
            }
            if px.len() > MAX_FIXED_POINTS {
                bail!(
                    "{}: more than {MAX_FIXED_POINTS} fixed points",
                    path.display()
                );
            }
        }
    } else {
        bail!(
            "{}: fixed points must be a .csv or .geojson file",
            path.display()
        );
    }
    let mut out = Vec::new();
    let mut skipped = 0usize;
    for (fx, fy) in px {
        if !(fx.is_finite() && fy.is_finite()) || fx < 0.0 || fy < 0.0 {
            skipped += 1;
            continue;
        }
        let (x, y) = (fx.floor() as usize, fy.floor() as usize);
        if x >= h.width() || y >= h.height() || !h.get(x, y).is_finite() {
            skipped += 1;
            continue;
        }
        out.push((x, y));
    }
    if out.len() > MAX_FIXED_POINTS {
        bail!(
            "{}: more than {MAX_FIXED_POINTS} fixed points",
            path.display()
        );
    }
    out.sort_unstable();
    out.dedup();
    if skipped > 0 {
        eprintln!(
            "warning: {}: {skipped} fixed point(s) outside the DEM or on nodata were skipped",
            path.display()
        );
    }
    if out.is_empty() {
        bail!("{}: no fixed point falls on the DEM", path.display());
    }
    Ok(out)
}

/// Gather every coordinate pair of Points, MultiPoints and LineStrings.
fn collect_geojson(v: &serde_json::Value, out: &mut Vec<(f64, f64)>, depth: usize) {
    if depth > 8 || out.len() > MAX_FIXED_POINTS {
        return;
    }
    let pair = |c: &serde_json::Value| -> Option<(f64, f64)> {
        let a = c.as_array()?;
        Some((a.first()?.as_f64()?, a.get(1)?.as_f64()?))
    };
    match v.get("type").and_then(|t| t.as_str()) {
        Some("FeatureCollection") => {
            if let Some(fs) = v.get("features").and_then(|f| f.as_array()) {
                for f in fs {
                    collect_geojson(f, out, depth + 1);
                }
            }
        }
        Some("Feature") => {
            if let Some(g) = v.get("geometry") {
                collect_geojson(g, out, depth + 1);
            }
        }
        Some("Point") => {
            if let Some(p) = v.get("coordinates").and_then(pair) {
                out.push(p);
            }
        }
        Some("MultiPoint") | Some("LineString") => {
            if let Some(cs) = v.get("coordinates").and_then(|c| c.as_array()) {
                out.extend(cs.iter().filter_map(pair));
            }
        }
        _ => {}
    }
}

/// Read, erode, write.
pub fn run(
    input: &crate::In,
    model: &StreamPowerArgs,
    out: &crate::Out,
    run: &crate::Run,
) -> Result<()> {
    struct A<'a> {
        input: &'a crate::In,
        model: &'a StreamPowerArgs,
        out: &'a crate::Out,
        run: &'a crate::Run,
    }
    let a = A {
        input,
        model,
        out,
        run,
    };
    a.model.params()?;
    let cfg = crate::engine(a.run)?;
    let src = crate::open(a.input)?;
    let oo = crate::output_options(&a.out.fmt)?;
    let info = src.info().clone();
    let need = info.width as u64 * info.height as u64 * BYTES_PER_CELL;
    let tiled = a.model.tiled || need > cfg.memory_budget;
    if tiled {
        if !a.model.levels.is_empty() || a.model.fixed_points.is_some() {
            bail!(
                "{}: --levels and --fixed-points run in memory only ({}); raise --memory (about {:.1} GiB) or drop them",
                a.input.input.display(),
                if a.model.tiled { "--tiled was given" } else { "the DEM does not fit in --memory" },
                need as f64 / (1u64 << 30) as f64
            );
        }
        if a.model.depressions == Some(DepressionsArg::BasinGraph) {
            bail!(
                "{}: --depressions basin-graph runs in memory only ({}); use --depressions fill or none, or raise --memory (about {:.1} GiB)",
                a.input.input.display(),
                if a.model.tiled { "--tiled was given" } else { "the DEM does not fit in --memory" },
                need as f64 / (1u64 << 30) as f64
            );
        }
    } else if a.model.scratch.is_some() {
        bail!("--scratch applies to the tiled stream-power solve only (give --tiled, or a DEM larger than --memory)");
    }
    let cell = match a.model.cell {
        Some(c) => {
            if !(c.is_finite() && c > 0.0) {
                bail!("--cell {c}: give a cell size in metres > 0");
            }
            c
        }
        None => {
            let (cx, cy) = info.georef.cell_size_m(info.height as i64 / 2);
            if (cx - cy).abs() > 0.01 * cx.max(cy) {
                eprintln!(
                    "warning: {}: cells are {cx:.2} x {cy:.2} m; the solver uses square cells of {:.2} m (pass --cell to choose)",
                    a.input.input.display(),
                    0.5 * (cx + cy)
                );
            }
            0.5 * (cx + cy)
        }
    };
    if tiled {
        return run_tiled(a.model, src.as_ref(), cell, a.out, a.run, &oo, &cfg);
    }
    let dem = read_window::<f64>(src.as_ref(), Window::full(info.width, info.height))?;
    let out = a
        .model
        .erode(&dem, cell, &info.georef)
        .with_context(|| format!("{}", a.input.input.display()))?;
    // Output nodata: −9999 unless the eroded surface may reach it
    // (bathymetry), then a customary value below it (`hydro::out_nodata`'s
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
    let bound = sp_lower_bound(input_min, None, a.model, a.model.params()?.dt)?;
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
    orogen::ops::convert(&mem, &a.out.output, &oo, a.run.tile, &cfg)?;
    crate::wrote(&a.out.output);
    Ok(())
}

/// The tiled (out-of-core) solve, written tile by tile to the output.
fn run_tiled(
    model: &StreamPowerArgs,
    src: &dyn orogen::raster::RasterSource,
    cell: f64,
    out: &crate::Out,
    run: &crate::Run,
    oo: &orogen::io::OutputOptions,
    cfg: &orogen::exec::EngineConfig,
) -> Result<()> {
    use orogen::erosion::stream_power_tiled::{
        stream_power_tiled, SpBackend, TiledUplift, TILE_BYTES_PER_CELL,
    };
    let p = model.params()?;
    let info = src.info().clone();
    let t0 = std::time::Instant::now();
    let layout = orogen::ops::choose_layout(src, std::slice::from_ref(&out.output), oo, run.tile);
    let map_src = match &model.uplift_map {
        Some(path) => Some(orogen::io::open_raster(path, &Default::default())?),
        None => None,
    };
    let uplift = match &map_src {
        Some(m) => TiledUplift::Map(m.as_ref()),
        None => TiledUplift::Uniform(model.uplift_rate()),
    };
    let cells = info.width as u64 * info.height as u64;
    let (backend, cleanup) = match &model.scratch {
        None if cells.saturating_mul(TILE_BYTES_PER_CELL) <= cfg.memory_budget / 2 => {
            (SpBackend::Memory, None)
        }
        Some(d) => {
            let dir = d.join("orogen-sp-scratch");
            (SpBackend::Disk(dir.clone()), Some(dir))
        }
        None => {
            let name = out
                .output
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_else(|| "erosion".into());
            let dir = out.output.with_file_name(format!(".{name}.sp-scratch"));
            (SpBackend::Disk(dir.clone()), Some(dir))
        }
    };
    let nd = tiled_nodata(src, map_src.as_deref(), model, p.dt)?;
    let georef = info.georef.clone().with_nodata(Some(nd));
    let prov = orogen::store::Provenance::new(
        "erode-stream-power",
        serde_json::json!({
            "model": "stream-power", "k": p.k, "m": p.m, "n": p.n, "dt": p.dt, "kd": p.kd,
            "steps": model.steps, "uplift": model.uplift_rate(),
            "uplift_map": model.uplift_map.as_ref().map(|p| p.display().to_string()),
            "depressions": format!("{:?}", p.depressions), "cell": cell,
        }),
        vec![info.path.display().to_string()],
    );
    let mut sink = orogen::io::create_sink(
        &out.output,
        info.width,
        info.height,
        orogen::raster::DType::F32,
        &georef,
        oo,
        prov,
    )?;
    let result = stream_power_tiled(
        src,
        cell,
        &p,
        &uplift,
        model.steps,
        layout.tile,
        &backend,
        |id, win, g| {
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
                return Err(orogen::Error::invalid(format!(
                    "tile {id}: an eroded elevation ({low}) reaches the output nodata ({nd}) chosen from the input's minimum; this is a bug, please report it"
                )));
            }
            sink.write(id, win, AnyGrid::F32(g))
        },
    );
    if let Some(dir) = &cleanup {
        if let Err(e) = std::fs::remove_dir_all(dir) {
            if e.kind() != std::io::ErrorKind::NotFound {
                eprintln!(
                    "warning: {}: cannot remove the scratch folder: {e}",
                    dir.display()
                );
            }
        }
    }
    let stats = result.with_context(|| format!("{}", info.path.display()))?;
    sink.finish()?;
    if !run.quiet {
        eprintln!(
            "erode: stream power (tiled, {}-cell tiles, {}) on {}x{} cells, {} steps, {} tile passes (longest round {}), {:.1} s",
            layout.tile,
            if cleanup.is_some() { "scratch files" } else { "in memory" },
            info.width,
            info.height,
            model.steps,
            stats.passes,
            stats.max_round,
            t0.elapsed().as_secs_f64()
        );
    }
    crate::wrote(&out.output);
    Ok(())
}

/// Output nodata of the tiled solve, fixed before the first tile is written:
/// the rule of `hydro::out_nodata` (−9999 unless the data come within 1 m of
/// it, then a customary value below them) applied to [`sp_lower_bound`].
/// One read pass over the input (and the uplift map).
fn tiled_nodata(
    src: &dyn orogen::raster::RasterSource,
    map: Option<&dyn orogen::raster::RasterSource>,
    model: &StreamPowerArgs,
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
/// (U: `--uplift`, or the minimum of `--uplift-map`, opened here unless
/// `map` is given). None without valid input cells.
fn sp_lower_bound(
    input_min: Option<f32>,
    map: Option<&dyn orogen::raster::RasterSource>,
    model: &StreamPowerArgs,
    dt: f64,
) -> Result<Option<f32>> {
    let Some(lo) = input_min else {
        return Ok(None);
    };
    let u_min = match (map, &model.uplift_map) {
        (Some(m), _) => valid_range(m)?.map_or(0.0, |r| r.0 as f64),
        (None, Some(path)) => {
            let m = orogen::io::open_raster(path, &Default::default())?;
            valid_range(m.as_ref())?.map_or(0.0, |r| r.0 as f64)
        }
        (None, None) => model.uplift_rate(),
    };
    let steps = model.steps as f64 * model.levels.len().max(1) as f64;
    Ok(Some((lo as f64 + steps * dt * u_min.min(0.0)) as f32))
}
