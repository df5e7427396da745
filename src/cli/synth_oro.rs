//! `orogen synth profile | divide-tree | from-tree | orometric`: the
//! arguments of `orogen::ops::synth::orometric` (orometric terrain
//! synthesis). The profile and the divide tree are JSON files a user may
//! edit between the steps.

use super::erode::printer;
use crate::{engine, output_options, In, Out, Run};
use anyhow::Result;
use clap::Args;
use orogen::ops::synth::orometric as oro;
use std::path::PathBuf;

/// Arguments of `orogen synth profile`.
#[derive(Args)]
pub struct ProfileArgs {
    /// A DEM to measure, or a profile (.json) to edit.
    #[command(flatten)]
    pub input: In,
    /// Peaks counted have at least this prominence (m).
    #[arg(long, default_value_t = 30.0)]
    pub min_prominence: f64,
    /// Label of the region type.
    #[arg(long)]
    pub label: Option<String>,
    /// Edit: multiply prominences (2 = peaks twice as prominent).
    #[arg(long)]
    pub scale_prominence: Option<f64>,
    /// Edit: multiply the peak density.
    #[arg(long)]
    pub scale_density: Option<f64>,
    /// Output profile (.json).
    #[arg(short, long)]
    pub output: PathBuf,
}

/// Options of the divide-tree synthesis shared by `divide-tree` and `orometric`.
#[derive(Args, Clone)]
pub struct TreeArgs {
    /// Profile made by `orogen synth profile`.
    #[arg(long)]
    pub profile: PathBuf,
    /// Size in cells, WIDTHxHEIGHT (or one number for a square).
    #[arg(long, default_value = "1024")]
    pub size: String,
    /// Cell size in metres.
    #[arg(long, default_value_t = 30.0)]
    pub cell: f64,
    /// Random seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Number of peaks (default: the profile's density × area).
    #[arg(long)]
    pub peaks: Option<usize>,
    /// Ridge weight exponent ρ (0, 1 or 2): MST weight ‖Pi−Pj‖ / min(h)^ρ.
    #[arg(long, default_value_t = 2)]
    pub rho: u8,
    /// Peak density map C_P (any raster, stretched over the domain).
    #[arg(long)]
    pub density_map: Option<PathBuf>,
    /// Coarse elevation map C_H (any raster, stretched over the domain, m).
    #[arg(long)]
    pub elevation_map: Option<PathBuf>,
    /// Fixed peaks: GeoJSON points (map metres, origin bottom-left as in the
    /// rasters written, property "elevation").
    #[arg(long)]
    pub fixed_peaks: Option<PathBuf>,
    /// Isolation proposals at this multiple of the target distance (the
    /// terrain's higher ground is nearer than the higher summit).
    #[arg(long, default_value_t = orogen::synth::orometric::tree_synth::DEFAULT_ISOLATION_STRETCH)]
    pub isolation_stretch: f64,
    /// Least relief contrast of the ridge weights (1 = the paper's
    /// ‖Pi−Pj‖ / min(h)^ρ; larger measures elevations above a base so that
    /// low-relief regions still route ridges through higher peaks).
    #[arg(long, default_value_t = orogen::synth::orometric::tree_synth::DEFAULT_RIDGE_CONTRAST)]
    pub ridge_contrast: f64,
    /// Least base of the ridge weights as a fraction (0..1) of the lowest
    /// peak (0: the contrast rule alone; see `TreeOptions::ridge_base`).
    #[arg(long, default_value_t = orogen::synth::orometric::tree_synth::DEFAULT_RIDGE_BASE)]
    pub ridge_base: f64,
    /// Width (metres) of the band over which the type map's region profiles
    /// blend at their borders (0: sharp borders; about 6000 mixes a few
    /// peaks of each side).
    #[arg(long = "type-blend", value_name = "METRES", default_value_t = orogen::synth::orometric::tree_synth::DEFAULT_TYPE_BLEND_M)]
    pub type_blend_m: f64,
    /// Skip the local search on saddle heights after the assignment (the
    /// paper's method alone).
    #[arg(long)]
    pub no_refine: bool,
    // Multi-pass placement and authoring (Argudo et al. 2019 §5, §7).
    /// Placement passes by prominence bins: the most prominent bin first,
    /// each next bin about twice as many peaks; 1 = one pass.
    #[arg(long, default_value_t = orogen::synth::orometric::tree_synth::DEFAULT_PASSES)]
    pub passes: usize,
    /// Weight (0..1) of the diffused ridges of earlier passes in the
    /// acceptance of later peaks (0: none).
    #[arg(long, default_value_t = orogen::synth::orometric::tree_synth::DEFAULT_RIDGE_ATTRACTION)]
    pub ridge_attraction: f64,
    /// Type map C_T: a raster of integer region labels stretched over the
    /// domain (nodata: no peaks), or GeoJSON polygons with an integer "label"
    /// property (map metres, origin bottom-left; outside them: no peaks);
    /// labels without --type-profile use --profile.
    #[arg(long)]
    pub type_map: Option<PathBuf>,
    /// Profile of a type-map label, LABEL=PROFILE.json (repeat per label).
    #[arg(long = "type-profile", value_name = "LABEL=PROFILE")]
    pub type_profiles: Vec<String>,
    /// Paste a fragment of a real divide tree: the peaks.csv `orogen peaks`
    /// wrote for a real DEM (give --cell = that DEM's cell size).
    #[arg(long)]
    pub paste: Option<PathBuf>,
    /// Window of the real DEM to paste, COL,ROW,WIDTH,HEIGHT in its cells.
    #[arg(long)]
    pub paste_window: Option<String>,
    /// Where the window's top-left cell goes in the synthesised domain, COL,ROW.
    #[arg(long, default_value = "0,0")]
    pub paste_at: String,
}

