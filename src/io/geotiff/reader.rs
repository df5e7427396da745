//! Streaming GeoTIFF reader on top of the `tiff` crate's chunk API.
//!
//! Opening reads only the header, the first IFD and its tags. A window read
//! decodes just the strips or tiles it intersects (`Decoder::read_chunk_bytes`),
//! in parallel when there are several, through a pool of decoders (one
//! `Decoder<BufReader<File>>` per concurrent user, created on demand) and a
//! byte-bounded LRU cache of decoded blocks.
//!
//! Multi-band files: one band is read (`ReaderOptions::band`, 1-based,
//! default 1), from pixel-interleaved (PlanarConfiguration 1) and
//! band-interleaved (planar, 2) files alike; [`RasterSource::band`] tells
//! which band of how many was read. Samples are read as stored, whatever the
//! photometric interpretation (WhiteIsZero, RGB, palette, CMYK: see
//! `photometric.rs`), as GDAL reads them.
//!
//! Known difference from GDAL: an *uncompressed* file carrying a Predictor
//! tag is un-predicted by the `tiff` crate, while libtiff (GDAL) ignores the
//! predictor without compression. No common writer produces such files
//! (orogen's writer never does).

use super::cache::BlockCache;
use super::georef::{
    crs_from_keys, half_cell_shift, parse_nodata, raster_type_from_keys, transform_from_matrix,
    transform_from_scale_tiepoint,
};
use super::mask::{self, MaskSource};
use super::photometric::{self, ifd_heads, IfdHead, SampleFile, View};
use super::SUPPORTED_COMPRESSION;
use crate::error::{Error, IoContext, Result};
use crate::raster::{
    AnyGrid, Crs, DType, GeoKeys, GeoRef, RasterInfo, RasterSource, RasterType, Window,
};
use rayon::prelude::*;
use std::fs::File;
use std::io::BufReader;
use std::path::Path;
use std::sync::{Arc, Mutex};
use tiff::decoder::{ChunkType, Decoder, DecodingResult, Limits};
use tiff::tags::Tag;
use tiff::TiffError;

/// Largest raster orogen accepts (cells): 2^40, about 10^12.
const MAX_CELLS: u64 = 1 << 40;

type Dec = Decoder<BufReader<SampleFile>>;

/// Reader settings.
#[derive(Debug, Clone)]
pub struct ReaderOptions {
    /// Bytes of decoded blocks kept in the LRU cache (0 = no cache).
    pub cache_bytes: usize,
    /// Largest decoded strip or tile accepted, in bytes (larger ones: TooLarge).
    pub max_block_bytes: usize,
    /// The band read from a multi-band file (1-based).
    pub band: usize,
}

impl Default for ReaderOptions {
    fn default() -> Self {
        ReaderOptions {
            cache_bytes: 64 << 20,
            max_block_bytes: 1 << 30,
            band: 1,
        }
    }
}

/// A GeoTIFF opened for streaming window reads (see the module doc).
pub struct GeoTiffReader {
    info: RasterInfo,
    tiled: bool,
    /// Nominal block size (tile, or image width x rows per strip).
    chunk_w: usize,
    chunk_h: usize,
    /// Blocks per row of blocks.
    across: usize,
    /// Samples per pixel in one decoded block: all the bands of a
    /// pixel-interleaved file, 1 for a band-interleaved one.
    samples: usize,
    /// The sample of a pixel that is read (0-based, within a block).
    sample: usize,
    /// Blocks before the read band's first one (band-interleaved files).
    plane_offset: usize,
    /// The band read (1-based) and the file's band count.
    band: (usize, usize),
    /// Georeferencing in the file that is not used (GCPs, RPCs).
    unused_georef: Option<String>,
    /// The read band's scale and offset in GDAL_METADATA (not applied
    /// here: [`super::super::scaling::unscale`] does).
    file_scaling: Option<crate::raster::Scaling>,
    /// float16 samples, presented as float32.
    half: bool,
    /// LERC compression (its additional layer) and every block's offset and
    /// byte count, read by [`super::lerc`] (the crate does not decode it).
    lerc: Option<super::lerc::Additional>,
    /// Old-style (pre-TIFF 6.0, LSB-first) LZW, which libtiff still reads
    /// (`LZWDecodeCompat`) and the crate does not: decoded here by weezl.
    old_lzw: bool,
    chunks: Vec<(u64, u64)>,
    /// The cell type blocks decode to (float16 as f32) before a mask
    /// widens them to `info.dtype`.
    native: DType,
    /// The nodata the file declares (sparse blocks read as it).
    file_nodata: Option<f64>,
    /// The per-dataset mask read as nodata, its decoders (internal mask)
    /// and the value masked cells read as ([`super::mask`]).
    mask: Option<(MaskSource, f64)>,
    mask_pool: Mutex<Vec<Dec>>,
    /// Blocks (of every plane) stored as offset 0 and 0 bytes: GDAL's
    /// `SPARSE_OK` leaves never-written blocks so and reads them as the
    /// nodata value (0 without one); so does this reader.
    sparse: Vec<bool>,
    /// How the decoder is shown the file (photometric value read as
    /// BlackIsZero, missing tags supplied: see `photometric.rs`).
    view: View,
    limits: Limits,
    pool: Mutex<Vec<Dec>>,
    cache: Mutex<BlockCache>,
}

