//! The flow graph (`orogen::flow`) against brute force that shares no code
//! with it: receivers decoded or chosen by a direct scan of the 8
//! neighbours, drainage counted by following every cell's receivers to its
//! root, the stack invariant (every cell after its receiver), the fill
//! levels against `hydro::fill` (another algorithm: region-growing
//! Priority-Flood), on f32 and f64 DEMs with flats, pits and nodata.

use crate::common::hydro::dem;
use crate::common::random_terrain;
use orogen::flow::{
    accumulate_d8_codes, route_d8_codes, route_steepest, FlowFloat, FlowGraph, Lakes, BASE, NONE,
    VALID,
};
use orogen::hydro::{accumulate, d8_directions, fill, NODATA_DIR};
use orogen::raster::Grid;
use proptest::prelude::*;

/// Neighbour `k` (0 = east, then clockwise in steps of 45° with y
/// southwards: E, SE, S, SW, W, NW, N, NE) as `(dx, dy)`, from its compass
/// angle.
fn nb(k: usize) -> (i64, i64) {
    let a = k as f64 * std::f64::consts::FRAC_PI_4;
    (a.cos().round() as i64, a.sin().round() as i64)
}

fn at(w: usize, h: usize, x: usize, y: usize, k: usize) -> Option<usize> {
    let (dx, dy) = nb(k);
    let (nx, ny) = (x as i64 + dx, y as i64 + dy);
    (nx >= 0 && ny >= 0 && nx < w as i64 && ny < h as i64).then(|| ny as usize * w + nx as usize)
}

/// Flags of a DEM: every finite cell valid; the four borders and the cells
/// next to nodata are base levels when `base`.
fn flags_of(z: &[f64], w: usize, h: usize, base: bool) -> Vec<u8> {
    let mut f = vec![0u8; w * h];
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            if !z[i].is_finite() {
                continue;
            }
            f[i] = VALID;
            let edge = x == 0 || y == 0 || x + 1 == w || y + 1 == h;
            let hole = (0..8).any(|k| at(w, h, x, y, k).is_some_and(|j| !z[j].is_finite()));
            if base && (edge || hole) {
                f[i] |= BASE;
            }
        }
    }
    f
}

/// Every cell on the stack once, every cell after its receiver, cells
/// outside the graph absent.
fn check_stack<T: FlowFloat>(g: &FlowGraph<T>) {
    let rec = g.receivers();
    let mut pos = vec![usize::MAX; rec.len()];
    for (k, &c) in g.stack().iter().enumerate() {
        assert_eq!(pos[c as usize], usize::MAX, "cell {c} twice on the stack");
        pos[c as usize] = k;
    }
    for (i, &r) in rec.iter().enumerate() {
        if r == NONE {
            assert_eq!(
                pos[i],
                usize::MAX,
                "cell {i} outside the graph is on the stack"
            );
        } else {
            assert_ne!(pos[i], usize::MAX, "cell {i} is not on the stack");
            assert!(
                pos[r as usize] <= pos[i],
                "cell {i} before its receiver {r}"
            );
        }
    }
}

/// For each cell, the number of graph cells whose receiver path passes
/// through it (itself included), by walking every path to its root.
fn brute_counts(rec: &[u32]) -> Vec<u64> {
    let mut cnt = vec![0u64; rec.len()];
    for s in 0..rec.len() {
        if rec[s] == NONE {
            continue;
        }
        let mut c = s;
        for _ in 0..=rec.len() {
            cnt[c] += 1;
            let r = rec[c] as usize;
            if r == c {
                break;
            }
            c = r;
        }
        assert_eq!(rec[c] as usize, c, "the path from {s} has no root");
    }
    cnt
}

fn graph_counts<T: FlowFloat>(g: &FlowGraph<T>) -> Vec<u64> {
    let mut acc: Vec<u64> = g
        .receivers()
        .iter()
        .map(|&r| u64::from(r != NONE))
        .collect();
    g.accumulate(&mut acc).unwrap();
    acc
}

