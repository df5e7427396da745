//! `synth profile | divide-tree | from-tree | orometric`: orometric terrain
//! synthesis (Argudo et al. 2019; see `crate::synth::orometric`). The
//! profile and the divide tree are JSON files a user may edit between the
//! steps.

use super::parse_size;
use crate::error::{Error, Result};
use crate::exec::EngineConfig;
use crate::exec::MemoryFit;
use crate::io::{open_raster, OpenOptions, OutputOptions};
use crate::ops::note::{bail, open_input, preview, Note, Notify};
use crate::raster::{read_window, AnyGrid, Grid, MemRaster, RasterSource, Window};
use crate::synth::orometric::tree_synth::{
    DEFAULT_ISOLATION_STRETCH, DEFAULT_PASSES, DEFAULT_RIDGE_ATTRACTION, DEFAULT_RIDGE_BASE,
    DEFAULT_RIDGE_CONTRAST, DEFAULT_TYPE_BLEND_M,
};
use crate::synth::orometric::{
    build_terrain, synthesize_tree, SynthPeak, SynthProfile, SynthTree, TerrainModel,
    TerrainOptions, TreeOptions,
};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Options of `synth profile`: measure a DEM, or edit a profile.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields, default)]
pub struct ProfileOptions {
    /// A DEM to measure, or a profile (.json) to edit.
    pub input: PathBuf,
    /// Peaks counted have at least this prominence (m).
    pub min_prominence: f64,
    /// Label of the region type.
    pub label: Option<String>,
    /// Edit: multiply prominences.
    pub scale_prominence: Option<f64>,
    /// Edit: multiply the peak density.
    pub scale_density: Option<f64>,
    /// Output profile (.json).
    pub output: PathBuf,
}

impl Default for ProfileOptions {
    fn default() -> Self {
        ProfileOptions {
            input: PathBuf::new(),
            min_prominence: 30.0,
            label: None,
            scale_prominence: None,
            scale_density: None,
            output: PathBuf::new(),
        }
    }
}

/// Options of the divide-tree synthesis shared by `divide-tree` and `orometric`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields, default)]
pub struct TreeSynthOptions {
    /// Profile made by `synth profile`.
    pub profile: PathBuf,
    /// Size in cells, WIDTHxHEIGHT (or one number for a square).
    pub size: String,
    /// Cell size in metres.
    pub cell: f64,
    /// Random seed.
    pub seed: u64,
    /// Number of peaks (default: the profile's density × area).
    pub peaks: Option<usize>,
    /// Ridge weight exponent ρ (0, 1 or 2).
    pub rho: u8,
    /// Peak density map C_P.
    pub density_map: Option<PathBuf>,
    /// Coarse elevation map C_H.
    pub elevation_map: Option<PathBuf>,
    /// Fixed peaks: GeoJSON points with an "elevation" property.
    pub fixed_peaks: Option<PathBuf>,
    /// Isolation proposals at this multiple of the target distance.
    pub isolation_stretch: f64,
    /// Least relief contrast of the ridge weights.
    pub ridge_contrast: f64,
    /// Least base of the ridge weights as a fraction of the lowest peak.
    pub ridge_base: f64,
    /// Width (metres) of the blend band of the type map's regions.
    #[serde(rename = "type-blend")]
    pub type_blend_m: f64,
    /// Skip the local search on saddle heights after the assignment.
    pub no_refine: bool,
    /// Placement passes by prominence bins.
    pub passes: usize,
    /// Weight (0..1) of the diffused ridges of earlier passes.
    pub ridge_attraction: f64,
    /// Type map C_T: a raster of labels or GeoJSON polygons with a "label".
    pub type_map: Option<PathBuf>,
    /// Profiles of type-map labels, LABEL=PROFILE.json.
    #[serde(rename = "type-profile")]
    pub type_profiles: Vec<String>,
    /// Paste a fragment of a real divide tree (peaks.csv of `peaks`).
    pub paste: Option<PathBuf>,
    /// Window of the real DEM to paste, COL,ROW,WIDTH,HEIGHT.
    pub paste_window: Option<String>,
    /// Where the window's top-left cell goes, COL,ROW.
    pub paste_at: String,
}

