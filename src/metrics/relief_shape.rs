//! Relief-and-steepness descriptors over a disk with a distance cutoff:
//! ORS, the omni-directional relief and steepness of Earl & Metzler (2015,
//! "Cloud-capped towers: capturing terrain characteristics using topographic
//! functionals", Quaestiones Geographicae 34(4)), and jut and rut, the
//! angle-reduced heights of Xu (2022, "Datumless topography: a universally
//! consistent way to quantify relief", arXiv 2208.01600), in their planar
//! form as the survey of Argudo et al. (sec. 3.5) uses them.
//!
//! For the cell `p` and every other valid cell `q` with horizontal distance
//! `0 < d ≤ R` (true metres) and height difference `Δ = z_p − z_q`:
//! - ORS `= √(Σ_{Δ>0} f(Δ/d) ΔA)` with Earl & Metzler's convergent kernel
//!   `f(u) = 4/π³ (2u atan u − ln(1+u²) − atan² u)` (≥ 0; ~ 2u⁴/π³ for small
//!   u, ~ 4u/π² for large u);
//! - jut `= max(0, max_q Δ|Δ|/√(d²+Δ²))`: the height of `p` above `q`
//!   reduced by the sine of the angle between them (cliffs jut most);
//! - rut `= max(0, max_q (−Δ)|Δ|/√(d²+Δ²))`: the same for cells above `p`.
//!
//! Halo = cutoff, so the values within the cutoff are exact in tiles.

use super::dominance::DiskPosition;
use super::fractional::disk_map;
use super::param::{PLANET, RADIUS_CUTOFF};
use super::registry::metric_def;
use crate::raster::{Grid, TileView};

/// Earl & Metzler's ORS kernel `f(u)`, clamped at 0 against rounding.
#[inline]
pub fn ors_kernel(u: f64) -> f64 {
    let a = u.atan();
    (4.0 / std::f64::consts::PI.powi(3) * (2.0 * u * a - (u * u + 1.0).ln() - a * a)).max(0.0)
}

/// Which of the three descriptors to compute.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReliefShape {
    Ors,
    Jut,
    Rut,
}

/// ORS, jut or rut of every core cell with cutoff `radius_m` (at most `rc`
/// cells per axis, `rc ≤` the view's halo). Nodata cells are nodata and are
/// left out of the neighbourhoods.
pub fn relief_shape(
    view: &TileView<f32>,
    rc: usize,
    radius_m: f64,
    which: ReliefShape,
    o: &mut Grid<f32>,
) {
    let area_of = |row: i64, _: &mut [f64]| {
        let (ew, ns) = view.georef.cell_size_m(row);
        ew * ns
    };
    disk_map(view, rc, radius_m, o, area_of, |area, z, disk| {
        let mut acc = 0.0f64;
        for (v, d) in disk.cells() {
            // NaN neighbours fail every comparison below.
            let dz = z - v;
            match which {
                ReliefShape::Ors => {
                    if dz > 0.0 {
                        acc += ors_kernel(dz / d);
                    }
                }
                // dz²/√(d²+dz²) < |dz|: a cell with |dz| ≤ acc cannot
                // raise the maximum, so the division is skipped (exact).
                ReliefShape::Jut => {
                    if dz > acc {
                        acc = acc.max(dz * dz / (d * d + dz * dz).sqrt());
                    }
                }
                ReliefShape::Rut => {
                    if -dz > acc {
                        acc = acc.max(dz * dz / (d * d + dz * dz).sqrt());
                    }
                }
            }
        }
        if which == ReliefShape::Ors {
            (acc * area).sqrt()
        } else {
            acc
        }
    });
}

/// `ors`: omni-directional relief and steepness sqrt(sum over lower cells in the disk of f(drop/distance) * cell area).
///
/// Source: Earl & Metzler 2015, Quaestiones Geographicae 34(4) (ORS); disk cutoff.
pub static ORS: DiskPosition = DiskPosition(metric_def!(
        Ors,
        "ors",
        &[RADIUS_CUTOFF],
        "z",
        "omni-directional relief and steepness sqrt(sum over lower cells in the disk of f(drop/distance) * cell area)",
        "Earl & Metzler 2015, Quaestiones Geographicae 34(4) (ORS); disk cutoff"
    ));

/// `jut`: max over the disk of the angle-reduced height dz*|dz|/d3 of the cell above others (planar; with planet=R km heights above the base horizon on a sphere; >= 0).
///
/// Source: Xu 2022, Beyond elevation / datumless topography (arXiv 2208.01600); planar, or spherical with planet=R km; disk cutoff.
pub static JUT: DiskPosition = DiskPosition(metric_def!(
        Jut,
        "jut",
        &[RADIUS_CUTOFF, PLANET],
        "z",
        "max over the disk of the angle-reduced height dz*|dz|/d3 of the cell above others (planar; with planet=R km heights above the base horizon on a sphere; >= 0)",
        "Xu 2022, Beyond elevation / datumless topography (arXiv 2208.01600); planar, or spherical with planet=R km; disk cutoff"
    ));

/// `rut`: max over the disk of the angle-reduced height dz*|dz|/d3 of others above the cell (planar; with planet=R km heights above the base horizon on a sphere; >= 0).
///
/// Source: Xu 2022, Beyond elevation / datumless topography (arXiv 2208.01600); planar, or spherical with planet=R km; disk cutoff.
pub static RUT: DiskPosition = DiskPosition(metric_def!(
        Rut,
        "rut",
        &[RADIUS_CUTOFF, PLANET],
        "z",
        "max over the disk of the angle-reduced height dz*|dz|/d3 of others above the cell (planar; with planet=R km heights above the base horizon on a sphere; >= 0)",
        "Xu 2022, Beyond elevation / datumless topography (arXiv 2208.01600); planar, or spherical with planet=R km; disk cutoff"
    ));
