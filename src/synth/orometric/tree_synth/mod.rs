//! Divide-tree synthesis (Argudo et al. 2019, "Orometry-based terrain
//! analysis and synthesis", ACM TOG 38(6), §5).
//!
//! 1. Peak count from the profile's density (or given); elevations are
//!    stratified samples of the elevation histogram, placed in decreasing
//!    order (user-fixed peaks first, where the user put them).
//! 2. Dart throwing: a candidate for a peak of elevation h is accepted with
//!    probability C_P(p) · n(C_H(p) − h) · p(isolation) · p(direction), with
//!    the user maps C_P (density) and C_H (coarse elevation), n a Gaussian of
//!    σ = 1/20 of C_H's range. Isolation and its direction are matched by
//!    proposing candidates at a target isolation distance (a stratified
//!    sample of the profile's isolation histogram, larger for higher peaks)
//!    in a target direction (stratified from the direction histogram) from a
//!    random higher peak, accepted when no higher peak is much closer; after
//!    a bounded number of failures the best of a few uniform darts is taken.
//! 3. Ridges: the Delaunay triangulation of the peaks (spade) and its
//!    minimum spanning tree (Kruskal) with weights ‖Pi − Pj‖ / min(h_i, h_j)^ρ.
//! 4. One saddle per ridge at a random split point (t ∈ [0.35, 0.65]) moved
//!    sideways by up to 10 % of the ridge length; saddle elevations by
//!    optimal assignment ([`super::assign`]).
//!
//! 5. Multi-pass placement by prominence bins ([`TreeOptions::passes`]):
//!    bins of 1 : 2 : 4 : … parts, the most prominent placed first; before
//!    each later pass the ridges (Delaunay MST) of the peaks placed so far
//!    are rasterised, diffused and multiplied into C_P, so less prominent
//!    peaks gather along the ridges of the prominent ones.
//! 6. Authoring: fixed peaks, ridges kept verbatim between them (a pasted
//!    real fragment, [`super::fragment`]), keep-out rectangles, and a type
//!    map C_T giving each region its own profile ([`super::typemap`]): the
//!    peak count, elevations, isolation and saddle targets of a peak come
//!    from the profile of the region it is placed in.

mod maps;
mod options;
mod ridges;
mod tree;
pub use maps::coherent_elevation_map;
pub use options::{
    TreeOptions, DEFAULT_ISOLATION_STRETCH, DEFAULT_PASSES, DEFAULT_RIDGE_ATTRACTION,
    DEFAULT_RIDGE_BASE, DEFAULT_RIDGE_CONTRAST, DEFAULT_TYPE_BLEND_M, MAX_PEAKS, MAX_SIDE,
};
pub use ridges::{pass_of_rank, ridge_tree, ridge_tree_with, FixedRidge};

use super::assign::{
    assign_saddles_grouped, refine_histograms, GroupTargets, SaddleProblem, PROMINENCE_MARGIN,
};
use super::clearance::{clear_ridges, Node};
use super::profile::SynthProfile;
use crate::error::{Error, Result};
use crate::oro::stats::SplitMix64;
use crate::raster::Grid;
use maps::coherent_map_with;
use maps::DomainMap;
use maps::PeakGrid;
use ridges::ridge_density;
use serde::{Deserialize, Serialize};

/// A peak of a synthesised divide tree. Coordinates are metres from the
/// top-left corner of the domain, x east, y south (down the rows).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SynthPeak {
    pub x: f64,
    pub y: f64,
    pub elevation: f64,
    /// Placed by the user (kept by edits and re-synthesis).
    #[serde(default)]
    pub fixed: bool,
}

/// A saddle on the ridge between two peaks.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SynthSaddle {
    pub x: f64,
    pub y: f64,
    pub elevation: f64,
    /// Indices into [`SynthTree::peaks`] of the ridge's two ends.
    pub peaks: [usize; 2],
}

