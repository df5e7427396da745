//! The region-growing fill (`hydro::fill`, Zhou, Sun & Fu 2016) against two
//! oracles: the Barnes et al. (2014) Priority-Flood it replaced
//! (`fill_reference`, bit for bit) and an independent brute-force minimax
//! relaxation written here; plus the no-pit invariant (every valid non-outlet
//! cell of the filled DEM has a neighbour not higher than itself, and no
//! cell is lowered).

use orogen::hydro::fill;
use orogen::hydro::fill::fill_reference;
use orogen::raster::Grid;
use proptest::prelude::*;

use crate::NB;

fn nbrs(w: usize, h: usize, x: usize, y: usize) -> impl Iterator<Item = Option<usize>> {
    NB.iter().map(move |&(dx, dy)| {
        let (nx, ny) = (x as i64 + dx, y as i64 + dy);
        if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
            None
        } else {
            Some(ny as usize * w + nx as usize)
        }
    })
}

fn is_outlet(z: &[f32], w: usize, h: usize, x: usize, y: usize) -> bool {
    z[y * w + x].is_finite() && nbrs(w, h, x, y).any(|n| n.is_none_or(|i| !z[i].is_finite()))
}

/// Minimax fill by relaxation in f64 until nothing changes: outlets keep
/// their height, every other valid cell takes max(z, min over neighbours).
fn brute(z: &[f32], w: usize, h: usize) -> Vec<f32> {
    let mut f: Vec<f64> = (0..z.len())
        .map(|i| {
            let (x, y) = (i % w, i / w);
            if !z[i].is_finite() {
                f64::NAN
            } else if is_outlet(z, w, h, x, y) {
                z[i] as f64
            } else {
                f64::INFINITY
            }
        })
        .collect();
    loop {
        let mut changed = false;
        for i in 0..z.len() {
            let (x, y) = (i % w, i / w);
            if !z[i].is_finite() || is_outlet(z, w, h, x, y) {
                continue;
            }
            let m = nbrs(w, h, x, y)
                .flatten()
                .filter(|&n| z[n].is_finite())
                .map(|n| f[n])
                .fold(f64::INFINITY, f64::min);
            let v = (z[i] as f64).max(m);
            if v < f[i] {
                f[i] = v;
                changed = true;
            }
        }
        if !changed {
            break;
        }
    }
    f.into_iter().map(|v| v as f32).collect()
}

/// The bits of every cell, with -0 written as +0: where -0 and +0 cells meet,
/// which zero a filled cell carries depends on flood order (in both floods);
/// every other value must match bit for bit.
fn bits(g: &Grid<f32>) -> Vec<u32> {
    g.data()
        .iter()
        .map(|&v| if v == 0.0 { 0 } else { v.to_bits() })
        .collect()
}

/// Grids with plateaus (few distinct levels), negative heights, NaN holes
/// and ±∞ cells (also nodata).
fn grid(max: usize) -> impl Strategy<Value = Grid<f32>> {
    (1..max, 1..max).prop_flat_map(|(w, h)| {
        prop::collection::vec(
            prop_oneof![
                8 => (-4i32..6).prop_map(|v| v as f32 * 0.5),
                2 => -1000.0f32..1000.0,
                1 => Just(f32::NAN),
                1 => prop_oneof![Just(f32::INFINITY), Just(f32::NEG_INFINITY), Just(-0.0f32)],
            ],
            w * h,
        )
        .prop_map(move |v| Grid::from_vec(w, h, v).unwrap())
    })
}

