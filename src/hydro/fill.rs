//! Depression filling by Priority-Flood.
//!
//! Barnes, R., Lehman, C., Mulla, D. (2014). "Priority-Flood: An Optimal
//! Depression-Filling and Watershed-Labeling Algorithm for Digital Elevation
//! Models". Computers & Geosciences 62, 117–127.
//! - [`fill`]: Algorithm 2, "Improved Priority-Flood": a priority queue for
//!   cells above the current water level plus a plain FIFO for cells inside a
//!   depression (they are raised to the level of the cell that reached them).
//! - [`fill_epsilon`]: Algorithm 3, each cell raised to the next representable
//!   f32 above the cell that reached it, so every cell drains strictly.
//! - [`watershed_labels`]: Algorithm 4/5, the label of the outlet cell each
//!   cell drains to.
//!
//! The filled elevation of a cell is the minimax over all 8-connected paths to
//! an outlet cell (see the module conventions in [`crate::hydro`]) of the
//! highest elevation along the path; outlet cells keep their own elevation.
//! Priority ties are broken by the cell's row-major index, so labels and
//! epsilon-filled values are deterministic.
//!
//! Peer check (`tools/richdem_compare.py`): [`fill`] equals RichDEM 0.3.4's
//! `FillDepressions` bit for bit on DEMs without nodata (bigtujunga 1197x643,
//! SRTM3 S33W071 and qgis_dem25, lidar_dem). RichDEM does not treat nodata
//! cells as outlets and floods them, so on DEMs with voids its surface is
//! higher near the voids (SRTM3 N46E008: 2170 cells) — the documented
//! convention difference.

use super::{next_up, order_key, outlet_cells, valid, DX, DY};
use crate::error::{Error, Result};
use crate::raster::Grid;
use std::cmp::Reverse;
use std::collections::{BinaryHeap, VecDeque};

/// Label of "not reached yet" in [`flood_labelled`]'s label array.
pub(crate) const UNLABELLED: u32 = 0;

/// Improved Priority-Flood (Barnes et al. 2014, Alg. 2) with label propagation
/// (Alg. 4): `z` (row-major `w` x `h`) is filled in place; `labels[i]` must be
/// non-zero exactly for the seed cells, which are processed first in the order
/// of `seeds` for equal elevations (ties by index); every reached cell takes
/// the label of the cell that reached it. `on_spill(a, b, e)` is called for
/// each pair of adjacent cells with different labels `a` (cell being
/// processed) and `b`, with `e` the higher of their filled elevations — the
/// spill graph of Barnes (2016). Nodata cells are never touched.
pub(crate) fn flood_labelled(
    z: &mut [f32],
    w: usize,
    h: usize,
    labels: &mut [u32],
    seeds: &[usize],
    mut on_spill: impl FnMut(u32, u32, f32),
) {
    debug_assert_eq!(z.len(), w * h);
    debug_assert_eq!(labels.len(), w * h);
    debug_assert!(z.len() <= MAX_CELLS);
    // Priority = order key of the elevation in the high 32 bits, cell index
    // (the deterministic tie-break) in the low 32 bits: one u64 compare.
    let mut open: BinaryHeap<Reverse<u64>> = BinaryHeap::with_capacity(seeds.len());
    let mut pit: VecDeque<usize> = VecDeque::new();
    for &s in seeds {
        open.push(Reverse(pack(z[s], s)));
    }
    let mut nb = [0usize; 8];
    loop {
        let c = if let Some(c) = pit.pop_front() {
            c
        } else if let Some(Reverse(k)) = open.pop() {
            (k & 0xFFFF_FFFF) as usize
        } else {
            break;
        };
        let zc = z[c];
        let lc = labels[c];
        let count = neighbours(c, w, h, &mut nb);
        for &n in &nb[..count] {
            let zn = z[n];
            if !valid(zn) {
                continue;
            }
            let ln = labels[n];
            if ln != UNLABELLED {
                if ln != lc {
                    on_spill(lc, ln, if zn > zc { zn } else { zc });
                }
                continue;
            }
            labels[n] = lc;
            if zn <= zc {
                z[n] = zc;
                pit.push_back(n);
            } else {
                open.push(Reverse(pack(zn, n)));
            }
        }
    }
}

/// Largest grid (cells) the in-memory floods handle: indices fit in 32 bits.
pub(crate) const MAX_CELLS: usize = 1 << 32;

