//! Many metrics in one pass: [`MultiMetric`] is a local step with one f32
//! output per requested metric (NaN = nodata) and the largest halo any of
//! them needs. Intermediate products are computed once per tile and shared:
//! the quadric coefficients (all curvatures of one radius), one summed-area table of
//! values, counts and squares (stdev, variance, NTPI, disk windows at any
//! radius; square-window mean and TPI use exact running sums instead), one field of fixed-point unit normals (roughness at any radius,
//! by running sums), and one horizon scan per (radius, directions) for openness and
//! sky view.
//!
//! Nodata: a cell whose value is nodata is nodata in every output; 3x3
//! metrics (including Evans curvatures, radius 1) are nodata where a
//! neighbour is nodata or beyond the raster (gdaldem's default); windowed
//! metrics (including Wood's curvatures, radius > 1) exclude nodata cells
//! and cells beyond the raster from their windows.

use super::horizon::{horizon, HorizonOut};
use super::landform;
use super::neighbourhood::{walk_3x3, EdgeMode};
use super::quadric::{laplacian, rugosity, tri_riley, tri_wilson, wood_fit, Quadric};
use super::registry::{is_curvature, resolve, MetricKind, MetricSpec, Resolved, MAX_RADIUS_CELLS};
use super::terrain::horn_gradient;
use super::windowed::{
    open_close, running_max, to_fixed, Sat, WindowSums, FRAC_BITS, MAX_ABS_VALUE,
};
use crate::error::{Error, Result};
use crate::exec::{EngineConfig, LocalStep};
use crate::io::OutputOptions;
use crate::raster::{DType, Grid, RasterInfo, RasterSource, TileView};
use serde_json::json;
use std::path::PathBuf;

/// Nodata value written for metric outputs in files (gdaldem's -9999, as slope).
pub const METRIC_NODATA: f64 = -9999.0;

/// Fractional bits of the fixed-point unit normals summed for roughness.
const NORMAL_FRAC: u32 = 60;

/// Several metrics computed in one tiled pass.
#[derive(Debug, Clone)]
pub struct MultiMetric {
    metrics: Vec<Resolved>,
    halo: usize,
    /// The input's path, for error messages.
    path: String,
}

impl MultiMetric {
    /// Bind `specs` to the raster described by `info` (radii to cells).
    pub fn new(specs: &[MetricSpec], info: &RasterInfo) -> Result<MultiMetric> {
        let metrics = resolve(specs, info)?;
        // descr4: whole-raster metrics run their own global passes.
        if let Some(m) = metrics
            .iter()
            .find(|m| super::peak_dw::is_whole_raster(m.spec.kind))
        {
            return Err(Error::invalid(format!(
                "{} needs whole-raster statistics and is not a local (tile + halo) metric: compute it with metrics::compute (orogen metric), which runs its global passes",
                m.spec.def().name
            )));
        }
        let halo = metrics.iter().map(Resolved::halo).max().unwrap_or(1).max(1);
        Ok(MultiMetric {
            metrics,
            halo,
            path: info.path.display().to_string(),
        })
    }

    /// The metrics, in output order.
    pub fn metrics(&self) -> &[Resolved] {
        &self.metrics
    }

    /// Upper bound of the scratch memory one tile of `tile x tile` cells
    /// allocates in [`LocalStep::run`] beyond its input view and outputs
    /// (summed-area tables, normals, quadric grids, relief passes), for
    /// memory budgets: the engine's own estimate counts views and outputs only.
    pub fn scratch_estimate(&self, tile: usize) -> u64 {
        let core = (tile * tile) as u64;
        let region = |r: usize| ((tile + 2 * r + 1) * (tile + 2 * r + 1)) as u64;
        let mut b = 0u64;
        let radius = |f: &dyn Fn(MetricKind) -> bool| {
            self.metrics
                .iter()
                .filter(|m| f(m.spec.kind))
                .map(|m| m.radius_cells)
                .max()
        };
        if let Some(r) = radius(&|k| {
            matches!(
                k,
                MetricKind::Mean
                    | MetricKind::Stdev
                    | MetricKind::Variance
                    | MetricKind::Tpi
                    | MetricKind::Ntpi
            )
        }) {
            // values (f64) + count (u32) + two i128 tables
            b += region(r) * (8 + 4 + 16 + 16);
        }
        if let Some(r) = self
            .metrics
            .iter()
            .filter(|m| m.spec.kind == MetricKind::WeissLandform)
            .map(|m| m.radius_cells.max(m.radius2_cells))
            .max()
        {
            // summed-area tables as above plus two NTPI grids
            b += region(r) * (8 + 4 + 16 + 16) + 2 * core * 4;
        }
        if let Some(r) = radius(&|k| k == MetricKind::Roughness) {
            // fixed-point normals: six i32 limbs + an i32 count per cell
            b += region(r) * (7 * 4);
        }
        if let Some(r) = radius(&|k| k == MetricKind::Relief) {
            b += region(r) * 8 + (tile + 2 * r) as u64 * tile as u64 * 16;
        }
        if let Some(r) = radius(&|k| matches!(k, MetricKind::TopHatWhite | MetricKind::TopHatBlack))
        {
            // region, flipped copy, first pass, running lines
            b += region(2 * r) * 8 * 4;
        }
        let quadrics = {
            let mut rs: Vec<usize> = self
                .metrics
                .iter()
                .filter(|m| is_curvature(m.spec.kind))
                .map(|m| m.radius_cells.max(1))
                .collect();
            rs.sort_unstable();
            rs.dedup();
            rs.len() as u64
        };
        // visibility & solar: horizon tangents (f64, up and down), per-direction
        // solar horizons (f32) and sky-view sums.
        if self.metrics.iter().any(|m| {
            use MetricKind::*;
            matches!(
                m.spec.kind,
                HorizonAngle
                    | Zenith
                    | Nadir
                    | Accessibility
                    | SolarDirect
                    | SolarGlobal
                    | SolarAnnual
            )
        }) {
            b += core * (2 * 8 + 16 * 4 + 8 + 4 + 3 * 8);
        }
        // more descriptors: gradients, slopes and two tables per window metric
        if let Some(r) =
            radius(&|k| matches!(k, MetricKind::AverageSlope | MetricKind::HillslopeAsymmetry))
        {
            b += region(r) * (4 * 8 + 2 * (4 + 16));
        }
        // descr3: gradients, side, rank, value, order and two Fenwick trees
        if let Some(r) = radius(&|k| k == MetricKind::AsymmetryIndex) {
            b += region(r) * (2 * 8 + 1 + 4 + 8 + 8 + 4 + 2 * 4);
        }
        b + quadrics * core * std::mem::size_of::<Quadric>() as u64 + 3 * core * 4
    }
}

