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
mod with_mpi {
    use super::HaloTransport;
    use crate::error::{Error, Result};
    use mpi::topology::SimpleCommunicator;
    use mpi::traits::*;

    /// Tag of halo strips.
    const TAG_HALO: i32 = 21;
    /// Tag of finished tiles (rank -> rank 0).
    const TAG_FINAL: i32 = 22;

    /// Halo exchange over `MPI_COMM_WORLD` (the ranks of the MPI engine):
    /// each round posts every receive and send without blocking
    /// (MPI_Irecv/MPI_Isend) and waits for all, so the order of peers
    /// cannot deadlock.
    pub struct MpiHalo {
        comm: SimpleCommunicator,
    }

    impl MpiHalo {
        /// The transport of the running MPI engine (`--engine mpi`).
        pub fn new() -> Result<Self> {
            if !crate::exec::mpi::active() {
                return Err(Error::invalid(
                    "halo exchange over MPI: the MPI engine is not running (--engine mpi)",
                ));
            }
            Ok(MpiHalo {
                comm: SimpleCommunicator::world(),
            })
        }
    }

    fn count_ok(n: usize) -> Result<()> {
        if n > i32::MAX as usize {
            return Err(Error::invalid(format!(
                "halo exchange: a message of {n} values is over MPI's 2^31 count limit; use smaller tiles (--tile) or a smaller --exchange"
            )));
        }
        Ok(())
    }

    impl HaloTransport for MpiHalo {
        fn rank(&self) -> (usize, usize) {
            (
                self.comm.rank().max(0) as usize,
                self.comm.size().max(1) as usize,
            )
        }
        fn distributed(&self) -> bool {
            true
        }
        fn exchange(&mut self, out: &[Vec<f64>], inbox: &mut [Vec<f64>]) -> Result<()> {
            for v in out.iter().chain(inbox.iter()) {
                count_ok(v.len())?;
            }
            let comm = &self.comm;
            mpi::request::scope(|scope| {
                let mut recvs = Vec::new();
                for (p, buf) in inbox.iter_mut().enumerate() {
                    if !buf.is_empty() {
                        recvs.push(
                            comm.process_at_rank(p as i32)
                                .immediate_receive_into_with_tag(scope, &mut buf[..], TAG_HALO),
                        );
                    }
                }
                let mut sends = Vec::new();
                for (q, buf) in out.iter().enumerate() {
                    if !buf.is_empty() {
                        sends.push(comm.process_at_rank(q as i32).immediate_send_with_tag(
                            scope,
                            &buf[..],
                            TAG_HALO,
                        ));
                    }
                }
                for r in recvs {
                    r.wait_without_status();
                }
                for s in sends {
                    s.wait_without_status();
                }
            });
            Ok(())
        }
        fn send_to_root(&mut self, data: &[f64]) -> Result<()> {
            count_ok(data.len())?;
            self.comm.process_at_rank(0).send_with_tag(data, TAG_FINAL);
            Ok(())
        }
        fn recv_from(&mut self, from: usize, buf: &mut [f64]) -> Result<()> {
            count_ok(buf.len())?;
            let status = self
                .comm
                .process_at_rank(from as i32)
                .receive_into_with_tag(buf, TAG_FINAL);
            let got = status.count(f64::equivalent_datatype());
            if got as usize != buf.len() {
                return Err(Error::invalid(format!(
                    "halo exchange: rank {from} sent a tile of {got} values, expected {}",
                    buf.len()
                )));
            }
            Ok(())
        }
        fn send_to_root_f32(&mut self, data: &[f32]) -> Result<()> {
            count_ok(data.len())?;
            self.comm.process_at_rank(0).send_with_tag(data, TAG_FINAL);
            Ok(())
        }
        fn recv_from_f32(&mut self, from: usize, buf: &mut [f32]) -> Result<()> {
            count_ok(buf.len())?;
            let status = self
                .comm
                .process_at_rank(from as i32)
                .receive_into_with_tag(buf, TAG_FINAL);
            let got = status.count(f32::equivalent_datatype());
            if got as usize != buf.len() {
                return Err(Error::invalid(format!(
                    "halo exchange: rank {from} sent a tile of {got} f32 values, expected {}",
                    buf.len()
                )));
            }
            Ok(())
        }
        fn sum(&mut self, v: &[u64]) -> Result<Vec<u64>> {
            let n = self.comm.size().max(1) as usize;
            let mut all = vec![0u64; v.len() * n];
            self.comm.all_gather_into(v, &mut all[..]);
            let mut s = vec![0u64; v.len()];
            for chunk in all.chunks_exact(v.len().max(1)) {
                for (a, b) in s.iter_mut().zip(chunk) {
                    *a += b;
                }
            }
            Ok(s)
        }
        fn all_gather(&mut self, v: &[f64]) -> Result<Vec<Vec<f64>>> {
            use mpi::datatype::PartitionMut;
            count_ok(v.len())?;
            let n = self.comm.size().max(1) as usize;
            let mut counts = vec![0i32; n];
            self.comm
                .all_gather_into(&(v.len() as i32), &mut counts[..]);
            let total: usize = counts.iter().map(|&c| c as usize).sum();
            count_ok(total)?;
            let displs: Vec<i32> = counts
                .iter()
                .scan(0i32, |acc, &c| {
                    let d = *acc;
                    *acc += c;
                    Some(d)
                })
                .collect();
            let mut all = vec![0f64; total];
            {
                let mut part = PartitionMut::new(&mut all[..], &counts[..], &displs[..]);
                self.comm.all_gather_varcount_into(v, &mut part);
            }
            Ok(counts
                .iter()
                .zip(&displs)
                .map(|(&c, &d)| all[d as usize..(d + c) as usize].to_vec())
                .collect())
        }
        fn barrier(&mut self) {
            self.comm.barrier();
        }
        fn fail(&self, e: Error) -> Error {
            crate::exec::mpi::abort(&e.to_string())
        }
    }
}

