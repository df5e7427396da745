//! Ridge clearance against brute-force oracles: offences, pass heights,
//! planarity and the tree kept.

use super::*;
use crate::oro::stats::SplitMix64;
use crate::synth::orometric::tree_synth::{ridge_tree, SynthPeak, SynthSaddle};

/// A free peak at the centre of cell (x, y) of 30 m cells.
fn pk(x: f64, y: f64, e: f64) -> SynthPeak {
    SynthPeak {
        x: (x + 0.5) * 30.0,
        y: (y + 0.5) * 30.0,
        elevation: e,
        fixed: false,
    }
}

/// A saddle at the centre of cell (x, y) of 30 m cells, joining a, b.
fn sd(x: f64, y: f64, e: f64, a: usize, b: usize) -> SynthSaddle {
    SynthSaddle {
        x: (x + 0.5) * 30.0,
        y: (y + 0.5) * 30.0,
        elevation: e,
        peaks: [a, b],
    }
}

/// Random peaks at cell centres two cells apart, ridges the Delaunay
/// minimum spanning tree, each saddle at its ridge's midpoint below both
/// ends.
fn random_tree(n: usize, seed: u64) -> SynthTree {
    let mut r = SplitMix64(seed);
    let (side, cell) = (60usize, 30.0);
    let mut peaks: Vec<SynthPeak> = Vec::new();
    while peaks.len() < n {
        let x = ((r.unit() * side as f64).floor() + 0.5) * cell;
        let y = ((r.unit() * side as f64).floor() + 0.5) * cell;
        if peaks.iter().all(|p| (p.x - x).hypot(p.y - y) >= 2.0 * cell) {
            peaks.push(SynthPeak {
                x,
                y,
                elevation: 1000.0 + 1000.0 * r.unit(),
                fixed: r.unit() < 0.1,
            });
        }
    }
    let saddles = ridge_tree(&peaks, 0)
        .unwrap()
        .into_iter()
        .map(|(a, b)| {
            let lo = peaks[a].elevation.min(peaks[b].elevation);
            SynthSaddle {
                x: 0.5 * (peaks[a].x + peaks[b].x),
                y: 0.5 * (peaks[a].y + peaks[b].y),
                elevation: lo - 1.0 - 400.0 * r.unit(),
                peaks: [a, b],
            }
        })
        .collect();
    SynthTree {
        format: "orogen-synthtree".into(),
        version: 1,
        width: side,
        height: side,
        cell,
        seed,
        min_prominence: 20.0,
        peaks,
        saddles,
    }
}

/// Oracle pass height: the lowest node on the tree path between two
/// points, each a peak (`None` half) or a point splitting half-ridge
/// (p, k) at elevation z, by depth-first search over peaks, saddles and
/// the split points.
fn brute_pass(t: &SynthTree, from: (usize, Option<(usize, f64)>), to: (usize, usize, f64)) -> f64 {
    let (np, ns) = (t.peaks.len(), t.saddles.len());
    let mut w: Vec<f64> = t.peaks.iter().map(|p| p.elevation).collect();
    w.extend(t.saddles.iter().map(|s| s.elevation));
    let mut splits = vec![(to.0, to.1, to.2)];
    if let (p, Some((k, z))) = from {
        splits.push((p, k, z));
    }
    let mut adj = vec![Vec::new(); np + ns + splits.len()];
    for (k, s) in t.saddles.iter().enumerate() {
        for &q in &s.peaks {
            let mut chain = vec![q];
            for (m, &(sp, sk, z)) in splits.iter().enumerate() {
                if sp == q && sk == k {
                    chain.push(np + ns + m);
                    w.push(z);
                }
            }
            chain.push(np + k);
            for pair in chain.windows(2) {
                adj[pair[0]].push(pair[1]);
                adj[pair[1]].push(pair[0]);
            }
        }
    }
    w.resize(np + ns + splits.len(), f64::NAN);
    let start = if from.1.is_some() {
        np + ns + 1
    } else {
        from.0
    };
    let mut low = vec![f64::NAN; w.len()];
    low[start] = w[start];
    let mut stack = vec![start];
    while let Some(u) = stack.pop() {
        for &v in &adj[u] {
            if low[v].is_nan() {
                low[v] = low[u].min(w[v]);
                stack.push(v);
            }
        }
    }
    low[np + ns]
}

type Point3 = (f64, f64, f64);

