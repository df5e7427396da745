//! Realism report: measure two terrains with the same analyses and compare
//! them feature by feature (`orogen compare A B`), e.g. a synthetic terrain
//! against a real exemplar.
//!
//! Each terrain is analysed in memory ([`analyse`]):
//! - **orometry**: peaks with a prominence threshold, the Table 1 features
//!   of Argudo et al. (2019) pooled over blue-noise disks
//!   ([`crate::oro::stats::orostats`]); histograms share fixed bins, so
//!   they compare directly; distance per feature = 1-D Earth Mover's
//!   Distance ([`emd::emd_1d`]) in the feature's unit;
//! - **pits**: depressions filled by Priority-Flood ([`crate::hydro::fill`]);
//!   a depression is an 8-connected region of raised cells; count and
//!   volume per km²;
//! - **hypsometry**: the normalised hypsometric curve (Strahler 1952,
//!   "Hypsometric (area-altitude) analysis of erosional topography", GSA
//!   Bulletin 63): fraction of the area at or above each relative height
//!   (z − zmin)/(zmax − zmin) in 0..1, sampled at 101 heights, and its
//!   integral; distance = mean |a − b| over the samples (the area between
//!   the curves);
//! - **slope, profile curvature, geomorphons** from [`crate::metrics`]
//!   (Horn slope in degrees, Evans profile curvature in 1/m, geomorphons of
//!   Jasiewicz & Stepinski 2013 with the registry's default radius);
//!   slope on 90 bins of 1°, curvature on 60 bins over ±(the larger 99th
//!   percentile of |k| of the two), both common to A and B; EMD for slope
//!   and curvature, total variation for the 10 landform classes;
//! - **drainage**: D8 on the filled DEM, channels where the drainage area
//!   reaches a stated threshold (default 1 km²), drainage density (channel
//!   length per area, km/km²; Horton 1945) and Horton's bifurcation, length
//!   and area ratios ([`crate::hydro::streams::horton`]).
//!
//! Normalisation: counts and volumes are per km² of valid cells, lengths
//! per km², distributions are fractions of valid cells (of peaks for the
//! orometric histograms), so terrains of different sizes and cell sizes
//! compare. Scalar distances are relative: |a − b| / max(|a|, |b|) (0 when
//! both are 0). All distances are 0 for a terrain compared with itself;
//! NaN (JSON null) where a figure is undefined for one side (e.g. no peak,
//! fewer than two stream orders). Without georeferencing, cells are 1 x 1
//! metres.

pub mod emd;
pub mod output;

use crate::error::{Error, Result};
use crate::exec::{run_local_to_memory, EngineConfig, LocalEngine, MemoryFit};
use crate::hydro::streams::{self, ChannelRule, Horton, NetworkOptions};
use crate::metrics::{parse_specs, MultiMetric};
use crate::oro::stats::{orostats, OroProfile, StatsOptions, FEATURES};
use crate::raster::{DType, GeoRef, Grid, MemRaster, RasterSource, TileLayout};
use serde::Serialize;
use std::collections::BTreeMap;

/// Samples of the hypsometric curve (relative heights 0, 0.01, ..., 1).
pub const HYPSOMETRY_SAMPLES: usize = 101;
/// Slope bins: 1° each over 0..90°.
pub const SLOPE_BINS: usize = 90;
/// Profile-curvature bins over the common symmetric range.
pub const CURVATURE_BINS: usize = 60;
/// Bytes per cell the analysis of one terrain holds at its peak (DEM,
/// filled DEM, directions, network extraction, three metric outputs).
pub const BYTES_PER_CELL: u64 = 4 + 4 + 1 + streams::NETWORK_BYTES_PER_CELL + 12 + 8;

/// Geomorphon class names, classes 1..=10 (GRASS r.geomorphon numbering).
pub const LANDFORMS: [&str; 10] = [
    "flat",
    "peak",
    "ridge",
    "shoulder",
    "spur",
    "slope",
    "hollow",
    "footslope",
    "valley",
    "pit",
];

