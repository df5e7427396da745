//! Rounds over tiles to a fixed point, in parallel and across ranks.
//!
//! A global quantity that is the fixed point of a local rule (water levels,
//! breadth-first distances, counts summed down a graph, a front of solved
//! cells…) is solved by *rounds*: in each round every tile that has
//! something new to read runs one *pass* of the step's per-tile work
//! ([`TileWork`]) on its own state, reading only what its neighbours
//! *published in the previous round* on the [`Board`] (a few values per
//! perimeter cell), and writes its own new publication. This is a Jacobi
//! iteration over tiles: no pass sees another pass of the same round, so the
//! result cannot depend on the order of the passes nor on the number of
//! threads. The passes of a round run in parallel (rayon).
//!
//! After a round the driver compares each publication with the previous one
//! (bit for bit) and exchanges the changed ones: in one process it replaces
//! them on the board; over several ranks ([`HaloTransport::all_gather`], the
//! MPI engine's `MpiHalo`) every rank sends the publications of its changed
//! tiles to every other, so each rank's board is the same. A tile runs again
//! only when one of its (up to 8) neighbours changed and it is not final
//! (dirty tracking); the fixed point is reached when no publication changed
//! anywhere. Skipping a tile whose inputs did not change is exact when each
//! pass takes its tile to the fixed point of its inputs (a pass run twice on
//! the same inputs changes nothing), which [`TileWork::pass`] requires.
//! This is label correcting at tile granularity (Barnes 2016, "Parallel
//! priority-flood depression filling for trillion cell digital elevation
//! models on desktops or clusters", Computers & Geosciences 96), iterated
//! instead of solved over a perimeter graph, with the bulk-synchronous
//! rounds of Valiant (1990, "A bridging model for parallel computation",
//! CACM 33(8)).
//!
//! Tiles are owned by ranks in contiguous ranges of tile ids
//! ([`super::mpi_halo::partition`]); each rank keeps only its tiles' states
//! ([`TileStates`]: in memory with [`MemStates`], or wherever the step
//! keeps them), and the board (O(tiles' perimeters)) everywhere.
//!
//! The same driver runs *ghost-zone rounds* ([`Rounds::ghost_rounds`],
//! `iterate/ghost.rs`): a fixed number of rounds in which every tile reads
//! the previous round's states of the tiles within a ghost zone of its
//! core, exchanged point to point between ranks instead of on the board
//! (the tiled local erosion models).

mod ghost;

pub use ghost::{CoreStates, GhostPatch, GhostRun};

use super::mpi_halo::{partition, HaloTransport};
use crate::error::{Error, Result};
use crate::raster::{TileId, TileLayout};
use rayon::prelude::*;
use std::sync::Mutex;

/// Published values of every tile (what its neighbours may read), the
/// same on every rank after each exchange.
pub struct Board {
    pubs: Vec<Vec<f64>>,
}

impl Board {
    /// Tile `id`'s publication.
    #[inline]
    pub fn get(&self, id: TileId) -> &[f64] {
        &self.pubs[id]
    }
}

/// The per-tile work of one fixed point (or of one round, [`Rounds::once`]).
pub trait TileWork: Sync {
    /// What a tile keeps between passes.
    type State: Send;
    /// One pass on tile `id`: read `board` (the publications of the previous
    /// round; this tile's own is there too), update `state`, and write the
    /// tile's new publication into `out` (holding its previous one). `round`
    /// is 0 on the first pass of a fixed point, where every tile runs.
    /// Run again on the same board, a pass must change nothing. Returns true
    /// when the tile is final (no later input can change it).
    fn pass(
        &self,
        id: TileId,
        round: u64,
        state: &mut Self::State,
        board: &Board,
        out: &mut [f64],
    ) -> Result<bool>;
}

