//! A synthetic divide tree as data: its checks, edges and prominences, peak
//! deletion, and JSON / GeoJSON reading and writing.

use super::super::assign::prominences;
use super::options::MAX_PEAKS;
use super::options::MAX_SIDE;
use super::SynthTree;
use crate::error::Error;
use crate::error::Result;
use crate::raster::UnionFind;
use std::path::Path;

impl SynthTree {
    /// Total planar length (m) of the ridges: each saddle joined straight to
    /// its two peaks (the bound the terrain models put on their refinement).
    pub fn ridge_length(&self) -> f64 {
        self.saddles
            .iter()
            .map(|s| {
                let a = &self.peaks[s.peaks[0]];
                let b = &self.peaks[s.peaks[1]];
                (a.x - s.x).hypot(a.y - s.y) + (b.x - s.x).hypot(b.y - s.y)
            })
            .sum()
    }

    /// Check an edited or loaded tree: sizes, finite values inside the
    /// domain, n − 1 saddles forming one tree over the peaks, each saddle
    /// between 0 and the lower of its two peaks. Errors name the element.
    pub fn validate(&self) -> Result<()> {
        if self.format != "orogen-synthtree" || self.version != 1 {
            return Err(Error::invalid(format!(
                "divide tree format {:?} version {}; expected orogen-synthtree 1 (made by `orogen synth divide-tree`)",
                self.format, self.version
            )));
        }
        if self.width == 0 || self.height == 0 || self.width > MAX_SIDE || self.height > MAX_SIDE {
            return Err(Error::invalid("divide tree: domain size out of range"));
        }
        if !(self.cell.is_finite() && self.cell > 0.0) {
            return Err(Error::invalid(
                "divide tree: the cell size must be positive",
            ));
        }
        if self.peaks.is_empty() {
            return Err(Error::invalid("divide tree: it has no peak"));
        }
        if self.peaks.len() > MAX_PEAKS {
            return Err(Error::invalid("divide tree: too many peaks"));
        }
        let (wm, hm) = (
            self.width as f64 * self.cell,
            self.height as f64 * self.cell,
        );
        let inside = |x: f64, y: f64| {
            x.is_finite() && y.is_finite() && x >= 0.0 && y >= 0.0 && x < wm && y < hm
        };
        for (i, p) in self.peaks.iter().enumerate() {
            if !inside(p.x, p.y) || !p.elevation.is_finite() || p.elevation <= 0.0 {
                return Err(Error::invalid(format!(
                    "divide tree: peak {i} at ({}, {}) m, {} m is outside the {wm} x {hm} m domain or not above 0 m",
                    p.x, p.y, p.elevation
                )));
            }
        }
        if self.saddles.len() + 1 != self.peaks.len() {
            return Err(Error::invalid(format!(
                "divide tree: {} peaks need {} saddles (one per ridge), found {}: the edit disconnected the tree or added a loop",
                self.peaks.len(),
                self.peaks.len() - 1,
                self.saddles.len()
            )));
        }
        let mut uf = UnionFind::<usize>::new(self.peaks.len());
        for (k, s) in self.saddles.iter().enumerate() {
            let [a, b] = s.peaks;
            if a >= self.peaks.len() || b >= self.peaks.len() || a == b {
                return Err(Error::invalid(format!(
                    "divide tree: saddle {k} joins peaks {a} and {b}; it needs two different existing peaks"
                )));
            }
            if !inside(s.x, s.y) || !s.elevation.is_finite() {
                return Err(Error::invalid(format!(
                    "divide tree: saddle {k} lies outside the domain or has no elevation"
                )));
            }
            let lo = self.peaks[a].elevation.min(self.peaks[b].elevation);
            if s.elevation < 0.0 || s.elevation >= lo {
                return Err(Error::invalid(format!(
                    "divide tree: saddle {k} at {} m must lie between 0 m and its lower peak ({lo} m)",
                    s.elevation
                )));
            }
            if !uf.join(a, b) {
                return Err(Error::invalid(format!(
                    "divide tree: saddle {k} closes a loop (peaks {a} and {b} are already joined); the edit disconnected the tree elsewhere"
                )));
            }
        }
        Ok(())
    }

    /// Ridges as (peak, peak) pairs, saddle by saddle.
    pub fn edges(&self) -> Vec<(usize, usize)> {
        self.saddles
            .iter()
            .map(|s| (s.peaks[0], s.peaks[1]))
            .collect()
    }

