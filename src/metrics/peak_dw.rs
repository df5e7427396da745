//! Multi-scale peakedness after Deng & Wilson (2008), "Multi-scale and
//! multi-criteria mapping of mountain peaks as fuzzy entities", IJGIS 22(2),
//! with the choices of the terrain-descriptors survey's reference code
//! (Argudo et al., `HeightField::Peakness`): at each scale (square windows
//! of half-side 5, 20 and 50 cells) every cell gets four factors
//!
//! 1. relief: max − min of the window;
//! 2. slope: mean gradient norm (Horn) of the window;
//! 3. relative elevation: (z − min) / (max − min) over the window three
//!    times as wide (0 where that window is flat);
//! 4. isolation: 1 / (1 + number of peaks in the window three times as wide),
//!
//! where a *peak* of a scale is the highest cell of its window whose relief
//! exceeds 20, 80 and 80 (z units) at the three scales. Two outputs:
//!
//! - `peak_prototypicality`: per scale, the mean of the four factors each
//!   min–max normalised over the WHOLE raster; weighted 1 / 1.2 / 1.4 over
//!   the scales;
//! - `peakedness_dw` (the survey's "peakness similarity"): per scale, the
//!   centroid of the raw factors of the `top` share (default 20 %) of the
//!   scale's peaks with the highest prototypicality; every cell's distance to
//!   it, each factor divided by its variance over the peaks; the similarity
//!   `(d_max − d) / (d_max − d_min)` with the extremes over the whole raster;
//!   weighted as above.
//!
//! Both need whole-raster statistics, so they are two tiled global passes
//! ([`PeakStats`]: map = per-tile factor ranges and peaks, reduce =
//! normalisation, centroid and variances, apply = prototypicality;
//! [`PeakSimilarity`]: map = per-tile distance ranges, reduce = their
//! extremes, apply = similarity). Every per-cell quantity is exact in the
//! window (running extrema, an exact fixed-point summed-area table, integer
//! peak counts) and the reduces order the peaks by global cell index, so the
//! result does not depend on the tiling or the thread count.
//!
//! Differences from the reference code (documented, deliberate): windows are
//! centred (2r+1)² squares (the reference's slope SAT covers a 2r × 2r box
//! shifted by half a cell); cells without a full 3x3 neighbourhood have no
//! slope and are left out of the slope mean (the reference uses one-sided
//! differences); a flat extended window gives relative elevation 0 (the
//! reference divides 0 by 0); a factor with zero variance over the peaks is
//! left out of the distance (the reference divides by 0); a scale without
//! peaks is left out of the similarity and the weights are renormalised
//! (the reference reads an empty queue). Nodata cells are nodata and are
//! excluded from every window and statistic.
//!
//! Memory: the reduce holds every peak (40 bytes each and scale); peaks
//! are local maxima over windows of at least 11 x 11 cells, so there are at
//! most about one per 36 cells except on flat summit plateaus.

// The four factors are parallel fixed-size arrays indexed together.
#![allow(clippy::needless_range_loop)]

use super::directional::gradient_region;
use super::param::TOP;
use super::registry::{metric_def, Metric, MetricDef};
use super::registry::{MetricKind, Resolved};
use super::tile::Tile;
use super::windowed::{box_max, Sat};
use crate::error::{Error, Result};
use crate::exec::output::OutputSpec;
use crate::exec::{Engine, EngineConfig, GlobalStep, MemSink, Run, TileSink};
use crate::raster::RasterInfo;
use crate::raster::{DType, Grid, RasterSource, TileId, TileLayout, TileView};
use serde::{Deserialize, Serialize};
use serde_json::json;

