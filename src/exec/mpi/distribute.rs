//! Tiles spread over the ranks and written on rank 0 in tile order: the
//! local steps and the apply phase of global steps ([`MpiEngine::distribute`]),
//! rank 0's reorder buffer and writer, the other ranks' sender, and which
//! outputs the ranks write themselves (tile stores, [`TileSink::delegate`]).

use super::last_words::{self, note_pending};
use super::world::{broadcast_bytes, fail};
use super::{schedule, MpiEngine};
use crate::error::{Error, Result};
use crate::exec::mpi_codec::{decode_tile_written, encode_tile_written, Queue, TileParts};
use crate::exec::mpi_queue::{self, Work};
use crate::exec::tile_io::{finish_all, write_outputs};
use crate::exec::TileSink;
use crate::raster::{AnyGrid, DType, TileId, TileLayout};
use crate::store::{DelegatedTiles, TileEntry, TileState};
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;

/// Rank 0's payload of a grant: the packed slices of the granted tiles.
pub(super) type SlicesOut<'a> = &'a (dyn Fn(&[TileId]) -> Result<Vec<u8>> + Sync);
/// A rank's intake of a grant's payload (granted tiles, packed slices).
pub(super) type SlicesIn<'a> = &'a (dyn Fn(&[TileId], &[u8]) -> Result<()> + Sync);

/// How a tile arrived at rank 0 before its turn to be written.
enum Arrived {
    /// Computed on rank 0 (the sinks' native types).
    Own(Vec<AnyGrid>),
    /// A tile message from another rank.
    Remote(Vec<u8>),
}

/// Rank 0's side of [`MpiEngine::distribute`]: puts tiles arriving in any
/// order back into tile order and writes them (or records the receipts of
/// delegated writes) exactly as the in-process engine does.
struct Writer<'a> {
    pub(super) name: &'a str,
    pub(super) layout: &'a TileLayout,
    pub(super) ids: &'a [TileId],
    pub(super) meta: &'a [(DType, Option<f64>)],
    pub(super) sinks: Vec<Box<dyn TileSink>>,
    pub(super) delegated: &'a [Option<DelegatedTiles>],
    pub(super) slices: Option<SlicesOut<'a>>,
    /// Positions that arrived and wait for an earlier one (at most the
    /// queue's window when cells travel; receipts only otherwise).
    pub(super) buffer: std::collections::BTreeMap<usize, Arrived>,
    pub(super) got: Vec<bool>,
    pub(super) left: Vec<usize>,
    pub(super) frontier: usize,
    pub(super) moved: u64,
}

impl Writer<'_> {
    pub(super) fn shapes_of(&self, id: TileId) -> Vec<(DType, usize, usize)> {
        let core = self.layout.window(id);
        self.meta
            .iter()
            .zip(self.delegated)
            .filter(|(_, d)| d.is_none())
            .map(|(m, _)| (m.0, core.w, core.h))
            .collect()
    }

    /// Write the tile at the frontier if it is there (one tile, so the
    /// queue is served between writes); true if one was written.
    pub(super) fn write_next(&mut self, q: &Queue) -> Result<bool> {
        let Some(a) = self.buffer.remove(&self.frontier) else {
            return Ok(false);
        };
        let id = self.ids[self.frontier];
        match a {
            Arrived::Own(grids) => write_outputs(&mut self.sinks, self.layout, id, grids)
                .map_err(|e| Error::tile(self.name, id, e))?,
            Arrived::Remote(msg) => self
                .write_remote(id, &msg)
                .map_err(|e| Error::tile(self.name, id, e))?,
        }
        self.frontier += 1;
        note_pending(self.name, self.ids, q, &self.got, self.frontier, &self.left);
        Ok(true)
    }

    pub(super) fn write_remote(&mut self, id: TileId, msg: &[u8]) -> Result<()> {
        let n_written = self.delegated.iter().filter(|d| d.is_some()).count();
        let (cells, written) = decode_tile_written(msg, id, &self.shapes_of(id), n_written)?;
        let core = self.layout.window(id);
        let mut cells = cells.into_iter();
        let mut written = written.into_iter();
        for (s, d) in self.sinks.iter_mut().zip(self.delegated) {
            let done = s.is_done(id);
            if d.is_some() {
                let Some((crc32, bytes)) = written.next() else {
                    break;
                };
                if !done {
                    s.record_delegated(
                        id,
                        TileEntry {
                            state: TileState::Done,
                            crc32,
                            bytes,
                        },
                    )?;
                }
            } else {
                let Some(g) = cells.next() else { break };
                if !done {
                    s.write(id, core, g)?;
                }
            }
        }
        Ok(())
    }

    pub(super) fn arrive(&mut self, k: usize, from: usize, q: &Queue) -> Result<()> {
        if q.owner(k) != Some(from) || self.got[k] {
            return Err(Error::invalid(format!(
                "{}: rank {from} delivered tile {}, which it was not granted or which came twice",
                self.name, self.ids[k]
            )));
        }
        self.got[k] = true;
        if let Some(l) = self.left.get_mut(from) {
            *l = l.saturating_sub(1);
        }
        Ok(())
    }
}

