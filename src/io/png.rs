//! Greyscale PNG heightmaps (8- or 16-bit, optionally with alpha), the format
//! of game engines and of many terrain-synthesis papers' data sets.
//!
//! A sample `v` means the elevation `offset + v * scale`. PNG has no field
//! for it; orogen's writes record it twice, in `tEXt` chunks
//! (`height_scale`, `height_offset`) and in a GDAL PAM sidecar
//! (`<file>.aux.xml`, band 1 `<Scale>`/`<Offset>`, which `gdalinfo` reports
//! and `gdal_translate -unscale` applies), and reads take it from there
//! unless the caller gives one (`--png-scale`/`--png-offset`). Alpha 0
//! marks nodata. PNG
//! carries no georeference: the result uses pixel coordinates
//! ([`GeoRef::pixel`]). Decoding uses the `png` crate with its allocation
//! limit set from the file size (deflate expands at most ~1032:1, RFC 1951),
//! so a hostile header cannot make us allocate more than the data can fill.

use super::ascii::tmp_path;
use crate::error::{Error, IoContext, Result};
use crate::raster::{AnyGrid, GeoRef, Grid, MemRaster, Scaling};
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
    read_png(path.as_ref(), Some(Scaling { scale, offset }))
}

/// Read a greyscale PNG heightmap with the mapping `mapping`, or, when
/// None, the one the file records ([`recorded_scaling`]: orogen's `tEXt`
/// chunks, else a GDAL `.aux.xml` sidecar), else the samples as they are.
pub fn read_png(path: &Path, mapping: Option<Scaling>) -> Result<MemRaster> {
    let mapping = match mapping {
        Some(m) => m,
        None => recorded_scaling(path)?.unwrap_or(Scaling {
            scale: 1.0,
            offset: 0.0,
        }),
    };
    let (scale, offset) = (mapping.scale, mapping.offset);
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
/// quantisation error is at most `scale / 2`. The mapping is recorded in
/// the file ([`SCALE_KEY`], [`OFFSET_KEY`] `tEXt` chunks, read back by
/// [`read_png`]) and in a GDAL PAM sidecar `<path>.aux.xml` (band Scale and
/// Offset, so `gdalinfo` reports them and `gdal_translate -unscale` gives
/// metres). Written atomically.
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
    let m = Scaling {
        scale: (max - min) / 65535.0,
        offset: min,
    };
    encode_to(path, grid, m, false)?;
    Ok((m.scale, m.offset))
}

/// `tEXt` keyword of the metres per PNG unit of orogen's heightmaps.
pub const SCALE_KEY: &str = "height_scale";
/// `tEXt` keyword of the elevation of PNG value 0.
pub const OFFSET_KEY: &str = "height_offset";

/// The mapping an output PNG is written with: `given` (either part may be
/// left to the data: the offset to its minimum, the scale to fit its maximum
/// into 65535 units), else the finite range of `grid` ([`finite_range`]).
pub fn output_scaling(grid: &Grid<f32>, scale: Option<f64>, offset: Option<f64>) -> Scaling {
    let (lo, hi) = finite_range(grid);
    let offset = offset.unwrap_or(lo);
    let scale = scale.unwrap_or_else(|| {
        let s = (hi - offset) / 65535.0;
        if s > 0.0 && s.is_finite() {
            s
        } else {
            (hi - lo) / 65535.0
        }
    });
    Scaling { scale, offset }
}

/// Write `grid` as a 16-bit greyscale PNG with sample `v` meaning
/// `offset + v * scale` (see [`write_png16`] for what is recorded). A cell
/// the mapping cannot hold (below `offset` or above `offset + 65535 *
/// scale` by more than half a unit) is an error naming the range and the
/// fix; nothing is written then.
pub fn write_png16_mapped(path: &Path, grid: &Grid<f32>, m: Scaling) -> Result<()> {
    encode_to(path, grid, m, true)
}

