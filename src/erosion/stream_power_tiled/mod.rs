//! Out-of-core stream-power erosion: the scheme of [`super::stream_power`]
//! (Braun & Willett 2013, implicit O(n)) run over tiles, equal to the
//! in-memory solver **bit for bit** for every tile size, thread count and
//! number of MPI ranks.
//!
//! The state (heights `h` in f64 and the per-step flow graph) lives in tiles,
//! in memory or in a scratch folder of one raw file per tile (`tile`); the
//! only global state is each tile's *perimeter* (its ring of edge cells) for
//! the fields a neighbour needs: O(tiles' boundary), the board of the round
//! driver [`crate::exec::iterate`]. Every global quantity of a step is the
//! fixed point of a local rule, solved by rounds of passes over the tiles
//! that read the neighbours' perimeters of the previous round (label
//! correcting at tile granularity, as in Barnes 2016/2017's tiled priority
//! flood and accumulation, but iterated instead of solved over a perimeter
//! graph); the passes of a round run in parallel, a tile runs again only
//! when a neighbour published something new, and each value is exact, so
//! neither the order nor the tile size changes a bit:
//!
//! 1. **Uplift** (local).
//! 2. **Routing** (`routing`). Steepest descent on `h*` (local, halo 1);
//!    that is all of `None`, and all of `Fill` when no tile has a pit (a
//!    routed cell without a strictly lower neighbour, found in the same pass
//!    and reduced over tiles and ranks): then the levels equal `h*` and no
//!    cell is on a flat, exactly as the in-memory solver skips its sink
//!    resolver. Otherwise `Fill` computes the minimax water level `L(i) = max(h(i), min_j L(j))`
//!    (`L = h` on base levels) by a priority flood inside each tile seeded
//!    from the neighbours' perimeter levels, repeated until no perimeter
//!    level drops (`max`/`min` only: exact; after the first pass only from
//!    the ring cells that lower a level); then the flat distances `D`
//!    (breadth first over equal-`L` cells from draining cells, Barnes, Lehman
//!    & Mulla 2014) the same way; receivers from `L` and `D` (local). The
//!    in-memory solver uses the same definition.
//! 3. **Drainage area** (`update`): cell counts summed down the receiver
//!    graph (Kahn's topological order inside a tile); a cell whose upstream
//!    reaches into another tile waits until that tile has published the count
//!    of the perimeter cell draining into it, and later passes only add the
//!    newly published counts. Counts are integers below 2^53, so any order
//!    gives the same bits; area = count · cell².
//! 4. **Implicit update** in rounds: inside a tile, a cell is solved as soon
//!    as its receiver's new height is known — solved in this tile, or an
//!    exit published by a neighbour — with the same arithmetic as the
//!    untiled solver; the others wait for a later round. The number of
//!    rounds is bounded by the number of tile crossings along the flow paths.
//! 5. **Diffusion** (`K_d > 0`): each explicit substep reads the neighbours'
//!    perimeter heights of the previous substep (halo exchange of depth 1).
//!
//! Under the MPI engine ([`stream_power_tiled_ranked`] with
//! `exec::mpi_halo::MpiHalo`) each rank keeps the states of a contiguous
//! range of tiles, the board's changed perimeters are exchanged after every
//! round, and rank 0 writes the finished tiles.
//!
//! Not supported: [`Depressions::BasinGraph`] (its minimum spanning tree of
//! basin passes is not written as a tiled pass): refused with an error.

// Tile and cell loops index several parallel arrays at once.
#![allow(clippy::needless_range_loop)]

mod routing;
mod tile;
mod update;

pub use tile::TILE_BYTES_PER_CELL;

use super::stream_power::{
    diffusion_substeps, is_base, BaseHeight, Depressions, StreamPowerParams, BASE, VALID,
};
use crate::error::{Error, Result};
use crate::exec::iterate::{Board, MemStates, Rounds, TileStates, TileWork};
use crate::exec::mpi_halo::{HaloTransport, Single};
use crate::raster::{perimeter_len, read_window, Grid, RasterSource, TileId, TileLayout, Window};
use std::path::PathBuf;
use tile::{for_perimeter, Geo, Pad, Store, Tile, FLAGS, H, NF};

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

