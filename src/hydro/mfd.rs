//! Multiple-flow-direction (MFD) routing and accumulation of divergent flow.
//!
//! [`FlowFractions`] is the shared result of every divergent router of this
//! module and of [`super::dinf`]: for each valid cell, the fraction of its
//! water sent to each of its 8 neighbours (order E, SE, S, SW, W, NW, N, NE).
//! A fraction aimed at a nodata or off-raster neighbour leaves the DEM.
//!
//! MFD weights for the downslope neighbours `i` (tan βᵢ = drop / distance,
//! distance 1 for edge neighbours and √2 for diagonals, square cells):
//! - [`MfdMethod::Quinn`]: Quinn, P., Beven, K., Chevallier, P., Planchon, O.
//!   (1991). "The prediction of hillslope flow paths for distributed
//!   hydrological modelling using digital terrain models", Hydrological
//!   Processes 5(1): wᵢ = tan βᵢ · Lᵢ with contour lengths L = 0.5 (cardinal)
//!   and √2/4 ≈ 0.354 (diagonal), in cell sizes.
//! - [`MfdMethod::Holmgren`]: Holmgren, P. (1994). "Multiple flow direction
//!   algorithms for runoff modelling in grid based elevation models: an
//!   empirical evaluation", Hydrological Processes 8(4): wᵢ = (tan βᵢ)^h.
//! - [`MfdMethod::Freeman`]: Freeman, T. G. (1991). "Calculating catchment
//!   area with divergent flow based on a regular grid", Computers &
//!   Geosciences 17(3): wᵢ = (tan βᵢ)^1.1, no contour lengths.
//!
//! Fractions are wᵢ / Σw. Nodata neighbours have no elevation and take no MFD
//! share. A cell with no lower valid neighbour (a flat of a filled DEM, an
//! outlet cell at the bottom of its surroundings, or a pit) falls back to the
//! D8 direction of [`super::d8_directions`], which drains flats by the
//! gradients of Barnes et al. (2014) and points outlet cells off the DEM; all
//! its water goes that way. Pits of unfilled DEMs (D8 `NO_FLOW`) keep no flow.
//!
//! Accumulation ([`accumulate_fractions`]) visits cells in a topological order
//! of the flow graph found by in-degree counting (Kahn 1962, "Topological
//! sorting of large networks", CACM 5), O(n). Sums are exact fixed-point
//! integers (`i128`, [`super::WEIGHT_SCALE_BITS`] fractional bits, as for D8
//! in [`super::accum`]), and a cell's accumulation `A` is split among its
//! receivers by [`split_fixed`]: integer shares `q_d` = round(f_d · 2^32) of
//! the fractions, `⌊A·q_d / 2^32⌋` to every receiver but the one with the
//! largest share, the remainder to that one. The split depends only on `A` and the cell's own
//! fractions, and the shares sum exactly to `A`, so (i) water is conserved
//! exactly, and (ii) the result does not depend on the order in which a
//! cell's inflows are added — which is what lets
//! [`super::tiled_mfd::TiledMultiAccumulation`] reproduce it bit for bit
//! tile by tile. Compared with f64 sums, each split loses at most 2^-32 of
//! a cell per receiver.

use super::accum::{fixed_to_f64, weight_to_fixed};
use super::{code_to_dir, valid, NODATA_DIR};
use crate::error::{Error, Result};
pub(crate) use crate::raster::neighbours::neighbour;
use crate::raster::neighbours::{CellGeometry, RowGeometry};
use crate::raster::Grid;

/// Fractions marking a nodata cell (never routed, never counted).
const NODATA_FRAC: [f64; 8] = [f64::NAN; 8];

/// Largest grid routed in memory (the flow graph uses 64 bytes per cell).
const MAX_CELLS: usize = u32::MAX as usize;

