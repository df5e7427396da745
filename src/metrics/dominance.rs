//! Position-in-the-surroundings descriptors over a disk with a distance
//! cutoff (the orometric family of the survey of Argudo, Guérin, Schott &
//! Galin, sec. 3.5), computed per cell with halo = cutoff so that tiled runs
//! equal untiled ones:
//!
//! - **dominance** and **submission** (Xu 2022, "Datumless topography: a
//!   universally consistent way to quantify relief", arXiv 2208.01600), in
//!   the planar form used for jut and rut (`relief_shape`): dominance
//!   `= max(0, max_q z_p − z_q)`, how far the cell rises above the lowest
//!   cell of the disk (0 = a "submissive" cell, the lowest of its
//!   surroundings); submission `= max(0, max_q z_q − z_p)`, how far it dips
//!   below the highest (0 = a "dominant" cell). Xu's spherical form lets the
//!   planet's curvature bound the search; on a DEM the cutoff does.
//! - **peakedness** (Deng & Wilson 2008, "Multi-scale and multi-criteria
//!   mapping of mountain peaks as fuzzy entities", IJGIS 22(1-2); the
//!   survey's code computes it as Llobera's 2001 "topographic prominence"):
//!   the share (0..1) of the other valid cells of the disk strictly lower
//!   than the cell. Unlike `percentile` (square window, in %), the window is
//!   the true-metre disk. Deng & Wilson's multi-scale summary is the mean of
//!   this value over several radii (request several radii and average).
//! - **geographical domination** ("Dominanz" of German orometry; the
//!   isolation of a summit): the horizontal distance in metres from the cell
//!   to the nearest strictly higher valid cell. A cell with no higher cell
//!   within the cutoff gets the cutoff (its domination is at least that).
//!
//! `q` ranges over the valid cells at true-metre distance `0 < d ≤ R`
//! (`fractional::disk_offsets`); nodata cells are nodata and left out of the
//! neighbourhoods. O(r²) per cell.

use super::fractional::disk_offsets;
use super::param::{PLANET, RADIUS_CUTOFF};
use super::registry::{metric_def, Metric, MetricDef, MetricKind};
use super::spec::Resolved;
use super::tile::Tile;
use crate::error::Result;
use crate::raster::{Grid, TileView};

/// The disk of [`disk_offsets`] as contiguous row spans `(offset of the
/// first cell, length)` in the view's grid (the centre row in two spans
/// around the centre), so that the order-free reductions (min, max,
/// counts) run over contiguous slices, which the compiler vectorises.
pub fn disk_spans(view: &TileView<f32>, rc: usize, radius_m: f64, row: i64) -> Vec<(isize, usize)> {
    let (ew, ns) = view.georef.cell_size_m(row);
    let gw = view.grid.width() as isize;
    let rc = rc as isize;
    let mut spans = Vec::new();
    for dy in -rc..=rc {
        // Same test as disk_offsets; |dx| ≤ hw is an interval.
        let inside = |dx: isize| {
            ((dx as f64 * ew).powi(2) + (dy as f64 * ns).powi(2)).sqrt() <= radius_m * (1.0 + 1e-12)
        };
        let mut hw: isize = -1;
        while hw < rc && inside(hw + 1) {
            hw += 1;
        }
        if hw < 0 {
            continue;
        }
        if dy == 0 {
            if hw > 0 {
                spans.push((-hw, hw as usize));
                spans.push((1, hw as usize));
            }
        } else {
            spans.push((dy * gw - hw, (2 * hw + 1) as usize));
        }
    }
    spans
}

/// Which descriptor to compute.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Position {
    Dominance,
    Submission,
    Peakedness,
    Domination,
}

/// The descriptor `which` of every core cell with cutoff `radius_m` (at
/// most `rc` cells per axis, `rc ≤` the view's halo).
pub fn position(
    view: &TileView<f32>,
    rc: usize,
    radius_m: f64,
    which: Position,
    o: &mut Grid<f32>,
) {
    let (h, gw) = (view.halo, view.grid.width());
    let data = view.grid.data();
    for y in 0..view.core.h {
        let row = view.core.y + y as i64;
        // Domination: offsets by increasing distance, so that the first
        // higher cell met is the nearest (the scan stops there).
        let by_dist: Vec<(f64, isize)> = if which == Position::Domination {
            let (off, dist) = disk_offsets(view, rc, radius_m, row);
            let mut v: Vec<(f64, isize)> = dist.into_iter().zip(off).collect();
            v.sort_by(|a, b| a.0.total_cmp(&b.0));
            v
        } else {
            Vec::new()
        };
        let spans = disk_spans(view, rc, radius_m, row);
        for x in 0..view.core.w {
            let ci = (y + h) * gw + x + h;
            let z = data[ci];
            if z.is_nan() {
                o.set(x, y, f32::NAN);
                continue;
            }
            let span = |&(s, n): &(isize, usize)| {
                let a = (ci as isize + s) as usize;
                &data[a..a + n]
            };
            let v = match which {
                Position::Dominance => {
                    // min over valid neighbours; NaN never lowers it.
                    let mut lo = z;
                    for sp in &spans {
                        lo = span(sp).iter().fold(lo, |m, &v| if v < m { v } else { m });
                    }
                    z as f64 - lo as f64
                }
                Position::Submission => {
                    let mut hi = z;
                    for sp in &spans {
                        hi = span(sp).iter().fold(hi, |m, &v| if v > m { v } else { m });
                    }
                    hi as f64 - z as f64
                }
                Position::Peakedness => {
                    let (mut lower, mut n) = (0u32, 0u32);
                    for sp in &spans {
                        for &v in span(sp) {
                            n += u32::from(!v.is_nan());
                            lower += u32::from(v < z);
                        }
                    }
                    if n == 0 {
                        f64::NAN
                    } else {
                        lower as f64 / n as f64
                    }
                }
                Position::Domination => {
                    let mut best = radius_m;
                    for &(d, k) in &by_dist {
                        if data[(ci as isize + k) as usize] > z {
                            best = best.min(d);
                            break;
                        }
                    }
                    best
                }
            };
            o.set(x, y, v as f32);
        }
    }
}

