//! Disjoint sets over `0..n` (union-find, Tarjan 1975, "Efficiency of a
//! good but not linear set union algorithm", J. ACM 22(2)): a flat array of
//! parents, finds with path halving (Tarjan & van Leeuwen 1984, "Worst-case
//! analysis of set union algorithms", J. ACM 31(2)).
//!
//! Which element stays the root of a union is the caller's choice, because
//! the callers index side arrays (tops, lowest levels, merged areas) by the
//! root and some read the root itself as a label: [`UnionFind::union_into`]
//! keeps the root it is told to keep, [`UnionFind::union_min`] keeps the lower
//! index. A caller wanting union by rank keeps the ranks beside the sets
//! (the divide-tree sweep does) and calls `union_into`. Path halving only
//! shortens paths; it never changes which element is a root, so every
//! caller's results are those of any other compression rule.
//!
//! No crate is used: petgraph's `UnionFind` and the `disjoint-sets` crate
//! choose the surviving root by rank, which would change which element
//! carries a component's data in the sweeps that use this type.

/// An element index of a [`UnionFind`]: `u32` (compact; most callers) or
/// `usize` (sets that may exceed 2^32 elements).
pub trait SetIndex: Copy + Eq + Ord + std::fmt::Debug {
    /// As an array index.
    fn index(self) -> usize;
    /// From an array index (`i < n` of a set built for `n` elements).
    fn from_index(i: usize) -> Self;
}

impl SetIndex for u32 {
    #[inline]
    fn index(self) -> usize {
        self as usize
    }
    #[inline]
    fn from_index(i: usize) -> Self {
        i as u32
    }
}

impl SetIndex for usize {
    #[inline]
    fn index(self) -> usize {
        self
    }
    #[inline]
    fn from_index(i: usize) -> Self {
        i
    }
}

/// Disjoint sets over `0..n`; see the module doc.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct UnionFind<I: SetIndex = u32> {
    parent: Vec<I>,
}

impl<I: SetIndex> UnionFind<I> {
    /// `n` singleton sets `{0}, {1}, …, {n-1}`. With `I = u32`, `n` must not
    /// exceed `u32::MAX as usize + 1`.
    pub fn new(n: usize) -> Self {
        debug_assert!(I::from_index(n.saturating_sub(1)).index() == n.saturating_sub(1));
        UnionFind {
            parent: (0..n).map(I::from_index).collect(),
        }
    }

    /// Number of elements.
    pub fn len(&self) -> usize {
        self.parent.len()
    }

    /// Whether there are no elements.
    pub fn is_empty(&self) -> bool {
        self.parent.is_empty()
    }

    /// The root of `x`'s set, halving the path on the way.
    #[inline]
    pub fn find(&mut self, mut x: I) -> I {
        let p = &mut self.parent;
        while p[x.index()] != x {
            let g = p[p[x.index()].index()];
            p[x.index()] = g;
            x = g;
        }
        x
    }

    /// Whether `x` is the root of its set (no path is changed).
    #[inline]
    pub fn is_root(&self, x: I) -> bool {
        self.parent[x.index()] == x
    }

    /// Join the set of root `other` into the set of root `keep`, which stays
    /// the root. Both must be roots (the callers hold them from [`find`]);
    /// `keep == other` does nothing.
    ///
    /// [`find`]: UnionFind::find
    #[inline]
    pub fn union_into(&mut self, keep: I, other: I) {
        debug_assert!(self.is_root(keep) && self.is_root(other));
        self.parent[other.index()] = keep;
    }

    /// Join the sets of roots `a` and `b`; the lower index stays the root,
    /// which is returned.
    #[inline]
    pub fn union_min(&mut self, a: I, b: I) -> I {
        let (lo, hi) = if a < b { (a, b) } else { (b, a) };
        self.union_into(lo, hi);
        lo
    }