/// Per-cell flow fractions towards the 8 neighbours (order E..NE).
#[derive(Clone, Debug, PartialEq)]
pub struct FlowFractions {
    width: usize,
    height: usize,
    frac: Vec<[f64; 8]>,
}

impl FlowFractions {
    /// Width of the routed grid in cells.
    pub fn width(&self) -> usize {
        self.width
    }
    /// Height of the routed grid in cells.
    pub fn height(&self) -> usize {
        self.height
    }
    /// Fractions of cell (x, y) towards E, SE, S, SW, W, NW, N, NE; `None`
    /// for nodata. All zero for a valid cell without flow (a pit); otherwise
    /// each is in [0, 1] and they sum to 1 (up to f64 rounding).
    pub fn fractions(&self, x: usize, y: usize) -> Option<&[f64; 8]> {
        let f = &self.frac[y * self.width + x];
        if f[0].is_nan() {
            None
        } else {
            Some(f)
        }
    }
    /// True when cell (x, y) is valid and sends its water somewhere.
    pub fn has_flow(&self, x: usize, y: usize) -> bool {
        self.fractions(x, y)
            .is_some_and(|f| f.iter().any(|&v| v > 0.0))
    }
}

/// How MFD weights the downslope neighbours (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MfdMethod {
    /// Quinn et al. (1991): tan β · contour length.
    Quinn,
    /// Holmgren (1994): tan β ^ h, with h > 0 finite (h → ∞ approaches D8).
    Holmgren(f64),
    /// Freeman (1991): tan β ^ 1.1.
    Freeman,
}

pub(crate) fn check_size(w: usize, h: usize) -> Result<()> {
    match w.checked_mul(h) {
        Some(n) if n <= MAX_CELLS => Ok(()),
        _ => Err(Error::invalid(format!(
            "a {w}x{h} grid is too large for in-memory divergent flow routing (limit 2^32 cells); \
             crop or resample the DEM"
        ))),
    }
}

/// Builds a [`FlowFractions`] from `route`, which fills the fractions of a
/// valid cell (given its row's geometry from `geo`) and returns false when
/// the cell has no downslope direction; such cells take their D8 direction
/// on the same geometry (flats, outlet cells, pits).
pub(crate) fn route_with_fallback(
    dem: &Grid<f32>,
    geo: &CellGeometry,
    mut route: impl FnMut(&[f32], usize, usize, &RowGeometry, &mut [f64; 8]) -> bool,
) -> Result<(FlowFractions, Vec<bool>)> {
    let (w, h) = (dem.width(), dem.height());
    check_size(w, h)?;
    let z = dem.data();
    let mut frac = vec![NODATA_FRAC; z.len()];
    let mut fell_back = vec![false; z.len()];
    let mut any_fallback = false;
    for y in 0..h {
        for x in 0..w {
            let c = y * w + x;
            if !valid(z[c]) {
                continue;
            }
            let mut f = [0.0f64; 8];
            if !route(z, x, y, geo.row(y), &mut f) {
                fell_back[c] = true;
                any_fallback = true;
            }
            frac[c] = f;
        }
    }
    if any_fallback {
        let d8 = super::d8_directions_on(dem, geo);
        for (c, &fb) in fell_back.iter().enumerate() {
            if !fb {
                continue;
            }
            frac[c] = d8_fallback(d8.data()[c]);
        }
    }
    Ok((
        FlowFractions {
            width: w,
            height: h,
            frac,
        },
        fell_back,
    ))
}

/// MFD weighting of `method` as (exponent, use Quinn's contour lengths).
/// Errors for a Holmgren exponent that is not a finite positive number.
pub(crate) fn mfd_params(method: MfdMethod) -> Result<(f64, bool)> {
    match method {
        MfdMethod::Quinn => Ok((1.0, true)),
        MfdMethod::Freeman => Ok((1.1, false)),
        MfdMethod::Holmgren(p) => {
            if p.is_finite() && p > 0.0 {
                Ok((p, false))
            } else {
                Err(Error::invalid(format!(
                    "Holmgren MFD exponent must be a finite number > 0, got {p}"
                )))
            }
        }
    }
}

