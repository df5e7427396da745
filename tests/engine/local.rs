//! Local steps through `LocalEngine`: tiled == untiled (brute-force oracles
//! written independently of the engine), identical bytes for 1 and 2
//! threads, memory-budget bound, and error propagation.

use orogen::exec::{
    output::OutputSpec, tiles_in_flight, Engine, EngineConfig, LocalEngine, LocalStep, MemSink,
    Run, TileSink,
};
use orogen::raster::{AnyGrid, DType, GeoRef, Grid, MemRaster, RasterSource, TileLayout, TileView};
use orogen::store::{Provenance, StoreOptions, StoreWriter, TileStore};
use orogen::{Error, Result};
use std::sync::atomic::{AtomicUsize, Ordering};

use crate::common::{dir_bytes, Rng};

/// Integer-valued cells in -50..50 (sums are exact), ~5 % NaN.
fn random_grid(w: usize, h: usize, seed: u64) -> Vec<f64> {
    let mut r = Rng(seed);
    (0..w * h)
        .map(|_| {
            let v = r.next();
            if v.is_multiple_of(20) {
                f64::NAN
            } else {
                ((v >> 8) % 100) as f64 - 50.0
            }
        })
        .collect()
}

fn cell(data: &[f64], w: usize, h: usize, x: i64, y: i64) -> Option<f64> {
    if x < 0 || y < 0 || x >= w as i64 || y >= h as i64 {
        None
    } else {
        Some(data[y as usize * w + x as usize])
    }
}

/// Brute force: max over the (2r+1)^2 window of valid cells.
fn oracle_max(data: &[f64], w: usize, h: usize, r: i64) -> Vec<f64> {
    let mut out = vec![f64::NAN; w * h];
    for y in 0..h as i64 {
        for x in 0..w as i64 {
            let mut best: Option<f64> = None;
            for dy in -r..=r {
                for dx in -r..=r {
                    if let Some(v) = cell(data, w, h, x + dx, y + dy).filter(|v| !v.is_nan()) {
                        best = Some(best.map_or(v, |b: f64| if v > b { v } else { b }));
                    }
                }
            }
            out[y as usize * w + x as usize] = best.unwrap_or(f64::NAN);
        }
    }
    out
}

/// Brute force: mean over the (2r+1)^2 window of valid cells.
fn oracle_mean(data: &[f64], w: usize, h: usize, r: i64) -> Vec<f64> {
    let mut out = vec![f64::NAN; w * h];
    for y in 0..h as i64 {
        for x in 0..w as i64 {
            let (mut s, mut n) = (0.0, 0usize);
            for dy in -r..=r {
                for dx in -r..=r {
                    if let Some(v) = cell(data, w, h, x + dx, y + dy) {
                        if !v.is_nan() {
                            s += v;
                            n += 1;
                        }
                    }
                }
            }
            out[y as usize * w + x as usize] = if n == 0 { f64::NAN } else { s / n as f64 };
        }
    }
    out
}

/// Brute force: cells of the 5x5 window outside the raster or nodata.
fn oracle_missing(data: &[f64], w: usize, h: usize) -> Vec<u16> {
    let mut out = vec![0u16; w * h];
    for y in 0..h as i64 {
        for x in 0..w as i64 {
            let mut n = 0;
            for dy in -2..=2 {
                for dx in -2..=2 {
                    match cell(data, w, h, x + dx, y + dy) {
                        None => n += 1,
                        Some(v) if v.is_nan() => n += 1,
                        _ => {}
                    }
                }
            }
            out[y as usize * w + x as usize] = n;
        }
    }
    out
}

/// Max (r = 1) or mean (r = 5) over a square window, via `TileView::at`.
struct Window {
    r: i64,
    mean: bool,
}
impl LocalStep for Window {
    type In = f64;
    type Out = f64;
    fn name(&self) -> String {
        if self.mean { "mean" } else { "max" }.into()
    }
    fn params(&self) -> serde_json::Value {
        serde_json::json!({ "r": self.r })
    }
    fn halo(&self) -> usize {
        self.r as usize
    }
    fn outputs(&self) -> Vec<OutputSpec> {
        vec![OutputSpec::continuous(DType::F64, 0.0)]
    }
    fn run(&self, inputs: &[TileView<f64>], out: &mut [Grid<f64>]) -> Result<()> {
        let v = &inputs[0];
        let o = &mut out[0];
        for y in 0..v.core.h {
            for x in 0..v.core.w {
                let mut acc = if self.mean { 0.0 } else { f64::NEG_INFINITY };
                let mut n = 0;
                for dy in -self.r..=self.r {
                    for dx in -self.r..=self.r {
                        let c = v.at(x as i64 + dx, y as i64 + dy);
                        if c.is_nan() {
                            continue;
                        }
                        n += 1;
                        if self.mean {
                            acc += c;
                        } else {
                            acc = acc.max(c);
                        }
                    }
                }
                let r = match (n, self.mean) {
                    (0, _) => f64::NAN,
                    (_, true) => acc / n as f64,
                    (_, false) => acc,
                };
                o.set(x, y, r);
            }
        }
        Ok(())
    }
}

