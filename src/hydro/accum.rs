//! D8 flow accumulation by topological order.
//!
//! Each cell's accumulation is its own contribution plus that of every cell
//! upstream of it, summed down the D8 codes' flow graph by
//! [`crate::flow::accumulate_d8_codes`] (the graph's fast form for code
//! rasters: in-degree counting, Kahn 1962, "Topological sorting of large
//! networks", CACM 5; the downstream walk of Barnes 2017, "Parallel
//! non-divergent flow accumulation for trillion cell digital elevation
//! models on desktops or clusters", EMS 92, Alg. 1): O(n).
//!
//! Sums are exact integers so that any summation order — in particular the
//! tile-by-tile order of [`super::tiled::TiledAccumulation`] — gives the same
//! bits: cell counts as `u64`, weights as fixed-point `i128` with
//! [`WEIGHT_SCALE_BITS`] fractional bits (each f32 weight rounded to a
//! multiple of 2^-32 ≈ 2.3e-10; the result is converted to f64 once at the
//! end, so weights up to ~10^6 lose nothing compared with f64 sums and
//! large totals are not degraded by rounding at each addition).

use super::{code_to_dir, DX, DY, NODATA_DIR};
use crate::error::{Error, Result};
use crate::flow::accumulate_d8_codes;
use crate::raster::Grid;

/// Fractional bits of the fixed-point weights.
pub const WEIGHT_SCALE_BITS: u32 = 32;
const WEIGHT_SCALE: f64 = (1u64 << WEIGHT_SCALE_BITS) as f64;
/// Largest accepted |weight| (2^62): keeps every sum of up to 2^32 cells in
/// i128 range; larger sums are checked and reported.
const MAX_WEIGHT: f64 = 4.611_686_018_427_388e18;

/// Fixed-point value of a weight; NaN (nodata weight) counts as 0.
pub(crate) fn weight_to_fixed(v: f32) -> Result<i128> {
    if v.is_nan() {
        return Ok(0);
    }
    let f = v as f64;
    if f.is_nan() || f.abs() > MAX_WEIGHT {
        return Err(Error::invalid(format!(
            "flow accumulation weight {v} is out of range (|weight| must be <= 2^62)"
        )));
    }
    Ok((f * WEIGHT_SCALE).round() as i128)
}

/// f64 value of a fixed-point accumulation.
#[inline]
pub(crate) fn fixed_to_f64(v: i128) -> f64 {
    v as f64 / WEIGHT_SCALE
}

/// Receiver of cell (x, y) with code `code` inside a `w` x `h` array:
/// `Ok(Some(n))` in the array, `Ok(None)` no receiver in the array (NO_FLOW,
/// or pointing beyond), `Err(())` for an invalid code.
#[inline]
pub(crate) fn receiver(
    x: usize,
    y: usize,
    code: u8,
    w: usize,
    h: usize,
) -> Result<Option<usize>, ()> {
    if code == 0 {
        return Ok(None);
    }
    let Some(d) = code_to_dir(code) else {
        return Err(());
    };
    let nx = x as i64 + DX[d];
    let ny = y as i64 + DY[d];
    if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
        Ok(None)
    } else {
        Ok(Some(ny as usize * w + nx as usize))
    }
}

pub(crate) use crate::flow::bad_code;

/// An exact accumulator: cell counts in `u64`, fixed-point weights in `i128`.
pub(crate) use crate::flow::Flux as Acc;

/// Core accumulation over a `w` x `h` direction array: `acc` holds each
/// cell's own contribution on entry and its accumulation on exit (nodata
/// cells are left untouched). Flow into nodata or beyond the array is
/// dropped. Returns the topological order (upstream first) of valid cells:
/// the flow graph's stack taken backwards ([`accumulate_d8_codes`]).
pub(crate) fn accumulate_core<A: Acc>(
    dirs: &[u8],
    w: usize,
    h: usize,
    acc: &mut [A],
) -> Result<Vec<u32>> {
    let mut order = Vec::new();
    accumulate_d8_codes(dirs, w, h, acc, Some(&mut order))?;
    Ok(order)
}

/// Number of cells draining through each cell, itself included (0 for nodata).
/// `dirs` are ESRI D8 codes as made by [`super::d8_directions`]; errors on an
/// invalid code or a cycle.
pub fn accumulate(dirs: &Grid<u8>) -> Result<Grid<u64>> {
    let mut acc: Vec<u64> = dirs
        .data()
        .iter()
        .map(|&c| if c == NODATA_DIR { 0 } else { 1 })
        .collect();
    accumulate_d8_codes(dirs.data(), dirs.width(), dirs.height(), &mut acc, None)?;
    Grid::from_vec(dirs.width(), dirs.height(), acc)
}

/// Sum of `weights` over the cells draining through each cell, itself
/// included (NaN for nodata directions; a NaN weight counts as 0). Exact
/// fixed-point summation, see the module docs.
pub fn accumulate_weighted(dirs: &Grid<u8>, weights: &Grid<f32>) -> Result<Grid<f64>> {
    if weights.width() != dirs.width() || weights.height() != dirs.height() {
        return Err(Error::invalid(format!(
            "weights are {}x{} but flow directions are {}x{}",
            weights.width(),
            weights.height(),
            dirs.width(),
            dirs.height()
        )));
    }
    let mut acc = Vec::with_capacity(dirs.len());
    for (&c, &wv) in dirs.data().iter().zip(weights.data()) {
        acc.push(if c == NODATA_DIR {
            0
        } else {
            weight_to_fixed(wv)?
        });
    }
    accumulate_d8_codes(dirs.data(), dirs.width(), dirs.height(), &mut acc, None)?;
    let out = acc
        .iter()
        .zip(dirs.data())
        .map(|(&v, &c)| {
            if c == NODATA_DIR {
                f64::NAN
            } else {
                fixed_to_f64(v)
            }
        })
        .collect();
    Grid::from_vec(dirs.width(), dirs.height(), out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chain_accumulates() {
        // 4 cells flowing east, last one off the edge
        let d = Grid::from_vec(4, 1, vec![1u8, 1, 1, 1]).unwrap();
        assert_eq!(accumulate(&d).unwrap().data(), &[1, 2, 3, 4]);
        let wts = Grid::from_vec(4, 1, vec![0.5f32, 1.0, f32::NAN, 2.0]).unwrap();
        assert_eq!(
            accumulate_weighted(&d, &wts).unwrap().data(),
            &[0.5, 1.5, 1.5, 3.5]
        );
    }

    #[test]
    fn cycles_and_bad_codes_are_errors() {
        let d = Grid::from_vec(2, 1, vec![1u8, 16]).unwrap();
        assert!(accumulate(&d).is_err());
        let d = Grid::from_vec(2, 1, vec![3u8, 0]).unwrap();
        assert!(accumulate(&d).is_err());
    }
}
