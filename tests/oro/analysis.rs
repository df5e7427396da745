//! Orometric analysis: line parents, relevance, dominance groups, NNI,
//! anti-prominence, statistics, the classifier and ridge networks, each
//! against an oracle written here independently (brute force, closed forms,
//! hand computations).

use crate::common::Rng;
use orogen::oro::metrics::{self, Nni};
use orogen::oro::{self, EdgeConvention};
use orogen::raster::{GeoRef, Grid};
use std::collections::HashSet;

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
    levels.into_iter().find(|&s| {
        component(z, w, h, p, z[s], true)
            .iter()
            .any(|&c| z[c] > z[p])
    })
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
                assert_eq!(
                    got, want,
                    "case {case} peak {i} at {c}, min prominence {min_prom}"
                );
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
    let at = |c: u32| {
        tree.peaks
            .iter()
            .position(|p| p.col == c && p.row == 1)
            .unwrap()
    };
    let lp = metrics::line_parents(&tree, &g).unwrap();
    assert_eq!(lp[at(1)], Some(at(3)), "P -> Y");
    assert_eq!(
        tree.peaks[at(1)].parent,
        Some(at(5)),
        "P's prominence parent is A"
    );
    assert_eq!(lp[at(3)], Some(at(5)), "Y -> A");
    assert_eq!(lp[at(5)], None, "A is the top");
    // Pruned at prominence 5.5 (Y has 5, P has 5 too: both go): nothing left but A.
    let pruned = tree.pruned(5.5);
    assert_eq!(pruned.peaks.len(), 1);
    // Pruned at 4.5: P (8 - 3 = 5) and Y (9 - 4 = 5) stay.
    let pr = tree.pruned(4.5);
    let lp = metrics::line_parents(&pr, &g).unwrap();
    let at = |c: u32| {
        pr.peaks
            .iter()
            .position(|p| p.col == c && p.row == 1)
            .unwrap()
    };
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
    assert_eq!(
        metrics::relevance(800.0, 800.0, 3000.0, 1000.0, 3000.0),
        1.0
    );
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
    let gr = GeoRef::north_up(
        500_000.0,
        4_000_000.0,
        10.0,
        orogen::raster::Crs::projected(32632),
    );
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
    assert!(metrics::anti_prominence(&Grid::new(4, 4, 5.0f32), 0.0)
        .unwrap()
        .is_empty());
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
            (
                c as f64 * d + if r % 2 == 1 { d / 2.0 } else { 0.0 },
                r as f64 * dy,
            )
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
    assert!(
        close(rp.ratio_corrected, 1.0, 0.04),
        "corrected {}",
        rp.ratio_corrected
    );
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

// ---------------------------------------------------------------- statistics

use orogen::oro::classify::{self, Dataset, ForestParams};
use orogen::oro::ridges;
use orogen::oro::stats::{self, OroProfile, StatsOptions};
use orogen::raster::Crs;

#[test]
fn poisson_disc_is_separated_deterministic_and_fills_the_box() {
    let r = 7.0;
    let a = stats::poisson_disc(0.0, 0.0, 200.0, 120.0, r, 5, 100_000);
    let b = stats::poisson_disc(0.0, 0.0, 200.0, 120.0, r, 5, 100_000);
    let c = stats::poisson_disc(0.0, 0.0, 200.0, 120.0, r, 6, 100_000);
    assert_eq!(a, b, "same seed, same points");
    assert_ne!(a, c, "another seed, other points");
    for (i, p) in a.iter().enumerate() {
        assert!(p.0 >= 0.0 && p.0 <= 200.0 && p.1 >= 0.0 && p.1 <= 120.0);
        for q in &a[..i] {
            assert!((p.0 - q.0).hypot(p.1 - q.1) >= r, "{p:?} {q:?}");
        }
    }
    // Maximal Poisson-disc sets cover the plane at density between the
    // hexagonal packing of r/2-disks (≤ 2/(√3 r²)) and about 0.7 of it in
    // practice; check a loose lower bound so an early stop would fail.
    let max_density = 2.0 / (3f64.sqrt() * r * r);
    let n = a.len() as f64;
    let area = 200.0 * 120.0;
    assert!(n < max_density * (200.0 + r) * (120.0 + r), "{n}");
    assert!(n > 0.45 * max_density * area, "only {n} points");
    // No box point farther than 2r from a sample (Bridson's maximality).
    let mut rng = Rng(3);
    for _ in 0..500 {
        let (x, y) = (rng.unit() * 200.0, rng.unit() * 120.0);
        let d = a
            .iter()
            .map(|p| (p.0 - x).hypot(p.1 - y))
            .fold(f64::MAX, f64::min);
        assert!(d < 2.0 * r, "hole at ({x}, {y}): {d}");
    }
    assert_eq!(
        stats::poisson_disc(0.0, 0.0, 10.0, 10.0, 1.0, 1, 3).len(),
        3
    );
    assert!(stats::poisson_disc(0.0, 0.0, 10.0, 10.0, f64::NAN, 1, 3).is_empty());
}

