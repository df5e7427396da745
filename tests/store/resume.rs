//! Tile store writing: ingest, resume after interruption without
//! recomputing finished tiles, torn tiles and journal lines, parameter
//! checks, the writer lock, compression, exact native copies.

use crate::common::dir_bytes;
use crate::common::store::small_writer;
use orogen::exec::{ingest, EngineConfig};
use orogen::raster::{
    AnyGrid, DType, GeoRef, Grid, MemRaster, RasterInfo, RasterSource, TileLayout, Window,
};
use orogen::store::{Compression, StoreOptions, TileStore};
use orogen::{Error, Result};
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};

/// SplitMix64 (Steele, Lea & Flood 2014).
fn splitmix(s: &mut u64) -> u64 {
    *s = s.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *s;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

fn dem_i16(w: usize, h: usize) -> MemRaster {
    let mut s = 11;
    let g = Grid::from_fn(w, h, |x, y| {
        ((x * 7 + y * 3) as i16) + (splitmix(&mut s) % 5) as i16
    });
    MemRaster::new(
        AnyGrid::I16(g),
        // Origins that do not survive a JSON round trip without
        // serde_json's float_roundtrip (the manifest then looked changed
        // and resuming refused; found by a kill -9 job test).
        GeoRef::north_up(
            388313.6554542635,
            3801917.8276283755,
            30.0,
            orogen::raster::Crs::projected(32611),
        )
        .with_nodata(Some(-32768.0)),
        "dem.mem",
    )
}

/// A source that counts reads and fails reading one window.
struct Counting<'a> {
    inner: &'a MemRaster,
    reads: AtomicUsize,
    fail: Option<Window>,
}
impl<'a> Counting<'a> {
    fn new(inner: &'a MemRaster, fail: Option<Window>) -> Self {
        Counting {
            inner,
            reads: AtomicUsize::new(0),
            fail,
        }
    }
}
impl RasterSource for Counting<'_> {
    fn info(&self) -> &RasterInfo {
        self.inner.info()
    }
    fn read_native(&self, win: Window) -> Result<AnyGrid> {
        if Some(win) == self.fail {
            return Err(Error::invalid("simulated read failure"));
        }
        self.reads.fetch_add(1, Ordering::SeqCst);
        self.inner.read_native(win)
    }
}

fn cfg(threads: usize) -> EngineConfig {
    EngineConfig {
        threads,
        memory_budget: 1 << 20,
        progress: false,
        observer: None,
        engine: Default::default(),
    }
}

fn opts(tile: usize) -> StoreOptions {
    StoreOptions {
        tile,
        sync: true,
        ..Default::default()
    }
}

const W: usize = 100;
const H: usize = 70;
const TILE: usize = 16; // 7 x 5 = 35 tiles
const TILES: usize = 35;

/// A temporary folder, the W x H source, and the bytes of its store ingested
/// there uninterrupted (`ref.tiles`).
fn with_reference() -> (tempfile::TempDir, MemRaster, Vec<(String, Vec<u8>)>) {
    let tmp = tempfile::tempdir().unwrap();
    let src = dem_i16(W, H);
    let want = reference(tmp.path(), &src);
    (tmp, src, want)
}

fn reference(tmp: &Path, src: &MemRaster) -> Vec<(String, Vec<u8>)> {
    let dir = tmp.join("ref.tiles");
    ingest(src, &dir, opts(TILE), &cfg(2)).unwrap();
    dir_bytes(&dir)
}

/// Interrupt an ingest at tile `k`; returns the tiles recorded done.
fn interrupted(src: &MemRaster, dir: &Path, k: usize, threads: usize) -> usize {
    let layout = TileLayout::new(W, H, TILE);
    let failing = Counting::new(src, Some(layout.window(k)));
    let e = ingest(&failing, dir, opts(TILE), &cfg(threads)).unwrap_err();
    assert!(e.to_string().contains(&format!("tile {k}")), "{e}");
    let e = TileStore::open(dir).unwrap_err();
    assert!(e.to_string().contains("rerun"), "{e}");
    assert!(matches!(e, Error::Store { .. }));
    let journal = std::fs::read_to_string(dir.join("journal")).unwrap();
    journal.lines().count()
}

