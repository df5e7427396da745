//! Metric specs: a metric with its parameter values (`tpi:radius=500m`),
//! parsed from text, labelled for file names, and bound to a raster
//! ([`Resolved`]: radii in cells, raster-dependent defaults and checks).

use super::param::{parse_length, Length, ParamDef, ParamKind, MAX_RADIUS_CELLS};
use super::registry::{all_names, def, metric, MetricDef, MetricKind, METRICS};
use super::terrain::SlopeUnits;
use crate::error::{Error, Result};
use crate::raster::RasterInfo;
use serde::{Deserialize, Serialize};

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
    /// Named numeric parameters ([`ParamKind::Value`]); absent = `auto`.
    #[serde(default)]
    pub values: std::collections::BTreeMap<String, f64>,
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
    /// Geomorphons by GRASS r.geomorphon's rules instead of the paper's.
    #[serde(default)]
    pub grass: bool,
}

impl MetricSpec {
    /// The metric with its default parameters.
    pub fn new(kind: MetricKind) -> MetricSpec {
        let mut s = MetricSpec::unset(kind);
        for p in def(kind).params {
            // Defaults are registry constants, parsed by the unit tests.
            let _ = s.set(p, p.default);
        }
        s
    }

    /// The metric before any parameter is set (8 directions, degrees).
    pub(crate) fn unset(kind: MetricKind) -> MetricSpec {
        MetricSpec {
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
            grass: false,
        }
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
            // Quadric metrics at their default (Evans 3x3) keep the plain name.
            if !(metric(self.kind).plain_at_one_cell() && r == Length::Cells(1)) {
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
        if self
            .def()
            .params
            .iter()
            .any(|p| p.kind == ParamKind::SlopeUnits)
            && self.units == SlopeUnits::Percent
        {
            s.push_str("_pct");
        }
        // Non-default named values.
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
        if let Some(a) = self.azimuth.filter(|&a| a != 0.0) {
            s.push_str(&format!("_a{a}"));
        }
        if self.grass {
            s.push_str("_grass");
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

    pub(crate) fn set(&mut self, p: &ParamDef, value: &str) -> std::result::Result<(), String> {
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
            ParamKind::Value => match super::visibility::parse_value(p.name, value)? {
                Some(v) => {
                    self.values.insert(p.name.to_string(), v);
                }
                None => {
                    self.values.remove(p.name);
                }
            },
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
            ParamKind::Rule => {
                self.grass = match value.trim() {
                    "paper" => false,
                    "grass" => true,
                    _ => return Err(format!("'{value}' is not paper or grass")),
                }
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
                "unknown metric '{name}'{}; known metrics: {}",
                did_you_mean(name),
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
    /// Halo in cells the metric needs ([`super::Metric::halo`]).
    pub fn halo(&self) -> usize {
        metric(self.spec.kind).halo(self)
    }
}

/// ` (did you mean 'x'?)` for the metric names nearest `name` (Damerau–
/// Levenshtein distance at most 2 or a third of the name), or nothing.
fn did_you_mean(name: &str) -> String {
    let limit = (name.chars().count() / 3).max(2);
    let mut near: Vec<(usize, &str)> = METRICS
        .iter()
        .map(|d| (strsim::damerau_levenshtein(name, d.name), d.name))
        .filter(|&(k, _)| k <= limit)
        .collect();
    near.sort();
    match near.as_slice() {
        [] => String::new(),
        [(_, a)] => format!(" (did you mean '{a}'?)"),
        [(_, a), (_, b), ..] => format!(" (did you mean '{a}' or '{b}'?)"),
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
            let mut r = Resolved {
                spec: s.clone(),
                radius_cells,
                radius_m,
                radius2_cells,
            };
            metric(s.kind).bind(&mut r, info)?;
            Ok(r)
        })
        .collect()
}
