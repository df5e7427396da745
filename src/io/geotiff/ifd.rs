//! TIFF image file directories (TIFF 6.0 section 2, BigTIFF as specified by
//! Aware Systems / libtiff): entries with their field types, the directory
//! laid out with its out-of-line values after it, and the GeoTIFF tags of
//! a georeference.

use super::georef::{format_nodata, half_cell_shift, keys_for_write};
use crate::raster::{DType, GeoRef, RasterType};

// TIFF field types.
const SHORT: u16 = 3;
const LONG: u16 = 4;
const ASCII: u16 = 2;
const DOUBLE: u16 = 12;
const LONG8: u16 = 16;

/// One IFD entry before layout: tag, field type, count, little-endian value bytes.
pub(crate) struct Entry {
    pub(super) tag: u16,
    pub(super) typ: u16,
    pub(super) count: u64,
    pub(super) bytes: Vec<u8>,
}

impl Entry {
    pub(super) fn shorts(tag: u16, v: &[u16]) -> Entry {
        Entry {
            tag,
            typ: SHORT,
            count: v.len() as u64,
            bytes: v.iter().flat_map(|x| x.to_le_bytes()).collect(),
        }
    }
    pub(super) fn long(tag: u16, v: u32) -> Entry {
        Entry {
            tag,
            typ: LONG,
            count: 1,
            bytes: v.to_le_bytes().to_vec(),
        }
    }
    pub(super) fn doubles(tag: u16, v: &[f64]) -> Entry {
        Entry {
            tag,
            typ: DOUBLE,
            count: v.len() as u64,
            bytes: v.iter().flat_map(|x| x.to_le_bytes()).collect(),
        }
    }
    pub(super) fn ascii(tag: u16, s: &str) -> Entry {
        let mut bytes = s.as_bytes().to_vec();
        bytes.push(0);
        Entry {
            tag,
            typ: ASCII,
            count: bytes.len() as u64,
            bytes,
        }
    }
    /// Offsets or byte counts: LONG (classic TIFF) or LONG8 (BigTIFF) values.
    pub(super) fn offsets(tag: u16, v: &[u64], bigtiff: bool) -> Entry {
        let bytes: Vec<u8> = if bigtiff {
            v.iter().flat_map(|x| x.to_le_bytes()).collect()
        } else {
            v.iter().flat_map(|x| (*x as u32).to_le_bytes()).collect()
        };
        Entry {
            tag,
            typ: if bigtiff { LONG8 } else { LONG },
            count: v.len() as u64,
            bytes,
        }
    }
    /// `n` zeroed offsets (LONG or LONG8), patched later.
    pub(super) fn placeholder(tag: u16, n: usize, bigtiff: bool) -> Entry {
        let (typ, size) = if bigtiff { (LONG8, 8) } else { (LONG, 4) };
        Entry {
            tag,
            typ,
            count: n as u64,
            bytes: vec![0; n * size],
        }
    }
}

/// Encode one IFD placed at file offset `start`, its out-of-line values
/// following it. Returns the bytes and, per entry (in `entries` order after
/// sorting by tag), the absolute offset of its value bytes.
pub(crate) fn encode_ifd(
    entries: &mut [Entry],
    start: u64,
    bigtiff: bool,
    next_ifd: u64,
) -> (Vec<u8>, Vec<u64>) {
    entries.sort_by_key(|e| e.tag);
    let (count_size, entry_size, inline) = if bigtiff {
        (8u64, 20u64, 8usize)
    } else {
        (2, 12, 4)
    };
    let n = entries.len() as u64;
    let next_size = if bigtiff { 8 } else { 4 };
    let dir_len = count_size + entry_size * n + next_size;
    let mut extra_at = start + dir_len;
    let mut dir = Vec::with_capacity(dir_len as usize);
    let mut extra = Vec::new();
    let mut positions = Vec::with_capacity(entries.len());
    if bigtiff {
        dir.extend_from_slice(&n.to_le_bytes());
    } else {
        dir.extend_from_slice(&(n as u16).to_le_bytes());
    }
    for e in entries.iter() {
        dir.extend_from_slice(&e.tag.to_le_bytes());
        dir.extend_from_slice(&e.typ.to_le_bytes());
        if bigtiff {
            dir.extend_from_slice(&e.count.to_le_bytes());
        } else {
            dir.extend_from_slice(&(e.count as u32).to_le_bytes());
        }
        if e.bytes.len() <= inline {
            positions.push(start + dir.len() as u64);
            let mut v = e.bytes.clone();
            v.resize(inline, 0);
            dir.extend_from_slice(&v);
        } else {
            positions.push(extra_at);
            if bigtiff {
                dir.extend_from_slice(&extra_at.to_le_bytes());
            } else {
                dir.extend_from_slice(&(extra_at as u32).to_le_bytes());
            }
            extra.extend_from_slice(&e.bytes);
            if extra.len() % 2 == 1 {
                extra.push(0); // word alignment (TIFF 6.0 section 2)
            }
            extra_at = start + dir_len + extra.len() as u64;
        }
    }
    if bigtiff {
        dir.extend_from_slice(&next_ifd.to_le_bytes());
    } else {
        dir.extend_from_slice(&(next_ifd as u32).to_le_bytes());
    }
    dir.extend_from_slice(&extra);
    (dir, positions)
}

