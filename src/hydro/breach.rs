//! Depression breaching: flood-order breaching, Lindsay's selective
//! breach/fill hybrid and least-cost breaching within a distance — in memory
//! on a [`Grid<f32>`] (module conventions of [`crate::hydro`]: NaN/±∞ =
//! nodata, nodata and the raster's edge are outlets).
//!
//! Breaching removes a depression by *lowering* a channel from its bottom
//! to lower ground instead of raising the depression to its spill level
//! (filling). After [`BreachMethod::Breach`], every valid cell has a
//! non-increasing 8-connected path to an outlet, and no cell is raised.
//!
//! - **Flood-order breaching** ([`BreachMethod::Breach`]), as described by
//!   Soille, P. (2004). "Optimal removal of spurious pits in grid digital
//!   elevation models", Water Resources Research 40, W12509, and Lindsay,
//!   J. B. (2016). "Efficient hybrid breaching-filling sink removal methods
//!   for flow path enforcement in digital elevation models", Hydrological
//!   Processes 30, 846–857: a priority-flood (Barnes, Lehman & Mulla 2014)
//!   grows from the outlets, remembering for each cell the cell that reached
//!   it. When the flood reaches a cell `n` lower than the cell `c` it comes
//!   from, the path back from `c` along those links is carved to a monotone
//!   profile ending at `n`'s level: each cell on it is lowered to `z[n]`
//!   (or, with `epsilon`, to one more representable f32 below the previous
//!   one) until a cell already low enough is met. The carved path is the
//!   flood's own path, which is cheap to find but not the cheapest channel.
//! - **Selective hybrid** ([`BreachMethod::Hybrid`]), Lindsay (2016)'s
//!   selective breaching: breach where the channel is short and shallow,
//!   fill elsewhere. The rule implemented, per flood event: when the flood
//!   reaches a lower cell `n` from `c`, the carve described above is made if
//!   it lowers at most `max_length` cells and leaves none more than
//!   `max_depth` below its *input* elevation; otherwise `n` is raised to `c`'s level (filled, as in the
//!   priority-flood fill) and the flood goes on. `max_depth = 0` gives
//!   exactly [`super::fill()`]; unbounded limits give [`BreachMethod::Breach`].
//! - **Least-cost breaching** ([`BreachMethod::LeastCost`]) after Lindsay,
//!   J. B. & Dhun, K. (2015). "Modelling surface drainage patterns in
//!   altered landscapes using LiDAR", IJGIS 29(3), 397–411 (the method behind
//!   WhiteboxTools' BreachDepressionsLeastCost): from each pit, a Dijkstra
//!   search confined to the `(2·dist+1)²` window centred on the pit finds the
//!   path of least cost to a cell that needs no carving beyond it, the cost
//!   being the total lowering (`Σ max(0, z − z_pit)` over the path's cells),
//!   and the path is carved to the pit's level. See [`BreachMethod::LeastCost`]
//!   for the exact definitions; pits are carved *independently* on the input
//!   DEM and the result is the pointwise minimum of all carves, which makes
//!   the result independent of processing order and computable tile by tile
//!   exactly (see [`super::tiled_breach`]).

use super::fill::{flood_labelled, neighbours, MAX_CELLS, UNLABELLED};
use super::{next_up, order_key, outlet_cells, valid, DX, DY};
use crate::error::{Error, Result};
use crate::raster::Grid;
use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// Largest `dist` accepted by least-cost breaching (cells): the search window
/// is `(2·dist+1)²` cells per pit.
pub const MAX_BREACH_DIST: usize = 10_000;

