//! Orometric statistics of a region (Argudo et al. 2019, "Orometry-based
//! terrain analysis and synthesis", ACM TOG 38(6), §4 and Table 1):
//! histograms of per-peak metrics over disks of radius R placed by seeded
//! blue-noise sampling, one feature vector per disk, and a region profile
//! (the pooled distributions) that can be saved, loaded and compared.
//!
//! Features of a disk (peaks whose summit lies inside it), each histogram
//! normalised to sum to 1 over the peaks that have the value (all zeros when
//! none do); bins are [`FEATURES`]:
//! normalised elevation (h − zmin)/(zmax − zmin) over the disk's cells;
//! prominence (m); relative prominence (prominence / the disk's largest);
//! dominance (prominence / elevation); Jurgalski dominance groups; isolation
//! distance (km) and direction (8 sectors of 45° centred on N, NE, ...);
//! key-saddle distance (km) and direction; relevance (over the disk, see
//! [`super::metrics::relevance`]). Two scalars follow: peak density (peaks
//! per 100 km²) and the Nearest Neighbor Index of the disk's peaks
//! (Donnelly-corrected, 0 with fewer than 2 peaks).

use super::metrics::{self, dominance_group, nearest_neighbor_index, PlanarFrame};
use super::tree::{DivideTree, EdgeConvention};
use super::{IsolationIndex, PeakOptions};
use crate::error::{Error, Result};
use crate::raster::{GeoRef, Grid};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

const INF: f64 = f64::INFINITY;
const UNIT10: [f64; 11] = [0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0];
const DIST_KM: [f64; 11] = [0.0, 0.5, 1.0, 2.0, 3.0, 5.0, 7.5, 10.0, 15.0, 20.0, INF];
const SECTORS: [f64; 9] = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0];
const GROUPS: [f64; 9] = SECTORS;

/// A histogram feature: its name and bin edges (bins are [e_i, e_{i+1});
/// values beyond the last edge go to the last bin, below the first to the first).
#[derive(Debug, Clone, Copy)]
pub struct FeatureSpec {
    pub name: &'static str,
    pub edges: &'static [f64],
}

/// The histogram features, in feature-vector order.
pub const FEATURES: [FeatureSpec; 10] = [
    FeatureSpec {
        name: "elevation_norm",
        edges: &UNIT10,
    },
    FeatureSpec {
        name: "prominence_m",
        edges: &[
            0.0, 50.0, 100.0, 150.0, 200.0, 300.0, 400.0, 600.0, 800.0, 1000.0, 1500.0, INF,
        ],
    },
    FeatureSpec {
        name: "prominence_rel",
        edges: &UNIT10,
    },
    FeatureSpec {
        name: "dominance",
        edges: &[0.0, 0.02, 0.05, 0.1, 0.15, 0.2, 0.3, 0.4, 0.6, 0.8, 1.0],
    },
    FeatureSpec {
        name: "dominance_group",
        edges: &GROUPS,
    },
    FeatureSpec {
        name: "isolation_km",
        edges: &DIST_KM,
    },
    FeatureSpec {
        name: "isolation_dir",
        edges: &SECTORS,
    },
    FeatureSpec {
        name: "saddle_km",
        edges: &DIST_KM,
    },
    FeatureSpec {
        name: "saddle_dir",
        edges: &SECTORS,
    },
    FeatureSpec {
        name: "relevance",
        edges: &UNIT10,
    },
];

/// Names of the scalar features that follow the histograms.
pub const SCALARS: [&str; 2] = ["density_per_100km2", "nni"];

/// Bin of `v` among `edges` (clamped to the first and last bin); None for NaN.
pub fn bin_of(edges: &[f64], v: f64) -> Option<usize> {
    if v.is_nan() || edges.len() < 2 {
        return None;
    }
    let nb = edges.len() - 1;
    let i = edges[1..nb].iter().take_while(|&&e| v >= e).count();
    Some(i.min(nb - 1))
}

/// Sector 0..8 of a bearing (degrees from north): 0 = N (337.5°–22.5°), 1 = NE, ...
pub fn sector(bearing_deg: f64) -> Option<f64> {
    bearing_deg.is_finite().then(|| {
        (((bearing_deg + 22.5).rem_euclid(360.0)) / 45.0)
            .floor()
            .min(7.0)
    })
}

