//! Reading a finished tile store as a [`RasterSource`].

use super::manifest::Manifest;
use super::tile::{tile_file, with_raw};
use super::MANIFEST;
use crate::dispatch_any;
use crate::error::{Error, Result};
use crate::raster::{AnyGrid, RasterInfo, RasterSource, TileLayout, Window};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

/// Default byte budget of the decoded-tile cache of compressed stores.
pub const DEFAULT_CACHE_BYTES: u64 = 64 << 20;

/// Recently decompressed tiles of a compressed store, least recently used
/// evicted first. A read with a halo touches up to nine tiles and the engine
/// visits tiles in row-major order, so without it each zstd tile would be
/// decompressed up to nine times per pass.
#[derive(Debug, Default)]
struct TileCache {
    /// (tile id, raw bytes, last use tick).
    slots: Vec<(usize, Arc<Vec<u8>>, u64)>,
}

/// A finished tile store opened for reading. Every read maps the tiles it
/// touches one at a time, copies the needed cells and unmaps, so reading
/// keeps no store pages resident. Each tile's checksum is verified the first
/// time it is read through this handle (halo reads touch a tile up to nine
/// times; verifying once keeps that cheap).
#[derive(Debug)]
pub struct TileStore {
    dir: PathBuf,
    manifest: Manifest,
    layout: TileLayout,
    info: RasterInfo,
    verify: bool,
    verified: Vec<AtomicBool>,
    cache: Mutex<TileCache>,
    cache_tiles: usize,
    tick: AtomicU64,
}

impl TileStore {
    /// Open the store in directory `path` (`NAME.tiles/`). Fails with a
    /// [`Error::Store`] if it is unfinished (a writer was interrupted: rerun
    /// the command to resume) and with typed errors if the manifest is
    /// missing, garbled or declares absurd sizes.
    pub fn open(path: impl AsRef<Path>) -> Result<TileStore> {
        let dir = path.as_ref().to_path_buf();
        if !dir.is_dir() {
            return Err(Error::store(
                &dir,
                "not a tile store directory (no such directory)",
            ));
        }
        let mpath = dir.join(MANIFEST);
        let manifest = Manifest::read(&mpath)?;
        if !manifest.complete {
            let done = manifest
                .tiles
                .iter()
                .filter(|t| t.state == super::TileState::Done)
                .count();
            return Err(Error::store(
                &dir,
                format!(
                    "unfinished tile store ({done} of {} tiles recorded in the manifest); rerun the command that writes it to resume",
                    manifest.tiles.len()
                ),
            ));
        }
        let layout = manifest.layout();
        let info = RasterInfo {
            width: manifest.width,
            height: manifest.height,
            dtype: manifest.dtype,
            georef: manifest.georef.clone(),
            block: (manifest.tile, manifest.tile),
            path: dir.clone(),
        };
        let verified = (0..manifest.tiles.len())
            .map(|_| AtomicBool::new(false))
            .collect();
        let mut store = TileStore {
            dir,
            manifest,
            layout,
            info,
            verify: true,
            verified,
            cache: Mutex::new(TileCache::default()),
            cache_tiles: 0,
            tick: AtomicU64::new(0),
        };
        store.set_cache_bytes(DEFAULT_CACHE_BYTES);
        Ok(store)
    }

    /// Byte budget of the decoded-tile cache (compressed stores only; raw
    /// stores are memory-mapped and need none). 0 disables it.
    pub fn set_cache_bytes(&mut self, bytes: u64) {
        let tile_bytes = (self.manifest.tile * self.manifest.tile * self.info.dtype.size()) as u64;
        self.cache_tiles = if self.manifest.compression == super::Compression::None {
            0
        } else {
            (bytes / tile_bytes.max(1)) as usize
        };
        if let Ok(mut c) = self.cache.lock() {
            c.slots.clear();
        }
    }

