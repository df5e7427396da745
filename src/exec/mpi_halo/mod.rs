//! Point-to-point halo exchange between ranks for iterative local steps
//! (the erosion models of `erosion::tiled`).
//!
//! Tiles are split between ranks in contiguous ranges of tile ids
//! ([`partition`]), so most of a tile's neighbours live on the same rank.
//! Every rank holds only its tiles' state. Before each round of `k`
//! substeps, the cells of a tile's ghost zone (the core grown by `g` cells)
//! that belong to tiles of *other* ranks are sent by their owners: for each
//! pair (owner, receiver) the union of the cells the receiver's patches need
//! from each of the owner's tiles, cut into disjoint rectangles
//! ([`disjoint_cover`]), so no cell crosses the network twice in one round.
//! Both sides derive the same list of rectangles ([`HaloPlan`]) from the
//! layout, the ghost depth and the owners alone, so the messages carry only
//! values (no headers). Tiles of the same rank are read in memory as before.
//! This is the ghost-cell (halo) exchange of domain-decomposed stencil codes
//! (e.g. Gropp, Lusk & Skjellum, *Using MPI*, 3rd ed., MIT Press 2014,
//! ch. 4, "mesh exchange"), with tiles instead of one block per rank.
//!
//! The plan, the strip copies and the single-process transport ([`Single`])
//! are always built and tested without MPI; [`MpiHalo`] (feature `mpi`)
//! moves the strips with non-blocking sends and receives over rsmpi.

use crate::error::{Error, Result};
use crate::raster::{TileId, TileLayout, Window};
use std::collections::BTreeMap;

/// Owner rank of every tile: contiguous ranges of tile ids (row-major), as
/// even as possible (`count / ranks` tiles each, the first `count % ranks`
/// ranks one more). Depends only on the layout and `ranks`.
pub fn partition(layout: &TileLayout, ranks: usize) -> Vec<usize> {
    let n = layout.count();
    let r = ranks.max(1);
    let (q, extra) = (n / r, n % r);
    let mut owner = Vec::with_capacity(n);
    for rank in 0..r {
        let len = q + usize::from(rank < extra);
        owner.extend(std::iter::repeat_n(rank, len));
    }
    owner
}

/// The cells covered by `rects` as disjoint rectangles, in a canonical order
/// (by row bands from the top, then by column): each row's covered columns
/// are merged into intervals, and runs of rows with the same intervals form
/// one band. The result depends only on the set of covered cells.
pub fn disjoint_cover(rects: &[Window]) -> Vec<Window> {
    let rects: Vec<&Window> = rects.iter().filter(|r| !r.is_empty()).collect();
    let (Some(y0), Some(y1)) = (
        rects.iter().map(|r| r.y).min(),
        rects.iter().map(|r| r.y_end()).max(),
    ) else {
        return Vec::new();
    };
    let mut out = Vec::new();
    // Current band: first row and its intervals.
    let mut band: Option<(i64, Vec<(i64, i64)>)> = None;
    let close = |from: i64, to: i64, iv: &[(i64, i64)], out: &mut Vec<Window>| {
        for &(a, b) in iv {
            out.push(Window::new(a, from, (b - a) as usize, (to - from) as usize));
        }
    };
    for y in y0..=y1 {
        let mut iv: Vec<(i64, i64)> = if y < y1 {
            rects
                .iter()
                .filter(|r| r.y <= y && y < r.y_end())
                .map(|r| (r.x, r.x_end()))
                .collect()
        } else {
            Vec::new()
        };
        iv.sort_unstable();
        let mut merged: Vec<(i64, i64)> = Vec::with_capacity(iv.len());
        for (a, b) in iv {
            match merged.last_mut() {
                Some(last) if a <= last.1 => last.1 = last.1.max(b),
                _ => merged.push((a, b)),
            }
        }
        match &band {
            Some((_, cur)) if *cur == merged => {}
            _ => {
                if let Some((from, cur)) = band.take() {
                    close(from, y, &cur, &mut out);
                }
                if !merged.is_empty() {
                    band = Some((y, merged));
                }
            }
        }
    }
    out
}

/// A rectangle `win` of tile `tile`'s state that crosses between two ranks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Strip {
    pub tile: TileId,
    pub win: Window,
}

