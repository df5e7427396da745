//! SRTM `.hgt` tiles: headerless big-endian 16-bit signed elevations, one
//! square degree per file, named after the south-west corner (`N43E006.hgt`).
//!
//! Format facts (NASA/USGS SRTM documentation, "SRTM Topography" readme):
//! rows run north to south, columns west to east; 3" tiles are 1201 x 1201,
//! 1" tiles 3601 x 3601 (and 1801 x 3601 above 50° in some 1" products);
//! voids are -32768. The edge rows and columns are shared with the
//! neighbouring tiles, so cell centres lie on whole degrees and the raster's
//! outer corner is half a cell beyond the degree square — which is how GDAL's
//! SRTMHGT driver georeferences it. We store that transform in the area
//! convention (`RasterType::Area`).

use crate::error::{Error, IoContext, Result};
use crate::raster::{AnyGrid, Crs, GeoRef, Grid, MemRaster};
use std::io::Read;
use std::path::Path;

/// Void (nodata) value of SRTM tiles.
pub const HGT_NODATA: i16 = -32768;

/// Accepted (columns, rows) of a `.hgt` file.
const SIZES: [(usize, usize); 3] = [(1201, 1201), (3601, 3601), (1801, 3601)];

/// Parse the south-west corner (lat, lon) in whole degrees from a file name
/// such as `N43E006.hgt` or `s33w071.SRTMGL1.hgt` (case-insensitive; S and W
/// are negative). The name must start with the 7-character pattern.
pub fn parse_hgt_name(name: &str) -> Option<(i32, i32)> {
    let b = name.as_bytes();
    if b.len() < 7 {
        return None;
    }
    let lat_sign = match b[0].to_ascii_uppercase() {
        b'N' => 1,
        b'S' => -1,
        _ => return None,
    };
    let lon_sign = match b[3].to_ascii_uppercase() {
        b'E' => 1,
        b'W' => -1,
        _ => return None,
    };
    let digits = |s: &[u8]| -> Option<i32> {
        let mut v = 0i32;
        for &c in s {
            if !c.is_ascii_digit() {
                return None;
            }
            v = v * 10 + (c - b'0') as i32;
        }
        Some(v)
    };
    let lat = digits(&b[1..3])?;
    let lon = digits(&b[4..7])?;
    // The character after the pattern must end it (no "N43E0067").
    if b.len() > 7 && b[7].is_ascii_alphanumeric() {
        return None;
    }
    if lat > 90 || lon > 180 {
        return None;
    }
    Some((lat_sign * lat, lon_sign * lon))
}

/// The georeference of a `.hgt` tile whose south-west cell centre is
/// (`lat`, `lon`), with `cols` x `rows` cells: EPSG:4326, cell size
/// 1/(cols-1) by 1/(rows-1) degrees, top-left corner half a cell west and north
/// of (lon, lat + 1). Nodata -32768.
pub fn hgt_georef(lat: i32, lon: i32, cols: usize, rows: usize) -> GeoRef {
    let dx = 1.0 / (cols as f64 - 1.0);
    let dy = 1.0 / (rows as f64 - 1.0);
    let mut g = GeoRef::north_up(
        lon as f64 - dx / 2.0,
        lat as f64 + 1.0 + dy / 2.0,
        dx,
        Crs::wgs84(),
    );
    g.transform[5] = -dy;
    g.with_nodata(Some(HGT_NODATA as f64))
}

/// Read an SRTM `.hgt` file into memory as i16 with its georeference.
///
/// The size comes from the file length (1201², 3601² or 1801x3601 cells of 2
/// bytes); the corner from the file name. Any other length, or a name not
/// matching `[NS]dd[EW]ddd`, is an error saying what is accepted.
pub fn read_hgt(path: impl AsRef<Path>) -> Result<MemRaster> {
    let path = path.as_ref();
    let name = path
        .file_name()
        .and_then(|n| n.to_str())
        .ok_or_else(|| Error::invalid(format!("{}: not a file name", path.display())))?;
    let (lat, lon) = parse_hgt_name(name).ok_or_else(|| {
        Error::unsupported(
            path,
            "an SRTM .hgt file must be named after its south-west corner, \
             [N|S]dd[E|W]ddd.hgt (e.g. N43E006.hgt); rename the file",
        )
    })?;
    let mut f = std::fs::File::open(path).at(path)?;
    let len = f.metadata().at(path)?.len();
    let (cols, rows) = SIZES
        .iter()
        .copied()
        .find(|&(c, r)| (c * r * 2) as u64 == len)
        .ok_or_else(|| {
            Error::corrupt(
                path,
                format!(
                    "file is {len} bytes; an SRTM .hgt file holds 1201x1201 (2884802 bytes, 3\"), \
                     3601x3601 (25934402 bytes, 1\") or 1801x3601 (12967202 bytes) big-endian \
                     16-bit cells; the file is truncated or not a .hgt"
                ),
            )
        })?;
    let mut bytes = vec![0u8; cols * rows * 2];
    f.read_exact(&mut bytes).at(path)?;
    let data: Vec<i16> = bytes
        .chunks_exact(2)
        .map(|c| i16::from_be_bytes([c[0], c[1]]))
        .collect();
    let grid = Grid::from_vec(cols, rows, data)?;
    Ok(MemRaster::new(
        AnyGrid::I16(grid),
        hgt_georef(lat, lon, cols, rows),
        path,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names() {
        assert_eq!(parse_hgt_name("N43E006.hgt"), Some((43, 6)));
        assert_eq!(parse_hgt_name("s33w071.HGT"), Some((-33, -71)));
        assert_eq!(parse_hgt_name("S01W180.SRTMGL1.hgt"), Some((-1, -180)));
        assert_eq!(parse_hgt_name("N43E0067.hgt"), None);
        assert_eq!(parse_hgt_name("X43E006.hgt"), None);
        assert_eq!(parse_hgt_name("N91E006.hgt"), None);
        assert_eq!(parse_hgt_name("N4E006"), None);
    }
}