/// Output paths for `specs` in `dir`: `<label>.<ext>` (e.g. `tpi_r500m.tif`);
/// an error if two specs would write the same file.
pub fn output_paths(
    specs: &[MetricSpec],
    dir: &std::path::Path,
    ext: &str,
) -> Result<Vec<PathBuf>> {
    let mut out: Vec<PathBuf> = Vec::with_capacity(specs.len());
    for s in specs {
        let p = dir.join(format!("{}.{ext}", s.label()));
        if out.contains(&p) {
            return Err(Error::invalid(format!(
                "metric {} is requested twice (both would write {}): remove the duplicate",
                s.label(),
                p.display()
            )));
        }
        out.push(p);
    }
    Ok(out)
}

fn is_sat(k: MetricKind) -> bool {
    use MetricKind::*;
    matches!(k, Mean | Stdev | Variance | Tpi | Ntpi)
}

/// Square-window mean and TPI: running sums ([`box_stat`]), no SAT.
fn is_box(k: MetricKind, disk: bool) -> bool {
    matches!(k, MetricKind::Mean | MetricKind::Tpi) && !disk
}

fn is_horizon(k: MetricKind) -> bool {
    use MetricKind::*;
    matches!(k, OpennessPositive | OpennessNegative | SkyView)
}

impl LocalStep for MultiMetric {
    type In = f32;
    type Out = f32;
    fn name(&self) -> String {
        let names: Vec<String> = self.metrics.iter().map(|m| m.spec.label()).collect();
        format!("metric {}", names.join(","))
    }
    fn params(&self) -> serde_json::Value {
        json!({ "metrics": self.metrics, "halo": self.halo })
    }
    fn halo(&self) -> usize {
        self.halo
    }
    fn scratch_bytes(&self, tile: usize) -> u64 {
        self.scratch_estimate(tile)
    }
    fn outputs(&self) -> usize {
        self.metrics.len()
    }
    fn run(&self, inputs: &[TileView<f32>], out: &mut [Grid<f32>]) -> Result<()> {
        let view = inputs
            .first()
            .ok_or_else(|| Error::invalid("metrics need one input"))?;
        if out.len() != self.metrics.len() {
            return Err(Error::invalid("metrics: wrong number of outputs"));
        }
        let (cw, ch) = (view.core.w, view.core.h);
        let nan = f32::NAN;

        // Shared: quadric coefficients per curvature radius (Evans 3x3 for
        // radius 1, Wood's n x n fit beyond).
        let mut quads: Vec<(usize, Grid<Quadric>)> = Vec::new();
        for m in self.metrics.iter().filter(|m| {
            is_curvature(m.spec.kind)
                || m.spec.kind == MetricKind::DikauForm
                || m.spec.kind == MetricKind::SharyLandform
        }) {
            let r = m.radius_cells.max(1);
            if quads.iter().any(|q| q.0 == r) {
                continue;
            }
            let mut g = Grid::new(cw, ch, Quadric::NAN);
            if r == 1 {
                walk_3x3(view, &mut g, EdgeMode::Nodata, Quadric::NAN, Quadric::fit);
            } else {
                wood_fit(view, r, &mut g);
            }
            quads.push((r, g));
        }
        // Shared: one SAT over core + the largest SAT radius.
        let sat_r = self
            .metrics
            .iter()
            .filter(|m| is_sat(m.spec.kind) && !is_box(m.spec.kind, m.spec.disk))
            .map(|m| m.radius_cells)
            .chain(
                self.metrics
                    .iter()
                    .filter(|m| m.spec.kind == MetricKind::WeissLandform)
                    .map(|m| m.radius_cells.max(m.radius2_cells)),
            )
            .max();
        let sat = match sat_r {
            Some(r) => {
                let vals = region(view, r);
                let squares = self.metrics.iter().any(|m| {
                    matches!(
                        m.spec.kind,
                        MetricKind::Stdev
                            | MetricKind::Variance
                            | MetricKind::Ntpi
                            | MetricKind::WeissLandform
                    )
                });
                Some((
                    r,
                    Sat::new(&vals, cw + 2 * r, ch + 2 * r, squares, &self.path)?,
                ))
            }
            None => None,
        };
        // Shared: unit normals and their tables for roughness.
        let rough_r = self
            .metrics
            .iter()
            .filter(|m| m.spec.kind == MetricKind::Roughness)
            .map(|m| m.radius_cells)
            .max();
        let normals = rough_r.map(|r| (r, normal_field(view, r)));

        let mut done_horizon = vec![false; self.metrics.len()];
        let (mut g1, mut g2) = (Vec::new(), Vec::new());
        for k in 0..self.metrics.len() {
            let m = &self.metrics[k];
            let o = &mut out[k];
            use MetricKind::*;
            match m.spec.kind {
                Dzdx => walk_3x3(view, o, EdgeMode::Nodata, nan, |w, ew, ns| {
                    horn_gradient(w, ew, ns).0 as f32
                }),
                Dzdy => walk_3x3(view, o, EdgeMode::Nodata, nan, |w, ew, ns| {
                    horn_gradient(w, ew, ns).1 as f32
                }),
                Slope => {
                    let s = super::terrain::Slope {
                        units: m.spec.units,
                        ..super::terrain::Slope::default()
                    };
                    s.run(inputs, std::slice::from_mut(o))?;
                }
                Aspect => {
                    super::terrain::Aspect::default().run(inputs, std::slice::from_mut(o))?;
                }
                // cos(aspect)·sin(slope) = −q/√(1+p²+q²) (aspect = atan2(−p, −q)).
                Northness | NormalY => walk_3x3(view, o, EdgeMode::Nodata, nan, |w, ew, ns| {
                    let (p, q) = horn_gradient(w, ew, ns);
                    (-q / (1.0 + p * p + q * q).sqrt()) as f32
                }),
                Eastness | NormalX => walk_3x3(view, o, EdgeMode::Nodata, nan, |w, ew, ns| {
                    let (p, q) = horn_gradient(w, ew, ns);
                    (-p / (1.0 + p * p + q * q).sqrt()) as f32
                }),
                NormalZ => walk_3x3(view, o, EdgeMode::Nodata, nan, |w, ew, ns| {
                    let (p, q) = horn_gradient(w, ew, ns);
                    (1.0 / (1.0 + p * p + q * q).sqrt()) as f32
                }),
                Laplacian => walk_3x3(view, o, EdgeMode::Nodata, nan, |w, ew, ns| {
                    laplacian(w, ew, ns) as f32
                }),
                TriRiley => walk_3x3(view, o, EdgeMode::Nodata, nan, |w, _, _| {
                    tri_riley(w) as f32
                }),
                TriWilson => walk_3x3(view, o, EdgeMode::Nodata, nan, |w, _, _| {
                    tri_wilson(w) as f32
                }),
                Rugosity => walk_3x3(view, o, EdgeMode::Nodata, nan, |w, ew, ns| {
                    rugosity(w, ew, ns) as f32
                }),
                ProfileCurvature | PlanCurvature | TangentialCurvature | MeanCurvature
                | GaussianCurvature | MinCurvature | MaxCurvature => {
                    let r = m.radius_cells.max(1);
                    let Some(qg) = quads.iter().find(|q| q.0 == r).map(|q| &q.1) else {
                        return Err(Error::invalid("metrics: quadric table missing"));
                    };
                    let kind = m.spec.kind;
                    for (o, c) in o.data_mut().iter_mut().zip(qg.data()) {
                        *o = if c.p.is_nan() {
                            nan
                        } else {
                            (match kind {
                                ProfileCurvature => c.profile(),
                                PlanCurvature => c.plan(),
                                TangentialCurvature => c.tangential(),
                                MeanCurvature => c.mean(),
                                GaussianCurvature => c.gaussian(),
                                MinCurvature => c.min_max().0,
                                _ => c.min_max().1,
                            }) as f32
                        };
                    }
                }
                Mean | Tpi if !m.spec.disk => {
                    box_stat(view, m.radius_cells, m.spec.kind, &self.path, o)?;
                }
                Mean | Stdev | Variance | Tpi | Ntpi => {
                    let Some((big, sat)) = sat.as_ref() else {
                        return Err(Error::invalid("metrics: summed-area table missing"));
                    };
                    windowed_stat(view, sat, *big, m.radius_cells, m.spec.disk, m.spec.kind, o);
                }
                Relief => relief(view, m.radius_cells, o, &mut g1, &mut g2),
                Geomorphon | GeomorphonPattern => {
                    if done_horizon[k] {
                        continue;
                    }
                    let flat = m.spec.threshold.unwrap_or(1.0);
                    // One scan for a class and a pattern with the same rays.
                    let key = (m.radius_cells, m.radius_m.to_bits(), flat.to_bits());
                    let other = if m.spec.kind == Geomorphon {
                        GeomorphonPattern
                    } else {
                        Geomorphon
                    };
                    let twin = (k + 1..self.metrics.len()).find(|&j| {
                        let n = &self.metrics[j];
                        n.spec.kind == other
                            && (
                                n.radius_cells,
                                n.radius_m.to_bits(),
                                n.spec.threshold.unwrap_or(1.0).to_bits(),
                            ) == key
                    });
                    let mut extra = twin.map(|_| Grid::new(cw, ch, nan));
                    let (c, p) = if m.spec.kind == Geomorphon {
                        (Some(&mut *o), extra.as_mut())
                    } else {
                        (extra.as_mut(), Some(&mut *o))
                    };
                    landform::geomorphon(view, m.radius_cells, m.radius_m, flat, c, p);
                    if let (Some(j), Some(g)) = (twin, extra) {
                        done_horizon[j] = true;
                        out[j].data_mut().copy_from_slice(g.data());
                    }
                }
                GeomorphonCanonical => {
                    let flat = m.spec.threshold.unwrap_or(1.0);
                    landform::geomorphon(view, m.radius_cells, m.radius_m, flat, None, Some(o));
                    for v in o.data_mut() {
                        if !v.is_nan() {
                            *v = landform::canonical_code(*v as u32) as f32;
                        }
                    }
                }
                WeissLandform => {
                    let Some((big, sat)) = sat.as_ref() else {
                        return Err(Error::invalid("metrics: summed-area table missing"));
                    };
                    let mut sn = Grid::new(cw, ch, nan);
                    let mut ln = Grid::new(cw, ch, nan);
                    windowed_stat(view, sat, *big, m.radius_cells, false, Ntpi, &mut sn);
                    windowed_stat(view, sat, *big, m.radius2_cells, false, Ntpi, &mut ln);
                    super::terrain::Slope::default().run(inputs, std::slice::from_mut(o))?;
                    let t = m.spec.threshold.unwrap_or(5.0);
                    for ((o, a), b) in o.data_mut().iter_mut().zip(sn.data()).zip(ln.data()) {
                        *o = landform::weiss_class(*a as f64, *b as f64, *o as f64, t);
                    }
                }
                DikauForm => {
                    let r = m.radius_cells.max(1);
                    let Some(qg) = quads.iter().find(|q| q.0 == r).map(|q| &q.1) else {
                        return Err(Error::invalid("metrics: quadric table missing"));
                    };
                    let t = m.spec.threshold.unwrap_or(0.0);
                    for (o, c) in o.data_mut().iter_mut().zip(qg.data()) {
                        *o = if c.p.is_nan() {
                            nan
                        } else {
                            landform::dikau_class(c.profile(), c.plan(), t)
                        };
                    }
                }
                SkyViewApprox => walk_3x3(view, o, EdgeMode::Nodata, nan, |w, ew, ns| {
                    let (p, q) = horn_gradient(w, ew, ns);
                    // cos β = 1/√(1+p²+q²)
                    ((1.0 + 1.0 / (1.0 + p * p + q * q).sqrt()) / 2.0) as f32
                }),
                Percentile => percentile(view, m.radius_cells, o),
                TopHatWhite | TopHatBlack => {
                    let r = m.radius_cells;
                    let vals = region(view, 2 * r);
                    let w = view.core.w + 4 * r;
                    let white = m.spec.kind == TopHatWhite;
                    let oc = open_close(&vals, w, view.core.h + 4 * r, r, !white);
                    for (i, (o, v)) in o.data_mut().iter_mut().zip(&oc).enumerate() {
                        let z = vals[(i / cw + 2 * r) * w + i % cw + 2 * r];
                        *o = if z.is_nan() {
                            nan
                        } else if white {
                            (z - v) as f32
                        } else {
                            (v - z) as f32
                        };
                    }
                }
                Roughness => {
                    let Some((big, ns)) = normals.as_ref() else {
                        return Err(Error::invalid("metrics: normal field missing"));
                    };
                    roughness(view, ns, *big, m.radius_cells, o);
                }
                OpennessPositive | OpennessNegative | SkyView => {
                    if done_horizon[k] {
                        continue;
                    }
                    // One scan for every horizon metric with the same rays.
                    let key = (m.radius_cells, m.radius_m.to_bits(), m.spec.directions);
                    let same: Vec<usize> = (k..self.metrics.len())
                        .filter(|&j| {
                            let n = &self.metrics[j];
                            is_horizon(n.spec.kind)
                                && (n.radius_cells, n.radius_m.to_bits(), n.spec.directions) == key
                        })
                        .collect();
                    let mut hout = HorizonOut {
                        positive: None,
                        negative: None,
                        sky_view: None,
                    };
                    let mut grids: Vec<(MetricKind, usize, Grid<f32>)> = Vec::new();
                    for &j in &same {
                        done_horizon[j] = true;
                        grids.push((self.metrics[j].spec.kind, j, Grid::new(cw, ch, nan)));
                    }
                    for (kind, _, g) in grids.iter_mut() {
                        match kind {
                            OpennessPositive if hout.positive.is_none() => hout.positive = Some(g),
                            OpennessNegative if hout.negative.is_none() => hout.negative = Some(g),
                            SkyView if hout.sky_view.is_none() => hout.sky_view = Some(g),
                            _ => {}
                        }
                    }
                    horizon(view, m.radius_cells, m.radius_m, m.spec.directions, hout);
                    // Duplicates of one kind copy the first grid of that kind.
                    for i in 0..grids.len() {
                        let first = grids.iter().position(|g| g.0 == grids[i].0).unwrap_or(i);
                        let data = grids[first].2.data().to_vec();
                        out[grids[i].1].data_mut().copy_from_slice(&data);
                    }
                }
                // visibility & solar
                HorizonAngle => {
                    let dir = m.spec.value("dir").and_then(super::visibility::lattice_dir);
                    let ho = super::horizon::HorizonExtra {
                        angle: Some((dir.unwrap_or(0), o)),
                        ..Default::default()
                    };
                    super::horizon::horizon_extra(
                        view,
                        m.radius_cells,
                        m.radius_m,
                        0,
                        super::horizon::HorizonMethod::Sweep,
                        ho,
                    );
                }
                Zenith | Nadir | Accessibility => {
                    if done_horizon[k] {
                        continue;
                    }
                    // One scan for every zenith/nadir/accessibility with the same rays.
                    let key = (m.radius_cells, m.radius_m.to_bits(), m.spec.directions);
                    let same: Vec<usize> = (k..self.metrics.len())
                        .filter(|&j| {
                            let n = &self.metrics[j];
                            matches!(n.spec.kind, Zenith | Nadir | Accessibility)
                                && (n.radius_cells, n.radius_m.to_bits(), n.spec.directions) == key
                        })
                        .collect();
                    let mut grids: Vec<Grid<f32>> =
                        same.iter().map(|_| Grid::new(cw, ch, nan)).collect();
                    let mut ho = super::horizon::HorizonExtra::default();
                    for (&j, g) in same.iter().zip(grids.iter_mut()) {
                        done_horizon[j] = true;
                        match self.metrics[j].spec.kind {
                            Zenith if ho.zenith.is_none() => ho.zenith = Some(g),
                            Nadir if ho.nadir.is_none() => ho.nadir = Some(g),
                            Accessibility if ho.accessibility.is_none() => {
                                ho.accessibility = Some(g)
                            }
                            _ => {}
                        }
                    }
                    super::horizon::horizon_extra(
                        view,
                        m.radius_cells,
                        m.radius_m,
                        m.spec.directions,
                        super::horizon::HorizonMethod::Sweep,
                        ho,
                    );
                    // Duplicates of one kind copy the first grid of that kind.
                    for (i, &j) in same.iter().enumerate() {
                        let kind = self.metrics[j].spec.kind;
                        let first = same
                            .iter()
                            .position(|&f| self.metrics[f].spec.kind == kind)
                            .unwrap_or(i);
                        out[j].data_mut().copy_from_slice(grids[first].data());
                    }
                }
                VisibilityIndex => super::visibility::visibility_index(
                    view,
                    m.radius_cells,
                    m.radius_m,
                    m.spec.directions,
                    m.spec.value("height").unwrap_or(1.7),
                    m.spec.value("target").unwrap_or(0.0),
                    o,
                ),
                SolarDirect | SolarGlobal | SolarAnnual => super::solar::solar(view, m, o)?,
                VisibilityIndexExact => super::visibility::visibility_index_exact(
                    view,
                    m.radius_cells,
                    m.radius_m,
                    m.spec.value("height").unwrap_or(1.7),
                    m.spec.value("target").unwrap_or(0.0),
                    o,
                ),
                HeatIndex => {
                    let amax = m.spec.value("alpha_max").unwrap_or(202.5);
                    walk_3x3(view, o, EdgeMode::Nodata, nan, |w, ew, ns| {
                        super::solar::heat_index(w, ew, ns, amax) as f32
                    })
                }
                // more descriptors
                DirectionalSlope => {
                    let a = m.spec.azimuth.unwrap_or(0.0);
                    walk_3x3(view, o, EdgeMode::Nodata, nan, |w, ew, ns| {
                        let (p, q) = horn_gradient(w, ew, ns);
                        super::directional::directional_slope(p, q, a) as f32
                    })
                }
                AverageSlope => {
                    super::directional::average_slope(view, m.radius_cells, &self.path, o)?
                }
                HillslopeAsymmetry => super::asymmetry::hillslope_asymmetry(
                    view,
                    m.radius_cells,
                    m.spec.azimuth.unwrap_or(0.0),
                    m.spec.threshold.unwrap_or(45.0),
                    &self.path,
                    o,
                )?,
                FractionalLaplacian => super::fractional::fractional_laplacian(
                    view,
                    m.radius_cells,
                    m.radius_m,
                    m.spec.exponent.unwrap_or(0.5),
                    o,
                ),
                // descr4: Xu's spherical forms when a planet radius is given.
                Dominance | Submission | Jut | Rut if m.spec.value("planet").is_some() => {
                    use super::xu::{spherical, Xu};
                    let which = match m.spec.kind {
                        Dominance => Xu::Dominance,
                        Submission => Xu::Submission,
                        Jut => Xu::Jut,
                        _ => Xu::Rut,
                    };
                    let planet_m = m.spec.value("planet").unwrap_or(f64::INFINITY) * 1000.0;
                    spherical(view, m.radius_cells, m.radius_m, planet_m, which, o);
                }
                Ors | Jut | Rut => {
                    use super::relief_shape::{relief_shape, ReliefShape};
                    let which = match m.spec.kind {
                        Ors => ReliefShape::Ors,
                        Jut => ReliefShape::Jut,
                        _ => ReliefShape::Rut,
                    };
                    relief_shape(view, m.radius_cells, m.radius_m, which, o);
                }
                FuzzyLandform => super::fuzzy::fuzzy_membership(
                    view,
                    m.spec.scales.as_deref().unwrap_or(&[1, 2, 4]),
                    m.spec.feature.unwrap_or(0),
                    m.spec.threshold.unwrap_or(1e-4),
                    o,
                ),
                SharyLandform => {
                    let r = m.radius_cells.max(1);
                    let Some(qg) = quads.iter().find(|q| q.0 == r).map(|q| &q.1) else {
                        return Err(Error::invalid("metrics: quadric table missing"));
                    };
                    let t = m.spec.threshold.unwrap_or(0.0);
                    for (o, c) in o.data_mut().iter_mut().zip(qg.data()) {
                        *o = if c.p.is_nan() {
                            nan
                        } else {
                            super::shary::shary_class(
                                c.gaussian(),
                                c.mean(),
                                c.tangential(),
                                c.profile(),
                                t,
                            )
                        };
                    }
                }
                // last descriptors
                Dominance | Submission | Peakedness | Domination => {
                    use super::dominance::{position, Position};
                    let which = match m.spec.kind {
                        Dominance => Position::Dominance,
                        Submission => Position::Submission,
                        Peakedness => Position::Peakedness,
                        _ => Position::Domination,
                    };
                    position(view, m.radius_cells, m.radius_m, which, o);
                }
                // descr3
                AsymmetryIndex => super::asymmetry::asymmetry_index(
                    view,
                    m.radius_cells,
                    m.spec.azimuth.unwrap_or(0.0),
                    m.spec.threshold.unwrap_or(45.0),
                    o,
                ),
                // descr4: refused by `new`.
                PeakednessDw | PeakPrototypicality => {
                    return Err(Error::invalid(format!(
                        "{} is a whole-raster metric: use metrics::compute",
                        m.spec.def().name
                    )))
                }
            }
        }
        Ok(())
    }
}

