//! `orogen synth rivers`: river-network terrain (see
//! `orogen::synth::rivers`): the river graph is built once, then the terrain
//! is rasterised tile by tile and streamed to any output.

use super::synth_noise::parse_size;
use super::synth_tectonic::{parse_xy, preview};
use crate::{engine, output_options, wrote, Out, Run};
use anyhow::{bail, Result};
use clap::Args;
use orogen::raster::{Crs, GeoRef};
use orogen::synth::rivers::{network_geojson, LandMask, RiverNetwork, RiverParams, RiverTerrain};
use orogen::synth::vector::VectorMap;
use orogen::tiles::render::RenderKind;
use std::path::PathBuf;

/// Arguments of `orogen synth rivers`.
#[derive(Args)]
pub struct RiversArgs {
    /// Size in cells, WIDTHxHEIGHT (or one number for a square).
    #[arg(long, default_value = "1024")]
    pub size: String,
    /// Cell size in metres.
    #[arg(long, default_value_t = 30.0)]
    pub cell: f64,
    /// Top-left corner X,Y of the output (metres); default 0, height x cell.
    #[arg(long)]
    pub origin: Option<String>,
    /// Random seed (nodes, growth jitter, noise land mask).
    #[arg(long, default_value_t = 42)]
    pub seed: u64,
    /// Spacing of the river nodes (cells).
    #[arg(long, default_value_t = 12.0)]
    pub radius: f64,
    /// Land mask from the coastline polygons of this GeoJSON map instead of noise.
    #[arg(long)]
    pub coast: Option<PathBuf>,
    /// Units of the --coast map: crs (metres, like --origin) or pixels.
    #[arg(long, default_value = "crs")]
    pub map_units: String,
    /// Noise land mask: wavelength (cells; default: half the larger side).
    #[arg(long)]
    pub land_wavelength: Option<f64>,
    /// Noise land mask: threshold (higher = less land).
    #[arg(long, default_value_t = -0.1)]
    pub land_threshold: f64,
    /// Directional inertia of river growth (0 = none).
    #[arg(long, default_value_t = 1.0)]
    pub inertia: f64,
    /// Random perturbation of river growth (0..1).
    #[arg(long, default_value_t = 0.5)]
    pub jitter: f64,
    /// River slope at a drainage area of 1 km² (m/m).
    #[arg(long, default_value_t = 0.05)]
    pub channel_slope: f64,
    /// Slope-area exponent.
    #[arg(long, default_value_t = 0.45)]
    pub concavity: f64,
    /// Smallest river slope (m/m).
    #[arg(long, default_value_t = 0.0005)]
    pub min_slope: f64,
    /// Slope cap (m/m), like a talus angle.
    #[arg(long, default_value_t = 0.7)]
    pub max_slope: f64,
    /// Smallest hillslope beside rivers (m/m).
    #[arg(long, default_value_t = 0.05)]
    pub hill_slope: f64,
    /// Sea floor depth (m).
    #[arg(long, default_value_t = 20.0)]
    pub sea_depth: f64,
    /// Write the river trees as GeoJSON lines (drainage area, heights) here.
    #[arg(long)]
    pub network: Option<PathBuf>,
    /// Write a hillshaded preview PNG here.
    #[arg(long)]
    pub preview: Option<PathBuf>,
    #[command(flatten)]
    pub out: Out,
    #[command(flatten)]
    pub run: Run,
}

/// Build the network and write the terrain.
pub fn run(a: RiversArgs) -> Result<()> {
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
                "crs" => orogen::synth::tectonic::map_to_pixels(&map, &georef)?,
                "pixels" => map,
                u => bail!("--map-units {u:?}: use crs or pixels"),
            };
            LandMask::Rings(px.coasts)
        }
        None => LandMask::Noise {
            fbm: orogen::synth::Fbm {
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
    let cfg = engine(&a.run)?;
    let oo = output_options(&a.out.fmt)?;
    let net = RiverNetwork::build(w, h, a.cell, &p)?;
    if let Some(path) = &a.network {
        let text = serde_json::to_string(&network_geojson(&net, &georef))?;
        orogen::io::atomic::write_file_atomic(path, text.as_bytes())?;
        wrote(path);
    }
    let src = RiverTerrain::new(net, w, h, a.cell, a.radius, a.sea_depth, Some(georef))?;
    orogen::ops::convert(&src, &a.out.output, &oo, a.run.tile, &cfg)?;
    wrote(&a.out.output);
    if let Some(pv) = &a.preview {
        preview(&src, pv, RenderKind::Elevation)?;
    }
    Ok(())
}
