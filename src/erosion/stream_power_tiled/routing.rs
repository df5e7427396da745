//! The routing passes of a step: uplift, minimax water levels, flat
//! distances and receivers, each a [`TileWork`] of the round driver.

use super::super::stream_power::{
    no_uplift_rate, order_key, raise, Uplift as Rates, BASE, DX, DY, VALID,
};
use super::tile::{for_perimeter, publish, CNT, DD, DIR, FLAGS, H, HN, LEV, NONE, OK};
use super::{step_len, Ctx, Cx, SpPass, TiledUplift};
use crate::error::Result;
use crate::raster::{perimeter_cells, read_window};
use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// Flags of a published value (NaN beyond the raster: 0).
#[inline]
pub(super) fn as_flags(v: f64) -> u8 {
    v as u8
}

/// Uplift (local); with fill routing also the initial water levels
/// (`L = h` on base levels, +inf elsewhere).
pub(super) struct Uplift<'a> {
    pub ctx: &'a Ctx,
    pub uplift: &'a TiledUplift<'a>,
}

impl SpPass for Uplift<'_> {
    fn run(&self, c: Cx<'_>) -> Result<bool> {
        let (_, t, _, out, win, _, pl) = c.parts();
        let dt = self.ctx.p.dt;
        let raised = match self.uplift {
            TiledUplift::Uniform(r) => raise(&mut t.h, &t.flags, dt, &Rates::Uniform(*r)),
            TiledUplift::Map(m) => {
                let g = read_window::<f64>(*m, win)?;
                raise(&mut t.h, &t.flags, dt, &Rates::Map(&g))
            }
        };
        raised
            .map_err(|i| no_uplift_rate(win.x as usize + i % win.w, win.y as usize + i / win.w))?;
        publish(out, win.w, win.h, pl, H, |i| t.h[i]);
        if self.ctx.fill {
            for i in 0..t.h.len() {
                t.lev[i] = if t.flags[i] & BASE != 0 {
                    t.h[i]
                } else if t.flags[i] & VALID != 0 {
                    f64::INFINITY
                } else {
                    f64::NAN
                };
            }
            publish(out, win.w, win.h, pl, LEV, |i| t.lev[i]);
        }
        Ok(true)
    }
}

/// Minimax water levels `L(i) = max(h(i), min_j L(j))`: a priority flood
/// inside the tile seeded from the neighbours' perimeter levels. The first
/// pass floods the whole tile; later ones only from the ring cells whose
/// level lowers a cell of the tile (levels only drop: label correcting).
pub(super) struct Levels<'a> {
    pub ctx: &'a Ctx,
}

impl SpPass for Levels<'_> {
    fn run(&self, c: Cx<'_>) -> Result<bool> {
        let (round, t, board, out, win, pd, pl) = c.parts();
        let geo = &self.ctx.geo;
        // The flood runs on padded arrays (no index conversion per
        // neighbour); the ring holds the neighbours' levels and flags.
        let mut lp = geo.pad(board, &pd, &t.lev, LEV, f64::NAN, |v| v);
        let mut fp = geo.pad(board, &pd, &t.flags, FLAGS, f64::NAN, as_flags);
        let mut hp = vec![f64::NAN; lp.len()];
        for y in 0..pd.h {
            let q = pd.at(0, y);
            hp[q..q + pd.w].copy_from_slice(&t.h[y * pd.w..(y + 1) * pd.w]);
        }
        let mut heap: BinaryHeap<Reverse<(u64, u32)>> = BinaryHeap::new();
        // Lower cell q from its neighbours' levels (any upper bound of a
        // neighbour's level gives one of q's: label correcting).
        let relax = |q: usize, lp: &mut [f64], fp: &[u8], hp: &[f64]| -> bool {
            let mut low = false;
            for d in 0..8 {
                let j = pd.nb(q, d);
                if fp[j] & VALID == 0 || !lp[j].is_finite() {
                    continue;
                }
                let c = hp[q].max(lp[j]);
                if c < lp[q] {
                    lp[q] = c;
                    low = true;
                }
            }
            low
        };
        if round == 0 {
            for y in 0..pd.h {
                for x in 0..pd.w {
                    let q = pd.at(x, y);
                    if fp[q] != VALID {
                        if fp[q] & BASE != 0 {
                            heap.push(Reverse((order_key(lp[q]), q as u32)));
                        }
                        continue;
                    }
                    relax(q, &mut lp, &fp, &hp);
                    if lp[q].is_finite() {
                        heap.push(Reverse((order_key(lp[q]), q as u32)));
                    }
                }
            }
        } else {
            // Only the perimeter cells read the ring.
            for_perimeter(pd.w, pd.h, |i, _| {
                let (x, y) = pd.xy(i);
                let q = pd.at(x, y);
                if fp[q] == VALID && relax(q, &mut lp, &fp, &hp) {
                    heap.push(Reverse((order_key(lp[q]), q as u32)));
                }
            });
        }
        // The flood stays inside the tile.
        for (px, py) in perimeter_cells(pd.w + 2, pd.h + 2) {
            fp[py * pd.pw + px] = 0;
        }
        while let Some(Reverse((key, q))) = heap.pop() {
            let q = q as usize;
            let lq = lp[q];
            if order_key(lq) != key {
                continue;
            }
            for d in 0..8 {
                let j = pd.nb(q, d);
                if fp[j] != VALID {
                    continue;
                }
                let cand = hp[j].max(lq);
                if cand < lp[j] {
                    lp[j] = cand;
                    heap.push(Reverse((order_key(cand), j as u32)));
                }
            }
        }
        for y in 0..pd.h {
            let q = pd.at(0, y);
            t.lev[y * pd.w..(y + 1) * pd.w].copy_from_slice(&lp[q..q + pd.w]);
        }
        publish(out, win.w, win.h, pl, LEV, |i| t.lev[i]);
        Ok(false)
    }
}

