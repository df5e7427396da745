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
//! let mut a = NoiseOptions { size: "96x64".into(), output: dir.join("a.tif"), ..Default::default() };
//! a.noise.seed = 7;
//! let b = NoiseOptions { output: dir.join("b.tif"), tile: Some(40), ..a.clone() };
//! let mut c = NoiseOptions { output: dir.join("c.tif"), ..a.clone() };
//! c.noise.seed = 8;
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
use crate::synth::{Noise, NoiseSource};
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// Options of `synth noise` (the CLI's names and defaults): the raster's
/// size and cell, the noise parameters ([`Noise`], its keys flat beside
/// these) and the output.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields, default)]
pub struct NoiseOptions {
    /// Size in cells, WIDTHxHEIGHT (or one number for a square).
    pub size: String,
    /// Cell size in metres.
    pub cell: f64,
    /// The noise: kind, seed, octaves, amplitude...
    #[serde(flatten)]
    pub noise: Noise,
    /// Output raster.
    pub output: PathBuf,
    /// Work-tile size in cells (default 1024).
    pub tile: Option<usize>,
}

impl Default for NoiseOptions {
    fn default() -> Self {
        NoiseOptions {
            size: "1024".into(),
            cell: 30.0,
            noise: Noise::default(),
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
    let src = NoiseSource::new(a.noise.clone(), w, h, a.cell)?;
    crate::ops::convert(&src, &a.output, oo, a.tile, cfg)?;
    notify(Note::Wrote(a.output.clone()));
    Ok(())
}
