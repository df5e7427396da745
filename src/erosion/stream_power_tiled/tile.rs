//! A tile's state, where it is kept (memory or one scratch file per tile),
//! and the geometry of a tile padded with the ring of its neighbours'
//! published perimeter cells.

use super::super::stream_power::{DX, DY};
use crate::error::{Error, IoContext, Result};
use crate::exec::iterate::{Board, MemStates, TileStates};
use crate::raster::{perimeter_cells, perimeter_index, perimeter_len, TileId, TileLayout, Window};
use std::path::{Path, PathBuf};

/// Bytes per cell of a tile's state (h, level, area: f64; flat distance: u32;
/// flags, receiver direction, done: u8), plus one byte per cell of the ring
/// around the tile.
pub const TILE_BYTES_PER_CELL: u64 = 31;

/// No receiver (root) in the direction array.
pub(super) const NONE: u8 = 8;

/// Published fields, each one value per perimeter cell, one after the other:
/// height, water level, upstream count (NaN until final), new height (valid
/// where `OK` is 1), flat distance, flags, receiver direction, new height known.
pub(super) const H: usize = 0;
pub(super) const LEV: usize = 1;
pub(super) const CNT: usize = 2;
pub(super) const HN: usize = 3;
pub(super) const DD: usize = 4;
pub(super) const FLAGS: usize = 5;
pub(super) const DIR: usize = 6;
pub(super) const OK: usize = 7;
/// Number of published fields.
pub(super) const NF: usize = 8;

/// One tile's state (core cells, row-major), plus `ring`: one flag per cell
/// of the ring around the tile (the drainage-area pass marks the
/// neighbours' counts it has added).
#[derive(Default)]
pub(super) struct Tile {
    pub h: Vec<f64>,
    pub lev: Vec<f64>,
    pub area: Vec<f64>,
    /// Flat distances; during the drainage-area pass, the donors still awaited.
    pub dd: Vec<u32>,
    pub flags: Vec<u8>,
    pub dir: Vec<u8>,
    pub done: Vec<u8>,
    pub ring: Vec<u8>,
}

impl Tile {
    /// A tile of `n` cells with a ring of `r` cells.
    pub fn new(n: usize, r: usize) -> Tile {
        Tile {
            h: vec![0.0; n],
            lev: vec![0.0; n],
            area: vec![0.0; n],
            dd: vec![0; n],
            flags: vec![0; n],
            dir: vec![NONE; n],
            done: vec![0; n],
            ring: vec![0; r],
        }
    }

    fn encode(&self) -> Vec<u8> {
        let n = self.h.len();
        let mut b = Vec::with_capacity(n * TILE_BYTES_PER_CELL as usize + self.ring.len());
        for v in [&self.h, &self.lev, &self.area] {
            for x in v.iter() {
                b.extend_from_slice(&x.to_le_bytes());
            }
        }
        for x in &self.dd {
            b.extend_from_slice(&x.to_le_bytes());
        }
        b.extend_from_slice(&self.flags);
        b.extend_from_slice(&self.dir);
        b.extend_from_slice(&self.done);
        b.extend_from_slice(&self.ring);
        b
    }

    fn decode(b: &[u8], n: usize, r: usize, path: &Path) -> Result<Tile> {
        let want = n as u64 * TILE_BYTES_PER_CELL + r as u64;
        if b.len() as u64 != want {
            return Err(Error::corrupt(
                path,
                format!(
                    "stream-power scratch tile has {} bytes, expected {want}; was the scratch folder changed during the run?",
                    b.len(),
                ),
            ));
        }
        let f64s = |k: usize| -> Vec<f64> {
            b[k * 8 * n..(k + 1) * 8 * n]
                .chunks_exact(8)
                .map(|c| f64::from_le_bytes([c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]]))
                .collect()
        };
        let o = 24 * n;
        let dd = b[o..o + 4 * n]
            .chunks_exact(4)
            .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        let o = o + 4 * n;
        Ok(Tile {
            h: f64s(0),
            lev: f64s(1),
            area: f64s(2),
            dd,
            flags: b[o..o + n].to_vec(),
            dir: b[o + n..o + 2 * n].to_vec(),
            done: b[o + 2 * n..o + 3 * n].to_vec(),
            ring: b[o + 3 * n..].to_vec(),
        })
    }
}

/// Tile storage of one rank: in memory, or one file per tile.
pub(super) enum Store {
    Mem(MemStates<Tile>),
    Disk(PathBuf, TileLayout),
}

