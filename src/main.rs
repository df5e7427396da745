//! The `orogen` command line: parses arguments and calls the library.

use anyhow::{bail, Context, Result};
use clap::{Args, Parser, Subcommand, ValueEnum};
use orogen::exec::EngineConfig;
use orogen::io::geotiff::{Compression, WriteOptions};
use orogen::io::{self, OpenOptions, OutputOptions};
use orogen::metrics::{Aspect, EdgeMode, Hillshade, Slope, SlopeUnits};
use orogen::ops;
use orogen::raster::{DType, RasterSource};
use std::path::{Path, PathBuf};

mod cli;

#[derive(Parser)]
#[command(name = "orogen", version, about = "Out-of-core engine for digital elevation models", long_about = None)]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Args, Clone)]
struct Run {
    /// Worker threads (0 = all cores).
    #[arg(long, default_value_t = 0, global = true)]
    threads: usize,
    /// Memory budget for tiles in flight, e.g. 512MiB, 2GiB.
    #[arg(long, default_value = "1GiB", global = true)]
    memory: String,
    /// Work-tile size in cells (default: the input store's, else 1024).
    #[arg(long, global = true)]
    tile: Option<usize>,
    /// No progress bar.
    #[arg(long, short, global = true)]
    quiet: bool,
    /// Engine: `local` (this process's threads) or `mpi` (the ranks of
    /// `mpirun -n N orogen ...`; needs a build with `--features mpi`).
    #[arg(long, value_enum, global = true)]
    engine: Option<EngineArg>,
}

/// `--engine` values (see `orogen::exec::EngineKind`).
#[derive(Copy, Clone, ValueEnum)]
pub(crate) enum EngineArg {
    Local,
    Mpi,
}

impl EngineArg {
    /// Make this the engine of the process (MPI starts here).
    pub(crate) fn select(self) -> Result<()> {
        orogen::exec::select_engine(match self {
            EngineArg::Local => orogen::exec::EngineKind::Local,
            EngineArg::Mpi => orogen::exec::EngineKind::Mpi,
        })?;
        Ok(())
    }
}

#[derive(Args, Clone)]
struct Out {
    /// Output: .tif (GeoTIFF), .tiles (tile store), .png (16-bit), .asc.
    #[arg(short, long)]
    output: PathBuf,
    #[command(flatten)]
    fmt: OutFmt,
}

/// Output format options (GeoTIFF and tile-store settings).
#[derive(Args, Clone)]
struct OutFmt {
    /// GeoTIFF compression.
    #[arg(long, value_enum, default_value_t = Compress::Deflate)]
    compress: Compress,
    /// GeoTIFF predictor (1 none, 2 horizontal, 3 floating point; default: automatic).
    #[arg(long)]
    predictor: Option<u16>,
    /// GeoTIFF block (tile) size.
    #[arg(long, default_value_t = 256)]
    block: usize,
    /// BigTIFF: yes, no or auto (auto: when the file could pass 4 GiB).
    #[arg(long, default_value = "auto")]
    bigtiff: String,
    /// Tile-store tile size (for .tiles outputs).
    #[arg(long, default_value_t = 1024)]
    store_tile: usize,
    /// Compress tile-store tiles with zstd.
    #[arg(long)]
    zstd: bool,
    /// Replace an existing output tile store instead of resuming it.
    #[arg(long)]
    overwrite: bool,
    /// Write .tif outputs as Cloud-Optimized GeoTIFFs (internal overviews).
    #[arg(long)]
    cog: bool,
    /// COG overview resampling: average (continuous data) or nearest (classes, codes).
    #[arg(long, default_value = "average")]
    overviews: String,
}

#[derive(Args, Clone)]
struct In {
    /// Input raster: GeoTIFF, .hgt, .asc, PNG heightmap or tile store.
    input: PathBuf,
    #[command(flatten)]
    png: PngArgs,
}

#[derive(Args, Clone)]
struct PngArgs {
    /// PNG heightmaps: metres per PNG unit.
    #[arg(long, default_value_t = 1.0)]
    png_scale: f64,
    /// PNG heightmaps: elevation of PNG value 0.
    #[arg(long, default_value_t = 0.0)]
    png_offset: f64,
}

impl PngArgs {
    fn open_options(&self) -> OpenOptions {
        OpenOptions {
            png_scale: self.png_scale,
            png_offset: self.png_offset,
        }
    }
}

#[derive(Copy, Clone, ValueEnum)]
enum Compress {
    None,
    Deflate,
    Lzw,
    Zstd,
}

