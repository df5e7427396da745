//! The D8-code router: a flow graph from a raster of ESRI D8 direction codes
//! (the powers of two E=1, SE=2, S=4, SW=8, W=16, NW=32, N=64, NE=128 of
//! ArcGIS, WhiteboxTools `--esri_pntr` and TauDEM users, as
//! hydrology's D8 directions write them), [`NO_FLOW`] = 0 for a valid
//! cell that does not drain and [`NODATA_DIR`] = 255 for nodata.
//!
//! A valid cell is a root when its code is [`NO_FLOW`] or points beyond the
//! raster or at a nodata cell (its water leaves the raster); nodata cells
//! are outside the graph. Distances are `cell` times 1 or √2.

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

/// Set the receivers and distances of `g` from the D8 `codes` of its raster
/// (row-major, cells of `cell` units; see the module documentation). Errors
/// on a byte that is not a code, naming its cell.
pub fn route_d8_codes<T: FlowFloat>(g: &mut FlowGraph<T>, codes: &[u8], cell: f64) -> Result<()> {
    let (w, h) = (g.width(), g.height());
    if codes.len() != w * h {
        return Err(Error::invalid(format!(
            "flow graph: {} direction codes for {w}x{h} cells",
            codes.len()
        )));
    }
    let off = offsets(w);
    let len: [T; 8] = step_lengths(cell).map(T::from_f64);
    for y in 0..h {
        let row = y * w;
        let inner_row = y > 0 && y + 1 < h;
        for x in 0..w {
            let c = row + x;
            let code = codes[c];
            g.dist[c] = T::default();
            if code == NODATA_DIR {
                g.rec[c] = NONE;
                continue;
            }
            g.rec[c] = c as u32;
            let d1 = DIR1[code as usize];
            if d1 == 0 {
                continue;
            }
            if d1 == BAD {
                return Err(bad_code(code, x, y));
            }
            let d = (d1 - 1) as usize;
            let r = if inner_row && x > 0 && x + 1 < w {
                (c as isize + off[d]) as usize
            } else {
                match neighbour(x, y, d, w, h) {
                    Some(r) => r,
                    None => continue,
                }
            };
            if codes[r] != NODATA_DIR {
                g.rec[c] = r as u32;
                g.dist[c] = len[d];
            }
        }
    }
    Ok(())
}