/// Draining cells of the flats (distance 0): base levels and cells with a
/// lower-level neighbour; the others start at "unreached".
pub(super) struct FlatStart<'a> {
    pub ctx: &'a Ctx,
}

impl SpPass for FlatStart<'_> {
    fn run(&self, c: Cx<'_>) -> Result<bool> {
        let (_, t, board, out, win, pd, pl) = c.parts();
        let geo = &self.ctx.geo;
        let lev = geo.pad(board, &pd, &t.lev, LEV, f64::NAN, |v| v);
        let fl = geo.pad(board, &pd, &t.flags, FLAGS, f64::NAN, as_flags);
        for y in 0..pd.h {
            for x in 0..pd.w {
                let i = y * pd.w + x;
                t.dd[i] = u32::MAX;
                if t.flags[i] & VALID == 0 {
                    continue;
                }
                let q = pd.at(x, y);
                let mut drains = t.flags[i] & BASE != 0;
                if !drains {
                    for d in 0..8 {
                        let j = pd.nb(q, d);
                        if fl[j] & VALID != 0 && lev[j] < lev[q] {
                            drains = true;
                            break;
                        }
                    }
                }
                if drains {
                    t.dd[i] = 0;
                }
            }
        }
        publish(out, win.w, win.h, pl, DD, |i| t.dd[i] as f64);
        Ok(true)
    }
}

/// Breadth-first distances `D` over equal-level cells from the draining
/// cells (Barnes, Lehman & Mulla 2014), by Dijkstra inside the tile seeded
/// from the neighbours' perimeter distances; later passes only from the ring
/// cells that shorten a distance.
pub(super) struct Flats<'a> {
    pub ctx: &'a Ctx,
}