/// MFD fractions of the valid cell (x, y) of a `w` x `h` elevation array
/// into `f`; false when no valid neighbour is lower (the caller falls back
/// to D8). Shared by the in-memory and the tiled routers, so both get the
/// same bits.
#[allow(clippy::too_many_arguments, clippy::needless_range_loop)]
pub(crate) fn mfd_cell(
    z: &[f32],
    w: usize,
    h: usize,
    x: usize,
    y: usize,
    (exponent, contour): (f64, bool),
    g: &RowGeometry,
    f: &mut [f64; 8],
) -> bool {
    let zc = z[y * w + x] as f64;
    // tan β of every lower valid neighbour; remember the steepest so that
    // large exponents are computed relative to it (no overflow to ∞).
    let mut tan = [0.0f64; 8];
    let mut max_tan = 0.0f64;
    for d in 0..8 {
        if let Some(n) = neighbour(x, y, d, w, h) {
            let zn = z[n];
            if valid(zn) && (zn as f64) < zc {
                tan[d] = (zc - zn as f64) / g.dist[d];
                max_tan = max_tan.max(tan[d]);
            }
        }
    }
    if max_tan <= 0.0 {
        return false;
    }
    let mut sum = 0.0;
    for d in 0..8 {
        if tan[d] > 0.0 {
            let mut wgt = if exponent == 1.0 {
                tan[d] / max_tan
            } else {
                (tan[d] / max_tan).powf(exponent)
            };
            if contour {
                wgt *= g.contour[d];
            }
            f[d] = wgt;
            sum += wgt;
        }
    }
    // the steepest neighbour has weight 1 (× L), so 0 < sum <= 8
    for v in f.iter_mut() {
        *v /= sum;
    }
    true
}

/// Fractions of a cell that falls back to its D8 direction `code`: all the
/// water that way, none for NO_FLOW (a pit) or NODATA_DIR.
#[inline]
pub(crate) fn d8_fallback(code: u8) -> [f64; 8] {
    let mut f = [0.0f64; 8];
    if code != NODATA_DIR {
        if let Some(d) = code_to_dir(code) {
            f[d] = 1.0;
        }
    }
    f
}

/// MFD flow fractions of `dem` (normally a filled DEM; NaN = nodata) with
/// the weighting `method`. Errors for a Holmgren exponent that is not a
/// finite positive number and for grids of more than 2^32 cells.
pub fn mfd_flow(dem: &Grid<f32>, method: MfdMethod) -> Result<FlowFractions> {
    mfd_flow_on(dem, method, &CellGeometry::square())
}

/// [`mfd_flow`] with the distances and contour lengths of `geo` (one row per
/// row of `dem`; true distances on geographic grids).
pub fn mfd_flow_on(
    dem: &Grid<f32>,
    method: MfdMethod,
    geo: &CellGeometry,
) -> Result<FlowFractions> {
    let params = mfd_params(method)?;
    let (w, h) = (dem.width(), dem.height());
    let (flow, _) = route_with_fallback(dem, geo, |z, x, y, g, f| {
        mfd_cell(z, w, h, x, y, params, g, f)
    })?;
    Ok(flow)
}

/// Exact (fixed-point) accumulation over a [`FlowFractions`] grid.
#[derive(Clone, Debug, PartialEq)]
pub struct FixedAccumulation {
    /// Width of the grid in cells.
    pub width: usize,
    /// Height of the grid in cells.
    pub height: usize,
    /// Accumulation of each cell in units of 2^-[`super::WEIGHT_SCALE_BITS`]
    /// (0 for nodata).
    pub acc: Vec<i128>,
    /// Water that left the DEM (into nodata or beyond the edge).
    pub left: i128,
    /// Water held by cells without flow (pits of unfilled DEMs).
    pub held: i128,
}

