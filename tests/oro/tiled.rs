//! The divide tree computed across tiles equals the in-memory one exactly
//! (peaks, representative cells, key saddles and their order, parents,
//! prominences, edge flags), for many tile sizes and both edge conventions.
//! The oracle is `oro::divide_tree` on the whole grid, itself checked against
//! brute force (`brute_force.rs`) and akirmse/mountains (`reference.rs`);
//! the tiled code shares no sweep code with it (only the neighbour order and
//! the breadth-first growth of flat regions, which the brute force checks).

use crate::common::cli::{ok, orogen};
use crate::common::write_esri_ascii;
use orogen::exec::{EngineConfig, LocalEngine};
use orogen::oro::{self, divide_tree_tiled, DivideTree, EdgeConvention};
use orogen::raster::{GeoRef, Grid, MemRaster, RasterSource};
use proptest::prelude::*;

const CONVS: [EdgeConvention; 2] = [EdgeConvention::SeaLevel, EdgeConvention::Unknown];

fn engine(threads: usize) -> LocalEngine {
    LocalEngine::new(EngineConfig {
        threads,
        memory_budget: 1 << 28,
        progress: false,
        observer: None,
        engine: Default::default(),
    })
}

fn mem(g: &Grid<f32>) -> MemRaster {
    MemRaster::from_grid(g.clone(), GeoRef::pixel())
}

fn tiled(g: &Grid<f32>, conv: EdgeConvention, tile: usize) -> DivideTree {
    divide_tree_tiled(&mem(g) as &dyn RasterSource, conv, tile, &engine(1)).expect("tiled tree")
}

fn check_equal(g: &Grid<f32>, tiles: &[usize]) {
    for conv in CONVS {
        let want = oro::divide_tree(g, conv).expect("in-memory tree");
        for &t in tiles {
            let got = tiled(g, conv, t);
            if got != want {
                // Show the first difference.
                let np = got.peaks.len().min(want.peaks.len());
                let first = (0..np).find(|&i| got.peaks[i] != want.peaks[i]);
                panic!(
                    "tile {t}, {conv:?}: {} vs {} peaks, {} vs {} saddles; first peak diff at {first:?}: {:?} vs {:?}",
                    got.peaks.len(),
                    want.peaks.len(),
                    got.saddles.len(),
                    want.saddles.len(),
                    first.map(|i| &got.peaks[i]),
                    first.map(|i| &want.peaks[i]),
                );
            }
        }
    }
}

fn grid(w: usize, h: usize, f: impl Fn(usize, usize) -> f32) -> Grid<f32> {
    Grid::from_fn(w, h, f)
}

/// Random terrain with few levels (plateaus, equal heights, k-way saddles),
/// optional NaN holes and negative cells.
fn terrain() -> impl Strategy<Value = Grid<f32>> {
    (
        3usize..42,
        3usize..42,
        any::<u64>(),
        2u32..9,
        0u32..4,
        any::<bool>(),
    )
        .prop_map(|(w, h, seed, levels, holes, negative)| {
            let mut s = seed | 1;
            let mut next = move || {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                s
            };
            let mut data: Vec<f32> = (0..w * h)
                .map(|_| {
                    let v = (next() % levels as u64) as f32;
                    if negative {
                        v - 2.0
                    } else {
                        v + 1.0
                    }
                })
                .collect();
            // Smooth a little so ridges and plateaus span several cells.
            let raw = data.clone();
            for y in 0..h {
                for x in 0..w {
                    if next() % 3 == 0 {
                        let xn = (x + 1).min(w - 1);
                        data[y * w + x] = raw[y * w + xn];
                    }
                }
            }
            for _ in 0..holes {
                let (cx, cy, r) = (
                    (next() % w as u64) as i64,
                    (next() % h as u64) as i64,
                    (next() % 3) as i64,
                );
                for y in 0..h as i64 {
                    for x in 0..w as i64 {
                        if (x - cx).abs() <= r && (y - cy).abs() <= r {
                            data[y as usize * w + x as usize] = f32::NAN;
                        }
                    }
                }
            }
            Grid::from_vec(w, h, data).expect("sizes match")
        })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 150, ..ProptestConfig::default() })]
    #[test]
    fn tiled_equals_in_memory(g in terrain(), t in prop::sample::select(vec![1usize, 2, 3, 4, 5, 7, 13])) {
        check_equal(&g, &[t]);
    }
}

