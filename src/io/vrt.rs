//! GDAL virtual rasters (`.vrt`) read as the mosaic of their sources, the
//! way `gdalbuildvrt` writes them for DEM tile sets.
//!
//! Implements the subset of the GDAL VRT format
//! (<https://gdal.org/drivers/raster/vrt.html>) that `gdalbuildvrt` writes
//! for tiles at one resolution:
//! - `VRTDataset` `rasterXSize` / `rasterYSize`, its `GeoTransform` (absent:
//!   pixel coordinates) and `SRS` (WKT 1 or 2, or `EPSG:n`; the EPSG code is
//!   the outermost `AUTHORITY` / `ID`, geographic when the outermost keyword
//!   is `GEOGCS` / `GEOGCRS`, the linear unit from the projected CRS's `UNIT`);
//! - the `VRTRasterBand` asked for (`--band`, 1-based), its `dataType`
//!   (Byte, Int8, UInt16, Int16, UInt32, Int32, Float32, Float64) and
//!   `NoDataValue`;
//! - its `SimpleSource` and `ComplexSource` elements: `SourceFilename`
//!   (`relativeToVRT="1"`: relative to the .vrt's folder; `"0"`: as written),
//!   `SourceBand`, `SrcRect`, `DstRect` (absent: the whole source, the whole
//!   VRT) and, for a `ComplexSource`, `NODATA` (source cells of that value
//!   leave the cells below them unchanged). Sources are painted in document
//!   order, a later one over an earlier one, as GDAL does; a source reads its
//!   file's raw cells (no GDAL scale/offset), converted to the band's type
//!   (integers rounded and saturated). A source file may be a GeoTIFF, an
//!   SRTM `.hgt`, an ESRI ASCII grid or another `.vrt` (up to 8 deep).
//!
//! Refused, each with one error naming the .vrt, what it uses and the fix
//! (`gdal_translate` it to a GeoTIFF, which GDAL computes exactly): warped
//! VRTs (`VRTWarpedDataset`), derived (pixel-function), raw and other band
//! subclasses, band `Scale`/`Offset` other than identity, sources other than
//! simple and complex ones (`AveragedSource`, `KernelFilteredSource`, ...),
//! resampling (`SrcRect` size different from `DstRect` size, or fractional
//! rectangles), `ScaleOffset`/`ScaleRatio` other than 0/1, `LUT`,
//! `Exponent`, `SrcMin`/`SrcMax`/`DstMin`/`DstMax`, colour-table expansion,
//! mask-band sources and GDAL virtual file systems (`/vsizip/`, `/vsicurl/`,
//! ...). These change cell values in ways orogen does not reproduce, and a
//! silently different DEM is worse than a refusal.
//!
//! One departure: where no source covers a cell and the band declares no
//! `NoDataValue`, GDAL reads 0, an elevation; orogen then declares the
//! type's default nodata ([`super::mosaic::default_nodata`]) and reads that.
//!
//! Streaming: opening reads the XML only and checks that every source file
//! exists; a window read opens (and reads) only the sources whose
//! `DstRect` overlaps it. Opened sources are kept in a small
//! least-recently-used cache ([`OPEN_SOURCES`] of them), so memory stays
//! bounded whatever the number of tiles (an `.hgt` is held whole while open).

use super::mosaic::{default_nodata, Coverage};
use crate::error::{Error, Result};
use crate::raster::{AnyGrid, Cell, Crs, DType, GeoRef, Grid, RasterInfo, RasterSource, Window};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

/// How many opened sources a VRT keeps (least recently used dropped first).
pub const OPEN_SOURCES: usize = 8;

/// Nesting limit of VRTs whose sources are VRTs.
const MAX_DEPTH: usize = 8;

/// Largest .vrt file read (a tile set of 100 000 sources is ~60 MB).
const MAX_XML: u64 = 256 << 20;

/// One `SimpleSource` / `ComplexSource`.
#[derive(Debug, Clone)]
struct Source {
    file: PathBuf,
    band: usize,
    /// `SrcRect` offset in the source's cells (size = `dst`'s).
    src_x: i64,
    src_y: i64,
    /// `DstRect` in the VRT's cells.
    dst: Window,
    /// `ComplexSource` `NODATA`: source cells of this value are transparent.
    nodata: Option<f64>,
}