impl Store {
    fn path(dir: &Path, id: TileId) -> PathBuf {
        dir.join(format!("sp-{id}.bin"))
    }
}

impl TileStates<Tile> for Store {
    fn load(&self, id: TileId) -> Result<Tile> {
        match self {
            Store::Mem(m) => m.load(id),
            Store::Disk(dir, lay) => {
                let p = Store::path(dir, id);
                let b = std::fs::read(&p).at(&p)?;
                let w = lay.window(id);
                Tile::decode(&b, w.w * w.h, perimeter_len(w.w + 2, w.h + 2), &p)
            }
        }
    }
    fn save(&self, id: TileId, t: Tile) -> Result<()> {
        match self {
            Store::Mem(m) => m.save(id, t),
            Store::Disk(dir, _) => {
                let p = Store::path(dir, id);
                std::fs::write(&p, t.encode()).at(&p)
            }
        }
    }
}

/// Exact `n / d` and `n % d` of a 32-bit `n` by multiplications instead of
/// a division, `M = ceil(2^64 / d)` (Lemire, Kaser & Kurz 2019, "Faster
/// remainder by direct computation: applications to compilers and software
/// libraries", *Software: Practice and Experience* 49(6), 953–970,
/// Theorem 1 with F = 2N = 64).
#[derive(Clone, Copy)]
pub(super) struct Divisor {
    d: u64,
    /// `M`, or 0 for `d = 1` (where `M` = 2^64 does not fit).
    m: u64,
}

impl Divisor {
    pub fn new(d: usize) -> Divisor {
        let d = d.max(1) as u64;
        let m = if d == 1 { 0 } else { u64::MAX / d + 1 };
        Divisor { d, m }
    }
    /// `(n / d, n % d)`; `n` below 2^32.
    #[inline]
    pub fn divmod(&self, n: usize) -> (usize, usize) {
        debug_assert!(n < 1 << 32);
        if self.m == 0 {
            return (n, 0);
        }
        let n = n as u64;
        let q = (self.m as u128 * n as u128) >> 64;
        let low = self.m.wrapping_mul(n);
        let r = (low as u128 * self.d as u128) >> 64;
        (q as usize, r as usize)
    }
}

/// A tile padded with a ring of one cell: index helpers.
#[derive(Clone, Copy)]
pub(super) struct Pad {
    /// Core window.
    pub x0: usize,
    pub y0: usize,
    pub w: usize,
    pub h: usize,
    /// Padded width (w + 2).
    pub pw: usize,
    /// Offsets of the 8 neighbours in the padded array.
    pub off: [isize; 8],
    /// Division by `w` (core index to column and row).
    by_w: Divisor,
}

impl Pad {
    pub fn new(win: Window) -> Pad {
        let pw = win.w + 2;
        let mut off = [0isize; 8];
        for d in 0..8 {
            off[d] = DY[d] * pw as isize + DX[d];
        }
        Pad {
            x0: win.x as usize,
            y0: win.y as usize,
            w: win.w,
            h: win.h,
            pw,
            off,
            by_w: Divisor::new(win.w),
        }
    }
    /// Column and row of core index `i`.
    #[inline]
    pub fn xy(&self, i: usize) -> (usize, usize) {
        let (y, x) = self.by_w.divmod(i);
        (x, y)
    }
    /// Core index of neighbour `d` of core cell (x, y), if it lies in the core.
    #[inline]
    pub fn core_nb(&self, x: usize, y: usize, d: usize) -> Option<usize> {
        let (nx, ny) = (x as isize + DX[d], y as isize + DY[d]);
        if nx >= 0 && ny >= 0 && (nx as usize) < self.w && (ny as usize) < self.h {
            Some(ny as usize * self.w + nx as usize)
        } else {
            None
        }
    }
    /// Padded index of core cell (x, y).
    #[inline]
    pub fn at(&self, x: usize, y: usize) -> usize {
        (y + 1) * self.pw + x + 1
    }
    #[inline]
    pub fn nb(&self, q: usize, d: usize) -> usize {
        (q as isize + self.off[d]) as usize
    }
    /// Ring index of padded cell (px, py), if it lies on the ring.
    #[inline]
    pub fn ring_index(&self, px: usize, py: usize) -> Option<usize> {
        perimeter_index(self.w + 2, self.h + 2, px, py)
    }
    /// Core index of padded cell (px, py) (signed), if it lies in the core.
    #[inline]
    pub fn core_xy(&self, px: isize, py: isize) -> Option<usize> {
        if px >= 1 && py >= 1 && px <= self.w as isize && py <= self.h as isize {
            Some((py as usize - 1) * self.w + px as usize - 1)
        } else {
            None
        }
    }
}

