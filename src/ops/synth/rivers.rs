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

/// Options of `synth rivers` (the CLI's names and defaults).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields, default)]
pub struct RiversOptions {
    /// Size in cells, WIDTHxHEIGHT (or one number for a square).
    pub size: String,
    /// Cell size in metres.
    pub cell: f64,
    /// Top-left corner X,Y of the output (metres); default 0, height x cell.
    pub origin: Option<String>,
    /// Random seed (nodes, growth jitter, noise land mask).
    pub seed: u64,
    /// Spacing of the river nodes (cells).
    pub radius: f64,
    /// Land mask from the coastline polygons of this GeoJSON map instead of noise.
    pub coast: Option<PathBuf>,
    /// Units of the coast map: crs (metres, like `origin`) or pixels.
    pub map_units: String,
    /// Noise land mask: wavelength (cells; default: half the larger side).
    pub land_wavelength: Option<f64>,
    /// Noise land mask: threshold (higher = less land).
    pub land_threshold: f64,
    /// Directional inertia of river growth (0 = none).
    pub inertia: f64,
    /// Random perturbation of river growth (0..1).
    pub jitter: f64,
    /// River slope at a drainage area of 1 km² (m/m).
    pub channel_slope: f64,
    /// Slope-area exponent.
    pub concavity: f64,
    /// Smallest river slope (m/m).
    pub min_slope: f64,
    /// Slope cap (m/m), like a talus angle.
    pub max_slope: f64,
    /// Smallest hillslope beside rivers (m/m).
    pub hill_slope: f64,
    /// Sea floor depth (m).
    pub sea_depth: f64,
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
            seed: 42,
            radius: 12.0,
            coast: None,
            map_units: "crs".into(),
            land_wavelength: None,
            land_threshold: -0.1,
            inertia: 1.0,
            jitter: 0.5,
            channel_slope: 0.05,
            concavity: 0.45,
            min_slope: 0.0005,
            max_slope: 0.7,
            hill_slope: 0.05,
            sea_depth: 20.0,
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
                seed: a.seed ^ 0x1a4d,
                octaves: 6,
                wavelength: a.land_wavelength.unwrap_or(w.max(h) as f64 / 2.0),
                warp: 0.0,
                ..Default::default()
            },
            threshold: a.land_threshold,
        },
    };
    let p = RiverParams {
        seed: a.seed,
        radius: a.radius,
        mask,
        inertia: a.inertia,
        jitter: a.jitter,
        channel_slope: a.channel_slope,
        concavity: a.concavity,
        min_slope: a.min_slope,
        max_slope: a.max_slope,
        hill_slope: a.hill_slope,
        sea_depth: a.sea_depth,
    };
    let net = RiverNetwork::build(w, h, a.cell, &p)?;
    if let Some(path) = &a.network {
        let text = serde_json::to_string(&network_geojson(&net, &georef))
            .map_err(|e| Error::invalid(e.to_string()))?;
        crate::io::atomic::write_file_atomic(path, text.as_bytes())?;
        notify(Note::Wrote(path.clone()));
    }
    let src = RiverTerrain::new(net, w, h, a.cell, a.radius, a.sea_depth, Some(georef))?;
    crate::ops::convert(&src, &a.output, oo, a.tile, cfg)?;
    notify(Note::Wrote(a.output.clone()));
    if let Some(pv) = &a.preview {
        preview(&src, pv, RenderKind::Elevation, notify)?;
    }
    Ok(())
}
