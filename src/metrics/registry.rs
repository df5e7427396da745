//! The terrain-descriptor registry: every metric orogen computes, its
//! parameters (types, defaults, allowed ranges), the halo it needs, units,
//! one-line description and citation; parsing of metric specs such as
//! `slope,tpi:radius=500m,openness:radius=1km`.
//!
//! The families and their definitions follow the survey of Argudo, Guérin,
//! Schott & Galin, "Terrain descriptors for landscape synthesis, analysis and
//! simulation" (Computer Graphics Forum, Eurographics 2025 state of the art
//! report), sections 2-4; each metric's
//! own citation is in [`MetricDef::citation`].

use crate::error::{Error, Result};
use crate::metrics::terrain::SlopeUnits;
use crate::raster::RasterInfo;
use serde::{Deserialize, Serialize};

/// Every metric in the registry.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MetricKind {
    Dzdx,
    Dzdy,
    Slope,
    Aspect,
    Northness,
    Eastness,
    NormalX,
    NormalY,
    NormalZ,
    Laplacian,
    ProfileCurvature,
    PlanCurvature,
    TangentialCurvature,
    MeanCurvature,
    GaussianCurvature,
    MinCurvature,
    MaxCurvature,
    Mean,
    Stdev,
    Variance,
    Tpi,
    Ntpi,
    Relief,
    Percentile,
    TopHatWhite,
    TopHatBlack,
    TriRiley,
    TriWilson,
    Roughness,
    Rugosity,
    OpennessPositive,
    OpennessNegative,
    SkyView,
    SkyViewApprox,
    Geomorphon,
    GeomorphonPattern,
    GeomorphonCanonical,
    WeissLandform,
    DikauForm,
    // visibility & solar
    HorizonAngle,
    Zenith,
    Nadir,
    Accessibility,
    VisibilityIndex,
    SolarDirect,
    SolarGlobal,
    SolarAnnual,
    HeatIndex,
    VisibilityIndexExact,
    // more descriptors
    DirectionalSlope,
    AverageSlope,
    FractionalLaplacian,
    HillslopeAsymmetry,
    SharyLandform,
    Ors,
    Jut,
    Rut,
    FuzzyLandform,
    // last descriptors
    Dominance,
    Submission,
    Peakedness,
    Domination,
    // descr3
    AsymmetryIndex,
    // descr4
    PeakednessDw,
    PeakPrototypicality,
}

/// What a metric's parameters are.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ParamKind {
    /// A length: metres (`500m`, `1.5km`) or cells (`25c`).
    Radius,
    /// Number of horizon directions: 8 or 16.
    Directions,
    /// Slope units: `degrees` or `percent`.
    SlopeUnits,
    /// Window shape: `square` or `disk`.
    Shape,
    /// A second length (the large scale of Weiss's landforms), as `Radius`.
    Radius2,
    /// A non-negative number (threshold in the metric's units).
    Threshold,
    // visibility & solar
    /// A number stored by name in [`MetricSpec::values`], checked by
    /// `visibility::check_value` (`auto` leaves it unset).
    Value,
    // more descriptors
    /// An azimuth in degrees clockwise from north (any finite value, taken mod 360).
    Azimuth,
    /// An exponent strictly between 0 and 1 (the fractional Laplacian's s).
    Exponent,
    /// One of Wood's features: peak, ridge, pass, plane, channel, pit.
    Feature,
    /// Window radii in cells separated by '/', e.g. `1/2/4`.
    Scales,
}

/// One parameter of a metric, as the registry describes it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ParamDef {
    pub name: &'static str,
    pub kind: ParamKind,
    /// Default, in the syntax `parse_specs` accepts.
    pub default: &'static str,
    /// Allowed values, in words.
    pub range: &'static str,
}

/// Registry entry of one metric.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MetricDef {
    pub kind: MetricKind,
    /// Name used in specs and output file names.
    pub name: &'static str,
    pub params: &'static [ParamDef],
    /// Units of the output values.
    pub units: &'static str,
    /// One-line description.
    pub description: &'static str,
    /// Source of the definition.
    pub citation: &'static str,
}

/// Largest radius in cells accepted (windowed sums stay exact in i128
/// fixed point up to this window size; see `windowed`).
pub const MAX_RADIUS_CELLS: usize = 2000;

const RADIUS: ParamDef = ParamDef {
    name: "radius",
    kind: ParamKind::Radius,
    default: "3c",
    range: "1c..=2000c, or a length in m/km (> 0) converted with the smallest true cell size",
};
const SHAPE: ParamDef = ParamDef {
    name: "shape",
    kind: ParamKind::Shape,
    default: "square",
    range: "square (SAT, O(1) per cell) or disk (dx²+dy² ≤ r² in cells, O(r) per cell)",
};
const RADIUS_HORIZON: ParamDef = ParamDef {
    name: "radius",
    kind: ParamKind::Radius,
    default: "10c",
    range: "1c..=2000c, or a length in m/km (> 0); the horizon search cutoff",
};
const RADIUS_QUADRIC: ParamDef = ParamDef {
    name: "radius",
    kind: ParamKind::Radius,
    default: "1c",
    range: "1c (Evans 3x3) ..=2000c, or a length in m/km: Wood's (2r+1)^2 least-squares quadric",
};
const DIRECTIONS: ParamDef = ParamDef {
    name: "directions",
    kind: ParamKind::Directions,
    default: "8",
    range: "8 or 16",
};
const UNITS: ParamDef = ParamDef {
    name: "units",
    kind: ParamKind::SlopeUnits,
    default: "degrees",
    range: "degrees or percent",
};