fn too_many(w: usize, h: usize) -> Result<()> {
    if w.checked_mul(h).is_none_or(|n| n > MAX_CELLS) {
        return Err(Error::invalid(format!(
            "{w}x{h} cells is more than the in-memory fill handles (2^32); use the tiled fill"
        )));
    }
    Ok(())
}

#[inline]
fn pack(z: f32, i: usize) -> u64 {
    ((order_key(z) as u64) << 32) | i as u64
}

/// Indices of the in-grid neighbours of cell `c` in E..NE order; returns
/// how many were written. Interior cells skip the bounds checks.
#[inline(always)]
pub(crate) fn neighbours(c: usize, w: usize, h: usize, out: &mut [usize; 8]) -> usize {
    let (x, y) = (c % w, c / w);
    if x > 0 && y > 0 && x + 1 < w && y + 1 < h {
        *out = [
            c + 1,
            c + w + 1,
            c + w,
            c + w - 1,
            c - 1,
            c - w - 1,
            c - w,
            c - w + 1,
        ];
        return 8;
    }
    let mut k = 0;
    for d in 0..8 {
        let nx = x as i64 + DX[d];
        let ny = y as i64 + DY[d];
        if nx >= 0 && ny >= 0 && nx < w as i64 && ny < h as i64 {
            out[k] = ny as usize * w + nx as usize;
            k += 1;
        }
    }
    k
}

/// Fill all depressions of `dem` (NaN/±∞ = nodata): every valid cell is
/// raised to the lowest level from which water can reach an outlet.
/// Barnes et al. (2014), Algorithm 2 (Improved Priority-Flood). Errors only
/// for grids of more than 2^32 cells (use [`super::tiled::TiledFill`]).
pub fn fill(dem: &Grid<f32>) -> Result<Grid<f32>> {
    let (w, h) = (dem.width(), dem.height());
    too_many(w, h)?;
    let mut z = dem.data().to_vec();
    let outlets = outlet_cells(&z, w, h);
    let mut labels = vec![UNLABELLED; z.len()];
    let mut seeds = Vec::new();
    for (i, &o) in outlets.iter().enumerate() {
        if o {
            labels[i] = 1;
            seeds.push(i);
        }
    }
    flood_labelled(&mut z, w, h, &mut labels, &seeds, |_, _, _| {});
    // Nodata cells are returned as NaN whatever non-finite value they held.
    for v in z.iter_mut() {
        if !valid(*v) {
            *v = f32::NAN;
        }
    }
    Grid::from_vec(w, h, z)
}

/// Watershed labels (Barnes et al. 2014, Algorithms 4/5): each outlet cell
/// gets its own label, 1, 2, … in row-major order, and every valid cell the
/// label of the outlet its water leaves the DEM through after filling
/// (0 = nodata). Returns the labels and the filled DEM. Errors for grids of
/// more than 2^32 cells.
pub fn watershed_labels(dem: &Grid<f32>) -> Result<(Grid<u32>, Grid<f32>)> {
    let (w, h) = (dem.width(), dem.height());
    too_many(w, h)?;
    let mut z = dem.data().to_vec();
    let outlets = outlet_cells(&z, w, h);
    let mut labels = vec![UNLABELLED; z.len()];
    let mut seeds = Vec::new();
    let mut next = 1u32;
    for (i, &o) in outlets.iter().enumerate() {
        if o {
            labels[i] = next;
            next = next.wrapping_add(1).max(1);
            seeds.push(i);
        }
    }
    flood_labelled(&mut z, w, h, &mut labels, &seeds, |_, _, _| {});
    for v in z.iter_mut() {
        if !valid(*v) {
            *v = f32::NAN;
        }
    }
    Ok((Grid::from_vec(w, h, labels)?, Grid::from_vec(w, h, z)?))
}

