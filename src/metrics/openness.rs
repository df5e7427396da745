//! Descriptors of the horizon: positive and negative openness, the sky-view
//! factor, the horizon angle along one direction, the zenith and nadir
//! angles and the accessibility (ambient occlusion). The scans are in
//! [`super::horizon`]; metrics of the pass with the same rays (radius,
//! cutoff, directions) share one scan per tile.
//!
//! Sources: Yokoyama, Shirasawa & Pike 2002, PE&RS 68(3) (openness, zenith
//! and nadir angles); Zakšek, Oštir & Kokalj 2011, Remote Sensing 3(2) (sky
//! view); Dozier & Frew 1990, IEEE TGRS 28(5) (horizons, accessibility);
//! line-sweep hulls after Stewart 1998, IEEE TVCG 4(1).

use super::horizon::{horizon, horizon_extra, HorizonExtra, HorizonMethod, HorizonOut};
use super::param::{DIRECTIONS, RADIUS_HORIZON};
use super::registry::{metric_def, Metric, MetricDef, MetricKind, ScratchClass};
use super::spec::Resolved;
use super::tile::Tile;
use crate::error::Result;
use crate::raster::{Grid, TileView};

/// Scratch of the horizon scans with tangents (f64, up and down),
/// per-direction solar horizons (f32) and sky-view sums, shared with the
/// solar metrics.
pub fn horizon_scratch(tile: usize) -> (ScratchClass, u64) {
    let core = (tile * tile) as u64;
    (("horizon", 0), core * (2 * 8 + 16 * 4 + 8 + 4 + 3 * 8))
}

/// The rays of a horizon metric: radius in cells, cutoff, directions.
fn rays(m: &Resolved) -> (usize, u64, usize) {
    (m.radius_cells, m.radius_m.to_bits(), m.spec.directions)
}

/// Write `m`'s output from the one horizon scan per tile that every metric
/// of the pass in `family` with `m`'s rays shares: the first to ask runs
/// `scan(view, (radius cells, cutoff m, directions), kinds, grids)`, which
/// fills one grid per distinct kind.
fn shared_scan(
    t: &mut Tile<'_>,
    m: &Resolved,
    name: &'static str,
    family: fn(MetricKind) -> bool,
    o: &mut Grid<f32>,
    scan: impl FnOnce(&TileView<f32>, (usize, f64, usize), &[MetricKind], &mut [Grid<f32>]),
) {
    let key = rays(m);
    let r = (m.radius_cells, m.radius_m, m.spec.directions);
    t.grouped(
        (name, key.0, key.1, key.2 as u64),
        m,
        |n| family(n.spec.kind) && rays(n) == key,
        |view, kinds| {
            let (cw, ch) = (view.core.w, view.core.h);
            let mut grids: Vec<Grid<f32>> =
                kinds.iter().map(|_| Grid::new(cw, ch, f32::NAN)).collect();
            scan(view, r, kinds, &mut grids);
            grids
        },
        o,
    );
}

/// Openness (positive or negative) or sky view.
pub struct Openness(MetricDef);

fn is_openness(k: MetricKind) -> bool {
    use MetricKind::*;
    matches!(k, OpennessPositive | OpennessNegative | SkyView)
}

impl Metric for Openness {
    fn def(&self) -> &MetricDef {
        &self.0
    }
    fn halo(&self, m: &Resolved) -> usize {
        m.radius_cells
    }
    fn run(&self, t: &mut Tile<'_>, m: &Resolved, o: &mut Grid<f32>) -> Result<()> {
        // One scan for every openness / sky view with the same rays.
        shared_scan(
            t,
            m,
            "openness",
            is_openness,
            o,
            |view, (r, rm, dirs), kinds, grids| {
                let mut hout = HorizonOut {
                    positive: None,
                    negative: None,
                    sky_view: None,
                };
                for (kind, g) in kinds.iter().zip(grids.iter_mut()) {
                    match kind {
                        MetricKind::OpennessPositive => hout.positive = Some(g),
                        MetricKind::OpennessNegative => hout.negative = Some(g),
                        _ => hout.sky_view = Some(g),
                    }
                }
                horizon(view, r, rm, dirs, hout);
            },
        );
        Ok(())
    }
}

/// The horizon elevation angle along one lattice direction.
pub struct HorizonAngle(MetricDef);

impl Metric for HorizonAngle {
    fn def(&self) -> &MetricDef {
        &self.0
    }
    fn halo(&self, m: &Resolved) -> usize {
        m.radius_cells.max(1)
    }
    fn scratch(&self, _m: &Resolved, tile: usize) -> Option<(ScratchClass, u64)> {
        Some(horizon_scratch(tile))
    }
    fn run(&self, t: &mut Tile<'_>, m: &Resolved, o: &mut Grid<f32>) -> Result<()> {
        let dir = m.spec.value("dir").and_then(super::visibility::lattice_dir);
        let ho = HorizonExtra {
            angle: Some((dir.unwrap_or(0), o)),
            ..Default::default()
        };
        horizon_extra(
            t.view,
            m.radius_cells,
            m.radius_m,
            0,
            HorizonMethod::Sweep,
            ho,
        );
        Ok(())
    }
}

/// Zenith angle, nadir angle or accessibility.
pub struct Zenith(MetricDef);

fn is_zenith(k: MetricKind) -> bool {
    use MetricKind::*;
    matches!(k, Zenith | Nadir | Accessibility)
}

