//! Writing a tile store: atomic tile files, an append-only journal of
//! finished tiles, a writer lock, resume after interruption, and the final
//! manifest.
//!
//! Crash model: a tile is written to `t_Y_X.bin.tmp`, fsynced and renamed;
//! only then is a line `id crc32 bytes` appended to `journal` and fsynced.
//! On resume a journal line (or a `done` entry of an unfinished manifest) is
//! trusted only if the tile file exists, has the recorded size and its
//! content matches the recorded CRC-32, so a torn tile, a lost rename or a
//! torn last journal line all lead to the tile being recomputed, never
//! trusted. `finish` rewrites the manifest atomically with every tile
//! `done` and `complete: true`, then removes the journal.

use super::manifest::{
    check_dims, Compression, Manifest, Provenance, TileEntry, TileState, FORMAT, VERSION,
};
use super::sink::TileSink;
use super::tile::{is_intact, sync_dir, tile_file, write_atomic};
use super::{JOURNAL, LOCK, MANIFEST};
use crate::error::{Error, IoContext, Result};
use crate::raster::{AnyGrid, DType, GeoRef, TileId, TileLayout, Window};
use std::fs::{File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Largest journal file read on resume (bytes).
const MAX_JOURNAL_BYTES: u64 = 1 << 30;

/// How a store is written.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StoreOptions {
    /// Tile side in cells.
    pub tile: usize,
    /// Per-tile compression.
    pub compression: Compression,
    /// Replace an existing store at the path instead of resuming it.
    pub overwrite: bool,
    /// fsync tiles, the journal and the manifest (on by default; turning it
    /// off keeps atomic renames but loses durability on power failure).
    pub sync: bool,
}

impl Default for StoreOptions {
    fn default() -> Self {
        StoreOptions {
            tile: 1024,
            compression: Compression::None,
            overwrite: false,
            sync: true,
        }
    }
}

/// An exclusive writer lock: an OS advisory lock (`flock(2)` through
/// [`File::try_lock`]) on the file `.lock`, held for the writer's lifetime
/// and released by the kernel when the process ends however it ends, so a
/// killed writer never blocks the next one and a reused pid never looks
/// like a live writer. The file also holds the owner's pid, only for the
/// message a refused writer prints. It appears with that content already in
/// it (written to `.lock.PID`, then hard-linked to `.lock`); a writer taking
/// over an unlocked lock file overwrites the pid in place before truncating,
/// so the file is never seen empty.
///
/// Protocol (the usual one for lock files that are removed on release):
/// open `.lock`, `try_lock`, then check that the path still names the inode
/// we locked; if the previous owner removed it meanwhile, start over.
#[derive(Debug)]
struct Lock {
    path: PathBuf,
    /// The open, locked `.lock`; `None` once released.
    file: Option<File>,
}

impl Lock {
    fn acquire(path: PathBuf) -> Result<Lock> {
        let me = std::process::id();
        let mut own = path.as_os_str().to_owned();
        own.push(format!(".{me}"));
        let own = PathBuf::from(own);
        remove_stale_lock_temps(&path);
        {
            let mut f = File::create(&own).at(&own)?;
            f.write_all(format!("{me}\n").as_bytes()).at(&own)?;
            f.sync_all().at(&own)?;
        }
        let result = Self::take(&own, path);
        let _ = std::fs::remove_file(&own);
        result
    }

