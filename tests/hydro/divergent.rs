//! D-infinity and MFD routing and accumulation against oracles that share no
//! code with `orogen::hydro::{dinf, mfd}`: closed forms on planes and cones,
//! hand-computed MFD weights, conservation of mass, and a naive recursive
//! propagation along every flow path.

// Direction indices are the point of these loops (they pair fractions with offsets).
#![allow(clippy::needless_range_loop)]

use orogen::hydro::dinf::{dinf, DINF_NO_FLOW};
use orogen::hydro::fill;
use orogen::hydro::mfd::{
    accumulate_cells, accumulate_fractions, mfd_flow, specific_catchment_area, FlowFractions,
    MfdMethod,
};
use orogen::raster::Grid;
use proptest::prelude::*;
use std::f64::consts::{FRAC_PI_4, PI, SQRT_2};

// Neighbour offsets in the crate's order E, SE, S, SW, W, NW, N, NE (the
// tests' own table, not the crate's).
use crate::NB as OFF;

fn nb(x: usize, y: usize, d: usize, w: usize, h: usize) -> Option<(usize, usize)> {
    let (nx, ny) = (x as i64 + OFF[d].0, y as i64 + OFF[d].1);
    (nx >= 0 && ny >= 0 && nx < w as i64 && ny < h as i64).then_some((nx as usize, ny as usize))
}

/// Direction index (crate order) of the compass angle `k·π/4` (ccw from east).
fn dir_of_angle_step(k: usize) -> usize {
    (8 - k % 8) % 8
}

#[test]
fn dinf_angle_on_a_plane_is_its_aspect() {
    // z = c + a·x + b·y with y growing south: the downslope vector is
    // (-a east, +b north), so the aspect is atan2(b, -a).
    let planes = [
        (-3.0, 1.0),
        (-1.0, 3.0),
        (1.0, 3.0),
        (3.0, 1.0),
        (3.0, -1.0),
        (1.0, -3.0),
        (-1.0, -3.0),
        (-3.0, -1.0),
        (-1.0, 0.0),
        (0.0, 2.0),
        (-2.0, 2.0),
        (5.0, 5.0),
        (0.5, -0.25),
    ];
    for &(a, b) in &planes {
        let g = Grid::from_fn(7, 7, |x, y| (100.0 + a * x as f64 + b * y as f64) as f32);
        let r = dinf(&g).unwrap();
        let mut aspect = f64::atan2(b, -a);
        if aspect < 0.0 {
            aspect += 2.0 * PI;
        }
        for y in 1..6 {
            for x in 1..6 {
                let got = r.angle.get(x, y) as f64;
                assert!(
                    (got - aspect).abs() < 1e-6,
                    "plane ({a},{b}) cell ({x},{y}): angle {got} vs aspect {aspect}"
                );
                // the split by angular proximity, computed from the aspect
                let k = (aspect / FRAC_PI_4).floor() as usize;
                let t = aspect / FRAC_PI_4 - k as f64;
                let mut want = [0.0f64; 8];
                want[dir_of_angle_step(k)] += 1.0 - t;
                want[dir_of_angle_step(k + 1)] += t;
                let f = r.flow.fractions(x, y).unwrap();
                for d in 0..8 {
                    assert!(
                        (f[d] - want[d]).abs() < 1e-9,
                        "plane ({a},{b}) ({x},{y}) dir {d}: {f:?} vs {want:?}"
                    );
                }
            }
        }
    }
}