/// How the tiled solve runs: tile size, where tiles live, worker threads.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SpTiling {
    /// Tile side in cells.
    pub tile: usize,
    /// Where the tiles' states are kept.
    pub backend: SpBackend,
    /// Worker threads (0 = all cores).
    pub threads: usize,
}

impl SpTiling {
    /// Tiles of `tile` cells in memory, on `threads` threads.
    pub fn memory(tile: usize, threads: usize) -> Self {
        SpTiling {
            tile,
            backend: SpBackend::Memory,
            threads,
        }
    }
}

/// Counters of a tiled run (for reports and tests).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct SpTiledStats {
    /// Tile passes of all rounds, summed over steps (and ranks).
    pub passes: u64,
    /// Largest number of rounds of one fixed point (a bound on tile crossings).
    pub max_round: u64,
}

/// Run `steps` steps of stream power on the raster `src` (cell size `cell`
/// metres, square; nodata = outside the domain), tiles as `tiling` says,
/// and hand each finished tile to `write` in increasing tile id order (core
/// window, heights in f64, NaN = nodata).
pub fn stream_power_tiled(
    src: &dyn RasterSource,
    cell: f64,
    p: &StreamPowerParams,
    uplift: &TiledUplift,
    steps: usize,
    tiling: &SpTiling,
    write: impl FnMut(TileId, Window, &Grid<f64>) -> Result<()>,
) -> Result<SpTiledStats> {
    stream_power_tiled_ranked(src, cell, p, uplift, steps, tiling, &mut Single, write)
}

/// [`stream_power_tiled`] over the ranks of `x`: this rank keeps its tiles
/// ([`crate::exec::mpi_halo::partition`]), and `write` is called on rank 0
/// only, with every tile. The same bits for any number of ranks.
#[allow(clippy::too_many_arguments)]
pub fn stream_power_tiled_ranked<X: HaloTransport>(
    src: &dyn RasterSource,
    cell: f64,
    p: &StreamPowerParams,
    uplift: &TiledUplift,
    steps: usize,
    tiling: &SpTiling,
    x: &mut X,
    mut write: impl FnMut(TileId, Window, &Grid<f64>) -> Result<()>,
) -> Result<SpTiledStats> {
    if steps == 0 {
        return Err(Error::invalid(
            "stream power: steps = 0; give at least one time step",
        ));
    }
    let ctx = Ctx::new(src, cell, p, tiling.tile)?;
    if let TiledUplift::Uniform(r) = uplift {
        if !r.is_finite() {
            return Err(Error::invalid(format!(
                "stream power: uplift rate {r} is not finite"
            )));
        }
    }
    if let TiledUplift::Map(m) = uplift {
        let (mw, mh) = (m.info().width, m.info().height);
        if mw != ctx.geo.lay.width || mh != ctx.geo.lay.height {
            return Err(Error::invalid(format!(
                "stream power: the uplift map is {mw}x{mh} but the DEM is {}x{}",
                ctx.geo.lay.width, ctx.geo.lay.height
            )));
        }
    }
    let nsub = if p.kd > 0.0 {
        Some(diffusion_substeps(p, cell)?)
    } else {
        None
    };
    let lay = ctx.geo.lay;
    let mut rounds = Rounds::new(lay, tiling.threads, x, |id| ctx.geo.pub_len(id))?;
    let store = match &tiling.backend {
        SpBackend::Memory => Store::Mem(MemStates::new(lay.count())),
        SpBackend::Disk(d) => {
            std::fs::create_dir_all(d).map_err(|e| Error::io(d, e))?;
            Store::Disk(d.clone(), lay)
        }
    };
    ctx.start(src, &mut rounds, &store)?;
    for _ in 0..steps {
        ctx.step(uplift, nsub, &mut rounds, &store)?;
    }
    // Rank 0 writes every tile in id order; the others send theirs.
    let (me, ranks) = rounds.transport().rank();
    let owner = rounds.owner().to_vec();
    let mine = rounds.mine().to_vec();
    let mut buf = Vec::new();
    if me == 0 {
        for id in 0..lay.count() {
            let win = lay.window(id);
            let h = if owner[id] == 0 {
                store.load(id).map_err(|e| rounds.fail(e))?.h
            } else {
                buf.resize(win.len(), 0.0);
                let x = rounds.transport();
                x.recv_from(owner[id], &mut buf).map_err(|e| x.fail(e))?;
                buf.clone()
            };
            let g = Grid::from_vec(win.w, win.h, h).map_err(|e| rounds.fail(e))?;
            write(id, win, &g).map_err(|e| rounds.fail(e))?;
        }
    } else {
        for &id in &mine {
            let t = store.load(id).map_err(|e| rounds.fail(e))?;
            let x = rounds.transport();
            x.send_to_root(&t.h).map_err(|e| x.fail(e))?;
        }
    }
    let st = rounds.stats();
    let passes = if ranks > 1 {
        let x = rounds.transport();
        x.sum(&[st.passes]).map_err(|e| x.fail(e))?[0]
    } else {
        st.passes
    };
    Ok(SpTiledStats {
        passes,
        max_round: st.max_rounds,
    })
}

