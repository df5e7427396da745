//! D-infinity flow directions (Tarboton, D. G. (1997). "A new method for the
//! determination of flow directions and upslope areas in grid digital
//! elevation models", Water Resources Research 33(2), 309–319).
//!
//! Around each cell the 8 triangular facets formed by the cell, one edge
//! neighbour e1 and the diagonal neighbour e2 next to it are fitted with a
//! plane; the facet with the steepest downslope gradient gives the flow
//! angle (radians, 0 = east, counter-clockwise, north up, as Tarboton and
//! TauDEM). Within a facet, with s1 = (e0 − e1)/d1 and s2 = (e1 − e2)/d2
//! (d1 the distance to e1, d2 the spacing from e1 to e2: 1 and 1 on square
//! cells), r = atan2(s2, s1) is clamped to [0, atan(d2/d1)]: at 0 the slope
//! is s1, at the facet's angle it is (e0 − e2)/√(d1² + d2²), in between
//! √(s1² + s2²) (Tarboton 1997, eqs. 1–3, written there for rectangular
//! cells d1 x d2). The flow is split between e1 and e2 in proportion to
//! angular proximity: e2 gets r / atan(d2/d1), e1 the rest. The legs come
//! from [`CellGeometry`]: square cells give the paper's π/4 facets bit for
//! bit; on geographic grids each row has its own legs in metres (as TauDEM
//! does with its per-row dx on geographic grids). Ties between facets go to the first facet in
//! Tarboton's order (E–NE, N–NE, N–NW, W–NW, W–SW, S–SW, S–SE, E–SE).
//!
//! Facets with a nodata or off-raster vertex are not considered. A cell with
//! no facet sloping down (a flat of a filled DEM, an outlet cell whose only
//! way down is off the DEM, a pit) takes the D8 direction of
//! [`super::d8_directions`] — Barnes et al. (2014) flat gradients on flats,
//! the first off-DEM neighbour on outlet cells — with all its water and the
//! angle of that direction; unfilled-DEM pits keep no flow and angle −1.
//! Accumulation of the resulting [`FlowFractions`] is
//! [`super::mfd::accumulate_fractions`] and friends.

use super::mfd::{neighbour, route_with_fallback, FlowFractions};
use super::valid;
use crate::error::Result;
use crate::raster::neighbours::{CellGeometry, RowGeometry};
use crate::raster::Grid;
use std::f64::consts::{FRAC_PI_2, FRAC_PI_4};

/// Angle of a valid cell that does not drain (pit of an unfilled DEM).
pub const DINF_NO_FLOW: f32 = -1.0;

/// Facets in Tarboton's order: (edge neighbour e1, diagonal neighbour e2) as
/// indices into the module's E, SE, S, SW, W, NW, N, NE order, and the
/// (a_c, a_f) of the angle a = a_c·π/2 + a_f·r.
const FACETS: [(usize, usize, f64, f64); 8] = [
    (0, 7, 0.0, 1.0),  // E, NE
    (6, 7, 1.0, -1.0), // N, NE
    (6, 5, 1.0, 1.0),  // N, NW
    (4, 5, 2.0, -1.0), // W, NW
    (4, 3, 2.0, 1.0),  // W, SW
    (2, 3, 3.0, -1.0), // S, SW
    (2, 1, 3.0, 1.0),  // S, SE
    (0, 1, 4.0, -1.0), // E, SE
];

/// D∞ routing of a DEM: flow angles and the flow fractions they imply.
#[derive(Clone, Debug)]
pub struct Dinf {
    /// Flow angle in radians in [0, 2π) (0 = east, counter-clockwise); NaN
    /// for nodata, [`DINF_NO_FLOW`] for a valid cell that does not drain.
    pub angle: Grid<f32>,
    /// Fractions towards the 8 neighbours (at most two non-zero).
    pub flow: FlowFractions,
}

/// Angle (radians, counter-clockwise from east) of neighbour direction `d`
/// of the E, SE, S, SW, W, NW, N, NE order.
fn dir_angle(d: usize) -> f64 {
    ((8 - d) % 8) as f64 * FRAC_PI_4
}

