//! Global steps over the ranks: the map phase drawn from the work queue,
//! the summaries (JSON records, zstd-packed) and their checks, and the
//! apply phase with each tile's slice, replicated on every rank or sent by
//! rank 0 with the grants (Barnes 2016, 2017; see the module above).

use super::distribute::{SlicesIn, SlicesOut};
use super::last_words;
use super::world::fail;
use super::{schedule, MpiEngine, Phase};
use crate::error::{Error, Result};
use crate::exec::mpi_codec::{decode_records, perimeter_cells, push_record, Queue};
use crate::exec::mpi_queue::{self, Work};
use crate::exec::tile_io::{apply_tile, out_meta, read_views};
use crate::exec::{GlobalStep, TileSink};
use crate::raster::{AnyGrid, RasterSource, TileId, TileLayout};
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use std::sync::Mutex;
use std::time::Instant;

/// Rank 0's side of the map phase: its own summaries into a record list;
/// the last words name each rank's latest grant (summaries travel only at
/// the end of the phase).
struct MapServe<'a> {
    pub(super) name: &'a str,
    pub(super) records: Vec<u8>,
    pub(super) last: Vec<String>,
}

impl mpi_queue::Serve<Vec<u8>> for MapServe<'_> {
    fn payload(&mut self, _ks: &[usize]) -> Result<Vec<u8>> {
        Ok(Vec::new())
    }
    fn granted(&mut self, r: usize, ks: &[usize], _q: &Queue) {
        if let (Some(slot), Some(a), Some(b)) = (self.last.get_mut(r), ks.first(), ks.last()) {
            *slot = format!("tiles {a}..={b}");
        }
        let mut lines = String::new();
        for (r, l) in self.last.iter().enumerate().skip(1) {
            if !l.is_empty() {
                lines.push_str(&format!("\n  rank {r}: last granted {l}"));
            }
        }
        last_words::set(&format!(
            "error: MPI rank 0 ended (SIGTERM) during {}, map phase (summaries travel at its end);{lines}\nerror: a rank died or the job was cancelled (mpirun names the rank); rerun the same command to resume from the finished tiles of tile-store outputs\n",
            self.name
        ));
    }
    fn own(&mut self, k: usize, b: Vec<u8>, _q: &Queue) -> Result<()> {
        push_record(&mut self.records, k, &b);
        Ok(())
    }
    fn remote(&mut self, from: usize, _msg: Vec<u8>, _q: &Queue) -> Result<()> {
        Err(Error::invalid(format!(
            "{}: rank {from} sent a tile message during the map phase",
            self.name
        )))
    }
    fn write_one(&mut self, _q: &Queue) -> Result<bool> {
        Ok(false)
    }
    fn frontier(&self) -> usize {
        0
    }
    fn complete(&self) -> bool {
        true
    }
}

/// A rank's side of the map phase: summaries into a record list.
struct MapDraw {
    pub(super) records: Vec<u8>,
}

impl mpi_queue::Draw<Vec<u8>> for MapDraw {
    fn payload(&mut self, _ks: &[usize], _bytes: &[u8]) -> Result<()> {
        Ok(())
    }
    fn result(&mut self, k: usize, b: Vec<u8>) -> Result<Option<Vec<u8>>> {
        push_record(&mut self.records, k, &b);
        Ok(None)
    }
}

/// Compress a record list for the wire: raw length (`u64`), then zstd
/// (level 3) of the JSON records, which are mostly decimal numbers.
pub(super) fn pack(records: &[u8]) -> Result<Vec<u8>> {
    let z = zstd::bulk::compress(records, 3)
        .map_err(|e| Error::invalid(format!("MPI engine: compressing summaries: {e}")))?;
    let mut out = Vec::with_capacity(8 + z.len());
    out.extend_from_slice(&(records.len() as u64).to_le_bytes());
    out.extend_from_slice(&z);
    Ok(out)
}

/// [`pack`] a rank's summaries: the packed bytes and the raw length
/// (errors end the job).
fn pack_records(records: Vec<u8>) -> (Vec<u8>, u64) {
    let raw = records.len() as u64;
    (pack(&records).unwrap_or_else(|e| fail(e)), raw)
}

/// Undo [`pack`]; the declared size is checked against zstd's own frame
/// header before anything that large is allocated.
fn unpack(msg: &[u8]) -> Result<Vec<u8>> {
    if msg.len() < 8 {
        return Err(Error::invalid(
            "a summary message is shorter than its header",
        ));
    }
    let mut a = [0u8; 8];
    a.copy_from_slice(&msg[..8]);
    let n = u64::from_le_bytes(a);
    let frame = zstd::zstd_safe::get_frame_content_size(&msg[8..])
        .ok()
        .flatten();
    if frame != Some(n) {
        return Err(Error::invalid(format!(
            "a summary message declares {n} bytes but its zstd frame {frame:?}"
        )));
    }
    let n = usize::try_from(n)
        .map_err(|_| Error::invalid(format!("a summary message declares {n} bytes")))?;
    zstd::bulk::decompress(&msg[8..], n)
        .map_err(|e| Error::invalid(format!("decompressing summaries: {e}")))
}