/// The core plus `r` cells on each side of `view`, as f64 (NaN = nodata).
fn region(view: &TileView<f32>, r: usize) -> Vec<f64> {
    let (h, gw) = (view.halo, view.grid.width());
    let (w, hh) = (view.core.w + 2 * r, view.core.h + 2 * r);
    let mut v = Vec::with_capacity(w * hh);
    for y in 0..hh {
        let start = (y + h - r) * gw + h - r;
        v.extend(view.grid.data()[start..start + w].iter().map(|&z| z as f64));
    }
    v
}

/// Mean, stdev, variance, TPI or NTPI of every core cell from the SAT built
/// over core + `big` cells; window half-side `r ≤ big`.
///
/// With `disk`, the window is the disk of cells with `dx² + dy² ≤ r²` (in
/// cells), summed as one SAT row segment per row: O(r) per cell, exact.
#[allow(clippy::too_many_arguments)]
fn windowed_stat(
    view: &TileView<f32>,
    sat: &Sat,
    big: usize,
    r: usize,
    disk: bool,
    kind: MetricKind,
    o: &mut Grid<f32>,
) {
    let h = view.halo;
    let gw = view.grid.width();
    let data = view.grid.data();
    // Half-widths of the disk's rows (exact integer test dx² ≤ r² − dy²).
    let half: Vec<usize> = (0..=r)
        .map(|dy| {
            let mut hw = 0;
            while (hw + 1) * (hw + 1) + dy * dy <= r * r {
                hw += 1;
            }
            hw
        })
        .collect();
    for y in 0..view.core.h {
        let (y0, y1) = (y + big - r, y + big + r + 1);
        for x in 0..view.core.w {
            let z = data[(y + h) * gw + x + h];
            if z.is_nan() {
                o.set(x, y, f32::NAN);
                continue;
            }
            let ws = if disk {
                let cx = x + big;
                let mut acc = sat.window(cx - half[0], y + big, cx + half[0] + 1, y + big + 1);
                for (dy, &hw) in half.iter().enumerate().skip(1) {
                    for yy in [y + big - dy, y + big + dy] {
                        acc = acc.plus(&sat.window(cx - hw, yy, cx + hw + 1, yy + 1));
                    }
                }
                acc
            } else {
                sat.window(x + big - r, y0, x + big + r + 1, y1)
            };
            o.set(x, y, stat_value(ws, z, kind) as f32);
        }
    }
}