#[derive(Subcommand)]
enum Cmd {
    /// Describe a raster: size, type, georeference, nodata, statistics.
    #[command(
        after_help = "Example:\n  orogen info ../shared/data/srtm3_N46E008.tif\n  orogen info dem.tiles --json"
    )]
    Info {
        #[command(flatten)]
        input: In,
        /// Print JSON.
        #[arg(long)]
        json: bool,
        /// Also compute min/max/mean (reads every cell).
        #[arg(long)]
        stats: bool,
        #[command(flatten)]
        run: Run,
    },
    /// Ingest one or more rasters (a mosaic) into a tile store.
    #[command(
        after_help = "Examples:\n  orogen ingest ../shared/data/poland_N49-55_E014-025.tif -o poland.tiles --memory 256MiB\n  orogen ingest N43E006.hgt N43E007.hgt -o alps.tiles --tile 512\n  orogen ingest srtm_folder/ -o mosaic.tiles\nRerunning an interrupted ingest resumes it."
    )]
    Ingest {
        /// Input rasters or folders (several = one mosaic).
        #[arg(required = true)]
        inputs: Vec<PathBuf>,
        #[command(flatten)]
        png: PngArgs,
        #[command(flatten)]
        out: Out,
        #[command(flatten)]
        run: Run,
    },
    /// Export a raster or tile store to GeoTIFF (or .png/.asc).
    #[command(
        after_help = "Example:\n  orogen export dem.tiles -o dem.tif --compress zstd --predictor 2"
    )]
    Export {
        #[command(flatten)]
        input: In,
        #[command(flatten)]
        out: Out,
        #[command(flatten)]
        run: Run,
    },
    /// Slope (Horn 1981, as gdaldem slope), in degrees or percent.
    #[command(
        after_help = "Example:\n  orogen slope dem.tif -o slope.tif\n  orogen slope dem.tiles -o slope.tiles --units percent"
    )]
    Slope {
        #[command(flatten)]
        input: In,
        #[arg(long, value_enum, default_value_t = UnitsArg::Degrees)]
        units: UnitsArg,
        /// Vertical exaggeration.
        #[arg(long, default_value_t = 1.0)]
        z_factor: f64,
        /// Compute edge cells with missing neighbours (gdaldem -compute_edges).
        #[arg(long)]
        compute_edges: bool,
        #[command(flatten)]
        out: Out,
        #[command(flatten)]
        run: Run,
    },
    /// Aspect (Horn 1981, as gdaldem aspect): azimuth of downslope, degrees from north.
    #[command(after_help = "Example:\n  orogen aspect dem.tif -o aspect.tif --zero-for-flat")]
    Aspect {
        #[command(flatten)]
        input: In,
        /// Flat cells get 0 instead of nodata.
        #[arg(long)]
        zero_for_flat: bool,
        #[arg(long)]
        compute_edges: bool,
        #[command(flatten)]
        out: Out,
        #[command(flatten)]
        run: Run,
    },
    /// Hillshade (Horn 1981, as gdaldem hillshade), byte values 1-255, 0 = nodata.
    #[command(
        after_help = "Example:\n  orogen hillshade dem.tif -o shade.tif --azimuth 315 --altitude 45"
    )]
    Hillshade {
        #[command(flatten)]
        input: In,
        #[arg(long, default_value_t = 315.0)]
        azimuth: f64,
        #[arg(long, default_value_t = 45.0)]
        altitude: f64,
        #[arg(long, default_value_t = 1.0)]
        z_factor: f64,
        #[arg(long)]
        compute_edges: bool,
        #[command(flatten)]
        out: Out,
        #[command(flatten)]
        run: Run,
    },
    /// Terrain descriptors: `orogen metric list`, or several metrics in one pass over the tiles.
    #[command(
        after_help = "Examples:\n  orogen metric list\n  orogen metric table [DEM] -o table/   (cost table and correlation matrix; see orogen metric table --help)\n  orogen metric dem.tif --metric slope,aspect,tpi:radius=500m,openness:radius=1km -o out/\n  orogen metric dem.tiles --metric curv_mean:radius=5c,relief:radius=300m -o out/ --format tiles\nOne file per metric is written into the output folder, named after the metric and its parameters."
    )]
    Metric {
        /// Input raster, or `list` to print the metrics and their parameters.
        input: PathBuf,
        /// Comma-separated metrics with parameters (`name:param=value:...`).
        #[arg(long, short = 'm')]
        metric: Option<String>,
        /// Output folder.
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// Output format: tif or tiles.
        #[arg(long, default_value = "tif")]
        format: String,
        #[command(flatten)]
        png: PngArgs,
        #[command(flatten)]
        out: OutFmt,
        #[command(flatten)]
        run: Run,
    },
    /// Peaks with prominence, key saddles, parents, isolation and the divide tree.
    #[command(
        after_help = "Example:\n  orogen peaks ../shared/data/srtm3_S33W071.tif --min-prominence 30 -o out/\nWrites peaks.csv, peaks.geojson, saddles.geojson, divide_tree.geojson and divide_tree.json.\nConventions (Kirmse & de Ferranti 2017): with --edge sea-level (default) the DEM's edge and\nnodata are sea level 0; with --edge unknown the outside is ignored.\nRuns in memory (about 28 bytes per cell) when --memory allows it, else tile by tile with the\nsame results (--tiled forces it):\n  orogen peaks poland.tif --memory 512MiB -o out/"
    )]
    Peaks {
        #[command(flatten)]
        input: In,
        /// Keep peaks with at least this prominence (DEM units, usually metres).
        #[arg(long, default_value_t = 30.0)]
        min_prominence: f64,
        /// Edge and nodata convention: sea-level or unknown.
        #[arg(long, default_value = "sea-level")]
        edge: String,
        /// Skip isolation (distance to higher ground).
        #[arg(long)]
        no_isolation: bool,
        /// Work tile by tile even if the DEM fits the memory budget.
        #[arg(long)]
        tiled: bool,
        /// Also write line parents, relevance and normalised elevation (needs the
        /// whole DEM in memory; not with --tiled).
        #[arg(long)]
        line_parents: bool,
        /// Output folder.
        #[arg(short, long)]
        output: PathBuf,
        #[command(flatten)]
        run: Run,
    },
    /// Orometric feature vectors over blue-noise disks (Argudo et al. 2019, Table 1) and a region profile.
    #[command(
        after_help = "Example:\n  orogen orostats ../shared/data/srtm3_N46E008.tif -R 10km --label alps -o alps.csv --profile alps.json\nOne feature vector per disk: histograms of normalised elevation, prominence, relative prominence,\ndominance, Jurgalski dominance groups, isolation and key-saddle distance and direction, relevance;\npeak density and nearest-neighbour index. Runs in memory (about 40 bytes per cell)."
    )]
    Orostats(cli::oro::OrostatsArgs),
    /// Region classifier: random forest over `orostats` feature vectors (train, predict, evaluate).
    #[command(
        after_help = "Examples:\n  orogen classify evaluate alps.csv andes.csv poland.csv --repeats 10 -o confusion.csv\n  orogen classify train alps.csv andes.csv -o model.json\n  orogen classify predict model.json unknown.csv"
    )]
    Classify(cli::oro::ClassifyArgs),
    /// Ridge networks: divide-tree ridges with hierarchy levels and orders, and PPA ridges.
    #[command(
        after_help = "Example:\n  orogen ridges ../shared/data/srtm3_S33W071.tif --min-prominence 100 -o ridges/\nWrites ridges.geojson (steepest-ascent paths saddle -> peak, with longest-path level and\nStrahler order), ridge_levels.tif, ridge_orders.tif (0 = no ridge) and ppa_ridges.tif\n(Chang et al. 1998 profile recognition + maximum spanning tree, 1 = ridge). Runs in memory."
    )]
    Ridges(cli::oro::RidgesArgs),
    /// Fill depressions (Priority-Flood; exact across tiles after Barnes 2016).
    #[command(
        after_help = "Example:\n  orogen fill dem.tif -o filled.tif\n  orogen fill poland.tiles -o filled.tiles --memory 512MiB\nNodata cells and the DEM's edge are outlets."
    )]
    Fill {
        #[command(flatten)]
        input: In,
        #[command(flatten)]
        out: Out,
        #[command(flatten)]
        run: Run,
    },
    /// D8 flow directions of a filled DEM (ESRI codes 1..128, 0 = no flow, 255 = nodata),
    /// flats drained per Barnes, Lehman & Mulla 2014, exact across tiles.
    #[command(
        after_help = "Example:\n  orogen fill dem.tif -o filled.tif && orogen flow filled.tif -o d8.tif\n  orogen flow filled.tif --method rho8 --seed 7 -o rho8.tif\nFlats (sea, lakes) are drained exactly across tiles (Barnes, Lehman & Mulla 2014)."
    )]
    Flow {
        #[command(flatten)]
        input: In,
        /// Routing: d8 (steepest descent) or rho8 (Fairfield & Leymarie 1991, stochastic, seeded).
        #[arg(long, default_value = "d8")]
        method: String,
        /// Rho8 seed (same seed, same directions, whatever the tiling).
        #[arg(long, default_value_t = 0)]
        seed: u64,
        #[command(flatten)]
        out: Out,
        #[command(flatten)]
        run: Run,
    },
    /// Breach depressions: carve channels out of pits instead of filling them
    /// (flood-order, Lindsay's selective hybrid, or least-cost within a distance).
    #[command(
        after_help = "Examples:\n  orogen breach dem.tif -o breached.tif\n  orogen breach dem.tif --method hybrid --max-depth 2 --max-length 50 -o hybrid.tif\n  orogen breach dem.tiles --method least-cost --dist 100 --fill-remaining -o breached.tiles\nbreach and hybrid run in memory (about 32 bytes per cell; see --memory); least-cost runs\nacross tiles and is exact for any tile size (halo 2*dist+1). Nodata and the edge are outlets."
    )]
    Breach(cli::breach::BreachArgs),
    /// Fill depressions to a strictly draining epsilon surface: each flat cell rises
    /// k ULPs above its fill level, k = its distance to the flat's exit; exact across tiles.
    #[command(
        after_help = "Example:\n  orogen fill-epsilon dem.tif -o eps.tif\nErrors (instead of raising terrain) where a flat is too wide for f32 steps;\nthen use fill + flow."
    )]
    FillEpsilon(cli::fill_epsilon::FillEpsilonArgs),
    /// Stream-power erosion with uplift (Braun & Willett 2013 implicit solver), optional
    /// Watershed labels from D8 directions: each cell gets the row-major index + 1 of
    /// the cell where its flow leaves the DEM (u32, 0 = nodata); exact across tiles.
    #[command(
        after_help = "Example:\n  orogen fill dem.tif -o f.tif && orogen flow f.tif -o d8.tif\n  orogen watersheds d8.tif -o basins.tif"
    )]
    Watersheds(cli::watersheds::WatershedsArgs),
    /// Flow accumulation in cells (or weighted): D8 from `orogen flow` directions, exact
    /// across tiles (Barnes 2017); or D-infinity / MFD from a filled DEM (in memory when it
    /// fits --memory, else exact across tiles in bounded rounds).
    #[command(
        after_help = "Examples:\n  orogen accumulate d8.tif -o acc.tif\n  orogen accumulate d8.tif --weights rain.tif -o acc.tif\n  orogen accumulate filled.tif --method dinf -o acc_dinf.tif\n  orogen accumulate filled.tif --method holmgren --exponent 4 -o acc_mfd.tif\nMethods: d8 (input: D8 directions), dinf (Tarboton 1997), quinn (Quinn et al. 1991),\nholmgren (Holmgren 1994, --exponent), freeman (Freeman 1991): input a filled DEM."
    )]
    Accumulate {
        /// D8 directions from `orogen flow` (method d8), or a filled DEM (other methods).
        #[command(flatten)]
        input: In,
        /// Routing: d8, dinf, quinn, holmgren, freeman.
        #[arg(long, default_value = "d8")]
        method: String,
        /// Holmgren's exponent.
        #[arg(long, default_value_t = 4.0)]
        exponent: f64,
        /// Weights raster (same size): accumulate its values instead of cells.
        #[arg(long)]
        weights: Option<PathBuf>,
        #[command(flatten)]
        out: Out,
        #[command(flatten)]
        run: Run,
    },
    /// Basin labels of every outlet, or watersheds of pour points (exact across tiles),
    /// optionally with per-basin metrics (area, perimeter, circularity, hypsometry, ...).
    #[command(
        after_help = "Examples:\n  orogen basins d8.tif -o basins.tif\n  orogen basins d8.tif --points gauges.csv --snap 5 --acc acc.tif -o watersheds.tif\n  orogen basins d8.tif -o basins.tif --metrics basins.csv --dem filled.tif --min-cells 1000\nLabels: a basin is labelled by its outlet's row-major cell index + 1; with --points by the\npoint's number (1 = first point). --metrics runs in memory (about 64 bytes per cell)."
    )]
    Basins(cli::hydro_net::BasinsArgs),
    /// Stream network from D8 directions: GeoJSON links with Strahler order, Shreve magnitude,
    /// length and drainage area; stream raster; Horton/Tokunaga statistics (in memory).
    #[command(
        after_help = "Examples:\n  orogen streams d8.tif -o streams.geojson --threshold 500 --raster order.tif --stats stats.json\n  orogen streams d8.tif -o streams.geojson --area 1e6 --csv links.csv --nodes nodes.geojson\n  orogen streams d8.tif --dem filled.tif --slope-area 200 -o streams.geojson\nRuns in memory (about 64 bytes per cell); --memory must allow it."
    )]
    Streams(cli::hydro_net::StreamsArgs),
    /// Hydrological indices: twi, spi, sti, ls (tile by tile), hand (exact across tiles),
    /// dtw (depth to water) and branch-length (maximum branch length), in memory.
    #[command(
        after_help = "Examples:\n  orogen hydro-index --index twi --dem filled.tif --acc acc.tif -o twi.tif\n  orogen hydro-index --index hand --dem filled.tif --dirs d8.tif --acc acc.tif --threshold 1000 -o hand.tif\n  orogen hydro-index --index dtw --dem filled.tif --streams order.tif --threshold 1 -o dtw.tif\n  orogen hydro-index --index branch-length --dirs d8.tif -o bmax.tif\nStreams are cells of --streams (default --acc) with a value >= --threshold."
    )]
    HydroIndex(cli::hydro_net::HydroIndexArgs),
    /// Render a preview PNG: hillshade blended with a hypsometric colour ramp.
    #[command(
        after_help = "Example:\n  orogen render dem.tiles -o preview.png --legend\n  orogen render slope.tif -o slope.png --grey"
    )]
    Render {
        #[command(flatten)]
        input: In,
        #[arg(short, long)]
        output: PathBuf,
        /// Longest side of the preview in pixels.
        #[arg(long, default_value_t = 2048)]
        max_size: usize,
        /// Draw a colour legend.
        #[arg(long)]
        legend: bool,
        /// Greyscale, no hillshade (for non-elevation rasters).
        #[arg(long)]
        grey: bool,
        #[command(flatten)]
        run: Run,
    },
    /// Web-map tile pyramid (Web Mercator): Terrain-RGB, Terrarium or colour PNG tiles
    /// into a z/x/y folder, an MBTiles file and/or a PMTiles archive.
    #[command(
        after_help = "Examples:\n  orogen tiles dem.tif -o dem.pmtiles\n  orogen tiles dem.tiles -o tiles/ -o dem.mbtiles --encoding terrarium --max-zoom 12\n  orogen tiles shade.tif -o shade.pmtiles --encoding color --ramp grey --range 0,255\nInputs: geographic, UTM (WGS 84 / ETRS89) or EPSG:3857 rasters. Nodata is transparent."
    )]
    Tiles(cli::tiles::TilesArgs),
    /// Serve a tile pyramid on localhost and show it as 3D terrain (MapLibre GL JS).
    #[command(
        after_help = "Examples:\n  orogen tiles dem.tif -o dem.pmtiles && orogen view dem.pmtiles\n  orogen view tiles/ --port 8080\nNeeds MapLibre GL JS from npm: bash tools/viewer_setup.sh (once)."
    )]
    View(cli::view::ViewArgs),
    /// Run a batch job: steps (any orogen command) from a TOML file, resumable.
    #[command(
        after_help = "Examples:\n  orogen run configs/continent-analysis.toml\n  orogen run job.toml --memory 512MiB --log job.jsonl\n  orogen run job.toml --dry-run\nA rerun skips the steps already done (same command, same inputs) and resumes\ninterrupted tile stores. Writes report.html into the job's output_dir.\nExit codes: 0 success, 1 a step or the job file failed (the message names it),\n2 bad command-line usage."
    )]
    Run(cli::job::RunArgs),
    /// Viewshed of an observer (R3 line of sight, Franklin & Ray 1994), cumulative
    /// viewshed of several, or Fisher's fuzzy viewshed.
    #[command(
        after_help = "Examples:\n  orogen viewshed dem.tif --at 352000,4590000 --observer-height 1.7 --radius 10km -o vis.tif\n  orogen viewshed srtm.tif --at=-105.2,39.7 --curvature -o vis.tif\n  orogen viewshed dem.tif --points towers.csv --radius 5km -o count.tif\n  orogen viewshed dem.tif --at 352000,4590000 --fuzzy 1000,2000 -o fuzzy.tif\nOne observer: u8, 1 visible, 0 hidden, 255 beyond the radius or nodata. Several: u16 count\nof observers seeing each cell. --fuzzy: f32 sum of memberships. The output covers the\nobservers' radius, clipped to the DEM. Coordinates are in the DEM's CRS (--pixel: col,row)."
    )]
    Viewshed(cli::viewshed::ViewshedArgs),
    /// Erosion: hydraulic (virtual pipes), thermal (talus), hillslope diffusion (tiled with
    /// halo exchange, bit-identical to an untiled run for any tile size) or stream power
    /// with uplift (Braun & Willett 2013; constrained and coarse-to-fine; in memory, or tiled out of core with the same bytes).
    #[command(
        after_help = "Examples:\n  orogen erode dem.tif --model hydraulic --steps 300 -o eroded.tif --preview previews/\n  orogen erode dem.tif --model thermal --steps 200 --talus 33 -o slumped.tif\n  orogen erode dem.tif --model diffusion --steps 100 --diffusivity 0.01 --dt 1000 -o smooth.tif\n  orogen erode dem.tiles --model hydraulic --steps 300 --params configs/erosion-hydraulic.toml --set rain=0.02 -o eroded.tiles\n  orogen erode dem.tif --model stream-power --steps 200 --dt 1000 --k 1e-5 --m 0.4 --n 1 --uplift 1e-3 -o sp.tif\n  orogen erode dem.tif --model stream-power --uplift-map u.tif --diffusivity 0.01 --depressions basin-graph -o sp.tif\n  orogen erode dem.tif --model stream-power --fixed-points peaks.csv --radius 300 --levels 100,50,30 -o sp.tif\nParameters: --params FILE (a table per model), then --set KEY=VALUE, then the named flags;\nstream power takes flags only (--k --m --n --uplift ...). Units: metres, seconds (hydraulic),\nyears (diffusion, stream power); see docs/notes/erosion.md and docs/notes/stream_power.md."
    )]
    Erode(cli::erode::ErodeArgs),
    /// Terrain synthesis: `orogen synth noise|...` (see `orogen synth --help`).
    Synth(cli::synth::SynthArgs),
    /// Realism report: compare two terrains (orometric histogram EMDs, pits,
    /// hypsometry, slope/curvature/geomorphon distributions, drainage density,
    /// Horton ratios) into compare.json, compare.html and PNG charts.
    #[command(
        after_help = "Examples:\n  orogen compare synth.tif ../shared/data/srtm3_S33W071.tif -o cmp/\n  orogen compare a.tif b.tif -o cmp/ --min-prominence 50 --radius 5km --channel-area 0.5\nBoth terrains are read into memory (limit: --memory). Densities are per km²,\ndistributions are fractions on common bins; every distance is 0 for identical terrains."
    )]
    Compare(cli::compare::CompareArgs),
    /// Generate a seeded terrain and run the pipeline on it into ./orogen-demo/.
    #[command(
        after_help = "Example:\n  orogen demo\n  orogen demo --size 4096 --seed 7 -o /tmp/demo"
    )]
    Demo {
        /// Output folder.
        #[arg(short, long, default_value = "orogen-demo")]
        output: PathBuf,
        /// Size in cells (square).
        #[arg(long, default_value_t = 1024)]
        size: usize,
        /// Random seed.
        #[arg(long, default_value_t = 42)]
        seed: u64,
        #[command(flatten)]
        run: Run,
    },
}

