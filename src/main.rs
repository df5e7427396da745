//! The `orogen` command line: parses arguments and calls the library
//! (`orogen::ops`); each subcommand's arguments and conversion into the
//! library's options live in `cli/<command>.rs`, the shared ones in
//! `cli/args.rs`.

use anyhow::Result;
use clap::{Parser, Subcommand};

mod cli;

pub(crate) use cli::args::{
    distance, engine, open, output_options, target, warn_georef, wrote, EngineArg, GeoJsonArg, In,
    InputArgs, Out, OutFmt, Run,
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
    Info(cli::info::InfoArgs),
    /// Ingest one or more rasters (a mosaic) into a tile store.
    Ingest(cli::convert::IngestArgs),
    /// Export a raster or tile store to GeoTIFF (or .png/.asc).
    Export(cli::convert::ExportArgs),
    /// Slope (Horn 1981, as gdaldem slope), in degrees or percent.
    Slope(cli::terrain::SlopeArgs),
    /// Aspect (Horn 1981, as gdaldem aspect): azimuth of downslope, degrees from north.
    Aspect(cli::terrain::AspectArgs),
    /// Hillshade (Horn 1981, as gdaldem hillshade), byte values 1-255, 0 = nodata.
    Hillshade(cli::terrain::HillshadeArgs),
    /// Terrain descriptors: `orogen metric list`, or several metrics in one pass over the tiles.
    Metric(cli::metric::MetricArgs),
    /// Peaks with prominence, key saddles, parents, isolation and the divide tree.
    Peaks(cli::peaks::PeaksArgs),
    /// Orometric feature vectors over blue-noise disks (Argudo et al. 2019, Table 1) and a region profile.
    Orostats(cli::oro::OrostatsArgs),
    /// Region classifier: random forest over `orostats` feature vectors (train, predict, evaluate).
    Classify(cli::oro::ClassifyArgs),
    /// Ridge networks: divide-tree ridges with hierarchy levels and orders, and PPA ridges.
    Ridges(cli::oro::RidgesArgs),
    /// Fill voids (nodata cells) before hydrology: inverse-distance weighting of the
    /// first valid cell on each of 16 rays, out to --max-distance; exact across tiles.
    FillNodata(cli::fill_nodata::FillNodataArgs),
    /// Fill depressions (Priority-Flood; exact across tiles after Barnes 2016).
    Fill(cli::fill::FillArgs),
    /// D8 flow directions of a filled DEM (ESRI codes 1..128, 0 = no flow, 255 = nodata),
    /// flats drained per Barnes, Lehman & Mulla 2014, exact across tiles; true distances
    /// per row on lat/lon grids.
    Flow(cli::flow::FlowArgs),
    /// Breach depressions: carve channels out of pits instead of filling them
    /// (flood-order, Lindsay's selective hybrid, or least-cost within a distance).
    Breach(cli::breach::BreachArgs),
    /// Fill depressions to a strictly draining epsilon surface: each flat cell rises
    /// k ULPs above its fill level, k = its distance to the flat's exit; exact across tiles.
    FillEpsilon(cli::fill_epsilon::FillEpsilonArgs),
    /// Watershed labels from D8 directions: each cell gets the row-major index + 1 of
    /// the cell where its flow leaves the DEM (u32, 0 = nodata); exact across tiles.
    Watersheds(cli::watersheds::WatershedsArgs),
    /// Flow accumulation in cells (or weighted): D8 from `orogen flow` directions, exact
    /// across tiles (Barnes 2017); or D-infinity / MFD from a filled DEM (in memory when it
    /// fits --memory, else exact across tiles in bounded rounds).
    Accumulate(cli::accumulate::AccumulateArgs),
    /// Basin labels of every outlet, or watersheds of pour points (exact across tiles),
    /// optionally with per-basin metrics (area, perimeter, circularity, hypsometry, ...).
    Basins(cli::hydro_net::BasinsArgs),
    /// Stream network from D8 directions: GeoJSON links with Strahler order, Shreve magnitude,
    /// length and drainage area; stream raster; Horton/Tokunaga statistics (in memory).
    Streams(cli::hydro_net::StreamsArgs),
    /// Hydrological indices: twi, spi, sti, ls (tile by tile), hand (exact across tiles),
    /// dtw (depth to water) and branch-length (maximum branch length), in memory.
    HydroIndex(cli::hydro_net::HydroIndexArgs),
    /// Render a preview PNG: hillshade blended with a hypsometric colour ramp.
    Render(cli::render::RenderArgs),
    /// Web-map tile pyramid (Web Mercator): Terrain-RGB, Terrarium or colour PNG tiles
    /// into a z/x/y folder, an MBTiles file and/or a PMTiles archive.
    Tiles(cli::tiles::TilesArgs),
    /// Serve a tile pyramid on localhost and show it as 3D terrain (MapLibre GL JS).
    View(cli::view::ViewArgs),
    /// Run a batch job: steps (any orogen command) from a TOML file, resumable.
    #[command(
        after_help = "Examples:\n  orogen run configs/continent-analysis.toml\n  orogen run job.toml --memory 512MiB --log job.jsonl\n  orogen run job.toml --dry-run\nA rerun skips the steps already done (same command, same inputs) and resumes\ninterrupted tile stores. Writes report.html into the job's output_dir.\nExit codes: 0 success, 1 a step or the job file failed (the message names it),\n2 bad command-line usage."
    )]
    Run(cli::job::RunArgs),
    /// Viewshed of an observer (R3 line of sight, Franklin & Ray 1994), cumulative
    /// viewshed of several, or Fisher's fuzzy viewshed.
    Viewshed(cli::viewshed::ViewshedArgs),
    /// Erosion: hydraulic (virtual pipes), thermal (talus), hillslope diffusion (tiled with
    /// halo exchange, bit-identical to an untiled run for any tile size) or stream power
    /// with uplift (Braun & Willett 2013; constrained and coarse-to-fine; in memory, or tiled out of core with the same bytes).
    #[command(
        after_help = "Examples:\n  orogen erode dem.tif --model hydraulic --steps 300 -o eroded.tif --preview previews/\n  orogen erode dem.tif --model thermal --steps 200 --talus 33 -o slumped.tif\n  orogen erode dem.tif --model diffusion --steps 100 --diffusivity 0.01 --dt 1000 -o smooth.tif\n  orogen erode dem.tiles --model hydraulic --steps 300 --params configs/erosion-hydraulic.toml --set rain=0.02 -o eroded.tiles\n  orogen erode dem.tif --model stream-power --steps 200 --dt 1000 --k 1e-5 --m 0.4 --n 1 --uplift 1e-3 -o sp.tif\n  orogen erode dem.tif --model stream-power --uplift-map u.tif --diffusivity 0.01 --depressions basin-graph -o sp.tif\n  orogen erode dem.tif --model stream-power --fixed-points peaks.csv --radius 300 --levels 100,50,30 -o sp.tif\nParameters: --params FILE (a table per model), then --set KEY=VALUE, then the named flags;\nstream power takes flags only (--k --m --n --uplift ...). Units: metres, seconds (hydraulic),\nyears (diffusion, stream power); see docs/design/erosion.md#local-models-and-the-halo-exchange-driver and docs/design/erosion.md#stream-power."
    )]
    Erode(cli::erode::ErodeArgs),
    /// Terrain synthesis: `orogen synth noise|...` (see `orogen synth --help`).
    Synth(cli::synth::SynthArgs),
    /// Realism report: compare two terrains (orometric histogram EMDs, pits,
    /// hypsometry, slope/curvature/geomorphon distributions, drainage density,
    /// Horton ratios) into compare.json, compare.html and PNG charts.
    Compare(cli::compare::CompareArgs),
    /// Generate a seeded terrain and run the pipeline on it into ./orogen-demo/.
    Demo(cli::demo::DemoArgs),
}

fn main() {
    restore_sigpipe();
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

/// Let a closed stdout end the process quietly, as it does other Unix
/// tools (`orogen run job.toml --dry-run | head`): the Rust runtime ignores
/// SIGPIPE, so a write to a closed pipe fails and `println!` panics. Every
/// file output is written to a temporary and renamed into place, so a run
/// ended this way leaves no partial output.
fn restore_sigpipe() {
    #[cfg(unix)]
    // SAFETY: setting a signal's disposition to the default before any other
    // thread exists; no handler runs.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
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
        Cmd::FillNodata(a) => cli::fill_nodata::run(a)?,
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
