//! Orometry on DEMs with elevations at or below 0: the sea rule of
//! `EdgeConvention::SeaLevel` (the sea is met at min(0, L), L the highest
//! level at which a peak's land touches the edge or nodata) and the shift
//! invariance of `EdgeConvention::Unknown`, in memory, tiled and in the CLI.
//!
//! Two oracles, sharing no code with `orogen::oro` nor with each other:
//! [`level_oracle`] (per peak, BFS of the superlevel set at every level) for
//! small grids, [`bottleneck_oracle`] (per peak, a best-first search by the
//! highest path minimum) for real crops.

use crate::common::cli::{ok, orogen};
use crate::common::write_esri_ascii;
use orogen::exec::{EngineConfig, LocalEngine};
use orogen::oro::{self, divide_tree_tiled, DivideTree, EdgeConvention, PeakOptions};
use orogen::raster::{GeoRef, Grid, MemRaster, RasterSource};
use proptest::prelude::*;
use std::cmp::Ordering;
use std::collections::{BinaryHeap, VecDeque};
use std::path::Path;

const SEA: EdgeConvention = EdgeConvention::SeaLevel;
const UNK: EdgeConvention = EdgeConvention::Unknown;

/// (col, row, elevation, prominence), sorted by row then column.
type PeakRow = (u32, u32, f32, f64);

fn neighbours(w: usize, h: usize, i: usize) -> impl Iterator<Item = Option<usize>> {
    let (x, y) = ((i % w) as i64, (i / w) as i64);
    (-1i64..=1)
        .flat_map(|dy| (-1i64..=1).map(move |dx| (dx, dy)))
        .filter(|&d| d != (0, 0))
        .map(move |(dx, dy)| {
            let (nx, ny) = (x + dx, y + dy);
            (nx >= 0 && ny >= 0 && nx < w as i64 && ny < h as i64)
                .then(|| ny as usize * w + nx as usize)
        })
}

/// The cell is on the grid border or next to a nodata cell.
fn touches_outside(z: &[f32], w: usize, h: usize, i: usize) -> bool {
    neighbours(w, h, i).any(|n| n.is_none_or(|n| z[n].is_nan()))
}

/// Flat regions: for every valid cell the smallest index of its region.
fn regions(z: &[f32], w: usize, h: usize) -> Vec<usize> {
    let mut rep = vec![usize::MAX; z.len()];
    for s in 0..z.len() {
        if z[s].is_nan() || rep[s] != usize::MAX {
            continue;
        }
        // Scanning in index order, `s` is the region's smallest index.
        rep[s] = s;
        let mut q = VecDeque::from([s]);
        while let Some(c) = q.pop_front() {
            for n in neighbours(w, h, c).flatten() {
                if rep[n] == usize::MAX && z[n] == z[s] {
                    rep[n] = s;
                    q.push_back(n);
                }
            }
        }
    }
    rep
}

/// Peak regions (their first cell) by the definition: no valid neighbour at
/// least as high outside the region, and a valid neighbour, or (SeaLevel)
/// an elevation above 0.
fn peak_regions(z: &[f32], w: usize, h: usize, conv: EdgeConvention, rep: &[usize]) -> Vec<usize> {
    let mut out = Vec::new();
    for p in 0..z.len() {
        if z[p].is_nan() || rep[p] != p {
            continue;
        }
        let (mut any, mut top) = (false, true);
        for c in (0..z.len()).filter(|&c| rep[c] == p) {
            for n in neighbours(w, h, c).flatten() {
                if z[n].is_nan() || rep[n] == p {
                    continue;
                }
                any = true;
                top &= z[n] < z[p];
            }
        }
        if top && (any || (conv == SEA && z[p] > 0.0)) {
            out.push(p);
        }
    }
    out
}

/// Higher ground than the peak region `p` (ties: the region whose first cell
/// comes later counts as higher).
fn is_higher(z: &[f32], rep: &[usize], p: usize, c: usize) -> bool {
    z[c] > z[p] || (z[c] == z[p] && rep[c] > p)
}