/// D∞ by the paper's definition, written here: per cell the steepest of
/// Tarboton's 8 facets (first in his order on ties), the flow split between
/// the facet's two vertices by angle, then every cell's unit area passed
/// downslope in decreasing elevation. Only cells all of whose facets lie on
/// the grid are routed (the cone's interior); water of the others stays.
fn dinf_brute_accumulation(z: &Grid<f32>) -> Grid<f64> {
    // facets (e1, e2) in Tarboton's order, crate direction indices
    const F: [(usize, usize); 8] = [
        (0, 7),
        (6, 7),
        (6, 5),
        (4, 5),
        (4, 3),
        (2, 3),
        (2, 1),
        (0, 1),
    ];
    let (w, h) = (z.width(), z.height());
    let mut order: Vec<(usize, usize)> = (0..h).flat_map(|y| (0..w).map(move |x| (x, y))).collect();
    order.sort_by(|a, b| z.get(b.0, b.1).total_cmp(&z.get(a.0, a.1)));
    let mut acc = Grid::from_fn(w, h, |_, _| 1.0f64);
    for (x, y) in order {
        if x == 0 || y == 0 || x + 1 == w || y + 1 == h {
            continue;
        }
        let e0 = z.get(x, y) as f64;
        let at = |d: usize| {
            let (nx, ny) = nb(x, y, d, w, h).unwrap();
            z.get(nx, ny) as f64
        };
        let mut best: Option<(f64, usize, f64)> = None;
        for (k, &(d1, d2)) in F.iter().enumerate() {
            let (s1, s2) = (e0 - at(d1), at(d1) - at(d2));
            let r = s2.atan2(s1);
            let (r, s) = if r <= 0.0 {
                (0.0, s1)
            } else if r >= FRAC_PI_4 {
                (FRAC_PI_4, (e0 - at(d2)) / SQRT_2)
            } else {
                (r, s1.hypot(s2))
            };
            if s > 0.0 && best.is_none_or(|b| s > b.0) {
                best = Some((s, k, r));
            }
        }
        let Some((_, k, r)) = best else { continue };
        let (d1, d2) = F[k];
        let a = acc.get(x, y);
        for (d, p) in [(d2, r / FRAC_PI_4), (d1, 1.0 - r / FRAC_PI_4)] {
            let (nx, ny) = nb(x, y, d, w, h).unwrap();
            let v = acc.get(nx, ny) + a * p;
            acc.set(nx, ny, v);
        }
    }
    acc
}

#[test]
fn dinf_specific_catchment_area_on_a_cone_is_r_over_2() {
    // Cone with its peak at the centre: radial divergent flow, so the area
    // upslope of a contour arc of width θ·r is θ·r²/2 and the specific
    // catchment area is r/2 (the test surface of Tarboton 1997, § 4).
    // The library's SCA must equal D∞ as the paper defines it, computed by
    // brute force here, on every cell of r <= 25 (whose upslope cells are
    // all interior), within the fixed-point rounding of the accumulation
    // (2^-32 of a cell per split). Against the continuous r/2, D∞ is off by
    // its discretisation: the mean signed relative error off the cardinal
    // axes is within ±0.1 (seen −0.07), and on the axes D∞ concentrates
    // flow (the axis cells' facets point exactly along the axis and receive
    // whole upstream columns), so there SCA >= r/2.
    let n = 61usize;
    let c = (n / 2) as f64;
    let g = Grid::from_fn(n, n, |x, y| {
        (100.0 - ((x as f64 - c).powi(2) + (y as f64 - c).powi(2)).sqrt()) as f32
    });
    let r = dinf(&g).unwrap();
    let sca = specific_catchment_area(&r.flow, 1.0).unwrap();
    let brute = dinf_brute_accumulation(&g);
    let mut sum_rel = 0.0;
    let mut count = 0;
    for y in 0..n {
        for x in 0..n {
            let (dx, dy) = (x as f64 - c, y as f64 - c);
            let rad = dx.hypot(dy);
            if rad > 25.0 {
                continue;
            }
            let got = sca.get(x, y);
            let exact = brute.get(x, y);
            assert!(
                (got - exact).abs() <= 1e-6 * exact.max(1.0),
                "cell ({x},{y}): sca {got} vs D∞ by hand {exact}"
            );
            if rad < 4.0 {
                continue;
            }
            let want = rad / 2.0;
            if dx.abs() <= 1.0 || dy.abs() <= 1.0 {
                if dx == 0.0 || dy == 0.0 {
                    assert!(got >= want, "axis cell ({x},{y}) r={rad:.2}: sca {got}");
                }
                continue;
            }
            sum_rel += (got - want) / want;
            count += 1;
        }
    }
    assert!(count > 1500, "{count}");
    let mean = sum_rel / count as f64;
    assert!(mean.abs() < 0.1, "mean relative error {mean}");
    // SCA is cells × cell size: scaling the cell size scales it linearly
    let sca10 = specific_catchment_area(&r.flow, 10.0).unwrap();
    assert!((sca10.get(40, 40) - 10.0 * sca.get(40, 40)).abs() < 1e-9);
    // and all the cone's water leaves through its edges
    let cells = accumulate_cells(&r.flow).unwrap();
    assert!((leaving(&r.flow, &cells) - (n * n) as f64).abs() < 1e-6);
}

