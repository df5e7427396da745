//! Type map C_T (Argudo, Galin, Peytavie, Paris, Gain & Guérin 2019,
//! "Orometry-based terrain analysis and synthesis", ACM TOG 38(6), §5 and
//! §7): a raster of region labels stretched over the synthesis domain, each
//! label with its own [`SynthProfile`]. A peak placed in a region takes its
//! elevation, isolation and prominence/dominance targets from that region's
//! profile, and each region gets its profile's density × its area.

use super::profile::SynthProfile;
use crate::error::{Error, Result};
use crate::raster::Grid;

/// Largest number of labelled regions.
pub const MAX_REGIONS: usize = 64;

/// Region labels (integers stored as f32; NaN = no peaks there) and the
/// profile of each listed label. Labels not listed use the synthesis's
/// main profile (region 0).
#[derive(Debug, Clone)]
pub struct TypeMap {
    labels: Grid<f32>,
    /// (label, profile); region k + 1 of the synthesis is `regions[k]`.
    pub regions: Vec<(i64, SynthProfile)>,
    /// Region index of every map cell (0: main profile; u8::MAX: none).
    cell_region: Vec<u8>,
}

impl TypeMap {
    /// Check the labels (integers or nodata) and the profiles.
    pub fn new(labels: Grid<f32>, regions: Vec<(i64, SynthProfile)>) -> Result<TypeMap> {
        if regions.len() > MAX_REGIONS {
            return Err(Error::invalid(format!(
                "the type map lists {} region profiles; at most {MAX_REGIONS}",
                regions.len()
            )));
        }
        for (k, (l, p)) in regions.iter().enumerate() {
            p.validate()
                .map_err(|e| Error::invalid(format!("profile of type-map label {l}: {e}")))?;
            if regions[..k].iter().any(|(m, _)| m == l) {
                return Err(Error::invalid(format!(
                    "type-map label {l} is given two profiles"
                )));
            }
        }
        let mut cell_region = Vec::with_capacity(labels.data().len());
        for &v in labels.data() {
            if !v.is_finite() {
                cell_region.push(u8::MAX);
                continue;
            }
            if v.fract() != 0.0 {
                return Err(Error::invalid(format!(
                    "the type map holds {v}: labels must be integers (region numbers)"
                )));
            }
            let l = v as i64;
            let r = regions
                .iter()
                .position(|(m, _)| *m == l)
                .map(|k| k + 1)
                .unwrap_or(0);
            cell_region.push(r as u8);
        }
        if cell_region.iter().all(|&r| r == u8::MAX) {
            return Err(Error::invalid(
                "the type map is nodata everywhere: no region may hold a peak",
            ));
        }
        Ok(TypeMap {
            labels,
            regions,
            cell_region,
        })
    }

    /// The label grid.
    pub fn labels(&self) -> &Grid<f32> {
        &self.labels
    }

    /// Region (0 = main profile, k + 1 = `regions[k]`) at the domain
    /// fraction (fx, fy) ∈ [0, 1)² (x east, y down), nearest map cell; None
    /// on nodata.
    pub fn region_at(&self, fx: f64, fy: f64) -> Option<usize> {
        let (w, h) = (self.labels.width(), self.labels.height());
        if !(fx.is_finite() && fy.is_finite()) {
            return None;
        }
        let c = ((fx * w as f64).max(0.0) as usize).min(w - 1);
        let r = ((fy * h as f64).max(0.0) as usize).min(h - 1);
        match self.cell_region[r * w + c] {
            u8::MAX => None,
            k => Some(k as usize),
        }
    }

    /// Fraction of the map's cells in each region (index as
    /// [`TypeMap::region_at`]; nodata cells are in none).
    pub fn fractions(&self) -> Vec<f64> {
        let mut f = vec![0.0; self.regions.len() + 1];
        for &r in &self.cell_region {
            if r != u8::MAX {
                f[r as usize] += 1.0;
            }
        }
        let n = self.cell_region.len() as f64;
        f.iter_mut().for_each(|v| *v /= n);
        f
    }
}
