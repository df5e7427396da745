//! Mosaics: several aligned rasters read as one [`RasterSource`] without
//! loading them (each window reads only the sources it touches).
//!
//! Rules (chosen to be deterministic and simple to state):
//! - All sources share the CRS (EPSG code and geographic flag), are north-up,
//!   have the same cell size (within 1e-9 relative) and grid-aligned origins
//!   (offsets a whole number of cells within 1e-6 cell).
//! - The extent is the union of the sources; cells covered by none are nodata.
//! - Sources are ordered by path; for each cell the first source in that
//!   order with a valid value (not NaN, not its nodata) wins. Adjacent SRTM
//!   tiles share an edge row/column, so this decides which tile's edge is kept.
//! - Data type: the common type, else the first type of u8, i8, u16, i16, u32,
//!   i32, f32, f64 that holds every source type exactly (i16 + f32 -> f32,
//!   u16 + i16 -> i32, i32 + f32 -> f64).
//! - Nodata: the sources' common nodata value when they all have the same one
//!   and it fits the output type; otherwise the type's default: NaN for
//!   floats, the minimum for signed integers (-32768 for i16), the maximum for
//!   unsigned ones.

use crate::error::{Error, Result};
use crate::raster::{AnyGrid, Cell, DType, GeoRef, Grid, RasterInfo, RasterSource, Window};
use std::path::{Path, PathBuf};

/// One input placed in mosaic coordinates.
struct Placed {
    src: Box<dyn RasterSource>,
    /// The input's extent in mosaic cell coordinates.
    win: Window,
}

/// Aligned rasters read as one.
pub struct Mosaic {
    info: RasterInfo,
    inputs: Vec<Placed>,
}

/// Whether type `c` holds every value of type `t` exactly.
fn holds(c: DType, t: DType) -> bool {
    if c == t || c == DType::F64 {
        return true;
    }
    match (c.is_float(), t.is_float()) {
        (false, false) => {
            let (clo, chi) = c.int_range();
            let (tlo, thi) = t.int_range();
            clo <= tlo && chi >= thi
        }
        (true, false) => t.size() <= 2,
        _ => false,
    }
}

/// The output type of a mosaic of `types` (see the module doc).
pub fn common_dtype(types: &[DType]) -> DType {
    // The first (narrowest) type that holds every input's values.
    DType::ALL
        .into_iter()
        .find(|&c| types.iter().all(|&t| holds(c, t)))
        .unwrap_or(DType::F64)
}

/// The default nodata value of a type: NaN, the signed minimum or the unsigned maximum.
pub fn default_nodata(d: DType) -> f64 {
    match d {
        DType::F32 | DType::F64 => f64::NAN,
        DType::I8 | DType::I16 | DType::I32 => d.int_range().0,
        DType::U8 | DType::U16 | DType::U32 => d.int_range().1,
    }
}