/// Window half-sides (cells) of the three scales (the reference's radii).
pub const SCALES: [usize; 3] = [5, 20, 50];
/// Least relief (z units) of a peak's window, per scale.
pub const PEAK_RELIEF: [f64; 3] = [20.0, 80.0, 80.0];
/// Weights of the scales in both outputs.
pub const WEIGHTS: [f64; 3] = [1.0, 1.2, 1.4];
/// The extended window (relative elevation, isolation) is this many times wider.
pub const EXTENDED: usize = 3;
/// Halo both passes need: peaks counted in the extended window around a core
/// cell are themselves maxima over their own window.
pub const HALO: usize = (EXTENDED + 1) * SCALES[2];
/// Default share of the peaks (by prototypicality) averaged into the centroid.
pub const DEFAULT_TOP: f64 = 0.2;
/// Most peaks (all scales) the reduce accepts (40 bytes each).
pub const MAX_PEAKS: u64 = 1 << 26;

const NF: usize = 4;

/// True for the metrics computed here (whole-raster statistics: they do not
/// run in [`super::MultiMetric`]'s local pass).
pub fn is_whole_raster(k: MetricKind) -> bool {
    super::registry::metric(k).whole_raster()
}

/// The four factors of every core cell at one scale (NaN = no value) and
/// which core cells are peaks.
#[derive(Debug, Clone)]
pub struct ScaleFactors {
    /// `f[k][y * w + x]`: relief, mean slope, relative elevation, isolation.
    pub f: [Vec<f64>; NF],
    /// Peak flags of the core cells.
    pub peak: Vec<bool>,
}

/// The core plus `m` cells on each side of `view` as f64 (NaN = nodata).
fn region(view: &TileView<f32>, m: usize) -> Vec<f64> {
    let (h, gw) = (view.halo, view.grid.width());
    let (w, hh) = (view.core.w + 2 * m, view.core.h + 2 * m);
    let mut v = Vec::with_capacity(w * hh);
    for y in 0..hh {
        let start = (y + h - m) * gw + h - m;
        v.extend(view.grid.data()[start..start + w].iter().map(|&z| z as f64));
    }
    v
}

/// Square-window max and min (half-side `r`) of the inner cells of a region.
fn box_max_min(vals: &[f64], w: usize, h: usize, r: usize) -> (Vec<f64>, Vec<f64>) {
    let mx = box_max(vals, w, h, r);
    let neg: Vec<f64> = vals.iter().map(|v| -v).collect();
    let mn = box_max(&neg, w, h, r).into_iter().map(|v| -v).collect();
    (mx, mn)
}

/// The factors of scale `si` for the core cells of `view` (halo ≥ 4r).
pub fn factors(view: &TileView<f32>, si: usize, path: &str) -> Result<ScaleFactors> {
    let r = SCALES[si];
    let e = EXTENDED * r;
    if view.halo < e + r {
        return Err(Error::invalid(format!(
            "peakedness_dw: tile halo {} is smaller than {}",
            view.halo,
            e + r
        )));
    }
    let (cw, ch) = (view.core.w, view.core.h);
    let n = cw * ch;
    // Peaks over core + e: maxima of their r-window with enough relief.
    let m = e + r;
    let vals = region(view, m);
    let (vw, vh) = (cw + 2 * m, ch + 2 * m);
    let (rmax, rmin) = box_max_min(&vals, vw, vh, r);
    let (pw, ph) = (cw + 2 * e, ch + 2 * e);
    // Integer summed-area table of the peak flags (exact counts).
    let mut count = vec![0u32; (pw + 1) * (ph + 1)];
    let mut peak_core = vec![false; n];
    for y in 0..ph {
        let mut row = 0u32;
        for x in 0..pw {
            let z = vals[(y + r) * vw + x + r];
            let i = y * pw + x;
            let is = !z.is_nan() && z >= rmax[i] && rmax[i] - rmin[i] > PEAK_RELIEF[si];
            row += is as u32;
            count[(y + 1) * (pw + 1) + x + 1] = count[y * (pw + 1) + x + 1] + row;
            if is && (e..e + cw).contains(&x) && (e..e + ch).contains(&y) {
                peak_core[(y - e) * cw + x - e] = true;
            }
        }
    }
    // Extended window extrema at the core.
    let ext = region(view, e);
    let (emax, emin) = box_max_min(&ext, cw + 2 * e, ch + 2 * e, e);
    // Mean Horn gradient norm over the r-window, exact fixed point.
    let (p, q) = gradient_region(view, r);
    let slope: Vec<f64> = p
        .iter()
        .zip(&q)
        .map(|(a, b)| (a * a + b * b).sqrt())
        .collect();
    let sat = Sat::new(&slope, cw + 2 * r, ch + 2 * r, false, path)?;
    let mut f: [Vec<f64>; NF] = std::array::from_fn(|_| vec![f64::NAN; n]);
    let mut peak = vec![false; n];
    for y in 0..ch {
        for x in 0..cw {
            let z = vals[(y + m) * vw + x + m];
            if z.is_nan() {
                continue;
            }
            let i = y * cw + x;
            let pi = (y + e) * pw + x + e;
            let relief = rmax[pi] - rmin[pi];
            let mean_slope = sat.window(x, y, x + 2 * r + 1, y + 2 * r + 1).mean();
            let span = emax[i] - emin[i];
            let rel = if span > 0.0 {
                (z - emin[i]) / span
            } else {
                0.0
            };
            let (x0, y0, x1, y1) = (x, y, x + 2 * e + 1, y + 2 * e + 1);
            let w1 = pw + 1;
            let c = count[y1 * w1 + x1] + count[y0 * w1 + x0]
                - count[y0 * w1 + x1]
                - count[y1 * w1 + x0];
            let iso = 1.0 / (1.0 + c as f64);
            let v = [relief, mean_slope, rel, iso];
            if v.iter().all(|a| a.is_finite()) {
                for k in 0..NF {
                    f[k][i] = v[k];
                }
                peak[i] = peak_core[i];
            }
        }
    }
    Ok(ScaleFactors { f, peak })
}

