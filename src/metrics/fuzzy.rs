//! Fuzzy multi-scale landforms (Fisher, Wood & Cheng 2004, "Where is
//! Helvellyn? Fuzziness of multi-scale landscape morphometry", Transactions
//! of the Institute of British Geographers 29(1), 106-128): Wood's six
//! morphometric features are classified at several window sizes, and the
//! membership of a cell in a feature is the proportion of scales at which
//! it is classified as that feature (0..1).
//!
//! Wood's features (Wood 1996, *The geomorphological characterisation of
//! digital elevation models*, PhD thesis, Leicester, ch. 5; as in GRASS
//! r.param.scale `method=feature`), from the quadric of the (2r+1)² window
//! (Evans for r = 1, Wood's least squares beyond; curvatures convex
//! positive, `t` the curvature tolerance):
//! - sloping cells (slope > 1°): cross-sectional (tangential) curvature
//!   > t → ridge, < −t → channel, else planar;
//! - flat cells: with the principal curvatures kmin ≤ kmax:
//!   kmin > t → peak, kmax < −t → pit, kmax > t and kmin < −t → pass,
//!   kmax > t → ridge, kmin < −t → channel, else planar.

use super::neighbourhood::{walk_3x3, EdgeMode};
use super::param::{FEATURE, FUZZY_T, SCALES};
use super::quadric::{wood_fit, Quadric};
use super::registry::{metric_def, Metric, MetricDef};
use super::spec::Resolved;
use super::tile::Tile;
use crate::error::Result;
use crate::raster::{Grid, TileView};

/// Feature names, in class-code order 0..6.
pub const FEATURES: [&str; 6] = ["peak", "ridge", "pass", "plane", "channel", "pit"];

/// Slope (degrees) up to which a cell is "flat" in Wood's classification.
pub const FLAT_SLOPE_DEG: f64 = 1.0;

/// Wood's feature code (index into [`FEATURES`]) of a fitted quadric, or
/// `None` for a nodata quadric.
pub fn wood_feature(c: &Quadric, t: f64) -> Option<u8> {
    if c.p.is_nan() {
        return None;
    }
    let slope = (c.p * c.p + c.q * c.q).sqrt().atan().to_degrees();
    Some(if slope > FLAT_SLOPE_DEG {
        let kh = c.tangential();
        if kh > t {
            1
        } else if kh < -t {
            4
        } else {
            3
        }
    } else {
        let (kmin, kmax) = c.min_max();
        if kmin > t {
            0
        } else if kmax < -t {
            5
        } else if kmax > t && kmin < -t {
            2
        } else if kmax > t {
            1
        } else if kmin < -t {
            4
        } else {
            3
        }
    })
}

/// Membership (0..1) of every core cell in feature `class` over the window
/// radii `scales` (cells, each ≤ the view's halo); a scale whose quadric is
/// nodata is left out; nodata if all are.
pub fn fuzzy_membership(
    view: &TileView<f32>,
    scales: &[usize],
    class: u8,
    t: f64,
    o: &mut Grid<f32>,
) {
    let (cw, ch) = (view.core.w, view.core.h);
    let mut hits = vec![0u32; cw * ch];
    let mut valid = vec![0u32; cw * ch];
    let mut q = Grid::new(cw, ch, Quadric::NAN);
    for &r in scales {
        if r <= 1 {
            walk_3x3(view, &mut q, EdgeMode::Nodata, Quadric::NAN, Quadric::fit);
        } else {
            wood_fit(view, r, &mut q);
        }
        for (i, c) in q.data().iter().enumerate() {
            if let Some(f) = wood_feature(c, t) {
                valid[i] += 1;
                hits[i] += u32::from(f == class);
            }
        }
    }
    for (i, v) in o.data_mut().iter_mut().enumerate() {
        *v = if valid[i] == 0 {
            f32::NAN
        } else {
            (hits[i] as f64 / valid[i] as f64) as f32
        };
    }
}

/// The share of scales at which Wood's classification gives a feature.
pub struct FuzzyLandform(MetricDef);

impl Metric for FuzzyLandform {
    fn def(&self) -> &MetricDef {
        &self.0
    }
    fn halo(&self, m: &Resolved) -> usize {
        m.spec
            .scales
            .as_ref()
            .and_then(|v| v.iter().max().copied())
            .unwrap_or(1)
    }
    fn run(&self, t: &mut Tile<'_>, m: &Resolved, o: &mut Grid<f32>) -> Result<()> {
        fuzzy_membership(
            t.view,
            m.spec.scales.as_deref().unwrap_or(&[1, 2, 4]),
            m.spec.feature.unwrap_or(0),
            m.spec.threshold.unwrap_or(1e-4),
            o,
        );
        Ok(())
    }
}

/// `fuzzy_landform`: share of the window radii (scales) at which Wood's feature classification gives the class.
///
/// Source: Fisher, Wood & Cheng 2004, Trans. IBG 29(1); features of Wood 1996 (PhD thesis, Leicester), as r.param.scale.
pub static FUZZY_LANDFORM: FuzzyLandform = FuzzyLandform(metric_def!(
        FuzzyLandform,
        "fuzzy_landform",
        &[FEATURE, SCALES, FUZZY_T],
        "0..1",
        "share of the window radii (scales) at which Wood's feature classification gives the class",
        "Fisher, Wood & Cheng 2004, Trans. IBG 29(1); features of Wood 1996 (PhD thesis, Leicester), as r.param.scale"
    ));