/// Terrain options shared by `from-tree` and `orometric`.
#[derive(Args, Clone)]
pub struct TerrainArgs {
    // --- terrain model (issue 10, §6 of the paper) ---
    /// Terrain model: `tin` (the paper's: river network dual of the divide tree,
    /// valley widths ∝ A^0.4, constrained Delaunay TIN) or `tents` (upper
    /// envelope of sloped tents over the ridges; faster, V-shaped valleys).
    #[arg(long, value_enum, default_value_t = TerrainKind::Tin)]
    pub terrain: TerrainKind,
    /// TIN model: valley floor width (m) at 1 km² of drainage area (grows as A^0.4).
    #[arg(long, default_value_t = 100.0)]
    pub valley_width: f64,
    /// TIN model: river slope (m/m) at 1 km² of drainage area (falls as A^-0.45).
    #[arg(long, default_value_t = 0.2)]
    pub river_slope: f64,
    // --- end terrain model ---
    /// Flank slope (m/m) of the tents model.
    #[arg(long, default_value_t = 0.6)]
    pub slope: f64,
    /// Ridge refinement spacing λ (m).
    #[arg(long, default_value_t = 200.0)]
    pub spacing: f64,
    /// Noise amplitude (m; default 0.3 × the prominence threshold).
    #[arg(long)]
    pub noise: Option<f64>,
    /// Also write a PNG preview (hillshaded).
    #[arg(long)]
    pub preview: Option<PathBuf>,
    /// Finish with constrained stream-power erosion (Argudo et al. 2019 §6.3): this many
    /// outer iterations of 10 erosion steps, each followed by the compensating uplift
    /// that keeps every peak and saddle of the tree at its elevation. 0 = none. In memory.
    #[arg(long, default_value_t = 0)]
    pub erode: usize,
    /// Radius (m) of the compensating uplift around each peak and saddle
    /// (default: 10 cells).
    #[arg(long)]
    pub erode_radius: Option<f64>,
    /// Erodibility K of the constrained erosion (m^0.2/yr for m = 0.4, n = 1).
    #[arg(long, default_value_t = 2e-5)]
    pub erode_k: f64,
}

/// Terrain model of `--terrain`.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum TerrainKind {
    /// River network, valley widths and a constrained TIN (Argudo et al. 2019 §6).
    Tin,
    /// Upper envelope of tents over the refined ridges.
    Tents,
}

/// Arguments of `orogen synth divide-tree`.
#[derive(Args)]
pub struct DivideTreeArgs {
    #[command(flatten)]
    pub tree: TreeArgs,
    /// Output divide tree (.json, editable).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Also write the tree as GeoJSON (peaks, saddles, ridges), in the tree's
    /// local metric frame (synthetic: not RFC 7946 lon/lat, no "crs" member).
    #[arg(long)]
    pub geojson: Option<PathBuf>,
}

