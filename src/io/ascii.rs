//! ESRI ASCII grids (`.asc`, "Arc/Info ASCII Grid").
//!
//! Format (ESRI ArcGIS documentation, "Esri ASCII raster format"): a header of
//! `key value` lines — `ncols`, `nrows`, `xllcorner`|`xllcenter`,
//! `yllcorner`|`yllcenter`, `cellsize` (GDAL also writes and reads `dx`/`dy`
//! for non-square cells), optional `NODATA_value` — in any order and any case,
//! then `ncols * nrows` whitespace-separated values, row by row from the north.
//!
//! Choices made here (documented because the format leaves them open):
//! - **Data type**: i32 when every value is written as an integer (no `.`, no
//!   exponent, no NaN) and fits i32; otherwise f32; f64 only when some value is
//!   written with more than 9 significant digits (9 digits round-trip any f32,
//!   so longer text means the writer had double-precision data).
//! - **Decimal commas** (`xllcorner 2,5`, `12,75`) read as points, as GDAL does.
//! - **Nodata**: `NODATA_value` if given; `nan` text is accepted and is nodata
//!   in the float types.
//! - **CRS**: unknown (not geographic, EPSG none) unless a `.prj` beside the
//!   file holds a `GEOGCS` WKT without `PROJCS`; it is then geographic, and
//!   EPSG:4326 when the WKT names WGS 84. Projected `.prj` files are not
//!   interpreted (the CRS stays unknown, units taken as metres).
//! - The whole file is read into memory (ASCII grids are small by nature);
//!   files over [`MAX_ASCII_BYTES`] are refused.

use crate::error::{Error, IoContext, Result};
use crate::raster::{AnyGrid, Cell, Crs, DType, GeoRef, Grid, MemRaster};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Largest ASCII grid read (4 GiB): beyond it, convert to GeoTIFF first.
pub const MAX_ASCII_BYTES: u64 = 4 << 30;

/// Nodata written by [`write_ascii`] for float grids without a nodata value
/// that contain NaN cells.
pub const DEFAULT_ASCII_NODATA: f64 = -9999.0;

/// Whitespace-separated tokens of a byte slice, with their start offsets.
struct Tokens<'a> {
    b: &'a [u8],
    pos: usize,
}

impl<'a> Tokens<'a> {
    fn new(b: &'a [u8]) -> Self {
        Tokens { b, pos: 0 }
    }
    fn peek(&self) -> Option<&'a [u8]> {
        let mut t = Tokens {
            b: self.b,
            pos: self.pos,
        };
        t.next()
    }
}

impl<'a> Iterator for Tokens<'a> {
    type Item = &'a [u8];
    #[inline]
    fn next(&mut self) -> Option<&'a [u8]> {
        let b = self.b;
        let mut i = self.pos;
        while i < b.len() && b[i].is_ascii_whitespace() {
            i += 1;
        }
        if i == b.len() {
            self.pos = i;
            return None;
        }
        let s = i;
        while i < b.len() && !b[i].is_ascii_whitespace() {
            i += 1;
        }
        self.pos = i;
        Some(&b[s..i])
    }
}

/// How a value token is written.
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Kind {
    /// Integer text fitting i32.
    Int,
    /// Float text representable as f32 without losing written digits.
    F32,
    /// Float text with more than 9 significant digits.
    F64,
}