/// One peak of one scale: global cell index and raw factors.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PeakRecord {
    pub idx: u64,
    pub f: [f64; NF],
}

/// What one tile tells about one scale.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct ScaleSummary {
    /// Factor ranges over the tile's valid cells (None: no valid cell).
    pub range: Option<([f64; NF], [f64; NF])>,
    /// The tile's peaks.
    pub peaks: Vec<PeakRecord>,
}

/// Whole-raster statistics of one scale.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ScaleStats {
    /// Factor minima and maxima over the raster's valid cells.
    pub lo: [f64; NF],
    pub hi: [f64; NF],
    /// Number of peaks.
    pub peaks: u64,
    /// Centroid of the raw factors of the top peaks (None: no peak).
    pub centroid: Option<[f64; NF]>,
    /// Population variance of each factor over the peaks.
    pub variance: [f64; NF],
}

impl ScaleStats {
    /// Mean of the four min–max normalised factors (a constant factor
    /// normalises to 1, as the reference's `normalize`).
    pub fn proto(&self, v: &[f64; NF]) -> f64 {
        let mut s = 0.0;
        for k in 0..NF {
            let d = self.hi[k] - self.lo[k];
            s += if d > 0.0 {
                (v[k] - self.lo[k]) / d
            } else {
                1.0
            };
        }
        s / NF as f64
    }

    /// Variance-scaled distance to the centroid (factors with zero variance
    /// left out); None without peaks.
    pub fn distance(&self, v: &[f64; NF]) -> Option<f64> {
        let c = self.centroid?;
        let mut d = 0.0;
        for k in 0..NF {
            if self.variance[k] > 0.0 {
                let t = v[k] - c[k];
                d += t * t / self.variance[k];
            }
        }
        Some(d.sqrt())
    }
}

/// First pass: factor ranges and peaks (map), normalisation, centroids and
/// variances (reduce), prototypicality (apply, one output).
#[derive(Debug, Clone)]
pub struct PeakStats {
    /// Share of the peaks in the centroid, 0 < top ≤ 1.
    pub top: f64,
    /// Raster width (global cell indices).
    pub width: usize,
    /// Input path, for messages.
    pub path: String,
}

fn cell_values(sf: &ScaleFactors, i: usize) -> Option<[f64; NF]> {
    let v = [sf.f[0][i], sf.f[1][i], sf.f[2][i], sf.f[3][i]];
    (!v[0].is_nan()).then_some(v)
}

