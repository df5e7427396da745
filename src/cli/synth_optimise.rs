//! `orogen synth optimise`: the arguments of `orogen::ops::synth::optimise`
//! (example-based terrain synthesis with pit removal).

use super::erode::printer;
use crate::cli::args::enum_parser;
use crate::{engine, output_options, Out, Run};
use anyhow::Result;
use clap::{Args, ValueEnum};
use orogen::ops::synth::optimise::{self, OptimiseOptions, PitMethod};
use orogen::synth::optimise::{Weighting, DEFAULT_DETAIL_DEPTH};
use std::path::PathBuf;

#[derive(Copy, Clone, PartialEq, Eq, ValueEnum)]
pub enum PitArg {
    /// Flood-order breaching (default).
    Breach,
    /// Priority-flood fill.
    Fill,
    /// Selective breaching: short channels carved, the rest filled.
    Hybrid,
    /// No pit removal.
    None,
}

/// Arguments of `orogen synth optimise`.
#[derive(Args)]
pub struct OptimiseArgs {
    /// The exemplar: a real DEM whose patches build the output.
    #[arg(long)]
    pub source: PathBuf,
    /// The guide: a coarse elevation map (sketch, noise, downsampled DEM), at most the output size.
    #[arg(long)]
    pub guide: PathBuf,
    /// Output size WIDTHxHEIGHT (or one number); default: the guide's size.
    #[arg(long)]
    pub size: Option<String>,
    /// Pit removal after each E-step at every level but the finest.
    #[arg(long, value_enum, default_value_t = PitArg::Breach)]
    pub pit: PitArg,
    /// Hybrid: deepest carve (DEM units; default unlimited).
    #[arg(long)]
    pub hybrid_depth: Option<f32>,
    /// Hybrid: longest carved channel in cells.
    #[arg(long, default_value_t = 20)]
    pub hybrid_length: usize,
    /// Remove pits at the finest level too (the output is then depression-free; not in the paper).
    #[arg(long)]
    pub pit_finest: bool,
    /// After pit removal at the coarser levels, make flats drain with this
    /// gradient (rise / run, e.g. 0.01; 0 = off): less depression volume, more (shallow) depressions.
    #[arg(long, default_value_t = 0.0)]
    pub drain_slope: f32,
    /// Finest level: remove the depressions at most K times the source's
    /// finest detail RMS deep (with the --pit method; deeper ones stay).
    #[arg(long, default_value_t = DEFAULT_DETAIL_DEPTH)]
    pub finest_detail: f32,
    /// Finest level: remove the depressions at most this deep (DEM units) instead.
    #[arg(long, conflicts_with = "finest_detail")]
    pub finest_depth: Option<f32>,
    /// Leave the finest level as its E-step made it (the paper: no pit removal there).
    #[arg(long, conflicts_with_all = ["finest_detail", "finest_depth"])]
    pub finest_keep: bool,

    /// Sink mask raster (output size): non-zero valid cells are extra outlets.
    #[arg(long)]
    pub sinks: Option<PathBuf>,
    /// Patch size N.
    #[arg(long, default_value_t = 7)]
    pub patch: usize,
    /// Patch grid spacing (default N/2).
    #[arg(long)]
    pub spacing: Option<usize>,
    /// Coarsest pyramid level L (default: from the output and source sizes).
    #[arg(long)]
    pub levels: Option<usize>,
    /// EM iterations per level.
    #[arg(long, default_value_t = 2)]
    pub iterations: usize,
    /// PatchMatch passes per M-step.
    #[arg(long, default_value_t = 4)]
    pub passes: usize,
    /// Guide weighting across levels.
    #[arg(
        long,
        value_parser = enum_parser(&Weighting::ALL, Weighting::name, None),
        default_value = OptimiseOptions::default().weighting.name()
    )]
    pub weighting: Weighting,
    /// Guide weight alpha (0..1).
    #[arg(long, default_value_t = 0.75)]
    pub alpha: f32,
    /// Search without rotations.
    #[arg(long)]
    pub no_rotation: bool,
    /// Search without reflections.
    #[arg(long)]
    pub no_reflection: bool,
    /// Integer translations only.
    #[arg(long)]
    pub no_subpixel: bool,
    /// Allow a per-patch height offset (off by default, as the paper advises).
    #[arg(long)]
    pub height_offset: bool,
    /// Random seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Gaussian falloff of patch cell weights, sigma as a fraction of the patch size.
    #[arg(long, default_value_t = 0.3)]
    pub falloff: f32,
    /// Uniform patch weights (no falloff).
    #[arg(long, conflicts_with = "falloff")]
    pub uniform: bool,
    /// Write a hillshade PNG of each pyramid level's result into this folder.
    #[arg(long)]
    pub previews: Option<PathBuf>,
    /// Print per-level energies and the output's depression statistics.
    #[arg(long)]
    pub stats: bool,
    #[command(flatten)]
    pub out: Out,
    #[command(flatten)]
    pub run: Run,
}

/// Synthesise and write.
pub fn run(a: OptimiseArgs) -> Result<()> {
    let cfg = engine(&a.run)?;
    let oo = output_options(&a.out.fmt)?;
    let opts = OptimiseOptions {
        source: a.source,
        guide: a.guide,
        size: a.size,
        pit: match a.pit {
            PitArg::Breach => PitMethod::Breach,
            PitArg::Fill => PitMethod::Fill,
            PitArg::Hybrid => PitMethod::Hybrid,
            PitArg::None => PitMethod::None,
        },
        hybrid_depth: a.hybrid_depth,
        hybrid_length: a.hybrid_length,
        pit_finest: a.pit_finest,
        drain_slope: a.drain_slope,
        finest_detail: a.finest_detail,
        finest_depth: a.finest_depth,
        finest_keep: a.finest_keep,
        sinks: a.sinks,
        patch: a.patch,
        spacing: a.spacing,
        levels: a.levels,
        iterations: a.iterations,
        passes: a.passes,
        weighting: a.weighting,
        alpha: a.alpha,
        no_rotation: a.no_rotation,
        no_reflection: a.no_reflection,
        no_subpixel: a.no_subpixel,
        height_offset: a.height_offset,
        seed: a.seed,
        falloff: a.falloff,
        uniform: a.uniform,
        previews: a.previews,
        stats: a.stats,
        output: a.out.output.clone(),
        tile: a.run.tile,
    };
    optimise::run(&opts, &oo, &cfg, &mut printer(a.run.quiet))?;
    Ok(())
}
