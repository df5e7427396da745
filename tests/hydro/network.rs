//! Basins, streams, network statistics, basin metrics and indices against
//! oracles that share no code with the implementation: hand-computed trees,
//! brute-force walks down D8 paths, closed forms, brute-force shortest paths.

use orogen::exec::{run_local_to_memory, EngineConfig, GlobalStep, LocalEngine};
use orogen::hydro::basin_metrics::basin_metrics;
use orogen::hydro::basins::{point_seeds, Seeds, TiledDownstream};
use orogen::hydro::indices::{depth_to_water, max_branch_length, HydroIndex, IndexKind};
use orogen::hydro::streams::{
    extract_network, horton, tokunaga, ChannelRule, Network, NetworkOptions,
};
use orogen::hydro::{basin_labels, d8_directions, fill, hand, watersheds};
use orogen::raster::{
    read_view, read_window, Crs, DType, GeoRef, Grid, MemRaster, RasterSource, TileLayout,
    TileView, Window,
};
use proptest::prelude::*;

const SQ2: f64 = std::f64::consts::SQRT_2;

fn geo10() -> GeoRef {
    GeoRef::north_up(0.0, 0.0, 10.0, Crs::projected(32611))
}

// ---- independent D8 decoding for the oracles ----

/// (dx, dy) of an ESRI code, written out by hand.
fn step(code: u8) -> Option<(i64, i64)> {
    match code {
        1 => Some((1, 0)),
        2 => Some((1, 1)),
        4 => Some((0, 1)),
        8 => Some((-1, 1)),
        16 => Some((-1, 0)),
        32 => Some((-1, -1)),
        64 => Some((0, -1)),
        128 => Some((1, -1)),
        _ => None,
    }
}

/// Next cell downstream, or None when the flow stops or leaves the valid cells.
fn down(d: &Grid<u8>, x: usize, y: usize) -> Option<(usize, usize)> {
    let (dx, dy) = step(d.get(x, y))?;
    let (nx, ny) = (x as i64 + dx, y as i64 + dy);
    if nx < 0 || ny < 0 || nx >= d.width() as i64 || ny >= d.height() as i64 {
        return None;
    }
    let (nx, ny) = (nx as usize, ny as usize);
    (d.get(nx, ny) != 255).then_some((nx, ny))
}

/// The D8 path of a cell, itself first.
fn path(d: &Grid<u8>, x: usize, y: usize) -> Vec<(usize, usize)> {
    let mut p = vec![(x, y)];
    let mut c = (x, y);
    while let Some(n) = down(d, c.0, c.1) {
        p.push(n);
        c = n;
        assert!(p.len() <= d.len(), "cycle");
    }
    p
}

/// Sequential global-step driver (map, reduce, slice, apply), summaries and
/// slices round-tripped through JSON.
fn run_global<S: GlobalStep<In = f64, Out = f64>>(
    step: &S,
    srcs: &[&dyn RasterSource],
    tile: usize,
) -> Grid<f64> {
    let info = srcs[0].info();
    let layout = TileLayout::new(info.width, info.height, tile);
    let views = |id| -> Vec<TileView<f64>> {
        srcs.iter()
            .map(|s| read_view::<f64>(*s, &layout, id, step.halo()).unwrap())
            .collect()
    };
    let mut sums = Vec::new();
    for id in 0..layout.count() {
        let s = step.map(&views(id)).unwrap();
        let j = serde_json::to_string(&s).unwrap();
        sums.push(serde_json::from_str(&j).unwrap());
    }
    let sol = step.reduce(&layout, sums).unwrap();
    let mut out = Grid::new(info.width, info.height, f64::NAN);
    for id in 0..layout.count() {
        let sl = step.slice(&sol, id);
        let sl = serde_json::from_str(&serde_json::to_string(&sl).unwrap()).unwrap();
        let core = layout.window(id);
        let mut o = vec![Grid::new(core.w, core.h, f64::NAN)];
        step.apply(&views(id), &sl, &mut o).unwrap();
        out.paste(&o[0], core.x, core.y);
    }
    out
}

fn mem<T: orogen::raster::IntoAny>(g: &Grid<T>, nodata: Option<f64>) -> MemRaster {
    MemRaster::from_grid(g.clone(), GeoRef::pixel().with_nodata(nodata))
}

/// The network of every cell draining at least one cell, on 10 m cells.
fn cells_network(d: &Grid<u8>, valley_window: usize) -> Network {
    extract_network(
        d,
        None,
        &geo10(),
        &NetworkOptions {
            rule: ChannelRule::Cells(1.0),
            valley_window,
        },
    )
    .unwrap()
}

fn same_f64(a: &Grid<f64>, b: &Grid<f64>) -> bool {
    a.data()
        .iter()
        .zip(b.data())
        .all(|(x, y)| x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan()))
}

// ---- a hand-built tree (see the comments for every expected value) ----

/// 7x7, nodata everywhere but this tree; trunk down column 3 leaving at (3,6).
fn tree() -> Grid<u8> {
    let mut d = Grid::new(7, 7, 255u8);
    for y in 0..7 {
        d.set(3, y, 4); // trunk flows S
    }
    d.set(1, 0, 2); // A: SE, SE into (3,2)
    d.set(2, 1, 2);
    d.set(5, 0, 8); // B: SW, SW into (3,2)
    d.set(4, 1, 8);
    d.set(0, 3, 1); // C: E, E, SE into (3,4)
    d.set(1, 3, 1);
    d.set(2, 3, 2);
    d.set(6, 4, 16); // D: W, W into (4,4) then W into (3,4)
    d.set(5, 4, 16);
    d.set(4, 4, 16);
    d.set(6, 2, 8); // E: SW, SW into (4,4)
    d.set(5, 3, 8);
    d.set(1, 5, 1); // F: E, E into (3,5)
    d.set(2, 5, 1);
    d
}