#[derive(Copy, Clone, ValueEnum)]
enum UnitsArg {
    Degrees,
    Percent,
}

fn parse_bytes(s: &str) -> Result<u64> {
    let t = s.trim();
    let split = t
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(t.len());
    let (num, unit) = t.split_at(split);
    let v: f64 = num
        .parse()
        .with_context(|| format!("--memory {s:?}: expected a size like 512MiB or 2GiB"))?;
    let mult = match unit.trim().to_ascii_lowercase().as_str() {
        "" | "b" => 1.0,
        "k" | "kb" | "kib" => 1024.0,
        "m" | "mb" | "mib" => 1024.0 * 1024.0,
        "g" | "gb" | "gib" => 1024.0 * 1024.0 * 1024.0,
        "t" | "tb" | "tib" => 1024.0f64.powi(4),
        u => bail!("--memory {s:?}: unknown unit {u:?} (use KiB, MiB, GiB)"),
    };
    let b = v * mult;
    if b.is_nan() || b < 16.0 * 1024.0 * 1024.0 {
        bail!("--memory {s:?} is too small: give at least 16MiB");
    }
    Ok(b as u64)
}

fn engine(run: &Run) -> Result<EngineConfig> {
    use std::io::IsTerminal;
    QUIET.store(run.quiet, std::sync::atomic::Ordering::Relaxed);
    if let Some(e) = run.engine {
        e.select()?;
    }
    Ok(EngineConfig {
        threads: run.threads,
        memory_budget: parse_bytes(&run.memory)?,
        progress: !run.quiet && std::io::stderr().is_terminal(),
    })
}