impl MpiEngine {
    /// Map phase of a global step: the ranks map all tiles, drawn from the
    /// work queue; returns (rank 0) the queue, which records who mapped
    /// which tile, this rank's summaries as a packed record list of JSON
    /// ([`pack`]) with its length before packing, and this
    /// rank's work. Errors end the job.
    pub(super) fn map_mine<S: GlobalStep>(
        &self,
        comm: &SimpleCommunicator,
        step: &S,
        inputs: &[&dyn RasterSource],
        layout: &TileLayout,
    ) -> (Option<Queue>, Vec<u8>, u64, Work) {
        let name = step.name();
        let halo = step.halo();
        let all: Vec<TileId> = (0..layout.count()).collect();
        let map_bytes = crate::exec::local_tile_bytes(
            layout,
            halo,
            inputs,
            std::mem::size_of::<S::In>(),
            0,
            &[],
        );
        let map_name = format!("{name} (map)");
        let map = |id: TileId| -> Result<Vec<u8>> {
            let views = read_views::<S::In>(inputs, layout, id, halo)?;
            let s = step.map(&views)?;
            serde_json::to_vec(&s).map_err(|e| {
                Error::invalid(format!("{name}: a tile summary does not serialise: {e}"))
            })
        };
        let threads = self.local.config().threads.max(1);
        let cap = self.cap(map_bytes);
        if comm.rank() == 0 {
            let mut q = Queue::new(
                all.len(),
                comm.size() as usize,
                schedule(),
                None,
                usize::MAX,
            )
            .unwrap_or_else(|e| fail(e));
            let mut h = MapServe {
                name: &map_name,
                records: Vec::new(),
                last: vec![String::new(); comm.size().max(1) as usize],
            };
            let work = mpi_queue::serve(comm, &map_name, threads, cap, &all, &mut q, &map, &mut h);
            last_words::clear();
            let (packed, raw) = pack_records(h.records);
            (Some(q), packed, raw, work)
        } else {
            let mut h = MapDraw {
                records: Vec::new(),
            };
            let work = mpi_queue::draw(comm, &map_name, threads, cap, &all, &map, &mut h);
            let (packed, raw) = pack_records(h.records);
            (None, packed, raw, work)
        }
    }

