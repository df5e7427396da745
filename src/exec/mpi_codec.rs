//! Wire formats and tile assignment of the MPI engine, kept free of MPI so
//! they build (and are tested) without the `mpi` feature.
//!
//! Messages are plain little-endian byte strings:
//! - a *tile message* carries one tile's outputs in their native types:
//!   `id: u64, n: u32`, then per output `dtype: u8, width: u64, height: u64`
//!   and `width * height * dtype.size()` bytes of cells;
//! - a *record list* carries tile summaries (or any per-tile bytes):
//!   repeated `id: u64, len: u64, len bytes`.
//!
//! Decoding checks every length against the bytes present before it
//! allocates, so a short or garbled message is an error, not a panic.

use crate::error::{Error, Result};
use crate::raster::{AnyGrid, DType, TileId, TileLayout};

/// The cell types in wire order (the byte code is the index).
const DTYPES: [DType; 8] = DType::ALL;

fn dtype_code(d: DType) -> u8 {
    DTYPES.iter().position(|&x| x == d).unwrap_or(0) as u8
}

/// Encode tile `id`'s outputs (native types) as one tile message.
pub fn encode_tile(id: TileId, grids: &[AnyGrid]) -> Vec<u8> {
    let body: usize = grids.iter().map(|g| 17 + g.as_le_bytes().len()).sum();
    let mut out = Vec::with_capacity(12 + body);
    out.extend_from_slice(&(id as u64).to_le_bytes());
    out.extend_from_slice(&(grids.len() as u32).to_le_bytes());
    for g in grids {
        out.push(dtype_code(g.dtype()));
        out.extend_from_slice(&(g.width() as u64).to_le_bytes());
        out.extend_from_slice(&(g.height() as u64).to_le_bytes());
        out.extend_from_slice(g.as_le_bytes());
    }
    out
}

/// A cursor over a message that refuses to read past its end.
struct Reader<'a> {
    b: &'a [u8],
    at: usize,
    what: &'static str,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Result<&'a [u8]> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.b.len());
        match end {
            Some(e) => {
                let s = &self.b[self.at..e];
                self.at = e;
                Ok(s)
            }
            None => Err(Error::invalid(format!(
                "MPI engine: a {} of {} bytes ends early (wanted {n} more bytes at offset {}); the ranks run different orogen builds or a message was cut",
                self.what,
                self.b.len(),
                self.at
            ))),
        }
    }
    fn u64(&mut self) -> Result<u64> {
        let mut a = [0u8; 8];
        a.copy_from_slice(self.take(8)?);
        Ok(u64::from_le_bytes(a))
    }
    fn u32(&mut self) -> Result<u32> {
        let mut a = [0u8; 4];
        a.copy_from_slice(self.take(4)?);
        Ok(u32::from_le_bytes(a))
    }
    fn done(&self) -> bool {
        self.at == self.b.len()
    }
}

/// Decode a tile message; `expect` is the tile id the receiver waits for,
/// `shapes[k]` the `(dtype, width, height)` output `k` must have.
pub fn decode_tile(
    msg: &[u8],
    expect: TileId,
    shapes: &[(DType, usize, usize)],
) -> Result<Vec<AnyGrid>> {
    let mut r = Reader {
        b: msg,
        at: 0,
        what: "tile message",
    };
    let out = decode_cells(&mut r, expect, shapes)?;
    if !r.done() {
        return Err(Error::invalid(format!(
            "MPI engine: tile {expect} message has {} bytes after its outputs",
            msg.len() - r.at
        )));
    }
    Ok(out)
}

/// What a rank reports of an output it wrote itself: `(crc32, bytes)` of
/// the tile file, as a tile store's journal records them.
pub type Receipt = (u32, u64);

/// A decoded tile message: the outputs whose cells travelled, and the
/// receipts of those the sender wrote itself.
pub type TileParts = (Vec<AnyGrid>, Vec<Receipt>);