/// Arguments of `orogen synth from-tree`.
#[derive(Args)]
pub struct FromTreeArgs {
    /// Divide tree (.json) from `orogen synth divide-tree`, possibly edited.
    pub tree: PathBuf,
    // Edits and regeneration (Argudo et al. 2019 §7).
    /// Apply an edit file (JSON "orogen-tree-edits": move_peak, set_peak,
    /// insert_peak, delete_peak, move_saddle, set_saddle, delete_ridge; see
    /// the docs) to the tree, then regenerate ridges and saddles.
    #[arg(long)]
    pub edits: Option<PathBuf>,
    /// Save the edited and regenerated tree (.json).
    #[arg(long)]
    pub edited_tree: Option<PathBuf>,
    #[command(flatten)]
    pub terrain: TerrainArgs,
    #[command(flatten)]
    pub out: Out,
    #[command(flatten)]
    pub run: Run,
}

/// Arguments of `orogen synth orometric`.
#[derive(Args)]
pub struct OrometricArgs {
    #[command(flatten)]
    pub tree: TreeArgs,
    #[command(flatten)]
    pub terrain: TerrainArgs,
    /// Also save the divide tree (.json).
    #[arg(long)]
    pub tree_out: Option<PathBuf>,
    #[command(flatten)]
    pub out: Out,
    #[command(flatten)]
    pub run: Run,
}

impl TreeArgs {
    /// The operation's options.
    pub fn options(&self) -> oro::TreeSynthOptions {
        oro::TreeSynthOptions {
            profile: self.profile.clone(),
            size: self.size.clone(),
            cell: self.cell,
            seed: self.seed,
            peaks: self.peaks,
            rho: self.rho,
            density_map: self.density_map.clone(),
            elevation_map: self.elevation_map.clone(),
            fixed_peaks: self.fixed_peaks.clone(),
            isolation_stretch: self.isolation_stretch,
            ridge_contrast: self.ridge_contrast,
            ridge_base: self.ridge_base,
            type_blend_m: self.type_blend_m,
            no_refine: self.no_refine,
            passes: self.passes,
            ridge_attraction: self.ridge_attraction,
            type_map: self.type_map.clone(),
            type_profiles: self.type_profiles.clone(),
            paste: self.paste.clone(),
            paste_window: self.paste_window.clone(),
            paste_at: self.paste_at.clone(),
        }
    }
}

impl TerrainArgs {
    /// The operation's options.
    pub fn options(&self) -> oro::TerrainSynthOptions {
        oro::TerrainSynthOptions {
            terrain: match self.terrain {
                TerrainKind::Tin => oro::TerrainKind::Tin,
                TerrainKind::Tents => oro::TerrainKind::Tents,
            },
            valley_width: self.valley_width,
            river_slope: self.river_slope,
            slope: self.slope,
            spacing: self.spacing,
            noise: self.noise,
            preview: self.preview.clone(),
            erode: self.erode,
            erode_radius: self.erode_radius,
            erode_k: self.erode_k,
        }
    }
}

/// `orogen synth profile`.
pub fn run_profile(a: ProfileArgs) -> Result<()> {
    let opts = oro::ProfileOptions {
        input: a.input.input.clone(),
        min_prominence: a.min_prominence,
        label: a.label,
        scale_prominence: a.scale_prominence,
        scale_density: a.scale_density,
        output: a.output,
    };
    oro::run_profile(&opts, &a.input.reading.open_options(), &mut printer(false))?;
    Ok(())
}

/// `orogen synth divide-tree`.
pub fn run_divide_tree(a: DivideTreeArgs) -> Result<()> {
    let opts = oro::DivideTreeOptions {
        tree: a.tree.options(),
        output: a.output,
        geojson: a.geojson,
    };
    oro::run_divide_tree(&opts, &mut printer(false))?;
    Ok(())
}

/// `orogen synth from-tree`.
pub fn run_from_tree(a: FromTreeArgs) -> Result<()> {
    let cfg = engine(&a.run)?;
    let oo = output_options(&a.out.fmt)?;
    let opts = oro::FromTreeOptions {
        tree: a.tree,
        edits: a.edits,
        edited_tree: a.edited_tree,
        terrain: a.terrain.options(),
        output: a.out.output.clone(),
        tile: a.run.tile,
    };
    oro::run_from_tree(&opts, &oo, &cfg, &mut printer(a.run.quiet))?;
    Ok(())
}

/// `orogen synth orometric`.
pub fn run_orometric(a: OrometricArgs) -> Result<()> {
    let cfg = engine(&a.run)?;
    let oo = output_options(&a.out.fmt)?;
    let opts = oro::OrometricOptions {
        tree: a.tree.options(),
        terrain: a.terrain.options(),
        tree_out: a.tree_out,
        output: a.out.output.clone(),
        tile: a.run.tile,
    };
    oro::run_orometric(&opts, &oo, &cfg, &mut printer(a.run.quiet))?;
    Ok(())
}
