//! Orometric analysis: line parents, relevance, dominance groups, NNI,
//! anti-prominence, statistics, the classifier and ridge networks, each
//! against an oracle written here independently (brute force, closed forms,
//! hand computations).

use orogen::oro::metrics::{self, Nni};
use orogen::oro::{self, EdgeConvention};
use orogen::raster::{GeoRef, Grid};
use std::collections::HashSet;

/// SplitMix64 (Steele, Lea & Flood 2014), independent of the crate's RNG.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// A grid of distinct heights (a random permutation of 1..=w*h).
fn distinct_grid(w: usize, h: usize, rng: &mut Rng) -> Grid<f32> {
    let mut v: Vec<f32> = (1..=w * h).map(|x| x as f32).collect();
    for i in (1..v.len()).rev() {
        let j = (rng.next() % (i as u64 + 1)) as usize;
        v.swap(i, j);
    }
    Grid::from_vec(w, h, v).unwrap()
}

fn nbrs(w: usize, h: usize, c: usize) -> Vec<usize> {
    let (x, y) = ((c % w) as i64, (c / w) as i64);
    let mut out = Vec::new();
    for dy in -1..=1i64 {
        for dx in -1..=1i64 {
            let (nx, ny) = (x + dx, y + dy);
            if (dx, dy) != (0, 0) && nx >= 0 && ny >= 0 && nx < w as i64 && ny < h as i64 {
                out.push(ny as usize * w + nx as usize);
            }
        }
    }
    out
}

/// Cells of the 8-connected component of {z > level} (or ≥ with `ge`) holding `seed`.
fn component(z: &[f32], w: usize, h: usize, seed: usize, level: f32, ge: bool) -> HashSet<usize> {
    let ok = |c: usize| if ge { z[c] >= level } else { z[c] > level };
    let mut seen = HashSet::new();
    if !ok(seed) {
        return seen;
    }
    let mut stack = vec![seed];
    seen.insert(seed);
    while let Some(c) = stack.pop() {
        for n in nbrs(w, h, c) {
            if ok(n) && seen.insert(n) {
                stack.push(n);
            }
        }
    }
    seen
}

/// Brute-force key saddle of a peak cell on a distinct-valued grid: the
/// highest level L whose superlevel component holds a higher cell.
fn brute_key_saddle(z: &[f32], w: usize, h: usize, p: usize) -> Option<usize> {
    let mut levels: Vec<usize> = (0..z.len()).filter(|&c| z[c] < z[p]).collect();
    levels.sort_by(|&a, &b| z[b].total_cmp(&z[a]));
    levels
        .into_iter()
        .find(|&s| component(z, w, h, p, z[s], true).iter().any(|&c| z[c] > z[p]))
}

fn brute_ascend(z: &[f32], w: usize, h: usize, mut c: usize) -> usize {
    loop {
        let best = nbrs(w, h, c)
            .into_iter()
            .max_by(|&a, &b| z[a].total_cmp(&z[b]))
            .unwrap();
        if z[best] > z[c] {
            c = best;
        } else {
            return c;
        }
    }
}

/// Brute-force line parent: cross the key saddle into the component holding
/// the highest cell among those the saddle joins, climb steepest, repeat
/// until a peak at least as high as the start with prominence ≥ min_prom.
fn brute_line_parent(z: &[f32], w: usize, h: usize, p: usize, min_prom: f32) -> Option<usize> {
    let mut cur = p;
    loop {
        let s = brute_key_saddle(z, w, h, cur)?;
        // Components of {z > z(s)} around the saddle; the winner holds the highest cell.
        let mut comps: Vec<HashSet<usize>> = Vec::new();
        for n in nbrs(w, h, s) {
            if z[n] > z[s] && !comps.iter().any(|c| c.contains(&n)) {
                comps.push(component(z, w, h, n, z[s], false));
            }
        }
        let top = |c: &HashSet<usize>| c.iter().map(|&i| z[i]).fold(f32::MIN, f32::max);
        let win = comps
            .iter()
            .max_by(|a, b| top(a).total_cmp(&top(b)))
            .unwrap();
        let entry = nbrs(w, h, s)
            .into_iter()
            .filter(|n| win.contains(n))
            .max_by(|&a, &b| z[a].total_cmp(&z[b]))
            .unwrap();
        let q = brute_ascend(z, w, h, entry);
        let prom_q = match brute_key_saddle(z, w, h, q) {
            Some(sq) => z[q] - z[sq],
            None => f32::INFINITY,
        };
        if z[q] >= z[p] && prom_q >= min_prom {
            return Some(q);
        }
        cur = q;
    }
}