/// Map a `tiff` crate error to an orogen error naming `path`.
fn tiff_err(path: &Path, e: TiffError) -> Error {
    match e {
        TiffError::IoError(io) if io.kind() == std::io::ErrorKind::UnexpectedEof => Error::corrupt(
            path,
            format!("the file is truncated ({io}); re-download or re-export it"),
        ),
        TiffError::IoError(io) => Error::io(path, io),
        // The decoder's messages that name no tag get the tags they mean.
        TiffError::FormatError(tiff::TiffFormatError::InconsistentSizesEncountered) => Error::corrupt(
            path,
            "not a valid TIFF: the number of StripOffsets/StripByteCounts (or TileOffsets/TileByteCounts) entries does not match ImageWidth, ImageLength and RowsPerStrip (or TileWidth, TileLength)",
        ),
        TiffError::FormatError(f) => Error::corrupt(path, format!("not a valid TIFF: {f}")),
        TiffError::UnsupportedError(u) => Error::unsupported(
            path,
            format!("{u}; orogen reads single-band (or pixel-interleaved) int8/16/32, uint8/16/32, float32/64 TIFFs compressed with {SUPPORTED_COMPRESSION}"),
        ),
        TiffError::LimitsExceeded => Error::too_large(path, "a TIFF structure exceeds the decoder's memory limits"),
        other => Error::corrupt(path, format!("invalid TIFF: {other}")),
    }
}

fn open_decoder(path: &Path, limits: &Limits, view: &View) -> Result<Dec> {
    let f = File::open(path).at(path)?;
    let f = SampleFile::new(f, view.clone()).at(path)?;
    let dec = Decoder::new(BufReader::with_capacity(64 << 10, f)).map_err(|e| tiff_err(path, e))?;
    Ok(dec.with_limits(limits.clone()))
}

/// A decoder error reading tag `tag`, the tag named (the decoder's
/// "tag has invalid type" does not say which).
fn tag_err(path: &Path, tag: u16, e: TiffError) -> Error {
    match tiff_err(path, e) {
        Error::Corrupt { path, msg } => Error::Corrupt {
            msg: format!("TIFF tag {tag}: {msg}"),
            path,
        },
        e => e,
    }
}

/// Read an optional tag as doubles (any numeric type accepted).
fn tag_f64s(dec: &mut Dec, path: &Path, tag: u16) -> Result<Option<Vec<f64>>> {
    let t = Tag::from_u16_exhaustive(tag);
    tag_count(dec, path, t)?;
    let v = dec.find_tag(t).map_err(|e| tag_err(path, tag, e))?;
    match v {
        None => Ok(None),
        Some(v) => v
            .into_f64_vec()
            .map(Some)
            .map_err(|_| Error::corrupt(path, format!("GeoTIFF tag {tag} does not hold numbers"))),
    }
}

/// Read an optional tag as unsigned integers.
fn tag_u64s(dec: &mut Dec, path: &Path, tag: Tag) -> Result<Option<Vec<u64>>> {
    let num = tag.to_u16();
    tag_count(dec, path, tag)?;
    match dec.find_tag(tag).map_err(|e| tag_err(path, num, e))? {
        None => Ok(None),
        Some(v) => v.into_u64_vec().map(Some).map_err(|_| {
            Error::corrupt(
                path,
                format!("TIFF tag {num} has the wrong type (expected unsigned integers)"),
            )
        }),
    }
}

/// The longest text tag read (GeoAsciiParams, GDAL_NODATA hold a few
/// dozen bytes in practice). It also keeps tiff 0.11.3 from printing a stray
/// `dbg!` line to stderr, which it does for an ASCII tag longer than its
/// buffer limit (at least 1 MiB here).
const MAX_TEXT_TAG: u64 = 1 << 20;

/// The declared count of a tag of the current IFD (`None` if absent),
/// checked before the tiff crate reads the tag: every value takes at least
/// one byte, so a count beyond the file's length means a truncated or
/// corrupt file (a clearer error than the decoder's memory limit, which it
/// would otherwise hit).
fn tag_count(dec: &mut Dec, path: &Path, tag: Tag) -> Result<Option<u64>> {
    let Some(count) = dec.image_ifd().find_entry(tag).map(|e| e.count()) else {
        return Ok(None);
    };
    let len = dec.inner().get_ref().file().metadata().at(path)?.len();
    if count > len {
        return Err(Error::corrupt(
            path,
            format!(
                "TIFF tag {} declares {count} values, more than the file's {len} bytes \
                 can hold: the file is truncated or corrupt",
                tag.to_u16()
            ),
        ));
    }
    Ok(Some(count))
}

fn tag_ascii(dec: &mut Dec, path: &Path, tag: u16) -> Result<Option<String>> {
    let t = Tag::from_u16_exhaustive(tag);
    if let Some(count) = tag_count(dec, path, t)?.filter(|&c| c > MAX_TEXT_TAG) {
        return Err(Error::too_large(
            path,
            format!(
                "TIFF tag {tag} declares {count} bytes of text; orogen reads at most {MAX_TEXT_TAG}"
            ),
        ));
    }
    match dec.find_tag(t).map_err(|e| tag_err(path, tag, e))? {
        None => Ok(None),
        Some(v) => v
            .into_string()
            .map(Some)
            .map_err(|_| Error::corrupt(path, format!("TIFF tag {tag} should be ASCII text"))),
    }
}

fn single_u64(dec: &mut Dec, path: &Path, tag: Tag, default: u64) -> Result<u64> {
    Ok(tag_u64s(dec, path, tag)?
        .and_then(|v| v.first().copied())
        .unwrap_or(default))
}

impl GeoTiffReader {
    /// Open `path` with default options.
    pub fn open(path: impl AsRef<Path>) -> Result<GeoTiffReader> {
        Self::open_with(path, &ReaderOptions::default())
    }

