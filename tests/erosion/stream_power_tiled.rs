//! The tiled (out-of-core) stream-power solve equals the in-memory solver bit
//! for bit: random DEMs with pits, flats, nodata holes and plateaus; real DEMs
//! from `tests/data`; several tile sizes, both depression modes it supports,
//! n = 1, 2 and 1.5, diffusion, uplift maps, scratch files. The oracle is the
//! in-memory solver (`stream_power::stream_power`), whose routing is checked
//! against brute-force definitions in `sp_fill_definition` below.

use orogen::erosion::stream_power::{
    stream_power, BaseHeight, Boundary, Depressions, StreamPower, StreamPowerParams, Uplift,
};
use orogen::erosion::stream_power_tiled::{stream_power_tiled_grid, SpBackend, SpTiling};
use orogen::raster::{read_window, Grid, Window};
use proptest::prelude::*;

/// SplitMix64 in [0, 1).
fn rng(seed: u64) -> impl FnMut() -> f64 {
    let mut s = seed;
    move || {
        s = s.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = s;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Rough terrain: a tilted bowl plus noise rounded to whole metres (many
/// equal heights: flats and plateaus), a few nodata holes.
fn terrain(w: usize, h: usize, seed: u64, holes: bool) -> Grid<f64> {
    let mut r = rng(seed);
    let (cx, cy) = (w as f64 * 0.4, h as f64 * 0.6);
    let mut g = Grid::from_fn(w, h, |x, y| {
        let (dx, dy) = (x as f64 - cx, y as f64 - cy);
        let bowl = 30.0 - 0.5 * (dx * dx + dy * dy).sqrt() + 0.2 * x as f64;
        (bowl + 6.0 * r()).round().max(0.0) + 100.0
    });
    if holes {
        for _ in 0..(w * h / 200).max(1) {
            let (x, y) = ((r() * w as f64) as usize, (r() * h as f64) as usize);
            g.set(x, y, f64::NAN);
            if x + 1 < w {
                g.set(x + 1, y, f64::NAN);
            }
        }
    }
    g
}

fn same_bits(a: &Grid<f64>, b: &Grid<f64>) -> Option<(usize, f64, f64)> {
    a.data()
        .iter()
        .zip(b.data())
        .enumerate()
        .find(|(_, (x, y))| x.to_bits() != y.to_bits() && !(x.is_nan() && y.is_nan()))
        .map(|(i, (x, y))| (i, *x, *y))
}

/// Run both solvers and compare; returns the untiled result.
fn check(
    g: &Grid<f64>,
    p: &StreamPowerParams,
    up: Option<&Grid<f64>>,
    steps: usize,
    tiles: &[usize],
) -> Grid<f64> {
    let mut a = g.clone();
    let u = match up {
        Some(m) => Uplift::Map(m),
        None => Uplift::Uniform(0.0),
    };
    stream_power(&mut a, 50.0, p, &u, steps).unwrap();
    for &t in tiles {
        // One worker thread and two: the rounds are Jacobi, so the same bits.
        for threads in [1, 2] {
            let (b, _) =
                stream_power_tiled_grid(g, 50.0, p, up, steps, &SpTiling::memory(t, threads))
                    .unwrap();
            if let Some((i, x, y)) = same_bits(&a, &b) {
                panic!(
                    "tile {t}, {threads} threads, {:?}: cell ({}, {}) untiled {x} tiled {y}",
                    p.depressions,
                    i % g.width(),
                    i / g.width()
                );
            }
        }
    }
    a
}

fn params(dep: Depressions, n: f64, kd: f64) -> StreamPowerParams {
    StreamPowerParams {
        k: 2e-4,
        m: 0.45,
        n,
        dt: 500.0,
        kd,
        depressions: dep,
        ..Default::default()
    }
}

fn uplift_map(w: usize, h: usize) -> Grid<f64> {
    Grid::from_fn(w, h, |x, y| {
        1e-3 * (1.0 + ((x * 3 + y * 5) % 7) as f64 / 7.0)
    })
}

#[test]
fn fill_equals_untiled_for_many_tile_sizes() {
    let g = terrain(61, 47, 1, false);
    let up = uplift_map(61, 47);
    let out = check(
        &g,
        &params(Depressions::Fill, 1.0, 0.0),
        Some(&up),
        6,
        &[1, 2, 3, 7, 13, 16, 64, 100],
    );
    // The run did erode (not a no-op comparison).
    let changed = out
        .data()
        .iter()
        .zip(g.data())
        .filter(|(a, b)| (**a - (**b + 6.0 * 500.0 * 1e-3)).abs() > 1e-6)
        .count();
    assert!(changed > 1000, "{changed} cells eroded");
}

/// Distance to the border (1 m per cell) plus under 0.5 m of noise: no
/// pit, as in the fastscapelib comparison's start.
fn ramp(w: usize, h: usize, seed: u64) -> Grid<f64> {
    let mut r = rng(seed);
    Grid::from_fn(w, h, |x, y| {
        let d = x.min(y).min(w - 1 - x).min(h - 1 - y) as f64;
        d + 0.49 * r()
    })
}

#[test]
fn pit_free_steps_skip_the_levels_and_equal_untiled() {
    let (w, h) = (57, 49);
    let g = ramp(w, h, 6);
    let p = params(Depressions::Fill, 1.0, 0.0);
    check(&g, &p, Some(&uplift_map(w, h)), 5, &[1, 7, 16, 64]);
    // The same ramp with one pit dug in the middle of a tile: the step
    // routes on the levels, which takes more tile passes than the
    // pit-free step (steepest descent only).
    let mut dug = g.clone();
    dug.set(10, 10, 0.5);
    let tiling = SpTiling::memory(8, 1);
    let (_, plain) = stream_power_tiled_grid(&g, 50.0, &p, None, 1, &tiling).unwrap();
    let (_, pit) = stream_power_tiled_grid(&dug, 50.0, &p, None, 1, &tiling).unwrap();
    let tiles = (w.div_ceil(8) * h.div_ceil(8)) as u64;
    assert!(
        plain.passes + 3 * tiles <= pit.passes,
        "{} vs {} passes",
        plain.passes,
        pit.passes
    );
    check(&dug, &p, None, 3, &[7, 16]);
}

#[test]
fn none_equals_untiled() {
    let g = terrain(53, 40, 2, true);
    check(
        &g,
        &params(Depressions::None, 1.0, 0.0),
        Some(&uplift_map(53, 40)),
        5,
        &[1, 7, 13, 64, 100],
    );
}

#[test]
fn nodata_holes_nonlinear_n_and_diffusion() {
    let g = terrain(50, 45, 3, true);
    let up = uplift_map(50, 45);
    for (n, kd) in [(2.0, 0.0), (1.5, 0.0), (1.0, 0.5), (2.0, 0.3)] {
        check(
            &g,
            &params(Depressions::Fill, n, kd),
            Some(&up),
            4,
            &[7, 13, 64],
        );
    }
    check(
        &g,
        &params(Depressions::None, 1.0, 0.5),
        Some(&up),
        3,
        &[7, 13],
    );
}

#[test]
fn borders_base_height_and_uniform_uplift() {
    let g = terrain(40, 33, 4, false);
    for (side, bh) in [
        ("north,west", BaseHeight::Zero),
        ("south", BaseHeight::Initial),
    ] {
        let p = StreamPowerParams {
            boundary: Boundary::parse(side).unwrap(),
            base_height: bh,
            ..params(Depressions::Fill, 1.0, 0.0)
        };
        let mut a = g.clone();
        stream_power(&mut a, 50.0, &p, &Uplift::Uniform(2e-3), 5).unwrap();
        for t in [7, 13, 64] {
            let src = orogen::raster::MemRaster::new(
                orogen::raster::AnyGrid::F64(g.clone()),
                Default::default(),
                std::path::PathBuf::from("<mem>"),
            );
            let mut b = Grid::new(40, 33, f64::NAN);
            orogen::erosion::stream_power_tiled::stream_power_tiled(
                &src,
                50.0,
                &p,
                &orogen::erosion::stream_power_tiled::TiledUplift::Uniform(2e-3),
                5,
                &SpTiling::memory(t, 2),
                |_, win, tile| {
                    b.paste(tile, win.x, win.y);
                    Ok(())
                },
            )
            .unwrap();
            assert_eq!(same_bits(&a, &b), None, "{side} tile {t}");
        }
    }
}

#[test]
fn scratch_files_give_the_same_bits() {
    let g = terrain(45, 38, 5, true);
    let up = uplift_map(45, 38);
    let p = params(Depressions::Fill, 1.0, 0.2);
    let (mem, _) =
        stream_power_tiled_grid(&g, 50.0, &p, Some(&up), 4, &SpTiling::memory(9, 1)).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let (disk, _) = stream_power_tiled_grid(
        &g,
        50.0,
        &p,
        Some(&up),
        4,
        &SpTiling {
            tile: 9,
            backend: SpBackend::Disk(dir.path().join("scratch")),
            threads: 2,
        },
    )
    .unwrap();
    assert_eq!(same_bits(&mem, &disk), None);
    let mut a = g.clone();
    stream_power(&mut a, 50.0, &p, &Uplift::Map(&up), 4).unwrap();
    assert_eq!(same_bits(&a, &disk), None);
}

#[test]
fn real_dems_equal_untiled() {
    for (path, win) in [
        ("tests/data/bigtujunga_crop.tif", Window::new(0, 0, 90, 80)),
        ("tests/data/whitebox_DEM.tif", Window::new(20, 30, 110, 70)),
    ] {
        let src = orogen::io::open_raster(std::path::Path::new(path), &Default::default()).unwrap();
        let info = src.info().clone();
        let win = Window::new(
            win.x,
            win.y,
            win.w.min(info.width - win.x as usize),
            win.h.min(info.height - win.y as usize),
        );
        let g = read_window::<f64>(src.as_ref(), win).unwrap();
        let up = Grid::new(g.width(), g.height(), 5e-4);
        let p = StreamPowerParams {
            k: 5e-5,
            m: 0.5,
            n: 1.0,
            dt: 1000.0,
            ..Default::default()
        };
        let out = check(&g, &p, Some(&up), 5, &[7, 13, 64, 100]);
        let diff: f64 = out
            .data()
            .iter()
            .zip(g.data())
            .filter(|(a, b)| a.is_finite() && b.is_finite())
            .map(|(a, b)| (a - b).abs())
            .sum();
        assert!(diff > 1.0, "{path}: nothing changed");
        check(
            &g,
            &params(Depressions::None, 1.0, 0.0),
            Some(&up),
            3,
            &[13, 64],
        );
    }
}

#[test]
fn basin_graph_is_refused_with_a_clear_error() {
    let g = terrain(20, 20, 6, false);
    let p = params(Depressions::BasinGraph, 1.0, 0.0);
    let e = stream_power_tiled_grid(&g, 50.0, &p, None, 1, &SpTiling::memory(7, 1))
        .unwrap_err()
        .to_string();
    assert!(e.contains("basin-graph") && e.contains("fill"), "{e}");
}

#[test]
fn bad_input_is_refused() {
    let g = terrain(20, 20, 6, false);
    let p = params(Depressions::Fill, 1.0, 0.0);
    assert!(stream_power_tiled_grid(&g, 50.0, &p, None, 0, &SpTiling::memory(7, 1)).is_err());
    assert!(stream_power_tiled_grid(&g, 0.0, &p, None, 1, &SpTiling::memory(7, 1)).is_err());
    let bad = StreamPowerParams {
        k: -1.0,
        ..p.clone()
    };
    assert!(stream_power_tiled_grid(&g, 50.0, &bad, None, 1, &SpTiling::memory(7, 1)).is_err());
    let up = Grid::new(19, 20, 1e-3);
    assert!(stream_power_tiled_grid(&g, 50.0, &p, Some(&up), 1, &SpTiling::memory(7, 1)).is_err());
    let mut up = Grid::new(20, 20, 1e-3);
    up.set(5, 5, f64::NAN);
    let e = stream_power_tiled_grid(&g, 50.0, &p, Some(&up), 1, &SpTiling::memory(7, 1))
        .unwrap_err()
        .to_string();
    assert!(e.contains("column 5, row 5"), "{e}");
    let nob = StreamPowerParams {
        boundary: Boundary::parse("none").unwrap(),
        ..p
    };
    assert!(stream_power_tiled_grid(&g, 50.0, &nob, None, 1, &SpTiling::memory(7, 1)).is_err());
}

/// The in-memory fill routing against brute-force definitions: levels by
/// Bellman-style iteration of `L = max(h, min_j L_j)` to the fixed point,
/// flat distances by repeated relaxation, receivers by exhaustive choice.
#[test]
fn sp_fill_definition() {
    let (w, h) = (31, 27);
    let g = terrain(w, h, 7, true);
    let p = StreamPowerParams {
        k: 0.0,
        ..params(Depressions::Fill, 1.0, 0.0)
    };
    let mut z = g.clone();
    let mut sp = StreamPower::new(&mut z, 10.0, &p).unwrap();
    sp.step(&mut z, &Uplift::Uniform(0.0)).unwrap();
    let hv = g.data();
    let nb = |i: usize| {
        let (x, y) = ((i % w) as i64, (i / w) as i64);
        crate::common::EAST8
            .iter()
            .enumerate()
            .filter_map(move |(d, (dx, dy))| {
                let (nx, ny) = (x + dx, y + dy);
                (nx >= 0 && ny >= 0 && nx < w as i64 && ny < h as i64)
                    .then(|| (d, ny as usize * w + nx as usize))
            })
            .collect::<Vec<_>>()
    };
    let valid = |i: usize| hv[i].is_finite();
    let mut lev: Vec<f64> = (0..w * h)
        .map(|i| if sp.is_base(i) { hv[i] } else { f64::INFINITY })
        .collect();
    loop {
        let mut ch = false;
        for i in 0..w * h {
            if !valid(i) || sp.is_base(i) {
                continue;
            }
            let m = nb(i)
                .into_iter()
                .filter(|&(_, j)| valid(j))
                .map(|(_, j)| lev[j])
                .fold(f64::INFINITY, f64::min);
            let v = hv[i].max(m);
            if v != lev[i] {
                lev[i] = v;
                ch = true;
            }
        }
        if !ch {
            break;
        }
    }
    let drains =
        |i: usize| sp.is_base(i) || nb(i).iter().any(|&(_, j)| valid(j) && lev[j] < lev[i]);
    let mut dd: Vec<u64> = (0..w * h)
        .map(|i| if valid(i) && drains(i) { 0 } else { u64::MAX })
        .collect();
    loop {
        let mut ch = false;
        for i in 0..w * h {
            if !valid(i) || dd[i] == 0 {
                continue;
            }
            for (_, j) in nb(i) {
                if valid(j) && lev[j] == lev[i] && dd[j] != u64::MAX && dd[j] + 1 < dd[i] {
                    dd[i] = dd[j] + 1;
                    ch = true;
                }
            }
        }
        if !ch {
            break;
        }
    }
    let mut lakes = 0;
    for i in 0..w * h {
        let r = sp.receivers()[i] as usize;
        if !valid(i) || sp.is_base(i) {
            assert_eq!(r, i);
            continue;
        }
        if lev[i] > hv[i] {
            lakes += 1;
        }
        // Steepest strictly lower neighbour on the levels, first on ties.
        let mut best = (0.0, i);
        for (d, j) in nb(i) {
            if !valid(j) {
                continue;
            }
            let len = if d % 2 == 1 {
                10.0 * std::f64::consts::SQRT_2
            } else {
                10.0
            };
            let s = (lev[i] - lev[j]) / len;
            if s > best.0 {
                best = (s, j);
            }
        }
        let want = if best.1 != i {
            best.1
        } else {
            assert!(dd[i] != u64::MAX && dd[i] > 0, "cell {i} stranded");
            nb(i)
                .into_iter()
                .filter(|&(_, j)| valid(j) && lev[j] == lev[i])
                .min_by_key(|&(d, j)| (dd[j], d))
                .map(|(_, j)| j)
                .unwrap()
        };
        assert_eq!(r, want, "cell ({}, {})", i % w, i / w);
    }
    assert!(lakes > 10, "{lakes} lake cells: the case has no depression");
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]
    #[test]
    fn random_grids_and_tiles(
        w in 2usize..30,
        h in 2usize..30,
        seed in 0u64..1000,
        tile in 1usize..20,
        steps in 1usize..4,
        fill in any::<bool>(),
        holes in any::<bool>(),
        n2 in any::<bool>(),
        threads in 1usize..4,
    ) {
        let g = terrain(w, h, seed, holes);
        let dep = if fill { Depressions::Fill } else { Depressions::None };
        let p = params(dep, if n2 { 2.0 } else { 1.0 }, 0.0);
        let up = uplift_map(w, h);
        let mut a = g.clone();
        let r1 = stream_power(&mut a, 50.0, &p, &Uplift::Map(&up), steps);
        let r2 = stream_power_tiled_grid(&g, 50.0, &p, Some(&up), steps, &SpTiling::memory(tile, threads));
        match (r1, r2) {
            (Ok(()), Ok((b, _))) => prop_assert_eq!(same_bits(&a, &b), None),
            (Err(_), Err(_)) => {}
            (x, y) => prop_assert!(false, "{:?} vs {:?}", x.err(), y.err().map(|e| e.to_string())),
        }
    }
}