fn output_options(o: &OutFmt) -> Result<OutputOptions> {
    let compression = match o.compress {
        Compress::None => Compression::None,
        Compress::Deflate => Compression::Deflate { level: 6 },
        Compress::Lzw => Compression::Lzw,
        Compress::Zstd => Compression::Zstd { level: 9 },
    };
    let bigtiff = match o.bigtiff.as_str() {
        "auto" => None,
        "yes" | "true" => Some(true),
        "no" | "false" => Some(false),
        b => bail!("--bigtiff {b:?}: use yes, no or auto"),
    };
    if let Some(p) = o.predictor {
        if !(1..=3).contains(&p) {
            bail!("--predictor {p}: use 1 (none), 2 (horizontal) or 3 (floating point)");
        }
    }
    if o.block < 16 || !o.block.is_multiple_of(16) {
        bail!(
            "--block {}: GeoTIFF tiles must be a multiple of 16 (e.g. 256, 512)",
            o.block
        );
    }
    if o.store_tile < 16 {
        bail!("--store-tile {}: use at least 16 (e.g. 1024)", o.store_tile);
    }
    let tiff = WriteOptions {
        compression,
        predictor: o.predictor,
        block: o.block,
        bigtiff,
    };
    let mut store = orogen::store::StoreOptions::default();
    store.tile = o.store_tile;
    store.compression = if o.zstd {
        orogen::store::Compression::Zstd { level: 3 }
    } else {
        orogen::store::Compression::None
    };
    store.overwrite = o.overwrite;
    let cog = if o.cog {
        Some(match o.overviews.as_str() {
            "average" => orogen::io::geotiff::Resampling::Average,
            "nearest" => orogen::io::geotiff::Resampling::Nearest,
            r => bail!("--overviews {r:?}: use average (continuous data) or nearest (classes)"),
        })
    } else {
        None
    };
    Ok(OutputOptions { tiff, store, cog })
}

