//! Reading a finished tile store as a [`RasterSource`].

use super::manifest::Manifest;
use super::tile::{tile_file, with_raw};
use super::MANIFEST;
use crate::dispatch_any;
use crate::error::{Error, Result};
use crate::raster::{AnyGrid, RasterInfo, RasterSource, TileLayout, Window};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};

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
        Ok(TileStore {
            dir,
            manifest,
            layout,
            info,
            verify: true,
            verified,
        })
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
            with_raw(
                &path,
                entry,
                core.len() * cell,
                self.manifest.compression,
                verify,
                |raw| {
                    for r in 0..part.h {
                        let sy = (part.y - core.y) as usize + r;
                        let sx = (part.x - core.x) as usize;
                        let src = &raw[sy * tile_stride + sx * cell..][..row_bytes];
                        let dy = (part.y - win.y) as usize + r;
                        let dx = (part.x - win.x) as usize;
                        out_bytes[dy * out_stride + dx * cell..][..row_bytes].copy_from_slice(src);
                    }
                },
            )?;
            if verify {
                self.verified[id].store(true, Ordering::Relaxed);
            }
        }
        Ok(out)
    }
}