impl Metric for Zenith {
    fn def(&self) -> &MetricDef {
        &self.0
    }
    fn halo(&self, m: &Resolved) -> usize {
        m.radius_cells.max(1)
    }
    fn scratch(&self, _m: &Resolved, tile: usize) -> Option<(ScratchClass, u64)> {
        Some(horizon_scratch(tile))
    }
    fn run(&self, t: &mut Tile<'_>, m: &Resolved, o: &mut Grid<f32>) -> Result<()> {
        // One scan for every zenith/nadir/accessibility with the same rays.
        shared_scan(
            t,
            m,
            "zenith",
            is_zenith,
            o,
            |view, (r, rm, dirs), kinds, grids| {
                let mut ho = HorizonExtra::default();
                for (kind, g) in kinds.iter().zip(grids.iter_mut()) {
                    match kind {
                        MetricKind::Zenith => ho.zenith = Some(g),
                        MetricKind::Nadir => ho.nadir = Some(g),
                        _ => ho.accessibility = Some(g),
                    }
                }
                horizon_extra(view, r, rm, dirs, HorizonMethod::Sweep, ho);
            },
        );
        Ok(())
    }
}

/// `openness`: positive openness: mean over directions of 90 - horizon elevation angle.
///
/// Source: Yokoyama, Shirasawa & Pike 2002, PE&RS 68(3).
pub static OPENNESS_POSITIVE: Openness = Openness(metric_def!(
    OpennessPositive,
    "openness",
    &[RADIUS_HORIZON, DIRECTIONS],
    "degrees",
    "positive openness: mean over directions of 90 - horizon elevation angle",
    "Yokoyama, Shirasawa & Pike 2002, PE&RS 68(3)"
));

/// `openness_neg`: negative openness: mean over directions of 90 + nadir (min) elevation angle.
///
/// Source: Yokoyama, Shirasawa & Pike 2002, PE&RS 68(3).
pub static OPENNESS_NEGATIVE: Openness = Openness(metric_def!(
    OpennessNegative,
    "openness_neg",
    &[RADIUS_HORIZON, DIRECTIONS],
    "degrees",
    "negative openness: mean over directions of 90 + nadir (min) elevation angle",
    "Yokoyama, Shirasawa & Pike 2002, PE&RS 68(3)"
));

/// `sky_view`: sky-view factor 1 - mean sin(max(horizon angle, 0)).
///
/// Source: Zakšek, Oštir & Kokalj 2011, Remote Sensing 3(2).
pub static SKY_VIEW: Openness = Openness(metric_def!(
    SkyView,
    "sky_view",
    &[RADIUS_HORIZON, DIRECTIONS],
    "0..1",
    "sky-view factor 1 - mean sin(max(horizon angle, 0))",
    "Zakšek, Oštir & Kokalj 2011, Remote Sensing 3(2)"
));

/// `horizon`: horizon elevation angle (max atan(dz/d) within the cutoff) along one lattice direction.
///
/// Source: Dozier & Frew 1990, IEEE TGRS 28(5); exact lattice rays, line-sweep hulls after Stewart 1998, IEEE TVCG 4(1).
pub static HORIZON_ANGLE: HorizonAngle = HorizonAngle(metric_def!(
        HorizonAngle,
        "horizon",
        &[RADIUS_HORIZON, super::visibility::DIR],
        "degrees",
        "horizon elevation angle (max atan(dz/d) within the cutoff) along one lattice direction",
        "Dozier & Frew 1990, IEEE TGRS 28(5); exact lattice rays, line-sweep hulls after Stewart 1998, IEEE TVCG 4(1)"
    ));

/// `zenith`: zenith angle: min over directions of 90 - horizon elevation angle.
///
/// Source: Yokoyama, Shirasawa & Pike 2002, PE&RS 68(3) (per-direction zenith angle, min over directions).
pub static ZENITH: Zenith = Zenith(metric_def!(
        Zenith,
        "zenith",
        &[RADIUS_HORIZON, DIRECTIONS],
        "degrees",
        "zenith angle: min over directions of 90 - horizon elevation angle",
        "Yokoyama, Shirasawa & Pike 2002, PE&RS 68(3) (per-direction zenith angle, min over directions)"
    ));

/// `nadir`: nadir angle: min over directions of 90 + lowest elevation angle.
///
/// Source: Yokoyama, Shirasawa & Pike 2002, PE&RS 68(3) (per-direction nadir angle, min over directions).
pub static NADIR: Zenith = Zenith(metric_def!(
    Nadir,
    "nadir",
    &[RADIUS_HORIZON, DIRECTIONS],
    "degrees",
    "nadir angle: min over directions of 90 + lowest elevation angle",
    "Yokoyama, Shirasawa & Pike 2002, PE&RS 68(3) (per-direction nadir angle, min over directions)"
));

/// `accessibility`: ambient occlusion / accessibility: cosine-weighted visible sky mean cos^2(max(horizon angle, 0)).
///
/// Source: Dozier & Frew 1990, IEEE TGRS 28(5) (sky view of a horizontal surface).
pub static ACCESSIBILITY: Zenith = Zenith(metric_def!(
        Accessibility,
        "accessibility",
        &[RADIUS_HORIZON, DIRECTIONS],
        "0..1",
        "ambient occlusion / accessibility: cosine-weighted visible sky mean cos^2(max(horizon angle, 0))",
        "Dozier & Frew 1990, IEEE TGRS 28(5) (sky view of a horizontal surface)"
    ));