/// Where tile states live between passes; `load` and `save` are called from
/// worker threads, each tile by one thread at a time.
pub trait TileStates<S>: Sync {
    /// Tile `id`'s state (moved out).
    fn load(&self, id: TileId) -> Result<S>;
    /// Put tile `id`'s state back.
    fn save(&self, id: TileId, s: S) -> Result<()>;
}

/// States in memory, one slot per tile (empty for other ranks' tiles).
pub struct MemStates<S> {
    slots: Vec<Mutex<S>>,
}

impl<S: Default> MemStates<S> {
    /// `count` empty slots.
    pub fn new(count: usize) -> Self {
        MemStates {
            slots: (0..count).map(|_| Mutex::new(S::default())).collect(),
        }
    }
}

impl<S: Default + Send> TileStates<S> for MemStates<S> {
    fn load(&self, id: TileId) -> Result<S> {
        let mut g = self.slots[id]
            .lock()
            .map_err(|_| Error::invalid("tile rounds: a worker thread panicked"))?;
        Ok(std::mem::take(&mut *g))
    }
    fn save(&self, id: TileId, s: S) -> Result<()> {
        let mut g = self.slots[id]
            .lock()
            .map_err(|_| Error::invalid("tile rounds: a worker thread panicked"))?;
        *g = s;
        Ok(())
    }
}

/// Counters of a driver (summed over its fixed points).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RoundStats {
    /// Passes run by this rank.
    pub passes: u64,
    /// Rounds (exchanges), the same on every rank.
    pub rounds: u64,
    /// Most rounds of one fixed point.
    pub max_rounds: u64,
}

/// The round driver of one rank: the layout, who owns which tile, the
/// board, the worker threads and the transport to the other ranks.
pub struct Rounds<'x, X: HaloTransport> {
    layout: TileLayout,
    owner: Vec<usize>,
    me: usize,
    mine: Vec<TileId>,
    board: Board,
    /// The 8-neighbour tiles of every tile.
    around: Vec<Vec<TileId>>,
    pool: rayon::ThreadPool,
    x: &'x mut X,
    stats: RoundStats,
}

/// Tile ids around `id` (up to 8), increasing.
fn around(layout: &TileLayout, id: TileId) -> Vec<TileId> {
    let (tx, ty) = layout.coords(id);
    let (nx, ny) = (layout.tiles_x(), layout.tiles_y());
    let mut v = Vec::with_capacity(8);
    for y in ty.saturating_sub(1)..(ty + 2).min(ny) {
        for x in tx.saturating_sub(1)..(tx + 2).min(nx) {
            if (x, y) != (tx, ty) {
                v.push(layout.id(x, y));
            }
        }
    }
    v
}

impl<'x, X: HaloTransport> Rounds<'x, X> {
    /// A driver over `layout` on `threads` worker threads (0 = all cores),
    /// tile `id` publishing `len(id)` values (NaN until first published).
    pub fn new(
        layout: TileLayout,
        threads: usize,
        x: &'x mut X,
        len: impl Fn(TileId) -> usize,
    ) -> Result<Self> {
        let (me, ranks) = x.rank();
        let owner = partition(&layout, ranks);
        let mine = (0..layout.count()).filter(|&t| owner[t] == me).collect();
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .map_err(|e| {
                Error::invalid(format!("tile rounds: cannot start worker threads: {e}"))
            })?;
        let board = Board {
            pubs: (0..layout.count())
                .map(|t| vec![f64::NAN; len(t)])
                .collect(),
        };
        let around = (0..layout.count()).map(|t| around(&layout, t)).collect();
        Ok(Rounds {
            layout,
            owner,
            me,
            mine,
            board,
            around,
            pool,
            x,
            stats: RoundStats::default(),
        })
    }