/// The one input view of a pass, or an error naming the step (`what`)
/// when the engine passed none.
fn one_input<'a>(inputs: &'a [TileView<f32>], what: &str) -> Result<&'a TileView<f32>> {
    inputs
        .first()
        .ok_or_else(|| Error::invalid(format!("{what} needs one input")))
}

/// The parameters every output of Deng & Wilson's statistics records (the
/// scales, the peak relief and the weights), with `key` = `value` added.
fn dw_params(key: &str, value: serde_json::Value) -> serde_json::Value {
    let mut p = json!({ "scales": SCALES, "peak_relief": PEAK_RELIEF, "weights": WEIGHTS });
    p[key] = value;
    p
}

/// The one input view and the one output grid of an `apply`, or an error
/// naming the step (`what`) when the engine passed none.
fn one_in_out<'a, 'b>(
    inputs: &'a [TileView<f32>],
    out: &'b mut [Grid<f32>],
    what: &str,
) -> Result<(&'a TileView<f32>, &'b mut Grid<f32>)> {
    let view = one_input(inputs, what)?;
    let o = out
        .first_mut()
        .ok_or_else(|| Error::invalid(format!("{what}: no output")))?;
    Ok((view, o))
}

impl GlobalStep for PeakStats {
    type In = f32;
    type Out = f32;
    type Summary = Vec<ScaleSummary>;
    type Solution = Vec<ScaleStats>;
    type Slice = Vec<ScaleStats>;
    fn name(&self) -> String {
        "peak_prototypicality".into()
    }
    fn params(&self) -> serde_json::Value {
        dw_params("top", json!(self.top))
    }
    fn halo(&self) -> usize {
        HALO
    }
    fn outputs(&self) -> Vec<OutputSpec> {
        vec![OutputSpec::continuous(DType::F32, super::METRIC_NODATA)]
    }
    fn map(&self, inputs: &[TileView<f32>]) -> Result<Self::Summary> {
        let view = one_input(inputs, "peak statistics")?;
        let mut out = Vec::with_capacity(SCALES.len());
        for si in 0..SCALES.len() {
            let sf = factors(view, si, &self.path)?;
            let mut s = ScaleSummary::default();
            let cw = view.core.w;
            for i in 0..cw * view.core.h {
                let Some(v) = cell_values(&sf, i) else {
                    continue;
                };
                let (lo, hi) = s.range.get_or_insert((v, v));
                for k in 0..NF {
                    lo[k] = lo[k].min(v[k]);
                    hi[k] = hi[k].max(v[k]);
                }
                if sf.peak[i] {
                    let gx = view.core.x as u64 + (i % cw) as u64;
                    let gy = view.core.y as u64 + (i / cw) as u64;
                    s.peaks.push(PeakRecord {
                        idx: gy * self.width as u64 + gx,
                        f: v,
                    });
                }
            }
            out.push(s);
        }
        Ok(out)
    }
    fn reduce(
        &self,
        _layout: &TileLayout,
        summaries: Vec<Self::Summary>,
    ) -> Result<Self::Solution> {
        let total: u64 = summaries
            .iter()
            .flat_map(|t| t.iter().map(|s| s.peaks.len() as u64))
            .sum();
        if total > MAX_PEAKS {
            return Err(Error::too_large(
                &self.path,
                format!("peakedness_dw found {total} peaks (limit {MAX_PEAKS}): the DEM has large flat summit plateaus or is too large for the in-memory peak list; crop it"),
            ));
        }
        let mut tiles: Vec<Vec<ScaleSummary>> = summaries;
        let mut stats = Vec::with_capacity(SCALES.len());
        for si in 0..SCALES.len() {
            let mut range: Option<([f64; NF], [f64; NF])> = None;
            let mut peaks: Vec<PeakRecord> = Vec::new();
            for t in tiles.iter_mut() {
                let Some(s) = t.get_mut(si) else {
                    return Err(Error::invalid(
                        "peak statistics: a tile summary misses a scale",
                    ));
                };
                if let Some((a, b)) = s.range {
                    let (lo, hi) = range.get_or_insert((a, b));
                    for k in 0..NF {
                        lo[k] = lo[k].min(a[k]);
                        hi[k] = hi[k].max(b[k]);
                    }
                }
                peaks.append(&mut s.peaks);
            }
            let (lo, hi) = range.unwrap_or(([0.0; NF], [0.0; NF]));
            let mut st = ScaleStats {
                lo,
                hi,
                peaks: peaks.len() as u64,
                centroid: None,
                variance: [0.0; NF],
            };
            if !peaks.is_empty() {
                // Global index order: the sums below do not depend on the tiling.
                peaks.sort_by_key(|p| p.idx);
                let n = peaks.len() as f64;
                for k in 0..NF {
                    let mean = peaks.iter().map(|p| p.f[k]).sum::<f64>() / n;
                    st.variance[k] = peaks.iter().map(|p| (p.f[k] - mean).powi(2)).sum::<f64>() / n;
                }
                // Highest prototypicality first; ties: higher index first.
                let mut order: Vec<(f64, u64, usize)> = peaks
                    .iter()
                    .enumerate()
                    .map(|(j, p)| (st.proto(&p.f), p.idx, j))
                    .collect();
                order.sort_by(|a, b| b.0.total_cmp(&a.0).then(b.1.cmp(&a.1)));
                let nc = ((peaks.len() as f64 * self.top).floor() as usize).clamp(1, peaks.len());
                let mut c = [0.0; NF];
                for &(_, _, j) in &order[..nc] {
                    for k in 0..NF {
                        c[k] += peaks[j].f[k];
                    }
                }
                for v in c.iter_mut() {
                    *v /= nc as f64;
                }
                st.centroid = Some(c);
            }
            stats.push(st);
        }
        Ok(stats)
    }
    fn slice(&self, solution: &Self::Solution, _id: TileId) -> Self::Slice {
        solution.clone()
    }
    fn apply(
        &self,
        inputs: &[TileView<f32>],
        slice: &Self::Slice,
        out: &mut [Grid<f32>],
    ) -> Result<()> {
        let (view, o) = one_in_out(inputs, out, "peak prototypicality")?;
        let wsum: f64 = WEIGHTS.iter().sum();
        let mut acc = vec![0.0f64; view.core.w * view.core.h];
        let mut valid = vec![true; acc.len()];
        for (si, st) in slice.iter().enumerate().take(SCALES.len()) {
            let sf = factors(view, si, &self.path)?;
            for (i, a) in acc.iter_mut().enumerate() {
                match cell_values(&sf, i) {
                    Some(v) => *a += WEIGHTS[si] * st.proto(&v),
                    None => valid[i] = false,
                }
            }
        }
        for ((o, a), ok) in o.data_mut().iter_mut().zip(&acc).zip(&valid) {
            *o = if *ok { (a / wsum) as f32 } else { f32::NAN };
        }
        Ok(())
    }
}

