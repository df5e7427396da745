//! GeoTIFF: a streaming reader ([`GeoTiffReader`], block by block through the
//! `tiff` crate's chunk API, with a decoder pool and a bounded block cache) and
//! a streaming tiled writer ([`GeoTiffWriter`], hand-written TIFF structure,
//! IFD first, as a Cloud-Optimized GeoTIFF needs).
//!
//! Georeferencing follows the GeoTIFF 1.0/1.1 specification (OGC 19-008r4):
//! ModelPixelScale + ModelTiepoint or ModelTransformation, the GeoKey
//! directory, and GDAL's private GDAL_NODATA tag (42113), with the transform
//! reported the way GDAL's `GetGeoTransform` reports it.

mod cache;
mod cog;
mod georef;
mod ifd;
mod lerc;
mod mask;
mod photometric;
mod reader;
mod rows;
mod writer;

pub use cog::{CogWriter, Resampling};
pub use georef::{format_nodata, parse_nodata};
pub use reader::{GeoTiffReader, ReaderOptions};
pub use writer::{write_geotiff, Compression, GeoTiffWriter, WriteOptions};

/// TIFF compression codes orogen reads.
pub(crate) const SUPPORTED_COMPRESSION: &str =
    "none (1), LZW (5), DEFLATE (8 and 32946), PackBits (32773), ZSTD (50000), LERC (34887, with DEFLATE or ZSTD)";
