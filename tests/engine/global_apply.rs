//! `Engine::run_global_apply` (the path on which, under MPI, only rank 0
//! reduces) and delegated tile-store writes (ranks writing their own tiles
//! into a store another process owns), without MPI: the default
//! `run_global_apply` writes exactly what `run_global` writes; a store whose
//! tiles were written through `delegate()` + `record_delegated` is
//! byte-identical to one written through `write`; an unrecorded or torn
//! delegated tile is not trusted on resume.

use orogen::exec::output::OutputSpec;
use orogen::exec::{Engine, GlobalStep, MemSink, Run, TileSink};
use orogen::raster::{
    AnyGrid, DType, GeoRef, Grid, MemRaster, RasterSource, TileId, TileLayout, TileView,
};
use orogen::store::{Provenance, StoreOptions, StoreWriter, TileEntry, TileStore};
use orogen::{Error, Result};
use std::path::Path;

use crate::common::engine::{engine, tile_min};
use crate::common::Rng;

/// Deterministic test heights with a few nodata cells (SplitMix64, Steele,
/// Lea & Flood 2014).
fn heights(w: usize, h: usize, seed: u64) -> Vec<f32> {
    let mut rng = Rng(seed);
    (0..w * h)
        .map(|_| {
            let z = rng.next();
            if z.is_multiple_of(37) {
                f32::NAN
            } else {
                ((z >> 9) % 1000) as f32 * 0.25
            }
        })
        .collect()
}

/// Each cell minus the minimum of the tiles *before* it in tile order (0
/// for tile 0): the slice differs per tile, so a slice routed to the wrong
/// tile changes the output.
struct MinusPrefixMin;
impl GlobalStep for MinusPrefixMin {
    type In = f32;
    type Out = f32;
    type Summary = Option<f32>;
    type Solution = Vec<f32>;
    type Slice = f32;
    fn name(&self) -> String {
        "minus-prefix-min".into()
    }
    fn params(&self) -> serde_json::Value {
        serde_json::Value::Null
    }
    fn outputs(&self) -> Vec<OutputSpec> {
        vec![OutputSpec::continuous(DType::F32, 0.0)]
    }
    fn map(&self, inputs: &[TileView<f32>]) -> Result<Option<f32>> {
        Ok(tile_min(inputs))
    }
    fn reduce(&self, layout: &TileLayout, summaries: Vec<Option<f32>>) -> Result<Vec<f32>> {
        if summaries.len() != layout.count() {
            return Err(Error::invalid("wrong summary count"));
        }
        let mut out = Vec::with_capacity(summaries.len());
        let mut m: Option<f32> = None;
        for s in summaries {
            out.push(m.unwrap_or(0.0));
            m = match (m, s) {
                (Some(a), Some(b)) => Some(a.min(b)),
                (a, b) => a.or(b),
            };
        }
        Ok(out)
    }
    fn slice(&self, solution: &Vec<f32>, id: TileId) -> f32 {
        solution[id]
    }
    fn apply(&self, inputs: &[TileView<f32>], slice: &f32, out: &mut [Grid<f32>]) -> Result<()> {
        out[0] = inputs[0].core_grid().map(|v| v - slice);
        Ok(())
    }
}

/// The expected output, computed cell by cell from the definition.
fn oracle(data: &[f32], w: usize, h: usize, tile: usize) -> Vec<f32> {
    let tiles_x = w.div_ceil(tile);
    let tiles = tiles_x * h.div_ceil(tile);
    let mut tile_min = vec![f32::INFINITY; tiles];
    for y in 0..h {
        for x in 0..w {
            let v = data[y * w + x];
            let t = (y / tile) * tiles_x + x / tile;
            if !v.is_nan() && v < tile_min[t] {
                tile_min[t] = v;
            }
        }
    }
    let mut out = vec![0f32; w * h];
    for y in 0..h {
        for x in 0..w {
            let t = (y / tile) * tiles_x + x / tile;
            let before = tile_min[..t].iter().copied().fold(f32::INFINITY, f32::min);
            let sub = if before.is_finite() { before } else { 0.0 };
            out[y * w + x] = data[y * w + x] - sub;
        }
    }
    out
}

fn same(a: &[f32], b: &[f32]) -> bool {
    a.len() == b.len()
        && a.iter()
            .zip(b)
            .all(|(x, y)| x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan()))
}

#[test]
fn default_run_global_apply_writes_what_run_global_writes() {
    let (w, h) = (83, 57);
    let data = heights(w, h, 3);
    let src = MemRaster::from_grid(Grid::from_vec(w, h, data.clone()).unwrap(), GeoRef::pixel());
    for tile in [1, 16, 30, 100] {
        let want = oracle(&data, w, h, tile);
        for threads in [1, 2] {
            let layout = TileLayout::new(w, h, tile);
            let (s1, h1) = MemSink::new(w, h, DType::F32, None);
            let sol = engine(threads)
                .run_global(
                    &MinusPrefixMin,
                    Run::new(&[&src as &dyn RasterSource], layout, vec![Box::new(s1)]),
                )
                .unwrap();
            assert_eq!(sol.len(), layout.count());
            let (s2, h2) = MemSink::new(w, h, DType::F32, None);
            engine(threads)
                .run_global_apply(
                    &MinusPrefixMin,
                    Run::new(&[&src as &dyn RasterSource], layout, vec![Box::new(s2)]),
                )
                .unwrap();
            let a: Grid<f32> = h1.take().unwrap().to_typed(None);
            let b: Grid<f32> = h2.take().unwrap().to_typed(None);
            assert!(same(a.data(), &want), "run_global, tile {tile}");
            assert!(same(b.data(), &want), "run_global_apply, tile {tile}");
        }
    }
}

