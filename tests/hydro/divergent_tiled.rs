//! Tiled divergent (MFD, D∞) accumulation == in-memory accumulation, bit for
//! bit, through the real engine (`run_multi_accumulation` on a
//! `LocalEngine`), for tile sizes 7, 37 and 100, on proptest grids with
//! plateaus and nodata holes and on real DEMs; and exact conservation of
//! the fixed-point sums.

use orogen::exec::{EngineConfig, LocalEngine, MemSink, TileSink};
use orogen::hydro::dinf::dinf;
use orogen::hydro::mfd::{accumulate_fixed, mfd_flow, FixedAccumulation, FlowFractions, MfdMethod};
use orogen::hydro::tiled_mfd::{run_multi_accumulation, Router};
use orogen::hydro::{d8_directions, fill};
use orogen::raster::{AnyGrid, DType, GeoRef, Grid, MemRaster, RasterSource, TileLayout};
use proptest::prelude::*;

use crate::common::hydro::read_raw;

const ROUTERS: [Router; 5] = [
    Router::Dinf,
    Router::Mfd(MfdMethod::Quinn),
    Router::Mfd(MfdMethod::Freeman),
    Router::Mfd(MfdMethod::Holmgren(1.0)),
    Router::Mfd(MfdMethod::Holmgren(4.0)),
];

fn in_memory(dem: &Grid<f32>, router: Router) -> FlowFractions {
    match router {
        Router::Dinf => dinf(dem).unwrap().flow,
        Router::Mfd(m) => mfd_flow(dem, m).unwrap(),
    }
}

/// Bits of an f64 grid with every NaN mapped to one value.
fn bits(v: &[f64]) -> Vec<u64> {
    v.iter()
        .map(|v| if v.is_nan() { u64::MAX } else { v.to_bits() })
        .collect()
}

/// The in-memory answer as the f64 values the tiled run writes.
fn want(flow: &FlowFractions, weights: Option<&Grid<f32>>) -> (Vec<f64>, FixedAccumulation) {
    let acc = accumulate_fixed(flow, weights).unwrap();
    let v = (0..flow.height())
        .flat_map(|y| (0..flow.width()).map(move |x| (x, y)))
        .map(|(x, y)| {
            if flow.fractions(x, y).is_none() {
                f64::NAN
            } else {
                acc.acc[y * flow.width() + x] as f64 / 4_294_967_296.0
            }
        })
        .collect();
    (v, acc)
}

/// Tiled run through the engine; returns the values and the rounds.
fn tiled(
    dem: &Grid<f32>,
    weights: Option<&Grid<f32>>,
    router: Router,
    tile: usize,
    threads: usize,
) -> (Vec<f64>, usize) {
    let (w, h) = (dem.width(), dem.height());
    let d8 = d8_directions(dem);
    let zsrc = MemRaster::from_grid(dem.clone(), GeoRef::pixel().with_nodata(None));
    let dsrc = MemRaster::from_grid(d8, GeoRef::pixel().with_nodata(Some(255.0)));
    let wsrc = weights.map(|g| MemRaster::from_grid(g.clone(), GeoRef::pixel()));
    let mut inputs: Vec<&dyn RasterSource> = vec![&zsrc, &dsrc];
    if let Some(ws) = &wsrc {
        inputs.push(ws);
    }
    let (sink, handle) = MemSink::new(w, h, DType::F64, None);
    let sinks: Vec<Box<dyn TileSink>> = vec![Box::new(sink)];
    let engine = LocalEngine::new(EngineConfig {
        threads,
        ..EngineConfig::default()
    });
    let run = run_multi_accumulation(
        &engine,
        router,
        weights.is_some(),
        &inputs,
        TileLayout::new(w, h, tile),
        sinks,
    )
    .expect("tiled run");
    let Some(AnyGrid::F64(g)) = handle.take() else {
        panic!("sink holds an f64 grid")
    };
    (g.data().to_vec(), run.rounds)
}

fn weights_for(w: usize, h: usize, seed: u32) -> Grid<f32> {
    Grid::from_fn(w, h, |x, y| {
        if (x * 7 + y * 3 + seed as usize).is_multiple_of(11) {
            f32::NAN
        } else {
            ((x * 31 + y * 17 + seed as usize) % 13) as f32 * 0.37 - 1.5
        }
    })
}

