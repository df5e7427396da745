//! `orogen erode`: local erosion models (hydraulic, thermal, diffusion) over
//! tiles with halo exchange (see `orogen::erosion`). Model parameters come
//! from a TOML file (`--params`, one table per model), `--set KEY=VALUE` and a
//! few named flags, in that order of precedence (later wins); unknown keys are
//! rejected with the list of valid ones.
//!
//! Under `--engine mpi` the hydraulic, thermal and diffusion models run
//! distributed (each rank its tiles, ghost zones exchanged point to point,
//! rank 0 writes; `erosion::tiled::run_ranked`); stream power does not: every
//! rank runs the whole solve (same bytes, no speed-up) and rank 0 writes.

use crate::{engine, open, output_options, wrote, In, Out, Run};
use anyhow::{bail, Context, Result};
use clap::{Args, ValueEnum};
use orogen::erosion::tiled::erode_to_paths;
use orogen::erosion::{
    CellSize, Diffusion, DiffusionParams, Hydraulic, HydraulicParams, LocalModel, Thermal,
    ThermalParams,
};
use std::path::PathBuf;

/// The erosion model.
#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum ModelArg {
    /// Virtual-pipe water flow, sediment capacity, erosion/deposition (Mei et al. 2007).
    Hydraulic,
    /// Talus slumping (Musgrave, Kolb & Mace 1989).
    Thermal,
    /// Linear hillslope diffusion, explicit and CFL-stable.
    Diffusion,
    /// Stream power with uplift, implicit (Braun & Willett 2013); in memory. Under
    /// --engine mpi every rank runs the whole solve (not distributed).
    StreamPower,
}

impl ModelArg {
    fn key(self) -> &'static str {
        match self {
            ModelArg::Hydraulic => "hydraulic",
            ModelArg::Thermal => "thermal",
            ModelArg::Diffusion => "diffusion",
            ModelArg::StreamPower => "stream-power",
        }
    }
}

/// Arguments of `orogen erode`.
#[derive(Args)]
pub struct ErodeArgs {
    #[command(flatten)]
    pub input: In,
    /// Erosion model.
    #[arg(long, value_enum)]
    pub model: ModelArg,
    /// Number of steps (hydraulic/thermal: iterations of dt; diffusion: steps of dt years,
    /// each cut into CFL-stable substeps). Overrides `steps` in --params.
    #[arg(long)]
    pub steps: Option<u64>,
    /// TOML parameter file: optional top-level `steps` and `exchange`, and one table per
    /// model ([hydraulic], [thermal], [diffusion], [stream-power]); see
    /// configs/erosion-hydraulic.toml and configs/erosion-stream-power.toml.
    #[arg(long, value_name = "FILE")]
    pub params: Option<PathBuf>,
    /// Set a model parameter (repeatable), e.g. --set rain=0.02 --set settle=false.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Seed of the rain pattern (hydraulic).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Time step: seconds (hydraulic) or years (diffusion).
    #[arg(long, allow_negative_numbers = true)]
    pub dt: Option<f64>,
    /// Talus angle in degrees, 0 < talus < 90 (thermal).
    #[arg(long, allow_negative_numbers = true)]
    pub talus: Option<f64>,
    /// Diffusivity in m²/yr (diffusion).
    #[arg(long, allow_negative_numbers = true)]
    pub diffusivity: Option<f64>,
    /// Substeps between halo exchanges; the ghost zone is exchange x radius cells
    /// (default 8, or `exchange` in --params). Does not change the result.
    #[arg(long)]
    pub exchange: Option<usize>,
    /// Also write the final water depth (hydraulic), f32 metres.
    #[arg(long, value_name = "OUT")]
    pub water: Option<PathBuf>,
    /// Also write the final suspended sediment (hydraulic, with --set settle=false), f32 metres.
    #[arg(long, value_name = "OUT")]
    pub sediment: Option<PathBuf>,
    /// Write hillshaded previews of the input and the result (before.png, after.png) into DIR.
    #[arg(long, value_name = "DIR")]
    pub preview: Option<PathBuf>,
    /// Keep tile states between exchanges in a scratch folder inside DIR (default: in
    /// memory when two copies fit in half of --memory, else next to the output).
    #[arg(long, value_name = "DIR")]
    pub scratch: Option<PathBuf>,
    /// Stream-power options (--model stream-power).
    #[command(flatten)]
    pub sp: Box<crate::cli::erode_sp::StreamPowerArgs>,
    #[command(flatten)]
    pub out: Out,
    #[command(flatten)]
    pub run: Run,
}