/// Ranks simulated by threads, for tests of the ranked drivers without MPI.
#[cfg(test)]
pub(crate) mod thread_ranks {
    use super::HaloTransport;
    use crate::error::{Error, Result};
    use std::sync::mpsc::{channel, Receiver, Sender};
    use std::sync::{Arc, Barrier};

    /// Ranks simulated by threads: one FIFO channel per ordered pair of
    /// ranks (the driver's messages between two ranks are received in the
    /// order they are sent, as MPI guarantees for one source and tag).
    pub(crate) struct Chan {
        pub(crate) me: usize,
        n: usize,
        tx: Vec<Sender<Vec<f64>>>,
        rx: Vec<Receiver<Vec<f64>>>,
        barrier: Arc<Barrier>,
    }

    pub(crate) fn chans(n: usize) -> Vec<Chan> {
        let mut tx: Vec<Vec<Option<Sender<Vec<f64>>>>> = (0..n).map(|_| vec![None; n]).collect();
        let mut rx: Vec<Vec<Option<Receiver<Vec<f64>>>>> =
            (0..n).map(|_| (0..n).map(|_| None).collect()).collect();
        for (p, txp) in tx.iter_mut().enumerate() {
            for (q, t) in txp.iter_mut().enumerate() {
                let (s, r) = channel();
                *t = Some(s);
                rx[q][p] = Some(r);
            }
        }
        let barrier = Arc::new(Barrier::new(n));
        tx.into_iter()
            .zip(rx)
            .enumerate()
            .map(|(me, (t, r))| Chan {
                me,
                n,
                tx: t.into_iter().map(|s| s.unwrap()).collect(),
                rx: r.into_iter().map(|s| s.unwrap()).collect(),
                barrier: barrier.clone(),
            })
            .collect()
    }

    impl Chan {
        fn recv(&self, from: usize, buf: &mut [f64]) -> Result<()> {
            let v = self.rx[from]
                .recv()
                .map_err(|_| Error::invalid(format!("rank {from} hung up")))?;
            if v.len() != buf.len() {
                return Err(Error::invalid(format!(
                    "rank {} got {} values from {from}, expected {}",
                    self.me,
                    v.len(),
                    buf.len()
                )));
            }
            buf.copy_from_slice(&v);
            Ok(())
        }
    }