/// A GDAL VRT mosaic read as one raster (see the module doc).
pub struct Vrt {
    info: RasterInfo,
    sources: Vec<Source>,
    /// The value of cells no source covers.
    fill: f64,
    depth: usize,
    /// Opened sources, most recently used last.
    open: Mutex<Vec<(usize, Arc<dyn RasterSource>)>>,
}

/// The one refusal: what the VRT uses, and the fix (GDAL computes it).
fn refuse(path: &Path, what: impl std::fmt::Display) -> Error {
    let name = path
        .file_name()
        .map_or("IN.vrt".into(), |n| n.to_string_lossy());
    let stem = path
        .file_stem()
        .map_or("OUT".into(), |n| n.to_string_lossy());
    Error::unsupported(
        path,
        format!(
            "this VRT uses {what}, which orogen does not read; gdal_translate it to a GeoTIFF \
             first (gdal_translate {name} {stem}.tif) and give orogen the GeoTIFF"
        ),
    )
}

fn corrupt(path: &Path, what: impl std::fmt::Display) -> Error {
    Error::corrupt(path, format!("not a readable GDAL VRT: {what}"))
}

/// A GDAL data type name as orogen's type.
/// The first child element of `n` named `name`.
fn child<'a, 'i>(n: roxmltree::Node<'a, 'i>, name: &str) -> Option<roxmltree::Node<'a, 'i>> {
    n.children()
        .find(|c| c.is_element() && c.tag_name().name() == name)
}

fn dtype_of(name: &str) -> Option<DType> {
    Some(match name {
        "Byte" => DType::U8,
        "Int8" => DType::I8,
        "UInt16" => DType::U16,
        "Int16" => DType::I16,
        "UInt32" => DType::U32,
        "Int32" => DType::I32,
        "Float32" => DType::F32,
        "Float64" => DType::F64,
        _ => return None,
    })
}

fn parse_f64(path: &Path, what: &str, s: &str) -> Result<f64> {
    s.trim()
        .parse::<f64>()
        .map_err(|_| corrupt(path, format!("{what} `{}` is not a number", s.trim())))
}

/// The keywords and bracket contents at depth 1 of a WKT string: a list
/// of (keyword, contents) of the outermost node's children, and the outermost keyword.
fn wkt_children(wkt: &str) -> (String, Vec<(String, String)>) {
    let b = wkt.as_bytes();
    let Some(open) = wkt.find(['[', '(']) else {
        return (wkt.trim().to_ascii_uppercase(), Vec::new());
    };
    let top = wkt[..open].trim().to_ascii_uppercase();
    let mut children = Vec::new();
    let mut depth = 0usize;
    let mut in_str = false;
    let mut kw_start = open + 1;
    let mut body_start = 0;
    let mut kw = String::new();
    for i in open..b.len() {
        let c = b[i];
        if c == b'"' {
            in_str = !in_str;
            continue;
        }
        if in_str {
            continue;
        }
        match c {
            b'[' | b'(' => {
                depth += 1;
                if depth == 2 {
                    kw = wkt[kw_start..i].trim().to_ascii_uppercase();
                    body_start = i + 1;
                }
            }
            b']' | b')' => {
                if depth == 2 {
                    children.push((std::mem::take(&mut kw), wkt[body_start..i].to_string()));
                }
                depth = depth.saturating_sub(1);
                if depth == 1 {
                    kw_start = i + 1;
                }
            }
            b',' if depth == 1 => kw_start = i + 1,
            _ => {}
        }
    }
    (top, children)
}

