//! `orogen erode`: the arguments of `orogen::ops::erode` (local erosion
//! models over tiles with halo exchange, and stream power). Model parameters
//! come from a TOML file (`--params`, one table per model), `--set KEY=VALUE`
//! and a few named flags, in that order of precedence (later wins); unknown
//! keys are rejected with the list of valid ones.
//!
//! Under `--engine mpi` the hydraulic, thermal and diffusion models run
//! distributed (each rank its tiles, ghost zones exchanged point to point,
//! rank 0 writes; `erosion::tiled::run_ranked`), and so does the tiled
//! stream-power solve (`--tiled`, or a DEM larger than `--memory`: each rank
//! its tiles, changed perimeters exchanged after every round, rank 0 writes;
//! `erosion::stream_power_tiled::stream_power_tiled_ranked`); the in-memory
//! stream-power solve is not: every rank runs it whole (same bytes, no
//! speed-up) and rank 0 writes.

use crate::{engine, output_options, wrote, In, Out, Run};
use anyhow::Result;
use clap::{Args, ValueEnum};
use orogen::ops::erode::{self, ErodeOptions, Model};
use orogen::ops::note::Note;
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
    /// Stream power with uplift, implicit (Braun & Willett 2013); in memory, or tiled
    /// (--tiled), which --engine mpi distributes over the ranks.
    StreamPower,
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

/// The printer of an operation's notes: `wrote PATH` (unless `--quiet`),
/// `warning: ...`, and summaries unless `quiet`.
pub fn printer(quiet: bool) -> impl FnMut(Note) {
    move |n| match n {
        Note::Wrote(p) => wrote(&p),
        Note::Warning(w) => eprintln!("warning: {w}"),
        Note::Info(s) => {
            if !quiet {
                eprintln!("{s}");
            }
        }
        Note::Message(s) => eprintln!("{s}"),
        Note::Print(s) => print!("{s}"),
    }
}

impl ErodeArgs {
    /// The operation's options.
    pub fn options(&self) -> ErodeOptions {
        let mut o = ErodeOptions {
            input: self.input.input.clone(),
            model: match self.model {
                ModelArg::Hydraulic => Model::Hydraulic,
                ModelArg::Thermal => Model::Thermal,
                ModelArg::Diffusion => Model::Diffusion,
                ModelArg::StreamPower => Model::StreamPower,
            },
            steps: self.steps,
            params: self.params.clone(),
            set: self.set.clone(),
            seed: self.seed,
            dt: self.dt,
            talus: self.talus,
            diffusivity: self.diffusivity,
            exchange: self.exchange,
            water: self.water.clone(),
            sediment: self.sediment.clone(),
            preview: self.preview.clone(),
            scratch: self.scratch.clone(),
            output: self.out.output.clone(),
            tile: self.run.tile,
            ..Default::default()
        };
        self.sp.apply(&mut o);
        o
    }
}

/// Run `orogen erode`.
pub fn run(a: ErodeArgs) -> Result<()> {
    let cfg = engine(&a.run)?;
    let oo = output_options(&a.out.fmt)?;
    let opts = a.options();
    erode::run(
        &opts,
        &a.input.reading.open_options(),
        &oo,
        &cfg,
        &mut printer(a.run.quiet),
    )?;
    Ok(())
}
