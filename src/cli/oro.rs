//! Orometric analysis commands: `orostats` (feature vectors and a region
//! profile), `classify` (random forest over feature vectors) and `ridges`.

use anyhow::{bail, Context, Result};
use clap::{Args, Subcommand};
use orogen::oro::classify::{self, Dataset, ForestParams, Model};
use orogen::oro::stats::{self, StatsOptions};
use orogen::oro::EdgeConvention;
use orogen::raster::{GeoRef, Grid, Window};
use std::path::{Path, PathBuf};

/// A distance like `10km`, `500m` or `2500` (metres).
pub fn parse_distance(s: &str) -> Result<f64> {
    let t = s.trim().to_ascii_lowercase();
    let (num, mult) = if let Some(v) = t.strip_suffix("km") {
        (v, 1000.0)
    } else if let Some(v) = t.strip_suffix('m') {
        (v, 1.0)
    } else {
        (t.as_str(), 1.0)
    };
    let v: f64 = num
        .trim()
        .parse()
        .with_context(|| format!("{s:?}: expected a distance like 10km or 500m"))?;
    let d = v * mult;
    if !(d.is_finite() && d > 0.0) {
        bail!("{s:?}: give a positive distance");
    }
    Ok(d)
}

fn convention(edge: &str) -> Result<EdgeConvention> {
    Ok(match edge {
        "sea-level" => EdgeConvention::SeaLevel,
        "unknown" => EdgeConvention::Unknown,
        e => bail!("--edge {e:?}: use sea-level or unknown"),
    })
}

/// Read a whole DEM as f32 (NaN = nodata), refusing what the memory budget cannot hold.
pub(crate) fn read_dem(
    input: &crate::In,
    run: &crate::Run,
    bytes_per_cell: u64,
) -> Result<(Grid<f32>, GeoRef)> {
    let cfg = crate::engine(run)?;
    let src = crate::open(input)?;
    let info = src.info().clone();
    let need = (info.width as u64) * (info.height as u64) * bytes_per_cell;
    if need > cfg.memory_budget {
        bail!(
            "{}: this step runs in memory and needs about {:.1} GiB for {}x{} cells; raise --memory (e.g. --memory {}GiB)",
            input.input.display(),
            need as f64 / (1u64 << 30) as f64,
            info.width,
            info.height,
            need.div_ceil(1 << 30)
        );
    }
    let dem =
        orogen::raster::read_window::<f32>(src.as_ref(), Window::full(info.width, info.height))?;
    Ok((dem, info.georef))
}

#[derive(Args)]
pub struct OrostatsArgs {
    #[command(flatten)]
    input: crate::In,
    /// Disk radius, e.g. 10km or 5000m.
    #[arg(short = 'R', long, default_value = "10km")]
    radius: String,
    /// Minimum distance between disk centres (at least R/2; default R/2).
    #[arg(long)]
    separation: Option<String>,
    /// Region label stored with every feature vector (for `orogen classify`).
    #[arg(long, default_value = "")]
    label: String,
    /// Seed of the blue-noise disk placement.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Peaks with at least this prominence.
    #[arg(long, default_value_t = 30.0)]
    min_prominence: f64,
    /// Edge and nodata convention: sea-level or unknown.
    #[arg(long, default_value = "sea-level")]
    edge: String,
    /// Skip disks with a smaller fraction of valid cells.
    #[arg(long, default_value_t = 0.9)]
    min_valid: f64,
    /// Feature vectors: .csv or .json.
    #[arg(short, long)]
    output: PathBuf,
    /// Also write the region profile (pooled distributions, JSON).
    #[arg(long)]
    profile: Option<PathBuf>,
    #[command(flatten)]
    run: crate::Run,
}