/// Encode tile `id`'s message when some outputs were written by the sender
/// itself (delegated tile-store writes): the tile message of the outputs
/// whose cells travel (`cells`), then `n: u32` and per written output its
/// `crc32: u32, bytes: u64` (what the store's writer records).
pub fn encode_tile_written(id: TileId, cells: &[AnyGrid], written: &[Receipt]) -> Vec<u8> {
    let mut out = encode_tile(id, cells);
    out.extend_from_slice(&(written.len() as u32).to_le_bytes());
    for &(crc, bytes) in written {
        out.extend_from_slice(&crc.to_le_bytes());
        out.extend_from_slice(&bytes.to_le_bytes());
    }
    out
}

/// Decode [`encode_tile_written`]: the outputs whose cells travel (shapes as
/// in [`decode_tile`]) and the `n_written` receipts `(crc32, bytes)`.
pub fn decode_tile_written(
    msg: &[u8],
    expect: TileId,
    shapes: &[(DType, usize, usize)],
    n_written: usize,
) -> Result<TileParts> {
    let mut r = Reader {
        b: msg,
        at: 0,
        what: "tile message",
    };
    let cells = decode_cells(&mut r, expect, shapes)?;
    let n = r.u32()? as usize;
    if n != n_written {
        return Err(Error::invalid(format!(
            "MPI engine: tile {expect} reports {n} outputs written by its rank, expected {n_written}"
        )));
    }
    let mut written = Vec::with_capacity(n);
    for _ in 0..n {
        let crc = r.u32()?;
        written.push((crc, r.u64()?));
    }
    if !r.done() {
        return Err(Error::invalid(format!(
            "MPI engine: tile {expect} message has {} bytes after its outputs",
            msg.len() - r.at
        )));
    }
    Ok((cells, written))
}

/// The outputs of a tile message, leaving the reader after them.
fn decode_cells(
    r: &mut Reader,
    expect: TileId,
    shapes: &[(DType, usize, usize)],
) -> Result<Vec<AnyGrid>> {
    let id = r.u64()?;
    if id != expect as u64 {
        return Err(Error::invalid(format!(
            "MPI engine: expected tile {expect}, received tile {id}"
        )));
    }
    let n = r.u32()? as usize;
    if n != shapes.len() {
        return Err(Error::invalid(format!(
            "MPI engine: tile {id} carries {n} outputs, the step has {}",
            shapes.len()
        )));
    }
    let mut out = Vec::with_capacity(n);
    for &(dt, w, h) in shapes {
        let code = r.take(1)?[0] as usize;
        let got = DTYPES.get(code).copied();
        let (gw, gh) = (r.u64()?, r.u64()?);
        if got != Some(dt) || gw != w as u64 || gh != h as u64 {
            return Err(Error::invalid(format!(
                "MPI engine: tile {id} output is {gw}x{gh} of type code {code}, expected {w}x{h} {dt}"
            )));
        }
        let len = w.checked_mul(h).and_then(|c| c.checked_mul(dt.size()));
        let bytes = r.take(len.unwrap_or(usize::MAX))?;
        out.push(AnyGrid::from_le_bytes(dt, w, h, bytes)?);
    }
    Ok(out)
}

/// How the tiles to do are dealt to the ranks.
///
/// Both deal tiles on request (a rank asks rank 0 when its own queue runs
/// low), so both run through the same code and the same flow control; they
/// differ only in which tiles a request gets. The output never depends on
/// the schedule.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Schedule {
    /// Dynamic work queue with a guided schedule (the default): a request
    /// gets the next `ceil(remaining / (2 x ranks))` tiles in tile order
    /// (at least 1), so chunks are large while much is left and single
    /// tiles at the end, when a rank that drew cheap tiles takes over the
    /// last expensive ones. Guided self-scheduling: Polychronopoulos & Kuck
    /// (1987), "Guided self-scheduling: a practical scheduling scheme for
    /// parallel supercomputers", IEEE Trans. Computers C-36(12); the
    /// `2 x ranks` divisor is the "factoring" refinement (Hummel, Schonberg
    /// & Flynn 1992, "Factoring: a method for scheduling parallel loops",
    /// CACM 35(8)), which leaves half of the work to later, smaller chunks.
    Queue,
    /// Static round robin (the `k`-th tile to do belongs to rank
    /// `k mod ranks`), handed out in the same requests: kept to measure the
    /// queue against (`OROGEN_MPI_SCHEDULE=round-robin`).
    RoundRobin,
}

