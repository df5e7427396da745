//! `synth noise`: seeded noise terrains (see `crate::synth::noise`: fBm,
//! ridged multifractal, billow, simplex, domain-warped, diamond-square,
//! power-law spectral), generated tile by tile and streamed to any output, so
//! a tile store of any size is written in bounded memory.
//!
//! ```
//! use orogen::exec::EngineConfig;
//! use orogen::ops::synth::noise::{self, NoiseOptions};
//! use orogen::raster::{read_window, Window};
//! let dir = std::env::temp_dir().join(format!("orogen-doc-noise-{}", std::process::id()));
//! std::fs::create_dir_all(&dir)?;
//! let cfg = EngineConfig { threads: 1, ..Default::default() };
//! let read = |opts: &NoiseOptions| -> orogen::Result<Vec<f32>> {
//!     noise::run(opts, &Default::default(), &cfg, &mut |_| {})?;
//!     let src = orogen::io::open_raster(&opts.output, &Default::default())?;
//!     assert_eq!((src.info().width, src.info().height), (96, 64));
//!     Ok(read_window::<f32>(src.as_ref(), Window::full(96, 64))?.data().to_vec())
//! };
//! let a = NoiseOptions { size: "96x64".into(), seed: 7, output: dir.join("a.tif"), ..Default::default() };
//! let b = NoiseOptions { output: dir.join("b.tif"), tile: Some(40), ..a.clone() };
//! let c = NoiseOptions { output: dir.join("c.tif"), seed: 8, ..a.clone() };
//! // The same seed gives the same terrain whatever the tiling; another seed another one.
//! assert_eq!(read(&a)?, read(&b)?);
//! assert_ne!(read(&a)?, read(&c)?);
//! assert!(read(&a)?.iter().all(|v| v.is_finite()));
//! std::fs::remove_dir_all(&dir)?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use super::parse_size;
use crate::error::Result;
use crate::exec::EngineConfig;
use crate::io::OutputOptions;
use crate::ops::note::{Note, Notify};
use crate::synth::{Noise, NoiseKind, NoiseSource};
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// Options of `synth noise` (the CLI's names and defaults).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields, default)]
pub struct NoiseOptions {
    /// Kind of noise.
    pub kind: NoiseKind,
    /// Size in cells, WIDTHxHEIGHT (or one number for a square).
    pub size: String,
    /// Cell size in metres.
    pub cell: f64,
    /// Random seed.
    pub seed: u64,
    /// Octaves (fbm, ridged, billow, simplex, warped).
    pub octaves: u32,
    /// Frequency multiplier between octaves.
    pub lacunarity: f64,
    /// Amplitude multiplier between octaves, in (0, 1).
    pub gain: f64,
    /// Wavelength of the first octave in cells.
    pub wavelength: f64,
    /// Mean elevation (m).
    pub base: f64,
    /// Amplitude (m): elevations span about base ± amplitude.
    pub amplitude: f64,
    /// Ridged/warped: Musgrave's offset.
    pub ridge_offset: f64,
    /// Ridged/warped: Musgrave's weight gain.
    pub ridge_gain: f64,
    /// Warped: domain-warp displacement in cells.
    pub warp: f64,
    /// Warped: share of the ridged multifractal in the blend with fBm (0..1).
    pub blend: f64,
    /// Spectral: exponent of the power spectrum.
    pub beta: f64,
    /// Output raster.
    pub output: PathBuf,
    /// Work-tile size in cells (default 1024).
    pub tile: Option<usize>,
}

impl Default for NoiseOptions {
    fn default() -> Self {
        NoiseOptions {
            kind: NoiseKind::Fbm,
            size: "1024".into(),
            cell: 30.0,
            seed: 42,
            octaves: 8,
            lacunarity: 2.0,
            gain: 0.5,
            wavelength: 512.0,
            base: 1200.0,
            amplitude: 1400.0,
            ridge_offset: 1.0,
            ridge_gain: 2.0,
            warp: 80.0,
            blend: 0.7,
            beta: 3.0,
            output: PathBuf::new(),
            tile: None,
        }
    }
}

/// Generate the terrain and write it to `opts.output`.
pub fn run(
    opts: &NoiseOptions,
    oo: &OutputOptions,
    cfg: &EngineConfig,
    notify: Notify<'_>,
) -> Result<()> {
    let a = opts;
    let (w, h) = parse_size(&a.size)?;
    let noise = Noise {
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
    };
    let src = NoiseSource::new(noise, w, h, a.cell)?;
    crate::ops::convert(&src, &a.output, oo, a.tile, cfg)?;
    notify(Note::Wrote(a.output.clone()));
    Ok(())
}
