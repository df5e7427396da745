//! `synth tectonic`: tectonic folds from a GeoJSON map (see
//! `crate::synth::tectonic`), streamed tile by tile to any output; optional
//! intermediates (plates, velocity, folds, watershed map), previews and a
//! final hydraulic erosion.

use super::{parse_size, parse_xy, preview};
use crate::error::{Error, Result};
use crate::exec::EngineConfig;
use crate::io::OutputOptions;
use crate::ops::note::{bail, Note, Notify};
use crate::raster::{Crs, GeoRef};
use crate::synth::tectonic::{
    map_to_pixels, TectonicLayer, TectonicModel, TectonicParams, TectonicSource,
};
use crate::synth::vector::VectorMap;
use crate::tiles::render::RenderKind;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;
use std::sync::Arc;

/// Options of `synth tectonic` (the CLI's names and defaults): the map and
/// the raster's extent, the fold noise, the fold parameters
/// ([`TectonicParams`], its keys flat beside these), the outputs and a
/// final erosion.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields, default)]
pub struct TectonicOptions {
    /// GeoJSON map: coastline polygons, river lines, peak points.
    pub map: PathBuf,
    /// Units of the map's coordinates: crs or pixels.
    pub map_units: String,
    /// Size in cells, WIDTHxHEIGHT; default: the map's extent plus the margin.
    pub size: Option<String>,
    /// Cell size in metres.
    pub cell: f64,
    /// Top-left corner X,Y in map units (crs only); default: from the map's extent.
    pub origin: Option<String>,
    /// Margin around the map's extent, as a fraction of its larger side.
    pub margin: f64,
    /// Seed of the fold noise.
    pub seed: u64,
    /// Wavelength of the fold noise (cells).
    pub wavelength: f64,
    /// Octaves of the fold noise.
    pub octaves: u32,
    /// Plates, velocity blur, folds, watershed map.
    #[serde(flatten)]
    pub folds: TectonicParams,
    /// Write the intermediates as GeoTIFFs into this folder.
    pub intermediates: Option<PathBuf>,
    /// Write a hillshaded preview PNG of the terrain here (and PNGs of the intermediates).
    pub preview: Option<PathBuf>,
    /// Finish with this many substeps of hydraulic erosion (0 = none).
    pub erode_steps: u64,
    /// Seed of the erosion's rain.
    pub erode_seed: u64,
    /// Output raster.
    pub output: PathBuf,
    /// Work-tile size in cells (default 1024).
    pub tile: Option<usize>,
}

impl Default for TectonicOptions {
    fn default() -> Self {
        let folds = TectonicParams::default();
        TectonicOptions {
            map: PathBuf::new(),
            map_units: "crs".into(),
            size: None,
            cell: 30.0,
            origin: None,
            margin: 0.05,
            seed: folds.fbm.seed,
            wavelength: folds.fbm.wavelength,
            octaves: folds.fbm.octaves,
            folds,
            intermediates: None,
            preview: None,
            erode_steps: 0,
            erode_seed: 1,
            output: PathBuf::new(),
            tile: None,
        }
    }
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
                    let Some(b) = bb else {
                        bail!("the map is empty; give --size");
                    };
                    let m = margin * (b[2].max(b[3]));
                    (fit((b[2] + m) * cell)?, fit((b[3] + m) * cell)?)
                }
            };
            let g = GeoRef::north_up(0.0, h as f64 * cell, cell, Crs::default());
            Ok((w, h, g, map.clone()))
        }
        "crs" => {
            let Some(b) = bb else {
                bail!("the map is empty");
            };
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

/// Generate and write the terrain (and the intermediates and previews asked for).
pub fn run(
    opts: &TectonicOptions,
    oo: &OutputOptions,
    cfg: &EngineConfig,
    notify: Notify<'_>,
) -> Result<()> {
    let a = opts;
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
        fbm: crate::synth::Fbm {
            seed: a.seed,
            octaves: a.octaves,
            wavelength: a.wavelength,
            ..a.folds.fbm.clone()
        },
        ..a.folds.clone()
    };
    let model = Arc::new(TectonicModel::new(&px, w, h, a.cell, params)?);
    if let Some(dir) = &a.intermediates {
        std::fs::create_dir_all(dir)
            .map_err(|e| Error::invalid(format!("cannot create {}: {e}", dir.display())))?;
        for (layer, name) in TectonicLayer::INTERMEDIATES {
            let src = TectonicSource::new(model.clone(), layer, georef.clone());
            let path = dir.join(format!("{name}.tif"));
            crate::ops::convert(&src, &path, oo, a.tile, cfg)?;
            notify(Note::Wrote(path));
            if a.preview.is_some() {
                let kind = match layer {
                    TectonicLayer::Plates => RenderKind::Ramp("viridis".into()),
                    TectonicLayer::VelocityMagnitude | TectonicLayer::VelocityDirection => {
                        RenderKind::Grey
                    }
                    _ => RenderKind::Elevation,
                };
                preview(&src, &dir.join(format!("{name}.png")), kind, &mut *notify)?;
            }
        }
    }
    let src = TectonicSource::new(model, TectonicLayer::Terrain, georef);
    if a.erode_steps == 0 {
        crate::ops::convert(&src, &a.output, oo, a.tile, cfg)?;
    } else {
        // The folded terrain is tileable, so the erosion reads it tile by tile.
        let params = crate::erosion::hydraulic::HydraulicParams {
            seed: a.erode_seed,
            ..Default::default()
        };
        let model = crate::erosion::hydraulic::Hydraulic::new(
            params,
            a.erode_steps,
            crate::erosion::CellSize::square(a.cell),
        )?;
        crate::erosion::tiled::erode_to_paths(
            &model,
            &src,
            &[(0, a.output.clone())],
            oo,
            a.tile,
            8,
            None,
            cfg,
        )?;
    }
    notify(Note::Wrote(a.output.clone()));
    if let Some(p) = &a.preview {
        let out = crate::io::open_raster(&a.output, &crate::io::OpenOptions::default())?;
        preview(out.as_ref(), p, RenderKind::Elevation, notify)?;
    }
    Ok(())
}