/// Oracle 1: prominence = elevation − the highest level c at which the
/// peak's component of {z ≥ c} holds higher ground or, under SeaLevel, with
/// c ≤ 0, touches the edge or nodata (the sea at 0 is in {z ≥ c}). Under
/// Unknown a peak never beaten gets elevation − the lowest cell it reaches.
fn level_oracle(z: &[f32], w: usize, h: usize, conv: EdgeConvention) -> Vec<PeakRow> {
    let rep = regions(z, w, h);
    let mut out = Vec::new();
    for p in peak_regions(z, w, h, conv, &rep) {
        let hp = z[p];
        let mut levels: Vec<f32> = z.iter().copied().filter(|v| *v <= hp).collect();
        if hp >= 0.0 {
            levels.push(0.0);
        }
        levels.sort_by(|a, b| b.total_cmp(a));
        levels.dedup();
        let mut key = None;
        let mut low = hp;
        for &c in &levels {
            let mut seen = vec![false; z.len()];
            seen[p] = true;
            let mut q = VecDeque::from([p]);
            let (mut higher, mut outside) = (false, false);
            while let Some(i) = q.pop_front() {
                higher |= is_higher(z, &rep, p, i);
                outside |= touches_outside(z, w, h, i);
                low = low.min(z[i]);
                for n in neighbours(w, h, i).flatten() {
                    if !seen[n] && !z[n].is_nan() && z[n] >= c {
                        seen[n] = true;
                        q.push_back(n);
                    }
                }
            }
            if higher || (conv == SEA && c <= 0.0 && outside) {
                key = Some(c);
                break;
            }
        }
        let prom = match key {
            Some(c) => hp as f64 - c as f64,
            None => {
                assert_eq!(conv, UNK, "under SeaLevel every peak meets the sea");
                hp as f64 - low as f64
            }
        };
        out.push(((p % w) as u32, (p / w) as u32, hp, prom));
    }
    out.sort_by_key(|a| (a.1, a.0));
    out
}

/// What stopped the best-first search of [`bottleneck_oracle`].
#[derive(Debug, Clone, Copy, PartialEq)]
enum Key {
    /// Higher ground reached through a col at this level.
    Col(f32),
    /// The sea (SeaLevel) at this level: min(0, the edge-touch level).
    Sea(f32),
    /// Neither (Unknown): the lowest cell of the peak's area.
    Area(f32),
}