#[test]
fn hand_built_tree_orders_lengths_areas() {
    let d = tree();
    let net = cells_network(&d, 1);
    // 7 heads, 3 confluences ((3,2), (4,4), (3,4), (3,5) = 4), 1 outlet
    assert_eq!(net.nodes.len(), 7 + 4 + 1);
    assert_eq!(net.links.len(), 11);
    let find = |sx: usize, sy: usize| {
        let w = 7;
        net.links
            .iter()
            .find(|l| l.cells[0] as usize == sy * w + sx)
            .unwrap_or_else(|| panic!("no link from ({sx},{sy})"))
    };
    // (start, strahler, shreve, length m, area cells)
    type Want = ((usize, usize), u32, u64, f64, u64);
    let want: [Want; 11] = [
        ((3, 0), 1, 1, 20.0, 2),
        ((1, 0), 1, 1, 20.0 * SQ2, 2),
        ((5, 0), 1, 1, 20.0 * SQ2, 2),
        ((3, 2), 2, 3, 20.0, 8),
        ((0, 3), 1, 1, 20.0 + 10.0 * SQ2, 3),
        ((6, 4), 1, 1, 20.0, 2),
        ((6, 2), 1, 1, 20.0 * SQ2, 2),
        ((4, 4), 2, 2, 10.0, 5),
        ((3, 4), 3, 6, 10.0, 17),
        ((1, 5), 1, 1, 20.0, 2),
        ((3, 5), 3, 7, 10.0, 21),
    ];
    for ((sx, sy), so, sh, len, area) in want {
        let l = find(sx, sy);
        assert_eq!(l.strahler, so, "strahler of link from ({sx},{sy})");
        assert_eq!(l.shreve, sh, "shreve of link from ({sx},{sy})");
        assert!(
            (l.length_m - len).abs() < 1e-9,
            "length ({sx},{sy}) {}",
            l.length_m
        );
        assert_eq!(l.area_cells, area, "area of link from ({sx},{sy})");
        assert!((l.area_m2 - area as f64 * 100.0).abs() < 1e-6);
    }
    // sinuosity of C: (20 + 10√2) / (10√10)
    let c = find(0, 3);
    assert!((c.sinuosity() - (20.0 + 10.0 * SQ2) / (10.0 * 10f64.sqrt())).abs() < 1e-12);
    // stream raster
    let o = &net.order;
    for (x, y, v) in [
        (3, 0, 1),
        (3, 1, 1),
        (3, 2, 2),
        (3, 3, 2),
        (4, 4, 2),
        (3, 4, 3),
        (3, 5, 3),
        (3, 6, 3),
        (0, 3, 1),
        (0, 0, 255),
    ] {
        assert_eq!(o.get(x, y), v, "order at ({x},{y})");
    }
    // Horton: N = [7, 2, 1]; R_B = 10^(log10(7)/2) = √7
    let ho = horton(&net);
    assert_eq!(ho.count, vec![7, 2, 1]);
    assert!((ho.bifurcation_ratio - 7f64.sqrt()).abs() < 1e-9);
    // 20 + 20√2 + 20√2 + (20 + 10√2) + 20 + 20√2 + 20
    let l1 = (80.0 + 70.0 * SQ2) / 7.0;
    let ml = [l1, 15.0, 20.0];
    for (a, b) in ho.mean_length_m.iter().zip(ml) {
        assert!((a - b).abs() < 1e-9, "{a} vs {b}");
    }
    // R_L = 10^slope of log10 L against order (slope by hand: (log L3 − log L1)/2)
    let rl = 10f64.powf((20f64.log10() - l1.log10()) / 2.0);
    assert!((ho.length_ratio - rl).abs() < 1e-9);
    // areas: order 1 mean (2+2+2+3+2+2+2)/7 cells, order 2 (8+5)/2, order 3 21
    let a1: f64 = 15.0 / 7.0 * 100.0;
    let ra = 10f64.powf(((2100f64).log10() - a1.log10()) / 2.0);
    assert!((ho.area_ratio - ra).abs() < 1e-9);
    // Tokunaga: side tributaries C (1 -> 3) and F (1 -> 3) only
    let tk = tokunaga(&net);
    let t = |i: u32, j: u32| tk.t.iter().find(|p| p.0 == i && p.1 == j).unwrap().2;
    assert_eq!(t(1, 2), 0.0);
    assert_eq!(t(1, 3), 2.0);
    assert_eq!(t(2, 3), 0.0);
    assert_eq!(tk.t_k, vec![0.0, 2.0]);
    assert!(tk.a.is_nan());
    // order-3 stream is straight: CI = 1, indices undefined
    let s3 = net.streams.iter().find(|s| s.order == 3).unwrap();
    assert_eq!(s3.links.len(), 2);
    let (ci, _, _, hsi, _) = s3.mueller();
    assert!((ci - 1.0).abs() < 1e-12 && hsi.is_nan());
}

#[test]
fn tokunaga_fit_on_a_self_similar_tree() {
    // A Peano-like tree: order-2 streams each get one side order-1 tributary.
    // Column 1: trunk S from (1,0) to (1,4) and out. Heads at (0,0) SE->(1,1)
    // (with (1,0) makes order 2 at (1,1)), side tributary (0,2) E->(1,2)? no:
    // (0,3) NE -> (1,2) joins the order-2 stream from the side.
    let mut d = Grid::new(3, 5, 255u8);
    for y in 0..5 {
        d.set(1, y, 4);
    }
    d.set(0, 0, 2);
    d.set(0, 3, 128);
    let net = cells_network(&d, 0);
    let tk = tokunaga(&net);
    // streams: order 1: (1,0), (0,0), (0,3) -> 3; order 2: one. Side: (0,3) -> T_{1,2} = 1
    assert_eq!(tk.t, vec![(1, 2, 1.0)]);
    let ho = horton(&net);
    assert_eq!(ho.count, vec![3, 1]);
    assert!((ho.bifurcation_ratio - 3.0).abs() < 1e-12);
}

// ---- basins, watersheds, HAND: brute force and tiled ----

fn brute_labels(d: &Grid<u8>) -> Vec<f64> {
    let w = d.width();
    let mut out = Vec::new();
    for y in 0..d.height() {
        for x in 0..w {
            if d.get(x, y) == 255 {
                out.push(f64::NAN);
                continue;
            }
            let p = path(d, x, y);
            let (ex, ey) = *p.last().unwrap();
            out.push((ey * w + ex + 1) as f64);
        }
    }
    out
}

fn brute_watersheds(d: &Grid<u8>, pts: &[(usize, usize)]) -> Vec<u32> {
    let mut out = Vec::new();
    for y in 0..d.height() {
        for x in 0..d.width() {
            let mut id = 0;
            if d.get(x, y) != 255 {
                for c in path(d, x, y) {
                    if let Some(i) = pts.iter().position(|&p| p == c) {
                        id = i as u32 + 1;
                        break;
                    }
                }
            }
            out.push(id);
        }
    }
    out
}