/// How depressions are removed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum BreachMethod {
    /// Flood-order breaching (Soille 2004; Lindsay 2016): every depression is
    /// breached, none filled.
    Breach,
    /// Lindsay (2016) selective breaching: carve when the channel lowers at
    /// most `max_length` cells, none by more than `max_depth` (DEM units);
    /// fill otherwise.
    Hybrid { max_depth: f32, max_length: usize },
    /// Least-cost breaching (Lindsay & Dhun 2015) with the search confined to
    /// `dist` cells (Chebyshev) around each pit.
    ///
    /// Definitions: `fill` is the priority-flood fill of the input. A *pit*
    /// is a valid cell with `fill > z` (it cannot drain), no neighbour lower
    /// than itself and at least one higher neighbour (single-cell pits, and
    /// the rim cells of flat-bottomed pits). A search starts from each pit
    /// that has no equal neighbour earlier in row-major order which is a pit
    /// too (so a flat-bottomed pit is searched from one rim cell per run of
    /// rim cells, not from all of them; a local rule, radius 2). An *end* for a pit at level `p`
    /// is a cell `q ≠ pit` with `z[q] < p`, or `z[q] == p` and `q` drains
    /// (`fill == z`), or an outlet cell. Entering a cell `q` costs
    /// `max(0, z[q] − p)`; the search stops at the first end popped (ties by
    /// row-major index). The path's cells after the pit are lowered to `p`
    /// (with `epsilon`, to `p` stepped down one f32 per cell, but never below
    /// the end's own level); an outlet end higher than `p` is lowered too.
    /// A pit with no end in its window is left alone ("unresolved"), unless
    /// `fill_remaining` fills the result afterwards.
    LeastCost { dist: usize },
}

/// Options of [`breach`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BreachOptions {
    pub method: BreachMethod,
    /// Carved channels descend strictly (one representable f32 per cell)
    /// instead of being flat at the pit's level; filled cells (hybrid,
    /// `fill_remaining`) are epsilon-filled.
    pub epsilon: bool,
    /// Least-cost only: fill what is left undrained after carving
    /// (priority-flood fill, or epsilon fill with `epsilon`).
    pub fill_remaining: bool,
}

impl Default for BreachOptions {
    fn default() -> Self {
        BreachOptions {
            method: BreachMethod::Breach,
            epsilon: false,
            fill_remaining: false,
        }
    }
}

impl BreachOptions {
    /// Check the parameters (finite non-negative depth, `dist` in 1..=10000).
    pub fn validate(&self) -> Result<()> {
        match self.method {
            BreachMethod::Breach => Ok(()),
            BreachMethod::Hybrid { max_depth, .. } => {
                if max_depth.is_nan() || max_depth < 0.0 {
                    Err(Error::invalid(format!(
                        "breach: max depth {max_depth} must be 0 or more (DEM units)"
                    )))
                } else {
                    Ok(())
                }
            }
            BreachMethod::LeastCost { dist } => {
                if dist == 0 || dist > MAX_BREACH_DIST {
                    Err(Error::invalid(format!(
                        "breach: distance {dist} must be between 1 and {MAX_BREACH_DIST} cells"
                    )))
                } else {
                    Ok(())
                }
            }
        }
    }
}

/// Remove the depressions of `dem` by breaching (see the module docs and
/// [`BreachMethod`]). Nodata cells come back as NaN. Errors for invalid
/// options, grids of 2^32 cells or more, and carves or fills that leave the
/// f32 range.
pub fn breach(dem: &Grid<f32>, opts: &BreachOptions) -> Result<Grid<f32>> {
    breach_masked(dem, opts, None)
}

