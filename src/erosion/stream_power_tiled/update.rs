//! The passes of a step after routing: drainage area, the implicit update
//! and explicit diffusion, each a [`TileWork`] of the round driver.

use super::super::stream_power::{newton, DX, DY, VALID};
use super::routing::as_flags;
use super::tile::{for_perimeter, publish, Tile, CNT, DIR, FLAGS, H, HN, NONE, OK};
use super::{step_len, Ctx, Cx, SpPass};
use crate::error::Result;
use crate::raster::perimeter_cells;

/// Drainage area: cell counts summed down the receiver graph in Kahn's
/// order inside the tile. A cell whose donors include a cell of another
/// tile waits until that tile has published the donor's count; the first
/// pass sets up the tile (counts 1, awaited donors in `dd`), later passes
/// only add the counts newly published on the ring (marked in `ring`) and
/// continue. Counts are integers below 2^53, so any order gives the same
/// bits; area = count · cell² once the whole tile is final.
pub(super) struct Accumulate<'a> {
    pub ctx: &'a Ctx,
}

impl SpPass for Accumulate<'_> {
    fn run(&self, c: Cx<'_>) -> Result<bool> {
        let (round, t, board, out, win, pd, pl) = c.parts();
        let geo = &self.ctx.geo;
        let n = t.h.len();
        let dir = geo.ring(board, &pd, DIR, NONE as f64);
        let cnt = geo.ring(board, &pd, CNT, f64::NAN);
        let mut stack: Vec<u32> = Vec::new();
        if round == 0 {
            for i in 0..n {
                t.area[i] = if t.flags[i] & VALID != 0 { 1.0 } else { 0.0 };
                t.dd[i] = 0;
                t.done[i] = 0;
            }
            t.ring.iter_mut().for_each(|v| *v = 0);
            for y in 0..pd.h {
                for x in 0..pd.w {
                    let d = t.dir[y * pd.w + x];
                    if d != NONE {
                        if let Some(r) = pd.core_nb(x, y, d as usize) {
                            t.dd[r] += 1;
                        }
                    }
                }
            }
        }
        // Donors on the ring (other tiles) pointing into this tile.
        for (k, (px, py)) in perimeter_cells(pd.w + 2, pd.h + 2).enumerate() {
            let dj = dir[k] as u8;
            if t.ring[k] == 2 || dj == NONE {
                continue;
            }
            let (rx, ry) = (px as isize + DX[dj as usize], py as isize + DY[dj as usize]);
            let Some(i) = pd.core_xy(rx, ry) else {
                continue;
            };
            if cnt[k].is_nan() {
                if round == 0 {
                    t.dd[i] += 1;
                    t.ring[k] = 1;
                }
                continue;
            }
            t.area[i] += cnt[k];
            if t.ring[k] == 1 {
                t.dd[i] -= 1;
                if t.dd[i] == 0 {
                    stack.push(i as u32);
                }
            }
            t.ring[k] = 2;
        }
        if round == 0 {
            for i in 0..n {
                if t.dd[i] == 0 {
                    stack.push(i as u32);
                }
            }
        }
        while let Some(c) = stack.pop() {
            let c = c as usize;
            t.done[c] = 1;
            if t.dir[c] == NONE {
                continue;
            }
            let (x, y) = pd.xy(c);
            if let Some(r) = pd.core_nb(x, y, t.dir[c] as usize) {
                t.area[r] += t.area[c];
                t.dd[r] -= 1;
                if t.dd[r] == 0 {
                    stack.push(r as u32);
                }
            }
        }
        for_perimeter(win.w, win.h, |i, k| {
            if t.done[i] == 1 && out[CNT * pl + k].is_nan() {
                out[CNT * pl + k] = t.area[i];
            }
        });
        let complete = t.done.iter().all(|&v| v == 1);
        if complete {
            let ca = self.ctx.cell * self.ctx.cell;
            for a in t.area.iter_mut() {
                *a *= ca;
            }
        }
        Ok(complete)
    }
}

/// The implicit update (Braun & Willett 2013, eq. 22 and its Newton form
/// for n ≠ 1): a cell is solved as soon as its receiver's new height is
/// known — solved in this tile, or published by a neighbour — with the
/// arithmetic of the untiled solver; the first pass scans the tile, later
/// passes start only from the perimeter cells whose receiver is on the ring.
pub(super) struct Erode<'a> {
    pub ctx: &'a Ctx,
    /// The step has lakes (fill routing found pits): cells under their
    /// water level are not eroded.
    pub lakes: bool,
}

impl Erode<'_> {
    /// Solve cell i given its receiver's new height.
    #[inline]
    fn solve(&self, t: &mut Tile, i: usize, hr: f64) {
        let p = &self.ctx.p;
        let hs = t.h[i];
        if p.k == 0.0 || hs <= hr || (self.lakes && t.lev[i] > hs) {
            return;
        }
        let d = step_len(self.ctx.cell, t.dir[i] as usize);
        let c = p.k * p.dt * t.area[i].powf(p.m);
        if p.n == 1.0 {
            let fac = c / d;
            t.h[i] = (hs + fac * hr) / (1.0 + fac);
        } else {
            t.h[i] = newton(hs, hr, d, c, p.n);
        }
    }
}

