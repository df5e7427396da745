//! `orogen basins`, `orogen streams` and `orogen hydro-index`: basins and
//! watersheds, stream networks and their statistics, hydrological indices
//! (`orogen::ops::basins`, `ops::streams`, `ops::hydro_index`).

use anyhow::Result;
use clap::Args;
use orogen::ops::basins::{self, BasinsOptions};
use orogen::ops::hydro_index::{self, HydroIndexOptions};
use orogen::ops::streams::{self, StreamsOptions};
use orogen::ops::Target;
use std::path::PathBuf;

// ------------------------------------------------------------ basins ----

#[derive(Args)]
#[command(
    after_help = "Examples:\n  orogen basins d8.tif -o basins.tif\n  orogen basins d8.tif --points gauges.csv --snap 5 --acc acc.tif -o watersheds.tif\n  orogen basins d8.tif -o basins.tif --metrics basins.csv --dem filled.tif --min-cells 1000\nLabels: a basin is labelled by its outlet's row-major cell index + 1; with --points by the\npoint's number (1 = first point). --metrics runs in memory (about 64 bytes per cell).\nThe outlines GeoJSON of --metrics is WGS 84 longitude/latitude (RFC 7946) unless\n--geojson-crs native; areas, lengths and outlet_x/outlet_y (as in the CSV) stay in the\nraster's CRS units. GeoJSON pour points are in the rasters' CRS unless the file has a \"crs\"\nmember (CRS84/EPSG:4326: longitude/latitude; the rasters' EPSG code)."
)]
pub struct BasinsArgs {
    /// D8 flow directions (from `orogen flow`).
    pub dirs: PathBuf,
    /// Output label raster (.tif or .tiles): basin label = outlet's row-major index + 1,
    /// or pour-point number with --points; 0 = none/nodata.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Pour points (CSV with x,y or lon,lat columns, or GeoJSON Points) in the rasters' CRS:
    /// delineate their watersheds instead of every outlet's basin.
    #[arg(long)]
    pub points: Option<PathBuf>,
    /// Snap each pour point to the cell of largest accumulation within this many cells.
    #[arg(long, default_value_t = 0)]
    pub snap: usize,
    /// Flow accumulation (for --snap).
    #[arg(long)]
    pub acc: Option<PathBuf>,
    /// Also write per-basin metrics to this CSV and, beside it (.geojson), the basins' outlines
    /// as MultiPolygons with the metrics as properties; needs --dem.
    #[arg(long)]
    pub metrics: Option<PathBuf>,
    /// DEM (filled) for --metrics.
    #[arg(long)]
    pub dem: Option<PathBuf>,
    /// Only basins with at least this many cells in --metrics.
    #[arg(long, default_value_t = 1)]
    pub min_cells: u64,
    /// Samples on the hypsometric curve in --metrics.
    #[arg(long, default_value_t = 21)]
    pub hyp_samples: usize,
    #[command(flatten)]
    pub geojson: crate::GeoJsonArg,
    #[command(flatten)]
    pub fmt: crate::OutFmt,
    #[command(flatten)]
    pub run: crate::Run,
}

/// Basin labels (and metrics) of the D8 directions.
pub fn run_basins(a: BasinsArgs) -> Result<()> {
    let cfg = crate::engine(&a.run)?;
    let dirs = orogen::io::open_raster(&a.dirs, &Default::default())?;
    let opts = BasinsOptions {
        points: a.points.clone(),
        snap: a.snap,
        acc: a.acc.clone(),
        metrics: a.metrics.clone(),
        dem: a.dem.clone(),
        min_cells: a.min_cells,
        hyp_samples: a.hyp_samples,
        geojson_crs: a.geojson.crs,
    };
    let t = Target {
        path: a.output.clone(),
        options: crate::output_options(&a.fmt)?,
        tile: a.run.tile,
    };
    let labels = basins::write_labels(dirs.as_ref(), &opts, &t, &cfg)?;
    if let Some(w) = labels.warning(&opts) {
        super::erode::printer(false)(orogen::ops::note::Note::Warning(w.to_string()));
    }
    crate::wrote(&a.output);
    for f in basins::write_metrics(dirs.as_ref(), &opts, &labels, &cfg)? {
        crate::wrote(&f);
    }
    Ok(())
}

// ----------------------------------------------------------- streams ----

