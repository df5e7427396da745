//! The flow graph: one receiver per cell, the distance to it, and the stack.
//!
//! A single-flow-direction graph in the sense of Braun & Willett (2013, "A
//! very efficient O(n), implicit and parallel method to solve the stream
//! power equation governing fluvial incision and landscape evolution",
//! *Geomorphology* 180–181, 170–179, §2.2–2.3): every cell of the graph has
//! one receiver (itself for a root: a base level, an outlet or an unresolved
//! pit), and the *stack* lists the cells so that every cell comes after its
//! receiver. Walking the stack forwards visits receivers before donors (the
//! implicit erosion); walking it backwards visits donors first (drainage
//! accumulation). Cells outside the graph (nodata of a D8 direction raster)
//! have the receiver [`NONE`] and are not on the stack.
//!
//! The stack is built in O(n) without donor lists by in-degree counting
//! (Kahn 1962, "Topological sorting of large networks", *CACM* 5, 558–562):
//! each cell no other cell drains into starts a walk downstream, in
//! row-major order, that continues while the next cell has received all its
//! inflows (the order of Barnes 2017, "Parallel non-divergent flow
//! accumulation for trillion cell digital elevation models on desktops or
//! clusters", *Environmental Modelling & Software* 92, 202–212, Alg. 1:
//! memory is touched along flow paths). The walk lists donors first; the
//! stack is that list reversed, so it is one of the orders Braun & Willett's
//! depth-first stack may take: every cell after its receiver.
//!
//! Receivers are 8-neighbours (every router of [`super`] makes them so), so
//! a cell has at most 8 donors and the in-degrees fit in a byte.

use super::float::FlowFloat;
use crate::error::{Error, Result};

/// Receiver of a cell outside the graph (not routed, not on the stack).
pub const NONE: u32 = u32::MAX;

/// A single-flow-direction graph over a `width` x `height` raster
/// (row-major cell indices); see the module documentation.
#[derive(Debug, Clone)]
pub struct FlowGraph<T> {
    width: usize,
    height: usize,
    /// Receiver of each cell: itself for a root, [`NONE`] outside the graph.
    pub(super) rec: Vec<u32>,
    /// Distance to the receiver (metres or cell sizes, as the router was
    /// told); 0 for roots and cells outside the graph.
    pub(super) dist: Vec<T>,
    /// The cells of the graph, every cell after its receiver.
    stack: Vec<u32>,
    /// Scratch of [`FlowGraph::build_stack`]: in-degrees.
    indeg: Vec<u8>,
}

impl<T: FlowFloat> FlowGraph<T> {
    /// A graph of `width` x `height` cells, every cell its own root, empty
    /// stack. Errors when the raster has 2^32 - 1 cells or more (cell
    /// indices are `u32`, [`NONE`] excluded).
    pub fn new(width: usize, height: usize) -> Result<FlowGraph<T>> {
        let n = width
            .checked_mul(height)
            .filter(|&n| n < NONE as usize)
            .ok_or_else(|| {
                Error::invalid(format!(
                    "flow graph: {width}x{height} cells is more than a flow graph in memory \
                     indexes (2^32 - 1)"
                ))
            })?;
        Ok(FlowGraph {
            width,
            height,
            rec: (0..n as u32).collect(),
            dist: vec![T::default(); n],
            stack: Vec::with_capacity(n),
            indeg: Vec::new(),
        })
    }

    /// Raster width (cells).
    pub fn width(&self) -> usize {
        self.width
    }
    /// Raster height (cells).
    pub fn height(&self) -> usize {
        self.height
    }
    /// Number of cells of the raster (in the graph or not).
    pub fn len(&self) -> usize {
        self.rec.len()
    }
    /// True for a raster without cells.
    pub fn is_empty(&self) -> bool {
        self.rec.is_empty()
    }
    /// Receiver of each cell (row-major index; a root is its own receiver,
    /// a cell outside the graph has [`NONE`]).
    pub fn receivers(&self) -> &[u32] {
        &self.rec
    }
    /// Distance from each cell to its receiver (0 for roots).
    pub fn distances(&self) -> &[T] {
        &self.dist
    }
    /// The cells of the graph ordered so that every cell comes after its
    /// receiver (valid after [`FlowGraph::build_stack`]).
    pub fn stack(&self) -> &[u32] {
        &self.stack
    }
    /// The stack, taken out of the graph (which keeps an empty one).
    pub fn take_stack(&mut self) -> Vec<u32> {
        std::mem::take(&mut self.stack)
    }

    /// Build the stack from the receivers (see the module documentation).
    /// Returns the number of graph cells left off it because they lie on a
    /// cycle (each cell has one receiver, so nothing lies downstream of a
    /// cycle): 0 for every graph the routers of [`super`] make.
    pub fn build_stack(&mut self) -> usize {
        const DONE: u8 = u8::MAX;
        let n = self.rec.len();
        self.indeg.clear();
        self.indeg.resize(n, 0);
        let mut cells = 0usize;
        for i in 0..n {
            let r = self.rec[i];
            if r == NONE {
                self.indeg[i] = DONE;
                continue;
            }
            cells += 1;
            let r = r as usize;
            if r != i {
                debug_assert!(self.rec[r] != NONE && self.indeg[r] < 8);
                self.indeg[r] += 1;
            }
        }
        self.stack.clear();
        self.stack.resize(cells, 0);
        let mut pos = cells;
        for c0 in 0..n {
            if self.indeg[c0] != 0 {
                continue;
            }
            let mut c = c0;
            loop {
                self.indeg[c] = DONE;
                pos -= 1;
                self.stack[pos] = c as u32;
                let r = self.rec[c] as usize;
                if r == c {
                    break;
                }
                self.indeg[r] -= 1;
                if self.indeg[r] != 0 {
                    break;
                }
                c = r;
            }
        }
        if pos != 0 {
            // Cells on cycles never reach in-degree 0: drop the unused front.
            self.stack.drain(..pos);
        }
        pos
    }
}