#[derive(PartialEq)]
struct Item(f32, usize);
impl Eq for Item {}
impl PartialOrd for Item {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Item {
    fn cmp(&self, o: &Self) -> Ordering {
        self.0.total_cmp(&o.0).then(o.1.cmp(&self.1))
    }
}

/// Oracle 2, for larger grids: from each peak, visit cells in decreasing
/// order of the best path minimum ("bottleneck") from the summit. The first
/// higher cell visited gives the key col; the first cell touching the
/// outside gives the edge-touch level L and the sea at min(0, L).
fn bottleneck_oracle(z: &[f32], w: usize, h: usize, conv: EdgeConvention) -> Vec<(PeakRow, Key)> {
    let rep = regions(z, w, h);
    let mut out = Vec::new();
    let mut seen = vec![false; z.len()];
    for p in peak_regions(z, w, h, conv, &rep) {
        let hp = z[p];
        seen.iter_mut().for_each(|s| *s = false);
        let mut heap = BinaryHeap::from([Item(hp, p)]);
        seen[p] = true;
        let mut sea: Option<f32> = None;
        let mut low = hp;
        let mut key = None;
        // Bottleneck of the first higher cell visited.
        let mut col: Option<f32> = None;
        while let Some(Item(b, i)) = heap.pop() {
            if let Some(c) = col {
                if b < c {
                    break;
                }
            }
            low = low.min(z[i]);
            if col.is_none() && is_higher(z, &rep, p, i) {
                // Higher ground through a col at b; go on through the cells
                // at the same bottleneck: if one touches the outside, the
                // land meets the sea at the same level, and the sea wins.
                col = Some(b);
            }
            if conv == SEA && sea.is_none() && touches_outside(z, w, h, i) {
                sea = Some(b.min(0.0));
            }
            if let (None, Some(s)) = (col, sea) {
                if b <= s {
                    // Higher ground, if any, lies beyond a col ≤ b ≤ s.
                    key = Some(Key::Sea(s));
                    break;
                }
            }
            for n in neighbours(w, h, i).flatten() {
                if !seen[n] && !z[n].is_nan() {
                    seen[n] = true;
                    heap.push(Item(b.min(z[n]), n));
                }
            }
        }
        let key = match (key, col, sea) {
            (Some(k), _, _) => k,
            (None, Some(c), Some(s)) if s >= c => Key::Sea(s),
            (None, Some(c), _) => Key::Col(c),
            (None, None, Some(s)) => Key::Sea(s),
            (None, None, None) => Key::Area(low),
        };
        let base = match key {
            Key::Col(c) | Key::Sea(c) | Key::Area(c) => c,
        };
        let row = ((p % w) as u32, (p / w) as u32, hp, hp as f64 - base as f64);
        out.push((row, key));
    }
    out.sort_by_key(|a| (a.0 .1, a.0 .0));
    out
}

fn ours(t: &DivideTree) -> Vec<PeakRow> {
    let mut v: Vec<_> = t
        .peaks
        .iter()
        .map(|p| (p.col, p.row, p.elevation, p.prominence))
        .collect();
    v.sort_by_key(|a| (a.1, a.0));
    v
}

fn engine() -> LocalEngine {
    LocalEngine::new(EngineConfig {
        threads: 1,
        memory_budget: 1 << 28,
        progress: false,
        observer: None,
        engine: Default::default(),
    })
}

fn tiled(g: &Grid<f32>, conv: EdgeConvention, tile: usize) -> DivideTree {
    let src = MemRaster::from_grid(g.clone(), GeoRef::pixel());
    divide_tree_tiled(&src as &dyn RasterSource, conv, tile, &engine()).expect("tiled tree")
}

/// The tree of `g` in memory, checked against the tiled tree for `tiles`.
fn tree_everywhere(g: &Grid<f32>, conv: EdgeConvention, tiles: &[usize]) -> DivideTree {
    let want = oro::divide_tree(g, conv).expect("in-memory tree");
    for &t in tiles {
        assert!(
            tiled(g, conv, t) == want,
            "tile {t} {conv:?}: tiled != in memory"
        );
    }
    want
}

/// Every cell + `dz`, which must be exact in f32.
fn shifted(g: &Grid<f32>, dz: f32) -> Grid<f32> {
    let s = g.map(|z| z + dz);
    for (a, b) in g.data().iter().zip(s.data()) {
        assert!(
            a.is_nan() && b.is_nan() || b - dz == *a,
            "{a} + {dz} is not exact"
        );
    }
    s
}

/// Peaks as (col, row, prominence, key saddle cell, parent cell): all that a
/// shift of every elevation must leave alone.
type Shape = (u32, u32, f64, Option<(u32, u32)>, Option<(u32, u32)>);

fn shape(t: &DivideTree) -> Vec<Shape> {
    t.peaks
        .iter()
        .map(|p| {
            (
                p.col,
                p.row,
                p.prominence,
                p.key_saddle.map(|s| (t.saddles[s].col, t.saddles[s].row)),
                p.parent.map(|q| (t.peaks[q].col, t.peaks[q].row)),
            )
        })
        .collect()
}

// ------------------------------------------------------- hand computed ----

/// A "Dead Sea" grid: all land below 0. The border ring is at −420 (with
/// an edge summit D at −390), a basin at −430 inside it; hills A (−350) and
/// B (−380) joined by a col at −400, rising from the basin; hill C (−300)
/// whose spur (−310, −415, −418) runs down to the ring; hill E (−340) next
/// to a nodata cell through a shoulder at −365.
fn dead_sea() -> Grid<f32> {
    let (w, h) = (11, 7);
    let mut g = Grid::from_fn(w, h, |x, y| {
        if x == 0 || y == 0 || x == w - 1 || y == h - 1 {
            -420.0f32
        } else {
            -430.0
        }
    });
    for (x, y, z) in [
        (9, 0, -390.0), // D, on the edge
        (2, 2, -350.0), // A
        (3, 2, -400.0), // col A-B
        (4, 2, -380.0), // B
        (7, 2, -300.0), // C
        (7, 3, -310.0),
        (7, 4, -415.0),
        (7, 5, -418.0), // C's spur meets the ring at (7, 6)
        (3, 4, -340.0), // E
        (4, 4, -365.0), // E's shoulder, next to nodata
        (5, 4, f32::NAN),
    ] {
        g.set(x, y, z);
    }
    g
}

/// (col, row, prominence, key saddle elevation, parent col/row), in the
/// tree's order.
type Hand = (u32, u32, f64, Option<f32>, Option<(u32, u32)>);

fn hand(t: &DivideTree) -> Vec<Hand> {
    t.peaks
        .iter()
        .map(|p| {
            (
                p.col,
                p.row,
                p.prominence,
                p.key_saddle.map(|s| t.saddles[s].elevation),
                p.parent.map(|q| (t.peaks[q].col, t.peaks[q].row)),
            )
        })
        .collect()
}

#[test]
fn dead_sea_grid_by_hand() {
    let g = dead_sea();
    // SeaLevel. The sea is met where the land first touches the edge or
    // nodata, every level here being below 0:
    // C: its spur reaches the ring at −420          → −300 − (−420) = 120
    // E: its shoulder touches nodata at −365         → −340 − (−365) = 25
    // A: its land reaches the ring only through the basin at −430 → 80
    // B: joins A (higher) at the col −400 first      → −380 − (−400) = 20
    // D: its summit is on the edge (the sea at −390) → 0
    let sea = tree_everywhere(&g, SEA, &[1, 2, 3, 4, 5, 7]);
    assert_eq!(
        hand(&sea),
        vec![
            (7, 2, 120.0, None, None),
            (3, 4, 25.0, None, None),
            (2, 2, 80.0, None, None),
            (4, 2, 20.0, Some(-400.0), Some((2, 2))),
            (9, 0, 0.0, None, None),
        ]
    );
    assert!(sea.peaks[4].on_edge && !sea.peaks[0].on_edge);
    // Unknown: the area's lowest cell is −430; C is the highest.
    // C: −300 − (−430) = 130. E and A reach C through the basin (first cell
    // (1, 1)): 90 and 80. D reaches C's spur through the ring (first cell
    // (0, 0)) at −420: 30. B: 20 at its col.
    let unk = tree_everywhere(&g, UNK, &[1, 2, 3, 4, 5, 7]);
    assert_eq!(
        hand(&unk),
        vec![
            (7, 2, 130.0, None, None),
            (3, 4, 90.0, Some(-430.0), Some((7, 2))),
            (2, 2, 80.0, Some(-430.0), Some((7, 2))),
            (4, 2, 20.0, Some(-400.0), Some((2, 2))),
            (9, 0, 30.0, Some(-420.0), Some((7, 2))),
        ]
    );
    // Both oracles agree with the hand values.
    let (w, h) = (g.width(), g.height());
    for conv in [SEA, UNK] {
        let t = oro::divide_tree(&g, conv).unwrap();
        assert_eq!(ours(&t), level_oracle(g.data(), w, h, conv), "{conv:?}");
        let b: Vec<PeakRow> = bottleneck_oracle(g.data(), w, h, conv)
            .into_iter()
            .map(|a| a.0)
            .collect();
        assert_eq!(ours(&t), b, "{conv:?}");
    }
    // Lifted 1000 m above the sea, Unknown does not change; under SeaLevel
    // everything now rises from 0 through the ring: C is an island of 700,
    // the others keep their cols (the basin, the ring) as under Unknown.
    let up = shifted(&g, 1000.0);
    assert_eq!(shape(&tree_everywhere(&up, UNK, &[3, 4])), shape(&unk));
    let up_sea = tree_everywhere(&up, SEA, &[3, 4]);
    let mut want = shape(&unk);
    want[0].2 = 700.0;
    assert_eq!(shape(&up_sea), want);
    // The threshold no longer drops the island tops below sea level.
    let list = oro::peaks(
        &g,
        &GeoRef::pixel(),
        &PeakOptions {
            min_prominence: 20.0,
            ..Default::default()
        },
    )
    .unwrap();
    let kept: Vec<(u32, u32)> = list.tree.peaks.iter().map(|p| (p.col, p.row)).collect();
    assert_eq!(kept, vec![(7, 2), (3, 4), (2, 2), (4, 2)]);
    // Dominance is not defined at or below sea level.
    assert!(list.tree.peaks.iter().all(|p| p.dominance().is_none()));
}

#[test]
fn flats_and_coasts_at_and_below_zero() {
    // A flat at or below 0 has no peak under either convention; above 0 it
    // is an island under SeaLevel.
    for z in [-100.0f32, 0.0] {
        for conv in [SEA, UNK] {
            assert!(tree_everywhere(&Grid::new(6, 5, z), conv, &[2, 4])
                .peaks
                .is_empty());
        }
    }
    // A summit at 0 on the edge with lower land inside: prominence 0 under
    // SeaLevel (it meets the sea at once), its drop under Unknown.
    let g = Grid::from_vec(3, 1, vec![0.0f32, -5.0, -2.0]).unwrap();
    assert_eq!(
        hand(&tree_everywhere(&g, SEA, &[1, 2])),
        vec![(0, 0, 0.0, None, None), (2, 0, 0.0, None, None)]
    );
    assert_eq!(
        hand(&tree_everywhere(&g, UNK, &[1, 2])),
        vec![
            (0, 0, 5.0, None, None),
            (2, 0, 3.0, Some(-5.0), Some((0, 0)))
        ]
    );
    // A hill of 50 m whose land reaches the edge only through a basin at
    // −30 m: it meets the sea at −30, prominence 80 (not 50).
    let g = Grid::from_fn(5, 5, |x, y| match (x, y) {
        (2, 2) => 50.0f32,
        (0 | 4, _) | (_, 0 | 4) => -10.0,
        _ => -30.0,
    });
    let t = tree_everywhere(&g, SEA, &[1, 2, 3]);
    assert_eq!(hand(&t)[0], (2, 2, 80.0, None, None));
    assert_eq!(t.peaks[0].dominance(), Some(80.0 / 50.0));
}

// ----------------------------------------------------------- proptests ----

/// Small grids of mixed-sign heights around a random base (−1000, 0, 1000
/// or 3: all below, mixed, all above 0), with nodata.
fn grid_strategy() -> impl Strategy<Value = Grid<f32>> {
    (
        1usize..9,
        1usize..9,
        prop::sample::select(vec![-1000.0f32, -2.0, 0.0, 3.0, 1000.0]),
    )
        .prop_flat_map(|(w, h, base)| {
            let cell = prop_oneof![
                10 => (-3i32..4).prop_map(move |v| base + v as f32),
                1 => Just(f32::NAN)
            ];
            proptest::collection::vec(cell, w * h)
                .prop_map(move |v| Grid::from_vec(w, h, v).unwrap())
        })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, .. ProptestConfig::default() })]

    /// The sweep against both oracles, prominence ≥ 0 under both
    /// conventions, tiled == in memory, and Unknown shift-invariant.
    #[test]
    fn prominence_by_definition_any_sign(g in grid_strategy(), tile in prop::sample::select(vec![1usize, 2, 3, 5])) {
        let (w, h) = (g.width(), g.height());
        for conv in [SEA, UNK] {
            let t = oro::divide_tree(&g, conv).unwrap();
            t.validate().unwrap();
            let got = ours(&t);
            prop_assert_eq!(&got, &level_oracle(g.data(), w, h, conv), "{:?}", conv);
            let b: Vec<PeakRow> = bottleneck_oracle(g.data(), w, h, conv).into_iter().map(|a| a.0).collect();
            prop_assert_eq!(&got, &b, "{:?} (bottleneck oracle)", conv);
            prop_assert!(t.peaks.iter().all(|p| p.prominence >= 0.0));
            for p in &t.peaks {
                if let Some(s) = p.key_saddle {
                    prop_assert_eq!(p.prominence, p.elevation as f64 - t.saddles[s].elevation as f64);
                }
            }
            prop_assert!(tiled(&g, conv, tile) == t, "tile {} {:?}", tile, conv);
            let m = 1.0;
            let pt = oro::pruned_tree_tiled(
                &MemRaster::from_grid(g.clone(), GeoRef::pixel()) as &dyn RasterSource,
                conv, m, tile, &engine()).unwrap();
            prop_assert!(pt == t.pruned(m), "pruned, tile {} {:?}", tile, conv);
        }
        let base = oro::divide_tree(&g, UNK).unwrap();
        for dz in [-1000.0f32, 1000.0] {
            prop_assert_eq!(shape(&oro::divide_tree(&shifted(&g, dz), UNK).unwrap()), shape(&base));
        }
    }
}

