//! Out-of-core stream-power erosion: the scheme of [`super::stream_power`]
//! (Braun & Willett 2013, implicit O(n)) run over tiles, equal to the
//! in-memory solver **bit for bit** for every tile size.
//!
//! The state (heights `h` in f64 and the per-step flow graph) lives in tiles,
//! in memory or in a scratch folder of one raw file per tile; the only
//! global state is each tile's *perimeter* (its ring of edge cells) for the
//! fields a neighbour needs: O(tiles' boundary). One tile is worked on at a
//! time. Every global quantity of a step is the fixed point of a local rule,
//! solved by repeated passes over the tiles that read the neighbours'
//! perimeters (label correcting at tile granularity, as in Barnes 2016/2017's
//! tiled priority flood and accumulation, but iterated instead of solved over
//! a perimeter graph); each value is exact, so the pass order does not matter:
//!
//! 1. **Uplift** (local).
//! 2. **Routing**. `None`: steepest descent on `h*` (local, halo 1).
//!    `Fill`: the minimax water level `L(i) = max(h(i), min_j L(j))`
//!    (`L = h` on base levels) by a priority flood inside each tile seeded
//!    from the neighbours' perimeter levels, repeated until no perimeter
//!    level drops (`max`/`min` only: exact); then the flat distances `D`
//!    (breadth first over equal-`L` cells from draining cells, Barnes, Lehman
//!    & Mulla 2014) the same way; receivers from `L` and `D` (local). The
//!    in-memory solver uses the same definition.
//! 3. **Drainage area**: cell counts summed down the receiver graph (Kahn's
//!    topological order inside a tile); a cell whose upstream reaches into
//!    another tile waits until that tile has published the count of the
//!    perimeter cell draining into it. Counts are integers below 2^53, so any
//!    order gives the same bits; area = count · cell².
//! 4. **Implicit update** in rounds: inside a tile, a cell is solved as soon
//!    as its receiver's new height is known — solved in this tile, or an
//!    exit published by a neighbour — with the same arithmetic as the
//!    untiled solver; the others wait for the next pass. The number of passes
//!    is bounded by the number of tile crossings along the flow paths.
//! 5. **Diffusion** (`K_d > 0`): each explicit substep reads the neighbours'
//!    perimeter heights of the previous substep (halo exchange of depth 1).
//!
//! Not supported: [`Depressions::BasinGraph`] (its minimum spanning tree of
//! basin passes is not written as a tiled pass): refused with an error.
//! Tiles are processed one after another (one thread); the result does not
//! depend on the order nor on the tile size.

// Tile and cell loops index several parallel arrays and `self` at once.
#![allow(clippy::needless_range_loop)]

use super::stream_power::{
    diffusion_substeps, is_base, newton, order_key, BaseHeight, Depressions, StreamPowerParams,
    BASE, DX, DY, VALID,
};
use crate::error::{Error, IoContext, Result};
use crate::raster::{perimeter_index, perimeter_len};
use crate::raster::{read_window, Grid, RasterSource, TileId, TileLayout, Window};
use std::cmp::Reverse;
use std::collections::BinaryHeap;
use std::path::{Path, PathBuf};

/// Uplift of the tiled solve: one rate, or a raster of rates (m/yr) of the DEM's size.
#[derive(Clone, Copy)]
pub enum TiledUplift<'a> {
    /// The same rate on every cell that is not a base level.
    Uniform(f64),
    /// A rate per cell, read tile by tile at every step.
    Map(&'a dyn RasterSource),
}

/// Where the tiled solve keeps its tiles.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SpBackend {
    /// All tiles in memory (about 31 bytes per cell).
    Memory,
    /// One raw file per tile in this folder (created; removed by the caller).
    Disk(PathBuf),
}

/// Counters of a tiled run (for reports and tests).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct SpTiledStats {
    /// Tile passes made by the level / flat / area / update rounds, summed over steps.
    pub passes: u64,
    /// Largest number of passes of one round (a bound on tile crossings).
    pub max_round: u64,
}

/// Bytes per cell of a tile's state (h, level, area: f64; flat distance: u32;
/// flags, receiver direction, done: u8).
pub const TILE_BYTES_PER_CELL: u64 = 31;

/// No receiver (root) in the direction array.
const NONE: u8 = 8;