impl Schedule {
    /// Parse `queue` or `round-robin` (the value of `OROGEN_MPI_SCHEDULE`).
    pub fn parse(s: &str) -> Result<Schedule> {
        match s {
            "queue" | "" => Ok(Schedule::Queue),
            "round-robin" => Ok(Schedule::RoundRobin),
            _ => Err(Error::invalid(format!(
                "OROGEN_MPI_SCHEDULE={s}: expected `queue` (the default) or `round-robin`"
            ))),
        }
    }
}

/// Rank 0's record of the work queue over the tiles to do, numbered
/// `0..len` (positions in the tile list every rank holds): which rank got
/// which position, and what a request gets ([`Schedule`]).
///
/// With a `window` (outputs that travel to rank 0, which writes them in
/// tile order), no position at or beyond `frontier + window` is handed out,
/// where `frontier` is the first position rank 0 has not yet written: rank
/// 0 then never holds more than `window` tiles waiting for an earlier one.
/// The position at the frontier itself is always grantable, so the queue
/// cannot stall (see the deadlock note in `exec::mpi_queue`).
#[derive(Debug, Clone)]
pub struct Queue {
    len: usize,
    ranks: usize,
    schedule: Schedule,
    window: Option<usize>,
    max_chunk: usize,
    /// Queue: next position to hand out.
    next: usize,
    /// Round robin: next position of each rank (`r`, `r + ranks`, ...).
    next_of: Vec<usize>,
    owner: Vec<u32>,
}

/// Owner value of a position not yet handed out.
const NOBODY: u32 = u32::MAX;

impl Queue {
    /// A queue over `len` positions for `ranks` ranks; `window` as above;
    /// no grant is larger than `max_chunk` (at least 1).
    pub fn new(
        len: usize,
        ranks: usize,
        schedule: Schedule,
        window: Option<usize>,
        max_chunk: usize,
    ) -> Result<Queue> {
        let ranks = ranks.max(1);
        if ranks >= NOBODY as usize {
            return Err(Error::invalid(format!("MPI engine: {ranks} ranks")));
        }
        Ok(Queue {
            len,
            ranks,
            schedule,
            window: window.map(|w| w.max(1)),
            max_chunk: max_chunk.max(1),
            next: 0,
            next_of: (0..ranks).collect(),
            owner: vec![NOBODY; len],
        })
    }

    /// Positions to do.
    pub fn len(&self) -> usize {
        self.len
    }

    /// True if there is nothing to do at all.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// True when rank `r` will never be granted anything more.
    pub fn exhausted(&self, r: usize) -> bool {
        match self.schedule {
            Schedule::Queue => self.next >= self.len,
            Schedule::RoundRobin => self.next_of.get(r).is_none_or(|&k| k >= self.len),
        }
    }

    /// The rank position `k` was granted to, if any.
    pub fn owner(&self, k: usize) -> Option<usize> {
        self.owner
            .get(k)
            .filter(|&&o| o != NOBODY)
            .map(|&o| o as usize)
    }

    /// Grant rank `r` up to `want` positions (increasing); `frontier` is the
    /// first position rank 0 has not consumed (only used with a window).
    /// Empty when nothing can be granted now (window full) or ever
    /// ([`Queue::exhausted`]).
    pub fn grant(&mut self, r: usize, want: usize, frontier: usize) -> Vec<usize> {
        let limit = match self.window {
            Some(w) => frontier.saturating_add(w).min(self.len),
            None => self.len,
        };
        if r >= self.ranks {
            return Vec::new();
        }
        let out: Vec<usize> = match self.schedule {
            Schedule::Queue => {
                let remaining = self.len.saturating_sub(self.next);
                let guided = remaining.div_ceil(2 * self.ranks).max(1);
                // Under a window no grant takes more than a 2·ranks-th of
                // it, or one rank would hold the whole window and the others
                // wait for it to write.
                let share = self
                    .window
                    .map_or(usize::MAX, |w| (w / (2 * self.ranks)).max(1));
                let n = guided
                    .min(share)
                    .min(self.max_chunk)
                    .min(limit.saturating_sub(self.next));
                let ks: Vec<usize> = (self.next..self.next + n).collect();
                self.next += n;
                ks
            }
            Schedule::RoundRobin => {
                let mut ks = Vec::new();
                let k = &mut self.next_of[r];
                while *k < limit && ks.len() < want.clamp(1, self.max_chunk) {
                    ks.push(*k);
                    *k += self.ranks;
                }
                ks
            }
        };
        for &k in &out {
            self.owner[k] = r as u32;
        }
        out
    }
}

