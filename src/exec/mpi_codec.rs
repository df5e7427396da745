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
const DTYPES: [DType; 8] = [
    DType::U8,
    DType::I8,
    DType::U16,
    DType::I16,
    DType::U32,
    DType::I32,
    DType::F32,
    DType::F64,
];

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

/// Owner rank of every tile of `count` tiles for the tiles to do `ids`
/// (`None` for tiles not to do): the routing table by which rank 0 sends
/// each rank the slices of exactly its tiles.
pub fn owner_table(ids: &[TileId], ranks: usize, count: usize) -> Result<Vec<Option<usize>>> {
    let mut table = vec![None; count];
    for (&id, o) in ids.iter().zip(owners(ids, ranks)) {
        match table.get_mut(id) {
            Some(slot @ None) => *slot = Some(o),
            Some(Some(_)) => {
                return Err(Error::invalid(format!(
                    "MPI engine: tile {id} is listed twice among the tiles to do"
                )))
            }
            None => {
                return Err(Error::invalid(format!(
                    "MPI engine: tile {id} is listed to do, the layout has {count} tiles"
                )))
            }
        }
    }
    Ok(table)
}

/// Split per-tile records (`(id, bytes)` in increasing id order) into one
/// record list per rank by `table` (see [`owner_table`]); a record of a
/// tile that is not to do is an error.
pub fn route_records(
    records: &[(TileId, Vec<u8>)],
    table: &[Option<usize>],
    ranks: usize,
) -> Result<Vec<Vec<u8>>> {
    let mut lists = vec![Vec::new(); ranks.max(1)];
    for (id, b) in records {
        let owner = table
            .get(*id)
            .copied()
            .flatten()
            .filter(|&o| o < lists.len());
        let Some(o) = owner else {
            return Err(Error::invalid(format!(
                "MPI engine: a slice of tile {id}, which no rank is to do"
            )));
        };
        push_record(&mut lists[o], *id, b);
    }
    Ok(lists)
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

/// Owner rank of each entry of `ids` (a list in increasing tile order):
/// the `k`-th tile to do goes to rank `k mod ranks`. Round robin over the
/// row-major order spreads every band of rows, and hence uneven work that
/// follows the terrain, over all ranks; the owners depend only on `ids` and
/// `ranks`, and the output never depends on them.
pub fn owners(ids: &[TileId], ranks: usize) -> Vec<usize> {
    let r = ranks.max(1);
    (0..ids.len()).map(|k| k % r).collect()
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

    #[test]
    fn slices_are_routed_to_the_owner_of_their_tile_only() {
        // 10 tiles, 3..=8 to do on 2 ranks: 3,5,7 -> rank 0; 4,6,8 -> rank 1.
        let ids: Vec<TileId> = (3..=8).collect();
        let table = owner_table(&ids, 2, 10).unwrap();
        let want: Vec<Option<usize>> = (0..10)
            .map(|t| (3..=8).contains(&t).then(|| (t - 3) % 2))
            .collect();
        assert_eq!(table, want);
        let records: Vec<(TileId, Vec<u8>)> =
            ids.iter().map(|&id| (id, vec![id as u8; id])).collect();
        let lists = route_records(&records, &table, 2).unwrap();
        assert_eq!(lists.len(), 2);
        for (r, list) in lists.iter().enumerate() {
            let got = decode_records(list, 10).unwrap();
            let got_ids: Vec<TileId> = got.iter().map(|(id, _)| *id).collect();
            let want_ids: Vec<TileId> = ids.iter().copied().filter(|t| (t - 3) % 2 == r).collect();
            assert_eq!(got_ids, want_ids, "rank {r}");
            for (id, b) in got {
                assert_eq!(b, &vec![id as u8; id][..]);
            }
        }
        // A slice for a tile no rank does, a duplicate or out-of-range id.
        assert!(route_records(&[(0, vec![1])], &table, 2).is_err());
        assert!(owner_table(&[1, 1], 2, 10).is_err());
        assert!(owner_table(&[10], 2, 10).is_err());
        // More ranks than tiles: the extra ranks get empty lists.
        let t4 = owner_table(&[2, 5], 4, 6).unwrap();
        let l4 = route_records(&[(2, vec![9]), (5, vec![8])], &t4, 4).unwrap();
        assert_eq!(
            l4.iter().map(|l| l.is_empty()).collect::<Vec<_>>(),
            vec![false, false, true, true]
        );
    }

    #[test]
    fn owners_cover_every_rank_evenly() {
        let ids: Vec<TileId> = vec![0, 2, 3, 4, 7, 8, 9];
        assert_eq!(owners(&ids, 3), vec![0, 1, 2, 0, 1, 2, 0]);
        assert_eq!(owners(&ids, 1), vec![0; 7]);
        assert_eq!(owners(&ids, 0), vec![0; 7]);
    }

    #[test]
    fn perimeter_counts_edge_cells_once_per_tile() {
        // 10x7 in tiles of 4: tiles 4x4 (12), 4x4, 2x4 (8); 4x3 (10), 4x3, 2x3 (6).
        let l = TileLayout::new(10, 7, 4);
        assert_eq!(perimeter_cells(&l), 12 + 12 + 8 + 10 + 10 + 6);
        assert_eq!(perimeter_cells(&TileLayout::new(5, 1, 4)), 4 + 1);
    }
}
