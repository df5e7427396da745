//! `orogen synth tectonic`: tectonic folds from a GeoJSON map (see
//! `orogen::synth::tectonic`), streamed tile by tile to any output; optional
//! intermediates (plates, velocity, folds, watershed map) and previews.

use super::synth_noise::parse_size;
use crate::{engine, output_options, wrote, Out, Run};
use anyhow::{bail, Context, Result};
use clap::Args;
use orogen::raster::{Crs, GeoRef, RasterSource};
use orogen::synth::tectonic::{
    map_to_pixels, TectonicLayer, TectonicModel, TectonicParams, TectonicSource,
};
use orogen::synth::vector::VectorMap;
use orogen::tiles::render::{render_preview, RenderKind, RenderOptions};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Arguments of `orogen synth tectonic`.
#[derive(Args)]
pub struct TectonicArgs {
    /// GeoJSON map: coastline polygons, river lines, peak points (format:
    /// docs/notes/tectonic.md; example: configs/tectonic-map.geojson).
    #[arg(long)]
    pub map: PathBuf,
    /// Units of the map's coordinates: crs (x east, y north, in the output
    /// CRS, metres) or pixels (column, row from the top-left corner).
    #[arg(long, default_value = "crs")]
    pub map_units: String,
    /// Size in cells, WIDTHxHEIGHT; default: the map's extent plus the margin.
    #[arg(long)]
    pub size: Option<String>,
    /// Cell size in metres.
    #[arg(long, default_value_t = 30.0)]
    pub cell: f64,
    /// Top-left corner X,Y in map units (crs only); default: from the map's extent.
    #[arg(long)]
    pub origin: Option<String>,
    /// Margin around the map's extent, as a fraction of its larger side.
    #[arg(long, default_value_t = 0.05)]
    pub margin: f64,
    /// Seed of the fold noise.
    #[arg(long, default_value_t = 42)]
    pub seed: u64,
    /// Merge plates whose normalised velocities have a dot product >= T1.
    #[arg(long, default_value_t = 0.8)]
    pub t1: f64,
    /// ... and whose area ratio (smaller/larger) is >= T2.
    #[arg(long, default_value_t = 0.25)]
    pub t2: f64,
    /// Gaussian sigma of the velocity blur (cells).
    #[arg(long, default_value_t = 24.0)]
    pub blur: f64,
    /// Warp strength: noise sampled at p + strength * V(p).
    #[arg(long, default_value_t = 1.0)]
    pub fold_strength: f64,
    /// Height of peaks without an elevation property (m).
    #[arg(long, default_value_t = 2000.0)]
    pub relief: f64,
    /// Attenuation radius of the folds around peaks (cells).
    #[arg(long, default_value_t = 120.0)]
    pub peak_radius: f64,
    /// Share of the noise in the folds (0..1).
    #[arg(long, default_value_t = 0.6)]
    pub noise_share: f64,
    /// Wavelength of the fold noise (cells).
    #[arg(long, default_value_t = 256.0)]
    pub wavelength: f64,
    /// Octaves of the fold noise.
    #[arg(long, default_value_t = 8)]
    pub octaves: u32,
    /// Slope along rivers in the watershed map (m/m).
    #[arg(long, default_value_t = 0.003)]
    pub river_slope: f64,
    /// Slope away from rivers in the watershed map (m/m).
    #[arg(long, default_value_t = 0.03)]
    pub hill_slope: f64,
    /// Distance from rivers (cells) beyond which the folds apply fully.
    #[arg(long, default_value_t = 40.0)]
    pub river_width: f64,
    /// Longest side of the coarse grid for plates, velocity and watershed map.
    #[arg(long, default_value_t = 512)]
    pub coarse: usize,
    /// Write plates, velocity (magnitude, direction), folds and the watershed map as GeoTIFFs here.
    #[arg(long)]
    pub intermediates: Option<PathBuf>,
    /// Write a hillshaded preview PNG of the terrain here (and PNGs of the intermediates).
    #[arg(long)]
    pub preview: Option<PathBuf>,
    /// Finish with this many substeps of hydraulic erosion (virtual pipes, default
    /// parameters; `orogen erode --model hydraulic` gives every parameter). 0 = none.
    #[arg(long, default_value_t = 0)]
    pub erode_steps: u64,
    /// Seed of the erosion's rain.
    #[arg(long, default_value_t = 1)]
    pub erode_seed: u64,
    #[command(flatten)]
    pub out: Out,
    #[command(flatten)]
    pub run: Run,
}

/// Parse `X,Y`.
pub fn parse_xy(s: &str, what: &str) -> Result<(f64, f64)> {
    let (a, b) = s
        .split_once(',')
        .with_context(|| format!("{what} {s:?}: expected X,Y"))?;
    let p = |t: &str| -> Result<f64> {
        let v: f64 = t
            .trim()
            .parse()
            .with_context(|| format!("{what} {s:?}: {t:?} is not a number"))?;
        if !v.is_finite() {
            bail!("{what} {s:?}: coordinates must be finite");
        }
        Ok(v)
    };
    Ok((p(a)?, p(b)?))
}

