//! Tile files: naming, encoding (raw or zstd), atomic writing, and reading
//! through a short-lived memory map.

use super::manifest::{Compression, TileEntry, TileState};
use crate::error::{Error, IoContext, Result};
use std::fs::{File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};

/// File name of tile (tx, ty).
pub fn tile_file(dir: &Path, tx: usize, ty: usize) -> PathBuf {
    dir.join(format!("t_{ty}_{tx}.bin"))
}

/// Encode raw tile bytes for storage.
pub fn encode(raw: &[u8], compression: Compression, path: &Path) -> Result<Vec<u8>> {
    match compression {
        Compression::None => Ok(raw.to_vec()),
        Compression::Zstd { level } => zstd::bulk::compress(raw, level).at(path),
    }
}

/// Write `bytes` to `path` atomically: a temporary sibling is written and
/// fsynced (when `sync`), then renamed over `path`. `kind` names the file's
/// role for the crash harness ([`super::crash::point`]: `KIND.tmp` before
/// the rename, `KIND.renamed` after it).
pub fn write_atomic(path: &Path, bytes: &[u8], sync: bool, kind: &str) -> Result<()> {
    let mut tmp = path.as_os_str().to_owned();
    tmp.push(".tmp");
    let tmp = PathBuf::from(tmp);
    {
        let mut f = OpenOptions::new()
            .write(true)
            .create(true)
            .truncate(true)
            .open(&tmp)
            .at(&tmp)?;
        f.write_all(bytes).at(&tmp)?;
        if sync {
            f.sync_all().at(&tmp)?;
        }
    }
    super::crash::point(kind, "tmp");
    std::fs::rename(&tmp, path).at(path)?;
    super::crash::point(kind, "renamed");
    Ok(())
}

/// fsync a directory so renames in it are durable.
pub fn sync_dir(dir: &Path) -> Result<()> {
    File::open(dir).and_then(|f| f.sync_all()).at(dir)
}

/// Read a tile file and hand its raw (decompressed) bytes to `f`, checking
/// the file size against `entry`, the decompressed size against `raw_len`,
/// and (when `verify`) the CRC-32. Uncompressed tiles are handed over straight
/// from a memory map that lives only for this call, so `f` copies just the
/// part it needs and the touched pages leave the resident set on return.
pub fn with_raw<R>(
    path: &Path,
    entry: &TileEntry,
    raw_len: usize,
    compression: Compression,
    verify: bool,
    f: impl FnOnce(&[u8]) -> R,
) -> Result<R> {
    if entry.state != TileState::Done {
        return Err(Error::store(
            path,
            "tile is not finished; rerun the command that writes the store",
        ));
    }
    let file = File::open(path).at(path)?;
    let len = file.metadata().at(path)?.len();
    if len != entry.bytes {
        return Err(Error::corrupt(
            path,
            format!(
                "tile file has {len} bytes but the manifest records {}; the store is damaged, rerun the command that wrote it with --overwrite",
                entry.bytes
            ),
        ));
    }
    if len == 0 {
        return Err(Error::corrupt(path, "empty tile file"));
    }
    // SAFETY: the map is private to this call and dropped before return; the
    // store's files are only replaced by rename, never truncated in place by
    // orogen, and the length was checked just above.
    let map = unsafe { memmap2::Mmap::map(&file) }.at(path)?;
    let check = |raw: &[u8]| -> Result<()> {
        if raw.len() != raw_len {
            return Err(Error::corrupt(
                path,
                format!("tile holds {} bytes, expected {raw_len}", raw.len()),
            ));
        }
        if verify {
            let crc = crc32fast::hash(raw);
            if crc != entry.crc32 {
                return Err(Error::corrupt(
                    path,
                    format!(
                        "checksum mismatch (crc32 {crc:08x}, manifest {:08x}); the tile is damaged, rerun the command that wrote the store with --overwrite",
                        entry.crc32
                    ),
                ));
            }
        }
        Ok(())
    };
    match compression {
        Compression::None => {
            check(&map)?;
            Ok(f(&map))
        }
        Compression::Zstd { .. } => {
            let v = zstd::bulk::decompress(&map, raw_len)
                .map_err(|e| Error::corrupt(path, format!("zstd tile does not decompress: {e}")))?;
            drop(map);
            check(&v)?;
            Ok(f(&v))
        }
    }
}

/// True if the tile file exists, has the size recorded in `entry`, decodes
/// to `raw_len` bytes and matches the recorded checksum (resume check: a
/// torn or stale tile fails and is recomputed).
pub fn is_intact(path: &Path, entry: &TileEntry, raw_len: usize, compression: Compression) -> bool {
    with_raw(path, entry, raw_len, compression, true, |_| ()).is_ok()
}