/// Options of [`compare`].
#[derive(Debug, Clone)]
pub struct CompareOptions {
    /// Peaks with at least this prominence (m).
    pub min_prominence: f64,
    /// Disk radius of the orometric statistics (m); None: 10 km, or a
    /// quarter of the shorter side of the smaller terrain if less.
    pub radius_m: Option<f64>,
    /// Channels start where the drainage area reaches this (m²).
    pub channel_area_m2: f64,
    /// Seed of the disk placement.
    pub seed: u64,
    /// Engine for the metric pass.
    pub engine: EngineConfig,
}

impl Default for CompareOptions {
    fn default() -> Self {
        CompareOptions {
            min_prominence: 30.0,
            radius_m: None,
            channel_area_m2: 1e6,
            seed: 1,
            engine: EngineConfig::default(),
        }
    }
}

/// A terrain to compare: elevations (NaN = nodata) and georeference.
#[derive(Debug, Clone)]
pub struct Terrain {
    pub name: String,
    pub dem: Grid<f32>,
    pub georef: GeoRef,
}

/// Depressions of a terrain.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Pits {
    /// 8-connected regions raised by the fill.
    pub count: u64,
    /// Total fill volume (m³).
    pub volume_m3: f64,
    /// Area of the raised cells (km²).
    pub area_km2: f64,
    pub count_per_km2: f64,
    /// Fill volume per km² of terrain (m³/km²).
    pub volume_m3_per_km2: f64,
}

/// Channel network figures of a terrain.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Drainage {
    /// The channel threshold used (m² of drainage area).
    pub channel_area_m2: f64,
    pub links: usize,
    pub channel_length_km: f64,
    /// Channel length per area (km/km²).
    pub density_km_per_km2: f64,
    pub horton: Horton,
}

/// Everything measured on one terrain.
#[derive(Debug, Clone, Serialize)]
pub struct Analysis {
    pub name: String,
    pub width: usize,
    pub height: usize,
    pub georeferenced: bool,
    pub valid_cells: u64,
    pub area_km2: f64,
    /// Square root of the mean cell area (m).
    pub mean_cell_m: f64,
    pub z_min: f64,
    pub z_max: f64,
    pub z_mean: f64,
    /// Fraction of the area at or above relative height k/100, k = 0..=100.
    pub hypsometry: Vec<f64>,
    /// Area-weighted mean relative height (the area under the exact curve).
    pub hypsometric_integral: f64,
    pub pits: Pits,
    pub drainage: Drainage,
    /// Fractions of the valid cells in each geomorphon class (see [`LANDFORMS`]).
    pub geomorphons: Vec<f64>,
    /// Orometric profile (None when no disk fits: see `oro_note`).
    pub oro: Option<OroProfile>,
    pub oro_note: Option<String>,
    /// Slope (degrees) of every cell with a value (not serialised).
    #[serde(skip)]
    pub slope_deg: Vec<f32>,
    /// Profile curvature (1/m) of every cell with a value (not serialised).
    #[serde(skip)]
    pub curvature: Vec<f32>,
}

/// A pair of histograms on common bins.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct PairHistogram {
    /// Bin edges (len = bins + 1; an open last bin has `f64::MAX`).
    pub edges: Vec<f64>,
    /// Fractions per bin (sum 1, or all 0 when empty).
    pub a: Vec<f64>,
    pub b: Vec<f64>,
    /// Distance between them (EMD in the feature's unit, or total variation).
    pub distance: f64,
}

/// The result of [`compare`].
#[derive(Debug, Clone, Serialize)]
pub struct Comparison {
    pub format: &'static str,
    pub min_prominence: f64,
    pub radius_m: f64,
    pub a: Analysis,
    pub b: Analysis,
    pub slope: PairHistogram,
    pub curvature: PairHistogram,
    pub geomorphons: PairHistogram,
    /// Per Table 1 feature: the pooled histograms of A and B and their EMD.
    pub orometry: BTreeMap<String, PairHistogram>,
    /// Every distance by name (0 = identical); see the module docs.
    pub distances: BTreeMap<String, f64>,
}

/// |a − b| / max(|a|, |b|): 0 when both are 0, NaN when either is NaN.
pub fn relative_difference(a: f64, b: f64) -> f64 {
    let m = a.abs().max(b.abs());
    if a.is_nan() || b.is_nan() {
        f64::NAN
    } else if m == 0.0 || a == b {
        0.0
    } else {
        (a - b).abs() / m
    }
}