#[derive(Args)]
#[command(
    after_help = "Examples:\n  orogen streams d8.tif -o streams.geojson --threshold 500 --raster order.tif --stats stats.json\n  orogen streams d8.tif -o streams.geojson --area 1e6 --csv links.csv --nodes nodes.geojson\n  orogen streams d8.tif --dem filled.tif --slope-area 200 -o streams.geojson\nRuns in memory (about 64 bytes per cell); --memory must allow it.\nThe links and --nodes GeoJSON are WGS 84 longitude/latitude (RFC 7946) unless\n--geojson-crs native; length_m and area_m2 are metres either way:\n  orogen streams d8_utm.tif -o streams.geojson --geojson-crs native"
)]
pub struct StreamsArgs {
    /// D8 flow directions (from `orogen flow`).
    pub dirs: PathBuf,
    /// Output GeoJSON of stream links (LineStrings with Strahler, Shreve, length, area, nodes).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Channel threshold in cells of drainage area (default 1000 unless --area/--slope-area).
    #[arg(long)]
    pub threshold: Option<f64>,
    /// Channel threshold as drainage area in m².
    #[arg(long)]
    pub area: Option<f64>,
    /// Channel initiation A·s² > C (Montgomery & Dietrich), A in m², s = D8 slope; needs --dem.
    #[arg(long)]
    pub slope_area: Option<f64>,
    /// Filled DEM (for --slope-area).
    #[arg(long)]
    pub dem: Option<PathBuf>,
    /// Also write the stream raster (Strahler order, 0 = no stream, 255 nodata).
    #[arg(long)]
    pub raster: Option<PathBuf>,
    /// Also write network statistics (Horton ratios, Tokunaga numbers, Mueller sinuosity) as JSON.
    #[arg(long)]
    pub stats: Option<PathBuf>,
    /// Also write one CSV row per link.
    #[arg(long)]
    pub csv: Option<PathBuf>,
    /// Also write the network's nodes (heads, confluences, outlets) as GeoJSON Points.
    #[arg(long)]
    pub nodes: Option<PathBuf>,
    /// Half window (cells) of the valley-line smoothing for Mueller's valley length.
    #[arg(long, default_value_t = 10)]
    pub valley_window: usize,
    #[command(flatten)]
    pub geojson: crate::GeoJsonArg,
    #[command(flatten)]
    pub fmt: crate::OutFmt,
    #[command(flatten)]
    pub run: crate::Run,
}

/// The stream network of the D8 directions.
pub fn run_streams(a: StreamsArgs) -> Result<()> {
    let cfg = crate::engine(&a.run)?;
    let opts = StreamsOptions {
        threshold: a.threshold,
        area: a.area,
        slope_area: a.slope_area,
        dem: a.dem.clone(),
        raster: a.raster.clone(),
        stats: a.stats.clone(),
        csv: a.csv.clone(),
        nodes: a.nodes.clone(),
        valley_window: a.valley_window,
        geojson_crs: a.geojson.crs,
    };
    // Checked before the directions are opened.
    opts.rule()?;
    let dirs = orogen::io::open_raster(&a.dirs, &Default::default())?;
    // The format options apply to the stream raster only.
    let options = match &a.raster {
        Some(_) => crate::output_options(&a.fmt)?,
        None => Default::default(),
    };
    let t = Target {
        path: a.output.clone(),
        options,
        tile: a.run.tile,
    };
    let net = streams::run(dirs.as_ref(), &opts, &t, &cfg)?;
    for w in &net.warnings {
        super::erode::printer(false)(orogen::ops::note::Note::Warning(w.clone()));
    }
    for f in &net.files {
        crate::wrote(f);
    }
    if !a.run.quiet {
        eprintln!(
            "{} links, {} nodes, highest Strahler order {}",
            net.links, net.nodes, net.max_order
        );
    }
    Ok(())
}

// --------------------------------------------------------- hydro-index ----

#[derive(Args)]
#[command(
    after_help = "Examples:\n  orogen hydro-index --index twi --dem filled.tif --acc acc.tif -o twi.tif\n  orogen hydro-index --index hand --dem filled.tif --dirs d8.tif --acc acc.tif --threshold 1000 -o hand.tif\n  orogen hydro-index --index dtw --dem filled.tif --streams order.tif --threshold 1 -o dtw.tif\n  orogen hydro-index --index branch-length --dirs d8.tif -o bmax.tif\nStreams are cells of --streams (default --acc) with a value >= --threshold."
)]
pub struct HydroIndexArgs {
    /// Index: twi, spi, sti, ls (tile by tile), hand (exact across tiles),
    /// dtw, branch-length (in memory).
    #[arg(long)]
    pub index: String,
    /// Filled DEM (twi, spi, sti, ls, hand, dtw).
    #[arg(long)]
    pub dem: Option<PathBuf>,
    /// D8 flow accumulation in cells (twi, spi, sti, ls; also the stream raster by default).
    #[arg(long)]
    pub acc: Option<PathBuf>,
    /// D8 flow directions (hand, branch-length).
    #[arg(long)]
    pub dirs: Option<PathBuf>,
    /// Raster defining streams as cells >= --threshold (hand, dtw); default: --acc.
    #[arg(long)]
    pub streams: Option<PathBuf>,
    /// Stream threshold on --streams (cells of accumulation, or 1 for a stream-order raster).
    #[arg(long, default_value_t = 1000.0)]
    pub threshold: f64,
    /// Smallest tan(slope) in TWI (keeps flats finite).
    #[arg(long, default_value_t = 1e-4)]
    pub min_slope: f64,
    #[command(flatten)]
    pub out: crate::Out,
    #[command(flatten)]
    pub run: crate::Run,
}

/// A hydrological index.
pub fn run_hydro_index(a: HydroIndexArgs) -> Result<()> {
    let cfg = crate::engine(&a.run)?;
    let opts = HydroIndexOptions {
        index: a.index.clone(),
        dem: a.dem.clone(),
        acc: a.acc.clone(),
        dirs: a.dirs.clone(),
        streams: a.streams.clone(),
        threshold: a.threshold,
        min_slope: a.min_slope,
    };
    let t = crate::target(&a.out, &a.run)?;
    hydro_index::run(&opts, &t, &cfg)?;
    crate::wrote(&a.out.output);
    Ok(())
}
