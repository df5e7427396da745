//! Reading the pyramids `orogen tiles` writes: a `z/x/y.png` folder (with
//! `metadata.json`), an MBTiles file (SQLite, TMS row order) or a PMTiles v3
//! archive (its metadata; tiles are read by byte range by the client).
//! The readers of the writers in [`super::pyramid`] and [`super::archive`].

use crate::error::{Error, Result};
use std::io::{Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

/// A tile pyramid on disk.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum TileSource {
    /// A `z/x/y.png` folder.
    Dir(PathBuf),
    /// An MBTiles file.
    Mbtiles(PathBuf),
    /// A PMTiles v3 archive.
    Pmtiles(PathBuf),
}

impl TileSource {
    /// Open `path` by its extension (`.pmtiles`, `.mbtiles`, else a folder)
    /// and read its JSON metadata; archives' `minzoom`/`maxzoom` are copied to
    /// `min_zoom`/`max_zoom` as folder pyramids write them.
    pub fn open(path: &Path) -> Result<(TileSource, serde_json::Value)> {
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
        let (source, mut meta) = match ext {
            "pmtiles" => (
                TileSource::Pmtiles(path.to_path_buf()),
                pmtiles_metadata(path)?,
            ),
            "mbtiles" => (
                TileSource::Mbtiles(path.to_path_buf()),
                mbtiles_metadata(path)?,
            ),
            _ => (TileSource::Dir(path.to_path_buf()), dir_metadata(path)?),
        };
        // Folder pyramids write min_zoom/max_zoom; archives minzoom/maxzoom.
        for (from, to) in [("minzoom", "min_zoom"), ("maxzoom", "max_zoom")] {
            if let Some(v) = meta.get(from).cloned() {
                meta[to] = v;
            }
        }
        Ok((source, meta))
    }

    /// The PNG of tile `z/x/y` (XYZ row order) of a folder or MBTiles
    /// pyramid; `None` when it is missing (empty, transparent) and for
    /// PMTiles archives (read by byte range).
    pub fn tile(&self, z: u8, x: u32, y: u32) -> Option<Vec<u8>> {
        match self {
            TileSource::Dir(d) => std::fs::read(d.join(format!("{z}/{x}/{y}.png"))).ok(),
            TileSource::Mbtiles(p) => {
                rusqlite::Connection::open_with_flags(p, rusqlite::OpenFlags::SQLITE_OPEN_READ_ONLY)
                    .ok()
                    .and_then(|db| {
                        let row = (1i64 << z) - 1 - y as i64;
                        db.query_row(
                            "SELECT tile_data FROM tiles WHERE zoom_level=?1 AND tile_column=?2 AND tile_row=?3",
                            rusqlite::params![z as i64, x as i64, row],
                            |r| r.get::<_, Vec<u8>>(0),
                        )
                        .ok()
                    })
            }
            TileSource::Pmtiles(_) => None,
        }
    }
}

/// The `metadata.json` of a pyramid folder.
pub fn dir_metadata(dir: &Path) -> Result<serde_json::Value> {
    let m = dir.join("metadata.json");
    let text = std::fs::read_to_string(&m).map_err(|e| {
        Error::corrupt(&m, format!("not a pyramid folder from `orogen tiles`: {e}"))
    })?;
    serde_json::from_str(&text).map_err(|e| Error::corrupt(&m, e.to_string()))
}

/// The `json` metadata row of an orogen MBTiles file.
pub fn mbtiles_metadata(p: &Path) -> Result<serde_json::Value> {
    let db = rusqlite::Connection::open_with_flags(p, rusqlite::OpenFlags::SQLITE_OPEN_READ_ONLY)
        .map_err(|e| Error::invalid(format!("opening {}: {e}", p.display())))?;
    let json: String = db
        .query_row("SELECT value FROM metadata WHERE name='json'", [], |r| {
            r.get(0)
        })
        .map_err(|e| {
            Error::corrupt(
                p,
                format!("not an orogen MBTiles file (no json metadata): {e}"),
            )
        })?;
    serde_json::from_str(&json).map_err(|e| Error::corrupt(p, e.to_string()))
}

/// The JSON metadata of a PMTiles v3 archive (header fields at fixed
/// offsets of the 127-byte header; metadata possibly gzip-compressed).
pub fn pmtiles_metadata(p: &Path) -> Result<serde_json::Value> {
    let mut f = std::fs::File::open(p)
        .map_err(|e| Error::invalid(format!("opening {}: {e}", p.display())))?;
    let mut h = [0u8; 127];
    f.read_exact(&mut h)
        .map_err(|e| Error::corrupt(p, format!("too short for a PMTiles archive: {e}")))?;
    if &h[0..7] != b"PMTiles" || h[7] != 3 {
        return Err(Error::corrupt(p, "not a PMTiles v3 archive"));
    }
    let u64at = |o: usize| u64::from_le_bytes(h[o..o + 8].try_into().unwrap_or([0; 8]));
    let (off, len) = (u64at(24), u64at(32));
    if len > 64 << 20 {
        return Err(Error::corrupt(
            p,
            format!("metadata of {len} bytes is implausible"),
        ));
    }
    f.seek(SeekFrom::Start(off)).map_err(|e| Error::io(p, e))?;
    let mut raw = vec![0u8; len as usize];
    f.read_exact(&mut raw).map_err(|e| Error::io(p, e))?;
    let text = if h[97] == 2 {
        let mut s = String::new();
        flate2::read::GzDecoder::new(&raw[..])
            .read_to_string(&mut s)
            .map_err(|e| Error::corrupt(p, format!("metadata: {e}")))?;
        s
    } else {
        String::from_utf8(raw).map_err(|e| Error::corrupt(p, format!("metadata: {e}")))?
    };
    serde_json::from_str(&text).map_err(|e| Error::corrupt(p, format!("metadata: {e}")))
}