#[test]
fn line_parent_matches_brute_force_on_random_grids() {
    let mut rng = Rng(7);
    let mut checked = 0;
    for case in 0..60 {
        let (w, h) = (5 + case % 5, 4 + case % 6);
        let g = distinct_grid(w, h, &mut rng);
        let z = g.data().to_vec();
        for min_prom in [0.0f32, 3.0, 10.0] {
            let tree = oro::divide_tree(&g, EdgeConvention::Unknown)
                .unwrap()
                .pruned(min_prom as f64);
            let lp = metrics::line_parents(&tree, &g).unwrap();
            for (i, p) in tree.peaks.iter().enumerate() {
                let c = p.row as usize * w + p.col as usize;
                let want = if p.key_saddle.is_some() {
                    brute_line_parent(&z, w, h, c, min_prom)
                } else {
                    None
                };
                let got = lp[i].map(|q| {
                    let q = &tree.peaks[q];
                    q.row as usize * w + q.col as usize
                });
                assert_eq!(got, want, "case {case} peak {i} at {c}, min prominence {min_prom}");
                checked += usize::from(want.is_some());
            }
        }
    }
    assert!(checked > 200, "only {checked} line parents checked");
}

#[test]
fn line_parent_differs_from_prominence_parent_on_a_ridge() {
    // One ridge along the middle row: P(8) - 3 - Y(9) - 4 - A(10).
    // Y's key saddle is 4 (towards A); P's is 3, and the component it joins
    // there has A as its highest peak (the prominence parent of `tree.rs`),
    // but walking the ridge from P over its key saddle climbs to Y first, and
    // Y (9) ≥ P (8): P's line parent is Y.
    let row = [0.0f32, 8.0, 3.0, 9.0, 4.0, 10.0, 0.0];
    let g = Grid::from_fn(7, 3, |x, y| if y == 1 { row[x] } else { row[x] - 0.5 });
    let tree = oro::divide_tree(&g, EdgeConvention::Unknown).unwrap();
    let at = |c: u32| tree.peaks.iter().position(|p| p.col == c && p.row == 1).unwrap();
    let lp = metrics::line_parents(&tree, &g).unwrap();
    assert_eq!(lp[at(1)], Some(at(3)), "P -> Y");
    assert_eq!(tree.peaks[at(1)].parent, Some(at(5)), "P's prominence parent is A");
    assert_eq!(lp[at(3)], Some(at(5)), "Y -> A");
    assert_eq!(lp[at(5)], None, "A is the top");
    // Pruned at prominence 5.5 (Y has 5, P has 5 too: both go): nothing left but A.
    let pruned = tree.pruned(5.5);
    assert_eq!(pruned.peaks.len(), 1);
    // Pruned at 4.5: P (8 - 3 = 5) and Y (9 - 4 = 5) stay.
    let pr = tree.pruned(4.5);
    let lp = metrics::line_parents(&pr, &g).unwrap();
    let at = |c: u32| pr.peaks.iter().position(|p| p.col == c && p.row == 1).unwrap();
    assert_eq!(lp[at(1)], Some(at(3)));
}

#[test]
fn dominance_groups_follow_jurgalski_bounds() {
    let cases = [
        (0.0, 0),
        (0.0034, 0),
        (0.0035, 1),
        (0.0069, 1),
        (0.007, 2),
        (0.014, 3),
        (0.021, 4),
        (0.0419, 4),
        (0.042, 5),
        (0.07, 6),
        (0.105, 7),
        (1.0, 7),
    ];
    for (d, g) in cases {
        assert_eq!(metrics::dominance_group(d), Some(g), "dominance {d}");
    }
    assert_eq!(metrics::dominance_group(f64::NAN), None);
    assert_eq!(metrics::dominance_group(-0.1), None);
}

#[test]
fn relevance_by_hand() {
    // prominence 200 of max 800 -> 0.25; elevation 1500 in [1000, 3000] -> 0.25; sqrt(1/16) = 0.25.
    assert!((metrics::relevance(200.0, 800.0, 1500.0, 1000.0, 3000.0) - 0.25).abs() < 1e-12);
    // The highest, most prominent peak: 1.
    assert_eq!(metrics::relevance(800.0, 800.0, 3000.0, 1000.0, 3000.0), 1.0);
    // No relief: 0, no NaN.
    assert_eq!(metrics::relevance(10.0, 10.0, 5.0, 5.0, 5.0), 0.0);
    assert_eq!(metrics::relevance(10.0, 0.0, 5.0, 0.0, 9.0), 0.0);
}

#[test]
fn peak_metrics_key_saddle_distance_and_bearing() {
    // A peak at (2, 1) with its key saddle at (4, 1) on a 10 m projected grid:
    // 20 m to the east, bearing 90.
    let row = [0.0f32, 3.0, 9.0, 5.0, 4.0, 6.0, 12.0, 1.0];
    let g = Grid::from_fn(8, 3, |x, y| if y == 1 { row[x] } else { row[x] - 0.5 });
    let gr = GeoRef::north_up(500_000.0, 4_000_000.0, 10.0, orogen::raster::Crs::projected(32632));
    let tree = oro::divide_tree(&g, EdgeConvention::Unknown).unwrap();
    let i = tree.peaks.iter().position(|p| p.col == 2).unwrap();
    let s = &tree.saddles[tree.peaks[i].key_saddle.unwrap()];
    assert_eq!((s.col, s.row), (4, 1));
    let m = metrics::peak_metrics(&tree, &g, &gr).unwrap();
    assert!((m[i].key_saddle_distance_m.unwrap() - 20.0).abs() < 1e-9);
    assert!((m[i].key_saddle_bearing_deg.unwrap() - 90.0).abs() < 1e-9);
    // Dominance (9 - 4) / 9 = 0.556 -> A1; normalised elevation (9 - (-0.5)) / 12.5.
    assert_eq!(m[i].dominance_group, Some(7));
    assert!((m[i].normalised_elevation.unwrap() - 9.5 / 12.5).abs() < 1e-9);
    let top = tree.peaks.iter().position(|p| p.col == 6).unwrap();
    assert_eq!(m[i].line_parent, Some(top));
    let rp = 5.0 / tree.peaks[top].prominence;
    assert!((m[i].relevance.unwrap() - (rp * 9.5 / 12.5).sqrt()).abs() < 1e-9);
}