impl Default for TreeSynthOptions {
    fn default() -> Self {
        TreeSynthOptions {
            profile: PathBuf::new(),
            size: "1024".into(),
            cell: 30.0,
            seed: 1,
            peaks: None,
            rho: 2,
            density_map: None,
            elevation_map: None,
            fixed_peaks: None,
            isolation_stretch: DEFAULT_ISOLATION_STRETCH,
            ridge_contrast: DEFAULT_RIDGE_CONTRAST,
            ridge_base: DEFAULT_RIDGE_BASE,
            type_blend_m: DEFAULT_TYPE_BLEND_M,
            no_refine: false,
            passes: DEFAULT_PASSES,
            ridge_attraction: DEFAULT_RIDGE_ATTRACTION,
            type_map: None,
            type_profiles: vec![],
            paste: None,
            paste_window: None,
            paste_at: "0,0".into(),
        }
    }
}

/// Terrain model (`terrain`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum TerrainKind {
    /// River network, valley widths and a constrained TIN (Argudo et al. 2019 §6).
    Tin,
    /// Upper envelope of tents over the refined ridges.
    Tents,
}

/// Terrain options shared by `from-tree` and `orometric`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields, default)]
pub struct TerrainSynthOptions {
    /// Terrain model.
    pub terrain: TerrainKind,
    /// TIN model: valley floor width (m) at 1 km² of drainage area.
    pub valley_width: f64,
    /// TIN model: river slope (m/m) at 1 km² of drainage area.
    pub river_slope: f64,
    /// Flank slope (m/m) of the tents model.
    pub slope: f64,
    /// Ridge refinement spacing λ (m).
    pub spacing: f64,
    /// Noise amplitude (m; default 0.3 × the prominence threshold).
    pub noise: Option<f64>,
    /// Also write a PNG preview (hillshaded).
    pub preview: Option<PathBuf>,
    /// Outer iterations of constrained stream-power erosion (0 = none).
    pub erode: usize,
    /// Radius (m) of the compensating uplift (default: 10 cells).
    pub erode_radius: Option<f64>,
    /// Erodibility K of the constrained erosion.
    pub erode_k: f64,
}

impl Default for TerrainSynthOptions {
    fn default() -> Self {
        TerrainSynthOptions {
            terrain: TerrainKind::Tin,
            valley_width: 100.0,
            river_slope: 0.2,
            slope: 0.6,
            spacing: 200.0,
            noise: None,
            preview: None,
            erode: 0,
            erode_radius: None,
            erode_k: 2e-5,
        }
    }
}

/// Options of `synth divide-tree`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub struct DivideTreeOptions {
    #[serde(flatten)]
    pub tree: TreeSynthOptions,
    /// Output divide tree (.json, editable).
    #[serde(default)]
    pub output: PathBuf,
    /// Also write the tree as GeoJSON (peaks, saddles, ridges).
    #[serde(default)]
    pub geojson: Option<PathBuf>,
}

/// Options of `synth from-tree`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub struct FromTreeOptions {
    /// Divide tree (.json) from `synth divide-tree`, possibly edited.
    #[serde(default)]
    pub tree: PathBuf,
    /// Apply an edit file to the tree, then regenerate ridges and saddles.
    #[serde(default)]
    pub edits: Option<PathBuf>,
    /// Save the edited and regenerated tree (.json).
    #[serde(default)]
    pub edited_tree: Option<PathBuf>,
    #[serde(flatten)]
    pub terrain: TerrainSynthOptions,
    /// Output raster.
    #[serde(default)]
    pub output: PathBuf,
    /// Work-tile size in cells for writing.
    #[serde(default)]
    pub tile: Option<usize>,
}

