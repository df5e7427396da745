//! Depression filling by Priority-Flood.
//!
//! Barnes, R., Lehman, C., Mulla, D. (2014). "Priority-Flood: An Optimal
//! Depression-Filling and Watershed-Labeling Algorithm for Digital Elevation
//! Models". Computers & Geosciences 62, 117–127.
//! - [`fill_reference`]: Algorithm 2, "Improved Priority-Flood": a priority queue for
//!   cells above the current water level plus a plain FIFO for cells inside a
//!   depression (they are raised to the level of the cell that reached them).
//! - [`fill`]: the same surface by the region-growing variant of Zhou, Sun &
//!   Fu (2016), see [`super::fill_zhou`].
//! - [`fill_epsilon`] / [`epsilon_surface`]: a strictly draining surface in
//!   the spirit of Algorithm 3 (Priority-Flood+ε), redefined so that it does
//!   not depend on flood order and has an exact tiled form
//!   ([`super::tiled::TiledEpsilon`]); see [`epsilon_surface`].
//! - [`watershed_labels`]: the outlet cell each cell's water leaves the DEM
//!   through, following the D8 directions of the filled DEM (canonical
//!   numbering: row-major index of that outlet + 1), equal to the tiled
//!   [`super::tiled::TiledLabels`].
//!
//! The filled elevation of a cell is the minimax over all 8-connected paths to
//! an outlet cell (see the module conventions in [`crate::hydro`]) of the
//! highest elevation along the path; outlet cells keep their own elevation.
//! Priority ties are broken by the cell's row-major index, so the flood is
//! deterministic.
//!
//! Peer check (`tools/richdem_compare.py`): [`fill`] equals RichDEM 0.3.4's
//! `FillDepressions` bit for bit on DEMs without nodata (bigtujunga 1197x643,
//! SRTM3 S33W071 and qgis_dem25, lidar_dem). RichDEM does not treat nodata
//! cells as outlets and floods them, so on DEMs with voids its surface is
//! higher near the voids (SRTM3 N46E008: 2170 cells) — the documented
//! convention difference.

use super::{order_key, outlet_cells, valid, DX, DY, NODATA_DIR, NO_FLOW};
use crate::error::{Error, Result};
use crate::raster::neighbours::CellGeometry;
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
/// Region-growing Priority-Flood of Zhou, Sun & Fu (2016)
/// ([`super::fill_zhou`]); equal bit for bit to [`fill_reference`] (the
/// filled surface is unique) and faster, since most cells bypass the
/// priority queue. Errors only for grids of more than 2^32 cells (use
/// [`super::tiled::TiledFill`]).
pub fn fill(dem: &Grid<f32>) -> Result<Grid<f32>> {
    let (w, h) = (dem.width(), dem.height());
    too_many(w, h)?;
    let mut z = dem.data().to_vec();
    if !super::fill_zhou::fill_in_place(&mut z, w, h) {
        // the padded array would not fit u32 indices: the plain flood
        return fill_reference(dem);
    }
    // Nodata cells are returned as NaN whatever non-finite value they held.
    for v in z.iter_mut() {
        if !valid(*v) {
            *v = f32::NAN;
        }
    }
    Grid::from_vec(w, h, z)
}