/// Count NaN cells (nodata or beyond the raster edge) in the 5x5 window.
struct Missing;
impl LocalStep for Missing {
    type In = f32;
    type Out = u16;
    fn name(&self) -> String {
        "missing".into()
    }
    fn params(&self) -> serde_json::Value {
        serde_json::Value::Null
    }
    fn halo(&self) -> usize {
        2
    }
    fn outputs(&self) -> Vec<OutputSpec> {
        vec![OutputSpec::continuous(DType::U16, 0.0)]
    }
    fn run(&self, inputs: &[TileView<f32>], out: &mut [Grid<u16>]) -> Result<()> {
        let v = &inputs[0];
        for y in 0..v.core.h {
            for x in 0..v.core.w {
                let mut n = 0u16;
                for yy in y..y + 5 {
                    for xx in x..x + 5 {
                        n += v.grid.get(xx, yy).is_nan() as u16;
                    }
                }
                out[0].set(x, y, n);
            }
        }
        Ok(())
    }
}

fn engine(threads: usize) -> LocalEngine {
    LocalEngine::new(EngineConfig {
        threads,
        memory_budget: 1 << 26,
        progress: false,
        observer: None,
        engine: Default::default(),
    })
}

fn source(data: &[f64], w: usize, h: usize) -> MemRaster {
    MemRaster::from_grid(
        Grid::from_vec(w, h, data.to_vec()).unwrap(),
        GeoRef::pixel(),
    )
}

fn run_mem<S: LocalStep>(
    step: &S,
    src: &MemRaster,
    tile: usize,
    threads: usize,
    dtype: DType,
) -> AnyGrid {
    let info = src.info();
    let (sink, handle) = MemSink::new(info.width, info.height, dtype, None);
    let layout = TileLayout::new(info.width, info.height, tile);
    engine(threads)
        .run_local(
            step,
            Run::new(&[src as &dyn RasterSource], layout, vec![Box::new(sink)]),
        )
        .unwrap();
    handle.take().unwrap()
}