fn open(i: &In) -> Result<Box<dyn RasterSource>> {
    let src = io::open_raster(&i.input, &i.png.open_options())?;
    warn_georef(src.as_ref());
    Ok(src)
}

fn warn_georef(src: &dyn RasterSource) {
    let info = src.info();
    if !info.georef.georeferenced {
        eprintln!(
            "warning: {} has no georeferencing; using pixel coordinates with 1 x 1 cells (slopes assume cells of 1 elevation unit)",
            info.path.display()
        );
    }
}

fn edge(compute: bool) -> EdgeMode {
    if compute {
        EdgeMode::Compute
    } else {
        EdgeMode::Nodata
    }
}

static QUIET: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

fn wrote(p: &Path) {
    if !QUIET.load(std::sync::atomic::Ordering::Relaxed) {
        eprintln!("wrote {}", p.display());
    }
}

fn main() {
    // `orogen metric table ...` has its own parser (cli/metric_table.rs).
    let argv: Vec<std::ffi::OsString> = std::env::args_os().collect();
    if argv.get(1).is_some_and(|a| a == "metric") && argv.get(2).is_some_and(|a| a == "table") {
        let args = cli::metric_table::MetricTableArgs::parse_from(
            std::iter::once(std::ffi::OsString::from("orogen metric table"))
                .chain(argv[3..].iter().cloned()),
        );
        if let Err(e) = cli::metric_table::run(args) {
            eprintln!("error: {e:#}");
            std::process::exit(1);
        }
        return;
    }
    let cli = Cli::parse();
    if let Err(e) = run(cli) {
        // Under MPI this ends every rank (MPI_Abort), naming this one.
        orogen::exec::abort_engine(&format!("{e:#}"));
    }
    orogen::exec::finish_engine();
}