    impl HaloTransport for Chan {
        fn rank(&self) -> (usize, usize) {
            (self.me, self.n)
        }
        fn distributed(&self) -> bool {
            false
        }
        fn exchange(&mut self, out: &[Vec<f64>], inbox: &mut [Vec<f64>]) -> Result<()> {
            for (q, v) in out.iter().enumerate() {
                if !v.is_empty() {
                    self.tx[q]
                        .send(v.clone())
                        .map_err(|_| Error::invalid("peer gone"))?;
                }
            }
            for (p, buf) in inbox.iter_mut().enumerate() {
                if !buf.is_empty() {
                    self.recv(p, buf)?;
                }
            }
            Ok(())
        }
        fn send_to_root(&mut self, data: &[f64]) -> Result<()> {
            self.tx[0]
                .send(data.to_vec())
                .map_err(|_| Error::invalid("rank 0 gone"))
        }
        fn recv_from(&mut self, from: usize, buf: &mut [f64]) -> Result<()> {
            self.recv(from, buf)
        }
        // The test channel carries f64: f32 values widened (exact) and back.
        fn send_to_root_f32(&mut self, data: &[f32]) -> Result<()> {
            self.tx[0]
                .send(data.iter().map(|&v| f64::from(v)).collect())
                .map_err(|_| Error::invalid("rank 0 gone"))
        }
        fn recv_from_f32(&mut self, from: usize, buf: &mut [f32]) -> Result<()> {
            let mut wide = vec![0.0f64; buf.len()];
            self.recv(from, &mut wide)?;
            for (d, s) in buf.iter_mut().zip(&wide) {
                *d = *s as f32;
            }
            Ok(())
        }
        fn sum(&mut self, v: &[u64]) -> Result<Vec<u64>> {
            // Exact for the counts the drivers sum (below 2^53).
            let wide: Vec<f64> = v.iter().map(|&c| c as f64).collect();
            let all = self.all_gather(&wide)?;
            Ok((0..v.len())
                .map(|i| all.iter().map(|m| m[i] as u64).sum())
                .collect())
        }
        fn all_gather(&mut self, v: &[f64]) -> Result<Vec<Vec<f64>>> {
            for q in 0..self.n {
                if q != self.me {
                    self.tx[q]
                        .send(v.to_vec())
                        .map_err(|_| Error::invalid("peer gone"))?;
                }
            }
            (0..self.n)
                .map(|p| {
                    if p == self.me {
                        Ok(v.to_vec())
                    } else {
                        self.rx[p]
                            .recv()
                            .map_err(|_| Error::invalid(format!("rank {p} hung up")))
                    }
                })
                .collect()
        }
        fn barrier(&mut self) {
            self.barrier.wait();
        }
        fn fail(&self, e: Error) -> Error {
            e
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Brute force: the set of cells of `rects`.
    fn cells(rects: &[Window]) -> std::collections::BTreeSet<(i64, i64)> {
        let mut s = std::collections::BTreeSet::new();
        for r in rects {
            for y in r.y..r.y_end() {
                for x in r.x..r.x_end() {
                    s.insert((x, y));
                }
            }
        }
        s
    }

    #[test]
    fn partition_is_contiguous_and_even() {
        let l = TileLayout::new(367, 359, 50); // 8 x 8 = 64 tiles
        for ranks in 1..=7 {
            let o = partition(&l, ranks);
            assert_eq!(o.len(), 64);
            assert!(o.windows(2).all(|w| w[0] <= w[1] && w[1] - w[0] <= 1));
            let sizes: Vec<usize> = (0..ranks)
                .map(|r| o.iter().filter(|&&x| x == r).count())
                .collect();
            assert_eq!(sizes.iter().sum::<usize>(), 64);
            let (mn, mx) = (sizes.iter().min().unwrap(), sizes.iter().max().unwrap());
            assert!(mx - mn <= 1, "{ranks} ranks: {sizes:?}");
        }
        // More ranks than tiles: the last ranks own nothing.
        let o = partition(&TileLayout::new(10, 10, 5), 6);
        assert_eq!(o, vec![0, 1, 2, 3]);
    }

    #[test]
    fn disjoint_cover_matches_the_union() {
        let sets: Vec<Vec<Window>> = vec![
            vec![],
            vec![Window::new(3, 4, 5, 2)],
            // L-shape (right strip + bottom strip of a tile), overlapping.
            vec![Window::new(40, 0, 10, 50), Window::new(0, 45, 50, 5)],
            // Nested, touching and disjoint pieces.
            vec![
                Window::new(0, 0, 10, 3),
                Window::new(2, 1, 3, 1),
                Window::new(10, 0, 4, 3),
                Window::new(20, 2, 2, 6),
                Window::new(0, 3, 14, 1),
            ],
        ];
        for rects in sets {
            let cover = disjoint_cover(&rects);
            let total: usize = cover.iter().map(|w| w.len()).sum();
            let want = cells(&rects);
            assert_eq!(total, want.len(), "overlap in {cover:?}");
            assert_eq!(cells(&cover), want);
            // Canonical: order of the input does not matter.
            let mut rev = rects.clone();
            rev.reverse();
            assert_eq!(disjoint_cover(&rev), cover);
        }
        // A full-width strip stays one rectangle.
        let c = disjoint_cover(&[Window::new(0, 0, 50, 4), Window::new(0, 0, 9, 4)]);
        assert_eq!(c, vec![Window::new(0, 0, 50, 4)]);
    }

    /// A value that identifies field and global cell.
    fn val(f: usize, x: i64, y: i64) -> f64 {
        (f * 1_000_000) as f64 + (y * 1000 + x) as f64 + 0.25
    }

    fn tile_state(layout: &TileLayout, id: TileId, nf: usize) -> Vec<f64> {
        let w = layout.window(id);
        let mut v = Vec::with_capacity(w.len() * nf);
        for f in 0..nf {
            for y in w.y..w.y_end() {
                for x in w.x..w.x_end() {
                    v.push(val(f, x, y));
                }
            }
        }
        v
    }

    /// Every rank's plan, strips extracted from the owners' tiles, "sent"
    /// and pasted with the local tiles into each patch, equals the patch
    /// copied cell by cell from the global state; and each rank receives
    /// exactly the distinct remote cells its patches need.
    #[test]
    fn strips_rebuild_every_patch() {
        let nf = 3;
        for &(w, h, tile, ghost) in &[
            (37usize, 29usize, 8usize, 3usize),
            (37, 29, 8, 11), // ghost wider than a tile
            (64, 16, 16, 4),
            (23, 41, 7, 1),
            (20, 20, 32, 5), // one tile
        ] {
            let layout = TileLayout::new(w, h, tile);
            let states: Vec<Vec<f64>> = (0..layout.count())
                .map(|id| tile_state(&layout, id, nf))
                .collect();
            for ranks in 1..=5 {
                let owner = partition(&layout, ranks);
                let plans: Vec<HaloPlan> = (0..ranks)
                    .map(|r| HaloPlan::new(&layout, ghost, owner.clone(), (r, ranks), nf).unwrap())
                    .collect();
                // Messages: outbox[p][q].
                let outbox: Vec<Vec<Vec<f64>>> = plans
                    .iter()
                    .map(|pl| {
                        let mut out = vec![Vec::new(); ranks];
                        for (q, strips) in pl.sends.iter().enumerate() {
                            for s in strips {
                                let tw = layout.window(s.tile);
                                extract(tw, &states[s.tile], nf, s.win, &mut out[q]);
                            }
                        }
                        out
                    })
                    .collect();
                for (r, pl) in plans.iter().enumerate() {
                    assert_eq!(
                        pl.mine,
                        (0..layout.count())
                            .filter(|&t| owner[t] == r)
                            .collect::<Vec<_>>()
                    );
                    let inbox: Vec<&Vec<f64>> = (0..ranks).map(|p| &outbox[p][r]).collect();
                    for (p, msg) in inbox.iter().enumerate() {
                        assert_eq!(msg.len(), pl.recv_len[p], "{ranks} ranks, {p}->{r}");
                    }
                    // Distinct remote cells this rank's patches need.
                    let mut want_remote = std::collections::BTreeSet::new();
                    for &id in &pl.mine {
                        let pw = patch_window(&layout, id, ghost);
                        let mut fields = vec![vec![f64::NAN; pw.len()]; nf];
                        for tid in layout.tiles_in(&pw) {
                            let tw = layout.window(tid);
                            let iw = tw.intersect(&pw).unwrap();
                            if owner[tid] == r {
                                paste(pw, &mut fields, tw, &states[tid], iw);
                            } else {
                                for y in iw.y..iw.y_end() {
                                    for x in iw.x..iw.x_end() {
                                        want_remote.insert((x, y));
                                    }
                                }
                                for g in &pl.ghosts[tid] {
                                    let n = g.win.len() * nf;
                                    let src = &inbox[g.from][g.offset..g.offset + n];
                                    paste(pw, &mut fields, g.win, src, iw);
                                }
                            }
                        }
                        for (f, field) in fields.iter().enumerate() {
                            for y in 0..pw.h {
                                for x in 0..pw.w {
                                    let (gx, gy) = (pw.x + x as i64, pw.y + y as i64);
                                    assert_eq!(
                                        field[y * pw.w + x].to_bits(),
                                        val(f, gx, gy).to_bits(),
                                        "{w}x{h} tile {tile} ghost {ghost}, {ranks} ranks: rank {r} tile {id} field {f} cell ({gx},{gy})"
                                    );
                                }
                            }
                        }
                    }
                    let got: usize = pl.recv_len.iter().sum();
                    assert_eq!(got, want_remote.len() * nf, "no cell received twice");
                }
            }
        }
    }
}
