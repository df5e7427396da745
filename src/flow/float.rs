//! The two cell types a [`FlowGraph`](super::FlowGraph) is built over: `f32`
//! (hydrology, which stores elevations as `f32`) and `f64` (the eroders).
//! Slopes are always computed in `f64` from the cell values, so an `f32` DEM
//! routes exactly as the same values widened to `f64` would.

use crate::raster::Cell;

/// A floating-point cell value of a flow graph (heights, distances): a
/// [`Cell`] (exact `to_f64`, `from_f64` rounding to nearest) with the two
/// operations the sink resolvers need.
pub trait FlowFloat: Cell {
    /// Negative infinity (the water level of the base-level basin).
    const NEG_INFINITY: Self;
    /// The larger of two values; a NaN operand yields the other one
    /// (IEEE 754 `maxNum`, as `f64::max`).
    fn max(self, o: Self) -> Self;
}

impl FlowFloat for f32 {
    const NEG_INFINITY: Self = f32::NEG_INFINITY;
    #[inline]
    fn max(self, o: Self) -> Self {
        f32::max(self, o)
    }
}

impl FlowFloat for f64 {
    const NEG_INFINITY: Self = f64::NEG_INFINITY;
    #[inline]
    fn max(self, o: Self) -> Self {
        f64::max(self, o)
    }
}

/// Order-preserving map of a finite f64 to u64 (for heap and sort keys):
/// negative values have all bits flipped, others get the sign bit set
/// (IEEE 754 total order).
#[inline]
pub fn order_key(v: f64) -> u64 {
    let b = v.to_bits();
    if b >> 63 == 1 {
        !b
    } else {
        b | (1 << 63)
    }
}
