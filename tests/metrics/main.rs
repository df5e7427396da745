//! Terrain metrics: slope, aspect and hillshade, curvatures and windowed
//! statistics, descriptors, landforms, solar and visibility metrics against
//! closed forms, brute force and gdaldem; tiled == untiled; the metric table
//! and viewshed commands.

#[path = "../common/mod.rs"]
mod common;

mod asymmetry_index;
mod cli_table;
mod cli_viewshed;
mod curvature_and_windows;
mod dominance;
mod gdaldem_slope_aspect;
mod gdaldem_tri_tpi;
mod landform;
mod multiscale_peakedness;
mod percentile_and_normal_z;
mod pointwise_descriptors;
mod slope_closed_form;
mod solar;
mod tiled;
mod visibility;
