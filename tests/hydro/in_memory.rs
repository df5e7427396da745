//! In-memory hydrology against oracles that share no code with `orogen::hydro`:
//! a brute-force minimax fill (Planchon & Darboux-style repeated relaxation),
//! path-walking accumulation, and invariants checked with proptest.

use orogen::hydro::{
    accumulate, accumulate_weighted, d8_directions, fill, fill_epsilon, watershed_labels,
    NODATA_DIR, NO_FLOW,
};
use orogen::raster::Grid;
use proptest::prelude::*;

use crate::NB;

fn ok(z: f32) -> bool {
    z.is_finite()
}

fn inside(w: usize, h: usize, x: i64, y: i64) -> bool {
    x >= 0 && y >= 0 && x < w as i64 && y < h as i64
}

/// Valid cell with a nodata or off-grid neighbour.
fn is_outlet(g: &Grid<f32>, x: usize, y: usize) -> bool {
    ok(g.get(x, y))
        && NB.iter().any(|&(dx, dy)| {
            let (nx, ny) = (x as i64 + dx, y as i64 + dy);
            !inside(g.width(), g.height(), nx, ny) || !ok(g.get(nx as usize, ny as usize))
        })
}

/// Minimax fill by relaxation until nothing changes: F = z on outlets,
/// F(c) = max(z(c), min over valid neighbours F(n)) elsewhere.
fn brute_fill(g: &Grid<f32>) -> Grid<f32> {
    let (w, h) = (g.width(), g.height());
    let mut f = Grid::from_fn(w, h, |x, y| {
        let z = g.get(x, y);
        if !ok(z) {
            f32::NAN
        } else if is_outlet(g, x, y) {
            z
        } else {
            f32::INFINITY
        }
    });
    loop {
        let mut changed = false;
        for y in 0..h {
            for x in 0..w {
                let z = g.get(x, y);
                if !ok(z) || is_outlet(g, x, y) {
                    continue;
                }
                let mut m = f32::INFINITY;
                for &(dx, dy) in &NB {
                    let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                    let v = f.get(nx as usize, ny as usize);
                    if ok(g.get(nx as usize, ny as usize)) && v < m {
                        m = v;
                    }
                }
                let nv = if z > m { z } else { m };
                if nv < f.get(x, y) {
                    f.set(x, y, nv);
                    changed = true;
                }
            }
        }
        if !changed {
            return f;
        }
    }
}

/// Follow D8 codes from (x, y); returns the cells visited (start included)
/// and whether the walk left the DEM (off-grid or into nodata).
fn walk(dirs: &Grid<u8>, x: usize, y: usize) -> (Vec<(usize, usize)>, bool) {
    let (w, h) = (dirs.width(), dirs.height());
    let mut path = vec![(x, y)];
    let (mut cx, mut cy) = (x as i64, y as i64);
    for _ in 0..=w * h {
        let c = dirs.get(cx as usize, cy as usize);
        if c == NO_FLOW {
            return (path, false);
        }
        let k = (0..8).find(|&k| 1u8 << k == c).expect("valid code");
        let (nx, ny) = (cx + NB[k].0, cy + NB[k].1);
        if !inside(w, h, nx, ny) || dirs.get(nx as usize, ny as usize) == NODATA_DIR {
            return (path, true);
        }
        cx = nx;
        cy = ny;
        path.push((cx as usize, cy as usize));
    }
    panic!("flow path from ({x},{y}) loops");
}

fn same_bits(a: &Grid<f32>, b: &Grid<f32>) -> bool {
    a.data()
        .iter()
        .zip(b.data())
        .all(|(p, q)| (p.is_nan() && q.is_nan()) || p.to_bits() == q.to_bits())
}

