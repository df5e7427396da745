//! Arguments and helpers every subcommand shares: the run settings (`Run`:
//! threads, memory, tile, quiet, engine), the output path and format (`Out`,
//! `OutFmt`), the input (`In`, `PngArgs`), and their conversion into the
//! library's `EngineConfig`, `OutputOptions` and `ops::Target`. `main.rs`
//! re-exports them at the crate root (`crate::Run`, `crate::engine`, ...).

use anyhow::{bail, Context, Result};
use clap::{Args, ValueEnum};
use orogen::exec::EngineConfig;
use orogen::io::geotiff::{Compression, WriteOptions};
use orogen::io::{self, OpenOptions, OutputOptions};
use orogen::raster::RasterSource;
use std::path::{Path, PathBuf};

#[derive(Args, Clone)]
pub(crate) struct Run {
    /// Worker threads (0 = all cores).
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
    /// COG overview resampling: average (continuous data) or nearest (classes, codes).
    #[arg(long, default_value = "average")]
    pub(crate) overviews: String,
}

#[derive(Args, Clone)]
pub(crate) struct In {
    /// Input raster: GeoTIFF, .hgt, .asc, PNG heightmap or tile store.
    pub(crate) input: PathBuf,
    #[command(flatten)]
    pub(crate) png: PngArgs,
}

#[derive(Args, Clone)]
pub(crate) struct PngArgs {
    /// PNG heightmaps: metres per PNG unit.
    #[arg(long, default_value_t = 1.0)]
    pub(crate) png_scale: f64,
    /// PNG heightmaps: elevation of PNG value 0.
    #[arg(long, default_value_t = 0.0)]
    pub(crate) png_offset: f64,
}

impl PngArgs {
    pub(crate) fn open_options(&self) -> OpenOptions {
        OpenOptions {
            png_scale: self.png_scale,
            png_offset: self.png_offset,
        }
    }
}

#[derive(Copy, Clone, ValueEnum)]
pub(crate) enum Compress {
    None,
    Deflate,
    Lzw,
    Zstd,
}

pub(crate) fn parse_bytes(s: &str) -> Result<u64> {
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

pub(crate) fn engine(run: &Run) -> Result<EngineConfig> {
    use std::io::IsTerminal;
    QUIET.store(run.quiet, std::sync::atomic::Ordering::Relaxed);
    if let Some(e) = run.engine {
        e.select()?;
    }
    Ok(EngineConfig {
        threads: run.threads,
        memory_budget: parse_bytes(&run.memory)?,
        progress: !run.quiet && std::io::stderr().is_terminal(),
        engine: orogen::exec::EngineKind::current(),
    })
}

pub(crate) fn output_options(o: &OutFmt) -> Result<OutputOptions> {
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

pub(crate) fn open(i: &In) -> Result<Box<dyn RasterSource>> {
    let src = io::open_raster(&i.input, &i.png.open_options())?;
    warn_georef(src.as_ref());
    Ok(src)
}

pub(crate) fn warn_georef(src: &dyn RasterSource) {
    let info = src.info();
    if !info.georef.georeferenced {
        eprintln!(
            "warning: {} has no georeferencing; using pixel coordinates with 1 x 1 cells (slopes assume cells of 1 elevation unit)",
            info.path.display()
        );
    }
}

static QUIET: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

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