#[test]
fn bins_and_sectors_by_hand() {
    let e = [0.0, 1.0, 2.0, 5.0];
    assert_eq!(stats::bin_of(&e, -3.0), Some(0));
    assert_eq!(stats::bin_of(&e, 0.99), Some(0));
    assert_eq!(stats::bin_of(&e, 1.0), Some(1));
    assert_eq!(stats::bin_of(&e, 4.9), Some(2));
    assert_eq!(stats::bin_of(&e, 99.0), Some(2));
    assert_eq!(stats::bin_of(&e, f64::NAN), None);
    assert_eq!(stats::sector(0.0), Some(0.0));
    assert_eq!(stats::sector(22.4), Some(0.0));
    assert_eq!(stats::sector(22.5), Some(1.0));
    assert_eq!(stats::sector(180.0), Some(4.0));
    assert_eq!(stats::sector(337.6), Some(0.0));
    assert_eq!(stats::sector(359.9), Some(0.0));
    let names = stats::feature_names();
    let nh: usize = stats::FEATURES.iter().map(|f| f.edges.len() - 1).sum();
    assert_eq!(names.len(), nh + 2);
    assert!(names.iter().all(|n| !n.contains(',')), "CSV-safe names");
}

/// Cones of known heights on a lattice, sea level 0 around: every cone is an
/// island (prominence = height, dominance 1, no key saddle).
fn cones() -> (Grid<f32>, GeoRef, Vec<(usize, usize, f32)>) {
    let (w, h) = (200, 160);
    let mut apex = Vec::new();
    for j in 0..8 {
        for i in 0..10 {
            let (x, y) = (10 + i * 20, 10 + j * 20);
            apex.push((x, y, 200.0 + 100.0 * ((i + 3 * j) % 5) as f32));
        }
    }
    let g = Grid::from_fn(w, h, |x, y| {
        let mut z = 0.0f32;
        for &(ax, ay, ah) in &apex {
            let d = ((x as f32 - ax as f32).powi(2) + (y as f32 - ay as f32).powi(2)).sqrt();
            z = z.max(ah - 100.0 * d);
        }
        z
    });
    let gr = GeoRef::north_up(300_000.0, 5_000_000.0, 100.0, Crs::projected(32633));
    (g, gr, apex)
}