    fn take(own: &Path, path: PathBuf) -> Result<Lock> {
        use std::os::unix::fs::MetadataExt;
        let me = format!("{}\n", std::process::id());
        // A few rounds: each lost one means another writer released or
        // replaced the lock file between our open and our lock.
        for _ in 0..8 {
            match std::fs::hard_link(own, &path) {
                Ok(()) => {}
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {}
                Err(e) => return Err(Error::io(&path, e)),
            }
            let mut f = match OpenOptions::new().read(true).write(true).open(&path) {
                Ok(f) => f,
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => continue,
                Err(e) => return Err(Error::io(&path, e)),
            };
            match f.try_lock() {
                Ok(()) => {}
                Err(std::fs::TryLockError::WouldBlock) => return Err(Self::busy(&path, &mut f)),
                Err(std::fs::TryLockError::Error(e)) => {
                    return Err(Error::store(
                        &path,
                        format!("cannot lock the store ({e}); the file system must support advisory locks (flock): write the store on a local disk"),
                    ))
                }
            }
            let ours = f.metadata().at(&path)?;
            match std::fs::metadata(&path) {
                Ok(m) if m.dev() == ours.dev() && m.ino() == ours.ino() => {}
                Ok(_) => continue,
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => continue,
                Err(e) => return Err(Error::io(&path, e)),
            }
            // Ours now. A lock file left by a dead writer (or a foreign one)
            // gets our pid: written over the head first, then cut to length.
            let mut head = [0u8; 32];
            let n = std::io::Read::read(&mut f, &mut head).at(&path)?;
            if &head[..n] != me.as_bytes() || ours.len() != me.len() as u64 {
                use std::os::unix::fs::FileExt;
                f.write_all_at(me.as_bytes(), 0).at(&path)?;
                f.set_len(me.len() as u64).at(&path)?;
                f.sync_all().at(&path)?;
            }
            super::crash::point("store.lock", "taken");
            return Ok(Lock {
                path,
                file: Some(f),
            });
        }
        Err(Error::store(
            &path,
            "could not take the lock (other writers kept replacing it); retry",
        ))
    }

    /// The error for a lock held by another process, naming its pid.
    fn busy(path: &Path, f: &mut File) -> Error {
        // A pid and a newline: read no more than that (a hostile or
        // foreign `.lock` may be any size).
        let mut head = [0u8; 32];
        let n = std::io::Read::read(f, &mut head).unwrap_or(0);
        let text = String::from_utf8_lossy(&head[..n]);
        match text.trim().parse::<u32>() {
            Ok(p) => Error::store(
                path,
                format!("the store is locked by another writer (pid {p}); wait for it to finish, or use another output"),
            ),
            Err(_) => Error::store(
                path,
                "the store is locked by another writer (unreadable pid); wait for it to finish, or use another output",
            ),
        }
    }

    /// Remove the lock file, then unlock (closing the file): a writer
    /// waiting on the old inode then sees the path gone and starts over.
    fn release(&mut self) -> Result<()> {
        if let Some(f) = self.file.take() {
            let removed = match std::fs::remove_file(&self.path) {
                Ok(()) => Ok(()),
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
                Err(e) => Err(Error::io(&self.path, e)),
            };
            drop(f);
            removed?;
        }
        Ok(())
    }
}

/// Remove `.lock.PID` temporaries of writers that no longer run (killed
/// between writing their pid and linking it as the lock).
fn remove_stale_lock_temps(lock: &Path) {
    let (Some(dir), Some(name)) = (lock.parent(), lock.file_name()) else {
        return;
    };
    crate::io::atomic::remove_dead_pid_files(dir, &format!("{}.", name.to_string_lossy()));
}

impl Drop for Lock {
    fn drop(&mut self) {
        let _ = self.release();
    }
}

/// Writes a tile store; a [`TileSink`] for the engine, which must run with
/// the store's [`StoreWriter::layout`].
#[derive(Debug)]
pub struct StoreWriter {
    dir: PathBuf,
    manifest: Manifest,
    layout: TileLayout,
    opts: StoreOptions,
    journal: File,
    lock: Lock,
}