/// Second pass: distance ranges (map/reduce) and similarity (apply).
#[derive(Debug, Clone)]
pub struct PeakSimilarity {
    pub stats: Vec<ScaleStats>,
    pub path: String,
}

impl PeakSimilarity {
    /// Refuses statistics without any peak (the similarity is undefined).
    pub fn new(stats: Vec<ScaleStats>, path: &str) -> Result<PeakSimilarity> {
        if stats.iter().all(|s| s.centroid.is_none()) {
            return Err(Error::invalid(format!(
                "{path}: peakedness_dw found no peak at any scale (a peak is the highest cell of a {}x{} window with relief > {} z units): the DEM is too flat or too small for this metric",
                2 * SCALES[0] + 1,
                2 * SCALES[0] + 1,
                PEAK_RELIEF[0]
            )));
        }
        Ok(PeakSimilarity {
            stats,
            path: path.to_string(),
        })
    }

    /// Distances of the core cells to each scale's centroid (NaN: nodata or
    /// no peak at that scale).
    fn distances(&self, view: &TileView<f32>) -> Result<Vec<Vec<f64>>> {
        let n = view.core.w * view.core.h;
        let mut out = Vec::with_capacity(SCALES.len());
        for (si, st) in self.stats.iter().enumerate().take(SCALES.len()) {
            let mut d = vec![f64::NAN; n];
            if st.centroid.is_some() {
                let sf = factors(view, si, &self.path)?;
                for (i, d) in d.iter_mut().enumerate() {
                    if let Some(v) = cell_values(&sf, i) {
                        *d = st.distance(&v).unwrap_or(f64::NAN);
                    }
                }
            }
            out.push(d);
        }
        Ok(out)
    }
}