#[test]
fn anti_prominence_of_two_pits() {
    // Two pits in a 100 m plateau: 10 m (depth 90 below the rim 100... ) and 40 m,
    // joined through a 70 m pass.
    let mut g = Grid::new(9, 5, 100.0f32);
    g.set(2, 2, 10.0);
    g.set(3, 2, 70.0);
    g.set(4, 2, 70.0);
    g.set(5, 2, 70.0);
    g.set(6, 2, 40.0);
    let pits = metrics::anti_prominence(&g, 1.0).unwrap();
    assert_eq!(pits.len(), 2);
    assert_eq!((pits[0].col, pits[0].row, pits[0].elevation), (2, 2, 10.0));
    assert_eq!(pits[0].anti_prominence, 90.0, "deepest: whole relief");
    assert_eq!(pits[0].key_saddle, None);
    assert_eq!((pits[1].col, pits[1].elevation), (6, 40.0));
    assert_eq!(pits[1].anti_prominence, 30.0, "40 m pit overflows at 70 m");
    assert_eq!(pits[1].key_saddle.map(|s| s.2), Some(70.0));
    // Flat DEM: no pits.
    assert!(metrics::anti_prominence(&Grid::new(4, 4, 5.0f32), 0.0).unwrap().is_empty());
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol
}

#[test]
fn nni_of_lattices_and_poisson() {
    // Square lattice of spacing d, n x n points each owning a d x d cell:
    // every nearest distance is d, density 1/d², so R = d / (0.5 d) = 2 exactly
    // (Clark & Evans' value for a square lattice; edges add nothing when the
    // domain is the union of the cells).
    let d = 30.0;
    let n = 20;
    let pts: Vec<(f64, f64)> = (0..n * n)
        .map(|i| ((i % n) as f64 * d, (i / n) as f64 * d))
        .collect();
    let side = n as f64 * d;
    let r: Nni = metrics::nearest_neighbor_index(&pts, side * side, 4.0 * side).unwrap();
    assert!(close(r.mean_nn, d, 1e-9));
    assert!(close(r.ratio, 2.0, 1e-12), "{}", r.ratio);
    // Hexagonal lattice: density 2/(√3 d²), R = d / (0.5/√density) = 2/√(√3/2) ≈ 2.1491\n    // (the largest possible value).
    let rows = 24;
    let cols = 24;
    let dy = d * 3f64.sqrt() / 2.0;
    let hex: Vec<(f64, f64)> = (0..rows * cols)
        .map(|i| {
            let (c, r) = (i % cols, i / cols);
            (c as f64 * d + if r % 2 == 1 { d / 2.0 } else { 0.0 }, r as f64 * dy)
        })
        .collect();
    let area = cols as f64 * d * rows as f64 * dy;
    let rh = metrics::nearest_neighbor_index(&hex, area, 0.0).unwrap();
    let closed = 2.0 / (3f64.sqrt() / 2.0).sqrt();
    assert!(close(rh.ratio, closed, 1e-9), "{} vs {closed}", rh.ratio);
    assert!(close(closed, 2.1491, 1e-4));
    // Poisson points in the unit square: R ≈ 1 (standard error ≈ 0.523/√n = 0.012).
    let mut rng = Rng(99);
    let m = 2000;
    let p: Vec<(f64, f64)> = (0..m).map(|_| (rng.unit(), rng.unit())).collect();
    let rp = metrics::nearest_neighbor_index(&p, 1.0, 4.0).unwrap();
    assert!(close(rp.ratio_corrected, 1.0, 0.04), "corrected {}", rp.ratio_corrected);
    // Without correction the boundary inflates the mean distance.
    assert!(rp.ratio > rp.ratio_corrected);
    // Brute-force nearest distances.
    let nn = metrics::nearest_distances(&p[..300]);
    for (i, a) in p[..300].iter().enumerate() {
        let want = p[..300]
            .iter()
            .enumerate()
            .filter(|&(j, _)| j != i)
            .map(|(_, b)| (a.0 - b.0).hypot(a.1 - b.1))
            .fold(f64::INFINITY, f64::min);
        assert_eq!(nn[i], want);
    }
    assert!(metrics::nearest_neighbor_index(&p[..1], 1.0, 4.0).is_none());
}