fn brute_hand(z: &Grid<f32>, d: &Grid<u8>, s: &Grid<bool>) -> Vec<f32> {
    let mut out = Vec::new();
    for y in 0..d.height() {
        for x in 0..d.width() {
            let mut v = f32::NAN;
            if d.get(x, y) != 255 {
                for (px, py) in path(d, x, y) {
                    if s.get(px, py) && z.get(px, py).is_finite() {
                        v = (z.get(x, y) as f64 - z.get(px, py) as f64) as f32;
                        break;
                    }
                }
            }
            out.push(v);
        }
    }
    out
}

/// DEM from proptest values with some nodata cells; its filled D8 directions.
fn dem_and_dirs(w: usize, h: usize, vals: &[f32]) -> (Grid<f32>, Grid<u8>) {
    let g = Grid::from_fn(w, h, |x, y| {
        let v = vals[(y * w + x) % vals.len()];
        if v < 0.5 {
            f32::NAN
        } else {
            (v * 10.0).floor()
        }
    });
    let f = fill(&g).unwrap();
    let d = d8_directions(&f);
    (f, d)
}

fn check_downstream(w: usize, h: usize, vals: &[f32], tiles: &[usize]) {
    let (z, d) = dem_and_dirs(w, h, vals);
    let labels = basin_labels(&d).unwrap();
    let brute = brute_labels(&d);
    for (i, (&l, &b)) in labels.data().iter().zip(&brute).enumerate() {
        let want = if b.is_nan() { 0 } else { b as u64 };
        assert_eq!(l, want, "label of cell {i}");
    }
    let dsrc = mem(&d, Some(255.0));
    for &t in tiles {
        let got = run_global(
            &TiledDownstream {
                seeds: Seeds::Outlets,
                labels: DType::F64,
            },
            &[&dsrc],
            t,
        );
        for (i, (&g, &b)) in got.data().iter().zip(&brute).enumerate() {
            assert!(
                g == b || (g.is_nan() && b.is_nan()),
                "tile {t}: cell {i}: {g} vs {b}"
            );
        }
    }
    // watersheds of three points
    let pts = [(w / 2, h / 2), (w / 3, h - 1), (0, h / 3)];
    let ws = watersheds(&d, &pts).unwrap();
    assert_eq!(ws.data(), brute_watersheds(&d, &pts).as_slice());
    for &t in tiles {
        let step = TiledDownstream {
            seeds: point_seeds(&pts, w),
            labels: DType::F64,
        };
        let got = run_global(&step, &[&dsrc], t);
        for (i, (&g, &b)) in got.data().iter().zip(ws.data()).enumerate() {
            let g = if g.is_nan() { 0 } else { g as u32 };
            assert_eq!(g, b, "watershed tile {t} cell {i}");
        }
    }
    // HAND with a stream threshold on accumulation
    let acc = orogen::hydro::accumulate(&d).unwrap();
    let acc_f = acc.map(|v| v as f64);
    let streams = acc.map(|v| v >= 4);
    let hnd = hand(&z, &d, &streams).unwrap();
    let bh = brute_hand(&z, &d, &streams);
    for (i, (&a, &b)) in hnd.data().iter().zip(&bh).enumerate() {
        assert!(
            a == b || (a.is_nan() && b.is_nan()),
            "hand cell {i}: {a} vs {b}"
        );
    }
    let zsrc = mem(&z, None);
    let asrc = mem(&acc_f, None);
    let want = hnd.map(|v| v as f64);
    for &t in tiles {
        let step = TiledDownstream {
            seeds: Seeds::Streams { threshold: 4.0 },
            labels: DType::F64,
        };
        let got = run_global(&step, &[&dsrc, &zsrc, &asrc], t);
        assert!(same_f64(&got, &want), "tiled HAND, tile {t}");
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, .. ProptestConfig::default() })]
    #[test]
    fn downstream_passes_equal_brute_force_and_tiled(
        w in 3usize..60, h in 3usize..60,
        vals in prop::collection::vec(0.0f32..10.0, 1..400)
    ) {
        check_downstream(w, h, &vals, &[7, 37, 100]);
    }
}

#[test]
fn real_dem_basins_tiled_equal_untiled() {
    let src = orogen::io::open_raster(
        std::path::Path::new("tests/data/whitebox_DEM.tif"),
        &Default::default(),
    )
    .unwrap();
    let i = src.info().clone();
    let z = read_window::<f32>(src.as_ref(), Window::full(i.width, i.height)).unwrap();
    let d = d8_directions(&fill(&z).unwrap());
    let labels = basin_labels(&d).unwrap();
    let brute = brute_labels(&d);
    let lf = labels.map(|v| if v == 0 { f64::NAN } else { v as f64 });
    assert!(same_f64(
        &lf,
        &Grid::from_vec(i.width, i.height, brute).unwrap()
    ));
    let dsrc = mem(&d, Some(255.0));
    for t in [7, 37, 100] {
        let got = run_global(
            &TiledDownstream {
                seeds: Seeds::Outlets,
                labels: DType::F64,
            },
            &[&dsrc],
            t,
        );
        assert!(same_f64(&got, &lf), "tile {t}");
    }
}

#[test]
fn cycles_are_errors_across_tiles() {
    // a 2-cell cycle straddling a tile edge
    let mut d = Grid::new(4, 1, 1u8);
    d.set(1, 0, 1);
    d.set(2, 0, 16);
    let dsrc = mem(&d, Some(255.0));
    let layout = TileLayout::new(4, 1, 2);
    let step = TiledDownstream {
        seeds: Seeds::Outlets,
        labels: DType::F64,
    };
    let sums: Vec<_> = (0..2)
        .map(|id| {
            step.map(&[read_view::<f64>(&dsrc, &layout, id, 1).unwrap()])
                .unwrap()
        })
        .collect();
    assert!(step.reduce(&layout, sums).is_err());
    assert!(basin_labels(&d).is_err());
}

// ---- basin metrics: closed forms ----