/// The CRS of a VRT's `SRS` text (see the module doc).
fn crs_of(srs: &str) -> Crs {
    let s = srs.trim();
    if let Some(code) = s
        .strip_prefix("EPSG:")
        .or_else(|| s.strip_prefix("epsg:"))
        .and_then(|c| c.trim().parse::<u32>().ok())
    {
        return if code == 4326 {
            Crs::wgs84()
        } else {
            Crs::projected(code)
        };
    }
    let (top, children) = wkt_children(s);
    let geographic = matches!(top.as_str(), "GEOGCS" | "GEOGCRS" | "GEOGRAPHICCRS");
    let mut crs = Crs {
        geographic,
        ..Crs::default()
    };
    for (kw, body) in &children {
        let parts: Vec<&str> = body
            .split(',')
            .map(|p| p.trim().trim_matches('"'))
            .collect();
        match kw.as_str() {
            "AUTHORITY" | "ID" if parts.len() >= 2 && parts[0].eq_ignore_ascii_case("EPSG") => {
                crs.epsg = parts[1].parse().ok();
            }
            "UNIT" | "LENGTHUNIT" if !geographic && parts.len() >= 2 => {
                if let Ok(f) = parts[1].parse::<f64>() {
                    if f > 0.0 {
                        crs.linear_unit_m = f;
                    }
                }
            }
            _ => {}
        }
    }
    // WKT 2 puts the unit inside CS/AXIS nodes: take the last LENGTHUNIT.
    if !geographic
        && !children
            .iter()
            .any(|(k, _)| k == "UNIT" || k == "LENGTHUNIT")
    {
        if let Some(i) = s.rfind("LENGTHUNIT[") {
            let rest = &s[i + 11..];
            if let Some(f) = rest
                .split(',')
                .nth(1)
                .and_then(|p| p.trim_end_matches([']', ' ']).trim().parse::<f64>().ok())
            {
                if f > 0.0 {
                    crs.linear_unit_m = f;
                }
            }
        }
    }
    crs
}

/// An integer attribute of a rectangle element; fractional values mean
/// resampling.
fn rect(path: &Path, node: roxmltree::Node, kind: &str) -> Result<(i64, i64, usize, usize)> {
    let get = |a: &str| -> Result<f64> {
        let v = node
            .attribute(a)
            .ok_or_else(|| corrupt(path, format!("<{kind}> without {a}")))?;
        parse_f64(path, &format!("<{kind}> {a}"), v)
    };
    let (x, y, w, h) = (get("xOff")?, get("yOff")?, get("xSize")?, get("ySize")?);
    let whole = |v: f64| v.is_finite() && v.fract() == 0.0 && v.abs() < 1e15;
    if !(whole(x) && whole(y) && whole(w) && whole(h)) {
        return Err(refuse(
            path,
            format!(
                "a fractional <{kind}> ({x}, {y}, {w} x {h}): sub-cell placement is resampling"
            ),
        ));
    }
    if w < 0.0 || h < 0.0 {
        return Err(corrupt(path, format!("<{kind}> with a negative size")));
    }
    Ok((x as i64, y as i64, w as usize, h as usize))
}

/// Whether the VRT file starts (after blanks, a BOM and an XML declaration
/// or comments) with `<VRTDataset`.
pub fn looks_like_vrt(head: &[u8]) -> bool {
    let s = String::from_utf8_lossy(head);
    let mut s = s.trim_start_matches('\u{feff}').trim_start();
    loop {
        if let Some(r) = s.strip_prefix("<?") {
            match r.find("?>") {
                Some(i) => s = r[i + 2..].trim_start(),
                None => return false,
            }
        } else if let Some(r) = s.strip_prefix("<!--") {
            match r.find("-->") {
                Some(i) => s = r[i + 3..].trim_start(),
                None => return false,
            }
        } else {
            return s.starts_with("<VRTDataset");
        }
    }
}

impl Vrt {
    /// Open the VRT at `path`, band `band` (1-based). Errors name the .vrt
    /// and what it uses that is not read, or the missing source file.
    pub fn open(path: &Path, band: usize) -> Result<Vrt> {
        Self::open_depth(path, band, 0)
    }