/// Parse one value token: its f64 value and how it is written. A decimal
/// comma (`12,5`, written by software in locales that use one) is read as
/// a decimal point, as GDAL's AAIGrid driver does.
#[inline]
fn classify(t: &[u8]) -> Option<(f64, Kind)> {
    if t.contains(&b',') && !t.contains(&b'.') {
        let dotted: Vec<u8> = t
            .iter()
            .map(|&c| if c == b',' { b'.' } else { c })
            .collect();
        return classify(&dotted);
    }
    let s = std::str::from_utf8(t).ok()?;
    let digits = s.strip_prefix(['-', '+']).unwrap_or(s);
    if !digits.is_empty() && digits.bytes().all(|c| c.is_ascii_digit()) {
        if let Ok(v) = s.parse::<i64>() {
            if v >= i32::MIN as i64 && v <= i32::MAX as i64 {
                return Some((v as f64, Kind::Int));
            }
        }
    }
    let v: f64 = s.parse().ok()?;
    if v.is_infinite() {
        return None;
    }
    // Significant digits of the mantissa: strip exponent, sign, point,
    // leading zeros and trailing zeros of the fraction.
    let mant = digits.split(['e', 'E']).next().unwrap_or("");
    let mant = if mant.contains('.') {
        mant.trim_end_matches('0')
    } else {
        mant
    };
    let sig = mant
        .bytes()
        .filter(|c| c.is_ascii_digit())
        .skip_while(|&c| c == b'0')
        .count();
    Some((v, if sig > 9 { Kind::F64 } else { Kind::F32 }))
}

/// Parsed header.
struct Header {
    ncols: usize,
    nrows: usize,
    transform: [f64; 6],
    nodata: Option<f64>,
}

fn parse_header(path: &Path, toks: &mut Tokens) -> Result<Header> {
    let mut ncols = None;
    let mut nrows = None;
    let (mut xll, mut yll) = (None, None);
    let (mut xcenter, mut ycenter) = (false, false);
    let (mut cellsize, mut dx, mut dy) = (None, None, None);
    let mut nodata = None;
    while let Some(key) = toks.peek() {
        let key = String::from_utf8_lossy(key).to_ascii_lowercase();
        let known = matches!(
            key.as_str(),
            "ncols"
                | "nrows"
                | "xllcorner"
                | "xllcenter"
                | "yllcorner"
                | "yllcenter"
                | "cellsize"
                | "dx"
                | "dy"
                | "nodata_value"
        );
        if !known {
            break;
        }
        toks.next();
        let val = toks
            .next()
            .ok_or_else(|| Error::corrupt(path, format!("header key `{key}` has no value")))?;
        let text = String::from_utf8_lossy(val);
        let num: f64 = text.replace(',', ".").parse().map_err(|_| {
            Error::corrupt(
                path,
                format!("header `{key}` value `{text}` is not a number"),
            )
        })?;
        let count = |v: f64| -> Result<usize> {
            if v.fract() == 0.0 && v >= 1.0 && v <= u32::MAX as f64 {
                Ok(v as usize)
            } else {
                Err(Error::corrupt(
                    path,
                    format!("header `{key}` must be a positive integer, got `{text}`"),
                ))
            }
        };
        match key.as_str() {
            "ncols" => ncols = Some(count(num)?),
            "nrows" => nrows = Some(count(num)?),
            "xllcorner" | "xllcenter" => {
                xll = Some(num);
                xcenter = key == "xllcenter";
            }
            "yllcorner" | "yllcenter" => {
                yll = Some(num);
                ycenter = key == "yllcenter";
            }
            "cellsize" => cellsize = Some(num),
            "dx" => dx = Some(num),
            "dy" => dy = Some(num),
            _ => nodata = Some(num),
        }
    }
    let missing = |k: &str| {
        Error::corrupt(
            path,
            format!("ESRI ASCII header lacks `{k}` (needs ncols, nrows, xllcorner|xllcenter, yllcorner|yllcenter, cellsize)"),
        )
    };
    let ncols = ncols.ok_or_else(|| missing("ncols"))?;
    let nrows = nrows.ok_or_else(|| missing("nrows"))?;
    let xll = xll.ok_or_else(|| missing("xllcorner"))?;
    let yll = yll.ok_or_else(|| missing("yllcorner"))?;
    let (cx, cy) = match (cellsize, dx, dy) {
        (Some(c), _, _) => (c, c),
        (None, Some(x), Some(y)) => (x, y),
        _ => return Err(missing("cellsize")),
    };
    for (k, v) in [
        ("cellsize/dx", cx),
        ("cellsize/dy", cy),
        ("xll", xll),
        ("yll", yll),
    ] {
        if !v.is_finite() {
            return Err(Error::corrupt(path, format!("header `{k}` is not finite")));
        }
    }
    if cx <= 0.0 || cy <= 0.0 {
        return Err(Error::corrupt(path, "cell size must be positive"));
    }
    let x0 = if xcenter { xll - cx / 2.0 } else { xll };
    let ybottom = if ycenter { yll - cy / 2.0 } else { yll };
    let y0 = ybottom + nrows as f64 * cy;
    Ok(Header {
        ncols,
        nrows,
        transform: [x0, cx, 0.0, y0, 0.0, -cy],
        nodata,
    })
}

