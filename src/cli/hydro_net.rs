//! `orogen basins`, `orogen streams` and `orogen hydro-index`: basins and
//! watersheds, stream networks and their statistics, hydrological indices.

use anyhow::{bail, Result};
use clap::Args;
use orogen::exec::EngineConfig;
use orogen::hydro::basins::{self, Seeds, TiledDownstream};
use orogen::hydro::{basin_metrics, indices, streams, NODATA_DIR, NO_FLOW};
use orogen::io::{self, OpenOptions};
use orogen::raster::{read_window, DType, GeoRef, Grid, MemRaster, RasterSource, Window};
use std::path::{Path, PathBuf};

fn open_path(p: &Path) -> Result<Box<dyn RasterSource>> {
    Ok(io::open_raster(p, &OpenOptions::default())?)
}

/// Refuse an in-memory step whose working set exceeds `--memory`.
fn guard(src: &dyn RasterSource, per_cell: u64, what: &str, cfg: &EngineConfig) -> Result<()> {
    let info = src.info();
    let need = (info.width as u64) * (info.height as u64) * per_cell;
    if need > cfg.memory_budget {
        bail!(
            "{}: {what} runs in memory and needs about {:.2} GiB for {}x{} cells; raise --memory (e.g. --memory {}GiB)",
            info.path.display(),
            need as f64 / (1u64 << 30) as f64,
            info.width,
            info.height,
            need.div_ceil(1 << 30)
        );
    }
    Ok(())
}

fn full(src: &dyn RasterSource) -> Window {
    let i = src.info();
    Window::full(i.width, i.height)
}

/// Read D8 directions (any numeric type; NaN/nodata/255 -> 255), checking codes.
fn read_dirs(src: &dyn RasterSource) -> Result<Grid<u8>> {
    let g = read_window::<f64>(src, full(src))?;
    let w = g.width();
    let mut out = Vec::with_capacity(g.len());
    for (i, &v) in g.data().iter().enumerate() {
        let c = if v.is_nan() || v == NODATA_DIR as f64 {
            NODATA_DIR
        } else if (0.0..=128.0).contains(&v) && v.fract() == 0.0 {
            let c = v as u8;
            if c != NO_FLOW && orogen::hydro::code_to_dir(c).is_none() {
                bail!(
                    "{}: value {v} at cell ({}, {}) is not a D8 code; give directions from `orogen flow`",
                    src.info().path.display(),
                    i % w,
                    i / w
                );
            }
            c
        } else {
            bail!(
                "{}: value {v} at cell ({}, {}) is not a D8 code; give directions from `orogen flow`",
                src.info().path.display(),
                i % w,
                i / w
            );
        };
        out.push(c);
    }
    Ok(Grid::from_vec(g.width(), g.height(), out)?)
}

fn same_size(a: &dyn RasterSource, b: &dyn RasterSource) -> Result<()> {
    let (ia, ib) = (a.info(), b.info());
    if (ia.width, ia.height) != (ib.width, ib.height) {
        bail!(
            "{} is {}x{} but {} is {}x{}: the rasters must have the same size",
            ib.path.display(),
            ib.width,
            ib.height,
            ia.path.display(),
            ia.width,
            ia.height
        );
    }
    Ok(())
}

// ------------------------------------------------------------ basins ----

#[derive(Args)]
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
    pub fmt: crate::OutFmt,
    #[command(flatten)]
    pub run: crate::Run,
}

pub fn run_basins(a: BasinsArgs) -> Result<()> {
    let cfg = crate::engine(&a.run)?;
    let dirs = open_path(&a.dirs)?;
    let info = dirs.info().clone();
    let mut cells = None;
    let seeds = match &a.points {
        None => Seeds::Outlets,
        Some(p) => {
            let pts = basins::read_points(p)?;
            let acc = match &a.acc {
                Some(ap) => {
                    let s = open_path(ap)?;
                    same_size(dirs.as_ref(), s.as_ref())?;
                    Some(s)
                }
                None => None,
            };
            if a.snap > 0 && acc.is_none() {
                bail!("--snap needs the flow accumulation: add --acc acc.tif");
            }
            let c = basins::locate_points(dirs.as_ref(), &pts, acc.as_deref(), a.snap)?;
            let s = basins::point_seeds(&c, info.width);
            cells = Some(c);
            s
        }
    };
    let n = (info.width as u64) * (info.height as u64);
    let ty = if n < u32::MAX as u64 {
        (DType::U32, Some(0.0))
    } else {
        (DType::F64, Some(0.0))
    };
    let step = TiledDownstream { seeds };
    let out = crate::Out {
        output: a.output.clone(),
        fmt: a.fmt.clone(),
    };
    crate::global1(&step, &[dirs.as_ref()], &out, &a.run, ty)?;
    if let Some(mp) = &a.metrics {
        let Some(dp) = &a.dem else {
            bail!("--metrics needs the DEM: add --dem filled.tif");
        };
        let dem = open_path(dp)?;
        same_size(dirs.as_ref(), dem.as_ref())?;
        guard(
            dirs.as_ref(),
            basin_metrics::BASIN_METRICS_BYTES_PER_CELL,
            "basin metrics",
            &cfg,
        )?;
        let d = read_dirs(dirs.as_ref())?;
        let labels: Grid<u64> = match &cells {
            None => orogen::hydro::basin_labels(&d)?,
            Some(c) => {
                let g = orogen::hydro::watersheds(&d, c)?;
                g.map(|v| v as u64)
            }
        };
        let z = read_window::<f32>(dem.as_ref(), full(dem.as_ref()))?;
        let m = basin_metrics::basin_metrics(
            &labels,
            &z,
            &d,
            &info.georef,
            a.hyp_samples,
            a.min_cells,
        )?;
        basin_metrics::write_csv(mp, &info.georef, &m)?;
        crate::wrote(mp);
        let gj = mp.with_extension("geojson");
        let outlines = basin_metrics::basin_outlines(&labels)?;
        basin_metrics::write_geojson(&gj, &info.georef, &m, Some(&outlines))?;
        crate::wrote(&gj);
    }
    Ok(())
}

