//! Opening any supported raster by path, and creating an output sink by the
//! output path's extension.

use super::memsink::WholeFileSink;
use crate::error::{Error, IoContext, Result};
use crate::io::geotiff::{GeoTiffReader, GeoTiffWriter, ReaderOptions, WriteOptions};
use crate::raster::{DType, GeoRef, RasterInfo, RasterSource};
use crate::store::sink::TileSink;
use crate::store::{Provenance, StoreOptions, StoreWriter, TileStore};
use std::io::Read;
use std::path::{Path, PathBuf};

/// How to interpret inputs that carry no elevation units of their own.
#[derive(Debug, Clone)]
pub struct OpenOptions {
    /// PNG heightmaps: elevation = offset + value * scale. Neither given:
    /// the mapping the file records (orogen's writes), else the samples.
    pub png_scale: Option<f64>,
    /// PNG heightmaps: elevation of value 0 (None with a scale: 0).
    pub png_offset: Option<f64>,
    /// The band read from a multi-band GeoTIFF (1-based); every other
    /// format has one band.
    pub band: usize,
    /// The input's nodata value, replacing the file's or assigning one
    /// ([`super::reassign`]).
    pub nodata: Option<f64>,
    /// Cells at or below this elevation are read as nodata: the sea becomes
    /// an outlet ([`super::reassign`]).
    pub sea_level: Option<f64>,
    /// A raster on the input's grid: where it is 0 or nodata the input is
    /// read as nodata ([`super::reassign`]).
    pub mask: Option<PathBuf>,
    /// Build a mosaic (several inputs, a folder, a `.vrt`) even when its
    /// sources leave more than [`MAX_EMPTY_FRACTION`](super::mosaic::MAX_EMPTY_FRACTION)
    /// of its extent uncovered (refused otherwise).
    pub allow_sparse: bool,
}

impl Default for OpenOptions {
    fn default() -> Self {
        OpenOptions {
            png_scale: None,
            png_offset: None,
            band: 1,
            nodata: None,
            sea_level: None,
            mask: None,
            allow_sparse: false,
        }
    }
}

/// The kinds of raster orogen reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    GeoTiff,
    Hgt,
    Ascii,
    Png,
    Store,
    Vrt,
}

impl Format {
    /// The format's name, as `info` reports it.
    pub fn name(self) -> &'static str {
        match self {
            Format::GeoTiff => "geotiff",
            Format::Hgt => "hgt",
            Format::Ascii => "ascii-grid",
            Format::Png => "png",
            Format::Store => "tile-store",
            Format::Vrt => "vrt",
        }
    }
}

/// Detect a file's format from its magic bytes, then its extension.
pub fn detect(path: &Path) -> Result<Format> {
    if path.is_dir() {
        if path.join("manifest.json").is_file() {
            return Ok(Format::Store);
        }
        return Err(Error::unsupported(
            path,
            "a directory that is not a tile store (no manifest.json); to mosaic the files in a folder, use `orogen ingest DIR -o OUT.tiles`",
        ));
    }
    let mut magic = [0u8; 512];
    let mut n = 0;
    {
        let mut f = std::fs::File::open(path).at(path)?;
        while n < magic.len() {
            let k = f.read(&mut magic[n..]).at(path)?;
            if k == 0 {
                break;
            }
            n += k;
        }
    }
    let m = &magic[..n];
    if m.starts_with(b"II*\0")
        || m.starts_with(b"MM\0*")
        || m.starts_with(b"II+\0")
        || m.starts_with(b"MM\0+")
    {
        return Ok(Format::GeoTiff);
    }
    if m.starts_with(b"\x89PNG\r\n\x1a\n") {
        return Ok(Format::Png);
    }
    if super::vrt::looks_like_vrt(m) {
        return Ok(Format::Vrt);
    }
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    match ext.as_str() {
        "hgt" => Ok(Format::Hgt),
        "asc" => Ok(Format::Ascii),
        "tif" | "tiff" => Err(Error::corrupt(path, "not a TIFF file (wrong magic bytes)")),
        "png" => Err(Error::corrupt(path, "not a PNG file (wrong signature)")),
        "vrt" => Err(Error::corrupt(
            path,
            "not a GDAL VRT (no <VRTDataset> element at the start)",
        )),
        _ => Err(Error::unsupported(
            path,
            "unknown raster format; orogen reads GeoTIFF (.tif), SRTM .hgt, ESRI ASCII (.asc), 16-bit PNG heightmaps, GDAL VRT mosaics (.vrt) and tile stores (.tiles)",
        )),
    }
}