impl mpi_queue::Serve<Vec<AnyGrid>> for Writer<'_> {
    fn payload(&mut self, ks: &[usize]) -> Result<Vec<u8>> {
        match self.slices {
            Some(f) => f(&ks.iter().map(|&k| self.ids[k]).collect::<Vec<_>>()),
            None => Ok(Vec::new()),
        }
    }
    fn granted(&mut self, r: usize, ks: &[usize], q: &Queue) {
        if let Some(l) = self.left.get_mut(r) {
            *l += ks.len();
        }
        note_pending(self.name, self.ids, q, &self.got, self.frontier, &self.left);
    }
    fn own(&mut self, k: usize, grids: Vec<AnyGrid>, q: &Queue) -> Result<()> {
        self.arrive(k, 0, q)?;
        self.buffer.insert(k, Arrived::Own(grids));
        note_pending(self.name, self.ids, q, &self.got, self.frontier, &self.left);
        Ok(())
    }
    fn remote(&mut self, from: usize, msg: Vec<u8>, q: &Queue) -> Result<()> {
        let id = msg
            .get(..8)
            .map(|b| {
                let mut a = [0u8; 8];
                a.copy_from_slice(b);
                u64::from_le_bytes(a)
            })
            .ok_or_else(|| {
                Error::invalid(format!(
                    "{}: a tile message from rank {from} is shorter than its header",
                    self.name
                ))
            })?;
        let k = usize::try_from(id)
            .ok()
            .and_then(|id| self.ids.binary_search(&id).ok())
            .ok_or_else(|| {
                Error::invalid(format!(
                    "{}: rank {from} sent tile {id}, which is not to do",
                    self.name
                ))
            })?;
        self.arrive(k, from, q)?;
        self.moved += msg.len() as u64;
        self.buffer.insert(k, Arrived::Remote(msg));
        note_pending(self.name, self.ids, q, &self.got, self.frontier, &self.left);
        Ok(())
    }
    fn write_one(&mut self, q: &Queue) -> Result<bool> {
        self.write_next(q)
    }
    fn frontier(&self) -> usize {
        self.frontier
    }
    fn complete(&self) -> bool {
        self.frontier >= self.ids.len()
    }
}

/// A rank's side of [`MpiEngine::distribute`]: tiles (and receipts) to
/// rank 0 as they finish; slices that come with grants to `slices`.
struct Sender<'a> {
    pub(super) ids: &'a [TileId],
    pub(super) slices: Option<SlicesIn<'a>>,
    pub(super) moved: u64,
}

impl mpi_queue::Draw<TileParts> for Sender<'_> {
    fn payload(&mut self, ks: &[usize], bytes: &[u8]) -> Result<()> {
        match self.slices {
            Some(f) => f(&ks.iter().map(|&k| self.ids[k]).collect::<Vec<_>>(), bytes),
            None => Ok(()),
        }
    }
    fn result(&mut self, k: usize, (cells, written): TileParts) -> Result<Option<Vec<u8>>> {
        let msg = encode_tile_written(self.ids[k], &cells, &written);
        self.moved += msg.len() as u64;
        Ok(Some(msg))
    }
}

