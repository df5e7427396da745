//! Tiles of a store written by processes other than its writer (the MPI
//! engine's ranks on a shared filesystem).
//!
//! Protocol: the [`super::StoreWriter`] (rank 0) keeps the only lock, the
//! journal and the manifest. It hands out a [`DelegatedTiles`] (directory,
//! layout, type, compression, fsync); another process writes a tile file
//! exactly as the writer would (same encoding, written to a temporary,
//! fsynced, renamed) and returns the tile's [`TileEntry`] (CRC-32 and size);
//! the writer then records it ([`super::sink::TileSink::record_delegated`]),
//! which appends the journal line. So the crash model is the writer's own: a
//! tile is finished only once it is journalled; a tile file that was written
//! but not recorded, or torn, fails the resume check (size and CRC) and is
//! recomputed.

use super::manifest::{check_dims, Compression, TileEntry, TileState};
use super::tile::{encode, tile_file, write_atomic};
use crate::error::{Error, Result};
use crate::raster::{AnyGrid, DType, TileId, TileLayout};
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// What a process needs to write tiles into a store another process owns.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DelegatedTiles {
    /// The store directory (on a filesystem every writer shares).
    pub dir: PathBuf,
    /// Raster width in cells.
    pub width: usize,
    /// Raster height in cells.
    pub height: usize,
    /// Tile side in cells.
    pub tile: usize,
    /// Cell type of the tile files.
    pub dtype: DType,
    /// Per-tile compression.
    pub compression: Compression,
    /// fsync each tile file before it is reported.
    pub sync: bool,
}

impl DelegatedTiles {
    /// The store's tile layout (after checking the dimensions are sane).
    pub fn layout(&self) -> Result<TileLayout> {
        check_dims(&self.dir, self.width, self.height, self.tile)?;
        Ok(TileLayout::new(self.width, self.height, self.tile))
    }

    /// Write tile `id`'s file (atomically, as the store's writer would) and
    /// return the entry the writer must record for it. Crash point
    /// `store.delegated-tile.{tmp,renamed}` (only processes writing
    /// delegated tiles reach it).
    pub fn write_tile(&self, id: TileId, data: &AnyGrid) -> Result<TileEntry> {
        self.write_tile_at(id, data, "store.delegated-tile")
    }

    /// [`DelegatedTiles::write_tile`] with crash point `{kind}.{tmp,renamed}`
    /// (the store's own writer: `store.tile`).
    pub(super) fn write_tile_at(
        &self,
        id: TileId,
        data: &AnyGrid,
        kind: &str,
    ) -> Result<TileEntry> {
        let layout = self.layout()?;
        if id >= layout.count() {
            return Err(Error::store(
                &self.dir,
                format!("tile {id} is outside the store ({} tiles)", layout.count()),
            ));
        }
        let core = layout.window(id);
        if data.dtype() != self.dtype || data.width() != core.w || data.height() != core.h {
            return Err(Error::store(
                &self.dir,
                format!(
                    "tile {id}: got {}x{} {} cells, the store holds {}x{} {}",
                    data.width(),
                    data.height(),
                    data.dtype(),
                    core.w,
                    core.h,
                    self.dtype
                ),
            ));
        }
        let raw = data.as_le_bytes();
        let crc = crc32fast::hash(raw);
        let (tx, ty) = layout.coords(id);
        let path = tile_file(&self.dir, tx, ty);
        let enc = encode(raw, self.compression, &path)?;
        write_atomic(&path, &enc, self.sync, kind)?;
        Ok(TileEntry {
            state: TileState::Done,
            crc32: crc,
            bytes: enc.len() as u64,
        })
    }
}
