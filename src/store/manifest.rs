//! The store's `manifest.json`: what the store holds (size, type, georef,
//! tiling, compression), the state and checksum of every tile, and the
//! provenance of the data. It holds no timestamps, host names or anything
//! else that changes between identical runs, so a store is byte-identical
//! whenever its content is.

use crate::error::{Error, Result};
use crate::raster::{DType, GeoRef, OutputKind, TileLayout};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Value of [`Manifest::format`].
pub const FORMAT: &str = "orogen-tile-store";
/// Current value of [`Manifest::version`].
pub const VERSION: u32 = 1;
/// Largest raster dimension a manifest may declare (cells per side).
pub const MAX_DIM: usize = 1 << 24;
/// Largest tile side a manifest may declare (cells; an f64 tile of this side is 512 MiB).
pub const MAX_TILE: usize = 1 << 13;
/// Largest number of tiles a manifest may declare.
pub const MAX_TILES: usize = 1 << 24;
/// Largest manifest file read (bytes).
pub const MAX_MANIFEST_BYTES: u64 = 1 << 30;

/// Per-tile compression of a store.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(tag = "kind", rename_all = "lowercase")]
pub enum Compression {
    /// Raw little-endian cells.
    #[default]
    None,
    /// Zstandard at the given level (1..=22; 3 is zstd's default).
    Zstd { level: i32 },
}

/// Where the data came from: the step and parameters that produced it.
/// A resumed run must carry the same provenance as the store it resumes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct Provenance {
    /// Step name (e.g. `"ingest"`, `"slope"`).
    pub step: String,
    /// Step parameters.
    pub params: serde_json::Value,
    /// Input files or stores.
    pub inputs: Vec<String>,
    /// orogen version that wrote the store.
    pub version: String,
    /// What the values are (the step's declared output kind); omitted
    /// when continuous, so a manifest without it is continuous.
    #[serde(default, skip_serializing_if = "OutputKind::is_continuous")]
    pub kind: OutputKind,
}

impl Provenance {
    /// Provenance for `step` with `params` and `inputs`, stamped with this
    /// crate's version.
    pub fn new(step: impl Into<String>, params: serde_json::Value, inputs: Vec<String>) -> Self {
        Provenance {
            step: step.into(),
            params,
            inputs,
            version: env!("CARGO_PKG_VERSION").to_string(),
            kind: OutputKind::Continuous,
        }
    }

    /// This provenance for values of kind `kind`.
    pub fn with_kind(self, kind: OutputKind) -> Self {
        Provenance { kind, ..self }
    }
}

/// State of one tile.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum TileState {
    /// Not written yet.
    Pending,
    /// Written, synced, and recorded.
    Done,
}

/// One tile's record.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct TileEntry {
    /// State.
    pub state: TileState,
    /// CRC-32 (IEEE, crc32fast) of the raw uncompressed little-endian cells.
    pub crc32: u32,
    /// Size of the tile file in bytes (compressed size for zstd).
    pub bytes: u64,
}

impl TileEntry {
    /// A tile not written yet.
    pub const PENDING: TileEntry = TileEntry {
        state: TileState::Pending,
        crc32: 0,
        bytes: 0,
    };
}

/// The content of `manifest.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    /// Always [`FORMAT`].
    pub format: String,
    /// Format version ([`VERSION`]).
    pub version: u32,
    /// Raster columns.
    pub width: usize,
    /// Raster rows.
    pub height: usize,
    /// Native cell type of the tiles.
    pub dtype: DType,
    /// Georeference (its `nodata` equals [`Manifest::nodata`]).
    pub georef: GeoRef,
    /// Tile side in cells (edge tiles are clipped to the raster).
    pub tile: usize,
    /// Nodata value.
    pub nodata: Option<f64>,
    /// Per-tile compression.
    pub compression: Compression,
    /// True once every tile is written and the writer finished.
    pub complete: bool,
    /// What produced the data.
    pub provenance: Provenance,
    /// One entry per tile, in row-major tile id order.
    pub tiles: Vec<TileEntry>,
}

impl Manifest {
    /// The tile layout.
    pub fn layout(&self) -> TileLayout {
        TileLayout::new(self.width, self.height, self.tile)
    }

