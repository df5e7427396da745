//! Xu's datumless measures on a spherical planet: dominance, submission,
//! jut and rut (K. Xu 2022, "Beyond elevation: new metrics to quantify the
//! relief of mountains and surfaces of any terrestrial body", arXiv
//! 2208.01600), next to the planar forms of `dominance` and `relief_shape`.
//!
//! What could be retrieved of the definitions (Xu's README, the jut article
//! citing the paper, and the survey's reference code): jut is the maximum
//! *angle-reduced height* `H' = H sin e`, the projection on the line of sight
//! of the summit's height `H`, where `e` is the summit's elevation angle seen
//! from the base. That projection equals `H sin e` only if `H` is measured
//! along the BASE's plumb line, so on a sphere of radius `R` with the
//! summit at radius `a = R + z_s`, the base at `b = R + z_b` and the
//! horizontal distance `d` read as an arc (`θ = d / R`):
//!
//! - `H = a cos θ − b` (height of the summit above the base's horizon plane;
//!   computed as `(z_s − z_b) − 2a sin²(θ/2)`, without cancellation),
//! - line of sight `L = √((z_s − z_b)² + 4ab sin²(θ/2))`, `H' = H|H| / L`.
//!
//! For a cell `p` and every valid `q` of the disk `0 < d ≤ cutoff`:
//! dominance `= max(0, max_q H(summit p, base q))`, submission
//! `= max(0, max_q H(summit q, base p))`, jut and rut the same with `H'`.
//! The planet's curvature makes far cells drop below the base's horizon, so
//! the maxima are bounded even without the cutoff (which tiles still need:
//! halo = cutoff). As R → ∞ they tend to the planar forms. The rut equals
//! the survey code's `RutCurved`; its `JutCurved` measures `H` along the
//! summit's plumb line instead (`a − b cos θ`, which grows with distance),
//! which does not match `H sin e`; orogen uses the base's for both.
//! Nodata cells are nodata and left out. O(r²) per cell.

use super::fractional::disk_map;
use crate::raster::{Grid, TileView};

/// Which of Xu's four measures.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Xu {
    Dominance,
    Submission,
    Jut,
    Rut,
}

/// The spherical measure `which` of every core cell, planet radius
/// `planet_m` metres, cutoff `radius_m` (at most `rc` cells per axis, `rc ≤`
/// the view's halo).
pub fn spherical(
    view: &TileView<f32>,
    rc: usize,
    radius_m: f64,
    planet_m: f64,
    which: Xu,
    o: &mut Grid<f32>,
) {
    // 2 sin²(θ/2) = 1 − cos θ per offset, in place of the distance.
    let half_versine = |_: i64, dist: &mut [f64]| {
        for d in dist.iter_mut() {
            let t = (*d / planet_m / 2.0).sin();
            *d = 2.0 * t * t;
        }
    };
    disk_map(view, rc, radius_m, o, half_versine, |(), z, disk| {
        let a = planet_m + z;
        let mut acc = 0.0f64;
        for (v, s) in disk.cells() {
            if v.is_nan() {
                continue;
            }
            let b = planet_m + v;
            // (summit, base) and the summit's height above the base's horizon.
            let (dz, hh, ab) = match which {
                Xu::Dominance | Xu::Jut => (z - v, (z - v) - a * s, a * b),
                Xu::Submission | Xu::Rut => (v - z, (v - z) - b * s, a * b),
            };
            match which {
                Xu::Dominance | Xu::Submission => acc = acc.max(hh),
                // H' = H²/L ≤ H (L is the chord, H its projection): a
                // height ≤ acc cannot raise the maximum.
                Xu::Jut | Xu::Rut => {
                    if hh > acc {
                        let l = (dz * dz + 2.0 * ab * s).sqrt();
                        acc = acc.max(hh * hh / l);
                    }
                }
            }
        }
        acc
    });
}
