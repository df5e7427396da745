//! Breaching (flood-order, hybrid, least-cost) and Rho8, against oracles
//! that share no code with `orogen::hydro`: a brute-force drainage check
//! (breadth-first search over non-increasing steps from the outlets), a
//! brute-force fill (fixed-point relaxation of the minimax definition), a
//! brute-force least-cost search over all simple paths, and the closed-form
//! Rho8 probability on a plane. Tiled == untiled with a sequential driver.

use orogen::exec::{GlobalStep, LocalStep};
use orogen::hydro::tiled::TiledFill;
use orogen::hydro::tiled_breach::{TiledLeastCostBreach, TiledRho8};
use orogen::hydro::{breach, breach_masked, rho8_directions, BreachMethod, BreachOptions};
use orogen::raster::{read_view, GeoRef, Grid, MemRaster, RasterSource, TileLayout, TileView};
use proptest::prelude::*;

use crate::common::hydro::read_raw;
use std::time::Instant;

use crate::NB as N8;

fn ok(v: f32) -> bool {
    v.is_finite()
}

/// Valid neighbours' indices and whether the cell touches nodata/the edge.
fn nbrs(g: &Grid<f32>, x: usize, y: usize) -> (Vec<usize>, bool) {
    let (w, h) = (g.width() as i64, g.height() as i64);
    let mut v = Vec::new();
    let mut edge = false;
    for (dx, dy) in N8 {
        let (nx, ny) = (x as i64 + dx, y as i64 + dy);
        if nx < 0 || ny < 0 || nx >= w || ny >= h {
            edge = true;
            continue;
        }
        let i = (ny * w + nx) as usize;
        if ok(g.data()[i]) {
            v.push(i);
        } else {
            edge = true;
        }
    }
    (v, edge)
}

/// Oracle: cells with a non-increasing 8-path to an outlet cell (BFS
/// backwards from the outlets: u is reached from a reached neighbour v when
/// z[v] <= z[u]). `extra` marks additional outlets (sink mask).
fn drained(g: &Grid<f32>, extra: Option<&Grid<bool>>) -> Vec<bool> {
    let (w, h) = (g.width(), g.height());
    let z = g.data();
    let mut done = vec![false; w * h];
    let mut queue = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            let sink = extra.is_some_and(|m| m.data()[i]);
            if ok(z[i]) && (nbrs(g, x, y).1 || sink) {
                done[i] = true;
                queue.push(i);
            }
        }
    }
    while let Some(v) = queue.pop() {
        for u in nbrs(g, v % w, v / w).0 {
            if !done[u] && z[v] <= z[u] {
                done[u] = true;
                queue.push(u);
            }
        }
    }
    done
}

fn assert_drains(g: &Grid<f32>, what: &str) {
    let d = drained(g, None);
    for (i, &v) in g.data().iter().enumerate() {
        assert!(
            !ok(v) || d[i],
            "{what}: cell ({}, {}) = {v} has no non-increasing path to an outlet",
            i % g.width(),
            i / g.width()
        );
    }
}

/// Oracle fill: F = z on outlets, +inf elsewhere, relaxed to the fixed point
/// F(u) = max(z(u), min over neighbours F(v)).
fn brute_fill(g: &Grid<f32>) -> Vec<f32> {
    let (w, h) = (g.width(), g.height());
    let z = g.data();
    let mut f: Vec<f32> = (0..w * h)
        .map(|i| {
            if !ok(z[i]) {
                f32::NAN
            } else if nbrs(g, i % w, i / w).1 {
                z[i]
            } else {
                f32::INFINITY
            }
        })
        .collect();
    loop {
        let mut changed = false;
        for i in 0..w * h {
            if !ok(z[i]) || nbrs(g, i % w, i / w).1 {
                continue;
            }
            let m = nbrs(g, i % w, i / w)
                .0
                .iter()
                .map(|&j| f[j])
                .fold(f32::INFINITY, f32::min);
            let v = if m > z[i] { m } else { z[i] };
            if v < f[i] {
                f[i] = v;
                changed = true;
            }
        }
        if !changed {
            return f;
        }
    }
}

fn same_bits(a: &Grid<f32>, b: &Grid<f32>) -> bool {
    a.data()
        .iter()
        .zip(b.data())
        .all(|(x, y)| (x.is_nan() && y.is_nan()) || x.to_bits() == y.to_bits())
}

