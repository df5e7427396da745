//! The options of divide-tree synthesis ([`TreeOptions`]) and their
//! defaults and limits.

use super::super::typemap::TypeMap;
use super::ridges::FixedRidge;
use super::SynthPeak;
use crate::raster::Grid;

/// Options of [`synthesize_tree`].
#[derive(Debug, Clone)]
pub struct TreeOptions {
    pub width: usize,
    pub height: usize,
    /// Cell size, metres.
    pub cell: f64,
    pub seed: u64,
    /// Number of peaks; None: profile density × area.
    pub n_peaks: Option<usize>,
    /// MST weight exponent ρ ∈ {0, 1, 2}.
    pub rho: u8,
    /// Density map C_P (any size, stretched over the domain; ≥ 0).
    pub density_map: Option<Grid<f32>>,
    /// Coarse elevation map C_H (any size, stretched over the domain; m).
    pub elevation_map: Option<Grid<f32>>,
    /// Peaks the user placed (kept where they are; `fixed` is set).
    pub fixed_peaks: Vec<SynthPeak>,
    /// Prominence/dominance alternations of the saddle assignment.
    pub iterations: usize,
    /// Without an elevation map, use a coherent random one (see
    /// [`coherent_elevation_map`]); false: elevations are placed anywhere.
    pub coherent: bool,
    /// Isolation proposals are made at this multiple of the target distance
    /// (the terrain's nearest higher ground lies on the higher peak's ridges,
    /// closer than its summit). Default 1.2 ([`DEFAULT_ISOLATION_STRETCH`]),
    /// calibrated on the TIN terrain of the Mont Blanc and Dallas profiles
    /// over six seeds each once the render kept exactly the tree's peaks
    /// (1.1 suits the Alps best, 1.3 Dallas; 1.3 was the default while
    /// knolls of the render stood near many peaks; see
    /// docs/design/orometric-synthesis.md#placement).
    pub isolation_stretch: f64,
    /// Placement passes by prominence bins (§5): the most prominent bin
    /// first, each next bin about twice as many peaks, earlier peaks fixed.
    /// 1: one pass in decreasing elevation.
    pub passes: usize,
    /// Weight in [0, 1] of the diffused ridges of earlier passes in the
    /// acceptance (1 − a + a · ridges): 0 leaves C_P alone.
    pub ridge_attraction: f64,
    /// Ridges kept verbatim between fixed peaks (a pasted real fragment).
    pub fixed_ridges: Vec<FixedRidge>,
    /// Rectangles [x0, y0, x1, y1] (m, the tree's frame) where no free peak
    /// is placed (a pasted fragment's footprint).
    pub keep_out: Vec<[f64; 4]>,
    /// Type map C_T: a profile per region label ([`TypeMap`]).
    pub type_map: Option<TypeMap>,
    /// After the assignment, a local search on the saddle heights that
    /// lowers the prominence and dominance histogram distances directly
    /// ([`super::assign::refine_histograms`]). Default true; false gives the
    /// trees of the assignment alone.
    pub refine: bool,
    /// Least relief contrast C ≥ 1 of the ridge weights: the MST uses
    /// ‖Pi − Pj‖ / (min(h_i, h_j) − b)^ρ with the base b ≥ 0 the smallest
    /// that makes (highest − b) / (lowest − b) ≥ C (b ≤ lowest − threshold).
    /// A departure from Argudo et al. 2019 §5 (which weighs absolute
    /// elevations), default [`DEFAULT_RIDGE_CONTRAST`] = 5: on a low-relief
    /// region (Dallas: peaks 165–298 m, contrast 1.8) min(h)^2 barely tells
    /// high peaks from low ones, so the MST routed high peaks to higher
    /// ground through much lower peaks whose saddles capped their
    /// prominence (tree dominance error 2.4–5.4 %, measured; 0.0–1.2 % with
    /// C = 5). Profiles already that contrasted (Mont Blanc: 876–4810 m,
    /// 5.5) get b = 0 from this rule (but see [`TreeOptions::ridge_base`]).
    /// 1 with `ridge_base` 0: the paper's weights.
    pub ridge_contrast: f64,
    /// Least base of the ridge weights as a fraction β ∈ [0, 1) of the
    /// lowest peak: b = max(b_C, β · lowest) with b_C the base of
    /// [`TreeOptions::ridge_contrast`]. Default [`DEFAULT_RIDGE_BASE`]. On
    /// Mont Blanc (876–4810 m, contrast 5.5, so b_C = 0) the paper's
    /// weights joined high peaks through much lower ones, whose h_max caps
    /// the saddles on the way: the tree kept 4–7 peaks of prominence over
    /// 3000 m where the profile has 1 and too many of 800–1500 m (tree
    /// prominence error 1.6–3.2 %, rendered 2.0–3.5 %, seeds 1–6); with
    /// β = 0.72 (contrast ≈ 17) 1.2–2.3 % and 1.4–2.6 % (docs/design/orometric-synthesis.md#ridges).
    /// On Dallas b_C (contrast 5: 132 m = 0.8 · 165 m) is larger, so its
    /// trees do not change. 0: the contrast alone.
    pub ridge_base: f64,
    /// Width (m) of the band over which the type map's region profiles are
    /// blended at their borders (see [`super::typemap`]). Default
    /// [`DEFAULT_TYPE_BLEND_M`] = 0: sharp borders.
    pub type_blend_m: f64,
}

