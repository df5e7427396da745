//! Terrain synthesis: noise, example-based optimisation, river networks,
//! tectonic folds and orometric synthesis (profiles, divide trees, terrain,
//! authoring, blends).

#[path = "../oro_common/mod.rs"]
mod oro_common;

mod noise;
mod noise_oracles;
mod optimise;
mod orometric;
mod orometric_author;
mod orometric_blend;
mod orometric_render_peaks;
mod orometric_terrain;
mod rivers;
mod tectonic;