impl StoreWriter {
    /// Create the store `path` (a directory, conventionally `NAME.tiles`), or
    /// resume it if an unfinished (or finished) store with the same
    /// dimensions, type, georeference, tiling, compression and provenance is
    /// there. With `opts.overwrite` an existing store is replaced.
    pub fn create(
        path: impl AsRef<Path>,
        width: usize,
        height: usize,
        dtype: DType,
        georef: &GeoRef,
        opts: StoreOptions,
        provenance: Provenance,
    ) -> Result<StoreWriter> {
        let dir = path.as_ref().to_path_buf();
        check_dims(&dir, width, height, opts.tile)?;
        if let Compression::Zstd { level } = opts.compression {
            if !(1..=22).contains(&level) {
                return Err(Error::invalid(format!(
                    "zstd level {level} is outside 1..=22"
                )));
            }
        }
        let mut georef = georef.clone();
        if georef.nodata.is_some_and(f64::is_nan) {
            // NaN is what float rasters hold for missing cells anyway, and JSON cannot spell it.
            georef.nodata = None;
        }
        if let Some(nd) = georef.nodata {
            if nd.is_infinite() {
                return Err(Error::invalid(format!(
                    "nodata {nd} cannot be recorded in a store manifest (JSON has no infinity)"
                )));
            }
            if !dtype.represents(nd) {
                return Err(Error::invalid(format!(
                    "nodata {nd} cannot be stored in {dtype}"
                )));
            }
        }
        std::fs::create_dir_all(&dir).at(&dir)?;
        let lock = Lock::acquire(dir.join(LOCK))?;
        let layout = TileLayout::new(width, height, opts.tile);
        let mut manifest = Manifest {
            format: FORMAT.to_string(),
            version: VERSION,
            width,
            height,
            dtype,
            nodata: georef.nodata,
            georef,
            tile: opts.tile,
            compression: opts.compression,
            complete: false,
            provenance,
            tiles: vec![TileEntry::PENDING; layout.count()],
        };
        let mpath = dir.join(MANIFEST);
        let jpath = dir.join(JOURNAL);
        if opts.overwrite {
            clear_store_files(&dir)?;
        } else if mpath.exists() {
            let old = Manifest::read(&mpath).map_err(|e| {
                Error::store(
                    &mpath,
                    format!("cannot resume ({e}); use --overwrite to replace the store"),
                )
            })?;
            check_same(&mpath, &old, &manifest)?;
            let mut candidates: Vec<Option<TileEntry>> = old
                .tiles
                .iter()
                .map(|t| (t.state == TileState::Done).then_some(*t))
                .collect();
            for (id, crc, bytes) in read_journal(&jpath)? {
                if id < candidates.len() {
                    candidates[id] = Some(TileEntry {
                        state: TileState::Done,
                        crc32: crc,
                        bytes,
                    });
                }
            }
            let cell = dtype.size();
            for (id, c) in candidates.into_iter().enumerate() {
                if let Some(entry) = c {
                    let (tx, ty) = layout.coords(id);
                    let raw_len = layout.window(id).len() * cell;
                    if is_intact(&tile_file(&dir, tx, ty), &entry, raw_len, opts.compression) {
                        manifest.tiles[id] = entry;
                    }
                }
            }
        } else if std::fs::read_dir(&dir)
            .at(&dir)?
            .flatten()
            .any(|e| !is_bookkeeping(&e.file_name()))
        {
            return Err(Error::store(
                &dir,
                "the directory exists, is not empty and is not a tile store; choose another name or use --overwrite",
            ));
        }
        if !mpath.exists() && !opts.overwrite {
            // A creation killed before its first manifest was renamed into
            // place leaves only bookkeeping files (lock, manifest temporary):
            // the store simply starts over.
            clear_store_files(&dir)?;
        }
        // Record the verified tiles in the (unfinished) manifest, then start
        // an empty journal: a crash in between leaves the old journal, whose
        // entries are verified again on the next resume.
        write_atomic(&mpath, &manifest.to_bytes()?, opts.sync, "store.manifest")?;
        if opts.sync {
            sync_dir(&dir)?;
        }
        let journal = OpenOptions::new()
            .write(true)
            .create(true)
            .truncate(true)
            .open(&jpath)
            .at(&jpath)?;
        Ok(StoreWriter {
            dir,
            manifest,
            layout,
            opts,
            journal,
            lock,
        })
    }

    /// The layout the engine must use for this sink.
    pub fn layout(&self) -> TileLayout {
        self.layout
    }

    /// Number of tiles already finished (after a resume: those verified).
    pub fn done_count(&self) -> usize {
        self.manifest
            .tiles
            .iter()
            .filter(|t| t.state == TileState::Done)
            .count()
    }

    /// The store directory.
    pub fn path(&self) -> &Path {
        &self.dir
    }
}

