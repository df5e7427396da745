//! Curvatures: the 5-point Laplacian, and the seven curvatures of the local
//! quadric (Evans 3x3 at radius 1, Wood's least-squares fit over larger
//! windows; the fit is in [`super::quadric`], computed once per tile and
//! radius for every curvature of the pass).
//!
//! Sources: Evans 1979 (3x3 quadric); Wood 1996, PhD thesis (Leicester),
//! ch. 4 (n x n windows); the curvature formulas of Florinsky 2016, *Digital
//! Terrain Analysis in Soil Science and Geology*, 2nd ed., ch. 2.

use super::landform::dikau_class;
use super::neighbourhood::{walk_3x3, EdgeMode};
use super::param::RADIUS_QUADRIC;
use super::quadric::{laplacian, Quadric};
use super::registry::{metric_def, Metric, MetricDef, MetricKind, Needs, ScratchClass};
use super::shary::shary_class;
use super::spec::Resolved;
use super::tile::Tile;
use crate::error::Result;
use crate::raster::Grid;

/// Citation of the quadric curvatures.
pub const EVANS: &str =
    "Evans 1979 3x3 quadric (radius 1c), Wood 1996 PhD thesis (Leicester) ch. 4 for larger windows; formulas of Florinsky 2016, Digital Terrain Analysis in Soil Science and Geology, 2nd ed., ch. 2";

/// True for the quadric curvatures (Evans 3x3 or Wood n x n).
pub fn is_curvature(k: MetricKind) -> bool {
    use MetricKind::*;
    matches!(
        k,
        ProfileCurvature
            | PlanCurvature
            | TangentialCurvature
            | MeanCurvature
            | GaussianCurvature
            | MinCurvature
            | MaxCurvature
    )
}

/// The 5-point Laplacian on the 3x3 window.
pub struct Laplacian(MetricDef);

impl Metric for Laplacian {
    fn def(&self) -> &MetricDef {
        &self.0
    }
    fn run(&self, t: &mut Tile<'_>, _m: &Resolved, o: &mut Grid<f32>) -> Result<()> {
        walk_3x3(t.view, o, EdgeMode::Nodata, f32::NAN, |w, ew, ns| {
            laplacian(w, ew, ns) as f32
        });
        Ok(())
    }
}

/// A metric read from the local quadric alone: the seven curvatures here,
/// Dikau's forms ([`super::landform::dikau_class`]) and Shary's landforms
/// ([`super::shary::shary_class`]). Nodata where the fit is.
pub struct FromQuadric(pub MetricDef);

/// Write `f` of every fitted quadric of the tile into `o` (nodata where the
/// cell has no fit); one monomorphic loop per metric.
#[inline]
fn map_fits(qg: &Grid<Quadric>, o: &mut Grid<f32>, f: impl Fn(&Quadric) -> f32) {
    for (o, c) in o.data_mut().iter_mut().zip(qg.data()) {
        *o = if c.p.is_nan() { f32::NAN } else { f(c) };
    }
}

impl Metric for FromQuadric {
    fn def(&self) -> &MetricDef {
        &self.0
    }
    fn halo(&self, m: &Resolved) -> usize {
        m.radius_cells.max(1)
    }
    fn needs(&self, m: &Resolved) -> Needs {
        Needs {
            quadric: Some(m.radius_cells.max(1)),
            ..Needs::default()
        }
    }
    fn scratch(&self, m: &Resolved, tile: usize) -> Option<(ScratchClass, u64)> {
        // The tile's grid of fits (one per core cell), shared by every metric
        // of the pass at the same radius.
        let core = (tile * tile) as u64;
        Some((
            ("quadric", m.radius_cells.max(1)),
            core * std::mem::size_of::<Quadric>() as u64,
        ))
    }
    fn plain_at_one_cell(&self) -> bool {
        true
    }
    fn run(&self, t: &mut Tile<'_>, m: &Resolved, o: &mut Grid<f32>) -> Result<()> {
        let qg = t.quadric(m.radius_cells.max(1))?;
        let th = m.spec.threshold.unwrap_or(0.0);
        use MetricKind::*;
        match self.0.kind {
            ProfileCurvature => map_fits(qg, o, |c| c.profile() as f32),
            PlanCurvature => map_fits(qg, o, |c| c.plan() as f32),
            TangentialCurvature => map_fits(qg, o, |c| c.tangential() as f32),
            MeanCurvature => map_fits(qg, o, |c| c.mean() as f32),
            GaussianCurvature => map_fits(qg, o, |c| c.gaussian() as f32),
            MinCurvature => map_fits(qg, o, |c| c.min_max().0 as f32),
            DikauForm => map_fits(qg, o, |c| dikau_class(c.profile(), c.plan(), th)),
            SharyLandform => map_fits(qg, o, |c| {
                shary_class(c.gaussian(), c.mean(), c.tangential(), c.profile(), th)
            }),
            _ => map_fits(qg, o, |c| c.min_max().1 as f32),
        }
        Ok(())
    }
}