impl Mosaic {
    /// Build a mosaic of `sources` (see the module doc for the rules). Errors
    /// name the source that differs from the first and how.
    pub fn new(mut sources: Vec<Box<dyn RasterSource>>) -> Result<Mosaic> {
        if sources.is_empty() {
            return Err(Error::invalid("a mosaic needs at least one input raster"));
        }
        sources.sort_by(|a, b| a.info().path.cmp(&b.info().path));
        let r = sources[0].info().clone();
        let rt = r.georef.transform;
        let check_north_up = |i: &RasterInfo| -> Result<()> {
            let t = i.georef.transform;
            if !i.georef.is_north_up() || t[1] <= 0.0 || (i.georef.georeferenced && t[5] >= 0.0) {
                return Err(Error::unsupported(
                    &i.path,
                    "mosaic inputs must be north-up (no rotation, x growing east, y growing north); \
                     warp the file first",
                ));
            }
            Ok(())
        };
        check_north_up(&r)?;
        let (dx, dy) = (rt[1], rt[5]);
        let mut offsets = Vec::with_capacity(sources.len());
        for s in &sources {
            let i = s.info();
            check_north_up(i)?;
            let g = &i.georef;
            if g.georeferenced != r.georef.georeferenced
                || g.crs.epsg != r.georef.crs.epsg
                || g.crs.geographic != r.georef.crs.geographic
            {
                let d = |g: &GeoRef| {
                    if !g.georeferenced {
                        "no georeference".to_string()
                    } else {
                        format!(
                            "{} ({})",
                            g.crs
                                .epsg
                                .map_or("unknown EPSG".into(), |e| format!("EPSG:{e}")),
                            if g.crs.geographic {
                                "geographic"
                            } else {
                                "projected"
                            }
                        )
                    }
                };
                return Err(Error::unsupported(
                    &i.path,
                    format!(
                        "CRS {} differs from {} of {}; reproject the inputs to one CRS",
                        d(g),
                        d(&r.georef),
                        r.path.display()
                    ),
                ));
            }
            let t = g.transform;
            if (t[1] - dx).abs() > 1e-9 * dx.abs() || (t[5] - dy).abs() > 1e-9 * dy.abs() {
                return Err(Error::unsupported(
                    &i.path,
                    format!(
                        "cell size {} x {} differs from {} x {} of {}; resample the inputs to one cell size",
                        t[1],
                        t[5].abs(),
                        dx,
                        dy.abs(),
                        r.path.display()
                    ),
                ));
            }
            let fx = (t[0] - rt[0]) / dx;
            let fy = (t[3] - rt[3]) / dy;
            let (ox, oy) = (fx.round(), fy.round());
            if (fx - ox).abs() > 1e-6
                || (fy - oy).abs() > 1e-6
                || !fx.is_finite()
                || !fy.is_finite()
            {
                return Err(Error::unsupported(
                    &i.path,
                    format!(
                        "origin is offset by ({fx:.6}, {fy:.6}) cells from {}: not a whole number of \
                         cells; the grids are not aligned (resample onto a common grid)",
                        r.path.display()
                    ),
                ));
            }
            if ox.abs() > 1e12 || oy.abs() > 1e12 {
                return Err(Error::too_large(
                    &i.path,
                    format!("origin lies {ox} x {oy} cells from {}", r.path.display()),
                ));
            }
            offsets.push((ox as i64, oy as i64));
        }
        let x0 = offsets.iter().map(|o| o.0).min().unwrap_or(0);
        let y0 = offsets.iter().map(|o| o.1).min().unwrap_or(0);
        let mut x1 = i64::MIN;
        let mut y1 = i64::MIN;
        for (s, o) in sources.iter().zip(&offsets) {
            let i = s.info();
            x1 = x1.max(o.0 + i.width as i64);
            y1 = y1.max(o.1 + i.height as i64);
        }
        let (width, height) = ((x1 - x0) as usize, (y1 - y0) as usize);
        if width.checked_mul(height).is_none() {
            return Err(Error::too_large(
                &r.path,
                format!("mosaic of {width} x {height} cells overflows"),
            ));
        }
        let types: Vec<DType> = sources.iter().map(|s| s.info().dtype).collect();
        let dtype = common_dtype(&types);
        let first_nd = r.georef.nodata;
        let agree = sources.iter().all(|s| {
            let n = s.info().georef.nodata;
            match (n, first_nd) {
                (Some(a), Some(b)) => a == b || (a.is_nan() && b.is_nan()),
                _ => false,
            }
        });
        let nodata = match first_nd {
            Some(v) if agree && dtype.represents(v) => v,
            _ => default_nodata(dtype),
        };
        let mut georef = r.georef.shifted(x0, y0);
        georef.nodata = Some(nodata);
        let path = if sources.len() == 1 {
            r.path.clone()
        } else {
            r.path
                .parent()
                .filter(|p| !p.as_os_str().is_empty())
                .map_or(r.path.clone(), Path::to_path_buf)
        };
        let info = RasterInfo {
            width,
            height,
            dtype,
            georef,
            block: r.block,
            path,
        };
        let inputs = sources
            .into_iter()
            .zip(offsets)
            .map(|(src, (ox, oy))| {
                let i = src.info();
                let win = Window::new(ox - x0, oy - y0, i.width, i.height);
                Placed { src, win }
            })
            .collect();
        Ok(Mosaic { info, inputs })
    }

    /// Number of inputs.
    pub fn len(&self) -> usize {
        self.inputs.len()
    }

    /// True when the mosaic has no inputs (never: `new` refuses that).
    pub fn is_empty(&self) -> bool {
        self.inputs.is_empty()
    }

