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
//! Terrain models ([`build_terrain`]): [`TinTerrain`] (default; the paper's
//! §6: [`rivers`] dual of the tree, valley widths, constrained TIN, [`tin`])
//! and [`OroTerrain`] (tents). Not here yet: the type map C_T mixing several
//! profiles, pasting real divide-tree fragments.

pub mod assign;
pub mod profile;
pub mod rivers;
pub mod terrain;
pub mod terrain_tin;
pub mod tin;
pub mod tree_synth;

pub use profile::{Hist, PeakSamples, SynthProfile};
pub use terrain::{build_terrain, OroTerrain, TerrainModel, TerrainOptions};
pub use terrain_tin::TinTerrain;
pub use tree_synth::{ridge_tree, synthesize_tree, SynthPeak, SynthSaddle, SynthTree, TreeOptions};