    /// Open `path`: read and validate the header, the first IFD and the
    /// georeferencing; no pixel data is read.
    pub fn open_with(path: impl AsRef<Path>, opts: &ReaderOptions) -> Result<GeoTiffReader> {
        let path = path.as_ref();
        let file_len = std::fs::metadata(path).at(path)?.len();
        let limits = {
            let mut l = Limits::default();
            l.decoding_buffer_size = opts.max_block_bytes.max(1 << 20);
            l.intermediate_buffer_size = opts.max_block_bytes.max(1 << 20);
            l
        };
        // Tag values are read into a `Vec<Value>` sized from the declared
        // count before anything is read (tiff 0.11.3 bounds it only by
        // `decoding_buffer_size`): a 1 KiB file declaring 33 M GeoKey shorts
        // asked for 1 GiB (found by fuzzing). A tag cannot hold more
        // values than the file has bytes, so the metadata decoder is bounded
        // by that; blocks are decoded with the full limits (set below).
        let meta_limits = {
            let mut l = limits.clone();
            let per_file = (file_len as usize)
                .saturating_mul(std::mem::size_of::<tiff::decoder::ifd::Value>());
            l.decoding_buffer_size = per_file.clamp(1 << 20, l.decoding_buffer_size);
            l
        };
        let (view, heads) = decoder_view(path)?;
        let mut dec = open_decoder(path, &meta_limits, &view)?;
        let (w, h) = dec.dimensions().map_err(|e| tiff_err(path, e))?;
        let (width, height) = (w as usize, h as usize);
        if width == 0 || height == 0 {
            return Err(Error::corrupt(
                path,
                format!("the image is empty ({width} x {height} cells)"),
            ));
        }
        if (w as u64) * (h as u64) > MAX_CELLS {
            return Err(Error::too_large(
                path,
                format!(
                    "declared size {width} x {height} cells exceeds orogen's limit of 2^40 cells"
                ),
            ));
        }

        // The structural tags must hold unsigned integers: the crate would
        // otherwise turn e.g. ASCII offsets into character codes.
        for (num, name) in [
            (256, "ImageWidth"),
            (257, "ImageLength"),
            (258, "BitsPerSample"),
            (259, "Compression"),
            (273, "StripOffsets"),
            (277, "SamplesPerPixel"),
            (278, "RowsPerStrip"),
            (279, "StripByteCounts"),
            (284, "PlanarConfiguration"),
            (317, "Predictor"),
            (322, "TileWidth"),
            (323, "TileLength"),
            (324, "TileOffsets"),
            (325, "TileByteCounts"),
            (339, "SampleFormat"),
        ] {
            if let Some(e) = dec.image_ifd().find_entry(Tag::from_u16_exhaustive(num)) {
                let t = e.field_type().to_u16();
                // BYTE, SHORT, LONG, LONG8
                if !matches!(t, 1 | 3 | 4 | 16) {
                    return Err(Error::corrupt(
                        path,
                        format!("TIFF tag {name} ({num}) has field type {t}; it must be an unsigned integer (BYTE, SHORT, LONG or LONG8)"),
                    ));
                }
            }
        }

        // Compression: refuse what cannot be decoded before any pixel read.
        let compression = single_u64(&mut dec, path, Tag::Compression, 1)?;
        if !matches!(compression, 1 | 5 | 8 | 32946 | 32773 | 50000 | 34887) {
            let name = match compression {
                6 | 7 => "JPEG",
                34925 => "LZMA",
                50001 => "WebP",
                2..=4 => "CCITT fax",
                _ => "unknown",
            };
            return Err(Error::unsupported(
                path,
                format!("compression {name} ({compression}); supported: {SUPPORTED_COMPRESSION}; convert with e.g. `gdal_translate -co COMPRESS=DEFLATE`"),
            ));
        }

        // Sample layout and type.
        let samples = single_u64(&mut dec, path, Tag::SamplesPerPixel, 1)? as usize;
        let planar = single_u64(&mut dec, path, Tag::PlanarConfiguration, 1)? == 2 && samples > 1;
        if samples == 0 || samples > 256 {
            return Err(Error::corrupt(
                path,
                format!("invalid SamplesPerPixel {samples}"),
            ));
        }
        if opts.band == 0 || opts.band > samples {
            return Err(Error::invalid(format!(
                "{}: band {} asked for, the file has {samples} band{}: choose --band 1{}",
                path.display(),
                opts.band,
                if samples == 1 { "" } else { "s" },
                if samples == 1 {
                    String::new()
                } else {
                    format!(" to {samples}")
                }
            )));
        }
        // A block holds every band of its pixels (pixel-interleaved) or one
        // band (band-interleaved: band b's blocks follow band b - 1's).
        let (block_samples, sample) = if planar {
            (1, 0)
        } else {
            (samples, opts.band - 1)
        };
        let bits = tag_u64s(&mut dec, path, Tag::BitsPerSample)?.unwrap_or_else(|| vec![1]);
        let bits0 = bits.first().copied().unwrap_or(1);
        if bits.iter().any(|&b| b != bits0) {
            return Err(Error::unsupported(
                path,
                format!("bands with different bit depths {bits:?}"),
            ));
        }
        let fmt = tag_u64s(&mut dec, path, Tag::SampleFormat)?.unwrap_or_else(|| vec![1]);
        let fmt0 = fmt.first().copied().unwrap_or(1);
        // float16 samples are presented as float32 (exact: every half is
        // a float), as GDAL does.
        let half = (fmt0, bits0) == (3, 16);
        let dtype = match (fmt0, bits0) {
            (3, 16) => DType::F32,
            (1, 8) => DType::U8,
            (2, 8) => DType::I8,
            (1, 16) => DType::U16,
            (2, 16) => DType::I16,
            (1, 32) => DType::U32,
            (2, 32) => DType::I32,
            (3, 32) => DType::F32,
            (3, 64) => DType::F64,
            (1 | 2, 1..=64) | (3, 24) => {
                let kind = match fmt0 {
                    1 => "unsigned integer",
                    2 => "signed integer",
                    _ => "floating-point",
                };
                return Err(Error::unsupported(
                    path,
                    format!("{bits0}-bit {kind} samples are not supported (orogen reads 8-, 16- and 32-bit integers and 16-, 32- and 64-bit floats); convert with e.g. `gdal_translate -ot {}`", if fmt0 == 3 { "Float32" } else if bits0 > 32 { "Float64" } else if bits0 > 16 { "Int32" } else { "Int16" }),
                ));
            }
            (1..=3, _) => {
                return Err(Error::corrupt(
                    path,
                    format!("BitsPerSample {bits0} is inconsistent with SampleFormat {fmt0}"),
                ))
            }
            _ => {
                return Err(Error::unsupported(
                    path,
                    format!("SampleFormat {fmt0} (only 1 unsigned, 2 signed, 3 float are read)"),
                ))
            }
        };
        let predictor = single_u64(&mut dec, path, Tag::Predictor, 1)?;
        match (predictor, dtype.is_float()) {
            (1 | 2, _) | (3, true) => {}
            (3, false) => {
                return Err(Error::corrupt(
                    path,
                    "floating-point predictor (3) on integer samples",
                ));
            }
            (p, _) => {
                return Err(Error::unsupported(
                    path,
                    format!("predictor {p}; supported: 1, 2, 3"),
                ))
            }
        }

        // Block layout, checked against the file size.
        let tiled = dec.get_chunk_type() == ChunkType::Tile;
        let (chunk_w, chunk_h) = if tiled {
            let tw = single_u64(&mut dec, path, Tag::TileWidth, 0)?;
            let th = single_u64(&mut dec, path, Tag::TileLength, 0)?;
            (tw as usize, th as usize)
        } else {
            let rps = single_u64(&mut dec, path, Tag::RowsPerStrip, height as u64)?;
            (width, (rps as usize).min(height))
        };
        if chunk_w == 0 || chunk_h == 0 {
            return Err(Error::corrupt(path, "zero tile or strip size"));
        }
        let stored = if half { 2 } else { dtype.size() };
        let block_bytes =
            (chunk_w as u64) * (chunk_h as u64) * (block_samples as u64) * (stored as u64);
        if block_bytes > opts.max_block_bytes as u64 {
            return Err(Error::too_large(
                path,
                format!("one {} of {chunk_w} x {chunk_h} cells decodes to {block_bytes} bytes (limit {}); re-tile it with `gdal_translate -co TILED=YES`", if tiled { "tile" } else { "strip" }, opts.max_block_bytes),
            ));
        }
        let across = width.div_ceil(chunk_w);
        let down = height.div_ceil(chunk_h);
        let (otag, ctag) = if tiled {
            (Tag::TileOffsets, Tag::TileByteCounts)
        } else {
            (Tag::StripOffsets, Tag::StripByteCounts)
        };
        let offsets = tag_u64s(&mut dec, path, otag)?.unwrap_or_default();
        let counts = tag_u64s(&mut dec, path, ctag)?.unwrap_or_default();
        let planes = if planar { samples } else { 1 };
        if offsets.len() != across * down * planes || counts.len() != offsets.len() {
            return Err(Error::corrupt(
                path,
                format!(
                    "{} offsets/byte counts arrays have {} and {} entries, expected {}",
                    if tiled { "tile" } else { "strip" },
                    offsets.len(),
                    counts.len(),
                    across * down * planes
                ),
            ));
        }
        // LERC blocks are read and decoded here, not by the crate.
        let lerc = if compression == 34887 {
            let params = tag_u64s(&mut dec, path, Tag::from_u16_exhaustive(50674))?;
            Some(super::lerc::additional(path, params.as_deref())?)
        } else {
            None
        };
        // Old-style LZW: libtiff tells it by the first two bytes of a strip
        // (0, then an odd byte: a clear code written LSB first); the first
        // stored block decides for the file.
        let old_lzw = compression == 5 && {
            match offsets.iter().zip(&counts).find(|(_, &c)| c >= 2) {
                Some((&at, _)) => {
                    let b = stored_bytes(path, at, 2)?;
                    b[0] == 0 && b[1] & 1 == 1
                }
                None => false,
            }
        };
        if old_lzw && predictor != 1 {
            return Err(Error::unsupported(
                path,
                format!("old-style (pre-TIFF 6.0) LZW with predictor {predictor}; rewrite it with `gdal_translate -co COMPRESS=LZW`"),
            ));
        }
        let chunks: Vec<(u64, u64)> = if lerc.is_some() || old_lzw {
            offsets
                .iter()
                .copied()
                .zip(counts.iter().copied())
                .collect()
        } else {
            Vec::new()
        };
        let sparse: Vec<bool> = offsets
            .iter()
            .zip(&counts)
            .map(|(&o, &c)| o == 0 && c == 0)
            .collect();
        for (i, (&o, &c)) in offsets.iter().zip(&counts).enumerate() {
            if o.checked_add(c).is_none_or(|end| end > file_len) {
                return Err(Error::corrupt(
                    path,
                    format!("block {i} lies past the end of the file (offset {o} + {c} bytes > file size {file_len}): the file is truncated or corrupt"),
                ));
            }
        }
        if compression == 1 {
            let stride = (block_samples * stored) as u64;
            for (i, &c) in counts.iter().enumerate() {
                if sparse[i] {
                    continue;
                }
                let rows = if tiled {
                    chunk_h
                } else {
                    chunk_h.min(height - ((i % (across * down)) * chunk_h).min(height))
                };
                let need = chunk_w as u64 * rows as u64 * stride;
                if c < need {
                    return Err(Error::corrupt(
                        path,
                        format!("uncompressed block {i} holds {c} bytes, needs {need}: the file is truncated or corrupt"),
                    ));
                }
            }
        }

        let (mut georef, tiepoints) = read_georef(&mut dec, path, dtype)?;
        let gcps = tiepoints > 1;
        let unused_georef = unused_georef(&mut dec, path, tiepoints)?;
        let file_scaling = tag_ascii(&mut dec, path, 42112)?
            .and_then(|xml| crate::io::scaling::from_gdal_metadata(&xml, opts.band));
        if gcps && !georef.georeferenced {
            // The GeoKeys are the ground control points' CRS, not a CRS of
            // the grid (GDAL reports the dataset without one).
            georef.crs = Crs::default();
        }
        let extra = tag_u64s(&mut dec, path, Tag::ExtraSamples)?.unwrap_or_default();
        let source = find_mask(&heads, width, height).or_else(|| {
            // The first alpha among the extra samples (the last ones).
            let first_extra = samples.checked_sub(extra.len())?;
            let k = extra.iter().position(|&e| e == 1 || e == 2)?;
            Some(MaskSource::Alpha {
                sample: first_extra + k,
            })
        });
        let source = source.filter(|m| {
            *m != MaskSource::Alpha {
                sample: opts.band - 1,
            }
        });
        let file_nodata = georef.nodata;
        let (shown, mask, mask_pool) = match source {
            None => (dtype, None, Vec::new()),
            Some(m) => {
                let (shown, fill) = mask::presented(dtype, file_nodata);
                if file_nodata.is_none() {
                    georef.nodata = Some(f64::NAN);
                }
                let pool = match m {
                    MaskSource::Ifd {
                        index,
                        photometric_at,
                    } => {
                        let mut d = mask_decoder(path, &limits, index, photometric_at, &view)?;
                        let (mw, mh) = if d.get_chunk_type() == ChunkType::Tile {
                            (
                                single_u64(&mut d, path, Tag::TileWidth, 0)? as usize,
                                single_u64(&mut d, path, Tag::TileLength, 0)? as usize,
                            )
                        } else {
                            let rows =
                                single_u64(&mut d, path, Tag::RowsPerStrip, u32::MAX as u64)?;
                            (width, rows.min(height as u64) as usize)
                        };
                        if (d.get_chunk_type() == ChunkType::Tile) != tiled
                            || (mw, mh.min(height)) != (chunk_w, chunk_h.min(height))
                        {
                            return Err(Error::unsupported(
                                path,
                                format!("its internal mask is stored in {mw} x {mh} blocks, the image in {chunk_w} x {chunk_h}; orogen reads masks stored like the image (as GDAL writes them): rewrite it with `gdal_translate`"),
                            ));
                        }
                        vec![d]
                    }
                    MaskSource::Alpha { .. } => Vec::new(),
                };
                (shown, Some((m, fill)), pool)
            }
        };
        let dec = dec.with_limits(limits.clone());
        let info = RasterInfo {
            width,
            height,
            dtype: shown,
            georef,
            block: (chunk_w, chunk_h),
            path: path.to_path_buf(),
        };
        Ok(GeoTiffReader {
            info,
            tiled,
            chunk_w,
            chunk_h,
            across,
            samples: block_samples,
            sample,
            plane_offset: if planar {
                (opts.band - 1) * across * down
            } else {
                0
            },
            band: (opts.band, samples),
            unused_georef,
            file_scaling,
            half,
            lerc,
            old_lzw,
            chunks,
            native: dtype,
            file_nodata,
            mask,
            mask_pool: Mutex::new(mask_pool),
            sparse,
            view,
            limits,
            pool: Mutex::new(vec![dec]),
            cache: Mutex::new(BlockCache::new(opts.cache_bytes)),
        })
    }