const RADIUS_GEOMORPHON: ParamDef = ParamDef {
    name: "radius",
    kind: ParamKind::Radius,
    default: "10c",
    range: "1c..=2000c, or a length in m/km (> 0); the lookup distance L",
};
const FLAT: ParamDef = ParamDef {
    name: "flat",
    kind: ParamKind::Threshold,
    default: "1",
    range: "flatness threshold t in degrees, >= 0",
};
const RADIUS_SMALL: ParamDef = ParamDef {
    name: "radius",
    kind: ParamKind::Radius,
    default: "3c",
    range: "small-scale TPI radius: 1c..=2000c, or a length in m/km",
};
const RADIUS_LARGE: ParamDef = ParamDef {
    name: "large",
    kind: ParamKind::Radius2,
    default: "10c",
    range: "large-scale TPI radius: 1c..=2000c, or a length in m/km",
};
const SLOPE_T: ParamDef = ParamDef {
    name: "slope",
    kind: ParamKind::Threshold,
    default: "5",
    range: "slope (degrees, >= 0) separating plains (class 5) from open slopes (6)",
};
const CURV_T: ParamDef = ParamDef {
    name: "threshold",
    kind: ParamKind::Threshold,
    default: "0.0016667",
    range: "|curvature| (1/m, >= 0) counted as straight; default 1/600 m",
};

// more descriptors
const AZIMUTH: ParamDef = ParamDef {
    name: "azimuth",
    kind: ParamKind::Azimuth,
    default: "0",
    range: "degrees clockwise from north, any finite number (taken mod 360)",
};
// descr4
const PLANET: ParamDef = ParamDef {
    name: "planet",
    kind: ParamKind::Value,
    default: "none",
    range: "planet radius in km (1..=1e6; 6371 for the Earth) for the spherical form (heights measured along the base's plumb line, horizontal distances as arcs), or none (planar)",
};
const TOP: ParamDef = ParamDef {
    name: "top",
    kind: ParamKind::Threshold,
    default: "0.2",
    range: "share of the peaks (by prototypicality) averaged into the centroid, 0 < top <= 1",
};
const RADIUS_CUTOFF: ParamDef = ParamDef {
    name: "radius",
    kind: ParamKind::Radius,
    default: "10c",
    range: "1c..=2000c, or a length in m/km (> 0); the disk cutoff (O(r²) per cell)",
};
const EXPONENT: ParamDef = ParamDef {
    name: "s",
    kind: ParamKind::Exponent,
    default: "0.5",
    range: "fractional order s, 0 < s < 1",
};
const TOLERANCE: ParamDef = ParamDef {
    name: "tolerance",
    kind: ParamKind::Threshold,
    default: "45",
    range:
        "half-width in degrees (0 < t <= 90) of the aspect sectors around azimuth and azimuth+180",
};
const FEATURE: ParamDef = ParamDef {
    name: "class",
    kind: ParamKind::Feature,
    default: "peak",
    range: "peak, ridge, pass, plane, channel or pit",
};
const SCALES: ParamDef = ParamDef {
    name: "scales",
    kind: ParamKind::Scales,
    default: "1/2/4",
    range: "window radii in cells separated by '/', each 1..=2000 (e.g. 1/2/4/8)",
};
const FUZZY_T: ParamDef = ParamDef {
    name: "threshold",
    kind: ParamKind::Threshold,
    default: "0.0001",
    range: "curvature tolerance (1/m, >= 0) of Wood's features",
};
const SHARY_T: ParamDef = ParamDef {
    name: "threshold",
    kind: ParamKind::Threshold,
    default: "0",
    range: "|curvature| (1/m, >= 0; 1/m^2 squared for K) counted as zero: such cells are class 0",
};

const HORN: &str = "Horn 1981, Proc. IEEE 69(1) (3x3 weighted gradient)";
const EVANS: &str =
    "Evans 1979 3x3 quadric (radius 1c), Wood 1996 PhD thesis (Leicester) ch. 4 for larger windows; formulas of Florinsky 2016, Digital Terrain Analysis in Soil Science and Geology, 2nd ed., ch. 2";

macro_rules! def {
    ($k:ident, $n:expr, $p:expr, $u:expr, $d:expr, $c:expr) => {
        MetricDef {
            kind: MetricKind::$k,
            name: $n,
            params: $p,
            units: $u,
            description: $d,
            citation: $c,
        }
    };
}