impl SpPass for Flats<'_> {
    fn run(&self, c: Cx<'_>) -> Result<bool> {
        let (round, t, board, out, win, pd, pl) = c.parts();
        let geo = &self.ctx.geo;
        let mut heap: BinaryHeap<Reverse<(u32, u32)>> = BinaryHeap::new();
        let as_dd = |v: f64| v as u32;
        if round == 0 {
            let lev = geo.pad(board, &pd, &t.lev, LEV, f64::NAN, |v| v);
            let fl = geo.pad(board, &pd, &t.flags, FLAGS, f64::NAN, as_flags);
            let ddp = geo.pad(board, &pd, &t.dd, DD, u32::MAX as f64, as_dd);
            for y in 0..pd.h {
                for x in 0..pd.w {
                    let i = y * pd.w + x;
                    if t.flags[i] & VALID == 0 {
                        continue;
                    }
                    if t.dd[i] != 0 {
                        let q = pd.at(x, y);
                        for d in 0..8 {
                            let j = pd.nb(q, d);
                            if pd.core_nb(x, y, d).is_some()
                                || fl[j] & VALID == 0
                                || ddp[j] == u32::MAX
                                || lev[j] != lev[q]
                            {
                                continue;
                            }
                            if ddp[j] + 1 < t.dd[i] {
                                t.dd[i] = ddp[j] + 1;
                            }
                        }
                    }
                    // A draining cell seeds the search only next to a flat
                    // cell of its level (most cells drain and have none).
                    let seeds = match t.dd[i] {
                        u32::MAX => false,
                        0 => (0..8).any(|d| {
                            pd.core_nb(x, y, d).is_some_and(|j| {
                                t.flags[j] & VALID != 0 && t.dd[j] != 0 && t.lev[j] == t.lev[i]
                            })
                        }),
                        _ => true,
                    };
                    if seeds {
                        heap.push(Reverse((t.dd[i], i as u32)));
                    }
                }
            }
        } else {
            let lev = geo.ring(board, &pd, LEV, f64::NAN);
            let fl = geo.ring(board, &pd, FLAGS, f64::NAN);
            let dd = geo.ring(board, &pd, DD, u32::MAX as f64);
            for (k, (px, py)) in perimeter_cells(pd.w + 2, pd.h + 2).enumerate() {
                let dj = as_dd(dd[k]);
                if as_flags(fl[k]) & VALID == 0 || dj == u32::MAX {
                    continue;
                }
                for d in 0..8 {
                    let Some(i) = pd.core_xy(px as isize + DX[d], py as isize + DY[d]) else {
                        continue;
                    };
                    if t.flags[i] & VALID == 0 || t.dd[i] == 0 || lev[k] != t.lev[i] {
                        continue;
                    }
                    if dj + 1 < t.dd[i] {
                        t.dd[i] = dj + 1;
                        heap.push(Reverse((dj + 1, i as u32)));
                    }
                }
            }
        }
        while let Some(Reverse((dc, c))) = heap.pop() {
            let c = c as usize;
            if t.dd[c] != dc {
                continue;
            }
            let (x, y) = pd.xy(c);
            for d in 0..8 {
                let Some(j) = pd.core_nb(x, y, d) else {
                    continue;
                };
                if t.flags[j] & VALID == 0 || t.dd[j] == 0 || t.lev[j] != t.lev[c] {
                    continue;
                }
                if dc + 1 < t.dd[j] {
                    t.dd[j] = dc + 1;
                    heap.push(Reverse((dc + 1, j as u32)));
                }
            }
        }
        publish(out, win.w, win.h, pl, DD, |i| t.dd[i] as f64);
        Ok(false)
    }
}

/// Receivers: steepest descent on `L` (`on_levels`, after the levels and
/// flat distances of fill routing; flats by `D`) or on `h*` (no routing, and
/// the first routing of every fill step). Also clears the published counts
/// and new heights of the previous step. Final when the tile has no pit (a
/// routed cell without a receiver).
pub(super) struct Receivers<'a> {
    pub ctx: &'a Ctx,
    pub on_levels: bool,
}

impl SpPass for Receivers<'_> {
    fn run(&self, c: Cx<'_>) -> Result<bool> {
        let (_, t, board, out, win, pd, pl) = c.parts();
        let (geo, cell, lev) = (&self.ctx.geo, self.ctx.cell, self.on_levels);
        let z = if lev {
            geo.pad(board, &pd, &t.lev, LEV, f64::NAN, |v| v)
        } else {
            geo.pad(board, &pd, &t.h, H, f64::NAN, |v| v)
        };
        let fl = geo.pad(board, &pd, &t.flags, FLAGS, f64::NAN, as_flags);
        let ddp = if lev {
            geo.pad(board, &pd, &t.dd, DD, u32::MAX as f64, |v| v as u32)
        } else {
            Vec::new()
        };
        let len: [f64; 8] = std::array::from_fn(|d| step_len(cell, d));
        let mut pits = 0usize;
        for y in 0..pd.h {
            for x in 0..pd.w {
                let i = y * pd.w + x;
                t.dir[i] = NONE;
                if t.flags[i] != VALID {
                    continue;
                }
                let q = pd.at(x, y);
                let zi = z[q];
                let mut best = 0.0;
                let mut bd = NONE;
                for d in 0..8 {
                    let j = pd.nb(q, d);
                    if fl[j] & VALID == 0 {
                        continue;
                    }
                    let s = (zi - z[j]) / len[d];
                    if s > best {
                        best = s;
                        bd = d as u8;
                    }
                }
                if bd == NONE && lev {
                    let mut bdd = ddp[q];
                    for d in 0..8 {
                        let j = pd.nb(q, d);
                        if fl[j] & VALID != 0 && z[j] == zi && ddp[j] < bdd {
                            bdd = ddp[j];
                            bd = d as u8;
                        }
                    }
                }
                if bd == NONE {
                    pits += 1;
                }
                t.dir[i] = bd;
            }
        }
        for_perimeter(win.w, win.h, |i, k| {
            out[DIR * pl + k] = t.dir[i] as f64;
            out[CNT * pl + k] = f64::NAN;
            out[HN * pl + k] = f64::NAN;
            out[OK * pl + k] = 0.0;
        });
        Ok(pits == 0)
    }
}