/// Fail unless a resumed store matches the parameters of this run.
fn check_same(path: &Path, old: &Manifest, new: &Manifest) -> Result<()> {
    let mut diffs = Vec::new();
    if (old.width, old.height) != (new.width, new.height) {
        diffs.push(format!(
            "size {}x{} (this run: {}x{})",
            old.width, old.height, new.width, new.height
        ));
    }
    if old.dtype != new.dtype {
        diffs.push(format!("type {} (this run: {})", old.dtype, new.dtype));
    }
    if old.tile != new.tile {
        diffs.push(format!("tile size {} (this run: {})", old.tile, new.tile));
    }
    if old.compression != new.compression {
        diffs.push(format!(
            "compression {:?} (this run: {:?})",
            old.compression, new.compression
        ));
    }
    let json = |v: &dyn ToJson| v.to_json();
    if json(&old.georef) != json(&new.georef) {
        diffs.push("georeference".to_string());
    }
    if json(&old.provenance) != json(&new.provenance) {
        diffs.push(format!(
            "provenance (step {:?}, params {}, inputs {:?}, orogen {}; this run: step {:?}, params {}, inputs {:?}, orogen {})",
            old.provenance.step,
            old.provenance.params,
            old.provenance.inputs,
            old.provenance.version,
            new.provenance.step,
            new.provenance.params,
            new.provenance.inputs,
            new.provenance.version
        ));
    }
    if diffs.is_empty() {
        Ok(())
    } else {
        Err(Error::store(
            path,
            format!(
                "an existing store differs from this run in {}; use --overwrite to replace it",
                diffs.join(", ")
            ),
        ))
    }
}

/// Serialised form for comparisons (what the manifest would record).
trait ToJson {
    fn to_json(&self) -> Option<serde_json::Value>;
}
impl<T: serde::Serialize> ToJson for T {
    fn to_json(&self) -> Option<serde_json::Value> {
        serde_json::to_value(self).ok()
    }
}

/// Parse the journal: complete lines `id crc32hex bytes`. A line that does
/// not parse (a torn last line) is ignored; a missing journal is empty.
fn read_journal(path: &Path) -> Result<Vec<(usize, u32, u64)>> {
    let meta = match std::fs::metadata(path) {
        Ok(m) => m,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(Error::io(path, e)),
    };
    if meta.len() > MAX_JOURNAL_BYTES {
        return Err(Error::too_large(
            path,
            "journal larger than any valid journal; use --overwrite to replace the store",
        ));
    }
    let bytes = std::fs::read(path).at(path)?;
    let mut out = Vec::new();
    let mut lines: Vec<&[u8]> = bytes.split(|&b| b == b'\n').collect();
    // The part after the last newline is a torn (or empty) line.
    lines.pop();
    for line in lines {
        let Ok(text) = std::str::from_utf8(line) else {
            continue;
        };
        let mut it = text.split_ascii_whitespace();
        let (Some(a), Some(b), Some(c), None) = (it.next(), it.next(), it.next(), it.next()) else {
            continue;
        };
        if let (Ok(id), Ok(crc), Ok(n)) = (a.parse(), u32::from_str_radix(b, 16), c.parse()) {
            out.push((id, crc, n));
        }
    }
    Ok(out)
}

/// Files a store's writer leaves before its first manifest exists: the lock
/// (and a `.lock.PID` temporary), the manifest's temporary and the journal (a directory holding only these
/// is a store whose creation was interrupted, not someone else's folder).
fn is_bookkeeping(name: &std::ffi::OsStr) -> bool {
    let tmp = format!("{MANIFEST}.tmp");
    let lock_tmp = name
        .to_str()
        .and_then(|n| n.strip_prefix(LOCK))
        .and_then(|r| r.strip_prefix('.'))
        .is_some_and(|pid| pid.parse::<u32>().is_ok());
    name == LOCK || name == JOURNAL || name == tmp.as_str() || lock_tmp
}

/// Remove the files of a store (manifest, journal, tiles, temporaries) from
/// `dir`, leaving anything else and the lock alone.
fn clear_store_files(dir: &Path) -> Result<()> {
    for e in std::fs::read_dir(dir).at(dir)? {
        let e = e.at(dir)?;
        let name = e.file_name();
        let Some(name) = name.to_str() else { continue };
        let ours = name == MANIFEST
            || name == JOURNAL
            || name.ends_with(".tmp")
            || (name.starts_with("t_") && name.ends_with(".bin"));
        if ours {
            let p = e.path();
            std::fs::remove_file(&p).at(&p)?;
        }
    }
    Ok(())
}