/// Open one raster of any supported format.
pub fn open_raster(path: &Path, opts: &OpenOptions) -> Result<Box<dyn RasterSource>> {
    let format = detect(path)?;
    if opts.band != 1 && !matches!(format, Format::GeoTiff | Format::Vrt) {
        return Err(Error::invalid(format!(
            "{}: band {} asked for, the file has 1 band: choose --band 1",
            path.display(),
            opts.band
        )));
    }
    let mut scaling = None;
    let src: Box<dyn RasterSource> = match format {
        Format::GeoTiff => {
            let r = GeoTiffReader::open_with(
                path,
                &ReaderOptions {
                    band: opts.band,
                    ..Default::default()
                },
            )?;
            scaling = r.file_scaling();
            Box::new(r)
        }
        Format::Hgt => Box::new(super::hgt::read_hgt(path)?),
        Format::Ascii => Box::new(super::ascii::read_ascii(path)?),
        Format::Png => {
            let given = (opts.png_scale.is_some() || opts.png_offset.is_some()).then(|| {
                crate::raster::Scaling {
                    scale: opts.png_scale.unwrap_or(1.0),
                    offset: opts.png_offset.unwrap_or(0.0),
                }
            });
            Box::new(super::png::read_png(path, given)?)
        }
        Format::Store => Box::new(TileStore::open(path)?),
        Format::Vrt => {
            let v = super::vrt::Vrt::open(path, opts.band)?;
            let rects: Vec<_> = v.extents().into_iter().map(|(_, w)| w).collect();
            super::mosaic::check_sparse(
                &path.display().to_string(),
                v.info(),
                &rects,
                opts.allow_sparse,
            )?;
            Box::new(v)
        }
    };
    let mask = match &opts.mask {
        Some(m) => Some(open_raster(m, &OpenOptions::default())?),
        None => None,
    };
    match scaling.filter(|s| !s.is_identity()) {
        // The nodata value is the raw cells' (as GDAL compares it), the sea
        // level an elevation: reassign the one, scale, then mask the other.
        Some(s) => {
            let raw = super::reassign::reassign(src, opts.nodata, None, None)?;
            let scaled = super::scaling::unscale(raw, s);
            super::reassign::reassign(scaled, None, opts.sea_level, mask)
        }
        None => super::reassign::reassign(src, opts.nodata, opts.sea_level, mask),
    }
}

/// Open one input or a mosaic of several (directories expand to the rasters
/// they contain, sorted by name). A mosaic whose inputs leave more than
/// [`MAX_EMPTY_FRACTION`](super::mosaic::MAX_EMPTY_FRACTION) of its extent
/// uncovered is refused unless `opts.allow_sparse`.
pub fn open_inputs(paths: &[PathBuf], opts: &OpenOptions) -> Result<Box<dyn RasterSource>> {
    let files = super::mosaic::expand_inputs(paths)?;
    if files.is_empty() {
        return Err(Error::invalid(
            "no input rasters given (or the folder holds none)",
        ));
    }
    if files.len() == 1 {
        return open_raster(&files[0], opts);
    }
    let mut sources = Vec::with_capacity(files.len());
    for f in &files {
        sources.push(open_raster(f, opts)?);
    }
    let m = super::mosaic::Mosaic::new(sources)?;
    let rects: Vec<_> = m.extents().into_iter().map(|(_, w)| w).collect();
    let what = match paths {
        [one] => format!(
            "the mosaic of the {} files in {}",
            files.len(),
            one.display()
        ),
        _ => format!("the mosaic of {} files", files.len()),
    };
    super::mosaic::check_sparse(&what, m.info(), &rects, opts.allow_sparse)?;
    Ok(Box::new(m))
}

/// Output settings shared by all commands that write rasters.
#[derive(Debug, Clone, Default)]
pub struct OutputOptions {
    /// GeoTIFF options (compression, predictor, block, BigTIFF).
    pub tiff: WriteOptions,
    /// Tile-store options (tile size, zstd, overwrite).
    pub store: StoreOptions,
    /// Write `.tif` outputs as Cloud-Optimized GeoTIFFs with internal
    /// overviews made this way (None: plain tiled GeoTIFF).
    pub cog: Option<Overviews>,
    /// Outputs kept in memory instead of written (the paths they claim);
    /// `None`: every output is written.
    pub memory: Option<crate::store::sink::MemoryOutputs>,
    /// PNG heightmap outputs: metres per unit and elevation of 0 (None: from
    /// the data's range, [`crate::io::png::output_scaling`]).
    pub png_scale: Option<f64>,
    pub png_offset: Option<f64>,
}