/// Fill all depressions of `dem` (NaN/±∞ = nodata): every valid cell is
/// raised to the lowest level from which water can reach an outlet.
/// Barnes et al. (2014), Algorithm 2 (Improved Priority-Flood): the
/// implementation [`fill`] used before Zhou et al.'s variant, kept as the
/// oracle of its tests and for comparison. Errors only for grids of more
/// than 2^32 cells (use [`super::tiled::TiledFill`]).
pub fn fill_reference(dem: &Grid<f32>) -> Result<Grid<f32>> {
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

/// Watershed labels: every valid cell gets the label of the outlet cell its
/// water leaves the DEM through, following the D8 directions
/// ([`super::d8_directions`], flats drained after Barnes, Lehman & Mulla
/// 2014) of the filled DEM ([`fill`]); 0 = nodata. Labels are canonical:
/// the row-major index of that outlet cell plus 1 (see
/// [`super::flow::outlet_labels`]), so the tiled
/// [`super::tiled::TiledLabels`] gives the same numbers.
///
/// This differs from the flood labels of Barnes et al. (2014, Alg. 4/5),
/// where a cell takes the label of whichever outlet's flood reaches it first:
/// on a filled flat that choice depends on flood order, which a tiled run
/// cannot reproduce; D8 paths are a property of the surface. Returns the
/// labels and the filled DEM. Errors for grids of 2^32 cells or more.
pub fn watershed_labels(dem: &Grid<f32>) -> Result<(Grid<u32>, Grid<f32>)> {
    let f = fill(dem)?;
    let labels = super::flow::outlet_labels(&super::flow::d8_directions(&f))?;
    Ok((labels, f))
}

/// `next_up` applied `k` times (finite `z`; ±0 step to the smallest
/// subnormal as in [`super::next_up`]), in O(1): the IEEE 754 order keys of
/// consecutive floats are consecutive integers, with −0 and +0 merged.
/// Returns +∞ past `f32::MAX`.
pub(crate) fn next_up_n(z: f32, k: u32) -> f32 {
    if k == 0 || !z.is_finite() {
        return z;
    }
    let b = z.to_bits();
    // merged key: +0 and -0 both 0x8000_0000
    let key: u64 = if b & 0x8000_0000 != 0 {
        (!b) as u64 + 1
    } else {
        (b | 0x8000_0000) as u64
    };
    let r = key + k as u64;
    if r > 0xFF7F_FFFF {
        f32::INFINITY
    } else if r > 0x8000_0000 {
        f32::from_bits((r & 0x7FFF_FFFF) as u32)
    } else if r == 0x8000_0000 {
        // landed on zero: only reachable from below, as next_up gives -0
        -0.0
    } else {
        f32::from_bits(!((r - 1) as u32))
    }
}

pub(crate) fn not_filled((x, y): (i64, i64)) -> Error {
    Error::invalid(format!(
        "epsilon fill: cell ({x}, {y}) lies in a flat or pit with no drainage; the input \
         must be a filled DEM (the output of fill)"
    ))
}

pub(crate) fn eps_overflow((x, y): (i64, i64)) -> Error {
    Error::invalid(format!(
        "epsilon fill: cell ({x}, {y}) would have to rise above f32::MAX; rescale the elevations"
    ))
}

pub(crate) fn eps_too_wide((x, y): (i64, i64), z: f32) -> Error {
    Error::invalid(format!(
        "epsilon fill: cell ({x}, {y}) at {z} would lose its strictly lower neighbour: the flat \
         below it is so wide that its epsilon rise reaches this level at f32 resolution; \
         use fill and flow (flats drained without epsilon) instead"
    ))
}

/// Fill depressions so that every valid cell that is not an outlet cell has a
/// strictly lower neighbour: `epsilon_surface(fill(dem))`. Errors as
/// [`epsilon_surface`], and for grids of more than 2^32 cells.
pub fn fill_epsilon(dem: &Grid<f32>) -> Result<Grid<f32>> {
    epsilon_surface(&fill(dem)?)
}

/// The epsilon surface of a filled DEM (the output of [`fill`]): every valid
/// cell becomes `next_up^k(F)`, with `F` its fill level and `k` its
/// geodesic (8-connected, unit-step) distance inside its flat to the flat's
/// draining edge — a *flat* being a connected set of cells of equal level
/// without a lower neighbour that are not outlet cells, its draining edge the
/// cells of the same level next to it that drain (`k` = the towards-lower
/// distance of Barnes, Lehman & Mulla 2014, minus one). Cells outside flats
/// keep their level. Each flat cell thus has a neighbour exactly one ULP-step
/// lower towards the exit, so the surface drains strictly.
///
/// Differences from RichDEM's Priority-Flood+ε (Barnes et al. 2014, Alg. 3),
/// where a cell is one ULP above the cell that reached it in flood order:
/// the rise depends only on the distance to the exit, not on the order in
/// which the flood happened to reach the flat (so the tiled form
/// [`super::tiled::TiledEpsilon`] can equal it bit for bit), and it is the
/// smallest such rise along shortest paths. When a wide flat's rise
/// `k` ULPs reaches the level of terrain draining into it (f32 spacing near
/// `F` times `k` ≥ the step to the next level: e.g. 164 cells for a 1 cm step
/// at 1000 m), Alg. 3 silently raises that terrain too; here that terrain
/// would lose its strictly lower neighbour, and the function returns an
/// error instead (the surface returned is always strictly draining). Errors
/// also if a cell would rise above `f32::MAX`, or if the input has a flat or
/// pit without drainage (it was not filled).
pub fn epsilon_surface(filled: &Grid<f32>) -> Result<Grid<f32>> {
    let (w, h) = (filled.width(), filled.height());
    too_many(w, h)?;
    let z = filled.data();
    // only which cells drain matters here, not where: square distances
    let codes = super::flow::steepest_descent(z, w, h, &CellGeometry::square());
    let n = z.len();
    const UNSET: u32 = u32::MAX;
    // k: breadth-first distance over NO_FLOW cells from the draining edge
    let mut k = vec![UNSET; n];
    let mut cur = Vec::new();
    let mut nb = [0usize; 8];
    for c in 0..n {
        if codes[c] != NO_FLOW {
            continue;
        }
        let cnt = neighbours(c, w, h, &mut nb);
        if nb[..cnt]
            .iter()
            .any(|&m| codes[m] != NO_FLOW && codes[m] != NODATA_DIR && z[m] == z[c])
        {
            k[c] = 1;
            cur.push(c);
        }
    }
    let mut level = 1u32;
    let mut nxt = Vec::new();
    while !cur.is_empty() {
        level += 1;
        for &c in &cur {
            let cnt = neighbours(c, w, h, &mut nb);
            for &m in &nb[..cnt] {
                if codes[m] == NO_FLOW && k[m] == UNSET {
                    k[m] = level;
                    nxt.push(m);
                }
            }
        }
        std::mem::swap(&mut cur, &mut nxt);
        nxt.clear();
    }
    let pos = |c: usize| ((c % w.max(1)) as i64, (c / w.max(1)) as i64);
    let mut e = vec![f32::NAN; n];
    for c in 0..n {
        if !valid(z[c]) {
            continue;
        }
        let kc = if codes[c] == NO_FLOW {
            if k[c] == UNSET {
                return Err(not_filled(pos(c)));
            }
            k[c]
        } else {
            0
        };
        e[c] = next_up_n(z[c], kc);
        if e[c] == f32::INFINITY {
            return Err(eps_overflow(pos(c)));
        }
    }
    let outlets = outlet_cells(z, w, h);
    for c in 0..n {
        if !valid(z[c]) || codes[c] == NO_FLOW || outlets[c] {
            continue;
        }
        let cnt = neighbours(c, w, h, &mut nb);
        if !nb[..cnt].iter().any(|&m| e[m] < z[c]) {
            return Err(eps_too_wide(pos(c), z[c]));
        }
    }
    Grid::from_vec(w, h, e)
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
        assert_eq!(f.get(2, 1), super::super::next_up(2.0));
        assert_eq!(
            f.get(1, 1),
            super::super::next_up(super::super::next_up(2.0))
        );
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
    fn next_up_n_equals_iterated_next_up() {
        for z in [
            -3.5f32, -4e-45, -1e-45, -0.0, 0.0, 1e-45, 1.0, 12345.678, -7e20,
        ] {
            let mut it = z;
            for k in 0..40u32 {
                let got = next_up_n(z, k);
                assert_eq!(got.to_bits(), it.to_bits(), "{z} + {k}");
                it = super::super::next_up(it);
            }
        }
        assert_eq!(next_up_n(f32::MAX, 1), f32::INFINITY);
        assert_eq!(next_up_n(f32::MAX, 0), f32::MAX);
        assert_eq!(next_up_n(f32::MIN, u32::MAX), f32::INFINITY);
        assert_eq!(next_up_n(1.0, 1 << 23), 2.0);
    }

    #[test]
    fn too_wide_flat_is_an_error_not_a_non_draining_surface() {
        // a corridor flat at 1.0 draining west (to 0.5); its far end (k = 4)
        // is the only lower neighbour of a cell at 1.0 + 2 ulp
        let up2 = super::super::next_up(super::super::next_up(1.0));
        let w = 8;
        let mut v = vec![9.0f32; w * 3];
        v[w] = 0.5;
        for x in 1..6 {
            v[w + x] = 1.0;
        }
        v[w + 6] = up2;
        let d = g(w, 3, &v);
        assert_eq!(fill(&d).unwrap(), d, "nothing to fill");
        // one ulp less and it drains
        v[w + 6] = next_up_n(1.0, 5);
        assert!(fill_epsilon(&g(w, 3, &v)).is_ok());
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
        // canonical numbering: row-major index of the outlet cell + 1
        assert_eq!(west, 5 + 1);
        assert_eq!(east, 9 + 1);
        assert_eq!(l.get(1, 1), west);
        assert_eq!(l.get(3, 1), east);
    }
}
