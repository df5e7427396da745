//! Terrain synthesis. For now: seeded, tileable fBm (the demo terrain).

pub mod noise;
pub mod rivers;
pub mod tectonic;
pub mod vector;

pub use noise::{Fbm, FbmSource};
