//! `orogen synth profile | divide-tree | from-tree | orometric`: orometric
//! terrain synthesis (see `orogen::synth::orometric`). The profile and the
//! divide tree are JSON files a user may edit between the steps.

use crate::{engine, output_options, wrote, In, Out, Run};
use anyhow::{bail, Context, Result};
use clap::Args;
use orogen::io::{open_raster, OpenOptions};
use orogen::raster::{read_window, Grid, Window};
use orogen::synth::orometric::{
    build_terrain, synthesize_tree, SynthPeak, SynthProfile, SynthTree, TerrainModel,
    TerrainOptions, TreeOptions,
};
use std::path::{Path, PathBuf};

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
    /// Also write the tree as GeoJSON (peaks, saddles, ridges).
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

/// `orogen synth profile`.
pub fn run_profile(a: ProfileArgs) -> Result<()> {
    let path = &a.input.input;
    let is_json = path
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("json"));
    let mut prof = if is_json {
        SynthProfile::load(path)?
    } else {
        let src = crate::open(&a.input)?;
        let dem = read_all(&*src, path)?;
        let name = path
            .file_stem()
            .and_then(|s| s.to_str())
            .unwrap_or("region")
            .to_string();
        let label = a.label.clone().unwrap_or_else(|| name.clone());
        SynthProfile::from_dem(
            &dem,
            &src.info().georef,
            a.min_prominence,
            &label,
            &path.display().to_string(),
        )
        .with_context(|| format!("profile of {}", path.display()))?
    };
    if let Some(l) = &a.label {
        prof.label = l.clone();
    }
    if let Some(f) = a.scale_prominence {
        prof.scale_prominence(f)?;
    }
    if let Some(f) = a.scale_density {
        prof.scale_density(f)?;
    }
    prof.save(&a.output)?;
    wrote(&a.output);
    Ok(())
}

/// Largest map (density, elevation) read into memory, cells.
const MAX_MAP_CELLS: usize = 1 << 26;

fn read_all(src: &dyn orogen::raster::RasterSource, path: &Path) -> Result<Grid<f32>> {
    let (w, h) = (src.info().width, src.info().height);
    if w.saturating_mul(h) > 1 << 30 {
        bail!(
            "{}: {w}x{h} cells is too large to measure in memory; crop it first",
            path.display()
        );
    }
    Ok(read_window::<f32>(src, Window::full(w, h))?)
}

fn read_map(path: &Path) -> Result<Grid<f32>> {
    let src = open_raster(path, &OpenOptions::default())?;
    let (w, h) = (src.info().width, src.info().height);
    if w.saturating_mul(h) > MAX_MAP_CELLS {
        bail!(
            "{}: a control map of {w}x{h} cells is larger than needed (at most {MAX_MAP_CELLS} cells); downsample it",
            path.display()
        );
    }
    Ok(read_window::<f32>(&*src, Window::full(w, h))?)
}

/// Fixed peaks from GeoJSON points with an "elevation" property.
fn read_fixed(path: &Path, h_cells: usize, cell: f64) -> Result<Vec<SynthPeak>> {
    let meta = std::fs::metadata(path).with_context(|| format!("{}", path.display()))?;
    if meta.len() > 256 << 20 {
        bail!("{}: fixed-peak file over 256 MiB", path.display());
    }
    let text = std::fs::read_to_string(path).with_context(|| format!("{}", path.display()))?;
    let v: serde_json::Value =
        serde_json::from_str(&text).with_context(|| format!("{}: not JSON", path.display()))?;
    let Some(feats) = v.get("features").and_then(|f| f.as_array()) else {
        bail!(
            "{}: expected a GeoJSON FeatureCollection of points with an \"elevation\" property",
            path.display()
        );
    };
    let hm = h_cells as f64 * cell;
    let mut out = Vec::new();
    for (i, f) in feats.iter().enumerate() {
        let c = f
            .pointer("/geometry/coordinates")
            .and_then(|c| c.as_array())
            .filter(|c| c.len() >= 2);
        let (Some(c), Some(z)) = (
            c,
            f.pointer("/properties/elevation").and_then(|z| z.as_f64()),
        ) else {
            bail!(
                "{}: feature {i} is not a point with a numeric \"elevation\" property",
                path.display()
            );
        };
        let (Some(x), Some(y)) = (c[0].as_f64(), c[1].as_f64()) else {
            bail!(
                "{}: feature {i} has non-numeric coordinates",
                path.display()
            );
        };
        out.push(SynthPeak {
            x,
            y: hm - y,
            elevation: z,
            fixed: true,
        });
    }
    Ok(out)
}