/// Histogram of `v` on `edges` (values outside go to the end bins), as fractions.
pub fn histogram(v: &[f32], edges: &[f64]) -> Vec<f64> {
    let nb = edges.len() - 1;
    let (lo, hi) = (edges[0], edges[nb]);
    let w = (hi - lo) / nb as f64;
    let mut c = vec![0u64; nb];
    for &x in v {
        let x = x as f64;
        if x.is_finite() {
            let i = if w > 0.0 {
                ((x - lo) / w).floor().clamp(0.0, (nb - 1) as f64) as usize
            } else {
                0
            };
            c[i] += 1;
        }
    }
    let n = v.len().max(1) as f64;
    c.into_iter().map(|k| k as f64 / n).collect()
}

/// Read the whole of `src` as f32 (NaN = nodata) for a comparison; refuses
/// rasters whose analysis would not fit in `memory_budget` bytes.
pub fn load_terrain(src: &dyn RasterSource, name: &str, memory_budget: u64) -> Result<Terrain> {
    let info = src.info();
    MemoryFit::cells(info.width, info.height, BYTES_PER_CELL, memory_budget).check(|fit| {
        Error::over_budget(
            format!(
                "{}: comparing a {} x {} raster needs about {} MiB in memory, over the budget of {} MiB; crop or downsample it (orogen export), or raise --memory",
                info.path.display(),
                info.width,
                info.height,
                fit.need_mib(),
                fit.budget_mib()
            ),
        )
    })?;
    let dem = crate::raster::read_window::<f32>(
        src,
        crate::raster::Window::full(info.width, info.height),
    )?;
    Ok(Terrain {
        name: name.to_string(),
        dem,
        georef: info.georef.clone(),
    })
}

/// Cell areas (m²) of every row.
fn row_areas(georef: &GeoRef, h: usize) -> Vec<f64> {
    (0..h)
        .map(|y| {
            let (ew, ns) = georef.cell_size_m(y as i64);
            ew * ns
        })
        .collect()
}

/// Depressions: cells the fill raised, grouped into 8-connected regions.
fn pits(dem: &Grid<f32>, filled: &Grid<f32>, areas: &[f64], area_km2: f64) -> Pits {
    let d = crate::hydro::depressions::depressions(dem, filled, areas, 0.0);
    let per = |v: f64| if area_km2 > 0.0 { v / area_km2 } else { 0.0 };
    Pits {
        count: d.count as u64,
        volume_m3: d.volume,
        area_km2: d.area / 1e6,
        count_per_km2: per(d.count as f64),
        volume_m3_per_km2: per(d.volume),
    }
}

/// Normalised hypsometric curve and integral (area-weighted).
fn hypsometry(dem: &Grid<f32>, areas: &[f64], zmin: f64, zmax: f64) -> (Vec<f64>, f64) {
    let w = dem.width();
    let span = zmax - zmin;
    let mut above = vec![0.0f64; HYPSOMETRY_SAMPLES];
    let (mut total, mut integral) = (0.0, 0.0);
    let last = (HYPSOMETRY_SAMPLES - 1) as f64;
    for (i, &v) in dem.data().iter().enumerate() {
        if !v.is_finite() {
            continue;
        }
        let a = areas[i / w];
        let r = if span > 0.0 {
            (v as f64 - zmin) / span
        } else {
            0.0
        };
        total += a;
        integral += a * r;
        // Samples k/100 <= r: k = 0..=floor(100 r) (with a guard against
        // 100 r landing just below an integer it equals).
        let mut k = (r * last).floor() as usize;
        if ((k + 1) as f64 / last) <= r {
            k += 1;
        }
        above[k.min(HYPSOMETRY_SAMPLES - 1)] += a;
    }
    // Suffix sums: fraction at or above each sample.
    let mut acc = 0.0;
    for v in above.iter_mut().rev() {
        acc += *v;
        *v = if total > 0.0 { acc / total } else { 0.0 };
    }
    (above, if total > 0.0 { integral / total } else { 0.0 })
}

