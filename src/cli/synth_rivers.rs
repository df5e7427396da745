//! `orogen synth rivers`: the arguments of `orogen::ops::synth::rivers`
//! (river-network terrain, see `orogen::synth::rivers`).

use super::erode::printer;
use crate::{engine, output_options, Out, Run};
use anyhow::Result;
use clap::Args;
use orogen::ops::synth::rivers::{self, RiversOptions};
use orogen::synth::rivers::RiverParams;
use std::path::PathBuf;

/// The river parameters on the command line, defaults from
/// [`RiverParams::default`]; converted once into a [`RiverParams`] (the
/// land mask is `synth rivers`' own options).
#[derive(Args)]
pub struct RiverArgs {
    /// Random seed (nodes, growth jitter, noise land mask).
    #[arg(long, default_value_t = RiverParams::default().seed)]
    pub seed: u64,
    /// Spacing of the river nodes (cells).
    #[arg(long, default_value_t = RiverParams::default().radius)]
    pub radius: f64,
    /// Directional inertia of river growth (0 = none).
    #[arg(long, default_value_t = RiverParams::default().inertia)]
    pub inertia: f64,
    /// Random perturbation of river growth (0..1).
    #[arg(long, default_value_t = RiverParams::default().jitter)]
    pub jitter: f64,
    /// River slope at a drainage area of 1 km² (m/m).
    #[arg(long, default_value_t = RiverParams::default().channel_slope)]
    pub channel_slope: f64,
    /// Slope-area exponent.
    #[arg(long, default_value_t = RiverParams::default().concavity)]
    pub concavity: f64,
    /// Smallest river slope (m/m).
    #[arg(long, default_value_t = RiverParams::default().min_slope)]
    pub min_slope: f64,
    /// Slope cap (m/m), like a talus angle.
    #[arg(long, default_value_t = RiverParams::default().max_slope)]
    pub max_slope: f64,
    /// Smallest hillslope beside rivers (m/m).
    #[arg(long, default_value_t = RiverParams::default().hill_slope)]
    pub hill_slope: f64,
    /// Sea floor depth (m).
    #[arg(long, default_value_t = RiverParams::default().sea_depth)]
    pub sea_depth: f64,
}

impl From<RiverArgs> for RiverParams {
    fn from(a: RiverArgs) -> RiverParams {
        RiverParams {
            seed: a.seed,
            radius: a.radius,
            inertia: a.inertia,
            jitter: a.jitter,
            channel_slope: a.channel_slope,
            concavity: a.concavity,
            min_slope: a.min_slope,
            max_slope: a.max_slope,
            hill_slope: a.hill_slope,
            sea_depth: a.sea_depth,
            ..RiverParams::default()
        }
    }
}

/// Arguments of `orogen synth rivers`.
#[derive(Args)]
pub struct RiversArgs {
    /// Size in cells, WIDTHxHEIGHT (or one number for a square).
    #[arg(long, default_value_t = RiversOptions::default().size)]
    pub size: String,
    /// Cell size in metres.
    #[arg(long, default_value_t = RiversOptions::default().cell)]
    pub cell: f64,
    /// Top-left corner X,Y of the output (metres); default 0, height x cell.
    #[arg(long)]
    pub origin: Option<String>,
    /// Land mask from the coastline polygons of this GeoJSON map instead of noise.
    #[arg(long)]
    pub coast: Option<PathBuf>,
    /// Units of the --coast map: crs (metres, like --origin) or pixels.
    #[arg(long, default_value_t = RiversOptions::default().map_units)]
    pub map_units: String,
    /// Noise land mask: wavelength (cells; default: half the larger side).
    #[arg(long)]
    pub land_wavelength: Option<f64>,
    /// Noise land mask: threshold (higher = less land).
    #[arg(long, default_value_t = RiversOptions::default().land_threshold)]
    pub land_threshold: f64,
    #[command(flatten)]
    pub river: RiverArgs,
    /// Write the river trees as GeoJSON lines (drainage area, heights) here,
    /// in the synthetic terrain's map metres (it has no place on Earth, so
    /// not RFC 7946 lon/lat and no "crs" member).
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
    let opts = RiversOptions {
        size: a.size,
        cell: a.cell,
        origin: a.origin,
        coast: a.coast,
        map_units: a.map_units,
        land_wavelength: a.land_wavelength,
        land_threshold: a.land_threshold,
        river: a.river.into(),
        network: a.network,
        preview: a.preview,
        output: a.out.output.clone(),
        tile: a.run.tile,
    };
    let cfg = engine(&a.run)?;
    let oo = output_options(&a.out.fmt)?;
    rivers::run(&opts, &oo, &cfg, &mut printer(a.run.quiet))?;
    Ok(())
}