impl GlobalStep for PeakSimilarity {
    type In = f32;
    type Out = f32;
    /// Per scale, (min, max) of the distance over the tile's valid cells.
    type Summary = Vec<Option<(f64, f64)>>;
    type Solution = Vec<Option<(f64, f64)>>;
    type Slice = Vec<Option<(f64, f64)>>;
    fn name(&self) -> String {
        "peakedness_dw".into()
    }
    fn params(&self) -> serde_json::Value {
        dw_params("stats", json!(self.stats))
    }
    fn halo(&self) -> usize {
        HALO
    }
    fn outputs(&self) -> Vec<OutputSpec> {
        vec![OutputSpec::continuous(DType::F32, super::METRIC_NODATA)]
    }
    fn map(&self, inputs: &[TileView<f32>]) -> Result<Self::Summary> {
        let view = one_input(inputs, "peakedness_dw")?;
        let ds = self.distances(view)?;
        Ok(ds
            .iter()
            .map(|d| {
                d.iter()
                    .filter(|v| !v.is_nan())
                    .fold(None, |acc, &v| match acc {
                        None => Some((v, v)),
                        Some((a, b)) => Some((f64::min(a, v), f64::max(b, v))),
                    })
            })
            .collect())
    }
    fn reduce(
        &self,
        _layout: &TileLayout,
        summaries: Vec<Self::Summary>,
    ) -> Result<Self::Solution> {
        let mut out: Vec<Option<(f64, f64)>> = vec![None; SCALES.len()];
        for t in &summaries {
            for (o, s) in out.iter_mut().zip(t) {
                if let Some((a, b)) = *s {
                    *o = Some(match *o {
                        None => (a, b),
                        Some((c, d)) => (c.min(a), d.max(b)),
                    });
                }
            }
        }
        Ok(out)
    }
    fn slice(&self, solution: &Self::Solution, _id: TileId) -> Self::Slice {
        solution.clone()
    }
    fn apply(
        &self,
        inputs: &[TileView<f32>],
        slice: &Self::Slice,
        out: &mut [Grid<f32>],
    ) -> Result<()> {
        let (view, o) = one_in_out(inputs, out, "peakedness_dw")?;
        let ds = self.distances(view)?;
        let used: Vec<usize> = (0..SCALES.len().min(self.stats.len()))
            .filter(|&s| self.stats[s].centroid.is_some())
            .collect();
        let wsum: f64 = used.iter().map(|&s| WEIGHTS[s]).sum();
        for (i, o) in o.data_mut().iter_mut().enumerate() {
            let mut acc = 0.0;
            let mut ok = true;
            for &s in &used {
                let d = ds[s][i];
                match slice.get(s).copied().flatten() {
                    Some((lo, hi)) if !d.is_nan() => {
                        let sim = if hi > lo { (hi - d) / (hi - lo) } else { 1.0 };
                        acc += WEIGHTS[s] * sim;
                    }
                    _ => ok = false,
                }
            }
            *o = if ok { (acc / wsum) as f32 } else { f32::NAN };
        }
        Ok(())
    }
}

