//! Arguments and helpers every subcommand shares: the run settings (`Run`:
//! threads, memory, tile, quiet, engine), the output path and format (`Out`,
//! `OutFmt`), the input (`In`, `InputArgs`), and their conversion into the
//! library's `EngineConfig`, `OutputOptions` and `ops::Target`. `main.rs`
//! re-exports them at the crate root (`crate::Run`, `crate::engine`, ...).

use anyhow::Result;
use clap::{Args, ValueEnum};
use orogen::exec::EngineConfig;
use orogen::io::{OpenOptions, OutputOptions};
use orogen::ops::parse::{self, FormatOptions, InputOptions, RunOptions};
use orogen::raster::RasterSource;
use std::path::{Path, PathBuf};

#[derive(Args, Clone)]
pub(crate) struct Run {
    /// Worker threads (0 = all cores; more than the cores are clamped to them: the
    /// results are the same for any count).
    #[arg(long, default_value_t = 0, global = true)]
    pub(crate) threads: usize,
    /// Memory budget for tiles in flight, e.g. 512MiB, 2GiB.
    #[arg(long, default_value = "1GiB", global = true)]
    pub(crate) memory: String,
    /// Work-tile size in cells (default: the input store's, else 1024).
    #[arg(long, global = true)]
    pub(crate) tile: Option<usize>,
    /// No progress bar.
    #[arg(long, short, global = true)]
    pub(crate) quiet: bool,
    /// Engine: `local` (this process's threads) or `mpi` (the ranks of
    /// `mpirun -n N orogen ...`; needs a build with `--features mpi`).
    #[arg(long, value_enum, global = true)]
    pub(crate) engine: Option<EngineArg>,
}

/// `--engine` values (see `orogen::exec::EngineKind`).
#[derive(Copy, Clone, ValueEnum)]
pub(crate) enum EngineArg {
    Local,
    Mpi,
}

impl EngineArg {
    /// The library's engine kind.
    pub(crate) fn kind(self) -> orogen::exec::EngineKind {
        match self {
            EngineArg::Local => orogen::exec::EngineKind::Local,
            EngineArg::Mpi => orogen::exec::EngineKind::Mpi,
        }
    }
}

#[derive(Args, Clone)]
pub(crate) struct Out {
    /// Output: .tif (GeoTIFF), .tiles (tile store), .png (16-bit), .asc.
    #[arg(short, long)]
    pub(crate) output: PathBuf,
    #[command(flatten)]
    pub(crate) fmt: OutFmt,
}

/// Output format options (GeoTIFF and tile-store settings).
#[derive(Args, Clone)]
pub(crate) struct OutFmt {
    /// GeoTIFF compression.
    #[arg(long, value_enum, default_value_t = Compress::Deflate)]
    pub(crate) compress: Compress,
    /// GeoTIFF predictor (1 none, 2 horizontal, 3 floating point; default: automatic).
    #[arg(long)]
    pub(crate) predictor: Option<u16>,
    /// GeoTIFF block (tile) size.
    #[arg(long, default_value_t = 256)]
    pub(crate) block: usize,
    /// BigTIFF: yes, no or auto (auto: when the file could pass 4 GiB).
    #[arg(long, default_value = "auto")]
    pub(crate) bigtiff: String,
    /// Tile-store tile size (for .tiles outputs).
    #[arg(long, default_value_t = 1024)]
    pub(crate) store_tile: usize,
    /// Compress tile-store tiles with zstd.
    #[arg(long)]
    pub(crate) zstd: bool,
    /// Replace an existing output tile store instead of resuming it.
    #[arg(long)]
    pub(crate) overwrite: bool,
    /// Write .tif outputs as Cloud-Optimized GeoTIFFs (internal overviews).
    #[arg(long)]
    pub(crate) cog: bool,
    /// COG overview resampling: auto (nearest for classes, codes and angles,
    /// average otherwise), average or nearest.
    #[arg(long, default_value = "auto")]
    pub(crate) overviews: String,
    /// PNG heightmap output: metres per PNG unit (default: the data's range
    /// over 0..65535). Recorded in the file and a .aux.xml sidecar.
    #[arg(long, value_name = "M")]
    pub(crate) png_out_scale: Option<f64>,
    /// PNG heightmap output: elevation of PNG value 0 (default: the data's minimum).
    #[arg(long, value_name = "Z", allow_negative_numbers = true)]
    pub(crate) png_out_offset: Option<f64>,
}