impl StoreWriter {
    /// Journal tile `id` as finished (`entry`), then mark it in the manifest:
    /// a tile is finished only once this line is durable.
    fn journal_done(&mut self, id: TileId, entry: TileEntry) -> Result<()> {
        let jpath = self.dir.join(JOURNAL);
        self.journal
            .write_all(format!("{id} {:08x} {}\n", entry.crc32, entry.bytes).as_bytes())
            .at(&jpath)?;
        if self.opts.sync {
            self.journal.sync_data().at(&jpath)?;
        }
        super::crash::point("store.journal", "appended");
        self.manifest.tiles[id] = entry;
        Ok(())
    }

    /// What a process needs to write this store's tile files itself.
    fn tiles(&self) -> super::DelegatedTiles {
        super::DelegatedTiles {
            dir: self.dir.clone(),
            width: self.layout.width,
            height: self.layout.height,
            tile: self.layout.tile,
            dtype: self.manifest.dtype,
            compression: self.opts.compression,
            sync: self.opts.sync,
        }
    }
}

impl TileSink for StoreWriter {
    fn dtype(&self) -> DType {
        self.manifest.dtype
    }

    fn nodata(&self) -> Option<f64> {
        self.manifest.nodata
    }

    fn layout(&self) -> Option<TileLayout> {
        Some(self.layout)
    }

    fn is_done(&self, id: TileId) -> bool {
        self.manifest
            .tiles
            .get(id)
            .is_some_and(|t| t.state == TileState::Done)
    }

    fn write(&mut self, id: TileId, core: Window, data: AnyGrid) -> Result<()> {
        if id >= self.layout.count() || core != self.layout.window(id) {
            return Err(Error::store(
                &self.dir,
                format!(
                    "tile {id} at {core:?} does not belong to the store's layout ({}x{} in tiles of {}); run the engine with the store's layout",
                    self.layout.width, self.layout.height, self.layout.tile
                ),
            ));
        }
        // The tile's checks, file and entry are the delegated writers' (the
        // same bytes whoever writes a tile).
        let entry = self.tiles().write_tile_at(id, &data, "store.tile")?;
        self.journal_done(id, entry)
    }

    fn delegate(&self) -> Option<super::DelegatedTiles> {
        Some(self.tiles())
    }

    fn record_delegated(&mut self, id: TileId, entry: TileEntry) -> Result<()> {
        if id >= self.layout.count() || entry.state != TileState::Done {
            return Err(Error::store(
                &self.dir,
                format!("tile {id}: a delegated write reported {entry:?}, which is not a finished tile of this store"),
            ));
        }
        // A size check (no read-back, which would cost this process the I/O
        // the delegation saves): catches ranks that do not share this
        // filesystem. The CRC is verified on resume, as for every tile.
        let (tx, ty) = self.layout.coords(id);
        let path = tile_file(&self.dir, tx, ty);
        let len = std::fs::metadata(&path).map(|m| m.len()).ok();
        if len != Some(entry.bytes) {
            return Err(Error::store(
                &path,
                format!(
                    "tile {id} was reported written ({} bytes) by another process but the file here {}; do all ranks see the same filesystem at this path?",
                    entry.bytes,
                    match len {
                        Some(n) => format!("has {n} bytes"),
                        None => "is missing".to_string(),
                    }
                ),
            ));
        }
        self.journal_done(id, entry)
    }

    fn finish(mut self: Box<Self>) -> Result<()> {
        let missing = self
            .manifest
            .tiles
            .iter()
            .filter(|t| t.state != TileState::Done)
            .count();
        if missing > 0 {
            return Err(Error::store(
                &self.dir,
                format!("{missing} tiles were never written; the store stays unfinished, rerun the command to complete it"),
            ));
        }
        self.manifest.complete = true;
        let mpath = self.dir.join(MANIFEST);
        write_atomic(
            &mpath,
            &self.manifest.to_bytes()?,
            self.opts.sync,
            "store.final-manifest",
        )?;
        let jpath = self.dir.join(JOURNAL);
        std::fs::remove_file(&jpath).at(&jpath)?;
        if self.opts.sync {
            sync_dir(&self.dir)?;
        }
        super::crash::point("store.finish", "journal-removed");
        self.lock.release()
    }
}