/// How a Cloud-Optimized GeoTIFF's overviews are made.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Overviews {
    /// By the output's kind (the sink's provenance):
    /// [`Resampling::for_kind`](crate::io::geotiff::Resampling::for_kind).
    ByKind,
    /// This way whatever the output holds.
    Fixed(crate::io::geotiff::Resampling),
}

impl Overviews {
    /// The resampling for an output of `kind`.
    pub fn resampling(self, kind: crate::raster::OutputKind) -> crate::io::geotiff::Resampling {
        match self {
            Overviews::ByKind => crate::io::geotiff::Resampling::for_kind(kind),
            Overviews::Fixed(r) => r,
        }
    }
}

/// True if `path` names a tile store output (`*.tiles`).
pub fn is_store_path(path: &Path) -> bool {
    path.extension().and_then(|e| e.to_str()) == Some("tiles")
}

/// [`create_sink`] for an output of the width and height of the raster
/// `like` (an output computed cell by cell from that input).
pub fn create_sink_like(
    path: &Path,
    like: &RasterInfo,
    dtype: DType,
    georef: &GeoRef,
    oo: &OutputOptions,
    provenance: Provenance,
) -> Result<Box<dyn TileSink>> {
    create_sink(path, like.width, like.height, dtype, georef, oo, provenance)
}

/// Create the sink for an output path: `.tif`/`.tiff` GeoTIFF (streamed),
/// `.tiles` tile store (streamed, resumable), `.png` 16-bit heightmap or
/// `.asc` ESRI ASCII (assembled in memory, small rasters only); a path
/// claimed by `oo.memory` is kept in memory instead.
pub fn create_sink(
    path: &Path,
    width: usize,
    height: usize,
    dtype: DType,
    georef: &GeoRef,
    oo: &OutputOptions,
    provenance: Provenance,
) -> Result<Box<dyn TileSink>> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    if let Some(sink) = oo
        .memory
        .as_ref()
        .and_then(|m| m.sink(path, width, height, dtype, georef))
    {
        return Ok(sink);
    }
    if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
        if !parent.is_dir() {
            return Err(Error::invalid(format!(
                "{}: the output folder {} does not exist; create it first",
                path.display(),
                parent.display()
            )));
        }
    }
    if super::memsink::RemoteRankSink::applies() {
        let layout = (ext == "tiles")
            .then(|| crate::raster::TileLayout::new(width, height, oo.store.tile.max(1)));
        // The nodata the real sink would report (a store records NaN as none),
        // since tiles are converted to the sinks' types before they travel.
        let nodata = match ext.as_str() {
            "tiles" => georef.nodata.filter(|v| !v.is_nan()),
            _ => georef.nodata,
        };
        return Ok(Box::new(super::memsink::RemoteRankSink::new(
            dtype, nodata, layout,
        )));
    }
    // Formats written whole at the end (the raster held in memory).
    type Finisher = Box<dyn FnOnce(crate::raster::AnyGrid, &GeoRef) -> Result<()> + Send>;
    let whole = |finisher: Finisher| -> Result<Box<dyn TileSink>> {
        Ok(Box::new(WholeFileSink::new(
            width,
            height,
            dtype,
            georef.clone(),
            finisher,
        )?))
    };
    let p = path.to_path_buf();
    Ok(match ext.as_str() {
        "tif" | "tiff" => match oo.cog {
            Some(o) => Box::new(crate::io::geotiff::CogWriter::create(
                path,
                width,
                height,
                dtype,
                georef,
                &oo.tiff,
                o.resampling(provenance.kind),
            )?),
            None => Box::new(GeoTiffWriter::create(
                path, width, height, dtype, georef, &oo.tiff,
            )?),
        },
        "tiles" => Box::new(StoreWriter::create(
            path,
            width,
            height,
            dtype,
            georef,
            oo.store,
            provenance,
        )?),
        "png" => {
            let (scale, offset) = (oo.png_scale, oo.png_offset);
            whole(Box::new(move |g, geo| {
                let g = g.to_typed::<f32>(geo.nodata);
                let m = crate::io::png::output_scaling(&g, scale, offset);
                crate::io::png::write_png16_mapped(&p, &g, m)
            }))?
        }
        "asc" => whole(Box::new(move |g, geo| {
            crate::io::ascii::write_ascii(&p, &g, geo)
        }))?,
        _ => {
            return Err(Error::unsupported(
                path,
                "unknown output format; use .tif (GeoTIFF), .tiles (tile store), .png (16-bit heightmap) or .asc (ESRI ASCII)",
            ))
        }
    })
}
