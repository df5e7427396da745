//! Terrain synthesis. For now: seeded, tileable fBm (the demo terrain).

pub mod noise;
pub mod optimise;

pub use noise::{Fbm, FbmSource};
