//! Hydraulic erosion on the grid with the virtual-pipe model.
//!
//! Source: X. Mei, P. Decaudin, B.-G. Hu, "Fast Hydraulic Erosion Simulation
//! and Visualization on GPU", Pacific Graphics 2007 (§3: water increment,
//! outflow flux through virtual pipes with the scaling factor K (eqs. 2–5),
//! water surface update (eqs. 6–7), velocity field (eqs. 8–9), erosion and
//! deposition against the sediment transport capacity C = Kc·sin α·|v|
//! (eqs. 10–12), evaporation (eq. 14)); O. Št'ava et al., "Interactive
//! Terrain Modeling Using Hydraulic Erosion", SCA 2008 (capacity ramped to
//! zero in shallow water, here `max_depth`).
//!
//! One substep, every cell with data (units: metres, seconds):
//! 1. rain: with probability `rain_probability` (a counter-based hash of the
//!    seed, substep and global cell) the cell gets `rain / rain_probability`
//!    metres of water, so the expected rain per step is `rain`;
//! 2. flux: `f_k = max(0, f_k + dt·A·g·Δh_k / l_k)` towards each of the four
//!    neighbours (Δh = difference of terrain + water), then all four scaled
//!    by `K = min(1, d·lx·ly / (Σf·dt))` so no cell sends more water than it
//!    holds (Mei eqs. 2–5);
//! 3. water: `d2 = d1 + dt·(Σf_in − Σf_out)/(lx·ly)`; velocity from the mean
//!    flux through the cell over the mean depth (Mei eqs. 8–9), its magnitude
//!    clamped to `min(lx, ly)/dt` (water moves at most one cell per substep);
//! 4. sediment transport — **differs from Mei**: Mei advects sediment
//!    semi-Lagrangianly (backtracing along v), which does not conserve mass.
//!    Here suspended sediment moves with the water through the same pipes,
//!    the upwind (donor-cell) finite-volume scheme (LeVeque, *Finite Volume
//!    Methods for Hyperbolic Problems*, 2002, §4.8): a cell sends the fraction
//!    `f_k·dt / (d1·lx·ly)` of its sediment to neighbour k. The fractions
//!    sum to at most 1 by the scaling K, so the scheme is stable, and every
//!    piece leaves one cell and enters another: sediment is conserved;
//! 5. erosion/deposition against `C = Kc·max(sin α, min_tilt)·|v|·min(1, d2/max_depth)`
//!    (α from central differences of the terrain): if `C > s`, `dt·Ks·(C − s)`
//!    of terrain is dissolved into the water, else `dt·Kd·(s − C)` of
//!    sediment is deposited (Mei eqs. 10–12 with rates per second);
//! 6. evaporation: `d ← d2·(1 − Ke·dt)` (Mei eq. 14).
//!
//! Boundaries: the raster's edge and nodata cells are walls (no water or
//! sediment crosses them), so terrain + suspended sediment is conserved to
//! round-off. The stencil reaches one cell in step 2 and one more in steps
//! 3–5: [`LocalModel::radius`] is 2.

use super::{
    check_cell, check_positive, check_range, hash_unit, run_cell, valid, CellSize, LocalModel,
    Patch,
};
use crate::error::Result;
use serde::{Deserialize, Serialize};

/// Field indices of the hydraulic state.
pub const TERRAIN: usize = 0;
/// Water depth (m).
pub const WATER: usize = 1;
/// Suspended sediment, as a height of material over the cell (m).
pub const SEDIMENT: usize = 2;
const FE: usize = 3;
const FW: usize = 4;
const FN: usize = 5;
const FS: usize = 6;

