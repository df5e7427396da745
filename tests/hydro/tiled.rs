//! Tiled global passes == in-memory results, bit for bit, with a sequential
//! driver doing exactly what an engine does (map every tile -> reduce ->
//! slice -> apply every tile), summaries and slices round-tripped through
//! JSON as a distributed engine would ship them.

use orogen::exec::GlobalStep;
use orogen::hydro::flow::outlet_labels;
use orogen::hydro::tiled::{TiledAccumulation, TiledD8, TiledEpsilon, TiledFill, TiledLabels};
use orogen::hydro::{
    accumulate, accumulate_weighted, d8_directions, fill, fill_epsilon, watershed_labels,
    NODATA_DIR,
};
use orogen::raster::{
    read_view, Cell, GeoRef, Grid, IntoAny, MemRaster, RasterSource, TileLayout, TileView,
};
use proptest::prelude::*;

use crate::common::hydro::read_raw;
use crate::NB;
use std::time::Instant;

fn run_global<S>(step: &S, srcs: &[&dyn RasterSource], tile: usize) -> orogen::Result<Grid<S::Out>>
where
    S: GlobalStep<In = f32>,
    S::Out: Cell,
{
    let info = srcs[0].info();
    let layout = TileLayout::new(info.width, info.height, tile);
    let views = |id| -> orogen::Result<Vec<TileView<f32>>> {
        srcs.iter()
            .map(|s| read_view::<f32>(*s, &layout, id, step.halo()))
            .collect()
    };
    let mut sums = Vec::with_capacity(layout.count());
    for id in 0..layout.count() {
        let s = step.map(&views(id)?)?;
        let json = serde_json::to_string(&s).expect("summary serialises");
        sums.push(serde_json::from_str(&json).expect("summary deserialises"));
    }
    let sol = step.reduce(&layout, sums)?;
    let mut out = Grid::new(info.width, info.height, S::Out::from_f64(f64::NAN));
    for id in 0..layout.count() {
        let slice = step.slice(&sol, id);
        let json = serde_json::to_string(&slice).expect("slice serialises");
        let slice = serde_json::from_str(&json).expect("slice deserialises");
        let core = layout.window(id);
        let mut o = vec![Grid::new(core.w, core.h, S::Out::from_f64(f64::NAN))];
        step.apply(&views(id)?, &slice, &mut o)?;
        out.paste(&o[0], core.x, core.y);
    }
    Ok(out)
}

fn mem<T: IntoAny>(g: &Grid<T>, nodata: Option<f64>) -> MemRaster {
    MemRaster::from_grid(g.clone(), GeoRef::pixel().with_nodata(nodata))
}

fn bits32(g: &Grid<f32>) -> Vec<u32> {
    g.data()
        .iter()
        .map(|v| if v.is_nan() { u32::MAX } else { v.to_bits() })
        .collect()
}

fn bits64(g: &Grid<f64>) -> Vec<u64> {
    g.data()
        .iter()
        .map(|v| if v.is_nan() { u64::MAX } else { v.to_bits() })
        .collect()
}

/// The next f32 above `z` by bit manipulation (the test's own oracle).
fn up(z: f32) -> f32 {
    if z == 0.0 {
        f32::from_bits(1)
    } else if z > 0.0 {
        f32::from_bits(z.to_bits() + 1)
    } else {
        f32::from_bits(z.to_bits() - 1)
    }
}

fn cell_ok(g: &Grid<f32>, x: i64, y: i64) -> bool {
    x >= 0
        && y >= 0
        && (x as usize) < g.width()
        && (y as usize) < g.height()
        && g.get(x as usize, y as usize).is_finite()
}

fn is_outlet(g: &Grid<f32>, x: usize, y: usize) -> bool {
    NB.iter()
        .any(|&(dx, dy)| !cell_ok(g, x as i64 + dx, y as i64 + dy))
}