/// Output size, georeference and the map in pixel coordinates.
pub fn domain(
    map: &VectorMap,
    units: &str,
    size: Option<&str>,
    cell: f64,
    origin: Option<&str>,
    margin: f64,
) -> Result<(usize, usize, GeoRef, VectorMap)> {
    if !(cell.is_finite() && cell > 0.0) {
        bail!("--cell must be a positive number of metres");
    }
    if !(margin.is_finite() && (0.0..=10.0).contains(&margin)) {
        bail!("--margin must be in 0..10");
    }
    let size = size.map(parse_size).transpose()?;
    let bb = map.bbox();
    let fit = |extent: f64| -> Result<usize> {
        let n = (extent / cell).ceil();
        if !(1.0..=1e6).contains(&n) {
            bail!("the map's extent gives {n} cells at --cell {cell}; give --size or a different --cell (1..1000000 cells a side)");
        }
        Ok(n as usize)
    };
    match units {
        "pixels" => {
            if origin.is_some() {
                bail!("--origin applies to --map-units crs only");
            }
            let (w, h) = match size {
                Some(s) => s,
                None => {
                    let b = bb.context("the map is empty; give --size")?;
                    let m = margin * (b[2].max(b[3]));
                    (fit((b[2] + m) * cell)?, fit((b[3] + m) * cell)?)
                }
            };
            let g = GeoRef::north_up(0.0, h as f64 * cell, cell, Crs::default());
            Ok((w, h, g, map.clone()))
        }
        "crs" => {
            let b = bb.context("the map is empty")?;
            let m = margin * (b[2] - b[0]).max(b[3] - b[1]);
            let (x0, y0) = match origin {
                Some(o) => parse_xy(o, "--origin")?,
                None => (b[0] - m, b[3] + m),
            };
            let (w, h) = match size {
                Some(s) => s,
                None => (fit(b[2] + m - x0)?, fit(y0 - (b[1] - m))?),
            };
            let g = GeoRef::north_up(x0, y0, cell, Crs::default());
            let px = map_to_pixels(map, &g)?;
            Ok((w, h, g, px))
        }
        u => bail!("--map-units {u:?}: use crs or pixels"),
    }
}

/// Preview of `src` at `path`.
pub fn preview(src: &dyn RasterSource, path: &Path, kind: RenderKind) -> Result<()> {
    let opts = RenderOptions {
        kind,
        legend: true,
        ..Default::default()
    };
    render_preview(src, path, &opts)?;
    wrote(path);
    Ok(())
}

/// Generate and write the terrain (and intermediates).
pub fn run(a: TectonicArgs) -> Result<()> {
    let map = VectorMap::read(&a.map)?;
    let (w, h, georef, px) = domain(
        &map,
        &a.map_units,
        a.size.as_deref(),
        a.cell,
        a.origin.as_deref(),
        a.margin,
    )?;
    let params = TectonicParams {
        fbm: orogen::synth::Fbm {
            seed: a.seed,
            octaves: a.octaves,
            wavelength: a.wavelength,
            ..TectonicParams::default().fbm
        },
        t1: a.t1,
        t2: a.t2,
        blur: a.blur,
        fold_strength: a.fold_strength,
        relief: a.relief,
        peak_radius: a.peak_radius,
        noise_share: a.noise_share,
        river_slope: a.river_slope,
        hill_slope: a.hill_slope,
        river_width: a.river_width,
        coarse: a.coarse,
        ..TectonicParams::default()
    };
    let model = Arc::new(TectonicModel::new(&px, w, h, a.cell, params)?);
    let cfg = engine(&a.run)?;
    let oo = output_options(&a.out.fmt)?;
    if let Some(dir) = &a.intermediates {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
        for (layer, name) in TectonicLayer::INTERMEDIATES {
            let src = TectonicSource::new(model.clone(), layer, georef.clone());
            let path = dir.join(format!("{name}.tif"));
            orogen::ops::convert(&src, &path, &oo, a.run.tile, &cfg)?;
            wrote(&path);
            if a.preview.is_some() {
                let kind = match layer {
                    TectonicLayer::Plates => RenderKind::Ramp("viridis".into()),
                    TectonicLayer::VelocityMagnitude | TectonicLayer::VelocityDirection => {
                        RenderKind::Grey
                    }
                    _ => RenderKind::Elevation,
                };
                preview(&src, &dir.join(format!("{name}.png")), kind)?;
            }
        }
    }
    let src = TectonicSource::new(model, TectonicLayer::Terrain, georef);
    if a.erode_steps == 0 {
        orogen::ops::convert(&src, &a.out.output, &oo, a.run.tile, &cfg)?;
    } else {
        // The folded terrain is tileable, so the erosion reads it tile by tile.
        let params = orogen::erosion::hydraulic::HydraulicParams {
            seed: a.erode_seed,
            ..Default::default()
        };
        let model = orogen::erosion::hydraulic::Hydraulic::new(
            params,
            a.erode_steps,
            orogen::erosion::CellSize::square(a.cell),
        )?;
        orogen::erosion::tiled::erode_to_paths(
            &model,
            &src,
            &[(0, a.out.output.clone())],
            &oo,
            a.run.tile,
            8,
            None,
            &cfg,
        )?;
    }
    wrote(&a.out.output);
    if let Some(p) = &a.preview {
        let out = orogen::io::open_raster(&a.out.output, &orogen::io::OpenOptions::default())?;
        preview(out.as_ref(), p, RenderKind::Elevation)?;
    }
    Ok(())
}