#[test]
fn mfd_weights_on_a_plane_match_the_formulas() {
    // z = 100 − 2x − y: from any interior cell the lower neighbours are
    // E (drop 2, tan 2), SE (drop 3, tan 3/√2), S (drop 1, tan 1) and
    // NE (drop 1, tan 1/√2).
    let g = Grid::from_fn(5, 5, |x, y| (100.0 - 2.0 * x as f64 - y as f64) as f32);
    let tan = [2.0, 3.0 / SQRT_2, 1.0, 1.0 / SQRT_2];
    let dirs = [0usize, 1, 2, 7];
    // Quinn: tan·L = 1, 0.75, 0.5, 0.25 → / 2.5
    let quinn = [0.4, 0.3, 0.2, 0.1];
    // Holmgren h = 2: tan² = 4, 4.5, 1, 0.5 → / 10
    let holm = [0.4, 0.45, 0.1, 0.05];
    let fw: Vec<f64> = tan.iter().map(|t: &f64| t.powf(1.1)).collect();
    let fs: f64 = fw.iter().sum();
    let freeman: Vec<f64> = fw.iter().map(|v| v / fs).collect();
    for (method, want) in [
        (MfdMethod::Quinn, quinn.to_vec()),
        (MfdMethod::Holmgren(2.0), holm.to_vec()),
        (MfdMethod::Freeman, freeman),
        // Holmgren with h = 1.1 is Freeman
        (MfdMethod::Holmgren(1.1), {
            let s: f64 = tan.iter().map(|t| t.powf(1.1)).sum();
            tan.iter().map(|t| t.powf(1.1) / s).collect()
        }),
    ] {
        let f = mfd_flow(&g, method).unwrap();
        for y in 1..4 {
            for x in 1..4 {
                let fr = f.fractions(x, y).unwrap();
                let mut full = [0.0; 8];
                for (i, &d) in dirs.iter().enumerate() {
                    full[d] = want[i];
                }
                for d in 0..8 {
                    assert!(
                        (fr[d] - full[d]).abs() < 1e-12,
                        "{method:?} ({x},{y}) dir {d}: {fr:?} vs {full:?}"
                    );
                }
            }
        }
    }
}

#[test]
fn pits_keep_no_flow_and_flats_drain() {
    // an unfilled pit in the middle: no flow, D∞ angle −1
    let mut z = vec![5.0f32; 25];
    z[12] = 1.0;
    let g = Grid::from_vec(5, 5, z).unwrap();
    let r = dinf(&g).unwrap();
    assert_eq!(r.angle.get(2, 2), DINF_NO_FLOW);
    assert!(!r.flow.has_flow(2, 2));
    let m = mfd_flow(&g, MfdMethod::Quinn).unwrap();
    assert!(!m.has_flow(2, 2));
    // the same DEM filled is one flat draining off its edges: every cell flows
    let f = fill(&g).unwrap();
    for flow in [
        dinf(&f).unwrap().flow,
        mfd_flow(&f, MfdMethod::Freeman).unwrap(),
    ] {
        for y in 0..5 {
            for x in 0..5 {
                assert!(flow.has_flow(x, y), "({x},{y})");
            }
        }
        let acc = accumulate_cells(&flow).unwrap();
        let total = leaving(&flow, &acc);
        assert!((total - 25.0).abs() < 1e-9, "{total}");
    }
}

