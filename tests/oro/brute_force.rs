//! Brute-force oracles for the orometry module: prominence by its definition
//! (per peak, the highest level at which the peak's connected superlevel set
//! reaches higher ground, by BFS at every level), isolation by a full scan.
//! Nothing here shares code with `orogen::oro`.

use orogen::oro::{self, DivideTree, EdgeConvention, IsolationIndex, PeakOptions};
use orogen::raster::{Crs, GeoRef, Grid};
use proptest::prelude::*;
use std::collections::VecDeque;

const N8: [(i64, i64); 8] = [
    (-1, -1),
    (0, -1),
    (1, -1),
    (-1, 0),
    (1, 0),
    (-1, 1),
    (0, 1),
    (1, 1),
];

fn nbrs(w: usize, h: usize, i: usize) -> impl Iterator<Item = Option<usize>> {
    let (x, y) = ((i % w) as i64, (i / w) as i64);
    N8.iter().map(move |&(dx, dy)| {
        let (nx, ny) = (x + dx, y + dy);
        (nx >= 0 && ny >= 0 && nx < w as i64 && ny < h as i64)
            .then(|| ny as usize * w + nx as usize)
    })
}

/// Cells reachable from `start` through valid cells with value ≥ `level`.
fn reach(z: &[f32], w: usize, h: usize, start: usize, level: f32) -> Vec<bool> {
    let mut seen = vec![false; z.len()];
    let mut q = VecDeque::from([start]);
    seen[start] = true;
    while let Some(c) = q.pop_front() {
        for n in nbrs(w, h, c).flatten() {
            if !seen[n] && !z[n].is_nan() && z[n] >= level {
                seen[n] = true;
                q.push_back(n);
            }
        }
    }
    seen
}

/// (rep index of its flat region) for every cell, by equal-height flooding.
fn flat_reps(z: &[f32], w: usize, h: usize) -> Vec<usize> {
    let mut rep = vec![usize::MAX; z.len()];
    for s in 0..z.len() {
        if z[s].is_nan() || rep[s] != usize::MAX {
            continue;
        }
        let mut members = vec![s];
        let mut k = 0;
        rep[s] = s;
        while k < members.len() {
            let c = members[k];
            k += 1;
            for n in nbrs(w, h, c).flatten() {
                if rep[n] == usize::MAX && z[n] == z[s] {
                    rep[n] = s;
                    members.push(n);
                }
            }
        }
        let m = *members.iter().min().unwrap();
        for c in members {
            rep[c] = m;
        }
    }
    rep
}

/// Oracle peaks: (col, row, elevation, prominence); all cells > 0. Of equal
/// summits, the one whose plateau starts later in row-major order is higher.
fn oracle(z: &[f32], w: usize, h: usize, conv: EdgeConvention) -> Vec<(u32, u32, f32, f64)> {
    let rep = flat_reps(z, w, h);
    let mut out = Vec::new();
    for p in 0..z.len() {
        if z[p].is_nan() || rep[p] != p {
            continue;
        }
        let hp = z[p];
        let members: Vec<usize> = (0..z.len()).filter(|&c| rep[c] == p).collect();
        let mut any = false;
        let mut is_peak = true;
        for &c in &members {
            for n in nbrs(w, h, c).flatten() {
                if z[n].is_nan() || rep[n] == p {
                    continue;
                }
                any = true;
                if z[n] >= hp {
                    is_peak = false;
                }
            }
        }
        // Unknown: a plateau with no valid neighbour is not a peak; SeaLevel:
        // it is an island (all test heights are > 0 = the sea).
        if !is_peak || (!any && conv == EdgeConvention::Unknown) {
            continue;
        }
        let mut levels: Vec<f32> = z
            .iter()
            .copied()
            .filter(|v| !v.is_nan() && *v < hp)
            .collect();
        levels.sort_by(|a, b| b.total_cmp(a));
        levels.dedup();
        let mut prom = None;
        for &l in &levels {
            let s = reach(z, w, h, p, l);
            let found = (0..z.len()).any(|c| s[c] && (z[c] > hp || (z[c] == hp && rep[c] > p)));
            if found {
                prom = Some(hp as f64 - l as f64);
                break;
            }
        }
        let prom = prom.unwrap_or_else(|| match conv {
            EdgeConvention::SeaLevel => hp as f64,
            EdgeConvention::Unknown => {
                let s = reach(z, w, h, p, f32::NEG_INFINITY);
                let low = (0..z.len())
                    .filter(|&c| s[c])
                    .map(|c| z[c])
                    .fold(f32::INFINITY, f32::min);
                hp as f64 - low as f64
            }
        });
        out.push(((p % w) as u32, (p / w) as u32, hp, prom));
    }
    out.sort_by_key(|a| (a.1, a.0));
    out
}

