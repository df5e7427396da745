//! `erode`: the erosion models as one operation. Hydraulic (virtual pipes),
//! thermal (talus) and diffusion run over tiles with halo exchange
//! (`erosion::tiled`, bit-identical to an untiled run for any tile size);
//! stream power with uplift (Braun & Willett 2013) runs in memory or tiled
//! ([`stream_power`]). Model parameters come from a TOML file (`params`, one
//! table per model), `set` (`KEY=VALUE`) and a few named options, in that
//! order of precedence (later wins); unknown keys are rejected with the list
//! of valid ones.
//!
//! ```
//! use orogen::exec::EngineConfig;
//! use orogen::ops::erode::{self, ErodeOptions, Model};
//! use orogen::ops::synth::noise::{self, NoiseOptions};
//! let dir = std::env::temp_dir().join(format!("orogen-doc-erode-{}", std::process::id()));
//! std::fs::create_dir_all(&dir)?;
//! let cfg = EngineConfig { threads: 1, ..Default::default() };
//! let dem = dir.join("dem.tif");
//! let terrain = NoiseOptions { size: "64".into(), output: dem.clone(), ..Default::default() };
//! noise::run(&terrain, &Default::default(), &cfg, &mut |_| {})?;
//! let opts = ErodeOptions {
//!     input: dem.clone(),
//!     model: Model::Thermal,
//!     steps: Some(20),
//!     output: dir.join("eroded.tif"),
//!     ..Default::default()
//! };
//! let mut wrote = vec![];
//! erode::run(&opts, &Default::default(), &Default::default(), &cfg, &mut |n| wrote.push(n))?;
//! assert!(wrote.contains(&orogen::ops::note::Note::Wrote(opts.output.clone())));
//! // Talus slumping moves material downhill: the highest cell never rises.
//! let max = |p: &std::path::Path| -> orogen::Result<f32> {
//!     let src = orogen::io::open_raster(p, &Default::default())?;
//!     let g = orogen::raster::read_window::<f32>(src.as_ref(), orogen::raster::Window::full(64, 64))?;
//!     Ok(g.data().iter().copied().fold(f32::MIN, f32::max))
//! };
//! assert!(max(&opts.output)? <= max(&dem)?);
//! std::fs::remove_dir_all(&dir)?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod points;
pub mod stream_power;

use crate::erosion::tiled::erode_to_paths;
use crate::erosion::{
    CellSize, Diffusion, DiffusionParams, Hydraulic, HydraulicParams, LocalModel, Thermal,
    ThermalParams,
};
use crate::error::{Error, Result};
use crate::exec::EngineConfig;
use crate::io::{OpenOptions, OutputOptions};
use crate::ops::note::{bail, open_input, preview, Note, Notify};
use crate::raster::RasterSource;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;
pub use stream_power::{BaseLevelHeight, DepressionRouting, StreamPowerOptions};

/// The erosion model.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Model {
    /// Virtual-pipe water flow, sediment capacity, erosion/deposition (Mei et al. 2007).
    #[default]
    Hydraulic,
    /// Talus slumping (Musgrave, Kolb & Mace 1989).
    Thermal,
    /// Linear hillslope diffusion, explicit and CFL-stable.
    Diffusion,
    /// Stream power with uplift, implicit (Braun & Willett 2013).
    StreamPower,
}

impl Model {
    /// The model's name in parameter files and messages.
    pub fn key(self) -> &'static str {
        match self {
            Model::Hydraulic => "hydraulic",
            Model::Thermal => "thermal",
            Model::Diffusion => "diffusion",
            Model::StreamPower => "stream-power",
        }
    }
}

