//! Constrained erosion: stream-power erosion that keeps the elevations of
//! given fixed points (typically the peaks and saddles of a divide tree), after
//! Argudo, Galin, Peytavie, Paris, Gain & Guérin (2019), "Orometry-based
//! terrain analysis and synthesis", *ACM Trans. Graph.* 38(6), §6.3.
//!
//! Outer iterations alternate `steps_per_iteration` steps of
//! [`stream_power`](super::stream_power::StreamPower) with a compensating
//! uplift: for each fixed point `p` whose elevation dropped by `δ_p`, every
//! valid non-base cell within `R` of `p` is raised by `δ_p · g(d/R)`, with
//! `g(r) = (1 − r²)³` (1 at the point, 0 with zero slope at `R`). When
//! several discs overlap, one pass would leave each point off by its
//! neighbours' contributions, so the compensation is repeated point by point
//! (Gauss–Seidel on the system `Σ_q g(d_pq/R)·w_q = δ_p`) until every point
//! is within `tolerance` of its target or `max_sweeps` sweeps were made.

use super::stream_power::{StreamPower, StreamPowerParams, Uplift};
use crate::error::{Error, Result};
use crate::raster::Grid;

/// Parameters of [`erode_constrained`].
#[derive(Debug, Clone, PartialEq)]
pub struct ConstrainedParams {
    /// Stream-power parameters of each erosion step (diffusion included).
    pub stream: StreamPowerParams,
    /// Background uplift rate (m/yr) applied during the erosion steps.
    pub uplift: f64,
    /// Outer iterations (erosion + compensation), ≥ 1.
    pub iterations: usize,
    /// Erosion steps per outer iteration, ≥ 1.
    pub steps_per_iteration: usize,
    /// Largest distance (m) a fixed point may end from its target.
    pub tolerance: f64,
    /// Most compensation sweeps per iteration.
    pub max_sweeps: usize,
}

impl Default for ConstrainedParams {
    fn default() -> Self {
        ConstrainedParams {
            stream: StreamPowerParams::default(),
            uplift: 0.0,
            iterations: 10,
            steps_per_iteration: 10,
            tolerance: 1e-3,
            max_sweeps: 50,
        }
    }
}

/// Erode `h` (f32 elevations, square cells of `cell` m, NaN = nodata) while
/// keeping the initial elevations of the `fixed` cells (column, row) — see the
/// module doc. Uses only the given arrays (no georeference needed): the
/// orometric synthesis calls it with the peaks and saddles of its divide tree.
/// The computation runs in f64 and is rounded to f32 at the end; the fixed
/// points end within `p.tolerance` (plus f32 rounding) of their targets, or
/// the error says by how much they missed.
pub fn erode_constrained(
    h: &mut Grid<f32>,
    cell: f64,
    fixed: &[(usize, usize)],
    radius_m: f64,
    p: &ConstrainedParams,
) -> Result<()> {
    let mut g = h.map(|v| v as f64);
    erode_constrained_f64(&mut g, cell, fixed, radius_m, p)?;
    *h = g.map(|v| v as f32);
    Ok(())
}