/// The registry, in the order `orogen metric list` prints it.
pub const METRICS: &[MetricDef] = &[
    def!(
        Dzdx,
        "dzdx",
        &[],
        "z/m",
        "gradient component east (dz/dx)",
        HORN
    ),
    def!(
        Dzdy,
        "dzdy",
        &[],
        "z/m",
        "gradient component north (dz/dy)",
        HORN
    ),
    def!(
        Slope,
        "slope",
        &[UNITS],
        "degrees|percent",
        "slope angle (as the `slope` command)",
        HORN
    ),
    def!(
        Aspect,
        "aspect",
        &[],
        "degrees",
        "azimuth of steepest descent, clockwise from north; flat = nodata",
        HORN
    ),
    def!(
        Northness,
        "northness",
        &[],
        "-1..1",
        "cos(aspect)*sin(slope), slope-weighted so flat cells are 0 (= normal_y)",
        "aspect and slope of Horn 1981; slope-weighted form chosen here (plain cos(aspect) is undefined on flats)"
    ),
    def!(
        Eastness,
        "eastness",
        &[],
        "-1..1",
        "sin(aspect)*sin(slope), slope-weighted so flat cells are 0 (= normal_x)",
        "aspect and slope of Horn 1981; slope-weighted form chosen here (plain sin(aspect) is undefined on flats)"
    ),
    def!(
        NormalX,
        "normal_x",
        &[],
        "-1..1",
        "unit surface normal, east component -p/sqrt(1+p^2+q^2)",
        HORN
    ),
    def!(
        NormalY,
        "normal_y",
        &[],
        "-1..1",
        "unit surface normal, north component -q/sqrt(1+p^2+q^2)",
        HORN
    ),
    def!(
        NormalZ,
        "normal_z",
        &[],
        "0..1",
        "unit surface normal, up component 1/sqrt(1+p^2+q^2)",
        HORN
    ),
    def!(
        Laplacian,
        "laplacian",
        &[],
        "z/m^2",
        "5-point Laplacian d2z/dx2 + d2z/dy2",
        "finite differences (Argudo et al. survey sec. 3)"
    ),
    def!(
        ProfileCurvature,
        "profile_curvature",
        &[RADIUS_QUADRIC],
        "1/m",
        "vertical (profile) curvature kv; convex positive; 0 where flat",
        EVANS
    ),
    def!(
        PlanCurvature,
        "plan_curvature",
        &[RADIUS_QUADRIC],
        "1/m",
        "plan (contour) curvature kp; convex positive; 0 where flat",
        EVANS
    ),
    def!(
        TangentialCurvature,
        "tangential_curvature",
        &[RADIUS_QUADRIC],
        "1/m",
        "horizontal (tangential) curvature kh; convex positive; 0 where flat",
        EVANS
    ),
    def!(
        MeanCurvature,
        "mean_curvature",
        &[RADIUS_QUADRIC],
        "1/m",
        "mean curvature H; convex positive",
        EVANS
    ),
    def!(
        GaussianCurvature,
        "gaussian_curvature",
        &[RADIUS_QUADRIC],
        "1/m^2",
        "Gaussian curvature K",
        EVANS
    ),
    def!(
        MinCurvature,
        "min_curvature",
        &[RADIUS_QUADRIC],
        "1/m",
        "minimal curvature H - sqrt(H^2-K)",
        EVANS
    ),
    def!(
        MaxCurvature,
        "max_curvature",
        &[RADIUS_QUADRIC],
        "1/m",
        "maximal curvature H + sqrt(H^2-K)",
        EVANS
    ),
    def!(
        Mean,
        "mean",
        &[RADIUS, SHAPE],
        "z",
        "mean of valid cells in the square window of side 2r+1",
        "summed-area tables, Crow 1984 (SIGGRAPH)"
    ),
    def!(
        Stdev,
        "stdev",
        &[RADIUS, SHAPE],
        "z",
        "population standard deviation of valid cells in the square window",
        "summed-area tables, Crow 1984"
    ),
    def!(
        Variance,
        "variance",
        &[RADIUS, SHAPE],
        "z^2",
        "population variance of valid cells in the square window",
        "summed-area tables, Crow 1984"
    ),
    def!(
        Tpi,
        "tpi",
        &[RADIUS, SHAPE],
        "z",
        "z minus the mean of the other valid cells of the square window",
        "Weiss 2001 (TPI poster, ESRI UC); square window, centre excluded"
    ),
    def!(
        Ntpi,
        "ntpi",
        &[RADIUS, SHAPE],
        "-",
        "TPI / standard deviation of the window (0 where the window is flat)",
        "Weiss 2001; De Reu et al. 2013 (DEV)"
    ),
    def!(
        Relief,
        "relief",
        &[RADIUS],
        "z",
        "local relief: max - min of valid cells in the square window",
        "van Herk 1992 / Gil & Werman 1993 running max/min"
    ),
    def!(
        Percentile,
        "percentile",
        &[RADIUS],
        "%",
        "share of the other valid cells of the square window lower than the cell (O(r^2) per cell)",
        "elevation percentile (Argudo et al. survey sec. 3, local statistics)"
    ),
    def!(
        TopHatWhite,
        "tophat_white",
        &[RADIUS],
        "z",
        "white top-hat z - opening (square window): height above the local 'floor'",
        "grey-level morphology, Serra 1982; van Herk/Gil-Werman max/min"
    ),
    def!(
        TopHatBlack,
        "tophat_black",
        &[RADIUS],
        "z",
        "black top-hat closing - z (square window): depth below the local 'lid'",
        "grey-level morphology, Serra 1982; van Herk/Gil-Werman max/min"
    ),
    def!(
        TriRiley,
        "tri_riley",
        &[],
        "z",
        "sqrt of the sum of squared differences to the 8 neighbours",
        "Riley, DeGloria & Elliot 1999, Intermountain J. Sci. 5"
    ),
    def!(
        TriWilson,
        "tri",
        &[],
        "z",
        "mean absolute difference to the 8 neighbours (gdaldem TRI -alg Wilson)",
        "Wilson et al. 2007, Marine Geodesy 30"
    ),
    def!(
        Roughness,
        "roughness",
        &[RADIUS],
        "degrees",
        "spherical standard deviation of unit normals in the square window",
        "Lindsay, Newman & Francioni 2019, Geosciences 9(7) 322"
    ),
    def!(
        Rugosity,
        "rugosity",
        &[],
        ">=1",
        "surface area / planimetric area of the cell (8 triangles)",
        "Jenness 2004, Wildlife Society Bulletin 32(3)"
    ),
    def!(
        OpennessPositive,
        "openness",
        &[RADIUS_HORIZON, DIRECTIONS],
        "degrees",
        "positive openness: mean over directions of 90 - horizon elevation angle",
        "Yokoyama, Shirasawa & Pike 2002, PE&RS 68(3)"
    ),
    def!(
        OpennessNegative,
        "openness_neg",
        &[RADIUS_HORIZON, DIRECTIONS],
        "degrees",
        "negative openness: mean over directions of 90 + nadir (min) elevation angle",
        "Yokoyama, Shirasawa & Pike 2002, PE&RS 68(3)"
    ),
    def!(
        SkyView,
        "sky_view",
        &[RADIUS_HORIZON, DIRECTIONS],
        "0..1",
        "sky-view factor 1 - mean sin(max(horizon angle, 0))",
        "Zakšek, Oštir & Kokalj 2011, Remote Sensing 3(2)"
    ),
    def!(
        SkyViewApprox,
        "sky_view_approx",
        &[],
        "0..1",
        "(1 + cos slope)/2: the sky view of an infinite plane of that slope",
        "isotropic sky view of a tilted plane (Liu & Jordan 1963, Solar Energy 7(2)); Horn slope"
    ),
    def!(
        Geomorphon,
        "geomorphon",
        &[RADIUS_GEOMORPHON, FLAT],
        "class 1..10",
        "geomorphon landform: 1 flat, 2 peak, 3 ridge, 4 shoulder, 5 spur, 6 slope, 7 hollow, 8 footslope, 9 valley, 10 pit",
        "Jasiewicz & Stepinski 2013, Geomorphology 182 (classes numbered as GRASS r.geomorphon)"
    ),
    def!(
        GeomorphonPattern,
        "geomorphon_pattern",
        &[RADIUS_GEOMORPHON, FLAT],
        "0..6560",
        "geomorphon ternary pattern sum d_i 3^i, i = N,NE,..,NW clockwise; d = 0 flat, 1 '+', 2 '-' (not canonicalised)",
        "Jasiewicz & Stepinski 2013, Geomorphology 182"
    ),
    def!(
        GeomorphonCanonical,
        "geomorphon_canonical",
        &[RADIUS_GEOMORPHON, FLAT],
        "0..6560",
        "geomorphon_pattern reduced to its smallest code over 8 rotations and their mirrors (498 values)",
        "Jasiewicz & Stepinski 2013, Geomorphology 182, sec. 2.2"
    ),
    def!(
        WeissLandform,
        "weiss_landform",
        &[RADIUS_SMALL, RADIUS_LARGE, SLOPE_T],
        "class 1..10",
        "Weiss TPI landforms from NTPI at two scales (thresholds +-1) and Horn slope: 1 canyon .. 5 plain, 6 open slope .. 10 mountain top",
        "Weiss 2001 (TPI poster, ESRI UC); standardised locally (NTPI) instead of over the whole raster"
    ),
    def!(
        DikauForm,
        "dikau_form",
        &[RADIUS_QUADRIC, CURV_T],
        "class 1..9",
        "Dikau form 3p+q+1 from profile (p) and plan (q) curvature: 0 concave, 1 straight, 2 convex",
        "Dikau 1989 (in Raper, 3D applications in GIS); curvatures of Evans/Wood as profile_curvature/plan_curvature"
    ),
    // visibility & solar
    def!(
        HorizonAngle,
        "horizon",
        &[RADIUS_HORIZON, super::visibility::DIR],
        "degrees",
        "horizon elevation angle (max atan(dz/d) within the cutoff) along one lattice direction",
        "Dozier & Frew 1990, IEEE TGRS 28(5); exact lattice rays, line-sweep hulls after Stewart 1998, IEEE TVCG 4(1)"
    ),
    def!(
        Zenith,
        "zenith",
        &[RADIUS_HORIZON, DIRECTIONS],
        "degrees",
        "zenith angle: min over directions of 90 - horizon elevation angle",
        "Yokoyama, Shirasawa & Pike 2002, PE&RS 68(3) (per-direction zenith angle, min over directions)"
    ),
    def!(
        Nadir,
        "nadir",
        &[RADIUS_HORIZON, DIRECTIONS],
        "degrees",
        "nadir angle: min over directions of 90 + lowest elevation angle",
        "Yokoyama, Shirasawa & Pike 2002, PE&RS 68(3) (per-direction nadir angle, min over directions)"
    ),
    def!(
        Accessibility,
        "accessibility",
        &[RADIUS_HORIZON, DIRECTIONS],
        "0..1",
        "ambient occlusion / accessibility: cosine-weighted visible sky mean cos^2(max(horizon angle, 0))",
        "Dozier & Frew 1990, IEEE TGRS 28(5) (sky view of a horizontal surface)"
    ),
    def!(
        VisibilityIndex,
        "visibility_index",
        &[
            RADIUS_HORIZON,
            DIRECTIONS,
            super::visibility::HEIGHT,
            super::visibility::TARGET
        ],
        "0..1",
        "share of the cells on the lattice rays within the cutoff that the observer (height above the cell) sees",
        "Franklin & Ray 1994 (Proc. Spatial Data Handling) visibility index, targets sampled along 8/16 exact rays"
    ),
    def!(
        SolarDirect,
        "solar_direct",
        super::solar::SOLAR_PARAMS,
        "Wh/m2 (day), W/m2 (hour)",
        "clear-sky direct (beam) irradiation on the slope with cast shadows, for one solar hour or the whole day",
        super::solar::SOLAR_CITE
    ),
    def!(
        SolarGlobal,
        "solar_global",
        super::solar::SOLAR_PARAMS,
        "Wh/m2 (day), W/m2 (hour)",
        "clear-sky direct + isotropic diffuse (x sky-view factor) irradiation, one solar hour or the whole day",
        super::solar::SOLAR_CITE
    ),
    def!(
        SolarAnnual,
        "solar_annual",
        super::solar::ANNUAL_PARAMS,
        "kWh/m2",
        "clear-sky direct + isotropic diffuse irradiation over a year (sampled days, scaled to 365)",
        super::solar::SOLAR_CITE
    ),
    def!(
        HeatIndex,
        "heat_index",
        &[super::solar::ALPHA_MAX],
        "-1.57..1.57",
        "diurnal anisotropic heating cos(alpha_max - aspect) * atan(slope in radians); flat = 0",
        "Böhner & Antonić 2009 (in Hengl & Reuter, Geomorphometry, ch. 8), as SAGA"
    ),
    def!(
        VisibilityIndexExact,
        "visibility_index_exact",
        &[
            super::visibility::RADIUS_EXACT,
            super::visibility::HEIGHT,
            super::visibility::TARGET
        ],
        "0..1",
        "share of all cells within the cutoff disk visible (R3 line of sight) from the observer; O(r^3) per cell",
        "Franklin & Ray 1994 (Proc. Spatial Data Handling) visibility index, R3 line of sight to every target"
    ),
    // more descriptors
    def!(
        DirectionalSlope,
        "directional_slope",
        &[AZIMUTH],
        "z/m",
        "slope along an azimuth: grad z . (sin a, cos a), positive uphill (Horn gradient)",
        "directional derivative (Argudo et al. survey sec. 3.1); Horn 1981 gradient"
    ),
    def!(
        AverageSlope,
        "average_slope",
        &[RADIUS],
        "degrees",
        "mean Horn slope angle of the valid cells of the square window (exact SAT)",
        "average slope (Argudo et al. survey sec. 3.1); summed-area tables, Crow 1984"
    ),
    def!(
        FractionalLaplacian,
        "fractional_laplacian",
        &[RADIUS_CUTOFF, EXPONENT],
        "z/m^2s",
        "(-Laplacian)^s z = C(s) sum over 0<|y|<=R of (z(x)-z(x+y))/|y|^(2+2s) * cell area (disk cutoff)",
        "integral form, Di Nezza, Palatucci & Valdinoci 2012, Bull. Sci. Math. 136(5), eq. 3.1; C(s) of their eq. 3.2 for n = 2"
    ),
    def!(
        HillslopeAsymmetry,
        "hillslope_asymmetry",
        &[RADIUS, AZIMUTH, TOLERANCE],
        "log10 ratio",
        "log10(mean gradient of cells facing azimuth / mean gradient of cells facing azimuth+180) in the square window; cells under 5% gradient left out",
        "Poulos, Pierce, Flores & Benner 2012, GRL 39 L06406 (medians there; means as in the Argudo et al. survey code)"
    ),
    def!(
        SharyLandform,
        "shary_landform",
        &[RADIUS_QUADRIC, SHARY_T],
        "class 0..12",
        "Shary's 12 types from the signs of K, H, kh (tangential) and kv (profile): see metrics::shary; 0 where one is zero",
        "Shary 1995, Mathematical Geology 27(3); Shary, Sharaya & Mitusov 2002, Geoderma 107; curvatures of Evans/Wood"
    ),
    def!(
        Ors,
        "ors",
        &[RADIUS_CUTOFF],
        "z",
        "omni-directional relief and steepness sqrt(sum over lower cells in the disk of f(drop/distance) * cell area)",
        "Earl & Metzler 2015, Quaestiones Geographicae 34(4) (ORS); disk cutoff"
    ),
    def!(
        Jut,
        "jut",
        &[RADIUS_CUTOFF, PLANET],
        "z",
        "max over the disk of the angle-reduced height dz*|dz|/d3 of the cell above others (planar; with planet=R km heights above the base horizon on a sphere; >= 0)",
        "Xu 2022, Beyond elevation / datumless topography (arXiv 2208.01600); planar, or spherical with planet=R km; disk cutoff"
    ),
    def!(
        Rut,
        "rut",
        &[RADIUS_CUTOFF, PLANET],
        "z",
        "max over the disk of the angle-reduced height dz*|dz|/d3 of others above the cell (planar; with planet=R km heights above the base horizon on a sphere; >= 0)",
        "Xu 2022, Beyond elevation / datumless topography (arXiv 2208.01600); planar, or spherical with planet=R km; disk cutoff"
    ),
    def!(
        FuzzyLandform,
        "fuzzy_landform",
        &[FEATURE, SCALES, FUZZY_T],
        "0..1",
        "share of the window radii (scales) at which Wood's feature classification gives the class",
        "Fisher, Wood & Cheng 2004, Trans. IBG 29(1); features of Wood 1996 (PhD thesis, Leicester), as r.param.scale"
    ),
    // last descriptors
    def!(
        Dominance,
        "dominance",
        &[RADIUS_CUTOFF, PLANET],
        "z",
        "how far the cell rises above the lowest valid cell of the disk: max(0, max (z - z_q)) (planar; planet=R km: height above the horizon plane of q on a sphere); 0 = submissive",
        "Xu 2022, Beyond elevation / datumless topography (arXiv 2208.01600); planar, or spherical with planet=R km; disk cutoff"
    ),
    def!(
        Submission,
        "submission",
        &[RADIUS_CUTOFF, PLANET],
        "z",
        "how far the cell dips below the highest valid cell of the disk: max(0, max (z_q - z)) (planar; planet=R km: height of q above the horizon plane of the cell); 0 = dominant",
        "Xu 2022, Beyond elevation / datumless topography (arXiv 2208.01600); planar, or spherical with planet=R km; disk cutoff"
    ),
    def!(
        Peakedness,
        "peakedness",
        &[RADIUS_CUTOFF],
        "0..1",
        "share of the other valid cells of the disk strictly lower than the cell",
        "Deng & Wilson 2008, IJGIS 22(1-2) (elevation-percentile criterion at one scale); Llobera 2001 as the survey code; disk cutoff"
    ),
    def!(
        Domination,
        "domination",
        &[RADIUS_CUTOFF],
        "m",
        "geographical domination: distance to the nearest strictly higher valid cell; the cutoff if none within it",
        "'Dominanz' of German orometry (isolation of a point); disk cutoff"
    ),
    // descr3
    def!(
        AsymmetryIndex,
        "asymmetry_index",
        &[RADIUS, AZIMUTH, TOLERANCE],
        "log10 ratio",
        "log10(median gradient of cells facing azimuth / median gradient of cells facing azimuth+180) in the square window; cells under 5% gradient left out",
        "Poulos, Pierce, Flores & Benner 2012, GRL 39 L06406, sec. 2 (medians, as published; hillslope_asymmetry uses means)"
    ),
    // descr4
    def!(
        PeakednessDw,
        "peakedness_dw",
        &[TOP],
        "0..1",
        "multi-scale peakedness: weighted similarity to the centroid of the top peaks of relief, mean slope, relative elevation and isolation at 5/20/50-cell windows, normalised over the WHOLE raster (two tiled global passes)",
        "Deng & Wilson 2008, IJGIS 22(2); factors, scales and weights of the survey code (Argudo et al., HeightField::Peakness)"
    ),
    def!(
        PeakPrototypicality,
        "peak_prototypicality",
        &[TOP],
        "0..1",
        "weighted mean over 5/20/50-cell windows of relief, mean slope, relative elevation and isolation, each min-max normalised over the WHOLE raster (one tiled global pass)",
        "Deng & Wilson 2008, IJGIS 22(2); as the survey code's peak prototypicality (HeightField::Peakness)"
    ),
];

