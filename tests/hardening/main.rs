//! Hostile input and interruption: concurrent writers, crash points and I/O
//! errors, killed tile runs, numerics at the edges of f32/f64, hostile
//! GeoTIFFs, and the fuzz seeds and findings.

#[path = "../common/mod.rs"]
mod common;

mod crashes_and_io_errors;
mod fuzz_findings;
mod fuzz_seeds;
mod hostile_geotiff;
mod killed_tiles_and_bathymetry;
mod numerics;