/// Parameters of the virtual-pipe hydraulic model (units in the field docs).
/// Every field has a default; TOML tables may give any subset.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct HydraulicParams {
    /// Seed of the rain pattern.
    pub seed: u64,
    /// Time step (s).
    pub dt: f64,
    /// Expected rain per step and cell (m of water).
    pub rain: f64,
    /// Probability that a cell gets rain in a step (0 < p <= 1).
    pub rain_probability: f64,
    /// Cross-section of a virtual pipe (m²).
    pub pipe_area: f64,
    /// Gravity (m/s²).
    pub gravity: f64,
    /// Sediment capacity constant Kc (m of sediment per m/s of flow).
    pub capacity: f64,
    /// Dissolving rate Ks (1/s; Ks·dt <= 1).
    pub dissolving: f64,
    /// Deposition rate Kd (1/s; Kd·dt <= 1).
    pub deposition: f64,
    /// Evaporation rate Ke (1/s; Ke·dt < 1).
    pub evaporation: f64,
    /// Smallest sin α used in the capacity, so flat ground still carries sediment.
    pub min_tilt: f64,
    /// Water depth (m) from which the capacity is not reduced (Št'ava's ramp).
    pub max_depth: f64,
    /// At the end, deposit the suspended sediment where it is (terrain + sediment).
    pub settle: bool,
    /// Cell size in metres (default: from the raster's georeference).
    pub cell: Option<f64>,
}

impl Default for HydraulicParams {
    fn default() -> Self {
        HydraulicParams {
            seed: 1,
            dt: 0.5,
            rain: 0.01,
            rain_probability: 0.1,
            pipe_area: 1.0,
            gravity: 9.81,
            capacity: 0.01,
            dissolving: 0.5,
            deposition: 0.5,
            evaporation: 0.05,
            min_tilt: 0.01,
            max_depth: 0.1,
            settle: true,
            cell: None,
        }
    }
}

impl HydraulicParams {
    /// Check every parameter; the error names the parameter and its range.
    pub fn validate(&self) -> Result<()> {
        check_positive("dt", self.dt, 3600.0, " s")?;
        check_range("rain", self.rain, 0.0, 100.0, " m")?;
        check_positive("rain_probability", self.rain_probability, 1.0, "")?;
        check_positive("pipe_area", self.pipe_area, 1e12, " m²")?;
        check_positive("gravity", self.gravity, 1e3, " m/s²")?;
        check_range("capacity", self.capacity, 0.0, 1e6, "")?;
        check_range(
            "dissolving",
            self.dissolving,
            0.0,
            1.0 / self.dt,
            " 1/s (dissolving·dt <= 1)",
        )?;
        check_range(
            "deposition",
            self.deposition,
            0.0,
            1.0 / self.dt,
            " 1/s (deposition·dt <= 1)",
        )?;
        check_range(
            "evaporation",
            self.evaporation,
            0.0,
            0.999_999 / self.dt,
            " 1/s (evaporation·dt < 1)",
        )?;
        check_range("min_tilt", self.min_tilt, 0.0, 1.0, "")?;
        check_positive("max_depth", self.max_depth, 1e6, " m")?;
        check_cell(self.cell)
    }
}

/// The hydraulic model ready to run: parameters, steps and cell size.
#[derive(Debug, Clone)]
pub struct Hydraulic {
    pub params: HydraulicParams,
    pub steps: u64,
    pub cell: CellSize,
}

impl Hydraulic {
    /// Validate and build. `cell` is used unless `params.cell` overrides it.
    pub fn new(params: HydraulicParams, steps: u64, cell: CellSize) -> Result<Self> {
        params.validate()?;
        let cell = run_cell(steps, params.cell, cell)?;
        Ok(Hydraulic {
            params,
            steps,
            cell,
        })
    }
}

/// Piece of sediment carried by flux `f` out of a cell holding `s` with
/// `c = dt / water volume`: computed by the same expression on the sending
/// and the receiving side, so what leaves one cell is what enters the other.
#[inline(always)]
fn piece(s: f64, f: f64, c: f64) -> f64 {
    s * (f * c)
}