// ----------------------------------------------------------- streams ----

#[derive(Args)]
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
    pub fmt: crate::OutFmt,
    #[command(flatten)]
    pub run: crate::Run,
}

pub fn run_streams(a: StreamsArgs) -> Result<()> {
    let cfg = crate::engine(&a.run)?;
    let given = [a.threshold, a.area, a.slope_area]
        .iter()
        .filter(|v| v.is_some())
        .count();
    if given > 1 {
        bail!("give only one of --threshold, --area, --slope-area");
    }
    let rule = if let Some(t) = a.area {
        streams::ChannelRule::Area(t)
    } else if let Some(c) = a.slope_area {
        streams::ChannelRule::SlopeArea(c)
    } else {
        streams::ChannelRule::Cells(a.threshold.unwrap_or(1000.0))
    };
    let t = match rule {
        streams::ChannelRule::Cells(t)
        | streams::ChannelRule::Area(t)
        | streams::ChannelRule::SlopeArea(t) => t,
    };
    if !t_ok(t) {
        bail!("the channel threshold must be a positive number, not {t}");
    }
    let dirs = open_path(&a.dirs)?;
    guard(
        dirs.as_ref(),
        streams::NETWORK_BYTES_PER_CELL,
        "stream network extraction",
        &cfg,
    )?;
    let info = dirs.info().clone();
    let d = read_dirs(dirs.as_ref())?;
    let dem = match &a.dem {
        Some(p) => {
            let s = open_path(p)?;
            same_size(dirs.as_ref(), s.as_ref())?;
            Some(read_window::<f32>(s.as_ref(), full(s.as_ref()))?)
        }
        None => None,
    };
    if matches!(rule, streams::ChannelRule::SlopeArea(_)) && dem.is_none() {
        bail!("--slope-area needs the filled DEM: add --dem filled.tif");
    }
    let net = streams::extract_network(
        &d,
        dem.as_ref(),
        &info.georef,
        &streams::NetworkOptions {
            rule,
            valley_window: a.valley_window,
        },
    )?;
    net.write_geojson(&a.output)?;
    crate::wrote(&a.output);
    if let Some(p) = &a.csv {
        net.write_links_csv(p)?;
        crate::wrote(p);
    }
    if let Some(p) = &a.nodes {
        net.write_nodes_geojson(p)?;
        crate::wrote(p);
    }
    if let Some(p) = &a.stats {
        let s = serde_json::to_string_pretty(&net.stats_json())?;
        orogen::io::atomic::write_file_atomic(p, s.as_bytes())?;
        crate::wrote(p);
    }
    if let Some(p) = &a.raster {
        let mem = MemRaster::from_grid(net.order.clone(), info.georef.clone());
        write_mem(
            mem,
            p,
            &a.fmt,
            &a.run,
            &cfg,
            (DType::U8, Some(NODATA_DIR as f64)),
        )?;
    }
    if !a.run.quiet {
        eprintln!(
            "{} links, {} nodes, highest Strahler order {}",
            net.links.len(),
            net.nodes.len(),
            net.links.iter().map(|l| l.strahler).max().unwrap_or(0)
        );
    }
    Ok(())
}

fn t_ok(t: f64) -> bool {
    t.is_finite() && t > 0.0
}