/// Run `steps` steps of stream power on the raster `src` (cell size `cell`
/// metres, square; nodata = outside the domain), tiles of `tile` cells kept
/// in `backend`, and hand each finished tile to `write` in increasing tile
/// id order (core window, heights in f64, NaN = nodata).
#[allow(clippy::too_many_arguments)]
pub fn stream_power_tiled(
    src: &dyn RasterSource,
    cell: f64,
    p: &StreamPowerParams,
    uplift: &TiledUplift,
    steps: usize,
    tile: usize,
    backend: &SpBackend,
    mut write: impl FnMut(TileId, Window, &Grid<f64>) -> Result<()>,
) -> Result<SpTiledStats> {
    if steps == 0 {
        return Err(Error::invalid(
            "stream power: steps = 0; give at least one time step",
        ));
    }
    let mut s = Solver::new(src, cell, p, tile, backend)?;
    if let TiledUplift::Map(m) = uplift {
        let (mw, mh) = (m.info().width, m.info().height);
        if mw != s.lay.width || mh != s.lay.height {
            return Err(Error::invalid(format!(
                "stream power: the uplift map is {mw}x{mh} but the DEM is {}x{}",
                s.lay.width, s.lay.height
            )));
        }
    }
    for _ in 0..steps {
        s.step(uplift)?;
    }
    for id in 0..s.lay.count() {
        let t = s.store.take(id, &s.lay)?;
        let win = s.lay.window(id);
        let g = Grid::from_vec(win.w, win.h, t.h.clone())?;
        s.store.put(id, t)?;
        write(id, win, &g)?;
    }
    Ok(s.stats)
}

/// [`stream_power_tiled`] on an in-memory grid, returning the whole result
/// (for tests and small rasters; `tile` cells per tile, tiles in memory).
pub fn stream_power_tiled_grid(
    h: &Grid<f64>,
    cell: f64,
    p: &StreamPowerParams,
    uplift: Option<&Grid<f64>>,
    steps: usize,
    tile: usize,
    backend: &SpBackend,
) -> Result<(Grid<f64>, SpTiledStats)> {
    use crate::raster::{AnyGrid, GeoRef, MemRaster};
    let src = MemRaster::new(
        AnyGrid::F64(h.clone()),
        GeoRef::default(),
        PathBuf::from("<memory>"),
    );
    let up_src = uplift.map(|u| {
        MemRaster::new(
            AnyGrid::F64(u.clone()),
            GeoRef::default(),
            PathBuf::from("<uplift>"),
        )
    });
    let up = match &up_src {
        Some(m) => TiledUplift::Map(m),
        None => TiledUplift::Uniform(0.0),
    };
    let mut out = Grid::new(h.width(), h.height(), f64::NAN);
    let stats = stream_power_tiled(&src, cell, p, &up, steps, tile, backend, |_, win, g| {
        out.paste(g, win.x, win.y);
        Ok(())
    })?;
    Ok((out, stats))
}

/// One tile's state (core cells, row-major).
#[derive(Default)]
struct Tile {
    h: Vec<f64>,
    lev: Vec<f64>,
    area: Vec<f64>,
    dd: Vec<u32>,
    flags: Vec<u8>,
    dir: Vec<u8>,
    done: Vec<u8>,
}

impl Tile {
    fn encode(&self) -> Vec<u8> {
        let n = self.h.len();
        let mut b = Vec::with_capacity(n * TILE_BYTES_PER_CELL as usize);
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
        b
    }

