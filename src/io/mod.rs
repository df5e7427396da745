//! Readers and writers.

pub mod geotiff;