/// Tiled == in memory for every router and tile size, counts and weights;
/// the fixed-point totals are conserved exactly.
fn check(dem: &Grid<f32>, tiles: &[usize], seed: u32) -> Result<(), TestCaseError> {
    let (w, h) = (dem.width(), dem.height());
    let wts = weights_for(w, h, seed);
    // independent oracle of the totals: each valid cell's weight rounded to 2^-32
    let total_cells = dem.data().iter().filter(|z| z.is_finite()).count() as i128;
    let total_w: i128 = dem
        .data()
        .iter()
        .zip(wts.data())
        .filter(|(z, v)| z.is_finite() && !v.is_nan())
        .map(|(_, &v)| (v as f64 * 4_294_967_296.0).round() as i128)
        .sum();
    for router in ROUTERS {
        let flow = in_memory(dem, router);
        let (want_c, acc_c) = want(&flow, None);
        let (want_w, acc_w) = want(&flow, Some(&wts));
        prop_assert_eq!(acc_c.left + acc_c.held, total_cells << 32, "{:?}", router);
        prop_assert_eq!(acc_w.left + acc_w.held, total_w, "{:?}", router);
        for &t in tiles {
            let (got, _) = tiled(dem, None, router, t, 1);
            prop_assert!(
                bits(&got) == bits(&want_c),
                "{:?} tile {} counts",
                router,
                t
            );
            let (got, _) = tiled(dem, Some(&wts), router, t, 2);
            prop_assert!(
                bits(&got) == bits(&want_w),
                "{:?} tile {} weights",
                router,
                t
            );
        }
    }
    Ok(())
}

/// Grids with plateaus (few distinct levels), nodata holes and noise.
fn dem_strategy() -> impl Strategy<Value = Grid<f32>> {
    (8usize..=130, 8usize..=130, any::<u64>()).prop_map(|(w, h, seed)| {
        let mut s = seed | 1;
        let mut next = move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            s
        };
        Grid::from_fn(w, h, |x, y| {
            let r = next();
            if r % 23 == 0 {
                f32::NAN
            } else {
                // a tilted surface quantised into terraces, plus small bumps
                let base = ((x as f32 * 0.3 + y as f32 * 0.2) / 3.0).floor();
                base + ((r >> 8) % 3) as f32 * (if (r >> 4) % 4 == 0 { 1.0 } else { 0.0 })
            }
        })
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(12))]

    #[test]
    fn tiled_equals_untiled_on_filled_grids(dem in dem_strategy(), seed in 0u32..50) {
        let filled = fill(&dem).unwrap();
        check(&filled, &[7, 37, 100], seed)?;
    }

    #[test]
    fn tiled_equals_untiled_on_unfilled_grids(dem in dem_strategy()) {
        // pits (D8 NO_FLOW) hold their water; tiles must agree there too
        check(&dem, &[7, 37], 3)?;
    }
}

#[test]
fn single_tile_needs_one_round_and_threads_do_not_matter() {
    let dem = fill(&Grid::from_fn(50, 40, |x, y| {
        100.0 - ((x as f32 - 20.0).powi(2) + (y as f32 - 25.0).powi(2)).sqrt()
    }))
    .unwrap();
    let router = Router::Mfd(MfdMethod::Quinn);
    let (a, r) = tiled(&dem, None, router, 64, 1);
    assert_eq!(r, 1);
    let (b, r7) = tiled(&dem, None, router, 7, 1);
    let (c, _) = tiled(&dem, None, router, 7, 2);
    assert!(r7 > 1);
    assert_eq!(bits(&a), bits(&b));
    assert_eq!(bits(&b), bits(&c));
    // a cone drains outwards: the apex holds 1 cell, everything sums to
    // the cell count at the edges
    assert_eq!(a[25 * 50 + 20], 1.0);
}

#[test]
fn all_nodata_and_constant_grids() {
    check(&Grid::new(9, 6, f32::NAN), &[1, 4, 9], 0).unwrap();
    check(&Grid::new(23, 11, 5.0), &[1, 3, 7, 23], 0).unwrap();
}

#[test]
fn inputs_are_checked() {
    let dem = Grid::new(10, 10, 1.0f32);
    let zsrc = MemRaster::from_grid(dem.clone(), GeoRef::pixel());
    let bad = MemRaster::from_grid(Grid::new(10, 10, 3.0f32), GeoRef::pixel());
    let engine = LocalEngine::new(EngineConfig::default());
    let (sink, _) = MemSink::new(10, 10, DType::F64, None);
    // a D8 "code" of 3 is no direction
    let r = run_multi_accumulation(
        &engine,
        Router::Dinf,
        false,
        &[&zsrc, &bad],
        TileLayout::new(10, 10, 4),
        vec![Box::new(sink)],
    );
    assert!(r.is_err());
    // the DEM alone is not enough
    let (sink, _) = MemSink::new(10, 10, DType::F64, None);
    let r = run_multi_accumulation(
        &engine,
        Router::Dinf,
        false,
        &[&zsrc],
        TileLayout::new(10, 10, 4),
        vec![Box::new(sink)],
    );
    assert!(r.is_err());
}