    fn decode(b: &[u8], n: usize, path: &Path) -> Result<Tile> {
        if b.len() as u64 != n as u64 * TILE_BYTES_PER_CELL {
            return Err(Error::corrupt(
                path,
                format!(
                    "stream-power scratch tile has {} bytes, expected {}; was the scratch folder changed during the run?",
                    b.len(),
                    n as u64 * TILE_BYTES_PER_CELL
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
        })
    }
}

/// Tile storage: in memory, or one file per tile.
enum Store {
    Mem(Vec<Tile>),
    Disk(PathBuf),
}

impl Store {
    fn path(dir: &Path, id: TileId) -> PathBuf {
        dir.join(format!("sp-{id}.bin"))
    }
    fn take(&mut self, id: TileId, lay: &TileLayout) -> Result<Tile> {
        match self {
            Store::Mem(v) => Ok(std::mem::take(&mut v[id])),
            Store::Disk(dir) => {
                let p = Store::path(dir, id);
                let b = std::fs::read(&p).at(&p)?;
                let w = lay.window(id);
                Tile::decode(&b, w.w * w.h, &p)
            }
        }
    }
    fn put(&mut self, id: TileId, t: Tile) -> Result<()> {
        match self {
            Store::Mem(v) => {
                v[id] = t;
                Ok(())
            }
            Store::Disk(dir) => {
                let p = Store::path(dir, id);
                std::fs::write(&p, t.encode()).at(&p)
            }
        }
    }
}

/// The perimeter fields of one tile that its neighbours read.
struct Edge {
    h: Vec<f64>,
    lev: Vec<f64>,
    cnt: Vec<f64>,
    hn: Vec<f64>,
    dd: Vec<u32>,
    flags: Vec<u8>,
    dir: Vec<u8>,
    hn_ok: Vec<bool>,
}

struct Solver {
    lay: TileLayout,
    cell: f64,
    p: StreamPowerParams,
    store: Store,
    edges: Vec<Edge>,
    stats: SpTiledStats,
}

/// A tile padded with a ring of one cell: index helpers.
#[derive(Clone, Copy)]
struct Pad {
    /// Core window.
    x0: usize,
    y0: usize,
    w: usize,
    h: usize,
    /// Padded width (w + 2).
    pw: usize,
    /// Offsets of the 8 neighbours in the padded array.
    off: [isize; 8],
}

impl Pad {
    fn new(win: Window) -> Pad {
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
        }
    }
    /// Padded index of core cell (x, y).
    #[inline]
    fn at(&self, x: usize, y: usize) -> usize {
        (y + 1) * self.pw + x + 1
    }
    /// Core index of a padded index that lies in the core, else None.
    #[inline]
    fn core(&self, q: usize) -> Option<usize> {
        let (px, py) = (q % self.pw, q / self.pw);
        if px >= 1 && py >= 1 && px <= self.w && py <= self.h {
            Some((py - 1) * self.w + px - 1)
        } else {
            None
        }
    }
    #[inline]
    fn nb(&self, q: usize, d: usize) -> usize {
        (q as isize + self.off[d]) as usize
    }
}

fn step_len(cell: f64, d: usize) -> f64 {
    if d % 2 == 1 {
        cell * std::f64::consts::SQRT_2
    } else {
        cell
    }
}

impl Solver {
    fn new(
        src: &dyn RasterSource,
        cell: f64,
        p: &StreamPowerParams,
        tile: usize,
        backend: &SpBackend,
    ) -> Result<Solver> {
        p.validate()?;
        if p.depressions == Depressions::BasinGraph {
            return Err(Error::invalid(
                "stream power: the basin-graph depression routing runs in memory only; \
                 use --depressions fill (or none) for a DEM larger than --memory, or raise --memory",
            ));
        }
        if !(cell.is_finite() && cell > 0.0) {
            return Err(Error::invalid(format!(
                "stream power: cell size {cell} m is invalid; it must be finite and > 0"
            )));
        }
        let info = src.info();
        let (w, ht) = (info.width, info.height);
        if w == 0 || ht == 0 {
            return Err(Error::invalid("stream power: the DEM has no cells"));
        }
        if tile == 0 {
            return Err(Error::invalid("stream power: tile size 0; give at least 1"));
        }
        let lay = TileLayout::new(w, ht, tile);
        let mut store = match backend {
            SpBackend::Memory => Store::Mem((0..lay.count()).map(|_| Tile::default()).collect()),
            SpBackend::Disk(d) => {
                std::fs::create_dir_all(d).at(d)?;
                Store::Disk(d.clone())
            }
        };
        let b = p.boundary;
        let mut nbase = 0u64;
        let mut edges = Vec::with_capacity(lay.count());
        for id in 0..lay.count() {
            let win = lay.window(id);
            let padded =
                read_window::<f64>(src, Window::new(win.x - 1, win.y - 1, win.w + 2, win.h + 2))?;
            let pd = Pad::new(win);
            let pv = padded.data();
            let n = win.w * win.h;
            let mut t = Tile {
                h: vec![0.0; n],
                lev: vec![0.0; n],
                area: vec![0.0; n],
                dd: vec![0; n],
                flags: vec![0; n],
                dir: vec![NONE; n],
                done: vec![0; n],
            };
            for y in 0..win.h {
                for x in 0..win.w {
                    let (gx, gy) = (pd.x0 + x, pd.y0 + y);
                    let i = y * win.w + x;
                    let q = pd.at(x, y);
                    t.h[i] = pv[q];
                    if !pv[q].is_finite() {
                        continue;
                    }
                    let mut f = VALID;
                    if is_base(&b, gx, gy, w, ht, |d, _, _| !pv[pd.nb(q, d)].is_finite()) {
                        f |= BASE;
                        nbase += 1;
                        if p.base_height == BaseHeight::Zero {
                            t.h[i] = 0.0;
                        }
                    }
                    t.flags[i] = f;
                }
            }
            let pl = perimeter_len(win.w, win.h);
            let mut e = Edge {
                h: vec![f64::NAN; pl],
                lev: vec![f64::NAN; pl],
                cnt: vec![f64::NAN; pl],
                hn: vec![f64::NAN; pl],
                dd: vec![u32::MAX; pl],
                flags: vec![0; pl],
                dir: vec![NONE; pl],
                hn_ok: vec![false; pl],
            };
            for_perimeter(win.w, win.h, |i, k| {
                e.h[k] = t.h[i];
                e.flags[k] = t.flags[i];
            });
            edges.push(e);
            store.put(id, t)?;
        }
        if nbase == 0 {
            return Err(Error::invalid(
                "stream power: no base level (no border selected and no nodata cell); \
                 select at least one border (e.g. all)",
            ));
        }
        Ok(Solver {
            lay,
            cell,
            p: p.clone(),
            store,
            edges,
            stats: SpTiledStats::default(),
        })
    }

