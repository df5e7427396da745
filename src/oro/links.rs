//! Ridge links of the divide tree: which peak each key saddle reaches by
//! steepest ascent on either side.
//!
//! The divide tree of Kirmse & de Ferranti 2017 joins each saddle to the two
//! peaks reached by walking uphill from it, one in each of the components it
//! separates. `tree.rs` stores instead each peak's *prominence* parent, which
//! is not ridge-adjacent. This module recovers the ridge adjacency from the
//! DEM: a descending union-find sweep over flat regions (the join-tree sweep
//! of Carr, Snoeyink & Axen 2003, without the sea) records, at every merge,
//! the highest cell next to the saddle in each merging component (the entry
//! cell); steepest ascent from an entry cell stays inside its component and
//! ends at one of its peaks.
//!
//! Steepest ascent works on flat regions so plateaus are exact: from a region,
//! go to the highest cell adjacent to it and strictly higher (ties: smallest
//! row-major index); a region with no higher neighbour is a peak, named by its
//! representative (first) cell, as in `tree.rs`.
//!
//! Sweep order and tie rule are those of `tree.rs` (elevation decreasing, then
//! region id decreasing), so "higher" of two equal peaks means the same thing.

use super::regions::{neighbours_in, Regions, NONE};
use crate::error::Result;
use crate::raster::{Grid, UnionFind};

/// One merge at a saddle: a losing component (top peak `loser_top`) meets
/// the winning one. A k-way saddle gives k − 1 events.
#[derive(Debug, Clone, Copy)]
pub(crate) struct MergeEvent {
    /// Region of the saddle.
    pub saddle: u32,
    /// Highest cell next to the saddle region in the losing component.
    pub loser_entry: u32,
    /// Highest cell next to the saddle region in the winning component.
    pub winner_entry: u32,
}

/// Regions, steepest-ascent pointers and merge events of one DEM.
pub(crate) struct Links {
    pub reg: Regions,
    /// Per region: the cell its steepest ascent moves to (NONE: a peak).
    pub exit: Vec<u32>,
    /// Per peak region: index into `events` of the merge it lost (NONE: it
    /// never lost, i.e. it is the top of its connected area).
    pub lost_at: Vec<u32>,
    pub events: Vec<MergeEvent>,
}

impl Links {
    /// Build the links of `dem` (NaN = nodata).
    pub fn new(dem: &Grid<f32>) -> Result<Links> {
        let reg = Regions::new(dem)?;
        let (w, h) = (reg.width, reg.height);
        let data = dem.data();
        let nreg = reg.len();
        // Steepest-ascent exits, one pass over all cells.
        let mut exit = vec![NONE; nreg];
        for (c, &r) in reg.label.iter().enumerate() {
            if r == NONE {
                continue;
            }
            let z = reg.elev[r as usize];
            for (n, nz) in higher_neighbours(data, w, h, c, z) {
                let e = &mut exit[r as usize];
                if *e == NONE
                    || nz > data[*e as usize]
                    || (nz == data[*e as usize] && (n as u32) < *e)
                {
                    *e = n as u32;
                }
            }
        }
        // Sweep order: elevation decreasing, region id decreasing on ties.
        let mut order: Vec<u32> = (0..nreg as u32).collect();
        order.sort_unstable_by(|&a, &b| {
            // + 0.0 makes -0.0 equal to 0.0, as in `tree.rs`.
            let (za, zb) = (reg.elev[a as usize] + 0.0, reg.elev[b as usize] + 0.0);
            zb.total_cmp(&za).then(b.cmp(&a))
        });
        let mut pos = vec![0u32; nreg];
        for (i, &r) in order.iter().enumerate() {
            pos[r as usize] = i as u32;
        }
        let mut uf = UnionFind::<u32>::new(nreg);
        let mut top = vec![NONE; nreg];
        let mut lost_at = vec![NONE; nreg];
        let mut events = Vec::new();
        // (root, entry cell) of the components around the current region.
        let mut around: Vec<(u32, u32)> = Vec::with_capacity(8);
        for &r in &order {
            let z = reg.elev[r as usize];
            around.clear();
            for &c in reg.cells_of(r as usize) {
                for (n, nz) in higher_neighbours(data, w, h, c as usize, z) {
                    let root = uf.find(reg.label[n]);
                    match around.iter_mut().find(|(rt, _)| *rt == root) {
                        Some((_, e)) => {
                            let ez = data[*e as usize];
                            if nz > ez || (nz == ez && (n as u32) < *e) {
                                *e = n as u32;
                            }
                        }
                        None => around.push((root, n as u32)),
                    }
                }
            }
            if around.is_empty() {
                top[r as usize] = r;
                continue;
            }
            let &(wroot, wentry) = around
                .iter()
                .min_by_key(|(rt, _)| pos[top[*rt as usize] as usize])
                .expect("non-empty");
            let wtop = top[wroot as usize];
            for &(root, entry) in &around {
                if root == wroot {
                    continue;
                }
                let t = top[root as usize];
                lost_at[t as usize] = events.len() as u32;
                events.push(MergeEvent {
                    saddle: r,
                    loser_entry: entry,
                    winner_entry: wentry,
                });
                uf.union_into(wroot, root);
            }
            uf.union_into(wroot, r);
            top[wroot as usize] = wtop;
        }
        Ok(Links {
            reg,
            exit,
            lost_at,
            events,
        })
    }

    /// Region of a cell.
    pub fn region_of(&self, cell: u32) -> u32 {
        self.reg.label[cell as usize]
    }

    /// Peak region reached by steepest ascent from `cell`.
    pub fn ascend(&self, cell: u32) -> u32 {
        let mut r = self.region_of(cell);
        // Each step goes strictly up, so the walk ends.
        while self.exit[r as usize] != NONE {
            r = self.region_of(self.exit[r as usize]);
        }
        r
    }

    /// Cells visited by steepest ascent from `cell` (the start, then each
    /// exit cell), ending on the peak region reached.
    pub fn ascent_path(&self, cell: u32) -> (Vec<u32>, u32) {
        let mut path = vec![cell];
        let mut r = self.region_of(cell);
        while self.exit[r as usize] != NONE {
            let e = self.exit[r as usize];
            path.push(e);
            r = self.region_of(e);
        }
        let rep = self.reg.rep(r as usize);
        if *path.last().expect("non-empty") != rep {
            path.push(rep);
        }
        (path, r)
    }

    /// The ridge-adjacent peak on the far side of the key saddle of peak
    /// region `p` (None if `p` never lost a merge).
    pub fn ridge_next(&self, p: u32) -> Option<u32> {
        let e = self.lost_at[p as usize];
        (e != NONE).then(|| self.ascend(self.events[e as usize].winner_entry))
    }
}

/// The neighbours of cell `c` (of a `w` x `h` grid `data`) that are valid and
/// strictly higher than `z`, as (cell, elevation).
#[inline]
fn higher_neighbours(
    data: &[f32],
    w: usize,
    h: usize,
    c: usize,
    z: f32,
) -> impl Iterator<Item = (usize, f32)> + '_ {
    neighbours_in(w, h, c).filter_map(move |(n, _, _)| {
        let nz = data[n];
        (!nz.is_nan() && nz > z).then_some((n, nz))
    })
}
