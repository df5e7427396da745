//! D8 flow directions with drainage over flats.
//!
//! - Steepest descent (O'Callaghan & Mark 1984, "The extraction of drainage
//!   networks from digital elevation data", CVGIP 28): each cell drains to the
//!   neighbour with the largest drop / distance. Distances are the grid's
//!   true ones ([`CellGeometry`]): 1 and √2 on square cells, the cells'
//!   aspect ratio on rectangular projected cells, and metres on the WGS 84
//!   ellipsoid per row on geographic (lat/lon) grids, where the east-west
//!   spacing shrinks with cos φ (a departure from the paper's square cells,
//!   which would send flow on a 3" SRTM tile at 49.5°N elsewhere than the
//!   true steepest descent on about a quarter of the cells).
//! - Flats: Barnes, R., Lehman, C., Mulla, D. (2014). "An efficient assignment
//!   of drainage direction over flat surfaces in raster digital elevation
//!   models". Computers & Geosciences 62, 128–135. Cells of a flat get a
//!   gradient *towards lower terrain* (breadth-first distance from the flat's
//!   low edges) and one *away from higher terrain* (distance from its high
//!   edges), combined as `2·towards + (flat height − away)`; each flat cell then
//!   drains to its same-flat neighbour of smallest combined value (the paper's
//!   Algorithms 1–7).
//!
//! Module conventions in [`crate::hydro`]: outlet cells without a lower
//! neighbour drain off the DEM; codes are the ESRI powers of two.

use super::{code_to_dir, valid, D8_CODES, NODATA_DIR, NO_FLOW};
use crate::error::{Error, Result};
use crate::raster::neighbours::{neighbour, CellGeometry};
use crate::raster::Grid;

/// D8 flow directions of `dem` (normally a filled DEM) with flats resolved,
/// on square cells. Valid cells get an ESRI code; cells in pits or in flats
/// with no outlet (possible only on unfilled DEMs) get [`NO_FLOW`]; nodata
/// gets [`NODATA_DIR`].
pub fn d8_directions(dem: &Grid<f32>) -> Grid<u8> {
    d8_directions_on(dem, &CellGeometry::square())
}

/// [`d8_directions`] with the distances of `geo` (one row per row of
/// `dem`, e.g. `CellGeometry::of_rows(georef, 0, height)`).
pub fn d8_directions_on(dem: &Grid<f32>, geo: &CellGeometry) -> Grid<u8> {
    let (w, h) = (dem.width(), dem.height());
    let z = dem.data();
    let mut dir = steepest_descent(z, w, h, geo);
    resolve_flats(z, w, h, &mut dir);
    Grid::from_vec(w, h, dir).expect("same size as the input")
}

/// Watershed label of every cell of a D8 direction grid: the row-major
/// index plus 1 of the *terminal* cell its flow path ends at — a cell whose
/// code points beyond the grid or at a nodata cell (an outlet), or a
/// [`NO_FLOW`] cell (a pit of an unfilled DEM) — and 0 for nodata. Paths are
/// followed once (memoised), so the cost is linear. The numbering depends
/// only on the directions, which makes it canonical: the tiled
/// [`super::tiled::TiledLabels`] gives the same numbers. Errors for codes
/// that are not D8 codes, cycles, and grids of 2^32 cells or more.
pub fn outlet_labels(dirs: &Grid<u8>) -> Result<Grid<u32>> {
    let (w, h) = (dirs.width(), dirs.height());
    let n = w
        .checked_mul(h)
        .filter(|&n| n <= u32::MAX as usize)
        .ok_or_else(|| {
            Error::invalid(format!(
                "{w}x{h} cells: watershed labels need fewer than 2^32 cells"
            ))
        })?;
    let d = dirs.data();
    let mut lab = vec![0u32; n];
    // 0 = not visited, 1 = on the current path, 2 = labelled
    let mut state = vec![0u8; n];
    let mut path = Vec::new();
    for s in 0..n {
        if d[s] == NODATA_DIR || state[s] == 2 {
            continue;
        }
        let mut c = s;
        let label = loop {
            if state[c] == 2 {
                break lab[c];
            }
            let (x, y) = (c % w, c / w);
            if state[c] == 1 {
                return Err(Error::invalid(format!(
                    "flow directions contain a cycle through cell ({x}, {y})"
                )));
            }
            state[c] = 1;
            path.push(c);
            let code = d[c];
            if code == NO_FLOW {
                break c as u32 + 1;
            }
            let dir = code_to_dir(code).ok_or_else(|| {
                Error::invalid(format!(
                    "flow direction {code} at cell ({x}, {y}) is not a D8 code"
                ))
            })?;
            match neighbour(x, y, dir, w, h) {
                Some(m) if d[m] != NODATA_DIR => c = m,
                _ => break c as u32 + 1,
            }
        };
        for &p in &path {
            lab[p] = label;
            state[p] = 2;
        }
        path.clear();
    }
    Grid::from_vec(w, h, lab)
}