/// Write an in-memory raster (already in its output type) to `p`.
fn write_mem(
    mem: MemRaster,
    p: &Path,
    fmt: &crate::OutFmt,
    run: &crate::Run,
    cfg: &EngineConfig,
    ty: (DType, Option<f64>),
) -> Result<()> {
    let mem = MemRaster::new(
        mem.grid().clone(),
        mem.info().georef.clone().with_nodata(ty.1),
        mem.info().path.clone(),
    );
    let oo = crate::output_options(fmt)?;
    orogen::ops::convert(&mem, p, &oo, run.tile, cfg)?;
    crate::wrote(p);
    Ok(())
}

// --------------------------------------------------------- hydro-index ----

#[derive(Args)]
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

fn need(p: &Option<PathBuf>, flag: &str, index: &str) -> Result<Box<dyn RasterSource>> {
    match p {
        Some(p) => open_path(p),
        None => bail!("--index {index} needs {flag}"),
    }
}

pub fn run_hydro_index(a: HydroIndexArgs) -> Result<()> {
    use indices::IndexKind;
    let cfg = crate::engine(&a.run)?;
    let f32_out = (DType::F32, Some(-9999.0));
    let local = match a.index.as_str() {
        "twi" => Some(IndexKind::Twi),
        "spi" => Some(IndexKind::Spi),
        "sti" => Some(IndexKind::Sti),
        "ls" => Some(IndexKind::Ls),
        "hand" | "dtw" | "branch-length" => None,
        i => bail!("--index {i:?}: use twi, spi, sti, ls, hand, dtw or branch-length"),
    };
    if !(a.threshold.is_finite()) {
        bail!("--threshold must be a number");
    }
    if let Some(kind) = local {
        if !(a.min_slope.is_finite() && a.min_slope > 0.0) {
            bail!("--min-slope must be a positive number");
        }
        let dem = need(&a.dem, "--dem", &a.index)?;
        let acc = need(&a.acc, "--acc", &a.index)?;
        same_size(dem.as_ref(), acc.as_ref())?;
        let step = indices::HydroIndex {
            kind,
            min_slope: a.min_slope,
        };
        let oo = crate::output_options(&a.out.fmt)?;
        orogen::ops::run_local_to_paths(
            &step,
            &[dem.as_ref(), acc.as_ref()],
            std::slice::from_ref(&a.out.output),
            &[f32_out],
            &oo,
            a.run.tile,
            &cfg,
        )?;
        crate::wrote(&a.out.output);
        return Ok(());
    }
    let streams_path = a.streams.clone().or_else(|| a.acc.clone());
    match a.index.as_str() {
        "hand" => {
            let dirs = need(&a.dirs, "--dirs", "hand")?;
            let dem = need(&a.dem, "--dem", "hand")?;
            let st = need(&streams_path, "--streams or --acc", "hand")?;
            same_size(dirs.as_ref(), dem.as_ref())?;
            same_size(dirs.as_ref(), st.as_ref())?;
            let step = TiledDownstream {
                seeds: Seeds::Streams {
                    threshold: a.threshold,
                },
            };
            crate::global1(
                &step,
                &[dirs.as_ref(), dem.as_ref(), st.as_ref()],
                &a.out,
                &a.run,
                f32_out,
            )?;
        }
        "dtw" => {
            let dem = need(&a.dem, "--dem", "dtw")?;
            let st = need(&streams_path, "--streams or --acc", "dtw")?;
            same_size(dem.as_ref(), st.as_ref())?;
            guard(
                dem.as_ref(),
                indices::DTW_BYTES_PER_CELL,
                "depth to water",
                &cfg,
            )?;
            let z = read_window::<f32>(dem.as_ref(), full(dem.as_ref()))?;
            let s = read_window::<f64>(st.as_ref(), full(st.as_ref()))?;
            let mask = s.map(|v| v >= a.threshold);
            let georef = dem.info().georef.clone();
            let g = indices::depth_to_water(&z, &mask, &georef)?;
            write_f32(g, georef, &a, &cfg)?;
        }
        _ => {
            let dirs = need(&a.dirs, "--dirs", "branch-length")?;
            guard(
                dirs.as_ref(),
                indices::BRANCH_BYTES_PER_CELL,
                "branch length",
                &cfg,
            )?;
            let d = read_dirs(dirs.as_ref())?;
            let georef = dirs.info().georef.clone();
            let g = indices::max_branch_length(&d, &georef)?;
            write_f32(g, georef, &a, &cfg)?;
        }
    }
    Ok(())
}

fn write_f32(g: Grid<f32>, georef: GeoRef, a: &HydroIndexArgs, cfg: &EngineConfig) -> Result<()> {
    let g = g.map(|v| if v.is_nan() { -9999.0 } else { v });
    let mem = MemRaster::from_grid(g, georef);
    write_mem(
        mem,
        &a.out.output,
        &a.out.fmt,
        &a.run,
        cfg,
        (DType::F32, Some(-9999.0)),
    )
}