#[test]
fn orostats_on_cones_matches_hand_histograms() {
    let (g, gr, apex) = cones();
    let mut o = StatsOptions::new(3000.0);
    o.seed = 11;
    let st = stats::orostats(&g, &gr, &o, "cones", "test").unwrap();
    assert_eq!(st.profile.n_peaks, apex.len());
    assert!(st.disks.len() >= 10, "{} disks", st.disks.len());
    let names = stats::feature_names();
    let col = |n: &str| names.iter().position(|x| x == n).unwrap();
    for d in &st.disks {
        // Peaks inside the disk, by hand: cell centres within 3000 m (30 cells).
        let inside: Vec<f32> = apex
            .iter()
            .filter(|&&(x, y, _)| (x as f64 - d.col).hypot(y as f64 - d.row) <= 30.0 + 1e-9)
            .map(|a| a.2)
            .collect();
        assert_eq!(d.n_peaks, inside.len(), "disk at {}, {}", d.col, d.row);
        let area_100 = std::f64::consts::PI * 9.0 / 100.0;
        let dens = d.values[col("density_per_100km2")];
        assert!((dens - inside.len() as f64 / area_100).abs() < 1e-9);
        if inside.is_empty() {
            assert!(d.values[..names.len() - 2].iter().all(|&v| v == 0.0));
            continue;
        }
        let n = inside.len() as f64;
        // Dominance 1 -> the last dominance bin and group A1.
        assert_eq!(d.values[col("dominance:0.8-1")], 1.0);
        assert_eq!(d.values[col("dominance_group:7-8")], 1.0);
        // No key saddles.
        assert!(names
            .iter()
            .zip(&d.values)
            .filter(|(nm, _)| nm.starts_with("saddle_"))
            .all(|(_, &v)| v == 0.0));
        // Prominence = height: 200..600 fall in bins 200-300, 300-400, 400-600 (twice), 600-800.
        let frac =
            |lo: f32, hi: f32| inside.iter().filter(|&&z| z >= lo && z < hi).count() as f64 / n;
        assert!((d.values[col("prominence_m:200-300")] - frac(200.0, 300.0)).abs() < 1e-12);
        assert!((d.values[col("prominence_m:400-600")] - frac(400.0, 600.0)).abs() < 1e-12);
        assert!((d.values[col("prominence_m:600-800")] - frac(600.0, 800.0)).abs() < 1e-12);
        // Relative prominence and relevance: the disk's DEM minimum is 0 (the
        // sea between cones), its maximum the highest cone inside (cones
        // outside the disk may reach in with their flanks only below it).
        let top = inside.iter().cloned().fold(0.0f32, f32::max) as f64;
        let mut want = [0.0; 10];
        for &z in &inside {
            let rel = z as f64 / top;
            let b = ((rel * 10.0).floor() as usize).min(9);
            want[b] += 1.0 / n;
        }
        for (b, wv) in want.iter().enumerate() {
            let name = &names[col("prominence_rel:0-0.1") + b];
            assert!((d.values[col(name)] - wv).abs() < 1e-12, "{name}");
            // Relevance = √(rel · rel) = rel: the same histogram.
            let rname = &names[col("relevance:0-0.1") + b];
            assert!((d.values[col(rname)] - wv).abs() < 1e-12, "{rname}");
        }
    }
    // Pooled profile: prominence histogram = disks' counts summed.
    let pooled = &st.profile.histograms["prominence_m"];
    let total: f64 = st.disks.iter().map(|d| d.n_peaks as f64).sum();
    assert_eq!(pooled.n, total);
    assert!((pooled.p.iter().sum::<f64>() - 1.0).abs() < 1e-12);
    // Deterministic: same seed, same features.
    let again = stats::orostats(&g, &gr, &o, "cones", "test").unwrap();
    assert_eq!(again.disks, st.disks);
}

#[test]
fn profile_saves_loads_and_compares() {
    let (g, gr, _) = cones();
    let st = stats::orostats(&g, &gr, &StatsOptions::new(3000.0), "cones", "t").unwrap();
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("cones.json");
    st.profile.save(&p).unwrap();
    let back = OroProfile::load(&p).unwrap();
    assert_eq!(back, st.profile);
    let d = back.compare(&st.profile);
    assert!(d.values().all(|&v| v == 0.0));
    // A profile with everything twice as prominent differs in prominence only.
    let mut other = back.clone();
    let h = other.histograms.get_mut("prominence_m").unwrap();
    h.p = vec![0.0; h.p.len()];
    h.p[0] = 1.0;
    let d = back.compare(&other);
    assert!(d["prominence_m"] > 0.5);
    assert_eq!(d["dominance"], 0.0);
    std::fs::write(&p, "{\"format\": 3}").unwrap();
    let e = OroProfile::load(&p).unwrap_err().to_string();
    assert!(e.contains("cones.json"), "{e}");
}

