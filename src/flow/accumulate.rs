//! Accumulation over a flow graph: each cell's value becomes its own plus
//! that of every cell upstream of it, by one pass over the stack in reverse
//! (donors before receivers; Braun & Willett 2013, §2.3, the drainage area
//! as the sum over the stack taken backwards). O(n).
//!
//! With integer or fixed-point values (cell counts, fixed-point weights)
//! the sums are exact, so they do not depend on the order of the additions:
//! any stack of the same receivers, and any tiling of the same pass, gives
//! the same bits.

use super::float::FlowFloat;
use super::graph::FlowGraph;
use crate::error::{Error, Result};

/// A value accumulated downstream.
pub trait Flux: Copy {
    /// `self + o`, or `None` when the sum leaves the type's range.
    fn add(self, o: Self) -> Option<Self>;
}

impl Flux for u64 {
    #[inline]
    fn add(self, o: Self) -> Option<Self> {
        self.checked_add(o)
    }
}
impl Flux for i128 {
    #[inline]
    fn add(self, o: Self) -> Option<Self> {
        self.checked_add(o)
    }
}
impl Flux for f64 {
    #[inline]
    fn add(self, o: Self) -> Option<Self> {
        Some(self + o)
    }
}

impl<T: FlowFloat> FlowGraph<T> {
    /// Accumulate `acc` (each cell's own contribution on entry, one value
    /// per raster cell) downstream along the stack. Cells off the stack are
    /// left untouched. Errors when an integer sum overflows.
    pub fn accumulate<A: Flux>(&self, acc: &mut [A]) -> Result<()> {
        if acc.len() != self.rec.len() {
            return Err(Error::invalid(format!(
                "flow accumulation: {} values for a flow graph of {} cells",
                acc.len(),
                self.rec.len()
            )));
        }
        for &c in self.stack().iter().rev() {
            let c = c as usize;
            let r = self.rec[c] as usize;
            if r != c {
                acc[r] = acc[r].add(acc[c]).ok_or_else(|| {
                    Error::invalid("flow accumulation overflowed its integer range")
                })?;
            }
        }
        Ok(())
    }
}
