//! Readers and writers of raster formats: GeoTIFF read against GDAL's
//! fixtures, GeoTIFF and COG writing, ESRI ASCII, SRTM .hgt, PNG heightmaps,
//! mosaics and GDAL VRT mosaics.

#[path = "../common/mod.rs"]
mod common;

mod ascii;
mod cog;
mod geotiff_cases;
mod geotiff_read;
mod geotiff_write;
mod hgt;
mod mosaic;
mod png;
mod scaling;
mod vrt;