#[test]
fn orostats_bad_input() {
    let gr = GeoRef::north_up(0.0, 0.0, 100.0, Crs::projected(32633));
    // Flat DEM: no peaks under the unknown-edge convention, zero histograms.
    let flat = Grid::new(100, 100, 250.0f32);
    let mut o = StatsOptions::new(2000.0);
    o.convention = EdgeConvention::Unknown;
    let st = stats::orostats(&flat, &gr, &o, "", "").unwrap();
    assert_eq!(st.profile.n_peaks, 0);
    assert!(!st.disks.is_empty());
    assert!(st
        .disks
        .iter()
        .all(|d| d.n_peaks == 0 && d.values.iter().all(|&v| v == 0.0)));
    // All nodata: a clear error.
    let none = Grid::new(100, 100, f32::NAN);
    let e = stats::orostats(&none, &gr, &o, "", "")
        .unwrap_err()
        .to_string();
    assert!(e.contains("no valid cells"), "{e}");
    // Radius larger than the DEM.
    let e = stats::orostats(&flat, &gr, &StatsOptions::new(9000.0), "", "")
        .unwrap_err()
        .to_string();
    assert!(e.contains("does not fit"), "{e}");
    // Separation below R/2 is refused.
    let mut o2 = StatsOptions::new(2000.0);
    o2.separation_m = 500.0;
    assert!(stats::orostats(&flat, &gr, &o2, "", "").is_err());
    // A single peak: every disk holding it sees one peak.
    let one = Grid::from_fn(100, 100, |x, y| {
        1000.0 - 10.0 * ((x as f32 - 50.0).powi(2) + (y as f32 - 50.0).powi(2)).sqrt()
    });
    let st = stats::orostats(&one, &gr, &o, "", "").unwrap();
    assert_eq!(st.profile.n_peaks, 1);
    assert!(st.disks.iter().all(|d| d.n_peaks <= 1));
}

// ---------------------------------------------------------------- classifier

fn separable(n_per: usize, seed: u64) -> Dataset {
    let mut rng = Rng(seed);
    let mut ds = Dataset {
        names: (0..6).map(|i| format!("f{i}")).collect(),
        ..Default::default()
    };
    for (k, label) in ["alps", "andes", "plains"].iter().enumerate() {
        for _ in 0..n_per {
            let mut row: Vec<f64> = (0..6).map(|_| rng.unit()).collect();
            // Feature 2 separates the classes by a wide margin.
            row[2] = 3.0 * k as f64 + rng.unit();
            ds.labels.push(label.to_string());
            ds.rows.push(row);
        }
    }
    ds
}

#[test]
fn classifier_separates_separable_classes_and_is_deterministic() {
    let ds = separable(30, 4);
    let p = ForestParams {
        n_trees: 25,
        seed: 9,
        ..Default::default()
    };
    let ev = classify::evaluate(&ds, &p, 5, 0.2, 3).unwrap();
    assert_eq!(ev.accuracies.len(), 5);
    assert!(
        ev.accuracies.iter().all(|&a| a == 1.0),
        "{:?}",
        ev.accuracies
    );
    assert_eq!(ev.mean, 1.0);
    assert_eq!(ev.sd, 0.0);
    // Stratified 20 %: 6 of each class per repetition, all on the diagonal.
    assert_eq!(
        ev.confusion,
        vec![vec![30, 0, 0], vec![0, 30, 0], vec![0, 0, 30]]
    );
    assert_eq!(classify::evaluate(&ds, &p, 5, 0.2, 3).unwrap(), ev);
    assert!(ev
        .confusion_csv()
        .starts_with("true\\predicted,alps,andes,plains\nalps,30,0,0\n"));
    // Train, save, load, predict.
    let m = classify::train(&ds, &p).unwrap();
    let test = separable(5, 77);
    let pred = m.predict(&test.rows).unwrap();
    assert_eq!(pred, test.labels);
    let dir = tempfile::tempdir().unwrap();
    let f = dir.path().join("m.json");
    m.save(&f).unwrap();
    let m2 = classify::Model::load(&f).unwrap();
    assert_eq!(m2.predict(&test.rows).unwrap(), pred);
    // Random labels: accuracy near chance, not 1.
    let mut noisy = separable(30, 4);
    let mut rng = Rng(1);
    for r in noisy.rows.iter_mut() {
        r[2] = rng.unit();
    }
    let ev = classify::evaluate(&noisy, &p, 3, 0.2, 3).unwrap();
    assert!(ev.mean < 0.75, "{}", ev.mean);
}

