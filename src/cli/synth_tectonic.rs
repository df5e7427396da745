//! `orogen synth tectonic`: the arguments of `orogen::ops::synth::tectonic`
//! (tectonic folds from a GeoJSON map, see `orogen::synth::tectonic`).

use super::erode::printer;
use crate::{engine, output_options, Out, Run};
use anyhow::Result;
use clap::Args;
use orogen::ops::synth::tectonic::{self, TectonicOptions};
use orogen::synth::tectonic::TectonicParams;
use std::path::PathBuf;

/// The fold parameters on the command line, defaults from
/// [`TectonicParams::default`]; converted once into a [`TectonicParams`].
#[derive(Args)]
pub struct FoldArgs {
    /// Merge plates whose normalised velocities have a dot product >= T1.
    #[arg(long, default_value_t = TectonicParams::default().t1)]
    pub t1: f64,
    /// ... and whose area ratio (smaller/larger) is >= T2.
    #[arg(long, default_value_t = TectonicParams::default().t2)]
    pub t2: f64,
    /// Gaussian sigma of the velocity blur (cells).
    #[arg(long, default_value_t = TectonicParams::default().blur)]
    pub blur: f64,
    /// Warp strength: noise sampled at p + strength * V(p).
    #[arg(long, default_value_t = TectonicParams::default().fold_strength)]
    pub fold_strength: f64,
    /// Height of peaks without an elevation property (m).
    #[arg(long, default_value_t = TectonicParams::default().relief)]
    pub relief: f64,
    /// Attenuation radius of the folds around peaks (cells).
    #[arg(long, default_value_t = TectonicParams::default().peak_radius)]
    pub peak_radius: f64,
    /// Share of the noise in the folds (0..1).
    #[arg(long, default_value_t = TectonicParams::default().noise_share)]
    pub noise_share: f64,
    /// Slope along rivers in the watershed map (m/m).
    #[arg(long, default_value_t = TectonicParams::default().river_slope)]
    pub river_slope: f64,
    /// Slope away from rivers in the watershed map (m/m).
    #[arg(long, default_value_t = TectonicParams::default().hill_slope)]
    pub hill_slope: f64,
    /// Distance from rivers (cells) beyond which the folds apply fully.
    #[arg(long, default_value_t = TectonicParams::default().river_width)]
    pub river_width: f64,
    /// Longest side of the coarse grid for plates, velocity and watershed map.
    #[arg(long, default_value_t = TectonicParams::default().coarse)]
    pub coarse: usize,
}

impl From<FoldArgs> for TectonicParams {
    fn from(a: FoldArgs) -> TectonicParams {
        TectonicParams {
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
        }
    }
}

/// Arguments of `orogen synth tectonic`.
#[derive(Args)]
pub struct TectonicArgs {
    /// GeoJSON map: coastline polygons, river lines, peak points (format:
    /// docs/design/synthesis.md#tectonic-folds-synthtectonic; example: configs/tectonic-map.geojson).
    #[arg(long)]
    pub map: PathBuf,
    /// Units of the map's coordinates: crs (x east, y north, in the output
    /// CRS, metres) or pixels (column, row from the top-left corner).
    #[arg(long, default_value_t = TectonicOptions::default().map_units)]
    pub map_units: String,
    /// Size in cells, WIDTHxHEIGHT; default: the map's extent plus the margin.
    #[arg(long)]
    pub size: Option<String>,
    /// Cell size in metres.
    #[arg(long, default_value_t = TectonicOptions::default().cell)]
    pub cell: f64,
    /// Top-left corner X,Y in map units (crs only); default: from the map's extent.
    #[arg(long)]
    pub origin: Option<String>,
    /// Margin around the map's extent, as a fraction of its larger side.
    #[arg(long, default_value_t = TectonicOptions::default().margin)]
    pub margin: f64,
    /// Seed of the fold noise.
    #[arg(long, default_value_t = TectonicOptions::default().seed)]
    pub seed: u64,
    /// Wavelength of the fold noise (cells).
    #[arg(long, default_value_t = TectonicOptions::default().wavelength)]
    pub wavelength: f64,
    /// Octaves of the fold noise.
    #[arg(long, default_value_t = TectonicOptions::default().octaves)]
    pub octaves: u32,
    #[command(flatten)]
    pub folds: FoldArgs,
    /// Write plates, velocity (magnitude, direction), folds and the watershed map as GeoTIFFs here.
    #[arg(long)]
    pub intermediates: Option<PathBuf>,
    /// Write a hillshaded preview PNG of the terrain here (and PNGs of the intermediates).
    #[arg(long)]
    pub preview: Option<PathBuf>,
    /// Finish with this many substeps of hydraulic erosion (virtual pipes, default
    /// parameters; `orogen erode --model hydraulic` gives every parameter). 0 = none.
    #[arg(long, default_value_t = TectonicOptions::default().erode_steps)]
    pub erode_steps: u64,
    /// Seed of the erosion's rain.
    #[arg(long, default_value_t = TectonicOptions::default().erode_seed)]
    pub erode_seed: u64,
    #[command(flatten)]
    pub out: Out,
    #[command(flatten)]
    pub run: Run,
}

/// Generate and write the terrain (and intermediates).
pub fn run(a: TectonicArgs) -> Result<()> {
    let opts = TectonicOptions {
        map: a.map,
        map_units: a.map_units,
        size: a.size,
        cell: a.cell,
        origin: a.origin,
        margin: a.margin,
        seed: a.seed,
        wavelength: a.wavelength,
        octaves: a.octaves,
        folds: a.folds.into(),
        intermediates: a.intermediates,
        preview: a.preview,
        erode_steps: a.erode_steps,
        erode_seed: a.erode_seed,
        output: a.out.output.clone(),
        tile: a.run.tile,
    };
    let cfg = engine(&a.run)?;
    let oo = output_options(&a.out.fmt)?;
    tectonic::run(&opts, &oo, &cfg, &mut printer(a.run.quiet))?;
    Ok(())
}
