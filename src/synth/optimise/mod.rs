//! Example-based terrain synthesis with pit removal: terrain optimisation
//! after Scott, J. J. & Dodgson, N. A. (2022), "Example-based terrain
//! synthesis with pit removal", Computers & Graphics 99, built on the
//! texture optimisation of Kwatra, Essa, Bobick & Kwatra (2005), "Texture
//! optimization for example-based synthesis", SIGGRAPH, with matches found
//! by (Generalized) PatchMatch (Barnes et al. 2009, 2010; see [`patchmatch`]).
//!
//! # Method
//! - Gaussian pyramids (Burt & Adelson REDUCE, [`pyramid`]) of the source
//!   (the exemplar) and of the guide, the guide first resampled bilinearly to
//!   the output size. Levels `k = 0` (finest, the output size) to `L`
//!   (coarsest); `L` is chosen so the coarsest output level is at least
//!   `max(4N, 24)` cells and the coarsest source level at least `3N` on its
//!   shorter side (at most 12), or given.
//! - Synthesis patches are `N x N` (default 7) on a grid with spacing `s`
//!   (default `⌊N/2⌋` = 3; Kwatra et al. 2005 use a spacing of about N/4 to
//!   N/2), the last row and column moved back to the edge; every cell is
//!   covered by up to ⌈N/s⌉² patches. A correspondence per patch: source
//!   centre (continuous), rotation angle, reflection, height offset.
//! - At the coarsest level the target starts as the guide and the
//!   correspondences at random; at finer levels the correspondences are
//!   upsampled ([`patchmatch::Level::upsample`]) and the target rebuilt from
//!   them. Then µ EM iterations (default 2): **M-step** = PatchMatch passes
//!   against the target (jump flooding, jumps 2^(P−1) … 1 patches);
//!   **E-step** = mean of the overlapping source patches; then the soft
//!   constraint `R^k = w_k G^k + (1 − w_k)·reconstruction`, and at every
//!   level but the finest, pit removal on `R^k` ([`pits`], sinks = the
//!   border and an optional mask). `R^k` is the next M-step's target. The
//!   expanded starting target of a level with pit removal is made pit-free
//!   as well (bilinear expansion can block diagonal channels).
//!   `pit_finest` extends removal to the finest level (not in the paper).
//! - Guide weight `w_k = α (2^k − 1)/(2^L − 1)` (the paper's exponential
//!   weighting; 0 at the finest level, α at the coarsest); `Linear`
//!   (`α k / L`), `Constant` (α) and `Zero` for comparison.
//!
//! # Energy
//! Each level records `Σ_p ‖R_p − z_p‖²` (sum of patch SSDs between the
//! target and its matched source patches) before the first M-step and after
//! every M- and E-step. The M-step only accepts strict improvements and the
//! E-step is the least-squares minimiser for fixed matches, so with guide
//! weight 0 and no pit removal (the finest level with the default weighting)
//! the sequence never increases.
//!
//! # Source nodata
//! Nodata (NaN) spreads through the source pyramid (a coarse cell is nodata
//! when its filter support touches nodata); a match is allowed only where its
//! whole footprint is valid (checked with a summed-area table of nodata
//! counts). A level without any valid position is an error.
//!
//! # Determinism
//! Every random choice hashes (seed, level, iteration, pass, patch,
//! candidate); passes read the previous map and write a new one; the E-step
//! gathers per cell in a fixed order. The output is the same bytes for any
//! number of threads.

pub mod patchmatch;
pub mod pits;
pub mod pyramid;

pub use pits::{
    depression_stats, detail_rms, drain_strictly, remove_pits, remove_shallow_pits,
    DepressionStats, PitRemoval,
};

use crate::error::{Error, Result};
use crate::raster::Grid;
use patchmatch::{mix, Corr, Geom, Level, SourceLevel, Space};