/// Options of `erode` (the CLI's names; `None` = the model's default).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields, default)]
pub struct ErodeOptions {
    /// Input DEM.
    pub input: PathBuf,
    /// Erosion model.
    pub model: Model,
    /// Number of steps (overrides `steps` in `params`).
    pub steps: Option<u64>,
    /// TOML parameter file: optional top-level `steps` and `exchange`, and one
    /// table per model.
    pub params: Option<PathBuf>,
    /// Model parameters as `KEY=VALUE` (TOML values), after `params`.
    pub set: Vec<String>,
    /// Seed of the rain pattern (hydraulic).
    pub seed: Option<u64>,
    /// Time step: seconds (hydraulic) or years (diffusion, stream power).
    pub dt: Option<f64>,
    /// Talus angle in degrees (thermal).
    pub talus: Option<f64>,
    /// Diffusivity in m²/yr (diffusion, stream power).
    pub diffusivity: Option<f64>,
    /// Substeps between halo exchanges (default [`DEFAULT_EXCHANGE`]).
    pub exchange: Option<usize>,
    /// Also write the final water depth (hydraulic).
    pub water: Option<PathBuf>,
    /// Also write the final suspended sediment (hydraulic).
    pub sediment: Option<PathBuf>,
    /// Write before.png and after.png previews into this folder.
    pub preview: Option<PathBuf>,
    /// Scratch folder for tile states between exchanges (or of the tiled
    /// stream-power solve).
    pub scratch: Option<PathBuf>,
    /// Stream power: erodibility K [default 1e-5].
    pub k: Option<f64>,
    /// Stream power: drainage-area exponent m [default 0.4].
    pub m: Option<f64>,
    /// Stream power: slope exponent n [default 1].
    pub n: Option<f64>,
    /// Stream power: uniform uplift rate in m/yr [default 0].
    pub uplift: Option<f64>,
    /// Stream power: uplift rate map (m/yr) of the DEM's size.
    pub uplift_map: Option<PathBuf>,
    /// Stream power: depression routing [default fill].
    pub depressions: Option<DepressionRouting>,
    /// Stream power: base-level borders (all, none, or north,south,east,west).
    pub base_level: Option<String>,
    /// Stream power: height of the base-level cells [default initial].
    pub base_height: Option<BaseLevelHeight>,
    /// Stream power: force the tiled (out-of-core) solve.
    pub tiled: bool,
    /// Stream power: fixed points to keep (CSV or GeoJSON).
    pub fixed_points: Option<PathBuf>,
    /// Stream power: radius of the compensating uplift (metres).
    pub radius: Option<f64>,
    /// Stream power: steps between two compensations.
    pub compensate_every: usize,
    /// Stream power: coarse-to-fine cell sizes in metres.
    pub levels: Vec<f64>,
    /// Stream power: cell size in metres (default: from the georeference).
    pub cell: Option<f64>,
    /// Output raster (.tif, .tiles, .png, .asc).
    pub output: PathBuf,
    /// Work-tile size in cells (default: the input store's, else 1024).
    pub tile: Option<usize>,
}

impl Default for ErodeOptions {
    fn default() -> Self {
        ErodeOptions {
            input: PathBuf::new(),
            model: Model::default(),
            steps: None,
            params: None,
            set: vec![],
            seed: None,
            dt: None,
            talus: None,
            diffusivity: None,
            exchange: None,
            water: None,
            sediment: None,
            preview: None,
            scratch: None,
            k: None,
            m: None,
            n: None,
            uplift: None,
            uplift_map: None,
            depressions: None,
            base_level: None,
            base_height: None,
            tiled: false,
            fixed_points: None,
            radius: None,
            compensate_every: 10,
            levels: vec![],
            cell: None,
            output: PathBuf::new(),
            tile: None,
        }
    }
}

impl ErodeOptions {
    /// The stream-power options given here (before the parameter tables).
    pub fn stream_power(&self) -> StreamPowerOptions {
        StreamPowerOptions {
            k: self.k,
            m: self.m,
            n: self.n,
            uplift: self.uplift,
            uplift_map: self.uplift_map.clone(),
            depressions: self.depressions,
            base_level: self.base_level.clone(),
            base_height: self.base_height,
            tiled: self.tiled,
            scratch: self.scratch.clone(),
            fixed_points: self.fixed_points.clone(),
            radius: self.radius,
            compensate_every: self.compensate_every,
            levels: self.levels.clone(),
            cell: self.cell,
            ..StreamPowerOptions::default()
        }
    }
}

/// Top-level keys of a parameter file.
const FILE_KEYS: [&str; 6] = [
    "steps",
    "exchange",
    "hydraulic",
    "thermal",
    "diffusion",
    "stream-power",
];

/// Default substeps between exchanges.
pub const DEFAULT_EXCHANGE: usize = 8;