/// Mean, variance, stdev, TPI or NTPI of a valid centre `z` from its
/// window's exact sums.
#[inline]
fn stat_value(ws: WindowSums, z: f32, kind: MetricKind) -> f64 {
    match kind {
        MetricKind::Mean => ws.mean(),
        MetricKind::Variance => ws.variance(),
        MetricKind::Stdev => ws.variance().sqrt(),
        _ => {
            // The window without its centre.
            let mut others = ws;
            others.n -= 1;
            others.sum = others
                .sum
                .wrapping_sub(super::windowed::to_fixed(z as f64, ws.frac));
            let tpi = z as f64 - others.mean();
            if kind == MetricKind::Tpi {
                tpi
            } else {
                let sd = ws.variance().sqrt();
                if tpi.is_nan() {
                    f64::NAN
                } else if sd == 0.0 {
                    0.0
                } else {
                    tpi / sd
                }
            }
        }
    }
}

/// Mean or TPI over square windows of half-side `r` by exact running sums
/// (no summed-area table): each value's fixed-point `q` ([`FRAC_BITS`]) is
/// split into limbs `q = hi·2²⁴ + lo`, `0 ≤ lo < 2²⁴`, `|hi| ≤ 5·10⁷ < 2²⁶`
/// ([`MAX_ABS_VALUE`]); column sums of the `2r+1` rows are slid down the
/// rows and row sums along them. With at most (2·2000+1)² < 2²⁴ cells per
/// window ([`MAX_RADIUS_CELLS`]), |Σhi| < 2⁵⁰ and Σlo < 2⁴⁸: both limbs sum
/// in i64 without overflow, the row loops are plain i64 adds the compiler
/// vectorises, and `Σq = Σhi·2²⁴ + Σlo` is the same integer the SAT gave
/// (same bits, whatever the tiling). Nodata cells add zero limbs and no
/// count. `what` names the input in the range error.
fn box_stat(
    view: &TileView<f32>,
    r: usize,
    kind: MetricKind,
    what: &str,
    o: &mut Grid<f32>,
) -> Result<()> {
    const _: () = assert!(FRAC_BITS == 24 && MAX_ABS_VALUE <= 67_108_864.0);
    const _: () = assert!(MAX_RADIUS_CELLS <= 2000);
    let (cw, ch) = (view.core.w, view.core.h);
    if cw == 0 || ch == 0 {
        return Ok(());
    }
    let h = view.halo;
    let gw = view.grid.width();
    let data = view.grid.data();
    let (cols, rows, k) = (cw + 2 * r, ch + 2 * r, 2 * r + 1);
    let mut hi = vec![0i32; cols * rows];
    let mut lo = vec![0i32; cols * rows];
    let mut cnt = vec![0i32; cols * rows];
    for y in 0..rows {
        let start = (y + h - r) * gw + h - r;
        let row = &data[start..start + cols];
        for (x, &z) in row.iter().enumerate() {
            if z.is_nan() {
                continue;
            }
            let z = z as f64;
            if z.abs() > MAX_ABS_VALUE {
                return Err(Error::invalid(format!(
                    "{what}: value {z} is beyond ±{MAX_ABS_VALUE}, the range of the windowed statistics: rescale the input"
                )));
            }
            let q = to_fixed(z, FRAC_BITS) as i64;
            let i = y * cols + x;
            hi[i] = (q >> FRAC_BITS) as i32;
            lo[i] = (q & ((1 << FRAC_BITS) - 1)) as i32;
            cnt[i] = 1;
        }
    }
    let (mut chi, mut clo, mut cc) = (vec![0i64; cols], vec![0i64; cols], vec![0i32; cols]);
    for y in 0..k {
        let b = y * cols;
        for c in 0..cols {
            chi[c] += hi[b + c] as i64;
            clo[c] += lo[b + c] as i64;
            cc[c] += cnt[b + c];
        }
    }
    for y in 0..ch {
        if y > 0 {
            let (a, b) = ((y + k - 1) * cols, (y - 1) * cols);
            let (ha, hb) = (&hi[a..a + cols], &hi[b..b + cols]);
            let (la, lb) = (&lo[a..a + cols], &lo[b..b + cols]);
            let (na, nb) = (&cnt[a..a + cols], &cnt[b..b + cols]);
            for c in 0..cols {
                chi[c] += ha[c] as i64 - hb[c] as i64;
                clo[c] += la[c] as i64 - lb[c] as i64;
                cc[c] += na[c] - nb[c];
            }
        }
        let (mut sh, mut sl, mut n) = (0i64, 0i64, 0i32);
        for c in 0..k {
            sh += chi[c];
            sl += clo[c];
            n += cc[c];
        }
        let zrow = &data[(y + h) * gw + h..(y + h) * gw + h + cw];
        for (x, &z) in zrow.iter().enumerate() {
            if x > 0 {
                sh += chi[x + k - 1] - chi[x - 1];
                sl += clo[x + k - 1] - clo[x - 1];
                n += cc[x + k - 1] - cc[x - 1];
            }
            if z.is_nan() {
                o.set(x, y, f32::NAN);
                continue;
            }
            let ws = WindowSums {
                n: n as u32,
                sum: ((sh as i128) << FRAC_BITS) + sl as i128,
                sumsq: 0,
                frac: FRAC_BITS,
            };
            o.set(x, y, stat_value(ws, z, kind) as f32);
        }
    }
    Ok(())
}