/// The descriptors of relative position in a disk: dominance, submission,
/// peakedness and domination (here), ORS, jut and rut
/// ([`super::relief_shape`]); dominance, submission, jut and rut in Xu's
/// spherical form ([`super::xu`]) when `planet` gives a radius (km).
pub struct DiskPosition(pub MetricDef);

impl Metric for DiskPosition {
    fn def(&self) -> &MetricDef {
        &self.0
    }
    fn halo(&self, m: &Resolved) -> usize {
        m.radius_cells
    }
    fn run(&self, t: &mut Tile<'_>, m: &Resolved, o: &mut Grid<f32>) -> Result<()> {
        use super::relief_shape::{relief_shape, ReliefShape};
        use super::xu::{spherical, Xu};
        use MetricKind::*;
        let (view, rc, rm) = (t.view, m.radius_cells, m.radius_m);
        let kind = self.0.kind;
        if let (Some(planet), Dominance | Submission | Jut | Rut) = (m.spec.value("planet"), kind) {
            let which = match kind {
                Dominance => Xu::Dominance,
                Submission => Xu::Submission,
                Jut => Xu::Jut,
                _ => Xu::Rut,
            };
            spherical(view, rc, rm, planet * 1000.0, which, o);
            return Ok(());
        }
        match kind {
            Ors => relief_shape(view, rc, rm, ReliefShape::Ors, o),
            Jut => relief_shape(view, rc, rm, ReliefShape::Jut, o),
            Rut => relief_shape(view, rc, rm, ReliefShape::Rut, o),
            Dominance => position(view, rc, rm, Position::Dominance, o),
            Submission => position(view, rc, rm, Position::Submission, o),
            Peakedness => position(view, rc, rm, Position::Peakedness, o),
            _ => position(view, rc, rm, Position::Domination, o),
        }
        Ok(())
    }
}

/// `dominance`: how far the cell rises above the lowest valid cell of the disk: max(0, max (z - z_q)) (planar; planet=R km: height above the horizon plane of q on a sphere); 0 = submissive.
///
/// Source: Xu 2022, Beyond elevation / datumless topography (arXiv 2208.01600); planar, or spherical with planet=R km; disk cutoff.
pub static DOMINANCE: DiskPosition = DiskPosition(metric_def!(
        Dominance,
        "dominance",
        &[RADIUS_CUTOFF, PLANET],
        "z",
        "how far the cell rises above the lowest valid cell of the disk: max(0, max (z - z_q)) (planar; planet=R km: height above the horizon plane of q on a sphere); 0 = submissive",
        "Xu 2022, Beyond elevation / datumless topography (arXiv 2208.01600); planar, or spherical with planet=R km; disk cutoff"
    ));

/// `submission`: how far the cell dips below the highest valid cell of the disk: max(0, max (z_q - z)) (planar; planet=R km: height of q above the horizon plane of the cell); 0 = dominant.
///
/// Source: Xu 2022, Beyond elevation / datumless topography (arXiv 2208.01600); planar, or spherical with planet=R km; disk cutoff.
pub static SUBMISSION: DiskPosition = DiskPosition(metric_def!(
        Submission,
        "submission",
        &[RADIUS_CUTOFF, PLANET],
        "z",
        "how far the cell dips below the highest valid cell of the disk: max(0, max (z_q - z)) (planar; planet=R km: height of q above the horizon plane of the cell); 0 = dominant",
        "Xu 2022, Beyond elevation / datumless topography (arXiv 2208.01600); planar, or spherical with planet=R km; disk cutoff"
    ));

/// `peakedness`: share of the other valid cells of the disk strictly lower than the cell.
///
/// Source: Deng & Wilson 2008, IJGIS 22(1-2) (elevation-percentile criterion at one scale); Llobera 2001 as the survey code; disk cutoff.
pub static PEAKEDNESS: DiskPosition = DiskPosition(metric_def!(
        Peakedness,
        "peakedness",
        &[RADIUS_CUTOFF],
        "0..1",
        "share of the other valid cells of the disk strictly lower than the cell",
        "Deng & Wilson 2008, IJGIS 22(1-2) (elevation-percentile criterion at one scale); Llobera 2001 as the survey code; disk cutoff"
    ));

/// `domination`: geographical domination: distance to the nearest strictly higher valid cell; the cutoff if none within it.
///
/// Source: 'Dominanz' of German orometry (isolation of a point); disk cutoff.
pub static DOMINATION: DiskPosition = DiskPosition(metric_def!(
        Domination,
        "domination",
        &[RADIUS_CUTOFF],
        "m",
        "geographical domination: distance to the nearest strictly higher valid cell; the cutoff if none within it",
        "'Dominanz' of German orometry (isolation of a point); disk cutoff"
    ));
