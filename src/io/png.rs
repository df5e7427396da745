//! Greyscale PNG heightmaps (8- or 16-bit, optionally with alpha), the format
//! of game engines and of many terrain-synthesis papers' data sets.
//!
//! A sample `v` means the elevation `offset + v * scale`; the mapping is not
//! stored in the file, so the caller supplies it. Alpha 0 marks nodata. PNG
//! carries no georeference: the result uses pixel coordinates
//! ([`GeoRef::pixel`]). Decoding uses the `png` crate with its allocation
//! limit set from the file size (deflate expands at most ~1032:1, RFC 1951),
//! so a hostile header cannot make us allocate more than the data can fill.

use super::ascii::tmp_path;
use crate::error::{Error, IoContext, Result};
use crate::raster::{AnyGrid, GeoRef, Grid, MemRaster};
use std::io::{BufReader, Write};
use std::path::Path;

/// Largest heightmap read: 2^30 pixels (4 GiB as f32).
pub const MAX_PNG_PIXELS: u64 = 1 << 30;

fn png_err(path: &Path, e: ::png::DecodingError) -> Error {
    match e {
        ::png::DecodingError::LimitsExceeded => Error::too_large(
            path,
            "PNG declares more pixels than its compressed data can hold or than orogen reads (2^30)",
        ),
        e => Error::corrupt(path, format!("PNG decoding failed: {e}")),
    }
}

/// Read a greyscale PNG heightmap: elevation = `offset + v * scale`.
///
/// Accepts greyscale and grey+alpha, 1 to 16 bits (low bit depths and a tRNS
/// transparent grey are expanded to 8-bit grey+alpha). With `scale == 1`,
/// `offset == 0` and no alpha the native u8/u16 samples are returned;
/// otherwise f32 with NaN where alpha is 0 (no nodata value: NaN is nodata).
/// Colour PNGs are rejected (they are not heightmaps unless encoded, e.g.
/// Terrain-RGB, which this reader does not decode).
pub fn read_png_heightmap(path: impl AsRef<Path>, scale: f64, offset: f64) -> Result<MemRaster> {
    let path = path.as_ref();
    if !scale.is_finite() || !offset.is_finite() {
        return Err(Error::invalid(format!(
            "{}: PNG scale and offset must be finite (got {scale}, {offset})",
            path.display()
        )));
    }
    let f = std::fs::File::open(path).at(path)?;
    let len = f.metadata().at(path)?.len();
    let limit = len
        .saturating_mul(1100)
        .saturating_add(1 << 20)
        .min(MAX_PNG_PIXELS * 4 + (1 << 20));
    let mut dec = ::png::Decoder::new_with_limits(
        BufReader::new(f),
        ::png::Limits {
            bytes: usize::try_from(limit).unwrap_or(usize::MAX),
        },
    );
    dec.set_transformations(::png::Transformations::EXPAND);
    let mut reader = dec.read_info().map_err(|e| png_err(path, e))?;
    let (w, h) = reader.info().size();
    let (w, h) = (w as usize, h as usize);
    if (w as u64) * (h as u64) > MAX_PNG_PIXELS {
        return Err(Error::too_large(
            path,
            format!("PNG of {w}x{h} pixels exceeds the 2^30-pixel limit of the heightmap reader"),
        ));
    }
    let (ct, depth) = reader.output_color_type();
    let alpha = match ct {
        ::png::ColorType::Grayscale => false,
        ::png::ColorType::GrayscaleAlpha => true,
        other => {
            return Err(Error::unsupported(
                path,
                format!(
                    "PNG colour type {other:?}: a heightmap must be greyscale (8 or 16 bit, \
                     optionally with alpha); convert it to greyscale first"
                ),
            ))
        }
    };
    let bytes_per_sample = match depth {
        ::png::BitDepth::Eight => 1,
        ::png::BitDepth::Sixteen => 2,
        d => {
            return Err(Error::unsupported(
                path,
                format!("PNG bit depth {d:?} after expansion"),
            ))
        }
    };
    let size = reader
        .output_buffer_size()
        .ok_or_else(|| Error::too_large(path, "PNG frame size overflows"))?;
    if size as u64 > limit {
        return Err(Error::too_large(
            path,
            format!(
                "PNG declares {w}x{h} pixels ({size} bytes decoded) but the file is only {len} \
                 bytes: the header is corrupt or hostile"
            ),
        ));
    }
    let mut buf = vec![0u8; size];
    let out = reader.next_frame(&mut buf).map_err(|e| png_err(path, e))?;
    let line = out.line_size;
    let chans = if alpha { 2 } else { 1 };
    let sample = |row: &[u8], x: usize, c: usize| -> u16 {
        let i = (x * chans + c) * bytes_per_sample;
        if bytes_per_sample == 2 {
            u16::from_be_bytes([row[i], row[i + 1]])
        } else {
            row[i] as u16
        }
    };
    let identity = scale == 1.0 && offset == 0.0 && !alpha;
    let grid = if identity && bytes_per_sample == 1 {
        AnyGrid::U8(Grid::from_fn(w, h, |x, y| buf[y * line + x]))
    } else if identity {
        AnyGrid::U16(Grid::from_fn(w, h, |x, y| sample(&buf[y * line..], x, 0)))
    } else {
        AnyGrid::F32(Grid::from_fn(w, h, |x, y| {
            let row = &buf[y * line..];
            if alpha && sample(row, x, 1) == 0 {
                f32::NAN
            } else {
                (offset + sample(row, x, 0) as f64 * scale) as f32
            }
        }))
    };
    Ok(MemRaster::new(grid, GeoRef::pixel(), path))
}