impl LocalModel for Hydraulic {
    fn name(&self) -> &'static str {
        "hydraulic"
    }
    fn params_json(&self) -> serde_json::Value {
        super::model_json(self.name(), self.steps, self.cell, &self.params)
    }
    fn field_names(&self) -> &'static [&'static str] {
        &[
            "terrain", "water", "sediment", "flux_e", "flux_w", "flux_n", "flux_s",
        ]
    }
    fn radius(&self) -> usize {
        2
    }
    fn substeps(&self) -> u64 {
        self.steps
    }

    fn substep(&self, p: &mut Patch, n: u64) {
        let q = &self.params;
        let (w, hh) = (p.w, p.h);
        let (lx, ly) = (self.cell.dx, self.cell.dy);
        let area = lx * ly;
        let dt = q.dt;
        // 1. Rain.
        if q.rain > 0.0 {
            let amount = q.rain / q.rain_probability;
            let (h, rest) = p.fields.split_at_mut(1);
            let (h, d) = (&h[0], &mut rest[0]);
            for y in 0..hh {
                let gy = p.y0 + y as i64;
                for x in 0..w {
                    let i = y * w + x;
                    if valid(h[i]) && hash_unit(q.seed, n, p.x0 + x as i64, gy) < q.rain_probability
                    {
                        d[i] += amount;
                    }
                }
            }
        }
        // 2. Outflow flux through the four pipes, scaled by K.
        {
            let kf = dt * q.pipe_area * q.gravity;
            let (kx, ky) = (kf / lx, kf / ly);
            // The driver allocates `field_names().len()` = 7 fields.
            let [h, d, _, fe, fw, fnn, fs] = &mut p.fields[..] else {
                return;
            };
            let (h, d) = (&*h, &*d);
            for y in 0..hh {
                for x in 0..w {
                    let i = y * w + x;
                    let hi = h[i];
                    if !valid(hi) {
                        continue;
                    }
                    let surf = hi + d[i];
                    let flux = |j: usize, f: f64, k: f64| -> f64 {
                        if valid(h[j]) {
                            (f + k * (surf - (h[j] + d[j]))).max(0.0)
                        } else {
                            0.0
                        }
                    };
                    let mut e = if x + 1 < w {
                        flux(i + 1, fe[i], kx)
                    } else {
                        0.0
                    };
                    let mut wv = if x > 0 { flux(i - 1, fw[i], kx) } else { 0.0 };
                    let mut nv = if y > 0 { flux(i - w, fnn[i], ky) } else { 0.0 };
                    let mut s = if y + 1 < hh {
                        flux(i + w, fs[i], ky)
                    } else {
                        0.0
                    };
                    let sum = (e + wv) + (nv + s);
                    if sum > 0.0 {
                        let vol = d[i] * area;
                        if sum * dt > vol {
                            let k = vol / (sum * dt);
                            e *= k;
                            wv *= k;
                            nv *= k;
                            s *= k;
                        }
                    }
                    fe[i] = e;
                    fw[i] = wv;
                    fnn[i] = nv;
                    fs[i] = s;
                }
            }
        }
        // 3–6. Water, velocity, transport, erosion/deposition, evaporation.
        let mut scratch = std::mem::take(&mut p.scratch);
        if scratch.len() < 4 {
            scratch.resize_with(4, Vec::new);
        }
        for s in &mut scratch[..4] {
            s.resize(w * hh, 0.0);
        }
        {
            let [nh, nd, ns, cc, ..] = &mut scratch[..] else {
                return;
            };
            let f = &p.fields;
            let (h, d, sed) = (&f[TERRAIN], &f[WATER], &f[SEDIMENT]);
            let (fe, fw, fnn, fs) = (&f[FE], &f[FW], &f[FN], &f[FS]);
            // dt / water volume of every cell (0 without water): the fraction
            // of a cell's sediment a flux f carries away is f·c.
            for (c, &dv) in cc.iter_mut().zip(d.iter()) {
                *c = if dv > 0.0 { dt / (dv * area) } else { 0.0 };
            }
            let cc = &*cc;
            let c_of = |j: usize| -> f64 { cc[j] };
            let vmax = lx.min(ly) / dt;
            let evap = 1.0 - q.evaporation * dt;
            let (two_lx, two_ly) = (2.0 * lx, 2.0 * ly);
            for y in 0..hh {
                for x in 0..w {
                    let i = y * w + x;
                    let hi = h[i];
                    if !valid(hi) {
                        nh[i] = hi;
                        nd[i] = d[i];
                        ns[i] = sed[i];
                        continue;
                    }
                    // Fluxes into this cell (walls outside the patch).
                    let in_w = if x > 0 { fe[i - 1] } else { 0.0 };
                    let in_e = if x + 1 < w { fw[i + 1] } else { 0.0 };
                    let in_n = if y > 0 { fs[i - w] } else { 0.0 };
                    let in_s = if y + 1 < hh { fnn[i + w] } else { 0.0 };
                    let out = (fe[i] + fw[i]) + (fnn[i] + fs[i]);
                    let inn = (in_w + in_e) + (in_n + in_s);
                    let d1 = d[i];
                    let d2 = (d1 + dt * (inn - out) / area).max(0.0);
                    // Velocity (Mei eqs. 8–9): mean flux through the cell.
                    let wx = 0.5 * ((in_w - fw[i]) + (fe[i] - in_e));
                    let wy = 0.5 * ((in_n - fnn[i]) + (fs[i] - in_s));
                    let dm = 0.5 * (d1 + d2);
                    let speed = if dm > 1e-12 {
                        (wx / (ly * dm)).hypot(wy / (lx * dm)).min(vmax)
                    } else {
                        0.0
                    };
                    // Donor-cell sediment transport along the pipes.
                    let ci = c_of(i);
                    let si = sed[i];
                    let sent = (piece(si, fe[i], ci) + piece(si, fw[i], ci))
                        + (piece(si, fnn[i], ci) + piece(si, fs[i], ci));
                    let mut got = 0.0;
                    if x > 0 {
                        got += piece(sed[i - 1], fe[i - 1], c_of(i - 1));
                    }
                    if x + 1 < w {
                        got += piece(sed[i + 1], fw[i + 1], c_of(i + 1));
                    }
                    if y > 0 {
                        got += piece(sed[i - w], fs[i - w], c_of(i - w));
                    }
                    if y + 1 < hh {
                        got += piece(sed[i + w], fnn[i + w], c_of(i + w));
                    }
                    let st = (si - sent) + got;
                    // Local tilt from central differences (own value at walls).
                    let nb = |ok: bool, j: usize| if ok && valid(h[j]) { h[j] } else { hi };
                    let gx = (nb(x + 1 < w, i + 1) - nb(x > 0, i.wrapping_sub(1))) / two_lx;
                    let gy = (nb(y + 1 < hh, i + w) - nb(y > 0, i.wrapping_sub(w))) / two_ly;
                    let t2 = gx * gx + gy * gy;
                    let sin_a = (t2 / (1.0 + t2)).sqrt().max(q.min_tilt);
                    let cap = q.capacity * sin_a * speed * (d2 / q.max_depth).min(1.0);
                    if cap > st {
                        let m = dt * q.dissolving * (cap - st);
                        nh[i] = hi - m;
                        ns[i] = st + m;
                    } else {
                        let m = dt * q.deposition * (st - cap);
                        nh[i] = hi + m;
                        ns[i] = st - m;
                    }
                    nd[i] = d2 * evap;
                }
            }
        }
        std::mem::swap(&mut p.fields[TERRAIN], &mut scratch[0]);
        std::mem::swap(&mut p.fields[WATER], &mut scratch[1]);
        std::mem::swap(&mut p.fields[SEDIMENT], &mut scratch[2]);
        p.scratch = scratch;
    }

    fn finish(&self, p: &mut Patch) {
        if !self.params.settle {
            return;
        }
        let (a, b) = p.fields.split_at_mut(SEDIMENT);
        let (h, s) = (&mut a[TERRAIN], &mut b[0]);
        for (hv, sv) in h.iter_mut().zip(s.iter_mut()) {
            if valid(*hv) {
                *hv += *sv;
                *sv = 0.0;
            }
        }
    }
}