/// Analyse one terrain (see the module docs). `radius_m` is the disk radius
/// of the orometric statistics.
pub fn analyse(t: &Terrain, radius_m: f64, opts: &CompareOptions) -> Result<Analysis> {
    let dem = &t.dem;
    let (w, h) = (dem.width(), dem.height());
    let areas = row_areas(&t.georef, h);
    let (mut n, mut area, mut zmin, mut zmax, mut zsum) =
        (0u64, 0.0f64, f64::INFINITY, f64::NEG_INFINITY, 0.0f64);
    for (i, &v) in dem.data().iter().enumerate() {
        if v.is_finite() {
            let z = v as f64;
            n += 1;
            area += areas[i / w];
            zmin = zmin.min(z);
            zmax = zmax.max(z);
            zsum += z;
        }
    }
    if n == 0 {
        return Err(Error::invalid(format!(
            "{}: no valid cells (all nodata); nothing to compare",
            t.name
        )));
    }
    let area_km2 = area / 1e6;
    let (hyps, hi) = hypsometry(dem, &areas, zmin, zmax);

    let filled = crate::hydro::fill(dem)?;
    let pits = pits(dem, &filled, &areas, area_km2);
    let dirs = crate::hydro::d8_directions(&filled);
    drop(filled);
    let net = streams::extract_network(
        &dirs,
        None,
        &t.georef,
        &NetworkOptions {
            rule: ChannelRule::Area(opts.channel_area_m2),
            valley_window: 5,
        },
    )?;
    drop(dirs);
    let length_km = net.links.iter().map(|l| l.length_m).sum::<f64>() / 1e3;
    let drainage = Drainage {
        channel_area_m2: opts.channel_area_m2,
        links: net.links.len(),
        channel_length_km: length_km,
        density_km_per_km2: if area_km2 > 0.0 {
            length_km / area_km2
        } else {
            0.0
        },
        horton: streams::horton(&net),
    };
    drop(net);

    // Slope, profile curvature and geomorphons in one tiled pass.
    let src = MemRaster::from_grid(dem.clone(), t.georef.clone());
    let specs = parse_specs("slope,profile_curvature,geomorphon")?;
    let step = MultiMetric::new(&specs, src.info())?;
    let engine = LocalEngine::new(EngineConfig {
        progress: false,
        ..opts.engine.clone()
    });
    let outs = run_local_to_memory(
        &engine,
        &step,
        &[&src],
        TileLayout::new(w, h, 1024),
        &[(DType::F32, None); 3],
    )?;
    let finite = |g: &crate::raster::AnyGrid| -> Vec<f32> {
        g.to_typed::<f32>(None)
            .data()
            .iter()
            .copied()
            .filter(|v| v.is_finite())
            .collect()
    };
    let slope_deg = finite(&outs[0]);
    let curvature = finite(&outs[1]);
    let geo = finite(&outs[2]);
    let mut geomorphons = vec![0.0; LANDFORMS.len()];
    for &c in &geo {
        let k = c as usize;
        if (1..=LANDFORMS.len()).contains(&k) {
            geomorphons[k - 1] += 1.0;
        }
    }
    let ng = geo.len().max(1) as f64;
    geomorphons.iter_mut().for_each(|v| *v /= ng);
    drop(outs);

    let mut so = StatsOptions::new(radius_m);
    so.min_prominence = opts.min_prominence;
    so.seed = opts.seed;
    let (oro, oro_note) = match orostats(dem, &t.georef, &so, "", &t.name) {
        Ok(st) if st.profile.n_disks > 0 => (Some(st.profile), None),
        Ok(_) => (
            None,
            Some(format!(
                "no disk of radius {radius_m} m with 90% valid cells fits; give a smaller --radius"
            )),
        ),
        Err(e) => (None, Some(e.to_string())),
    };
    Ok(Analysis {
        name: t.name.clone(),
        width: w,
        height: h,
        georeferenced: t.georef.georeferenced,
        valid_cells: n,
        area_km2,
        mean_cell_m: (area / n as f64).sqrt(),
        z_min: zmin,
        z_max: zmax,
        z_mean: zsum / n as f64,
        hypsometry: hyps,
        hypsometric_integral: hi,
        pits,
        drainage,
        geomorphons,
        oro,
        oro_note,
        slope_deg,
        curvature,
    })
}