pub fn run_orostats(a: OrostatsArgs) -> Result<()> {
    let r = parse_distance(&a.radius)?;
    let mut opts = StatsOptions::new(r);
    if let Some(s) = &a.separation {
        opts.separation_m = parse_distance(s)?;
    }
    if !(a.min_prominence.is_finite() && a.min_prominence >= 0.0) {
        bail!(
            "--min-prominence {}: give a prominence of 0 or more",
            a.min_prominence
        );
    }
    if !(0.0..=1.0).contains(&a.min_valid) {
        bail!(
            "--min-valid {}: give a fraction between 0 and 1",
            a.min_valid
        );
    }
    opts.seed = a.seed;
    opts.min_prominence = a.min_prominence;
    opts.convention = convention(&a.edge)?;
    opts.min_valid_fraction = a.min_valid;
    let ext = a
        .output
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    if ext != "csv" && ext != "json" {
        bail!("-o {}: name the output .csv or .json", a.output.display());
    }
    let (dem, georef) = read_dem(&a.input, &a.run, 40)?;
    let source = a
        .input
        .input
        .file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let st = stats::orostats(&dem, &georef, &opts, &a.label, &source)?;
    if st.profile.n_peaks == 0 && !a.run.quiet {
        eprintln!(
            "warning: {}: no peaks with prominence >= {} (flat or all-nodata DEM?); the histograms are all zero",
            a.input.input.display(),
            a.min_prominence
        );
    }
    if st.disks.is_empty() {
        bail!(
            "{}: no disk of radius {} m with at least {:.0}% valid cells fits in the DEM; give a smaller -R or --min-valid",
            a.input.input.display(),
            r,
            a.min_valid * 100.0
        );
    }
    if ext == "csv" {
        stats::write_features_csv(&a.output, &st.disks)?;
    } else {
        stats::write_features_json(&a.output, &st.disks)?;
    }
    if !a.run.quiet {
        eprintln!(
            "{} disks of radius {} m, {} peaks (prominence >= {})",
            st.disks.len(),
            r,
            st.profile.n_peaks,
            a.min_prominence
        );
    }
    crate::wrote(&a.output);
    if let Some(p) = &a.profile {
        st.profile.save(p)?;
        crate::wrote(p);
    }
    Ok(())
}

#[derive(Args)]
pub struct ClassifyArgs {
    #[command(subcommand)]
    cmd: ClassifyCmd,
}

#[derive(Args, Clone)]
struct ForestArgs {
    /// Number of trees.
    #[arg(long, default_value_t = 100)]
    trees: u16,
    /// Seed of the forest.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Features tried per split (default √features).
    #[arg(long)]
    mtry: Option<usize>,
    /// Maximum tree depth.
    #[arg(long)]
    max_depth: Option<u16>,
}

impl ForestArgs {
    fn params(&self) -> ForestParams {
        ForestParams {
            n_trees: self.trees,
            seed: self.seed,
            m: self.mtry,
            max_depth: self.max_depth,
        }
    }
}

#[derive(Subcommand)]
enum ClassifyCmd {
    /// Train a random forest on labelled feature files and save it.
    Train {
        /// Feature CSVs from `orogen orostats --label ...`.
        #[arg(required = true)]
        features: Vec<PathBuf>,
        #[command(flatten)]
        forest: ForestArgs,
        /// Model file (JSON).
        #[arg(short, long)]
        output: PathBuf,
    },
    /// Label feature vectors with a trained model.
    Predict {
        /// Model from `orogen classify train`.
        model: PathBuf,
        /// Feature CSVs.
        #[arg(required = true)]
        features: Vec<PathBuf>,
        /// Write `true_label,predicted` per vector here (default: print counts).
        #[arg(short, long)]
        output: Option<PathBuf>,
    },
    /// Repeated stratified hold-out: accuracy mean ± sd and a confusion matrix.
    Evaluate {
        /// Labelled feature CSVs.
        #[arg(required = true)]
        features: Vec<PathBuf>,
        #[command(flatten)]
        forest: ForestArgs,
        /// Repetitions.
        #[arg(long, default_value_t = 10)]
        repeats: usize,
        /// Fraction held out for testing.
        #[arg(long, default_value_t = 0.2)]
        test_fraction: f64,
        /// Confusion matrix CSV.
        #[arg(short, long)]
        output: Option<PathBuf>,
    },
}

fn load_all(files: &[PathBuf]) -> Result<Dataset> {
    let mut ds = Dataset::default();
    for f in files {
        ds.extend(Dataset::read_csv(f)?)
            .with_context(|| format!("{}", f.display()))?;
    }
    Ok(ds)
}