/// Run both passes over `layout`: the statistics (and the prototypicality
/// into `proto` if given), then the similarity into `similarity` if given.
/// Returns the statistics.
pub fn run(
    src: &dyn RasterSource,
    top: f64,
    layout: TileLayout,
    cfg: &EngineConfig,
    proto: Option<Box<dyn TileSink>>,
    similarity: Option<Box<dyn TileSink>>,
) -> Result<Vec<ScaleStats>> {
    let info = src.info();
    let path = info.path.display().to_string();
    if !(top > 0.0 && top <= 1.0) {
        return Err(Error::invalid(format!(
            "peakedness_dw: top={top} is out of range: use 0 < top <= 1 (share of the peaks in the centroid)"
        )));
    }
    let engine = crate::exec::engine(cfg)?;
    let stats_step = PeakStats {
        top,
        width: info.width,
        path: path.clone(),
    };
    let stats = engine.run_global(
        &stats_step,
        Run::new(&[src], layout, proto.into_iter().collect()),
    )?;
    if let Some(sink) = similarity {
        let sim = PeakSimilarity::new(stats.clone(), &path)?;
        engine.run_global_apply(&sim, Run::new(&[src], layout, vec![sink]))?;
    }
    Ok(stats)
}

/// `(prototypicality, similarity)` grids, each if requested.
pub type Outputs = (Option<Grid<f32>>, Option<Grid<f32>>);

/// Both outputs in memory (whole raster), for tests and the cost table:
/// `(prototypicality, similarity)` as requested.
pub fn run_to_memory(
    src: &dyn RasterSource,
    top: f64,
    layout: TileLayout,
    cfg: &EngineConfig,
    want_proto: bool,
    want_similarity: bool,
) -> Result<Outputs> {
    let (w, h) = (layout.width, layout.height);
    let mk = |want: bool| {
        want.then(|| {
            let (s, hd) = MemSink::new(w, h, DType::F32, None);
            (Box::new(s) as Box<dyn TileSink>, hd)
        })
    };
    let (p, s) = (mk(want_proto), mk(want_similarity));
    let (ps, ph) = match p {
        Some((s, h)) => (Some(s), Some(h)),
        None => (None, None),
    };
    let (ss, sh) = match s {
        Some((s, h)) => (Some(s), Some(h)),
        None => (None, None),
    };
    run(src, top, layout, cfg, ps, ss)?;
    let take = |h: Option<crate::exec::MemSinkHandle>| -> Result<Option<Grid<f32>>> {
        match h {
            None => Ok(None),
            Some(h) => h
                .take()
                .map(|g| Some(g.to_typed::<f32>(None)))
                .ok_or_else(|| Error::invalid("internal: in-memory sink finished without a grid")),
        }
    };
    Ok((take(ph)?, take(sh)?))
}

/// The `top` parameter of a resolved spec.
pub fn top_of(m: &Resolved) -> f64 {
    m.spec.threshold.unwrap_or(DEFAULT_TOP)
}

/// Write the whole-raster metrics `specs` (all [`is_whole_raster`]) to
/// `outputs` (f32, nodata [`super::METRIC_NODATA`]): one statistics pass and,
/// if `peakedness_dw` is asked for, one similarity pass per distinct `top`.
pub fn compute_paths(
    src: &dyn RasterSource,
    specs: &[super::MetricSpec],
    outputs: &[std::path::PathBuf],
    oo: &crate::io::OutputOptions,
    tile: Option<usize>,
    cfg: &EngineConfig,
) -> Result<()> {
    let info = src.info();
    if specs.len() != outputs.len() {
        return Err(Error::invalid("peakedness_dw: one output path per metric"));
    }
    let layout = crate::exec::plan::choose_layout(src, outputs, oo, tile);
    let mut done = vec![false; specs.len()];
    for i in 0..specs.len() {
        if done[i] {
            continue;
        }
        if !is_whole_raster(specs[i].kind) {
            return Err(Error::invalid(format!(
                "{} is not a whole-raster metric",
                specs[i].def().name
            )));
        }
        let top = specs[i].threshold.unwrap_or(DEFAULT_TOP);
        let same = |j: usize, k: MetricKind| {
            specs[j].kind == k
                && specs[j].threshold.unwrap_or(DEFAULT_TOP).to_bits() == top.to_bits()
        };
        let p = (i..specs.len()).find(|&j| same(j, MetricKind::PeakPrototypicality));
        let s = (i..specs.len()).find(|&j| same(j, MetricKind::PeakednessDw));
        let sink = |j: usize| -> Result<Box<dyn TileSink>> {
            let prov = crate::store::Provenance::new(
                specs[j].def().name.to_string(),
                dw_params("metric", json!(specs[j])),
                vec![info.path.display().to_string()],
            );
            crate::io::create_sink_like(
                &outputs[j],
                info,
                DType::F32,
                &info.georef.clone().with_nodata(Some(super::METRIC_NODATA)),
                oo,
                prov,
            )
        };
        let ps = p.map(sink).transpose()?;
        let ss = s.map(sink).transpose()?;
        run(src, top, layout, cfg, ps, ss)?;
        for j in (i..specs.len()).filter(|&j| Some(j) == p || Some(j) == s) {
            done[j] = true;
        }
    }
    Ok(())
}

