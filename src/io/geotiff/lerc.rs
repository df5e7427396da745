//! LERC-compressed GeoTIFF blocks (TIFF Compression 34887, Esri's Limited
//! Error Raster Compression, as GDAL writes it: `COMPRESS=LERC`,
//! `LERC_DEFLATE`, `LERC_ZSTD`). The `tiff` crate does not decode LERC, so
//! the reader reads a block's bytes itself, undoes the additional
//! compression named by the LercParameters tag (50674: `[LERC version,
//! additional compression 0 none / 1 DEFLATE (zlib) / 2 ZSTD]`, GDAL's
//! `tif_lerc.c` convention) and decodes the LERC2 blob with the pure-Rust
//! `lerc-rs` codec (byte-compatible with Esri's reference library).
//!
//! A block holds all samples of a pixel-interleaved file as the blob's
//! depth (one plane of a band-interleaved one). Cells the blob marks
//! invalid (GDAL writes the nodata cells so) read as the declared nodata,
//! NaN for floats without one, 0 for integers without one, as GDAL fills
//! them.

use crate::error::{Error, Result};
use crate::raster::DType;
use std::io::Read;
use std::path::Path;

/// The additional compression of a LERC block.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Additional {
    None,
    Deflate,
    Zstd,
}

/// The additional compression from LercParameters (absent: none).
pub(super) fn additional(path: &Path, params: Option<&[u64]>) -> Result<Additional> {
    match params.and_then(|p| p.get(1)).copied().unwrap_or(0) {
        0 => Ok(Additional::None),
        1 => Ok(Additional::Deflate),
        2 => Ok(Additional::Zstd),
        v => Err(Error::unsupported(
            path,
            format!("LERC with additional compression {v} (LercParameters); orogen reads none (0), DEFLATE (1) and ZSTD (2)"),
        )),
    }
}

/// Decode one LERC block of `w` x `h` pixels of `samples` samples of type
/// `dtype` from its stored bytes into native-endian rows of `w * samples`
/// cells, invalid cells set to `fill`. `max_bytes` bounds the decompressed
/// blob and the decoded block.
#[allow(clippy::too_many_arguments)]
pub(super) fn decode_block(
    path: &Path,
    stored: &[u8],
    additional: Additional,
    dtype: DType,
    (w, h, samples): (usize, usize, usize),
    fill: f64,
    max_bytes: usize,
) -> Result<Vec<u8>> {
    let corrupt = |what: String| Error::corrupt(path, format!("LERC block: {what}"));
    let inflated;
    let blob: &[u8] = match additional {
        Additional::None => stored,
        Additional::Deflate => {
            let mut out = Vec::new();
            flate2::read::ZlibDecoder::new(stored)
                .take(max_bytes as u64 + 1)
                .read_to_end(&mut out)
                .map_err(|e| corrupt(format!("DEFLATE layer: {e}")))?;
            inflated = out;
            &inflated
        }
        Additional::Zstd => {
            let mut out = Vec::new();
            zstd::stream::read::Decoder::new(stored)
                .map_err(|e| corrupt(format!("ZSTD layer: {e}")))?
                .take(max_bytes as u64 + 1)
                .read_to_end(&mut out)
                .map_err(|e| corrupt(format!("ZSTD layer: {e}")))?;
            inflated = out;
            &inflated
        }
    };
    if blob.len() > max_bytes {
        return Err(corrupt(format!("decompresses past {max_bytes} bytes")));
    }
    let info = lerc::decode_info(blob).map_err(|e| corrupt(e.to_string()))?;
    let (bw, bh, depth, bands) = (
        info.width as usize,
        info.height as usize,
        info.depth as usize,
        info.bands as usize,
    );
    if (bw, bh) != (w, h) || depth * bands != samples {
        return Err(corrupt(format!(
            "holds {bw} x {bh} pixels of {} samples, the block is {w} x {h} of {samples}",
            depth * bands
        )));
    }
    let image = lerc::decode(blob).map_err(|e| corrupt(e.to_string()))?;
    let n = w * h * samples;
    let mut out = Vec::with_capacity(n * dtype.size());
    macro_rules! cells {
        ($v:expr, $t:ty, $want:expr) => {{
            if dtype != $want {
                return Err(corrupt(format!(
                    "holds {} samples, the file declares {}",
                    $want.name(),
                    dtype.name()
                )));
            }
            let v: &[$t] = $v;
            if v.len() < n {
                return Err(corrupt(format!("decoded {} of {n} samples", v.len())));
            }
            let fill = fill as $t;
            for (k, &x) in v[..n].iter().enumerate() {
                // Depth is the fastest axis; bands (if several) follow
                // each other, each with its own mask.
                let (band, pixel) = if bands > 1 {
                    (k / (w * h), k % (w * h))
                } else {
                    (0, k / depth)
                };
                let ok = image
                    .valid_masks
                    .get(band)
                    .is_none_or(|m| m.is_valid(pixel));
                out.extend_from_slice(&(if ok { x } else { fill }).to_ne_bytes());
            }
        }};
    }
    match &image.data {
        lerc::SampleData::U8(v) => cells!(v, u8, DType::U8),
        lerc::SampleData::I8(v) => cells!(v, i8, DType::I8),
        lerc::SampleData::U16(v) => cells!(v, u16, DType::U16),
        lerc::SampleData::I16(v) => cells!(v, i16, DType::I16),
        lerc::SampleData::U32(v) => cells!(v, u32, DType::U32),
        lerc::SampleData::I32(v) => cells!(v, i32, DType::I32),
        lerc::SampleData::F32(v) => cells!(v, f32, DType::F32),
        lerc::SampleData::F64(v) => cells!(v, f64, DType::F64),
    }
    if bands > 1 {
        // Band-sequential blob to pixel-interleaved rows.
        let size = dtype.size();
        let mut px = vec![0u8; out.len()];
        for b in 0..bands {
            for p in 0..w * h {
                let from = (b * w * h + p) * size;
                let to = (p * bands + b) * size;
                px[to..to + size].copy_from_slice(&out[from..from + size]);
            }
        }
        out = px;
    }
    Ok(out)
}
