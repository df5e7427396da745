//! `orogen synth noise`: the arguments of `orogen::ops::synth::noise` (see `orogen::synth::noise`:
//! fBm, ridged multifractal, billow, simplex, domain-warped, diamond-square,
//! power-law spectral), generated tile by tile and streamed to any output, so
//! a tile store of any size is written in bounded memory.

use super::erode::printer;
use crate::{engine, output_options, Out, Run};
use anyhow::Result;
use clap::{Args, ValueEnum};
use orogen::ops::synth::noise::{self, NoiseOptions};
use orogen::synth::NoiseKind;

/// The kinds of noise, as named on the command line.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum Kind {
    /// fBm of gradient noise.
    Fbm,
    /// Ridged multifractal (sharp crests).
    Ridged,
    /// fBm of |noise| (rounded hills, creased valleys).
    Billow,
    /// fBm of simplex noise.
    Simplex,
    /// Domain-warped ridged multifractal blended with fBm.
    Warped,
    /// Diamond-square midpoint displacement.
    DiamondSquare,
    /// Power-law spectral synthesis (power ∝ f^-beta).
    Spectral,
}

impl From<Kind> for NoiseKind {
    fn from(k: Kind) -> NoiseKind {
        match k {
            Kind::Fbm => NoiseKind::Fbm,
            Kind::Ridged => NoiseKind::Ridged,
            Kind::Billow => NoiseKind::Billow,
            Kind::Simplex => NoiseKind::Simplex,
            Kind::Warped => NoiseKind::Warped,
            Kind::DiamondSquare => NoiseKind::DiamondSquare,
            Kind::Spectral => NoiseKind::Spectral,
        }
    }
}

/// Arguments of `orogen synth noise`.
#[derive(Args)]
pub struct NoiseArgs {
    /// Kind of noise.
    #[arg(long, value_enum, default_value_t = Kind::Fbm)]
    pub kind: Kind,
    /// Size in cells, WIDTHxHEIGHT (or one number for a square).
    #[arg(long, default_value = "1024")]
    pub size: String,
    /// Cell size in metres.
    #[arg(long, default_value_t = 30.0)]
    pub cell: f64,
    /// Random seed.
    #[arg(long, default_value_t = 42)]
    pub seed: u64,
    /// Octaves (fbm, ridged, billow, simplex, warped).
    #[arg(long, default_value_t = 8)]
    pub octaves: u32,
    /// Frequency multiplier between octaves (2 for diamond-square and spectral).
    #[arg(long, default_value_t = 2.0)]
    pub lacunarity: f64,
    /// Amplitude multiplier between octaves, in (0, 1) (diamond-square: per level).
    #[arg(long, default_value_t = 0.5)]
    pub gain: f64,
    /// Wavelength of the first octave in cells (diamond-square: coarse lattice
    /// spacing; spectral: longest wavelength).
    #[arg(long, default_value_t = 512.0)]
    pub wavelength: f64,
    /// Mean elevation (m).
    #[arg(long, default_value_t = 1200.0)]
    pub base: f64,
    /// Amplitude (m): elevations span about base ± amplitude.
    #[arg(long, default_value_t = 1400.0)]
    pub amplitude: f64,
    /// Ridged/warped: Musgrave's offset.
    #[arg(long, default_value_t = 1.0)]
    pub ridge_offset: f64,
    /// Ridged/warped: Musgrave's weight gain.
    #[arg(long, default_value_t = 2.0)]
    pub ridge_gain: f64,
    /// Warped: domain-warp displacement in cells.
    #[arg(long, default_value_t = 80.0)]
    pub warp: f64,
    /// Warped: share of the ridged multifractal in the blend with fBm (0..1).
    #[arg(long, default_value_t = 0.7)]
    pub blend: f64,
    /// Spectral: exponent of the power spectrum, power ∝ frequency^-beta.
    #[arg(long, default_value_t = 3.0)]
    pub beta: f64,
    #[command(flatten)]
    pub out: Out,
    #[command(flatten)]
    pub run: Run,
}

/// Generate and write the terrain.
pub fn run(a: NoiseArgs) -> Result<()> {
    let opts = NoiseOptions {
        kind: a.kind.into(),
        size: a.size,
        cell: a.cell,
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
        output: a.out.output.clone(),
        tile: a.run.tile,
    };
    let cfg = engine(&a.run)?;
    let oo = output_options(&a.out.fmt)?;
    noise::run(&opts, &oo, &cfg, &mut printer(a.run.quiet))?;
    Ok(())
}
