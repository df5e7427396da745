//! Ghost-zone rounds: a fixed number of rounds in which every tile reads the
//! previous round's *states* of the tiles around it, up to `ghost` cells
//! beyond its core (the tiled local erosion models of `erosion::tiled`).
//!
//! These are rounds of the same driver as the board rounds of the parent
//! module ([`Rounds`]: the same owner of every tile, worker threads,
//! transport and counters), with two differences the local models need.
//! A tile reads its neighbours' whole state near its core, not a small
//! publication, and the ghost zone may reach beyond the 8 tiles around it;
//! and the number of rounds is fixed (a model's substeps), every tile runs
//! in every round, so there is no dirty tracking and no fixed point. States
//! are kept twice (the previous round's, read by everyone, and the next,
//! written by each tile) in memory or in one raw file per tile and round
//! parity ([`CoreStates`]), where memory stays O(threads × patch).
//!
//! The exchange between ranks is point to point ([`HaloPlan`]: every rank
//! receives only the ghost cells its patches need from other ranks' tiles),
//! not the board's all-gather: gathering whole tile states to every rank
//! would move every rank's whole state to every other in every round
//! (`(ranks - 1) × cells × fields × 8` bytes received per rank per round),
//! where the ghost cells are about `perimeter × ghost × fields × 8` bytes
//! per rank boundary — for a 1000-cell tile and a 4-cell ghost zone about
//! 1/60 of a tile per neighbouring tile on another rank, and nothing for
//! tiles of the same rank.

use super::Rounds;
use crate::error::{Error, Result};
use crate::exec::mpi_halo::{extract, paste, patch_window, HaloPlan, HaloTransport};
use crate::raster::{TileId, Window};
use std::borrow::Cow;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// The core states of one round: `fields` arrays of the core's cells per
/// tile (this rank's tiles), in memory or one raw little-endian `f64` file
/// per tile in a directory.
pub enum CoreStates {
    Memory(Vec<Vec<f64>>),
    Disk(PathBuf),
}

fn tile_file(dir: &Path, id: TileId) -> PathBuf {
    dir.join(format!("t{id}.f64"))
}

fn write_tile(dir: &Path, id: TileId, data: &[f64]) -> Result<()> {
    let path = tile_file(dir, id);
    let mut bytes = Vec::with_capacity(data.len() * 8);
    for v in data {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    std::fs::write(&path, bytes).map_err(|e| Error::io(&path, e))
}

impl CoreStates {
    /// Tile `id`'s state, which holds `expect` values.
    pub fn get(&self, id: TileId, expect: usize) -> Result<Cow<'_, [f64]>> {
        match self {
            CoreStates::Memory(v) => Ok(Cow::Borrowed(&v[id])),
            CoreStates::Disk(dir) => {
                let path = tile_file(dir, id);
                let bytes = std::fs::read(&path).map_err(|e| Error::io(&path, e))?;
                if bytes.len() != expect * 8 {
                    return Err(Error::corrupt(
                        &path,
                        format!(
                            "erosion scratch tile has {} bytes, expected {}; was the scratch folder changed during the run?",
                            bytes.len(),
                            expect * 8
                        ),
                    ));
                }
                Ok(Cow::Owned(
                    bytes
                        .chunks_exact(8)
                        .map(|c| {
                            f64::from_le_bytes([c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]])
                        })
                        .collect(),
                ))
            }
        }
    }
}

/// Where the states of one round go: kept in memory (`None`) or written to
/// `dir` as soon as a tile is done (nothing kept).
fn keep(dir: Option<&Path>, id: TileId, v: Vec<f64>) -> Result<(TileId, Vec<f64>)> {
    if let Some(dir) = dir {
        write_tile(dir, id, &v)?;
        return Ok((id, Vec::new()));
    }
    Ok((id, v))
}

fn store(count: usize, dir: Option<&Path>, results: Vec<(TileId, Vec<f64>)>) -> CoreStates {
    match dir {
        None => {
            let mut v = vec![Vec::new(); count];
            for (id, d) in results {
                v[id] = d;
            }
            CoreStates::Memory(v)
        }
        Some(dir) => CoreStates::Disk(dir.to_path_buf()),
    }
}

/// A tile's patch in a ghost-zone round: its window (the core grown by the
/// ghost zone, clipped to the raster) and one array per field over it.
pub struct GhostPatch {
    pub win: Window,
    pub fields: Vec<Vec<f64>>,
    /// Working arrays of the step, handed back to be dropped only after the
    /// core is kept (dropped earlier, their memory would go back to the
    /// system just before the core takes as much again).
    pub scratch: Vec<Vec<f64>>,
}

/// What [`Rounds::ghost_rounds`] leaves: the last round's states of this
/// rank's tiles, the exchange plan and the time spent exchanging.
pub struct GhostRun {
    pub states: CoreStates,
    pub plan: HaloPlan,
    pub exchange_time: Duration,
}