/// Column names of a feature vector: `name:lo-hi` per bin (the bin [lo, hi)), then [`SCALARS`].
pub fn feature_names() -> Vec<String> {
    let mut out = Vec::new();
    for f in &FEATURES {
        for w in f.edges.windows(2) {
            out.push(format!("{}:{}-{}", f.name, w[0], w[1]));
        }
    }
    out.extend(SCALARS.iter().map(|s| s.to_string()));
    out
}

/// SplitMix64 (Steele, Lea & Flood 2014, "Fast splittable pseudorandom
/// number generators"): small, seedable, the same on every platform.
#[derive(Debug, Clone)]
pub struct SplitMix64(pub u64);

impl SplitMix64 {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Uniform in 0..n (n > 0), by rejection (no modulo bias).
    pub fn below(&mut self, n: u64) -> u64 {
        let zone = u64::MAX - u64::MAX % n;
        loop {
            let v = self.next_u64();
            if v < zone {
                return v % n;
            }
        }
    }
}

/// Poisson-disc samples in the rectangle [x0, x1] × [y0, y1], all pairwise
/// distances ≥ `r`, by Bridson's algorithm (Bridson 2007, "Fast Poisson disk
/// sampling in arbitrary dimensions", SIGGRAPH sketches): a background grid
/// of cell r/√2, an active list, `k` = 30 candidates per active point in the
/// annulus [r, 2r]. Deterministic for a seed. At most `max_points`.
pub fn poisson_disc(
    x0: f64,
    y0: f64,
    x1: f64,
    y1: f64,
    r: f64,
    seed: u64,
    max_points: usize,
) -> Vec<(f64, f64)> {
    const K: usize = 30;
    let usable = r > 0.0 && r.is_finite() && x1 >= x0 && y1 >= y0 && max_points > 0;
    if !usable {
        return Vec::new();
    }
    let cs = r / std::f64::consts::SQRT_2;
    let (gwf, ghf) = (
        ((x1 - x0) / cs).floor() + 1.0,
        ((y1 - y0) / cs).floor() + 1.0,
    );
    let (gw, gh) = (gwf as usize, ghf as usize);
    if gwf * ghf > (1u64 << 24) as f64 {
        // Over 16 M background cells (r tiny against the domain): refuse
        // rather than allocate; callers report "no disk".
        return Vec::new();
    }
    let mut grid = vec![u32::MAX; gw * gh];
    let mut rng = SplitMix64(seed ^ 0x6F72_6F67_656E);
    let mut pts: Vec<(f64, f64)> = Vec::new();
    let mut active: Vec<u32> = Vec::new();
    let cell = |x: f64, y: f64| {
        (
            (((x - x0) / cs) as usize).min(gw - 1),
            (((y - y0) / cs) as usize).min(gh - 1),
        )
    };
    let fits = |pts: &[(f64, f64)], grid: &[u32], x: f64, y: f64| {
        if x < x0 || x > x1 || y < y0 || y > y1 {
            return false;
        }
        let (cx, cy) = cell(x, y);
        for gy in cy.saturating_sub(2)..(cy + 3).min(gh) {
            for gx in cx.saturating_sub(2)..(cx + 3).min(gw) {
                let j = grid[gy * gw + gx];
                if j != u32::MAX {
                    let (u, v) = pts[j as usize];
                    if (u - x).hypot(v - y) < r {
                        return false;
                    }
                }
            }
        }
        true
    };
    let first = (x0 + rng.unit() * (x1 - x0), y0 + rng.unit() * (y1 - y0));
    let (cx, cy) = cell(first.0, first.1);
    grid[cy * gw + cx] = 0;
    pts.push(first);
    active.push(0);
    while !active.is_empty() && pts.len() < max_points {
        let ai = rng.below(active.len() as u64) as usize;
        let (px, py) = pts[active[ai] as usize];
        let mut placed = false;
        for _ in 0..K {
            let ang = rng.unit() * std::f64::consts::TAU;
            // Uniform in area over the annulus [r, 2r].
            let rad = (r * r * (1.0 + 3.0 * rng.unit())).sqrt();
            let (x, y) = (px + rad * ang.cos(), py + rad * ang.sin());
            if fits(&pts, &grid, x, y) {
                let (cx, cy) = cell(x, y);
                grid[cy * gw + cx] = pts.len() as u32;
                active.push(pts.len() as u32);
                pts.push((x, y));
                placed = true;
                break;
            }
        }
        if !placed {
            active.swap_remove(ai);
        }
    }
    pts
}

