//! Synthesis profile of a region: the target distributions of orometric
//! synthesis (Argudo, Galin, Peytavie, Paris, Gain & Guérin 2019,
//! "Orometry-based terrain analysis and synthesis", ACM TOG 38(6), §4–5):
//! peak elevation, prominence, dominance, isolation distance and direction,
//! key-saddle distance and direction, and peak density.
//!
//! Unlike [`crate::oro::stats::OroProfile`] (features pooled over disks, each
//! peak counted once per disk it lies in, open-ended last bins), every peak of
//! the domain counts once here and every bin is finite, so the histograms can
//! be sampled. Profiles are JSON and editable ([`SynthProfile::scale_prominence`]
//! is "peaks twice as prominent").

use crate::error::{Error, Result};
use crate::oro::stats::{bin_of, sector};
use crate::oro::{EdgeConvention, IsolationIndex, PeakOptions};
use crate::raster::{GeoRef, Grid};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

/// A histogram with finite edges; `p` sums to 1 (all zero when empty).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Hist {
    pub edges: Vec<f64>,
    pub p: Vec<f64>,
    /// Optional 101 quantiles (0 %, 1 %, ..., 100 %) of the values: sampling
    /// interpolates them when present (finer than the bins), else the bins.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub q: Vec<f64>,
}

impl Hist {
    /// Histogram of `values` over `edges` (values outside go to the end bins).
    pub fn of_values(edges: &[f64], values: &[f64]) -> Hist {
        let mut c = vec![0.0; edges.len().saturating_sub(1)];
        for &v in values {
            if let Some(b) = bin_of(edges, v) {
                c[b] += 1.0;
            }
        }
        let n: f64 = c.iter().sum();
        if n > 0.0 {
            c.iter_mut().for_each(|x| *x /= n);
        }
        Hist {
            edges: edges.to_vec(),
            p: c,
            q: Vec::new(),
        }
    }

    /// [`Hist::of_values`] plus the 101 quantiles of `values`.
    pub fn with_quantiles(edges: &[f64], values: &[f64]) -> Hist {
        let mut h = Hist::of_values(edges, values);
        let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
        v.sort_by(|a, b| a.total_cmp(b));
        if !v.is_empty() {
            let n = v.len() - 1;
            h.q = (0..=100)
                .map(|k| {
                    let f = k as f64 / 100.0 * n as f64;
                    let i = (f.floor() as usize).min(n);
                    let j = (i + 1).min(n);
                    v[i] + (f - i as f64) * (v[j] - v[i])
                })
                .collect();
        }
        h
    }

    /// Check edges (finite, strictly increasing, one more than bins) and
    /// probabilities (finite, ≥ 0, not all zero). `what` names the histogram.
    pub fn check(&self, what: &str) -> Result<()> {
        let ok_edges = self.edges.len() >= 2
            && self.edges.len() == self.p.len() + 1
            && self.edges.iter().all(|e| e.is_finite())
            && self.edges.windows(2).all(|w| w[1] > w[0]);
        if !ok_edges {
            return Err(Error::invalid(format!(
                "profile histogram '{what}': edges must be finite, increasing and one more than the bins"
            )));
        }
        if self.p.iter().any(|v| !(v.is_finite() && *v >= 0.0)) {
            return Err(Error::invalid(format!(
                "profile histogram '{what}': probabilities must be finite and ≥ 0"
            )));
        }
        if !self.q.is_empty()
            && (self.q.len() < 2
                || self.q.iter().any(|v| !v.is_finite())
                || self.q.windows(2).any(|w| w[1] < w[0]))
        {
            return Err(Error::invalid(format!(
                "profile histogram '{what}': quantiles must be finite and non-decreasing"
            )));
        }
        if self.p.iter().sum::<f64>() <= 0.0 {
            return Err(Error::invalid(format!(
                "profile histogram '{what}' is empty (all bins 0): the region had no peak with this value; give a profile made from a DEM with peaks"
            )));
        }
        Ok(())
    }