/// [`breach`] with a sink mask: cells where `sinks` is true are real sinks
/// (lakes, karst, culverts): they are treated as outlets, so water reaching
/// them leaves the DEM and the depressions that drain to them are kept.
pub fn breach_masked(
    dem: &Grid<f32>,
    opts: &BreachOptions,
    sinks: Option<&Grid<bool>>,
) -> Result<Grid<f32>> {
    opts.validate()?;
    let (w, h) = (dem.width(), dem.height());
    if w.checked_mul(h).is_none_or(|n| n >= MAX_CELLS - 1) {
        return Err(Error::invalid(format!(
            "breach: {w}x{h} cells is more than the in-memory breach handles (2^32); \
             use least-cost breaching across tiles"
        )));
    }
    let mut outlet = outlet_cells(dem.data(), w, h);
    if let Some(m) = sinks {
        if (m.width(), m.height()) != (w, h) {
            return Err(Error::invalid(format!(
                "breach: the sink mask is {}x{} but the DEM is {w}x{h}",
                m.width(),
                m.height()
            )));
        }
        for (o, (&s, &z)) in outlet.iter_mut().zip(m.data().iter().zip(dem.data())) {
            *o |= s && valid(z);
        }
    }
    let mut z = dem.data().to_vec();
    match opts.method {
        BreachMethod::Breach => {
            flood_breach(dem.data(), &mut z, w, h, &outlet, None, opts.epsilon)?
        }
        BreachMethod::Hybrid {
            max_depth,
            max_length,
        } => flood_breach(
            dem.data(),
            &mut z,
            w,
            h,
            &outlet,
            Some((max_depth as f64, max_length)),
            opts.epsilon,
        )?,
        BreachMethod::LeastCost { dist } => {
            let filled = fill_with_outlets(dem.data(), w, h, &outlet);
            let region = (0, 0, w, h);
            z = least_cost_carve(
                dem.data(),
                &filled,
                &outlet,
                w,
                h,
                dist,
                opts.epsilon,
                region,
            )?;
            if opts.fill_remaining {
                let g = Grid::from_vec(w, h, z)?;
                let f = if opts.epsilon {
                    super::fill_epsilon(&g)?
                } else if sinks.is_some() {
                    Grid::from_vec(w, h, fill_with_outlets(g.data(), w, h, &outlet))?
                } else {
                    super::fill(&g)?
                };
                z = f.into_vec();
            }
        }
    }
    for v in z.iter_mut() {
        if !valid(*v) {
            *v = f32::NAN;
        }
    }
    Grid::from_vec(w, h, z)
}

/// Priority-flood fill from the given outlet cells (Barnes et al. 2014).
fn fill_with_outlets(z: &[f32], w: usize, h: usize, outlet: &[bool]) -> Vec<f32> {
    let mut f = z.to_vec();
    let mut labels = vec![UNLABELLED; z.len()];
    let mut seeds = Vec::new();
    for (i, &o) in outlet.iter().enumerate() {
        if o {
            labels[i] = 1;
            seeds.push(i);
        }
    }
    flood_labelled(&mut f, w, h, &mut labels, &seeds, |_, _, _| {});
    f
}

/// The next representable f32 below `z`.
#[inline]
pub(crate) fn next_down(z: f32) -> f32 {
    -next_up(-z)
}

#[inline]
fn pack(z: f32, i: usize) -> u64 {
    ((order_key(z) as u64) << 32) | i as u64
}

const NONE: u32 = u32::MAX;

fn out_of_range() -> Error {
    Error::invalid(
        "breach: a carved or filled elevation leaves the f32 range; rescale the elevations",
    )
}

/// Flood-order breaching, or Lindsay's selective hybrid when `limits` =
/// `Some((max_depth, max_length))`; in place on `z` (a copy of `orig`, the
/// input, against which depths are measured).
fn flood_breach(
    orig: &[f32],
    z: &mut [f32],
    w: usize,
    h: usize,
    outlet: &[bool],
    limits: Option<(f64, usize)>,
    eps: bool,
) -> Result<()> {
    let n = z.len();
    let mut link = vec![NONE; n];
    let mut seen = vec![false; n];
    let mut open: BinaryHeap<Reverse<u64>> = BinaryHeap::new();
    for (i, &o) in outlet.iter().enumerate() {
        if o {
            seen[i] = true;
            open.push(Reverse(pack(z[i], i)));
        }
    }
    let step = |t: f32| if eps { next_down(t) } else { t };
    let mut nb = [0usize; 8];
    // Every cell is pushed once, when first seen; carves only lower cells
    // that were already popped (the links of popped cells), so heap entries
    // never go stale.
    while let Some(Reverse(k)) = open.pop() {
        let c = (k & 0xFFFF_FFFF) as usize;
        let count = neighbours(c, w, h, &mut nb);
        for &m in &nb[..count] {
            if seen[m] || !valid(z[m]) {
                continue;
            }
            seen[m] = true;
            link[m] = c as u32;
            let zm = z[m];
            if zm >= z[c] {
                open.push(Reverse(pack(zm, m)));
                continue;
            }
            let carve = match limits {
                None => true,
                Some((max_depth, max_len)) => {
                    // dry run of the carve: cells lowered and deepest cut
                    let mut t = step(zm);
                    let mut k = c;
                    let mut len = 0usize;
                    let mut ok = true;
                    loop {
                        if z[k] <= t {
                            break;
                        }
                        len += 1;
                        if len > max_len || (orig[k] as f64 - t as f64) > max_depth {
                            ok = false;
                            break;
                        }
                        match link[k] {
                            NONE => break,
                            p => k = p as usize,
                        }
                        t = step(t);
                    }
                    ok
                }
            };
            if carve {
                let mut t = step(zm);
                let mut k = c;
                loop {
                    if z[k] <= t {
                        break;
                    }
                    if !t.is_finite() {
                        return Err(out_of_range());
                    }
                    z[k] = t;
                    match link[k] {
                        NONE => break,
                        p => k = p as usize,
                    }
                    t = step(t);
                }
            } else {
                let up = if eps { next_up(z[c]) } else { z[c] };
                if !up.is_finite() {
                    return Err(out_of_range());
                }
                z[m] = up;
            }
            open.push(Reverse(pack(z[m], m)));
        }
    }
    Ok(())
}