/// A synthesised (or edited) divide tree on a rectangular domain: JSON,
/// editable; [`SynthTree::validate`] checks an edited tree.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SynthTree {
    /// Always "orogen-synthtree".
    pub format: String,
    pub version: u32,
    /// Domain in cells and cell size in metres.
    pub width: usize,
    pub height: usize,
    pub cell: f64,
    /// Seed of the synthesis; terrain generation derives its own from it.
    pub seed: u64,
    /// Prominence threshold of the profile it was made from (m).
    pub min_prominence: f64,
    pub peaks: Vec<SynthPeak>,
    pub saddles: Vec<SynthSaddle>,
}

/// Least distance from a peak to a ridge the tree joins to it only below
/// both ([`clear_ridges`]): cells (a raster joins crest points with one cell
/// between them), plus metres for part of the terrain's ridge jitter. Three
/// cells plus 50 m moved 45 % of the Alps profile's peaks and doubled the
/// isolation error; this moves about 4 % (docs/design/orometric-synthesis.md#ridge-clearance-clearancers).
pub const RIDGE_CLEARANCE_CELLS: f64 = 2.0;

/// See [`RIDGE_CLEARANCE_CELLS`].
pub const RIDGE_CLEARANCE_M: f64 = 25.0;

/// A join counts as offending when it stands more than this fraction of the
/// prominence threshold above the tree's pass height: the terrain noise's
/// bound (below half the threshold), within which the check accepts
/// elevations anyway.
pub const RIDGE_CLEARANCE_TOL: f64 = 0.5;

/// A peak still to place: its targets and region, and its pass.
struct Job {
    elev: f64,
    iso: f64,
    dir: f64,
    region: usize,
    pass: usize,
}

