//! Many metrics in one pass: [`MultiMetric`] is a local step with one f32
//! output per requested metric (NaN = nodata) and the largest halo any of
//! them needs. Each tile is a [`Tile`]: the products several metrics read
//! (quadric coefficients, one summed-area table, unit normals, horizon
//! scans) are computed once per tile and shared; each metric's kernel then
//! runs once per tile ([`super::Metric::run`]).
//!
//! Nodata: a cell whose value is nodata is nodata in every output; 3x3
//! metrics (including Evans curvatures, radius 1) are nodata where a
//! neighbour is nodata or beyond the raster (gdaldem's default); windowed
//! metrics (including Wood's curvatures, radius > 1) exclude nodata cells
//! and cells beyond the raster from their windows.

use super::registry::{metric, MetricDef, ScratchClass};
use super::spec::{resolve, MetricSpec, Resolved};
use super::tile::Tile;
use crate::error::{Error, Result};
use crate::exec::output::{NodataRule, OutputSpec};
use crate::exec::{EngineConfig, LocalStep};
use crate::io::OutputOptions;
use crate::raster::{DType, Grid, RasterInfo, RasterSource, TileView};
use serde_json::json;
use std::path::PathBuf;

/// Nodata value written for metric outputs in files (gdaldem's -9999, as slope).
pub const METRIC_NODATA: f64 = -9999.0;

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
        // Whole-raster metrics run their own global passes.
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
    /// memory budgets: the engine's own estimate counts views and outputs
    /// only. Each scratch class ([`super::Metric::scratch`]) counts once,
    /// at its largest request.
    pub fn scratch_estimate(&self, tile: usize) -> u64 {
        let core = (tile * tile) as u64;
        let mut classes: Vec<(ScratchClass, u64)> = Vec::new();
        for m in &self.metrics {
            if let Some((c, b)) = metric(m.spec.kind).scratch(m, tile) {
                match classes.iter_mut().find(|e| e.0 == c) {
                    Some(e) => e.1 = e.1.max(b),
                    None => classes.push((c, b)),
                }
            }
        }
        classes.iter().map(|e| e.1).sum::<u64>() + 3 * core * 4
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
    fn outputs(&self) -> Vec<OutputSpec> {
        self.metrics
            .iter()
            .map(|m| output_spec(m.spec.def()))
            .collect()
    }
    fn run(&self, inputs: &[TileView<f32>], out: &mut [Grid<f32>]) -> Result<()> {
        if inputs.is_empty() {
            return Err(Error::invalid("metrics need one input"));
        }
        if out.len() != self.metrics.len() {
            return Err(Error::invalid("metrics: wrong number of outputs"));
        }
        let mut t = Tile::new(inputs, &self.path, &self.metrics)?;
        for (m, o) in self.metrics.iter().zip(out.iter_mut()) {
            metric(m.spec.kind).run(&mut t, m, o)?;
        }
        Ok(())
    }
}

/// Compute `specs` on `src` in one tiled pass, writing metric `k` to
/// `outputs[k]` (`.tif` or `.tiles`, f32 with nodata [`METRIC_NODATA`], or
/// for metrics in the DEM's unit the value [`output_spec`] chooses).
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
    // Local metrics in one tiled pass, whole-raster ones in their
    // own global passes.
    let (whole, local): (Vec<usize>, Vec<usize>) =
        (0..specs.len()).partition(|&i| super::peak_dw::is_whole_raster(specs[i].kind));
    if !local.is_empty() {
        let ls: Vec<MetricSpec> = local.iter().map(|&i| specs[i].clone()).collect();
        let lp: Vec<PathBuf> = local.iter().map(|&i| outputs[i].clone()).collect();
        let step = MultiMetric::new(&ls, src.info())?;
        crate::exec::plan::run_local_to_paths(&step, &[src], &lp, oo, tile, cfg)?;
    }
    if !whole.is_empty() {
        let ws: Vec<MetricSpec> = whole.iter().map(|&i| specs[i].clone()).collect();
        let wp: Vec<PathBuf> = whole.iter().map(|&i| outputs[i].clone()).collect();
        super::peak_dw::compute_paths(src, &ws, &wp, oo, tile, cfg)?;
    }
    Ok(())
}

/// The output of metric `def` in a file: f32 of its kind; metrics in the
/// DEM's own unit (`z`: mean, TPI, relief, dominance, ...) take their nodata
/// below every value they can reach ([`NodataRule::BelowDifference`]: a
/// window mean lies between the extremes, a difference of two cells is at
/// least `lo − hi`), so bathymetry and other DEMs below −9999 m do not turn
/// real values into nodata; every other metric (angles, ratios, curvatures,
/// indices) writes nodata [`METRIC_NODATA`].
pub fn output_spec(def: &MetricDef) -> OutputSpec {
    OutputSpec {
        dtype: DType::F32,
        nodata: if def.units == "z" {
            NodataRule::BelowDifference
        } else {
            NodataRule::Value(METRIC_NODATA)
        },
        kind: def.output,
    }
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metrics::parse_specs;
    use crate::metrics::registry::{OutputKind, METRICS};
    use crate::raster::{Crs, GeoRef, MemRaster};

    #[test]
    fn every_metric_output_has_its_registered_kind() {
        // The kinds of the metrics' values as their sources define them,
        // written out here: class codes and the one circular quantity.
        let categorical = [
            "geomorphon",
            "geomorphon_pattern",
            "geomorphon_canonical",
            "weiss_landform",
            "dikau_form",
            "shary_landform",
        ];
        let src = MemRaster::from_grid(
            Grid::new(3000, 3000, 0.0f32),
            GeoRef::north_up(0.0, 0.0, 30.0, Crs::projected(32611)),
        );
        for m in METRICS {
            let def = m.def();
            let want = if categorical.contains(&def.name) {
                OutputKind::Categorical
            } else if def.name == "aspect" {
                OutputKind::Angle
            } else {
                OutputKind::Continuous
            };
            assert_eq!(def.output, want, "{}", def.name);
            let spec = output_spec(def);
            assert_eq!((spec.dtype, spec.kind), (DType::F32, want), "{}", def.name);
            let nodata = if def.units == "z" {
                NodataRule::BelowDifference
            } else {
                NodataRule::Value(-9999.0)
            };
            assert_eq!(spec.nodata, nodata, "{}", def.name);
            if !super::super::peak_dw::is_whole_raster(def.kind) {
                let step = MultiMetric::new(&parse_specs(def.name).unwrap(), src.info()).unwrap();
                assert_eq!(step.outputs(), vec![spec], "{}", def.name);
            }
        }
    }
}