/// Elevation percentile: 100 · (number of the other valid cells of the
/// square window strictly lower than the centre) / (number of the other
/// valid cells); nodata if there are none. Exact counting, O(r²) per cell.
fn percentile(view: &TileView<f32>, r: usize, o: &mut Grid<f32>) {
    let h = view.halo;
    let gw = view.grid.width();
    let data = view.grid.data();
    let side = 2 * r + 1;
    for y in 0..view.core.h {
        for x in 0..view.core.w {
            let c = (y + h) * gw + x + h;
            let z = data[c];
            if z.is_nan() {
                o.set(x, y, f32::NAN);
                continue;
            }
            let (mut lower, mut n) = (0u32, 0u32);
            for row in 0..side {
                let start = c + row * gw - r * gw - r;
                for &v in &data[start..start + side] {
                    // NaN compares false: neither counted nor lower.
                    n += u32::from(!v.is_nan());
                    lower += u32::from(v < z);
                }
            }
            let others = n - 1;
            o.set(
                x,
                y,
                if others == 0 {
                    f32::NAN
                } else {
                    (100.0 * lower as f64 / others as f64) as f32
                },
            );
        }
    }
}

/// Local relief (max − min over the square window of half-side `r`, valid
/// cells only) by separable van Herk / Gil-Werman running max and min.
fn relief(view: &TileView<f32>, r: usize, o: &mut Grid<f32>, g1: &mut Vec<f64>, g2: &mut Vec<f64>) {
    let (cw, ch) = (view.core.w, view.core.h);
    let vals = region(view, r);
    let w = cw + 2 * r;
    let rows = ch + 2 * r;
    // Horizontal pass: for every region row, max and min over columns.
    let mut hmax = vec![0.0; rows * cw];
    let mut hmin = vec![0.0; rows * cw];
    let mut line = vec![0.0; w];
    let mut res = vec![0.0; w];
    for y in 0..rows {
        let row = &vals[y * w..(y + 1) * w];
        for (l, &z) in line.iter_mut().zip(row) {
            *l = if z.is_nan() { f64::NEG_INFINITY } else { z };
        }
        running_max(&line, r, &mut res, g1, g2);
        hmax[y * cw..(y + 1) * cw].copy_from_slice(&res[r..r + cw]);
        for (l, &z) in line.iter_mut().zip(row) {
            *l = if z.is_nan() { f64::NEG_INFINITY } else { -z };
        }
        running_max(&line, r, &mut res, g1, g2);
        for (d, s) in hmin[y * cw..(y + 1) * cw].iter_mut().zip(&res[r..r + cw]) {
            *d = -s;
        }
    }
    // Vertical pass per core column.
    let mut col = vec![0.0; rows];
    let mut cmax = vec![0.0; rows];
    let mut cmin = vec![0.0; rows];
    for x in 0..cw {
        for (y, c) in col.iter_mut().enumerate() {
            *c = hmax[y * cw + x];
        }
        running_max(&col, r, &mut cmax, g1, g2);
        for (y, c) in col.iter_mut().enumerate() {
            // −(+∞) from an all-nodata row stays −∞ for the max of negatives.
            *c = -hmin[y * cw + x];
        }
        running_max(&col, r, &mut cmin, g1, g2);
        for y in 0..ch {
            let z = vals[(y + r) * w + x + r];
            let v = if z.is_nan() {
                f32::NAN
            } else {
                (cmax[y + r] + cmin[y + r]) as f32
            };
            o.set(x, y, v);
        }
    }
}