    /// Tile id and perimeter index of the global cell (gx, gy) (inside the raster).
    #[inline]
    fn locate(&self, gx: usize, gy: usize) -> (TileId, usize) {
        let ts = self.lay.tile;
        let id = self.lay.id(gx / ts, gy / ts);
        let win = self.lay.window(id);
        let (lx, ly) = (gx - win.x as usize, gy - win.y as usize);
        let k = perimeter_index(win.w, win.h, lx, ly).unwrap_or(usize::MAX);
        (id, k)
    }

    /// The tile's field padded with a ring read from the neighbours'
    /// perimeters (`outside` beyond the raster).
    fn pad<T: Copy>(
        &self,
        pd: &Pad,
        core: &[T],
        field: impl Fn(&Edge, usize) -> T,
        outside: T,
    ) -> Vec<T> {
        let (pw, ph) = (pd.w + 2, pd.h + 2);
        let mut v = vec![outside; pw * ph];
        for y in 0..pd.h {
            let q = pd.at(0, y);
            v[q..q + pd.w].copy_from_slice(&core[y * pd.w..(y + 1) * pd.w]);
        }
        let (w, h) = (self.lay.width as isize, self.lay.height as isize);
        for py in 0..ph {
            for px in 0..pw {
                if px != 0 && py != 0 && px != pw - 1 && py != ph - 1 {
                    continue;
                }
                let gx = pd.x0 as isize + px as isize - 1;
                let gy = pd.y0 as isize + py as isize - 1;
                if gx < 0 || gy < 0 || gx >= w || gy >= h {
                    continue;
                }
                let (id, k) = self.locate(gx as usize, gy as usize);
                v[py * pw + px] = field(&self.edges[id], k);
            }
        }
        v
    }

    /// Ids of the (up to 8) tiles around `id`.
    fn neighbours(&self, id: TileId) -> Vec<TileId> {
        let (tx, ty) = self.lay.coords(id);
        let (nx, ny) = (self.lay.tiles_x() as isize, self.lay.tiles_y() as isize);
        let mut v = Vec::with_capacity(8);
        for d in 0..8 {
            let (x, y) = (tx as isize + DX[d], ty as isize + DY[d]);
            if x >= 0 && y >= 0 && x < nx && y < ny {
                v.push(self.lay.id(x as usize, y as usize));
            }
        }
        v
    }

    fn step(&mut self, uplift: &TiledUplift) -> Result<()> {
        self.uplift(uplift)?;
        let fill = self.p.depressions == Depressions::Fill;
        if fill {
            self.levels()?;
            self.flat_distances()?;
        }
        self.receivers(fill)?;
        self.accumulate()?;
        self.erode(fill)?;
        if self.p.kd > 0.0 {
            self.diffuse()?;
        }
        Ok(())
    }