/// The CRS a `.prj` beside `path` declares, as far as this reader interprets it.
fn crs_from_prj(path: &Path) -> Crs {
    for ext in ["prj", "PRJ"] {
        let prj = path.with_extension(ext);
        // A .prj is small; anything large is not one.
        let Ok(meta) = std::fs::metadata(&prj) else {
            continue;
        };
        if meta.len() > 64 * 1024 {
            continue;
        }
        let Ok(text) = std::fs::read_to_string(&prj) else {
            continue;
        };
        let up = text.to_ascii_uppercase();
        if up.contains("GEOGCS") && !up.contains("PROJCS") {
            let wgs84 = up.contains("WGS_1984") || up.contains("WGS 84") || up.contains("WGS84");
            let mut c = Crs::wgs84();
            if !wgs84 {
                c.epsg = None;
            }
            return c;
        }
        return Crs::default();
    }
    Crs::default()
}

/// Read an ESRI ASCII grid into memory (see the module doc for the data type,
/// nodata and CRS rules).
pub fn read_ascii(path: impl AsRef<Path>) -> Result<MemRaster> {
    let path = path.as_ref();
    let len = std::fs::metadata(path).at(path)?.len();
    if len > MAX_ASCII_BYTES {
        return Err(Error::too_large(
            path,
            format!("ASCII grid of {len} bytes exceeds the 4 GiB limit; convert it to GeoTIFF"),
        ));
    }
    let bytes = std::fs::read(path).at(path)?;
    let mut toks = Tokens::new(&bytes);
    let h = parse_header(path, &mut toks)?;
    let n = h.ncols.checked_mul(h.nrows).ok_or_else(|| {
        Error::too_large(path, format!("{} x {} cells overflow", h.ncols, h.nrows))
    })?;
    let body = (bytes.len() - toks.pos) as u64;
    // Every value needs at least one character and one separator.
    if (n as u64).saturating_mul(2) > body + 1 {
        return Err(Error::corrupt(
            path,
            format!(
                "header declares {} x {} = {n} values but only {body} bytes follow it \
                 (each value needs at least 2); the file is truncated or the header is wrong",
                h.ncols, h.nrows
            ),
        ));
    }
    let body_start = toks.pos;
    // Pass 1: validate, count and choose the data type (no allocation).
    let mut kind = Kind::Int;
    let mut count = 0usize;
    for t in (Tokens {
        b: &bytes,
        pos: body_start,
    }) {
        let (v, k) = classify(t).ok_or_else(|| {
            let (r, c) = (count / h.ncols, count % h.ncols);
            Error::corrupt(
                path,
                format!(
                    "value {count} (row {r}, column {c}) `{}` is not a number",
                    String::from_utf8_lossy(&t[..t.len().min(40)])
                ),
            )
        })?;
        let k = if v.is_nan() && k == Kind::Int {
            Kind::F32
        } else {
            k
        };
        kind = kind.max(k);
        count += 1;
    }
    if count != n {
        return Err(Error::corrupt(
            path,
            format!(
                "expected {n} values ({} columns x {} rows), found {count}",
                h.ncols, h.nrows
            ),
        ));
    }
    // Pass 2: parse into the chosen type.
    fn fill<T: Cell>(bytes: &[u8], start: usize, n: usize) -> Vec<T> {
        let mut v = Vec::with_capacity(n);
        for t in (Tokens {
            b: bytes,
            pos: start,
        }) {
            // Pass 1 proved every token parses.
            v.push(T::from_f64(classify(t).map_or(f64::NAN, |(x, _)| x)));
        }
        v
    }
    let (w, hgt) = (h.ncols, h.nrows);
    let (grid, nodata) = match kind {
        Kind::Int => (
            AnyGrid::I32(Grid::from_vec(w, hgt, fill::<i32>(&bytes, body_start, n))?),
            h.nodata.filter(|&v| DType::I32.represents(v)),
        ),
        Kind::F32 => (
            AnyGrid::F32(Grid::from_vec(w, hgt, fill::<f32>(&bytes, body_start, n))?),
            h.nodata.map(|v| v as f32 as f64),
        ),
        Kind::F64 => (
            AnyGrid::F64(Grid::from_vec(w, hgt, fill::<f64>(&bytes, body_start, n))?),
            h.nodata,
        ),
    };
    let georef = GeoRef {
        transform: h.transform,
        crs: crs_from_prj(path),
        nodata,
        raster_type: Default::default(),
        georeferenced: true,
    };
    Ok(MemRaster::new(grid, georef, path))
}