/// Synthesise a divide tree matching `profile` on the domain of `opts`
/// (with a type map C_T, `profile` holds wherever the map's label has no
/// profile of its own).
pub fn synthesize_tree(profile: &SynthProfile, opts: &TreeOptions) -> Result<SynthTree> {
    profile.validate()?;
    let (w, h, cell) = (opts.width, opts.height, opts.cell);
    if w == 0 || h == 0 || w > MAX_SIDE || h > MAX_SIDE {
        return Err(Error::invalid(format!(
            "synthesis domain {w}x{h} cells: each side must be 1..{MAX_SIDE}"
        )));
    }
    if !(cell.is_finite() && cell > 0.0) {
        return Err(Error::invalid(
            "the cell size must be a positive number of metres",
        ));
    }
    if opts.rho > 2 {
        return Err(Error::invalid(
            "rho (the ridge weight exponent) must be 0, 1 or 2",
        ));
    }
    if !(opts.isolation_stretch.is_finite() && opts.isolation_stretch > 0.0) {
        return Err(Error::invalid(
            "isolation_stretch must be a positive number",
        ));
    }
    if !(opts.type_blend_m.is_finite() && opts.type_blend_m >= 0.0) {
        return Err(Error::invalid(
            "type_blend_m (the blend band at type-map borders) must be a number ≥ 0 m",
        ));
    }
    if opts.passes == 0 || opts.passes > 16 {
        return Err(Error::invalid(
            "passes (prominence bins placed one after the other) must be 1..16",
        ));
    }
    if !(0.0..=1.0).contains(&opts.ridge_attraction) {
        return Err(Error::invalid(
            "ridge_attraction must lie in [0, 1] (0: ridges of earlier passes do not attract peaks)",
        ));
    }
    let (wm, hm) = (w as f64 * cell, h as f64 * cell);
    let area_km2 = wm * hm / 1e6;
    // Regions: 0 = `profile`, then the type map's labelled profiles.
    let tm = opts.type_map.as_ref();
    let mut profiles: Vec<&SynthProfile> = vec![profile];
    if let Some(t) = tm {
        profiles.extend(t.regions.iter().map(|r| &r.1));
    }
    let nreg = profiles.len();
    let region_at = |x: f64, y: f64| -> Option<usize> {
        match tm {
            None => Some(0),
            Some(t) => t.region_at(x / wm, y / hm),
        }
    };
    let frac = match tm {
        None => vec![1.0],
        Some(t) => t.fractions(),
    };
    // Peaks wanted per region: density × area (or `n_peaks` shared in
    // proportion to it, largest remainders).
    let mut want: Vec<usize> = (0..nreg)
        .map(|r| (profiles[r].peak_density_per_km2 * area_km2 * frac[r]).round() as usize)
        .collect();
    if let Some(total) = opts.n_peaks {
        if nreg == 1 {
            want[0] = total;
        } else {
            let wts: Vec<f64> = (0..nreg)
                .map(|r| profiles[r].peak_density_per_km2 * frac[r])
                .collect();
            let sw: f64 = wts.iter().sum();
            if sw <= 0.0 {
                return Err(Error::invalid("the type map leaves no region with peaks"));
            }
            let raw: Vec<f64> = wts.iter().map(|v| v / sw * total as f64).collect();
            want = raw.iter().map(|v| v.floor() as usize).collect();
            let mut rest: Vec<usize> = (0..nreg).collect();
            rest.sort_by(|&a, &b| {
                (raw[b] - raw[b].floor())
                    .total_cmp(&(raw[a] - raw[a].floor()))
                    .then(a.cmp(&b))
            });
            let short = total - want.iter().sum::<usize>();
            for &r in rest.iter().take(short) {
                want[r] += 1;
            }
        }
    }
    let n_wanted: usize = want.iter().sum();
    if n_wanted.max(opts.fixed_peaks.len()) > MAX_PEAKS {
        return Err(Error::invalid(format!(
            "{} peaks requested; at most {MAX_PEAKS} per synthesis (use a smaller domain or density)",
            n_wanted.max(opts.fixed_peaks.len())
        )));
    }
    for f in &opts.fixed_peaks {
        if !(f.x.is_finite() && f.y.is_finite() && f.elevation.is_finite()) {
            return Err(Error::invalid(
                "a fixed peak has a non-finite coordinate or elevation",
            ));
        }
        if f.x < 0.0 || f.y < 0.0 || f.x >= wm || f.y >= hm {
            return Err(Error::invalid(format!(
                "fixed peak at ({:.0}, {:.0}) m lies outside the {wm:.0} x {hm:.0} m domain",
                f.x, f.y
            )));
        }
        if f.elevation <= 0.0 {
            return Err(Error::invalid("a fixed peak must be above 0 m"));
        }
    }
    // Free peaks per region: what is wanted less the fixed peaks there.
    let mut fixed_in = vec![0usize; nreg];
    for f in &opts.fixed_peaks {
        fixed_in[region_at(f.x, f.y).unwrap_or(0)] += 1;
    }
    let mut n_free: Vec<usize> = (0..nreg)
        .map(|r| want[r].saturating_sub(fixed_in[r]))
        .collect();
    if opts.fixed_peaks.is_empty() && n_free.iter().all(|&k| k == 0) {
        let big = (0..nreg)
            .max_by(|&a, &b| frac[a].total_cmp(&frac[b]).then(b.cmp(&a)))
            .unwrap_or(0);
        n_free[big] = 1;
    }
    let n = opts.fixed_peaks.len() + n_free.iter().sum::<usize>();
    // Peaks need distinct cells with room around them.
    if n as f64 * 4.0 > (w as f64) * (h as f64) {
        return Err(Error::invalid(format!(
            "{n} peaks do not fit in {w}x{h} cells (at most one per 4 cells); give a larger domain or a coarser cell"
        )));
    }
    let cp = match &opts.density_map {
        Some(g) => {
            let max = g
                .data()
                .iter()
                .filter(|v| v.is_finite())
                .fold(0.0f32, |a, &b| a.max(b));
            if g.data().iter().any(|v| v.is_finite() && *v < 0.0) {
                return Err(Error::invalid(
                    "the density map has negative values; densities must be ≥ 0",
                ));
            }
            if max <= 0.0 {
                return Err(Error::invalid(
                    "the density map is zero (or nodata) everywhere: no place may hold a peak",
                ));
            }
            Some((
                DomainMap {
                    g,
                    sx: g.width() as f64 / wm,
                    sy: g.height() as f64 / hm,
                },
                max as f64,
            ))
        }
        None => None,
    };
    // Without a user C_H, a coherent one: low-frequency fBm whose values are
    // mapped through the profile's peak-elevation quantiles, so high peaks
    // gather in massifs as in real ranges instead of landing next to low ones
    // (with a type map: the quantiles of the region's profile).
    // With a type map, the coherent map holds the fBm's rank fraction u and
    // a peak of region r reads r's quantile q_r(u) with r's σ (1/20 of its
    // elevation range): in a blend band each region's peaks keep their own
    // elevations (a blended elevation would suit neither side).
    let auto_ch;
    let mut rank_map = None;
    let ch_src = match &opts.elevation_map {
        Some(g) => Some(g),
        None if opts.coherent => match tm {
            None => {
                auto_ch = coherent_elevation_map(profile, w, h, opts.seed);
                Some(&auto_ch)
            }
            Some(_) => {
                rank_map = Some(coherent_map_with(w, h, opts.seed, |u, _, _| u));
                None
            }
        },
        None => None,
    };
    let rank_map = rank_map.as_ref().map(|g| DomainMap {
        g,
        sx: g.width() as f64 / wm,
        sy: g.height() as f64 / hm,
    });
    let region_sigma: Vec<f64> = profiles
        .iter()
        .map(|p| ((p.elevation.quantile(1.0) - p.elevation.quantile(0.0)) / 20.0).max(1.0))
        .collect();
    let (blend_fx, blend_fy) = (opts.type_blend_m / wm, opts.type_blend_m / hm);
    let ch = match ch_src {
        Some(g) => {
            let (lo, hi) = g
                .data()
                .iter()
                .filter(|v| v.is_finite())
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                    (a.min(v as f64), b.max(v as f64))
                });
            if !lo.is_finite() {
                return Err(Error::invalid("the elevation map has no valid cells"));
            }
            let sigma = ((hi - lo) / 20.0).max(1.0);
            Some((
                DomainMap {
                    g,
                    sx: g.width() as f64 / wm,
                    sy: g.height() as f64 / hm,
                },
                sigma,
            ))
        }
        None => None,
    };
    let mut rng = SplitMix64(opts.seed ^ 0x6f72_6f73_796e_7468);
    let snap =
        |v: f64, nmax: usize| ((v / cell).floor().clamp(0.0, nmax as f64 - 1.0) + 0.5) * cell;

    // Per region: elevations stratified, decreasing; isolation targets
    // (m) stratified, larger for higher peaks with a random rank jitter
    // (real isolation correlates with elevation rank, not perfectly);
    // directions stratified sectors, shuffled.
    let mut jobs: Vec<Job> = Vec::with_capacity(n);
    for (r, prof) in profiles.iter().enumerate() {
        let nf = n_free[r];
        if nf == 0 {
            continue;
        }
        let mut elev = prof.elevation.stratified(nf);
        elev.reverse();
        let mut iso: Vec<f64> = prof
            .isolation_km
            .stratified(nf)
            .into_iter()
            .map(|d| d * 1000.0 * opts.isolation_stretch)
            .collect();
        let keys: Vec<f64> = (0..nf)
            .map(|i| i as f64 + (rng.unit() - 0.5) * 0.5 * nf as f64)
            .collect();
        let mut idx: Vec<usize> = (0..nf).collect();
        idx.sort_by(|&a, &b| keys[a].total_cmp(&keys[b]).then(a.cmp(&b)));
        iso.sort_by(|a, b| b.total_cmp(a));
        let mut iso_of = vec![0.0; nf];
        for (rank, &i) in idx.iter().enumerate() {
            iso_of[i] = iso[rank];
        }
        let mut dirs = prof.isolation_dir.stratified(nf);
        for i in (1..dirs.len()).rev() {
            let j = rng.below(i as u64 + 1) as usize;
            dirs.swap(i, j);
        }
        // Prominence bins: the prominence rank of a peak is its elevation
        // rank with a random jitter (prominent peaks are mostly high ones;
        // the saddle assignment sets the prominences later).
        let mut pass = vec![0usize; nf];
        if opts.passes > 1 {
            let pk: Vec<f64> = (0..nf)
                .map(|i| i as f64 + (rng.unit() - 0.5) * 0.5 * nf as f64)
                .collect();
            let mut pidx: Vec<usize> = (0..nf).collect();
            pidx.sort_by(|&a, &b| pk[a].total_cmp(&pk[b]).then(a.cmp(&b)));
            for (rank, &i) in pidx.iter().enumerate() {
                pass[i] = pass_of_rank(rank, nf, opts.passes);
            }
        }
        for i in 0..nf {
            jobs.push(Job {
                elev: elev[i],
                iso: iso_of[i],
                dir: dirs[i],
                region: r,
                pass: pass[i],
            });
        }
    }
    // Placement order: pass by pass, each in decreasing elevation.
    jobs.sort_by(|a, b| a.pass.cmp(&b.pass).then(b.elev.total_cmp(&a.elev)));

    let min_sep = 2.0 * cell;
    let typical = (wm * hm / n as f64).sqrt().max(min_sep);
    let mut grid = PeakGrid::new(wm, hm, typical);
    let mut peaks: Vec<SynthPeak> = Vec::with_capacity(n);
    let mut group_of_peak: Vec<usize> = Vec::with_capacity(n);
    for f in &opts.fixed_peaks {
        let (x, y) = (snap(f.x, w), snap(f.y, h));
        if grid.nearest_higher(&peaks, x, y, f64::NEG_INFINITY, min_sep) < min_sep {
            return Err(Error::invalid(format!(
                "fixed peaks at ({:.0}, {:.0}) m are closer than two cells to another fixed peak",
                f.x, f.y
            )));
        }
        grid.insert(peaks.len(), x, y);
        peaks.push(SynthPeak {
            x,
            y,
            elevation: f.elevation,
            fixed: true,
        });
        group_of_peak.push(region_at(x, y).unwrap_or(0));
    }
    let n_fixed = peaks.len();
    let kept_out = |x: f64, y: f64| {
        opts.keep_out
            .iter()
            .any(|k| x >= k[0] && x <= k[2] && y >= k[1] && y <= k[3])
    };
    let accept_maps = |rng: &mut SplitMix64,
                       x: f64,
                       y: f64,
                       hh: f64,
                       region: usize,
                       ridges: Option<&DomainMap>|
     -> bool {
        if let Some(t) = tm {
            if t.region_blended(x / wm, y / hm, blend_fx, blend_fy, opts.seed) != Some(region) {
                return false;
            }
        }
        if kept_out(x, y) {
            return false;
        }
        if let Some((m, max)) = &cp {
            let v = m.at(x, y);
            if !(v.is_finite() && rng.unit() * max < v) {
                return false;
            }
        }
        if let Some((m, sigma)) = &ch {
            let v = m.at(x, y);
            if !v.is_finite() {
                return false;
            }
            let z = (v - hh) / sigma;
            if rng.unit() >= (-0.5 * z * z).exp() {
                return false;
            }
        }
        if let Some(m) = &rank_map {
            let v = profiles[region].elevation.quantile(m.at(x, y));
            let z = (v - hh) / region_sigma[region];
            if rng.unit() >= (-0.5 * z * z).exp() {
                return false;
            }
        }
        if let Some(m) = ridges {
            let a = opts.ridge_attraction;
            if rng.unit() >= (1.0 - a) + a * m.at(x, y) {
                return false;
            }
        }
        true
    };
    let margin = cell;
    let mut max_placed = peaks
        .iter()
        .map(|p| p.elevation)
        .fold(f64::NEG_INFINITY, f64::max);
    let mut ridge_grid: Option<Grid<f32>> = None;
    let mut cur_pass = 0usize;
    for job in &jobs {
        if job.pass != cur_pass {
            cur_pass = job.pass;
            // The ridges of the peaks placed so far attract the next bins.
            ridge_grid = if opts.ridge_attraction > 0.0 && peaks.len() >= 2 {
                Some(ridge_density(&peaks, opts.rho, wm, hm, typical)?)
            } else {
                None
            };
        }
        let rmap = ridge_grid.as_ref().map(|g| DomainMap {
            g,
            sx: g.width() as f64 / wm,
            sy: g.height() as f64 / hm,
        });
        let hh = job.elev;
        let d = job.iso.max(min_sep);
        let mut placed = None;
        // Proposals from a random higher peak at the target distance and
        // direction (some placed peak is at least as high iff the highest
        // placed one is).
        let have_higher = max_placed >= hh;
        if have_higher {
            for _ in 0..64 {
                // Random placed peak that is at least as high.
                let mut q = rng.below(peaks.len() as u64) as usize;
                let mut guard = 0;
                while peaks[q].elevation < hh && guard < 8 {
                    q = rng.below(peaks.len() as u64) as usize;
                    guard += 1;
                }
                if peaks[q].elevation < hh {
                    continue;
                }
                let theta = ((job.dir.floor() * 45.0) + (rng.unit() - 0.5) * 45.0).to_radians();
                // Vector from the new peak to q points along bearing theta.
                let x = peaks[q].x - d * theta.sin();
                let y = peaks[q].y + d * theta.cos();
                if x < margin || y < margin || x > wm - margin || y > hm - margin {
                    continue;
                }
                let (x, y) = (snap(x, w), snap(y, h));
                let dn = grid.nearest_higher(&peaks, x, y, hh, d * 1.5);
                let dall = grid.nearest_higher(&peaks, x, y, f64::NEG_INFINITY, min_sep * 2.0);
                if dn >= 0.85 * d
                    && dall >= min_sep
                    && accept_maps(&mut rng, x, y, hh, job.region, rmap.as_ref())
                {
                    placed = Some((x, y));
                    break;
                }
            }
        }
        if placed.is_none() {
            // Uniform darts: the best isolation match among a few accepted ones.
            let mut best: Option<(f64, f64, f64)> = None;
            for _ in 0..256 {
                let x = snap(margin + rng.unit() * (wm - 2.0 * margin), w);
                let y = snap(margin + rng.unit() * (hm - 2.0 * margin), h);
                let dall = grid.nearest_higher(&peaks, x, y, f64::NEG_INFINITY, min_sep * 2.0);
                if dall < min_sep || !accept_maps(&mut rng, x, y, hh, job.region, rmap.as_ref()) {
                    continue;
                }
                let dn = if have_higher {
                    grid.nearest_higher(&peaks, x, y, hh, d * 4.0)
                } else {
                    d
                };
                let score = (dn / d).ln().abs();
                if best.is_none_or(|b| score < b.2) {
                    best = Some((x, y, score));
                }
                if score < 0.1 {
                    break;
                }
            }
            placed = best.map(|b| (b.0, b.1));
        }
        if let Some((x, y)) = placed {
            max_placed = max_placed.max(hh);
            grid.insert(peaks.len(), x, y);
            peaks.push(SynthPeak {
                x,
                y,
                elevation: hh,
                fixed: false,
            });
            group_of_peak.push(job.region);
        }
    }
    if peaks.is_empty() {
        return Err(Error::invalid(
            "no peak could be placed (the density map leaves no room?)",
        ));
    }
    // Ridges (the pasted fragment's first, verbatim) and saddles.
    let mut forced = Vec::with_capacity(opts.fixed_ridges.len());
    for (k, fr) in opts.fixed_ridges.iter().enumerate() {
        let [a, b] = fr.peaks;
        if a >= n_fixed || b >= n_fixed {
            return Err(Error::invalid(format!(
                "kept ridge {k} joins fixed peaks {a} and {b}, but there are {n_fixed} fixed peaks"
            )));
        }
        let lo = peaks[a].elevation.min(peaks[b].elevation);
        let ok = fr.elevation.is_finite()
            && fr.elevation >= 0.0
            && fr.elevation < lo
            && fr.x.is_finite()
            && fr.y.is_finite();
        if !ok || fr.x < 0.0 || fr.y < 0.0 || fr.x >= wm || fr.y >= hm {
            return Err(Error::invalid(format!(
                "kept ridge {k}: its saddle must lie in the domain, between 0 m and its lower peak ({lo} m)"
            )));
        }
        forced.push((a, b));
    }
    if !(opts.ridge_contrast.is_finite() && opts.ridge_contrast >= 1.0) {
        return Err(Error::invalid(
            "ridge_contrast must be a number ≥ 1 (1: ridge weights on absolute elevations)",
        ));
    }
    if !(opts.ridge_base.is_finite() && (0.0..1.0).contains(&opts.ridge_base)) {
        return Err(Error::invalid(
            "ridge_base must be a fraction in [0, 1) of the lowest peak (0: the contrast alone)",
        ));
    }
    let edges = {
        // Ridge weights on the relief above a common base (see
        // `TreeOptions::ridge_contrast`); `ridge_tree_with` floors it at 1 m.
        let (lowest, highest) = peaks
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                (a.min(p.elevation), b.max(p.elevation))
            });
        let thr = profiles
            .iter()
            .map(|p| p.min_prominence)
            .fold(0.0f64, f64::max);
        let c = opts.ridge_contrast;
        let by_contrast = if c > 1.0 {
            (c * lowest - highest) / (c - 1.0)
        } else {
            0.0
        };
        let base = by_contrast
            .max(opts.ridge_base * lowest)
            .clamp(0.0, (lowest - thr).max(0.0));
        if base > 0.0 {
            let rel: Vec<SynthPeak> = peaks
                .iter()
                .map(|p| SynthPeak {
                    elevation: p.elevation - base,
                    ..p.clone()
                })
                .collect();
            ridge_tree_with(&rel, opts.rho, &forced, &[])?
        } else {
            ridge_tree_with(&peaks, opts.rho, &forced, &[])?
        }
    };
    let mut saddles = Vec::with_capacity(edges.len());
    let mut hmax = Vec::with_capacity(edges.len());
    let mut pinned = Vec::with_capacity(edges.len());
    for (e, &(i, j)) in edges.iter().enumerate() {
        let (a, b) = (&peaks[i], &peaks[j]);
        let lo = a.elevation.min(b.elevation);
        if let Some(fr) = opts.fixed_ridges.get(e) {
            // `ridge_tree_with` puts the forced ridges first, in order.
            saddles.push(SynthSaddle {
                x: snap(fr.x, w),
                y: snap(fr.y, h),
                elevation: fr.elevation,
                peaks: [i, j],
            });
            hmax.push(fr.elevation);
            pinned.push(true);
            continue;
        }
        let t = 0.35 + 0.3 * rng.unit();
        let off = (rng.unit() - 0.5) * 0.2;
        let (dx, dy) = (b.x - a.x, b.y - a.y);
        let mut x = a.x + t * dx - off * dy;
        let mut y = a.y + t * dy + off * dx;
        x = snap(x.clamp(0.0, wm - 1e-9), w);
        y = snap(y.clamp(0.0, hm - 1e-9), h);
        // A saddle must not share a peak's cell.
        if (x == a.x && y == a.y) || (x == b.x && y == b.y) {
            x = snap(a.x + 0.5 * dx, w);
            y = snap(a.y + 0.5 * dy, h);
        }
        saddles.push(SynthSaddle {
            x,
            y,
            elevation: 0.0,
            peaks: [i, j],
        });
        // Saddles stay at least 1 m (or 1 %) below both ends.
        hmax.push(lo - (0.01 * lo).clamp(0.0, 1.0).max(0.01));
        pinned.push(false);
    }
    let hp: Vec<f64> = peaks.iter().map(|p| p.elevation).collect();
    let ns = edges.len();
    let thr_of: Vec<f64> = profiles.iter().map(|p| p.min_prominence).collect();
    if ns > 0 {
        let groups: Vec<GroupTargets> = profiles
            .iter()
            .map(|p| GroupTargets {
                prominence: &p.prominence,
                dominance: &p.dominance,
            })
            .collect();
        // Start: each saddle a random prominence (of the profile of its
        // lower end) below its lower end.
        let mut hs: Vec<f64> = (0..ns)
            .map(|e| {
                if pinned[e] {
                    return saddles[e].elevation;
                }
                let (i, j) = edges[e];
                let low = if hp[i] <= hp[j] { i } else { j };
                let k = rng.below(ns as u64) as usize;
                let t = profiles[group_of_peak[low]]
                    .prominence
                    .quantile((k as f64 + 0.5) / ns as f64);
                (hmax[e] - t).clamp(0.0, hmax[e].max(0.0))
            })
            .collect();
        let problem = SaddleProblem {
            h: &hp,
            edges: &edges,
            hmax: &hmax,
            floor: 0.0,
            group_of_peak: &group_of_peak,
            groups: &groups,
            thresholds: &thr_of,
            pinned: &pinned,
        };
        assign_saddles_grouped(&problem, &mut hs, opts.iterations)?;
        // Repair: a peak whose prominence fell below its profile's threshold
        // (owners change as saddles move) gets its key saddle lowered to the
        // threshold. Lowering saddles never lowers another peak's
        // prominence, so this converges. Pasted saddles stay as they are.
        for _ in 0..32 {
            let own = super::assign::owners(&hp, &edges, &hs);
            let mut changed = false;
            for (e, &o) in own.iter().enumerate() {
                let thr = thr_of[group_of_peak[o]];
                if !pinned[e]
                    && hp[o] - hs[e] < thr * PROMINENCE_MARGIN * (1.0 - 1e-9)
                    && hs[e] > 0.0
                {
                    hs[e] = (hp[o] - thr * PROMINENCE_MARGIN).max(0.0);
                    changed = true;
                }
            }
            if !changed {
                break;
            }
        }
        if opts.refine {
            refine_histograms(&problem, &mut hs, opts.seed)?;
        }
        for (s, v) in saddles.iter_mut().zip(hs) {
            s.elevation = v;
        }
    }
    let home: Vec<(f64, f64)> = peaks.iter().map(|p| (p.x, p.y)).collect();
    let mut tree = SynthTree {
        format: "orogen-synthtree".into(),
        version: 1,
        width: w,
        height: h,
        cell,
        seed: opts.seed,
        min_prominence: thr_of.iter().copied().fold(f64::INFINITY, f64::min),
        peaks,
        saddles,
    };
    // Peaks and saddles keep clear of ridges joined to them only lower
    // down; a moved peak stays in its region, outside kept-out ground and
    // where the density map allows peaks.
    let tol = RIDGE_CLEARANCE_TOL * tree.min_prominence;
    clear_ridges(
        &mut tree,
        RIDGE_CLEARANCE_CELLS * cell + RIDGE_CLEARANCE_M,
        tol,
        &mut |node, x, y| match node {
            Node::Peak(i) => {
                let (x0, y0) = home[i];
                region_at(x, y) == region_at(x0, y0)
                    && !kept_out(x, y)
                    && cp.as_ref().is_none_or(|(m, _)| {
                        let v = m.at(x, y);
                        v.is_finite() && v > 0.0
                    })
            }
            // A pasted fragment's saddles stay where they were measured.
            Node::Saddle(k) => !pinned[k],
        },
    );
    tree.validate()?;
    Ok(tree)
}