/// Options of `synth orometric`: profile -> divide tree -> terrain.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub struct OrometricOptions {
    #[serde(flatten)]
    pub tree: TreeSynthOptions,
    #[serde(flatten)]
    pub terrain: TerrainSynthOptions,
    /// Also save the divide tree (.json).
    #[serde(default)]
    pub tree_out: Option<PathBuf>,
    /// Output raster.
    #[serde(default)]
    pub output: PathBuf,
    /// Work-tile size in cells for writing.
    #[serde(default)]
    pub tile: Option<usize>,
}

/// `synth profile`: the orometry profile of a DEM (or an edited profile).
pub fn run_profile(a: &ProfileOptions, open: &OpenOptions, notify: Notify<'_>) -> Result<()> {
    let path = &a.input;
    let is_json = path
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("json"));
    let mut prof = if is_json {
        SynthProfile::load(path)?
    } else {
        let src = open_input(path, open, &mut *notify)?;
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
        .map_err(|e| Error::invalid(format!("profile of {}: {e}", path.display())))?
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
    notify(Note::Wrote(a.output.clone()));
    Ok(())
}

/// Largest map (density, elevation) read into memory, cells.
const MAX_MAP_CELLS: usize = 1 << 26;

fn read_all(src: &dyn RasterSource, path: &Path) -> Result<Grid<f32>> {
    let (w, h) = (src.info().width, src.info().height);
    if w.saturating_mul(h) > 1 << 30 {
        bail!(
            "{}: {w}x{h} cells is too large to measure in memory; crop it first",
            path.display()
        );
    }
    read_window::<f32>(src, Window::full(w, h))
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
    read_window::<f32>(&*src, Window::full(w, h))
}

