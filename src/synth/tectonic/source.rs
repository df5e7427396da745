//! One layer of a tectonic model as a [`RasterSource`], and the map's
//! coordinates turned into pixels of a georeference.

use super::super::vector::VectorMap;
use super::TectonicLayer;
use super::TectonicModel;
use crate::error::Error;
use crate::error::Result;
use crate::raster::AnyGrid;
use crate::raster::DType;
use crate::raster::GeoRef;
use crate::raster::Grid;
use crate::raster::RasterInfo;
use crate::raster::RasterSource;
use crate::raster::Window;
use crate::synth::source_info;
use std::sync::Arc;

/// One layer of a [`TectonicModel`] as a tileable raster source.
pub struct TectonicSource {
    model: Arc<TectonicModel>,
    layer: TectonicLayer,
    info: RasterInfo,
}

impl TectonicSource {
    /// `layer` of `model`, georeferenced by `georef`.
    pub fn new(model: Arc<TectonicModel>, layer: TectonicLayer, georef: GeoRef) -> Self {
        let dtype = if layer == TectonicLayer::Plates {
            DType::I32
        } else {
            DType::F32
        };
        let info = source_info(model.width, model.height, dtype, georef, "<tectonic>");
        TectonicSource { model, layer, info }
    }
}

impl RasterSource for TectonicSource {
    fn info(&self) -> &RasterInfo {
        &self.info
    }
    fn read_native(&self, win: Window) -> Result<AnyGrid> {
        let mut v = vec![0.0; win.w * win.h];
        self.model.fill(self.layer, win, &mut v);
        Ok(if self.layer == TectonicLayer::Plates {
            AnyGrid::I32(Grid::from_vec(
                win.w,
                win.h,
                v.iter().map(|&x| x as i32).collect(),
            )?)
        } else {
            AnyGrid::F32(Grid::from_vec(
                win.w,
                win.h,
                v.iter().map(|&x| x as f32).collect(),
            )?)
        })
    }
}

/// Convert a map from CRS coordinates to pixel coordinates of `georef`
/// (north-up or rotated; errors on a singular transform).
pub fn map_to_pixels(map: &VectorMap, georef: &GeoRef) -> Result<VectorMap> {
    if georef.map_to_pixel(0.0, 0.0).is_none() {
        return Err(Error::invalid(
            "the output georeference has a singular transform",
        ));
    }
    Ok(map.transformed(|p| {
        let (c, r) = georef
            .map_to_pixel(p[0], p[1])
            .unwrap_or((f64::NAN, f64::NAN));
        [c, r]
    }))
}
