//! An undirected graph over the nodes `0..n` in compressed sparse row form
//! (the CSR layout of Saad 2003, *Iterative Methods for Sparse Linear
//! Systems*, 2nd ed., sec. 3.4): one array of neighbour lists, one of their
//! starts, built from an edge list by a counting pass and a prefix sum.

/// Neighbour lists of an undirected graph over `0..n`; see the module doc.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Adjacency {
    /// `start[v]..start[v + 1]` is `v`'s range of `adj`.
    start: Vec<usize>,
    adj: Vec<u32>,
}

impl Adjacency {
    /// The graph over `0..n` with the edges `edges` (each `(a, b)` joins `a`
    /// and `b` both ways; `a, b < n`). Each node's neighbours are in the
    /// order of its edges in `edges`; a repeated edge is repeated.
    pub fn undirected(n: usize, edges: &[(u32, u32)]) -> Adjacency {
        let mut start = vec![0usize; n + 1];
        for &(a, b) in edges {
            start[a as usize + 1] += 1;
            start[b as usize + 1] += 1;
        }
        for i in 0..n {
            start[i + 1] += start[i];
        }
        let mut at = start.clone();
        let mut adj = vec![0u32; start[n]];
        for &(a, b) in edges {
            adj[at[a as usize]] = b;
            at[a as usize] += 1;
            adj[at[b as usize]] = a;
            at[b as usize] += 1;
        }
        Adjacency { start, adj }
    }

    /// The neighbours of `v`.
    #[inline]
    pub fn neighbours(&self, v: usize) -> &[u32] {
        &self.adj[self.start[v]..self.start[v + 1]]
    }
}

#[cfg(test)]
mod tests {
    use super::Adjacency;

    #[test]
    fn neighbours_in_edge_order_both_ways() {
        // 0 - 1, 2 - 0, 1 - 3, and node 4 alone
        let g = Adjacency::undirected(5, &[(0, 1), (2, 0), (1, 3)]);
        assert_eq!(g.neighbours(0), &[1, 2]);
        assert_eq!(g.neighbours(1), &[0, 3]);
        assert_eq!(g.neighbours(2), &[0]);
        assert_eq!(g.neighbours(3), &[1]);
        assert!(g.neighbours(4).is_empty());
        assert!(Adjacency::undirected(0, &[]).adj.is_empty());
    }
}