/// [`stream_power_tiled`] on an in-memory grid, returning the whole result
/// (for tests and small rasters).
pub fn stream_power_tiled_grid(
    h: &Grid<f64>,
    cell: f64,
    p: &StreamPowerParams,
    uplift: Option<&Grid<f64>>,
    steps: usize,
    tiling: &SpTiling,
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
    let stats = stream_power_tiled(&src, cell, p, &up, steps, tiling, |_, win, g| {
        out.paste(g, win.x, win.y);
        Ok(())
    })?;
    Ok((out, stats))
}

/// Length of the step from a cell to its neighbour in direction `d`.
fn step_len(cell: f64, d: usize) -> f64 {
    if d % 2 == 1 {
        cell * std::f64::consts::SQRT_2
    } else {
        cell
    }
}

/// What one pass on a tile reads and writes: the arguments of
/// [`TileWork::pass`] with the tile's window, padded geometry and perimeter
/// length (the setup every pass needs).
struct Cx<'a> {
    pub round: u64,
    pub t: &'a mut Tile,
    pub board: &'a Board,
    pub out: &'a mut [f64],
    pub win: Window,
    pub pd: Pad,
    /// Perimeter cells of the tile.
    pub pl: usize,
}

impl<'a> Cx<'a> {
    /// The fields, in declaration order (one line in every pass).
    #[allow(clippy::type_complexity)]
    fn parts(
        self,
    ) -> (
        u64,
        &'a mut Tile,
        &'a Board,
        &'a mut [f64],
        Window,
        Pad,
        usize,
    ) {
        let Cx {
            round,
            t,
            board,
            out,
            win,
            pd,
            pl,
        } = self;
        (round, t, board, out, win, pd, pl)
    }
}

/// One pass of the tiled step on a tile ([`TileWork::pass`] through [`Run`]).
trait SpPass: Sync {
    /// The pass; returns true when the tile is final.
    fn run(&self, c: Cx<'_>) -> Result<bool>;
}

/// A [`SpPass`] as the round driver's [`TileWork`] (made by [`Ctx::run`]).
struct Run<'a, P> {
    geo: &'a Geo,
    pass: P,
}

impl<P: SpPass> TileWork for Run<'_, P> {
    type State = Tile;
    fn pass(
        &self,
        id: TileId,
        round: u64,
        t: &mut Tile,
        board: &Board,
        out: &mut [f64],
    ) -> Result<bool> {
        let win = self.geo.lay.window(id);
        let c = Cx {
            round,
            t,
            board,
            out,
            win,
            pd: Pad::new(win),
            pl: self.geo.perimeter(id),
        };
        self.pass.run(c)
    }
}

/// What every pass of a run reads: geometry and parameters.
struct Ctx {
    pub geo: Geo,
    pub cell: f64,
    pub p: StreamPowerParams,
    /// Fill routing (else none).
    pub fill: bool,
}

