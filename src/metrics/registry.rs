//! The terrain-descriptor registry: the [`Metric`] trait every metric
//! implements (descriptor, halo, shared caches, checks, kernel) and
//! [`METRICS`], the list of them in the order `orogen metric list` prints.
//!
//! The families and their definitions follow the survey of Argudo, Guérin,
//! Schott & Galin, "Terrain descriptors for landscape synthesis, analysis and
//! simulation" (Computer Graphics Forum, Eurographics 2025 state of the art
//! report), sections 2-4; each metric's own citation is in
//! [`MetricDef::citation`].

use super::tile::Tile;
use crate::error::Result;
use crate::raster::{Grid, RasterInfo};
use serde::{Deserialize, Serialize};

pub use super::param::{parse_length, Length, ParamDef, ParamKind, MAX_RADIUS_CELLS};
pub use super::spec::{min_cell_size_m, parse_specs, resolve, MetricSpec, Resolved};

/// Every metric in the registry (the identifier stored in specs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MetricKind {
    // Horn gradient (`gradient`)
    Dzdx,
    Dzdy,
    Slope,
    Aspect,
    Northness,
    Eastness,
    NormalX,
    NormalY,
    NormalZ,
    SkyViewApprox,
    DirectionalSlope,
    AverageSlope,
    HillslopeAsymmetry,
    AsymmetryIndex,
    HeatIndex,
    // Curvatures (`curvature`, `quadric`)
    Laplacian,
    ProfileCurvature,
    PlanCurvature,
    TangentialCurvature,
    MeanCurvature,
    GaussianCurvature,
    MinCurvature,
    MaxCurvature,
    FractionalLaplacian,
    // Window statistics and morphology (`local_stats`, `morphology`)
    Mean,
    Stdev,
    Variance,
    Tpi,
    Ntpi,
    Percentile,
    Relief,
    TopHatWhite,
    TopHatBlack,
    // Roughness (`roughness`)
    TriRiley,
    TriWilson,
    Roughness,
    Rugosity,
    // Horizons, visibility and sun (`openness`, `visibility`, `solar`)
    OpennessPositive,
    OpennessNegative,
    SkyView,
    HorizonAngle,
    Zenith,
    Nadir,
    Accessibility,
    VisibilityIndex,
    VisibilityIndexExact,
    SolarDirect,
    SolarGlobal,
    SolarAnnual,
    // Landform classes (`landform`, `shary`, `fuzzy`)
    Geomorphon,
    GeomorphonPattern,
    GeomorphonCanonical,
    WeissLandform,
    DikauForm,
    SharyLandform,
    FuzzyLandform,
    // Relative position in a disk (`relief_shape`, `dominance`, `xu`)
    Ors,
    Jut,
    Rut,
    Dominance,
    Submission,
    Peakedness,
    Domination,
    // Whole-raster peak statistics (`peak_dw`)
    PeakednessDw,
    PeakPrototypicality,
}

pub use crate::raster::OutputKind;

/// Descriptor of one metric: what `orogen metric list` prints and specs parse.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MetricDef {
    pub kind: MetricKind,
    /// Name used in specs and output file names.
    pub name: &'static str,
    pub params: &'static [ParamDef],
    /// Units of the output values (`z`: the DEM's own unit, whose nodata
    /// follows [`super::multi::output_spec`]; every other metric writes
    /// f32 with nodata [`super::METRIC_NODATA`]).
    pub units: &'static str,
    /// One-line description.
    pub description: &'static str,
    /// Source of the definition.
    pub citation: &'static str,
    /// Continuous, categorical or angle.
    pub output: OutputKind,
}

impl MetricDef {
    /// True if the output is in the DEM's own unit (`units == "z"`).
    pub fn in_dem_units(&self) -> bool {
        self.units == "z"
    }
}

/// Shared per-tile products a metric reads ([`Tile`] computes each once per
/// tile for every metric of the pass that needs it).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Needs {
    /// Quadric coefficients at this radius (Evans 3x3 for 1, Wood beyond).
    pub quadric: Option<usize>,
    /// The summed-area table over core + this radius, and whether it needs
    /// the squares (variances).
    pub sat: Option<(usize, bool)>,
    /// The fixed-point unit normals over core + this radius (roughness).
    pub normals: Option<usize>,
}