/// True if the statistics pass finds a peak at some scale on `src` (one
/// tile, one thread), i.e. if `peakedness_dw` is defined there.
pub fn has_peaks(src: &dyn RasterSource) -> bool {
    let info = src.info();
    let cfg = EngineConfig {
        threads: 1,
        ..EngineConfig::default()
    };
    let layout = TileLayout::new(info.width, info.height, info.width.max(info.height).max(1));
    run(src, DEFAULT_TOP, layout, &cfg, None, None)
        .map(|st| st.iter().any(|s| s.centroid.is_some()))
        .unwrap_or(false)
}

/// Multi-scale peakedness or peak prototypicality: whole-raster metrics
/// (their own global passes, [`compute_paths`]), refused by the local pass.
pub struct PeakDw(MetricDef);

impl Metric for PeakDw {
    fn def(&self) -> &MetricDef {
        &self.0
    }
    fn halo(&self, _m: &Resolved) -> usize {
        HALO
    }
    fn whole_raster(&self) -> bool {
        true
    }
    fn bind(&self, r: &mut Resolved, _info: &RasterInfo) -> Result<()> {
        let t = r.spec.threshold.unwrap_or(DEFAULT_TOP);
        if !(t > 0.0 && t <= 1.0) {
            return Err(Error::invalid(format!(
                "{}:top={t} is out of range: use 0 < top <= 1 (share of the peaks in the centroid)",
                self.0.name
            )));
        }
        Ok(())
    }
    fn run(&self, _t: &mut Tile<'_>, _m: &Resolved, _o: &mut Grid<f32>) -> Result<()> {
        Err(Error::invalid(format!(
            "{} is a whole-raster metric: use metrics::compute",
            self.0.name
        )))
    }
}

/// `peakedness_dw`: multi-scale peakedness: weighted similarity to the centroid of the top peaks of relief, mean slope, relative elevation and isolation at 5/20/50-cell windows, normalised over the WHOLE raster (two tiled global passes).
///
/// Source: Deng & Wilson 2008, IJGIS 22(2); factors, scales and weights of the survey code (Argudo et al., HeightField::Peakness).
pub static PEAKEDNESS_DW: PeakDw = PeakDw(metric_def!(
        PeakednessDw,
        "peakedness_dw",
        &[TOP],
        "0..1",
        "multi-scale peakedness: weighted similarity to the centroid of the top peaks of relief, mean slope, relative elevation and isolation at 5/20/50-cell windows, normalised over the WHOLE raster (two tiled global passes)",
        "Deng & Wilson 2008, IJGIS 22(2); factors, scales and weights of the survey code (Argudo et al., HeightField::Peakness)"
    ));

/// `peak_prototypicality`: weighted mean over 5/20/50-cell windows of relief, mean slope, relative elevation and isolation, each min-max normalised over the WHOLE raster (one tiled global pass).
///
/// Source: Deng & Wilson 2008, IJGIS 22(2); as the survey code's peak prototypicality (HeightField::Peakness).
pub static PEAK_PROTOTYPICALITY: PeakDw = PeakDw(metric_def!(
        PeakPrototypicality,
        "peak_prototypicality",
        &[TOP],
        "0..1",
        "weighted mean over 5/20/50-cell windows of relief, mean slope, relative elevation and isolation, each min-max normalised over the WHOLE raster (one tiled global pass)",
        "Deng & Wilson 2008, IJGIS 22(2); as the survey code's peak prototypicality (HeightField::Peakness)"
    ));