#[test]
fn classifier_bad_input() {
    let mut ds = separable(5, 1);
    ds.labels.iter_mut().for_each(|l| *l = "alps".into());
    let e = classify::train(&ds, &ForestParams::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("two"), "{e}");
    let mut ds = separable(5, 1);
    ds.rows[3][1] = f64::NAN;
    assert!(classify::train(&ds, &ForestParams::default()).is_err());
    assert!(classify::evaluate(&separable(5, 1), &ForestParams::default(), 3, 1.5, 1).is_err());
    let dir = tempfile::tempdir().unwrap();
    let f = dir.path().join("bad.csv");
    std::fs::write(&f, "label,source,col,row,n_peaks,a\nx,y,1,2,3,nope\n").unwrap();
    let e = Dataset::read_csv(&f).unwrap_err().to_string();
    assert!(e.contains("bad.csv") && e.contains("line 2"), "{e}");
    std::fs::write(&f, "hello\n").unwrap();
    assert!(Dataset::read_csv(&f).is_err());
    std::fs::write(&f, "{").unwrap();
    assert!(classify::Model::load(&f).is_err());
}

// ---------------------------------------------------------------- ridges

#[test]
fn ppa_finds_the_crest_of_a_single_ridge() {
    // z = 500 − 20·|x − 30| + 0.5·y: one straight crest on column 30, rising southwards.
    let (w, h) = (61, 80);
    let g = Grid::from_fn(w, h, |x, y| {
        500.0 - 20.0 * (x as f32 - 30.0).abs() + 0.5 * y as f32
    });
    let r = ridges::ppa_ridges(
        &g,
        &ridges::PpaOptions {
            half_window: 3,
            min_branch: 10,
        },
    )
    .unwrap();
    for y in 0..h {
        for x in 0..w {
            if r.get(x, y) == 1 && (5..h - 5).contains(&y) {
                assert_eq!(x, 30, "ridge cell off the crest at ({x}, {y})");
            }
        }
    }
    let on: usize = (5..h - 5).filter(|&y| r.get(30, y) == 1).count();
    assert_eq!(on, h - 10, "crest covered");
    assert!(ridges::ppa_ridges(
        &g,
        &ridges::PpaOptions {
            half_window: 0,
            min_branch: 1
        }
    )
    .is_err());
}

#[test]
fn ppa_finds_the_edges_of_a_pyramid() {
    // z = 1000 − 10·max(|dx|, |dy|) + 0.5·(|dx| + |dy|): a pyramid whose faces
    // rise slightly towards the edges, so the crest lines (the diagonals) are
    // strict maxima across every profile. (On a perfect pyramid the rows of a
    // face are level with the crest: PPA then marks bands, by its definition.)
    let n = 81;
    let c = 40i64;
    let g = Grid::from_fn(n, n, |x, y| {
        let (dx, dy) = ((x as i64 - c).abs(), (y as i64 - c).abs());
        1000.0 - 10.0 * dx.max(dy) as f32 + 0.5 * (dx + dy) as f32
    });
    let r = ridges::ppa_ridges(
        &g,
        &ridges::PpaOptions {
            half_window: 3,
            min_branch: 8,
        },
    )
    .unwrap();
    let mut on_diag = 0;
    for y in 0..n {
        for x in 0..n {
            let (dx, dy) = ((x as i64 - c).abs(), (y as i64 - c).abs());
            // Near the DEM's edge the surface also drops towards the outside
            // within a profile's reach: PPA legitimately marks cells there.
            let inner = (8..n - 8).contains(&x) && (8..n - 8).contains(&y);
            if r.get(x, y) == 1 && inner {
                assert!((dx - dy).abs() <= 1, "({x}, {y}) is not on a diagonal");
                on_diag += usize::from(dx == dy);
            }
        }
    }
    // The four inner half-diagonals have 4·32 cells plus the apex; most are found.
    assert!(on_diag >= 4 * 28, "{on_diag}");
}