/// A scratch-memory class: the pass allocates the largest request of each
/// class once per tile (name, and a radius where one allocation is made per
/// radius).
pub type ScratchClass = (&'static str, usize);

/// One terrain metric. Implementations are zero-sized or descriptor-only
/// statics, one per metric (a family file may hold several that share a
/// kernel); [`METRICS`] lists them. The per-cell work happens in
/// [`Metric::run`]'s monomorphic loops: the pass dispatches once per tile and
/// metric, never per cell.
pub trait Metric: Sync {
    /// Name, parameters (with defaults and ranges), units, description,
    /// citation and output kind.
    fn def(&self) -> &MetricDef;

    /// Halo in cells the bound metric needs (default: a 3x3 window).
    fn halo(&self, _m: &Resolved) -> usize {
        1
    }

    /// Shared per-tile products the bound metric reads.
    fn needs(&self, _m: &Resolved) -> Needs {
        Needs::default()
    }

    /// Scratch bytes one tile of `tile x tile` cells allocates for the bound
    /// metric beyond its input view, output and the shared quadrics, with
    /// the class under which requests of several metrics share one
    /// allocation (the largest counts).
    fn scratch(&self, _m: &Resolved, _tile: usize) -> Option<(ScratchClass, u64)> {
        None
    }

    /// True for the quadric metrics whose output name leaves out a radius of
    /// one cell (their Evans 3x3 default).
    fn plain_at_one_cell(&self) -> bool {
        false
    }

    /// Checks and raster-dependent defaults once radii are in cells (after
    /// the generic checks of [`resolve`]).
    fn bind(&self, _r: &mut Resolved, _info: &RasterInfo) -> Result<()> {
        Ok(())
    }

    /// True for metrics that need whole-raster statistics: they run their
    /// own global passes, not the local (tile + halo) pass.
    fn whole_raster(&self) -> bool {
        false
    }

    /// Compute the bound metric `m` on the core of `t`'s tile into `o`
    /// (NaN = nodata).
    fn run(&self, t: &mut Tile<'_>, m: &Resolved, o: &mut Grid<f32>) -> Result<()>;
}

/// The descriptor fields read directly on a registered metric
/// (`METRICS[i].name`).
impl std::ops::Deref for dyn Metric {
    type Target = MetricDef;
    fn deref(&self) -> &MetricDef {
        self.def()
    }
}

/// A [`MetricDef`] from its kind, name, parameters, units, description and
/// citation, continuous unless an output kind follows.
macro_rules! metric_def {
    ($k:ident, $n:expr, $p:expr, $u:expr, $d:expr, $c:expr $(,)?) => {
        $crate::metrics::registry::metric_def!($k, $n, $p, $u, $d, $c; Continuous)
    };
    ($k:ident, $n:expr, $p:expr, $u:expr, $d:expr, $c:expr; $o:ident) => {
        $crate::metrics::registry::MetricDef {
            kind: $crate::metrics::registry::MetricKind::$k,
            name: $n,
            params: $p,
            units: $u,
            description: $d,
            citation: $c,
            output: $crate::metrics::registry::OutputKind::$o,
        }
    };
}
pub(crate) use metric_def;

/// The registry, in the order `orogen metric list` prints it.
pub static METRICS: &[&dyn Metric] = &[
    &super::gradient::DZDX,
    &super::gradient::DZDY,
    &super::gradient::SLOPE,
    &super::gradient::ASPECT,
    &super::gradient::NORTHNESS,
    &super::gradient::EASTNESS,
    &super::gradient::NORMAL_X,
    &super::gradient::NORMAL_Y,
    &super::gradient::NORMAL_Z,
    &super::curvature::LAPLACIAN,
    &super::curvature::PROFILE_CURVATURE,
    &super::curvature::PLAN_CURVATURE,
    &super::curvature::TANGENTIAL_CURVATURE,
    &super::curvature::MEAN_CURVATURE,
    &super::curvature::GAUSSIAN_CURVATURE,
    &super::curvature::MIN_CURVATURE,
    &super::curvature::MAX_CURVATURE,
    &super::local_stats::MEAN,
    &super::local_stats::STDEV,
    &super::local_stats::VARIANCE,
    &super::local_stats::TPI,
    &super::local_stats::NTPI,
    &super::morphology::RELIEF,
    &super::local_stats::PERCENTILE,
    &super::morphology::TOP_HAT_WHITE,
    &super::morphology::TOP_HAT_BLACK,
    &super::roughness::TRI_RILEY,
    &super::roughness::TRI_WILSON,
    &super::roughness::ROUGHNESS,
    &super::roughness::RUGOSITY,
    &super::openness::OPENNESS_POSITIVE,
    &super::openness::OPENNESS_NEGATIVE,
    &super::openness::SKY_VIEW,
    &super::gradient::SKY_VIEW_APPROX,
    &super::landform::GEOMORPHON,
    &super::landform::GEOMORPHON_PATTERN,
    &super::landform::GEOMORPHON_CANONICAL,
    &super::landform::WEISS_LANDFORM,
    &super::landform::DIKAU_FORM,
    &super::openness::HORIZON_ANGLE,
    &super::openness::ZENITH,
    &super::openness::NADIR,
    &super::openness::ACCESSIBILITY,
    &super::visibility::VISIBILITY_INDEX,
    &super::solar::SOLAR_DIRECT,
    &super::solar::SOLAR_GLOBAL,
    &super::solar::SOLAR_ANNUAL,
    &super::solar::HEAT_INDEX,
    &super::visibility::VISIBILITY_INDEX_EXACT,
    &super::directional::DIRECTIONAL_SLOPE,
    &super::directional::AVERAGE_SLOPE,
    &super::fractional::FRACTIONAL_LAPLACIAN,
    &super::asymmetry::HILLSLOPE_ASYMMETRY,
    &super::shary::SHARY_LANDFORM,
    &super::relief_shape::ORS,
    &super::relief_shape::JUT,
    &super::relief_shape::RUT,
    &super::fuzzy::FUZZY_LANDFORM,
    &super::dominance::DOMINANCE,
    &super::dominance::SUBMISSION,
    &super::dominance::PEAKEDNESS,
    &super::dominance::DOMINATION,
    &super::asymmetry::ASYMMETRY_INDEX,
    &super::peak_dw::PEAKEDNESS_DW,
    &super::peak_dw::PEAK_PROTOTYPICALITY,
];

/// The registered metric of `kind`.
pub fn metric(kind: MetricKind) -> &'static dyn Metric {
    *METRICS
        .iter()
        .find(|m| m.kind == kind)
        .expect("every MetricKind has a registry entry (checked by a unit test)")
}

/// The registry entry of `kind`.
pub fn def(kind: MetricKind) -> &'static MetricDef {
    metric(kind).def()
}

