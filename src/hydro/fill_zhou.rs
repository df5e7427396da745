//! Depression filling by the region-growing Priority-Flood variant of
//! Zhou, G., Sun, Z., Fu, S. (2016). "An efficient variant of the
//! Priority-Flood algorithm for filling depressions in raster digital
//! elevation models". Computers & Geosciences 90, 87–96.
//!
//! Barnes et al. (2014, Alg. 2) put every cell that is not inside a
//! depression through the priority queue. Zhou et al. observe that a cell
//! reached from a cell of final level `F` with an elevation `z ≥ F` is final
//! at once (its level is `z`: the path through the reaching cell never goes
//! higher), and so is every cell reached from it uphill; such "slope" cells
//! are grown as a region with a plain stack. Only a slope cell that still has
//! a lower, unreached neighbour enters the priority queue, because that
//! neighbour's level (its own elevation or the slope cell's) can only be
//! decided once the flood has risen to the slope cell's elevation.
//! Depression cells are raised and grown with a second stack as in Barnes.
//!
//! Correctness (the filled surface is unique, so any flood order that keeps
//! the Priority-Flood invariant gives the same bits): every reached cell with
//! an unreached neighbour lower than its level is in the queue or the
//! depression stack; queue keys are never below the current level because
//! region growing only goes uphill from a cell at or above it. When a cell of
//! level `L` is expanded with an empty depression stack, every unreached
//! cell's optimal path to an outlet crosses a queued cell of level ≥ `L`.
//!
//! Implementation: the DEM is copied into an array with a one-cell border of
//! NaN, so that neighbours are fixed index offsets without bounds checks;
//! nodata and the border are marked "reached" from the start; indices are
//! u32; the priority queue is a radix heap on the order-preserving u32
//! elevation keys (flood levels never decrease), sequential and deterministic.

use super::{order_key, valid};

/// Largest padded array (cells) the u32 indices address.
pub(crate) const MAX_PADDED: usize = 1 << 32;

/// Fill the depressions of the `w` x `h` row-major array `z` in place
/// (non-finite = nodata, left untouched; edges and nodata are outlets).
/// Returns `false`, leaving `z` unchanged, when `(w + 2) * (h + 2)` exceeds
/// 2^32 cells (the caller then uses the reference flood).
pub(crate) fn fill_in_place(z: &mut [f32], w: usize, h: usize) -> bool {
    debug_assert_eq!(z.len(), w * h);
    if w == 0 || h == 0 {
        return true;
    }
    let (wp, hp) = (w + 2, h + 2);
    if wp.checked_mul(hp).is_none_or(|n| n > MAX_PADDED) {
        return false;
    }
    let mut zp = vec![f32::NAN; wp * hp];
    for y in 0..h {
        zp[(y + 1) * wp + 1..(y + 1) * wp + 1 + w].copy_from_slice(&z[y * w..(y + 1) * w]);
    }
    flood_padded(&mut zp, wp, hp);
    for y in 0..h {
        z[y * w..(y + 1) * w].copy_from_slice(&zp[(y + 1) * wp + 1..(y + 1) * wp + 1 + w]);
    }
    true
}

/// Monotone priority queue of (u32 key, u32 cell) pairs: a radix heap
/// (Ahuja, Mehlhorn, Orlin & Tarjan 1990, "Faster algorithms for the shortest
/// path problem", J. ACM 37(2), one-level form). Valid because the flood
/// never pushes a key below the last one popped. Bucket `b` holds the
/// entries whose key first differs from the last popped key at bit `b - 1`
/// (bucket 0: equal keys); popping from an empty bucket 0 takes the lowest
/// non-empty bucket, makes its minimum the new reference and redistributes
/// it into lower buckets. Each entry moves at most 32 times, memory is
/// sequential: far fewer cache misses than a binary heap of the same size.
/// Equal keys pop in LIFO order (deterministic; the fill does not depend on
/// it).
struct RadixHeap {
    last: u32,
    len: usize,
    buckets: [Vec<(u32, u32)>; 33],
}

impl RadixHeap {
    fn new() -> Self {
        RadixHeap {
            last: 0,
            len: 0,
            buckets: std::array::from_fn(|_| Vec::new()),
        }
    }

    #[inline(always)]
    fn bucket(&self, k: u32) -> usize {
        (32 - (k ^ self.last).leading_zeros()) as usize
    }