/// Steepest-descent codes with the distances of `geo` (row `y` of the
/// array is its row `y`); cells without a lower neighbour get NO_FLOW unless
/// they are outlet cells, which point at their first nodata/off-grid
/// neighbour.
pub(crate) fn steepest_descent(z: &[f32], w: usize, h: usize, geo: &CellGeometry) -> Vec<u8> {
    let mut dir = vec![NODATA_DIR; z.len()];
    for y in 0..h {
        let dists = &geo.row(y).dist;
        for x in 0..w {
            let c = y * w + x;
            let zc = z[c];
            if !valid(zc) {
                continue;
            }
            let mut best = 0.0f64;
            let mut best_d = usize::MAX;
            let mut exit_d = usize::MAX;
            for (d, &dist) in dists.iter().enumerate() {
                match neighbour(x, y, d, w, h) {
                    Some(n) if valid(z[n]) => {
                        let s = (zc as f64 - z[n] as f64) / dist;
                        if s > best {
                            best = s;
                            best_d = d;
                        }
                    }
                    _ => {
                        if exit_d == usize::MAX {
                            exit_d = d;
                        }
                    }
                }
            }
            dir[c] = if best_d != usize::MAX {
                D8_CODES[best_d]
            } else if exit_d != usize::MAX {
                D8_CODES[exit_d]
            } else {
                NO_FLOW
            };
        }
    }
    dir
}

/// Barnes et al. (2014) flat resolution, in place on `dir`.
pub(crate) fn resolve_flats(z: &[f32], w: usize, h: usize, dir: &mut [u8]) {
    let n = z.len();
    // Algorithm 3 (FlatEdges): low edges drain and touch a same-elevation
    // NO_FLOW cell; high edges are NO_FLOW and touch a higher cell.
    let mut low = Vec::new();
    let mut high = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let c = y * w + x;
            if dir[c] == NODATA_DIR {
                continue;
            }
            for d in 0..8 {
                let Some(m) = neighbour(x, y, d, w, h) else {
                    continue;
                };
                if dir[m] == NODATA_DIR {
                    continue;
                }
                if dir[c] != NO_FLOW && dir[m] == NO_FLOW && z[m] == z[c] {
                    low.push(c);
                    break;
                }
                if dir[c] == NO_FLOW && z[m] > z[c] {
                    high.push(c);
                    break;
                }
            }
        }
    }
    if low.is_empty() {
        return;
    }
    // Algorithm 4 (LabelFlat): flood each flat from its low edges over cells of
    // the same elevation.
    let mut label = vec![0u32; n];
    let mut next = 1u32;
    let mut stack = Vec::new();
    for &s in &low {
        if label[s] != 0 {
            continue;
        }
        let e = z[s];
        label[s] = next;
        stack.push(s);
        while let Some(c) = stack.pop() {
            let (x, y) = (c % w, c / w);
            for d in 0..8 {
                if let Some(m) = neighbour(x, y, d, w, h) {
                    if label[m] == 0 && dir[m] != NODATA_DIR && z[m] == e {
                        label[m] = next;
                        stack.push(m);
                    }
                }
            }
        }
        next += 1;
    }
    // High edges of flats without an outlet cannot be drained: drop them.
    high.retain(|&c| label[c] != 0);

    // Algorithm 5 (AwayFromHigher): BFS distance from the high edges through
    // the flat's NO_FLOW cells; flat height = largest distance per flat.
    let mut away = vec![0u32; n];
    let mut flat_height = vec![0u32; next as usize];
    bfs(&high, w, h, dir, &label, &mut away, |c, dist| {
        let l = label[c] as usize;
        if flat_height[l] < dist {
            flat_height[l] = dist;
        }
    });
    // Algorithm 6 (TowardsLower): BFS distance from the low edges.
    let mut towards = vec![0u32; n];
    bfs(&low, w, h, dir, &label, &mut towards, |_, _| {});

    // Combined mask (Alg. 6): 2·towards + (height − away) where away is known.
    // Algorithm 7 (D8MaskedFlowdirs): each NO_FLOW flat cell drains to its
    // same-label neighbour of smallest mask (first in E..NE order on ties).
    let mask = |c: usize| -> u64 {
        let t = 2 * towards[c] as u64;
        if away[c] > 0 {
            t + (flat_height[label[c] as usize] - away[c]) as u64
        } else {
            t
        }
    };
    for y in 0..h {
        for x in 0..w {
            let c = y * w + x;
            if dir[c] != NO_FLOW || label[c] == 0 {
                continue;
            }
            let mut best = mask(c);
            let mut best_d = usize::MAX;
            for d in 0..8 {
                if let Some(m) = neighbour(x, y, d, w, h) {
                    if label[m] == label[c] && towards[m] > 0 {
                        let v = mask(m);
                        if v < best {
                            best = v;
                            best_d = d;
                        }
                    }
                }
            }
            if best_d != usize::MAX {
                dir[c] = D8_CODES[best_d];
            }
        }
    }
}