impl Ctx {
    /// `pass` as work for the round driver.
    fn run<P: SpPass>(&self, pass: P) -> Run<'_, P> {
        Run {
            geo: &self.geo,
            pass,
        }
    }

    fn new(src: &dyn RasterSource, cell: f64, p: &StreamPowerParams, tile: usize) -> Result<Ctx> {
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
        Ok(Ctx {
            geo: Geo::new(TileLayout::new(w, ht, tile)),
            cell,
            p: p.clone(),
            fill: p.depressions == Depressions::Fill,
        })
    }

    /// Read this rank's tiles (flags, base levels, heights), publish their
    /// perimeters, and check that the domain has a base level.
    fn start<X: HaloTransport>(
        &self,
        src: &dyn RasterSource,
        rounds: &mut Rounds<'_, X>,
        store: &Store,
    ) -> Result<()> {
        let lay = self.geo.lay;
        let (w, ht) = (lay.width, lay.height);
        let b = self.p.boundary;
        let made = rounds
            .map_mine(|id| -> Result<(TileId, Vec<f64>, u64)> {
                let win = lay.window(id);
                let padded = read_window::<f64>(
                    src,
                    Window::new(win.x - 1, win.y - 1, win.w + 2, win.h + 2),
                )?;
                let pd = Pad::new(win);
                let pv = padded.data();
                let mut t = Tile::new(win.len(), perimeter_len(win.w + 2, win.h + 2));
                let mut nbase = 0u64;
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
                            if self.p.base_height == BaseHeight::Zero {
                                t.h[i] = 0.0;
                            }
                        }
                        t.flags[i] = f;
                    }
                }
                let pl = self.geo.perimeter(id);
                let mut e = vec![f64::NAN; NF * pl];
                for_perimeter(win.w, win.h, |i, k| {
                    e[H * pl + k] = t.h[i];
                    e[FLAGS * pl + k] = t.flags[i] as f64;
                });
                store.save(id, t)?;
                Ok((id, e, nbase))
            })
            .map_err(|e| rounds.fail(e))?;
        let mut nbase = 0u64;
        let mut pubs = Vec::with_capacity(made.len());
        for (id, e, nb) in made {
            nbase += nb;
            pubs.push((id, e));
        }
        rounds.publish(pubs)?;
        let x = rounds.transport();
        let nbase = if x.rank().1 > 1 {
            x.sum(&[nbase]).map_err(|e| x.fail(e))?[0]
        } else {
            nbase
        };
        if nbase == 0 {
            return Err(Error::invalid(
                "stream power: no base level (no border selected and no nodata cell); \
                 select at least one border (e.g. all)",
            ));
        }
        Ok(())
    }

    fn step<X: HaloTransport>(
        &self,
        uplift: &TiledUplift,
        nsub: Option<(usize, f64)>,
        rounds: &mut Rounds<'_, X>,
        store: &Store,
    ) -> Result<()> {
        let cycle =
            "stream power (tiled): the receiver graph has a cycle; this is a bug, please report it";
        rounds.once(&self.run(routing::Uplift { ctx: self, uplift }), store)?;
        // Steepest descent on the uplifted heights; with fill routing, a
        // step without any pit (the usual case on eroded terrain) needs no
        // levels: they equal the heights and no cell is on a flat (the
        // in-memory solver skips its sink resolver the same way).
        let steepest = self.run(routing::Receivers {
            ctx: self,
            on_levels: false,
        });
        let lakes = if self.fill {
            let no_pit = rounds.once_all_final(&steepest, store)?;
            if !no_pit {
                rounds.fixed_point(
                    &self.run(routing::Levels { ctx: self }),
                    store,
                    false,
                    cycle,
                )?;
                rounds.once(&self.run(routing::FlatStart { ctx: self }), store)?;
                rounds.fixed_point(&self.run(routing::Flats { ctx: self }), store, false, cycle)?;
                let on_levels = routing::Receivers {
                    ctx: self,
                    on_levels: true,
                };
                rounds.once(&self.run(on_levels), store)?;
            }
            !no_pit
        } else {
            rounds.once(&steepest, store)?;
            false
        };
        rounds.fixed_point(
            &self.run(update::Accumulate { ctx: self }),
            store,
            true,
            cycle,
        )?;
        let erode = update::Erode { ctx: self, lakes };
        rounds.fixed_point(&self.run(erode), store, true, cycle)?;
        if let Some((n, c)) = nsub {
            for _ in 0..n {
                rounds.once(&self.run(update::Diffuse { ctx: self, c }), store)?;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::erosion::stream_power::{stream_power, Uplift};
    use crate::exec::mpi_halo::thread_ranks::chans;
    use crate::raster::{AnyGrid, GeoRef, MemRaster};

    /// Rolling terrain rounded to whole metres (flats and lakes), a hole.
    fn terrain(w: usize, h: usize) -> Grid<f64> {
        Grid::from_fn(w, h, |x, y| {
            if (x, y) == (7, 5) {
                return f64::NAN;
            }
            let (fx, fy) = (x as f64, y as f64);
            (100.0 + 9.0 * (fx * 0.31).sin() * (fy * 0.27).cos() + 0.4 * fx).round()
        })
    }

    /// Ranks simulated by threads give the bits of the in-memory solver,
    /// with tiles in memory on some ranks and in scratch files on another,
    /// for fill routing and for no routing with diffusion.
    #[test]
    fn ranks_give_the_bits_of_the_in_memory_solver() {
        let (w, h) = (41, 33);
        let g = terrain(w, h);
        let src = MemRaster::new(AnyGrid::F64(g.clone()), GeoRef::default(), "<m>");
        for dep in [Depressions::Fill, Depressions::None] {
            let p = StreamPowerParams {
                k: 2e-4,
                m: 0.45,
                dt: 500.0,
                kd: if dep == Depressions::None { 0.3 } else { 0.0 },
                depressions: dep,
                ..Default::default()
            };
            let mut want = g.clone();
            stream_power(&mut want, 50.0, &p, &Uplift::Uniform(1e-3), 3).unwrap();
            for ranks in [2usize, 3, 5] {
                let dir = tempfile::tempdir().unwrap();
                let got = std::thread::scope(|s| {
                    let handles: Vec<_> = chans(ranks)
                        .into_iter()
                        .map(|mut x| {
                            let (src, p, dir) = (&src, &p, dir.path());
                            s.spawn(move || {
                                let (me, _) = x.rank();
                                let backend = if me == 1 {
                                    SpBackend::Disk(dir.join(format!("rank{me}")))
                                } else {
                                    SpBackend::Memory
                                };
                                let tiling = SpTiling {
                                    tile: 7,
                                    backend,
                                    threads: 2,
                                };
                                let mut out = Grid::new(w, h, f64::NAN);
                                let up = TiledUplift::Uniform(1e-3);
                                let mut wrote = 0;
                                stream_power_tiled_ranked(
                                    src,
                                    50.0,
                                    p,
                                    &up,
                                    3,
                                    &tiling,
                                    &mut x,
                                    |_, win, t| {
                                        out.paste(t, win.x, win.y);
                                        wrote += 1;
                                        Ok(())
                                    },
                                )
                                .unwrap();
                                (out, wrote)
                            })
                        })
                        .collect();
                    let all: Vec<(Grid<f64>, usize)> =
                        handles.into_iter().map(|h| h.join().unwrap()).collect();
                    // Only rank 0 writes, every tile.
                    assert_eq!(all[0].1, TileLayout::new(w, h, 7).count());
                    assert!(all[1..].iter().all(|(_, n)| *n == 0));
                    all.into_iter().next().unwrap().0
                });
                let same = want
                    .data()
                    .iter()
                    .zip(got.data())
                    .all(|(x, y)| x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan()));
                assert!(same, "{dep:?}, {ranks} ranks");
            }
            // Not a no-op comparison: more cells eroded (rose by less than
            // the 1.5 m of uplift) than there are base levels.
            let eroded = want
                .data()
                .iter()
                .zip(g.data())
                .filter(|(a, b)| a.is_finite() && **a < **b + 1.5 - 1e-6)
                .count();
            assert!(eroded > 2 * (w + h) + 8, "{dep:?}: {eroded} cells eroded");
        }
    }
}
