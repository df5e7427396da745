//! Hydrology core: depression filling, D8 flow directions with flats, flow
//! accumulation — in memory on [`Grid`](crate::raster::Grid)s and as exact
//! global passes across tiles ([`tiled`]: `TiledFill`, `TiledD8`,
//! `TiledAccumulation`, each equal to its in-memory counterpart bit for bit).
//!
//! A typical chain: `fill` → `d8_directions` → `accumulate`; tiled:
//! `TiledFill` → `TiledD8` (on the filled DEM) → `TiledAccumulation` (on the
//! directions, read as f32 with 255 declared as nodata). Sinks for D8 output
//! should be u8 with nodata 255 so that the codes round-trip.
//!
//! # Conventions (shared by every function of this module)
//! - **Elevations** are `f32`. A cell is *nodata* when its value is not finite
//!   (NaN, which is how [`read_window`](crate::raster::read_window) delivers a
//!   source's nodata value, and also ±∞). Nodata cells are never filled,
//!   never routed and never counted.
//! - **Outlets**: nodata cells and the area beyond the raster's edge are where
//!   water leaves the DEM. A valid cell is an *outlet cell* when one of its 8
//!   neighbours is nodata or lies beyond the edge. A DEM whose only outlets are
//!   interior nodata holes works the same way as one drained by its edges.
//! - **Connectivity**: 8 neighbours, always visited in the order
//!   E, SE, S, SW, W, NW, N, NE (x grows east, y grows south, row-major
//!   storage). Every tie (equal slopes, equal priorities, several possible
//!   exits) is broken by this order or by the row-major cell index, so every
//!   result is deterministic.
//! - **D8 codes** are the ESRI powers of two used by ArcGIS, GRASS (`r.watershed
//!   -a` style rasters converted), WhiteboxTools (`--esri_pntr`) and TauDEM
//!   users: E=1, SE=2, S=4, SW=8, W=16, NW=32, N=64, NE=128, stored as `u8`;
//!   [`NO_FLOW`] = 0 for a valid cell with nowhere to go (a pit or an
//!   undrainable flat of an unfilled DEM) and [`NODATA_DIR`] = 255 for nodata.
//!   An outlet cell with no lower neighbour points at its first nodata or
//!   off-raster neighbour (in the order above): its water leaves the DEM.

pub mod accum;
pub mod areas;
pub mod basin_metrics;
pub mod basins;
pub mod breach;
pub mod depressions;
pub mod dinf;
pub mod fill;
pub mod fill_nodata;
pub mod fill_zhou;
pub mod flow;
pub mod indices;
pub mod mfd;
pub mod rho8;
pub mod streams;
pub mod tiled;
pub mod tiled_breach;
pub mod tiled_flats;
pub mod tiled_labels;
pub mod tiled_mfd;

pub use accum::{accumulate, accumulate_weighted, WEIGHT_SCALE_BITS};
pub use basins::{basin_labels, hand, watersheds};
pub use breach::{breach, breach_masked, BreachMethod, BreachOptions};
pub use fill::{fill, fill_epsilon, watershed_labels};
pub use flow::{d8_directions, d8_directions_on};
pub use rho8::rho8_directions;

/// The output nodata rule of elevation outputs, now [`crate::exec::output`].
pub use crate::exec::output as out_nodata;
pub use crate::exec::output::FILL_NODATA;
/// Nodata of flow-accumulation outputs (f64; every real value is at least 0).
pub const ACCUMULATION_NODATA: f64 = -1.0;
/// The D8 codes (ESRI powers of two, [`NO_FLOW`], [`NODATA_DIR`]) are those
/// of the flow graph's D8-code router.
pub use crate::flow::{code_to_dir, D8_CODES, NODATA_DIR, NO_FLOW};
pub use crate::raster::neighbours::{DX, DY};

/// True for cells that carry an elevation (finite values).
#[inline]
pub(crate) fn valid(z: f32) -> bool {
    z.is_finite()
}

/// Order-preserving map of a finite (or infinite) f32 onto u32, so that the
/// priority queues compare integers: negative values have all bits flipped,
/// non-negative ones get the sign bit set (IEEE 754 total order).
#[inline]
pub(crate) fn order_key(z: f32) -> u32 {
    let b = z.to_bits();
    if b & 0x8000_0000 != 0 {
        !b
    } else {
        b | 0x8000_0000
    }
}

/// The next representable f32 above `z` (finite `z`; `f32::MAX` gives +∞),
/// by integer manipulation of the IEEE 754 bits (Rust's `f32::next_up` needs
/// a newer toolchain than the crate's MSRV).
#[inline]
#[allow(dead_code)] // the library steps by many ULPs at once (fill::next_up_n)
pub(crate) fn next_up(z: f32) -> f32 {
    if z.is_nan() || z == f32::INFINITY {
        return z;
    }
    if z == 0.0 {
        // both +0 and -0 step to the smallest positive subnormal
        return f32::from_bits(1);
    }
    let b = z.to_bits();
    if z > 0.0 {
        f32::from_bits(b + 1)
    } else {
        f32::from_bits(b - 1)
    }
}

/// For each cell of a `w` x `h` elevation array: is it a valid outlet cell
/// (a neighbour is nodata or beyond the array's edge)?
pub(crate) fn outlet_cells(z: &[f32], w: usize, h: usize) -> Vec<bool> {
    let mut out = vec![false; z.len()];
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            if !valid(z[i]) {
                continue;
            }
            if x == 0 || y == 0 || x + 1 == w || y + 1 == h {
                out[i] = true;
                continue;
            }
            for d in 0..8 {
                let n = ((y as i64 + DY[d]) as usize) * w + (x as i64 + DX[d]) as usize;
                if !valid(z[n]) {
                    out[i] = true;
                    break;
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn order_key_is_monotone() {
        let v = [
            f32::NEG_INFINITY,
            -1e30,
            -2.5,
            -1e-40,
            -0.0,
            0.0,
            1e-40,
            1.0,
            3.0e38,
            f32::INFINITY,
        ];
        for p in v.windows(2) {
            assert!(order_key(p[0]) <= order_key(p[1]), "{p:?}");
        }
        assert!(order_key(-2.5) < order_key(-1e-40));
    }

    #[test]
    fn next_up_is_the_next_float() {
        for z in [-3.5f32, -1e-45, -0.0, 0.0, 1e-45, 1.0, 12345.678, -7e20] {
            let u = next_up(z);
            assert!(u > z, "{z} -> {u}");
            // nothing lies strictly between z and u: the midpoint in f64 rounds to one of them
            let mid = ((z as f64 + u as f64) / 2.0) as f32;
            assert!(mid == z || mid == u);
        }
        assert_eq!(next_up(f32::MAX), f32::INFINITY);
        assert_eq!(next_up(1.0), 1.0 + f32::EPSILON);
    }

    #[test]
    fn codes_round_trip() {
        for (d, &c) in D8_CODES.iter().enumerate() {
            assert_eq!(code_to_dir(c), Some(d));
        }
        assert_eq!(code_to_dir(0), None);
        assert_eq!(code_to_dir(255), None);
        assert_eq!(code_to_dir(3), None);
    }
}
