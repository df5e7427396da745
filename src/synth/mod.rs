//! Terrain synthesis.