/// Options of [`orostats`].
#[derive(Debug, Clone)]
pub struct StatsOptions {
    /// Disk radius, metres.
    pub radius_m: f64,
    /// Minimum distance between disk centres, metres (≥ 0.5 R is the
    /// paper's choice; default 0.5 R).
    pub separation_m: f64,
    /// Seed of the blue-noise sampler.
    pub seed: u64,
    /// Upper bound on the number of disks.
    pub max_disks: usize,
    /// Skip disks with a smaller fraction of valid cells.
    pub min_valid_fraction: f64,
    /// Peak extraction: minimum prominence and edge convention.
    pub min_prominence: f64,
    pub convention: EdgeConvention,
}

impl StatsOptions {
    pub fn new(radius_m: f64) -> StatsOptions {
        StatsOptions {
            radius_m,
            separation_m: 0.5 * radius_m,
            seed: 1,
            max_disks: 10_000,
            min_valid_fraction: 0.9,
            min_prominence: 30.0,
            convention: EdgeConvention::SeaLevel,
        }
    }
}

/// One disk's feature vector.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DiskFeatures {
    pub label: String,
    pub source: String,
    /// Centre cell (fractional) of the disk.
    pub col: f64,
    pub row: f64,
    pub n_peaks: usize,
    /// Values in [`feature_names`] order.
    pub values: Vec<f64>,
    /// Raw (unnormalised) histogram counts, same layout as the histogram
    /// part of `values`; used to pool disks into a profile.
    #[serde(default)]
    pub counts: Vec<f64>,
}

/// A histogram with its edges; `p` sums to 1 (or all 0 when empty). An
/// open-ended last bin has the edge `f64::MAX` (JSON has no infinity).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Histogram {
    pub edges: Vec<f64>,
    pub p: Vec<f64>,
    /// Number of values counted.
    pub n: f64,
}

impl Histogram {
    fn from_counts(edges: &[f64], counts: &[f64]) -> Histogram {
        let n: f64 = counts.iter().sum();
        Histogram {
            edges: edges
                .iter()
                .map(|&e| {
                    if e.is_finite() {
                        e
                    } else {
                        f64::MAX.copysign(e)
                    }
                })
                .collect(),
            p: counts
                .iter()
                .map(|&c| if n > 0.0 { c / n } else { 0.0 })
                .collect(),
            n,
        }
    }
}

/// A region's orometry profile: pooled distributions of the disk features
/// plus whole-domain figures. Serialised as JSON; the target distributions
/// of orometric synthesis.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OroProfile {
    /// Always "orogen-oroprofile".
    pub format: String,
    pub version: u32,
    pub label: String,
    pub sources: Vec<String>,
    pub min_prominence: f64,
    pub radius_m: f64,
    pub n_disks: usize,
    /// Peaks of the whole domain (not only those in disks).
    pub n_peaks: usize,
    /// Area of the valid cells, km².
    pub area_km2: f64,
    pub peak_density_per_km2: f64,
    /// Peak elevations (absolute, m), 20 bins between the domain's lowest and
    /// highest cell.
    pub elevation: Histogram,
    /// Each feature of [`FEATURES`], pooled: the disks' counts summed, then
    /// normalised (a peak in k overlapping disks counts k times).
    pub histograms: BTreeMap<String, Histogram>,
    /// NNI of all peaks of the domain (Donnelly-corrected; 0 with < 2 peaks).
    pub nni: f64,
}

/// Result of [`orostats`].
#[derive(Debug, Clone)]
pub struct OroStats {
    pub disks: Vec<DiskFeatures>,
    pub profile: OroProfile,
    /// The peaks used (pruned tree with isolation).
    pub tree: DivideTree,
}

struct PeakRec {
    x: f64,
    y: f64,
    elevation: f64,
    prominence: f64,
    dominance: Option<f64>,
    iso_km: Option<f64>,
    iso_dir: Option<f64>,
    saddle_km: Option<f64>,
    saddle_dir: Option<f64>,
}