    fn open_depth(path: &Path, band: usize, depth: usize) -> Result<Vrt> {
        if depth > MAX_DEPTH {
            return Err(refuse(
                path,
                format!("VRTs nested more than {MAX_DEPTH} deep"),
            ));
        }
        let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
        if meta.len() > MAX_XML {
            return Err(Error::too_large(
                path,
                format!(
                    "a .vrt of {} bytes (orogen reads up to {MAX_XML})",
                    meta.len()
                ),
            ));
        }
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        let doc = roxmltree::Document::parse(&text).map_err(|e| corrupt(path, e))?;
        let root = doc.root_element();
        if root.tag_name().name() != "VRTDataset" {
            return Err(corrupt(path, "the root element is not <VRTDataset>"));
        }
        if let Some(sub) = root.attribute("subClass") {
            let what = if sub == "VRTWarpedDataset" {
                "a warped dataset (VRTWarpedDataset, as gdalwarp -of VRT writes): reprojection"
                    .to_string()
            } else {
                format!("a dataset of subClass {sub}")
            };
            return Err(refuse(path, what));
        }
        let size = |a: &str| -> Result<usize> {
            let v = root
                .attribute(a)
                .ok_or_else(|| corrupt(path, format!("<VRTDataset> without {a}")))?;
            v.trim()
                .parse::<usize>()
                .map_err(|_| corrupt(path, format!("{a} `{v}` is not a size")))
        };
        let (width, height) = (size("rasterXSize")?, size("rasterYSize")?);
        if width == 0 || height == 0 || width.checked_mul(height).is_none() {
            return Err(Error::too_large(
                path,
                format!("a VRT of {width} x {height} cells"),
            ));
        }
        let mut georef = GeoRef::pixel();
        if let Some(gt) = child(root, "GeoTransform") {
            let vals: Vec<f64> = gt
                .text()
                .unwrap_or("")
                .split(',')
                .map(|v| parse_f64(path, "a GeoTransform term", v))
                .collect::<Result<_>>()?;
            if vals.len() != 6 {
                return Err(corrupt(path, "a GeoTransform without 6 terms"));
            }
            georef.transform.copy_from_slice(&vals);
            georef.georeferenced = true;
        }
        if let Some(srs) = child(root, "SRS").and_then(|n| n.text()) {
            georef.crs = crs_of(srs);
        }
        let bands: Vec<_> = root
            .children()
            .filter(|c| c.is_element() && c.tag_name().name() == "VRTRasterBand")
            .collect();
        if band == 0 || band > bands.len() {
            return Err(Error::invalid(format!(
                "{}: band {band} asked for, the VRT has {} band{}: choose --band 1{}",
                path.display(),
                bands.len(),
                if bands.len() == 1 { "" } else { "s" },
                if bands.len() > 1 {
                    format!("..{}", bands.len())
                } else {
                    String::new()
                }
            )));
        }
        let b = bands
            .iter()
            .find(|n| n.attribute("band") == Some(band.to_string().as_str()))
            .unwrap_or(&bands[band - 1]);
        if let Some(sub) = b.attribute("subClass") {
            let what = match sub {
                "VRTDerivedRasterBand" => {
                    "a derived band (VRTDerivedRasterBand: a pixel function)".to_string()
                }
                "VRTRawRasterBand" => "a raw band (VRTRawRasterBand)".to_string(),
                s => format!("a band of subClass {s}"),
            };
            return Err(refuse(path, what));
        }
        let type_name = b.attribute("dataType").unwrap_or("Byte");
        let dtype = dtype_of(type_name)
            .ok_or_else(|| refuse(path, format!("the band data type {type_name}")))?;
        let mut nodata = None;
        let mut sources = Vec::new();
        let vrt_dir = path.parent().unwrap_or(Path::new(""));
        for n in b.children().filter(|c| c.is_element()) {
            let name = n.tag_name().name();
            match name {
                "NoDataValue" => {
                    nodata = Some(parse_f64(path, "NoDataValue", n.text().unwrap_or(""))?)
                }
                "Scale" | "Offset" => {
                    let v = parse_f64(path, name, n.text().unwrap_or(""))?;
                    if v != if name == "Scale" { 1.0 } else { 0.0 } {
                        return Err(refuse(path, format!("a band {name} of {v}")));
                    }
                }
                "SimpleSource" | "ComplexSource" => sources.push(Self::source(
                    path,
                    vrt_dir,
                    n,
                    name == "ComplexSource",
                    width,
                    height,
                )?),
                "AveragedSource" | "KernelFilteredSource" | "NoDataFromMaskSource" => {
                    return Err(refuse(
                        path,
                        format!("a <{name}> (resampling or filtering)"),
                    ))
                }
                n if n.ends_with("Source") => return Err(refuse(path, format!("a <{n}>"))),
                "PixelFunctionType" | "PixelFunctionLanguage" | "PixelFunctionCode" => {
                    return Err(refuse(path, "a pixel function"))
                }
                _ => {} // ColorInterp, Description, Metadata, Histograms, UnitType, ...
            }
        }
        let rects: Vec<Window> = sources.iter().map(|s| s.dst).collect();
        let covered = Coverage::of(width, height, &rects).covered_cells;
        let fill = match nodata {
            Some(v) => v,
            None if covered < width as u128 * height as u128 => {
                let v = default_nodata(dtype);
                nodata = Some(v);
                v
            }
            None => 0.0,
        };
        georef.nodata = nodata;
        let info = RasterInfo {
            width,
            height,
            dtype,
            georef,
            block: (width.min(512), height.min(256)),
            path: path.to_path_buf(),
        };
        Ok(Vrt {
            info,
            sources,
            fill,
            depth,
            open: Mutex::new(Vec::new()),
        })
    }