#[test]
fn divide_tree_ridges_follow_the_crest() {
    // A crest on column 20 with two summits (rows 10 and 40) and a col between.
    let (w, h) = (41, 51);
    let crest = |y: f32| {
        300.0
            + 200.0 * (-(y - 10.0).powi(2) / 60.0).exp()
            + 150.0 * (-(y - 40.0).powi(2) / 60.0).exp()
    };
    let g = Grid::from_fn(w, h, |x, y| {
        crest(y as f32) - 15.0 * (x as f32 - 20.0).abs()
    });
    let gr = GeoRef::north_up(0.0, 0.0, 10.0, Crs::projected(32633));
    let list = oro::peaks(
        &g,
        &gr,
        &oro::PeakOptions {
            min_prominence: 20.0,
            convention: EdgeConvention::Unknown,
            isolation: false,
        },
    )
    .unwrap();
    assert_eq!(list.tree.peaks.len(), 2);
    let net = ridges::divide_tree_ridges(&list.tree, &g, &gr).unwrap();
    assert_eq!(net.edges.len(), 2, "one saddle, two ascents");
    for e in &net.edges {
        assert!(e.path.iter().all(|&(c, _)| c == 20), "{:?}", e.path);
        let last = *e.path.last().unwrap();
        assert!(last == (20, 10) || last == (20, 40));
        assert_eq!(e.level, 1);
        assert_eq!(e.order, 1);
        // Length: 10 m per row step along the crest.
        let (r0, r1) = (e.path[0].1 as f64, last.1 as f64);
        assert!((e.length_m - 10.0 * (r1 - r0).abs()).abs() < 1e-9);
    }
    let lv = net.rasterise_levels();
    let cells = lv.data().iter().filter(|&&v| v > 0).count();
    assert_eq!(cells, 31, "rows 10..=40 of the crest");
    // GeoJSON parses back.
    let dir = tempfile::tempdir().unwrap();
    let f = dir.path().join("r.geojson");
    net.write_geojson(&f, &orogen::io::geojson::GeoJsonCoords::native(&gr))
        .unwrap();
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&f).unwrap()).unwrap();
    assert_eq!(v["features"].as_array().unwrap().len(), 2);
}

#[test]
fn hierarchy_levels_and_orders_by_hand() {
    // A tree:        0 —10— 1 —10— 2 —10— 3
    //                       |       |
    //                       4(3)    5(25) — 6(1)      7 —2— 8 (another tree)
    // Longest path: 0-1-2-5-6 (10+10+25+1 = 46); 3..6 is 36, 0..3 is 30.
    // So level 1: edges 0-1, 1-2, 2-5, 5-6; level 2: 2-3 and 1-4; 7-8 is
    // its own tree's level 1.
    let e = [
        (0, 1, 10.0),
        (1, 2, 10.0),
        (2, 3, 10.0),
        (1, 4, 3.0),
        (2, 5, 25.0),
        (5, 6, 1.0),
        (7, 8, 2.0),
    ];
    let lv = ridges::longest_path_levels(9, &e).unwrap();
    assert_eq!(lv, vec![1, 1, 2, 2, 1, 1, 1]);
    // A branch of a branch is level 3: hang 9 from 3 (2-3 is level 2).
    let mut e3 = e.to_vec();
    e3.push((3, 9, 4.0));
    e3.push((9, 10, 1.0));
    e3.push((9, 11, 2.0));
    let lv = ridges::longest_path_levels(12, &e3).unwrap();
    // 2-3-9-11 = 16 < 2-5-6 = 26: still level 2 from node 2; 9-10 hangs off it: level 3.
    assert_eq!(lv, vec![1, 1, 2, 2, 1, 1, 1, 2, 3, 2]);
    // Strahler rooted at node 0 (highest): leaves 3, 4, 6 -> 1; node 5 has
    // one child -> 1; node 2: children 3 (1) and 5 (1) -> 2; node 1:
    // children 2 (2) and 4 (1) -> 2. Edge orders = lower end's order.
    let elev = [9.0, 5.0, 4.0, 3.0, 2.0, 3.5, 1.0, 1.0, 2.0];
    let so = ridges::strahler_orders(9, &e, &elev).unwrap();
    assert_eq!(so, vec![2, 2, 1, 1, 1, 1, 1]);
    // Cycles are refused.
    assert!(ridges::longest_path_levels(3, &[(0, 1, 1.0), (1, 2, 1.0), (2, 0, 1.0)]).is_err());
}

