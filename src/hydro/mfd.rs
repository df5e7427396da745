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
//! sorting of large networks", CACM 5), O(n), summing in f64. The order is a
//! fixed function of the input, so results are the same bits on every run.

use super::{code_to_dir, valid, DX, DY, NODATA_DIR};
use crate::error::{Error, Result};
use crate::raster::Grid;

/// Fractions marking a nodata cell (never routed, never counted).
const NODATA_FRAC: [f64; 8] = [f64::NAN; 8];
/// Distance to each neighbour in cell sizes, order E..NE.
pub(crate) const DIST: [f64; 8] = [
    1.0,
    std::f64::consts::SQRT_2,
    1.0,
    std::f64::consts::SQRT_2,
    1.0,
    std::f64::consts::SQRT_2,
    1.0,
    std::f64::consts::SQRT_2,
];
/// Quinn et al. (1991) contour lengths (cell sizes), order E..NE.
const QUINN_L: [f64; 8] = [
    0.5,
    std::f64::consts::SQRT_2 / 4.0,
    0.5,
    std::f64::consts::SQRT_2 / 4.0,
    0.5,
    std::f64::consts::SQRT_2 / 4.0,
    0.5,
    std::f64::consts::SQRT_2 / 4.0,
];

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

/// Index of neighbour `d` of (x, y), or `None` beyond the grid.
#[inline]
pub(crate) fn neighbour(x: usize, y: usize, d: usize, w: usize, h: usize) -> Option<usize> {
    let nx = x as i64 + DX[d];
    let ny = y as i64 + DY[d];
    if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
        None
    } else {
        Some(ny as usize * w + nx as usize)
    }
}

/// Builds a [`FlowFractions`] from `route`, which fills the fractions of a
/// valid cell and returns false when the cell has no downslope direction;
/// such cells take their D8 direction (flats, outlet cells, pits).
pub(crate) fn route_with_fallback(
    dem: &Grid<f32>,
    mut route: impl FnMut(&[f32], usize, usize, &mut [f64; 8]) -> bool,
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
            if !route(z, x, y, &mut f) {
                fell_back[c] = true;
                any_fallback = true;
            }
            frac[c] = f;
        }
    }
    if any_fallback {
        let d8 = super::d8_directions(dem);
        for (c, &fb) in fell_back.iter().enumerate() {
            if !fb {
                continue;
            }
            let code = d8.data()[c];
            let mut f = [0.0f64; 8];
            if code != NODATA_DIR {
                if let Some(d) = code_to_dir(code) {
                    f[d] = 1.0;
                }
            }
            frac[c] = f;
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

/// MFD flow fractions of `dem` (normally a filled DEM; NaN = nodata) with
/// the weighting `method`. Errors for a Holmgren exponent that is not a
/// finite positive number and for grids of more than 2^32 cells.
pub fn mfd_flow(dem: &Grid<f32>, method: MfdMethod) -> Result<FlowFractions> {
    let (exponent, contour) = match method {
        MfdMethod::Quinn => (1.0, true),
        MfdMethod::Freeman => (1.1, false),
        MfdMethod::Holmgren(p) => {
            if !(p.is_finite() && p > 0.0) {
                return Err(Error::invalid(format!(
                    "Holmgren MFD exponent must be a finite number > 0, got {p}"
                )));
            }
            (p, false)
        }
    };
    let (w, h) = (dem.width(), dem.height());
    let (flow, _) = route_with_fallback(dem, |z, x, y, f| {
        let zc = z[y * w + x] as f64;
        // tan β of every lower valid neighbour; remember the steepest so that
        // large exponents are computed relative to it (no overflow to ∞).
        let mut tan = [0.0f64; 8];
        let mut max_tan = 0.0f64;
        for d in 0..8 {
            if let Some(n) = neighbour(x, y, d, w, h) {
                let zn = z[n];
                if valid(zn) && (zn as f64) < zc {
                    tan[d] = (zc - zn as f64) / DIST[d];
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
                    wgt *= QUINN_L[d];
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
    })?;
    Ok(flow)
}

/// Sum of `weights` over everything draining through each cell, each
/// upstream cell counted with the fraction of its water that reaches it,
/// the cell itself included. NaN for nodata; a NaN weight counts as 0; flow
/// into nodata or beyond the edge leaves. Errors when sizes differ or the
/// fractions contain a cycle (they never do when made by this module).
pub fn accumulate_fractions(flow: &FlowFractions, weights: &Grid<f32>) -> Result<Grid<f64>> {
    let (w, h) = (flow.width, flow.height);
    if weights.width() != w || weights.height() != h {
        return Err(Error::invalid(format!(
            "weights are {}x{} but the flow fractions are {w}x{h}",
            weights.width(),
            weights.height()
        )));
    }
    let mut acc: Vec<f64> = weights
        .data()
        .iter()
        .zip(&flow.frac)
        .map(|(&v, f)| {
            if f[0].is_nan() {
                f64::NAN
            } else if v.is_nan() {
                0.0
            } else {
                v as f64
            }
        })
        .collect();
    accumulate_core(flow, &mut acc)?;
    Grid::from_vec(w, h, acc)
}

/// Number of cells (fractionally) draining through each cell, itself
/// included; NaN for nodata.
pub fn accumulate_cells(flow: &FlowFractions) -> Result<Grid<f64>> {
    let mut acc: Vec<f64> = flow
        .frac
        .iter()
        .map(|f| if f[0].is_nan() { f64::NAN } else { 1.0 })
        .collect();
    accumulate_core(flow, &mut acc)?;
    Grid::from_vec(flow.width, flow.height, acc)
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

/// Kahn's topological order over the fraction graph; `acc` holds each valid
/// cell's own contribution on entry (NaN for nodata) and its accumulation on
/// exit.
fn accumulate_core(flow: &FlowFractions, acc: &mut [f64]) -> Result<()> {
    let (w, h) = (flow.width, flow.height);
    let frac = &flow.frac;
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
    let mut queue: Vec<usize> = (0..n).filter(|&c| is_valid(c) && indeg[c] == 0).collect();
    let mut head = 0;
    while head < queue.len() {
        let c = queue[head];
        head += 1;
        let (x, y) = (c % w, c / w);
        let a = acc[c];
        for (d, &f) in frac[c].iter().enumerate() {
            if f <= 0.0 {
                continue;
            }
            if let Some(r) = neighbour(x, y, d, w, h) {
                if is_valid(r) {
                    acc[r] += a * f;
                    indeg[r] -= 1;
                    if indeg[r] == 0 {
                        queue.push(r);
                    }
                }
            }
        }
    }
    if queue.len() != valid_cells {
        return Err(Error::invalid(format!(
            "flow fractions contain a cycle ({} cells never drain); they must come from one \
             routing of one DEM",
            valid_cells - queue.len()
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

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