/// The parameter table, the steps and the substeps between exchanges of
/// `a` (its parameter file, `set` and named options), checked.
fn settings(a: &ErodeOptions) -> Result<(toml::Table, u64, usize)> {
    let (table, file_steps, file_exchange) = gather(a)?;
    let Some(steps) = a.steps.or(file_steps) else {
        bail!("give the number of steps with --steps N (or `steps` in --params)");
    };
    let exchange = a.exchange.or(file_exchange).unwrap_or(DEFAULT_EXCHANGE);
    if exchange == 0 {
        bail!("--exchange 0: give at least 1 substep between halo exchanges");
    }
    Ok((table, steps, exchange))
}

impl ErodeOptions {
    /// Check what can be checked before the input is read: the parameter
    /// file, the `set` values, the steps and the exchange.
    pub fn validate(&self) -> Result<()> {
        settings(self).map(|_| ())
    }
}

/// Run `erode`: read `opts.input`, erode it with `opts.model`, write
/// `opts.output` (and the extra outputs and previews asked for).
/// Parameters are checked before the input is opened.
pub fn run(
    opts: &ErodeOptions,
    open: &OpenOptions,
    oo: &OutputOptions,
    cfg: &EngineConfig,
    notify: Notify<'_>,
) -> Result<()> {
    check(opts)?;
    let src = open_input(&opts.input, open, &mut *notify)?;
    run_on(opts, src.as_ref(), oo, cfg, notify)
}

/// Check `opts` without reading any input: the parameter file, `set`, the
/// steps and exchange, and the chosen model's parameters (what [`run`]
/// refuses before it opens the input).
pub fn check(opts: &ErodeOptions) -> Result<()> {
    let (table, steps, _) = settings(opts)?;
    match opts.model {
        Model::Hydraulic => {
            let p: HydraulicParams = parse_params(opts, table)?;
            Hydraulic::new(p, steps, CellSize::square(1.0)).map(|_| ())
        }
        Model::Thermal => {
            let p: ThermalParams = parse_params(opts, table)?;
            Thermal::new(p, steps, CellSize::square(1.0)).map(|_| ())
        }
        Model::Diffusion => {
            let p: DiffusionParams = parse_params(opts, table)?;
            DiffusionParams::validate(&p)?;
            crate::erosion::check_steps(steps)
        }
        Model::StreamPower => Run::stream_power_options(opts, table, steps).map(|_| ()),
    }
}

/// [`run`] on an opened input `src` (`opts.input` is not read; an array
/// from the Python package, say): erode it and write `opts.output` (and
/// the extra outputs and previews asked for).
pub fn run_on(
    opts: &ErodeOptions,
    src: &dyn RasterSource,
    oo: &OutputOptions,
    cfg: &EngineConfig,
    notify: Notify<'_>,
) -> Result<()> {
    let a = opts;
    let (table, steps, exchange) = settings(a)?;
    let run = Run {
        a,
        oo,
        cfg,
        exchange,
    };
    match a.model {
        Model::Hydraulic => {
            let p: HydraulicParams = parse_params(a, table)?;
            let has_cell = p.cell.is_some();
            let model = Hydraulic::new(p, steps, cell_of(src, has_cell)?)?;
            run.local(&model, src, notify)
        }
        Model::Thermal => {
            let p: ThermalParams = parse_params(a, table)?;
            let has_cell = p.cell.is_some();
            let model = Thermal::new(p, steps, cell_of(src, has_cell)?)?;
            run.local(&model, src, notify)
        }
        Model::Diffusion => {
            let p: DiffusionParams = parse_params(a, table)?;
            DiffusionParams::validate(&p)?;
            crate::erosion::check_steps(steps)?;
            let has_cell = p.cell.is_some();
            let model = Diffusion::new(p, steps, cell_of(src, has_cell)?)?;
            run.local(&model, src, notify)
        }
        Model::StreamPower => run.stream_power(src, table, steps, notify),
    }
}

/// What every model's run needs besides the model.
struct Run<'a> {
    a: &'a ErodeOptions,
    oo: &'a OutputOptions,
    cfg: &'a EngineConfig,
    exchange: usize,
}