/// The registry entry of `kind`.
pub fn def(kind: MetricKind) -> &'static MetricDef {
    METRICS
        .iter()
        .find(|d| d.kind == kind)
        .expect("every MetricKind has a registry entry (checked by a unit test)")
}

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

/// A length given by the user.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Length {
    Metres(f64),
    Cells(usize),
}

impl std::fmt::Display for Length {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Length::Metres(m) => write!(f, "{m}m"),
            Length::Cells(c) => write!(f, "{c}c"),
        }
    }
}

/// One requested metric with its parameters (defaults filled in).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MetricSpec {
    pub kind: MetricKind,
    /// Window radius or horizon cutoff (metrics with a `radius` parameter).
    pub radius: Option<Length>,
    /// Horizon directions (8 or 16) for openness and sky view.
    pub directions: usize,
    /// Slope units.
    pub units: SlopeUnits,
    /// Disk window instead of the square (windowed statistics).
    #[serde(default)]
    pub disk: bool,
    /// Second radius (large scale of `weiss_landform`).
    #[serde(default)]
    pub radius2: Option<Length>,
    /// Threshold of the landform classes (flatness, slope or curvature).
    #[serde(default)]
    pub threshold: Option<f64>,
    // visibility & solar
    /// Named numeric parameters ([`ParamKind::Value`]); absent = `auto`.
    #[serde(default)]
    pub values: std::collections::BTreeMap<String, f64>,
    // more descriptors
    /// Azimuth in degrees clockwise from north, in [0, 360).
    #[serde(default)]
    pub azimuth: Option<f64>,
    /// Exponent of the fractional Laplacian, in (0, 1).
    #[serde(default)]
    pub exponent: Option<f64>,
    /// Wood's feature code (index into `fuzzy::FEATURES`).
    #[serde(default)]
    pub feature: Option<u8>,
    /// Window radii in cells (fuzzy landforms).
    #[serde(default)]
    pub scales: Option<Vec<usize>>,
}

