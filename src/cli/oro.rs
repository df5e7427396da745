//! Orometric analysis commands: `orostats` (feature vectors and a region
//! profile), `classify` (random forest over feature vectors) and `ridges`
//! (`orogen::ops::orostats`, `ops::classify`, `ops::ridges`).

use crate::distance;
use anyhow::Result;
use clap::{Args, Subcommand};
use orogen::ops::classify::{self, EvaluateOptions, ForestOptions};
use orogen::ops::orostats::{self, OrostatsOptions};
use orogen::ops::peaks;
use orogen::ops::ridges::{self, RidgesOptions};
use std::path::PathBuf;

#[derive(Args)]
#[command(
    after_help = "Example:\n  orogen orostats ../shared/data/srtm3_N46E008.tif -R 10km --label alps -o alps.csv --profile alps.json\nOne feature vector per disk: histograms of normalised elevation, prominence, relative prominence,\ndominance, Jurgalski dominance groups, isolation and key-saddle distance and direction, relevance;\npeak density and nearest-neighbour index. Runs in memory (about 40 bytes per cell)."
)]
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
    /// Edge and nodata convention: sea-level (the edge and nodata are sea at 0;
    /// land below 0 that reaches them meets the sea at its own level) or
    /// unknown (the outside is ignored).
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

/// Feature vectors (and the profile) of the input.
pub fn run_orostats(a: OrostatsArgs) -> Result<()> {
    let opts = OrostatsOptions {
        radius: distance("--radius", &a.radius)?,
        separation: a
            .separation
            .as_deref()
            .map(|s| distance("--separation", s))
            .transpose()?,
        label: a.label.clone(),
        seed: a.seed,
        min_prominence: a.min_prominence,
        edge: peaks::parse_edge(&a.edge)?,
        min_valid: a.min_valid,
        profile: a.profile.clone(),
    };
    opts.stats_options()?;
    orostats::check_output(&a.output)?;
    let cfg = crate::engine(&a.run)?;
    let src = crate::open(&a.input)?;
    let mut notify = super::erode::printer(a.run.quiet);
    orostats::run_noted(src.as_ref(), &a.output, &opts, &cfg, &mut notify)?;
    Ok(())
}

#[derive(Args)]
#[command(
    after_help = "Examples:\n  orogen classify evaluate alps.csv andes.csv poland.csv --repeats 10 -o confusion.csv\n  orogen classify train alps.csv andes.csv -o model.json\n  orogen classify predict model.json unknown.csv"
)]
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
    fn options(&self) -> ForestOptions {
        ForestOptions {
            trees: self.trees,
            seed: self.seed,
            mtry: self.mtry,
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

/// Train, predict or evaluate (`ops::classify`).
pub fn run_classify(a: ClassifyArgs) -> Result<()> {
    let mut notify = super::erode::printer(false);
    match a.cmd {
        ClassifyCmd::Train {
            features,
            forest,
            output,
        } => {
            classify::train_noted(&features, &forest.options(), &output, &mut notify)?;
        }
        ClassifyCmd::Predict {
            model,
            features,
            output,
        } => classify::predict_noted(&model, &features, output.as_deref(), &mut notify)?,
        ClassifyCmd::Evaluate {
            features,
            forest,
            repeats,
            test_fraction,
            output,
        } => {
            let opts = EvaluateOptions {
                forest: forest.options(),
                repeats,
                test_fraction,
            };
            classify::evaluate_noted(&features, &opts, output.as_deref(), &mut notify)?;
        }
    }
    Ok(())
}

#[derive(Args)]
#[command(
    after_help = "Example:\n  orogen ridges ../shared/data/srtm3_S33W071.tif --min-prominence 100 -o ridges/\nWrites ridges.geojson (steepest-ascent paths saddle -> peak, with longest-path level and\nStrahler order), ridge_levels.tif, ridge_orders.tif (0 = no ridge) and ppa_ridges.tif\n(Chang et al. 1998 profile recognition + maximum spanning tree, 1 = ridge). Runs in memory.\nridges.geojson is WGS 84 longitude/latitude (RFC 7946) unless --geojson-crs native; length_m is metres."
)]
pub struct RidgesArgs {
    #[command(flatten)]
    input: crate::In,
    /// Ridges of peaks with at least this prominence.
    #[arg(long, default_value_t = 30.0)]
    min_prominence: f64,
    /// Edge and nodata convention of the divide tree: sea-level (the edge and
    /// nodata are sea at 0; land below 0 that reaches them meets the sea at its
    /// own level) or unknown (the outside is ignored).
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
    geojson: crate::GeoJsonArg,
    #[command(flatten)]
    fmt: crate::OutFmt,
    #[command(flatten)]
    run: crate::Run,
}

/// Ridge networks of the input into the output folder.
pub fn run_ridges(a: RidgesArgs) -> Result<()> {
    let opts = RidgesOptions {
        min_prominence: a.min_prominence,
        edge: peaks::parse_edge(&a.edge)?,
        half_window: a.half_window,
        min_branch: a.min_branch,
        no_ppa: a.no_ppa,
        geojson_crs: a.geojson.crs,
    };
    opts.validate()?;
    let cfg = crate::engine(&a.run)?;
    let src = crate::open(&a.input)?;
    let oo = crate::output_options(&a.fmt)?;
    let mut notify = super::erode::printer(a.run.quiet);
    ridges::run_noted(src.as_ref(), &a.output, &opts, &oo, &cfg, &mut notify)?;
    Ok(())
}