/// Brute-force epsilon surface of a filled DEM `f`, straight from the
/// definition: k = shortest 8-connected path length, through cells of the
/// same level that have no lower neighbour and are not outlets, to a cell of
/// that level that has one (or is an outlet); level raised k times by one ULP.
fn brute_epsilon(f: &Grid<f32>) -> Grid<f32> {
    let (w, h) = (f.width(), f.height());
    let drains = |x: usize, y: usize| -> bool {
        is_outlet(f, x, y)
            || NB.iter().any(|&(dx, dy)| {
                let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                cell_ok(f, nx, ny) && f.get(nx as usize, ny as usize) < f.get(x, y)
            })
    };
    let mut k = vec![u32::MAX; w * h];
    for y in 0..h {
        for x in 0..w {
            if f.get(x, y).is_finite() && drains(x, y) {
                k[y * w + x] = 0;
            }
        }
    }
    // Bellman-Ford relaxation until stable
    loop {
        let mut changed = false;
        for y in 0..h {
            for x in 0..w {
                if !f.get(x, y).is_finite() || k[y * w + x] == 0 {
                    continue;
                }
                for &(dx, dy) in &NB {
                    let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                    if !cell_ok(f, nx, ny) {
                        continue;
                    }
                    let (nx, ny) = (nx as usize, ny as usize);
                    let kn = k[ny * w + nx];
                    if f.get(nx, ny) == f.get(x, y) && kn != u32::MAX && kn + 1 < k[y * w + x] {
                        k[y * w + x] = kn + 1;
                        changed = true;
                    }
                }
            }
        }
        if !changed {
            break;
        }
    }
    Grid::from_fn(w, h, |x, y| {
        let mut z = f.get(x, y);
        if !z.is_finite() {
            return f32::NAN;
        }
        for _ in 0..k[y * w + x] {
            z = up(z);
        }
        z
    })
}

/// Brute-force labels: walk each cell's D8 path to its end.
fn brute_labels(d: &Grid<u8>) -> Vec<u32> {
    let (w, h) = (d.width(), d.height());
    let mut out = vec![0u32; w * h];
    for y0 in 0..h {
        for x0 in 0..w {
            if d.get(x0, y0) == NODATA_DIR {
                continue;
            }
            let (mut x, mut y) = (x0, y0);
            for _ in 0..=w * h {
                let code = d.get(x, y);
                if code == 0 {
                    break;
                }
                let (dx, dy) = NB[code.trailing_zeros() as usize];
                let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                if nx < 0
                    || ny < 0
                    || nx >= w as i64
                    || ny >= h as i64
                    || d.get(nx as usize, ny as usize) == NODATA_DIR
                {
                    break;
                }
                x = nx as usize;
                y = ny as usize;
            }
            out[y0 * w + x0] = (y * w + x) as u32 + 1;
        }
    }
    out
}