/// Random small DEMs: few distinct heights (plateaus and ties), negative
/// values, NaN holes and the odd infinity.
fn dem() -> impl Strategy<Value = Grid<f32>> {
    (1usize..11, 1usize..11).prop_flat_map(|(w, h)| {
        let cell = prop_oneof![
            12 => (-4i32..7).prop_map(|v| v as f32),
            3 => -400.0f32..900.0,
            2 => Just(f32::NAN),
            1 => Just(f32::NEG_INFINITY),
        ];
        proptest::collection::vec(cell, w * h)
            .prop_map(move |v| Grid::from_vec(w, h, v).expect("sized"))
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, .. ProptestConfig::default() })]

    #[test]
    fn fill_equals_brute_force_minimax(g in dem()) {
        let f = fill(&g).unwrap();
        let b = brute_fill(&g);
        prop_assert!(same_bits(&f, &b), "fill {:?}\nbrute {:?}", f.data(), b.data());
        // watershed labelling floods the same surface
        let (labels, f2) = watershed_labels(&g).unwrap();
        prop_assert!(same_bits(&f, &f2));
        for (i, &z) in g.data().iter().enumerate() {
            prop_assert_eq!(labels.data()[i] == 0, !ok(z));
        }
    }

    #[test]
    fn epsilon_fill_drains_strictly(g in dem()) {
        let e = fill_epsilon(&g).unwrap();
        let f = brute_fill(&g);
        let (w, h) = (g.width(), g.height());
        for y in 0..h {
            for x in 0..w {
                let z = g.get(x, y);
                if !ok(z) {
                    prop_assert!(e.get(x, y).is_nan());
                    continue;
                }
                prop_assert!(e.get(x, y) >= f.get(x, y));
                if is_outlet(&g, x, y) {
                    prop_assert_eq!(e.get(x, y).to_bits(), z.to_bits());
                    continue;
                }
                let lower = NB.iter().any(|&(dx, dy)| {
                    let (nx, ny) = ((x as i64 + dx) as usize, (y as i64 + dy) as usize);
                    ok(g.get(nx, ny)) && e.get(nx, ny) < e.get(x, y)
                });
                prop_assert!(lower, "({x},{y}) has no strictly lower neighbour");
            }
        }
    }

    #[test]
    fn d8_on_filled_dem_reaches_an_outlet_and_accumulation_conserves_cells(g in dem()) {
        let f = fill(&g).unwrap();
        let dirs = d8_directions(&f);
        let (w, h) = (g.width(), g.height());
        let acc = accumulate(&dirs).unwrap();
        // path-walking oracle for accumulation
        let mut brute = vec![0u64; w * h];
        let mut valid = 0u64;
        let mut at_exits = 0u64;
        for y in 0..h {
            for x in 0..w {
                if !ok(g.get(x, y)) {
                    prop_assert_eq!(dirs.get(x, y), NODATA_DIR);
                    continue;
                }
                valid += 1;
                prop_assert_ne!(dirs.get(x, y), NO_FLOW, "filled DEM cell ({},{}) does not drain", x, y);
                let (path, left) = walk(&dirs, x, y);
                prop_assert!(left);
                for p in path.windows(2) {
                    prop_assert!(f.get(p[1].0, p[1].1) <= f.get(p[0].0, p[0].1), "uphill step");
                }
                for &(px, py) in &path {
                    brute[py * w + px] += 1;
                }
                // steepest descent where a lower neighbour exists
                let zc = f.get(x, y) as f64;
                let best = NB.iter().enumerate().filter_map(|(k, &(dx, dy))| {
                    let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                    if !inside(w, h, nx, ny) { return None; }
                    let zn = f.get(nx as usize, ny as usize);
                    if !ok(zn) { return None; }
                    let dist = if k % 2 == 1 { 2f64.sqrt() } else { 1.0 };
                    Some((zc - zn as f64) / dist)
                }).fold(0.0f64, f64::max);
                if best > 0.0 {
                    let k = (0..8).find(|&k| 1u8 << k == dirs.get(x, y)).unwrap();
                    let (nx, ny) = ((x as i64 + NB[k].0) as usize, (y as i64 + NB[k].1) as usize);
                    let dist = if k % 2 == 1 { 2f64.sqrt() } else { 1.0 };
                    prop_assert_eq!((zc - f.get(nx, ny) as f64) / dist, best);
                }
            }
        }
        for y in 0..h {
            for x in 0..w {
                if ok(g.get(x, y)) && walk(&dirs, x, y).0.len() == 1 {
                    at_exits += acc.get(x, y);
                }
            }
        }
        prop_assert_eq!(acc.data(), &brute[..]);
        prop_assert_eq!(at_exits, valid);
    }

    #[test]
    fn weighted_accumulation_matches_path_walk(g in dem(), seed in 0u32..1000) {
        let dirs = d8_directions(&fill(&g).unwrap());
        let (w, h) = (g.width(), g.height());
        // dyadic weights so that the f64 oracle sum is exact
        let wts = Grid::from_fn(w, h, |x, y| ((x * 7 + y * 13 + seed as usize) % 11) as f32 * 0.25 - 1.0);
        let acc = accumulate_weighted(&dirs, &wts).unwrap();
        let mut brute = vec![0f64; w * h];
        for y in 0..h {
            for x in 0..w {
                if dirs.get(x, y) == NODATA_DIR { continue; }
                for (px, py) in walk(&dirs, x, y).0 {
                    brute[py * w + px] += wts.get(x, y) as f64;
                }
            }
        }
        for ((&code, &got), &want) in dirs.data().iter().zip(acc.data()).zip(&brute) {
            if code == NODATA_DIR {
                prop_assert!(got.is_nan());
            } else {
                prop_assert_eq!(got, want);
            }
        }
    }
}

#[test]
fn all_nodata_grid() {
    let g = Grid::new(6, 4, f32::NAN);
    assert!(fill(&g).unwrap().data().iter().all(|v| v.is_nan()));
    assert!(fill_epsilon(&g).unwrap().data().iter().all(|v| v.is_nan()));
    let d = d8_directions(&g);
    assert!(d.data().iter().all(|&c| c == NODATA_DIR));
    assert!(accumulate(&d).unwrap().data().iter().all(|&a| a == 0));
    let empty = Grid::<f32>::new(0, 0, 0.0);
    assert_eq!(fill(&empty).unwrap().len(), 0);
    assert_eq!(accumulate(&d8_directions(&empty)).unwrap().len(), 0);
}