    /// Prominence of every peak (the highest: its elevation).
    pub fn prominences(&self) -> Vec<f64> {
        let h: Vec<f64> = self.peaks.iter().map(|p| p.elevation).collect();
        let hs: Vec<f64> = self.saddles.iter().map(|s| s.elevation).collect();
        prominences(&h, &self.edges(), &hs)
    }

    /// Edit: delete peak `i` and reconnect its ridge neighbours to the
    /// highest of them through the saddles they had (the deleted peak's
    /// saddles are kept, moved to the new ridges' ends). Saddles above a new
    /// ridge's lower end are lowered just below it.
    pub fn delete_peak(&mut self, i: usize) -> Result<()> {
        if i >= self.peaks.len() || self.peaks.len() < 2 {
            return Err(Error::invalid(format!(
                "delete peak {i}: no such peak, or it is the only one"
            )));
        }
        let nbrs: Vec<(usize, usize)> = self
            .saddles
            .iter()
            .enumerate()
            .filter_map(|(k, s)| {
                if s.peaks[0] == i {
                    Some((k, s.peaks[1]))
                } else if s.peaks[1] == i {
                    Some((k, s.peaks[0]))
                } else {
                    None
                }
            })
            .collect();
        let Some(&(k0, hub)) = nbrs.iter().max_by(|a, b| {
            self.peaks[a.1]
                .elevation
                .total_cmp(&self.peaks[b.1].elevation)
                .then(b.1.cmp(&a.1))
        }) else {
            return Err(Error::invalid(format!("delete peak {i}: it has no ridge")));
        };
        for &(k, nb) in &nbrs {
            if k != k0 {
                let lo = self.peaks[nb].elevation.min(self.peaks[hub].elevation);
                let s = &mut self.saddles[k];
                s.peaks = [nb, hub];
                s.elevation = s.elevation.min(lo - 1.0).max(0.0);
            }
        }
        self.saddles.remove(k0);
        self.peaks.remove(i);
        for s in &mut self.saddles {
            for p in &mut s.peaks {
                if *p > i {
                    *p -= 1;
                }
            }
        }
        self.validate()
    }

    /// JSON text (pretty).
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).unwrap_or_default()
    }

    /// Save as JSON.
    pub fn save(&self, path: &Path) -> Result<()> {
        crate::io::atomic::write_file_atomic(path, self.to_json().as_bytes())
    }

    /// Load and validate (size-checked before reading).
    pub fn load(path: &Path) -> Result<SynthTree> {
        let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
        if meta.len() > 1 << 30 {
            return Err(Error::too_large(path, "a divide tree file over 1 GiB"));
        }
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        let t: SynthTree = serde_json::from_str(&text).map_err(|e| {
            Error::corrupt(
                path,
                format!("not a divide tree written by `orogen synth divide-tree`: {e}"),
            )
        })?;
        t.validate()
            .map_err(|e| Error::corrupt(path, e.to_string()))?;
        Ok(t)
    }

    /// GeoJSON (local metric CRS, y up as in the rasters orogen writes):
    /// peaks and saddles as points, ridges as two-segment lines.
    pub fn to_geojson(&self) -> String {
        let hm = self.height as f64 * self.cell;
        let prom = self.prominences();
        let mut f = Vec::new();
        for (i, p) in self.peaks.iter().enumerate() {
            f.push(format!(
                r#"{{"type":"Feature","geometry":{{"type":"Point","coordinates":[{},{}]}},"properties":{{"kind":"peak","id":{i},"elevation":{},"prominence":{},"fixed":{}}}}}"#,
                p.x, hm - p.y, p.elevation, prom[i], p.fixed
            ));
        }
        for (k, s) in self.saddles.iter().enumerate() {
            f.push(format!(
                r#"{{"type":"Feature","geometry":{{"type":"Point","coordinates":[{},{}]}},"properties":{{"kind":"saddle","id":{k},"elevation":{},"peaks":[{},{}]}}}}"#,
                s.x, hm - s.y, s.elevation, s.peaks[0], s.peaks[1]
            ));
            let (a, b) = (&self.peaks[s.peaks[0]], &self.peaks[s.peaks[1]]);
            f.push(format!(
                r#"{{"type":"Feature","geometry":{{"type":"LineString","coordinates":[[{},{}],[{},{}],[{},{}]]}},"properties":{{"kind":"ridge","saddle":{k}}}}}"#,
                a.x, hm - a.y, s.x, hm - s.y, b.x, hm - b.y
            ));
        }
        format!(
            "{{\"type\":\"FeatureCollection\",\"features\":[\n{}\n]}}\n",
            f.join(",\n")
        )
    }
}