/// Largest output (cells) synthesised in memory.
pub const MAX_OUTPUT_CELLS: usize = 1 << 26;
/// Largest source (cells) accepted.
pub const MAX_SOURCE_CELLS: usize = 1 << 26;

/// How the guide's weight varies with the level.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Weighting {
    /// `α (2^k − 1)/(2^L − 1)` (Scott & Dodgson 2022).
    Exponential,
    /// `α k / L`.
    Linear,
    /// `α` at every level.
    Constant,
    /// The guide only initialises the coarsest level.
    Zero,
}

impl Weighting {
    /// Every weighting.
    pub const ALL: [Weighting; 4] = [
        Weighting::Exponential,
        Weighting::Linear,
        Weighting::Constant,
        Weighting::Zero,
    ];
    /// The name used on the command line and in jobs.
    pub fn name(self) -> &'static str {
        match self {
            Weighting::Exponential => "exponential",
            Weighting::Linear => "linear",
            Weighting::Constant => "constant",
            Weighting::Zero => "zero",
        }
    }
    /// Guide weight at level `k` of levels `0..=l`.
    pub fn weight(self, alpha: f32, k: usize, l: usize) -> f32 {
        match self {
            Weighting::Zero => 0.0,
            Weighting::Constant => alpha,
            _ if l == 0 => 0.0,
            Weighting::Linear => alpha * k as f32 / l as f32,
            Weighting::Exponential => alpha * ((1u64 << k) - 1) as f32 / ((1u64 << l) - 1) as f32,
        }
    }
}

/// The PatchMatch search space (Barnes et al. 2010).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SearchSpace {
    /// Continuous rotation angles.
    pub rotation: bool,
    /// Mirrored patches.
    pub reflection: bool,
    /// Sub-pixel translations (bilinear sampling).
    pub subpixel: bool,
    /// Per-patch height offset (mean difference); off by default, as the
    /// paper advises (it lets patches from any altitude match anywhere).
    pub height_offset: bool,
}

impl Default for SearchSpace {
    fn default() -> Self {
        SearchSpace {
            rotation: true,
            reflection: true,
            subpixel: true,
            height_offset: false,
        }
    }
}

/// The final pass on the finest level (after its last E-step), with the
/// level's pit removal method, when pit removal is on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FinestPits {
    /// Leave the finest level as its E-step made it (the paper).
    Keep,
    /// Remove the depressions at most this deep (DEM units), keep deeper
    /// ones ([`remove_shallow_pits`]).
    MaxDepth(f32),
    /// Remove the depressions at most `k` times the exemplar's finest detail
    /// RMS deep ([`detail_rms`]: the relief the finest level adds).
    Detail(f32),
}

/// Parameters of [`synthesise`].
#[derive(Debug, Clone, PartialEq)]
pub struct OptimiseOptions {
    /// Output size in cells.
    pub width: usize,
    pub height: usize,
    /// Patch size N (3..=32).
    pub patch: usize,
    /// Patch grid spacing (1..=N); `None` = ⌊N/2⌋.
    pub spacing: Option<usize>,
    /// Coarsest level index L (levels 0..=L); `None` = automatic.
    pub levels: Option<usize>,
    /// EM iterations per level µ (1..=16).
    pub iterations: usize,
    /// PatchMatch passes per M-step (1..=16).
    pub passes: usize,
    pub weighting: Weighting,
    /// α of the weightings, in [0, 1].
    pub alpha: f32,
    pub search: SearchSpace,
    pub pit: PitRemoval,
    pub seed: u64,
    /// Gaussian falloff of patch cell weights, σ as a fraction of N
    /// (default 0.3); `None` = uniform weights (Kwatra et al. 2005's plain
    /// energy). Weighting the centre of each patch more softens the seams
    /// between overlapping patches, which otherwise leave small pits in the
    /// finest level (measured: 360 -> 196 depressions on the test case of
    /// `docs/design/example-based-synthesis.md`).
    pub falloff: Option<f32>,
    /// Remove pits at the finest level too (not in the paper; off by
    /// default): the output is then free of depressions.
    pub pit_finest: bool,
    /// After pit removal, make the surface drain strictly with this rise
    /// per finest-level cell (DEM units; `2^k` times that per cell at level
    /// `k`, the same physical gradient): flats left by fill and breach
    /// become ramps towards their outlet ([`drain_strictly`]), so the finer
    /// level's patches match draining shapes instead of averaging into
    /// small pits on flats. 0 = off (the paper's plain removal; the
    /// default). Measured (docs/design/example-based-synthesis.md): it lowers the output's
    /// depression volume further but raises the depression count.
    pub drain_step: f32,
    /// Final shallow-pit pass on the finest level (a departure from the
    /// paper, which leaves that level alone; see [`FinestPits`]). Only
    /// with pit removal on and without `pit_finest`.
    pub finest: FinestPits,
    /// Keep each level's result (for previews).
    pub keep_levels: bool,
}

