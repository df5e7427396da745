//! Linear hillslope diffusion, ∂h/∂t = D ∇²h.
//!
//! Source: the diffusion model of soil creep (Culling 1960; e.g. Roering,
//! Kirchner & Dietrich 1999, eq. 1 in its linear limit), discretised with the
//! standard explicit forward-time centred-space (FTCS) scheme
//! (W.H. Press et al., *Numerical Recipes*, 3rd ed., 2007, §20.3.1):
//! `h' = h + rx·((h_E − h) + (h_W − h)) + ry·((h_N − h) + (h_S − h))` with
//! `rx = D·τ/dx²`, `ry = D·τ/dy²`. Each step of `dt` years is cut into the
//! fewest equal substeps τ with `rx + ry <= 1/4`: half the von Neumann
//! stability limit (1/2), which also keeps the update a convex combination
//! (no new extrema, no oscillation). An explicit scheme keeps every substep
//! local (radius 1), so tiling stays exact; an implicit solver would not be.
//!
//! Boundaries: the raster's edge and nodata cells are zero-flux (the missing
//! difference counts as 0), so the volume is conserved to round-off.

use super::{check_cell, check_positive, run_cell, valid, CellSize, LocalModel, Patch};
use crate::error::{Error, Result};
use serde::{Deserialize, Serialize};

/// Most substeps a run may take.
pub const MAX_SUBSTEPS: u64 = 1_000_000_000;

/// Parameters of linear diffusion.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DiffusionParams {
    /// Diffusivity D (m²/yr), > 0.
    pub diffusivity: f64,
    /// Time per step (yr).
    pub dt: f64,
    /// Cell size in metres (default: from the raster's georeference).
    pub cell: Option<f64>,
}

impl Default for DiffusionParams {
    fn default() -> Self {
        DiffusionParams {
            diffusivity: 0.01,
            dt: 1000.0,
            cell: None,
        }
    }
}

impl DiffusionParams {
    /// Check every parameter.
    pub fn validate(&self) -> Result<()> {
        check_positive("diffusivity", self.diffusivity, 1e12, " m²/yr")?;
        check_positive("dt", self.dt, 1e12, " yr")?;
        check_cell(self.cell)
    }
}

/// Diffusion ready to run.
#[derive(Debug, Clone)]
pub struct Diffusion {
    pub params: DiffusionParams,
    pub steps: u64,
    pub cell: CellSize,
    /// Substeps per step.
    pub per_step: u64,
    rx: f64,
    ry: f64,
}

impl Diffusion {
    /// Validate, choose the substeps, build.
    pub fn new(params: DiffusionParams, steps: u64, cell: CellSize) -> Result<Self> {
        params.validate()?;
        let cell = run_cell(steps, params.cell, cell)?;
        let d = params.diffusivity;
        let a = d * params.dt * (1.0 / (cell.dx * cell.dx) + 1.0 / (cell.dy * cell.dy));
        let per = (a / 0.25).ceil().max(1.0);
        let total = per * steps as f64;
        if !(total.is_finite() && total <= MAX_SUBSTEPS as f64) {
            return Err(Error::invalid(format!(
                "diffusion: {steps} steps of {} yr with D = {d} m²/yr on {} x {} m cells need {total:.3e} stable substeps (more than {MAX_SUBSTEPS}); use a smaller dt or fewer steps",
                params.dt, cell.dx, cell.dy
            )));
        }
        let per_step = per as u64;
        let tau = params.dt / per;
        Ok(Diffusion {
            rx: d * tau / (cell.dx * cell.dx),
            ry: d * tau / (cell.dy * cell.dy),
            params,
            steps,
            cell,
            per_step,
        })
    }

    /// The coefficients (rx, ry) of one substep.
    pub fn coefficients(&self) -> (f64, f64) {
        (self.rx, self.ry)
    }
}

impl LocalModel for Diffusion {
    fn name(&self) -> &'static str {
        "diffusion"
    }
    fn params_json(&self) -> serde_json::Value {
        let mut j = super::model_json(self.name(), self.steps, self.cell, &self.params);
        j["substeps_per_step"] = self.per_step.into();
        j
    }
    fn radius(&self) -> usize {
        1
    }
    fn substeps(&self) -> u64 {
        self.steps * self.per_step
    }

    fn substep(&self, p: &mut Patch, _n: u64) {
        let (w, hh) = (p.w, p.h);
        let mut scratch = std::mem::take(&mut p.scratch);
        if scratch.is_empty() {
            scratch.push(Vec::new());
        }
        scratch[0].resize(w * hh, 0.0);
        let h = &p.fields[0];
        let nh = &mut scratch[0];
        let (rx, ry) = (self.rx, self.ry);
        for y in 0..hh {
            for x in 0..w {
                let i = y * w + x;
                let hi = h[i];
                if !valid(hi) {
                    nh[i] = hi;
                    continue;
                }
                let diff = |ok: bool, j: usize| {
                    if ok {
                        let hj = h[j];
                        if valid(hj) {
                            return hj - hi;
                        }
                    }
                    0.0
                };
                let ex = diff(x + 1 < w, i + 1) + diff(x > 0, i.wrapping_sub(1));
                let ey = diff(y + 1 < hh, i + w) + diff(y > 0, i.wrapping_sub(w));
                nh[i] = hi + (rx * ex + ry * ey);
            }
        }
        std::mem::swap(&mut p.fields[0], &mut scratch[0]);
        p.scratch = scratch;
    }
}
