//! Pass heights of a divide tree: for two points on its refined ridges, the
//! highest elevation at which one can walk from one to the other along the
//! ridges (the minimum elevation on their tree path).
//!
//! A terrain keeps the tree's topology exactly when every other path between
//! the two points goes below that height (Argudo et al. 2019, §6.1: river
//! elevation bounds "propagated from the saddles"). [`super::rivers`] caps
//! each river node and each gap between ridges by the pass height of the
//! ridge points on either side of it.
//!
//! Peaks are the leaves of a Kruskal reconstruction tree: the saddles in
//! decreasing elevation join the peak sets they connect (union-find), each
//! join a new node at the saddle's elevation, so the pass height of two
//! peaks is the elevation of their lowest common ancestor (Kruskal 1956; the
//! "merge tree" of contour-tree algorithms, Carr, Snoeyink & Axen 2003,
//! "Computing contour trees in all dimensions", §3). Ancestors by binary
//! lifting: O(P log P) memory and time to build, O(log P) per query.

use super::tree_synth::SynthTree;
use crate::raster::UnionFind;

/// Where a refined ridge point lies: a peak, a saddle, or the half-ridge
/// from a peak to one of its saddles.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RidgeAnchor {
    Peak(u32),
    Saddle(u32),
    /// (peak, saddle): between that peak and that saddle.
    Half(u32, u32),
}

/// Pass-height queries on a divide tree (see the module doc).
pub struct PassHeights {
    /// Ancestor tables: `up[j][v]` is the 2^j-th ancestor of node v.
    up: Vec<Vec<u32>>,
    depth: Vec<u32>,
    /// Elevation of each node: +∞ for a peak (a leaf), the saddle's for a join.
    elev: Vec<f64>,
    saddle_z: Vec<f64>,
    saddle_peaks: Vec<[u32; 2]>,
}

impl PassHeights {
    /// The merge tree of `tree` (validated: connected, one saddle per ridge).
    pub fn new(tree: &SynthTree) -> PassHeights {
        let np = tree.peaks.len();
        let ns = tree.saddles.len();
        let n = np + ns;
        let mut parent = vec![u32::MAX; n];
        let mut elev = vec![f64::INFINITY; n];
        // Union-find over peaks; `top[root]` is the merge-tree node of the set.
        let mut uf = UnionFind::<u32>::new(np);
        let mut top: Vec<u32> = (0..np as u32).collect();
        let mut order: Vec<usize> = (0..ns).collect();
        order.sort_by(|&a, &b| {
            tree.saddles[b]
                .elevation
                .total_cmp(&tree.saddles[a].elevation)
                .then(a.cmp(&b))
        });
        let mut next = np;
        for k in order {
            let [a, b] = tree.saddles[k].peaks;
            let (ra, rb) = (uf.find(a as u32), uf.find(b as u32));
            if ra == rb {
                continue;
            }
            elev[next] = tree.saddles[k].elevation;
            parent[top[ra as usize] as usize] = next as u32;
            parent[top[rb as usize] as usize] = next as u32;
            uf.union_into(ra, rb);
            top[ra as usize] = next as u32;
            next += 1;
        }
        let n = next;
        parent.truncate(n);
        elev.truncate(n);
        // Roots point to themselves; depth from the roots down (a parent
        // always has a larger index than its children).
        for (v, p) in parent.iter_mut().enumerate() {
            if *p == u32::MAX {
                *p = v as u32;
            }
        }
        let mut depth = vec![0u32; n];
        for v in (0..n).rev() {
            let p = parent[v] as usize;
            if p != v {
                depth[v] = depth[p] + 1;
            }
        }
        let levels = (usize::BITS - n.max(1).leading_zeros()) as usize + 1;
        let mut up = vec![parent];
        for j in 1..levels {
            let prev = &up[j - 1];
            let cur: Vec<u32> = (0..n).map(|v| prev[prev[v] as usize]).collect();
            up.push(cur);
        }
        PassHeights {
            up,
            depth,
            elev,
            saddle_z: tree.saddles.iter().map(|s| s.elevation).collect(),
            saddle_peaks: tree
                .saddles
                .iter()
                .map(|s| [s.peaks[0] as u32, s.peaks[1] as u32])
                .collect(),
        }
    }

    /// Pass height between peaks `a` and `b` (+∞ if a == b, −∞ if the tree
    /// does not connect them).
    pub fn peaks(&self, a: u32, b: u32) -> f64 {
        if a == b {
            return f64::INFINITY;
        }
        let (mut a, mut b) = (a as usize, b as usize);
        if self.depth[a] < self.depth[b] {
            std::mem::swap(&mut a, &mut b);
        }
        let mut d = self.depth[a] - self.depth[b];
        let mut j = 0;
        while d > 0 {
            if d & 1 == 1 {
                a = self.up[j][a] as usize;
            }
            d >>= 1;
            j += 1;
        }
        if a == b {
            return self.elev[a];
        }
        for j in (0..self.up.len()).rev() {
            let (ua, ub) = (self.up[j][a], self.up[j][b]);
            if ua != ub {
                a = ua as usize;
                b = ub as usize;
            }
        }
        let (pa, pb) = (self.up[0][a], self.up[0][b]);
        if pa != pb {
            return f64::NEG_INFINITY;
        }
        self.elev[pa as usize]
    }

    /// The ways out of a ridge point onto the peak tree: (peak, lowest
    /// elevation passed on the way).
    fn exits(&self, a: RidgeAnchor) -> ([(u32, f64); 2], usize) {
        match a {
            RidgeAnchor::Peak(p) => ([(p, f64::INFINITY), (p, f64::INFINITY)], 1),
            RidgeAnchor::Saddle(k) => {
                let [p, q] = self.saddle_peaks[k as usize];
                ([(p, f64::INFINITY), (q, f64::INFINITY)], 2)
            }
            RidgeAnchor::Half(p, k) => {
                let [a, b] = self.saddle_peaks[k as usize];
                let other = if a == p { b } else { a };
                ([(p, f64::INFINITY), (other, self.saddle_z[k as usize])], 2)
            }
        }
    }