/// A bowl-shaped terrain of `w` x `h` with random bumps: big nested
/// depressions, long slopes (the region-growing case), plateaus.
fn terrain(max: usize) -> impl Strategy<Value = Grid<f32>> {
    (3..max, 3..max).prop_flat_map(|(w, h)| {
        prop::collection::vec(0u8..8, w * h).prop_map(move |bumps| {
            let (cx, cy) = (w as f32 / 2.0, h as f32 / 2.0);
            let v = (0..w * h)
                .map(|i| {
                    let (x, y) = ((i % w) as f32, (i / w) as f32);
                    let r = ((x - cx).powi(2) + (y - cy).powi(2)).sqrt();
                    // rim high, centre low, quantised so plateaus occur
                    let base = (r * 1.5).min(12.0).floor() - 3.0;
                    if bumps[i] == 7 && i % 5 == 0 {
                        f32::NAN
                    } else {
                        base + (bumps[i] % 4) as f32
                    }
                })
                .collect();
            Grid::from_vec(w, h, v).unwrap()
        })
    })
}

fn check_no_pit(d: &Grid<f32>, f: &Grid<f32>) {
    let (w, h) = (d.width(), d.height());
    let (z, fz) = (d.data(), f.data());
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            if !z[i].is_finite() {
                assert!(fz[i].is_nan(), "nodata must stay NaN at ({x},{y})");
                continue;
            }
            assert!(fz[i] >= z[i], "lowered at ({x},{y})");
            if is_outlet(z, w, h, x, y) {
                assert_eq!(
                    fz[i].to_bits(),
                    z[i].to_bits(),
                    "outlet changed at ({x},{y})"
                );
                continue;
            }
            assert!(
                nbrs(w, h, x, y)
                    .flatten()
                    .any(|n| fz[n].is_finite() && fz[n] <= fz[i]),
                "pit at ({x},{y})"
            );
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]

    #[test]
    fn equals_reference_and_brute_force(d in grid(14)) {
        let f = fill(&d).unwrap();
        prop_assert_eq!(bits(&f), bits(&fill_reference(&d).unwrap()));
        let b = brute(d.data(), d.width(), d.height());
        for (i, (&a, &e)) in f.data().iter().zip(&b).enumerate() {
            // by value: the relaxation's min cannot tell -0 from +0
            prop_assert!(a == e || (a.is_nan() && e.is_nan()),
                "cell {} fill {} brute {}", i, a, e);
        }
        check_no_pit(&d, &f);
    }

    #[test]
    fn equals_reference_on_terrain(d in terrain(60)) {
        let f = fill(&d).unwrap();
        prop_assert_eq!(bits(&f), bits(&fill_reference(&d).unwrap()));
        check_no_pit(&d, &f);
    }
}

#[test]
fn nested_depressions_known_values() {
    // a ring at 9 with an inner ring at 5 around a pit at 1; outside, a
    // slope rising from the west edge (0) to the ring: region growing
    #[rustfmt::skip]
    let v = [
        0.0, 2.0, 9.0, 9.0, 9.0, 9.0, 9.0,
        0.0, 2.0, 9.0, 3.0, 3.0, 3.0, 9.0,
        0.0, 2.0, 9.0, 3.0, 1.0, 5.0, 7.0,
        0.0, 2.0, 9.0, 3.0, 3.0, 3.0, 9.0,
        0.0, 2.0, 9.0, 9.0, 9.0, 9.0, 9.0f32,
    ];
    let d = Grid::from_vec(7, 5, v.to_vec()).unwrap();
    let f = fill(&d).unwrap();
    // the basin spills east over the 5 and the 7 on the edge: level 7
    for (x, y) in [
        (3, 1),
        (4, 1),
        (5, 1),
        (3, 2),
        (4, 2),
        (5, 2),
        (3, 3),
        (4, 3),
        (5, 3),
    ] {
        assert_eq!(f.get(x, y), 7.0, "({x},{y})");
    }
    assert_eq!(f.get(6, 2), 7.0);
    assert_eq!(f.get(1, 2), 2.0);
    assert_eq!(f.get(2, 2), 9.0);
}

#[test]
fn empty_and_single_row_grids() {
    let d = Grid::from_vec(5, 1, vec![3.0, 1.0, f32::NAN, 0.0, 2.0]).unwrap();
    let f = fill(&d).unwrap();
    assert_eq!(&f.data()[..2], &[3.0, 1.0]);
    assert!(f.data()[2].is_nan());
    assert_eq!(&f.data()[3..], &[0.0, 2.0]);
}