/// `--model stream-power`: the implicit solver, in memory or tiled (out of core).
/// Parameters: the `[stream-power]` table of `--params`, then `--set`, then
/// `--dt`/`--diffusivity` (merged in `table` by [`gather`]), then the
/// stream-power flags (`--k`, `--m`, ...), which win.
fn run_stream_power(mut a: ErodeArgs, table: toml::Table, steps: u64) -> Result<()> {
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
    a.sp.steps = usize::try_from(steps).context("--steps is too large")?;
    let from = match &a.params {
        Some(p) => format!("[stream-power] of {} and --set", p.display()),
        None => "--set".to_string(),
    };
    a.sp.merge_table(table, &from)?;
    a.sp.scratch = a.scratch.clone();
    if let Some(dir) = &a.preview {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("{}: cannot create the preview folder", dir.display()))?;
        let src = open(&a.input)?;
        let p = dir.join("before.png");
        orogen::tiles::render::render_preview(src.as_ref(), &p, &Default::default())?;
        wrote(&p);
    }
    crate::cli::erode_sp::run(&a.input, &a.sp, &a.out, &a.run)?;
    if let Some(dir) = &a.preview {
        let out = orogen::io::open_raster(&a.out.output, &orogen::io::OpenOptions::default())?;
        let p = dir.join("after.png");
        orogen::tiles::render::render_preview(out.as_ref(), &p, &Default::default())?;
        wrote(&p);
    }
    Ok(())
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

