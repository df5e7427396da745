//! The `orogen` command line: parses arguments and calls the library
//! (`orogen::ops`); each subcommand's arguments and conversion into the
//! library's options live in `cli/<command>.rs`, the shared ones in
//! `cli/args.rs`.

use anyhow::Result;
use clap::{Parser, Subcommand};

mod cli;

pub(crate) use cli::args::{
    engine, global1, open, output_options, target, warn_georef, wrote, EngineArg, In, Out, OutFmt,
    PngArgs, Run,
};

#[derive(Parser)]
#[command(name = "orogen", version, about = "Out-of-core engine for digital elevation models", long_about = None)]
pub(crate) struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// Describe a raster: size, type, georeference, nodata, statistics.
    #[command(
        after_help = "Example:\n  orogen info ../shared/data/srtm3_N46E008.tif\n  orogen info dem.tiles --json"
    )]
    Info(cli::info::InfoArgs),
    /// Ingest one or more rasters (a mosaic) into a tile store.
    #[command(
        after_help = "Examples:\n  orogen ingest ../shared/data/poland_N49-55_E014-025.tif -o poland.tiles --memory 256MiB\n  orogen ingest N43E006.hgt N43E007.hgt -o alps.tiles --tile 512\n  orogen ingest srtm_folder/ -o mosaic.tiles\nRerunning an interrupted ingest resumes it."
    )]
    Ingest(cli::convert::IngestArgs),
    /// Export a raster or tile store to GeoTIFF (or .png/.asc).
    #[command(
        after_help = "Example:\n  orogen export dem.tiles -o dem.tif --compress zstd --predictor 2"
    )]
    Export(cli::convert::ExportArgs),
    /// Slope (Horn 1981, as gdaldem slope), in degrees or percent.
    #[command(
        after_help = "Example:\n  orogen slope dem.tif -o slope.tif\n  orogen slope dem.tiles -o slope.tiles --units percent"
    )]
    Slope(cli::terrain::SlopeArgs),
    /// Aspect (Horn 1981, as gdaldem aspect): azimuth of downslope, degrees from north.
    #[command(after_help = "Example:\n  orogen aspect dem.tif -o aspect.tif --zero-for-flat")]
    Aspect(cli::terrain::AspectArgs),
    /// Hillshade (Horn 1981, as gdaldem hillshade), byte values 1-255, 0 = nodata.
    #[command(
        after_help = "Example:\n  orogen hillshade dem.tif -o shade.tif --azimuth 315 --altitude 45"
    )]
    Hillshade(cli::terrain::HillshadeArgs),
    /// Terrain descriptors: `orogen metric list`, or several metrics in one pass over the tiles.
    #[command(
        after_help = "Examples:\n  orogen metric list\n  orogen metric table [DEM] -o table/   (cost table and correlation matrix; see orogen metric table --help)\n  orogen metric dem.tif --metric slope,aspect,tpi:radius=500m,openness:radius=1km -o out/\n  orogen metric dem.tiles --metric curv_mean:radius=5c,relief:radius=300m -o out/ --format tiles\nOne file per metric is written into the output folder, named after the metric and its parameters."
    )]
    Metric(cli::metric::MetricArgs),
    /// Peaks with prominence, key saddles, parents, isolation and the divide tree.
    #[command(
        after_help = "Example:\n  orogen peaks ../shared/data/srtm3_S33W071.tif --min-prominence 30 -o out/\nWrites peaks.csv, peaks.geojson, saddles.geojson, divide_tree.geojson and divide_tree.json.\nConventions (Kirmse & de Ferranti 2017): with --edge sea-level (default) the DEM's edge and\nnodata are sea level 0; with --edge unknown the outside is ignored.\nRuns in memory (about 28 bytes per cell) when --memory allows it, else tile by tile with the\nsame results (--tiled forces it):\n  orogen peaks poland.tif --memory 512MiB -o out/"
    )]
    Peaks(cli::peaks::PeaksArgs),
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
    Fill(cli::fill::FillArgs),
    /// D8 flow directions of a filled DEM (ESRI codes 1..128, 0 = no flow, 255 = nodata),
    /// flats drained per Barnes, Lehman & Mulla 2014, exact across tiles.
    #[command(
        after_help = "Example:\n  orogen fill dem.tif -o filled.tif && orogen flow filled.tif -o d8.tif\n  orogen flow filled.tif --method rho8 --seed 7 -o rho8.tif\nFlats (sea, lakes) are drained exactly across tiles (Barnes, Lehman & Mulla 2014)."
    )]
    Flow(cli::flow::FlowArgs),
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
    Accumulate(cli::accumulate::AccumulateArgs),
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
    Render(cli::render::RenderArgs),
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
    Demo(cli::demo::DemoArgs),
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
        Cmd::Info(a) => cli::info::run(a)?,
        Cmd::Ingest(a) => cli::convert::run_ingest(a)?,
        Cmd::Export(a) => cli::convert::run_export(a)?,
        Cmd::Slope(a) => cli::terrain::run_slope(a)?,
        Cmd::Aspect(a) => cli::terrain::run_aspect(a)?,
        Cmd::Hillshade(a) => cli::terrain::run_hillshade(a)?,
        Cmd::Metric(a) => cli::metric::run(a)?,
        Cmd::Peaks(a) => cli::peaks::run(a)?,
        Cmd::Orostats(a) => cli::oro::run_orostats(a)?,
        Cmd::Classify(a) => cli::oro::run_classify(a)?,
        Cmd::Ridges(a) => cli::oro::run_ridges(a)?,
        Cmd::Fill(a) => cli::fill::run(a)?,
        Cmd::Flow(a) => cli::flow::run(a)?,
        Cmd::Breach(args) => cli::breach::run(args)?,
        Cmd::FillEpsilon(a) => cli::fill_epsilon::run(a)?,
        Cmd::Watersheds(a) => cli::watersheds::run(a)?,
        Cmd::Accumulate(a) => cli::accumulate::run(a)?,
        Cmd::Basins(a) => cli::hydro_net::run_basins(a)?,
        Cmd::Streams(a) => cli::hydro_net::run_streams(a)?,
        Cmd::HydroIndex(a) => cli::hydro_net::run_hydro_index(a)?,
        Cmd::Render(a) => cli::render::run(a)?,
        Cmd::Viewshed(args) => cli::viewshed::run(args)?,
        Cmd::Erode(a) => cli::erode::run(a)?,
        Cmd::Synth(args) => cli::synth::run(args)?,
        Cmd::Compare(args) => cli::compare::run(args)?,
        Cmd::Demo(a) => cli::demo::run(a)?,
    }
    Ok(())
}