impl Default for OptimiseOptions {
    fn default() -> Self {
        OptimiseOptions {
            width: 256,
            height: 256,
            patch: 7,
            spacing: None,
            levels: None,
            iterations: 2,
            passes: 4,
            weighting: Weighting::Exponential,
            alpha: 0.75,
            search: SearchSpace::default(),
            pit: PitRemoval::Breach,
            seed: 1,
            falloff: Some(0.3),
            pit_finest: false,
            drain_step: 0.0,
            finest: FinestPits::Detail(DEFAULT_DETAIL_DEPTH),
            keep_levels: false,
        }
    }
}

/// Default depth limit of the finest level's shallow-pit pass, in units of
/// the exemplar's finest detail RMS (measured in docs/design/example-based-synthesis.md).
pub const DEFAULT_DETAIL_DEPTH: f32 = 2.0;

/// What happened at one level.
#[derive(Debug, Clone, PartialEq)]
pub struct LevelReport {
    /// Level index (0 = finest).
    pub level: usize,
    pub width: usize,
    pub height: usize,
    pub source_width: usize,
    pub source_height: usize,
    pub patches: usize,
    pub guide_weight: f32,
    /// Σ patch SSD: before the first M-step, then after each M- and E-step.
    pub energies: Vec<f64>,
}

/// The result of [`synthesise`].
#[derive(Debug, Clone)]
pub struct Synthesis {
    pub output: Grid<f32>,
    /// Coarsest first.
    pub levels: Vec<LevelReport>,
    /// Each level's result, coarsest first (only with `keep_levels`).
    pub level_grids: Vec<Grid<f32>>,
    /// Depth limit (DEM units) of the finest level's shallow-pit pass when
    /// one ran.
    pub finest_depth: Option<f32>,
}

fn footprint_radius(n: usize, rotation: bool) -> f32 {
    let far = (n - 1 - (n - 1) / 2) as f32;
    if rotation {
        far * std::f32::consts::SQRT_2 + 1e-3
    } else {
        far
    }
}