#[test]
fn rectangle_basin_metrics() {
    // a x b = 12 x 7 cells of 10 m at (5, 4) in a 30 x 20 grid; rows flow W,
    // column 5 flows S; the outlet is the bottom-left cell.
    let (a, b, x0, y0) = (12usize, 7usize, 5usize, 4usize);
    let (w, h) = (30, 20);
    let inside = |x: usize, y: usize| x >= x0 && x < x0 + a && y >= y0 && y < y0 + b;
    let labels = Grid::from_fn(w, h, |x, y| u64::from(inside(x, y)));
    let dirs = Grid::from_fn(w, h, |x, _| if x == x0 { 4u8 } else { 16 });
    let dem = Grid::from_fn(w, h, |x, y| (x + y) as f32);
    let m = basin_metrics(&labels, &dem, &dirs, &geo10(), 11, 1).unwrap();
    assert_eq!(m.len(), 1);
    let m = &m[0];
    let area = (a * b) as f64 * 100.0;
    let perim = 2.0 * (a - 1) as f64 * 10.0 + 2.0 * (b - 1) as f64 * 10.0 + 2.0 * 10.0 * SQ2;
    let lfp = ((a - 1) + (b - 1)) as f64 * 10.0;
    assert_eq!(m.outlet, (x0, y0 + b - 1));
    assert!((m.area_m2 - area).abs() < 1e-9);
    assert!((m.perimeter_m - perim).abs() < 1e-9, "{}", m.perimeter_m);
    assert!((m.longest_flow_path_m - lfp).abs() < 1e-9);
    assert!((m.form_factor - area / (lfp * lfp)).abs() < 1e-12);
    assert!((m.circularity - 4.0 * std::f64::consts::PI * area / (perim * perim)).abs() < 1e-12);
    // z = x + y over the rectangle: min x0+y0, max +a+b-2, mean at the centre
    let (zmin, zmax) = ((x0 + y0) as f64, (x0 + y0 + a + b - 2) as f64);
    assert_eq!((m.min_z, m.max_z), (zmin, zmax));
    assert!((m.hypsometric_integral - 0.5).abs() < 1e-12);
    assert!((m.melton - (zmax - zmin) / area.sqrt()).abs() < 1e-12);
    assert!((m.relief_ratio - (zmax - zmin) / lfp).abs() < 1e-12);
    assert_eq!(m.hypsometric_curve[0], 1.0);
}

#[test]
fn disk_circularity_and_cone_hypsometry() {
    // disk of radius 40 cells; cone z = H (1 - r/R)
    let (n, r) = (101usize, 40.0f64);
    let c = 50.0;
    let rho = |x: usize, y: usize| ((x as f64 - c).powi(2) + (y as f64 - c).powi(2)).sqrt();
    let labels = Grid::from_fn(n, n, |x, y| u64::from(rho(x, y) <= r));
    let dem = Grid::from_fn(n, n, |x, y| (1000.0 * (1.0 - rho(x, y) / r)) as f32);
    let dirs = Grid::new(n, n, 0u8); // every cell its own outlet: flow path 0
    let m = basin_metrics(&labels, &dem, &dirs, &geo10(), 21, 1).unwrap();
    let m = &m[0];
    // area of a digital disk ≈ πr² (Gauss circle problem: error O(r))
    let area = std::f64::consts::PI * (r * 10.0).powi(2);
    assert!((m.area_m2 / area - 1.0).abs() < 0.01);
    // marching squares overestimates curved outlines by ≈ 5.5 % on average
    // (segments at 0/45/90°): circularity ≈ 1/1.055² ≈ 0.90. Bound: [0.85, 0.97].
    assert!(
        m.circularity > 0.85 && m.circularity < 0.97,
        "{}",
        m.circularity
    );
    assert!((m.compactness - 1.0 / m.circularity.sqrt()).abs() < 1e-12);
    // cone: HI = 1/3 analytically; curve: area above relative height h is (1 - h)²
    assert!(
        (m.hypsometric_integral - 1.0 / 3.0).abs() < 0.01,
        "{}",
        m.hypsometric_integral
    );
    for (k, &v) in m.hypsometric_curve.iter().enumerate() {
        let hk = k as f64 / 20.0;
        assert!((v - (1.0 - hk).powi(2)).abs() < 0.03, "h {hk}: {v}");
    }
}

// ---- indices ----

#[test]
fn local_indices_on_a_tilted_plane() {
    // z = s·x·10 m per column (10 m cells): tan β = s exactly away from edges
    let (w, h) = (40, 30);
    let s = 0.2;
    let dem = Grid::from_fn(w, h, |x, _| (s * 10.0 * x as f64) as f32);
    let acc = Grid::from_fn(w, h, |x, y| (1 + (x * 7 + y * 3) % 50) as f32);
    let g = geo10();
    let dsrc = MemRaster::from_grid(dem.clone(), g.clone());
    let asrc = MemRaster::from_grid(acc.clone(), g.clone());
    let sinb = s / (1.0 + s * s).sqrt();
    for kind in [
        IndexKind::Twi,
        IndexKind::Spi,
        IndexKind::Sti,
        IndexKind::Ls,
    ] {
        let step = HydroIndex::new(kind);
        for tile in [7, 16, 64] {
            let out = run_local_to_memory(
                &LocalEngine::new(EngineConfig::default()),
                &step,
                &[&dsrc, &asrc],
                TileLayout::new(w, h, tile),
                &[(DType::F32, None)],
            )
            .unwrap();
            let out: Grid<f32> = out[0].to_typed(None);
            for y in 1..h - 1 {
                for x in 1..w - 1 {
                    let a = acc.get(x, y) as f64 * 10.0; // A·100 m² / 10 m
                    let want = match kind {
                        IndexKind::Twi => (a / s).ln(),
                        IndexKind::Spi => a * s,
                        IndexKind::Sti => (a / 22.13).powf(0.6) * (sinb / 0.0896).powf(1.3),
                        IndexKind::Ls => 1.4 * (a / 22.13).powf(0.4) * (sinb / 0.0896).powf(1.3),
                    };
                    let got = out.get(x, y) as f64;
                    assert!(
                        (got - want).abs() <= 1e-5 * want.abs().max(1.0),
                        "{kind:?} tile {tile} ({x},{y}): {got} vs {want}"
                    );
                }
            }
        }
    }
}