/// Where every tile's publication lies: the layout and perimeter lengths.
pub(super) struct Geo {
    pub lay: TileLayout,
    pl: Vec<usize>,
}

impl Geo {
    pub fn new(lay: TileLayout) -> Geo {
        let pl = (0..lay.count())
            .map(|id| {
                let w = lay.window(id);
                perimeter_len(w.w, w.h)
            })
            .collect();
        Geo { lay, pl }
    }

    /// Values tile `id` publishes.
    pub fn pub_len(&self, id: TileId) -> usize {
        NF * self.pl[id]
    }

    /// Perimeter length of tile `id`.
    pub fn perimeter(&self, id: TileId) -> usize {
        self.pl[id]
    }

    /// Published field `f` of the global cell (gx, gy), `outside` beyond the raster.
    #[inline]
    fn at(&self, board: &Board, gx: isize, gy: isize, f: usize, outside: f64) -> f64 {
        let (w, h) = (self.lay.width as isize, self.lay.height as isize);
        if gx < 0 || gy < 0 || gx >= w || gy >= h {
            return outside;
        }
        let (gx, gy) = (gx as usize, gy as usize);
        let ts = self.lay.tile;
        let id = self.lay.id(gx / ts, gy / ts);
        let win = self.lay.window(id);
        let (lx, ly) = (gx - win.x as usize, gy - win.y as usize);
        match perimeter_index(win.w, win.h, lx, ly) {
            Some(k) => board.get(id)[f * self.pl[id] + k],
            None => outside,
        }
    }

    /// Field `f` on the ring around the tile of `pd`, read from the
    /// neighbours' publications, in ring order ([`Pad::ring_index`]).
    pub fn ring(&self, board: &Board, pd: &Pad, f: usize, outside: f64) -> Vec<f64> {
        perimeter_cells(pd.w + 2, pd.h + 2)
            .map(|(px, py)| {
                let gx = pd.x0 as isize + px as isize - 1;
                let gy = pd.y0 as isize + py as isize - 1;
                self.at(board, gx, gy, f, outside)
            })
            .collect()
    }

    /// The tile's field `core` padded with the ring of field `f` read from
    /// the neighbours (`outside` beyond the raster), converted by `conv`.
    pub fn pad<T: Copy>(
        &self,
        board: &Board,
        pd: &Pad,
        core: &[T],
        f: usize,
        outside: f64,
        conv: impl Fn(f64) -> T,
    ) -> Vec<T> {
        let (pw, ph) = (pd.w + 2, pd.h + 2);
        let mut v = vec![conv(outside); pw * ph];
        for y in 0..pd.h {
            let q = pd.at(0, y);
            v[q..q + pd.w].copy_from_slice(&core[y * pd.w..(y + 1) * pd.w]);
        }
        for (px, py) in perimeter_cells(pw, ph) {
            let gx = pd.x0 as isize + px as isize - 1;
            let gy = pd.y0 as isize + py as isize - 1;
            v[py * pw + px] = conv(self.at(board, gx, gy, f, outside));
        }
        v
    }
}

/// Write `value(core index)` into field `f` of a tile's publication `out`
/// (`pl` perimeter cells of a `w` x `h` tile).
pub(super) fn publish(
    out: &mut [f64],
    w: usize,
    h: usize,
    pl: usize,
    f: usize,
    value: impl Fn(usize) -> f64,
) {
    for_perimeter(w, h, |i, k| out[f * pl + k] = value(i));
}

/// Calls `f(core index, perimeter index)` for every perimeter cell of a
/// `w` x `h` tile.
pub(super) fn for_perimeter(w: usize, h: usize, mut f: impl FnMut(usize, usize)) {
    for (k, (x, y)) in perimeter_cells(w, h).enumerate() {
        f(y * w + x, k);
    }
}

#[cfg(test)]
mod tests {
    use super::Divisor;

    #[test]
    fn divisor_equals_integer_division() {
        let ns = (0..5000usize).chain([65535, 65536, 1 << 31, (1 << 32) - 1]);
        let ns: Vec<usize> = ns.collect();
        for d in (1..300).chain([1023, 1024, 4097, 65535, 65536]) {
            let dv = Divisor::new(d);
            for &n in &ns {
                assert_eq!(dv.divmod(n), (n / d, n % d), "{n} / {d}");
            }
        }
    }
}
