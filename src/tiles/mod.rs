//! Tile-server outputs: web-map pyramids in Web Mercator ([`pyramid`]),
//! packed as MBTiles and PMTiles ([`archive`]), with the projections they
//! need ([`proj`], which lives in `raster::proj`), previews of a raster
//! as a PNG ([`render`]), and read back ([`reader`]: folders, MBTiles,
//! PMTiles metadata). Cloud-Optimized GeoTIFFs are in `io::geotiff::CogWriter`.

#[cfg(feature = "archives")]
pub mod archive;
pub mod pyramid;
#[cfg(feature = "archives")]
pub mod reader;
pub mod render;

pub use crate::raster::proj;

pub use pyramid::{build_pyramid, Encoding, PyramidInfo, PyramidOptions, Resampling};
#[cfg(feature = "archives")]
pub use reader::TileSource;
