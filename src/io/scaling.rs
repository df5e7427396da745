//! A band's scale and offset applied on read: the value a cell means is
//! `raw * scale + offset`, GDAL's band `Scale`/`Offset` (GDAL data model,
//! "Raster Band": "a scale factor and offset ... to convert raw pixel
//! values into meaningful values"; `gdal_translate -unscale` applies them).
//!
//! Where files keep them:
//! - GeoTIFF: GDAL's private GDAL_METADATA tag (42112), an XML list of
//!   `<Item name="SCALE" sample="S" role="scale">v</Item>` and the same with
//!   `OFFSET`/`role="offset"`, `S` the 0-based band ([`from_gdal_metadata`]).
//!   A UInt16 DEM with scale 0.1 and offset −500 holds decimetres above
//!   −500 m; read raw it is off by a factor of ten and 500 m.
//! - PNG heightmaps written by orogen: `tEXt` chunks and a GDAL `.aux.xml`
//!   sidecar ([`super::png`]).
//!
//! The scaled source reads as f32 (f64 for 32-bit integers and f64 cells,
//! which f32 cannot hold exactly), with the file's nodata cells as NaN: the
//! nodata value belongs to the raw cells (GDAL compares it before scaling),
//! so `--nodata V` is a raw value too, while `--sea-level Z` is an elevation
//! and is applied after scaling (see [`super::open_raster`]).

use crate::error::Result;
pub use crate::raster::Scaling;
use crate::raster::{AnyGrid, Cell, DType, Grid, RasterInfo, RasterSource, Window};

/// The scale and offset of band `band` (1-based) in the text of a
/// GDAL_METADATA tag, or None when it names neither (a missing one is 1 or
/// 0) or the text is not XML. Items without a `sample` attribute are
/// dataset metadata, not a band's, and are ignored, as GDAL does.
pub fn from_gdal_metadata(xml: &str, band: usize) -> Option<Scaling> {
    let want = band.checked_sub(1)?.to_string();
    let doc = roxmltree::Document::parse(xml.trim_end_matches('\0')).ok()?;
    let (mut scale, mut offset) = (None, None);
    for item in doc.descendants().filter(|n| n.has_tag_name("Item")) {
        if item.attribute("sample") != Some(want.as_str()) {
            continue;
        }
        let role = item.attribute("role").or_else(|| item.attribute("name"));
        let v = item
            .text()
            .and_then(|t| t.trim().parse::<f64>().ok())
            .filter(|v| v.is_finite());
        match role.map(|r| r.to_ascii_lowercase()).as_deref() {
            Some("scale") => scale = v.or(scale),
            Some("offset") => offset = v.or(offset),
            _ => {}
        }
    }
    (scale.is_some() || offset.is_some()).then(|| Scaling {
        scale: scale.unwrap_or(1.0),
        offset: offset.unwrap_or(0.0),
    })
}

/// `inner` with `scaling` applied on read (identity: `inner` unchanged).
pub fn unscale<'a>(
    inner: Box<dyn RasterSource + 'a>,
    scaling: Scaling,
) -> Box<dyn RasterSource + 'a> {
    if scaling.is_identity() {
        return inner;
    }
    let mut info = inner.info().clone();
    let raw_nodata = info.georef.nodata;
    info.dtype = match info.dtype {
        DType::U32 | DType::I32 | DType::F64 => DType::F64,
        _ => DType::F32,
    };
    info.georef.nodata = raw_nodata.map(|_| f64::NAN);
    Box::new(Unscaled {
        inner,
        info,
        raw_nodata,
        scaling,
    })
}

struct Unscaled<'a> {
    inner: Box<dyn RasterSource + 'a>,
    info: RasterInfo,
    raw_nodata: Option<f64>,
    scaling: Scaling,
}

/// `g`'s cells scaled into a grid of `T` (NaN at nodata and NaN cells).
fn scaled<S: Cell, T: Cell>(g: &Grid<S>, nodata: Option<f64>, s: Scaling) -> Grid<T> {
    g.map(|v| {
        let raw = v.to_f64();
        if raw.is_nan() || Some(raw) == nodata {
            T::from_f64(f64::NAN)
        } else {
            T::from_f64(raw * s.scale + s.offset)
        }
    })
}

impl RasterSource for Unscaled<'_> {
    fn info(&self) -> &RasterInfo {
        &self.info
    }

    fn read_native(&self, win: Window) -> Result<AnyGrid> {
        let g = self.inner.read_native(win)?;
        let (nd, s) = (self.raw_nodata, self.scaling);
        Ok(match self.info.dtype {
            DType::F64 => AnyGrid::F64(crate::dispatch_any!(&g, x => scaled(x, nd, s))),
            _ => AnyGrid::F32(crate::dispatch_any!(&g, x => scaled(x, nd, s))),
        })
    }

    fn band(&self) -> (usize, usize) {
        self.inner.band()
    }

    fn unused_georef(&self) -> Option<&str> {
        self.inner.unused_georef()
    }

    fn scaling(&self) -> Option<Scaling> {
        Some(self.scaling)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raster::{read_window, GeoRef, MemRaster};

    #[test]
    fn gdal_metadata_items_of_the_band_are_read() {
        let xml = r#"<GDALMetadata>
  <Item name="DataType">Generic</Item>
  <Item name="OFFSET" sample="0" role="offset">-500</Item>
  <Item name="SCALE" sample="0" role="scale">0.100000000000000006</Item>
  <Item name="SCALE" sample="1" role="scale">2</Item>
</GDALMetadata>"#;
        assert_eq!(
            from_gdal_metadata(xml, 1),
            Some(Scaling {
                scale: 0.1,
                offset: -500.0
            })
        );
        assert_eq!(
            from_gdal_metadata(xml, 2),
            Some(Scaling {
                scale: 2.0,
                offset: 0.0
            })
        );
        assert_eq!(from_gdal_metadata(xml, 3), None);
        assert_eq!(
            from_gdal_metadata(
                r#"<GDALMetadata><Item name="STATISTICS_MAXIMUM" sample="0">3</Item></GDALMetadata>"#,
                1
            ),
            None
        );
        assert_eq!(from_gdal_metadata("<GDALMetadata>", 1), None);
        assert_eq!(from_gdal_metadata("not xml", 1), None);
    }

    #[test]
    fn raw_cells_are_scaled_and_raw_nodata_is_nan() {
        let raw = Grid::from_vec(3, 1, vec![0u16, 65535, 5000]).unwrap();
        let mut georef = GeoRef::pixel();
        georef.nodata = Some(65535.0);
        let src: Box<dyn RasterSource> = Box::new(MemRaster::new(AnyGrid::U16(raw), georef, "x"));
        let s = unscale(
            src,
            Scaling {
                scale: 0.1,
                offset: -500.0,
            },
        );
        assert_eq!(s.info().dtype, DType::F32);
        assert!(s.info().georef.nodata.unwrap().is_nan());
        let g: Grid<f64> = read_window(s.as_ref(), Window::new(0, 0, 3, 1)).unwrap();
        assert_eq!(g.data()[0], -500.0);
        assert!(g.data()[1].is_nan());
        assert_eq!(g.data()[2], (5000.0f64 * 0.1 - 500.0) as f32 as f64);
    }
}