impl SpPass for Erode<'_> {
    fn run(&self, c: Cx<'_>) -> Result<bool> {
        let (round, t, board, out, win, pd, pl) = c.parts();
        let geo = &self.ctx.geo;
        let hn = geo.ring(board, &pd, HN, f64::NAN);
        let ok = geo.ring(board, &pd, OK, 0.0);
        let mut work: Vec<u32> = Vec::new();
        // New height of the ring cell at padded (px, py), if published.
        let remote = |px: isize, py: isize| -> Option<f64> {
            let k = pd.ring_index(px as usize, py as usize)?;
            (ok[k] == 1.0).then_some(hn[k])
        };
        if round == 0 {
            t.done.iter_mut().for_each(|v| *v = 0);
            for y in 0..pd.h {
                for x in 0..pd.w {
                    let i = y * pd.w + x;
                    if t.dir[i] == NONE || t.flags[i] != VALID {
                        t.done[i] = 1;
                        work.push(i as u32);
                        continue;
                    }
                    let d = t.dir[i] as usize;
                    let hr = match pd.core_nb(x, y, d) {
                        Some(r) => (t.done[r] != 0).then(|| t.h[r]),
                        None => remote(x as isize + 1 + DX[d], y as isize + 1 + DY[d]),
                    };
                    if let Some(hr) = hr {
                        self.solve(t, i, hr);
                        t.done[i] = 1;
                        work.push(i as u32);
                    }
                }
            }
        } else {
            for_perimeter(win.w, win.h, |i, _| {
                if t.done[i] != 0 {
                    return;
                }
                let (x, y) = pd.xy(i);
                let d = t.dir[i] as usize;
                if pd.core_nb(x, y, d).is_some() {
                    return;
                }
                if let Some(hr) = remote(x as isize + 1 + DX[d], y as isize + 1 + DY[d]) {
                    self.solve(t, i, hr);
                    t.done[i] = 1;
                    work.push(i as u32);
                }
            });
        }
        // The donors of a solved cell: neighbours whose direction is the
        // opposite of the way to them (E..NE order: d and d + 4 mod 8).
        while let Some(c) = work.pop() {
            let c = c as usize;
            let (x, y) = pd.xy(c);
            for d in 0..8 {
                let Some(j) = pd.core_nb(x, y, d) else {
                    continue;
                };
                if t.done[j] != 0 || t.dir[j] as usize != (d + 4) % 8 {
                    continue;
                }
                let hr = t.h[c];
                self.solve(t, j, hr);
                t.done[j] = 1;
                work.push(j as u32);
            }
        }
        for_perimeter(win.w, win.h, |i, k| {
            if t.done[i] != 0 && out[OK * pl + k] == 0.0 {
                out[HN * pl + k] = t.h[i];
                out[OK * pl + k] = 1.0;
            }
        });
        let complete = t.done.iter().all(|&v| v != 0);
        if complete {
            publish(out, win.w, win.h, pl, H, |i| t.h[i]);
        }
        Ok(complete)
    }
}

/// One explicit diffusion substep (coefficient `c` = Kd·dt'/cell²), reading
/// the neighbours' perimeter heights of the previous substep (a halo
/// exchange of depth 1).
pub(super) struct Diffuse<'a> {
    pub ctx: &'a Ctx,
    pub c: f64,
}

impl SpPass for Diffuse<'_> {
    fn run(&self, cx: Cx<'_>) -> Result<bool> {
        let (_, t, board, out, win, pd, pl) = cx.parts();
        let geo = &self.ctx.geo;
        let c = self.c;
        let old = geo.pad(board, &pd, &t.h, H, f64::NAN, |v| v);
        let fl = geo.pad(board, &pd, &t.flags, FLAGS, f64::NAN, as_flags);
        let pw = pd.pw;
        for y in 0..pd.h {
            for x in 0..pd.w {
                let i = y * pd.w + x;
                if t.flags[i] != VALID {
                    continue;
                }
                let q = pd.at(x, y);
                let hi = old[q];
                let mut lap = 0.0;
                if fl[q - 1] & VALID != 0 {
                    lap += old[q - 1] - hi;
                }
                if fl[q + 1] & VALID != 0 {
                    lap += old[q + 1] - hi;
                }
                if fl[q - pw] & VALID != 0 {
                    lap += old[q - pw] - hi;
                }
                if fl[q + pw] & VALID != 0 {
                    lap += old[q + pw] - hi;
                }
                t.h[i] = hi + c * lap;
            }
        }
        publish(out, win.w, win.h, pl, H, |i| t.h[i]);
        Ok(true)
    }
}