/// Breadth-first distances (1 at the sources) over NO_FLOW cells of the same
/// flat label as the cell they are reached from; sources keep distance 1 even
/// if they drain (low edges). `visit(cell, dist)` is called once per cell.
fn bfs(
    sources: &[usize],
    w: usize,
    h: usize,
    dir: &[u8],
    label: &[u32],
    dist: &mut [u32],
    mut visit: impl FnMut(usize, u32),
) {
    let mut cur: Vec<usize> = Vec::new();
    for &s in sources {
        if dist[s] == 0 {
            dist[s] = 1;
            visit(s, 1);
            cur.push(s);
        }
    }
    let mut level = 1u32;
    let mut nxt = Vec::new();
    while !cur.is_empty() {
        level += 1;
        for &c in &cur {
            let (x, y) = (c % w, c / w);
            for d in 0..8 {
                if let Some(m) = neighbour(x, y, d, w, h) {
                    if dist[m] == 0 && dir[m] == NO_FLOW && label[m] == label[c] {
                        dist[m] = level;
                        visit(m, level);
                        nxt.push(m);
                    }
                }
            }
        }
        std::mem::swap(&mut cur, &mut nxt);
        nxt.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raster::neighbours::{DX, DY};

    #[test]
    fn slope_picks_steepest_with_diagonal_distance() {
        // centre 10; E is 8 (drop 2/1), SE is 7 (drop 3/√2 = 2.12): SE wins
        #[rustfmt::skip]
        let d = Grid::from_vec(3, 3, vec![
            20.0, 20.0, 20.0,
            20.0, 10.0, 8.0,
            20.0, 20.0, 7.0]).unwrap();
        let dir = d8_directions(&d);
        assert_eq!(dir.get(1, 1), 2);
    }

    #[test]
    fn flat_drains_to_its_low_edge_and_away_from_high_ground() {
        // a 1-row-high corridor of equal cells closed by high walls, with
        // one exit on the east edge: every flat cell must point east-ish and
        // reach the exit.
        let w = 7;
        let h = 5;
        let mut v = vec![50.0f32; w * h];
        for x in 1..w {
            for y in 1..4 {
                v[y * w + x] = 10.0;
            }
        }
        let d = Grid::from_vec(w, h, v).unwrap();
        let dir = d8_directions(&d);
        // follow every flat cell to the edge
        for y in 1..4 {
            for x in 1..w - 1 {
                let (mut cx, mut cy) = (x as i64, y as i64);
                let mut steps = 0;
                loop {
                    let code = dir.get(cx as usize, cy as usize);
                    let k = super::super::code_to_dir(code).expect("drains");
                    let (nx, ny) = (cx + DX[k], cy + DY[k]);
                    if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
                        break;
                    }
                    assert_eq!(d.get(nx as usize, ny as usize), 10.0, "stays on the flat");
                    cx = nx;
                    cy = ny;
                    steps += 1;
                    assert!(steps < 50);
                }
                assert_eq!(cx, w as i64 - 1, "leaves through the east edge");
            }
        }
    }
}
