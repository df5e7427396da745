//! Terrain descriptors: pointwise metrics computed per tile with a halo.

pub mod neighbourhood;
pub mod terrain;

pub use neighbourhood::EdgeMode;
pub use terrain::{Aspect, Hillshade, Slope, SlopeUnits};