/// ESRI WKT of WGS 84 written to the `.prj` of geographic EPSG:4326 grids.
const WGS84_PRJ: &str = "GEOGCS[\"GCS_WGS_1984\",DATUM[\"D_WGS_1984\",SPHEROID[\"WGS_1984\",6378137.0,298.257223563]],PRIMEM[\"Greenwich\",0.0],UNIT[\"Degree\",0.0174532925199433]]";

/// Write `grid` as an ESRI ASCII grid (atomically: a temporary file renamed
/// into place). The transform must be north-up (ASCII grids cannot express
/// rotation); square cells are written as `cellsize`, others as `dx`/`dy`.
/// Without georeferencing the grid is written with its corner at (0, 0).
/// Float NaN cells are written as the nodata value (the georef's, or
/// [`DEFAULT_ASCII_NODATA`]); floats use the shortest text that reads back to
/// the same value. A `.prj` is written for EPSG:4326.
pub fn write_ascii(path: impl AsRef<Path>, grid: &AnyGrid, georef: &GeoRef) -> Result<()> {
    let path = path.as_ref();
    let t = georef.transform;
    if !georef.is_north_up() || (georef.georeferenced && t[5] >= 0.0) {
        return Err(Error::invalid(format!(
            "{}: an ESRI ASCII grid needs a north-up transform without rotation",
            path.display()
        )));
    }
    let (cx, cy) = (t[1].abs(), t[5].abs());
    let (x0, yll) = if georef.georeferenced {
        (t[0], t[3] + grid.height() as f64 * t[5])
    } else {
        (0.0, 0.0)
    };
    let has_nan = match grid {
        AnyGrid::F32(g) => g.data().iter().any(|v| v.is_nan()),
        AnyGrid::F64(g) => g.data().iter().any(|v| v.is_nan()),
        _ => false,
    };
    let nodata = georef.nodata.filter(|v| !v.is_nan()).or(if has_nan {
        Some(DEFAULT_ASCII_NODATA)
    } else {
        None
    });

    let tmp = tmp_path(path);
    let res = (|| -> std::io::Result<()> {
        let f = std::fs::File::create(&tmp)?;
        let mut w = std::io::BufWriter::new(f);
        writeln!(w, "ncols        {}", grid.width())?;
        writeln!(w, "nrows        {}", grid.height())?;
        writeln!(w, "xllcorner    {x0}")?;
        writeln!(w, "yllcorner    {yll}")?;
        if cx == cy {
            writeln!(w, "cellsize     {cx}")?;
        } else {
            writeln!(w, "dx           {cx}")?;
            writeln!(w, "dy           {cy}")?;
        }
        let nd_text = nodata.map(|v| {
            if grid.dtype().is_float() {
                format!("{v:?}")
            } else {
                format!("{}", v as i64)
            }
        });
        if let Some(s) = &nd_text {
            writeln!(w, "NODATA_value {s}")?;
        }
        let nd = nd_text.unwrap_or_else(|| "nan".into());
        let mut line = String::new();
        crate::dispatch_any!(grid, g => {
            for y in 0..g.height() {
                line.clear();
                for (i, v) in g.row(y).iter().enumerate() {
                    if i > 0 {
                        line.push(' ');
                    }
                    if v.is_nan() {
                        line.push_str(&nd);
                    } else {
                        use std::fmt::Write as _;
                        let _ = write!(line, "{v:?}");
                    }
                }
                line.push('\n');
                w.write_all(line.as_bytes())?;
            }
        });
        w.flush()?;
        w.get_ref().sync_all()?;
        Ok(())
    })();
    if let Err(e) = res {
        let _ = std::fs::remove_file(&tmp);
        return Err(Error::io(path, e));
    }
    std::fs::rename(&tmp, path).at(path)?;
    if georef.crs.geographic && georef.crs.epsg == Some(4326) {
        std::fs::write(path.with_extension("prj"), WGS84_PRJ).at(path.with_extension("prj"))?;
    }
    Ok(())
}