    fn uplift(&mut self, u: &TiledUplift) -> Result<()> {
        let dt = self.p.dt;
        if let TiledUplift::Uniform(r) = u {
            if !r.is_finite() {
                return Err(Error::invalid(format!(
                    "stream power: uplift rate {r} is not finite"
                )));
            }
        }
        for id in 0..self.lay.count() {
            let win = self.lay.window(id);
            let mut t = self.store.take(id, &self.lay)?;
            match u {
                TiledUplift::Uniform(r) => {
                    let du = r * dt;
                    for (v, f) in t.h.iter_mut().zip(&t.flags) {
                        if *f == VALID {
                            *v += du;
                        }
                    }
                }
                TiledUplift::Map(m) => {
                    let g = read_window::<f64>(*m, win)?;
                    for (i, (v, f)) in t.h.iter_mut().zip(&t.flags).enumerate() {
                        if *f == VALID {
                            let r = g.data()[i];
                            if !r.is_finite() {
                                return Err(Error::invalid(format!(
                                    "stream power: the uplift map has no value at column {}, row {} \
                                     where the DEM has one; give a rate for every valid cell",
                                    win.x as usize + i % win.w,
                                    win.y as usize + i / win.w
                                )));
                            }
                            *v += r * dt;
                        }
                    }
                }
            }
            let e = &mut self.edges[id];
            for_perimeter(win.w, win.h, |i, k| e.h[k] = t.h[i]);
            self.store.put(id, t)?;
        }
        Ok(())
    }

    /// Repeat `pass(id)` over dirty tiles until none is dirty; `pass` returns
    /// whether the tile's perimeter changed (its neighbours become dirty).
    fn rounds(&mut self, mut pass: impl FnMut(&mut Solver, TileId) -> Result<bool>) -> Result<()> {
        let nt = self.lay.count();
        let mut dirty = vec![true; nt];
        let mut left = nt;
        let mut npass = 0u64;
        while left > 0 {
            npass += 1;
            for id in 0..nt {
                if !dirty[id] {
                    continue;
                }
                dirty[id] = false;
                left -= 1;
                self.stats.passes += 1;
                if pass(self, id)? {
                    for j in self.neighbours(id) {
                        if !dirty[j] {
                            dirty[j] = true;
                            left += 1;
                        }
                    }
                }
            }
        }
        self.stats.max_round = self.stats.max_round.max(npass);
        Ok(())
    }

    /// Sweep the incomplete tiles in id order, round after round, until all
    /// are complete. `pass(id)` reports whether it published anything new on
    /// the tile's perimeter and whether the tile is now complete; a round in
    /// which no tile did either means the receiver graph has a cycle.
    fn sweeps(&mut self, mut pass: impl FnMut(&mut Solver, TileId) -> Result<Swept>) -> Result<()> {
        let nt = self.lay.count();
        let mut complete = vec![false; nt];
        let mut npass = 0u64;
        loop {
            npass += 1;
            let mut progress = false;
            let mut all = true;
            for id in 0..nt {
                if complete[id] {
                    continue;
                }
                self.stats.passes += 1;
                let swept = pass(self, id)?;
                progress |= swept.progress;
                if swept.complete {
                    complete[id] = true;
                    progress = true;
                } else {
                    all = false;
                }
            }
            if all {
                break;
            }
            if !progress {
                return Err(Error::invalid(
                    "stream power (tiled): the receiver graph has a cycle; this is a bug, please report it",
                ));
            }
        }
        self.stats.max_round = self.stats.max_round.max(npass);
        Ok(())
    }

    /// Minimax water levels (see the module doc).
    fn levels(&mut self) -> Result<()> {
        for id in 0..self.lay.count() {
            let win = self.lay.window(id);
            let mut t = self.store.take(id, &self.lay)?;
            for i in 0..t.h.len() {
                t.lev[i] = if t.flags[i] & BASE != 0 {
                    t.h[i]
                } else if t.flags[i] & VALID != 0 {
                    f64::INFINITY
                } else {
                    f64::NAN
                };
            }
            let e = &mut self.edges[id];
            for_perimeter(win.w, win.h, |i, k| e.lev[k] = t.lev[i]);
            self.store.put(id, t)?;
        }
        let mut heap: BinaryHeap<Reverse<(u64, u32)>> = BinaryHeap::new();
        self.rounds(|s, id| {
            let win = s.lay.window(id);
            let pd = Pad::new(win);
            let mut t = s.store.take(id, &s.lay)?;
            let lev = s.pad(&pd, &t.lev, |e, k| e.lev[k], f64::NAN);
            let fl = s.pad(&pd, &t.flags, |e, k| e.flags[k], 0);
            let mut l = t.lev.clone();
            heap.clear();
            for y in 0..pd.h {
                for x in 0..pd.w {
                    let i = y * pd.w + x;
                    if t.flags[i] != VALID {
                        if t.flags[i] & BASE != 0 {
                            heap.push(Reverse((order_key(l[i]), i as u32)));
                        }
                        continue;
                    }
                    let q = pd.at(x, y);
                    for d in 0..8 {
                        let j = pd.nb(q, d);
                        if pd.core(j).is_some() || fl[j] & VALID == 0 || !lev[j].is_finite() {
                            continue;
                        }
                        let c = t.h[i].max(lev[j]);
                        if c < l[i] {
                            l[i] = c;
                        }
                    }
                    if l[i].is_finite() {
                        heap.push(Reverse((order_key(l[i]), i as u32)));
                    }
                }
            }
            while let Some(Reverse((key, c))) = heap.pop() {
                let c = c as usize;
                if order_key(l[c]) != key {
                    continue;
                }
                let q = pd.at(c % pd.w, c / pd.w);
                for d in 0..8 {
                    let Some(j) = pd.core(pd.nb(q, d)) else {
                        continue;
                    };
                    if t.flags[j] != VALID {
                        continue;
                    }
                    let cand = t.h[j].max(l[c]);
                    if cand < l[j] {
                        l[j] = cand;
                        heap.push(Reverse((order_key(cand), j as u32)));
                    }
                }
            }
            t.lev = l;
            let mut changed = false;
            let e = &mut s.edges[id];
            for_perimeter(win.w, win.h, |i, k| {
                if e.lev[k].to_bits() != t.lev[i].to_bits() {
                    e.lev[k] = t.lev[i];
                    changed = true;
                }
            });
            s.store.put(id, t)?;
            Ok(changed)
        })
    }