    fn source(
        path: &Path,
        vrt_dir: &Path,
        n: roxmltree::Node,
        complex: bool,
        width: usize,
        height: usize,
    ) -> Result<Source> {
        let kind = n.tag_name().name();
        let mut file = None;
        let mut band = 1usize;
        let mut src_rect = None;
        let mut dst_rect = None;
        let mut nodata = None;
        let mut scale_offset = 0.0;
        let mut scale_ratio = 1.0;
        for c in n.children().filter(|c| c.is_element()) {
            let name = c.tag_name().name();
            let text = c.text().unwrap_or("").trim();
            match name {
                "SourceFilename" => {
                    if text.starts_with("/vsi") {
                        return Err(Error::unsupported(
                            path,
                            format!(
                                "its source {text} is a GDAL virtual file (/vsizip/, /vsicurl/, ...), which \
                                 orogen does not read; extract or download the files and rebuild the VRT \
                                 over them with gdalbuildvrt"
                            ),
                        ));
                    }
                    let relative = c
                        .attribute("relativeToVRT")
                        .is_some_and(|v| v.trim() == "1");
                    file = Some(if relative {
                        vrt_dir.join(text)
                    } else {
                        PathBuf::from(text)
                    });
                }
                "SourceBand" => {
                    band = text
                        .parse::<usize>()
                        .ok()
                        .filter(|&b| b >= 1)
                        .ok_or_else(|| {
                            if text.starts_with("mask") {
                                refuse(path, format!("a mask band as a source ({text})"))
                            } else {
                                corrupt(path, format!("SourceBand `{text}` is not a band number"))
                            }
                        })?;
                }
                "SrcRect" => src_rect = Some(rect(path, c, "SrcRect")?),
                "DstRect" => dst_rect = Some(rect(path, c, "DstRect")?),
                "NODATA" if complex => nodata = Some(parse_f64(path, "NODATA", text)?),
                "ScaleOffset" => scale_offset = parse_f64(path, name, text)?,
                "ScaleRatio" => scale_ratio = parse_f64(path, name, text)?,
                "UseMaskBand" if text.eq_ignore_ascii_case("true") || text == "1" => {
                    return Err(refuse(path, "a source's mask band (UseMaskBand)"))
                }
                "LUT"
                | "Exponent"
                | "SrcMin"
                | "SrcMax"
                | "DstMin"
                | "DstMax"
                | "ColorTableComponent" => {
                    return Err(refuse(
                        path,
                        format!("<{name}> in a <{kind}> (value mapping)"),
                    ))
                }
                _ => {} // SourceProperties, ResampleAlg (no resampling happens), OpenOptions
            }
        }
        if scale_offset != 0.0 || scale_ratio != 1.0 {
            return Err(refuse(
                path,
                format!("a <{kind}> scaling its values (ScaleOffset {scale_offset}, ScaleRatio {scale_ratio})"),
            ));
        }
        let file =
            file.ok_or_else(|| corrupt(path, format!("a <{kind}> without <SourceFilename>")))?;
        if !file.is_file() {
            return Err(Error::invalid(format!(
                "{}: its source {} is missing (no such file); restore the file, or rebuild the VRT \
                 from the tiles you have (gdalbuildvrt)",
                path.display(),
                file.display()
            )));
        }
        let src_rect = match src_rect {
            Some(r) => r,
            None => {
                // The whole source: its size is needed.
                let s = open_source(&file, band, 0)?;
                (0, 0, s.info().width, s.info().height)
            }
        };
        let dst_rect = dst_rect.unwrap_or((0, 0, width, height));
        if (src_rect.2, src_rect.3) != (dst_rect.2, dst_rect.3) {
            return Err(refuse(
                path,
                format!(
                    "resampling: source {} is read from {} x {} cells into {} x {} (SrcRect and DstRect sizes differ)",
                    file.display(),
                    src_rect.2,
                    src_rect.3,
                    dst_rect.2,
                    dst_rect.3
                ),
            ));
        }
        Ok(Source {
            file,
            band,
            src_x: src_rect.0,
            src_y: src_rect.1,
            dst: Window::new(dst_rect.0, dst_rect.1, dst_rect.2, dst_rect.3),
            nodata,
        })
    }