/// A temporary name beside `path` for atomic writes.
pub(crate) fn tmp_path(path: &Path) -> PathBuf {
    let mut name = path.file_name().unwrap_or_default().to_os_string();
    name.push(format!(".tmp{}", std::process::id()));
    path.with_file_name(name)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn classify_tokens() {
        assert!(classify(b"12").is_some_and(|(v, k)| v == 12.0 && k == Kind::Int));
        assert!(classify(b"-7").is_some_and(|(v, k)| v == -7.0 && k == Kind::Int));
        assert!(classify(b"1.5").is_some_and(|(v, k)| v == 1.5 && k == Kind::F32));
        assert!(classify(b"1234.56789").is_some_and(|(_, k)| k == Kind::F32));
        assert!(classify(b"1234.567890000").is_some_and(|(_, k)| k == Kind::F32));
        assert!(classify(b"1234.5678901").is_some_and(|(_, k)| k == Kind::F64));
        assert!(classify(b"0.000123456789").is_some_and(|(_, k)| k == Kind::F32));
        assert!(classify(b"1e3").is_some_and(|(v, k)| v == 1000.0 && k == Kind::F32));
        assert!(classify(b"3000000000").is_some_and(|(_, k)| k == Kind::F64));
        assert!(classify(b"nan").is_some_and(|(v, _)| v.is_nan()));
        assert!(classify(b"12a").is_none());
        assert!(classify(b"inf").is_none());
        assert!(classify(b"12,75").is_some_and(|(v, k)| v == 12.75 && k == Kind::F32));
        assert!(classify(b"1,2,3").is_none());
    }

    #[test]
    fn decimal_commas_read_as_points() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("comma.asc");
        std::fs::write(
            &p,
            "ncols 3\nnrows 2\nxllcorner 2,5\nyllcorner 10\ncellsize 0,5\nNODATA_value -9999\n1,25 2 3\n4 -9999 6,5\n",
        )
        .unwrap();
        let r = read_ascii(&p).unwrap();
        use crate::raster::RasterSource;
        let (w, h) = (r.info().width, r.info().height);
        let g: Grid<f32> =
            crate::raster::read_window(&r, crate::raster::Window::full(w, h)).unwrap();
        assert_eq!(g.data()[0], 1.25);
        assert_eq!(g.data()[5], 6.5);
        assert!(g.data()[4].is_nan());
        let t = r.info().georef.transform;
        assert_eq!((t[0], t[1], t[3]), (2.5, 0.5, 11.0));
    }
}