/// Default disk radius: 10 km, or a quarter of the shorter side (m) of the
/// smaller terrain when that is less.
pub fn default_radius(a: &Terrain, b: &Terrain) -> f64 {
    let side = |t: &Terrain| {
        let (ew, ns) = t.georef.cell_size_m((t.dem.height() / 2) as i64);
        (t.dem.width() as f64 * ew).min(t.dem.height() as f64 * ns)
    };
    (0.25 * side(a).min(side(b))).min(10_000.0)
}

/// The 99th percentile of |v| (0 when empty).
fn p99_abs(v: &[f32]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    let mut a: Vec<f32> = v.iter().map(|x| x.abs()).collect();
    let k = ((a.len() - 1) as f64 * 0.99).round() as usize;
    let (_, x, _) = a.select_nth_unstable_by(k, f32::total_cmp);
    *x as f64
}

/// Analyse both terrains and compare them (see the module docs).
pub fn compare(a: &Terrain, b: &Terrain, opts: &CompareOptions) -> Result<Comparison> {
    if !(opts.min_prominence.is_finite() && opts.min_prominence >= 0.0) {
        return Err(Error::invalid(format!(
            "compare: the minimum prominence must be 0 or more, got {}",
            opts.min_prominence
        )));
    }
    if !(opts.channel_area_m2.is_finite() && opts.channel_area_m2 > 0.0) {
        return Err(Error::invalid(format!(
            "compare: the channel threshold must be a positive area, got {} m²",
            opts.channel_area_m2
        )));
    }
    let radius = opts.radius_m.unwrap_or_else(|| default_radius(a, b));
    if !(radius.is_finite() && radius > 0.0) {
        return Err(Error::invalid(format!(
            "compare: the disk radius must be a positive distance, got {radius} m"
        )));
    }
    let aa = analyse(a, radius, opts)?;
    let ab = analyse(b, radius, opts)?;
    Ok(compare_analyses(aa, ab, opts.min_prominence, radius))
}