#[test]
fn resume_after_interruption_skips_finished_tiles_and_matches_uninterrupted() {
    let (tmp, src, want) = with_reference();
    assert_eq!(want.len(), TILES + 1);
    // One thread: exactly the tiles before the failing one are finished.
    let dir = tmp.path().join("a.tiles");
    let done = interrupted(&src, &dir, 12, 1);
    assert_eq!(done, 12);
    let counting = Counting::new(&src, None);
    ingest(&counting, &dir, opts(TILE), &cfg(2)).unwrap();
    assert_eq!(counting.reads.load(Ordering::SeqCst), TILES - 12);
    assert_eq!(dir_bytes(&dir), want);
    // Two threads: whatever was finished is not read again.
    let dir = tmp.path().join("b.tiles");
    let done = interrupted(&src, &dir, 20, 2);
    assert!(done <= 20);
    let counting = Counting::new(&src, None);
    ingest(&counting, &dir, opts(TILE), &cfg(1)).unwrap();
    assert_eq!(counting.reads.load(Ordering::SeqCst), TILES - done);
    assert_eq!(dir_bytes(&dir), want);
    // Rerunning a finished ingest reads nothing and changes nothing.
    let counting = Counting::new(&src, None);
    ingest(&counting, &dir, opts(TILE), &cfg(2)).unwrap();
    assert_eq!(counting.reads.load(Ordering::SeqCst), 0);
    assert_eq!(dir_bytes(&dir), want);
}

#[test]
fn torn_tile_and_torn_journal_lines_are_not_trusted() {
    let (tmp, src, want) = with_reference();
    let dir = tmp.path().join("torn.tiles");
    assert_eq!(interrupted(&src, &dir, 12, 1), 12);
    // Tile 3 = (tx 3, ty 0): truncate it, its journal entry stays.
    let t3 = dir.join("t_0_3.bin");
    let len = std::fs::metadata(&t3).unwrap().len();
    std::fs::OpenOptions::new()
        .write(true)
        .open(&t3)
        .unwrap()
        .set_len(len / 2)
        .unwrap();
    // Tile 5: same size, different content (a stale tile from another run).
    let t5 = dir.join("t_0_5.bin");
    let mut b = std::fs::read(&t5).unwrap();
    b[0] ^= 0xff;
    std::fs::write(&t5, b).unwrap();
    // A journal line for a tile never written, and a torn last line.
    let mut j = std::fs::read_to_string(dir.join("journal")).unwrap();
    j.push_str("30 deadbeef 512\n13 00ab");
    std::fs::write(dir.join("journal"), j).unwrap();
    let counting = Counting::new(&src, None);
    ingest(&counting, &dir, opts(TILE), &cfg(2)).unwrap();
    assert_eq!(counting.reads.load(Ordering::SeqCst), TILES - 12 + 2);
    assert_eq!(dir_bytes(&dir), want);
}

#[test]
fn resume_with_other_parameters_is_refused_unless_overwrite() {
    let tmp = tempfile::tempdir().unwrap();
    let src = dem_i16(W, H);
    let dir = tmp.path().join("p.tiles");
    interrupted(&src, &dir, 5, 1);
    let e = ingest(&src, &dir, opts(32), &cfg(2)).unwrap_err();
    assert!(e.to_string().contains("tile size 16 (this run: 32)"), "{e}");
    assert!(e.to_string().contains("--overwrite"), "{e}");
    let zstd = StoreOptions {
        compression: Compression::Zstd { level: 3 },
        ..opts(TILE)
    };
    let e = ingest(&src, &dir, zstd, &cfg(2)).unwrap_err();
    assert!(e.to_string().contains("compression"), "{e}");
    let other = MemRaster::new(src.grid().clone(), GeoRef::pixel(), "other.mem");
    let e = ingest(&other, &dir, opts(TILE), &cfg(2)).unwrap_err();
    assert!(
        e.to_string().contains("provenance") && e.to_string().contains("georeference"),
        "{e}"
    );
    let ow = StoreOptions {
        overwrite: true,
        ..opts(32)
    };
    ingest(&src, &dir, ow, &cfg(2)).unwrap();
    let st = TileStore::open(&dir).unwrap();
    assert_eq!(st.layout().tile, 32);
    assert_eq!(st.read_native(Window::full(W, H)).unwrap(), *src.grid());
    assert_eq!(dir_bytes(&dir).len(), 4 * 3 + 1);
}