/// Check the options and inputs, and choose L. Returns (L, spacing).
fn plan(
    source: &Grid<f32>,
    guide: &Grid<f32>,
    sinks: Option<&Grid<bool>>,
    o: &OptimiseOptions,
) -> Result<(usize, usize)> {
    let n = o.patch;
    if !(3..=32).contains(&n) {
        return Err(Error::invalid(format!(
            "synth optimise: patch size {n} must be 3 to 32 cells"
        )));
    }
    let s = o.spacing.unwrap_or(n / 2).max(1);
    if s > n {
        return Err(Error::invalid(format!(
            "synth optimise: patch spacing {s} must be at most the patch size {n}"
        )));
    }
    if !(1..=16).contains(&o.iterations) || !(1..=16).contains(&o.passes) {
        return Err(Error::invalid(
            "synth optimise: iterations and passes must be 1 to 16",
        ));
    }
    if let Some(f) = o.falloff {
        if !(f.is_finite() && f > 0.0) {
            return Err(Error::invalid(format!(
                "synth optimise: falloff {f} must be a positive fraction of the patch size"
            )));
        }
    }
    if !(o.drain_step.is_finite() && o.drain_step >= 0.0) {
        return Err(Error::invalid(format!(
            "synth optimise: drain step {} must be a finite rise per cell, 0 or more",
            o.drain_step
        )));
    }
    let fd = match o.finest {
        FinestPits::Keep => 0.0,
        FinestPits::MaxDepth(d) | FinestPits::Detail(d) => d,
    };
    if !(fd.is_finite() && fd >= 0.0) {
        return Err(Error::invalid(format!(
            "synth optimise: the finest level's pit depth limit {fd} must be finite, 0 or more"
        )));
    }
    if !(o.alpha.is_finite() && (0.0..=1.0).contains(&o.alpha)) {
        return Err(Error::invalid(format!(
            "synth optimise: alpha {} must be in 0..1",
            o.alpha
        )));
    }
    let (w, h) = (o.width, o.height);
    if w < n || h < n {
        return Err(Error::invalid(format!(
            "synth optimise: output {w}x{h} is smaller than one {n}x{n} patch"
        )));
    }
    if w.checked_mul(h).is_none_or(|c| c > MAX_OUTPUT_CELLS) {
        return Err(Error::too_large(
            "<output>",
            format!(
                "output {w}x{h} is more than {MAX_OUTPUT_CELLS} cells; synthesise a smaller size"
            ),
        ));
    }
    let (sw, sh) = (source.width(), source.height());
    if sw.checked_mul(sh).is_none_or(|c| c > MAX_SOURCE_CELLS) {
        return Err(Error::too_large(
            "<source>",
            format!(
                "source {sw}x{sh} is more than {MAX_SOURCE_CELLS} cells; crop or downsample it"
            ),
        ));
    }
    let rho = footprint_radius(n, o.search.rotation);
    let need = (2.0 * rho).ceil() as usize + 2;
    if sw < need || sh < need {
        return Err(Error::invalid(format!(
            "synth optimise: source {sw}x{sh} is smaller than one patch ({need}x{need} cells are needed for {n}x{n} patches{})",
            if o.search.rotation { " with rotation" } else { "" }
        )));
    }
    let (gw, gh) = (guide.width(), guide.height());
    if gw == 0 || gh == 0 {
        return Err(Error::invalid("synth optimise: the guide is empty"));
    }
    if gw > w || gh > h {
        return Err(Error::invalid(format!(
            "synth optimise: guide {gw}x{gh} is larger than the output {w}x{h}; a guide is a coarse map: downsample it, or ask for a larger output"
        )));
    }
    let bad = guide.data().iter().filter(|v| !v.is_finite()).count();
    if bad > 0 {
        return Err(Error::invalid(format!(
            "synth optimise: the guide has {bad} nodata cells; fill them first (e.g. orogen fill) or crop them away"
        )));
    }
    if let Some(m) = sinks {
        if (m.width(), m.height()) != (w, h) {
            return Err(Error::invalid(format!(
                "synth optimise: the sink mask is {}x{}, the output {w}x{h}; they must match",
                m.width(),
                m.height()
            )));
        }
    }
    let fits = |k: usize, min_out: usize, min_src: usize| {
        let (ow, oh) = pyramid::level_size(w, h, k);
        let (qw, qh) = pyramid::level_size(sw, sh, k);
        ow.min(oh) >= min_out && qw.min(qh) >= min_src
    };
    let l = match o.levels {
        Some(l) => {
            if l > 12 || !fits(l, n, need) {
                return Err(Error::invalid(format!(
                    "synth optimise: {l} pyramid levels make the coarsest output or source level smaller than a patch; use fewer levels"
                )));
            }
            l
        }
        None => {
            let mut l = 0;
            while l < 12 && fits(l + 1, (4 * n).max(24), (3 * n).max(need)) {
                l += 1;
            }
            l
        }
    };
    Ok((l, s))
}

