//! The parameters metrics take: their kinds, the shared definitions
//! (radius, shape, directions, thresholds...) with defaults and allowed
//! ranges in the words `orogen metric list` prints, and lengths
//! (`500m`, `1.5km`, `25c`).

use serde::{Deserialize, Serialize};

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
    /// A number stored by name in [`super::spec::MetricSpec::values`], checked by
    /// `visibility::check_value` (`auto` leaves it unset).
    Value,
    /// An azimuth in degrees clockwise from north (any finite value, taken mod 360).
    Azimuth,
    /// An exponent strictly between 0 and 1 (the fractional Laplacian's s).
    Exponent,
    /// One of Wood's features: peak, ridge, pass, plane, channel, pit.
    Feature,
    /// Window radii in cells separated by '/', e.g. `1/2/4`.
    Scales,
    /// The geomorphon line rule: `paper` or `grass`.
    Rule,
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

/// Largest radius in cells accepted (windowed sums stay exact in i128
/// fixed point up to this window size; see `windowed`).
pub const MAX_RADIUS_CELLS: usize = 2000;

pub const RADIUS: ParamDef = ParamDef {
    name: "radius",
    kind: ParamKind::Radius,
    default: "3c",
    range: "1c..=2000c, or a length in m/km (> 0) converted with the smallest true cell size",
};
pub const SHAPE: ParamDef = ParamDef {
    name: "shape",
    kind: ParamKind::Shape,
    default: "square",
    range: "square (SAT, O(1) per cell) or disk (dx²+dy² ≤ r² in cells, O(r) per cell)",
};
pub const RADIUS_HORIZON: ParamDef = ParamDef {
    name: "radius",
    kind: ParamKind::Radius,
    default: "10c",
    range: "1c..=2000c, or a length in m/km (> 0); the horizon search cutoff",
};
pub const RADIUS_QUADRIC: ParamDef = ParamDef {
    name: "radius",
    kind: ParamKind::Radius,
    default: "1c",
    range: "1c (Evans 3x3) ..=2000c, or a length in m/km: Wood's (2r+1)^2 least-squares quadric",
};
pub const DIRECTIONS: ParamDef = ParamDef {
    name: "directions",
    kind: ParamKind::Directions,
    default: "8",
    range: "8 or 16",
};
pub const UNITS: ParamDef = ParamDef {
    name: "units",
    kind: ParamKind::SlopeUnits,
    default: "degrees",
    range: "degrees or percent",
};

pub const RADIUS_GEOMORPHON: ParamDef = ParamDef {
    name: "radius",
    kind: ParamKind::Radius,
    default: "10c",
    range: "1c..=2000c, or a length in m/km (> 0); the lookup distance L",
};
pub const FLAT_T: ParamDef = ParamDef {
    name: "flat",
    kind: ParamKind::Threshold,
    default: "1",
    range: "flatness threshold t in degrees, >= 0",
};
pub const GEOMORPHON_RULE: ParamDef = ParamDef {
    name: "rule",
    kind: ParamKind::Rule,
    default: "paper",
    range: "paper (Jasiewicz & Stepinski 2013: a line is '+' when max + min elevation angle > t, '-' when < -t) or grass (GRASS r.geomorphon 8: a line is non-flat when |max| or |min| > t, signed by the larger; lines stop before the lookup distance, a line whose first cell is nodata is flat, the edge ring is nodata)",
};
pub const RADIUS_SMALL: ParamDef = ParamDef {
    name: "radius",
    kind: ParamKind::Radius,
    default: "3c",
    range: "small-scale TPI radius: 1c..=2000c, or a length in m/km",
};
pub const RADIUS_LARGE: ParamDef = ParamDef {
    name: "large",
    kind: ParamKind::Radius2,
    default: "10c",
    range: "large-scale TPI radius: 1c..=2000c, or a length in m/km",
};
pub const SLOPE_T: ParamDef = ParamDef {
    name: "slope",
    kind: ParamKind::Threshold,
    default: "5",
    range: "slope (degrees, >= 0) separating plains (class 5) from open slopes (6)",
};
pub const CURV_T: ParamDef = ParamDef {
    name: "threshold",
    kind: ParamKind::Threshold,
    default: "0.0016667",
    range: "|curvature| (1/m, >= 0) counted as straight; default 1/600 m",
};

pub const AZIMUTH: ParamDef = ParamDef {
    name: "azimuth",
    kind: ParamKind::Azimuth,
    default: "0",
    range: "degrees clockwise from north, any finite number (taken mod 360)",
};
pub const PLANET: ParamDef = ParamDef {
    name: "planet",
    kind: ParamKind::Value,
    default: "none",
    range: "planet radius in km (1..=1e6; 6371 for the Earth) for the spherical form (heights measured along the base's plumb line, horizontal distances as arcs), or none (planar)",
};
pub const TOP: ParamDef = ParamDef {
    name: "top",
    kind: ParamKind::Threshold,
    default: "0.2",
    range: "share of the peaks (by prototypicality) averaged into the centroid, 0 < top <= 1",
};
pub const RADIUS_CUTOFF: ParamDef = ParamDef {
    name: "radius",
    kind: ParamKind::Radius,
    default: "10c",
    range: "1c..=2000c, or a length in m/km (> 0); the disk cutoff (O(r²) per cell)",
};
pub const EXPONENT: ParamDef = ParamDef {
    name: "s",
    kind: ParamKind::Exponent,
    default: "0.5",
    range: "fractional order s, 0 < s < 1",
};
pub const TOLERANCE: ParamDef = ParamDef {
    name: "tolerance",
    kind: ParamKind::Threshold,
    default: "45",
    range:
        "half-width in degrees (0 < t <= 90) of the aspect sectors around azimuth and azimuth+180",
};
pub const FEATURE: ParamDef = ParamDef {
    name: "class",
    kind: ParamKind::Feature,
    default: "peak",
    range: "peak, ridge, pass, plane, channel or pit",
};
pub const SCALES: ParamDef = ParamDef {
    name: "scales",
    kind: ParamKind::Scales,
    default: "1/2/4",
    range: "window radii in cells separated by '/', each 1..=2000 (e.g. 1/2/4/8)",
};
pub const FUZZY_T: ParamDef = ParamDef {
    name: "threshold",
    kind: ParamKind::Threshold,
    default: "0.0001",
    range: "curvature tolerance (1/m, >= 0) of Wood's features",
};
pub const SHARY_T: ParamDef = ParamDef {
    name: "threshold",
    kind: ParamKind::Threshold,
    default: "0",
    range: "|curvature| (1/m, >= 0; 1/m^2 squared for K) counted as zero: such cells are class 0",
};

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