/// A value parser for a library enum (clap derives no parser for a
/// library type): the values `all`, each named on the command line by
/// `name` and, with `about`, described in `--help`.
pub(crate) fn enum_parser<T: Copy + Send + Sync + 'static>(
    all: &'static [T],
    name: fn(T) -> &'static str,
    about: Option<fn(T) -> &'static str>,
) -> impl clap::builder::TypedValueParser<Value = T> {
    use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
    let values = all.iter().map(move |&v| {
        let p = PossibleValue::new(name(v));
        match about {
            Some(about) => p.help(about(v)),
            None => p,
        }
    });
    PossibleValuesParser::new(values).map(move |given| {
        *all.iter()
            .find(|&&v| name(v) == given)
            .expect("a possible value is a value's name")
    })
}

/// One raster in, one raster out: the input, the output and the run
/// settings of `fill`, `fill-epsilon`, `watersheds`, `export`, `slope`,
/// `aspect` and `hillshade`.
#[derive(Args, Clone)]
pub(crate) struct InOut {
    #[command(flatten)]
    pub(crate) input: In,
    #[command(flatten)]
    pub(crate) out: Out,
    #[command(flatten)]
    pub(crate) run: Run,
}

/// Run `op`, an operation of one raster with options `opts`, from `io`'s
/// input into its output with its run settings, then say what was written.
pub(crate) fn run_one<O>(
    io: &InOut,
    opts: &O,
    op: impl FnOnce(&dyn RasterSource, &O, &orogen::ops::Target, &EngineConfig) -> orogen::Result<()>,
) -> Result<()> {
    let InOut { input, out, run } = io;
    let src = open(input)?;
    let t = target(out, run)?;
    op(src.as_ref(), opts, &t, &engine(run)?)?;
    wrote(&out.output);
    Ok(())
}

#[derive(Args, Clone)]
pub(crate) struct In {
    /// Input raster: GeoTIFF, .hgt, .asc, PNG heightmap, GDAL .vrt mosaic or tile store.
    pub(crate) input: PathBuf,
    #[command(flatten)]
    pub(crate) reading: InputArgs,
}

#[derive(Args, Clone)]
pub(crate) struct InputArgs {
    /// Band of a multi-band GeoTIFF to read (1-based; a note names it when
    /// the file has several).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u16).range(1..))]
    pub(crate) band: u16,
    /// PNG heightmap input: metres per PNG unit (default: the mapping the
    /// file records, as orogen writes it, else 1).
    #[arg(long, allow_negative_numbers = true)]
    pub(crate) png_scale: Option<f64>,
    /// PNG heightmap input: elevation of PNG value 0 (default: the recorded
    /// one, else 0).
    #[arg(long, allow_negative_numbers = true)]
    pub(crate) png_offset: Option<f64>,
    /// The input's nodata value: replaces the file's (cells of the old value
    /// become data, as GDAL's -a_nodata) or assigns one to a file without
    /// it (`nan` for NaN).
    #[arg(long, value_name = "V", allow_negative_numbers = true)]
    pub(crate) nodata: Option<f64>,
    /// Read every cell at or below Z (m) as nodata, so the sea is an outlet
    /// that drains the land instead of a flat the flow crosses (SRTM's sea
    /// is 0). Integer rasters need a nodata value (the file's or --nodata).
    #[arg(long, value_name = "Z", allow_negative_numbers = true)]
    pub(crate) sea_level: Option<f64>,
    /// A raster on the input's grid (e.g. a land mask): where it is 0 or
    /// nodata the input is read as nodata, an outlet.
    #[arg(long, value_name = "FILE")]
    pub(crate) mask: Option<PathBuf>,
    /// Build a mosaic (several inputs, a folder, a GDAL .vrt) even when its
    /// files cover less than half of its extent; without it such a mosaic,
    /// mostly nodata, is refused.
    #[arg(long)]
    pub(crate) allow_sparse: bool,
}

impl InputArgs {
    pub(crate) fn open_options(&self) -> OpenOptions {
        InputOptions {
            band: self.band as usize,
            png_scale: self.png_scale,
            png_offset: self.png_offset,
            nodata: self.nodata,
            sea_level: self.sea_level,
            mask: self.mask.clone(),
            allow_sparse: self.allow_sparse,
        }
        .open_options()
    }
}