#[test]
fn tile_sizes_7_13_37_100_on_a_larger_grid() {
    // Integer "SRTM-like" terrain with many ties: a sum of waves, rounded.
    let g = grid(157, 121, |x, y| {
        let (x, y) = (x as f32, y as f32);
        (40.0 * (x * 0.11).sin() * (y * 0.07).cos() + 25.0 * (x * 0.031 + y * 0.05).sin() + 60.0)
            .round()
    });
    check_equal(&g, &[7, 13, 37, 100]);
}

#[test]
fn thread_count_does_not_change_the_tree() {
    let g = grid(90, 70, |x, y| {
        ((x * 7 + y * 13) % 11) as f32 + ((x / 9 + y / 5) % 4) as f32
    });
    for conv in CONVS {
        let a = divide_tree_tiled(&mem(&g) as &dyn RasterSource, conv, 13, &engine(1)).unwrap();
        let b = divide_tree_tiled(&mem(&g) as &dyn RasterSource, conv, 13, &engine(2)).unwrap();
        assert_eq!(a, b);
        assert_eq!(a, oro::divide_tree(&g, conv).unwrap());
    }
}

#[test]
fn flat_dem_has_no_peak_unknown_and_one_island_sea_level() {
    let g = grid(20, 20, |_, _| 100.0);
    let sea = tiled(&g, EdgeConvention::SeaLevel, 7);
    assert_eq!(sea.peaks.len(), 1);
    assert_eq!((sea.peaks[0].col, sea.peaks[0].row), (0, 0));
    assert_eq!(sea.peaks[0].prominence, 100.0);
    assert!(tiled(&g, EdgeConvention::Unknown, 7).peaks.is_empty());
    check_equal(&g, &[1, 7, 13]);
}

#[test]
fn all_nodata_has_no_peak() {
    let g = grid(15, 9, |_, _| f32::NAN);
    for conv in CONVS {
        let t = tiled(&g, conv, 4);
        assert!(t.peaks.is_empty() && t.saddles.is_empty());
    }
}

#[test]
fn one_peak_cone_across_four_tiles() {
    // Apex at (10, 10), exactly on a tile corner for tile 10.
    let g = grid(21, 21, |x, y| {
        100.0 - ((x as f32 - 10.0).abs().max((y as f32 - 10.0).abs()))
    });
    for conv in CONVS {
        let t = tiled(&g, conv, 10);
        assert_eq!(t.peaks.len(), 1);
        let p = &t.peaks[0];
        assert_eq!((p.col, p.row, p.elevation), (10, 10, 100.0));
        let want = match conv {
            EdgeConvention::SeaLevel => 100.0,
            EdgeConvention::Unknown => 10.0,
        };
        assert_eq!(p.prominence, want);
    }
    check_equal(&g, &[3, 10, 11]);
}

#[test]
fn equal_twin_summits_across_a_seam() {
    // Two 50 m summits at (3, 3) and (6, 3), either side of the seams at
    // x = 4 (tile 4) or x = 5 (tile 5), with a two-cell notch at 30 m
    // between them on the seam.
    let mut g = grid(10, 7, |x, y| {
        10.0 + x.min(9 - x) as f32 + y.min(6 - y) as f32
    });
    g.set(3, 3, 50.0);
    g.set(6, 3, 50.0);
    g.set(4, 3, 30.0);
    g.set(5, 3, 30.0);
    for conv in CONVS {
        for tile in [4, 5] {
            let t = tiled(&g, conv, tile);
            // The eastern twin is processed first (later first cell), so it is
            // the "higher" one; the western gets the key saddle at 30 m.
            let tops: Vec<_> = t.peaks.iter().map(|p| (p.col, p.row)).take(2).collect();
            assert_eq!(tops, vec![(6, 3), (3, 3)], "tile {tile} {conv:?}");
            assert_eq!(t.peaks[1].prominence, 20.0);
            assert_eq!(t.peaks[1].parent, Some(0));
            let s = &t.saddles[t.peaks[1].key_saddle.unwrap()];
            // The notch is one flat region; its representative is its first cell.
            assert_eq!((s.col, s.row, s.elevation), (4, 3, 30.0));
        }
    }
    check_equal(&g, &[2, 3, 4, 5, 6]);
}