fn opts(method: BreachMethod, epsilon: bool, fill_remaining: bool) -> BreachOptions {
    BreachOptions {
        method,
        epsilon,
        fill_remaining,
    }
}

/// Random DEMs up to 10 x 10.
fn dem() -> impl Strategy<Value = Grid<f32>> {
    crate::common::hydro::dem(11)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, .. ProptestConfig::default() })]

    #[test]
    fn every_method_drains_and_moves_the_right_way(g in dem(), eps in any::<bool>()) {
        let big = g.width().max(g.height());
        let fillv = brute_fill(&g);
        // breach: drains, never raises, nodata untouched
        let b = breach(&g, &opts(BreachMethod::Breach, eps, false)).unwrap();
        assert_drains(&b, "breach");
        for (i, (&o, &n)) in g.data().iter().zip(b.data()).enumerate() {
            prop_assert_eq!(ok(o), ok(n), "nodata kept at {}", i);
            if ok(o) { prop_assert!(n <= o, "breach raised cell {} {} -> {}", i, o, n); }
        }
        // hybrid without limits == breach; with max_depth 0 == fill (never lowers)
        let hy = breach(&g, &opts(BreachMethod::Hybrid { max_depth: f32::INFINITY, max_length: usize::MAX }, eps, false)).unwrap();
        prop_assert!(same_bits(&hy, &b));
        let hf = breach(&g, &opts(BreachMethod::Hybrid { max_depth: 0.0, max_length: 100 }, eps, false)).unwrap();
        assert_drains(&hf, "hybrid depth 0");
        for (i, (&o, &n)) in g.data().iter().zip(hf.data()).enumerate() {
            if ok(o) {
                prop_assert!(n >= o, "fill-only hybrid lowered cell {}", i);
                if !eps { prop_assert_eq!(n, fillv[i], "fill-only hybrid == fill at {}", i); }
            }
        }
        // mixed hybrid: drains, between breach-like lowering and the fill
        for (md, ml) in [(1.0f32, 2usize), (3.0, 1), (0.5, 10)] {
            let m = breach(&g, &opts(BreachMethod::Hybrid { max_depth: md, max_length: ml }, eps, false)).unwrap();
            assert_drains(&m, "hybrid");
            for (i, &n) in m.data().iter().enumerate() {
                if ok(n) && !eps { prop_assert!(n <= fillv[i], "hybrid above fill at {}", i); }
                if ok(n) {
                    // a lowered cell is lowered by at most max_depth (a carve's bound)
                    prop_assert!(n as f64 >= g.data()[i] as f64 - md as f64 - 1e-3,
                        "hybrid cut deeper than {} at {}", md, i);
                }
            }
        }
        // least cost with a window covering the grid resolves every pit
        let lc = breach(&g, &opts(BreachMethod::LeastCost { dist: big }, eps, false)).unwrap();
        assert_drains(&lc, "least-cost");
        for (&o, &n) in g.data().iter().zip(lc.data()) {
            if ok(o) { prop_assert!(n <= o); }
        }
        // least cost with a small window plus the final fill
        let lf = breach(&g, &opts(BreachMethod::LeastCost { dist: 1 }, eps, true)).unwrap();
        assert_drains(&lf, "least-cost + fill");
        if !eps {
            for (i, &n) in lf.data().iter().enumerate() {
                if ok(n) { prop_assert!(n <= fillv[i], "carve + fill above fill at {}", i); }
            }
        }
    }

    #[test]
    fn least_cost_tiled_equals_untiled(g in dem(), dist in 1usize..4, eps in any::<bool>()) {
        let want = breach(&g, &opts(BreachMethod::LeastCost { dist }, eps, false)).unwrap();
        for tile in [1, 2, 3, 7] {
            let got = tiled_least_cost(&g, dist, eps, tile);
            prop_assert!(same_bits(&got, &want), "tile {}", tile);
        }
    }
}

