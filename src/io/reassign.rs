//! An input read with its nodata value reassigned and its sea masked, the
//! readers' options `--nodata V`, `--sea-level Z` and `--mask FILE`
//! ([`super::OpenOptions`]).
//!
//! - `nodata`: V is the input's nodata value, replacing the file's (as GDAL's
//!   `-a_nodata` does: cells holding the file's old value become data) or
//!   assigning one to a file that has none (a GeoTIFF without the
//!   GDAL_NODATA tag, an ASCII grid without NODATA_value).
//! - `sea_level`: every cell at or below Z becomes nodata. Nodata cells are
//!   outlets of routing, so the sea drains the land instead of being a flat
//!   the flow must cross: on an SRTM tile the sea is 0 m, and without the
//!   mask D8 accumulation gathers the coast's rivers into channels across
//!   the sea. Integer rasters need a nodata value to write into those cells
//!   (the file's or `nodata`); float rasters without one get NaN.
//! - `mask`: a raster on the same grid; where it is 0 or nodata the input is
//!   read as nodata (GDAL's mask convention: 0 = not valid). A land mask
//!   drawn from a coastline keeps the land and makes the sea an outlet where
//!   the sea is not a constant height (bathymetry, tides, a lake's level).
//!
//! The wrapper changes nothing else: size, type, georeferencing, blocks and
//! path are the inner source's, so tiling and error messages are as for the
//! file itself.

use crate::error::{Error, Result};
use crate::raster::{AnyGrid, Cell, DType, Grid, RasterInfo, RasterSource, Window};

/// `inner` with nodata `nodata` (if given), and the cells `<= sea_level` (if
/// given) and those where `mask` is 0 or nodata (if given) read as nodata.
/// Errors name the file and the fix: a nodata value its cells cannot hold,
/// a sea level or mask on an integer raster without a nodata value, a mask
/// of another size or grid.
pub fn reassign<'a>(
    inner: Box<dyn RasterSource + 'a>,
    nodata: Option<f64>,
    sea_level: Option<f64>,
    mask: Option<Box<dyn RasterSource + 'a>>,
) -> Result<Box<dyn RasterSource + 'a>> {
    if nodata.is_none() && sea_level.is_none() && mask.is_none() {
        return Ok(inner);
    }
    let mut info = inner.info().clone();
    let path = info.path.display().to_string();
    if let Some(v) = nodata {
        info.georef.nodata = Some(representable(v, info.dtype).ok_or_else(|| {
            let (lo, hi) = info.dtype.int_range();
            let within = if info.dtype.is_float() {
                format!("a value within ±{:e}", f32::MAX)
            } else {
                format!("an integer in {lo}..={hi}")
            };
            Error::invalid(format!(
                "{path}: --nodata {v} is not a value its {} cells can hold; give {within}",
                info.dtype.name()
            ))
        })?);
    }
    if let Some(z) = sea_level {
        if !z.is_finite() {
            return Err(Error::invalid(format!(
                "{path}: --sea-level {z} is not a finite elevation"
            )));
        }
    }
    let what = match (sea_level.is_some(), mask.is_some()) {
        (true, true) => Some("--sea-level and --mask need"),
        (true, false) => Some("--sea-level needs"),
        (false, true) => Some("--mask needs"),
        _ => None,
    };
    if let Some(what) = what {
        if !info.dtype.is_float() && info.georef.nodata.is_none() {
            return Err(Error::invalid(format!(
                "{path}: {what} a nodata value to write into the masked {} cells and the file has none; add --nodata V with a value the data does not use",
                info.dtype.name()
            )));
        }
    }
    if let Some(m) = &mask {
        same_grid(m.info(), &info, "mask")?;
    }
    Ok(Box::new(Reassigned {
        inner,
        info,
        sea_level,
        mask,
    }))
}