    /// The read band's scale and offset as GDAL_METADATA records them
    /// (`raw * scale + offset`); the reader returns raw cells.
    pub fn file_scaling(&self) -> Option<crate::raster::Scaling> {
        self.file_scaling
    }

    /// The file path.
    pub fn path(&self) -> &Path {
        &self.info.path
    }

    /// True for a tiled file, false for strips.
    pub fn is_tiled(&self) -> bool {
        self.tiled
    }

    /// Window of block `id` in raster coordinates (clipped to the raster).
    fn block_window(&self, id: usize) -> Window {
        let bx = id % self.across;
        let by = id / self.across;
        let x = bx * self.chunk_w;
        let y = by * self.chunk_h;
        Window::new(
            x as i64,
            y as i64,
            self.chunk_w.min(self.info.width - x),
            self.chunk_h.min(self.info.height - y),
        )
    }

    /// Decode block `id` into little-endian cells of its clipped window,
    /// masked cells set to their fill value ([`super::mask`]).
    fn decode_block(&self, id: usize) -> Result<Arc<Vec<u8>>> {
        let native = self.decode_native(id, self.plane_offset + id, self.sample)?;
        let Some((source, fill)) = self.mask else {
            return Ok(Arc::new(native));
        };
        let win = self.block_window(id);
        let valid = match source {
            MaskSource::Alpha { sample } => {
                // The alpha sample of the same pixels (its own plane in a
                // band-interleaved file); valid where it is not 0.
                let (chunk, sample) = if self.samples == 1 {
                    (sample * self.across * self.down() + id, 0)
                } else {
                    (id, sample)
                };
                let alpha = self.decode_native(id, chunk, sample)?;
                let size = self.native.size();
                alpha
                    .chunks_exact(size)
                    .map(|c| c.iter().any(|&b| b != 0))
                    .collect()
            }
            MaskSource::Ifd {
                index,
                photometric_at,
            } => {
                let path = &self.info.path;
                let mut dec = match self.mask_pool.lock().ok().and_then(|mut p| p.pop()) {
                    Some(d) => d,
                    None => mask_decoder(path, &self.limits, index, photometric_at, &self.view)?,
                };
                let stride = self.chunk_w.div_ceil(8);
                let mut res = DecodingResult::U8(Vec::new());
                dec.read_chunk_to_buffer(&mut res, id as u32, stride)
                    .map_err(|e| self.block_err(id, " of the internal mask", tiff_err(path, e)))?;
                if let Ok(mut p) = self.mask_pool.lock() {
                    p.push(dec);
                }
                mask::bits(path, res.as_buffer(0).as_bytes(), stride, win.w, win.h)?
            }
        };
        Ok(Arc::new(mask::apply(
            self.native,
            self.info.dtype,
            fill,
            &native,
            &valid,
        )))
    }