/// Compare two analyses (common bins, distances).
pub fn compare_analyses(
    a: Analysis,
    b: Analysis,
    min_prominence: f64,
    radius_m: f64,
) -> Comparison {
    let mut d = BTreeMap::new();
    let slope_edges: Vec<f64> = (0..=SLOPE_BINS).map(|i| i as f64).collect();
    let pair = |edges: Vec<f64>, va: &[f32], vb: &[f32]| {
        let (ha, hb) = (histogram(va, &edges), histogram(vb, &edges));
        let x = emd::bin_positions(&edges);
        let distance = emd::emd_1d(&x, &ha, &hb);
        PairHistogram {
            edges,
            a: ha,
            b: hb,
            distance,
        }
    };
    let slope = pair(slope_edges, &a.slope_deg, &b.slope_deg);
    let c = p99_abs(&a.curvature).max(p99_abs(&b.curvature));
    let c = if c > 0.0 { c } else { 1e-6 };
    let curv_edges: Vec<f64> = (0..=CURVATURE_BINS)
        .map(|i| -c + 2.0 * c * i as f64 / CURVATURE_BINS as f64)
        .collect();
    let curvature = pair(curv_edges, &a.curvature, &b.curvature);
    let geomorphons = PairHistogram {
        edges: (0..=LANDFORMS.len()).map(|i| i as f64 + 0.5).collect(),
        a: a.geomorphons.clone(),
        b: b.geomorphons.clone(),
        distance: emd::total_variation(&a.geomorphons, &b.geomorphons),
    };
    d.insert("slope_emd_deg".into(), slope.distance);
    d.insert("profile_curvature_emd_per_m".into(), curvature.distance);
    d.insert("geomorphon_total_variation".into(), geomorphons.distance);
    let hyp_l1 = a
        .hypsometry
        .iter()
        .zip(&b.hypsometry)
        .map(|(x, y)| (x - y).abs())
        .sum::<f64>()
        / HYPSOMETRY_SAMPLES as f64;
    d.insert("hypsometric_curve_l1".into(), hyp_l1);
    d.insert(
        "hypsometric_integral_abs".into(),
        (a.hypsometric_integral - b.hypsometric_integral).abs(),
    );
    d.insert(
        "pits_per_km2_rel".into(),
        relative_difference(a.pits.count_per_km2, b.pits.count_per_km2),
    );
    d.insert(
        "pit_volume_per_km2_rel".into(),
        relative_difference(a.pits.volume_m3_per_km2, b.pits.volume_m3_per_km2),
    );
    d.insert(
        "drainage_density_rel".into(),
        relative_difference(a.drainage.density_km_per_km2, b.drainage.density_km_per_km2),
    );
    let (ha, hb) = (&a.drainage.horton, &b.drainage.horton);
    d.insert(
        "horton_bifurcation_rel".into(),
        relative_difference(ha.bifurcation_ratio, hb.bifurcation_ratio),
    );
    d.insert(
        "horton_length_rel".into(),
        relative_difference(ha.length_ratio, hb.length_ratio),
    );
    d.insert(
        "horton_area_rel".into(),
        relative_difference(ha.area_ratio, hb.area_ratio),
    );
    let mut orometry = BTreeMap::new();
    for f in &FEATURES {
        let get = |an: &Analysis| {
            an.oro
                .as_ref()
                .and_then(|p| p.histograms.get(f.name))
                .map(|h| h.p.clone())
        };
        let edges: Vec<f64> = f
            .edges
            .iter()
            .map(|&e| if e.is_finite() { e } else { f64::MAX })
            .collect();
        let nb = edges.len() - 1;
        let (pa, pb) = (get(&a), get(&b));
        let distance = match (&pa, &pb) {
            (Some(x), Some(y)) => emd::emd_1d(&emd::bin_positions(f.edges), x, y),
            _ => f64::NAN,
        };
        d.insert(format!("oro_{}_emd", f.name), distance);
        orometry.insert(
            f.name.to_string(),
            PairHistogram {
                edges,
                a: pa.unwrap_or_else(|| vec![0.0; nb]),
                b: pb.unwrap_or_else(|| vec![0.0; nb]),
                distance,
            },
        );
    }
    let dens = |an: &Analysis| an.oro.as_ref().map_or(f64::NAN, |p| p.peak_density_per_km2);
    d.insert(
        "peak_density_rel".into(),
        relative_difference(dens(&a), dens(&b)),
    );
    Comparison {
        format: "orogen-compare-1",
        min_prominence,
        radius_m,
        a,
        b,
        slope,
        curvature,
        geomorphons,
        orometry,
        distances: d,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hypsometry_of_a_plane_is_linear() {
        // A plane rising evenly over 101 rows: each relative height k/100 has
        // one row; the fraction at or above k/100 is (101 − k)/101.
        let dem = Grid::from_fn(3, 101, |_, y| y as f32);
        let areas = vec![1.0; 101];
        let (c, hi) = hypsometry(&dem, &areas, 0.0, 100.0);
        for (k, v) in c.iter().enumerate() {
            assert!((v - (101 - k) as f64 / 101.0).abs() < 1e-12, "{k}: {v}");
        }
        assert!((hi - 0.5).abs() < 1e-12);
    }

    #[test]
    fn pits_brute_force() {
        // Two separate pits (one of 2 cells) in a flat-topped block.
        let mut dem = Grid::new(7, 5, 10.0f32);
        dem.set(1, 2, 7.0);
        dem.set(4, 2, 8.0);
        dem.set(5, 2, 9.0);
        let filled = crate::hydro::fill(&dem).unwrap();
        let p = pits(&dem, &filled, &[4.0; 5], 35.0 * 4.0 / 1e6);
        assert_eq!(p.count, 2);
        assert!((p.volume_m3 - (3.0 + 2.0 + 1.0) * 4.0).abs() < 1e-9);
        assert!((p.area_km2 - 3.0 * 4.0 / 1e6).abs() < 1e-15);
    }

    #[test]
    fn relative_difference_cases() {
        assert_eq!(relative_difference(0.0, 0.0), 0.0);
        assert_eq!(relative_difference(2.0, 1.0), 0.5);
        assert!(relative_difference(f64::NAN, 1.0).is_nan());
        assert_eq!(relative_difference(3.0, 3.0), 0.0);
    }
}