    /// `a`'s set joins `b`'s: find both roots; if they differ, `b`'s root
    /// stays the root and `true` is returned; if `a` and `b` are already in
    /// one set (an edge `(a, b)` would close a cycle), `false`.
    #[inline]
    pub fn join(&mut self, a: I, b: I) -> bool {
        let (ra, rb) = (self.find(a), self.find(b));
        if ra == rb {
            return false;
        }
        self.union_into(rb, ra);
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn singletons_are_their_own_roots() {
        let mut uf = UnionFind::<u32>::new(4);
        assert_eq!(uf.len(), 4);
        for i in 0..4 {
            assert_eq!(uf.find(i), i);
            assert!(uf.is_root(i));
        }
        assert!(UnionFind::<usize>::new(0).is_empty());
    }

    #[test]
    fn union_into_keeps_the_named_root() {
        let mut uf = UnionFind::<u32>::new(6);
        uf.union_into(4, 1); // {1, 4} rooted at 4
        uf.union_into(4, 2); // {1, 2, 4}
        uf.union_into(5, 4); // {1, 2, 4, 5} rooted at 5: the higher index
        for x in [1, 2, 4, 5] {
            assert_eq!(uf.find(x), 5);
        }
        assert_eq!(uf.find(0), 0);
        assert_eq!(uf.find(3), 3);
        assert!(!uf.is_root(4));
        // The same root twice is a no-op.
        uf.union_into(5, 5);
        assert_eq!(uf.find(5), 5);
    }

    #[test]
    fn union_min_keeps_the_lower_index() {
        let mut uf = UnionFind::<usize>::new(8);
        assert_eq!(uf.union_min(6, 3), 3);
        assert_eq!(uf.union_min(7, 2), 2);
        let (a, b) = (uf.find(6), uf.find(7));
        assert_eq!(uf.union_min(a, b), 2);
        for x in [2, 3, 6, 7] {
            assert_eq!(uf.find(x), 2);
        }
        assert_eq!(uf.find(5), 5);
    }

    #[test]
    fn join_reports_cycles() {
        let mut uf = UnionFind::<usize>::new(4);
        assert!(uf.join(0, 1));
        assert_eq!(uf.find(0), 1);
        assert!(uf.join(1, 2));
        assert_eq!(uf.find(0), 2);
        // 0 and 2 are already one set: the edge (0, 2) closes a cycle.
        assert!(!uf.join(0, 2));
        assert!(uf.join(3, 0));
        assert_eq!(uf.find(3), 2);
    }

    #[test]
    fn finds_halve_long_chains_without_moving_the_root() {
        // A chain 0 -> 1 -> ... -> 99 (each joined into the next).
        let n = 100u32;
        let mut uf = UnionFind::<u32>::new(n as usize);
        for i in 0..n - 1 {
            uf.union_into(i + 1, i);
        }
        assert_eq!(uf.find(0), 99);
        // Halving: 0 now skips every other node, so it sits at depth <= 50.
        let mut depth = 0;
        let mut x = 0u32;
        while !uf.is_root(x) {
            x = uf.parent[x as usize];
            depth += 1;
        }
        assert!(depth <= 50, "depth {depth}");
        for i in 0..n {
            assert_eq!(uf.find(i), 99);
        }
    }

    #[test]
    fn matches_a_naive_labelling() {
        // Random unions against labels relabelled by brute force.
        let n = 200usize;
        let mut uf = UnionFind::<u32>::new(n);
        let mut label: Vec<usize> = (0..n).collect();
        let mut s = 12345u64;
        for _ in 0..300 {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let a = (s >> 33) as usize % n;
            let b = (s >> 13) as usize % n;
            let (ra, rb) = (uf.find(a as u32), uf.find(b as u32));
            uf.union_min(ra, rb);
            let (la, lb) = (label[a], label[b]);
            let lo = la.min(lb);
            for l in label.iter_mut() {
                if *l == la || *l == lb {
                    *l = lo;
                }
            }
        }
        for (x, &l) in label.iter().enumerate() {
            // union_min keeps the lowest index of each set as its root.
            assert_eq!(uf.find(x as u32) as usize, l);
        }
    }
}
