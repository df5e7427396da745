//! Slope, aspect and hillshade run tiled through the engine equal the untiled
//! run bit for bit, and match gdaldem's output (recorded in tests/data/gdaldem,
//! made by GDAL 3.6 `gdaldem` on tests/data/bigtujunga_crop.tif).

use orogen::exec::{run_local_to_memory, EngineConfig, LocalEngine, LocalStep};
use orogen::io::{open_raster, OpenOptions};
use orogen::metrics::{Aspect, EdgeMode, Hillshade, Slope};
use orogen::raster::{AnyGrid, DType, Grid, RasterSource, TileLayout};
use std::path::Path;

fn data(p: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(p)
}

fn open(p: &str) -> Box<dyn RasterSource> {
    open_raster(&data(p), &OpenOptions::default()).unwrap()
}

/// Run `step` over `src` with work tiles of `tile` cells and `threads` threads.
fn run<S: LocalStep>(
    step: &S,
    src: &dyn RasterSource,
    tile: usize,
    threads: usize,
    dtype: DType,
    nd: f64,
) -> AnyGrid {
    let info = src.info();
    let engine = LocalEngine::new(EngineConfig {
        threads,
        memory_budget: 64 << 20,
        progress: false,
        observer: None,
        engine: Default::default(),
    });
    let layout = TileLayout::new(info.width, info.height, tile);
    run_local_to_memory(&engine, step, &[src], layout, &[(dtype, Some(nd))])
        .unwrap()
        .remove(0)
}

fn check_tiling<S: LocalStep>(step: &S, dtype: DType, nd: f64) -> AnyGrid {
    let src = open("bigtujunga_crop.tif");
    let whole = run(step, src.as_ref(), 4096, 1, dtype, nd);
    for tile in [1, 7, 64, 257] {
        for threads in [1, 2] {
            let t = run(step, src.as_ref(), tile, threads, dtype, nd);
            assert!(
                t == whole,
                "{} differs with tile {tile}, {threads} threads",
                step.name()
            );
        }
    }
    whole
}

fn gdal(p: &str) -> Grid<f64> {
    let r = open(p);
    let info = r.info();
    r.read_native(orogen::raster::Window::full(info.width, info.height))
        .unwrap()
        .to_typed::<f64>(None)
}

fn compare(ours: &AnyGrid, theirs: &Grid<f64>, tol: f64, circular: bool) -> usize {
    let o = ours.to_typed::<f64>(None);
    assert_eq!((o.width(), o.height()), (theirs.width(), theirs.height()));
    let mut n = 0;
    for (a, b) in o.data().iter().zip(theirs.data()) {
        // nodata patterns (-9999 / 0) must agree exactly
        assert_eq!(*a == -9999.0, *b == -9999.0);
        let mut d = (a - b).abs();
        if circular {
            d = d.min(360.0 - d);
        }
        assert!(d <= tol, "{a} vs gdaldem {b}");
        if *a != -9999.0 {
            n += 1;
        }
    }
    n
}

#[test]
fn slope_tiled_equals_untiled_and_gdaldem() {
    let s = check_tiling(&Slope::default(), DType::F32, -9999.0);
    let n = compare(&s, &gdal("gdaldem/slope.tif"), 1e-4, false);
    assert_eq!(n, 299 * 201);
}

#[test]
fn slope_compute_edges_matches_gdaldem() {
    let st = Slope {
        edge: EdgeMode::Compute,
        ..Default::default()
    };
    let s = check_tiling(&st, DType::F32, -9999.0).to_typed::<f64>(None);
    let g = gdal("gdaldem/slope_edges.tif");
    // Every cell computed; all but gdaldem's four corner cells (a rule of its
    // own, documented in EdgeMode::Compute) within 1e-4 degrees of gdaldem.
    let (w, h) = (s.width(), s.height());
    for y in 0..h {
        for x in 0..w {
            assert!(s.get(x, y) != -9999.0);
            let corner = (x == 0 || x == w - 1) && (y == 0 || y == h - 1);
            if !corner {
                let d = (s.get(x, y) - g.get(x, y)).abs();
                assert!(
                    d <= 1e-4,
                    "({x},{y}): {} vs gdaldem {}",
                    s.get(x, y),
                    g.get(x, y)
                );
            }
        }
    }
}

#[test]
fn aspect_tiled_equals_untiled_and_gdaldem() {
    let a = check_tiling(&Aspect::default(), DType::F32, -9999.0);
    compare(&a, &gdal("gdaldem/aspect.tif"), 1e-4, true);
}

#[test]
fn hillshade_tiled_equals_untiled_and_gdaldem() {
    let h = check_tiling(&Hillshade::default(), DType::U8, 0.0);
    let ours = h.to_typed::<f64>(None);
    let theirs = gdal("gdaldem/hillshade.tif");
    let same = ours
        .data()
        .iter()
        .zip(theirs.data())
        .filter(|(a, b)| a == b)
        .count();
    assert_eq!(same, ours.len(), "hillshade bytes differ from gdaldem");
}

/// The check: slope, aspect and hillshade computed from tile stores of
/// tile sizes 64, 257 and 1024 (raw and zstd) equal the in-memory result.
#[test]
fn from_stores_of_several_tile_sizes_equal_in_memory() {
    use orogen::store::{Compression, StoreOptions, TileStore};
    let src = open("bigtujunga_crop.tif");
    let slope = run(
        &Slope::default(),
        src.as_ref(),
        4096,
        1,
        DType::F32,
        -9999.0,
    );
    let aspect = run(
        &Aspect::default(),
        src.as_ref(),
        4096,
        1,
        DType::F32,
        -9999.0,
    );
    let shade = run(&Hillshade::default(), src.as_ref(), 4096, 1, DType::U8, 0.0);
    let dir = tempfile::tempdir().unwrap();
    let cfg = EngineConfig {
        threads: 2,
        memory_budget: 64 << 20,
        progress: false,
        observer: None,
        engine: Default::default(),
    };
    for tile in [64, 257, 1024] {
        for compression in [Compression::None, Compression::Zstd { level: 1 }] {
            let path = dir.path().join(format!(
                "d{tile}_{}.tiles",
                compression != Compression::None
            ));
            let opts = StoreOptions {
                tile,
                compression,
                ..Default::default()
            };
            orogen::exec::ingest(src.as_ref(), &path, opts, &cfg).unwrap();
            let store = TileStore::open(&path).unwrap();
            assert_eq!(store.layout().tile, tile);
            assert!(
                run(&Slope::default(), &store, tile, 2, DType::F32, -9999.0) == slope,
                "slope, store tile {tile}"
            );
            assert!(
                run(&Aspect::default(), &store, tile, 2, DType::F32, -9999.0) == aspect,
                "aspect, store tile {tile}"
            );
            assert!(
                run(&Hillshade::default(), &store, tile, 2, DType::U8, 0.0) == shade,
                "hillshade, store tile {tile}"
            );
        }
    }
}