impl MpiEngine {
    /// Compute the tiles `ids` spread over the ranks by the work queue
    /// ([`mpi_queue`]) and write them on rank 0 in increasing id order.
    /// `compute` gives a tile's outputs in the sinks' native types. Outputs
    /// whose sink on rank 0 can delegate its writes (a tile store:
    /// [`TileSink::delegate`]) are written by the rank that computed the
    /// tile, which sends rank 0 only the tile's checksum and size to record;
    /// the others travel to rank 0. Rank 0 writes (and records) in tile
    /// order whatever the order of arrival, so neither the output nor a
    /// store's journal depends on which rank did which tile.
    ///
    /// Memory on rank 0: its own tiles in flight (`d = min(cap, threads +
    /// 1)`, see `mpi_queue::depth`) plus the tiles that arrived before an
    /// earlier one was written. When cells travel, the queue grants nothing
    /// beyond a window of `W` positions past the first unwritten one, `W =
    /// max(2 x ranks, min(ranks x cap, budget / bytes_per_tile - d))`, so
    /// rank 0 holds at most `d + W` tiles: within its `--memory` budget
    /// unless that is under `2 x ranks + d` tiles. Receipts alone (12 bytes
    /// per delegated output) are not windowed. Other ranks hold at most `d`
    /// tiles, and each message buffer is one of those tiles.
    ///
    /// `slices_out` (rank 0) gives the payload of a grant (the slices of
    /// its tiles, when only rank 0 holds the solution); `slices_in` (other
    /// ranks) takes it. Returns the bytes sent to rank 0 (tiles, receipts)
    /// and this rank's work. Errors end the job (MPI_Abort).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn distribute(
        &self,
        comm: &SimpleCommunicator,
        name: &str,
        layout: &TileLayout,
        ids: &[TileId],
        meta: &[(DType, Option<f64>)],
        bytes: u64,
        sinks: Vec<Box<dyn TileSink>>,
        compute: &(dyn Fn(TileId) -> Result<Vec<AnyGrid>> + Sync),
        slices_out: Option<SlicesOut<'_>>,
        slices_in: Option<SlicesIn<'_>>,
    ) -> (u64, Work) {
        let me = comm.rank() as usize;
        let ranks = comm.size() as usize;
        let threads = self.local.config().threads.max(1);
        let cap = self.cap(bytes);
        let delegated = Self::shared_delegation(comm, &sinks, meta, layout);
        let (moved, work) = if me == 0 {
            let travels = delegated.iter().any(|d| d.is_none());
            // The reorder window and rank 0's own tiles in flight share its
            // memory budget (at least two tiles per rank, so every rank can
            // work while the next one travels).
            let own = mpi_queue::depth(cap, threads);
            let window = travels.then(|| {
                (ranks * cap)
                    .min(self.local.tiles_in_flight(bytes).saturating_sub(own))
                    .max(2 * ranks)
            });
            let max_chunk = if slices_out.is_some() {
                4 * cap
            } else {
                usize::MAX
            };
            let mut q = Queue::new(ids.len(), ranks, schedule(), window, max_chunk)
                .unwrap_or_else(|e| fail(e));
            let mut w = Writer {
                name,
                layout,
                ids,
                meta,
                sinks,
                delegated: &delegated,
                slices: slices_out,
                buffer: Default::default(),
                got: vec![false; ids.len()],
                left: vec![0; ranks],
                frontier: 0,
                moved: 0,
            };
            let work = mpi_queue::serve(comm, name, threads, cap, ids, &mut q, compute, &mut w);
            last_words::clear();
            if let Err(e) = finish_all(w.sinks) {
                fail(e);
            }
            (w.moved, work)
        } else {
            drop(sinks);
            // Compute, then write the delegated outputs here (on the
            // workers, in parallel): what travels is the rest plus receipts.
            let delegated = &delegated;
            let work = |id: TileId| -> Result<TileParts> {
                let grids = compute(id)?;
                let mut cells = Vec::new();
                let mut written = Vec::new();
                for (g, d) in grids.into_iter().zip(delegated) {
                    match d {
                        Some(d) => {
                            let e = d.write_tile(id, &g)?;
                            written.push((e.crc32, e.bytes));
                        }
                        None => cells.push(g),
                    }
                }
                Ok((cells, written))
            };
            let mut s = Sender {
                ids,
                slices: slices_in,
                moved: 0,
            };
            let work = mpi_queue::draw(comm, name, threads, cap, ids, &work, &mut s);
            (s.moved, work)
        };
        // Nobody goes on (and reads the output) before rank 0 finished it.
        comm.barrier();
        (moved, work)
    }

    /// Rank 0 decides, per output, whether the ranks write their tiles
    /// themselves (its sink can delegate, and `OROGEN_MPI_DELEGATE` is not
    /// `0`) and sends every rank the delegation (JSON), so all ranks agree.
    pub(super) fn shared_delegation(
        comm: &SimpleCommunicator,
        sinks: &[Box<dyn TileSink>],
        meta: &[(DType, Option<f64>)],
        layout: &TileLayout,
    ) -> Vec<Option<DelegatedTiles>> {
        let mine: Vec<Option<DelegatedTiles>> = if comm.rank() == 0 {
            let on = std::env::var("OROGEN_MPI_DELEGATE").as_deref() != Ok("0");
            sinks
                .iter()
                .map(|s| if on { s.delegate() } else { None })
                .collect()
        } else {
            Vec::new()
        };
        let bytes = if comm.rank() == 0 {
            serde_json::to_vec(&mine).unwrap_or_else(|e| {
                fail(Error::invalid(format!(
                    "MPI engine: a tile-store delegation does not serialise: {e}"
                )))
            })
        } else {
            Vec::new()
        };
        let bytes = broadcast_bytes(comm, bytes);
        let got: Vec<Option<DelegatedTiles>> = serde_json::from_slice(&bytes)
            .unwrap_or_else(|e| fail(Error::invalid(format!("MPI engine: rank 0's tile-store delegation does not parse (ranks of different orogen builds?): {e}"))));
        if got.len() != meta.len() {
            fail(Error::invalid(format!(
                "MPI engine: rank 0 delegates {} outputs, this rank has {}",
                got.len(),
                meta.len()
            )));
        }
        for (d, m) in got.iter().zip(meta) {
            if let Some(d) = d {
                if d.dtype != m.0 || d.layout().ok() != Some(*layout) {
                    fail(Error::invalid(format!(
                        "MPI engine: rank 0's store {} is {} in tiles of {}, this rank computes {} in tiles of {}",
                        d.dir.display(),
                        d.dtype,
                        d.tile,
                        m.0,
                        layout.tile
                    )));
                }
            }
        }
        got
    }
}