/// The parameter table of `model` merged from the file, `--set` and the flags,
/// plus the file's `steps` and `exchange`.
fn gather(a: &ErodeArgs) -> Result<(toml::Table, Option<u64>, Option<usize>)> {
    let mut table = toml::Table::new();
    let (mut steps, mut exchange) = (None, None);
    if let Some(path) = &a.params {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("{}: cannot read the parameter file", path.display()))?;
        let file: toml::Table = toml::from_str(&text)
            .map_err(|e| anyhow::anyhow!("{}: {}", path.display(), e.to_string().trim_end()))?;
        for (k, v) in file {
            match k.as_str() {
                "steps" => {
                    let n = v.as_integer().filter(|n| *n >= 0).with_context(|| {
                        format!("{}: steps must be a whole number", path.display())
                    })?;
                    steps = Some(n as u64);
                }
                "exchange" => {
                    let n = v.as_integer().filter(|n| *n >= 1).with_context(|| {
                        format!("{}: exchange must be a whole number >= 1", path.display())
                    })?;
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
    use ModelArg::*;
    if let Some(s) = a.seed {
        let s = i64::try_from(s).context("--seed: at most 9223372036854775807")?;
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
fn parse_params<T: serde::de::DeserializeOwned>(
    model: ModelArg,
    table: toml::Table,
    a: &ErodeArgs,
) -> Result<T> {
    let from = match &a.params {
        Some(p) => format!("[{}] of {} and --set", model.key(), p.display()),
        None => "--set".to_string(),
    };
    toml::Value::Table(table).try_into::<T>().map_err(|e| {
        anyhow::anyhow!(
            "{} parameters ({from}): {}",
            model.key(),
            e.to_string().trim_end()
        )
    })
}

fn execute<M: LocalModel>(
    model: &M,
    a: &ErodeArgs,
    src: &dyn orogen::raster::RasterSource,
    exchange: usize,
) -> Result<()> {
    let cfg = engine(&a.run)?;
    let oo = output_options(&a.out.fmt)?;
    let mut outputs = vec![(0usize, a.out.output.clone())];
    let extra = [
        (&a.water, orogen::erosion::hydraulic::WATER, "--water"),
        (
            &a.sediment,
            orogen::erosion::hydraulic::SEDIMENT,
            "--sediment",
        ),
    ];
    for (p, f, name) in extra {
        if let Some(p) = p {
            if a.model != ModelArg::Hydraulic {
                bail!("{name} applies to --model hydraulic only");
            }
            outputs.push((f, p.clone()));
        }
    }
    if let Some(dir) = &a.preview {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("{}: cannot create the preview folder", dir.display()))?;
        let p = dir.join("before.png");
        orogen::tiles::render::render_preview(src, &p, &Default::default())?;
        wrote(&p);
    }
    let t0 = std::time::Instant::now();
    let (stats, layout) = erode_to_paths(
        model,
        src,
        &outputs,
        &oo,
        a.run.tile,
        exchange,
        a.scratch.as_deref(),
        &cfg,
    )?;
    if !a.run.quiet {
        eprintln!(
            "erode: {} on {}x{} cells, {} substeps in {} exchanges ({}-cell tiles, ghost {} cells), {:.1} s",
            model.name(),
            layout.width,
            layout.height,
            stats.substeps,
            stats.rounds,
            layout.tile,
            stats.ghost,
            t0.elapsed().as_secs_f64()
        );
    }
    for (_, p) in &outputs {
        wrote(p);
    }
    if let Some(dir) = &a.preview {
        let out = orogen::io::open_raster(&a.out.output, &orogen::io::OpenOptions::default())?;
        let p = dir.join("after.png");
        orogen::tiles::render::render_preview(out.as_ref(), &p, &Default::default())?;
        wrote(&p);
    }
    Ok(())
}

fn cell_of(src: &dyn orogen::raster::RasterSource, has_cell: bool) -> Result<CellSize> {
    if has_cell {
        // Overridden by the `cell` parameter; any valid placeholder.
        return Ok(CellSize::square(1.0));
    }
    Ok(CellSize::of(src.info())?)
}

/// Run `orogen erode`.
pub fn run(a: ErodeArgs) -> Result<()> {
    let (table, file_steps, file_exchange) = gather(&a)?;
    let Some(steps) = a.steps.or(file_steps) else {
        bail!("give the number of steps with --steps N (or `steps` in --params)");
    };
    let exchange = a.exchange.or(file_exchange).unwrap_or(DEFAULT_EXCHANGE);
    if exchange == 0 {
        bail!("--exchange 0: give at least 1 substep between halo exchanges");
    }
    // Parameters are checked before the input is opened.
    match a.model {
        ModelArg::Hydraulic => {
            let p: HydraulicParams = parse_params(a.model, table, &a)?;
            let probe = Hydraulic::new(p.clone(), steps, CellSize::square(1.0))?;
            let src = open(&a.input)?;
            let model = Hydraulic::new(
                p,
                steps,
                cell_of(src.as_ref(), probe.params.cell.is_some())?,
            )?;
            execute(&model, &a, src.as_ref(), exchange)
        }
        ModelArg::Thermal => {
            let p: ThermalParams = parse_params(a.model, table, &a)?;
            let probe = Thermal::new(p.clone(), steps, CellSize::square(1.0))?;
            let src = open(&a.input)?;
            let model = Thermal::new(
                p,
                steps,
                cell_of(src.as_ref(), probe.params.cell.is_some())?,
            )?;
            execute(&model, &a, src.as_ref(), exchange)
        }
        ModelArg::Diffusion => {
            let p: DiffusionParams = parse_params(a.model, table, &a)?;
            DiffusionParams::validate(&p)?;
            orogen::erosion::check_steps(steps)?;
            let src = open(&a.input)?;
            let has_cell = p.cell.is_some();
            let model = Diffusion::new(p, steps, cell_of(src.as_ref(), has_cell)?)?;
            execute(&model, &a, src.as_ref(), exchange)
        }
        ModelArg::StreamPower => run_stream_power(a, table, steps),
    }
}