/// Synthesise a `width x height` terrain from the exemplar `source` (NaN =
/// nodata, see the module docs) following `guide` (no nodata, at most the
/// output size; resampled bilinearly to it). `sinks` (output size) marks
/// cells that may stay depressions' outlets during pit removal. Runs on the
/// current rayon pool. Errors for invalid options, a source smaller than a
/// patch, a guide larger than the output or with nodata, sizes beyond
/// [`MAX_OUTPUT_CELLS`] / [`MAX_SOURCE_CELLS`], and sources whose nodata
/// leaves no patch position at some level.
pub fn synthesise(
    source: &Grid<f32>,
    guide: &Grid<f32>,
    sinks: Option<&Grid<bool>>,
    o: &OptimiseOptions,
) -> Result<Synthesis> {
    let (l, spacing) = plan(source, guide, sinks, o)?;
    let n = o.patch;
    let space = Space {
        rotation: o.search.rotation,
        reflection: o.search.reflection,
        subpixel: o.search.subpixel,
        offset: o.search.height_offset,
    };
    let rho = footprint_radius(n, space.rotation);
    let weights = patchmatch::falloff_weights(n, o.falloff.map_or(f32::INFINITY, |f| f * n as f32));
    let src_pyr = pyramid::gaussian_pyramid(source, l);
    let guide_full = pyramid::resize_bilinear(guide, o.width, o.height);
    let guide_pyr = pyramid::gaussian_pyramid(&guide_full, l);
    drop(guide_full);
    let sink_pyr = sinks.map(|m| pyramid::mask_pyramid(m, l));

    let mut reports = Vec::new();
    let mut kept = Vec::new();
    let mut prev: Option<(Vec<Corr>, Geom)> = None;
    let mut x: Vec<f32> = Vec::new();
    let mut finest_depth = None;
    for k in (0..=l).rev() {
        let sg = &src_pyr[k];
        let src = SourceLevel::new(sg, rho).ok_or_else(|| {
            Error::invalid(format!(
                "synth optimise: the source at pyramid level {k} ({}x{}) is smaller than a patch; use fewer levels",
                sg.width(),
                sg.height()
            ))
        })?;
        if src.exhausted() {
            return Err(Error::invalid(format!(
                "synth optimise: at pyramid level {k} no {n}x{n} source patch is free of nodata; crop the source to its valid part or use fewer levels"
            )));
        }
        let g = &guide_pyr[k];
        let (w, h) = (g.width(), g.height());
        let geom = Geom::new(w, h, n, spacing);
        let lk = mix(o.seed ^ mix(0xC0FF_EE00 + k as u64));
        let lev = Level {
            src: &src,
            geom: &geom,
            space,
            key: lk,
            weights: &weights,
        };
        let wk = o.weighting.weight(o.alpha, k, l);
        let sinks_k = sink_pyr.as_ref().map(|p| &p[k]);
        let remove_here = (k > 0 || o.pit_finest) && o.pit != PitRemoval::None;
        let step_k = o.drain_step * (1u64 << k) as f32;
        let unpit = |grid: &Grid<f32>| -> Result<Grid<f32>> {
            let r = remove_pits(grid, o.pit, sinks_k)?;
            drain_strictly(&r, step_k, sinks_k)
        };
        let mut recon = vec![0f32; w * h];
        let finish = |recon: &[f32], x: &mut Vec<f32>| -> Result<()> {
            let blended: Vec<f32> = recon
                .iter()
                .zip(g.data())
                .map(|(&r, &gv)| wk * gv + (1.0 - wk) * r)
                .collect();
            *x = if remove_here {
                let grid = Grid::from_vec(w, h, blended)?;
                unpit(&grid)?.into_vec()
            } else {
                blended
            };
            Ok(())
        };
        let mut corr = match prev.take() {
            None => {
                x = g.data().to_vec();
                (0..geom.count())
                    .map(|q| lev.random(mix(lk ^ mix(q as u64))))
                    .collect()
            }
            Some((pc, pg)) => {
                let coarse = Grid::from_vec(pg.w, x.len() / pg.w.max(1), std::mem::take(&mut x))?;
                let up = pyramid::expand(&coarse, w, h);
                // Bilinear expansion can block diagonal channels; where pits
                // are removed at this level, the starting target is made
                // pit-free too.
                x = if remove_here {
                    unpit(&up)?.into_vec()
                } else {
                    up.into_vec()
                };
                lev.upsample(&pc, &pg)
            }
        };
        let mut energies = vec![lev.refresh(&x, &mut corr)];
        let mut other = corr.clone();
        for it in 0..o.iterations {
            for p in 0..o.passes {
                let jump = 1usize << (o.passes - 1 - p).min(20);
                let jump = jump.min(geom.nx().max(geom.cy.len()).div_ceil(2)).max(1);
                let pkey = mix(lk ^ mix(((it as u64) << 32) | p as u64));
                lev.pass(&x, &corr, &mut other, jump, pkey);
                std::mem::swap(&mut corr, &mut other);
            }
            energies.push(corr.iter().map(|c| c.cost as f64).sum());
            lev.e_step(&corr, &mut recon);
            finish(&recon, &mut x)?;
            energies.push(lev.refresh(&x, &mut corr));
        }
        // The finest level's shallow-pit pass (after the energies: it is not
        // part of the optimisation).
        if k == 0 && !remove_here && o.pit != PitRemoval::None {
            let d = match o.finest {
                FinestPits::Keep => 0.0,
                FinestPits::MaxDepth(d) => d,
                FinestPits::Detail(f) => f * detail_rms(source),
            };
            if d > 0.0 {
                let grid = Grid::from_vec(w, h, std::mem::take(&mut x))?;
                x = remove_shallow_pits(&grid, d, o.pit, sinks_k)?.into_vec();
                finest_depth = Some(d);
            }
        }
        reports.push(LevelReport {
            level: k,
            width: w,
            height: h,
            source_width: src.w,
            source_height: src.h,
            patches: geom.count(),
            guide_weight: wk,
            energies,
        });
        if o.keep_levels {
            kept.push(Grid::from_vec(w, h, x.clone())?);
        }
        prev = Some((corr, geom));
    }
    Ok(Synthesis {
        output: Grid::from_vec(o.width, o.height, x)?,
        levels: reports,
        level_grids: kept,
        finest_depth,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weightings() {
        // closed forms: exponential α(2^k−1)/(2^L−1)
        let e = Weighting::Exponential;
        assert_eq!(e.weight(0.6, 0, 4), 0.0);
        assert!((e.weight(0.6, 4, 4) - 0.6).abs() < 1e-7);
        assert!((e.weight(0.6, 2, 4) - 0.6 * 3.0 / 15.0).abs() < 1e-7);
        assert!((Weighting::Linear.weight(0.6, 1, 4) - 0.15).abs() < 1e-7);
        assert_eq!(Weighting::Constant.weight(0.6, 0, 4), 0.6);
        assert_eq!(Weighting::Zero.weight(0.6, 4, 4), 0.0);
    }

    #[test]
    fn geometry_covers_every_cell() {
        for (len, n, s) in [(7usize, 7usize, 3usize), (20, 7, 3), (33, 5, 5), (10, 3, 1)] {
            let g = Geom::new(len, len, n, s);
            let mut cov = vec![0u32; len];
            for &c in &g.cx {
                assert!(c + n <= len);
                for v in &mut cov[c..c + n] {
                    *v += 1;
                }
            }
            assert!(cov.iter().all(|&c| c > 0), "{len} {n} {s}");
        }
    }
}