    /// The sources' files and `DstRect`s in the VRT's cells, in painting order.
    pub fn extents(&self) -> Vec<(PathBuf, Window)> {
        self.sources
            .iter()
            .map(|s| (s.file.clone(), s.dst))
            .collect()
    }

    /// The opened source `i` (from the cache, else opened now).
    fn source_reader(&self, i: usize) -> Result<Arc<dyn RasterSource>> {
        {
            let mut open = self.open.lock().unwrap_or_else(|e| e.into_inner());
            if let Some(k) = open.iter().position(|(j, _)| *j == i) {
                let e = open.remove(k);
                let r = Arc::clone(&e.1);
                open.push(e);
                return Ok(r);
            }
        }
        let s = &self.sources[i];
        let r: Arc<dyn RasterSource> = Arc::from(open_source(&s.file, s.band, self.depth + 1)?);
        let mut open = self.open.lock().unwrap_or_else(|e| e.into_inner());
        if !open.iter().any(|(j, _)| *j == i) {
            if open.len() >= OPEN_SOURCES {
                open.remove(0);
            }
            open.push((i, Arc::clone(&r)));
        }
        Ok(r)
    }
}

/// Open a source file raw (no reassignment, no GDAL scale/offset).
fn open_source(file: &Path, band: usize, depth: usize) -> Result<Box<dyn RasterSource>> {
    use super::open::Format;
    let format = super::open::detect(file)?;
    if band != 1 && !matches!(format, Format::GeoTiff | Format::Vrt) {
        return Err(Error::invalid(format!(
            "{}: band {band} asked for by a VRT, the file has 1 band",
            file.display()
        )));
    }
    Ok(match format {
        Format::GeoTiff => Box::new(crate::io::geotiff::GeoTiffReader::open_with(
            file,
            &crate::io::geotiff::ReaderOptions {
                band,
                ..Default::default()
            },
        )?),
        Format::Hgt => Box::new(super::hgt::read_hgt(file)?),
        Format::Ascii => Box::new(super::ascii::read_ascii(file)?),
        Format::Vrt => Box::new(Vrt::open_depth(file, band, depth)?),
        Format::Png | Format::Store => {
            return Err(Error::unsupported(
                file,
                "a VRT source must be a GeoTIFF, .hgt, ESRI ASCII grid or .vrt",
            ))
        }
    })
}

/// Paint `part`'s cells (raw values; `nodata` ones transparent) into `out`
/// at (`ox`, `oy`).
fn paint<T: Cell>(out: &mut Grid<T>, part: &Grid<f64>, ox: usize, oy: usize, nodata: Option<f64>) {
    let ow = out.width();
    for y in 0..part.height() {
        let prow = part.row(y);
        let base = (y + oy) * ow + ox;
        let orow = &mut out.data_mut()[base..base + prow.len()];
        match nodata {
            Some(nd) => {
                let nan = nd.is_nan();
                for (o, &v) in orow.iter_mut().zip(prow) {
                    if !(v == nd || (nan && v.is_nan())) {
                        *o = T::from_f64(v);
                    }
                }
            }
            None => {
                for (o, &v) in orow.iter_mut().zip(prow) {
                    *o = T::from_f64(v);
                }
            }
        }
    }
}

impl RasterSource for Vrt {
    fn info(&self) -> &RasterInfo {
        &self.info
    }