    #[inline(always)]
    fn push(&mut self, k: u32, v: u32) {
        debug_assert!(k >= self.last);
        let b = self.bucket(k);
        self.buckets[b].push((k, v));
        self.len += 1;
    }

    fn pop(&mut self) -> Option<u32> {
        if self.len == 0 {
            return None;
        }
        if self.buckets[0].is_empty() {
            let i = (1..33).find(|&i| !self.buckets[i].is_empty())?;
            let mut b = std::mem::take(&mut self.buckets[i]);
            self.last = b.iter().map(|e| e.0).min()?;
            for &(k, v) in &b {
                let j = self.bucket(k);
                self.buckets[j].push((k, v));
            }
            b.clear();
            self.buckets[i] = b;
        }
        self.len -= 1;
        self.buckets[0].pop().map(|e| e.1)
    }
}

/// The flood on a padded array: `zp` is `wp` x `hp` with a border of
/// non-finite values (at least one cell wide).
fn flood_padded(zp: &mut [f32], wp: usize, hp: usize) {
    let n = zp.len();
    // 1 = reached (or nodata / border: never reached)
    let mut done: Vec<u8> = zp.iter().map(|&v| u8::from(!valid(v))).collect();
    // neighbour offsets in the order E, SE, S, SW, W, NW, N, NE
    let offs: [isize; 8] = [
        1,
        wp as isize + 1,
        wp as isize,
        wp as isize - 1,
        -1,
        -(wp as isize) - 1,
        -(wp as isize),
        -(wp as isize) + 1,
    ];
    let mut heap = RadixHeap::new();
    // seeds: valid cells with a nodata (or border) neighbour
    for y in 1..hp - 1 {
        for x in 1..wp - 1 {
            let i = y * wp + x;
            if done[i] != 0 {
                continue;
            }
            if offs.iter().any(|&o| !valid(zp[(i as isize + o) as usize])) {
                done[i] = 1;
                heap.push(order_key(zp[i]), i as u32);
            }
        }
    }
    debug_assert!(n <= MAX_PADDED);
    let mut pit: Vec<u32> = Vec::new();
    let mut slope: Vec<u32> = Vec::new();
    loop {
        let c = if let Some(c) = pit.pop() {
            c as usize
        } else if let Some(k) = heap.pop() {
            k as usize
        } else {
            break;
        };
        let zc = zp[c];
        for &o in &offs {
            let m = (c as isize + o) as usize;
            if done[m] != 0 {
                continue;
            }
            done[m] = 1;
            let zm = zp[m];
            if zm <= zc {
                zp[m] = zc;
                pit.push(m as u32);
            } else {
                // region growing uphill from m (Zhou et al. 2016)
                slope.push(m as u32);
                while let Some(t) = slope.pop() {
                    let t = t as usize;
                    let zt = zp[t];
                    let mut lower = false;
                    for &p in &offs {
                        let q = (t as isize + p) as usize;
                        if done[q] != 0 {
                            continue;
                        }
                        if zp[q] >= zt {
                            done[q] = 1;
                            slope.push(q as u32);
                        } else {
                            lower = true;
                        }
                    }
                    if lower {
                        heap.push(order_key(zt), t as u32);
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn radix_heap_pops_keys_in_order_under_monotone_pushes() {
        // oracle: a sorted list of the keys still queued
        let mut h = RadixHeap::new();
        let mut keys: Vec<u32> = Vec::new();
        let mut popped = Vec::new();
        let mut key_of = vec![u32::MAX; 5000];
        let mut s = 12345u64;
        let mut last = 0u32;
        for step in 0..5000u32 {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            if (s >> 62) != 0 || keys.is_empty() {
                let k = last + ((s >> 33) as u32 % 1000) * ((s >> 20) as u32 % 3);
                h.push(k, step);
                key_of[step as usize] = k;
                keys.push(k);
            } else {
                let v = h.pop().unwrap();
                keys.sort_unstable();
                let k = keys.remove(0);
                assert_eq!(key_of[v as usize], k, "popped a non-minimum key");
                popped.push((k, v));
                last = k;
            }
        }
        // every popped entry carried the minimum key at its time
        assert!(popped.windows(2).all(|p| p[0].0 <= p[1].0));
        while h.pop().is_some() {
            keys.pop();
        }
        assert!(keys.is_empty());
        assert_eq!(h.len, 0);
    }
}
