//! Orometric terrain synthesis after Argudo, Galin, Peytavie, Paris, Gain &
//! Guérin 2019, "Orometry-based terrain analysis and synthesis", ACM TOG
//! 38(6) (SIGGRAPH Asia), §5–7.
//!
//! Pipeline: a [`SynthProfile`] (target distributions measured on a real
//! DEM, [`profile`]) → a divide tree ([`synthesize_tree`]: peaks by dart
//! throwing, ridges by a Delaunay minimum spanning tree, saddle elevations
//! by optimal assignment, [`assign`]) → a terrain (any window on demand, so
//! it streams to a tile store). The divide tree is JSON and
//! editable between the two steps.
//!
//! Terrain models ([`build_terrain`]): [`TinTerrain`] (default; the paper's
//! §6: [`rivers`] dual of the tree, valley widths, constrained TIN, [`tin`])
//! and [`OroTerrain`] (tents).
//!
//! Authoring: fixed peaks, edits of a synthesised tree followed by
//! regeneration ([`edit`]), pasting a fragment of a real divide tree
//! ([`fragment`]) and a type map C_T mixing several profiles ([`typemap`]).

pub mod assign;
pub mod clearance;
pub mod edit;
pub mod fragment;
pub mod minimax;
pub mod profile;
pub mod reconstruct;
pub mod rivers;
pub mod terrain;
pub mod terrain_tin;
pub mod tin;
pub mod tree_synth;
pub mod typemap;

pub use edit::{apply_edits, TreeEdit, TreeEdits};
pub use fragment::Fragment;
pub use profile::{Hist, PeakSamples, SynthProfile};
pub use terrain::{build_terrain, OroTerrain, TerrainModel, TerrainOptions};
pub use terrain_tin::TinTerrain;
pub use tree_synth::{
    ridge_tree, ridge_tree_with, synthesize_tree, FixedRidge, SynthPeak, SynthSaddle, SynthTree,
    TreeOptions,
};
pub use typemap::TypeMap;
