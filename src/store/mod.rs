//! Tile store.
