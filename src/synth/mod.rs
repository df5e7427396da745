//! Terrain synthesis: seeded, tileable noise terrains (`noise`: fBm, ridged,
//! billow, simplex, warped; `diamond_square`; `spectral`), river-network
//! terrain (`rivers`), tectonic folds from a vector map (`tectonic`,
//! `vector`), example-based optimisation (`optimise`) and orometric synthesis
//! from a region's profile through a divide tree (`orometric`).

pub mod diamond_square;
pub mod noise;
pub mod optimise;
pub mod orometric;
pub mod rivers;
pub mod simplex;
pub mod spectral;
pub mod tectonic;
pub mod vector;

pub use noise::{Fbm, FbmSource, Noise, NoiseKind, NoiseSource};