/// Fixed-point unit normals (Horn gradient, [`NORMAL_FRAC`] fractional
/// bits, |component| ≤ 2⁶⁰) of the core plus `r` cells on each side,
/// row-major, each component split into 30-bit limbs `v = hi·2³⁰ + lo`
/// (`0 ≤ lo < 2³⁰`, `|hi| ≤ 2³⁰`: both fit i32), with a 0/1 validity count
/// (cells whose 3x3 window holds nodata or lies beyond the raster have zero
/// limbs and count 0).
struct NormalField {
    /// `hi[j]`, `lo[j]`: limbs of component j (x, y, z).
    hi: [Vec<i32>; 3],
    lo: [Vec<i32>; 3],
    count: Vec<i32>,
}

#[allow(clippy::needless_range_loop)] // parallel per-column arrays
fn normal_field(view: &TileView<f32>, r: usize) -> NormalField {
    const _: () = assert!(NORMAL_FRAC == 60);
    let h = view.halo;
    let gw = view.grid.width();
    let data = view.grid.data();
    let (w, hh) = (view.core.w + 2 * r, view.core.h + 2 * r);
    let zero = || vec![0i32; w * hh];
    let mut f = NormalField {
        hi: [zero(), zero(), zero()],
        lo: [zero(), zero(), zero()],
        count: zero(),
    };
    let fix = |v: f64| super::windowed::to_fixed(v, NORMAL_FRAC) as i64;
    let mut nb = [vec![0.0f64; w], vec![0.0f64; w], vec![0.0f64; w]];
    let mut ok = vec![false; w];
    for y in 0..hh {
        let vy = y + h - r;
        let (ew, ns) = view.georef.cell_size_m(view.core.y + vy as i64 - h as i64);
        // Rows above, at and below, from the column left of region column 0.
        let row = |yy: usize| &data[yy * gw + h - r - 1..yy * gw + h - r + w + 1];
        let (a, b, c) = (row(vy - 1), row(vy), row(vy + 1));
        // Two passes per row: the floating-point normals (branch-free, so
        // the divisions and square roots vectorise), then their fixed point.
        for x in 0..w {
            let win = [
                a[x] as f64,
                a[x + 1] as f64,
                a[x + 2] as f64,
                b[x] as f64,
                b[x + 1] as f64,
                b[x + 2] as f64,
                c[x] as f64,
                c[x + 1] as f64,
                c[x + 2] as f64,
            ];
            ok[x] = !win.iter().sum::<f64>().is_nan();
            let (p, q) = horn_gradient(&win, ew, ns);
            let d = (1.0 + p * p + q * q).sqrt();
            nb[0][x] = -p / d;
            nb[1][x] = -q / d;
            nb[2][x] = 1.0 / d;
        }
        let i0 = y * w;
        for x in 0..w {
            if !ok[x] {
                continue;
            }
            for j in 0..3 {
                let v = fix(nb[j][x]);
                f.hi[j][i0 + x] = (v >> 30) as i32;
                f.lo[j][i0 + x] = (v & ((1 << 30) - 1)) as i32;
            }
            f.count[i0 + x] = 1;
        }
    }
    f
}

