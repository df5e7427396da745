//! Web-map pyramids (projections, encodings, MBTiles/PMTiles) and the preview
//! renderer.

#[path = "../common/mod.rs"]
mod common;

mod preview;
mod pyramid;