#[test]
fn one_cell_pit_behind_one_cell_dam() {
    #[rustfmt::skip]
    let g = Grid::from_vec(5, 3, vec![
        9.0, 9.0, 9.0, 9.0, 9.0,
        9.0, 3.0, 7.0, 1.0, 9.0,
        9.0, 9.0, 9.0, 0.5, 9.0]).unwrap();
    for m in [
        BreachMethod::Breach,
        BreachMethod::LeastCost { dist: 2 },
        BreachMethod::Hybrid {
            max_depth: 4.5,
            max_length: 1,
        },
    ] {
        let b = breach(&g, &opts(m, false, false)).unwrap();
        let mut want = g.clone();
        want.set(2, 1, 3.0);
        assert_eq!(
            b, want,
            "{m:?}: only the dam is lowered, to the pit's level"
        );
        // with epsilon the dam goes just below the pit
        let e = breach(&g, &opts(m, true, false)).unwrap();
        assert!(e.get(2, 1) < 3.0 && e.get(2, 1) > 2.999);
        assert_eq!(e.get(1, 1), 3.0);
    }
}

#[test]
fn deep_wide_pit_is_filled_by_a_shallow_hybrid() {
    // a 5x5 basin (8..10) inside a rim at 50 with a notch at 30: breaching
    // cuts the notch by 22; hybrid with max_depth 2 fills to 30 instead.
    let (w, h) = (9, 9);
    let g = Grid::from_fn(w, h, |x, y| {
        if x == 0 || y == 0 || x == 8 || y == 8 {
            0.0
        } else if x == 1 || y == 1 || x == 7 || y == 7 {
            if (x, y) == (4, 1) {
                30.0
            } else {
                50.0
            }
        } else {
            10.0 - (x as f32 - 4.0).abs()
        }
    });
    let hy = breach(
        &g,
        &opts(
            BreachMethod::Hybrid {
                max_depth: 2.0,
                max_length: 10,
            },
            false,
            false,
        ),
    )
    .unwrap();
    for y in 2..7 {
        for x in 2..7 {
            assert_eq!(hy.get(x, y), 30.0, "({x},{y}) filled to the notch");
        }
    }
    assert_eq!(hy.get(4, 1), 30.0, "notch untouched");
    let br = breach(&g, &opts(BreachMethod::Breach, false, false)).unwrap();
    // the bowl's lowest cells are 8 (x = 2 and 6): the notch is cut to 8
    assert_eq!(br.get(4, 1), 8.0, "full breach cuts the notch");
    assert_drains(&hy, "hybrid");
}

#[test]
fn sink_mask_keeps_a_real_sink() {
    #[rustfmt::skip]
    let g = Grid::from_vec(5, 5, vec![
        9.0, 9.0, 9.0, 9.0, 9.0,
        9.0, 8.0, 8.0, 8.0, 9.0,
        9.0, 8.0, 1.0, 8.0, 9.0,
        9.0, 8.0, 8.0, 8.0, 9.0,
        9.0, 9.0, 9.0, 9.0, 9.0]).unwrap();
    let mut mask = Grid::new(5, 5, false);
    mask.set(2, 2, true);
    for m in [BreachMethod::Breach, BreachMethod::LeastCost { dist: 3 }] {
        let b = breach_masked(&g, &opts(m, false, true), Some(&mask)).unwrap();
        assert_eq!(b, g, "{m:?}: the masked sink is an outlet, nothing to do");
        let d = drained(&b, Some(&mask));
        assert!(d.iter().all(|&x| x));
        let plain = breach(&g, &opts(m, false, false)).unwrap();
        assert_ne!(plain, g);
    }
}

// ------------------------------------------------- least cost, brute force

struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
}

/// Pits by the documented definition, computed from the oracles.
fn pits(g: &Grid<f32>) -> Vec<usize> {
    let f = brute_fill(g);
    let w = g.width();
    let z = g.data();
    (0..z.len())
        .filter(|&i| {
            if !ok(z[i]) || f[i].partial_cmp(&z[i]) != Some(std::cmp::Ordering::Greater) {
                return false;
            }
            let (n, _) = nbrs(g, i % w, i / w);
            !n.iter().any(|&j| z[j] < z[i]) && n.iter().any(|&j| z[j] > z[i])
        })
        .collect()
}