impl Run<'_> {
    /// A local model over tiles with halo exchange.
    fn local<M: LocalModel>(
        &self,
        model: &M,
        src: &dyn RasterSource,
        notify: Notify<'_>,
    ) -> Result<()> {
        let a = self.a;
        let mut outputs = vec![(0usize, a.output.clone())];
        let extra = [
            (&a.water, crate::erosion::hydraulic::WATER, "--water"),
            (
                &a.sediment,
                crate::erosion::hydraulic::SEDIMENT,
                "--sediment",
            ),
        ];
        for (p, f, name) in extra {
            if let Some(p) = p {
                if a.model != Model::Hydraulic {
                    bail!("{name} applies to --model hydraulic only");
                }
                outputs.push((f, p.clone()));
            }
        }
        if let Some(dir) = &a.preview {
            create_preview_dir(dir)?;
            preview(
                src,
                &dir.join("before.png"),
                &Default::default(),
                &mut *notify,
            )?;
        }
        let t0 = std::time::Instant::now();
        let (stats, layout) = erode_to_paths(
            model,
            src,
            &outputs,
            self.oo,
            a.tile,
            self.exchange,
            a.scratch.as_deref(),
            self.cfg,
        )?;
        notify(Note::Info(format!(
            "erode: {} on {}x{} cells, {} substeps in {} exchanges ({}-cell tiles, ghost {} cells), {:.1} s",
            model.name(),
            layout.width,
            layout.height,
            stats.substeps,
            stats.rounds,
            layout.tile,
            stats.ghost,
            t0.elapsed().as_secs_f64()
        )));
        for (_, p) in &outputs {
            notify(Note::Wrote(p.clone()));
        }
        self.after_preview(notify)
    }

    /// The stream-power options of `a`: its named options over the
    /// `[stream-power]` table, checked.
    fn stream_power_options(
        a: &ErodeOptions,
        table: toml::Table,
        steps: u64,
    ) -> Result<StreamPowerOptions> {
        let local_only = [
            (a.exchange.is_some(), "--exchange"),
            (a.water.is_some(), "--water"),
            (a.sediment.is_some(), "--sediment"),
        ];
        for (given, flag) in local_only {
            if given {
                bail!("{flag} applies to the hydraulic, thermal and diffusion models, not to stream power");
            }
        }
        let mut sp = a.stream_power();
        sp.steps = usize::try_from(steps)
            .map_err(|e| Error::invalid(format!("--steps is too large: {e}")))?;
        let from = match &a.params {
            Some(p) => format!("[stream-power] of {} and --set", p.display()),
            None => "--set".to_string(),
        };
        sp.merge_table(table, &from)?;
        sp.params()?;
        Ok(sp)
    }

    /// Stream power, in memory or tiled. Parameters: the `[stream-power]`
    /// table of `params`, then `set`, then `dt`/`diffusivity` (merged in
    /// `table` by [`gather`]), then the stream-power options, which win.
    fn stream_power(
        &self,
        src: &dyn RasterSource,
        table: toml::Table,
        steps: u64,
        notify: Notify<'_>,
    ) -> Result<()> {
        let a = self.a;
        let sp = Self::stream_power_options(a, table, steps)?;
        if let Some(dir) = &a.preview {
            create_preview_dir(dir)?;
            preview(
                src,
                &dir.join("before.png"),
                &Default::default(),
                &mut *notify,
            )?;
        }
        stream_power::run(
            &src.info().path,
            src,
            &sp,
            &a.output,
            self.oo,
            a.tile,
            self.cfg,
            &mut *notify,
        )?;
        self.after_preview(notify)
    }

    /// `after.png` of the written output.
    fn after_preview(&self, notify: Notify<'_>) -> Result<()> {
        if let Some(dir) = &self.a.preview {
            let out = crate::io::open_raster(&self.a.output, &OpenOptions::default())?;
            preview(
                out.as_ref(),
                &dir.join("after.png"),
                &Default::default(),
                notify,
            )?;
        }
        Ok(())
    }
}

fn create_preview_dir(dir: &std::path::Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| {
        Error::invalid(format!(
            "{}: cannot create the preview folder: {e}",
            dir.display()
        ))
    })
}