    /// Pass height between two ridge points at elevations `za`, `zb`.
    ///
    /// The tree path leaves each point through one of its exits; a wrong
    /// exit only adds nodes to the path, so the true pass height is the
    /// largest over the exit pairs. Two points of one half-ridge see each
    /// other along it: the lower of the two.
    pub fn between(&self, a: RidgeAnchor, za: f64, b: RidgeAnchor, zb: f64) -> f64 {
        let (ea, na) = self.exits(a);
        let (eb, nb) = self.exits(b);
        let mut best = f64::NEG_INFINITY;
        for &(pa, ca) in &ea[..na] {
            for &(pb, cb) in &eb[..nb] {
                best = best.max(ca.min(cb).min(self.peaks(pa, pb)));
            }
        }
        za.min(zb).min(best)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::oro::stats::SplitMix64;
    use crate::synth::orometric::tree_synth::{SynthPeak, SynthSaddle};

    /// A random tree: peak i joins a random earlier peak through a saddle
    /// below both.
    fn random_tree(n: usize, seed: u64) -> SynthTree {
        let mut r = SplitMix64(seed);
        let mut t = SynthTree {
            format: "orogen-synthtree".into(),
            version: 1,
            width: 100,
            height: 100,
            cell: 30.0,
            seed,
            min_prominence: 1.0,
            peaks: Vec::new(),
            saddles: Vec::new(),
        };
        for i in 0..n {
            t.peaks.push(SynthPeak {
                x: 15.0,
                y: 15.0,
                elevation: 1000.0 + 1000.0 * r.unit(),
                fixed: false,
            });
            if i > 0 {
                let j = (r.unit() * i as f64) as usize;
                let lo = t.peaks[i].elevation.min(t.peaks[j].elevation);
                t.saddles.push(SynthSaddle {
                    x: 15.0,
                    y: 15.0,
                    elevation: lo - 1.0 - 900.0 * r.unit(),
                    peaks: [j, i],
                });
            }
        }
        t
    }

    /// Oracle: the tree as a node-weighted graph (peaks, saddles, and one
    /// extra point splitting the half-ridge `split` = (peak, saddle) at
    /// elevation `zx`), and the lowest node on the unique path from `a` to
    /// `b`, found by depth-first search. Nodes: peaks 0..P, saddles P..P+S,
    /// the extra point P+S.
    fn brute(t: &SynthTree, split: Option<(usize, usize, f64)>, a: usize, b: usize) -> f64 {
        let (np, ns) = (t.peaks.len(), t.saddles.len());
        let mut w: Vec<f64> = t.peaks.iter().map(|p| p.elevation).collect();
        w.extend(t.saddles.iter().map(|s| s.elevation));
        let mut adj = vec![Vec::new(); np + ns + 1];
        let link = |adj: &mut Vec<Vec<usize>>, u: usize, v: usize| {
            adj[u].push(v);
            adj[v].push(u);
        };
        for (k, s) in t.saddles.iter().enumerate() {
            for &p in &s.peaks {
                match split {
                    Some((sp, sk, _)) if sp == p && sk == k => {
                        link(&mut adj, p, np + ns);
                        link(&mut adj, np + ns, np + k);
                    }
                    _ => link(&mut adj, p, np + k),
                }
            }
        }
        w.push(split.map_or(f64::NAN, |s| s.2));
        let mut best = vec![f64::NAN; w.len()];
        best[a] = w[a];
        let mut stack = vec![a];
        while let Some(v) = stack.pop() {
            for &u in &adj[v] {
                if best[u].is_nan() {
                    best[u] = best[v].min(w[u]);
                    stack.push(u);
                }
            }
        }
        best[b]
    }

    #[test]
    fn peak_pass_heights_equal_the_lowest_saddle_on_the_path() {
        for seed in 1..6 {
            let t = random_tree(40, seed);
            let ph = PassHeights::new(&t);
            for a in 0..40 {
                for b in 0..40 {
                    let want = if a == b {
                        f64::INFINITY
                    } else {
                        brute(&t, None, a, b)
                    };
                    assert_eq!(ph.peaks(a as u32, b as u32), want, "{a} {b}");
                }
            }
        }
    }

    #[test]
    fn ridge_points_pass_through_their_saddle_or_peak() {
        let t = random_tree(30, 9);
        let (np, ns) = (t.peaks.len(), t.saddles.len());
        let ph = PassHeights::new(&t);
        for (k, s) in t.saddles.iter().enumerate() {
            for p in s.peaks {
                // A point on p's half of ridge k, 10 m above the saddle.
                let h = RidgeAnchor::Half(p as u32, k as u32);
                let zh = s.elevation + 10.0;
                let sp = Some((p, k, zh));
                for c in 0..np {
                    let got = ph.between(h, zh, RidgeAnchor::Peak(c as u32), t.peaks[c].elevation);
                    assert_eq!(got, brute(&t, sp, np + ns, c), "saddle {k} peak {c}");
                }
                for (k2, s2) in t.saddles.iter().enumerate() {
                    let got = ph.between(h, zh, RidgeAnchor::Saddle(k2 as u32), s2.elevation);
                    assert_eq!(
                        got,
                        brute(&t, sp, np + ns, np + k2),
                        "saddle {k} saddle {k2}"
                    );
                }
                // Two points of one half-ridge: the lower one.
                assert_eq!(ph.between(h, zh, h, zh + 5.0), zh);
            }
        }
    }
}