/// Check fill, epsilon fill, labels, D8 and (weighted) accumulation, tiled
/// vs in memory, for `tiles`.
fn check_all(g: &Grid<f32>, tiles: &[usize]) -> Result<(), TestCaseError> {
    let (w, h) = (g.width(), g.height());
    let want_fill = fill(g).unwrap();
    let dirs = d8_directions(&want_fill);
    // epsilon fill: the definition, and strict drainage
    let want_eps = fill_epsilon(g);
    let brute = brute_epsilon(&want_fill);
    let strict = (0..h).all(|y| {
        (0..w).all(|x| {
            let e = brute.get(x, y);
            !e.is_finite()
                || is_outlet(g, x, y)
                || NB.iter().any(|&(dx, dy)| {
                    let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                    cell_ok(g, nx, ny) && brute.get(nx as usize, ny as usize) < e
                })
        })
    });
    match &want_eps {
        Ok(e) => {
            prop_assert!(strict, "the definition drains strictly when no error");
            prop_assert_eq!(bits32(e), bits32(&brute), "epsilon = definition");
        }
        Err(_) => prop_assert!(
            !strict,
            "epsilon errs only when the definition does not drain"
        ),
    }
    // labels: path walking, and watershed_labels on the DEM
    let want_lab = outlet_labels(&dirs).unwrap();
    prop_assert_eq!(
        want_lab.data(),
        &brute_labels(&dirs)[..],
        "labels = path walk"
    );
    let (ws, _) = watershed_labels(g).unwrap();
    prop_assert_eq!(ws.data(), want_lab.data());
    let counts = accumulate(&dirs).expect("acyclic");
    let want_acc = Grid::from_fn(w, h, |x, y| {
        if dirs.get(x, y) == NODATA_DIR {
            f64::NAN
        } else {
            counts.get(x, y) as f64
        }
    });
    let wts = Grid::from_fn(w, h, |x, y| ((x * 31 + y * 17) % 13) as f32 * 0.37 - 1.5);
    let want_wacc = accumulate_weighted(&dirs, &wts).expect("acyclic");
    let src = mem(g, None);
    let fsrc = mem(&want_fill, None);
    let raw_dirs = d8_directions(g);
    let dsrc = mem(&dirs, Some(NODATA_DIR as f64));
    let wsrc = mem(&wts, None);
    for &t in tiles {
        let got = run_global(&TiledFill, &[&src], t).expect("tiled fill");
        prop_assert_eq!(bits32(&got), bits32(&want_fill), "fill, tile {}", t);
        let got = run_global(&TiledD8, &[&fsrc], t).expect("tiled d8");
        prop_assert_eq!(got.data(), dirs.data(), "d8 on the filled DEM, tile {}", t);
        let got = run_global(&TiledEpsilon, &[&fsrc], t);
        match (&got, &want_eps) {
            (Ok(a), Ok(b)) => prop_assert_eq!(bits32(a), bits32(b), "epsilon, tile {}", t),
            (Err(_), Err(_)) => {}
            _ => prop_assert!(
                false,
                "epsilon: tiled {:?} vs in memory {:?}",
                got.is_ok(),
                want_eps.is_ok()
            ),
        }
        let got = run_global(&TiledLabels, &[&dsrc], t).expect("tiled labels");
        prop_assert_eq!(got.data(), want_lab.data(), "labels, tile {}", t);
        let got = run_global(&TiledD8, &[&src], t).expect("tiled d8");
        prop_assert_eq!(
            got.data(),
            raw_dirs.data(),
            "d8 on the unfilled DEM, tile {}",
            t
        );
        let got = run_global(
            &TiledAccumulation {
                weighted: false,
                sca: false,
            },
            &[&dsrc],
            t,
        )
        .expect("tiled accumulation");
        prop_assert_eq!(bits64(&got), bits64(&want_acc), "accumulation, tile {}", t);
        let got = run_global(
            &TiledAccumulation {
                weighted: true,
                sca: false,
            },
            &[&dsrc, &wsrc],
            t,
        )
        .expect("tiled weighted accumulation");
        prop_assert_eq!(
            bits64(&got),
            bits64(&want_wacc),
            "weighted accumulation, tile {}",
            t
        );
    }
    Ok(())
}

/// Random DEMs up to 19 x 19.
fn dem() -> impl Strategy<Value = Grid<f32>> {
    crate::common::hydro::dem(20)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 120, .. ProptestConfig::default() })]

    #[test]
    fn tiled_equals_untiled(g in dem()) {
        let whole = g.width().max(g.height());
        check_all(&g, &[1, 2, 3, 7, 16, whole])?;
    }
}

#[test]
fn depression_spanning_many_tiles() {
    // a big bowl whose rim is cut by one channel at height 7 towards the west
    // edge: its fill level is decided far from most tiles.
    let (w, h) = (41, 33);
    let g = Grid::from_fn(w, h, |x, y| {
        let dx = x as f32 - 20.0;
        let dy = y as f32 - 16.0;
        let r = (dx * dx + dy * dy).sqrt();
        if x <= 7 && y == 16 {
            7.0
        } else if r > 14.0 {
            30.0 - (r - 14.0)
        } else {
            r * 0.5
        }
    });
    check_all(&g, &[1, 3, 5, 7, 16, 40]).unwrap();
    let f = fill(&g).unwrap();
    assert_eq!(f.get(20, 16), 7.0, "the bowl fills to the notch");
}

#[test]
fn all_nodata_and_constant_grids() {
    check_all(&Grid::new(9, 6, f32::NAN), &[1, 4, 9]).unwrap();
    check_all(&Grid::new(13, 11, 5.0), &[1, 3, 7, 13]).unwrap();
}

