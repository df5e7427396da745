//! Thermal erosion (talus slumping).
//!
//! Source: F.K. Musgrave, C.E. Kolb, R.S. Mace, "The Synthesis and Rendering
//! of Eroded Fractal Terrains", SIGGRAPH 1989, §3.1 (thermal weathering:
//! material moves to lower neighbours where the height difference exceeds
//! the talus threshold T, a fraction c of the excess per step, shared in
//! proportion to each neighbour's difference).
//!
//! Here, on the 8-neighbourhood with true distances `l_k` (metres), the
//! threshold is per direction, `T_k = tan(talus)·l_k`, and a neighbour's
//! excess is `e_k = (h − h_k) − T_k`. Where the largest excess is positive,
//! the cell sends `c·max e_k` in total, to each neighbour with `e_k > 0` in
//! proportion to `e_k`. With one receiver and `c = 1/2` the pair ends exactly
//! at the talus slope. Updates are simultaneous (Jacobi): phase 1 computes
//! every cell's eight outflows from the current heights, phase 2 applies
//! `h' = h − Σ out + Σ in`, so what leaves one cell enters another and mass
//! is conserved to round-off. Raster edge and nodata are walls. Radius 2.

use super::{check_cell, check_range, run_cell, valid, CellSize, LocalModel, Patch};
use crate::error::{Error, Result};
use serde::{Deserialize, Serialize};

use crate::raster::neighbours::OFFSETS;

/// Parameters of thermal erosion.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ThermalParams {
    /// Talus (angle of repose) in degrees, 0 < talus < 90.
    pub talus: f64,
    /// Fraction of the largest excess moved per step (0 < rate <= 0.5).
    pub rate: f64,
    /// Cell size in metres (default: from the raster's georeference).
    pub cell: Option<f64>,
}

impl Default for ThermalParams {
    fn default() -> Self {
        ThermalParams {
            talus: 35.0,
            rate: 0.5,
            cell: None,
        }
    }
}

impl ThermalParams {
    /// Check every parameter.
    pub fn validate(&self) -> Result<()> {
        if !(self.talus.is_finite() && self.talus > 0.0 && self.talus < 90.0) {
            return Err(Error::invalid(format!(
                "erosion parameter talus = {}°: the talus angle must be greater than 0 and less than 90 degrees",
                self.talus
            )));
        }
        check_range("rate", self.rate, 1e-9, 0.5, "")?;
        check_cell(self.cell)
    }
}

/// Thermal erosion ready to run.
#[derive(Debug, Clone)]
pub struct Thermal {
    pub params: ThermalParams,
    pub steps: u64,
    pub cell: CellSize,
    /// Threshold height difference per direction (m).
    thresh: [f64; 8],
}

impl Thermal {
    /// Validate and build (`params.cell` overrides `cell`).
    pub fn new(params: ThermalParams, steps: u64, cell: CellSize) -> Result<Self> {
        params.validate()?;
        let cell = run_cell(steps, params.cell, cell)?;
        let t = params.talus.to_radians().tan();
        let mut thresh = [0.0; 8];
        for (k, &(ox, oy)) in OFFSETS.iter().enumerate() {
            thresh[k] = t * (ox as f64 * cell.dx).hypot(oy as f64 * cell.dy);
        }
        Ok(Thermal {
            params,
            steps,
            cell,
            thresh,
        })
    }

    /// The threshold height difference towards neighbour `k` (m).
    pub fn threshold(&self, k: usize) -> f64 {
        self.thresh[k]
    }
}

impl LocalModel for Thermal {
    fn name(&self) -> &'static str {
        "thermal"
    }
    fn params_json(&self) -> serde_json::Value {
        super::model_json(self.name(), self.steps, self.cell, &self.params)
    }
    fn radius(&self) -> usize {
        2
    }
    fn substeps(&self) -> u64 {
        self.steps
    }

    fn substep(&self, p: &mut Patch, _n: u64) {
        let (w, hh) = (p.w as i64, p.h as i64);
        let mut scratch = std::mem::take(&mut p.scratch);
        if scratch.len() < 9 {
            scratch.resize_with(9, Vec::new);
        }
        for s in &mut scratch[..9] {
            s.resize(p.w * p.h, 0.0);
        }
        let h = &p.fields[0];
        let (outs, rest) = scratch.split_at_mut(8);
        let nh = &mut rest[0];
        // Phase 1: outflows.
        for y in 0..hh {
            for x in 0..w {
                let i = (y * w + x) as usize;
                let hi = h[i];
                let mut e = [f64::NEG_INFINITY; 8];
                let mut emax = 0.0f64;
                if valid(hi) {
                    for (k, &(ox, oy)) in OFFSETS.iter().enumerate() {
                        let (nx, ny) = (x + ox, y + oy);
                        if nx >= 0 && ny >= 0 && nx < w && ny < hh {
                            let hj = h[(ny * w + nx) as usize];
                            if valid(hj) {
                                e[k] = (hi - hj) - self.thresh[k];
                                emax = emax.max(e[k]);
                            }
                        }
                    }
                }
                if emax > 0.0 {
                    let mut esum = 0.0;
                    for &ek in &e {
                        if ek > 0.0 {
                            esum += ek;
                        }
                    }
                    let moved = self.params.rate * emax;
                    for k in 0..8 {
                        outs[k][i] = if e[k] > 0.0 {
                            moved * (e[k] / esum)
                        } else {
                            0.0
                        };
                    }
                } else {
                    for o in outs.iter_mut() {
                        o[i] = 0.0;
                    }
                }
            }
        }
        // Phase 2: apply.
        for y in 0..hh {
            for x in 0..w {
                let i = (y * w + x) as usize;
                let hi = h[i];
                if !valid(hi) {
                    nh[i] = hi;
                    continue;
                }
                let mut sent = 0.0;
                let mut got = 0.0;
                for (k, &(ox, oy)) in OFFSETS.iter().enumerate() {
                    sent += outs[k][i];
                    let (nx, ny) = (x + ox, y + oy);
                    if nx >= 0 && ny >= 0 && nx < w && ny < hh {
                        got += outs[k ^ 4][(ny * w + nx) as usize];
                    }
                }
                nh[i] = (hi - sent) + got;
            }
        }
        std::mem::swap(&mut p.fields[0], &mut scratch[8]);
        p.scratch = scratch;
    }
}