/// Brute-force steepest descent: strictly lower valid neighbour of largest
/// drop over distance, first of the E..NE order on ties.
fn brute_steepest(z: &[f64], f: &[u8], w: usize, h: usize, cell: f64) -> (Vec<u32>, Vec<f64>) {
    let mut rec: Vec<u32> = (0..(w * h) as u32).collect();
    let mut dist = vec![0.0; w * h];
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            if f[i] != VALID {
                continue;
            }
            let mut best = 0.0f64;
            for k in 0..8 {
                let Some(j) = at(w, h, x, y, k) else { continue };
                if f[j] & VALID == 0 {
                    continue;
                }
                let d = if k % 2 == 1 { cell * 2f64.sqrt() } else { cell };
                let s = (z[i] - z[j]) / d;
                if s > best {
                    best = s;
                    rec[i] = j as u32;
                    dist[i] = d;
                }
            }
        }
    }
    (rec, dist)
}

fn widen(g: &Grid<f32>) -> Vec<f64> {
    g.data().iter().map(|&v| v as f64).collect()
}

/// The D8-code graph of `dirs`: receivers decoded by the test's own table.
fn brute_d8_receivers(dirs: &Grid<u8>) -> Vec<u32> {
    let (w, h) = (dirs.width(), dirs.height());
    let d = dirs.data();
    let mut rec = vec![NONE; w * h];
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            if d[i] == NODATA_DIR {
                continue;
            }
            rec[i] = i as u32;
            if let Some(k) = (0..8).find(|&k| d[i] == 1u8 << k) {
                if let Some(j) = at(w, h, x, y, k) {
                    if d[j] != NODATA_DIR {
                        rec[i] = j as u32;
                    }
                }
            }
        }
    }
    rec
}

#[test]
fn d8_codes_graph_matches_brute_force_on_terrain_with_flats_and_holes() {
    let (w, h) = (61, 47);
    let z = Grid::from_vec(w, h, random_terrain(w, h, 7, 0.04, 0.5)).unwrap();
    for dem in [fill(&z).unwrap(), z] {
        let dirs = d8_directions(&dem);
        let mut g = FlowGraph::<f32>::new(w, h).unwrap();
        route_d8_codes(&mut g, dirs.data(), 30.0).unwrap();
        let want = brute_d8_receivers(&dirs);
        assert_eq!(g.receivers(), &want[..]);
        for (i, &r) in want.iter().enumerate() {
            let (dx, dy) = ((r as usize % w) != i % w, (r as usize / w) != i / w);
            let d = match (r == NONE || r as usize == i, dx && dy) {
                (true, _) => 0.0,
                (false, true) => (30.0 * 2f64.sqrt()) as f32,
                (false, false) => 30.0,
            };
            assert_eq!(g.distances()[i], d, "distance of cell {i}");
        }
        assert_eq!(g.build_stack(), 0);
        check_stack(&g);
        let cnt = graph_counts(&g);
        assert_eq!(cnt, brute_counts(&want));
        assert_eq!(cnt, accumulate(&dirs).unwrap().data());
    }
}

#[test]
fn d8_codes_graph_reports_cycles_and_bad_codes() {
    // E then W: a two-cell cycle, left off the stack; the third cell drains
    // into it and is on the stack (nothing drains into it).
    let mut g = FlowGraph::<f64>::new(3, 1).unwrap();
    route_d8_codes(&mut g, &[1, 16, 16], 1.0).unwrap();
    assert_eq!(g.build_stack(), 2);
    assert_eq!(g.stack(), &[2]);
    let err = route_d8_codes(&mut g, &[1, 3, 0], 1.0)
        .unwrap_err()
        .to_string();
    assert!(err.contains("flow direction 3 at cell (1, 0)"), "{err}");
}

fn steepest_case<T: FlowFloat>(zt: &[T], w: usize, h: usize, cell: f64, base: bool) {
    let z: Vec<f64> = zt.iter().map(|v| v.to_f64()).collect();
    let f = flags_of(&z, w, h, base);
    let mut g = FlowGraph::<T>::new(w, h).unwrap();
    let pits = route_steepest(&mut g, zt, &f, cell);
    let (rec, dist) = brute_steepest(&z, &f, w, h, cell);
    assert_eq!(g.receivers(), &rec[..]);
    let want: Vec<T> = dist.iter().map(|&d| T::from_f64(d)).collect();
    assert_eq!(g.distances(), &want[..]);
    let brute_pits = (0..w * h)
        .filter(|&i| f[i] == VALID && rec[i] as usize == i)
        .count();
    assert_eq!(pits, brute_pits);
    assert_eq!(g.build_stack(), 0);
    check_stack(&g);
    assert_eq!(graph_counts(&g), brute_counts(&rec));
}