/// The parameter table of the model merged from the file, `set` and the
/// named options, plus the file's `steps` and `exchange`.
fn gather(a: &ErodeOptions) -> Result<(toml::Table, Option<u64>, Option<usize>)> {
    let mut table = toml::Table::new();
    let (mut steps, mut exchange) = (None, None);
    if let Some(path) = &a.params {
        let text = std::fs::read_to_string(path).map_err(|e| {
            Error::invalid(format!(
                "{}: cannot read the parameter file: {e}",
                path.display()
            ))
        })?;
        let file: toml::Table = toml::from_str(&text).map_err(|e| {
            Error::invalid(format!("{}: {}", path.display(), e.to_string().trim_end()))
        })?;
        for (k, v) in file {
            match k.as_str() {
                "steps" => {
                    let Some(n) = v.as_integer().filter(|n| *n >= 0) else {
                        bail!("{}: steps must be a whole number", path.display());
                    };
                    steps = Some(n as u64);
                }
                "exchange" => {
                    let Some(n) = v.as_integer().filter(|n| *n >= 1) else {
                        bail!("{}: exchange must be a whole number >= 1", path.display());
                    };
                    exchange = Some(n as usize);
                }
                m if m == a.model.key() => match v {
                    toml::Value::Table(t) => table = t,
                    _ => bail!("{}: [{m}] must be a table of parameters", path.display()),
                },
                m if FILE_KEYS.contains(&m) => {}
                other => bail!(
                    "{}: unknown key `{other}`; valid top-level keys: {}",
                    path.display(),
                    FILE_KEYS.join(", ")
                ),
            }
        }
    }
    for kv in &a.set {
        let Some((k, v)) = kv.split_once('=') else {
            bail!("--set {kv:?}: expected KEY=VALUE, e.g. --set rain=0.02");
        };
        let (k, v) = (k.trim(), v.trim());
        let value = toml::from_str::<toml::Table>(&format!("v = {v}"))
            .ok()
            .and_then(|mut t| t.remove("v"))
            .unwrap_or_else(|| toml::Value::String(v.to_string()));
        table.insert(k.to_string(), value);
    }
    let flag = |table: &mut toml::Table, name: &str, ok: bool, v: toml::Value| -> Result<()> {
        if !ok {
            bail!(
                "--{name} does not apply to --model {} (see orogen erode --help)",
                a.model.key()
            );
        }
        table.insert(name.to_string(), v);
        Ok(())
    };
    use Model::*;
    if let Some(s) = a.seed {
        let s = i64::try_from(s)
            .map_err(|e| Error::invalid(format!("--seed: at most 9223372036854775807: {e}")))?;
        flag(
            &mut table,
            "seed",
            a.model == Hydraulic,
            toml::Value::Integer(s),
        )?;
    }
    if let Some(v) = a.dt {
        flag(&mut table, "dt", a.model != Thermal, toml::Value::Float(v))?;
    }
    if let Some(v) = a.talus {
        flag(
            &mut table,
            "talus",
            a.model == Thermal,
            toml::Value::Float(v),
        )?;
    }
    if let Some(v) = a.diffusivity {
        flag(
            &mut table,
            "diffusivity",
            a.model == Diffusion || a.model == StreamPower,
            toml::Value::Float(v),
        )?;
    }
    Ok((table, steps, exchange))
}

/// Deserialize a model's table; the error names the source of the values and
/// lists the valid keys (serde's unknown-field message).
fn parse_params<T: serde::de::DeserializeOwned>(a: &ErodeOptions, table: toml::Table) -> Result<T> {
    let model = a.model;
    let from = match &a.params {
        Some(p) => format!("[{}] of {} and --set", model.key(), p.display()),
        None => "--set".to_string(),
    };
    toml::Value::Table(table).try_into::<T>().map_err(|e| {
        Error::invalid(format!(
            "{} parameters ({from}): {}",
            model.key(),
            e.to_string().trim_end()
        ))
    })
}

fn cell_of(src: &dyn RasterSource, has_cell: bool) -> Result<CellSize> {
    if has_cell {
        // Overridden by the `cell` parameter; any valid placeholder.
        return Ok(CellSize::square(1.0));
    }
    CellSize::of(src.info())
}