    /// The layout.
    pub fn layout(&self) -> &TileLayout {
        &self.layout
    }
    /// Tiles of this rank, increasing.
    pub fn mine(&self) -> &[TileId] {
        &self.mine
    }
    /// Owner rank of every tile.
    pub fn owner(&self) -> &[usize] {
        &self.owner
    }
    /// The board as of the last exchange.
    pub fn board(&self) -> &Board {
        &self.board
    }
    /// Counters so far.
    pub fn stats(&self) -> RoundStats {
        self.stats
    }
    /// The transport (for the final gather of the tiles).
    pub fn transport(&mut self) -> &mut X {
        self.x
    }
    /// An error on this rank as the run's end (see [`HaloTransport::fail`]).
    pub fn fail(&self, e: Error) -> Error {
        self.x.fail(e)
    }

    /// `f(id)` for every tile of this rank, in parallel; the results in
    /// tile order, or the error of the first failing tile.
    pub fn map_mine<T: Send>(&self, f: impl Fn(TileId) -> Result<T> + Sync) -> Result<Vec<T>> {
        let mine = &self.mine;
        let res: Vec<Result<T>> = self
            .pool
            .install(|| mine.par_iter().map(|&id| f(id)).collect());
        res.into_iter().collect::<Result<Vec<T>>>()
    }

    /// Set the publications of this rank's tiles (`(id, values)`) and
    /// exchange them, so every rank's board starts the same.
    pub fn publish(&mut self, pubs: Vec<(TileId, Vec<f64>)>) -> Result<()> {
        for (id, v) in &pubs {
            if self.owner[*id] != self.me || v.len() != self.board.pubs[*id].len() {
                return Err(self.fail(Error::invalid(format!(
                    "tile rounds: rank {} published {} values for tile {id}",
                    self.me,
                    v.len()
                ))));
            }
        }
        self.exchange(pubs, 0).map(|_| ())
    }

    /// One round on every tile of this rank (a local step, or one substep
    /// of an explicit scheme): each reads the board of the previous round.
    pub fn once<W: TileWork>(
        &mut self,
        work: &W,
        states: &impl TileStates<W::State>,
    ) -> Result<()> {
        let mine = self.mine.clone();
        let (changed, _) = self.round(work, states, &mine, 0, None)?;
        drop(changed);
        self.stats.rounds += 1;
        self.stats.max_rounds = self.stats.max_rounds.max(1);
        Ok(())
    }

    /// [`once`](Self::once), and whether every tile of every rank returned
    /// final from its pass (a global "all" of a per-tile test, e.g. "this
    /// tile has no pit", at the cost of the round's exchange).
    pub fn once_all_final<W: TileWork>(
        &mut self,
        work: &W,
        states: &impl TileStates<W::State>,
    ) -> Result<bool> {
        let mine = self.mine.clone();
        let mut done = vec![false; self.layout.count()];
        let (_, open) = self.round(work, states, &mine, 0, Some(&mut done))?;
        self.stats.rounds += 1;
        self.stats.max_rounds = self.stats.max_rounds.max(1);
        Ok(open == 0)
    }

    /// Rounds until no publication changes. With `final_required`, every
    /// tile must end final ([`TileWork::pass`] returning true), else the
    /// rounds stalled (a cycle in what the tiles wait for) and `stalled`
    /// is the error. Returns the number of rounds.
    pub fn fixed_point<W: TileWork>(
        &mut self,
        work: &W,
        states: &impl TileStates<W::State>,
        final_required: bool,
        stalled: &str,
    ) -> Result<u64> {
        let nt = self.layout.count();
        let mut done = vec![false; nt];
        let mut todo = self.mine.clone();
        let mut round = 0u64;
        loop {
            let (changed, open) = self.round(work, states, &todo, round, Some(&mut done))?;
            round += 1;
            if !changed.iter().any(|&c| c) {
                if final_required && open > 0 {
                    return Err(self.fail(Error::invalid(stalled.to_string())));
                }
                break;
            }
            todo = self
                .mine
                .iter()
                .copied()
                .filter(|&id| !done[id] && self.around[id].iter().any(|&j| changed[j]))
                .collect();
        }
        self.stats.rounds += round;
        self.stats.max_rounds = self.stats.max_rounds.max(round);
        Ok(round)
    }

