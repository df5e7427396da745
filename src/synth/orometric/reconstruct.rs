//! Grey-scale reconstruction by dilation of a surface from markers (Vincent
//! 1993, "Morphological grayscale reconstruction in image analysis:
//! applications and efficient algorithms", IEEE TIP 2(2), §III), on any
//! graph: each vertex becomes min(its value, the highest level at which a
//! path joins it to a marker), i.e. every maximum not joined to a marker
//! above its col is cut to that col. Computed by a priority flood from the
//! markers, highest first (Barnes, Lehman & Mulla 2014's queue, turned
//! upside down): O(E log V).

use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// Order key of an f64 (monotone in the value, for the heap).
#[inline]
fn ord(v: f64) -> u64 {
    let b = v.to_bits();
    if b >> 63 == 1 {
        !b
    } else {
        b | (1 << 63)
    }
}

/// The reconstruction of `val` from the vertices with `marker` set;
/// `neighbours(v, buf)` fills `buf` with v's neighbours. Markers keep their
/// value, vertices no path joins to a marker too.
pub fn reconstruct(
    val: &[f64],
    marker: &[bool],
    mut neighbours: impl FnMut(usize, &mut Vec<usize>),
) -> Vec<f64> {
    let n = val.len();
    let mut level = vec![f64::NAN; n];
    let mut heap: BinaryHeap<(u64, Reverse<u32>)> = BinaryHeap::new();
    for v in 0..n {
        if marker[v] {
            level[v] = val[v];
            heap.push((ord(val[v]), Reverse(v as u32)));
        }
    }
    let mut done = vec![false; n];
    let mut buf = Vec::with_capacity(8);
    while let Some((_, Reverse(v))) = heap.pop() {
        let v = v as usize;
        if done[v] {
            continue;
        }
        done[v] = true;
        buf.clear();
        neighbours(v, &mut buf);
        for &u in &buf {
            if done[u] || marker[u] {
                continue;
            }
            let l = val[u].min(level[v]);
            if level[u].is_nan() || l > level[u] {
                level[u] = l;
                heap.push((ord(l), Reverse(u as u32)));
            }
        }
    }
    for (l, &v) in level.iter_mut().zip(val) {
        if l.is_nan() {
            *l = v;
        }
    }
    level
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::oro::stats::SplitMix64;

    /// Oracle: the widest-path values by Bellman-Ford style relaxation
    /// until nothing changes (no heap), on a small 8-connected grid.
    fn brute(val: &[f64], marker: &[bool], w: usize, h: usize) -> Vec<f64> {
        let mut l: Vec<f64> = (0..w * h)
            .map(|i| if marker[i] { val[i] } else { f64::NEG_INFINITY })
            .collect();
        loop {
            let mut changed = false;
            for i in 0..w * h {
                if marker[i] {
                    continue;
                }
                let (c, r) = ((i % w) as i64, (i / w) as i64);
                for dy in -1..=1i64 {
                    for dx in -1..=1i64 {
                        let (cc, rr) = (c + dx, r + dy);
                        if (dx, dy) == (0, 0)
                            || cc < 0
                            || rr < 0
                            || cc >= w as i64
                            || rr >= h as i64
                        {
                            continue;
                        }
                        let cand = val[i].min(l[rr as usize * w + cc as usize]);
                        if cand > l[i] {
                            l[i] = cand;
                            changed = true;
                        }
                    }
                }
            }
            if !changed {
                break;
            }
        }
        l.iter()
            .zip(val)
            .map(|(&x, &v)| if x == f64::NEG_INFINITY { v } else { x })
            .collect()
    }

    #[test]
    fn equals_the_relaxation_oracle_on_random_grids() {
        let mut rng = SplitMix64(7);
        for case in 0..40 {
            let (w, h) = (3 + case % 9, 2 + case % 7);
            let val: Vec<f64> = (0..w * h).map(|_| (rng.unit() * 20.0).floor()).collect();
            let marker: Vec<bool> = (0..w * h).map(|_| rng.unit() < 0.15).collect();
            let got = reconstruct(&val, &marker, |i, buf| {
                let (c, r) = (i % w, i / w);
                for rr in r.saturating_sub(1)..(r + 2).min(h) {
                    for cc in c.saturating_sub(1)..(c + 2).min(w) {
                        if (cc, rr) != (c, r) {
                            buf.push(rr * w + cc);
                        }
                    }
                }
            });
            let want = brute(&val, &marker, w, h);
            assert_eq!(got, want, "case {case}: {w} x {h}");
            // Never raised; markers kept.
            for i in 0..w * h {
                assert!(got[i] <= val[i]);
                if marker[i] {
                    assert_eq!(got[i], val[i]);
                }
            }
        }
    }

    #[test]
    fn a_knoll_is_cut_to_its_col() {
        // 1-D chain: marker 10, col 4, knoll 9, then 2.
        let val = [10.0, 4.0, 9.0, 2.0];
        let marker = [true, false, false, false];
        let got = reconstruct(&val, &marker, |i, buf| {
            if i > 0 {
                buf.push(i - 1);
            }
            if i + 1 < 4 {
                buf.push(i + 1);
            }
        });
        assert_eq!(got, vec![10.0, 4.0, 4.0, 2.0]);
    }
}