/// `side` (a `what`: "mask", "sink raster") is on `dem`'s grid: the same
/// size and, when both are georeferenced, the same origin and cell size;
/// else an error naming both files and the fix.
pub(crate) fn same_grid(side: &RasterInfo, dem: &RasterInfo, what: &str) -> Result<()> {
    let (mpath, path) = (side.path.display(), dem.path.display());
    if (side.width, side.height) != (dem.width, dem.height) {
        return Err(Error::invalid(format!(
            "{mpath}: the {what} is {}x{} cells and {path} is {}x{}; give a {what} on the input's grid (e.g. gdalwarp -te/-ts to it)",
            side.width, side.height, dem.width, dem.height
        )));
    }
    let (a, b) = (&side.georef, &dem.georef);
    let off = a
        .transform
        .iter()
        .zip(&b.transform)
        .any(|(x, y)| (x - y).abs() > 1e-9 * x.abs().max(y.abs()).max(1e-6));
    if a.georeferenced && b.georeferenced && off {
        return Err(Error::invalid(format!(
            "{mpath}: the {what}'s grid (origin and cell size) is not {path}'s; give a {what} on the input's grid (e.g. gdalwarp -te/-ts to it)"
        )));
    }
    Ok(())
}

/// The value `v` as the cells of `dtype` hold it (f32: rounded to f32, so
/// `--nodata 0.1` finds the cells holding 0.1f32), or None when they cannot
/// hold it (integers: fractions or out of range; f32: beyond its range).
fn representable(v: f64, dtype: DType) -> Option<f64> {
    match dtype {
        DType::F32 => {
            (v.is_nan() || v.is_infinite() || (v as f32).is_finite()).then_some(v as f32 as f64)
        }
        _ => dtype.represents(v).then_some(v),
    }
}

struct Reassigned<'a> {
    inner: Box<dyn RasterSource + 'a>,
    info: RasterInfo,
    sea_level: Option<f64>,
    mask: Option<Box<dyn RasterSource + 'a>>,
}

/// A borrowed source as an owned one, for [`reassign`] over a source the
/// caller keeps (an array read in place).
pub struct Borrowed<'a>(pub &'a dyn RasterSource);

impl RasterSource for Borrowed<'_> {
    fn info(&self) -> &RasterInfo {
        self.0.info()
    }
    fn read_native(&self, win: Window) -> Result<AnyGrid> {
        self.0.read_native(win)
    }
    fn band(&self) -> (usize, usize) {
        self.0.band()
    }
    fn unused_georef(&self) -> Option<&str> {
        self.0.unused_georef()
    }
    fn scaling(&self) -> Option<crate::raster::Scaling> {
        self.0.scaling()
    }
}

/// Cells of `g` set to `nodata` (NaN when None: float rasters only) where
/// they are `<= z` (if given) or `mask` (same cells) is 0 or nodata.
fn mask_cells<T: Cell>(
    g: &mut Grid<T>,
    z: Option<f64>,
    mask: Option<&Grid<f64>>,
    nodata: Option<f64>,
) {
    let fill = T::from_f64(nodata.unwrap_or(f64::NAN));
    let z = z.unwrap_or(f64::NEG_INFINITY);
    for (i, v) in g.data_mut().iter_mut().enumerate() {
        let off = mask.is_some_and(|m| {
            let x = m.data()[i];
            x == 0.0 || x.is_nan()
        });
        if off || v.to_f64() <= z {
            *v = fill;
        }
    }
}

