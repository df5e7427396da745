//! `synth optimise`: example-based terrain synthesis with pit removal (see
//! `crate::synth::optimise`). Source, guide and output are held in memory
//! (the output is limited to 2^26 cells).

use super::parse_size;
use crate::error::{Error, Result};
use crate::exec::EngineConfig;
use crate::io::{open_raster, OpenOptions, OutputOptions};
use crate::ops::note::{bail, preview, Note, Notify};
use crate::raster::{read_window, GeoRef, Grid, MemRaster, Window};
use crate::synth::optimise::{
    depression_stats, synthesise, FinestPits, OptimiseOptions as SynthOptions, PitRemoval,
    SearchSpace, Weighting, DEFAULT_DETAIL_DEPTH, MAX_OUTPUT_CELLS, MAX_SOURCE_CELLS,
};
use crate::tiles::render::RenderOptions;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Pit removal after each E-step (`pit`).
#[derive(Copy, Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum PitMethod {
    /// Flood-order breaching (default).
    Breach,
    /// Priority-flood fill.
    Fill,
    /// Selective breaching: short channels carved, the rest filled.
    Hybrid,
    /// No pit removal.
    None,
}

/// Options of `synth optimise` (the CLI's names and defaults).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields, default)]
pub struct OptimiseOptions {
    /// The exemplar: a real DEM whose patches build the output.
    pub source: PathBuf,
    /// The guide: a coarse elevation map, at most the output size.
    pub guide: PathBuf,
    /// Output size WIDTHxHEIGHT (or one number); default: the guide's size.
    pub size: Option<String>,
    /// Pit removal after each E-step at every level but the finest.
    pub pit: PitMethod,
    /// Hybrid: deepest carve (DEM units; default unlimited).
    pub hybrid_depth: Option<f32>,
    /// Hybrid: longest carved channel in cells.
    pub hybrid_length: usize,
    /// Remove pits at the finest level too.
    pub pit_finest: bool,
    /// Make flats drain with this gradient after pit removal (0 = off).
    pub drain_slope: f32,
    /// Finest level: remove the depressions at most K times the source's finest detail RMS deep.
    pub finest_detail: f32,
    /// Finest level: remove the depressions at most this deep instead.
    pub finest_depth: Option<f32>,
    /// Leave the finest level as its E-step made it.
    pub finest_keep: bool,
    /// Sink mask raster (output size): non-zero valid cells are extra outlets.
    pub sinks: Option<PathBuf>,
    /// Patch size N.
    pub patch: usize,
    /// Patch grid spacing (default N/2).
    pub spacing: Option<usize>,
    /// Coarsest pyramid level L (default: from the output and source sizes).
    pub levels: Option<usize>,
    /// EM iterations per level.
    pub iterations: usize,
    /// PatchMatch passes per M-step.
    pub passes: usize,
    /// Guide weighting across levels.
    pub weighting: Weighting,
    /// Guide weight alpha (0..1).
    pub alpha: f32,
    /// Search without rotations.
    pub no_rotation: bool,
    /// Search without reflections.
    pub no_reflection: bool,
    /// Integer translations only.
    pub no_subpixel: bool,
    /// Allow a per-patch height offset.
    pub height_offset: bool,
    /// Random seed.
    pub seed: u64,
    /// Gaussian falloff of patch cell weights, sigma as a fraction of the patch size.
    pub falloff: f32,
    /// Uniform patch weights (no falloff).
    pub uniform: bool,
    /// Write a hillshade PNG of each pyramid level's result into this folder.
    pub previews: Option<PathBuf>,
    /// Report per-level energies and the output's depression statistics.
    pub stats: bool,
    /// Output raster.
    pub output: PathBuf,
    /// Work-tile size in cells for writing (default 1024).
    pub tile: Option<usize>,
}