    /// Breadth-first distances on the flats of the water surface.
    fn flat_distances(&mut self) -> Result<()> {
        for id in 0..self.lay.count() {
            let win = self.lay.window(id);
            let pd = Pad::new(win);
            let mut t = self.store.take(id, &self.lay)?;
            let lev = self.pad(&pd, &t.lev, |e, k| e.lev[k], f64::NAN);
            let fl = self.pad(&pd, &t.flags, |e, k| e.flags[k], 0);
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
            let e = &mut self.edges[id];
            for_perimeter(win.w, win.h, |i, k| e.dd[k] = t.dd[i]);
            self.store.put(id, t)?;
        }
        let mut heap: BinaryHeap<Reverse<(u32, u32)>> = BinaryHeap::new();
        self.rounds(|s, id| {
            let win = s.lay.window(id);
            let pd = Pad::new(win);
            let mut t = s.store.take(id, &s.lay)?;
            let lev = s.pad(&pd, &t.lev, |e, k| e.lev[k], f64::NAN);
            let fl = s.pad(&pd, &t.flags, |e, k| e.flags[k], 0);
            let ddp = s.pad(&pd, &t.dd, |e, k| e.dd[k], u32::MAX);
            heap.clear();
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
                            if pd.core(j).is_some()
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
                    if t.dd[i] != u32::MAX {
                        heap.push(Reverse((t.dd[i], i as u32)));
                    }
                }
            }
            while let Some(Reverse((dc, c))) = heap.pop() {
                let c = c as usize;
                if t.dd[c] != dc {
                    continue;
                }
                let q = pd.at(c % pd.w, c / pd.w);
                for d in 0..8 {
                    let Some(j) = pd.core(pd.nb(q, d)) else {
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
            let mut changed = false;
            let e = &mut s.edges[id];
            for_perimeter(win.w, win.h, |i, k| {
                if e.dd[k] != t.dd[i] {
                    e.dd[k] = t.dd[i];
                    changed = true;
                }
            });
            s.store.put(id, t)?;
            Ok(changed)
        })
    }

    /// Receivers: steepest descent on `L` (fill) or `h*` (none); flats by `D`.
    fn receivers(&mut self, fill: bool) -> Result<()> {
        let cell = self.cell;
        for id in 0..self.lay.count() {
            let win = self.lay.window(id);
            let pd = Pad::new(win);
            let mut t = self.store.take(id, &self.lay)?;
            let z = if fill {
                self.pad(&pd, &t.lev, |e, k| e.lev[k], f64::NAN)
            } else {
                self.pad(&pd, &t.h, |e, k| e.h[k], f64::NAN)
            };
            let fl = self.pad(&pd, &t.flags, |e, k| e.flags[k], 0);
            let ddp = if fill {
                self.pad(&pd, &t.dd, |e, k| e.dd[k], u32::MAX)
            } else {
                Vec::new()
            };
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
                        let len = step_len(cell, d);
                        let s = (zi - z[j]) / len;
                        if s > best {
                            best = s;
                            bd = d as u8;
                        }
                    }
                    if bd == NONE && fill {
                        let mut bdd = ddp[q];
                        for d in 0..8 {
                            let j = pd.nb(q, d);
                            if fl[j] & VALID != 0 && z[j] == zi && ddp[j] < bdd {
                                bdd = ddp[j];
                                bd = d as u8;
                            }
                        }
                    }
                    t.dir[i] = bd;
                }
            }
            let e = &mut self.edges[id];
            for_perimeter(win.w, win.h, |i, k| e.dir[k] = t.dir[i]);
            self.store.put(id, t)?;
        }
        Ok(())
    }

    /// Drainage area by counts (see the module doc).
    fn accumulate(&mut self) -> Result<()> {
        for e in self.edges.iter_mut() {
            e.cnt.iter_mut().for_each(|v| *v = f64::NAN);
        }
        let ca = self.cell * self.cell;
        let mut pend: Vec<u32> = Vec::new();
        let mut stack: Vec<u32> = Vec::new();
        self.sweeps(|s, id| {
            let mut progress = false;
            let win = s.lay.window(id);
            let pd = Pad::new(win);
            let mut t = s.store.take(id, &s.lay)?;
            let dirp = s.pad(&pd, &t.dir, |e, k| e.dir[k], NONE);
            let cntp = s.pad(&pd, &vec![0.0; t.h.len()], |e, k| e.cnt[k], f64::NAN);
            let n = t.h.len();
            pend.clear();
            pend.resize(n, 0);
            for i in 0..n {
                t.area[i] = if t.flags[i] & VALID != 0 { 1.0 } else { 0.0 };
            }
            for y in 0..pd.h {
                for x in 0..pd.w {
                    let i = y * pd.w + x;
                    let q = pd.at(x, y);
                    if t.dir[i] != NONE {
                        if let Some(r) = pd.core(pd.nb(q, t.dir[i] as usize)) {
                            pend[r] += 1;
                        }
                    }
                    // Donors in the ring (other tiles) pointing at this cell.
                    if x == 0 || y == 0 || x + 1 == pd.w || y + 1 == pd.h {
                        for d in 0..8 {
                            let j = pd.nb(q, d);
                            if pd.core(j).is_some() || dirp[j] == NONE {
                                continue;
                            }
                            if pd.nb(j, dirp[j] as usize) != q {
                                continue;
                            }
                            if cntp[j].is_nan() {
                                pend[i] += 1;
                            } else {
                                t.area[i] += cntp[j];
                            }
                        }
                    }
                }
            }
            stack.clear();
            for i in 0..n {
                if pend[i] == 0 {
                    stack.push(i as u32);
                }
            }
            let mut nfinal = 0usize;
            for v in t.done.iter_mut() {
                *v = 0;
            }
            while let Some(c) = stack.pop() {
                let c = c as usize;
                t.done[c] = 1;
                nfinal += 1;
                if t.dir[c] == NONE {
                    continue;
                }
                let q = pd.at(c % pd.w, c / pd.w);
                if let Some(r) = pd.core(pd.nb(q, t.dir[c] as usize)) {
                    t.area[r] += t.area[c];
                    pend[r] -= 1;
                    if pend[r] == 0 {
                        stack.push(r as u32);
                    }
                }
            }
            let e = &mut s.edges[id];
            for_perimeter(win.w, win.h, |i, k| {
                if t.done[i] == 1 && e.cnt[k].is_nan() {
                    e.cnt[k] = t.area[i];
                    progress = true;
                }
            });
            let complete = nfinal == n;
            if complete {
                for a in t.area.iter_mut() {
                    *a *= ca;
                }
            }
            s.store.put(id, t)?;
            Ok(Swept { progress, complete })
        })
    }

    /// Implicit update in rounds (see the module doc).
    fn erode(&mut self, fill: bool) -> Result<()> {
        let (k, m, n, dt) = (self.p.k, self.p.m, self.p.n, self.p.dt);
        let cell = self.cell;
        let linear = n == 1.0;
        for e in self.edges.iter_mut() {
            e.hn_ok.iter_mut().for_each(|v| *v = false);
        }
        let mut work: Vec<u32> = Vec::new();
        // Solve cell i given its receiver's new height.
        let solve = |t: &mut Tile, i: usize, hr: f64| {
            let hs = t.h[i];
            if k == 0.0 || hs <= hr || (fill && t.lev[i] > hs) {
                return;
            }
            let d = step_len(cell, t.dir[i] as usize);
            let c = k * dt * t.area[i].powf(m);
            if linear {
                let fac = c / d;
                t.h[i] = (hs + fac * hr) / (1.0 + fac);
            } else {
                t.h[i] = newton(hs, hr, d, c, n);
            }
        };
        for t_id in 0..self.lay.count() {
            let mut t = self.store.take(t_id, &self.lay)?;
            t.done.iter_mut().for_each(|v| *v = 0);
            self.store.put(t_id, t)?;
        }
        self.sweeps(|s, id| {
            let mut progress = false;
            let win = s.lay.window(id);
            let pd = Pad::new(win);
            let mut t = s.store.take(id, &s.lay)?;
            let nc = t.h.len();
            let hnp = s.pad(
                &pd,
                &vec![f64::NAN; nc],
                |e, k| {
                    if e.hn_ok[k] {
                        e.hn[k]
                    } else {
                        f64::NAN
                    }
                },
                f64::NAN,
            );
            let okp = s.pad(&pd, &vec![false; nc], |e, k| e.hn_ok[k], false);
            work.clear();
            for i in 0..nc {
                if t.done[i] != 0 {
                    continue;
                }
                if t.dir[i] == NONE || t.flags[i] != VALID {
                    t.done[i] = 1;
                    work.push(i as u32);
                    continue;
                }
                let q = pd.at(i % pd.w, i / pd.w);
                let rq = pd.nb(q, t.dir[i] as usize);
                match pd.core(rq) {
                    Some(r) => {
                        if t.done[r] != 0 {
                            let hr = t.h[r];
                            solve(&mut t, i, hr);
                            t.done[i] = 1;
                            work.push(i as u32);
                        }
                    }
                    None => {
                        if okp[rq] {
                            solve(&mut t, i, hnp[rq]);
                            t.done[i] = 1;
                            work.push(i as u32);
                        }
                    }
                }
            }
            while let Some(c) = work.pop() {
                let c = c as usize;
                let q = pd.at(c % pd.w, c / pd.w);
                for d in 0..8 {
                    let Some(j) = pd.core(pd.nb(q, d)) else {
                        continue;
                    };
                    if t.done[j] != 0 || t.dir[j] == NONE {
                        continue;
                    }
                    let qj = pd.nb(q, d);
                    if pd.nb(qj, t.dir[j] as usize) != q {
                        continue;
                    }
                    let hr = t.h[c];
                    solve(&mut t, j, hr);
                    t.done[j] = 1;
                    work.push(j as u32);
                }
            }
            let ndone = t.done.iter().filter(|&&v| v != 0).count();
            let e = &mut s.edges[id];
            for_perimeter(win.w, win.h, |i, k| {
                if t.done[i] != 0 && !e.hn_ok[k] {
                    e.hn[k] = t.h[i];
                    e.hn_ok[k] = true;
                    progress = true;
                }
            });
            let complete = ndone == nc;
            if complete {
                for_perimeter(win.w, win.h, |i, k| e.h[k] = t.h[i]);
            }
            s.store.put(id, t)?;
            Ok(Swept { progress, complete })
        })
    }

    /// Explicit diffusion substeps with a halo exchange of depth 1 each.
    fn diffuse(&mut self) -> Result<()> {
        let (nsub, c) = diffusion_substeps(&self.p, self.cell)?;
        let nt = self.lay.count();
        let mut next: Vec<Vec<f64>> = self.edges.iter().map(|e| e.h.clone()).collect();
        for _ in 0..nsub {
            for id in 0..nt {
                let win = self.lay.window(id);
                let pd = Pad::new(win);
                let mut t = self.store.take(id, &self.lay)?;
                let old = self.pad(&pd, &t.h, |e, k| e.h[k], f64::NAN);
                let fl = self.pad(&pd, &t.flags, |e, k| e.flags[k], 0);
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
                let nx = &mut next[id];
                for_perimeter(win.w, win.h, |i, k| nx[k] = t.h[i]);
                self.store.put(id, t)?;
            }
            for (e, nx) in self.edges.iter_mut().zip(&next) {
                e.h.copy_from_slice(nx);
            }
        }
        Ok(())
    }
}

/// What one pass of [`Solver::sweeps`] did to its tile.
struct Swept {
    /// Something new was published on the tile's perimeter.
    progress: bool,
    /// Every cell of the tile is final.
    complete: bool,
}

/// Calls `f(core index, perimeter index)` for every perimeter cell of a
/// `w` x `h` tile.
fn for_perimeter(w: usize, h: usize, mut f: impl FnMut(usize, usize)) {
    for y in 0..h {
        let edge_row = y == 0 || y + 1 == h;
        for x in 0..w {
            if edge_row || x == 0 || x + 1 == w {
                if let Some(k) = perimeter_index(w, h, x, y) {
                    f(y * w + x, k);
                }
            }
        }
    }
}