#[test]
fn steepest_router_matches_brute_force_in_f32_and_f64() {
    let (w, h) = (53, 38);
    let z32 = random_terrain(w, h, 11, 0.03, 2.0);
    let z64: Vec<f64> = z32.iter().map(|&v| v as f64 * 1.5).collect();
    for base in [false, true] {
        steepest_case(&z32, w, h, 1.0, base);
        steepest_case(&z64, w, h, 25.0, base);
    }
}

#[test]
fn steepest_router_picks_hydro_d8_neighbour_wherever_a_cell_has_a_lower_one() {
    let (w, h) = (64, 50);
    let dem = Grid::from_vec(w, h, random_terrain(w, h, 3, 0.02, 1.0)).unwrap();
    let z = widen(&dem);
    let f = flags_of(&z, w, h, false);
    let mut g = FlowGraph::<f32>::new(w, h).unwrap();
    route_steepest(&mut g, dem.data(), &f, 1.0);
    let hydro = brute_d8_receivers(&d8_directions(&dem));
    let mut routed = 0;
    for (i, &r) in g.receivers().iter().enumerate() {
        if r as usize != i {
            assert_eq!(hydro[i], r, "cell {i}");
            routed += 1;
        }
    }
    assert!(routed > w * h / 2, "{routed} routed cells");
}

/// A bowl with a flat floor, a pit and a nodata hole on a tilted plane.
fn bowl(w: usize, h: usize) -> Vec<f64> {
    let (cx, cy) = (w as f64 / 2.0, h as f64 / 2.0);
    (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f64, (i / w) as f64);
            if (x - 3.0).abs() < 1.0 && (y - 3.0).abs() < 1.0 {
                return f64::NAN;
            }
            let r = ((x - cx).powi(2) + (y - cy).powi(2)).sqrt();
            let rim = 6.0 * (-(r - 5.0).powi(2) / 4.0).exp();
            let floor = if r < 3.0 { 0.0 } else { 1.0 };
            (10.0 + rim + floor + 0.01 * x).round()
        })
        .collect()
}

fn resolver_case<T: FlowFloat>(zt: &[T], w: usize, h: usize, carve: Option<bool>) -> Vec<T> {
    let z: Vec<f64> = zt.iter().map(|v| v.to_f64()).collect();
    let f = flags_of(&z, w, h, true);
    let mut g = FlowGraph::<T>::new(w, h).unwrap();
    let mut lakes = Lakes::<T>::new();
    assert!(route_steepest(&mut g, zt, &f, 10.0) > 0, "the DEM has pits");
    match carve {
        None => lakes.fill(&mut g, zt, &f, 10.0),
        Some(c) => lakes.basin_graph(&mut g, zt, &f, 10.0, c),
    }
    assert_eq!(g.build_stack(), 0);
    check_stack(&g);
    let rec = g.receivers();
    let cnt = brute_counts(rec);
    assert_eq!(graph_counts(&g), cnt);
    if carve != Some(false) {
        // Every valid cell reaches a base level: all water leaves the DEM.
        let valid = f.iter().filter(|&&v| v & VALID != 0).count() as u64;
        let out: u64 = (0..w * h)
            .filter(|&i| f[i] & BASE != 0)
            .map(|i| cnt[i])
            .sum();
        assert_eq!(out, valid);
        for (i, &r) in rec.iter().enumerate() {
            if r as usize != i {
                let (dx, dy) = (
                    (r as usize % w).abs_diff(i % w),
                    (r as usize / w).abs_diff(i / w),
                );
                assert!(dx <= 1 && dy <= 1, "receiver of {i} is not a neighbour");
                let d = if dx == 1 && dy == 1 {
                    10.0 * 2f64.sqrt()
                } else {
                    10.0
                };
                assert_eq!(g.distances()[i], T::from_f64(d));
            }
        }
    }
    lakes.levels().expect("a pit was resolved").to_vec()
}