/// Water leaving the grid: each cell's accumulation times its fractions
/// towards nodata or off-grid neighbours.
fn leaving(flow: &FlowFractions, acc: &Grid<f64>) -> f64 {
    let (w, h) = (flow.width(), flow.height());
    let mut out = 0.0;
    for y in 0..h {
        for x in 0..w {
            let Some(f) = flow.fractions(x, y) else {
                continue;
            };
            for d in 0..8 {
                let off = match nb(x, y, d, w, h) {
                    None => true,
                    Some((nx, ny)) => flow.fractions(nx, ny).is_none(),
                };
                if off {
                    out += acc.get(x, y) * f[d];
                }
            }
        }
    }
    out
}

fn routers(dem: &Grid<f32>) -> Vec<(&'static str, FlowFractions)> {
    vec![
        ("dinf", dinf(dem).unwrap().flow),
        ("quinn", mfd_flow(dem, MfdMethod::Quinn).unwrap()),
        (
            "holmgren4",
            mfd_flow(dem, MfdMethod::Holmgren(4.0)).unwrap(),
        ),
        ("freeman", mfd_flow(dem, MfdMethod::Freeman).unwrap()),
    ]
}

/// Random small DEM: integer-valued heights (many flats) with NaN holes.
fn dem_strategy(max: usize) -> impl Strategy<Value = Grid<f32>> {
    (2..=max, 2..=max).prop_flat_map(|(w, h)| {
        prop::collection::vec(
            prop_oneof![1 => Just(f32::NAN), 6 => (0u8..12).prop_map(|v| v as f32)],
            w * h,
        )
        .prop_map(move |v| Grid::from_vec(w, h, v).unwrap())
    })
}