/// Horn tan β written independently (3x3, nodata -> centre).
fn horn_tan(z: &Grid<f32>, x: usize, y: usize, cell: f64) -> f64 {
    let g = |dx: i64, dy: i64| -> f64 {
        let (nx, ny) = (x as i64 + dx, y as i64 + dy);
        if nx < 0 || ny < 0 || nx >= z.width() as i64 || ny >= z.height() as i64 {
            return z.get(x, y) as f64;
        }
        let v = z.get(nx as usize, ny as usize);
        if v.is_finite() {
            v as f64
        } else {
            z.get(x, y) as f64
        }
    };
    let ex = (g(1, -1) + 2.0 * g(1, 0) + g(1, 1)) - (g(-1, -1) + 2.0 * g(-1, 0) + g(-1, 1));
    let ny = (g(-1, -1) + 2.0 * g(0, -1) + g(1, -1)) - (g(-1, 1) + 2.0 * g(0, 1) + g(1, 1));
    (ex / (8.0 * cell)).hypot(ny / (8.0 * cell))
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, .. ProptestConfig::default() })]
    #[test]
    fn dtw_equals_bellman_ford(
        w in 2usize..12, h in 2usize..12,
        vals in prop::collection::vec(0.0f32..50.0, 1..150),
        sbits in prop::collection::vec(any::<bool>(), 1..40)
    ) {
        let z = Grid::from_fn(w, h, |x, y| vals[(y * w + x) % vals.len()]);
        let st = Grid::from_fn(w, h, |x, y| sbits[(x * 5 + y * 3) % sbits.len()] && (x + y) % 4 == 0);
        let got = depth_to_water(&z, &st, &geo10()).unwrap();
        // Bellman–Ford: relax every edge until nothing changes
        let n = w * h;
        let tb: Vec<f64> = (0..n).map(|c| horn_tan(&z, c % w, c / w, 10.0)).collect();
        let mut cost: Vec<f64> = (0..n).map(|c| if st.data()[c] { 0.0 } else { f64::INFINITY }).collect();
        loop {
            let mut changed = false;
            for c in 0..n {
                for dy in -1i64..=1 {
                    for dx in -1i64..=1 {
                        if dx == 0 && dy == 0 { continue; }
                        let (nx, ny) = ((c % w) as i64 + dx, (c / w) as i64 + dy);
                        if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 { continue; }
                        let m = ny as usize * w + nx as usize;
                        let len = if dx != 0 && dy != 0 { 10.0 * SQ2 } else { 10.0 };
                        let nd = cost[m] + 0.5 * (tb[c] + tb[m]) * len;
                        if nd < cost[c] - 1e-12 { cost[c] = nd; changed = true; }
                    }
                }
            }
            if !changed { break; }
        }
        for (c, (&g, &want)) in got.data().iter().zip(&cost).enumerate() {
            let g = g as f64;
            if want.is_infinite() {
                prop_assert!(g.is_nan());
            } else {
                prop_assert!((g - want).abs() <= 1e-4 * want.max(1.0), "cell {}: {} vs {}", c, g, want);
            }
        }
    }

    #[test]
    fn branch_length_equals_brute_force(
        w in 3usize..25, h in 3usize..25,
        vals in prop::collection::vec(0.0f32..10.0, 1..300)
    ) {
        let (_, d) = dem_and_dirs(w, h, &vals);
        let got = max_branch_length(&d, &geo10()).unwrap();
        let dist = |p: &[(usize, usize)], upto: usize| -> f64 {
            p[..=upto].windows(2).map(|s| {
                let dx = s[0].0.abs_diff(s[1].0) as f64;
                let dy = s[0].1.abs_diff(s[1].1) as f64;
                10.0 * (dx * dx + dy * dy).sqrt()
            }).sum()
        };
        for y in 0..h {
            for x in 0..w {
                if d.get(x, y) == 255 {
                    prop_assert!(got.get(x, y).is_nan());
                    continue;
                }
                let pi = path(&d, x, y);
                let mut best = 0.0f64;
                for dy in -1i64..=1 {
                    for dx in -1i64..=1 {
                        let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                        if (dx == 0 && dy == 0) || nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 { continue; }
                        let (nx, ny) = (nx as usize, ny as usize);
                        if d.get(nx, ny) == 255 { continue; }
                        let pj = path(&d, nx, ny);
                        // first cell of i's path that lies on j's path
                        let k = pi.iter().position(|c| pj.contains(c)).unwrap_or(pi.len() - 1);
                        best = best.max(dist(&pi, k));
                    }
                }
                let g = got.get(x, y) as f64;
                prop_assert!((g - best).abs() <= 1e-3, "({},{}): {} vs {}", x, y, g, best);
            }
        }
    }
}

// ---- end to end through the CLI ----

fn orogen(args: &[&str], dir: &std::path::Path) -> String {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_orogen"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("orogen runs");
    assert!(
        out.status.success(),
        "orogen {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stderr).into_owned()
}

fn read_json(p: &std::path::Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(p).unwrap()).expect("valid JSON")
}