/// `laplacian`: 5-point Laplacian d2z/dx2 + d2z/dy2.
///
/// Source: finite differences (Argudo et al. survey sec. 3).
pub static LAPLACIAN: Laplacian = Laplacian(metric_def!(
    Laplacian,
    "laplacian",
    &[],
    "z/m^2",
    "5-point Laplacian d2z/dx2 + d2z/dy2",
    "finite differences (Argudo et al. survey sec. 3)"
));

/// `profile_curvature`: vertical (profile) curvature kv; convex positive; 0 where flat.
///
/// Source: [`EVANS`].
pub static PROFILE_CURVATURE: FromQuadric = FromQuadric(metric_def!(
    ProfileCurvature,
    "profile_curvature",
    &[RADIUS_QUADRIC],
    "1/m",
    "vertical (profile) curvature kv; convex positive; 0 where flat",
    EVANS
));

/// `plan_curvature`: plan (contour) curvature kp; convex positive; 0 where flat.
///
/// Source: [`EVANS`].
pub static PLAN_CURVATURE: FromQuadric = FromQuadric(metric_def!(
    PlanCurvature,
    "plan_curvature",
    &[RADIUS_QUADRIC],
    "1/m",
    "plan (contour) curvature kp; convex positive; 0 where flat",
    EVANS
));

/// `tangential_curvature`: horizontal (tangential) curvature kh; convex positive; 0 where flat.
///
/// Source: [`EVANS`].
pub static TANGENTIAL_CURVATURE: FromQuadric = FromQuadric(metric_def!(
    TangentialCurvature,
    "tangential_curvature",
    &[RADIUS_QUADRIC],
    "1/m",
    "horizontal (tangential) curvature kh; convex positive; 0 where flat",
    EVANS
));

/// `mean_curvature`: mean curvature H; convex positive.
///
/// Source: [`EVANS`].
pub static MEAN_CURVATURE: FromQuadric = FromQuadric(metric_def!(
    MeanCurvature,
    "mean_curvature",
    &[RADIUS_QUADRIC],
    "1/m",
    "mean curvature H; convex positive",
    EVANS
));

/// `gaussian_curvature`: Gaussian curvature K.
///
/// Source: [`EVANS`].
pub static GAUSSIAN_CURVATURE: FromQuadric = FromQuadric(metric_def!(
    GaussianCurvature,
    "gaussian_curvature",
    &[RADIUS_QUADRIC],
    "1/m^2",
    "Gaussian curvature K",
    EVANS
));

/// `min_curvature`: minimal curvature H - sqrt(H^2-K).
///
/// Source: [`EVANS`].
pub static MIN_CURVATURE: FromQuadric = FromQuadric(metric_def!(
    MinCurvature,
    "min_curvature",
    &[RADIUS_QUADRIC],
    "1/m",
    "minimal curvature H - sqrt(H^2-K)",
    EVANS
));

/// `max_curvature`: maximal curvature H + sqrt(H^2-K).
///
/// Source: [`EVANS`].
pub static MAX_CURVATURE: FromQuadric = FromQuadric(metric_def!(
    MaxCurvature,
    "max_curvature",
    &[RADIUS_QUADRIC],
    "1/m",
    "maximal curvature H + sqrt(H^2-K)",
    EVANS
));

#[cfg(test)]
mod tests {
    use crate::metrics::{parse_specs, MultiMetric};
    use crate::raster::{GeoRef, Grid, MemRaster, RasterSource};

    /// Scratch estimate of one tile of 64 x 64 cells for the metrics `specs`
    /// on a 100 x 100 raster of unit cells.
    fn estimate(specs: &str) -> u64 {
        let src = MemRaster::from_grid(Grid::new(100, 100, 0.0f32), GeoRef::pixel());
        let specs = parse_specs(specs).unwrap();
        MultiMetric::new(&specs, src.info())
            .unwrap()
            .scratch_estimate(64)
    }

    /// Every metric read from the quadric declares the tile's grid of fits
    /// (64 x 64 fits of five f64 coefficients), once per radius however many
    /// metrics share it.
    #[test]
    fn quadric_metrics_declare_the_grid_of_fits() {
        let fits = 64 * 64 * 5 * 8;
        let base = 3 * 64 * 64 * 4;
        for m in ["profile_curvature", "dikau_form", "shary_landform"] {
            assert_eq!(estimate(m), base + fits, "{m}");
            assert_eq!(estimate(&format!("{m}:radius=2c")), base + fits, "{m}");
        }
        assert_eq!(
            estimate("dikau_form,shary_landform,profile_curvature"),
            base + fits
        );
        assert_eq!(
            estimate("dikau_form:radius=2c,shary_landform"),
            base + 2 * fits
        );
    }
}
