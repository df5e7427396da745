//! Terrain synthesis: seeded, tileable noise terrains (`noise`: fBm, ridged,
//! billow, simplex, warped; `diamond_square`; `spectral`), river-network
//! terrain (`rivers`), tectonic folds from a vector map (`tectonic`,
//! `vector`), example-based optimisation (`optimise`) and orometric synthesis
//! from a region's profile through a divide tree (`orometric`).

pub(crate) mod buckets;
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

use crate::raster::{DType, GeoRef, RasterInfo};

/// The description of a synthetic raster source: `width` x `height` cells of
/// `dtype` on `georef`, read in blocks of 256 x 256, named `path` (a
/// placeholder such as `<fbm>`: nothing is on disk).
pub(crate) fn source_info(
    width: usize,
    height: usize,
    dtype: DType,
    georef: GeoRef,
    path: impl Into<std::path::PathBuf>,
) -> RasterInfo {
    RasterInfo {
        width,
        height,
        dtype,
        georef,
        block: (256, 256),
        path: path.into(),
    }
}