    /// Apply phase of a global step: like a local step, each tile with its
    /// slice. The tiles to apply are drawn from the work queue again (apply
    /// costs need not follow map costs, and a resumed output applies fewer
    /// tiles than were mapped). `solution` is there on every rank (the
    /// replicated reduce) or on rank 0 only (`shipped`, Barnes): then rank 0 sends
    /// the slices of the tiles of each grant along with it. Errors end the
    /// job.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn apply_phase<S: GlobalStep>(
        &self,
        comm: &SimpleCommunicator,
        step: &S,
        inputs: &[&dyn RasterSource],
        layout: &TileLayout,
        sinks: Vec<Box<dyn TileSink>>,
        solution: Option<&S::Solution>,
        shipped: bool,
        t_reduce: Instant,
    ) {
        let name = step.name();
        let t1 = Instant::now();
        let me = comm.rank() as usize;
        let count = layout.count();
        let (meta, bytes) = out_meta::<S::In, S::Out>(layout, step.halo(), inputs, &sinks);
        let ids = Self::shared_todo(comm, layout, &sinks);
        self.note_resume(comm, &name, &ids, layout);
        Self::report(
            comm,
            Phase {
                step: &name,
                phase: "global: reduce",
                tiles: count,
                perimeter: perimeter_cells(layout),
                up: 0,
                down: 0,
                raw: 0,
                t0: t_reduce,
                work: Work::default(),
            },
        );
        // Slices that came with grants (ranks other than 0, Barnes).
        let received: Mutex<std::collections::HashMap<TileId, S::Slice>> =
            Mutex::new(Default::default());
        let slice_of = |id: TileId| -> Result<S::Slice> {
            match solution {
                Some(sol) => Ok(step.slice(sol, id)),
                None => received
                    .lock()
                    .map_err(|_| Error::invalid("MPI engine: slice table lock poisoned"))?
                    .remove(&id)
                    .ok_or_else(|| {
                        Error::invalid(format!("rank 0 sent no slice of tile {id} to this rank"))
                    }),
            }
        };
        let slices_out = |grant: &[TileId]| -> Result<Vec<u8>> {
            let Some(sol) = solution else {
                return Ok(Vec::new());
            };
            let mut list = Vec::new();
            for &id in grant {
                let b = serde_json::to_vec(&step.slice(sol, id)).map_err(|e| {
                    Error::invalid(format!(
                        "{name}: the slice of tile {id} does not serialise: {e}"
                    ))
                })?;
                push_record(&mut list, id, &b);
            }
            pack(&list)
        };
        let slices_in = |grant: &[TileId], bytes: &[u8]| -> Result<()> {
            let list = unpack(bytes)
                .map_err(|e| Error::invalid(format!("{name}: the slices sent by rank 0: {e}")))?;
            let mut got = received
                .lock()
                .map_err(|_| Error::invalid("MPI engine: slice table lock poisoned"))?;
            let mut n = 0;
            for (id, b) in decode_records(&list, count)? {
                if grant.binary_search(&id).is_err() || got.contains_key(&id) {
                    return Err(Error::invalid(format!(
                        "{name}: rank 0 sent the slice of tile {id}, which this rank was not granted or already has"
                    )));
                }
                let v: S::Slice = serde_json::from_slice(b).map_err(|e| {
                    Error::tile(
                        &name,
                        id,
                        Error::invalid(format!(
                            "its slice does not survive a serde_json round trip (NaN or infinity in an f64 field?): {e}"
                        )),
                    )
                })?;
                got.insert(id, v);
                n += 1;
            }
            if n != grant.len() {
                return Err(Error::invalid(format!(
                    "{name}: rank 0 granted {} tiles with {n} slices",
                    grant.len()
                )));
            }
            Ok(())
        };
        let apply_name = format!("{name} (apply)");
        let apply = |id: TileId| -> Result<Vec<AnyGrid>> {
            let slice = slice_of(id)?;
            apply_tile(step, &name, inputs, layout, id, &slice, &meta)
        };
        let (out, inn): (Option<SlicesOut<'_>>, Option<SlicesIn<'_>>) = match (shipped, me) {
            (false, _) => (None, None),
            (true, 0) => (Some(&slices_out), None),
            (true, _) => (None, Some(&slices_in)),
        };
        let (moved, work) = self.distribute(
            comm,
            &apply_name,
            layout,
            &ids,
            &meta,
            bytes,
            sinks,
            &apply,
            out,
            inn,
        );
        Self::report(
            comm,
            Phase {
                step: &name,
                phase: if shipped {
                    "global: apply (queue; slices with the grants), tiles (or receipts) to rank 0"
                } else {
                    "global: apply (queue), tiles (or receipts) to rank 0"
                },
                tiles: ids.len(),
                perimeter: perimeter_cells(layout),
                up: moved,
                down: work.payload_bytes,
                raw: moved,
                t0: t1,
                work,
            },
        );
    }
}

/// record does not decode. `what` names the record ("summary", "slice") in
/// the error, attached to tile `id` of step `step`.
fn decode_into<T: serde::de::DeserializeOwned>(
    slots: &mut [Option<T>],
    list: &[u8],
    step: &str,
    what: &str,
    refused: impl Fn(TileId) -> Option<String>,
) {
    for (id, b) in decode_records(list, slots.len()).unwrap_or_else(|e| fail(e)) {
        let why = refused(id).or_else(|| {
            slots[id]
                .is_some()
                .then(|| format!("{step}: the {what} of tile {id} came twice"))
        });
        if let Some(why) = why {
            fail(Error::invalid(why));
        }
        let v: T = serde_json::from_slice(b).unwrap_or_else(|e| {
            fail(Error::tile(
                step,
                id,
                Error::invalid(format!(
                    "its {what} does not survive a serde_json round trip (NaN or infinity in an f64 field?): {e}"
                )),
            ))
        });
        slots[id] = Some(v);
    }
}

/// Every tile's summary from the packed record lists by rank (`lists[r]`
/// from rank `r`), checking each tile comes exactly once and (on rank 0,
/// which holds the `queue`) from the rank that was granted it.
/// Errors end the job.
pub(super) fn decode_summaries<S: GlobalStep>(
    name: &str,
    lists: &[Vec<u8>],
    queue: Option<&Queue>,
    count: usize,
) -> Vec<S::Summary> {
    let map_name = format!("{name} (map)");
    let mut summaries: Vec<Option<S::Summary>> = (0..count).map(|_| None).collect();
    for (r, packed) in lists.iter().enumerate() {
        let list = unpack(packed).unwrap_or_else(|e| {
            fail(Error::invalid(format!(
                "{name}: the summaries of rank {r}: {e}"
            )))
        });
        decode_into(&mut summaries, &list, &map_name, "summary", |id| {
            queue.filter(|q| q.owner(id) != Some(r)).map(|_| {
                format!("{name}: rank {r} sent a summary of tile {id}, which it was not granted")
            })
        });
    }
    summaries
        .into_iter()
        .enumerate()
        .map(|(id, s)| {
            s.unwrap_or_else(|| fail(Error::invalid(format!("{name}: tile {id} has no summary"))))
        })
        .collect()
}
