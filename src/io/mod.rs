//! Readers and writers.
pub mod ascii;
pub mod hgt;
pub mod mosaic;
pub mod png;
pub mod render;
