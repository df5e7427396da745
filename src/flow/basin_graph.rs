//! The basin graph sink resolver of Cordonnier, Bovy & Braun (2019, "A
//! versatile, linear complexity algorithm for flow routing in topographies
//! with depressions", *Earth Surface Dynamics* 7, 549–562): the basins of a
//! steepest-descent graph (the cells draining to each root), the passes
//! between adjacent basins (pass height = the higher of the two 8-adjacent
//! cells), a minimum spanning tree of the basins by Kruskal over the passes
//! with every base-level basin merged into one root, and then, from the root
//! outwards, each basin's receivers reversed from its pass cell down to its
//! pit with the pass cell pointed across the pass (their "carving"
//! variant).
//!
//! A basin's water level is the highest pass on its tree path to the root:
//! the minimum spanning tree holds the minimax paths, so this is the level a
//! priority flood gives (Barnes, Lehman & Mulla 2014), found in O(n) plus a
//! sort of the passes instead of a heap operation per cell. [`Lakes`] keeps
//! the levels (and the scratch of the resolvers, reused from call to call).
//!
//! The result does not depend on the order of the stack: basins are
//! numbered in stack order, but the tree, its orientation from the root and
//! each basin's carved path depend only on the receivers, the heights and
//! the row-major cell indices that break ties between equal passes.

use super::float::{order_key, FlowFloat};
use super::graph::FlowGraph;
use super::steepest::{BASE, VALID};
use crate::raster::neighbours::{DX, DY};
use crate::raster::UnionFind;
use std::collections::VecDeque;

/// Water levels of the depressions of one routing, with the scratch the
/// sink resolvers reuse.
#[derive(Debug, Clone, Default)]
pub struct Lakes<T> {
    /// Water level of each cell (its height where it is not under water).
    pub(super) level: Vec<T>,
    /// True when `level` holds the levels of the last routing.
    pub(super) active: bool,
    /// Basin id of each cell (the basin graph), or breadth-first flat
    /// distances (filling).
    pub(super) basin: Vec<u32>,
    pit_of: Vec<u32>,
    edges: Vec<(u64, u32, u32)>,
    tree: Vec<(u32, u32, u32)>,
    off: Vec<usize>,
    done: Vec<bool>,
    water: Vec<T>,
    pub(super) queue: VecDeque<u32>,
    pub(super) flats: Vec<u32>,
}

impl<T: FlowFloat> Lakes<T> {
    /// No levels yet.
    pub fn new() -> Lakes<T> {
        Lakes {
            level: Vec::new(),
            active: false,
            basin: Vec::new(),
            pit_of: Vec::new(),
            edges: Vec::new(),
            tree: Vec::new(),
            off: Vec::new(),
            done: Vec::new(),
            water: Vec::new(),
            queue: VecDeque::new(),
            flats: Vec::new(),
        }
    }

    /// The water level of every cell after a resolver ran (a cell is under
    /// water where its level is above its height), `None` when the last
    /// routing resolved no depression.
    pub fn levels(&self) -> Option<&[T]> {
        self.active.then_some(self.level.as_slice())
    }

    /// Forget the levels (a routing without depressions to resolve).
    pub fn clear(&mut self) {
        self.active = false;
    }