#[test]
fn real_dems_tiled_equal_untiled() {
    for (name, w, h, nodata) in [
        ("bigtujunga_crop.f32", 301, 203, 32767.0),
        ("pysheds_dem.f32", 367, 359, -32768.0),
    ] {
        let f = fill(&read_raw(name, w, h, nodata)).unwrap();
        for router in [Router::Dinf, Router::Mfd(MfdMethod::Holmgren(4.0))] {
            let (want_c, acc) = want(&in_memory(&f, router), None);
            let cells = f.data().iter().filter(|z| z.is_finite()).count() as i128;
            assert_eq!(acc.left + acc.held, cells << 32);
            for t in [7, 37, 100] {
                let (got, rounds) = tiled(&f, None, router, t, 2);
                assert!(bits(&got) == bits(&want_c), "{name} {router:?} tile {t}");
                eprintln!("{name} {router:?} tile {t}: {rounds} rounds");
            }
        }
    }
}

#[test]
fn cli_accumulate_methods_are_tiled_and_exact() {
    use orogen::io::{open_raster, OpenOptions};
    use orogen::raster::{read_window, Window};
    let dir = std::env::temp_dir().join(format!("orogen_mfd_cli_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bin = env!("CARGO_BIN_EXE_orogen");
    // a 520 x 420 terrain (ridges, valleys, a nodata hole) as ESRI ASCII:
    // big enough that 16 MiB cannot hold the in-memory working set
    let (aw, ah) = (520usize, 420usize);
    let mut asc = format!(
        "ncols {aw}\nnrows {ah}\nxllcorner 0\nyllcorner 0\ncellsize 30\nNODATA_value -9999\n"
    );
    for y in 0..ah {
        let row: Vec<String> = (0..aw)
            .map(|x| {
                let (fx, fy) = (x as f64, y as f64);
                if (fx - 300.0).powi(2) + (fy - 200.0).powi(2) < 150.0 {
                    "-9999".to_string()
                } else {
                    let z = 500.0
                        + 0.4 * fx
                        + 0.25 * fy
                        + 40.0 * (fx / 23.0).sin() * (fy / 31.0).cos()
                        + 15.0 * ((fx + 2.0 * fy) / 11.0).sin();
                    format!("{:.1}", z)
                }
            })
            .collect();
        asc.push_str(&row.join(" "));
        asc.push('\n');
    }
    let src = dir.join("terrain.asc");
    std::fs::write(&src, asc).unwrap();
    let filled = dir.join("filled.tif");
    let st = std::process::Command::new(bin)
        .args([
            "fill",
            src.to_str().unwrap(),
            "-q",
            "-o",
            filled.to_str().unwrap(),
        ])
        .status()
        .unwrap();
    assert!(st.success());
    let fsrc = open_raster(&filled, &OpenOptions::default()).unwrap();
    let (w, h) = (fsrc.info().width, fsrc.info().height);
    let f = read_window::<f32>(fsrc.as_ref(), Window::full(w, h)).unwrap();
    for (method, router) in [
        ("dinf", Router::Dinf),
        ("quinn", Router::Mfd(MfdMethod::Quinn)),
        ("holmgren", Router::Mfd(MfdMethod::Holmgren(4.0))),
    ] {
        let (want_c, _) = want(&in_memory(&f, router), None);
        // 16 MiB forces the tiled route; 1 GiB lets the raster run in memory
        for (tile, memory) in [("37", "16MiB"), ("100", "16MiB"), ("100", "1GiB")] {
            let out = dir.join(format!("acc_{method}_{tile}_{memory}.tif"));
            let st = std::process::Command::new(bin)
                .args(["accumulate", filled.to_str().unwrap(), "--method", method])
                .args(["--tile", tile, "--memory", memory, "-q"])
                .args(["-o", out.to_str().unwrap()])
                .status()
                .unwrap();
            assert!(st.success(), "{method} {tile}");
            let a = open_raster(&out, &OpenOptions::default()).unwrap();
            let g = read_window::<f64>(a.as_ref(), Window::full(w, h)).unwrap();
            assert!(
                bits(g.data()) == bits(&want_c),
                "{method} tile {tile} memory {memory}"
            );
        }
    }
    // the temporary D8 store is gone
    let left: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().contains("d8-tmp"))
        .collect();
    assert!(left.is_empty());
    std::fs::remove_dir_all(&dir).ok();
}
