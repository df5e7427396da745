//! The steepest-descent D8 router (O'Callaghan & Mark 1984, "The extraction
//! of drainage networks from digital elevation data", *Computer Vision,
//! Graphics and Image Processing* 28, 323–344), as the stream-power eroder
//! of Braun & Willett (2013) routes: each routed cell drains to the strictly
//! lower 8-neighbour of largest slope `(z_i − z_j) / d_ij` (computed in
//! `f64`), `d_ij` the cell size times 1 or √2
//! ([`DIST`](crate::raster::neighbours::DIST)); on equal slopes the first
//! neighbour in the order E, SE, S, SW, W, NW, N, NE of
//! [`crate::raster::neighbours`] wins. With a cell size of 1 the slopes are
//! bit for bit those of hydrology's D8 directions, so both pick the same
//! neighbour wherever a cell has a lower one.
//!
//! Which cells are routed is given by per-cell flags: [`VALID`] marks the
//! cells of the domain (neighbours without it are never receivers), and a
//! valid cell that also carries [`BASE`] (a base level) is a root, like every
//! cell without [`VALID`].

use super::float::FlowFloat;
use super::graph::FlowGraph;
use crate::raster::neighbours::{DIST, DX, DY};

/// Cell flag: valid (finite) cell, part of the domain.
pub const VALID: u8 = 1;
/// Cell flag: base level (a root: never routed).
pub const BASE: u8 = 2;

/// Row-major index offsets of the 8 neighbours of an interior cell.
#[inline]
pub(super) fn offsets(w: usize) -> [isize; 8] {
    std::array::from_fn(|d| DY[d] as isize * w as isize + DX[d] as isize)
}

/// Neighbour `d` of cell `(x, y)` in a `w` x `h` raster, or `None` beyond it.
#[inline]
pub(super) fn neighbour(x: usize, y: usize, d: usize, w: usize, h: usize) -> Option<usize> {
    let (nx, ny) = (x as i64 + DX[d], y as i64 + DY[d]);
    if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
        None
    } else {
        Some(ny as usize * w + nx as usize)
    }
}

/// Distance to each neighbour for cells of `cell` units (E..NE).
#[inline]
pub(super) fn step_lengths(cell: f64) -> [f64; 8] {
    std::array::from_fn(|d| cell * DIST[d])
}

/// The steepest strictly lower valid neighbour of the interior-or-border
/// cell `i = (x, y)` on `z`: `(receiver, distance)`, or `(i, 0)` when there
/// is none. `lower` is set when some valid neighbour is strictly lower.
#[inline]
pub(super) fn steepest_of<T: FlowFloat>(
    z: &[T],
    flags: &[u8],
    (x, y, w, h): (usize, usize, usize, usize),
    off: &[isize; 8],
    len: &[f64; 8],
) -> (usize, f64, bool) {
    let i = y * w + x;
    let zi = z[i].to_f64();
    let mut best = 0.0;
    let mut bj = i;
    let mut bd = 0.0;
    let mut lower = false;
    let interior = x > 0 && y > 0 && x + 1 < w && y + 1 < h;
    for d in 0..8 {
        let j = if interior {
            (i as isize + off[d]) as usize
        } else {
            match neighbour(x, y, d, w, h) {
                Some(j) => j,
                None => continue,
            }
        };
        if flags[j] & VALID == 0 {
            continue;
        }
        let zj = z[j].to_f64();
        lower |= zj < zi;
        let s = (zi - zj) / len[d];
        if s > best {
            best = s;
            bj = j;
            bd = len[d];
        }
    }
    (bj, bd, lower)
}

/// Route every cell of `g` by steepest descent on `z` (cells of `cell`
/// units; see the module documentation). Cells whose flags are not exactly
/// [`VALID`] are roots. Returns the number of pits: routed cells without a
/// lower neighbour, left as roots.
pub fn route_steepest<T: FlowFloat>(
    g: &mut FlowGraph<T>,
    z: &[T],
    flags: &[u8],
    cell: f64,
) -> usize {
    let (w, h) = (g.width(), g.height());
    debug_assert!(z.len() == w * h && flags.len() == w * h);
    let off = offsets(w);
    let len = step_lengths(cell);
    let mut pits = 0;
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            if flags[i] != VALID {
                g.rec[i] = i as u32;
                g.dist[i] = T::default();
                continue;
            }
            let (r, d, _) = steepest_of(z, flags, (x, y, w, h), &off, &len);
            g.rec[i] = r as u32;
            g.dist[i] = T::from_f64(d);
            if r == i {
                pits += 1;
            }
        }
    }
    pits
}