    /// The decompressed bytes of tile `id`, from the cache or decoded now.
    fn cached_raw(
        &self,
        id: usize,
        path: &Path,
        raw_len: usize,
        verify: bool,
    ) -> Result<Arc<Vec<u8>>> {
        let tick = self.tick.fetch_add(1, Ordering::Relaxed);
        if let Ok(mut c) = self.cache.lock() {
            if let Some(slot) = c.slots.iter_mut().find(|s| s.0 == id) {
                slot.2 = tick;
                return Ok(slot.1.clone());
            }
        }
        let entry = &self.manifest.tiles[id];
        let raw = Arc::new(with_raw(
            path,
            entry,
            raw_len,
            self.manifest.compression,
            verify,
            |r| r.to_vec(),
        )?);
        if let Ok(mut c) = self.cache.lock() {
            if !c.slots.iter().any(|s| s.0 == id) {
                if c.slots.len() >= self.cache_tiles {
                    if let Some(old) = (0..c.slots.len()).min_by_key(|&i| c.slots[i].2) {
                        c.slots.swap_remove(old);
                    }
                }
                c.slots.push((id, raw.clone(), tick));
            }
        }
        Ok(raw)
    }

    /// Check every tile now: file present, size as recorded, decodes to the
    /// tile's size, CRC-32 as recorded. The first damaged tile is the error
    /// (what a resumed job uses to decide that a finished store must be
    /// written again: its writer then recomputes exactly the damaged tiles).
    pub fn verify_all(&self) -> Result<()> {
        let cell = self.info.dtype.size();
        for (id, entry) in self.manifest.tiles.iter().enumerate() {
            let (tx, ty) = self.layout.coords(id);
            let path = tile_file(&self.dir, tx, ty);
            let raw_len = self.layout.window(id).len() * cell;
            with_raw(
                &path,
                entry,
                raw_len,
                self.manifest.compression,
                true,
                |_| (),
            )?;
            self.verified[id].store(true, Ordering::Relaxed);
        }
        Ok(())
    }

    /// Check each tile's CRC-32 when it is read (on by default).
    pub fn set_verify(&mut self, verify: bool) {
        self.verify = verify;
    }

    /// The manifest.
    pub fn manifest(&self) -> &Manifest {
        &self.manifest
    }

    /// The store's tile layout (reads aligned to it touch one tile each).
    pub fn layout(&self) -> TileLayout {
        self.layout
    }

    /// Directory of the store.
    pub fn path(&self) -> &Path {
        &self.dir
    }
}

impl RasterSource for TileStore {
    fn info(&self) -> &RasterInfo {
        &self.info
    }

    fn read_native(&self, win: Window) -> Result<AnyGrid> {
        let full = Window::full(self.info.width, self.info.height);
        if win.is_empty() {
            return Ok(AnyGrid::filled(self.info.dtype, win.w, win.h, 0.0));
        }
        if win.intersect(&full) != Some(win) {
            return Err(Error::invalid(format!(
                "window {win:?} is not inside the {}x{} store {}",
                self.info.width,
                self.info.height,
                self.dir.display()
            )));
        }
        let cell = self.info.dtype.size();
        let mut out = AnyGrid::filled(self.info.dtype, win.w, win.h, 0.0);
        let out_bytes: &mut [u8] =
            dispatch_any!(&mut out, g => bytemuck::cast_slice_mut(g.data_mut()));
        let out_stride = win.w * cell;
        for id in self.layout.tiles_in(&win) {
            let core = self.layout.window(id);
            let Some(part) = core.intersect(&win) else {
                continue;
            };
            let (tx, ty) = self.layout.coords(id);
            let path = tile_file(&self.dir, tx, ty);
            let entry = &self.manifest.tiles[id];
            let tile_stride = core.w * cell;
            let row_bytes = part.w * cell;
            let verify = self.verify && !self.verified[id].load(Ordering::Relaxed);
            let mut copy = |raw: &[u8]| {
                for r in 0..part.h {
                    let sy = (part.y - core.y) as usize + r;
                    let sx = (part.x - core.x) as usize;
                    let src = &raw[sy * tile_stride + sx * cell..][..row_bytes];
                    let dy = (part.y - win.y) as usize + r;
                    let dx = (part.x - win.x) as usize;
                    out_bytes[dy * out_stride + dx * cell..][..row_bytes].copy_from_slice(src);
                }
            };
            if self.cache_tiles > 0 {
                copy(&self.cached_raw(id, &path, core.len() * cell, verify)?);
            } else {
                with_raw(
                    &path,
                    entry,
                    core.len() * cell,
                    self.manifest.compression,
                    verify,
                    copy,
                )?;
            }
            if verify {
                self.verified[id].store(true, Ordering::Relaxed);
            }
        }
        Ok(out)
    }
}