fn f64_bytes(v: &[f64]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

#[test]
fn tiled_equals_untiled_for_all_tile_sizes_and_thread_counts() {
    for &tile in &[1usize, 7, 64, 257, 1024] {
        let (w, h) = if tile == 1 { (37, 23) } else { (300, 211) };
        let data = random_grid(w, h, 7 + tile as u64);
        let src = source(&data, w, h);
        let max = f64_bytes(&oracle_max(&data, w, h, 1));
        let mean = f64_bytes(&oracle_mean(&data, w, h, 5));
        let missing: Vec<u8> = oracle_missing(&data, w, h)
            .iter()
            .flat_map(|x| x.to_le_bytes())
            .collect();
        for threads in [1, 2] {
            let g = run_mem(
                &Window { r: 1, mean: false },
                &src,
                tile,
                threads,
                DType::F64,
            );
            assert!(
                g.as_le_bytes() == &max[..],
                "max, tile {tile}, {threads} threads"
            );
            let g = run_mem(
                &Window { r: 5, mean: true },
                &src,
                tile,
                threads,
                DType::F64,
            );
            assert!(
                g.as_le_bytes() == &mean[..],
                "mean, tile {tile}, {threads} threads"
            );
            let g = run_mem(&Missing, &src, tile, threads, DType::U16);
            assert!(
                g.as_le_bytes() == &missing[..],
                "missing, tile {tile}, {threads} threads"
            );
        }
    }
}

#[test]
fn output_converted_to_sink_type_with_nodata() {
    // Mean written to an i16 sink with nodata -9999: NaN -> -9999, values rounded as Cell::from_f64 does.
    let (w, h) = (50, 40);
    let data = random_grid(w, h, 99);
    let src = source(&data, w, h);
    let (sink, handle) = MemSink::new(w, h, DType::I16, Some(-9999.0));
    engine(2)
        .run_local(
            &Window { r: 1, mean: false },
            Run::new(
                &[&src as &dyn RasterSource],
                TileLayout::new(w, h, 16),
                vec![Box::new(sink)],
            ),
        )
        .unwrap();
    let g = handle.take().unwrap();
    let want = oracle_max(&data, w, h, 1);
    for y in 0..h {
        for x in 0..w {
            let o = want[y * w + x];
            let e = if o.is_nan() { -9999.0 } else { o };
            assert_eq!(g.get_f64(x, y), e);
        }
    }
}

#[test]
fn store_output_identical_with_one_and_two_threads() {
    let (w, h) = (200, 150);
    let data = random_grid(w, h, 5);
    let src = source(&data, w, h);
    let tmp = tempfile::tempdir().unwrap();
    let step = Window { r: 5, mean: true };
    let mut outs = Vec::new();
    for threads in [1, 2] {
        let dir = tmp.path().join(format!("mean{threads}.tiles"));
        let opts = StoreOptions {
            tile: 64,
            sync: false,
            ..Default::default()
        };
        let prov = Provenance::new(step.name(), step.params(), vec!["mem".into()]);
        let wr = StoreWriter::create(&dir, w, h, DType::F32, &GeoRef::pixel(), opts, prov).unwrap();
        let layout = wr.layout();
        engine(threads)
            .run_local(
                &step,
                Run::new(&[&src as &dyn RasterSource], layout, vec![Box::new(wr)]),
            )
            .unwrap();
        outs.push(dir_bytes(&dir));
        let st = TileStore::open(&dir).unwrap();
        let g: Grid<f32> = st
            .read_native(orogen::raster::Window::full(w, h))
            .unwrap()
            .to_typed(None);
        let want = oracle_mean(&data, w, h, 5);
        for (a, b) in g.data().iter().zip(&want) {
            assert!((a.is_nan() && b.is_nan()) || *a == *b as f32);
        }
    }
    assert_eq!(outs[0], outs[1]);
    assert!(outs[0].iter().any(|(n, _)| n == "manifest.json"));
    assert_eq!(
        outs[0].len(),
        1 + 4 * 3,
        "manifest + 12 tiles, no journal or lock left"
    );
}

/// Records the largest number of tiles computing at once.
struct Concurrency {
    now: AtomicUsize,
    max: AtomicUsize,
}
impl LocalStep for Concurrency {
    type In = f32;
    type Out = f32;
    fn name(&self) -> String {
        "concurrency".into()
    }
    fn params(&self) -> serde_json::Value {
        serde_json::Value::Null
    }
    fn halo(&self) -> usize {
        0
    }
    fn outputs(&self) -> Vec<OutputSpec> {
        vec![OutputSpec::continuous(DType::F32, 0.0)]
    }
    fn run(&self, inputs: &[TileView<f32>], out: &mut [Grid<f32>]) -> Result<()> {
        let n = self.now.fetch_add(1, Ordering::SeqCst) + 1;
        self.max.fetch_max(n, Ordering::SeqCst);
        std::thread::sleep(std::time::Duration::from_millis(2));
        out[0] = inputs[0].core_grid();
        self.now.fetch_sub(1, Ordering::SeqCst);
        Ok(())
    }
}

#[test]
fn memory_budget_bounds_tiles_in_flight() {
    assert_eq!(tiles_in_flight(100, 30), 3);
    assert_eq!(tiles_in_flight(10, 30), 1);
    assert_eq!(tiles_in_flight(0, 0), 1);
    let (w, h) = (64, 64);
    let data = random_grid(w, h, 1);
    let src = source(&data, w, h);
    for (budget, bound) in [(1u64, 1usize), (16 * 16 * (8 + 8 + 4 + 4) * 2, 2)] {
        let step = Concurrency {
            now: AtomicUsize::new(0),
            max: AtomicUsize::new(0),
        };
        let (sink, handle) = MemSink::new(w, h, DType::F64, None);
        LocalEngine::new(EngineConfig {
            threads: 2,
            memory_budget: budget,
            progress: false,
            observer: None,
            engine: Default::default(),
        })
        .run_local(
            &step,
            Run::new(
                &[&src as &dyn RasterSource],
                TileLayout::new(w, h, 16),
                vec![Box::new(sink)],
            ),
        )
        .unwrap();
        assert!(step.max.load(Ordering::SeqCst) <= bound);
        assert!(handle.take().unwrap().as_le_bytes() == &f64_bytes(&data)[..]);
    }
}

/// Copies its input and fails on one tile.
struct FailAt(usize);
impl LocalStep for FailAt {
    type In = f32;
    type Out = f32;
    fn name(&self) -> String {
        "fail".into()
    }
    fn params(&self) -> serde_json::Value {
        serde_json::Value::Null
    }
    fn halo(&self) -> usize {
        0
    }
    fn outputs(&self) -> Vec<OutputSpec> {
        vec![OutputSpec::continuous(DType::F32, 0.0)]
    }
    fn run(&self, inputs: &[TileView<f32>], out: &mut [Grid<f32>]) -> Result<()> {
        if inputs[0].id == self.0 {
            return Err(Error::invalid("deliberate failure"));
        }
        out[0] = inputs[0].core_grid();
        Ok(())
    }
}

#[test]
fn step_error_stops_the_run_and_leaves_no_finished_store() {
    let (w, h) = (100, 100);
    let data = random_grid(w, h, 3);
    let src = source(&data, w, h);
    let tmp = tempfile::tempdir().unwrap();
    for threads in [1, 2] {
        let dir = tmp.path().join(format!("fail{threads}.tiles"));
        let opts = StoreOptions {
            tile: 10,
            sync: false,
            ..Default::default()
        };
        let wr = StoreWriter::create(
            &dir,
            w,
            h,
            DType::F32,
            &GeoRef::pixel(),
            opts,
            Provenance::default(),
        )
        .unwrap();
        let layout = wr.layout();
        let err = engine(threads)
            .run_local(
                &FailAt(42),
                Run::new(&[&src as &dyn RasterSource], layout, vec![Box::new(wr)]),
            )
            .unwrap_err();
        match &err {
            Error::Tile { id, inner, .. } => {
                assert_eq!(*id, 42);
                assert!(inner.to_string().contains("deliberate"));
            }
            e => panic!("unexpected error {e}"),
        }
        assert!(err.to_string().contains("tile 42"), "{err}");
        let e = TileStore::open(&dir).unwrap_err();
        assert!(e.to_string().contains("rerun"), "{e}");
        // The writer released its lock when dropped.
        assert!(!dir.join(".lock").exists());
    }
}

/// A step that panics on one tile (a bug in a step).
struct PanicAt(usize);
impl LocalStep for PanicAt {
    type In = f32;
    type Out = f32;
    fn name(&self) -> String {
        "panic".into()
    }
    fn params(&self) -> serde_json::Value {
        serde_json::Value::Null
    }
    fn halo(&self) -> usize {
        0
    }
    fn outputs(&self) -> Vec<OutputSpec> {
        vec![OutputSpec::continuous(DType::F32, 0.0)]
    }
    fn run(&self, inputs: &[TileView<f32>], out: &mut [Grid<f32>]) -> Result<()> {
        assert!(
            inputs[0].id != self.0,
            "deliberate panic in tile {}",
            self.0
        );
        out[0] = inputs[0].core_grid();
        Ok(())
    }
}

#[test]
fn step_panic_is_the_run_error_not_a_hang() {
    // Before the fix the consumer waited for ever for the panicked tile's
    // result; the run goes on a thread so a hang fails the test.
    let (w, h) = (100, 100);
    let data = random_grid(w, h, 3);
    for threads in [1, 2] {
        let data = data.clone();
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            let src = source(&data, w, h);
            let layout = TileLayout::new(w, h, 10);
            let (sink, _handle) = orogen::store::sink::MemSink::new(w, h, DType::F32, None);
            let r = engine(threads).run_local(
                &PanicAt(42),
                Run::new(&[&src as &dyn RasterSource], layout, vec![Box::new(sink)]),
            );
            let _ = tx.send(r.map_err(|e| e.to_string()));
        });
        let r = rx
            .recv_timeout(std::time::Duration::from_secs(120))
            .expect("the run hung after a tile's work panicked");
        let e = r.unwrap_err();
        assert!(
            e.contains("tile 42") && e.contains("deliberate panic in tile 42"),
            "{e}"
        );
    }
}