impl MetricSpec {
    /// The metric with its default parameters.
    pub fn new(kind: MetricKind) -> MetricSpec {
        let d = def(kind);
        let mut s = MetricSpec {
            kind,
            radius: None,
            directions: 8,
            units: SlopeUnits::Degrees,
            disk: false,
            radius2: None,
            threshold: None,
            values: Default::default(),
            azimuth: None,
            exponent: None,
            feature: None,
            scales: None,
        };
        for p in d.params {
            // Defaults are registry constants, parsed by the unit tests.
            let _ = s.set(p, p.default);
        }
        s
    }

    /// Registry entry.
    pub fn def(&self) -> &'static MetricDef {
        def(self.kind)
    }

    /// Output name: the metric's name plus its non-default parameters, e.g.
    /// `tpi_r500m` (file names of the CLI).
    pub fn label(&self) -> String {
        let mut s = self.def().name.to_string();
        if let Some(r) = self.radius {
            // Curvatures at their default (Evans 3x3) keep the plain name.
            if !((is_curvature(self.kind)
                || self.kind == MetricKind::DikauForm
                || self.kind == MetricKind::SharyLandform)
                && r == Length::Cells(1))
            {
                s.push_str(&format!("_r{r}"));
            }
        }
        if let Some(r) = self.radius2 {
            s.push_str(&format!("_R{r}"));
        }
        if let (Some(t), Some(p)) = (
            self.threshold,
            self.def()
                .params
                .iter()
                .find(|p| p.kind == ParamKind::Threshold),
        ) {
            if p.default.parse::<f64>().ok() != Some(t) {
                s.push_str(&format!("_t{t}"));
            }
        }
        if self
            .def()
            .params
            .iter()
            .any(|p| p.kind == ParamKind::Directions)
            && self.directions != 8
        {
            s.push_str(&format!("_d{}", self.directions));
        }
        if self.disk {
            s.push_str("_disk");
        }
        if self.kind == MetricKind::Slope && self.units == SlopeUnits::Percent {
            s.push_str("_pct");
        }
        // visibility & solar: non-default named values.
        for p in self
            .def()
            .params
            .iter()
            .filter(|p| p.kind == ParamKind::Value)
        {
            let v = self.values.get(p.name).copied();
            let dflt = super::visibility::parse_value(p.name, p.default)
                .ok()
                .flatten();
            if v != dflt {
                match v {
                    Some(v) => s.push_str(&format!("_{}{v}", p.name)),
                    None => s.push_str(&format!("_{}auto", p.name)),
                }
            }
        }
        // more descriptors
        if let Some(a) = self.azimuth.filter(|&a| a != 0.0) {
            s.push_str(&format!("_a{a}"));
        }
        if let Some(e) = self.exponent.filter(|&e| e != 0.5) {
            s.push_str(&format!("_s{e}"));
        }
        if let Some(f) = self.feature {
            let name = crate::metrics::fuzzy::FEATURES.get(f as usize).copied();
            s.push_str(&format!("_{}", name.unwrap_or("?")));
        }
        if let Some(sc) = self.scales.as_ref().filter(|v| v.as_slice() != [1, 2, 4]) {
            let v: Vec<String> = sc.iter().map(|c| c.to_string()).collect();
            s.push_str(&format!("_sc{}", v.join("-")));
        }
        s
    }

    /// A named value ([`ParamKind::Value`]) or `None` (`auto`).
    pub fn value(&self, name: &str) -> Option<f64> {
        self.values.get(name).copied()
    }

    fn set(&mut self, p: &ParamDef, value: &str) -> std::result::Result<(), String> {
        match p.kind {
            ParamKind::Radius => self.radius = Some(parse_length(value)?),
            ParamKind::Radius2 => self.radius2 = Some(parse_length(value)?),
            ParamKind::Threshold => {
                let v: f64 = value
                    .trim()
                    .parse()
                    .map_err(|_| format!("'{value}' is not a number"))?;
                if !(v.is_finite() && v >= 0.0) {
                    return Err(format!("'{value}' must be finite and >= 0"));
                }
                self.threshold = Some(v);
            }
            ParamKind::Directions => {
                self.directions = match value {
                    "8" => 8,
                    "16" => 16,
                    _ => return Err(format!("'{value}' is not 8 or 16")),
                }
            }
            ParamKind::Shape => {
                self.disk = match value {
                    "square" => false,
                    "disk" => true,
                    _ => return Err(format!("'{value}' is not square or disk")),
                }
            }
            ParamKind::SlopeUnits => {
                self.units = match value {
                    "degrees" | "deg" => SlopeUnits::Degrees,
                    "percent" | "pct" => SlopeUnits::Percent,
                    _ => return Err(format!("'{value}' is not degrees or percent")),
                }
            }
            // visibility & solar
            ParamKind::Value => match super::visibility::parse_value(p.name, value)? {
                Some(v) => {
                    self.values.insert(p.name.to_string(), v);
                }
                None => {
                    self.values.remove(p.name);
                }
            },
            // more descriptors
            ParamKind::Azimuth => {
                let v: f64 = value
                    .trim()
                    .parse()
                    .map_err(|_| format!("'{value}' is not a number of degrees"))?;
                if !v.is_finite() {
                    return Err(format!("'{value}' must be finite"));
                }
                self.azimuth = Some(v.rem_euclid(360.0));
            }
            ParamKind::Exponent => {
                let v: f64 = value
                    .trim()
                    .parse()
                    .map_err(|_| format!("'{value}' is not a number"))?;
                if !(v > 0.0 && v < 1.0) {
                    return Err(format!("'{value}' is not strictly between 0 and 1"));
                }
                self.exponent = Some(v);
            }
            ParamKind::Feature => {
                let f = crate::metrics::fuzzy::FEATURES
                    .iter()
                    .position(|n| *n == value.trim())
                    .ok_or_else(|| format!("'{value}' is not a feature"))?;
                self.feature = Some(f as u8);
            }
            ParamKind::Scales => {
                let mut v = Vec::new();
                for part in value.split('/') {
                    let c: usize =
                        part.trim().trim_end_matches('c').parse().map_err(|_| {
                            format!("'{part}' in '{value}' is not a radius in cells")
                        })?;
                    if !(1..=MAX_RADIUS_CELLS).contains(&c) {
                        return Err(format!("scale {c} is out of 1..={MAX_RADIUS_CELLS}"));
                    }
                    v.push(c);
                }
                v.sort_unstable();
                v.dedup();
                self.scales = Some(v);
            }
        }
        Ok(())
    }
}