/// A pit of least-cost breaching: a valid non-outlet cell that cannot drain
/// (`filled > z`), with no lower neighbour and at least one higher one.
#[inline]
fn is_pit(z: &[f32], filled: &[f32], outlet: &[bool], w: usize, h: usize, p: usize) -> bool {
    let zp = z[p];
    if !valid(zp) || outlet[p] || filled[p].partial_cmp(&zp) != Some(std::cmp::Ordering::Greater) {
        return false;
    }
    let (px, py) = ((p % w) as i64, (p / w) as i64);
    let mut higher = false;
    for k in 0..8 {
        let nx = px + DX[k];
        let ny = py + DY[k];
        if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
            continue;
        }
        let v = z[ny as usize * w + nx as usize];
        if v < zp {
            return false;
        }
        higher |= v > zp;
    }
    higher
}

/// Least-cost breaching kernel (see [`BreachMethod::LeastCost`]): carves, on
/// a copy of `z`, the least-cost path of every pit whose position lies in
/// `region` = (x0, y0, x1, y1) (half-open), each computed on the input `z`
/// alone, and returns the pointwise minimum. `filled` is the fill of `z`
/// (NaN where nodata); `outlet` marks outlet cells. The result at a cell
/// depends only on `z`, `filled` and `outlet` within `2·dist + 1` cells of
/// it, which is what makes the tiled version exact.
#[allow(clippy::too_many_arguments)]
pub(crate) fn least_cost_carve(
    z: &[f32],
    filled: &[f32],
    outlet: &[bool],
    w: usize,
    h: usize,
    dist: usize,
    eps: bool,
    region: (usize, usize, usize, usize),
) -> Result<Vec<f32>> {
    let n = z.len();
    let mut out = z.to_vec();
    // Search state with generation stamps, so no clearing between pits.
    let mut stamp = vec![0u32; n];
    let mut closed = vec![0u32; n];
    let mut cost = vec![0f64; n];
    let mut prev = vec![NONE; n];
    let mut gen = 0u32;
    let mut heap: BinaryHeap<Reverse<(u64, u32)>> = BinaryHeap::new();
    let mut path: Vec<usize> = Vec::new();
    let d = dist as i64;
    let (x0, y0, x1, y1) = region;
    for py in y0..y1.min(h) {
        for px in x0..x1.min(w) {
            let p = py * w + px;
            if !is_pit(z, filled, outlet, w, h, p) {
                continue;
            }
            let zp = z[p];
            // One search per run of rim cells of a flat-bottomed pit: skip
            // `p` if an equal neighbour before it (row-major) is a pit too.
            let mut later = false;
            for k in 0..8 {
                let nx = px as i64 + DX[k];
                let ny = py as i64 + DY[k];
                if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
                    continue;
                }
                let q = ny as usize * w + nx as usize;
                if q < p && z[q] == zp && is_pit(z, filled, outlet, w, h, q) {
                    later = true;
                    break;
                }
            }
            if later {
                continue;
            }
            // Dijkstra from the pit inside its window.
            gen = gen.wrapping_add(1);
            if gen == 0 {
                stamp.iter_mut().for_each(|s| *s = 0);
                closed.iter_mut().for_each(|s| *s = 0);
                gen = 1;
            }
            heap.clear();
            stamp[p] = gen;
            cost[p] = 0.0;
            prev[p] = NONE;
            heap.push(Reverse((0f64.to_bits(), p as u32)));
            let mut end = None;
            while let Some(Reverse((cb, c))) = heap.pop() {
                let c = c as usize;
                if closed[c] == gen {
                    continue;
                }
                closed[c] = gen;
                let zc = z[c];
                if c != p && (zc < zp || outlet[c] || (zc == zp && filled[c] == zc)) {
                    end = Some(c);
                    break;
                }
                let cc = f64::from_bits(cb);
                let (cx, cy) = ((c % w) as i64, (c / w) as i64);
                for k in 0..8 {
                    let nx = cx + DX[k];
                    let ny = cy + DY[k];
                    if nx < 0
                        || ny < 0
                        || nx >= w as i64
                        || ny >= h as i64
                        || (nx - px as i64).abs() > d
                        || (ny - py as i64).abs() > d
                    {
                        continue;
                    }
                    let m = ny as usize * w + nx as usize;
                    let zm = z[m];
                    if !valid(zm) || closed[m] == gen {
                        continue;
                    }
                    let step = if zm > zp { zm as f64 - zp as f64 } else { 0.0 };
                    let nc = cc + step;
                    if stamp[m] != gen || nc < cost[m] {
                        stamp[m] = gen;
                        cost[m] = nc;
                        prev[m] = c as u32;
                        heap.push(Reverse((nc.to_bits(), m as u32)));
                    }
                }
            }
            let Some(e) = end else { continue };
            path.clear();
            let mut k = e;
            while k != p {
                path.push(k);
                k = prev[k] as usize;
            }
            path.reverse(); // pit's successor first, end last
            let ze = z[e];
            let floor = if ze <= zp { ze } else { f32::NEG_INFINITY };
            let mut t = zp;
            for &q in &path {
                if eps {
                    t = next_down(t);
                }
                let target = if t > floor { t } else { floor };
                if !target.is_finite() {
                    return Err(out_of_range());
                }
                if q == e && ze <= zp {
                    break;
                }
                if target < out[q] {
                    out[q] = target;
                }
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn g(w: usize, h: usize, v: &[f32]) -> Grid<f32> {
        Grid::from_vec(w, h, v.to_vec()).unwrap()
    }

    #[test]
    fn next_down_is_below() {
        for z in [-3.5f32, 0.0, 1.0, 1234.5] {
            assert!(next_down(z) < z);
            assert_eq!(next_up(next_down(z)), z);
        }
    }

    #[test]
    fn one_cell_dam_is_lowered_to_the_pit() {
        // pit (1,1)=2 enclosed; the dam (2,1)=6 separates it from the edge
        // cell (3,1)=1: breaching lowers exactly the dam to 2.
        #[rustfmt::skip]
        let d = g(4, 3, &[
            9.0, 9.0, 9.0, 9.0,
            9.0, 2.0, 6.0, 1.0,
            9.0, 9.0, 9.0, 9.0]);
        for method in [
            BreachMethod::Breach,
            BreachMethod::LeastCost { dist: 3 },
            BreachMethod::Hybrid {
                max_depth: 10.0,
                max_length: 5,
            },
        ] {
            let o = BreachOptions {
                method,
                ..Default::default()
            };
            let b = breach(&d, &o).unwrap();
            let mut want = d.clone();
            want.set(2, 1, 2.0);
            assert_eq!(b, want, "{method:?}");
        }
    }

    #[test]
    fn bad_options_are_errors() {
        let d = g(2, 2, &[1.0; 4]);
        for method in [
            BreachMethod::LeastCost { dist: 0 },
            BreachMethod::Hybrid {
                max_depth: f32::NAN,
                max_length: 3,
            },
            BreachMethod::Hybrid {
                max_depth: -1.0,
                max_length: 3,
            },
        ] {
            let o = BreachOptions {
                method,
                ..Default::default()
            };
            assert!(breach(&d, &o).is_err());
        }
        let m = Grid::new(3, 3, false);
        assert!(breach_masked(&d, &BreachOptions::default(), Some(&m)).is_err());
    }
}