#[test]
fn cli_fill_flow_accumulate_streams_basins_indices() {
    let t = tempfile::tempdir().unwrap();
    let dir = t.path();
    let dem = std::fs::canonicalize("tests/data/bigtujunga_crop.tif").unwrap();
    let dem = dem.to_str().unwrap();
    orogen(&["fill", dem, "-o", "f.tif", "-q"], dir);
    orogen(&["flow", "f.tif", "-o", "d.tif", "-q"], dir);
    orogen(&["accumulate", "d.tif", "-o", "a.tif", "-q"], dir);
    orogen(
        &[
            "streams",
            "d.tif",
            "-o",
            "s.geojson",
            "--threshold",
            "200",
            "--raster",
            "o.tif",
            "--stats",
            "st.json",
            "--csv",
            "l.csv",
            "--nodes",
            "n.geojson",
            "-q",
        ],
        dir,
    );
    let gj = read_json(&dir.join("s.geojson"));
    let feats = gj["features"].as_array().unwrap();
    assert!(feats.len() > 20);
    let mut max_order = 0;
    for f in feats {
        assert_eq!(f["geometry"]["type"], "LineString");
        let c = f["geometry"]["coordinates"].as_array().unwrap();
        assert!(c.len() >= 2);
        let p = &f["properties"];
        for k in [
            "strahler",
            "shreve",
            "length_m",
            "area_m2",
            "from_node",
            "to_node",
        ] {
            assert!(!p[k].is_null(), "property {k}");
        }
        // 30 m UTM cells: a link of n vertices is between 30(n-1) and 30√2(n-1) m long
        let len = p["length_m"].as_f64().unwrap();
        let n = (c.len() - 1) as f64;
        assert!(len >= 30.0 * n - 1e-6 && len <= 30.0 * SQ2 * n + 1e-6);
        // 200 cells of 900 m² at least drain through every channel cell
        assert!(p["area_m2"].as_f64().unwrap() >= 200.0 * 900.0);
        max_order = max_order.max(p["strahler"].as_u64().unwrap());
    }
    let st = read_json(&dir.join("st.json"));
    assert_eq!(st["horton"]["max_order"].as_u64().unwrap(), max_order);
    assert!(st["horton"]["bifurcation_ratio"].as_f64().unwrap() > 1.5);
    // the stream raster's largest order is the network's
    let o = orogen::io::open_raster(&dir.join("o.tif"), &Default::default()).unwrap();
    let og = read_window::<f64>(o.as_ref(), Window::full(301, 203)).unwrap();
    let omax = og
        .data()
        .iter()
        .filter(|v| v.is_finite())
        .fold(0.0f64, |a, &b| a.max(b));
    assert_eq!(omax as u64, max_order);

    // basins: tiled with an odd tile equals the in-memory labels
    orogen(
        &[
            "basins",
            "d.tif",
            "-o",
            "b.tif",
            "--tile",
            "37",
            "--metrics",
            "b.csv",
            "--dem",
            "f.tif",
            "--min-cells",
            "500",
            "-q",
        ],
        dir,
    );
    let d = orogen::io::open_raster(&dir.join("d.tif"), &Default::default()).unwrap();
    let dg: Grid<u8> = read_window::<u8>(d.as_ref(), Window::full(301, 203)).unwrap();
    let want = basin_labels(&dg).unwrap();
    let b = orogen::io::open_raster(&dir.join("b.tif"), &Default::default()).unwrap();
    let bg = read_window::<f64>(b.as_ref(), Window::full(301, 203)).unwrap();
    for (g, w) in bg.data().iter().zip(want.data()) {
        assert_eq!(*g as u64, *w);
    }
    let csv = std::fs::read_to_string(dir.join("b.csv")).unwrap();
    assert!(csv.lines().count() >= 2);
    assert!(csv.starts_with("label,outlet_col,outlet_row"));
    let bj = read_json(&dir.join("b.geojson"));
    for f in bj["features"].as_array().unwrap() {
        assert_eq!(f["geometry"]["type"], "MultiPolygon");
        let p = &f["properties"];
        assert!(p["cells"].as_u64().unwrap() >= 500);
        let hi = p["hypsometric_integral"].as_f64().unwrap();
        assert!((0.0..=1.0).contains(&hi));
        assert_eq!(p["hypsometric_curve"].as_array().unwrap().len(), 21);
    }

    // pour points: a watershed of the largest-accumulation cell, snapped
    let (ox, oy) = orogen::hydro::accumulate(&dg)
        .unwrap()
        .data()
        .iter()
        .enumerate()
        .max_by_key(|p| (*p.1, std::cmp::Reverse(p.0)))
        .map(|(i, _)| (i % 301, i / 301))
        .unwrap();
    let g = d.info().georef.clone();
    let (mx, my) = g.pixel_to_map(ox as f64 + 1.5, oy as f64 + 0.5); // one cell off
    std::fs::write(dir.join("p.csv"), format!("id,x,y\ngauge,{mx},{my}\n")).unwrap();
    orogen(
        &[
            "basins", "d.tif", "--points", "p.csv", "--snap", "2", "--acc", "a.tif", "-o", "w.tif",
            "-q",
        ],
        dir,
    );
    let wsrc = orogen::io::open_raster(&dir.join("w.tif"), &Default::default()).unwrap();
    let wg = read_window::<f64>(wsrc.as_ref(), Window::full(301, 203)).unwrap();
    let ws = watersheds(&dg, &[(ox, oy)]).unwrap();
    for (g, w) in wg.data().iter().zip(ws.data()) {
        assert_eq!(*g as u32, *w);
    }

    // indices
    for i in ["twi", "spi", "sti", "ls"] {
        orogen(
            &[
                "hydro-index",
                "--index",
                i,
                "--dem",
                "f.tif",
                "--acc",
                "a.tif",
                "-o",
                &format!("{i}.tif"),
                "-q",
            ],
            dir,
        );
    }
    orogen(
        &[
            "hydro-index",
            "--index",
            "hand",
            "--dem",
            "f.tif",
            "--dirs",
            "d.tif",
            "--acc",
            "a.tif",
            "--threshold",
            "200",
            "--tile",
            "50",
            "-o",
            "hand.tif",
            "-q",
        ],
        dir,
    );
    let f = orogen::io::open_raster(&dir.join("f.tif"), &Default::default()).unwrap();
    let fz = read_window::<f32>(f.as_ref(), Window::full(301, 203)).unwrap();
    let acc = orogen::hydro::accumulate(&dg).unwrap();
    let want = hand(&fz, &dg, &acc.map(|v| v >= 200)).unwrap();
    let hs = orogen::io::open_raster(&dir.join("hand.tif"), &Default::default()).unwrap();
    let hg = read_window::<f32>(hs.as_ref(), Window::full(301, 203)).unwrap();
    for (g, w) in hg.data().iter().zip(want.data()) {
        assert!(g == w || (g.is_nan() && w.is_nan()), "{g} vs {w}");
    }
    for (i, extra) in [
        ("dtw", ["--dem", "f.tif"]),
        ("branch-length", ["--dirs", "d.tif"]),
    ] {
        orogen(
            &[
                "hydro-index",
                "--index",
                i,
                extra[0],
                extra[1],
                "--acc",
                "a.tif",
                "--threshold",
                "200",
                "-o",
                &format!("{i}.tif"),
                "-q",
            ],
            dir,
        );
        assert!(dir.join(format!("{i}.tif")).exists());
    }
}

#[test]
fn cli_errors_are_clear() {
    let t = tempfile::tempdir().unwrap();
    let dir = t.path();
    let dem = std::fs::canonicalize("tests/data/bigtujunga_crop.tif").unwrap();
    let run = |args: &[&str]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_orogen"))
            .args(args)
            .current_dir(dir)
            .output()
            .unwrap()
    };
    // elevations are not D8 codes
    let o = run(&["streams", dem.to_str().unwrap(), "-o", "s.geojson"]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("not a D8 code"));
    let o = run(&["hydro-index", "--index", "nope", "-o", "x.tif"]);
    assert!(String::from_utf8_lossy(&o.stderr).contains("use twi, spi"));
    let o = run(&["hydro-index", "--index", "twi", "-o", "x.tif"]);
    assert!(String::from_utf8_lossy(&o.stderr).contains("needs --dem"));
    std::fs::write(dir.join("p.csv"), "a,b\n1,2\n").unwrap();
    let o = run(&[
        "basins",
        dem.to_str().unwrap(),
        "--points",
        "p.csv",
        "-o",
        "w.tif",
    ]);
    assert!(String::from_utf8_lossy(&o.stderr).contains("x and y"));
    // the memory guard names the fix: 600x600 cells x 64 B > 16 MiB
    let big = MemRaster::from_grid(Grid::new(600, 600, 1u8), geo10().with_nodata(Some(255.0)));
    orogen::ops::convert(
        &big,
        &dir.join("big.tif"),
        &Default::default(),
        None,
        &EngineConfig::default(),
    )
    .unwrap();
    let o = run(&["streams", "big.tif", "-o", "s.geojson", "--memory", "16MiB"]);
    assert!(!o.status.success());
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(e.contains("raise --memory") && e.contains("big.tif"), "{e}");
    assert!(!dir.join("s.geojson").exists());
}