impl<'x, X: HaloTransport> Rounds<'x, X> {
    /// `rounds` ghost-zone rounds of this rank's tiles, `fields` values per
    /// cell. `init(id)` gives tile `id`'s first state (its core, field after
    /// field); in round `r` every tile's patch (its core grown by `ghost`
    /// cells) is assembled from the previous round's states — other ranks'
    /// cells arriving point to point ([`HaloPlan`]) — and `step(r, id, patch)`
    /// advances it; the core is kept as the tile's next state. States stay
    /// in memory, or with `disk` in its subfolders `r0` and `r1` (created).
    /// `after_round` is called after each round. Same bits for any number of
    /// threads and ranks: a round reads only the previous round's states.
    #[allow(clippy::too_many_arguments)]
    pub fn ghost_rounds(
        &mut self,
        ghost: usize,
        fields: usize,
        rounds: u64,
        disk: Option<&Path>,
        init: impl Fn(TileId) -> Result<Vec<f64>> + Sync,
        step: impl Fn(u64, TileId, GhostPatch) -> Result<GhostPatch> + Sync,
        mut after_round: impl FnMut(),
    ) -> Result<GhostRun> {
        let nf = fields;
        let layout = self.layout;
        let count = layout.count();
        let (me, ranks) = self.x.rank();
        let plan = HaloPlan::new(&layout, ghost, self.owner.clone(), (me, ranks), nf)
            .map_err(|e| self.fail(e))?;
        let parity_dir = |parity: u64| disk.map(|d| d.join(format!("r{parity}")));
        for p in 0..2 {
            if let Some(d) = parity_dir(p) {
                std::fs::create_dir_all(&d).map_err(|e| self.fail(Error::io(&d, e)))?;
            }
        }
        // From here on an error on one rank must end every rank (the others
        // would wait for its messages): `fail`.
        let dir0 = parity_dir(0);
        let init = self
            .map_mine(|id| keep(dir0.as_deref(), id, init(id)?))
            .map_err(|e| self.fail(e))?;
        let mut cur = store(count, dir0.as_deref(), init);
        // Halo messages, reused every round: strips out to each rank, in from each.
        let mut outbox: Vec<Vec<f64>> = plan
            .sends
            .iter()
            .map(|s| Vec::with_capacity(s.iter().map(|s| s.win.len() * nf).sum()))
            .collect();
        let mut inbox: Vec<Vec<f64>> = plan.recv_len.iter().map(|&n| vec![0.0; n]).collect();
        let mut exchange_time = Duration::ZERO;
        for round in 0..rounds {
            if ranks > 1 {
                let t = std::time::Instant::now();
                for (out, strips) in outbox.iter_mut().zip(&plan.sends) {
                    out.clear();
                    // Strips are grouped by tile: read each tile once.
                    for group in strips.chunk_by(|a, b| a.tile == b.tile) {
                        let tile = group[0].tile;
                        let tw = layout.window(tile);
                        let data = cur.get(tile, tw.len() * nf).map_err(|e| self.fail(e))?;
                        for s in group {
                            extract(tw, &data, nf, s.win, out);
                        }
                    }
                }
                self.x
                    .exchange(&outbox, &mut inbox)
                    .map_err(|e| self.x.fail(e))?;
                exchange_time += t.elapsed();
            }
            let next = parity_dir((round + 1) % 2);
            let (prev, inbox, plan, owner) = (&cur, &inbox, &plan, &self.owner);
            let results = self
                .map_mine(|id| {
                    let core = layout.window(id);
                    let pw = patch_window(&layout, id, ghost);
                    let mut fields = vec![vec![0.0; pw.len()]; nf];
                    for tid in layout.tiles_in(&pw) {
                        let tw = layout.window(tid);
                        let Some(iw) = tw.intersect(&pw) else {
                            continue;
                        };
                        if owner[tid] == me {
                            let data = prev.get(tid, tw.len() * nf)?;
                            paste(pw, &mut fields, tw, &data, iw);
                        } else {
                            for g in &plan.ghosts[tid] {
                                let n = g.win.len() * nf;
                                let data = &inbox[g.from][g.offset..g.offset + n];
                                paste(pw, &mut fields, g.win, data, iw);
                            }
                        }
                    }
                    let patch = GhostPatch {
                        win: pw,
                        fields,
                        scratch: Vec::new(),
                    };
                    let p = step(round, id, patch)?;
                    let mut v = Vec::with_capacity(core.len() * nf);
                    for f in &p.fields {
                        extract(p.win, f, 1, core, &mut v);
                    }
                    keep(next.as_deref(), id, v)
                })
                .map_err(|e| self.fail(e))?;
            cur = store(count, next.as_deref(), results);
            self.stats.passes += self.mine.len() as u64;
            after_round();
        }
        self.stats.rounds += rounds;
        self.stats.max_rounds = self.stats.max_rounds.max(rounds);
        Ok(GhostRun {
            states: cur,
            plan,
            exchange_time,
        })
    }
}