#[test]
fn a_second_writer_is_locked_out_and_a_stale_lock_is_taken_over() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("l.tiles");
    let first = small_writer(&dir, opts(4)).unwrap();
    let e = small_writer(&dir, opts(4)).unwrap_err();
    let msg = e.to_string();
    assert!(
        msg.contains(".lock") && msg.contains(&format!("pid {}", std::process::id())),
        "{msg}"
    );
    drop(first);
    assert!(!dir.join(".lock").exists());
    // A lock left by a dead process.
    std::fs::write(dir.join(".lock"), "999999999\n").unwrap();
    let w = small_writer(&dir, opts(4)).unwrap();
    assert_eq!(w.done_count(), 0);
}

#[test]
fn a_foreign_nonempty_directory_is_not_used() {
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("notes.txt"), "mine").unwrap();
    let e = small_writer(tmp.path(), opts(4)).unwrap_err();
    assert!(e.to_string().contains("not a tile store"), "{e}");
    assert!(tmp.path().join("notes.txt").exists());
}

#[test]
fn compressed_and_raw_stores_read_identically_and_exactly() {
    let tmp = tempfile::tempdir().unwrap();
    // f32 with NaN cells AND a nodata value: a native copy must keep both bit for bit.
    let (w, h) = (173, 91);
    let mut s = 5;
    let g = Grid::from_fn(w, h, |x, y| match splitmix(&mut s) % 10 {
        0 => f32::NAN,
        1 => -9999.0,
        _ => (x as f32 * 0.37 + y as f32 * 1.1).sin() * 100.0,
    });
    let src = MemRaster::new(
        AnyGrid::F32(g),
        GeoRef::pixel().with_nodata(Some(-9999.0)),
        "f.mem",
    );
    let raw_dir = tmp.path().join("raw.tiles");
    let z_dir = tmp.path().join("z.tiles");
    ingest(&src, &raw_dir, opts(32), &cfg(2)).unwrap();
    let zopts = StoreOptions {
        compression: Compression::Zstd { level: 9 },
        ..opts(32)
    };
    ingest(&src, &z_dir, zopts, &cfg(2)).unwrap();
    let raw = TileStore::open(&raw_dir).unwrap();
    let z = TileStore::open(&z_dir).unwrap();
    assert_eq!(raw.info().georef, src.info().georef);
    assert_eq!(z.manifest().compression, Compression::Zstd { level: 9 });
    let mut state = 77;
    let mut windows = vec![
        Window::full(w, h),
        Window::new(31, 31, 2, 2),
        Window::new(0, 90, 173, 1),
    ];
    for _ in 0..50 {
        let x = (splitmix(&mut state) % w as u64) as usize;
        let y = (splitmix(&mut state) % h as u64) as usize;
        let ww = 1 + (splitmix(&mut state) % (w - x) as u64) as usize;
        let hh = 1 + (splitmix(&mut state) % (h - y) as u64) as usize;
        windows.push(Window::new(x as i64, y as i64, ww, hh));
    }
    for win in windows {
        let want = src.grid().crop(win);
        let a = raw.read_native(win).unwrap();
        let b = z.read_native(win).unwrap();
        assert!(a.as_le_bytes() == want.as_le_bytes(), "{win:?}");
        assert!(b.as_le_bytes() == want.as_le_bytes(), "{win:?}");
    }
    let e = raw.read_native(Window::new(-1, 0, 3, 3)).unwrap_err();
    assert!(matches!(e, Error::InvalidArgument(_)));

    // A decoded-tile cache of two tiles (evicting all the time) reads the same.
    let mut small = TileStore::open(&z_dir).unwrap();
    small.set_cache_bytes(2 * 32 * 32 * 4);
    for win in [
        Window::full(w, h),
        Window::new(20, 20, 50, 50),
        Window::new(0, 0, 40, 40),
    ] {
        let want = src.grid().crop(win);
        assert!(small.read_native(win).unwrap().as_le_bytes() == want.as_le_bytes());
    }
    // The cache serves tile 0 again without touching its file; without a cache
    // the missing file is an error naming it.
    let win = Window::new(0, 0, 8, 8);
    let mut cached = TileStore::open(&z_dir).unwrap();
    cached.read_native(win).unwrap();
    let mut uncached = TileStore::open(&z_dir).unwrap();
    uncached.set_cache_bytes(0);
    let tile0 = orogen::store::tile_file(&z_dir, 0, 0);
    std::fs::remove_file(&tile0).unwrap();
    assert!(cached.read_native(win).unwrap().as_le_bytes() == src.grid().crop(win).as_le_bytes());
    cached.set_cache_bytes(DEFAULT_CACHE);
    assert!(cached.read_native(win).is_err());
    assert!(uncached.read_native(win).is_err());
}