/// Fill depressions so that every valid cell that is not an outlet cell has a
/// strictly lower neighbour on a path to an outlet: Barnes et al. (2014),
/// Algorithm 3 ("Priority-Flood+ε"), each cell raised to the next
/// representable f32 above the cell that reached it (the smallest possible
/// epsilon, so the surface stays within a few ULPs of [`fill`] per cell of
/// flat). Errors if a cell would have to rise above `f32::MAX`.
pub fn fill_epsilon(dem: &Grid<f32>) -> Result<Grid<f32>> {
    let (w, h) = (dem.width(), dem.height());
    too_many(w, h)?;
    let mut z = dem.data().to_vec();
    let outlets = outlet_cells(&z, w, h);
    let mut closed = vec![false; z.len()];
    let mut open: BinaryHeap<Reverse<u64>> = BinaryHeap::new();
    let mut pit: VecDeque<usize> = VecDeque::new();
    for (i, &o) in outlets.iter().enumerate() {
        if o {
            closed[i] = true;
            open.push(Reverse(pack(z[i], i)));
        }
    }
    let mut nb = [0usize; 8];
    let mut overflow = false;
    loop {
        // Alg. 3: a queued cell at the same elevation as the pit front goes
        // first, so that it is not raised needlessly by the pit.
        let idx = |k: u64| (k & 0xFFFF_FFFF) as usize;
        let c = match (pit.front(), open.peek()) {
            (Some(&p), Some(Reverse(k))) if (*k >> 32) as u32 == order_key(z[p]) => {
                open.pop().map(|Reverse(k)| idx(k))
            }
            (Some(_), _) => pit.pop_front(),
            (None, _) => open.pop().map(|Reverse(k)| idx(k)),
        };
        let Some(c) = c else { break };
        let up = next_up(z[c]);
        let count = neighbours(c, w, h, &mut nb);
        for &n in &nb[..count] {
            if closed[n] || !valid(z[n]) {
                continue;
            }
            closed[n] = true;
            if z[n] <= up {
                if up == f32::INFINITY {
                    overflow = true;
                }
                z[n] = up;
                pit.push_back(n);
            } else {
                open.push(Reverse(pack(z[n], n)));
            }
        }
    }
    if overflow {
        return Err(Error::invalid(
            "epsilon fill: a depression reaches f32::MAX and cannot be raised further; \
             rescale the elevations",
        ));
    }
    for v in z.iter_mut() {
        if !valid(*v) {
            *v = f32::NAN;
        }
    }
    Grid::from_vec(w, h, z)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn g(w: usize, h: usize, v: &[f32]) -> Grid<f32> {
        Grid::from_vec(w, h, v.to_vec()).unwrap()
    }

    #[test]
    fn fills_a_single_pit_to_its_rim() {
        #[rustfmt::skip]
        let d = g(3, 3, &[
            5.0, 5.0, 5.0,
            5.0, 1.0, 4.0,
            5.0, 5.0, 5.0]);
        let f = fill(&d).unwrap();
        assert_eq!(f.get(1, 1), 4.0);
        assert_eq!(f.get(2, 1), 4.0);
        assert_eq!(f.get(0, 0), 5.0);
    }

    #[test]
    fn epsilon_fill_steps_up_by_one_ulp() {
        #[rustfmt::skip]
        let d = g(4, 3, &[
            9.0, 9.0, 9.0, 9.0,
            9.0, 1.0, 1.0, 2.0,
            9.0, 9.0, 9.0, 9.0]);
        let f = fill_epsilon(&d).unwrap();
        assert_eq!(f.get(3, 1), 2.0);
        assert_eq!(f.get(2, 1), next_up(2.0));
        assert_eq!(f.get(1, 1), next_up(next_up(2.0)));
    }

    #[test]
    fn epsilon_fill_overflow_is_an_error() {
        let d = g(
            3,
            3,
            &[
                f32::MAX,
                f32::MAX,
                f32::MAX,
                f32::MAX,
                0.0,
                f32::MAX,
                f32::MAX,
                f32::MAX,
                f32::MAX,
            ],
        );
        assert!(fill_epsilon(&d).is_err());
    }

    #[test]
    fn watershed_labels_follow_outlets() {
        // two valleys draining west and east, divide in the middle column
        #[rustfmt::skip]
        let d = g(5, 3, &[
            9.0, 9.0, 9.0, 9.0, 9.0,
            1.0, 2.0, 8.0, 2.0, 0.5,
            9.0, 9.0, 9.0, 9.0, 9.0]);
        let (l, _) = watershed_labels(&d).unwrap();
        let west = l.get(0, 1);
        let east = l.get(4, 1);
        assert_ne!(west, east);
        assert_eq!(l.get(1, 1), west);
        assert_eq!(l.get(3, 1), east);
    }
}