    /// Value of the inverse CDF at `u` in [0, 1): interpolated between the
    /// stored quantiles if any, else uniform inside a bin.
    pub fn quantile(&self, u: f64) -> f64 {
        if self.q.len() >= 2 {
            let f = u.clamp(0.0, 1.0) * (self.q.len() - 1) as f64;
            let i = (f.floor() as usize).min(self.q.len() - 2);
            return self.q[i] + (f - i as f64) * (self.q[i + 1] - self.q[i]);
        }
        let total: f64 = self.p.iter().sum();
        let mut acc = 0.0;
        let target = u.clamp(0.0, 1.0) * total;
        for (i, &pi) in self.p.iter().enumerate() {
            if pi > 0.0 && (acc + pi >= target || i + 1 == self.p.len()) {
                let f = ((target - acc) / pi).clamp(0.0, 1.0);
                return self.edges[i] + f * (self.edges[i + 1] - self.edges[i]);
            }
            acc += pi;
        }
        // All mass before: the last non-empty bin's top.
        let last = self.p.iter().rposition(|&v| v > 0.0).unwrap_or(0);
        self.edges[last + 1]
    }

    /// `n` stratified samples: the quantiles at (k + 0.5)/n, ascending. Their
    /// histogram equals this one up to rounding (1/n per bin).
    pub fn stratified(&self, n: usize) -> Vec<f64> {
        (0..n)
            .map(|k| self.quantile((k as f64 + 0.5) / n as f64))
            .collect()
    }

    /// Probability density relative to the densest bin, in [0, 1] (0 outside).
    pub fn relative_density(&self, v: f64) -> f64 {
        let dens = |i: usize| self.p[i] / (self.edges[i + 1] - self.edges[i]);
        let max = (0..self.p.len()).map(dens).fold(0.0, f64::max);
        if max <= 0.0 || !v.is_finite() {
            return 0.0;
        }
        if v < self.edges[0] || v > self.edges[self.edges.len() - 1] {
            return 0.0;
        }
        bin_of(&self.edges, v).map(|b| dens(b) / max).unwrap_or(0.0)
    }

    /// Total variation distance ½ Σ|p − q| to `values` binned on these edges.
    pub fn error_against(&self, values: &[f64]) -> f64 {
        let q = Hist::of_values(&self.edges, values);
        0.5 * self
            .p
            .iter()
            .zip(&q.p)
            .map(|(a, b)| (a - b).abs())
            .sum::<f64>()
    }

    fn scale(&mut self, f: f64) {
        self.edges.iter_mut().for_each(|e| *e *= f);
        self.q.iter_mut().for_each(|e| *e *= f);
    }
}

/// Per-peak orometric values of a DEM (peaks with prominence ≥ the threshold).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PeakSamples {
    pub elevation: Vec<f64>,
    pub prominence: Vec<f64>,
    pub dominance: Vec<f64>,
    pub isolation_km: Vec<f64>,
    /// Sector 0..8 (N, NE, ..., NW) as f64.
    pub isolation_dir: Vec<f64>,
    pub saddle_km: Vec<f64>,
    pub saddle_dir: Vec<f64>,
    /// Area of the valid cells, km².
    pub area_km2: f64,
}