/// Spherical standard deviation of the unit normals in the window (Lindsay
/// et al. 2019): `s = √(−2 ln R̄)` in degrees, with `R̄ = |Σ n| / N` the mean
/// resultant length. Normals are those of the unsmoothed DEM (Lindsay et al.
/// smooth first; smooth the input for their multiscale variant). The sums
/// are exact integers (fixed-point normals) kept as running column sums
/// slid down the rows and running row sums along them: O(1) per cell, no
/// tables, and the same bits whatever the tiling. They are kept per 30-bit
/// limb ([`NormalField`]) in i64: with at most (2·2000+1)² < 2²⁴ cells per
/// window ([`MAX_RADIUS_CELLS`]), |Σhi| ≤ 2⁵⁴ and Σlo < 2⁵⁴, so nothing
/// overflows, the row loops are plain i64 adds (vectorised), and
/// `Σv = Σhi·2³⁰ + Σlo` is formed in i128 once per cell. `field` covers the
/// core plus `big ≥ r` cells on each side.
#[allow(clippy::needless_range_loop)] // parallel per-column arrays
fn roughness(view: &TileView<f32>, field: &NormalField, big: usize, r: usize, o: &mut Grid<f32>) {
    const _: () = assert!(MAX_RADIUS_CELLS <= 2000);
    let h = view.halo;
    let gw = view.grid.width();
    let data = view.grid.data();
    let (cw, ch) = (view.core.w, view.core.h);
    if cw == 0 || ch == 0 {
        return;
    }
    let w = cw + 2 * big;
    let off = big - r;
    let k = 2 * r + 1;
    let cols = cw + 2 * r;
    // Column c of the sums is region column off + c. Seven running column
    // sums: hi and lo limbs of x, y, z, and the count.
    let mut cs: [Vec<i64>; 7] = std::array::from_fn(|_| vec![0i64; cols]);
    let lane = |j: usize| -> &[i32] {
        match j {
            0..=2 => &field.hi[j],
            3..=5 => &field.lo[j - 3],
            _ => &field.count,
        }
    };
    for ry in off..off + k {
        let base = ry * w + off;
        for (j, c) in cs.iter_mut().enumerate() {
            let src = &lane(j)[base..base + cols];
            for (c, &v) in c.iter_mut().zip(src) {
                *c += v as i64;
            }
        }
    }
    let f = |s: i128| super::windowed::fixed_to_f64(s, NORMAL_FRAC);
    let (mut len2, mut cnt) = (vec![0.0f64; cw], vec![0.0f64; cw]);
    for y in 0..ch {
        if y > 0 {
            let (a, b) = ((off + y + k - 1) * w + off, (off + y - 1) * w + off);
            for (j, c) in cs.iter_mut().enumerate() {
                let l = lane(j);
                let (na, ob) = (&l[a..a + cols], &l[b..b + cols]);
                for ((c, &p), &m) in c.iter_mut().zip(na).zip(ob) {
                    *c += p as i64 - m as i64;
                }
            }
        }
        let mut s = [0i64; 7];
        for c in 0..k {
            for j in 0..7 {
                s[j] += cs[j][c];
            }
        }
        // Three passes per row: the exact sums as f64 (|Σn|², N), then R̄
        // (vectorised square roots and divisions), its logarithm (libm) and
        // the degrees; empty windows and nodata centres are NaN.
        let zrow = &data[(y + h) * gw + h..(y + h) * gw + h + cw];
        for x in 0..cw {
            if x > 0 {
                for j in 0..7 {
                    s[j] += cs[j][x + k - 1] - cs[j][x - 1];
                }
            }
            let sum = |j: usize| f(((s[j] as i128) << 30) + s[j + 3] as i128);
            let (sx, sy, sz) = (sum(0), sum(1), sum(2));
            len2[x] = sx * sx + sy * sy + sz * sz;
            cnt[x] = if zrow[x].is_nan() || s[6] == 0 {
                f64::NAN
            } else {
                s[6] as f64
            };
        }
        for x in 0..cw {
            // Not `min`: a NaN (no value) must stay NaN.
            let v = len2[x].sqrt() / cnt[x];
            len2[x] = if v > 1.0 { 1.0 } else { v };
        }
        for v in len2.iter_mut() {
            *v = v.ln();
        }
        let orow = &mut o.data_mut()[y * cw..(y + 1) * cw];
        for (o, &l) in orow.iter_mut().zip(&len2) {
            *o = if l.is_nan() {
                f32::NAN
            } else {
                (-2.0 * l).max(0.0).sqrt().to_degrees() as f32
            };
        }
    }
}