/// Encode a grant: `n: u32` runs of consecutive positions as
/// `start: u64, len: u64`, then the payload (slices of the granted tiles,
/// or nothing). No positions means "no more work".
pub fn encode_grant(ks: &[usize], payload: &[u8]) -> Vec<u8> {
    let mut runs: Vec<(usize, usize)> = Vec::new();
    for &k in ks {
        match runs.last_mut() {
            Some((s, n)) if *s + *n == k => *n += 1,
            _ => runs.push((k, 1)),
        }
    }
    let mut out = Vec::with_capacity(4 + 16 * runs.len() + payload.len());
    out.extend_from_slice(&(runs.len() as u32).to_le_bytes());
    for (s, n) in runs {
        out.extend_from_slice(&(s as u64).to_le_bytes());
        out.extend_from_slice(&(n as u64).to_le_bytes());
    }
    out.extend_from_slice(payload);
    out
}

/// Decode [`encode_grant`]: the positions (each `< len`, increasing, no
/// repeats) and the payload.
pub fn decode_grant(msg: &[u8], len: usize) -> Result<(Vec<usize>, &[u8])> {
    let mut r = Reader {
        b: msg,
        at: 0,
        what: "work-queue grant",
    };
    let runs = r.u32()?;
    let mut ks = Vec::new();
    let mut end = 0u64;
    for _ in 0..runs {
        let (s, n) = (r.u64()?, r.u64()?);
        let e = s
            .checked_add(n)
            .filter(|&e| n > 0 && s >= end && e <= len as u64);
        let Some(e) = e else {
            return Err(Error::invalid(format!(
                "MPI engine: a work-queue grant of positions {s}+{n} (after {end}) does not fit the {len} tiles to do"
            )));
        };
        ks.extend(s as usize..e as usize);
        end = e;
    }
    Ok((ks, &msg[r.at..]))
}

/// Append one record (`id`, `bytes`) to a record list.
pub fn push_record(list: &mut Vec<u8>, id: TileId, bytes: &[u8]) {
    list.extend_from_slice(&(id as u64).to_le_bytes());
    list.extend_from_slice(&(bytes.len() as u64).to_le_bytes());
    list.extend_from_slice(bytes);
}

/// Split a record list into `(id, bytes)` pairs; ids must be `< count`.
pub fn decode_records(list: &[u8], count: usize) -> Result<Vec<(TileId, &[u8])>> {
    let mut r = Reader {
        b: list,
        at: 0,
        what: "summary list",
    };
    let mut out = Vec::new();
    while !r.done() {
        let id = r.u64()?;
        if id >= count as u64 {
            return Err(Error::invalid(format!(
                "MPI engine: a summary names tile {id}, the layout has {count} tiles"
            )));
        }
        let len = usize::try_from(r.u64()?).unwrap_or(usize::MAX);
        out.push((id as TileId, r.take(len)?));
    }
    Ok(out)
}

