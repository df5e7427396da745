//! The D8-code router: a flow graph from a raster of ESRI D8 direction codes
//! (the powers of two E=1, SE=2, S=4, SW=8, W=16, NW=32, N=64, NE=128 of
//! ArcGIS, WhiteboxTools `--esri_pntr` and TauDEM users, as
//! hydrology's D8 directions write them), [`NO_FLOW`] = 0 for a valid
//! cell that does not drain and [`NODATA_DIR`] = 255 for nodata.
//!
//! A valid cell is a root when its code is [`NO_FLOW`] or points beyond the
//! raster or at a nodata cell (its water leaves the raster); nodata cells
//! are outside the graph. Distances are `cell` times 1 or √2.

use super::accumulate::Flux;
use super::float::FlowFloat;
use super::graph::{FlowGraph, NONE};
use super::steepest::{neighbour, offsets, step_lengths};
use crate::error::{Error, Result};

/// ESRI D8 code of each neighbour direction, order E, SE, S, SW, W, NW, N, NE.
pub const D8_CODES: [u8; 8] = [1, 2, 4, 8, 16, 32, 64, 128];
/// D8 code of a valid cell that does not drain (pit or undrainable flat).
pub const NO_FLOW: u8 = 0;
/// D8 code of a nodata cell.
pub const NODATA_DIR: u8 = 255;

/// Neighbour index (0..8, order E..NE) of an ESRI code, or `None` for 0, 255
/// and any value that is not a single power of two.
#[inline]
pub fn code_to_dir(code: u8) -> Option<usize> {
    if code != 0 && code.is_power_of_two() {
        Some(code.trailing_zeros() as usize)
    } else {
        None
    }
}

/// The error for a byte at `(x, y)` that is not a D8 code.
pub fn bad_code(code: u8, x: usize, y: usize) -> Error {
    Error::invalid(format!(
        "flow direction {code} at cell ({x}, {y}) is not a D8 code (0, 1, 2, 4, …, 128, or 255 for nodata)"
    ))
}

/// Neighbour index + 1 of each byte read as a D8 code: 0 for NO_FLOW and
/// NODATA_DIR, [`BAD`] for bytes that are not a code.
const DIR1: [u8; 256] = {
    let mut t = [BAD; 256];
    t[NO_FLOW as usize] = 0;
    t[NODATA_DIR as usize] = 0;
    let mut d = 0;
    while d < 8 {
        t[1usize << d] = d as u8 + 1;
        d += 1;
    }
    t
};
const BAD: u8 = 0xFF;

/// What a D8 code says of its cell.
#[derive(Clone, Copy)]
enum Decoded {
    /// A nodata cell (outside the graph).
    Nodata,
    /// A valid cell that does not drain into a valid cell of the raster.
    Root,
    /// A valid cell draining into `receiver` in direction `dir` (0..8).
    To { receiver: usize, dir: usize },
}

/// Decode every D8 code of a `w` x `h` raster once and hand each cell
/// index with its [`Decoded`] to `f`, in row-major order. Interior rows find
/// the receiver as `c + offset` without bounds tests. Errors on a byte that
/// is not a code, naming its cell.
#[inline]
fn decode(codes: &[u8], w: usize, h: usize, mut f: impl FnMut(usize, Decoded)) -> Result<()> {
    if codes.len() != w * h {
        return Err(Error::invalid(format!(
            "flow graph: {} direction codes for {w}x{h} cells",
            codes.len()
        )));
    }
    let off = offsets(w);
    for y in 0..h {
        let row = y * w;
        let inner_row = y > 0 && y + 1 < h;
        for x in 0..w {
            let c = row + x;
            let code = codes[c];
            if code == NODATA_DIR {
                f(c, Decoded::Nodata);
                continue;
            }
            let d1 = DIR1[code as usize];
            if d1 == 0 {
                f(c, Decoded::Root);
                continue;
            }
            if d1 == BAD {
                return Err(bad_code(code, x, y));
            }
            let dir = (d1 - 1) as usize;
            let r = if inner_row && x > 0 && x + 1 < w {
                Some((c as isize + off[dir]) as usize)
            } else {
                neighbour(x, y, dir, w, h)
            };
            match r {
                Some(receiver) if codes[receiver] != NODATA_DIR => {
                    f(c, Decoded::To { receiver, dir })
                }
                _ => f(c, Decoded::Root),
            }
        }
    }
    Ok(())
}