#[test]
fn real_dems_tiled_equal_untiled() {
    // whitebox_DEM is already depressionless (a conditioned test DEM);
    // pysheds_dem (integer metres, low relief) has no depressions but many flats
    for (name, w, h, nodata, pits, flats) in [
        ("bigtujunga_crop.f32", 301, 203, 32767.0, true, true),
        ("whitebox_DEM.f32", 237, 188, -32768.0, false, false),
        ("pysheds_dem.f32", 367, 359, -32768.0, false, true),
    ] {
        let g = read_raw(name, w, h, nodata);
        let t0 = Instant::now();
        let f = fill(&g).unwrap();
        let t_fill = t0.elapsed();
        let raised = f
            .data()
            .iter()
            .zip(g.data())
            .filter(|(a, b)| a != b && !a.is_nan())
            .count();
        assert_eq!(raised > 0, pits, "{name}: {raised} cells raised");
        // interior cells of the filled DEM without a lower neighbour: the
        // flats that the tiled D8 has to resolve across tiles
        let flat = (1..h - 1)
            .flat_map(|y| (1..w - 1).map(move |x| (x, y)))
            .filter(|&(x, y)| {
                let zc = f.get(x, y);
                (0..9).all(|k| {
                    let v = f.get(x + k % 3 - 1, y + k / 3 - 1);
                    v.is_finite() && v >= zc
                })
            })
            .count();
        assert_eq!(flat > 0, flats, "{name}: {flat} flat cells");
        check_all(&g, &[37, 64, 100, 256]).unwrap();
        eprintln!("{name}: {w}x{h}, fill {t_fill:?}, {raised} cells raised, {flat} flat cells");
    }
}

#[test]
fn one_flat_lake_across_many_whole_tiles() {
    // a walled square lake at one height with a single exit on the west
    // edge, and an island: the flat covers whole tiles (open tiles) and its
    // distances wrap around the island across tile edges.
    let (w, h) = (36, 30);
    let g = Grid::from_fn(w, h, |x, y| {
        let wall = x == 0 || y == 0 || x == w - 1 || y == h - 1;
        let island = (14..20).contains(&x) && (8..22).contains(&y);
        if (x, y) == (0, 15) {
            5.0
        } else if wall || island {
            50.0
        } else {
            5.0
        }
    });
    check_all(&g, &[1, 4, 5, 6, 9, 12, 36]).unwrap();
}

#[test]
fn bad_directions_and_summaries_are_errors() {
    let step = TiledAccumulation {
        weighted: false,
        sca: false,
    };
    // a cycle across two tiles: E then W
    let d = Grid::from_vec(2, 1, vec![1.0f32, 16.0]).unwrap();
    let src = mem(&d, None);
    assert!(run_global(&step, &[&src], 1).is_err());
    assert!(run_global(&step, &[&src], 2).is_err());
    // a value that is no D8 code
    let d = Grid::from_vec(3, 1, vec![1.0f32, 3.0, 0.0]).unwrap();
    assert!(run_global(&step, &[&mem(&d, None)], 1).is_err());
    // the weighted step without weights
    let d = Grid::from_vec(2, 1, vec![1.0f32, 1.0]).unwrap();
    assert!(run_global(
        &TiledAccumulation {
            weighted: true,
            sca: false
        },
        &[&mem(&d, None)],
        1
    )
    .is_err());
    // summaries that do not match the layout
    let layout = TileLayout::new(4, 4, 2);
    assert!(TiledFill.reduce(&layout, Vec::new()).is_err());
    assert!(step.reduce(&layout, Vec::new()).is_err());
    assert!(TiledD8.reduce(&layout, Vec::new()).is_err());
    let g = Grid::new(4, 4, 1.0f32);
    let gsrc = mem(&g, None);
    let mut sums: Vec<_> = (0..4)
        .map(|id| {
            TiledFill
                .map(&[read_view::<f32>(&gsrc, &layout, id, 1).unwrap()])
                .unwrap()
        })
        .collect();
    sums[2].perimeter[0].0 = 99; // a label the tile does not have
    assert!(TiledFill.reduce(&layout, sums).is_err());
}

/// Larger grids made of plateaus (blocks of equal height), negative
/// elevations and NaN holes: flats that cross tiles of 7, 37 and 100.
fn plateau_dem() -> impl Strategy<Value = Grid<f32>> {
    (20usize..90, 20usize..80, 3usize..12).prop_flat_map(|(w, h, b)| {
        let bw = w.div_ceil(b);
        let bh = h.div_ceil(b);
        let block = prop_oneof![
            10 => (-3i32..4).prop_map(|v| v as f32 * 10.0),
            1 => Just(f32::NAN),
        ];
        (
            proptest::collection::vec(block, bw * bh),
            proptest::collection::vec((0usize..w * h, -2i32..3), 0..20),
        )
            .prop_map(move |(blocks, bumps)| {
                let mut g = Grid::from_fn(w, h, |x, y| blocks[(y / b) * bw + x / b]);
                for (i, dz) in bumps {
                    let v = g.data()[i];
                    g.data_mut()[i] = v + dz as f32;
                }
                g
            })
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 16, .. ProptestConfig::default() })]

    #[test]
    fn plateaus_across_odd_tiles(g in plateau_dem()) {
        check_all(&g, &[7, 37, 100])?;
    }
}