impl PeakSamples {
    /// Peaks of `dem` (NaN = nodata) with prominence ≥ `min_prominence`,
    /// sea-level edge convention (as `orogen peaks`), and their values.
    pub fn of_dem(dem: &Grid<f32>, georef: &GeoRef, min_prominence: f64) -> Result<PeakSamples> {
        let opts = PeakOptions {
            min_prominence,
            convention: EdgeConvention::SeaLevel,
            isolation: true,
        };
        let list = crate::oro::peaks(dem, georef, &opts)?;
        let tree = &list.tree;
        let geo = IsolationIndex::new(dem, georef);
        let mut s = PeakSamples::default();
        for p in &tree.peaks {
            s.elevation.push(p.elevation as f64);
            s.prominence.push(p.prominence);
            if let Some(d) = p.dominance() {
                s.dominance.push(d);
            }
            if let Some(i) = p.isolation {
                s.isolation_km.push(i.distance_m / 1000.0);
                if let Some(sec) = sector(i.bearing_deg) {
                    s.isolation_dir.push(sec);
                }
            }
            if let Some(k) = p.key_saddle.and_then(|k| tree.saddles.get(k)) {
                let (d, b) = geo.distance_bearing(
                    p.col as usize,
                    p.row as usize,
                    k.col as usize,
                    k.row as usize,
                );
                s.saddle_km.push(d / 1000.0);
                if let Some(sec) = sector(b) {
                    s.saddle_dir.push(sec);
                }
            }
        }
        for y in 0..dem.height() {
            let (sx, sy) = georef.cell_size_m(y as i64);
            let n = dem.row(y).iter().filter(|z| z.is_finite()).count();
            s.area_km2 += n as f64 * sx * sy / 1e6;
        }
        Ok(s)
    }
}

/// Target distributions of orometric synthesis (JSON, editable).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SynthProfile {
    /// Always "orogen-synthprofile".
    pub format: String,
    pub version: u32,
    pub label: String,
    pub sources: Vec<String>,
    /// Peaks counted have prominence ≥ this (m).
    pub min_prominence: f64,
    /// Peaks per km² (with prominence ≥ `min_prominence`).
    pub peak_density_per_km2: f64,
    /// Peak elevations, m (20 bins between the lowest and highest peak).
    pub elevation: Hist,
    /// Prominence, m (from `min_prominence` to the largest).
    pub prominence: Hist,
    /// Prominence / elevation.
    pub dominance: Hist,
    /// Distance to the nearest higher ground, km.
    pub isolation_km: Hist,
    /// Direction of the nearest higher ground, 8 sectors from north clockwise.
    pub isolation_dir: Hist,
    /// Distance to the key saddle, km.
    pub saddle_km: Hist,
    /// Direction of the key saddle, 8 sectors.
    pub saddle_dir: Hist,
}

const DOM_EDGES: [f64; 11] = [0.0, 0.02, 0.05, 0.1, 0.15, 0.2, 0.3, 0.4, 0.6, 0.8, 1.0];
const SECTOR_EDGES: [f64; 9] = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0];
const PROM_EDGES: [f64; 13] = [
    0.0, 50.0, 100.0, 150.0, 200.0, 300.0, 400.0, 600.0, 800.0, 1000.0, 1500.0, 2000.0, 3000.0,
];
const DIST_EDGES: [f64; 11] = [0.0, 0.5, 1.0, 2.0, 3.0, 5.0, 7.5, 10.0, 15.0, 20.0, 30.0];

/// Edges `base` cut to (lo, hi]: `lo`, the base edges strictly between, `hi`.
fn edges_between(base: &[f64], lo: f64, hi: f64) -> Vec<f64> {
    let hi = hi.max(lo + 1e-6);
    let mut e = vec![lo];
    e.extend(base.iter().copied().filter(|&v| v > lo && v < hi));
    e.push(hi);
    e
}

/// Edges for distances: the standard ones up to the largest value, finer
/// (10 equal bins) when all values are short.
fn distance_edges(values: &[f64]) -> Vec<f64> {
    let max = values.iter().copied().fold(0.0, f64::max).max(1e-3);
    if max < 2.0 {
        (0..=10).map(|i| max * i as f64 / 10.0).collect()
    } else {
        edges_between(&DIST_EDGES, 0.0, max * (1.0 + 1e-9))
    }
}