/// Sum of `weights` (or 1 per cell when `None`) over everything draining
/// through each cell, itself included, in exact fixed point; see the module
/// docs. `left + held` equals the sum of the fixed-point weights exactly.
pub fn accumulate_fixed(
    flow: &FlowFractions,
    weights: Option<&Grid<f32>>,
) -> Result<FixedAccumulation> {
    let (w, h) = (flow.width, flow.height);
    let mut acc = own_contributions(&flow.frac, weights.map(|g| (g, w, h)))?;
    let mut left = 0i128;
    let mut held = 0i128;
    accumulate_fixed_core(&flow.frac, w, h, &mut acc, |_, d, v| {
        match d {
            Some(_) => left = left.checked_add(v).ok_or_else(overflow)?,
            None => held = held.checked_add(v).ok_or_else(overflow)?,
        }
        Ok(())
    })?;
    Ok(FixedAccumulation {
        width: w,
        height: h,
        acc,
        left,
        held,
    })
}

/// Each valid cell's own contribution in fixed point (1 per cell, or its
/// weight; a NaN weight counts 0), 0 for nodata.
pub(crate) fn own_contributions(
    frac: &[[f64; 8]],
    weights: Option<(&Grid<f32>, usize, usize)>,
) -> Result<Vec<i128>> {
    match weights {
        None => Ok(frac
            .iter()
            .map(|f| if f[0].is_nan() { 0 } else { ONE })
            .collect()),
        Some((g, w, h)) => {
            if g.width() != w || g.height() != h {
                return Err(Error::invalid(format!(
                    "weights are {}x{} but the flow fractions are {w}x{h}",
                    g.width(),
                    g.height()
                )));
            }
            frac.iter()
                .zip(g.data())
                .map(|(f, &v)| {
                    if f[0].is_nan() {
                        Ok(0)
                    } else {
                        weight_to_fixed(v)
                    }
                })
                .collect()
        }
    }
}

/// Fixed-point 1 (one cell).
pub(crate) const ONE: i128 = 1i128 << super::WEIGHT_SCALE_BITS;
const SPLIT_SCALE: f64 = (1u64 << 32) as f64;

pub(crate) fn overflow() -> Error {
    Error::invalid(
        "flow accumulation overflowed its fixed-point range (|total| < 2^63 cells or weight units)",
    )
}

/// Splits the fixed-point amount `a` of a cell among its receivers with
/// fractions `f` into `out` (see the module docs): integer shares
/// q_d = round(f_d · 2^32); every receiver but the one with the largest
/// share (the first of equals) gets ⌊a·q_d / 2^32⌋ (a shift, no division),
/// the largest gets the remainder, so Σ out = a exactly. A fraction below
/// 2^-33 gets nothing. All zero when no fraction is positive.
#[inline]
pub(crate) fn split_fixed(a: i128, f: &[f64; 8], out: &mut [i128; 8]) -> Result<()> {
    *out = [0; 8];
    let mut q = [0i128; 8];
    let mut big = 8;
    let mut n = 0;
    for d in 0..8 {
        if f[d] > 0.0 {
            q[d] = (f[d] * SPLIT_SCALE).round() as i128;
            if q[d] > 0 {
                if big == 8 || q[d] > q[big] {
                    big = d;
                }
                n += 1;
            }
        }
    }
    if big == 8 {
        return Ok(());
    }
    if n == 1 {
        out[big] = a;
        return Ok(());
    }
    // |a| < 2^94 keeps a·q (q <= 2^32) inside i128
    if a.unsigned_abs() >= 1u128 << 94 {
        return Err(overflow());
    }
    let mut given = 0i128;
    for d in 0..8 {
        if q[d] > 0 && d != big {
            let v = (a * q[d]) >> 32;
            out[d] = v;
            given += v;
        }
    }
    out[big] = a - given;
    Ok(())
}