/// Naive oracle: push every cell's weight down every path, recursively.
fn brute_force(flow: &FlowFractions, weights: &Grid<f32>) -> Vec<f64> {
    let (w, h) = (flow.width(), flow.height());
    let mut acc = vec![0.0f64; w * h];
    fn push(flow: &FlowFractions, x: usize, y: usize, amount: f64, acc: &mut [f64]) {
        let (w, h) = (flow.width(), flow.height());
        acc[y * w + x] += amount;
        let f = *flow.fractions(x, y).unwrap();
        for d in 0..8 {
            if f[d] > 0.0 {
                if let Some((nx, ny)) = nb(x, y, d, w, h) {
                    if flow.fractions(nx, ny).is_some() {
                        push(flow, nx, ny, amount * f[d], acc);
                    }
                }
            }
        }
    }
    for y in 0..h {
        for x in 0..w {
            if flow.fractions(x, y).is_some() {
                let v = weights.get(x, y);
                push(
                    flow,
                    x,
                    y,
                    if v.is_nan() { 0.0 } else { v as f64 },
                    &mut acc,
                );
            }
        }
    }
    acc
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(96))]

    #[test]
    fn routing_conserves_water_and_goes_downhill(
        dem in dem_strategy(12),
        seed in 0u32..1000,
    ) {
        let filled = fill(&dem).unwrap();
        let (w, h) = (dem.width(), dem.height());
        let weights = Grid::from_fn(w, h, |x, y| {
            (((x * 7 + y * 13) as u32 + seed) % 17) as f32 * 0.37 + 0.01
        });
        for (name, flow) in routers(&filled) {
            let mut total = 0.0f64;
            for y in 0..h {
                for x in 0..w {
                    let z = filled.get(x, y);
                    let f = flow.fractions(x, y);
                    prop_assert_eq!(f.is_none(), z.is_nan(), "{} ({},{})", name, x, y);
                    let Some(f) = f else { continue };
                    total += weights.get(x, y) as f64;
                    let s: f64 = f.iter().sum();
                    // a filled DEM drains everywhere
                    prop_assert!((s - 1.0).abs() < 1e-12, "{} ({},{}) sum {}", name, x, y, s);
                    for d in 0..8 {
                        prop_assert!((0.0..=1.0).contains(&f[d]), "{} {:?}", name, f);
                        if f[d] > 0.0 {
                            if let Some((nx, ny)) = nb(x, y, d, w, h) {
                                let zn = filled.get(nx, ny);
                                prop_assert!(zn.is_nan() || zn <= z,
                                    "{} uphill ({},{})->({},{})", name, x, y, nx, ny);
                            }
                        }
                    }
                }
            }
            let acc = accumulate_fractions(&flow, &weights).unwrap();
            let out = leaving(&flow, &acc);
            prop_assert!((out - total).abs() <= 1e-9 * total.max(1.0),
                "{}: leaving {} vs total {}", name, out, total);
        }
    }

    #[test]
    fn unfilled_pits_hold_what_does_not_leave(dem in dem_strategy(10)) {
        let (w, h) = (dem.width(), dem.height());
        for (name, flow) in routers(&dem) {
            let acc = accumulate_cells(&flow).unwrap();
            let mut total = 0.0;
            let mut held = 0.0;
            for y in 0..h {
                for x in 0..w {
                    if let Some(f) = flow.fractions(x, y) {
                        total += 1.0;
                        let s: f64 = f.iter().sum();
                        if s == 0.0 {
                            held += acc.get(x, y);
                        } else {
                            prop_assert!((s - 1.0).abs() < 1e-12);
                        }
                    }
                }
            }
            let out = leaving(&flow, &acc);
            prop_assert!((out + held - total).abs() <= 1e-9 * total.max(1.0),
                "{}: leaving {} + held {} vs {}", name, out, held, total);
        }
    }

    #[test]
    fn accumulation_equals_naive_path_sums(dem in dem_strategy(6), seed in 0u32..100) {
        let filled = fill(&dem).unwrap();
        let (w, h) = (dem.width(), dem.height());
        let weights = Grid::from_fn(w, h, |x, y| {
            if (x + y + seed as usize).is_multiple_of(5) { f32::NAN } else { (x + 2 * y) as f32 * 0.5 + 1.0 }
        });
        for (name, flow) in routers(&filled) {
            let acc = accumulate_fractions(&flow, &weights).unwrap();
            let want = brute_force(&flow, &weights);
            // Accumulation is exact fixed point (2^-32 units) with each split
            // rounded (shares q = round(f·2^32)): every split of an amount a
            // errs by at most 8·(|a|·2^-30 + 2^-32) in total, so over n cells
            // of total |weight| T the error is below n·(T + 1)·2^-27.
            let n = (w * h) as f64;
            let t: f64 = weights.data().iter().filter(|v| !v.is_nan()).map(|v| v.abs() as f64).sum();
            let tol = n * (t + 1.0) * 2f64.powi(-27);
            for y in 0..h {
                for x in 0..w {
                    let got = acc.get(x, y);
                    if filled.get(x, y).is_nan() {
                        prop_assert!(got.is_nan());
                    } else {
                        let e = want[y * w + x];
                        prop_assert!((got - e).abs() <= tol,
                            "{} ({},{}): {} vs {} (tolerance {})", name, x, y, got, e, tol);
                    }
                }
            }
        }
    }
}

#[test]
fn results_are_deterministic() {
    let g = Grid::from_fn(20, 15, |x, y| {
        ((x as f32 * 0.7).sin() * 3.0 + (y as f32 * 0.4).cos() * 2.0 + x as f32 * 0.1).round()
    });
    let f = fill(&g).unwrap();
    let a = accumulate_cells(&dinf(&f).unwrap().flow).unwrap();
    let b = accumulate_cells(&dinf(&f).unwrap().flow).unwrap();
    let ab: Vec<u64> = a.data().iter().map(|v| v.to_bits()).collect();
    let bb: Vec<u64> = b.data().iter().map(|v| v.to_bits()).collect();
    assert_eq!(ab, bb);
}
