//! Web-map pyramids (projections, encodings, MBTiles/PMTiles) and the preview
//! renderer.

mod preview;
mod pyramid;