// ------------------------------------------------------------ real DEM ----

fn bigtujunga() -> Grid<f32> {
    load("tests/data/bigtujunga_crop.tif")
}

fn load(rel: &str) -> Grid<f32> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join(rel);
    let src = orogen::io::open_raster(&p, &orogen::io::OpenOptions::default()).unwrap();
    let i = src.info();
    orogen::raster::read_window::<f32>(&*src, orogen::raster::Window::full(i.width, i.height))
        .unwrap()
}

fn dem_max(g: &Grid<f32>) -> f32 {
    g.data()
        .iter()
        .copied()
        .filter(|z| !z.is_nan())
        .fold(f32::NEG_INFINITY, f32::max)
}

fn dem_min(g: &Grid<f32>) -> f32 {
    g.data()
        .iter()
        .copied()
        .filter(|z| !z.is_nan())
        .fold(f32::INFINITY, f32::min)
}

#[test]
fn real_crop_shifted_by_1000_m_keeps_its_peaks_unknown() {
    let g = bigtujunga();
    assert!(g.data().iter().all(|z| z.fract() == 0.0), "an integer DEM");
    let base = tree_everywhere(&g, UNK, &[37]);
    assert!(base.peaks.len() > 100);
    for dz in [-1000.0f32, 1000.0] {
        let s = shifted(&g, dz);
        assert_eq!(
            shape(&tree_everywhere(&s, UNK, &[7, 37])),
            shape(&base),
            "{dz}"
        );
    }
}