/// Oracle pits and join saddles (sorted by row, col). A pit: a flat region
/// whose neighbours are all valid and higher. A join saddle: a region adjacent
/// to ≥ 2 distinct 8-connected components of the cells that come before it in
/// the sweep order (higher, or equal height with a later first cell).
type Cells = Vec<(u32, u32)>;

fn oracle_pits_saddles(z: &[f32], w: usize, h: usize) -> (Cells, Cells) {
    let rep = flat_reps(z, w, h);
    let (mut pits, mut saddles) = (Vec::new(), Vec::new());
    for r in 0..z.len() {
        if z[r].is_nan() || rep[r] != r {
            continue;
        }
        let before = |c: usize| !z[c].is_nan() && (z[c] > z[r] || (z[c] == z[r] && rep[c] > r));
        let members: Vec<usize> = (0..z.len()).filter(|&c| rep[c] == r).collect();
        let mut pit = true;
        let mut comps: Vec<Vec<bool>> = Vec::new();
        for &c in &members {
            for n in nbrs(w, h, c) {
                match n {
                    None => pit = false,
                    Some(n) if z[n].is_nan() => pit = false,
                    Some(n) if rep[n] == r => {}
                    Some(n) => {
                        if z[n] < z[r] {
                            pit = false;
                        }
                        if before(n) && !comps.iter().any(|m| m[n]) {
                            // Flood n's component within the `before` set.
                            let mut m = vec![false; z.len()];
                            let mut st = vec![n];
                            m[n] = true;
                            while let Some(x) = st.pop() {
                                for y in nbrs(w, h, x).flatten() {
                                    if !m[y] && before(y) {
                                        m[y] = true;
                                        st.push(y);
                                    }
                                }
                            }
                            comps.push(m);
                        }
                    }
                }
            }
        }
        let pos = ((r % w) as u32, (r / w) as u32);
        if pit {
            pits.push(pos);
        }
        if comps.len() >= 2 {
            saddles.push(pos);
        }
    }
    (pits, saddles)
}

fn ours(t: &DivideTree) -> Vec<(u32, u32, f32, f64)> {
    let mut v: Vec<_> = t
        .peaks
        .iter()
        .map(|p| (p.col, p.row, p.elevation, p.prominence))
        .collect();
    v.sort_by_key(|a| (a.1, a.0));
    v
}

/// Structural checks of a tree against the grid.
fn check_tree(t: &DivideTree, z: &[f32], w: usize, h: usize) {
    t.validate().unwrap();
    for p in &t.peaks {
        let pi = p.row as usize * w + p.col as usize;
        assert_eq!(z[pi], p.elevation);
        match (p.key_saddle, p.parent) {
            (Some(s), Some(q)) => {
                let s = &t.saddles[s];
                let q = &t.peaks[q];
                let si = s.row as usize * w + s.col as usize;
                assert_eq!(z[si], s.elevation);
                assert!(s.elevation < p.elevation);
                assert!(q.elevation >= p.elevation);
                assert_eq!(p.prominence, p.elevation as f64 - s.elevation as f64);
                // Parent and saddle are connected to the peak above the saddle level.
                let r = reach(z, w, h, pi, s.elevation);
                assert!(r[si] && r[q.row as usize * w + q.col as usize]);
                // Prominence parent: the highest summit (ties: later first cell)
                // of the saddle's component among the cells swept up to and
                // including the saddle region.
                let rep = flat_reps(z, w, h);
                let key = |c: usize| (z[c], rep[c]);
                let upto = |c: usize| {
                    !z[c].is_nan() && key(c).partial_cmp(&key(si)) != Some(std::cmp::Ordering::Less)
                };
                let mut seen = vec![false; z.len()];
                let mut st = vec![si];
                seen[si] = true;
                let mut best = si;
                while let Some(x) = st.pop() {
                    if key(x).partial_cmp(&key(best)) == Some(std::cmp::Ordering::Greater) {
                        best = x;
                    }
                    for y in nbrs(w, h, x).flatten() {
                        if !seen[y] && upto(y) {
                            seen[y] = true;
                            st.push(y);
                        }
                    }
                }
                assert_eq!(
                    rep[best],
                    q.row as usize * w + q.col as usize,
                    "prominence parent"
                );
            }
            (None, None) => {}
            other => panic!("key saddle and parent must come together: {other:?}"),
        }
    }
}