/// Fixed peaks from GeoJSON points with an "elevation" property.
fn read_fixed(path: &Path, h_cells: usize, cell: f64) -> Result<Vec<SynthPeak>> {
    let meta =
        std::fs::metadata(path).map_err(|e| Error::invalid(format!("{}: {e}", path.display())))?;
    if meta.len() > 256 << 20 {
        bail!("{}: fixed-peak file over 256 MiB", path.display());
    }
    let text = std::fs::read_to_string(path)
        .map_err(|e| Error::invalid(format!("{}: {e}", path.display())))?;
    let v: serde_json::Value = serde_json::from_str(&text)
        .map_err(|e| Error::invalid(format!("{}: not JSON: {e}", path.display())))?;
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

/// Synthesise the divide tree described by `t`.
pub fn make_tree(t: &TreeSynthOptions) -> Result<SynthTree> {
    let prof = SynthProfile::load(&t.profile)?;
    let (w, h) = parse_size(&t.size)?;
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
    synthesize_tree(&prof, &o)
}

/// Parse "a,b,…" into exactly `n` integers.
fn ints(s: &str, n: usize, what: &str) -> Result<Vec<i64>> {
    let v: Vec<i64> = s
        .split(',')
        .map(|x| x.trim().parse::<i64>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|e| {
            Error::invalid(format!(
                "{what} {s:?}: expected {n} integers separated by commas: {e}"
            ))
        })?;
    if v.len() != n {
        bail!("{what} {s:?}: expected {n} integers separated by commas");
    }
    Ok(v)
}

/// The multi-pass, type-map and pasted-fragment options of `t` into `o`.
fn author_options(t: &TreeSynthOptions, o: &mut TreeOptions) -> Result<()> {
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
            crate::synth::orometric::typemap::rasterize_geojson(p, w * o.cell, h * o.cell, c, r)?
        } else {
            read_map(p)?
        };
        let mut regions = Vec::new();
        for tp in &t.type_profiles {
            let Some((l, f)) = tp.split_once('=') else {
                bail!("--type-profile {tp:?}: expected LABEL=PROFILE.json");
            };
            let l: i64 = l.trim().parse().map_err(|e| {
                Error::invalid(format!(
                    "--type-profile {tp:?}: the label must be an integer: {e}"
                ))
            })?;
            regions.push((l, SynthProfile::load(Path::new(f.trim()))?));
        }
        o.type_map = Some(
            crate::synth::orometric::TypeMap::new(labels, regions)
                .map_err(|e| Error::invalid(format!("type map {}: {e}", p.display())))?,
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
        let frag = crate::synth::orometric::Fragment::from_peaks_csv(
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

fn terrain_opts(t: &TerrainSynthOptions) -> TerrainOptions {
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

/// Render the terrain of `tree` and write it to `output` (and its preview).
#[allow(clippy::too_many_arguments)]
fn write_terrain(
    tree: &SynthTree,
    t: &TerrainSynthOptions,
    output: &Path,
    tile: Option<usize>,
    oo: &OutputOptions,
    cfg: &EngineConfig,
    notify: Notify<'_>,
) -> Result<()> {
    let ter = build_terrain(tree, &terrain_opts(t))?;
    if t.erode == 0 {
        crate::ops::convert(&*ter, output, oo, tile, cfg)?;
    } else {
        let eroded = erode_keeping_tree(tree, &*ter, t, cfg)?;
        crate::ops::convert(&eroded, output, oo, tile, cfg)?;
    }
    notify(Note::Wrote(output.to_path_buf()));
    if let Some(p) = &t.preview {
        let written = open_raster(output, &OpenOptions::default())?;
        preview(written.as_ref(), p, &Default::default(), notify)?;
    }
    Ok(())
}

/// Constrained erosion of the rendered terrain: the cells holding the tree's
/// peaks and saddles are the fixed points (`erosion::constrained`).
fn erode_keeping_tree(
    tree: &SynthTree,
    ter: &dyn RasterSource,
    t: &TerrainSynthOptions,
    cfg: &EngineConfig,
) -> Result<MemRaster> {
    use crate::erosion::constrained::{erode_constrained, ConstrainedParams};
    let info = ter.info().clone();
    // Heights, receivers, stack, areas, donors and queues of the in-memory solver.
    let fit = MemoryFit::cells(info.width, info.height, 100, cfg.memory_budget);
    if !fit.fits() {
        return Err(crate::error::Error::over_budget(format!(
            "--erode runs in memory and needs about {:.1} GiB for {}x{} cells; raise --memory or drop --erode",
            fit.need_gib(),
            info.width,
            info.height
        )));
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

/// `synth divide-tree`: synthesise a divide tree and save it (and its GeoJSON).
pub fn run_divide_tree(a: &DivideTreeOptions, notify: Notify<'_>) -> Result<()> {
    let tree = make_tree(&a.tree)?;
    tree.save(&a.output)?;
    notify(Note::Wrote(a.output.clone()));
    if let Some(g) = &a.geojson {
        crate::io::atomic::write_file_atomic(g, tree.to_geojson().as_bytes())?;
        notify(Note::Wrote(g.clone()));
    }
    Ok(())
}

/// `synth from-tree`: the terrain of a (possibly edited) divide tree.
pub fn run_from_tree(
    a: &FromTreeOptions,
    oo: &OutputOptions,
    cfg: &EngineConfig,
    notify: Notify<'_>,
) -> Result<()> {
    let mut tree = SynthTree::load(&a.tree)?;
    if let Some(e) = &a.edits {
        let edits = crate::synth::orometric::TreeEdits::load(e)?;
        tree = crate::synth::orometric::apply_edits(&tree, &edits)
            .map_err(|err| Error::invalid(format!("edits {}: {err}", e.display())))?;
        if let Some(p) = &a.edited_tree {
            tree.save(p)?;
            notify(Note::Wrote(p.clone()));
        }
    } else if a.edited_tree.is_some() {
        bail!("--edited-tree needs --edits");
    }
    write_terrain(&tree, &a.terrain, &a.output, a.tile, oo, cfg, notify)
}

/// `synth orometric`: profile -> divide tree -> terrain.
pub fn run_orometric(
    a: &OrometricOptions,
    oo: &OutputOptions,
    cfg: &EngineConfig,
    notify: Notify<'_>,
) -> Result<()> {
    let tree = make_tree(&a.tree)?;
    if let Some(p) = &a.tree_out {
        tree.save(p)?;
        notify(Note::Wrote(p.clone()));
    }
    write_terrain(&tree, &a.terrain, &a.output, a.tile, oo, cfg, notify)
}