    /// Run `tiles` (of this rank) in parallel, then exchange. Returns which
    /// tiles changed (all ranks) and how many tiles are not final (all
    /// ranks; `done` tracks this rank's).
    fn round<W: TileWork>(
        &mut self,
        work: &W,
        states: &impl TileStates<W::State>,
        tiles: &[TileId],
        round: u64,
        done: Option<&mut Vec<bool>>,
    ) -> Result<(Vec<bool>, u64)> {
        let board = &self.board;
        // Per tile: final?, and the new publication if it changed.
        type Passed = (TileId, bool, Option<Vec<f64>>);
        let res: Vec<Result<Passed>> = self.pool.install(|| {
            tiles
                .par_iter()
                .map(|&id| {
                    let mut st = states.load(id)?;
                    let old = board.get(id);
                    let mut out = old.to_vec();
                    let fin = work.pass(id, round, &mut st, board, &mut out)?;
                    states.save(id, st)?;
                    let same = out.len() == old.len()
                        && out.iter().zip(old).all(|(a, b)| a.to_bits() == b.to_bits());
                    Ok((id, fin, if same { None } else { Some(out) }))
                })
                .collect()
        });
        self.stats.passes += tiles.len() as u64;
        let mut changed = Vec::new();
        let mut done = done;
        for r in res {
            let (id, fin, out) = r.map_err(|e| self.x.fail(e))?;
            if let Some(d) = done.as_deref_mut() {
                d[id] = fin;
            }
            if let Some(v) = out {
                changed.push((id, v));
            }
        }
        let open = match &done {
            Some(d) => self.mine.iter().filter(|&&id| !d[id]).count() as u64,
            None => 0,
        };
        self.exchange(changed, open)
    }