#[test]
fn peaks_csv_and_geojson_carry_the_new_columns() {
    let row = [0.0f32, 8.0, 3.0, 9.0, 4.0, 10.0, 0.0];
    let g = Grid::from_fn(7, 3, |x, y| if y == 1 { row[x] } else { row[x] - 0.5 });
    let gr = GeoRef::north_up(500_000.0, 4_000_000.0, 10.0, Crs::projected(32632));
    let opts = oro::PeakOptions {
        min_prominence: 1.0,
        convention: EdgeConvention::Unknown,
        isolation: true,
    };
    let list = oro::peaks(&g, &gr, &opts).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let files = list
        .write_all_with_dem(
            dir.path(),
            &g,
            &orogen::io::geojson::GeoJsonCoords::native(&gr),
        )
        .unwrap();
    let csv = std::fs::read_to_string(&files[0]).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert!(header.ends_with(&oro::EXTRA_COLUMNS.split(',').collect::<Vec<_>>()));
    let col = |n: &str| header.iter().position(|h| *h == n).unwrap();
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 3);
    // Line order: A (10), Y (9), P (8). P's line parent is Y (line 1), Y's is A (line 0).
    assert_eq!(rows[2][col("line_parent")], "1");
    assert_eq!(rows[1][col("line_parent")], "0");
    assert_eq!(rows[0][col("line_parent")], "");
    // P: key saddle at col 2, 10 m east of col 1 -> 0.01 km, bearing 90.
    assert_eq!(rows[2][col("key_saddle_km")], "0.01");
    assert_eq!(rows[2][col("key_saddle_bearing")], "90");
    let gj: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&files[1]).unwrap()).unwrap();
    assert_eq!(gj["features"][2]["properties"]["line_parent"], 1);
    // The tree-only writer leaves the DEM columns empty but keeps the layout.
    let p = dir.path().join("plain.csv");
    oro::write_peaks_csv(&p, &list.tree, &gr).unwrap();
    let plain = std::fs::read_to_string(&p).unwrap();
    assert_eq!(
        plain.lines().next().unwrap().split(',').count(),
        header.len()
    );
    assert_eq!(
        plain
            .lines()
            .nth(3)
            .unwrap()
            .split(',')
            .nth(col("line_parent")),
        Some("")
    );
}

#[test]
fn line_parents_on_a_real_dem_are_higher_ridge_neighbours() {
    // bigtujunga_crop (SRTM 30 m, sea-level convention): every line parent is
    // at least as high as its peak, and no higher than the prominence parent's
    // component allows (the prominence parent is the highest of that component).
    let src = orogen::io::open_raster(
        std::path::Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/tests/data/bigtujunga_crop.tif"
        )),
        &Default::default(),
    )
    .unwrap();
    let info = src.info().clone();
    let g = orogen::raster::read_window::<f32>(
        src.as_ref(),
        orogen::raster::Window::full(info.width, info.height),
    )
    .unwrap();
    let tree = oro::divide_tree(&g, EdgeConvention::SeaLevel)
        .unwrap()
        .pruned(20.0);
    let lp = metrics::line_parents(&tree, &g).unwrap();
    let mut n = 0;
    for (i, p) in tree.peaks.iter().enumerate() {
        match (p.key_saddle, lp[i]) {
            (Some(_), Some(q)) => {
                let (pe, qe) = (p.elevation, tree.peaks[q].elevation);
                assert!(qe >= pe, "peak {i}: line parent lower");
                let pp = p.parent.unwrap();
                assert!(
                    tree.peaks[pp].elevation >= qe,
                    "peak {i}: line parent above the prominence parent"
                );
                n += 1;
            }
            (None, lp) => assert_eq!(lp, None),
            (Some(_), None) => panic!("peak {i} has a key saddle but no line parent"),
        }
    }
    assert!(n > 10, "{n}");
}

#[test]
fn poisson_disc_refuses_absurd_grids() {
    // 1e6 x 1e6 with r = 1: 2e12 background cells; no allocation, no points.
    assert!(stats::poisson_disc(0.0, 0.0, 1e6, 1e6, 1.0, 1, 10).is_empty());
}