/// Feature vectors over blue-noise disks and the region profile of `dem`.
/// Errors name what is wrong (no valid cells, radius too large for the DEM).
/// A DEM with no peaks gives disks with zero histograms and a profile with
/// `n_peaks` 0.
pub fn orostats(
    dem: &Grid<f32>,
    georef: &GeoRef,
    opts: &StatsOptions,
    label: &str,
    source: &str,
) -> Result<OroStats> {
    let r = opts.radius_m;
    if !(r > 0.0 && r.is_finite()) {
        return Err(Error::invalid(format!(
            "orostats: the disk radius must be a positive distance, got {r}"
        )));
    }
    if !(opts.separation_m >= 0.5 * r && opts.separation_m.is_finite()) {
        return Err(Error::invalid(format!(
            "orostats: the separation of disk centres must be at least R/2 = {} m, got {}",
            0.5 * r,
            opts.separation_m
        )));
    }
    let (zmin, zmax) = metrics::dem_range(dem);
    let (Some(dzmin), Some(dzmax)) = (zmin, zmax) else {
        return Err(Error::invalid(
            "orostats: the DEM has no valid cells (all nodata)",
        ));
    };
    let (w, h) = (dem.width(), dem.height());
    let frame = PlanarFrame::new(georef, h);
    let popts = PeakOptions {
        min_prominence: opts.min_prominence,
        convention: opts.convention,
        isolation: true,
    };
    let list = super::peaks(dem, georef, &popts)?;
    let tree = list.tree;
    let geo = IsolationIndex::new(dem, georef);
    let recs: Vec<PeakRec> = tree
        .peaks
        .iter()
        .map(|p| {
            let (x, y) = frame.xy(p.col as f64, p.row as f64);
            let ks = geo.to_key_saddle(&tree, p);
            PeakRec {
                x,
                y,
                elevation: p.elevation as f64,
                prominence: p.prominence,
                dominance: p.dominance(),
                iso_km: p.isolation.map(|i| i.distance_m / 1000.0),
                iso_dir: p.isolation.and_then(|i| sector(i.bearing_deg)),
                saddle_km: ks.map(|k| k.0 / 1000.0),
                saddle_dir: ks.and_then(|k| sector(k.1)),
            }
        })
        .collect();
    // Planar extent of the DEM (cell centres of the corners).
    let corners = [
        frame.xy(0.0, 0.0),
        frame.xy(w as f64 - 1.0, 0.0),
        frame.xy(0.0, h as f64 - 1.0),
        frame.xy(w as f64 - 1.0, h as f64 - 1.0),
    ];
    let (mut x0, mut y0, mut x1, mut y1) = (INF, INF, -INF, -INF);
    for (x, y) in corners {
        x0 = x0.min(x);
        y0 = y0.min(y);
        x1 = x1.max(x);
        y1 = y1.max(y);
    }
    if x1 - x0 < 2.0 * r || y1 - y0 < 2.0 * r {
        return Err(Error::invalid(format!(
            "orostats: a disk of radius {r} m does not fit in the DEM ({:.0} x {:.0} m); give a smaller radius",
            x1 - x0,
            y1 - y0
        )));
    }
    let centres = poisson_disc(
        x0 + r,
        y0 + r,
        x1 - r,
        y1 - r,
        opts.separation_m,
        opts.seed,
        opts.max_disks,
    );
    if centres.is_empty() {
        return Err(Error::invalid(format!(
            "orostats: a separation of {} m is too small for a {:.0} x {:.0} m DEM (over 16 M sampler cells); give a larger separation or radius",
            opts.separation_m,
            x1 - x0,
            y1 - y0
        )));
    }
    let nh: usize = FEATURES.iter().map(|f| f.edges.len() - 1).sum();
    let mut disks = Vec::new();
    for (cx, cy) in centres {
        let Some((col, row)) = frame.to_pixel(cx, cy) else {
            continue;
        };
        // Disk cells: a bounding box in pixels from the metric cell size.
        let (sx, sy) = frame.cell_size_m(row);
        let (rc, rr) = ((r / sx).ceil() as i64 + 1, (r / sy).ceil() as i64 + 1);
        let (c0, c1) = (col as i64 - rc, col as i64 + rc);
        let (r0, r1) = (row as i64 - rr, row as i64 + rr);
        let (mut valid, mut total) = (0usize, 0usize);
        let (mut lo, mut hi) = (INF, -INF);
        for yy in r0.max(0)..=r1.min(h as i64 - 1) {
            for xx in c0.max(0)..=c1.min(w as i64 - 1) {
                let (px, py) = frame.xy(xx as f64, yy as f64);
                if (px - cx).hypot(py - cy) > r {
                    continue;
                }
                total += 1;
                let z = dem.get(xx as usize, yy as usize);
                if z.is_finite() {
                    valid += 1;
                    lo = lo.min(z as f64);
                    hi = hi.max(z as f64);
                }
            }
        }
        if total == 0 || (valid as f64) < opts.min_valid_fraction * total as f64 {
            continue;
        }
        let inside: Vec<&PeakRec> = recs
            .iter()
            .filter(|p| (p.x - cx).hypot(p.y - cy) <= r)
            .collect();
        let counts = disk_counts(&inside, lo, hi, nh);
        let mut values = normalise(&counts);
        let area_km2 = std::f64::consts::PI * r * r / 1e6 * valid as f64 / total as f64;
        values.push(inside.len() as f64 / area_km2 * 100.0);
        let pts: Vec<(f64, f64)> = inside.iter().map(|p| (p.x, p.y)).collect();
        let nni = nearest_neighbor_index(
            &pts,
            std::f64::consts::PI * r * r,
            std::f64::consts::TAU * r,
        )
        .map(|n| n.ratio_corrected)
        .unwrap_or(0.0);
        values.push(nni);
        disks.push(DiskFeatures {
            label: label.to_string(),
            source: source.to_string(),
            col,
            row,
            n_peaks: inside.len(),
            values,
            counts,
        });
    }
    // Whole domain.
    let mut valid_area_m2 = 0.0;
    for yy in 0..h {
        let (sx, sy) = georef.cell_size_m(yy as i64);
        let n = dem.row(yy).iter().filter(|z| z.is_finite()).count();
        valid_area_m2 += n as f64 * sx * sy;
    }
    let mut pooled = vec![0.0; nh];
    for d in &disks {
        for (a, b) in pooled.iter_mut().zip(&d.counts) {
            *a += b;
        }
    }
    let mut histograms = BTreeMap::new();
    let mut off = 0;
    for f in &FEATURES {
        let nb = f.edges.len() - 1;
        histograms.insert(
            f.name.to_string(),
            Histogram::from_counts(f.edges, &pooled[off..off + nb]),
        );
        off += nb;
    }
    let nbe = 20;
    let span = (dzmax - dzmin).max(1e-9);
    let edges: Vec<f64> = (0..=nbe)
        .map(|i| dzmin + span * i as f64 / nbe as f64)
        .collect();
    let mut ec = vec![0.0; nbe];
    for p in &recs {
        if let Some(b) = bin_of(&edges, p.elevation) {
            ec[b] += 1.0;
        }
    }
    let all: Vec<(f64, f64)> = recs.iter().map(|p| (p.x, p.y)).collect();
    let perim = 2.0 * ((x1 - x0) + (y1 - y0));
    let nni = nearest_neighbor_index(&all, valid_area_m2, perim)
        .map(|n| n.ratio_corrected)
        .unwrap_or(0.0);
    let area_km2 = valid_area_m2 / 1e6;
    let profile = OroProfile {
        format: "orogen-oroprofile".into(),
        version: 1,
        label: label.to_string(),
        sources: vec![source.to_string()],
        min_prominence: opts.min_prominence,
        radius_m: r,
        n_disks: disks.len(),
        n_peaks: recs.len(),
        area_km2,
        peak_density_per_km2: if area_km2 > 0.0 {
            recs.len() as f64 / area_km2
        } else {
            0.0
        },
        elevation: Histogram::from_counts(&edges, &ec),
        histograms,
        nni,
    };
    Ok(OroStats {
        disks,
        profile,
        tree,
    })
}