/// Minimum over all simple paths inside the window of the carve cost.
fn brute_least_cost(g: &Grid<f32>, p: usize, dist: usize) -> Option<f64> {
    let w = g.width();
    let z = g.data();
    let f = brute_fill(g);
    let zp = z[p];
    let (px, py) = ((p % w) as i64, (p / w) as i64);
    let is_end =
        |q: usize| q != p && (z[q] < zp || (z[q] == zp && f[q] == z[q]) || nbrs(g, q % w, q / w).1);
    let mut best: Option<f64> = None;
    let mut on = vec![false; z.len()];
    #[allow(clippy::too_many_arguments)]
    fn dfs(
        c: usize,
        acc: f64,
        g: &Grid<f32>,
        ctx: &dyn Fn(usize) -> bool,
        win: (i64, i64, i64),
        zp: f32,
        on: &mut Vec<bool>,
        best: &mut Option<f64>,
    ) {
        if best.is_some_and(|b| acc >= b) {
            return;
        }
        let w = g.width();
        for n in nbrs(g, c % w, c / w).0 {
            let (nx, ny) = ((n % w) as i64, (n / w) as i64);
            if on[n] || (nx - win.0).abs() > win.2 || (ny - win.1).abs() > win.2 {
                continue;
            }
            let zn = g.data()[n];
            let a = acc + if zn > zp { zn as f64 - zp as f64 } else { 0.0 };
            if ctx(n) {
                if best.is_none_or(|b| a < b) {
                    *best = Some(a);
                }
                continue;
            }
            on[n] = true;
            dfs(n, a, g, ctx, win, zp, on, best);
            on[n] = false;
        }
    }
    on[p] = true;
    dfs(
        p,
        0.0,
        g,
        &is_end,
        (px, py, dist as i64),
        zp,
        &mut on,
        &mut best,
    );
    best
}

#[test]
fn least_cost_matches_brute_force_on_tiny_grids() {
    let mut rng = Rng(0x1234_5678_9abc_def1);
    let mut checked = 0;
    for _ in 0..4000 {
        let w = 4 + (rng.next() % 2) as usize;
        let h = 4 + (rng.next() % 2) as usize;
        let g = Grid::from_fn(w, h, |_, _| (rng.next() % 7) as f32);
        let ps = pits(&g);
        if ps.len() != 1 {
            continue;
        }
        for dist in 1..=2 {
            let want = brute_least_cost(&g, ps[0], dist);
            let b = breach(&g, &opts(BreachMethod::LeastCost { dist }, false, false)).unwrap();
            let lowered: f64 = g
                .data()
                .iter()
                .zip(b.data())
                .map(|(&o, &n)| o as f64 - n as f64)
                .sum();
            match want {
                Some(c) => assert!(
                    (lowered - c).abs() < 1e-9,
                    "dist {dist}: carved {lowered}, brute-force minimum {c}\n{g:?}"
                ),
                None => assert_eq!(lowered, 0.0, "unresolvable pit left alone"),
            }
            checked += 1;
        }
    }
    assert!(checked > 200, "only {checked} single-pit grids");
}

// ------------------------------------------------------------ tiled drivers

fn mem(g: &Grid<f32>) -> MemRaster {
    MemRaster::from_grid(g.clone(), GeoRef::pixel())
}

fn run_global<S: GlobalStep<In = f32>>(
    step: &S,
    src: &dyn RasterSource,
    tile: usize,
    nan: S::Out,
) -> Grid<S::Out>
where
    S::Out: Copy,
{
    let info = src.info();
    let layout = TileLayout::new(info.width, info.height, tile);
    let view = |id| read_view::<f32>(src, &layout, id, step.halo()).unwrap();
    let sums: Vec<_> = (0..layout.count())
        .map(|id| {
            let s = step.map(&[view(id)]).unwrap();
            serde_json::from_str(&serde_json::to_string(&s).unwrap()).unwrap()
        })
        .collect();
    let sol = step.reduce(&layout, sums).unwrap();
    let mut out = Grid::new(info.width, info.height, nan);
    for id in 0..layout.count() {
        let slice = step.slice(&sol, id);
        let core = layout.window(id);
        let mut o = vec![Grid::new(core.w, core.h, nan)];
        step.apply(&[view(id)], &slice, &mut o).unwrap();
        out.paste(&o[0], core.x, core.y);
    }
    out
}