fn grid_strategy() -> impl Strategy<Value = (usize, usize, Vec<f32>)> {
    (1usize..10, 1usize..10).prop_flat_map(|(w, h)| {
        let cell = prop_oneof![9 => (1i32..6).prop_map(|v| v as f32), 1 => Just(f32::NAN)];
        (Just(w), Just(h), proptest::collection::vec(cell, w * h))
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 600, .. ProptestConfig::default() })]

    #[test]
    fn prominence_matches_definition((w, h, z) in grid_strategy()) {
        let g = Grid::from_vec(w, h, z.clone()).unwrap();
        for conv in [EdgeConvention::SeaLevel, EdgeConvention::Unknown] {
            let t = oro::divide_tree(&g, conv).unwrap();
            prop_assert_eq!(ours(&t), oracle(&z, w, h, conv));
            check_tree(&t, &z, w, h);
            let crit = oro::critical_points(&g, conv).unwrap();
            let mut cp = crit.peaks.clone();
            cp.sort_by_key(|a| (a.1, a.0));
            let op: Vec<(u32, u32)> = oracle(&z, w, h, conv).iter().map(|a| (a.0, a.1)).collect();
            prop_assert_eq!(cp, op);
            let (mut pits, mut sads) = (crit.pits.clone(), crit.saddles.clone());
            pits.sort_by_key(|a| (a.1, a.0));
            sads.sort_by_key(|a| (a.1, a.0));
            prop_assert_eq!((pits, sads), oracle_pits_saddles(&z, w, h));
            // Pruning = the oracle's peaks above the threshold, tree still valid.
            for thr in [1.0, 2.0, 3.0] {
                let pt = t.pruned(thr);
                check_tree(&pt, &z, w, h);
                let want: Vec<_> = oracle(&z, w, h, conv).into_iter().filter(|a| a.3 >= thr).collect();
                prop_assert_eq!(ours(&pt), want);
            }
            // JSON round trip.
            prop_assert_eq!(DivideTree::from_json(&t.to_json()).unwrap(), t);
        }
    }

    #[test]
    fn isolation_matches_full_scan((w, h, z) in grid_strategy()) {
        let g = Grid::from_vec(w, h, z.clone()).unwrap();
        let list = oro::peaks(&g, &GeoRef::pixel(), &PeakOptions { min_prominence: 0.0, ..Default::default() }).unwrap();
        for p in &list.tree.peaks {
            let (px, py) = (p.col as f64, p.row as f64);
            let mut best: Option<(f64, usize)> = None;
            for (i, &v) in z.iter().enumerate() {
                if v > p.elevation {
                    let d = ((i % w) as f64 - px).hypot((i / w) as f64 - py);
                    if best.is_none_or(|(bd, _)| d < bd) {
                        best = Some((d, i));
                    }
                }
            }
            match (best, p.isolation) {
                (None, None) => {}
                (Some((d, i)), Some(iso)) => {
                    prop_assert!((iso.distance_m - d).abs() < 1e-12);
                    prop_assert_eq!((iso.col as usize, iso.row as usize), (i % w, i / w));
                }
                other => prop_assert!(false, "isolation mismatch {:?}", other),
            }
        }
    }
}

/// Geographic isolation on a larger grid: the block search against a full
/// haversine scan (sphere radius 6371008.8 m), including far-away answers.
#[test]
fn isolation_geographic_full_scan() {
    let (w, h) = (150usize, 120usize);
    // Deterministic pseudo-random terrain (xorshift), a few isolated high cells.
    let mut s = 0x9e3779b97f4a7c15u64;
    let z: Vec<f32> = (0..w * h)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s % 1000) as f32
        })
        .collect();
    let g = Grid::from_vec(w, h, z.clone()).unwrap();
    let geo = GeoRef::north_up(10.0, 60.0, 0.01, Crs::wgs84());
    let idx = IsolationIndex::new(&g, &geo);
    let hav = |la0: f64, lo0: f64, la1: f64, lo1: f64| {
        let (a, b) = (la0.to_radians(), la1.to_radians());
        let x = ((b - a) / 2.0).sin().powi(2)
            + a.cos() * b.cos() * ((lo1 - lo0).to_radians() / 2.0).sin().powi(2);
        2.0 * 6_371_008.8 * x.sqrt().asin()
    };
    let ll = |i: usize| {
        (
            60.0 - ((i / w) as f64 + 0.5) * 0.01,
            10.0 + ((i % w) as f64 + 0.5) * 0.01,
        )
    };
    for &p in &[0usize, 77, 5000, 9999, 17999, w * h / 2 + 3] {
        for thr in [z[p], 990.0, 998.0] {
            let (la, lo) = ll(p);
            let mut best: Option<f64> = None;
            for (i, &v) in z.iter().enumerate() {
                if v > thr {
                    let (lb, lob) = ll(i);
                    let d = hav(la, lo, lb, lob);
                    if best.is_none_or(|b| d < b) {
                        best = Some(d);
                    }
                }
            }
            let got = idx.nearest_higher(p % w, p / w, thr);
            match (best, got) {
                (None, None) => {}
                (Some(d), Some(iso)) => {
                    assert!((iso.distance_m - d).abs() < 1e-6, "{d} vs {iso:?}")
                }
                other => panic!("mismatch {other:?}"),
            }
        }
    }
}
