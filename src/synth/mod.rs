//! Terrain synthesis. For now: seeded, tileable fBm (the demo terrain).

pub mod noise;
pub mod orometric;

pub use noise::{Fbm, FbmSource};
