//! Terrain synthesis: seeded, tileable noise terrains (`noise`: fBm, ridged,
//! billow, simplex, warped; `diamond_square`; `spectral`).

pub mod diamond_square;
pub mod noise;
pub mod optimise;
pub mod simplex;
pub mod spectral;

pub use noise::{Fbm, FbmSource, Noise, NoiseKind, NoiseSource};