/// Raw histogram counts of the peaks of one disk (zmin, zmax: the disk's cells).
fn disk_counts(inside: &[&PeakRec], zmin: f64, zmax: f64, nh: usize) -> Vec<f64> {
    let mut counts = vec![0.0; nh];
    let maxp = inside
        .iter()
        .map(|p| p.prominence)
        .filter(|v| v.is_finite())
        .fold(0.0, f64::max);
    for p in inside {
        let vals: [Option<f64>; 10] = [
            Some(metrics::normalised_elevation(p.elevation, zmin, zmax)),
            Some(p.prominence),
            (maxp > 0.0).then(|| p.prominence / maxp),
            p.dominance,
            p.dominance.and_then(dominance_group).map(|g| g as f64),
            p.iso_km,
            p.iso_dir,
            p.saddle_km,
            p.saddle_dir,
            Some(metrics::relevance(
                p.prominence,
                maxp,
                p.elevation,
                zmin,
                zmax,
            )),
        ];
        let mut off = 0;
        for (f, v) in FEATURES.iter().zip(vals) {
            if let Some(b) = v.and_then(|v| bin_of(f.edges, v)) {
                counts[off + b] += 1.0;
            }
            off += f.edges.len() - 1;
        }
    }
    counts
}

/// Per-feature normalisation of raw counts.
fn normalise(counts: &[f64]) -> Vec<f64> {
    let mut out = Vec::with_capacity(counts.len() + SCALARS.len());
    let mut off = 0;
    for f in &FEATURES {
        let nb = f.edges.len() - 1;
        out.extend(Histogram::from_counts(f.edges, &counts[off..off + nb]).p);
        off += nb;
    }
    out
}