/// Kahn's topological order over the fraction graph of a `w` x `h` array
/// (nodata = NaN fractions). `acc` holds each valid cell's own contribution
/// on entry and its accumulation on exit. Shares aimed beyond the array or
/// at nodata go to `export(cell, Some(direction), amount)`; a valid cell
/// without flow reports its accumulation as `export(cell, None, amount)`.
pub(crate) fn accumulate_fixed_core(
    frac: &[[f64; 8]],
    w: usize,
    h: usize,
    acc: &mut [i128],
    mut export: impl FnMut(usize, Option<usize>, i128) -> Result<()>,
) -> Result<()> {
    let n = frac.len();
    let is_valid = |c: usize| !frac[c][0].is_nan();
    let mut indeg = vec![0u8; n];
    let mut valid_cells = 0usize;
    for y in 0..h {
        for x in 0..w {
            let c = y * w + x;
            if !is_valid(c) {
                continue;
            }
            valid_cells += 1;
            for (d, &f) in frac[c].iter().enumerate() {
                if f > 0.0 {
                    if let Some(r) = neighbour(x, y, d, w, h) {
                        if is_valid(r) {
                            indeg[r] += 1;
                        }
                    }
                }
            }
        }
    }
    // a stack: depth-first along flow paths keeps recently touched cells hot
    let mut stack: Vec<u32> = (0..n as u32)
        .rev()
        .filter(|&c| is_valid(c as usize) && indeg[c as usize] == 0)
        .collect();
    let mut done = 0usize;
    let mut share = [0i128; 8];
    while let Some(c) = stack.pop() {
        let c = c as usize;
        done += 1;
        let (x, y) = (c % w, c / w);
        let f = &frac[c];
        split_fixed(acc[c], f, &mut share)?;
        let mut flows = false;
        for d in 0..8 {
            if f[d] <= 0.0 {
                continue;
            }
            flows = true;
            match neighbour(x, y, d, w, h) {
                Some(r) if is_valid(r) => {
                    acc[r] = acc[r].checked_add(share[d]).ok_or_else(overflow)?;
                    indeg[r] -= 1;
                    if indeg[r] == 0 {
                        stack.push(r as u32);
                    }
                }
                _ => export(c, Some(d), share[d])?,
            }
        }
        if !flows {
            export(c, None, acc[c])?;
        }
    }
    if done != valid_cells {
        return Err(Error::invalid(format!(
            "flow fractions contain a cycle ({} cells never drain); they must come from one \
             routing of one DEM",
            valid_cells - done
        )));
    }
    Ok(())
}

fn to_f64_grid(flow: &FlowFractions, acc: &FixedAccumulation) -> Result<Grid<f64>> {
    let out = acc
        .acc
        .iter()
        .zip(&flow.frac)
        .map(|(&v, f)| {
            if f[0].is_nan() {
                f64::NAN
            } else {
                fixed_to_f64(v)
            }
        })
        .collect();
    Grid::from_vec(flow.width, flow.height, out)
}

/// Sum of `weights` over everything draining through each cell, each
/// upstream cell counted with the fraction of its water that reaches it,
/// the cell itself included. NaN for nodata; a NaN weight counts as 0; flow
/// into nodata or beyond the edge leaves. Exact fixed-point sums (module
/// docs) converted to f64 at the end. Errors when sizes differ, on overflow,
/// or when the fractions contain a cycle (they never do when made by this
/// module).
pub fn accumulate_fractions(flow: &FlowFractions, weights: &Grid<f32>) -> Result<Grid<f64>> {
    let acc = accumulate_fixed(flow, Some(weights))?;
    to_f64_grid(flow, &acc)
}

/// Number of cells (fractionally) draining through each cell, itself
/// included; NaN for nodata.
pub fn accumulate_cells(flow: &FlowFractions) -> Result<Grid<f64>> {
    let acc = accumulate_fixed(flow, None)?;
    to_f64_grid(flow, &acc)
}