pub fn run_classify(a: ClassifyArgs) -> Result<()> {
    match a.cmd {
        ClassifyCmd::Train {
            features,
            forest,
            output,
        } => {
            let ds = load_all(&features)?;
            let m = classify::train(&ds, &forest.params())?;
            m.save(&output)?;
            eprintln!(
                "trained {} trees on {} vectors of {} classes: {}",
                forest.trees,
                ds.rows.len(),
                m.classes.len(),
                m.classes.join(", ")
            );
            crate::wrote(&output);
        }
        ClassifyCmd::Predict {
            model,
            features,
            output,
        } => {
            let m = Model::load(&model)?;
            let ds = load_all(&features)?;
            if ds.names != m.names {
                bail!("the feature files do not have the columns the model was trained on");
            }
            let pred = m.predict(&ds.rows)?;
            match &output {
                Some(p) => {
                    let mut s = String::from("label,predicted\n");
                    for (l, q) in ds.labels.iter().zip(&pred) {
                        s.push_str(&format!("{l},{q}\n"));
                    }
                    write(p, &s)?;
                    crate::wrote(p);
                }
                None => {
                    for c in &m.classes {
                        let n = pred.iter().filter(|q| *q == c).count();
                        println!("{c}\t{n}");
                    }
                }
            }
        }
        ClassifyCmd::Evaluate {
            features,
            forest,
            repeats,
            test_fraction,
            output,
        } => {
            let ds = load_all(&features)?;
            let ev =
                classify::evaluate(&ds, &forest.params(), repeats, test_fraction, forest.seed)?;
            print!("{}", ev.summary());
            if let Some(p) = &output {
                write(p, &ev.confusion_csv())?;
                crate::wrote(p);
            }
        }
    }
    Ok(())
}

fn write(p: &Path, s: &str) -> Result<()> {
    Ok(orogen::io::atomic::write_file_atomic(p, s.as_bytes())?)
}

#[derive(Args)]
pub struct RidgesArgs {
    #[command(flatten)]
    input: crate::In,
    /// Ridges of peaks with at least this prominence.
    #[arg(long, default_value_t = 30.0)]
    min_prominence: f64,
    /// Edge and nodata convention of the divide tree: sea-level or unknown.
    #[arg(long, default_value = "sea-level")]
    edge: String,
    /// PPA profile half-length, cells.
    #[arg(long, default_value_t = 3)]
    half_window: usize,
    /// PPA: remove side branches shorter than this many cells.
    #[arg(long, default_value_t = 10)]
    min_branch: usize,
    /// Skip the PPA ridges.
    #[arg(long)]
    no_ppa: bool,
    /// Output folder.
    #[arg(short, long)]
    output: PathBuf,
    #[command(flatten)]
    fmt: crate::OutFmt,
    #[command(flatten)]
    run: crate::Run,
}

fn write_u8(grid: Grid<u8>, georef: &GeoRef, path: &Path, a: &RidgesArgs) -> Result<()> {
    let g = georef.clone().with_nodata(None);
    let mem = orogen::raster::MemRaster::new(orogen::raster::AnyGrid::U8(grid), g, path);
    let oo = crate::output_options(&a.fmt)?;
    orogen::ops::convert(&mem, path, &oo, None, &crate::engine(&a.run)?)?;
    crate::wrote(path);
    Ok(())
}

pub fn run_ridges(a: RidgesArgs) -> Result<()> {
    if !(a.min_prominence.is_finite() && a.min_prominence >= 0.0) {
        bail!(
            "--min-prominence {}: give a prominence of 0 or more",
            a.min_prominence
        );
    }
    let conv = convention(&a.edge)?;
    let per_cell = if a.no_ppa {
        40
    } else {
        40 + orogen::oro::ridges::PPA_BYTES_PER_CELL
    };
    let (dem, georef) = read_dem(&a.input, &a.run, per_cell)?;
    std::fs::create_dir_all(&a.output)
        .with_context(|| format!("{}: cannot create the output folder", a.output.display()))?;
    let opts = orogen::oro::PeakOptions {
        min_prominence: a.min_prominence,
        convention: conv,
        isolation: false,
    };
    let list = orogen::oro::peaks(&dem, &georef, &opts)?;
    let net = orogen::oro::ridges::divide_tree_ridges(&list.tree, &dem, &georef)?;
    let gj = a.output.join("ridges.geojson");
    net.write_geojson(&gj, &georef)?;
    crate::wrote(&gj);
    write_u8(
        net.rasterise_levels(),
        &georef,
        &a.output.join("ridge_levels.tif"),
        &a,
    )?;
    write_u8(
        net.rasterise_orders(),
        &georef,
        &a.output.join("ridge_orders.tif"),
        &a,
    )?;
    if !a.no_ppa {
        let ppa = orogen::oro::ridges::ppa_ridges(
            &dem,
            &orogen::oro::ridges::PpaOptions {
                half_window: a.half_window,
                min_branch: a.min_branch,
            },
        )?;
        write_u8(ppa, &georef, &a.output.join("ppa_ridges.tif"), &a)?;
    }
    if !a.run.quiet {
        eprintln!(
            "{} peaks (prominence >= {}), {} ridge segments, {} levels",
            list.tree.peaks.len(),
            a.min_prominence,
            net.edges.len(),
            net.edges.iter().map(|e| e.level).max().unwrap_or(0)
        );
    }
    Ok(())
}