#[test]
fn real_crop_below_sea_level_sea_convention() {
    // int16 UTM, no nodata.
    below_sea_level_sea_convention(&bigtujunga(), &[7, 37]);
}

#[test]
fn real_crop_with_voids_below_sea_level_sea_convention() {
    // int16 SRTM3 with 8,021 void cells: nodata is sea, met at the level
    // where the land around a void touches it.
    let g = load("tests/data/oro/srtm3_N46E008_crop.tif");
    assert!(g.data().iter().any(|z| z.is_nan()));
    below_sea_level_sea_convention(&g, &[61]);
    let base = tree_everywhere(&g, UNK, &[]);
    for dz in [-5000.0f32, 1000.0] {
        assert_eq!(
            shape(&tree_everywhere(&shifted(&g, dz), UNK, &[61])),
            shape(&base)
        );
    }
}

/// The DEM `g` (all above 0) shifted entirely below sea level, under
/// SeaLevel: the same peaks, prominence ≥ 0, key cols as above sea level,
/// island tops at the oracle's edge-touch level; tiled == in memory.
fn below_sea_level_sea_convention(g: &Grid<f32>, tiles: &[usize]) {
    assert!(
        g.data().iter().all(|z| z.is_nan() || z.fract() == 0.0),
        "an integer DEM"
    );
    assert!(dem_min(g) > 0.0, "the unshifted crop is above sea level");
    let (w, h) = (g.width(), g.height());
    let up = tree_everywhere(g, SEA, &[]);
    // Entirely below 0: the highest cell at −1.
    let dz = -(dem_max(g) + 1.0);
    let s = shifted(g, dz);
    let down = tree_everywhere(&s, SEA, tiles);
    // Every peak is found (the same peak regions), with prominence ≥ 0.
    let cells = |t: &DivideTree| {
        let mut v: Vec<(u32, u32)> = t.peaks.iter().map(|p| (p.col, p.row)).collect();
        v.sort();
        v
    };
    // Every peak is found: the same peak regions as under Unknown (which
    // does not depend on the shift) ...
    assert_eq!(cells(&down), cells(&tree_everywhere(g, UNK, &[])));
    // ... and as above sea level, but for islands of valid cells with no
    // valid neighbour (in voids): above 0 they rise from the sea, below 0 the
    // sea is as high as they are, so they are not peaks (as a flat DEM).
    let down_cells = cells(&down);
    for p in &up.peaks {
        if down_cells.binary_search(&(p.col, p.row)).is_err() {
            assert!(p.key_saddle.is_none() && p.prominence == p.elevation as f64);
            let i = p.row as usize * g.width() + p.col as usize;
            assert!(neighbours(g.width(), g.height(), i)
                .flatten()
                .all(|n| g.data()[n].is_nan() || g.data()[n] == p.elevation));
        }
    }
    assert!(down.peaks.iter().all(|p| p.prominence >= 0.0));
    let at = |t: &DivideTree| {
        t.peaks
            .iter()
            .zip(shape(t))
            .map(|(p, sh)| ((p.col, p.row), sh))
            .collect::<std::collections::HashMap<_, _>>()
    };
    let up_at = at(&up);
    // The oracle: a key col, or the sea at the edge-touch level.
    let oracle: std::collections::HashMap<(u32, u32), (PeakRow, Key)> =
        bottleneck_oracle(s.data(), w, h, SEA)
            .into_iter()
            .map(|a| ((a.0 .0, a.0 .1), a))
            .collect();
    assert_eq!(oracle.len(), down.peaks.len());
    let (mut cols, mut islands) = (0, 0);
    for (p, sh) in down.peaks.iter().zip(shape(&down)) {
        let (row, key) = oracle[&(p.col, p.row)];
        assert_eq!(p.prominence, row.3, "peak ({}, {}) {key:?}", p.col, p.row);
        match p.key_saddle {
            // A real key col: the same col, parent and prominence as above
            // sea level. (The oracle may name the sea at the same level: a
            // col and an edge touch at one height.)
            Some(k) => {
                cols += 1;
                match key {
                    Key::Col(_) => {}
                    Key::Sea(l) => assert_eq!(l, down.saddles[k].elevation),
                    Key::Area(_) => panic!("no area key under SeaLevel"),
                }
                assert_eq!(sh, up_at[&(p.col, p.row)]);
            }
            // An island top: elevation − the level where it meets the edge.
            None => {
                islands += 1;
                let Key::Sea(l) = key else {
                    panic!("({}, {}): {key:?}", p.col, p.row)
                };
                assert_eq!(p.prominence, p.elevation as f64 - l as f64);
            }
        }
    }
    assert!(cols > 10 && islands > 10, "{cols} cols, {islands} islands");
    // The lifted DEM (all > 1000): the same tree as the original, which is
    // above 0 already, except island tops, which rise 1000 m more.
    let lifted = tree_everywhere(&shifted(g, 1000.0), SEA, tiles);
    assert_eq!(lifted.peaks.len(), up.peaks.len());
    for (a, b) in shape(&lifted).iter().zip(shape(&up)) {
        let d = if a.3.is_none() { 1000.0 } else { 0.0 };
        assert_eq!((a.0, a.1, a.2 - d, a.3, a.4), b);
    }
}

