//! `synth rivers`: river-network terrain (see `crate::synth::rivers`,
//! Génevaux et al. 2013): the river graph is built once, then the terrain is
//! rasterised tile by tile and streamed to any output.

use super::{parse_size, parse_xy, preview};
use crate::error::{Error, Result};
use crate::exec::EngineConfig;
use crate::io::OutputOptions;
use crate::ops::note::{bail, Note, Notify};
use crate::raster::{Crs, GeoRef};
use crate::synth::rivers::{network_geojson, LandMask, RiverNetwork, RiverParams, RiverTerrain};
use crate::synth::vector::VectorMap;
use crate::tiles::render::RenderKind;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// Options of `synth rivers` (the CLI's names and defaults): the raster's
/// extent, the land mask, the river parameters ([`RiverParams`], its keys
/// flat beside these; its mask is built here from `coast` or the `land-*`
/// keys) and the outputs.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields, default)]
pub struct RiversOptions {
    /// Size in cells, WIDTHxHEIGHT (or one number for a square).
    pub size: String,
    /// Cell size in metres.
    pub cell: f64,
    /// Top-left corner X,Y of the output (metres); default 0, height x cell.
    pub origin: Option<String>,
    /// Land mask from the coastline polygons of this GeoJSON map instead of noise.
    pub coast: Option<PathBuf>,
    /// Units of the coast map: crs (metres, like `origin`) or pixels.
    pub map_units: String,
    /// Noise land mask: wavelength (cells; default: half the larger side).
    pub land_wavelength: Option<f64>,
    /// Noise land mask: threshold (higher = less land).
    pub land_threshold: f64,
    /// The river network: seed, node spacing, growth, slopes, sea depth.
    #[serde(flatten)]
    pub river: RiverParams,
    /// Write the river trees as GeoJSON lines here.
    pub network: Option<PathBuf>,
    /// Write a hillshaded preview PNG here.
    pub preview: Option<PathBuf>,
    /// Output raster.
    pub output: PathBuf,
    /// Work-tile size in cells (default 1024).
    pub tile: Option<usize>,
}

impl Default for RiversOptions {
    fn default() -> Self {
        RiversOptions {
            size: "1024".into(),
            cell: 30.0,
            origin: None,
            coast: None,
            map_units: "crs".into(),
            land_wavelength: None,
            land_threshold: -0.1,
            river: RiverParams::default(),
            network: None,
            preview: None,
            output: PathBuf::new(),
            tile: None,
        }
    }
}

/// Build the network and write the terrain (and the network and preview asked for).
pub fn run(
    opts: &RiversOptions,
    oo: &OutputOptions,
    cfg: &EngineConfig,
    notify: Notify<'_>,
) -> Result<()> {
    let a = opts;
    let (w, h) = parse_size(&a.size)?;
    if !(a.cell.is_finite() && a.cell > 0.0) {
        bail!("--cell must be a positive number of metres");
    }
    let (x0, y0) = match &a.origin {
        Some(o) => parse_xy(o, "--origin")?,
        None => (0.0, h as f64 * a.cell),
    };
    let georef = GeoRef::north_up(x0, y0, a.cell, Crs::default());
    let mask = match &a.coast {
        Some(path) => {
            let map = VectorMap::read(path)?;
            if map.coasts.is_empty() {
                bail!("{}: no coastline polygons", path.display());
            }
            let px = match a.map_units.as_str() {
                "crs" => crate::synth::tectonic::map_to_pixels(&map, &georef)?,
                "pixels" => map,
                u => bail!("--map-units {u:?}: use crs or pixels"),
            };
            LandMask::Rings(px.coasts)
        }
        None => LandMask::Noise {
            fbm: crate::synth::Fbm {
                seed: a.river.seed ^ 0x1a4d,
                octaves: 6,
                wavelength: a.land_wavelength.unwrap_or(w.max(h) as f64 / 2.0),
                warp: 0.0,
                ..Default::default()
            },
            threshold: a.land_threshold,
        },
    };
    let p = RiverParams {
        mask,
        ..a.river.clone()
    };
    let net = RiverNetwork::build(w, h, a.cell, &p)?;
    if let Some(path) = &a.network {
        let text = serde_json::to_string(&network_geojson(&net, &georef))
            .map_err(|e| Error::invalid(e.to_string()))?;
        crate::io::atomic::write_file_atomic(path, text.as_bytes())?;
        notify(Note::Wrote(path.clone()));
    }
    let src = RiverTerrain::new(net, w, h, a.cell, p.radius, p.sea_depth, Some(georef))?;
    crate::ops::convert(&src, &a.output, oo, a.tile, cfg)?;
    notify(Note::Wrote(a.output.clone()));
    if let Some(pv) = &a.preview {
        preview(&src, pv, RenderKind::Elevation, notify)?;
    }
    Ok(())
}