fn store_files(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut v: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| !n.starts_with('.'))
        .map(|n| {
            let b = std::fs::read(dir.join(&n)).unwrap();
            (n, b)
        })
        .collect();
    v.sort();
    v
}

fn tile_grid(data: &[f32], w: usize, layout: &TileLayout, id: TileId) -> AnyGrid {
    let c = layout.window(id);
    AnyGrid::F32(Grid::from_fn(c.w, c.h, |x, y| {
        data[(c.y as usize + y) * w + c.x as usize + x]
    }))
}

fn create(dir: &Path, w: usize, h: usize, zstd: bool) -> StoreWriter {
    let opts = StoreOptions {
        tile: 16,
        compression: if zstd {
            orogen::store::Compression::Zstd { level: 3 }
        } else {
            orogen::store::Compression::None
        },
        sync: false,
        ..Default::default()
    };
    let prov = Provenance::new("delegation-test", serde_json::Value::Null, vec![]);
    StoreWriter::create(dir, w, h, DType::F32, &GeoRef::pixel(), opts, prov).unwrap()
}

#[test]
fn delegated_writes_give_the_store_written_directly() {
    let (w, h) = (50, 37);
    let data = heights(w, h, 11);
    for zstd in [false, true] {
        let tmp = tempfile::tempdir().unwrap();
        let direct = tmp.path().join("direct.tiles");
        let deleg = tmp.path().join("deleg.tiles");
        let mut a = create(&direct, w, h, zstd);
        let layout = a.layout();
        for id in 0..layout.count() {
            a.write(id, layout.window(id), tile_grid(&data, w, &layout, id))
                .unwrap();
        }
        Box::new(a).finish().unwrap();

        let mut b = create(&deleg, w, h, zstd);
        let d = b.delegate().expect("a store delegates its tile files");
        assert_eq!(d.layout().unwrap(), layout);
        // Odd tiles written "by another rank", even ones by the owner.
        for id in 0..layout.count() {
            let g = tile_grid(&data, w, &layout, id);
            if id % 2 == 1 {
                let e = d.write_tile(id, &g).unwrap();
                b.record_delegated(id, e).unwrap();
            } else {
                b.write(id, layout.window(id), g).unwrap();
            }
        }
        Box::new(b).finish().unwrap();
        assert_eq!(store_files(&direct), store_files(&deleg), "zstd {zstd}");
        // And the cells read back are the input's.
        let st = TileStore::open(&deleg).unwrap();
        let g: Grid<f32> = st
            .read_native(orogen::raster::Window::full(w, h))
            .unwrap()
            .to_typed(None);
        assert!(same(g.data(), &data));
    }
}

#[test]
fn unrecorded_or_torn_delegated_tiles_are_redone_on_resume() {
    let (w, h) = (40, 40); // 3x3 tiles of 16
    let data = heights(w, h, 5);
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("s.tiles");
    let mut wr = create(&dir, w, h, false);
    let layout = wr.layout();
    let d = wr.delegate().unwrap();
    let mut entries: Vec<TileEntry> = Vec::new();
    for id in 0..4 {
        entries.push(d.write_tile(id, &tile_grid(&data, w, &layout, id)).unwrap());
    }
    // Tiles 0..=2 recorded, tile 3 written but never recorded (the owner
    // died first); then tile 1's file is torn (cut short) and tile 2's
    // cells are damaged at the same size.
    for (id, e) in entries.iter().enumerate().take(3) {
        wr.record_delegated(id, *e).unwrap();
    }
    drop(wr); // the owner "dies": no finish
    let (tx, ty) = layout.coords(1);
    let t1 = orogen::store::tile_file(&dir, tx, ty);
    let len = std::fs::metadata(&t1).unwrap().len();
    std::fs::OpenOptions::new()
        .write(true)
        .open(&t1)
        .unwrap()
        .set_len(len - 3)
        .unwrap();
    let (tx, ty) = layout.coords(2);
    let t2 = orogen::store::tile_file(&dir, tx, ty);
    let mut b = std::fs::read(&t2).unwrap();
    b[10] ^= 0xff;
    std::fs::write(&t2, b).unwrap();

    let wr = create(&dir, w, h, false);
    let done: Vec<bool> = (0..layout.count()).map(|id| wr.is_done(id)).collect();
    assert_eq!(
        done,
        vec![true, false, false, false, false, false, false, false, false]
    );
    assert_eq!(wr.done_count(), 1);
}

#[test]
fn recording_a_tile_whose_file_is_missing_or_wrong_is_an_error() {
    let (w, h) = (20, 20);
    let data = heights(w, h, 8);
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("s.tiles");
    let mut wr = create(&dir, w, h, false);
    let layout = wr.layout();
    let d = wr.delegate().unwrap();
    let e = d.write_tile(0, &tile_grid(&data, w, &layout, 0)).unwrap();
    // Tile 1 never written (a rank that does not share the filesystem).
    let err = wr.record_delegated(1, e).unwrap_err().to_string();
    assert!(
        err.contains("missing") && err.contains("filesystem"),
        "{err}"
    );
    let wrong = TileEntry {
        bytes: e.bytes + 1,
        ..e
    };
    let err = wr.record_delegated(0, wrong).unwrap_err().to_string();
    assert!(err.contains("has "), "{err}");
    assert!(!wr.is_done(0) && !wr.is_done(1));
    // A tile of the wrong shape or out of range is refused before writing.
    assert!(d.write_tile(0, &tile_grid(&data, w, &layout, 3)).is_err());
    assert!(d.write_tile(99, &tile_grid(&data, w, &layout, 0)).is_err());
    wr.record_delegated(0, e).unwrap();
    assert!(wr.is_done(0));
}
