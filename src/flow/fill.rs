//! The filling sink resolver: receivers on the water surface of a
//! priority flood, defined so that a tiled solve can reproduce it exactly
//! (`erosion::stream_power_tiled` does):
//! 1. water level `L` = the minimax ("priority-flood") level of Barnes,
//!    Lehman & Mulla (2014, "Priority-Flood: An optimal depression-filling
//!    and watershed-labeling algorithm for digital elevation models",
//!    *Computers & Geosciences* 62, 117–127): `L = h` on base levels,
//!    elsewhere `L(i) = max(h(i), min over valid neighbours L(j))` — unique,
//!    computed here from the basin graph (see [`super::basin_graph`]: the
//!    highest pass on each basin's minimum-spanning-tree path);
//! 2. on flats of `L` (valid non-base cells with no strictly lower
//!    neighbour: lake surfaces and flat ground), the breadth-first
//!    distance `D` over equal-`L` 8-neighbours from the cells that drain
//!    (base levels and cells with a strictly lower neighbour, `D = 0`) —
//!    the "towards lower terrain" gradient of Barnes, Lehman & Mulla
//!    (2014, "An efficient assignment of drainage direction over flat
//!    surfaces in raster digital elevation models", *Computers &
//!    Geosciences* 62, 128–135);
//! 3. receivers: steepest descent on `L` ([`super::steepest`]); a flat cell
//!    drains to its equal-`L` neighbour of least `D` (first in E, SE, S, ...
//!    order), which is one step nearer the outlet. Along every receiver
//!    path `(L, D)` strictly decreases: no cycles.
//!
//! Not shared with hydrology's priority flood (`hydro::fill`): there is no
//! priority flood here to share (the levels come from the basin graph's
//! union-find, one pass over the sorted passes), and the two floods that do
//! exist differ in more than the cell type: `hydro::fill`'s is a one-shot
//! f32 flood from the outlets that labels watersheds and reports spills,
//! with its heap key packing the f32 bits and the cell index into one u64;
//! the tiled stream power's (`erosion::stream_power_tiled`) is a label
//! correcting f64 flood restarted from a tile's ring of upper bounds. An f64
//! key cannot share a u64 with the index, so a generic flood would need a
//! wider key and slow the f32 one.

use super::basin_graph::Lakes;
use super::float::FlowFloat;
use super::graph::FlowGraph;
use super::steepest::{neighbour, offsets, steepest_of, step_lengths, BASE, VALID};

impl<T: FlowFloat> Lakes<T> {
    /// Route `g` on the filled surface of `z` (see the module
    /// documentation): the levels are kept in `self`, the receivers and
    /// distances (cells of `cell` units) are written to `g`. Cells whose
    /// flags are not exactly [`VALID`] are roots.
    pub fn fill(&mut self, g: &mut FlowGraph<T>, z: &[T], flags: &[u8], cell: f64) {
        let (w, ht) = (g.width(), g.height());
        let n = w * ht;
        self.basin_graph(g, z, flags, cell, false);
        let level = std::mem::take(&mut self.level);
        // One scan: steepest descent on the levels; `dd` = 0 for cells that
        // drain (base levels, cells with a strictly lower neighbour), MAX for
        // flat cells, which are collected.
        let mut dd = std::mem::take(&mut self.basin);
        dd.clear();
        dd.resize(n, u32::MAX);
        let mut flats = std::mem::take(&mut self.flats);
        flats.clear();
        let off = offsets(w);
        let len = step_lengths(cell);
        for y in 0..ht {
            for x in 0..w {
                let i = y * w + x;
                g.rec[i] = i as u32;
                g.dist[i] = T::default();
                let f = flags[i];
                if f != VALID {
                    if f & BASE != 0 {
                        dd[i] = 0;
                    }
                    continue;
                }
                let (r, d, lower) = steepest_of(&level, flags, (x, y, w, ht), &off, &len);
                g.rec[i] = r as u32;
                g.dist[i] = T::from_f64(d);
                if lower {
                    dd[i] = 0;
                } else {
                    flats.push(i as u32);
                }
            }
        }
        if !flats.is_empty() {
            // Breadth-first distances over equal-level flat cells, from the
            // draining cells next to them (the only seeds that reach a flat).
            let queue = &mut self.queue;
            queue.clear();
            for &f in &flats {
                let f = f as usize;
                let (x, y) = (f % w, f / w);
                for d in 0..8 {
                    let Some(j) = neighbour(x, y, d, w, ht) else {
                        continue;
                    };
                    if flags[j] & VALID != 0 && dd[j] == 0 && level[j] == level[f] {
                        queue.push_back(j as u32);
                    }
                }
            }
            while let Some(c) = queue.pop_front() {
                let c = c as usize;
                let (x, y) = (c % w, c / w);
                let next = dd[c] + 1;
                for d in 0..8 {
                    let Some(j) = neighbour(x, y, d, w, ht) else {
                        continue;
                    };
                    if flags[j] & VALID != 0 && dd[j] == u32::MAX && level[j] == level[c] {
                        dd[j] = next;
                        queue.push_back(j as u32);
                    }
                }
            }
            // Flat cells without a strictly lower neighbour on the levels
            // drain to the equal-level neighbour nearest the outlet.
            for &f in &flats {
                let i = f as usize;
                let (x, y) = (i % w, i / w);
                let zi = level[i];
                let mut bdd = dd[i];
                for (d, &l) in len.iter().enumerate() {
                    let Some(j) = neighbour(x, y, d, w, ht) else {
                        continue;
                    };
                    if flags[j] & VALID != 0 && level[j] == zi && dd[j] < bdd {
                        bdd = dd[j];
                        g.rec[i] = j as u32;
                        g.dist[i] = T::from_f64(l);
                    }
                }
            }
        }
        self.flats = flats;
        self.basin = dd;
        self.level = level;
        self.active = true;
    }
}