/// Parse `500m`, `1.5km`, `25c` (a bare number is refused: say m or c).
pub fn parse_length(s: &str) -> std::result::Result<Length, String> {
    let s = s.trim();
    let bad =
        || format!("'{s}' is not a length: write metres (500m), kilometres (1.5km) or cells (25c)");
    let (num, scale, cells) = if let Some(n) = s.strip_suffix("km") {
        (n, 1000.0, false)
    } else if let Some(n) = s.strip_suffix('m') {
        (n, 1.0, false)
    } else if let Some(n) = s.strip_suffix('c') {
        (n, 1.0, true)
    } else {
        return Err(bad());
    };
    if cells {
        let c: i64 = num.trim().parse().map_err(|_| bad())?;
        if c < 1 || c as usize > MAX_RADIUS_CELLS {
            return Err(format!(
                "radius {s} is out of range: use 1c..={MAX_RADIUS_CELLS}c"
            ));
        }
        Ok(Length::Cells(c as usize))
    } else {
        let v: f64 = num.trim().parse().map_err(|_| bad())?;
        if !(v.is_finite() && v > 0.0) {
            return Err(format!("radius {s} must be a positive finite length"));
        }
        Ok(Length::Metres(v * scale))
    }
}

/// Names of all metrics, comma separated (for error messages).
fn all_names() -> String {
    METRICS
        .iter()
        .map(|d| d.name)
        .collect::<Vec<_>>()
        .join(", ")
}

