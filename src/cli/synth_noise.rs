//! `orogen synth noise`: seeded fBm terrain (see `orogen::synth::noise`),
//! generated tile by tile and streamed to any output, so a tile store of any
//! size is written in bounded memory.

use crate::{engine, output_options, wrote, Out, Run};
use anyhow::{bail, Context, Result};
use clap::Args;

/// Arguments of `orogen synth noise`.
#[derive(Args)]
pub struct NoiseArgs {
    /// Size in cells, WIDTHxHEIGHT (or one number for a square).
    #[arg(long, default_value = "1024")]
    pub size: String,
    /// Cell size in metres.
    #[arg(long, default_value_t = 30.0)]
    pub cell: f64,
    /// Random seed.
    #[arg(long, default_value_t = 42)]
    pub seed: u64,
    /// Octaves.
    #[arg(long, default_value_t = 10)]
    pub octaves: u32,
    /// Frequency multiplier between octaves.
    #[arg(long, default_value_t = 2.0)]
    pub lacunarity: f64,
    /// Amplitude multiplier between octaves.
    #[arg(long, default_value_t = 0.5)]
    pub gain: f64,
    /// Wavelength of the first octave in cells.
    #[arg(long, default_value_t = 512.0)]
    pub wavelength: f64,
    /// Mean elevation (m).
    #[arg(long, default_value_t = 1200.0)]
    pub base: f64,
    /// Amplitude (m).
    #[arg(long, default_value_t = 1400.0)]
    pub amplitude: f64,
    /// Domain-warp strength in cells (0 = none).
    #[arg(long, default_value_t = 60.0)]
    pub warp: f64,
    #[command(flatten)]
    pub out: Out,
    #[command(flatten)]
    pub run: Run,
}

/// Parse `WxH` or `N`.
pub fn parse_size(s: &str) -> Result<(usize, usize)> {
    let parse = |t: &str| -> Result<usize> {
        t.trim()
            .parse::<usize>()
            .with_context(|| format!("--size: '{t}' is not a whole number of cells"))
    };
    let (w, h) = match s.split_once(['x', 'X']) {
        Some((w, h)) => (parse(w)?, parse(h)?),
        None => {
            let n = parse(s)?;
            (n, n)
        }
    };
    if w == 0 || h == 0 {
        bail!("--size must be at least 1x1 (got {s})");
    }
    Ok((w, h))
}

/// Generate and write the terrain.
pub fn run(a: NoiseArgs) -> Result<()> {
    let (w, h) = parse_size(&a.size)?;
    let fbm = orogen::synth::Fbm {
        seed: a.seed,
        octaves: a.octaves,
        lacunarity: a.lacunarity,
        gain: a.gain,
        wavelength: a.wavelength,
        base: a.base,
        amplitude: a.amplitude,
        warp: a.warp,
    };
    let src = orogen::synth::FbmSource::new(fbm, w, h, a.cell)?;
    let cfg = engine(&a.run)?;
    let oo = output_options(&a.out.fmt)?;
    orogen::ops::convert(&src, &a.out.output, &oo, a.run.tile, &cfg)?;
    wrote(&a.out.output);
    Ok(())
}