impl TreeOptions {
    pub fn new(width: usize, height: usize, cell: f64, seed: u64) -> TreeOptions {
        TreeOptions {
            width,
            height,
            cell,
            seed,
            n_peaks: None,
            rho: 2,
            density_map: None,
            elevation_map: None,
            fixed_peaks: Vec::new(),
            iterations: 3,
            coherent: true,
            isolation_stretch: DEFAULT_ISOLATION_STRETCH,
            passes: DEFAULT_PASSES,
            ridge_attraction: DEFAULT_RIDGE_ATTRACTION,
            fixed_ridges: Vec::new(),
            keep_out: Vec::new(),
            type_map: None,
            refine: true,
            ridge_contrast: DEFAULT_RIDGE_CONTRAST,
            ridge_base: DEFAULT_RIDGE_BASE,
            type_blend_m: DEFAULT_TYPE_BLEND_M,
        }
    }
}

/// Default [`TreeOptions::ridge_contrast`] (the Mont Blanc profile's own
/// contrast, rounded down: it keeps the paper's weights there).
pub const DEFAULT_RIDGE_CONTRAST: f64 = 5.0;

/// Default [`TreeOptions::ridge_base`], calibrated on Mont Blanc, seeds
/// 1–6 (see the field). The sweep (docs/design/orometric-synthesis.md#ridges) put every seed
/// within the paper's figures at bases ≈ 0.72 and 0.81 of the lowest peak,
/// but ≈ 0.76 and 0.79 each missed on one seed by 0.1–0.2 points: the
/// margin is of the order of the seed-to-seed noise. Kept below 0.8 so the
/// Dallas trees (contrast base 0.8 · lowest) do not change.
pub const DEFAULT_RIDGE_BASE: f64 = 0.72;

/// Default [`TreeOptions::type_blend_m`]: 0, sharp borders (as before the
/// blend existed; the CLI has no flag for it yet). A band of about 6 km,
/// two to three peak spacings of the shipped profiles (Mont Blanc 0.16,
/// Dallas 0.18 peaks per km²), mixes a few peaks of each side at a border
/// instead of a step; wider bands ramp more slowly.
pub const DEFAULT_TYPE_BLEND_M: f64 = 0.0;

/// Default isolation stretch ([`TreeOptions::isolation_stretch`]).
pub const DEFAULT_ISOLATION_STRETCH: f64 = 1.2;

/// Default number of placement passes (see `docs/design/orometric-synthesis.md#authoring`).
pub const DEFAULT_PASSES: usize = 4;

/// Default ridge attraction of the multi-pass placement.
pub const DEFAULT_RIDGE_ATTRACTION: f64 = 0.8;

/// Largest number of peaks a synthesis accepts (memory and the O(n log n)
/// steps stay small; 4 M peaks ≈ a continent at 0.01 peaks/km²·…).
pub const MAX_PEAKS: usize = 4_000_000;

/// Largest domain side in cells.
pub const MAX_SIDE: usize = 1 << 21;