    /// `e`, raised decoding chunk `chunk`, saying which block of the file
    /// it is (a decoder's message, "corrupt deflate stream", names none)
    /// and what to do.
    fn block_err(&self, chunk: usize, of: &str, e: Error) -> Error {
        let (path, msg) = match e {
            Error::Corrupt { path, msg } => (path, msg),
            // The codecs report bad streams as I/O errors (InvalidData,
            // flate2: InvalidInput).
            Error::Io { path, err }
                if matches!(
                    err.kind(),
                    std::io::ErrorKind::InvalidData | std::io::ErrorKind::InvalidInput
                ) =>
            {
                (path, err.to_string())
            }
            e => return e,
        };
        let per_band = self.across * self.down();
        let (band, id) = (chunk / per_band, chunk % per_band);
        let w = self.block_window(id);
        let band = if self.samples == 1 && self.band.1 > 1 {
            format!(", band {}", band + 1)
        } else {
            String::new()
        };
        Error::Corrupt {
            msg: format!(
                "{} {id}{of} (cells {}..{} x {}..{}{band}) cannot be decoded: {msg}; the file is damaged: re-download or re-export it",
                if self.tiled { "tile" } else { "strip" },
                w.x,
                w.x_end(),
                w.y,
                w.y_end(),
            ),
            path,
        }
    }