/// Cells on the perimeter of every tile of `layout`, the unit Barnes (2017)
/// measures communication in.
pub fn perimeter_cells(layout: &TileLayout) -> u64 {
    (0..layout.count())
        .map(|id| {
            let w = layout.window(id);
            let (cw, ch) = (w.w as u64, w.h as u64);
            if cw <= 1 || ch <= 1 {
                cw * ch
            } else {
                2 * (cw + ch) - 4
            }
        })
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raster::Grid;

    fn grids() -> Vec<AnyGrid> {
        vec![
            AnyGrid::F32(Grid::from_fn(3, 2, |x, y| x as f32 * 1.5 - y as f32)),
            AnyGrid::U8(Grid::from_fn(3, 2, |x, y| (x * 7 + y) as u8)),
            AnyGrid::F64(Grid::from_fn(
                3,
                2,
                |x, y| if x == y { f64::NAN } else { -2.25 },
            )),
            AnyGrid::I16(Grid::from_fn(3, 2, |x, y| x as i16 - 300 * y as i16)),
        ]
    }

    fn shapes(g: &[AnyGrid]) -> Vec<(DType, usize, usize)> {
        g.iter()
            .map(|g| (g.dtype(), g.width(), g.height()))
            .collect()
    }

    #[test]
    fn tile_message_round_trips_bytes_exactly() {
        let g = grids();
        let msg = encode_tile(5, &g);
        // Header 12 bytes, per output 17 bytes + cells.
        assert_eq!(msg.len(), 12 + 4 * 17 + 6 * (4 + 1 + 8 + 2));
        let back = decode_tile(&msg, 5, &shapes(&g)).unwrap();
        for (a, b) in g.iter().zip(&back) {
            assert_eq!(a.dtype(), b.dtype());
            assert_eq!(a.as_le_bytes(), b.as_le_bytes());
        }
    }

    #[test]
    fn damaged_tile_messages_are_errors() {
        let g = grids();
        let s = shapes(&g);
        let msg = encode_tile(5, &g);
        for cut in [0, 7, 12, 20, msg.len() - 1] {
            assert!(decode_tile(&msg[..cut], 5, &s).is_err(), "cut at {cut}");
        }
        assert!(decode_tile(&msg, 6, &s).is_err(), "wrong id");
        assert!(decode_tile(&msg, 5, &s[..3]).is_err(), "wrong count");
        let mut wrong = s.clone();
        wrong[1].0 = DType::I8;
        assert!(decode_tile(&msg, 5, &wrong).is_err(), "wrong type");
        let mut longer = msg.clone();
        longer.push(0);
        assert!(decode_tile(&longer, 5, &s).is_err(), "trailing bytes");
        // A huge declared size must not allocate: the byte count is checked first.
        let mut huge = encode_tile(5, &g[..1]);
        huge[13..21].copy_from_slice(&u64::MAX.to_le_bytes());
        let big = [(DType::F32, usize::MAX, 1)];
        assert!(decode_tile(&huge, 5, &big).is_err());
    }

    #[test]
    fn record_lists_split_and_reject_bad_lengths() {
        let mut l = Vec::new();
        push_record(&mut l, 3, b"abc");
        push_record(&mut l, 0, b"");
        push_record(&mut l, 9, &[7u8; 40]);
        let r = decode_records(&l, 10).unwrap();
        assert_eq!(r.len(), 3);
        assert_eq!((r[0].0, r[0].1), (3, &b"abc"[..]));
        assert_eq!((r[1].0, r[1].1.len()), (0, 0));
        assert_eq!((r[2].0, r[2].1), (9, &[7u8; 40][..]));
        assert!(decode_records(&l, 9).is_err(), "id out of range");
        assert!(decode_records(&l[..l.len() - 1], 10).is_err(), "cut");
        let mut bad = Vec::new();
        bad.extend_from_slice(&1u64.to_le_bytes());
        bad.extend_from_slice(&u64::MAX.to_le_bytes());
        assert!(decode_records(&bad, 10).is_err(), "absurd length");
        assert!(decode_records(&[], 10).unwrap().is_empty());
    }

    #[test]
    fn tile_messages_with_receipts_round_trip_and_reject_damage() {
        let g = grids();
        let cells = &g[1..3];
        let written = [(0xdead_beef_u32, 12_345u64), (7, 0)];
        let msg = encode_tile_written(4, cells, &written);
        assert_eq!(msg.len(), encode_tile(4, cells).len() + 4 + 2 * 12);
        let (back, rec) = decode_tile_written(&msg, 4, &shapes(cells), 2).unwrap();
        assert_eq!(rec, written.to_vec());
        for (a, b) in cells.iter().zip(&back) {
            assert_eq!(a.as_le_bytes(), b.as_le_bytes());
        }
        // Only receipts (every output delegated), or none.
        let only = encode_tile_written(9, &[], &written[..1]);
        assert_eq!(
            decode_tile_written(&only, 9, &[], 1).unwrap(),
            (Vec::new(), vec![written[0]])
        );
        let none = encode_tile_written(9, cells, &[]);
        assert_eq!(
            decode_tile_written(&none, 9, &shapes(cells), 0).unwrap().1,
            vec![]
        );
        // Wrong receipt count, cut anywhere, trailing bytes, wrong tile.
        assert!(decode_tile_written(&msg, 4, &shapes(cells), 1).is_err());
        for cut in [0, 11, msg.len() - 12, msg.len() - 1] {
            assert!(decode_tile_written(&msg[..cut], 4, &shapes(cells), 2).is_err());
        }
        let mut longer = msg.clone();
        longer.push(1);
        assert!(decode_tile_written(&longer, 4, &shapes(cells), 2).is_err());
        assert!(decode_tile_written(&msg, 5, &shapes(cells), 2).is_err());
    }

    /// Hand out every position of `q` to ranks asking in turn, with the
    /// frontier following the lowest position not yet granted.
    fn drain(q: &mut Queue, ranks: usize, want: usize) -> Vec<Vec<usize>> {
        let mut got = vec![Vec::new(); ranks];
        let mut guard = 0;
        while (0..ranks).any(|r| !q.exhausted(r)) {
            for (r, g) in got.iter_mut().enumerate() {
                let frontier = (0..q.len())
                    .find(|&k| q.owner(k).is_none())
                    .unwrap_or(q.len());
                g.extend(q.grant(r, want, frontier));
            }
            guard += 1;
            assert!(guard < 10_000);
        }
        got
    }

    #[test]
    fn queue_hands_out_every_position_once_in_shrinking_chunks() {
        for ranks in 1..=5 {
            let mut q = Queue::new(100, ranks, Schedule::Queue, None, usize::MAX).unwrap();
            let mut sizes = Vec::new();
            let mut seen = [false; 100];
            let mut r = 0;
            while !q.exhausted(0) {
                let ks = q.grant(r % ranks, 8, 0);
                sizes.push(ks.len());
                for &k in &ks {
                    assert!(!seen[k]);
                    seen[k] = true;
                    assert_eq!(q.owner(k), Some(r % ranks));
                }
                r += 1;
            }
            assert!(seen.iter().all(|&s| s), "{ranks} ranks");
            // Guided: ceil(remaining / 2N), never growing, ending in ones.
            assert_eq!(sizes[0], 100usize.div_ceil(2 * ranks));
            assert!(sizes.windows(2).all(|w| w[0] >= w[1]), "{sizes:?}");
            assert_eq!(*sizes.last().unwrap(), 1);
            assert!(q.grant(0, 8, 0).is_empty());
        }
    }

    #[test]
    fn round_robin_gives_rank_r_the_positions_r_mod_n() {
        let mut q = Queue::new(11, 3, Schedule::RoundRobin, None, usize::MAX).unwrap();
        let got = drain(&mut q, 3, 2);
        assert_eq!(got[0], vec![0, 3, 6, 9]);
        assert_eq!(got[1], vec![1, 4, 7, 10]);
        assert_eq!(got[2], vec![2, 5, 8]);
    }

    #[test]
    fn window_limits_what_is_granted_ahead_of_the_frontier() {
        for schedule in [Schedule::Queue, Schedule::RoundRobin] {
            let mut q = Queue::new(50, 2, schedule, Some(6), usize::MAX).unwrap();
            // Frontier stuck at 0: nothing at or past position 6 goes out.
            let mut all = Vec::new();
            for _ in 0..20 {
                all.extend(q.grant(0, 4, 0));
                all.extend(q.grant(1, 4, 0));
            }
            assert!(all.iter().all(|&k| k < 6), "{schedule:?} {all:?}");
            assert_eq!(all.len(), 6, "{schedule:?}");
            // The frontier moves on: so does the window, and all is granted.
            let got = drain(&mut q, 2, 4);
            let mut every: Vec<usize> = got.concat();
            every.extend(all);
            every.sort_unstable();
            assert_eq!(every, (0..50).collect::<Vec<_>>(), "{schedule:?}");
        }
    }

    /// Discrete-event simulation of `ranks` ranks drawing from the queue
    /// (one tile at a time each, no communication cost): the time the last
    /// rank finishes.
    fn makespan(cost: &[u64], ranks: usize, schedule: Schedule) -> u64 {
        let mut q = Queue::new(cost.len(), ranks, schedule, None, usize::MAX).unwrap();
        let mut clock = vec![0u64; ranks];
        let mut local: Vec<std::collections::VecDeque<usize>> = vec![Default::default(); ranks];
        // The rank that is free first works next (ties: lowest rank).
        while let Some(r) = (0..ranks)
            .filter(|&r| !local[r].is_empty() || !q.exhausted(r))
            .min_by_key(|&r| (clock[r], r))
        {
            if local[r].is_empty() {
                local[r].extend(q.grant(r, 1, 0));
            }
            if let Some(k) = local[r].pop_front() {
                clock[r] += cost[k];
            }
        }
        clock.into_iter().max().unwrap_or(0)
    }

    #[test]
    fn queue_balances_what_round_robin_cannot() {
        // 10 x 10 tiles whose odd columns are empty (cost 1) and even ones
        // full (cost 100): round robin over 2 ranks gives rank 0 every full
        // tile. Brute-force bound: total / ranks + the largest tile.
        let cost: Vec<u64> = (0..100).map(|k| if k % 2 == 0 { 100 } else { 1 }).collect();
        let total: u64 = cost.iter().sum();
        assert_eq!(makespan(&cost, 2, Schedule::RoundRobin), 50 * 100);
        let m = makespan(&cost, 2, Schedule::Queue);
        assert!(m <= total / 2 + 100, "queue makespan {m}, total {total}");
        let m3 = makespan(&cost, 3, Schedule::Queue);
        assert!(m3 <= total / 3 + 100, "3 ranks: {m3}");
    }

    #[test]
    fn grants_round_trip_and_reject_damage() {
        let ks = vec![3, 4, 5, 9, 11, 12];
        let msg = encode_grant(&ks, b"slices");
        assert_eq!(msg.len(), 4 + 3 * 16 + 6);
        let (back, payload) = decode_grant(&msg, 13).unwrap();
        assert_eq!(back, ks);
        assert_eq!(payload, b"slices");
        let end = encode_grant(&[], &[]);
        assert_eq!(decode_grant(&end, 13).unwrap(), (vec![], &[][..]));
        assert!(decode_grant(&msg, 12).is_err(), "beyond the tiles to do");
        assert!(decode_grant(&msg[..10], 13).is_err(), "cut");
        // Overlapping, empty or absurd runs.
        let mut bad = Vec::new();
        bad.extend_from_slice(&2u32.to_le_bytes());
        for (s, n) in [(4u64, 2u64), (5, 1)] {
            bad.extend_from_slice(&s.to_le_bytes());
            bad.extend_from_slice(&n.to_le_bytes());
        }
        assert!(decode_grant(&bad, 13).is_err(), "overlap");
        let mut huge = Vec::new();
        huge.extend_from_slice(&1u32.to_le_bytes());
        huge.extend_from_slice(&1u64.to_le_bytes());
        huge.extend_from_slice(&u64::MAX.to_le_bytes());
        assert!(decode_grant(&huge, 13).is_err(), "absurd length");
        assert!(Schedule::parse("fifo").is_err());
        assert_eq!(
            Schedule::parse("round-robin").unwrap(),
            Schedule::RoundRobin
        );
    }

    #[test]
    fn perimeter_counts_edge_cells_once_per_tile() {
        // 10x7 in tiles of 4: tiles 4x4 (12), 4x4, 2x4 (8); 4x3 (10), 4x3, 2x3 (6).
        let l = TileLayout::new(10, 7, 4);
        assert_eq!(perimeter_cells(&l), 12 + 12 + 8 + 10 + 10 + 6);
        assert_eq!(perimeter_cells(&TileLayout::new(5, 1, 4)), 4 + 1);
    }
}
