//! Per-dataset masks read as nodata, as GDAL's masked reads do (RFC 15,
//! "Band Masks"; `GDALRasterBand::GetMaskBand`):
//!
//! - an **internal mask**: an IFD after the image with NewSubfileType bit 2
//!   set (and bit 0 clear: not an overview's mask), the image's size, one
//!   bit per cell (PhotometricInterpretation 4, TIFF 6.0 §8), 1 = valid,
//!   FillOrder 1 (most significant bit first) — what GDAL writes with
//!   `GDAL_TIFF_INTERNAL_MASK=YES` (its default since 3.x) for
//!   `gdal_translate -mask` or `CreateMaskBand(GMF_PER_DATASET)`;
//! - an **alpha sample**: ExtraSamples (tag 338) value 1 (associated) or 2
//!   (unassociated alpha). GDAL masks a cell of every other band where alpha
//!   is 0 (its mask for a 16-bit alpha is `alpha >> 8`, at least 1 where
//!   alpha > 0, so 0 exactly where alpha is 0); the alpha band itself is
//!   read unmasked, as GDAL reports it all-valid.
//!
//! The internal mask takes precedence over alpha, as in GDAL. GDAL's mask
//! replaces the nodata value for masked reads; orogen has one nodata value
//! per raster, so a masked cell reads as the declared nodata and, where the
//! file declares none, floats read NaN and integers are presented as f32
//! (≤ 16-bit samples, exact) or f64 (32-bit, exact) with nodata NaN. A cell
//! holding the declared nodata stays nodata even where the mask says valid
//! (GDAL would call it valid): a departure that keeps the declared nodata's
//! meaning.
//!
//! The mask is decoded block by block with the image's block: GDAL writes
//! it with the image's tiling or strips; another layout is refused with a
//! message (GDAL itself never writes one).

use crate::error::{Error, Result};
use crate::raster::DType;
use std::path::Path;

/// Where a raster's mask comes from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum MaskSource {
    /// The IFD at chain position `index` (0 is the image), whose
    /// PhotometricInterpretation value sits at `photometric_at`.
    Ifd { index: usize, photometric_at: u64 },
    /// Sample `sample` (0-based) of each pixel is alpha.
    Alpha { sample: usize },
}

/// The type a masked raster is presented as, and the value a masked cell
/// reads as: see the module documentation.
pub(super) fn presented(native: DType, nodata: Option<f64>) -> (DType, f64) {
    match (native, nodata) {
        (_, Some(v)) => (native, v),
        (DType::F32 | DType::F64, None) => (native, f64::NAN),
        (DType::U32 | DType::I32, None) => (DType::F64, f64::NAN),
        (_, None) => (DType::F32, f64::NAN),
    }
}

/// Convert a block of `native` little-endian cells into `out` cells,
/// masked ones (where `valid` is false) set to `fill`.
pub(super) fn apply(native: DType, out: DType, fill: f64, block: &[u8], valid: &[bool]) -> Vec<u8> {
    let (size, out_size) = (native.size(), out.size());
    let mut dst = vec![0u8; valid.len() * out_size];
    let fill = encode(out, fill);
    for ((&ok, c), d) in valid
        .iter()
        .zip(block.chunks_exact(size))
        .zip(dst.chunks_exact_mut(out_size))
    {
        if !ok {
            d.copy_from_slice(&fill[..out_size]);
        } else if out == native {
            d.copy_from_slice(c);
        } else {
            d.copy_from_slice(&encode(out, decode(native, c))[..out_size]);
        }
    }
    dst
}

/// One little-endian cell of `t` as f64.
fn decode(t: DType, c: &[u8]) -> f64 {
    match t {
        DType::U8 => c[0] as f64,
        DType::I8 => c[0] as i8 as f64,
        DType::U16 => u16::from_le_bytes([c[0], c[1]]) as f64,
        DType::I16 => i16::from_le_bytes([c[0], c[1]]) as f64,
        DType::U32 => u32::from_le_bytes([c[0], c[1], c[2], c[3]]) as f64,
        DType::I32 => i32::from_le_bytes([c[0], c[1], c[2], c[3]]) as f64,
        DType::F32 => f32::from_le_bytes([c[0], c[1], c[2], c[3]]) as f64,
        DType::F64 => f64::from_le_bytes([c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]]),
    }
}

/// `v` as one little-endian cell of `t` (saturating, as `as` casts do):
/// the first `t.size()` bytes.
pub(super) fn encode(t: DType, v: f64) -> [u8; 8] {
    let mut b = [0u8; 8];
    match t {
        DType::U8 => b[0] = v as u8,
        DType::I8 => b[0] = v as i8 as u8,
        DType::U16 => b[..2].copy_from_slice(&(v as u16).to_le_bytes()),
        DType::I16 => b[..2].copy_from_slice(&(v as i16).to_le_bytes()),
        DType::U32 => b[..4].copy_from_slice(&(v as u32).to_le_bytes()),
        DType::I32 => b[..4].copy_from_slice(&(v as i32).to_le_bytes()),
        DType::F32 => b[..4].copy_from_slice(&(v as f32).to_le_bytes()),
        DType::F64 => b = v.to_le_bytes(),
    }
    b
}

/// The validity of a `w` x `h` window from a decoded 1-bit mask chunk
/// whose rows are `stride` bytes apart (most significant bit first).
pub(super) fn bits(
    path: &Path,
    raw: &[u8],
    stride: usize,
    w: usize,
    h: usize,
) -> Result<Vec<bool>> {
    if raw.len() < (h.saturating_sub(1)) * stride + w.div_ceil(8) {
        return Err(Error::corrupt(
            path,
            "the internal mask's block decoded to fewer bytes than its size",
        ));
    }
    let mut v = Vec::with_capacity(w * h);
    for r in 0..h {
        let row = &raw[r * stride..];
        v.extend((0..w).map(|x| row[x / 8] >> (7 - x % 8) & 1 == 1));
    }
    Ok(v)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn masked_cells_take_the_nodata_or_nan_and_integers_widen_exactly() {
        assert_eq!(
            presented(DType::I16, Some(-32768.0)),
            (DType::I16, -32768.0)
        );
        assert_eq!(presented(DType::U8, None).0, DType::F32);
        assert_eq!(presented(DType::I32, None).0, DType::F64);
        assert!(presented(DType::F32, None).1.is_nan());
        let block: Vec<u8> = [-7i16, 300, i16::MIN]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        let out = apply(
            DType::I16,
            DType::F32,
            f64::NAN,
            &block,
            &[true, false, true],
        );
        let got: Vec<f32> = out
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        assert_eq!(got[0], -7.0);
        assert!(got[1].is_nan());
        assert_eq!(got[2], -32768.0);
    }

    #[test]
    fn mask_bits_are_read_most_significant_first() {
        // Two rows of 10 cells, rows 2 bytes apart: 1011_0000 01.., 0000_0001 1...
        let raw = [0b1011_0000, 0b0100_0000, 0b0000_0001, 0b1000_0000];
        let v = bits(Path::new("m.tif"), &raw, 2, 10, 2).unwrap();
        let ones: Vec<usize> = (0..20).filter(|&k| v[k]).collect();
        assert_eq!(ones, [0, 2, 3, 9, 17, 18]);
        assert!(bits(Path::new("m.tif"), &raw[..3], 2, 10, 2).is_err());
    }
}