    /// The `len` bytes of old-style LZW chunk `chunk` (LSB-first codes, the
    /// code size growing without TIFF 6.0's early change: weezl's
    /// GIF-style decoder), samples of `cell` bytes in native order.
    fn old_lzw_block(&self, chunk: usize, len: usize, cell: usize) -> Result<Vec<u8>> {
        let path = &self.info.path;
        let stored = self.chunk_bytes(chunk)?;
        let mut out = vec![0u8; len];
        let mut dec = weezl::decode::Decoder::new(weezl::BitOrder::Lsb, 8);
        let bad = |msg: String| self.block_err(chunk, "", Error::corrupt(path, msg));
        let (mut read, mut written) = (0, 0);
        // The decoder returns at every clear code: go on until the block is
        // full or the stream ends.
        while written < len {
            let r = dec.decode_bytes(&stored[read..], &mut out[written..]);
            read += r.consumed_in;
            written += r.consumed_out;
            match r.status {
                Err(e) => return Err(bad(format!("old-style LZW: {e}"))),
                Ok(weezl::LzwStatus::Done) => break,
                Ok(_) if r.consumed_in == 0 && r.consumed_out == 0 => break,
                Ok(_) => {}
            }
        }
        if written < len {
            return Err(bad(format!(
                "old-style LZW decoded {written} of {len} bytes"
            )));
        }
        if self.view.big_endian() && cell > 1 {
            for c in out.chunks_exact_mut(cell) {
                c.reverse();
            }
        }
        Ok(out)
    }

    /// The stored (compressed) bytes of chunk `chunk`, for the codecs the
    /// reader runs itself (LERC, old-style LZW).
    fn chunk_bytes(&self, chunk: usize) -> Result<Vec<u8>> {
        let (at, len) = self.chunks.get(chunk).copied().unwrap_or((0, 0));
        stored_bytes(&self.info.path, at, len)
    }

    /// Blocks per band (rows of blocks times blocks per row).
    fn down(&self) -> usize {
        self.info.height.div_ceil(self.chunk_h)
    }

    /// Decode chunk `chunk` (block `id` of its plane) into the little-endian
    /// `native` cells of sample `sample` of block `id`'s clipped window.
    fn decode_native(&self, id: usize, chunk: usize, sample: usize) -> Result<Vec<u8>> {
        let path = &self.info.path;
        if self.sparse.get(chunk) == Some(&true) {
            return Ok(self.sparse_block(id));
        }
        let win = self.block_window(id);
        let cell = self.native.size();
        let stored = if self.half { 2 } else { cell };
        let px = stored * self.samples;
        // Decode with the output row stride equal to the full block row, so
        // the decoder never has to read (and discard) the right-hand padding
        // of edge tiles: tiff 0.11.3's LZW reader fails with "no lzw end code
        // found" on some valid streams (weezl's, and so possibly others) when
        // that padding is skipped in a separate read at the end of the stream.
        let stride = self.chunk_w * px;
        let mut res = DecodingResult::U8(Vec::new());
        // Blocks the reader decodes itself: strips hold their own rows,
        // tiles are whole.
        let rows = if self.tiled { self.chunk_h } else { win.h };
        let (owned, decoded);
        let raw: &[u8] = if self.old_lzw {
            owned = self.old_lzw_block(chunk, rows * stride, stored)?;
            &owned
        } else if let Some(additional) = self.lerc {
            let bytes = self.chunk_bytes(chunk)?;
            let fill = self.file_nodata.unwrap_or(if self.native.is_float() {
                f64::NAN
            } else {
                0.0
            });
            owned = super::lerc::decode_block(
                path,
                &bytes,
                additional,
                self.native,
                (self.chunk_w, rows, self.samples),
                fill,
                self.limits.decoding_buffer_size,
            )?;
            &owned
        } else {
            let mut dec = match self.pool.lock().ok().and_then(|mut p| p.pop()) {
                Some(d) => d,
                None => open_decoder(path, &self.limits, &self.view)?,
            };
            dec.read_chunk_to_buffer(&mut res, chunk as u32, stride)
                .map_err(|e| self.block_err(chunk, "", tiff_err(path, e)))?;
            if let Ok(mut p) = self.pool.lock() {
                p.push(dec);
            }
            decoded = res.as_buffer(0);
            decoded.as_bytes()
        };
        let mut buf = vec![0u8; win.w * win.h * cell];
        for r in 0..win.h {
            let src = raw
                .get(r * stride..r * stride + win.w * px)
                .ok_or_else(|| {
                    Error::corrupt(
                        path,
                        format!("block {id} decoded to fewer bytes than its size"),
                    )
                })?;
            let dst = &mut buf[r * win.w * cell..(r + 1) * win.w * cell];
            if self.half {
                // The crate's f16 buffer is native-endian; cells are f32 LE.
                let at = sample * 2;
                for (d, s) in dst.chunks_exact_mut(4).zip(src.chunks_exact(px)) {
                    let v = half::f16::from_ne_bytes([s[at], s[at + 1]]).to_f32();
                    d.copy_from_slice(&v.to_le_bytes());
                }
            } else if self.samples == 1 {
                dst.copy_from_slice(src);
            } else {
                // The read band of pixel-interleaved samples.
                let at = sample * cell;
                for (d, s) in dst.chunks_exact_mut(cell).zip(src.chunks_exact(px)) {
                    d.copy_from_slice(&s[at..at + cell]);
                }
            }
        }
        Ok(buf)
    }