impl RasterSource for Reassigned<'_> {
    fn info(&self) -> &RasterInfo {
        &self.info
    }

    fn read_native(&self, win: Window) -> Result<AnyGrid> {
        let mut g = self.inner.read_native(win)?;
        let m: Option<Grid<f64>> = match &self.mask {
            Some(m) => Some(crate::raster::read_window(m.as_ref(), win)?),
            None => None,
        };
        if self.sea_level.is_some() || m.is_some() {
            let nd = self.info.georef.nodata;
            crate::dispatch_any!(&mut g, x => mask_cells(x, self.sea_level, m.as_ref(), nd));
        }
        Ok(g)
    }

    fn band(&self) -> (usize, usize) {
        self.inner.band()
    }

    fn unused_georef(&self) -> Option<&str> {
        self.inner.unused_georef()
    }

    fn scaling(&self) -> Option<crate::raster::Scaling> {
        self.inner.scaling()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raster::{read_window, GeoRef, MemRaster};

    fn src(g: AnyGrid, nodata: Option<f64>) -> Box<dyn RasterSource> {
        let mut georef = GeoRef::pixel();
        georef.nodata = nodata;
        Box::new(MemRaster::new(g, georef, "t.tif"))
    }

    #[test]
    fn nodata_is_assigned_or_replaced() {
        let g = AnyGrid::I16(Grid::from_vec(3, 1, vec![-9999i16, 5, -32768]).unwrap());
        // assigned where the file has none
        let r = reassign(src(g.clone(), None), Some(-9999.0), None, None).unwrap();
        let f: Grid<f32> = read_window(r.as_ref(), Window::full(3, 1)).unwrap();
        assert!(f.get(0, 0).is_nan() && f.get(1, 0) == 5.0 && f.get(2, 0) == -32768.0);
        // replaced: the old value becomes data
        let r = reassign(src(g, Some(-32768.0)), Some(-9999.0), None, None).unwrap();
        let f: Grid<f32> = read_window(r.as_ref(), Window::full(3, 1)).unwrap();
        assert!(f.get(0, 0).is_nan() && f.get(2, 0) == -32768.0);
    }

    #[test]
    fn sea_at_or_below_the_level_is_nodata() {
        let g = AnyGrid::I16(Grid::from_vec(4, 1, vec![0i16, 1, -3, -32768]).unwrap());
        let r = reassign(src(g, Some(-32768.0)), None, Some(0.0), None).unwrap();
        match r.read_native(Window::full(4, 1)).unwrap() {
            AnyGrid::I16(n) => assert_eq!(n.data(), &[-32768, 1, -32768, -32768]),
            other => panic!("{other:?}"),
        }
        let f = AnyGrid::F32(Grid::from_vec(3, 1, vec![0.5f32, 0.0, f32::NAN]).unwrap());
        let r = reassign(src(f, None), None, Some(0.0), None).unwrap();
        let v: Grid<f32> = read_window(r.as_ref(), Window::full(3, 1)).unwrap();
        assert!(v.get(0, 0) == 0.5 && v.get(1, 0).is_nan() && v.get(2, 0).is_nan());
    }

    #[test]
    fn masked_cells_are_nodata() {
        let g = AnyGrid::F32(Grid::from_vec(4, 1, vec![5.0f32, 6.0, 7.0, 8.0]).unwrap());
        let m = AnyGrid::U8(Grid::from_vec(4, 1, vec![1u8, 0, 255, 9]).unwrap());
        let mut mask = src(m, Some(255.0));
        let r = reassign(src(g.clone(), None), None, None, Some(mask)).unwrap();
        let v: Grid<f32> = read_window(r.as_ref(), Window::full(4, 1)).unwrap();
        assert!(
            v.get(0, 0) == 5.0
                && v.get(1, 0).is_nan()
                && v.get(2, 0).is_nan()
                && v.get(3, 0) == 8.0
        );
        // another size is refused, naming both
        mask = src(AnyGrid::U8(Grid::new(3, 1, 1u8)), None);
        let e = reassign(src(g, None), None, None, Some(mask))
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("3x1") && e.contains("4x1"), "{e}");
    }

    #[test]
    fn impossible_requests_name_the_file_and_the_fix() {
        let g = AnyGrid::U8(Grid::from_vec(1, 1, vec![3u8]).unwrap());
        let e = reassign(src(g.clone(), None), Some(-1.0), None, None)
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("t.tif") && e.contains("0..=255"), "{e}");
        let e = reassign(src(g.clone(), None), Some(2.5), None, None)
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("2.5"), "{e}");
        let e = reassign(src(g, None), None, Some(0.0), None)
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("t.tif") && e.contains("--nodata"), "{e}");
    }
}