/// Write `grid` as a 16-bit greyscale PNG mapping `[min, max]` linearly onto
/// 0..=65535 (values outside are clamped). NaN cells make the file grey+alpha
/// with alpha 0 there. Returns `(scale, offset)` such that
/// `elevation ≈ offset + v * scale`, to pass to [`read_png_heightmap`]; the
/// quantisation error is at most `scale / 2`. Written atomically.
pub fn write_png16(
    path: impl AsRef<Path>,
    grid: &Grid<f32>,
    min: f64,
    max: f64,
) -> Result<(f64, f64)> {
    let path = path.as_ref();
    if !(min.is_finite() && max.is_finite() && max > min) {
        return Err(Error::invalid(format!(
            "{}: PNG range must be finite with max > min (got {min}..{max})",
            path.display()
        )));
    }
    let (w, h) = (grid.width(), grid.height());
    let (Ok(w32), Ok(h32)) = (u32::try_from(w), u32::try_from(h)) else {
        return Err(Error::invalid(format!(
            "{}: {w}x{h} is too large for PNG",
            path.display()
        )));
    };
    if w == 0 || h == 0 {
        return Err(Error::invalid(format!("{}: empty grid", path.display())));
    }
    let scale = (max - min) / 65535.0;
    let alpha = grid.data().iter().any(|v| v.is_nan());
    let chans = if alpha { 2 } else { 1 };
    let mut data = Vec::with_capacity(w * h * 2 * chans);
    for &v in grid.data() {
        let (q, a) = if v.is_nan() {
            (0u16, 0u16)
        } else {
            let q = ((v as f64 - min) / scale).round().clamp(0.0, 65535.0) as u16;
            (q, 65535u16)
        };
        data.extend_from_slice(&q.to_be_bytes());
        if alpha {
            data.extend_from_slice(&a.to_be_bytes());
        }
    }
    let mut encoded = Vec::new();
    encode_png(&mut encoded, w32, h32, alpha_color(alpha), &data)
        .map_err(|e| Error::io(path, std::io::Error::other(e.to_string())))?;
    write_atomic(path, &encoded)?;
    Ok((scale, min))
}

fn alpha_color(alpha: bool) -> ::png::ColorType {
    if alpha {
        ::png::ColorType::GrayscaleAlpha
    } else {
        ::png::ColorType::Grayscale
    }
}

/// Encode 16-bit (grey, grey+alpha) or 8-bit (RGB, RGBA) samples as PNG into `out`.
pub(crate) fn encode_png(
    out: &mut Vec<u8>,
    w: u32,
    h: u32,
    color: ::png::ColorType,
    data: &[u8],
) -> std::result::Result<(), ::png::EncodingError> {
    let mut enc = ::png::Encoder::new(out, w, h);
    enc.set_color(color);
    enc.set_depth(match color {
        ::png::ColorType::Grayscale | ::png::ColorType::GrayscaleAlpha => ::png::BitDepth::Sixteen,
        _ => ::png::BitDepth::Eight,
    });
    let mut wr = enc.write_header()?;
    wr.write_image_data(data)?;
    wr.finish()
}

/// Write `bytes` to `path` atomically: a temporary file beside it, synced,
/// then renamed into place, so no half-written file ever carries the name.
pub(crate) fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let tmp = tmp_path(path);
    let res = (|| -> std::io::Result<()> {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()
    })();
    if let Err(e) = res {
        let _ = std::fs::remove_file(&tmp);
        return Err(Error::io(path, e));
    }
    std::fs::rename(&tmp, path).at(path)
}

/// The finite range of a grid for [`write_png16`]: (min, max) of its finite
/// cells, widened to (min, min + 1) when constant and (0, 1) when empty.
pub fn finite_range(grid: &Grid<f32>) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for &v in grid.data() {
        if v.is_finite() {
            lo = lo.min(v as f64);
            hi = hi.max(v as f64);
        }
    }
    if !lo.is_finite() {
        (0.0, 1.0)
    } else if hi <= lo {
        (lo, lo + 1.0)
    } else {
        (lo, hi)
    }
}