/// Where a received rectangle of a remote tile lies in the inbox: rank
/// `from`'s message, starting at value `offset` (fields one after the other,
/// each `win.len()` values, row-major).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Ghost {
    pub win: Window,
    pub from: usize,
    pub offset: usize,
}

/// What one rank sends and receives in every round (the same every round).
#[derive(Debug, Clone)]
pub struct HaloPlan {
    /// This rank.
    pub me: usize,
    /// Owner of every tile.
    pub owner: Vec<usize>,
    /// Tiles of this rank, increasing.
    pub mine: Vec<TileId>,
    /// Per destination rank: strips of this rank's tiles, in message order.
    pub sends: Vec<Vec<Strip>>,
    /// Per source rank: the number of values its message holds.
    pub recv_len: Vec<usize>,
    /// Per tile id: the received rectangles of that (remote) tile.
    pub ghosts: Vec<Vec<Ghost>>,
    /// Fields per cell.
    pub fields: usize,
}

/// The patch window of tile `id`: its core grown by `ghost`, clipped to the
/// raster.
pub fn patch_window(layout: &TileLayout, id: TileId, ghost: usize) -> Window {
    let core = layout.window(id);
    core.expand(ghost)
        .intersect(&Window::full(layout.width, layout.height))
        .unwrap_or(core)
}

impl HaloPlan {
    /// The plan of rank `me` of `ranks` for tiles owned as `owner`, ghost
    /// zones of `ghost` cells and `fields` values per cell.
    pub fn new(
        layout: &TileLayout,
        ghost: usize,
        owner: Vec<usize>,
        (me, ranks): (usize, usize),
        fields: usize,
    ) -> Result<Self> {
        let count = layout.count();
        if owner.len() != count || me >= ranks || owner.iter().any(|&o| o >= ranks) {
            return Err(Error::invalid(format!(
                "halo plan: {} owners for {count} tiles, rank {me} of {ranks}",
                owner.len()
            )));
        }
        // (receiver, tile) -> the rectangles of the tile its patches need.
        let mut need: BTreeMap<(usize, TileId), Vec<Window>> = BTreeMap::new();
        for (t, &q) in owner.iter().enumerate() {
            let pw = patch_window(layout, t, ghost);
            for tid in layout.tiles_in(&pw) {
                let o = owner[tid];
                if o == q || (q != me && o != me) {
                    continue;
                }
                if let Some(iw) = layout.window(tid).intersect(&pw) {
                    need.entry((q, tid)).or_default().push(iw);
                }
            }
        }
        let mut sends = vec![Vec::new(); ranks];
        let mut recv_len = vec![0usize; ranks];
        let mut ghosts = vec![Vec::new(); count];
        for ((q, tid), rects) in need {
            let cover = disjoint_cover(&rects);
            if q == me {
                let from = owner[tid];
                for win in cover {
                    ghosts[tid].push(Ghost {
                        win,
                        from,
                        offset: recv_len[from],
                    });
                    recv_len[from] += win.len() * fields;
                }
            } else {
                sends[q].extend(cover.into_iter().map(|win| Strip { tile: tid, win }));
            }
        }
        let mine = (0..count).filter(|&t| owner[t] == me).collect();
        Ok(HaloPlan {
            me,
            owner,
            mine,
            sends,
            recv_len,
            ghosts,
            fields,
        })
    }

    /// Values this rank sends per round.
    pub fn send_len(&self) -> usize {
        self.sends
            .iter()
            .flatten()
            .map(|s| s.win.len() * self.fields)
            .sum()
    }
}

/// Append the rectangle `win` of a tile state (`fields` fields of
/// `tile.len()` values each, row-major over the window `tile`) to `out`,
/// field after field.
pub fn extract(tile: Window, data: &[f64], fields: usize, win: Window, out: &mut Vec<f64>) {
    let (ox, oy) = ((win.x - tile.x) as usize, (win.y - tile.y) as usize);
    for f in 0..fields {
        let base = f * tile.len();
        for y in 0..win.h {
            let s = base + (oy + y) * tile.w + ox;
            out.extend_from_slice(&data[s..s + win.w]);
        }
    }
}