    /// Check dimensions and consistency before anything is allocated from
    /// them. `path` is the manifest file (for messages).
    pub fn validate(&self, path: &Path) -> Result<()> {
        if self.format != FORMAT {
            return Err(Error::corrupt(
                path,
                format!(
                    "not an orogen tile-store manifest (format {:?})",
                    self.format
                ),
            ));
        }
        if self.version != VERSION {
            return Err(Error::unsupported(
                path,
                format!(
                    "tile-store format version {} (this orogen reads version {VERSION}); rebuild the store with this orogen",
                    self.version
                ),
            ));
        }
        check_dims(path, self.width, self.height, self.tile)?;
        let n = self.layout().count();
        if self.tiles.len() != n {
            return Err(Error::corrupt(
                path,
                format!(
                    "manifest lists {} tiles but a {}x{} raster in {} tiles has {n}",
                    self.tiles.len(),
                    self.width,
                    self.height,
                    self.tile
                ),
            ));
        }
        let same_nodata = match (self.nodata, self.georef.nodata) {
            (None, None) => true,
            (Some(a), Some(b)) => a.to_bits() == b.to_bits() || a == b,
            _ => false,
        };
        if !same_nodata {
            return Err(Error::corrupt(
                path,
                "manifest nodata and georef nodata differ",
            ));
        }
        let layout = self.layout();
        let cell = self.dtype.size() as u64;
        for (id, t) in self.tiles.iter().enumerate() {
            if t.state == TileState::Done && self.compression == Compression::None {
                let raw = layout.window(id).len() as u64 * cell;
                if t.bytes != raw {
                    return Err(Error::corrupt(
                        path,
                        format!("tile {id} is recorded as {} bytes, expected {raw}", t.bytes),
                    ));
                }
            }
        }
        Ok(())
    }

    /// Serialise (pretty JSON, fixed key order, trailing newline).
    pub fn to_bytes(&self) -> Result<Vec<u8>> {
        let mut v = serde_json::to_vec_pretty(self)
            .map_err(|e| Error::invalid(format!("cannot serialise the store manifest: {e}")))?;
        v.push(b'\n');
        Ok(v)
    }

    /// Read and validate `path`.
    pub fn read(path: &Path) -> Result<Manifest> {
        let meta = std::fs::metadata(path).map_err(|e| {
            if e.kind() == std::io::ErrorKind::NotFound {
                Error::store(
                    path,
                    "no manifest: not a tile store (or its creation never started)",
                )
            } else {
                Error::io(path, e)
            }
        })?;
        if meta.len() > MAX_MANIFEST_BYTES {
            return Err(Error::too_large(
                path,
                format!(
                    "manifest of {} bytes is larger than any valid manifest",
                    meta.len()
                ),
            ));
        }
        let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
        let m: Manifest = serde_json::from_slice(&bytes).map_err(|e| {
            Error::corrupt(
                path,
                format!(
                    "garbled manifest ({e}); delete the store and rerun the command that made it"
                ),
            )
        })?;
        m.validate(path)?;
        Ok(m)
    }
}

/// Check raster and tile dimensions against sane limits.
pub fn check_dims(path: &Path, width: usize, height: usize, tile: usize) -> Result<()> {
    if width == 0 || height == 0 {
        return Err(Error::corrupt(
            path,
            format!("empty raster ({width}x{height})"),
        ));
    }
    if width > MAX_DIM || height > MAX_DIM {
        return Err(Error::too_large(
            path,
            format!(
                "raster of {width}x{height} cells exceeds the limit of {MAX_DIM} cells per side"
            ),
        ));
    }
    if tile == 0 || tile > MAX_TILE {
        return Err(Error::too_large(
            path,
            format!("tile size {tile} is outside 1..={MAX_TILE}"),
        ));
    }
    let n = width.div_ceil(tile) * height.div_ceil(tile);
    if n > MAX_TILES {
        return Err(Error::too_large(
            path,
            format!(
                "{n} tiles of {tile} cells exceed the limit of {MAX_TILES}; use a larger tile size"
            ),
        ));
    }
    Ok(())
}