#[test]
fn constant_dem_is_one_flat_draining_to_the_edges() {
    let (w, h) = (9, 7);
    let g = Grid::new(w, h, 100.0f32);
    assert_eq!(fill(&g).unwrap(), g);
    let dirs = d8_directions(&g);
    let acc = accumulate(&dirs).unwrap();
    let mut at_exits = 0;
    for y in 0..h {
        for x in 0..w {
            let (path, left) = walk(&dirs, x, y);
            assert!(left);
            // flat paths are shortest-ish: towards the nearest edge
            let edge_dist = x.min(y).min(w - 1 - x).min(h - 1 - y);
            assert_eq!(
                path.len(),
                edge_dist + 1,
                "({x},{y}) takes a detour: {path:?}"
            );
            if path.len() == 1 {
                at_exits += acc.get(x, y);
            }
        }
    }
    assert_eq!(at_exits, (w * h) as u64);
    // epsilon fill: edge cells stay, interior cells rise by ULPs towards the centre
    let e = fill_epsilon(&g).unwrap();
    assert_eq!(e.get(0, 0), 100.0);
    assert!(e.get(1, 3) > 100.0);
    assert!(e.get(4, 3) > e.get(1, 3));
}

#[test]
fn only_outlets_are_interior_nodata_holes() {
    // border of nodata (a clipped island) and a hole at (5, 4); a bowl
    // around the hole drains into it, a pit at (2, 2) must be filled.
    let (w, h) = (10, 9);
    let g = Grid::from_fn(w, h, |x, y| {
        if x == 0 || y == 0 || x == w - 1 || y == h - 1 || (x, y) == (5, 4) {
            f32::NAN
        } else if (x, y) == (2, 2) {
            1.0
        } else {
            let dx = x as f32 - 5.0;
            let dy = y as f32 - 4.0;
            10.0 + dx * dx + dy * dy
        }
    });
    let f = fill(&g).unwrap();
    assert!(same_bits(&f, &brute_fill(&g)));
    // the pit rises to its lowest rim neighbour: min over the 8 neighbours of (2,2)
    let rim = [
        (1, 1),
        (2, 1),
        (3, 1),
        (1, 2),
        (3, 2),
        (1, 3),
        (2, 3),
        (3, 3),
    ]
    .iter()
    .map(|&(x, y)| g.get(x, y))
    .fold(f32::INFINITY, f32::min);
    assert_eq!(f.get(2, 2), rim);
    // everything else is unchanged (the bowl drains into the hole)
    for y in 0..h {
        for x in 0..w {
            if (x, y) != (2, 2) && ok(g.get(x, y)) {
                assert_eq!(f.get(x, y), g.get(x, y));
            }
        }
    }
    let dirs = d8_directions(&f);
    let acc = accumulate(&dirs).unwrap();
    let valid = g.data().iter().filter(|v| ok(**v)).count() as u64;
    let around_hole: u64 = (3..=5)
        .flat_map(|y| (4..=6).map(move |x| (x, y)))
        .filter(|&(x, y)| (x, y) != (5, 4))
        .map(|(x, y)| acc.get(x, y))
        .sum();
    // all water ends in the hole or at the nodata border: total conserved
    let mut at_exits = 0;
    for y in 0..h {
        for x in 0..w {
            if ok(g.get(x, y)) && walk(&dirs, x, y).0.len() == 1 {
                at_exits += acc.get(x, y);
            }
        }
    }
    assert_eq!(at_exits, valid);
    assert!(
        around_hole > valid / 2,
        "the bowl drains into the hole: {around_hole} of {valid}"
    );
}

#[test]
fn negative_elevations_fill_like_shifted_ones() {
    // Dead-Sea-like: the same terrain 430 m below sea level fills to the same
    // surface shifted by -430 (integers: exact in f32).
    let base = Grid::from_fn(12, 10, |x, y| ((x * 37 + y * 91) % 17) as f32);
    let low = base.map(|v| v - 430.0);
    let fb = fill(&base).unwrap();
    let fl = fill(&low).unwrap();
    for (a, b) in fb.data().iter().zip(fl.data()) {
        assert_eq!(*a - 430.0, *b);
    }
    assert_eq!(d8_directions(&fb), d8_directions(&fl));
}

#[test]
fn infinities_are_nodata() {
    let mut g = Grid::from_fn(5, 5, |x, y| (x + y) as f32);
    g.set(2, 2, f32::INFINITY);
    let f = fill(&g).unwrap();
    assert!(f.get(2, 2).is_nan());
    assert_eq!(d8_directions(&g).get(2, 2), NODATA_DIR);
}
