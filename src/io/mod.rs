//! Readers and writers: GeoTIFF (streamed, no GDAL), SRTM .hgt, ESRI ASCII,
//! PNG heightmaps, mosaics of several files, GDAL VRT mosaics (`vrt`), previews, points from CSV and
//! GeoJSON files (`vector`), the coordinates of GeoJSON outputs and the `crs`
//! member of GeoJSON inputs (`geojson`); plus opening any of them by path.

pub mod ascii;
pub mod atomic;
pub mod geojson;
pub mod geotiff;
pub mod hgt;
pub mod memsink;
pub mod mosaic;
pub mod open;
pub mod png;
pub mod reassign;
pub mod scaling;
pub mod sinks;
pub mod vector;
pub mod vrt;

pub use open::{
    create_sink, create_sink_like, detect, is_store_path, open_inputs, open_raster, Format,
    OpenOptions, OutputOptions, Overviews,
};