    fn read_native(&self, win: Window) -> Result<AnyGrid> {
        let mut out = AnyGrid::filled(self.info.dtype, win.w, win.h, self.fill);
        for (i, s) in self.sources.iter().enumerate() {
            let Some(inter) = win.intersect(&s.dst) else {
                continue;
            };
            let r = self.source_reader(i)?;
            let si = r.info();
            // The part of `inter` whose source cells lie inside the file.
            let sx = s.src_x + (inter.x - s.dst.x);
            let sy = s.src_y + (inter.y - s.dst.y);
            let want = Window::new(sx, sy, inter.w, inter.h);
            let Some(local) = want.intersect(&Window::full(si.width, si.height)) else {
                continue;
            };
            let part: Grid<f64> = r.read_native(local)?.to_typed(None);
            let ox = (inter.x + (local.x - sx) - win.x) as usize;
            let oy = (inter.y + (local.y - sy) - win.y) as usize;
            crate::dispatch_any!(&mut out, g => paint(g, &part, ox, oy, s.nodata));
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srs_parsing() {
        let utm = r#"PROJCS["WGS 84 / UTM zone 11N",GEOGCS["WGS 84",DATUM["WGS_1984",SPHEROID["WGS 84",6378137,298.257223563,AUTHORITY["EPSG","7030"]],AUTHORITY["EPSG","6326"]],AUTHORITY["EPSG","4326"]],PROJECTION["Transverse_Mercator"],UNIT["metre",1,AUTHORITY["EPSG","9001"]],AXIS["Easting",EAST],AUTHORITY["EPSG","32611"]]"#;
        let c = crs_of(utm);
        assert_eq!(c.epsg, Some(32611));
        assert!(!c.geographic);
        assert_eq!(c.linear_unit_m, 1.0);
        let geo = r#"GEOGCS["WGS 84",DATUM["WGS_1984",SPHEROID["WGS 84",6378137,298.257223563]],UNIT["degree",0.0174532925199433],AUTHORITY["EPSG","4326"]]"#;
        let c = crs_of(geo);
        assert_eq!(c.epsg, Some(4326));
        assert!(c.geographic);
        let ft = r#"PROJCS["x",GEOGCS["y"],UNIT["US survey foot",0.304800609601219],AUTHORITY["EPSG","2229"]]"#;
        assert!((crs_of(ft).linear_unit_m - 0.3048006).abs() < 1e-6);
        let wkt2 = r#"PROJCRS["WGS 84 / UTM zone 11N",BASEGEOGCRS["WGS 84",ID["EPSG",4326]],CONVERSION["UTM zone 11N",ID["EPSG",16011]],CS[Cartesian,2],AXIS["(E)",east,LENGTHUNIT["metre",1]],ID["EPSG",32611]]"#;
        assert_eq!(crs_of(wkt2).epsg, Some(32611));
        assert_eq!(crs_of("EPSG:4326"), Crs::wgs84());
    }

    #[test]
    fn at_most_open_sources_stay_open() {
        // Twelve copies of one tile side by side: a read of them all keeps
        // OPEN_SOURCES opened, the last used.
        let tile = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/vrt/t_a.tif");
        let n = OPEN_SOURCES + 4;
        let mut xml = format!(
            "<VRTDataset rasterXSize=\"{}\" rasterYSize=\"90\"><VRTRasterBand dataType=\"Int16\" band=\"1\">",
            140 * n
        );
        for i in 0..n {
            xml += &format!(
                "<SimpleSource><SourceFilename>{}</SourceFilename><SourceBand>1</SourceBand>\
                 <SrcRect xOff=\"0\" yOff=\"0\" xSize=\"140\" ySize=\"90\"/>\
                 <DstRect xOff=\"{}\" yOff=\"0\" xSize=\"140\" ySize=\"90\"/></SimpleSource>",
                tile.display(),
                140 * i
            );
        }
        xml += "</VRTRasterBand></VRTDataset>";
        let dir = std::env::temp_dir().join(format!("orogen-vrt-lru-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("row.vrt");
        std::fs::write(&p, xml).unwrap();
        let v = Vrt::open(&p, 1).unwrap();
        let g = v.read_native(Window::full(140 * n, 90)).unwrap();
        assert_eq!(g.get_f64(5, 7), g.get_f64(140 * (n - 1) + 5, 7));
        let open: Vec<usize> = v.open.lock().unwrap().iter().map(|e| e.0).collect();
        assert_eq!(open, (n - OPEN_SOURCES..n).collect::<Vec<_>>());
        // A window over one tile opens only it.
        let v = Vrt::open(&p, 1).unwrap();
        v.read_native(Window::new(300, 10, 20, 20)).unwrap();
        assert_eq!(
            v.open
                .lock()
                .unwrap()
                .iter()
                .map(|e| e.0)
                .collect::<Vec<_>>(),
            vec![2]
        );
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn sniffing() {
        assert!(looks_like_vrt(b"<VRTDataset rasterXSize"));
        assert!(looks_like_vrt(
            b"\xef\xbb\xbf<?xml version=\"1.0\"?>\n<!-- x -->\n<VRTDataset"
        ));
        assert!(!looks_like_vrt(b"<html>"));
    }
}
