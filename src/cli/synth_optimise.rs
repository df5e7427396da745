//! `orogen synth optimise`: example-based terrain synthesis with pit removal
//! (see `orogen::synth::optimise`). Source, guide and output are held in
//! memory (the output is limited to 2^26 cells).

use crate::{engine, output_options, wrote, Out, Run};
use anyhow::{bail, Context, Result};
use clap::{Args, ValueEnum};
use orogen::io::{open_raster, OpenOptions};
use orogen::raster::{read_window, GeoRef, Grid, MemRaster, Window};
use orogen::synth::optimise::{
    depression_stats, synthesise, FinestPits, OptimiseOptions, PitRemoval, SearchSpace, Weighting,
    DEFAULT_DETAIL_DEPTH, MAX_OUTPUT_CELLS, MAX_SOURCE_CELLS,
};
use orogen::tiles::render::{render_preview, RenderOptions};
use std::path::{Path, PathBuf};

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

#[derive(Copy, Clone, PartialEq, Eq, ValueEnum)]
pub enum WeightArg {
    Exponential,
    Linear,
    Constant,
    Zero,
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
    #[arg(long, value_enum, default_value_t = WeightArg::Exponential)]
    pub weighting: WeightArg,
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

fn read_all(path: &Path, what: &str, max: usize) -> Result<(Grid<f32>, GeoRef)> {
    let src = open_raster(path, &OpenOptions::default())?;
    let info = src.info();
    let (w, h) = (info.width, info.height);
    if w.checked_mul(h).is_none_or(|c| c > max) {
        bail!(
            "{}: the {what} is {w}x{h} cells, more than the {max} synth optimise holds in memory; crop or downsample it",
            path.display()
        );
    }
    let g = read_window::<f32>(src.as_ref(), Window::full(w, h))
        .with_context(|| format!("reading the {what} {}", path.display()))?;
    Ok((g, info.georef.clone()))
}

/// Output georeference: the guide's extent at the output size; the source's
/// georeference when the guide has none.
fn output_georef(
    guide: &GeoRef,
    gsize: (usize, usize),
    source: &GeoRef,
    w: usize,
    h: usize,
) -> GeoRef {
    if guide.georeferenced {
        let mut g = guide.clone();
        let sx = gsize.0 as f64 / w as f64;
        let sy = gsize.1 as f64 / h as f64;
        g.transform[1] *= sx;
        g.transform[4] *= sx;
        g.transform[2] *= sy;
        g.transform[5] *= sy;
        g.with_nodata(None)
    } else {
        source.clone().with_nodata(None)
    }
}

fn scaled(g: &GeoRef, f: f64) -> GeoRef {
    let mut g = g.clone();
    for i in [1, 2, 4, 5] {
        g.transform[i] *= f;
    }
    g
}

/// Synthesise and write.
pub fn run(a: OptimiseArgs) -> Result<()> {
    let cfg = engine(&a.run)?;
    let oo = output_options(&a.out.fmt)?;
    let (source, sgeo) = read_all(&a.source, "source", MAX_SOURCE_CELLS)?;
    let (guide, ggeo) = read_all(&a.guide, "guide", MAX_OUTPUT_CELLS)?;
    let (w, h) = match &a.size {
        Some(s) => super::synth_noise::parse_size(s)?,
        None => (guide.width(), guide.height()),
    };
    let pit = match a.pit {
        PitArg::Breach => PitRemoval::Breach,
        PitArg::Fill => PitRemoval::Fill,
        PitArg::None => PitRemoval::None,
        PitArg::Hybrid => PitRemoval::Hybrid {
            max_depth: a.hybrid_depth.unwrap_or(f32::INFINITY),
            max_length: a.hybrid_length,
        },
    };
    if a.pit != PitArg::Hybrid && a.hybrid_depth.is_some() {
        bail!("--hybrid-depth needs --pit hybrid");
    }
    let sinks = match &a.sinks {
        None => None,
        Some(p) => {
            let (m, _) = read_all(p, "sink mask", MAX_OUTPUT_CELLS)?;
            if (m.width(), m.height()) != (w, h) {
                bail!(
                    "{}: the sink mask is {}x{}, the output {w}x{h}; they must match",
                    p.display(),
                    m.width(),
                    m.height()
                );
            }
            Some(m.map(|v| v.is_finite() && v != 0.0))
        }
    };
    // output cell size (DEM units = metres assumed when georeferenced)
    let cell_m = {
        let g = output_georef(&ggeo, (guide.width(), guide.height()), &sgeo, w, h);
        if g.georeferenced {
            let (cx, cy) = g.cell_size_m(h as i64 / 2);
            (0.5 * (cx.abs() + cy.abs())) as f32
        } else {
            1.0
        }
    };
    let opts = OptimiseOptions {
        width: w,
        height: h,
        patch: a.patch,
        spacing: a.spacing,
        levels: a.levels,
        iterations: a.iterations,
        passes: a.passes,
        weighting: match a.weighting {
            WeightArg::Exponential => Weighting::Exponential,
            WeightArg::Linear => Weighting::Linear,
            WeightArg::Constant => Weighting::Constant,
            WeightArg::Zero => Weighting::Zero,
        },
        alpha: a.alpha,
        search: SearchSpace {
            rotation: !a.no_rotation,
            reflection: !a.no_reflection,
            subpixel: !a.no_subpixel,
            height_offset: a.height_offset,
        },
        pit,
        seed: a.seed,
        falloff: (!a.uniform).then_some(a.falloff),
        pit_finest: a.pit_finest,
        drain_step: a.drain_slope * cell_m,
        finest: if a.finest_keep {
            FinestPits::Keep
        } else if let Some(d) = a.finest_depth {
            FinestPits::MaxDepth(d)
        } else {
            FinestPits::Detail(a.finest_detail)
        },
        keep_levels: a.previews.is_some(),
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(cfg.threads)
        .build()
        .context("starting the worker threads")?;
    let t0 = std::time::Instant::now();
    let syn = pool.install(|| synthesise(&source, &guide, sinks.as_ref(), &opts))?;
    let secs = t0.elapsed().as_secs_f64();
    let georef = output_georef(&ggeo, (guide.width(), guide.height()), &sgeo, w, h);
    if let Some(dir) = &a.previews {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        for (rep, g) in syn.levels.iter().zip(&syn.level_grids) {
            let f = (1u64 << rep.level) as f64;
            let mem = MemRaster::from_grid(g.clone(), scaled(&georef, f));
            let p = dir.join(format!("level_{}.png", rep.level));
            render_preview(&mem, &p, &RenderOptions::default())?;
            wrote(&p);
        }
    }
    if a.stats {
        for r in &syn.levels {
            let e: Vec<String> = r.energies.iter().map(|e| format!("{e:.4e}")).collect();
            eprintln!(
                "level {}: {}x{} (source {}x{}), {} patches, guide weight {:.3}, energy {}",
                r.level,
                r.width,
                r.height,
                r.source_width,
                r.source_height,
                r.patches,
                r.guide_weight,
                e.join(" -> ")
            );
        }
        let (cx, cy) = if georef.georeferenced {
            georef.cell_size_m(h as i64 / 2)
        } else {
            (1.0, 1.0)
        };
        if let Some(d) = syn.finest_depth {
            eprintln!("finest level: depressions at most {d:.3} deep removed");
        }
        let d = depression_stats(&syn.output, cx * cy, 1.0)?;
        let d5 = depression_stats(&syn.output, cx * cy, 0.5)?;
        eprintln!(
            "synthesis {secs:.2} s; output depressions: {} ({} at least 0.5 m deep, {} at least 1 m; {} cells), volume {:.4e} m3",
            d.count, d5.deep, d.deep, d.cells, d.volume
        );
    }
    let mem = MemRaster::from_grid(syn.output, georef);
    orogen::ops::convert(&mem, &a.out.output, &oo, a.run.tile, &cfg)?;
    wrote(&a.out.output);
    Ok(())
}