    /// Put this rank's changed publications on the board and exchange them
    /// with the other ranks (one message per rank to every rank: `open`,
    /// then for each changed tile its id and values).
    fn exchange(
        &mut self,
        changed: Vec<(TileId, Vec<f64>)>,
        open: u64,
    ) -> Result<(Vec<bool>, u64)> {
        let nt = self.layout.count();
        let mut flags = vec![false; nt];
        let (_, ranks) = self.x.rank();
        let mut open_all = open;
        if ranks > 1 {
            let mut msg =
                Vec::with_capacity(1 + changed.iter().map(|(_, v)| 1 + v.len()).sum::<usize>());
            msg.push(open as f64);
            for (id, v) in &changed {
                msg.push(*id as f64);
                msg.extend_from_slice(v);
            }
            let all = self.x.all_gather(&msg).map_err(|e| self.x.fail(e))?;
            for (r, m) in all.iter().enumerate() {
                if r == self.me {
                    continue;
                }
                let Some((&o, mut rest)) = m.split_first() else {
                    return Err(self.x.fail(Error::invalid(format!(
                        "tile rounds: empty message from rank {r}"
                    ))));
                };
                open_all += o as u64;
                while let Some((&idf, tail)) = rest.split_first() {
                    let id = idf as usize;
                    let n = self.board.pubs.get(id).map(|p| p.len());
                    match n {
                        Some(n) if self.owner[id] == r && tail.len() >= n => {
                            self.board.pubs[id].copy_from_slice(&tail[..n]);
                            flags[id] = true;
                            rest = &tail[n..];
                        }
                        _ => {
                            return Err(self.x.fail(Error::invalid(format!(
                                "tile rounds: malformed message from rank {r} (tile {idf})"
                            ))))
                        }
                    }
                }
            }
        }
        for (id, v) in changed {
            self.board.pubs[id] = v;
            flags[id] = true;
        }
        Ok((flags, open_all))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::exec::mpi_halo::Single;

    /// Distance to the nearest seed along a path of cells (4-neighbours)
    /// over a raster split in tiles: each tile publishes its perimeter
    /// distances; a pass is a full BFS of the tile from the seeds and the
    /// neighbours' published perimeter.
    struct Bfs {
        layout: TileLayout,
        seeds: Vec<(usize, usize)>,
    }

    impl TileWork for Bfs {
        type State = Vec<f64>;
        fn pass(
            &self,
            id: TileId,
            _round: u64,
            st: &mut Vec<f64>,
            board: &Board,
            out: &mut [f64],
        ) -> Result<bool> {
            let win = self.layout.window(id);
            let (w, h) = (win.w, win.h);
            if st.is_empty() {
                st.resize(w * h, f64::INFINITY);
            }
            let at = |gx: i64, gy: i64| -> f64 {
                if gx < 0
                    || gy < 0
                    || gx as usize >= self.layout.width
                    || gy as usize >= self.layout.height
                {
                    return f64::INFINITY;
                }
                let ts = self.layout.tile;
                let t = self.layout.id(gx as usize / ts, gy as usize / ts);
                let tw = self.layout.window(t);
                let (lx, ly) = ((gx - tw.x) as usize, (gy - tw.y) as usize);
                let k = crate::raster::perimeter_index(tw.w, tw.h, lx, ly).unwrap();
                let v = board.get(t)[k];
                if v.is_nan() {
                    f64::INFINITY
                } else {
                    v
                }
            };
            // Bellman-Ford inside the tile (tiny tiles).
            for (sx, sy) in &self.seeds {
                if win.contains(*sx as i64, *sy as i64) {
                    st[(*sy - win.y as usize) * w + *sx - win.x as usize] = 0.0;
                }
            }
            loop {
                let mut any = false;
                for y in 0..h {
                    for x in 0..w {
                        let mut best = st[y * w + x];
                        for (dx, dy) in [(-1i64, 0i64), (1, 0), (0, -1), (0, 1)] {
                            let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                            let v = if nx >= 0 && ny >= 0 && (nx as usize) < w && (ny as usize) < h
                            {
                                st[ny as usize * w + nx as usize]
                            } else {
                                at(win.x + nx, win.y + ny)
                            };
                            best = best.min(v + 1.0);
                        }
                        if best < st[y * w + x] {
                            st[y * w + x] = best;
                            any = true;
                        }
                    }
                }
                if !any {
                    break;
                }
            }
            for (x, y) in crate::raster::perimeter_cells(w, h) {
                out[crate::raster::perimeter_index(w, h, x, y).unwrap()] = st[y * w + x];
            }
            Ok(false)
        }
    }

    #[test]
    fn rounds_reach_the_distance_fixed_point_for_any_thread_count() {
        let (w, h) = (23usize, 17usize);
        let seeds = vec![(0, 0), (20, 15)];
        for tile in [1usize, 3, 5, 8, 30] {
            for threads in [1usize, 2, 3] {
                let layout = TileLayout::new(w, h, tile);
                let work = Bfs {
                    layout,
                    seeds: seeds.clone(),
                };
                let states = MemStates::<Vec<f64>>::new(layout.count());
                let mut x = Single;
                let mut r = Rounds::new(layout, threads, &mut x, |t| {
                    let win = layout.window(t);
                    crate::raster::perimeter_len(win.w, win.h)
                })
                .unwrap();
                r.fixed_point(&work, &states, false, "stalled").unwrap();
                for id in 0..layout.count() {
                    let win = layout.window(id);
                    let st = states.load(id).unwrap();
                    for y in 0..win.h {
                        for x in 0..win.w {
                            let (gx, gy) = (win.x as usize + x, win.y as usize + y);
                            // Oracle: Manhattan distance to the nearest seed.
                            let want = seeds
                                .iter()
                                .map(|&(sx, sy)| gx.abs_diff(sx) + gy.abs_diff(sy))
                                .min()
                                .unwrap() as f64;
                            assert_eq!(
                                st[y * win.w + x],
                                want,
                                "tile {tile} threads {threads} ({gx},{gy})"
                            );
                        }
                    }
                }
            }
        }
    }
}