fn run(cli: Cli) -> Result<()> {
    match cli.cmd {
        Cmd::Run(a) => cli::job::run(a)?,
        Cmd::Tiles(a) => cli::tiles::run(a)?,
        Cmd::View(a) => cli::view::run(a)?,
        Cmd::Info {
            input,
            json,
            stats,
            run,
        } => {
            let src = open(&input)?;
            let cfg = engine(&run)?;
            let report = orogen::ops::describe(src.as_ref(), stats, &cfg)?;
            if json {
                println!("{}", serde_json::to_string_pretty(&report)?);
            } else {
                print!("{}", orogen::ops::describe_text(&report));
            }
        }
        Cmd::Ingest {
            inputs,
            png,
            out,
            run,
        } => {
            let src = io::open_inputs(&inputs, &png.open_options())?;
            warn_georef(src.as_ref());
            convert1(src.as_ref(), &out, &run)?;
        }
        Cmd::Export { input, out, run } => {
            let src = open(&input)?;
            convert1(src.as_ref(), &out, &run)?;
        }
        Cmd::Slope {
            input,
            units,
            z_factor,
            compute_edges,
            out,
            run,
        } => {
            let src = open(&input)?;
            let step = Slope {
                units: match units {
                    UnitsArg::Degrees => SlopeUnits::Degrees,
                    UnitsArg::Percent => SlopeUnits::Percent,
                },
                z_factor,
                edge: edge(compute_edges),
            };
            run_f32(&step, src.as_ref(), &out, &run)?;
        }
        Cmd::Aspect {
            input,
            zero_for_flat,
            compute_edges,
            out,
            run,
        } => {
            let src = open(&input)?;
            let step = Aspect {
                edge: edge(compute_edges),
                zero_for_flat,
            };
            run_f32(&step, src.as_ref(), &out, &run)?;
        }
        Cmd::Hillshade {
            input,
            azimuth,
            altitude,
            z_factor,
            compute_edges,
            out,
            run,
        } => {
            if !(0.0..=90.0).contains(&altitude) {
                bail!("--altitude {altitude}: the sun's altitude must be between 0 and 90 degrees");
            }
            let src = open(&input)?;
            let step = Hillshade {
                azimuth,
                altitude,
                z_factor,
                edge: edge(compute_edges),
            };
            local1(&step, src.as_ref(), &out, &run, (DType::U8, Some(0.0)))?;
        }
        Cmd::Metric {
            input,
            metric,
            output,
            format,
            png,
            out,
            run,
        } => {
            if input.as_os_str() == "list" {
                print!("{}", orogen::metrics::list());
                return Ok(());
            }
            let Some(spec) = metric else {
                bail!("give the metrics to compute with --metric (see `orogen metric list`)");
            };
            let Some(dir) = output else {
                bail!("give an output folder with -o DIR");
            };
            if format != "tif" && format != "tiles" {
                bail!("--format {format:?}: use tif or tiles");
            }
            let specs = orogen::metrics::parse_specs(&spec)?;
            let src = open(&In {
                input: input.clone(),
                png,
            })?;
            std::fs::create_dir_all(&dir)
                .with_context(|| format!("{}: cannot create the output folder", dir.display()))?;
            let paths = orogen::metrics::output_paths(&specs, &dir, &format)?;
            let oo = output_options(&out)?;
            orogen::metrics::compute(src.as_ref(), &specs, &paths, &oo, run.tile, &engine(&run)?)?;
            for p in &paths {
                wrote(p);
            }
        }
        Cmd::Peaks {
            input,
            min_prominence,
            edge,
            no_isolation,
            tiled,
            line_parents,
            output,
            run,
        } => {
            let convention = match edge.as_str() {
                "sea-level" => orogen::oro::EdgeConvention::SeaLevel,
                "unknown" => orogen::oro::EdgeConvention::Unknown,
                e => bail!("--edge {e:?}: use sea-level or unknown"),
            };
            if !(min_prominence.is_finite() && min_prominence >= 0.0) {
                bail!("--min-prominence {min_prominence}: give a prominence of 0 or more");
            }
            let cfg = engine(&run)?;
            let src = open(&input)?;
            let info = src.info().clone();
            let opts = orogen::oro::PeakOptions {
                min_prominence,
                convention,
                isolation: !no_isolation,
            };
            let need = (info.width as u64) * (info.height as u64) * 28;
            let go_tiled = tiled || need > cfg.memory_budget;
            if line_parents && go_tiled {
                bail!(
                    "--line-parents needs the whole DEM in memory (about {} MiB); raise --memory and drop --tiled",
                    need >> 20
                );
            }
            let list = if go_tiled {
                let tile = ops::choose_tile(src.as_ref(), run.tile);
                if !run.quiet {
                    eprintln!(
                        "peaks: {}x{} cells, tile by tile ({tile}-cell tiles)",
                        info.width, info.height
                    );
                }
                // A quarter of the budget caches cells for the isolation search.
                let cache = cfg.memory_budget / 4;
                let eng = orogen::exec::LocalEngine::new(cfg);
                (
                    orogen::oro::peaks_tiled(src.as_ref(), &opts, tile, &eng, cache)?,
                    None,
                )
            } else {
                let dem = orogen::raster::read_window::<f32>(
                    src.as_ref(),
                    orogen::raster::Window::full(info.width, info.height),
                )?;
                (orogen::oro::peaks(&dem, &info.georef, &opts)?, Some(dem))
            };
            let (list, dem) = list;
            // Line parents, relevance and normalised elevation need the DEM in
            // memory (--line-parents); otherwise those columns are empty, so the
            // files are the same bytes tiled and untiled.
            let files = match &dem {
                Some(dem) if line_parents => list.write_all_with_dem(&output, dem)?,
                _ => list.write_all(&output)?,
            };
            if !run.quiet {
                eprintln!(
                    "{} peaks with prominence >= {min_prominence}",
                    list.tree.peaks.len()
                );
            }
            for f in &files {
                wrote(f);
            }
        }
        Cmd::Orostats(a) => cli::oro::run_orostats(a)?,
        Cmd::Classify(a) => cli::oro::run_classify(a)?,
        Cmd::Ridges(a) => cli::oro::run_ridges(a)?,
        Cmd::Fill { input, out, run } => {
            let src = open(&input)?;
            let nd = orogen::hydro::out_nodata::elevation_nodata(src.as_ref())?;
            let ty = (DType::F32, Some(nd));
            global1(
                &orogen::hydro::tiled::TiledFill,
                &[src.as_ref()],
                &out,
                &run,
                ty,
            )?;
        }
        Cmd::Flow {
            input,
            method,
            seed,
            out,
            run,
        } => {
            let src = open(&input)?;
            let ty = (DType::U8, Some(orogen::hydro::NODATA_DIR as f64));
            match method.as_str() {
                "d8" => global1(
                    &orogen::hydro::tiled::TiledD8,
                    &[src.as_ref()],
                    &out,
                    &run,
                    ty,
                )?,
                "rho8" => global1(
                    &orogen::hydro::tiled_breach::TiledRho8 { seed },
                    &[src.as_ref()],
                    &out,
                    &run,
                    ty,
                )?,
                m => bail!("--method {m:?}: use d8 or rho8"),
            }
        }
        Cmd::Breach(args) => cli::breach::run(args)?,
        Cmd::FillEpsilon(a) => cli::fill_epsilon::run(a)?,
        Cmd::Watersheds(a) => cli::watersheds::run(a)?,
        Cmd::Accumulate {
            input,
            method,
            exponent,
            weights,
            out,
            run,
        } => {
            use orogen::hydro::mfd::MfdMethod;
            let multi = match method.as_str() {
                "d8" => None,
                "dinf" => Some(ops::FlowMethod::Dinf),
                "quinn" => Some(ops::FlowMethod::Mfd(MfdMethod::Quinn)),
                "holmgren" => Some(ops::FlowMethod::Mfd(MfdMethod::Holmgren(exponent))),
                "freeman" => Some(ops::FlowMethod::Mfd(MfdMethod::Freeman)),
                m => bail!("--method {m:?}: use d8, dinf, quinn, holmgren or freeman"),
            };
            let src = open(&input)?;
            if let Some(m) = multi {
                let w = open_weights(weights.as_deref())?;
                let oo = output_options(&out.fmt)?;
                let rounds = ops::accumulate_multi(
                    src.as_ref(),
                    w.as_deref(),
                    m,
                    &out.output,
                    &oo,
                    run.tile,
                    &engine(&run)?,
                )?;
                if !run.quiet && rounds > 0 {
                    eprintln!("accumulate: {rounds} rounds over tiles to the exact fixed point");
                }
                wrote(&out.output);
                return Ok(());
            }
            if src.info().dtype != DType::U8 {
                bail!(
                    "{}: expected D8 directions (a byte raster from `orogen flow`), found {} cells",
                    input.input.display(),
                    src.info().dtype
                );
            }
            let w = open_weights(weights.as_deref())?;
            let mut inputs: Vec<&dyn RasterSource> = vec![src.as_ref()];
            if let Some(w) = &w {
                inputs.push(w.as_ref());
            }
            let step = orogen::hydro::tiled::TiledAccumulation {
                weighted: weights.is_some(),
            };
            global1(&step, &inputs, &out, &run, (DType::F64, Some(-1.0)))?;
        }
        Cmd::Basins(a) => cli::hydro_net::run_basins(a)?,
        Cmd::Streams(a) => cli::hydro_net::run_streams(a)?,
        Cmd::HydroIndex(a) => cli::hydro_net::run_hydro_index(a)?,
        Cmd::Render {
            input,
            output,
            max_size,
            legend,
            grey,
            run: _,
        } => {
            let src = open(&input)?;
            let opts = orogen::tiles::render::RenderOptions {
                max_size,
                legend,
                kind: if grey {
                    orogen::tiles::render::RenderKind::Grey
                } else {
                    orogen::tiles::render::RenderKind::Elevation
                },
                ..Default::default()
            };
            orogen::tiles::render::render_preview(src.as_ref(), &output, &opts)?;
            wrote(&output);
        }
        Cmd::Viewshed(args) => cli::viewshed::run(args)?,
        Cmd::Erode(a) => cli::erode::run(a)?,
        Cmd::Synth(args) => cli::synth::run(args)?,
        Cmd::Compare(args) => cli::compare::run(args)?,
        Cmd::Demo {
            output,
            size,
            seed,
            run,
        } => {
            let files = ops::demo(&output, size, seed, &engine(&run)?)?;
            println!(
                "orogen demo: a {size}x{size} seeded terrain (seed {seed}) and its analysis in {}:",
                output.display()
            );
            for (f, what) in files {
                println!("  {:<28} {what}", f.display());
            }
        }
    }
    Ok(())
}