fn make_tree(t: &TreeArgs) -> Result<SynthTree> {
    let prof = SynthProfile::load(&t.profile)?;
    let (w, h) = super::synth_noise::parse_size(&t.size)?;
    let mut o = TreeOptions::new(w, h, t.cell, t.seed);
    o.n_peaks = t.peaks;
    o.rho = t.rho;
    o.isolation_stretch = t.isolation_stretch;
    o.ridge_contrast = t.ridge_contrast;
    o.ridge_base = t.ridge_base;
    o.type_blend_m = t.type_blend_m;
    o.refine = !t.no_refine;
    if let Some(p) = &t.density_map {
        o.density_map = Some(read_map(p)?);
    }
    if let Some(p) = &t.elevation_map {
        o.elevation_map = Some(read_map(p)?);
    }
    if let Some(p) = &t.fixed_peaks {
        o.fixed_peaks = read_fixed(p, h, t.cell)?;
    }
    author_options(t, &mut o)?;
    Ok(synthesize_tree(&prof, &o)?)
}

/// Parse "a,b,…" into exactly `n` integers.
fn ints(s: &str, n: usize, what: &str) -> Result<Vec<i64>> {
    let v: Vec<i64> = s
        .split(',')
        .map(|x| x.trim().parse::<i64>())
        .collect::<std::result::Result<_, _>>()
        .with_context(|| format!("{what} {s:?}: expected {n} integers separated by commas"))?;
    if v.len() != n {
        bail!("{what} {s:?}: expected {n} integers separated by commas");
    }
    Ok(v)
}

/// The multi-pass, type-map and pasted-fragment options of `t` into `o`.
fn author_options(t: &TreeArgs, o: &mut TreeOptions) -> Result<()> {
    o.passes = t.passes;
    o.ridge_attraction = t.ridge_attraction;
    if let Some(p) = &t.type_map {
        let is_geojson = p
            .extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| e.eq_ignore_ascii_case("geojson") || e.eq_ignore_ascii_case("json"));
        let labels = if is_geojson {
            // 512 cells along the longer side: finer than any region matters.
            let (w, h) = (o.width as f64, o.height as f64);
            let (c, r) = if w >= h {
                (512, ((512.0 * h / w).ceil() as usize).max(1))
            } else {
                (((512.0 * w / h).ceil() as usize).max(1), 512)
            };
            orogen::synth::orometric::typemap::rasterize_geojson(p, w * o.cell, h * o.cell, c, r)?
        } else {
            read_map(p)?
        };
        let mut regions = Vec::new();
        for tp in &t.type_profiles {
            let Some((l, f)) = tp.split_once('=') else {
                bail!("--type-profile {tp:?}: expected LABEL=PROFILE.json");
            };
            let l: i64 = l
                .trim()
                .parse()
                .with_context(|| format!("--type-profile {tp:?}: the label must be an integer"))?;
            regions.push((l, SynthProfile::load(Path::new(f.trim()))?));
        }
        o.type_map = Some(
            orogen::synth::orometric::TypeMap::new(labels, regions)
                .with_context(|| format!("type map {}", p.display()))?,
        );
    } else if !t.type_profiles.is_empty() {
        bail!("--type-profile needs --type-map");
    }
    if let Some(csv) = &t.paste {
        let Some(win) = &t.paste_window else {
            bail!("--paste needs --paste-window COL,ROW,WIDTH,HEIGHT (cells of the real DEM)");
        };
        let w = ints(win, 4, "--paste-window")?;
        if w[2] <= 0 || w[3] <= 0 {
            bail!("--paste-window {win}: the width and height must be > 0");
        }
        let at = ints(&t.paste_at, 2, "--paste-at")?;
        let frag = orogen::synth::orometric::Fragment::from_peaks_csv(
            csv,
            Window::new(w[0], w[1], w[2] as usize, w[3] as usize),
            t.cell,
        )?;
        let (peaks, ridges, rect) = frag.placed(
            at[0] as f64 * t.cell,
            at[1] as f64 * t.cell,
            o.fixed_peaks.len(),
        );
        o.fixed_peaks.extend(peaks);
        o.fixed_ridges.extend(ridges);
        o.keep_out.push(rect);
    }
    Ok(())
}

fn terrain_opts(t: &TerrainArgs) -> TerrainOptions {
    TerrainOptions {
        slope: t.slope,
        spacing_m: t.spacing,
        noise_amplitude: t.noise,
        model: match t.terrain {
            TerrainKind::Tin => TerrainModel::Tin,
            TerrainKind::Tents => TerrainModel::Tents,
        },
        valley_width: t.valley_width,
        river_slope: t.river_slope,
        ..TerrainOptions::default()
    }
}