impl SynthProfile {
    /// Profile of the peaks of one DEM with prominence ≥ `min_prominence`.
    pub fn from_dem(
        dem: &Grid<f32>,
        georef: &GeoRef,
        min_prominence: f64,
        label: &str,
        source: &str,
    ) -> Result<SynthProfile> {
        if !(min_prominence.is_finite() && min_prominence > 0.0) {
            return Err(Error::invalid(format!(
                "profile: the minimum prominence must be a positive number of metres, got {min_prominence}"
            )));
        }
        let s = PeakSamples::of_dem(dem, georef, min_prominence)?;
        SynthProfile::from_samples(&[s], min_prominence, label, vec![source.to_string()])
    }

    /// Profile pooling the peaks of several DEMs (of one region type).
    pub fn from_samples(
        samples: &[PeakSamples],
        min_prominence: f64,
        label: &str,
        sources: Vec<String>,
    ) -> Result<SynthProfile> {
        let cat = |f: fn(&PeakSamples) -> &Vec<f64>| -> Vec<f64> {
            samples.iter().flat_map(|s| f(s).iter().copied()).collect()
        };
        let elev = cat(|s| &s.elevation);
        let prom = cat(|s| &s.prominence);
        let area: f64 = samples.iter().map(|s| s.area_km2).sum();
        if elev.len() < 2 || area <= 0.0 {
            return Err(Error::invalid(format!(
                "profile '{label}': the DEM has {} peak(s) with prominence ≥ {min_prominence} m; at least 2 are needed (give a lower --min-prominence or a larger DEM)",
                elev.len()
            )));
        }
        let (emin, emax) = elev
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                (a.min(v), b.max(v))
            });
        let emax = emax.max(emin + 1.0);
        let e_edges: Vec<f64> = (0..=20)
            .map(|i| emin + (emax - emin) * i as f64 / 20.0)
            .collect();
        let pmax = prom.iter().copied().fold(min_prominence, f64::max);
        let p_edges = edges_between(&PROM_EDGES, min_prominence, pmax * (1.0 + 1e-9));
        let iso = cat(|s| &s.isolation_km);
        let sad = cat(|s| &s.saddle_km);
        let prof = SynthProfile {
            format: "orogen-synthprofile".into(),
            version: 1,
            label: label.to_string(),
            sources,
            min_prominence,
            peak_density_per_km2: elev.len() as f64 / area,
            elevation: Hist::with_quantiles(&e_edges, &elev),
            prominence: Hist::with_quantiles(&p_edges, &prom),
            dominance: Hist::with_quantiles(&DOM_EDGES, &cat(|s| &s.dominance)),
            isolation_km: Hist::with_quantiles(&distance_edges(&iso), &iso),
            isolation_dir: Hist::of_values(&SECTOR_EDGES, &cat(|s| &s.isolation_dir)),
            saddle_km: Hist::with_quantiles(&distance_edges(&sad), &sad),
            saddle_dir: Hist::of_values(&SECTOR_EDGES, &cat(|s| &s.saddle_dir)),
        };
        prof.validate()?;
        Ok(prof)
    }

    /// Check every histogram and figure; errors say what to fix.
    pub fn validate(&self) -> Result<()> {
        if self.format != "orogen-synthprofile" || self.version != 1 {
            return Err(Error::invalid(format!(
                "profile format {:?} version {}; expected orogen-synthprofile 1 (make one with `orogen synth profile`)",
                self.format, self.version
            )));
        }
        if !(self.min_prominence.is_finite() && self.min_prominence > 0.0) {
            return Err(Error::invalid(
                "profile: min_prominence must be a positive number of metres",
            ));
        }
        if !(self.peak_density_per_km2.is_finite() && self.peak_density_per_km2 > 0.0) {
            return Err(Error::invalid(
                "profile: peak_density_per_km2 must be a positive number",
            ));
        }
        for (name, h) in self.histograms() {
            h.check(name)?;
        }
        if self.elevation.edges[0] < 0.0 {
            return Err(Error::invalid(
                "profile: peak elevations below 0 m are not supported (shift the elevation edges)",
            ));
        }
        Ok(())
    }

    /// The histograms by name.
    pub fn histograms(&self) -> [(&'static str, &Hist); 7] {
        [
            ("elevation", &self.elevation),
            ("prominence", &self.prominence),
            ("dominance", &self.dominance),
            ("isolation_km", &self.isolation_km),
            ("isolation_dir", &self.isolation_dir),
            ("saddle_km", &self.saddle_km),
            ("saddle_dir", &self.saddle_dir),
        ]
    }

    /// Edit: multiply prominences by `f` ("peaks twice as prominent": 2).
    /// Dominance is scaled alike (capped at 1).
    pub fn scale_prominence(&mut self, f: f64) -> Result<()> {
        if !(f.is_finite() && f > 0.0) {
            return Err(Error::invalid("prominence scale must be a positive number"));
        }
        self.prominence.scale(f);
        self.min_prominence *= f;
        // Dominance bins scaled, then the part beyond 1 folded into the last bin.
        let mut v = Vec::new();
        let samples = self.dominance.stratified(1000);
        for d in samples {
            v.push((d * f).min(1.0));
        }
        self.dominance = Hist::with_quantiles(&DOM_EDGES, &v);
        Ok(())
    }

    /// Edit: multiply peak density by `f` (isolation and saddle distances
    /// shrink by √f, as peak spacing does).
    pub fn scale_density(&mut self, f: f64) -> Result<()> {
        if !(f.is_finite() && f > 0.0) {
            return Err(Error::invalid("density scale must be a positive number"));
        }
        self.peak_density_per_km2 *= f;
        self.isolation_km.scale(1.0 / f.sqrt());
        self.saddle_km.scale(1.0 / f.sqrt());
        Ok(())
    }

    /// Histogram errors (total variation distance, 0..1) of measured peak
    /// values against this profile, per feature, plus `peak_density`
    /// (relative difference).
    pub fn errors(&self, s: &PeakSamples) -> BTreeMap<String, f64> {
        let mut out = BTreeMap::new();
        out.insert(
            "elevation".into(),
            self.elevation.error_against(&s.elevation),
        );
        out.insert(
            "prominence".into(),
            self.prominence.error_against(&s.prominence),
        );
        out.insert(
            "dominance".into(),
            self.dominance.error_against(&s.dominance),
        );
        out.insert(
            "isolation_km".into(),
            self.isolation_km.error_against(&s.isolation_km),
        );
        out.insert(
            "isolation_dir".into(),
            self.isolation_dir.error_against(&s.isolation_dir),
        );
        out.insert(
            "saddle_km".into(),
            self.saddle_km.error_against(&s.saddle_km),
        );
        out.insert(
            "saddle_dir".into(),
            self.saddle_dir.error_against(&s.saddle_dir),
        );
        let d = if s.area_km2 > 0.0 {
            s.elevation.len() as f64 / s.area_km2
        } else {
            0.0
        };
        let m = d.max(self.peak_density_per_km2);
        out.insert(
            "peak_density".into(),
            if m > 0.0 {
                (d - self.peak_density_per_km2).abs() / m
            } else {
                0.0
            },
        );
        out
    }

    /// Save as pretty JSON.
    pub fn save(&self, path: &Path) -> Result<()> {
        let text = serde_json::to_string_pretty(self)
            .map_err(|e| Error::invalid(format!("profile does not serialise: {e}")))?;
        crate::io::atomic::write_file_atomic(path, text.as_bytes())
    }

    /// Load and validate a profile (size-checked before reading).
    pub fn load(path: &Path) -> Result<SynthProfile> {
        let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
        if meta.len() > 16 << 20 {
            return Err(Error::too_large(
                path,
                "a synthesis profile is a few KB; this file is over 16 MiB",
            ));
        }
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        let p: SynthProfile = serde_json::from_str(&text).map_err(|e| {
            Error::corrupt(
                path,
                format!("not a synthesis profile (make one with `orogen synth profile`): {e}"),
            )
        })?;
        p.validate()
            .map_err(|e| Error::corrupt(path, e.to_string()))?;
        Ok(p)
    }
}