/// Oracle offences of a peak or saddle: the distance between the
/// nearest offending pair of points sampled along the half-ridges (a
/// saddle's crest: the half-ridges on either side of it).
fn brute_offence(t: &SynthTree, node: Node, clear: f64, tol: f64) -> Option<f64> {
    let inf = f64::INFINITY;
    let sample = |p: usize, k: usize, n: usize| -> Vec<Point3> {
        let (a, s) = (&t.peaks[p], &t.saddles[k]);
        (0..=n)
            .map(|j| {
                let u = j as f64 / n as f64;
                let z = a.elevation + u * (s.elevation - a.elevation);
                (a.x + u * (s.x - a.x), a.y + u * (s.y - a.y), z)
            })
            .collect()
    };
    let mut best: Option<f64> = None;
    for (k, s) in t.saddles.iter().enumerate() {
        for &p in &s.peaks {
            if node == Node::Peak(p) || node == Node::Saddle(k) {
                continue;
            }
            // (this node's crest points, the lowest other node on the
            // path from them to the half-ridge's interior)
            let crests: Vec<(Vec<Point3>, f64)> = match node {
                Node::Peak(i) => vec![(
                    vec![(t.peaks[i].x, t.peaks[i].y, t.peaks[i].elevation)],
                    brute_pass(t, (i, None), (p, k, inf)),
                )],
                Node::Saddle(j) => t.saddles[j]
                    .peaks
                    .iter()
                    .map(|&q| {
                        (
                            sample(q, j, 60),
                            brute_pass(t, (q, Some((j, inf))), (p, k, inf)),
                        )
                    })
                    .collect(),
            };
            let ys = sample(
                p,
                k,
                if matches!(node, Node::Peak(_)) {
                    400
                } else {
                    60
                },
            );
            for (xs, other) in &crests {
                for &(x0, y0, z0) in xs {
                    for &(x, y, z) in &ys[1..ys.len() - 1] {
                        let d = (x - x0).hypot(y - y0);
                        // The pass through both points is the lowest of
                        // them and the path's other nodes.
                        if d < clear && z0.min(z) > z0.min(z).min(*other) + tol {
                            best = Some(best.map_or(d, |b: f64| b.min(d)));
                        }
                    }
                }
            }
        }
    }
    best
}

/// A half-ridge: peak end, saddle end, peak index, saddle index.
type Half = ((f64, f64), (f64, f64), usize, usize);

fn segments(t: &SynthTree) -> Vec<Half> {
    let mut v = Vec::new();
    for (k, s) in t.saddles.iter().enumerate() {
        for &p in &s.peaks {
            v.push(((t.peaks[p].x, t.peaks[p].y), (s.x, s.y), p, k));
        }
    }
    v
}

/// Pairs of half-ridges that touch without sharing an end, by brute
/// force (orientation signs written out again).
fn crossings(t: &SynthTree) -> usize {
    let seg = segments(t);
    let side = |a: (f64, f64), b: (f64, f64), c: (f64, f64)| {
        ((b.0 - a.0) * (c.1 - a.1) - (b.1 - a.1) * (c.0 - a.0)).signum()
    };
    let mut n = 0;
    for i in 0..seg.len() {
        for j in i + 1..seg.len() {
            let (a, b, pa, ka) = seg[i];
            let (c, d, pb, kb) = seg[j];
            if pa == pb || ka == kb {
                continue;
            }
            if side(a, b, c) * side(a, b, d) <= 0.0 && side(c, d, a) * side(c, d, b) <= 0.0 {
                n += 1;
            }
        }
    }
    n
}

#[test]
fn offences_match_a_brute_force_oracle() {
    let (mut flagged, mut saddles) = (0, 0);
    for seed in 1..5 {
        let t = random_tree(30, seed);
        // No tolerance: no margin rule to model in the oracle.
        let (clear, tol) = (75.0, 0.0);
        let found = offenders(&t, clear, tol);
        flagged += found.len();
        saddles += found
            .iter()
            .filter(|n| matches!(n, Node::Saddle(_)))
            .count();
        let nodes = (0..t.peaks.len())
            .map(Node::Peak)
            .chain((0..t.saddles.len()).map(Node::Saddle));
        for n in nodes {
            let f = found.contains(&n);
            // Sampling misses offences that only graze the circle, so
            // the converse allows a sample spacing.
            if let Some(d) = brute_offence(&t, n, clear, tol) {
                assert!(f, "seed {seed} {n:?}: oracle offence at {d} m missed");
            }
            if f {
                assert!(
                    brute_offence(&t, n, clear + 15.0, tol - 0.5).is_some(),
                    "seed {seed} {n:?}: flagged without an offence"
                );
            }
        }
    }
    assert!(
        flagged > saddles && saddles > 0,
        "{flagged} offenders, {saddles} saddles"
    );
}