// ----------------------------------------------------------------- CLI ----

/// peaks.csv without the columns that depend on the elevation itself
/// (elevation, saddle elevation, dominance and its group, normalised
/// elevation, relevance).
fn csv_shape(path: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    let drop = [
        "elevation",
        "saddle_elevation",
        "dominance",
        "dominance_group",
        "normalised_elevation",
        "relevance",
    ];
    let keep: Vec<usize> = (0..head.len())
        .filter(|&i| !drop.contains(&head[i]))
        .collect();
    lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            keep.iter().map(|&i| f[i]).collect::<Vec<_>>().join(",")
        })
        .collect()
}

#[test]
fn cli_peaks_below_sea_level_unknown_edge() {
    let g = bigtujunga();
    let dir = tempfile::tempdir().unwrap();
    let dz = -(dem_max(&g) + 1.0) as f64;
    let write = |name: &str, dz: f64| {
        let p = dir.path().join(name);
        write_esri_ascii(&p, (g.width(), g.height()), (0.0, 0.0, 30.0), |x, y| {
            Some(g.get(x, y) as f64 + dz)
        });
        p
    };
    let run = |dem: &Path, name: &str, edge: &str| {
        let out = dir.path().join(name);
        ok(orogen()
            .arg("peaks")
            .arg(dem)
            .args(["--min-prominence", "20", "--edge", edge, "-q", "-o"])
            .arg(&out));
        out.join("peaks.csv")
    };
    let (a, b) = (write("up.asc", 0.0), write("down.asc", dz));
    let up = csv_shape(&run(&a, "up", "unknown"));
    let down = csv_shape(&run(&b, "down", "unknown"));
    assert!(up.len() > 20, "{} peaks ≥ 20 m", up.len());
    assert_eq!(down, up);
    // Under sea-level every peak of the lowered DEM keeps prominence ≥ 0,
    // and the peaks ≥ 20 m there are those of the in-memory tree.
    let sea = run(&b, "down_sea", "sea-level");
    let text = std::fs::read_to_string(&sea).unwrap();
    let n = text.lines().count() - 1;
    let want = oro::divide_tree(&shifted(&g, dz as f32), SEA)
        .unwrap()
        .pruned(20.0);
    assert_eq!(n, want.peaks.len());
    let lowered = shifted(&g, dz as f32);
    let by_oracle = bottleneck_oracle(lowered.data(), g.width(), g.height(), SEA)
        .iter()
        .filter(|a| a.0 .3 >= 20.0)
        .count();
    assert_eq!(n, by_oracle, "peaks ≥ 20 m: CLI vs oracle");
    // The crop's edge cuts through its mountains: most tops meet the sea
    // high up, at the edge, so fewer peaks reach 20 m than under unknown.
    assert!(n > 0 && n < up.len(), "{n} peaks ≥ 20 m");
}
