//! The parameters of the tectonic-folds source ([`TectonicParams`]), their
//! defaults and checks.

use super::super::noise::Fbm;
use crate::error::Error;
use crate::error::Result;
use serde::Deserialize;
use serde::Serialize;

/// Parameters of the tectonic pipeline (lengths in output cells, heights in
/// metres, slopes in metres per metre). As keys (serde) the fields are
/// kebab-case and each missing one takes its default; the fold noise, the
/// peak slope gain and the sea depth are no keys (a caller sets them).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields, default)]
pub struct TectonicParams {
    /// The fold noise (seed, octaves, wavelength...; `base` and `amplitude`
    /// are not used: the peaks set the heights).
    #[serde(skip)]
    pub fbm: Fbm,
    /// Merge threshold on the dot product of normalised velocities (-1..1).
    pub t1: f64,
    /// Merge threshold on the area ratio smaller/larger (0..1).
    pub t2: f64,
    /// Gaussian σ of the velocity-map blur (cells).
    pub blur: f64,
    /// Warp strength: the noise is sampled at p + strength · V(p).
    pub fold_strength: f64,
    /// Height of peaks without an `elevation` (m).
    pub relief: f64,
    /// Attenuation radius R of the folds around peaks (cells).
    pub peak_radius: f64,
    /// Share of the noise in the folds (0 = smooth bumps, 1 = pure noise).
    pub noise_share: f64,
    /// Slope along rivers in the watershed map.
    pub river_slope: f64,
    /// Slope away from rivers in the watershed map.
    pub hill_slope: f64,
    /// Slopes are multiplied by 1 + gain · a(d) (steeper near peaks).
    #[serde(skip)]
    pub peak_slope_gain: f64,
    /// Distance to a river (cells) beyond which the folds apply fully.
    pub river_width: f64,
    /// Depth of the open sea in the watershed map (m).
    #[serde(skip)]
    pub sea_depth: f64,
    /// Longest side of the coarse grid for plates, velocity and watershed map.
    pub coarse: usize,
}

impl Default for TectonicParams {
    fn default() -> Self {
        TectonicParams {
            fbm: Fbm {
                seed: 42,
                octaves: 8,
                wavelength: 256.0,
                warp: 20.0,
                ..Fbm::default()
            },
            t1: 0.8,
            t2: 0.25,
            blur: 24.0,
            fold_strength: 1.0,
            relief: 2000.0,
            peak_radius: 120.0,
            noise_share: 0.6,
            river_slope: 0.003,
            hill_slope: 0.03,
            peak_slope_gain: 2.0,
            river_width: 40.0,
            sea_depth: 60.0,
            coarse: 512,
        }
    }
}

impl TectonicParams {
    /// Check ranges.
    pub fn validate(&self) -> Result<()> {
        self.fbm.validate()?;
        let pos = |v: f64| v.is_finite() && v > 0.0;
        let nonneg = |v: f64| v.is_finite() && v >= 0.0;
        if !(self.t1.is_finite() && (-1.0..=1.0).contains(&self.t1)) {
            return Err(Error::invalid("tectonic t1 must be in -1..1"));
        }
        if !(self.t2.is_finite() && (0.0..=1.0).contains(&self.t2)) {
            return Err(Error::invalid("tectonic t2 must be in 0..1"));
        }
        if !(nonneg(self.blur) && self.blur <= 1e5) {
            return Err(Error::invalid("tectonic blur must be 0..100000 cells"));
        }
        if !(self.fold_strength.is_finite() && self.fold_strength.abs() <= 1e4) {
            return Err(Error::invalid(
                "tectonic fold strength must be a finite number up to 1e4",
            ));
        }
        if !(nonneg(self.relief) && self.relief < 1e5) {
            return Err(Error::invalid("tectonic relief must be 0..100000 m"));
        }
        if !(pos(self.peak_radius) && pos(self.river_width)) {
            return Err(Error::invalid(
                "tectonic peak radius and river width must be positive",
            ));
        }
        if !(nonneg(self.noise_share) && self.noise_share <= 1.0) {
            return Err(Error::invalid("tectonic noise share must be in 0..1"));
        }
        if !(nonneg(self.river_slope) && nonneg(self.hill_slope) && nonneg(self.peak_slope_gain))
            || self.river_slope > 10.0
            || self.hill_slope > 10.0
        {
            return Err(Error::invalid(
                "tectonic slopes must be in 0..10 and the gain >= 0",
            ));
        }
        if !(nonneg(self.sea_depth) && self.sea_depth < 1e5) {
            return Err(Error::invalid("tectonic sea depth must be 0..100000 m"));
        }
        if !(8..=8192).contains(&self.coarse) {
            return Err(Error::invalid("tectonic coarse grid must be 8..8192 cells"));
        }
        Ok(())
    }
}