    /// The cells of sparse block `id`: the nodata value, 0 without one (as
    /// GDAL reads them), little-endian.
    fn sparse_block(&self, id: usize) -> Vec<u8> {
        let win = self.block_window(id);
        let cell = mask::encode(self.native, self.file_nodata.unwrap_or(0.0));
        cell[..self.native.size()].repeat(win.w * win.h)
    }

    /// Block `id`, from the cache or decoded (and cached).
    fn block(&self, id: usize) -> Result<Arc<Vec<u8>>> {
        if let Some(b) = self.cache.lock().ok().and_then(|mut c| c.get(id as u32)) {
            return Ok(b);
        }
        let b = self.decode_block(id)?;
        if let Ok(mut c) = self.cache.lock() {
            c.put(id as u32, b.clone());
        }
        Ok(b)
    }
}

/// `len` bytes of `path` at `at` (the offsets were checked against the
/// file's size on opening).
fn stored_bytes(path: &Path, at: u64, len: u64) -> Result<Vec<u8>> {
    use std::io::{Read, Seek, SeekFrom};
    let mut f = File::open(path).at(path)?;
    f.seek(SeekFrom::Start(at)).at(path)?;
    let mut bytes = vec![0u8; len as usize];
    f.read_exact(&mut bytes).at(path)?;
    Ok(bytes)
}

/// What georeferencing the file holds that is not read: `tiepoints` > 1
/// (ground control points, which GDAL reports as GCPs instead of a
/// geotransform) and RPC coefficients (tag 50844).
fn unused_georef(dec: &mut Dec, path: &Path, tiepoints: usize) -> Result<Option<String>> {
    let mut unused = Vec::new();
    if tiepoints > 1 {
        unused.push(format!("{tiepoints} ground control points (GCPs)"));
    }
    if tag_count(dec, path, Tag::from_u16_exhaustive(50844))?.is_some() {
        unused.push("RPC coefficients".to_string());
    }
    Ok((!unused.is_empty()).then(|| unused.join(" and ")))
}

/// Georeferencing from the GeoTIFF tags (see `georef.rs`), and the number
/// of tiepoints (more than one: ground control points, no geotransform).
fn read_georef(dec: &mut Dec, path: &Path, dtype: DType) -> Result<(GeoRef, usize)> {
    let scale = tag_f64s(dec, path, 33550)?;
    let tie = tag_f64s(dec, path, 33922)?;
    let matrix = tag_f64s(dec, path, 34264)?;
    let dir = match tag_u64s(dec, path, Tag::from_u16_exhaustive(34735))? {
        Some(d) => Some(
            d.into_iter()
                .map(u16::try_from)
                .collect::<std::result::Result<Vec<u16>, _>>()
                .map_err(|_| {
                    Error::corrupt(path, "GeoKeyDirectory holds values that are not 16-bit")
                })?,
        ),
        None => None,
    };
    let keys = match dir {
        Some(directory) if directory.len() >= 4 => Some(GeoKeys {
            directory,
            doubles: tag_f64s(dec, path, 34736)?.unwrap_or_default(),
            ascii: tag_ascii(dec, path, 34737)?.unwrap_or_default(),
        }),
        _ => None,
    };
    let nodata = match tag_ascii(dec, path, 42113)? {
        Some(s)
            if !s
                .trim_matches(|c: char| c == '\0' || c.is_whitespace())
                .is_empty() =>
        {
            Some(parse_nodata(&s).ok_or_else(|| {
                Error::corrupt(
                    path,
                    format!("GDAL_NODATA tag holds {s:?}, which is not a number"),
                )
            })?)
        }
        _ => None,
    };
    // GDAL reports a float32 band's nodata rounded to float32 (the text
    // "-3.402823e+38" becomes -3.4028230607370965e+38), and only that value
    // compares equal to the cells; do the same.
    let nodata = match dtype {
        DType::F32 => nodata.map(|v| v as f32 as f64),
        _ => nodata,
    };
    let transform = match (&matrix, &scale, &tie) {
        (Some(m), _, _) => Some(
            transform_from_matrix(m)
                .ok_or_else(|| Error::corrupt(path, "ModelTransformation needs 16 values"))?,
        ),
        // Several tiepoints are ground control points, not a geotransform
        // (as GDAL reads them), even beside a ModelPixelScale.
        (None, Some(s), Some(t)) if t.len() <= 6 => {
            Some(transform_from_scale_tiepoint(s, t).ok_or_else(|| {
                Error::corrupt(path, "ModelPixelScale needs 3 and ModelTiepoint 6 values")
            })?)
        }
        _ => None,
    };
    let raster_type = raster_type_from_keys(keys.as_ref());
    let crs = keys.map(crs_from_keys).unwrap_or_else(Crs::default);
    let tiepoints = tie.as_ref().map_or(0, |t| t.len() / 6);
    let georef = match transform {
        Some(mut t) => {
            if raster_type == RasterType::Point {
                half_cell_shift(&mut t, -1.0);
            }
            GeoRef {
                transform: t,
                crs,
                nodata,
                raster_type,
                georeferenced: true,
            }
        }
        None => GeoRef {
            crs,
            nodata,
            raster_type,
            ..GeoRef::pixel()
        },
    };
    Ok((georef, tiepoints))
}