fn tiled_least_cost(g: &Grid<f32>, dist: usize, eps: bool, tile: usize) -> Grid<f32> {
    let src = mem(g);
    let filled = run_global(&TiledFill, &src, tile, f32::NAN);
    let fsrc = mem(&filled);
    let step = TiledLeastCostBreach { dist, epsilon: eps };
    let layout = TileLayout::new(g.width(), g.height(), tile);
    let mut out = Grid::new(g.width(), g.height(), f32::NAN);
    for id in 0..layout.count() {
        let views: Vec<TileView<f32>> = [&src, &fsrc]
            .iter()
            .map(|s| read_view::<f32>(*s, &layout, id, step.halo()).unwrap())
            .collect();
        let core = layout.window(id);
        let mut o = vec![Grid::new(core.w, core.h, f32::NAN)];
        step.run(&views, &mut o).unwrap();
        out.paste(&o[0], core.x, core.y);
    }
    out
}

#[test]
fn real_dem_all_methods_drain_and_least_cost_tiles_exactly() {
    let g = read_raw("bigtujunga_crop.f32", 301, 203, 32767.0);
    let npits = pits(&g).len();
    assert!(npits > 0, "the crop has pits");
    for (m, fill_rem) in [
        (BreachMethod::Breach, false),
        (
            BreachMethod::Hybrid {
                max_depth: 5.0,
                max_length: 20,
            },
            false,
        ),
        (BreachMethod::LeastCost { dist: 20 }, true),
    ] {
        for eps in [false, true] {
            let t0 = Instant::now();
            let b = breach(&g, &opts(m, eps, fill_rem)).unwrap();
            eprintln!("{m:?} eps={eps}: {:?}", t0.elapsed());
            assert_drains(&b, &format!("{m:?} eps={eps}"));
        }
    }
    for dist in [3, 10] {
        let want = breach(&g, &opts(BreachMethod::LeastCost { dist }, false, false)).unwrap();
        for tile in [7, 37, 100] {
            let got = tiled_least_cost(&g, dist, false, tile);
            assert!(same_bits(&got, &want), "dist {dist} tile {tile}");
        }
    }
}

// ----------------------------------------------------------------- Rho8

fn bits8(g: &Grid<u8>) -> &[u8] {
    g.data()
}

#[test]
fn rho8_is_seeded_and_tiling_independent() {
    let g = read_raw("bigtujunga_crop.f32", 301, 203, 32767.0);
    let f = breach(&g, &opts(BreachMethod::Breach, false, false)).unwrap();
    let a = rho8_directions(&f, 11);
    let b = rho8_directions(&f, 11);
    let c = rho8_directions(&f, 12);
    assert_eq!(bits8(&a), bits8(&b));
    assert_ne!(bits8(&a), bits8(&c));
    let src = mem(&f);
    for tile in [7, 37, 100] {
        let t = run_global(&TiledRho8 { seed: 11 }, &src, tile, 255u8);
        assert_eq!(bits8(&t), bits8(&a), "tile {tile}");
    }
}

#[test]
fn rho8_diagonal_frequency_matches_the_closed_form() {
    // plane z = -(x + t·y): E drop 1, SE drop 1 + t, S drop t. SE wins when
    // (1+t)/(2-r) > 1, i.e. r > 1 - t: probability t.
    for t in [0.25f32, 0.6] {
        let (w, h) = (160, 160);
        let g = Grid::from_fn(w, h, |x, y| 1000.0 - (x as f32 + t * y as f32));
        let d = rho8_directions(&g, 5);
        let (mut se, mut n) = (0usize, 0usize);
        for y in 1..h - 1 {
            for x in 1..w - 1 {
                let c = d.get(x, y);
                assert!(c == 1 || c == 2, "only E or SE on this plane, got {c}");
                se += (c == 2) as usize;
                n += 1;
            }
        }
        let p = se as f64 / n as f64;
        assert!(
            (p - t as f64).abs() < 0.015,
            "t = {t}: SE frequency {p}, expected {t}"
        );
    }
}

#[test]
fn rho8_on_flats_equals_d8() {
    let mut g = Grid::new(12, 9, 5.0f32);
    g.set(0, 4, 4.0);
    let r = rho8_directions(&g, 3);
    let d = orogen::hydro::d8_directions(&g);
    assert_eq!(r.data(), d.data());
}