/// Upslope area (cells × `cell_size`², map units squared) of each cell.
/// Errors unless `cell_size` is finite and > 0.
pub fn upslope_area(flow: &FlowFractions, cell_size: f64) -> Result<Grid<f64>> {
    check_cell_size(cell_size)?;
    let a = cell_size * cell_size;
    Ok(accumulate_cells(flow)?.map(|v| v * a))
}

/// Specific catchment area: upslope area per unit contour width, the
/// contour width being one cell size (Tarboton 1997, § 3): cells ×
/// `cell_size`. Errors unless `cell_size` is finite and > 0.
pub fn specific_catchment_area(flow: &FlowFractions, cell_size: f64) -> Result<Grid<f64>> {
    check_cell_size(cell_size)?;
    Ok(accumulate_cells(flow)?.map(|v| v * cell_size))
}

fn check_cell_size(s: f64) -> Result<()> {
    if s.is_finite() && s > 0.0 {
        Ok(())
    } else {
        Err(Error::invalid(format!(
            "cell size must be a finite number > 0, got {s}"
        )))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn split_is_exact_and_conserves() {
        let mut out = [0i128; 8];
        let f = [0.5, 0.25, 0.25, 0.0, 0.0, 0.0, 0.0, 0.0];
        split_fixed(3 * ONE, &f, &mut out).unwrap();
        assert_eq!(&out[..3], &[3 * ONE / 2, 3 * ONE / 4, 3 * ONE / 4]);
        // thirds of a negative amount: floors, the largest share (first of
        // equals) takes the remainder, the sum is exact
        let t = 1.0 / 3.0;
        let f = [t, 0.0, t, 0.0, t, 0.0, 0.0, 0.0];
        split_fixed(-7, &f, &mut out).unwrap();
        assert_eq!(out.iter().sum::<i128>(), -7);
        assert_eq!((out[2], out[4]), (-3, -3));
        assert_eq!(out[0], -1);
        // many amounts and uneven fractions: sums always exact
        let f = [0.1, 0.2, 0.0, 0.05, 0.3, 0.0, 0.15, 0.2];
        for k in 0..1000i128 {
            let a = k * k * 7919 - 123_456_789;
            split_fixed(a, &f, &mut out).unwrap();
            assert_eq!(out.iter().sum::<i128>(), a);
            assert_eq!(out[2], 0);
            assert_eq!(out[5], 0);
        }
        // no positive fraction: nothing moves; amounts beyond 2^94 are refused
        split_fixed(5, &[0.0; 8], &mut out).unwrap();
        assert_eq!(out, [0; 8]);
        assert!(split_fixed(
            1i128 << 100,
            &[0.5, 0.5, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            &mut out
        )
        .is_err());
    }

    #[test]
    fn bad_exponent_is_an_error() {
        let g = Grid::from_vec(2, 1, vec![1.0f32, 0.0]).unwrap();
        assert!(mfd_flow(&g, MfdMethod::Holmgren(f64::NAN)).is_err());
        assert!(mfd_flow(&g, MfdMethod::Holmgren(0.0)).is_err());
        assert!(upslope_area(&mfd_flow(&g, MfdMethod::Freeman).unwrap(), -1.0).is_err());
    }

    #[test]
    fn chain_accumulates_and_cycles_fail() {
        let g = Grid::from_vec(3, 1, vec![2.0f32, 1.0, 0.0]).unwrap();
        let f = mfd_flow(&g, MfdMethod::Quinn).unwrap();
        assert_eq!(accumulate_cells(&f).unwrap().data(), &[1.0, 2.0, 3.0]);
        let mut bad = f.clone();
        bad.frac[1] = [0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0];
        bad.frac[0] = [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        assert!(accumulate_cells(&bad).is_err());
    }
}
