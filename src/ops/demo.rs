//! `orogen demo`: a seeded terrain and the pipeline run on it.

use super::{convert, run_global_to, run_local_to};
use crate::error::{Error, Result};
use crate::exec::EngineConfig;
use crate::io::{self, OutputOptions};
use std::path::{Path, PathBuf};

/// Options of `orogen demo`.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DemoOptions {
    /// Size in cells (square).
    pub size: usize,
    /// Random seed.
    pub seed: u64,
}

impl Default for DemoOptions {
    fn default() -> Self {
        DemoOptions {
            size: 1024,
            seed: 42,
        }
    }
}

/// [`demo`] into `dir` with `opts`.
pub fn run(
    dir: &Path,
    opts: &DemoOptions,
    cfg: &EngineConfig,
) -> Result<Vec<(PathBuf, &'static str)>> {
    demo(dir, opts.size, opts.seed, cfg)
}

/// What `orogen demo` prints of a run into `dir`: the terrain and each
/// file written with its description.
pub fn listing(dir: &Path, opts: &DemoOptions, files: &[(PathBuf, &'static str)]) -> String {
    let mut s = format!(
        "orogen demo: a {}x{} seeded terrain (seed {}) and its analysis in {}:\n",
        opts.size,
        opts.size,
        opts.seed,
        dir.display()
    );
    for (f, what) in files {
        s.push_str(&format!("  {:<28} {what}\n", f.display()));
    }
    s
}

/// `orogen demo`: generate a seeded noise terrain (warped ridged fBm), ingest it into a tile store,
/// export it, derive slope, aspect and hillshade, fill depressions, route D8
/// flow and accumulate it (global passes across tiles), render a preview.
/// Returns the files written with a description of each.
pub fn demo(
    dir: &Path,
    size: usize,
    seed: u64,
    cfg: &EngineConfig,
) -> Result<Vec<(PathBuf, &'static str)>> {
    if !(64..=65536).contains(&size) {
        return Err(Error::invalid(
            "demo --size must be between 64 and 65536 cells",
        ));
    }
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    // A domain-warped ridged multifractal blended with fBm: sharp, sinuous
    // crests over rolling ground (see `synth::noise`).
    let wavelength = (size as f64 / 2.0).max(64.0);
    let noise = crate::synth::Noise {
        kind: crate::synth::NoiseKind::Warped,
        seed,
        wavelength,
        octaves: (wavelength.log2().floor() as u32 + 1).min(10),
        warp: 0.15 * wavelength,
        ..Default::default()
    };
    let src = crate::synth::NoiseSource::new(noise, size, size, 30.0)?;
    let mut oo = OutputOptions::default();
    oo.store.tile = 256.min(size);
    oo.store.overwrite = true;
    let mut files = Vec::new();
    let store = dir.join("terrain.tiles");
    convert(&src, &store, &oo, None, cfg)?;
    files.push((store.clone(), "tile store of the terrain (f32, 30 m cells)"));
    let dem = io::open_raster(&store, &io::OpenOptions::default())?;
    let tif = dir.join("terrain.tif");
    convert(dem.as_ref(), &tif, &oo, None, cfg)?;
    files.push((tif, "the terrain as a GeoTIFF (DEFLATE, tiled)"));
    let slope = dir.join("slope.tif");
    run_local_to(
        &crate::metrics::Slope::default(),
        dem.as_ref(),
        &slope,
        &oo,
        None,
        cfg,
    )?;
    files.push((slope, "slope in degrees (Horn)"));
    let aspect = dir.join("aspect.tif");
    run_local_to(
        &crate::metrics::Aspect::default(),
        dem.as_ref(),
        &aspect,
        &oo,
        None,
        cfg,
    )?;
    files.push((aspect, "aspect, degrees clockwise from north"));
    let shade = dir.join("hillshade.tif");
    run_local_to(
        &crate::metrics::Hillshade::default(),
        dem.as_ref(),
        &shade,
        &oo,
        None,
        cfg,
    )?;
    files.push((shade, "hillshade, light from 315 degrees at 45 degrees"));
    let filled = dir.join("filled.tif");
    run_global_to(
        &crate::hydro::tiled::TiledFill,
        &[dem.as_ref()],
        &filled,
        &oo,
        None,
        cfg,
    )?;
    files.push((
        filled.clone(),
        "depressions filled (Priority-Flood, exact across tiles)",
    ));
    let filled_src = io::open_raster(&filled, &io::OpenOptions::default())?;
    let d8 = dir.join("flow_d8.tif");
    run_global_to(
        &crate::hydro::tiled::TiledD8,
        &[filled_src.as_ref()],
        &d8,
        &oo,
        Some(oo.store.tile),
        cfg,
    )?;
    files.push((d8.clone(), "D8 flow directions (ESRI codes), flats drained"));
    let d8_src = io::open_raster(&d8, &io::OpenOptions::default())?;
    let acc = dir.join("accumulation.tif");
    run_global_to(
        &crate::hydro::tiled::TiledAccumulation {
            weighted: false,
            sca: false,
        },
        &[d8_src.as_ref()],
        &acc,
        &oo,
        Some(oo.store.tile),
        cfg,
    )?;
    files.push((acc, "D8 flow accumulation (cells)"));
    let preview = dir.join("preview.png");
    let ropts = crate::tiles::render::RenderOptions {
        legend: true,
        ..Default::default()
    };
    crate::tiles::render::render_preview(dem.as_ref(), &preview, &ropts)?;
    files.push((
        preview,
        "preview: hillshade over a hypsometric tint, with legend",
    ));
    Ok(files)
}