/// Parse a comma-separated list of metric specs: `name[:param=value[:param=value]]`,
/// e.g. `slope,tpi:radius=500m,openness:radius=1km:directions=16`.
/// Unknown metrics, parameters or values give `Error::Invalid` listing what
/// is accepted. Radii are checked against the raster later, by [`resolve`].
pub fn parse_specs(s: &str) -> Result<Vec<MetricSpec>> {
    let mut out = Vec::new();
    for item in s.split(',') {
        let item = item.trim();
        if item.is_empty() {
            return Err(Error::invalid(format!(
                "empty metric in '{s}': separate metrics with single commas (known: {})",
                all_names()
            )));
        }
        let mut parts = item.split(':');
        let name = parts.next().unwrap_or("").trim();
        let d = METRICS.iter().find(|d| d.name == name).ok_or_else(|| {
            Error::invalid(format!(
                "unknown metric '{name}'; known metrics: {}",
                all_names()
            ))
        })?;
        let mut spec = MetricSpec::new(d.kind);
        let mut seen: Vec<&str> = Vec::new();
        for kv in parts {
            let accepted = if d.params.is_empty() {
                "it takes no parameters".to_string()
            } else {
                format!(
                    "accepted: {}",
                    d.params
                        .iter()
                        .map(|p| format!("{} ({})", p.name, p.range))
                        .collect::<Vec<_>>()
                        .join("; ")
                )
            };
            let (k, v) = kv.split_once('=').ok_or_else(|| {
                Error::invalid(format!("'{kv}' in '{item}' is not param=value; {accepted}"))
            })?;
            let (k, v) = (k.trim(), v.trim());
            let p = d.params.iter().find(|p| p.name == k).ok_or_else(|| {
                Error::invalid(format!(
                    "metric '{name}' has no parameter '{k}'; {accepted}"
                ))
            })?;
            if seen.contains(&k) {
                return Err(Error::invalid(format!(
                    "parameter '{k}' given twice in '{item}'"
                )));
            }
            seen.push(k);
            spec.set(p, v).map_err(|m| {
                Error::invalid(format!(
                    "bad value for {name}:{k}: {m} (allowed: {})",
                    p.range
                ))
            })?;
        }
        out.push(spec);
    }
    Ok(out)
}

/// The table `orogen metric list` prints: one line per metric with its
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

/// A metric bound to a raster: radius in cells (window half-side or horizon
/// steps) and the horizon cutoff distance in metres.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Resolved {
    pub spec: MetricSpec,
    /// Radius in cells (0 for metrics without a radius).
    pub radius_cells: usize,
    /// Radius as a distance in metres (horizon cutoff); for a radius given in
    /// cells, cells times the smallest true cell size.
    pub radius_m: f64,
    /// Second radius in cells (`weiss_landform`'s large scale; else 0).
    #[serde(default)]
    pub radius2_cells: usize,
}

