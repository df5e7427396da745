//! Orometric terrain synthesis after Argudo, Galin, Peytavie, Paris, Gain &
//! Guérin 2019, "Orometry-based terrain analysis and synthesis", ACM TOG
//! 38(6) (SIGGRAPH Asia), §5–7.
//!
//! Pipeline: a [`SynthProfile`] (target distributions measured on a real
//! DEM, [`profile`]) → a divide tree ([`synthesize_tree`]: peaks by dart
//! throwing, ridges by a Delaunay minimum spanning tree, saddle elevations
//! by optimal assignment, [`assign`]) → a terrain ([`OroTerrain`]: ridges
//! refined and rasterised as an upper envelope of tents, any window on
//! demand, so it streams to a tile store). The divide tree is JSON and
//! editable between the two steps.
//!
//! Authoring: fixed peaks, edits of a synthesised tree followed by
//! regeneration ([`edit`]), pasting a fragment of a real divide tree
//! ([`fragment`]) and a type map C_T mixing several profiles ([`typemap`]).

pub mod assign;
pub mod edit;
pub mod fragment;
pub mod profile;
pub mod terrain;
pub mod tree_synth;
pub mod typemap;

pub use edit::{apply_edits, TreeEdit, TreeEdits};
pub use fragment::Fragment;
pub use profile::{Hist, PeakSamples, SynthProfile};
pub use terrain::{OroTerrain, TerrainOptions};
pub use tree_synth::{
    ridge_tree, ridge_tree_with, synthesize_tree, FixedRidge, SynthPeak, SynthSaddle, SynthTree,
    TreeOptions,
};
pub use typemap::TypeMap;
