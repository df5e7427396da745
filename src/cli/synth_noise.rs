//! `orogen synth noise`: the arguments of `orogen::ops::synth::noise` (see `orogen::synth::noise`:
//! fBm, ridged multifractal, billow, simplex, domain-warped, diamond-square,
//! power-law spectral), generated tile by tile and streamed to any output, so
//! a tile store of any size is written in bounded memory.

use super::erode::printer;
use crate::cli::args::enum_parser;
use crate::{engine, output_options, Out, Run};
use anyhow::Result;
use clap::Args;
use orogen::ops::synth::noise::{self, NoiseOptions};
use orogen::synth::{Noise, NoiseKind};

/// The noise parameters on the command line, defaults from
/// [`Noise::default`]; converted once into a [`Noise`].
#[derive(Args)]
pub struct NoiseParams {
    /// Kind of noise.
    #[arg(long, value_parser = enum_parser(&NoiseKind::ALL, NoiseKind::name, Some(NoiseKind::about)), default_value = Noise::default().kind.name())]
    pub kind: NoiseKind,
    /// Random seed.
    #[arg(long, default_value_t = Noise::default().seed)]
    pub seed: u64,
    /// Octaves (fbm, ridged, billow, simplex, warped).
    #[arg(long, default_value_t = Noise::default().octaves)]
    pub octaves: u32,
    /// Frequency multiplier between octaves (2 for diamond-square and spectral).
    #[arg(long, default_value_t = Noise::default().lacunarity)]
    pub lacunarity: f64,
    /// Amplitude multiplier between octaves, in (0, 1) (diamond-square: per level).
    #[arg(long, default_value_t = Noise::default().gain)]
    pub gain: f64,
    /// Wavelength of the first octave in cells (diamond-square: coarse lattice
    /// spacing; spectral: longest wavelength).
    #[arg(long, default_value_t = Noise::default().wavelength)]
    pub wavelength: f64,
    /// Mean elevation (m).
    #[arg(long, default_value_t = Noise::default().base)]
    pub base: f64,
    /// Amplitude (m): elevations span about base ± amplitude.
    #[arg(long, default_value_t = Noise::default().amplitude)]
    pub amplitude: f64,
    /// Ridged/warped: Musgrave's offset.
    #[arg(long, default_value_t = Noise::default().ridge_offset)]
    pub ridge_offset: f64,
    /// Ridged/warped: Musgrave's weight gain.
    #[arg(long, default_value_t = Noise::default().ridge_gain)]
    pub ridge_gain: f64,
    /// Warped: domain-warp displacement in cells.
    #[arg(long, default_value_t = Noise::default().warp)]
    pub warp: f64,
    /// Warped: share of the ridged multifractal in the blend with fBm (0..1).
    #[arg(long, default_value_t = Noise::default().blend)]
    pub blend: f64,
    /// Spectral: exponent of the power spectrum, power ∝ frequency^-beta.
    #[arg(long, default_value_t = Noise::default().beta)]
    pub beta: f64,
}

impl From<NoiseParams> for Noise {
    fn from(a: NoiseParams) -> Noise {
        Noise {
            kind: a.kind,
            seed: a.seed,
            octaves: a.octaves,
            lacunarity: a.lacunarity,
            gain: a.gain,
            wavelength: a.wavelength,
            base: a.base,
            amplitude: a.amplitude,
            ridge_offset: a.ridge_offset,
            ridge_gain: a.ridge_gain,
            warp: a.warp,
            blend: a.blend,
            beta: a.beta,
        }
    }
}

/// Arguments of `orogen synth noise`.
#[derive(Args)]
pub struct NoiseArgs {
    /// Size in cells, WIDTHxHEIGHT (or one number for a square).
    #[arg(long, default_value_t = NoiseOptions::default().size)]
    pub size: String,
    /// Cell size in metres.
    #[arg(long, default_value_t = NoiseOptions::default().cell)]
    pub cell: f64,
    #[command(flatten)]
    pub noise: NoiseParams,
    #[command(flatten)]
    pub out: Out,
    #[command(flatten)]
    pub run: Run,
}

/// Generate and write the terrain.
pub fn run(a: NoiseArgs) -> Result<()> {
    let opts = NoiseOptions {
        size: a.size,
        cell: a.cell,
        noise: a.noise.into(),
        output: a.out.output.clone(),
        tile: a.run.tile,
    };
    let cfg = engine(&a.run)?;
    let oo = output_options(&a.out.fmt)?;
    noise::run(&opts, &oo, &cfg, &mut printer(a.run.quiet))?;
    Ok(())
}