const DEFAULT_CACHE: u64 = orogen::store::DEFAULT_CACHE_BYTES;

#[test]
fn writer_checks_tiles_against_its_layout() {
    use orogen::exec::TileSink;
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("w.tiles");
    let mut wr = small_writer(&dir, opts(4)).unwrap();
    // A window off the layout, a wrong cell type, a tile beyond the store.
    for (id, win, dtype, want) in [
        (0, Window::new(0, 0, 5, 5), DType::U8, "layout"),
        (0, Window::new(0, 0, 4, 4), DType::I16, "i16"),
        (99, Window::new(0, 0, 4, 4), DType::U8, "tile 99"),
    ] {
        let e = wr
            .write(id, win, AnyGrid::filled(dtype, win.w, win.h, 1.0))
            .unwrap_err();
        assert!(e.to_string().contains(want), "{e}");
    }
    wr.write(
        8,
        Window::new(8, 8, 2, 2),
        AnyGrid::filled(DType::U8, 2, 2, 1.0),
    )
    .unwrap();
    assert!(wr.is_done(8) && !wr.is_done(0));
    let e = Box::new(wr).finish().unwrap_err();
    assert!(e.to_string().contains("8 tiles were never written"), "{e}");
}

/// A slow source, so a child process can be killed in the middle of an ingest.
struct Slow<'a>(&'a MemRaster);
impl RasterSource for Slow<'_> {
    fn info(&self) -> &RasterInfo {
        self.0.info()
    }
    fn read_native(&self, win: Window) -> Result<AnyGrid> {
        std::thread::sleep(std::time::Duration::from_millis(40));
        self.0.read_native(win)
    }
}

/// Child half of `killed_ingest_resumes`: ingests slowly into `$OROGEN_CHILD_DIR`.
/// Runs as a no-op unless `OROGEN_CHILD_DIR` is set (the parent test sets it).
#[test]
fn child_ingest() {
    let Ok(dir) = std::env::var("OROGEN_CHILD_DIR") else {
        return;
    };
    let src = dem_i16(W, H);
    ingest(&Slow(&src), Path::new(&dir), opts(TILE), &cfg(1)).unwrap();
}

#[test]
fn killed_ingest_resumes() {
    let (tmp, src, want) = with_reference();
    let dir = tmp.path().join("killed.tiles");
    let mut child = std::process::Command::new(std::env::current_exe().unwrap())
        // The test's name inside this binary (`store`): module path + name.
        .args(["resume::child_ingest", "--exact", "--quiet"])
        .env("OROGEN_CHILD_DIR", &dir)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let journal = dir.join("journal");
    let t0 = std::time::Instant::now();
    loop {
        let n = std::fs::read_to_string(&journal)
            .map(|j| j.lines().count())
            .unwrap_or(0);
        if n >= 5 {
            break;
        }
        assert!(t0.elapsed().as_secs() < 60, "child made no progress");
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    child.kill().unwrap(); // SIGKILL: no destructor runs, the lock stays
    child.wait().unwrap();
    assert!(dir.join(".lock").exists());
    let done = std::fs::read_to_string(&journal).unwrap().lines().count();
    assert!((5..TILES).contains(&done), "{done}");
    let counting = Counting::new(&src, None);
    ingest(&counting, &dir, opts(TILE), &cfg(2)).unwrap();
    assert_eq!(counting.reads.load(Ordering::SeqCst), TILES - done);
    assert_eq!(dir_bytes(&dir), want);
}