/// The tolerance shrinks to half the margin of the peak a join would
/// drop: the crest beside a saddle whose peak clears the threshold by
/// 1.5 m offends at a tolerance of 5 m (its part 0.75 m above the saddle
/// is within 85 m of a foreign ridge), and not once the margin is 6.4 m
/// (3.2 m above the saddle, the crest is 4 cells from that ridge).
#[test]
fn near_threshold_peaks_shrink_the_tolerance() {
    // Peak 0 (210 m) with two ridges leaving east, 3° apart: to peak 1
    // (a low peak, saddle 0 at 178.5 m) and to peak 2 (saddle 1 at
    // 204 m). Threshold 5 m.
    let tree = |thr: f64| SynthTree {
        format: "orogen-synthtree".into(),
        version: 1,
        width: 60,
        height: 60,
        cell: 30.0,
        seed: 1,
        min_prominence: thr,
        peaks: vec![
            pk(10.0, 10.0, 210.0),
            pk(24.0, 12.0, 185.0),
            pk(28.0, 31.0, 217.0),
        ],
        saddles: vec![sd(15.0, 14.0, 178.5, 0, 1), sd(19.0, 18.0, 204.0, 0, 2)],
    };
    let near = tree(5.0);
    assert_eq!(near.prominences()[1], 6.5);
    assert!(offenders(&near, 85.0, 5.0).contains(&Node::Saddle(0)));
    let far = tree(0.1);
    assert!(!offenders(&far, 85.0, 5.0).contains(&Node::Saddle(0)));
    // Without tolerance, the join offends either way.
    assert!(offenders(&far, 85.0, 0.0).contains(&Node::Saddle(0)));
}

#[test]
fn clearing_moves_free_peaks_keeps_ridges_planar_and_the_tree() {
    let mut cleared = 0;
    for seed in 1..9 {
        let mut t = random_tree(60, seed);
        let before = t.clone();
        assert_eq!(crossings(&t), 0);
        let (clear, tol) = (75.0, 10.0);
        let n0 = offenders(&t, clear, tol).len();
        let st = clear_ridges(&mut t, clear, tol, &mut |_, _, _| true);
        let left = offenders(&t, clear, tol);
        assert!(left.len() <= n0, "seed {seed}: {n0} → {}", left.len());
        cleared += n0 - left.len();
        assert_eq!(crossings(&t), 0, "seed {seed}: ridges cross");
        for (s, q) in t.saddles.iter().zip(&before.saddles) {
            assert_eq!((s.elevation, s.peaks), (q.elevation, q.peaks));
            let on_a_peak = t.peaks.iter().any(|p| {
                (p.x / t.cell).floor() == (s.x / t.cell).floor()
                    && (p.y / t.cell).floor() == (s.y / t.cell).floor()
            });
            assert!(!on_a_peak, "a saddle moved onto a peak's cell");
        }
        for (i, (p, q)) in t.peaks.iter().zip(&before.peaks).enumerate() {
            assert_eq!(p.elevation, q.elevation);
            if q.fixed {
                assert_eq!((p.x, p.y), (q.x, q.y), "fixed peak {i} moved");
            }
            // Cell centres inside the domain, two cells from the others.
            for v in [p.x, p.y] {
                let c = v / t.cell - 0.5;
                assert!((0.0..60.0).contains(&c) && c.fract() == 0.0, "{v}");
            }
            for p2 in &t.peaks[i + 1..] {
                assert!((p.x - p2.x).hypot(p.y - p2.y) >= 2.0 * t.cell - 1e-9);
            }
        }
        let moved = st.moves;
        // Deterministic.
        let mut again = before.clone();
        clear_ridges(&mut again, clear, tol, &mut |_, _, _| true);
        assert_eq!(again, t);
        // A veto keeps everything in place.
        let mut kept = before.clone();
        let st2 = clear_ridges(&mut kept, clear, tol, &mut |_, _, _| false);
        assert_eq!((st2.moves, kept), (0, before.clone()));
        assert!(moved == 0 || n0 > 0);
    }
    assert!(cleared > 0, "no offence was cleared on any seed");
}

/// A low peak one cell beside the high ridge of a peak it is joined
/// to only through a deep saddle moves to `clear` from that ridge.
#[test]
fn a_peak_beside_a_foreign_ridge_moves_away() {
    // 0: high peak with a ridge east to peak 1 over saddle 0 (1800 m);
    // 2: low peak just south of that ridge, joined to peak 0 from the
    // west through a 900 m saddle.
    let mut t = SynthTree {
        format: "orogen-synthtree".into(),
        version: 1,
        width: 40,
        height: 40,
        cell: 30.0,
        seed: 1,
        min_prominence: 20.0,
        peaks: vec![
            pk(10.0, 20.0, 2000.0),
            pk(30.0, 20.0, 1900.0),
            pk(20.0, 21.0, 1000.0),
        ],
        saddles: vec![sd(24.0, 20.0, 1800.0, 0, 1), sd(12.0, 30.0, 900.0, 0, 2)],
    };
    // Seen from the saddles too: peak 2 is on saddle 1's crest, and
    // saddle 0's crest runs beside it.
    assert_eq!(
        offenders(&t, 75.0, 10.0),
        vec![Node::Peak(2), Node::Saddle(0), Node::Saddle(1)]
    );
    let st = clear_ridges(&mut t, 75.0, 10.0, &mut |n, _, _| n == Node::Peak(2));
    assert_eq!(st, ClearStats { moves: 1 });
    assert!(offenders(&t, 75.0, 10.0).is_empty());
    let p = &t.peaks[2];
    // Straight away (south, +y), past 75 m from the ridge y = 20.5 cells.
    assert_eq!(p.x, 20.5 * 30.0);
    assert!(p.y - 20.5 * 30.0 >= 75.0, "{}", p.y);
}