impl Default for OptimiseOptions {
    fn default() -> Self {
        OptimiseOptions {
            source: PathBuf::new(),
            guide: PathBuf::new(),
            size: None,
            pit: PitMethod::Breach,
            hybrid_depth: None,
            hybrid_length: 20,
            pit_finest: false,
            drain_slope: 0.0,
            finest_detail: DEFAULT_DETAIL_DEPTH,
            finest_depth: None,
            finest_keep: false,
            sinks: None,
            patch: 7,
            spacing: None,
            levels: None,
            iterations: 2,
            passes: 4,
            weighting: Weighting::Exponential,
            alpha: 0.75,
            no_rotation: false,
            no_reflection: false,
            no_subpixel: false,
            height_offset: false,
            seed: 1,
            falloff: 0.3,
            uniform: false,
            previews: None,
            stats: false,
            output: PathBuf::new(),
            tile: None,
        }
    }
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
        .map_err(|e| Error::invalid(format!("reading the {what} {}: {e}", path.display())))?;
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

/// Synthesise and write the terrain (and the previews and statistics asked for).
pub fn run(
    opts: &OptimiseOptions,
    oo: &OutputOptions,
    cfg: &EngineConfig,
    notify: Notify<'_>,
) -> Result<()> {
    let a = opts;
    let (source, sgeo) = read_all(&a.source, "source", MAX_SOURCE_CELLS)?;
    let (guide, ggeo) = read_all(&a.guide, "guide", MAX_OUTPUT_CELLS)?;
    let (w, h) = match &a.size {
        Some(s) => parse_size(s)?,
        None => (guide.width(), guide.height()),
    };
    let pit = match a.pit {
        PitMethod::Breach => PitRemoval::Breach,
        PitMethod::Fill => PitRemoval::Fill,
        PitMethod::None => PitRemoval::None,
        PitMethod::Hybrid => PitRemoval::Hybrid {
            max_depth: a.hybrid_depth.unwrap_or(f32::INFINITY),
            max_length: a.hybrid_length,
        },
    };
    if a.pit != PitMethod::Hybrid && a.hybrid_depth.is_some() {
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
    let so = SynthOptions {
        width: w,
        height: h,
        patch: a.patch,
        spacing: a.spacing,
        levels: a.levels,
        iterations: a.iterations,
        passes: a.passes,
        weighting: a.weighting,
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
        .map_err(|e| Error::invalid(format!("starting the worker threads: {e}")))?;
    let t0 = std::time::Instant::now();
    let syn = pool.install(|| synthesise(&source, &guide, sinks.as_ref(), &so))?;
    let secs = t0.elapsed().as_secs_f64();
    let georef = output_georef(&ggeo, (guide.width(), guide.height()), &sgeo, w, h);
    if let Some(dir) = &a.previews {
        std::fs::create_dir_all(dir)
            .map_err(|e| Error::invalid(format!("creating {}: {e}", dir.display())))?;
        for (rep, g) in syn.levels.iter().zip(&syn.level_grids) {
            let f = (1u64 << rep.level) as f64;
            let mem = MemRaster::from_grid(g.clone(), scaled(&georef, f));
            let p = dir.join(format!("level_{}.png", rep.level));
            preview(&mem, &p, &RenderOptions::default(), &mut *notify)?;
        }
    }
    if a.stats {
        for r in &syn.levels {
            let e: Vec<String> = r.energies.iter().map(|e| format!("{e:.4e}")).collect();
            notify(Note::Message(format!(
                "level {}: {}x{} (source {}x{}), {} patches, guide weight {:.3}, energy {}",
                r.level,
                r.width,
                r.height,
                r.source_width,
                r.source_height,
                r.patches,
                r.guide_weight,
                e.join(" -> ")
            )));
        }
        let (cx, cy) = if georef.georeferenced {
            georef.cell_size_m(h as i64 / 2)
        } else {
            (1.0, 1.0)
        };
        if let Some(d) = syn.finest_depth {
            notify(Note::Message(format!(
                "finest level: depressions at most {d:.3} deep removed"
            )));
        }
        let d = depression_stats(&syn.output, cx * cy, 1.0)?;
        let d5 = depression_stats(&syn.output, cx * cy, 0.5)?;
        notify(Note::Message(format!(
            "synthesis {secs:.2} s; output depressions: {} ({} at least 0.5 m deep, {} at least 1 m; {} cells), volume {:.4e} m3",
            d.count, d5.deep, d.deep, d.cells, d.volume
        )));
    }
    let mem = MemRaster::from_grid(syn.output, georef);
    crate::ops::convert(&mem, &a.output, oo, a.tile, cfg)?;
    notify(Note::Wrote(a.output.clone()));
    Ok(())
}