/// D∞ fractions of the valid cell (x, y) of a `w` x `h` elevation array
/// into `f`, returning the flow angle; `None` when no facet slopes down (the
/// caller falls back to D8). Shared by the in-memory and tiled routers.
pub(crate) fn dinf_cell(
    z: &[f32],
    w: usize,
    h: usize,
    x: usize,
    y: usize,
    g: &RowGeometry,
    f: &mut [f64; 8],
) -> Option<f64> {
    let e0 = z[y * w + x] as f64;
    let mut best_s = 0.0f64;
    let mut best: Option<(usize, f64)> = None;
    for (k, &(d1, d2, _, _)) in FACETS.iter().enumerate() {
        let (Some(n1), Some(n2)) = (neighbour(x, y, d1, w, h), neighbour(x, y, d2, w, h)) else {
            continue;
        };
        let (z1, z2) = (z[n1], z[n2]);
        if !valid(z1) || !valid(z2) {
            continue;
        }
        let (e1, e2) = (z1 as f64, z2 as f64);
        let (l1, l2, r_max, hyp) = g.facet[k];
        let s1 = (e0 - e1) / l1;
        let s2 = (e1 - e2) / l2;
        let mut r = s2.atan2(s1);
        let s = if r <= 0.0 {
            r = 0.0;
            s1
        } else if r >= r_max {
            r = r_max;
            (e0 - e2) / hyp
        } else {
            s1.hypot(s2)
        };
        if s > best_s {
            best_s = s;
            best = Some((k, r));
        }
    }
    let (k, r) = best?;
    let (d1, d2, ac, af) = FACETS[k];
    let p2 = r / g.facet[k].2;
    f[d2] = p2;
    f[d1] = 1.0 - p2;
    let mut a = ac * FRAC_PI_2 + af * r;
    if a >= 2.0 * std::f64::consts::PI {
        a = 0.0;
    }
    Some(a)
}

/// D∞ flow angles and fractions of `dem` (normally a filled DEM; NaN =
/// nodata; square cells). Errors only for grids of more than 2^32 cells.
pub fn dinf(dem: &Grid<f32>) -> Result<Dinf> {
    dinf_on(dem, &CellGeometry::square())
}

/// [`dinf`] with the facet legs of `geo` (one row per row of `dem`; true
/// distances on geographic grids).
pub fn dinf_on(dem: &Grid<f32>, geo: &CellGeometry) -> Result<Dinf> {
    let (w, h) = (dem.width(), dem.height());
    let mut angle = vec![f32::NAN; w * h];
    let (flow, fell_back) = route_with_fallback(dem, geo, |z, x, y, g, f| {
        match dinf_cell(z, w, h, x, y, g, f) {
            Some(a) => {
                angle[y * w + x] = a as f32;
                true
            }
            None => false,
        }
    })?;
    for y in 0..h {
        for x in 0..w {
            let c = y * w + x;
            if !fell_back[c] {
                continue;
            }
            angle[c] = match flow.fractions(x, y) {
                Some(fr) => match fr.iter().position(|&v| v > 0.0) {
                    Some(d) => dir_angle(d) as f32,
                    None => DINF_NO_FLOW,
                },
                None => f32::NAN,
            };
        }
    }
    Ok(Dinf {
        angle: Grid::from_vec(w, h, angle)?,
        flow,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn facet_angles_follow_tarboton() {
        // 3x3 with the centre high and one lower neighbour: flow goes there.
        for d in 0..8 {
            let mut z = vec![10.0f32; 9];
            z[4] = 11.0;
            let (dx, dy) = (super::super::DX[d], super::super::DY[d]);
            z[((1 + dy) * 3 + 1 + dx) as usize] = 0.0;
            let r = dinf(&Grid::from_vec(3, 3, z).unwrap()).unwrap();
            let a = r.angle.get(1, 1) as f64;
            assert!((a - dir_angle(d) as f32 as f64).abs() < 1e-6, "d={d} a={a}");
            assert_eq!(r.flow.fractions(1, 1).unwrap()[d], 1.0);
        }
    }
}