    /// The inputs' paths and extents in mosaic cells, in priority order.
    pub fn extents(&self) -> Vec<(PathBuf, Window)> {
        self.inputs
            .iter()
            .map(|p| (p.src.info().path.clone(), p.win))
            .collect()
    }
}

/// Copy the valid cells of `part` (NaN = invalid) into the unfilled cells of
/// `out` at offset (`ox`, `oy`); returns how many cells were newly filled.
fn merge_into<T: Cell>(
    out: &mut Grid<T>,
    filled: &mut [bool],
    part: &Grid<f64>,
    ox: usize,
    oy: usize,
) -> usize {
    let ow = out.width();
    let mut n = 0;
    for y in 0..part.height() {
        let prow = part.row(y);
        let base = (y + oy) * ow + ox;
        let orow = &mut out.data_mut()[base..base + prow.len()];
        let frow = &mut filled[base..base + prow.len()];
        for ((o, f), &v) in orow.iter_mut().zip(frow.iter_mut()).zip(prow) {
            if !*f && !v.is_nan() {
                *o = T::from_f64(v);
                *f = true;
                n += 1;
            }
        }
    }
    n
}

impl RasterSource for Mosaic {
    fn info(&self) -> &RasterInfo {
        &self.info
    }

    fn read_native(&self, win: Window) -> Result<AnyGrid> {
        let nodata = self.info.georef.nodata.unwrap_or(f64::NAN);
        let mut out = AnyGrid::filled(self.info.dtype, win.w, win.h, nodata);
        let mut filled = vec![false; win.len()];
        let mut remaining = win.len();
        for p in &self.inputs {
            if remaining == 0 {
                break;
            }
            let Some(inter) = win.intersect(&p.win) else {
                continue;
            };
            let local = Window::new(inter.x - p.win.x, inter.y - p.win.y, inter.w, inter.h);
            let part: Grid<f64> = p
                .src
                .read_native(local)?
                .to_typed(p.src.info().georef.nodata);
            let (ox, oy) = ((inter.x - win.x) as usize, (inter.y - win.y) as usize);
            remaining -=
                crate::dispatch_any!(&mut out, g => merge_into(g, &mut filled, &part, ox, oy));
        }
        Ok(out)
    }
}

/// A mosaic whose sources leave more than this fraction of its extent
/// uncovered is refused unless `--allow-sparse` is given (50 %).
pub const MAX_EMPTY_FRACTION: f64 = 0.5;

/// How much of a mosaic's extent its sources cover, from their rectangles
/// alone (no cell is read).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Coverage {
    /// Cells of the extent.
    pub total_cells: u128,
    /// Cells inside at least one source rectangle.
    pub covered_cells: u128,
}

impl Coverage {
    /// The coverage of a `width` x `height` extent by `rects` (clipped to
    /// it; overlaps counted once): a sweep over the rectangles' column
    /// edges, merging the row intervals of those spanning each slab.
    pub fn of(width: usize, height: usize, rects: &[Window]) -> Coverage {
        let full = Window::full(width, height);
        let clipped: Vec<Window> = rects.iter().filter_map(|r| r.intersect(&full)).collect();
        let mut xs: Vec<i64> = clipped.iter().flat_map(|r| [r.x, r.x_end()]).collect();
        xs.sort_unstable();
        xs.dedup();
        let mut covered = 0u128;
        let mut spans: Vec<(i64, i64)> = Vec::new();
        for k in 1..xs.len() {
            let (a, b) = (xs[k - 1], xs[k]);
            spans.clear();
            spans.extend(
                clipped
                    .iter()
                    .filter(|r| r.x <= a && r.x_end() >= b)
                    .map(|r| (r.y, r.y_end())),
            );
            spans.sort_unstable();
            let (mut len, mut end) = (0i64, i64::MIN);
            for &(y0, y1) in &spans {
                let start = y0.max(end);
                if y1 > start {
                    len += y1 - start;
                }
                end = end.max(y1);
            }
            covered += (b - a) as u128 * len as u128;
        }
        Coverage {
            total_cells: width as u128 * height as u128,
            covered_cells: covered,
        }
    }

    /// The fraction of the extent no source covers.
    pub fn empty_fraction(&self) -> f64 {
        if self.total_cells == 0 {
            return 0.0;
        }
        1.0 - self.covered_cells as f64 / self.total_cells as f64
    }
}