/// Copy the part of `clip` inside both `src_win` and `dst_win` from `src`
/// (fields of `src_win.len()` values each) into `dst` (one array per field
/// over `dst_win`).
pub fn paste(dst_win: Window, dst: &mut [Vec<f64>], src_win: Window, src: &[f64], clip: Window) {
    let Some(c) = clip.intersect(&src_win).and_then(|c| c.intersect(&dst_win)) else {
        return;
    };
    for (f, field) in dst.iter_mut().enumerate() {
        let base = f * src_win.len();
        for y in c.y..c.y_end() {
            let s = base + (y - src_win.y) as usize * src_win.w + (c.x - src_win.x) as usize;
            let d = (y - dst_win.y) as usize * dst_win.w + (c.x - dst_win.x) as usize;
            field[d..d + c.w].copy_from_slice(&src[s..s + c.w]);
        }
    }
}

/// How ranks move halo strips and finished tiles. The driver calls it only
/// from the thread that started the run, between parallel tile loops.
pub trait HaloTransport {
    /// `(rank, ranks)`.
    fn rank(&self) -> (usize, usize);
    /// True when other processes take part (prints `OROGEN_MPI_STATS`).
    fn distributed(&self) -> bool;
    /// One round: send `out[q]` to every rank `q` with a non-empty vector
    /// and fill `inbox[p]` from every rank `p` with a non-empty buffer.
    fn exchange(&mut self, out: &[Vec<f64>], inbox: &mut [Vec<f64>]) -> Result<()>;
    /// Send a finished tile's values to rank 0 (in increasing tile order).
    fn send_to_root(&mut self, data: &[f64]) -> Result<()>;
    /// On rank 0: fill `buf` from rank `from`'s next finished tile.
    fn recv_from(&mut self, from: usize, buf: &mut [f64]) -> Result<()>;
    /// [`HaloTransport::send_to_root`] of values already rounded to `f32`
    /// (outputs that are written as `f32`: half the bytes, same output).
    fn send_to_root_f32(&mut self, data: &[f32]) -> Result<()>;
    /// On rank 0: the counterpart of [`HaloTransport::send_to_root_f32`].
    fn recv_from_f32(&mut self, from: usize, buf: &mut [f32]) -> Result<()>;
    /// Element-wise sum of `v` over the ranks.
    fn sum(&mut self, v: &[u64]) -> Result<Vec<u64>>;
    /// Every rank's `v` (of any length), indexed by rank, on every rank
    /// (the board exchange of `exec::iterate`).
    fn all_gather(&mut self, v: &[f64]) -> Result<Vec<Vec<f64>>>;
    /// Wait until every rank got here.
    fn barrier(&mut self);
    /// Turn an error on this rank into the run's end: under MPI this ends
    /// every rank (the others would wait forever); otherwise it returns it.
    fn fail(&self, e: Error) -> Error;
}

/// One process: every tile is local; nothing is ever sent.
#[derive(Debug, Default, Clone, Copy)]
pub struct Single;

impl HaloTransport for Single {
    fn rank(&self) -> (usize, usize) {
        (0, 1)
    }
    fn distributed(&self) -> bool {
        false
    }
    fn exchange(&mut self, _out: &[Vec<f64>], _inbox: &mut [Vec<f64>]) -> Result<()> {
        Ok(())
    }
    fn send_to_root(&mut self, _data: &[f64]) -> Result<()> {
        Err(Error::invalid(
            "halo exchange: a single process has no other rank to send to",
        ))
    }
    fn recv_from(&mut self, from: usize, _buf: &mut [f64]) -> Result<()> {
        Err(Error::invalid(format!(
            "halo exchange: a single process has no rank {from} to receive from"
        )))
    }
    fn send_to_root_f32(&mut self, _data: &[f32]) -> Result<()> {
        Err(Error::invalid(
            "halo exchange: a single process has no other rank to send to",
        ))
    }
    fn recv_from_f32(&mut self, from: usize, _buf: &mut [f32]) -> Result<()> {
        Err(Error::invalid(format!(
            "halo exchange: a single process has no rank {from} to receive from"
        )))
    }
    fn sum(&mut self, v: &[u64]) -> Result<Vec<u64>> {
        Ok(v.to_vec())
    }
    fn all_gather(&mut self, v: &[f64]) -> Result<Vec<Vec<f64>>> {
        Ok(vec![v.to_vec()])
    }
    fn barrier(&mut self) {}
    fn fail(&self, e: Error) -> Error {
        e
    }
}

#[cfg(feature = "mpi")]
pub use with_mpi::MpiHalo;

#[cfg(feature = "mpi")]
mod with_mpi;

#[cfg(test)]
pub(crate) mod thread_ranks;

#[cfg(test)]
mod tests;
