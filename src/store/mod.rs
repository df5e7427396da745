//! Tile store: a directory `NAME.tiles/` holding `manifest.json` and one file
//! per tile (`t_{ty}_{tx}.bin`, raw little-endian cells of the native type,
//! edge tiles at their clipped size, optionally zstd-compressed), written
//! atomically and resumably ([`StoreWriter`]) and read through short-lived
//! memory maps ([`TileStore`]). See DESIGN.md, "Tile store".

pub mod crash;
mod delegated;
mod manifest;
mod reader;
pub mod scratch;
pub mod sink;
mod tile;
mod writer;

pub use delegated::DelegatedTiles;
pub use manifest::{
    Compression, Manifest, Provenance, TileEntry, TileState, FORMAT, MAX_DIM, MAX_TILE, MAX_TILES,
    VERSION,
};
pub use reader::{TileStore, DEFAULT_CACHE_BYTES};
pub use tile::tile_file;
pub use writer::{StoreOptions, StoreWriter};

/// Manifest file name inside a store.
pub const MANIFEST: &str = "manifest.json";
/// Journal of finished tiles of an unfinished store.
pub const JOURNAL: &str = "journal";
/// Writer lock file.
pub const LOCK: &str = ".lock";