/// Refuse a mosaic (`info`: its extent; `rects`: its sources' extents in
/// its cells) that leaves more than [`MAX_EMPTY_FRACTION`] of its extent
/// uncovered, unless `allow_sparse`. `what` names the mosaic ("the mosaic
/// of 2 files in DIR", "VRT.vrt").
pub fn check_sparse(
    what: &str,
    info: &RasterInfo,
    rects: &[Window],
    allow_sparse: bool,
) -> Result<()> {
    let c = Coverage::of(info.width, info.height, rects);
    if allow_sparse || c.empty_fraction() <= MAX_EMPTY_FRACTION {
        return Ok(());
    }
    let g = &info.georef;
    let (xa, ya) = g.pixel_to_map(0.0, 0.0);
    let (xb, yb) = g.pixel_to_map(info.width as f64, info.height as f64);
    let units = if !g.georeferenced {
        "pixel coordinates"
    } else if g.crs.geographic {
        "degrees"
    } else {
        "map units"
    };
    let covered = 100.0 * c.covered_cells as f64 / c.total_cells as f64;
    Err(Error::invalid(format!(
        "{what}: its {} sources span {} x {} cells (x {} to {}, y {} to {} in {units}) but cover only \
         {covered:.1} % of that extent: {:.1} % would be nodata, more than the {:.0} % orogen accepts \
         unasked; pass --allow-sparse (job key allow_sparse) to build the mosaic anyway, or mosaic \
         tiles nearer each other",
        rects.len(),
        info.width,
        info.height,
        xa.min(xb),
        xa.max(xb),
        ya.min(yb),
        ya.max(yb),
        100.0 - covered,
        100.0 * MAX_EMPTY_FRACTION,
    )))
}

/// Raster file extensions a directory expands to.
const RASTER_EXTS: [&str; 5] = ["hgt", "tif", "tiff", "asc", "png"];

/// Expand `paths`: a directory becomes the raster files it contains
/// (`.hgt`, `.tif`, `.tiff`, `.asc`, `.png`, any case), sorted by name; a file
/// stays as given. A missing path is an error.
pub fn expand_inputs(paths: &[PathBuf]) -> Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    for p in paths {
        let meta = std::fs::metadata(p).map_err(|e| Error::io(p, e))?;
        if meta.is_dir() {
            let mut found = Vec::new();
            for e in std::fs::read_dir(p).map_err(|e| Error::io(p, e))? {
                let e = e.map_err(|e| Error::io(p, e))?;
                let path = e.path();
                let is_raster = path
                    .extension()
                    .and_then(|x| x.to_str())
                    .is_some_and(|x| RASTER_EXTS.contains(&x.to_ascii_lowercase().as_str()));
                if is_raster && path.is_file() {
                    found.push(path);
                }
            }
            found.sort();
            out.extend(found);
        } else {
            out.push(p.clone());
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dtype_promotion() {
        use DType::*;
        assert_eq!(common_dtype(&[I16, I16]), I16);
        assert_eq!(common_dtype(&[I16, F32]), F32);
        assert_eq!(common_dtype(&[U16, I16]), I32);
        assert_eq!(common_dtype(&[U8, I8]), I16);
        assert_eq!(common_dtype(&[I32, F32]), F64);
        assert_eq!(common_dtype(&[U8, U16]), U16);
        assert_eq!(default_nodata(I16), -32768.0);
        assert_eq!(default_nodata(U8), 255.0);
        assert!(default_nodata(F32).is_nan());
    }

    #[test]
    fn coverage_counts_overlaps_once() {
        let r = |x, y, w, h| Window::new(x, y, w, h);
        let c = Coverage::of(10, 10, &[r(0, 0, 5, 5), r(3, 3, 5, 5), r(8, 8, 5, 5)]);
        // 25 + 25 - 4 (overlap) + 4 (clipped to the extent).
        assert_eq!(c.covered_cells, 50);
        assert_eq!(c.empty_fraction(), 0.5);
        assert_eq!(
            Coverage::of(4, 4, &[r(0, 0, 4, 4), r(0, 0, 4, 4)]).covered_cells,
            16
        );
        assert_eq!(Coverage::of(4, 4, &[]).covered_cells, 0);
    }
}