#[test]
fn tokunaga_parameters_of_a_comb() {
    // Trunk down column 10 from (10,2), created by two order-2 rows (A from
    // the west, B from the east, both along row 2); a third order-2 row C
    // joins it from the west at row 8; two single heads join it from the east
    // at rows 12 and 15. Each row is made by two heads and gets one side head.
    let (w, h) = (20, 20);
    let mut d = Grid::new(w, h, 255u8);
    for y in 2..h {
        d.set(10, y, 4);
    }
    let west_row = |d: &mut Grid<u8>, y: usize| {
        for x in 3..10 {
            d.set(x, y, 1);
        }
        d.set(2, y, 1);
        d.set(2, y - 1, 2);
        d.set(6, y - 1, 4);
    };
    west_row(&mut d, 2);
    west_row(&mut d, 8);
    for x in 11..18 {
        d.set(x, 2, 16);
    }
    d.set(18, 2, 16);
    d.set(18, 1, 8);
    d.set(14, 1, 4);
    d.set(11, 12, 16);
    d.set(11, 15, 16);
    let net = cells_network(&d, 2);
    let ho = horton(&net);
    assert_eq!(ho.count, vec![11, 3, 1]);
    assert!((ho.bifurcation_ratio - 11f64.sqrt()).abs() < 1e-9);
    let tk = tokunaga(&net);
    assert_eq!(tk.t, vec![(1, 2, 1.0), (1, 3, 2.0), (2, 3, 1.0)]);
    assert_eq!(tk.t_k, vec![1.0, 2.0]);
    assert!((tk.a - 1.0).abs() < 1e-12 && (tk.c - 2.0).abs() < 1e-12);
    // trunk: straight, 17 cells from (10,2) to (10,19) = 170 m
    let s3 = net.streams.iter().find(|s| s.order == 3).unwrap();
    assert!((s3.length_m - 170.0).abs() < 1e-9 && (s3.straight_m - 170.0).abs() < 1e-9);
}

#[test]
fn lengths_are_metric_on_geographic_grids() {
    // 3" cells at 46°N: a link of 6 cells flowing east is 5 steps of the
    // WGS 84 east-west cell size N(φ) cos φ Δλ at the row's latitude.
    let cell = 1.0 / 1200.0;
    let g = GeoRef::north_up(8.0, 46.0 + cell / 2.0, cell, Crs::wgs84());
    let d = Grid::from_fn(6, 1, |_, _| 1u8);
    let net = extract_network(
        &d,
        None,
        &g,
        &NetworkOptions {
            rule: ChannelRule::Cells(1.0),
            valley_window: 0,
        },
    )
    .unwrap();
    let (a, e2) = (6_378_137.0f64, 0.006_694_379_990_141_317f64);
    let phi = 46f64.to_radians();
    let nphi = a / (1.0 - e2 * phi.sin().powi(2)).sqrt();
    let ew = nphi * phi.cos() * cell.to_radians();
    assert_eq!(net.links.len(), 1);
    let l = &net.links[0];
    assert!(
        (l.length_m - 5.0 * ew).abs() < 1e-6,
        "{} vs {}",
        l.length_m,
        5.0 * ew
    );
    assert!((ew - 64.4).abs() < 0.5); // ≈ 64.4 m at 46°N
}

/// Per-cell Strahler order and Shreve magnitude by recursion over channel
/// donors (cells whose D8 code points at the cell), with brute-force
/// accumulation (cells whose path passes through) deciding the channels.
fn brute_orders(d: &Grid<u8>, threshold: u64) -> (Vec<u32>, Vec<u64>, Vec<bool>) {
    let (w, h) = (d.width(), d.height());
    let mut acc = vec![0u64; w * h];
    for y in 0..h {
        for x in 0..w {
            if d.get(x, y) != 255 {
                for (px, py) in path(d, x, y) {
                    acc[py * w + px] += 1;
                }
            }
        }
    }
    let chan: Vec<bool> = acc.iter().map(|&a| a >= threshold).collect();
    fn rec(
        c: usize,
        d: &Grid<u8>,
        chan: &[bool],
        memo: &mut Vec<Option<(u32, u64)>>,
    ) -> (u32, u64) {
        if let Some(v) = memo[c] {
            return v;
        }
        let w = d.width();
        let (x, y) = (c % w, c / w);
        let mut orders = Vec::new();
        let mut shreve = 0;
        for dy in -1i64..=1 {
            for dx in -1i64..=1 {
                let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                if (dx, dy) == (0, 0)
                    || nx < 0
                    || ny < 0
                    || nx >= w as i64
                    || ny >= d.height() as i64
                {
                    continue;
                }
                let (nx, ny) = (nx as usize, ny as usize);
                let m = ny * w + nx;
                if chan[m] && d.get(nx, ny) != 255 && down(d, nx, ny) == Some((x, y)) {
                    let (o, s) = rec(m, d, chan, memo);
                    orders.push(o);
                    shreve += s;
                }
            }
        }
        let v = if orders.is_empty() {
            (1, 1)
        } else {
            let m = *orders.iter().max().unwrap();
            let k = orders.iter().filter(|&&o| o == m).count();
            (if k >= 2 { m + 1 } else { m }, shreve)
        };
        memo[c] = Some(v);
        v
    }
    let mut memo = vec![None; w * h];
    let mut ord = vec![0u32; w * h];
    let mut shr = vec![0u64; w * h];
    for c in 0..w * h {
        if chan[c] {
            let (o, s) = rec(c, d, &chan, &mut memo);
            ord[c] = o;
            shr[c] = s;
        }
    }
    (ord, shr, chan)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 32, .. ProptestConfig::default() })]
    #[test]
    fn network_orders_equal_per_cell_recursion(
        w in 3usize..40, h in 3usize..40,
        vals in prop::collection::vec(0.0f32..10.0, 1..300),
        threshold in 1u64..6
    ) {
        let (_, d) = dem_and_dirs(w, h, &vals);
        let net = extract_network(&d, None, &geo10(), &NetworkOptions {
            rule: ChannelRule::Cells(threshold as f64), valley_window: 3,
        }).unwrap();
        let (ord, shr, chan) = brute_orders(&d, threshold);
        for c in 0..w * h {
            let got = net.order.data()[c];
            if d.data()[c] == 255 {
                prop_assert_eq!(got, 255);
            } else if chan[c] {
                prop_assert_eq!(got as u32, ord[c], "order of cell {}", c);
            } else {
                prop_assert_eq!(got, 0);
            }
        }
        for l in &net.links {
            let s = l.cells[0] as usize;
            prop_assert_eq!(l.strahler, ord[s]);
            prop_assert_eq!(l.shreve, shr[s]);
            // every interior cell of a link has exactly one channel donor
            prop_assert!(l.cells.len() >= 2);
            let len: f64 = l.cells.windows(2).map(|p| {
                let (a, b) = (p[0] as usize, p[1] as usize);
                let dx = (a % w).abs_diff(b % w) as f64;
                let dy = (a / w).abs_diff(b / w) as f64;
                10.0 * (dx * dx + dy * dy).sqrt()
            }).sum();
            prop_assert!((l.length_m - len).abs() < 1e-9);
        }
        // Shreve at the outlets sums to the number of heads
        let heads = net.nodes.iter().filter(|n| n.kind == "head").count() as u64;
        let outlet_links: u64 = net.links.iter()
            .filter(|l| net.nodes[l.to as usize].kind == "outlet")
            .map(|l| l.shreve).sum();
        prop_assert_eq!(outlet_links, heads);
    }
}