impl Resolved {
    /// Halo in cells the metric needs.
    pub fn halo(&self) -> usize {
        use MetricKind::*;
        match self.spec.kind {
            Mean | Stdev | Variance | Tpi | Ntpi | Relief | OpennessPositive | OpennessNegative
            | SkyView => self.radius_cells,
            Percentile => self.radius_cells,
            // Two passes of the window.
            TopHatWhite | TopHatBlack => 2 * self.radius_cells,
            // Normals need one more ring.
            Roughness => self.radius_cells + 1,
            k if is_curvature(k) => self.radius_cells.max(1),
            Geomorphon | GeomorphonPattern | GeomorphonCanonical => self.radius_cells,
            WeissLandform => self.radius_cells.max(self.radius2_cells),
            DikauForm => self.radius_cells.max(1),
            // visibility & solar
            HorizonAngle | Zenith | Nadir | Accessibility | VisibilityIndex | SolarDirect
            | SolarGlobal | SolarAnnual | VisibilityIndexExact => self.radius_cells.max(1),
            // more descriptors
            AverageSlope | HillslopeAsymmetry | AsymmetryIndex => self.radius_cells + 1,
            FractionalLaplacian | Ors | Jut | Rut => self.radius_cells,
            SharyLandform => self.radius_cells.max(1),
            FuzzyLandform => self
                .spec
                .scales
                .as_ref()
                .and_then(|v| v.iter().max().copied())
                .unwrap_or(1),
            // last descriptors
            Dominance | Submission | Peakedness | Domination => self.radius_cells,
            // descr4: whole-raster metrics (their own passes, see peak_dw)
            PeakednessDw | PeakPrototypicality => super::peak_dw::HALO,
            _ => 1,
        }
    }
}

/// Smallest true cell size in metres over all rows of the raster (both axes).
pub fn min_cell_size_m(info: &RasterInfo) -> f64 {
    let g = &info.georef;
    let mut m = f64::INFINITY;
    if g.georeferenced && g.crs.geographic {
        for row in 0..info.height as i64 {
            let (a, b) = g.cell_size_m(row);
            m = m.min(a).min(b);
        }
    } else {
        let (a, b) = g.cell_size_m(0);
        m = a.min(b);
    }
    m
}

/// Bind specs to a raster: convert metre radii to cells with the smallest
/// true cell size over the rows (so a window covers at least the radius
/// everywhere), and refuse radii beyond the raster or the cell limit.
pub fn resolve(specs: &[MetricSpec], info: &RasterInfo) -> Result<Vec<Resolved>> {
    if specs.is_empty() {
        return Err(Error::invalid(format!(
            "no metric requested; known metrics: {}",
            all_names()
        )));
    }
    let cell = min_cell_size_m(info);
    if !(cell.is_finite() && cell > 0.0) {
        return Err(Error::invalid(format!(
            "{}: the cell size ({cell} m) is not positive: fix the georeferencing",
            info.path.display()
        )));
    }
    let extent = info.width.max(info.height);
    specs
        .iter()
        .map(|s| {
            let to_cells = |r: Option<Length>| -> Result<(usize, f64)> {
                let (cells, m) = match r {
                    None => (0.0, 0.0),
                    Some(Length::Cells(c)) => (c as f64, c as f64 * cell),
                    Some(Length::Metres(m)) => ((m / cell).ceil().max(1.0), m),
                };
                if r.is_some() && (cells > extent as f64 || cells > MAX_RADIUS_CELLS as f64) {
                    return Err(Error::invalid(format!(
                        "{}: radius {} of {} is {} cells (cell size {cell:.3} m), beyond the raster ({}x{} cells) or the limit of {MAX_RADIUS_CELLS} cells: use a smaller radius",
                        info.path.display(),
                        r.map(|r| r.to_string()).unwrap_or_default(),
                        s.def().name,
                        cells,
                        info.width,
                        info.height
                    )));
                }
                Ok((cells as usize, m))
            };
            let (radius_cells, radius_m) = to_cells(s.radius)?;
            let (radius2_cells, _) = to_cells(s.radius2)?;
            // more descriptors
            if let Some(&big) = s.scales.as_ref().and_then(|v| v.iter().max()) {
                if big > extent {
                    return Err(Error::invalid(format!(
                        "{}: scale {big}c of {} is beyond the raster ({}x{} cells): use smaller scales",
                        info.path.display(),
                        s.def().name,
                        info.width,
                        info.height
                    )));
                }
            }
            if matches!(s.kind, MetricKind::HillslopeAsymmetry | MetricKind::AsymmetryIndex) {
                let t = s.threshold.unwrap_or(45.0);
                if !(t > 0.0 && t <= 90.0) {
                    return Err(Error::invalid(format!(
                        "{}:tolerance={t} is out of range: use 0 < tolerance <= 90 (degrees)",
                        s.def().name
                    )));
                }
            }
            // descr4
            if super::peak_dw::is_whole_raster(s.kind) {
                let t = s.threshold.unwrap_or(super::peak_dw::DEFAULT_TOP);
                if !(t > 0.0 && t <= 1.0) {
                    return Err(Error::invalid(format!(
                        "{}:top={t} is out of range: use 0 < top <= 1 (share of the peaks in the centroid)",
                        s.def().name
                    )));
                }
            }
            let mut spec = s.clone();
            // Solar metrics on a projected raster whose CRS orogen can invert
            // (UTM, Web Mercator) default to the latitude of the raster's centre.
            if matches!(
                spec.kind,
                MetricKind::SolarDirect | MetricKind::SolarGlobal | MetricKind::SolarAnnual
            ) && spec.value("lat").is_none()
                && info.georef.georeferenced
                && !info.georef.crs.geographic
            {
                if let Ok(crs) = crate::raster::proj::SourceCrs::of(&info.georef, &info.path) {
                    let t = info.georef.transform;
                    let (c, r) = (info.width as f64 / 2.0, info.height as f64 / 2.0);
                    let (x, y) = (t[0] + c * t[1] + r * t[2], t[3] + c * t[4] + r * t[5]);
                    let (_, lat) = crs.to_lonlat(x, y);
                    if lat.is_finite() {
                        spec.values.insert("lat".to_string(), lat);
                    }
                }
            }
            let r = Resolved {
                spec,
                radius_cells,
                radius_m,
                radius2_cells,
            };
            // visibility & solar
            super::solar::check_resolved(&r, info)?;
            Ok(r)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_kind_once_and_defaults_parse() {
        for d in METRICS {
            assert_eq!(METRICS.iter().filter(|e| e.kind == d.kind).count(), 1);
            assert_eq!(METRICS.iter().filter(|e| e.name == d.name).count(), 1);
            let mut s = MetricSpec {
                kind: d.kind,
                radius: None,
                directions: 8,
                units: SlopeUnits::Degrees,
                disk: false,
                radius2: None,
                threshold: None,
                values: Default::default(),
                azimuth: None,
                exponent: None,
                feature: None,
                scales: None,
            };
            for p in d.params {
                s.set(p, p.default).unwrap();
            }
        }
    }
}