#[derive(Copy, Clone, ValueEnum)]
pub(crate) enum Compress {
    None,
    Deflate,
    Lzw,
    Zstd,
}

impl Run {
    /// The library's run settings (parsed by `orogen::ops::parse`).
    pub(crate) fn options(&self) -> RunOptions {
        RunOptions {
            threads: self.threads,
            memory: self.memory.clone(),
            tile: self.tile,
            quiet: self.quiet,
            engine: self.engine.map(EngineArg::kind),
            observer: None,
        }
    }
}

pub(crate) fn engine(run: &Run) -> Result<EngineConfig> {
    use std::io::IsTerminal;
    set_quiet(run.quiet);
    Ok(run
        .options()
        .engine_config(std::io::stderr().is_terminal())?)
}

impl OutFmt {
    /// The library's format settings (checked by `orogen::ops::parse`).
    pub(crate) fn options(&self) -> FormatOptions {
        FormatOptions {
            compress: match self.compress {
                Compress::None => parse::Compress::None,
                Compress::Deflate => parse::Compress::Deflate,
                Compress::Lzw => parse::Compress::Lzw,
                Compress::Zstd => parse::Compress::Zstd,
            },
            predictor: self.predictor,
            block: self.block,
            bigtiff: self.bigtiff.clone(),
            store_tile: self.store_tile,
            zstd: self.zstd,
            overwrite: self.overwrite,
            cog: self.cog,
            overviews: self.overviews.clone(),
            png_out_scale: self.png_out_scale,
            png_out_offset: self.png_out_offset,
        }
    }
}

/// `option`'s distance (`orogen::ops::parse::distance`), the error naming it.
pub(crate) fn distance(option: &str, s: &str) -> Result<f64> {
    parse::distance(s).map_err(|e| anyhow::anyhow!("{option} {e}"))
}

pub(crate) fn output_options(o: &OutFmt) -> Result<OutputOptions> {
    Ok(o.options().output_options()?)
}

pub(crate) fn open(i: &In) -> Result<Box<dyn RasterSource>> {
    let notify = &mut super::erode::printer(false);
    Ok(orogen::ops::note::open_input(
        &i.input,
        &i.reading.open_options(),
        notify,
    )?)
}

/// The library's warning when `src` has no georeferencing, on stderr.
pub(crate) fn warn_georef(src: &dyn RasterSource) {
    orogen::ops::note::warn_georef(src, &mut super::erode::printer(false));
}

static QUIET: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// `wrote PATH` lines off (`--quiet`) or on.
pub(crate) fn set_quiet(quiet: bool) {
    QUIET.store(quiet, std::sync::atomic::Ordering::Relaxed);
}

pub(crate) fn wrote(p: &Path) {
    if !QUIET.load(std::sync::atomic::Ordering::Relaxed) {
        eprintln!("wrote {}", p.display());
    }
}

/// The library's output target for `out` with the run's work-tile size.
pub(crate) fn target(out: &Out, run: &Run) -> Result<orogen::ops::Target> {
    Ok(orogen::ops::Target {
        path: out.output.clone(),
        options: output_options(&out.fmt)?,
        tile: run.tile,
    })
}

/// `--geojson-crs` of every command writing GeoJSON (`peaks`, `ridges`,
/// `streams`, `basins --metrics`); the rules are `orogen::io::geojson`'s.
#[derive(Args, Clone)]
pub(crate) struct GeoJsonArg {
    /// Coordinates of the GeoJSON outputs. wgs84 (default): longitude/latitude
    /// as RFC 7946 requires, projected from a geographic, UTM (EPSG:326zz,
    /// 327zz, 258zz) or Web Mercator (EPSG:3857) raster; any other EPSG code is
    /// an error (nothing is written); a raster without a CRS is written in its
    /// own coordinates with a warning. native: the raster's coordinates, with a
    /// "crs" member naming its EPSG code (GDAL places it). Properties (lengths,
    /// areas) are metres either way.
    #[arg(long = "geojson-crs", value_name = "wgs84|native", default_value = "wgs84", value_parser = geojson_crs_arg)]
    pub(crate) crs: parse::GeoJsonCrs,
}

fn geojson_crs_arg(s: &str) -> std::result::Result<parse::GeoJsonCrs, String> {
    parse::geojson_crs(s).map_err(|e| e.to_string())
}