#[test]
fn plateau_summit_spanning_many_tiles() {
    // A U-shaped summit plateau whose first cell lies in another tile than
    // most of it, and a k-way saddle plateau crossing seams.
    let mut g = grid(30, 20, |x, y| (x + y) as f32 % 5.0 + 1.0);
    for y in 2..15 {
        g.set(3, y, 80.0);
        g.set(20, y, 80.0);
    }
    for x in 3..=20 {
        g.set(x, 14, 80.0);
    }
    for x in 0..30 {
        g.set(x, 17, 40.0);
    }
    g.set(12, 5, 90.0);
    g.set(26, 4, 90.0);
    check_equal(&g, &[1, 2, 3, 4, 5, 7, 13]);
}

// ------------------------------------------------------------ real DEMs ----

fn open(path: &std::path::Path) -> Box<dyn RasterSource> {
    orogen::io::open_raster(path, &orogen::io::OpenOptions::default()).expect("opens")
}

fn whole(src: &dyn RasterSource) -> Grid<f32> {
    let info = src.info();
    orogen::raster::read_window::<f32>(src, orogen::raster::Window::full(info.width, info.height))
        .expect("reads")
}

/// Tiled == in-memory for the whole tree, and for the pruned peak list
/// with isolation (cache of one window, so most blocks are re-read).
fn check_real(path: &std::path::Path, tiles: &[usize], min_prominence: f64) {
    let src = open(path);
    let dem = whole(src.as_ref());
    for conv in CONVS {
        let want = oro::divide_tree(&dem, conv).unwrap();
        assert!(
            want.peaks.len() > 10,
            "{}: a real DEM has peaks",
            path.display()
        );
        for &t in tiles {
            let got = divide_tree_tiled(src.as_ref(), conv, t, &engine(2)).unwrap();
            assert!(
                got == want,
                "{} tile {t} {conv:?}: trees differ",
                path.display()
            );
        }
        let opts = oro::PeakOptions {
            min_prominence,
            convention: conv,
            isolation: true,
        };
        let want = oro::peaks(&dem, &src.info().georef, &opts).unwrap();
        let got = oro::peaks_tiled(src.as_ref(), &opts, tiles[0], &engine(2), 1).unwrap();
        assert_eq!(got, want, "{} {conv:?}: peak lists differ", path.display());
    }
}

#[test]
fn real_dems_in_tests_data() {
    let d = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    // Integers with nodata 0 (geographic, 3"), int16 UTM, float32 with nodata.
    check_real(&d.join("landlab_SRTMGL3_frontrange.asc"), &[37, 100], 30.0);
    check_real(&d.join("bigtujunga_crop.tif"), &[7, 64], 30.0);
    check_real(&d.join("whitebox_DEM.tif"), &[13, 100], 5.0);
}

#[test]
fn aconcagua_crop_tiled_equals_in_memory() {
    let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/oro/srtm3_S33W071_crop.tif");
    check_real(&p, &[97, 256], 30.0);
}

#[test]
fn alps_crop_with_voids_tiled_equals_in_memory() {
    let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/oro/srtm3_N46E008_crop.tif");
    check_real(&p, &[64, 131], 30.0);
}

#[test]
fn tiled_isolation_equals_in_memory_on_a_geographic_grid() {
    use orogen::raster::{Crs, GeoRef};
    let g = grid(300, 200, |x, y| {
        let (x, y) = (x as f32, y as f32);
        (30.0 * (x * 0.05).sin() * (y * 0.09).cos() + 0.1 * x + 50.0).round()
    });
    let mut geo = GeoRef::pixel();
    geo.transform = [10.0, 1.0 / 1200.0, 0.0, 47.0, 0.0, -1.0 / 1200.0];
    geo.georeferenced = true;
    geo.crs = Crs::wgs84();
    let src = MemRaster::from_grid(g.clone(), geo.clone());
    let mem_idx = oro::IsolationIndex::new(&g, &geo);
    let tiled_idx = oro::TiledIsolationIndex::new(&src, 1).unwrap();
    for (i, &z) in g.data().iter().enumerate().step_by(7) {
        let (c, r) = (i % 300, i / 300);
        assert_eq!(
            tiled_idx.nearest_higher(c, r, z).unwrap(),
            mem_idx.nearest_higher(c, r, z)
        );
    }
}