/// Copy `src` to the output (`orogen ingest`, `orogen export`).
fn convert1(src: &dyn RasterSource, out: &Out, run: &Run) -> Result<()> {
    let oo = output_options(&out.fmt)?;
    ops::convert(src, &out.output, &oo, run.tile, &engine(run)?)?;
    wrote(&out.output);
    Ok(())
}

/// The optional weights raster of `orogen accumulate`.
fn open_weights(p: Option<&Path>) -> Result<Option<Box<dyn RasterSource>>> {
    Ok(match p {
        Some(p) => Some(io::open_raster(p, &OpenOptions::default())?),
        None => None,
    })
}

/// Run a one-output local step and write it as `ty` (dtype, nodata).
fn local1<S: orogen::exec::LocalStep>(
    step: &S,
    src: &dyn RasterSource,
    out: &Out,
    run: &Run,
    ty: (DType, Option<f64>),
) -> Result<()> {
    let oo = output_options(&out.fmt)?;
    ops::run_local_to(step, src, &out.output, ty, &oo, run.tile, &engine(run)?)?;
    wrote(&out.output);
    Ok(())
}

/// Run a one-output global step on `inputs` and write it as `ty`.
fn global1<S: orogen::exec::GlobalStep>(
    step: &S,
    inputs: &[&dyn RasterSource],
    out: &Out,
    run: &Run,
    ty: (DType, Option<f64>),
) -> Result<()> {
    let oo = output_options(&out.fmt)?;
    ops::run_global_to(step, inputs, &out.output, ty, &oo, run.tile, &engine(run)?)?;
    wrote(&out.output);
    Ok(())
}

fn run_f32<S: orogen::exec::LocalStep<In = f32, Out = f32>>(
    step: &S,
    src: &dyn RasterSource,
    out: &Out,
    run: &Run,
) -> Result<()> {
    local1(
        step,
        src,
        out,
        run,
        (DType::F32, Some(orogen::metrics::terrain::SLOPE_NODATA)),
    )
}