/// Quantise `grid` with `m` and write it (with its records); `strict`: a
/// cell outside the mapping's range is an error, else it is clamped.
fn encode_to(path: &Path, grid: &Grid<f32>, m: Scaling, strict: bool) -> Result<()> {
    if !(m.scale.is_finite() && m.scale > 0.0 && m.offset.is_finite()) {
        return Err(Error::invalid(format!(
            "{}: a PNG heightmap needs a finite scale > 0 and a finite offset (got scale {}, offset {})",
            path.display(),
            m.scale,
            m.offset
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
    let (lo, hi) = finite_range(grid);
    let top = m.offset + 65535.0 * m.scale;
    let half = 0.5 * m.scale;
    if strict
        && grid.data().iter().any(|v| v.is_finite())
        && (lo < m.offset - half || hi > top + half)
    {
        return Err(Error::invalid(format!(
            "{}: the values {lo}..{hi} do not fit the PNG mapping (offset {}, scale {}: {}..{top}); give an offset ≤ {lo} and a scale ≥ {:e} (--png-out-offset, --png-out-scale), or leave them to the data",
            path.display(),
            m.offset,
            m.scale,
            m.offset,
            (hi - m.offset.min(lo)) / 65535.0
        )));
    }
    let alpha = grid.data().iter().any(|v| v.is_nan());
    let chans = if alpha { 2 } else { 1 };
    let mut data = Vec::with_capacity(w * h * 2 * chans);
    for &v in grid.data() {
        let (q, a) = if v.is_nan() {
            (0u16, 0u16)
        } else {
            let q = ((v as f64 - m.offset) / m.scale)
                .round()
                .clamp(0.0, 65535.0) as u16;
            (q, 65535u16)
        };
        data.extend_from_slice(&q.to_be_bytes());
        if alpha {
            data.extend_from_slice(&a.to_be_bytes());
        }
    }
    let text = [
        (SCALE_KEY, format!("{:?}", m.scale)),
        (OFFSET_KEY, format!("{:?}", m.offset)),
    ];
    let mut encoded = Vec::new();
    encode_png_text(&mut encoded, w32, h32, alpha_color(alpha), &data, &text)
        .map_err(|e| Error::io(path, std::io::Error::other(e.to_string())))?;
    write_atomic(path, &encoded)?;
    write_atomic(&aux_path(path), pam_sidecar(m).as_bytes())
}

/// The GDAL PAM sidecar of `path` (`<path>.aux.xml`).
pub fn aux_path(path: &Path) -> std::path::PathBuf {
    let mut p = path.as_os_str().to_owned();
    p.push(".aux.xml");
    p.into()
}

/// A PAM dataset whose band 1 has scale and offset `m` (GDAL's
/// `PAMRasterBand` `<Offset>`, `<Scale>`).
fn pam_sidecar(m: Scaling) -> String {
    format!(
        "<PAMDataset>\n  <PAMRasterBand band=\"1\">\n    <Offset>{:?}</Offset>\n    <Scale>{:?}</Scale>\n  </PAMRasterBand>\n</PAMDataset>\n",
        m.offset, m.scale
    )
}

/// The mapping a PNG records: its [`SCALE_KEY`]/[`OFFSET_KEY`] `tEXt`
/// chunks (those before the image data, where orogen writes them), else
/// band 1's Scale/Offset in a GDAL `.aux.xml` sidecar beside it; None when
/// neither is there. A recorded value that is not a finite number is an
/// error naming the file.
pub fn recorded_scaling(path: &Path) -> Result<Option<Scaling>> {
    let f = std::fs::File::open(path).at(path)?;
    let dec = ::png::Decoder::new(BufReader::new(f));
    let reader = dec.read_info().map_err(|e| png_err(path, e))?;
    let (mut scale, mut offset) = (None, None);
    for t in &reader.info().uncompressed_latin1_text {
        let slot = match t.keyword.as_str() {
            SCALE_KEY => &mut scale,
            OFFSET_KEY => &mut offset,
            _ => continue,
        };
        let v = t.text.trim().parse::<f64>().ok().filter(|v| v.is_finite());
        *slot = Some(v.ok_or_else(|| {
            Error::corrupt(
                path,
                format!(
                    "tEXt {} holds {:?}, not a number; pass --png-scale and --png-offset",
                    t.keyword, t.text
                ),
            )
        })?);
    }
    if scale.is_some() || offset.is_some() {
        return Ok(Some(Scaling {
            scale: scale.unwrap_or(1.0),
            offset: offset.unwrap_or(0.0),
        }));
    }
    let aux = aux_path(path);
    match std::fs::read_to_string(&aux) {
        Ok(xml) => Ok(pam_band1(&xml)),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(e) => Err(Error::io(&aux, e)),
    }
}

/// Band 1's `<Scale>` and `<Offset>` in a PAM sidecar's XML (None when it
/// has neither or is not XML).
fn pam_band1(xml: &str) -> Option<Scaling> {
    let doc = roxmltree::Document::parse(xml).ok()?;
    let band = doc
        .descendants()
        .find(|n| n.has_tag_name("PAMRasterBand") && n.attribute("band") == Some("1"))?;
    let value = |tag: &str| -> Option<f64> {
        band.children()
            .find(|n| n.has_tag_name(tag))?
            .text()?
            .trim()
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
    };
    let (scale, offset) = (value("Scale"), value("Offset"));
    (scale.is_some() || offset.is_some()).then(|| Scaling {
        scale: scale.unwrap_or(1.0),
        offset: offset.unwrap_or(0.0),
    })
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
    encode_png_text(out, w, h, color, data, &[])
}

/// [`encode_png`] with `tEXt` chunks (keyword, text) before the image data.
pub(crate) fn encode_png_text(
    out: &mut Vec<u8>,
    w: u32,
    h: u32,
    color: ::png::ColorType,
    data: &[u8],
    text: &[(&str, String)],
) -> std::result::Result<(), ::png::EncodingError> {
    let mut enc = ::png::Encoder::new(out, w, h);
    enc.set_color(color);
    enc.set_depth(match color {
        ::png::ColorType::Grayscale | ::png::ColorType::GrayscaleAlpha => ::png::BitDepth::Sixteen,
        _ => ::png::BitDepth::Eight,
    });
    for (k, v) in text {
        enc.add_text_chunk(k.to_string(), v.clone())?;
    }
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