// ------------------------------------------------------------------ CLI ----

/// `orogen peaks DEM ARGS -o OUT`, which must succeed: its stdout and stderr.
fn peaks_cli(dem: &std::path::Path, out: &std::path::Path, args: &[&str]) -> String {
    ok(orogen().arg("peaks").arg(dem).args(args).arg("-o").arg(out))
}

#[test]
fn cli_peaks_tiled_writes_the_same_files_as_in_memory() {
    let dem =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/bigtujunga_crop.tif");
    let dir = tempfile::tempdir().unwrap();
    let run = |name: &str, extra: &[&str]| {
        let out = dir.path().join(name);
        peaks_cli(
            &dem,
            &out,
            &[&["--min-prominence", "20", "-q"], extra].concat(),
        );
        out
    };
    let mem = run("mem", &[]);
    let forced = run("forced", &["--tiled", "--tile", "64"]);
    for f in [
        "peaks.csv",
        "peaks.geojson",
        "saddles.geojson",
        "divide_tree.geojson",
        "divide_tree.json",
    ] {
        let a = std::fs::read(mem.join(f)).unwrap();
        assert!(a.len() > 100, "{f} has content");
        assert_eq!(a, std::fs::read(forced.join(f)).unwrap(), "{f} (--tiled)");
    }
}

#[test]
fn cli_peaks_goes_tiled_when_the_dem_does_not_fit_the_budget() {
    // 800 x 800 cells need ~17.9 MB in memory: a 16 MiB budget goes tiled.
    let dir = tempfile::tempdir().unwrap();
    let dem = dir.path().join("dem.asc");
    let n = 800;
    write_esri_ascii(&dem, (n, n), (0.0, 0.0, 30.0), |x, y| {
        let (xf, yf) = (x as f32, y as f32);
        let z = 300.0 * (xf * 0.013).sin() * (yf * 0.017).cos()
            + 80.0 * (xf * 0.07 + yf * 0.05).sin()
            + 500.0;
        let hole = (x as i64 - 400).pow(2) + (y as i64 - 300).pow(2) < 400;
        (!hole).then_some(z.round() as i32 as f64)
    });
    let run = |name: &str, extra: &[&str]| {
        let out = dir.path().join(name);
        let log = peaks_cli(&dem, &out, &[&["--min-prominence", "30"], extra].concat());
        (out, log)
    };
    let (mem, log_mem) = run("mem", &[]);
    let (budget, log) = run("budget", &["--memory", "16MiB", "--tile", "100"]);
    assert!(log.contains("tile by tile"), "{log}");
    assert!(!log_mem.contains("tile by tile"), "{log_mem}");
    for f in ["peaks.csv", "saddles.geojson", "divide_tree.json"] {
        let a = std::fs::read(mem.join(f)).unwrap();
        assert!(a.len() > 100, "{f} has content");
        assert_eq!(a, std::fs::read(budget.join(f)).unwrap(), "{f} (--memory)");
    }
}

#[test]
fn infinite_elevation_is_an_error_not_a_panic() {
    let mut g = grid(20, 20, |x, y| (x + y) as f32);
    g.set(11, 3, f32::INFINITY);
    for conv in CONVS {
        let e = divide_tree_tiled(&mem(&g) as &dyn RasterSource, conv, 7, &engine(1))
            .expect_err("infinite cell");
        assert!(e.to_string().contains("(11, 3)"), "{e}");
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 100, ..ProptestConfig::default() })]
    /// Peaks dropped inside the tiles never change the pruned tree, also
    /// with sub-sea-level saddles (negative cells) under SeaLevel.
    #[test]
    fn pruned_tiled_equals_pruned_in_memory(
        g in terrain(),
        t in prop::sample::select(vec![2usize, 3, 5, 7, 13]),
        m in prop::sample::select(vec![0.0f64, 1.0, 2.0, 3.0, 5.0]),
    ) {
        for conv in CONVS {
            let want = oro::divide_tree(&g, conv).unwrap().pruned(m);
            let got = oro::pruned_tree_tiled(&mem(&g) as &dyn RasterSource, conv, m, t, &engine(1)).unwrap();
            prop_assert_eq!(got, want, "tile {} {:?} min {}", t, conv, m);
        }
    }
}