impl OroProfile {
    /// Save as pretty JSON.
    pub fn save(&self, path: &Path) -> Result<()> {
        let text = serde_json::to_string_pretty(self)
            .map_err(|e| Error::invalid(format!("profile does not serialise: {e}")))?;
        crate::io::atomic::write_file_atomic(path, text.as_bytes())
    }

    /// Load and check a profile written by [`OroProfile::save`].
    pub fn load(path: &Path) -> Result<OroProfile> {
        let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
        if meta.len() > 64 << 20 {
            return Err(Error::too_large(
                path,
                "an orometry profile is a few KB; this file is over 64 MiB",
            ));
        }
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        let p: OroProfile = serde_json::from_str(&text).map_err(|e| {
            Error::corrupt(
                path,
                format!("not an orometry profile written by orogen: {e}"),
            )
        })?;
        if p.format != "orogen-oroprofile" || p.version != 1 {
            return Err(Error::unsupported(
                path,
                format!(
                    "profile format {:?} version {}; expected orogen-oroprofile 1",
                    p.format, p.version
                ),
            ));
        }
        for hst in p.histograms.values().chain([&p.elevation]) {
            if hst.edges.len() != hst.p.len() + 1
                || hst.p.iter().any(|v| !(v.is_finite() && *v >= 0.0))
            {
                return Err(Error::corrupt(
                    path,
                    "a histogram has inconsistent edges or invalid probabilities",
                ));
            }
        }
        Ok(p)
    }

    /// Distance to another profile per feature: the total variation
    /// distance ½ Σ|p − q| of each pooled histogram present in both (0 =
    /// identical, 1 = disjoint), plus `peak_density` as |a − b| / max(a, b).
    pub fn compare(&self, other: &OroProfile) -> BTreeMap<String, f64> {
        let mut out = BTreeMap::new();
        for (k, a) in &self.histograms {
            if let Some(b) = other.histograms.get(k) {
                if a.p.len() == b.p.len() {
                    let d: f64 = a.p.iter().zip(&b.p).map(|(x, y)| (x - y).abs()).sum();
                    out.insert(k.clone(), 0.5 * d);
                }
            }
        }
        let (a, b) = (self.peak_density_per_km2, other.peak_density_per_km2);
        let m = a.max(b);
        out.insert(
            "peak_density".into(),
            if m > 0.0 { (a - b).abs() / m } else { 0.0 },
        );
        out
    }
}

/// CSV of feature vectors: `label,source,col,row,n_peaks,` then [`feature_names`].
pub fn write_features_csv(path: &Path, disks: &[DiskFeatures]) -> Result<()> {
    let mut s = String::from("label,source,col,row,n_peaks");
    for n in feature_names() {
        s.push(',');
        s.push_str(&n);
    }
    s.push('\n');
    for d in disks {
        s.push_str(&format!(
            "{},{},{},{},{}",
            csv_field(&d.label),
            csv_field(&d.source),
            d.col,
            d.row,
            d.n_peaks
        ));
        for v in &d.values {
            s.push_str(&format!(",{v}"));
        }
        s.push('\n');
    }
    crate::io::atomic::write_file_atomic(path, s.as_bytes())
}

/// Labels and sources may not hold commas, quotes or newlines in this
/// simple CSV: they are replaced by '_'.
fn csv_field(s: &str) -> String {
    s.chars()
        .map(|c| {
            if matches!(c, ',' | '"' | '\n' | '\r') {
                '_'
            } else {
                c
            }
        })
        .collect()
}

/// JSON of feature vectors: `{"names": [...], "disks": [...]}`.
pub fn write_features_json(path: &Path, disks: &[DiskFeatures]) -> Result<()> {
    let v = serde_json::json!({"names": feature_names(), "disks": disks});
    let text = serde_json::to_string(&v)
        .map_err(|e| Error::invalid(format!("features do not serialise: {e}")))?;
    crate::io::atomic::write_file_atomic(path, text.as_bytes())
}