    /// Resolve the pits of the steepest-descent graph `g` on `z` (made by
    /// [`route_steepest`](super::route_steepest) with the same `flags`) by
    /// the basin graph; `carve` reverses the receivers from each pass to
    /// its pit (else only the levels are computed). Rebuilds `g`'s stack
    /// first (basins are found along it). `cell` is the cell size the
    /// distances of carved receivers are given in.
    pub fn basin_graph(
        &mut self,
        g: &mut FlowGraph<T>,
        z: &[T],
        flags: &[u8],
        cell: f64,
        carve: bool,
    ) {
        let (w, ht) = (g.width(), g.height());
        let n = w * ht;
        // Basin of each cell = its root, found along the stack.
        let left = g.build_stack();
        debug_assert_eq!(left, 0);
        self.basin.clear();
        self.basin.resize(n, u32::MAX);
        // Basin ids: 0 = every base level (the "ocean"), then pits in stack order.
        let mut nb = 1u32;
        self.pit_of.clear();
        self.pit_of.push(u32::MAX);
        for &s in g.stack() {
            let i = s as usize;
            let r = g.rec[i] as usize;
            if r == i {
                if flags[i] & BASE != 0 || flags[i] & VALID == 0 {
                    self.basin[i] = 0;
                } else {
                    self.basin[i] = nb;
                    self.pit_of.push(i as u32);
                    nb += 1;
                }
            } else {
                self.basin[i] = self.basin[r];
            }
        }
        // Candidate passes: each 8-neighbour pair once (E, SE, S, SW of each cell).
        self.edges.clear();
        for y in 0..ht {
            for x in 0..w {
                let i = y * w + x;
                if flags[i] & VALID == 0 {
                    continue;
                }
                for d in 0..4 {
                    let (nx, ny) = (x as i64 + DX[d], y as i64 + DY[d]);
                    if nx < 0 || ny < 0 || nx as usize >= w || ny as usize >= ht {
                        continue;
                    }
                    let j = ny as usize * w + nx as usize;
                    if flags[j] & VALID == 0 || self.basin[i] == self.basin[j] {
                        continue;
                    }
                    let ph = z[i].max(z[j]);
                    self.edges
                        .push((order_key(ph.to_f64()), i as u32, j as u32));
                }
            }
        }
        self.edges.sort_unstable();
        // Kruskal with a union-find over basins.
        let mut uf = UnionFind::<u32>::new(nb as usize);
        // Tree adjacency per basin: (other basin, cell in this basin, cell in other).
        self.tree.clear();
        for &(_, i, j) in &self.edges {
            let (bi, bj) = (self.basin[i as usize], self.basin[j as usize]);
            let (ri, rj) = (uf.find(bi), uf.find(bj));
            if ri == rj {
                continue;
            }
            uf.union_min(ri, rj);
            self.tree.push((bi, i, j));
            self.tree.push((bj, j, i));
            if self.tree.len() / 2 + 1 == nb as usize {
                break;
            }
        }
        self.tree.sort_unstable();
        self.off.clear();
        self.off.resize(nb as usize + 1, 0);
        for t in &self.tree {
            self.off[t.0 as usize + 1] += 1;
        }
        for b in 0..nb as usize {
            self.off[b + 1] += self.off[b];
        }
        // Orient from the root (basin 0), breadth first. A basin's water
        // level is the highest pass on its tree path to the root.
        self.done.clear();
        self.done.resize(nb as usize, false);
        self.water.clear();
        self.water.resize(nb as usize, T::NEG_INFINITY);
        self.queue.clear();
        self.done[0] = true;
        self.queue.push_back(0u32);
        let diag = T::from_f64(cell * std::f64::consts::SQRT_2);
        let side = T::from_f64(cell);
        while let Some(b) = self.queue.pop_front() {
            let (a, e) = (self.off[b as usize], self.off[b as usize + 1]);
            for k in a..e {
                let (_, out_cell, in_cell) = self.tree[k];
                let c = self.basin[in_cell as usize];
                if self.done[c as usize] {
                    continue;
                }
                self.done[c as usize] = true;
                self.queue.push_back(c);
                let pass = z[out_cell as usize].max(z[in_cell as usize]);
                self.water[c as usize] = pass.max(self.water[b as usize]);
                if !carve {
                    continue;
                }
                // Reverse the path in_cell -> ... -> pit, then in_cell -> out_cell.
                let pit = self.pit_of[c as usize] as usize;
                let mut prev = out_cell as usize;
                let mut cur = in_cell as usize;
                loop {
                    let next = g.rec[cur] as usize;
                    g.rec[cur] = prev as u32;
                    let diagonal = cur % w != prev % w && cur / w != prev / w;
                    g.dist[cur] = if diagonal { diag } else { side };
                    if cur == pit {
                        break;
                    }
                    prev = cur;
                    cur = next;
                }
            }
        }
        self.level.clear();
        let water = &self.water;
        self.level.extend(z.iter().zip(&self.basin).map(|(&h, &b)| {
            if b == u32::MAX {
                h
            } else {
                h.max(water[b as usize])
            }
        }));
        self.active = true;
    }
}