/// True for the quadric curvatures (Evans 3x3 or Wood n x n).
pub fn is_curvature(k: MetricKind) -> bool {
    super::curvature::is_curvature(k)
}

/// Names of all metrics, comma separated (for error messages).
pub(crate) fn all_names() -> String {
    METRICS
        .iter()
        .map(|d| d.name)
        .collect::<Vec<_>>()
        .join(", ")
}

/// parameters (name=default, range), units, description and citation.
pub fn list() -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{:<22} {:<34} {:<16} description [source]",
        "metric", "parameters (default)", "units"
    );
    for d in METRICS {
        let params = if d.params.is_empty() {
            "-".to_string()
        } else {
            d.params
                .iter()
                .map(|p| format!("{}={}", p.name, p.default))
                .collect::<Vec<_>>()
                .join(" ")
        };
        let _ = writeln!(
            s,
            "{:<22} {:<34} {:<16} {} [{}]",
            d.name, params, d.units, d.description, d.citation
        );
    }
    let _ = writeln!(
        s,
        "\nradius: 500m, 1.5km (converted with the smallest true cell size of the raster) or 25c (cells), 1c..={MAX_RADIUS_CELLS}c;\nwindows are squares of side 2r+1 cells (mean/stdev/variance/tpi/ntpi: shape=disk for dx²+dy² ≤ r²); nodata cells are excluded from windows; a nodata centre is nodata."
    );
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_kind_once_and_defaults_parse() {
        for d in METRICS {
            assert_eq!(METRICS.iter().filter(|e| e.kind == d.kind).count(), 1);
            assert_eq!(METRICS.iter().filter(|e| e.name == d.name).count(), 1);
            let mut s = MetricSpec::unset(d.kind);
            for p in d.params {
                s.set(p, p.default).unwrap();
            }
        }
    }

    /// Every metric has a unique name, a description, units and a citation,
    /// and a halo that covers its radii (and is one ring for the 3x3
    /// metrics without a radius).
    #[test]
    fn every_metric_is_described_and_its_halo_covers_its_radii() {
        for d in METRICS {
            assert_eq!(METRICS.iter().filter(|e| e.name == d.name).count(), 1);
            assert!(!d.citation.trim().is_empty(), "{}: no citation", d.name);
            assert!(!d.description.trim().is_empty(), "{}", d.name);
            assert!(!d.units.trim().is_empty(), "{}", d.name);
            let has = |k: ParamKind| d.params.iter().any(|p| p.kind == k);
            for r in [1usize, 3, 7, 40] {
                let mut spec = MetricSpec::new(d.kind);
                if has(ParamKind::Scales) {
                    spec.scales = Some(vec![1, r]);
                }
                let bound = Resolved {
                    spec,
                    radius_cells: if has(ParamKind::Radius) { r } else { 0 },
                    radius_m: if has(ParamKind::Radius) {
                        10.0 * r as f64
                    } else {
                        0.0
                    },
                    radius2_cells: if has(ParamKind::Radius2) { 2 * r } else { 0 },
                };
                let halo = bound.halo();
                assert!(halo >= 1, "{}: halo 0", d.name);
                assert!(
                    halo >= bound.radius_cells,
                    "{}: halo {halo} < radius {r}",
                    d.name
                );
                assert!(
                    halo >= bound.radius2_cells,
                    "{}: halo below radius2",
                    d.name
                );
                if has(ParamKind::Scales) {
                    assert!(halo >= r, "{}: halo below its largest scale", d.name);
                }
                let radius_free =
                    !has(ParamKind::Radius) && !has(ParamKind::Radius2) && !has(ParamKind::Scales);
                if radius_free && !d.whole_raster() {
                    assert_eq!(halo, 1, "{}: a 3x3 metric with halo {halo}", d.name);
                }
            }
        }
    }
}
