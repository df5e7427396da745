//! Terrain descriptors.