#[test]
fn fill_and_basin_graph_levels_equal_priority_flood_fill() {
    let (w, h) = (31, 27);
    let z64 = bowl(w, h);
    let z32: Vec<f32> = z64.iter().map(|&v| v as f32).collect();
    let filled = fill(&Grid::from_vec(w, h, z32.clone()).unwrap()).unwrap();
    let want: Vec<f64> = filled.data().iter().map(|&v| v as f64).collect();
    let lake = want.iter().zip(&z64).filter(|(l, z)| l > z).count();
    assert!(lake > 20, "the bowl holds a lake of {lake} cells");
    for carve in [None, Some(true), Some(false)] {
        let l32 = resolver_case(&z32, w, h, carve);
        let l64 = resolver_case(&z64, w, h, carve);
        for i in 0..w * h {
            if z64[i].is_finite() {
                assert_eq!(l32[i] as f64, want[i], "{carve:?} f32 level of {i}");
                assert_eq!(l64[i], want[i], "{carve:?} f64 level of {i}");
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn stack_and_area_hold_on_random_dems(g in dem(14), carve in 0u8..3) {
        let (w, h) = (g.width(), g.height());
        let zt = g.data().to_vec();
        let z = widen(&g);
        let f = flags_of(&z, w, h, true);
        let valid = f.iter().filter(|&&v| v & VALID != 0).count() as u64;
        let mut fg = FlowGraph::<f32>::new(w, h).unwrap();
        let mut f64g = FlowGraph::<f64>::new(w, h).unwrap();
        let pits = route_steepest(&mut fg, &zt, &f, 1.0);
        prop_assert_eq!(route_steepest(&mut f64g, &z, &f, 1.0), pits);
        let (mut l32, mut l64) = (Lakes::<f32>::new(), Lakes::<f64>::new());
        if pits > 0 {
            match carve {
                0 => { l32.fill(&mut fg, &zt, &f, 1.0); l64.fill(&mut f64g, &z, &f, 1.0) }
                1 => {
                    l32.basin_graph(&mut fg, &zt, &f, 1.0, true);
                    l64.basin_graph(&mut f64g, &z, &f, 1.0, true)
                }
                _ => {}
            }
        }
        // f32 heights widened to f64 route the same.
        prop_assert_eq!(fg.receivers(), f64g.receivers());
        prop_assert_eq!(fg.build_stack(), 0);
        check_stack(&fg);
        prop_assert_eq!(f64g.build_stack(), 0);
        check_stack(&f64g);
        let cnt = graph_counts(&fg);
        prop_assert_eq!(&cnt, &brute_counts(fg.receivers()));
        let roots: u64 = (0..w * h)
            .filter(|&i| fg.receivers()[i] as usize == i && f[i] & VALID != 0)
            .map(|i| cnt[i])
            .sum();
        prop_assert_eq!(roots, valid);
        if pits > 0 && carve < 2 {
            let (a, b) = (l32.levels().unwrap(), l64.levels().unwrap());
            let want = fill(&g).unwrap();
            for i in 0..w * h {
                if f[i] & VALID != 0 {
                    prop_assert_eq!(a[i], want.data()[i]);
                    prop_assert_eq!(b[i], want.data()[i] as f64);
                }
            }
            // Resolved: every valid cell drains to a base level.
            let base: u64 = (0..w * h).filter(|&i| f[i] & BASE != 0).map(|i| cnt[i]).sum();
            prop_assert_eq!(base, valid);
        }
    }

    #[test]
    fn d8_codes_accumulate_as_brute_force_on_random_dems(g in dem(16)) {
        let dirs = d8_directions(&fill(&g).unwrap());
        let mut fg = FlowGraph::<f32>::new(g.width(), g.height()).unwrap();
        route_d8_codes(&mut fg, dirs.data(), 1.0).unwrap();
        prop_assert_eq!(fg.build_stack(), 0);
        check_stack(&fg);
        let want = brute_counts(&brute_d8_receivers(&dirs));
        prop_assert_eq!(&graph_counts(&fg), &want);
        let acc = accumulate(&dirs).unwrap();
        prop_assert_eq!(acc.data(), &want[..]);
        // the fast form walks the same order: the graph's stack reversed
        let mut fast: Vec<u64> = dirs.data().iter().map(|&c| u64::from(c != NODATA_DIR)).collect();
        let mut order = Vec::new();
        accumulate_d8_codes(dirs.data(), g.width(), g.height(), &mut fast, Some(&mut order)).unwrap();
        prop_assert_eq!(&fast, &want);
        let mut stack = fg.stack().to_vec();
        stack.reverse();
        prop_assert_eq!(order, stack);
    }
}