// ---- basin outlines ----

/// Shoelace area of a closed ring of corner coordinates.
fn ring_area(r: &[(usize, usize)]) -> f64 {
    r.windows(2)
        .map(|p| p[0].0 as f64 * p[1].1 as f64 - p[1].0 as f64 * p[0].1 as f64)
        .sum::<f64>()
        .abs()
        / 2.0
}

#[test]
fn outlines_of_a_rectangle_a_ring_and_a_diagonal_pair() {
    use orogen::hydro::basin_metrics::basin_outlines;
    let mut g = Grid::new(12, 10, 0u64);
    for y in 2..6 {
        for x in 3..9 {
            g.set(x, y, 5);
        }
    }
    let o = basin_outlines(&g).unwrap();
    assert_eq!(o.len(), 1);
    assert_eq!(o[0].0, 5);
    assert_eq!(o[0].1.len(), 1);
    let ring = &o[0].1[0][0];
    assert_eq!(ring.len(), 5);
    let mut corners: Vec<_> = ring[..4].to_vec();
    corners.sort();
    assert_eq!(corners, vec![(3, 2), (3, 6), (9, 2), (9, 6)]);
    // a 5x5 block with a hole in the middle
    let mut g = Grid::new(7, 7, 0u64);
    for y in 1..6 {
        for x in 1..6 {
            g.set(x, y, 1);
        }
    }
    g.set(3, 3, 0);
    let o = basin_outlines(&g).unwrap();
    let part = &o[0].1[0];
    assert_eq!(part.len(), 2);
    assert_eq!(ring_area(&part[0]), 25.0);
    assert_eq!(ring_area(&part[1]), 1.0);
    // cells touching at a corner are two parts
    let mut g = Grid::new(3, 3, 0u64);
    g.set(0, 0, 2);
    g.set(1, 1, 2);
    let o = basin_outlines(&g).unwrap();
    assert_eq!(o[0].1.len(), 2);
    // GeoJSON orientation: outer counter-clockwise in map coordinates (north up)
    let c = orogen::hydro::basin_metrics::outline_coordinates(&geo10(), &o[0].1);
    for part in &c {
        let r = &part[0];
        let a: f64 = r
            .windows(2)
            .map(|p| p[0][0] * p[1][1] - p[1][0] * p[0][1])
            .sum();
        assert!(a > 0.0);
        assert_eq!(r.first(), r.last());
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, .. ProptestConfig::default() })]
    #[test]
    fn outline_areas_equal_cell_counts(
        w in 1usize..20, h in 1usize..20,
        vals in prop::collection::vec(0u64..4, 1..400)
    ) {
        let g = Grid::from_fn(w, h, |x, y| vals[(y * w + x) % vals.len()]);
        let o = orogen::hydro::basin_metrics::basin_outlines(&g).unwrap();
        for (label, parts) in &o {
            let cells = g.data().iter().filter(|&&v| v == *label).count() as f64;
            let mut area = 0.0;
            for part in parts {
                for (k, ring) in part.iter().enumerate() {
                    prop_assert_eq!(ring.first(), ring.last());
                    for p in ring.windows(2) {
                        prop_assert!(p[0].0 == p[1].0 || p[0].1 == p[1].1, "axis-aligned edges");
                    }
                    let a = ring_area(ring);
                    area += if k == 0 { a } else { -a };
                }
            }
            prop_assert_eq!(area, cells, "label {}", label);
        }
        let labels: Vec<u64> = o.iter().map(|p| p.0).collect();
        let mut want: Vec<u64> = g.data().iter().copied().filter(|&v| v != 0).collect();
        want.sort();
        want.dedup();
        prop_assert_eq!(labels, want);
    }
}

#[test]
fn slope_area_channel_heads_on_a_plane() {
    // rows flow east down a plane of slope 0.1 (10 m cells): at column x the
    // drainage area is (x + 1)·100 m², so A·s² > 5.5 from x = 5 on (A·s² = x + 1)
    let (w, h) = (12, 4);
    let d = Grid::new(w, h, 1u8);
    let z = Grid::from_fn(w, h, |x, _| (100.0 - 1.0 * x as f64) as f32);
    let net = extract_network(
        &d,
        Some(&z),
        &geo10(),
        &NetworkOptions {
            rule: ChannelRule::SlopeArea(5.5),
            valley_window: 0,
        },
    )
    .unwrap();
    for y in 0..h {
        for x in 0..w {
            assert_eq!(net.order.get(x, y), u8::from(x >= 5), "({x},{y})");
        }
    }
    assert_eq!(net.links.len(), h);
    for l in &net.links {
        assert!((l.length_m - 10.0 * (w - 1 - 5) as f64).abs() < 1e-9);
        assert_eq!(l.area_cells, w as u64);
    }
    // area threshold: 600 m² = 6 cells -> from x = 5 as well
    let net = extract_network(
        &d,
        None,
        &geo10(),
        &NetworkOptions {
            rule: ChannelRule::Area(600.0),
            valley_window: 0,
        },
    )
    .unwrap();
    assert_eq!(net.order.get(4, 0), 0);
    assert_eq!(net.order.get(5, 0), 1);
}