/// [`erode_constrained`] on an f64 grid.
pub fn erode_constrained_f64(
    h: &mut Grid<f64>,
    cell: f64,
    fixed: &[(usize, usize)],
    radius_m: f64,
    p: &ConstrainedParams,
) -> Result<()> {
    if p.iterations == 0 || p.steps_per_iteration == 0 {
        return Err(Error::invalid(format!(
            "constrained erosion: iterations = {} and steps per iteration = {}; both must be at least 1",
            p.iterations, p.steps_per_iteration
        )));
    }
    if !(radius_m.is_finite() && radius_m > 0.0) {
        return Err(Error::invalid(format!(
            "constrained erosion: radius {radius_m} m is invalid; give a distance > 0 (e.g. 10 cells)"
        )));
    }
    if !(p.tolerance.is_finite() && p.tolerance > 0.0) || p.max_sweeps == 0 {
        return Err(Error::invalid(
            "constrained erosion: tolerance must be > 0 and max_sweeps >= 1",
        ));
    }
    if !p.uplift.is_finite() {
        return Err(Error::invalid(format!(
            "constrained erosion: uplift rate {} is not finite",
            p.uplift
        )));
    }
    let (w, ht) = (h.width(), h.height());
    let mut targets = Vec::with_capacity(fixed.len());
    for &(x, y) in fixed {
        if x >= w || y >= ht {
            return Err(Error::invalid(format!(
                "constrained erosion: fixed point (column {x}, row {y}) is outside the {w}x{ht} DEM"
            )));
        }
        let v = h.get(x, y);
        if !v.is_finite() {
            return Err(Error::invalid(format!(
                "constrained erosion: fixed point (column {x}, row {y}) is on a nodata cell"
            )));
        }
        targets.push(v);
    }
    let mut sp = StreamPower::new(h, cell, &p.stream)?;
    // Base-level heights may have been reset to zero: targets on base levels follow.
    for (t, &(x, y)) in targets.iter_mut().zip(fixed) {
        *t = h.get(x, y);
    }
    let disc = Disc::new(radius_m, cell);
    let up = Uplift::Uniform(p.uplift);
    for _ in 0..p.iterations {
        for _ in 0..p.steps_per_iteration {
            sp.step(h, &up)?;
        }
        compensate(h, &sp, fixed, &targets, &disc, p.tolerance, p.max_sweeps);
    }
    let worst = fixed
        .iter()
        .zip(&targets)
        .map(|(&(x, y), t)| (h.get(x, y) - t).abs())
        .fold(0.0f64, f64::max);
    if worst > p.tolerance {
        return Err(Error::invalid(format!(
            "constrained erosion: a fixed point is still {worst:.3} m from its target after {} sweeps; \
             the fixed points are too close for radius {radius_m} m (use a smaller radius or fewer points)",
            p.max_sweeps
        )));
    }
    Ok(())
}

/// Offsets and weights `g(d/R)` of the cells within `R` of a point.
struct Disc {
    cells: Vec<(isize, isize, f64)>,
}

impl Disc {
    fn new(radius_m: f64, cell: f64) -> Disc {
        let r = (radius_m / cell).floor() as isize;
        let mut cells = Vec::new();
        for dy in -r..=r {
            for dx in -r..=r {
                let d = ((dx * dx + dy * dy) as f64).sqrt() * cell;
                if d < radius_m {
                    let q = d / radius_m;
                    let t = 1.0 - q * q;
                    cells.push((dx, dy, t * t * t));
                }
            }
        }
        Disc { cells }
    }
}

/// Gauss–Seidel sweeps of the compensating uplift (see the module doc).
fn compensate(
    h: &mut Grid<f64>,
    sp: &StreamPower,
    fixed: &[(usize, usize)],
    targets: &[f64],
    disc: &Disc,
    tol: f64,
    max_sweeps: usize,
) {
    let (w, ht) = (h.width() as isize, h.height() as isize);
    let wu = h.width();
    for _ in 0..max_sweeps {
        let mut worst = 0.0f64;
        for (&(x, y), &t) in fixed.iter().zip(targets) {
            let delta = t - h.get(x, y);
            worst = worst.max(delta.abs());
            if delta == 0.0 {
                continue;
            }
            let data = h.data_mut();
            for &(dx, dy, g) in &disc.cells {
                let (nx, ny) = (x as isize + dx, y as isize + dy);
                if nx < 0 || ny < 0 || nx >= w || ny >= ht {
                    continue;
                }
                let i = ny as usize * wu + nx as usize;
                if sp.is_base(i) || !data[i].is_finite() {
                    continue;
                }
                data[i] += delta * g;
            }
        }
        if worst <= tol * 0.01 {
            break;
        }
    }
}