/// Set the receivers and distances of `g` from the D8 `codes` of its raster
/// (row-major, cells of `cell` units; see the module documentation). Errors
/// on a byte that is not a code, naming its cell.
pub fn route_d8_codes<T: FlowFloat>(g: &mut FlowGraph<T>, codes: &[u8], cell: f64) -> Result<()> {
    let (w, h) = (g.width(), g.height());
    let len: [T; 8] = step_lengths(cell).map(T::from_f64);
    let (rec, dist) = (&mut g.rec, &mut g.dist);
    decode(codes, w, h, |c, d| match d {
        Decoded::Nodata => {
            rec[c] = NONE;
            dist[c] = T::default();
        }
        Decoded::Root => {
            rec[c] = c as u32;
            dist[c] = T::default();
        }
        Decoded::To { receiver, dir } => {
            rec[c] = receiver as u32;
            dist[c] = len[dir];
        }
    })
}

/// Accumulate `acc` (each cell's own contribution on entry, one value per
/// cell; nodata cells untouched) down the graph of the D8 `codes` without
/// building it: the same sums as [`route_d8_codes`] +
/// [`FlowGraph::build_stack`] + [`FlowGraph::accumulate`], in the same
/// order, pushed to `order` (upstream first, i.e. the stack reversed) when
/// asked. This is the graph's fast form for code rasters: one byte of
/// direction and one of in-degree per cell instead of a 4-byte receiver,
/// distance and stack entry (figures in `docs/design/flow-graph.md`), the
/// walk of Barnes (2017, Alg. 1): downstream from each source cell in
/// row-major order while the next cell has received all its inflows.
/// Errors on an invalid code, an integer overflow or a cycle.
pub fn accumulate_d8_codes<A: Flux>(
    codes: &[u8],
    w: usize,
    h: usize,
    acc: &mut [A],
    mut order: Option<&mut Vec<u32>>,
) -> Result<()> {
    let n = codes.len();
    if n > u32::MAX as usize {
        return Err(Error::invalid(
            "flow accumulation in memory is limited to 2^32 cells; use the tiled pass",
        ));
    }
    if acc.len() != n {
        return Err(Error::invalid(
            "flow accumulation: directions and accumulator sizes differ",
        ));
    }
    let off = offsets(w);
    // direction + 1 (0 = root) and in-degree; DONE marks nodata and
    // processed cells
    const DONE: u8 = u8::MAX;
    let mut next = vec![0u8; n];
    let mut indeg = vec![0u8; n];
    let mut cells = 0usize;
    decode(codes, w, h, |c, d| match d {
        Decoded::Nodata => indeg[c] = DONE,
        Decoded::Root => cells += 1,
        Decoded::To { receiver, dir } => {
            cells += 1;
            next[c] = dir as u8 + 1;
            indeg[receiver] += 1;
        }
    })?;
    if let Some(o) = order.as_deref_mut() {
        o.clear();
        o.reserve_exact(cells);
    }
    let mut done = 0usize;
    let overflow = || Error::invalid("flow accumulation overflowed its integer range");
    for c0 in 0..n {
        if indeg[c0] != 0 {
            continue;
        }
        let mut c = c0;
        loop {
            indeg[c] = DONE;
            done += 1;
            if let Some(o) = order.as_deref_mut() {
                o.push(c as u32);
            }
            let d1 = next[c];
            if d1 == 0 {
                break;
            }
            let r = (c as isize + off[(d1 - 1) as usize]) as usize;
            acc[r] = acc[r].add(acc[c]).ok_or_else(overflow)?;
            indeg[r] -= 1;
            if indeg[r] != 0 {
                break;
            }
            c = r;
        }
    }
    if done != cells {
        return Err(Error::invalid(format!(
            "flow directions contain a cycle ({} cells never drain); directions must come from \
             a D8 routing of one DEM",
            cells - done
        )));
    }
    Ok(())
}