#[test]
fn nodata_tiles_and_hole_outlets() {
    // left third all nodata (whole tiles of 7 and 9 are empty), the rest a
    // bowl whose only outlets are the nodata region and one interior hole
    let (w, h) = (45, 30);
    let g = Grid::from_fn(w, h, |x, y| {
        if x < 15 || (x, y) == (32, 14) {
            f32::NAN
        } else {
            let dx = x as f32 - 32.0;
            let dy = y as f32 - 14.0;
            -50.0 + (dx * dx + dy * dy).sqrt().floor()
        }
    });
    check_all(&g, &[7, 9, 16, 45]).unwrap();
    // a clipped island: nodata border, a pit, outlets only at the border
    let g = Grid::from_fn(24, 21, |x, y| {
        if x == 0 || y == 0 || x == 23 || y == 20 {
            f32::NAN
        } else if (x, y) == (6, 6) {
            1.0
        } else {
            5.0
        }
    });
    check_all(&g, &[1, 5, 7, 24]).unwrap();
}

#[test]
fn constant_dem_labels_each_cell_by_its_edge_exit() {
    let g = Grid::new(15, 11, 3.0f32);
    check_all(&g, &[4, 7]).unwrap();
    let dirs = d8_directions(&fill(&g).unwrap());
    let labels = outlet_labels(&dirs).unwrap();
    // every label is an edge cell's index + 1
    for &l in labels.data() {
        let i = l as usize - 1;
        let (x, y) = (i % 15, i / 15);
        assert!(x == 0 || y == 0 || x == 14 || y == 10, "({x},{y})");
    }
}

#[test]
fn epsilon_errors_agree_tiled_and_in_memory() {
    // unfilled input (a pit): the tiled epsilon step refuses it
    let mut v = vec![5.0f32; 25];
    v[12] = 1.0;
    let pit = Grid::from_vec(5, 5, v).unwrap();
    for t in [2, 5] {
        assert!(run_global(&TiledEpsilon, &[&mem(&pit, None)], t).is_err());
    }
    // a flat too wide for the step above it: both refuse
    let up = |z: f32| f32::from_bits(z.to_bits() + 1);
    let w = 8;
    let mut v = vec![9.0f32; w * 3];
    v[w] = 0.5;
    for x in 1..6 {
        v[w + x] = 1.0;
    }
    v[w + 6] = up(up(1.0));
    let g = Grid::from_vec(w, 3, v).unwrap();
    assert!(fill_epsilon(&g).is_err());
    for t in [1, 2, 3, 8] {
        assert!(run_global(&TiledEpsilon, &[&mem(&g, None)], t).is_err());
    }
}

#[test]
fn bad_label_inputs_are_errors() {
    // a cycle across two tiles, a value that is no D8 code
    let d = Grid::from_vec(2, 1, vec![1.0f32, 16.0]).unwrap();
    for t in [1, 2] {
        assert!(run_global(&TiledLabels, &[&mem(&d, None)], t).is_err());
    }
    let d = Grid::from_vec(3, 1, vec![1.0f32, 3.0, 0.0]).unwrap();
    assert!(run_global(&TiledLabels, &[&mem(&d, None)], 1).is_err());
    let layout = TileLayout::new(4, 4, 2);
    assert!(TiledLabels.reduce(&layout, Vec::new()).is_err());
    assert!(TiledEpsilon.reduce(&layout, Vec::new()).is_err());
    // a flats summary with runs outside its tile
    let g = Grid::new(4, 4, 1.0f32);
    let src = mem(&g, None);
    let mut sums: Vec<_> = (0..4)
        .map(|id| {
            TiledD8
                .map(&[read_view::<f32>(&src, &layout, id, 2).unwrap()])
                .unwrap()
        })
        .collect();
    sums[1].runs = vec![(3, 9)];
    assert!(TiledD8.reduce(&layout, sums).is_err());
}