#[test]
fn wrong_layout_or_sink_count_is_refused() {
    let (w, h) = (40, 30);
    let data = random_grid(w, h, 3);
    let src = source(&data, w, h);
    let tmp = tempfile::tempdir().unwrap();
    let opts = StoreOptions {
        tile: 16,
        sync: false,
        ..Default::default()
    };
    let wr = StoreWriter::create(
        tmp.path().join("a.tiles"),
        w,
        h,
        DType::F32,
        &GeoRef::pixel(),
        opts,
        Provenance::default(),
    )
    .unwrap();
    let e = engine(1)
        .run_local(
            &FailAt(usize::MAX),
            Run::new(
                &[&src as &dyn RasterSource],
                TileLayout::new(w, h, 8),
                vec![Box::new(wr)],
            ),
        )
        .unwrap_err();
    assert!(e.to_string().contains("layout"), "{e}");
    let e = engine(1)
        .run_local(
            &FailAt(usize::MAX),
            Run::new(
                &[&src as &dyn RasterSource],
                TileLayout::new(w, h, 8),
                Vec::<Box<dyn TileSink>>::new(),
            ),
        )
        .unwrap_err();
    assert!(e.to_string().contains("sinks"), "{e}");
    let e = engine(1)
        .run_local(
            &FailAt(usize::MAX),
            Run::new(
                &[&src as &dyn RasterSource],
                TileLayout::new(w + 1, h, 8),
                vec![Box::new(MemSink::new(w + 1, h, DType::F32, None).0)],
            ),
        )
        .unwrap_err();
    assert!(e.to_string().contains("40x30"), "{e}");
}