/// The internal mask of a `width` x `height` image ([`super::mask`]): the
/// first IFD after the image (of the file's `heads`) flagged as a
/// full-resolution mask, one bit per cell.
fn find_mask(heads: &[IfdHead], width: usize, height: usize) -> Option<MaskSource> {
    heads.iter().enumerate().skip(1).find_map(|(index, h)| {
        let full_mask = h.subfile & 4 != 0 && h.subfile & 1 == 0;
        let same = (h.width, h.height) == (width as u64, height as u64);
        match (full_mask && same && h.bits == 1, h.photometric) {
            (true, Some((photometric_at, 4))) => Some(MaskSource::Ifd {
                index,
                photometric_at,
            }),
            _ => None,
        }
    })
}

/// A decoder on the internal mask IFD `index`, its photometric value (4,
/// a transparency mask, which the crate will not decode) read as
/// BlackIsZero: one-bit gray samples, through the image's `view` (its
/// IFD chain leads to the mask).
fn mask_decoder(
    path: &Path,
    limits: &Limits,
    index: usize,
    photometric_at: u64,
    view: &View,
) -> Result<Dec> {
    let view = view.clone().black_is_zero(photometric_at);
    let mut dec = open_decoder(path, limits, &view)?;
    dec.seek_to_image(index).map_err(|e| tiff_err(path, e))?;
    Ok(dec)
}

/// How the decoder is shown `path` (see `photometric.rs`): the photometric
/// value read as BlackIsZero where the stored samples are what GDAL
/// returns, missing tags libtiff supplies added; colour files GDAL
/// converts are refused. With the heads of its first 64 IFDs (one walk of
/// the chain: the mask is looked for among them).
fn decoder_view(path: &Path) -> Result<(View, Vec<IfdHead>)> {
    let mut f = File::open(path).at(path)?;
    let (heads, _) = ifd_heads(&mut f, 64).at(path)?;
    let patch = photometric_patch(path, heads.first().and_then(|h| h.photometric))?;
    Ok((photometric::file_view(&mut f, patch).at(path)?, heads))
}

/// Where the decoder must read PhotometricInterpretation as BlackIsZero
/// (see `photometric.rs`): `None` for files stored as BlackIsZero or
/// without the tag; an error for interpretations whose samples are not
/// values (CMYK, YCbCr, transparency masks, CIE L*a*b*, LogLuv).
fn photometric_patch(path: &Path, photometric: Option<(u64, u16)>) -> Result<Option<u64>> {
    let Some((at, value)) = photometric else {
        return Ok(None);
    };
    match value {
        photometric::BLACK_IS_ZERO => Ok(None),
        // WhiteIsZero, RGB, palette indices: stored samples are read, as
        // GDAL reads them.
        photometric::WHITE_IS_ZERO | 2 | 3 => Ok(Some(at)),
        v => {
            let name = match v {
                4 => "a transparency mask",
                // GDAL converts CMYK to RGBA on reading.
                5 => "CMYK colour",
                photometric::YCBCR => "YCbCr colour",
                8..=10 => "CIE L*a*b* colour",
                32844 | 32845 => "LogLuv colour",
                _ => "an unknown photometric interpretation",
            };
            Err(Error::unsupported(
                path,
                format!("the image is {name} (PhotometricInterpretation {v}), not values orogen can read as elevations; convert it with e.g. `gdal_translate -co PHOTOMETRIC=RGB` or extract a band with `gdal_translate -b 1`"),
            ))
        }
    }
}

impl RasterSource for GeoTiffReader {
    fn info(&self) -> &RasterInfo {
        &self.info
    }

    fn band(&self) -> (usize, usize) {
        self.band
    }

    fn unused_georef(&self) -> Option<&str> {
        self.unused_georef.as_deref()
    }

    fn read_native(&self, win: Window) -> Result<AnyGrid> {
        let (w, h) = (self.info.width, self.info.height);
        if win.x < 0 || win.y < 0 || win.x_end() > w as i64 || win.y_end() > h as i64 {
            return Err(Error::invalid(format!(
                "{}: window {win:?} is not inside the {w} x {h} raster",
                self.info.path.display()
            )));
        }
        let cell = self.info.dtype.size();
        let mut out = vec![0u8; win.len() * cell];
        if win.is_empty() {
            return AnyGrid::from_le_bytes(self.info.dtype, win.w, win.h, &out);
        }
        let (x0, y0) = (win.x as usize, win.y as usize);
        let bx0 = x0 / self.chunk_w;
        let bx1 = (x0 + win.w - 1) / self.chunk_w;
        let by0 = y0 / self.chunk_h;
        let by1 = (y0 + win.h - 1) / self.chunk_h;
        let ids: Vec<usize> = (by0..=by1)
            .flat_map(|by| (bx0..=bx1).map(move |bx| by * self.across + bx))
            .collect();
        let blocks: Vec<Arc<Vec<u8>>> = if ids.len() > 1 {
            ids.par_iter()
                .map(|&id| self.block(id))
                .collect::<Result<_>>()?
        } else {
            ids.iter()
                .map(|&id| self.block(id))
                .collect::<Result<_>>()?
        };
        for (&id, data) in ids.iter().zip(&blocks) {
            let bw = self.block_window(id);
            let Some(part) = bw.intersect(&win) else {
                continue;
            };
            let n = part.w * cell;
            for r in 0..part.h {
                let src_row = (part.y - bw.y) as usize + r;
                let src = (src_row * bw.w + (part.x - bw.x) as usize) * cell;
                let dst_row = (part.y - win.y) as usize + r;
                let dst = (dst_row * win.w + (part.x - win.x) as usize) * cell;
                out[dst..dst + n].copy_from_slice(&data[src..src + n]);
            }
        }
        AnyGrid::from_le_bytes(self.info.dtype, win.w, win.h, &out)
    }
}
