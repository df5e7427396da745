//! Web-map pyramids (projections, encodings, MBTiles/PMTiles) and the preview
//! renderer.

#[path = "../common/mod.rs"]
mod common;

mod cli;
mod preview;
mod pyramid;
