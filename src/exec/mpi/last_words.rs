//! What rank 0 is waiting for, printed to stderr if the process is ended
//! by SIGTERM, which is how `mpirun` (and Slurm) end the surviving ranks
//! after one rank died: with `mpirun`'s own "process rank R exited on
//! signal 9", it names the dead rank's unfinished tiles. The message lives
//! in a fixed static buffer of atomics and the handler only copies it and
//! calls `write(2)` and `_exit(2)`, both async-signal-safe (POSIX.1-2017,
//! "Signal Concepts", 2.4.3).
//!
//! Also what rank 0 sets as its last words while tiles of a step are out
//! ([`note_pending`]).

use crate::exec::mpi_codec::Queue;
use crate::raster::TileId;
use std::sync::atomic::{AtomicU8, AtomicUsize, Ordering};

const CAP: usize = 2048;
static BUF: [AtomicU8; CAP] = [const { AtomicU8::new(0) }; CAP];
static LEN: AtomicUsize = AtomicUsize::new(0);

/// Replace the message (truncated to the buffer).
pub(super) fn set(msg: &str) {
    LEN.store(0, Ordering::Release);
    let b = msg.as_bytes();
    let n = b.len().min(CAP);
    for (slot, &byte) in BUF.iter().zip(&b[..n]) {
        slot.store(byte, Ordering::Relaxed);
    }
    LEN.store(n, Ordering::Release);
}

/// No message (the handler then just exits).
pub(super) fn clear() {
    LEN.store(0, Ordering::Release);
}

extern "C" fn on_term(sig: libc::c_int) {
    let n = LEN.load(Ordering::Acquire).min(CAP);
    let mut local = [0u8; CAP];
    for (dst, src) in local.iter_mut().zip(BUF.iter()).take(n) {
        *dst = src.load(Ordering::Relaxed);
    }
    // SAFETY: `local` is a live stack buffer of at least `n` bytes;
    // write(2) and _exit(2) are async-signal-safe.
    unsafe {
        if n > 0 {
            libc::write(2, local.as_ptr().cast(), n);
        }
        libc::_exit(128 + sig);
    }
}

/// Install the SIGTERM handler (rank 0, once).
pub(super) fn install() {
    let handler: extern "C" fn(libc::c_int) = on_term;
    // SAFETY: the handler only touches atomics and calls
    // async-signal-safe functions.
    unsafe {
        libc::signal(libc::SIGTERM, handler as libc::sighandler_t);
    }
}

/// Rank 0's last words while tiles are still out: for each rank other
/// than 0, how many tiles it was granted and has not delivered (`left`),
/// naming the first few of them found in `ids[frontier..]` (a bounded
/// look-ahead, so a refresh costs O(ranks), not O(tiles)); `got[k]` says
/// position `k` arrived.
pub(super) fn note_pending(
    step: &str,
    ids: &[TileId],
    q: &Queue,
    got: &[bool],
    frontier: usize,
    left: &[usize],
) {
    let ranks = left.len();
    let mut first: Vec<Vec<String>> = vec![Vec::new(); ranks];
    for k in (frontier..ids.len()).take(64 * ranks.max(1)) {
        if got[k] {
            continue;
        }
        if let Some(f) = q
            .owner(k)
            .and_then(|o| first.get_mut(o))
            .filter(|f| f.len() < 6)
        {
            f.push(ids[k].to_string());
        }
    }
    let mut lines = String::new();
    for r in 1..ranks {
        let n = left[r];
        if n > 0 {
            lines.push_str(&format!(
                "\n  rank {r}: {n} tile(s) granted and not received: {}{}",
                first[r].join(", "),
                if n > first[r].len() { ", ..." } else { "" }
            ));
        }
    }
    let msg = format!(
        "error: MPI rank 0 ended (SIGTERM) during {step}; {}{lines}\nerror: a rank died or the job was cancelled (mpirun names the rank); rerun the same command to resume from the finished tiles of tile-store outputs\n",
        if lines.is_empty() {
            "every other rank had delivered the tiles granted to it"
        } else {
            "still missing from the other ranks:"
        }
    );
    set(&msg);
}