/// The directory entries of one tiled image (TIFF 6.0, Adobe 1992, sec. 8
/// and 15): size, bits per sample, compression `compression` (its tag code),
/// one sample, chunky planes, square `block` tiles, the tile offsets and
/// byte counts `offsets` and `counts` (tags 324 and 325), the sample format
/// of `dtype`, and the predictor where it is not 1 (none).
#[allow(clippy::too_many_arguments)]
pub(super) fn image_entries(
    width: usize,
    height: usize,
    dtype: DType,
    compression: u16,
    block: usize,
    predictor: u16,
    offsets: Entry,
    counts: Entry,
) -> Vec<Entry> {
    let mut e = vec![
        Entry::long(256, width as u32),
        Entry::long(257, height as u32),
        Entry::shorts(258, &[(dtype.size() * 8) as u16]),
        Entry::shorts(259, &[compression]),
        Entry::shorts(262, &[1]),
        Entry::shorts(277, &[1]),
        Entry::shorts(284, &[1]),
        Entry::long(322, block as u32),
        Entry::long(323, block as u32),
        offsets,
        counts,
        Entry::shorts(
            339,
            &[match dtype {
                DType::F32 | DType::F64 => 3,
                DType::I8 | DType::I16 | DType::I32 => 2,
                _ => 1,
            }],
        ),
    ];
    if predictor != 1 {
        e.push(Entry::shorts(317, &[predictor]));
    }
    e
}

/// GeoTIFF and GDAL tags for `georef` (none when not georeferenced, except
/// GDAL_NODATA which is written whenever there is a nodata value).
pub(super) fn geo_entries(georef: &GeoRef) -> Vec<Entry> {
    let mut out = Vec::new();
    if georef.georeferenced {
        let mut t = georef.transform;
        if georef.raster_type == RasterType::Point {
            half_cell_shift(&mut t, 1.0);
        }
        // ModelPixelScale + ModelTiepoint only for a north-up grid (x
        // growing east, y south); a south-up (positive row step), mirrored
        // or rotated grid gets ModelTransformation, as GDAL writes it
        // (a negative ModelPixelScale is read north-up by GDAL, with a
        // warning).
        if t[2] == 0.0 && t[4] == 0.0 && t[1] > 0.0 && t[5] < 0.0 {
            out.push(Entry::doubles(33550, &[t[1], -t[5], 0.0]));
            out.push(Entry::doubles(33922, &[0.0, 0.0, 0.0, t[0], t[3], 0.0]));
        } else {
            out.push(Entry::doubles(
                34264,
                &[
                    t[1], t[2], 0.0, t[0], t[4], t[5], 0.0, t[3], 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
                    0.0, 1.0,
                ],
            ));
        }
        let keys = keys_for_write(georef);
        if keys.directory.len() > 4 {
            out.push(Entry::shorts(34735, &keys.directory));
        }
        if !keys.doubles.is_empty() {
            out.push(Entry::doubles(34736, &keys.doubles));
        }
        if !keys.ascii.is_empty() {
            out.push(Entry::ascii(34737, &keys.ascii));
        }
    }
    if let Some(nd) = georef.nodata {
        out.push(Entry::ascii(42113, &format_nodata(nd)));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ifd_layout_puts_values_after_the_directory() {
        let mut e = vec![
            Entry::shorts(259, &[1]),
            Entry::long(256, 7),
            Entry::doubles(33550, &[1.0, 2.0, 0.0]),
        ];
        let (bytes, pos) = encode_ifd(&mut e, 8, false, 0);
        // 2 + 3 * 12 + 4 = 42 bytes of directory, then 24 bytes of doubles.
        assert_eq!(bytes.len(), 42 + 24);
        assert_eq!(u16::from_le_bytes([bytes[0], bytes[1]]), 3);
        // Sorted by tag: 256 first, its value inline at 8 + 2 + 8.
        assert_eq!(u16::from_le_bytes([bytes[2], bytes[3]]), 256);
        assert_eq!(pos[0], 8 + 2 + 8);
        assert_eq!(pos[2], 8 + 42);
        let (big, pos) = encode_ifd(&mut e, 16, true, 0);
        assert_eq!(big.len(), 8 + 3 * 20 + 8 + 24);
        assert_eq!(pos[2], 16 + 8 + 60 + 8);
    }
}