fn write_terrain(tree: &SynthTree, t: &TerrainArgs, out: &Out, run: &Run) -> Result<()> {
    let ter = build_terrain(tree, &terrain_opts(t))?;
    let cfg = engine(run)?;
    let oo = output_options(&out.fmt)?;
    if t.erode == 0 {
        orogen::ops::convert(&*ter, &out.output, &oo, run.tile, &cfg)?;
    } else {
        let eroded = erode_keeping_tree(tree, &*ter, t, &cfg)?;
        orogen::ops::convert(&eroded, &out.output, &oo, run.tile, &cfg)?;
    }
    wrote(&out.output);
    if let Some(p) = &t.preview {
        let written = orogen::io::open_raster(&out.output, &orogen::io::OpenOptions::default())?;
        orogen::tiles::render::render_preview(
            written.as_ref(),
            p,
            &orogen::tiles::render::RenderOptions::default(),
        )?;
        wrote(p);
    }
    Ok(())
}

/// Constrained erosion of the rendered terrain: the cells holding the tree's
/// peaks and saddles are the fixed points (`erosion::constrained`).
fn erode_keeping_tree(
    tree: &SynthTree,
    ter: &dyn orogen::raster::RasterSource,
    t: &TerrainArgs,
    cfg: &orogen::exec::EngineConfig,
) -> Result<orogen::raster::MemRaster> {
    use orogen::erosion::constrained::{erode_constrained, ConstrainedParams};
    use orogen::raster::{AnyGrid, MemRaster};
    let info = ter.info().clone();
    // Heights, receivers, stack, areas, donors and queues of the in-memory solver.
    let need = info.width as u64 * info.height as u64 * 100;
    if need > cfg.memory_budget {
        bail!(
            "--erode runs in memory and needs about {:.1} GiB for {}x{} cells; raise --memory or drop --erode",
            need as f64 / (1u64 << 30) as f64,
            info.width,
            info.height
        );
    }
    if !(t.erode_k.is_finite() && t.erode_k > 0.0) {
        bail!("--erode-k {}: give an erodibility > 0", t.erode_k);
    }
    let radius = t.erode_radius.unwrap_or(10.0 * tree.cell);
    if !(radius.is_finite() && radius > 0.0) {
        bail!("--erode-radius {radius}: give a radius in metres > 0");
    }
    let mut h = read_window::<f32>(ter, Window::full(info.width, info.height))?;
    let cell_of = |x: f64, y: f64| -> Option<(usize, usize)> {
        let (c, r) = ((x / tree.cell).floor(), (y / tree.cell).floor());
        (c >= 0.0 && r >= 0.0 && (c as usize) < info.width && (r as usize) < info.height)
            .then_some((c as usize, r as usize))
    };
    let mut fixed: Vec<(usize, usize)> = tree
        .peaks
        .iter()
        .map(|p| (p.x, p.y))
        .chain(tree.saddles.iter().map(|s| (s.x, s.y)))
        .filter_map(|(x, y)| cell_of(x, y))
        .collect();
    fixed.sort_unstable();
    fixed.dedup();
    let mut p = ConstrainedParams {
        iterations: t.erode,
        ..ConstrainedParams::default()
    };
    p.stream.k = t.erode_k;
    // The tree's elevations are kept to within a centimetre.
    p.tolerance = 0.01;
    erode_constrained(&mut h, tree.cell, &fixed, radius, &p)?;
    Ok(MemRaster::new(
        AnyGrid::F32(h),
        info.georef.clone(),
        info.path.clone(),
    ))
}

/// `orogen synth divide-tree`.
pub fn run_divide_tree(a: DivideTreeArgs) -> Result<()> {
    let tree = make_tree(&a.tree)?;
    tree.save(&a.output)?;
    wrote(&a.output);
    if let Some(g) = &a.geojson {
        orogen::io::atomic::write_file_atomic(g, tree.to_geojson().as_bytes())?;
        wrote(g);
    }
    Ok(())
}

/// `orogen synth from-tree`.
pub fn run_from_tree(a: FromTreeArgs) -> Result<()> {
    let mut tree = SynthTree::load(&a.tree)?;
    if let Some(e) = &a.edits {
        let edits = orogen::synth::orometric::TreeEdits::load(e)?;
        tree = orogen::synth::orometric::apply_edits(&tree, &edits)
            .with_context(|| format!("edits {}", e.display()))?;
        if let Some(p) = &a.edited_tree {
            tree.save(p)?;
            wrote(p);
        }
    } else if a.edited_tree.is_some() {
        bail!("--edited-tree needs --edits");
    }
    write_terrain(&tree, &a.terrain, &a.out, &a.run)
}

/// `orogen synth orometric`.
pub fn run_orometric(a: OrometricArgs) -> Result<()> {
    let tree = make_tree(&a.tree)?;
    if let Some(p) = &a.tree_out {
        tree.save(p)?;
        wrote(p);
    }
    write_terrain(&tree, &a.terrain, &a.out, &a.run)
}