/// Compute `specs` on `src` in one tiled pass, writing metric `k` to
/// `outputs[k]` (`.tif` or `.tiles`, f32 with nodata [`METRIC_NODATA`], or
/// for metrics in the DEM's unit the value [`output_nodata`] chooses).
pub fn compute(
    src: &dyn RasterSource,
    specs: &[MetricSpec],
    outputs: &[PathBuf],
    oo: &OutputOptions,
    tile: Option<usize>,
    cfg: &EngineConfig,
) -> Result<()> {
    if outputs.len() != specs.len() {
        return Err(Error::invalid(format!(
            "{} metric(s) requested but {} output path(s) given",
            specs.len(),
            outputs.len()
        )));
    }
    // Validate every spec (radii, ranges) before any pass runs.
    resolve(specs, src.info())?;
    // descr4: local metrics in one tiled pass, whole-raster ones in their
    // own global passes.
    let (whole, local): (Vec<usize>, Vec<usize>) =
        (0..specs.len()).partition(|&i| super::peak_dw::is_whole_raster(specs[i].kind));
    if !local.is_empty() {
        let ls: Vec<MetricSpec> = local.iter().map(|&i| specs[i].clone()).collect();
        let lp: Vec<PathBuf> = local.iter().map(|&i| outputs[i].clone()).collect();
        let step = MultiMetric::new(&ls, src.info())?;
        let nd = output_nodata(src, &ls)?;
        let types: Vec<(DType, Option<f64>)> = ls
            .iter()
            .map(|s| {
                (
                    DType::F32,
                    Some(if s.def().units == "z" {
                        nd
                    } else {
                        METRIC_NODATA
                    }),
                )
            })
            .collect();
        crate::exec::plan::run_local_to_paths(&step, &[src], &lp, &types, oo, tile, cfg)?;
    }
    if !whole.is_empty() {
        let ws: Vec<MetricSpec> = whole.iter().map(|&i| specs[i].clone()).collect();
        let wp: Vec<PathBuf> = whole.iter().map(|&i| outputs[i].clone()).collect();
        super::peak_dw::compute_paths(src, &ws, &wp, oo, tile, cfg)?;
    }
    Ok(())
}

/// Nodata of the outputs in the DEM's own unit (`z`: mean, TPI, relief,
/// dominance, ...), whose values lie in `[min(lo, lo − hi), hi − lo]` for
/// valid input cells in `[lo, hi]` (a window mean lies between the extremes;
/// a difference of two cells is at least `lo − hi`). [`METRIC_NODATA`]
/// (−9999) unless that bound comes within 1 m of it, then the rule of
/// [`crate::exec::output::below`] (−99 999, ...): bathymetry and other
/// DEMs below −9999 m would otherwise turn real values into nodata. One read
/// pass over the input, only when a `z` metric is asked for and the input
/// type can reach −9999 (u8 and i8 inputs cannot). Other metrics (angles,
/// ratios, curvatures, indices) keep −9999.
pub fn output_nodata(src: &dyn RasterSource, specs: &[MetricSpec]) -> Result<f64> {
    if !specs.iter().any(|s| s.def().units == "z")
        || matches!(src.info().dtype, DType::U8 | DType::I8)
    {
        return Ok(METRIC_NODATA);
    }
    let bound = crate::exec::output::valid_range(src)?
        .map(|(lo, hi)| (lo as f64).min(lo as f64 - hi as f64) as f32);
    Ok(crate::exec::output::below(bound).unwrap_or(f64::NAN))
}

/// Check that `specs` can run on a raster described by `info` (local or
/// whole-raster metrics), as [`compute`] would, without running them.
pub fn check(specs: &[MetricSpec], info: &RasterInfo) -> Result<()> {
    let local: Vec<MetricSpec> = specs
        .iter()
        .filter(|s| !super::peak_dw::is_whole_raster(s.kind))
        .cloned()
        .collect();
    resolve(specs, info)?;
    if !local.is_empty() {
        MultiMetric::new(&local, info)?;
    }
    Ok(())
}
