//! Flow accumulation in real areas (`orogen accumulate --units`): each cell
//! contributes its true area instead of 1, and the specific catchment area
//! divides the accumulated area by the width of the cell it flows through.
//!
//! - Cell areas: [`crate::raster::GeoRef::cell_area_m2`] — |det| of the
//!   transform on projected grids, the exact area of the cell's quadrangle
//!   on the WGS 84 ellipsoid per row on geographic grids (Snyder 1987,
//!   eq. 3-12), so a D8 accumulation in m² of a 3" SRTM tile counts a
//!   cell at 60°N as half one at the equator.
//! - [`CellAreas`] is a weights raster computed on the fly (area × the
//!   user's weight, or area alone), read by the D8, D∞ and MFD
//!   accumulations exactly as a weights file: the same bytes in memory and
//!   across tiles, with no second file on disk. Values are f32 as every
//!   weight (relative rounding ≤ 6e-8 per cell, then summed exactly in fixed
//!   point).
//! - Specific catchment area (SCA, Moore, Grayson & Ladson 1991, "Digital
//!   terrain modelling: a review of hydrological, geomorphological and
//!   biological applications", Hydrol. Process. 5, §3.1: upslope area per
//!   unit contour width): accumulated m² divided by the contour width
//!   `√(cell area)` of the cell's row — the cell size on square cells, as
//!   TauDEM's and WhiteboxTools' `A / cell size`; on geographic grids the
//!   side of the square of the row's cell area (a stated choice: a D8 cell
//!   has no single contour width when its sides differ).

use crate::error::{Error, Result};
use crate::raster::{AnyGrid, DType, GeoRef, Grid, RasterInfo, RasterSource, Window};

/// Units of an accumulation (`--units`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum AreaUnits {
    /// Cell counts (or sums of weights).
    #[default]
    Cells,
    /// Square metres of true cell area.
    M2,
    /// Square kilometres.
    Km2,
    /// Specific catchment area: m² per metre of contour width.
    Sca,
}

impl std::str::FromStr for AreaUnits {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        Ok(match s {
            "cells" => AreaUnits::Cells,
            "m2" => AreaUnits::M2,
            "km2" => AreaUnits::Km2,
            "sca" => AreaUnits::Sca,
            u => {
                return Err(Error::invalid(format!(
                    "--units {u:?}: use cells, m2, km2 or sca"
                )))
            }
        })
    }
}

impl AreaUnits {
    /// Scale of one m² in these units (cells: not an area, `None`).
    fn per_m2(self) -> Option<f64> {
        match self {
            AreaUnits::Cells => None,
            AreaUnits::M2 | AreaUnits::Sca => Some(1.0),
            AreaUnits::Km2 => Some(1e-6),
        }
    }
}

/// The contour width (m) of cells on `row` for [`AreaUnits::Sca`]: the side
/// of the square of the row's cell area.
pub fn contour_width(georef: &GeoRef, row: i64) -> f64 {
    georef.cell_area_m2(row).unwrap_or(1.0).sqrt()
}

/// Divide each row of `g` (raster rows from `first_row` on) by its contour
/// width: an accumulation of m² becomes the specific catchment area.
pub fn divide_by_contour_width(g: &mut Grid<f64>, georef: &GeoRef, first_row: i64) {
    let w = g.width().max(1);
    for (y, row) in g.data_mut().chunks_mut(w).enumerate() {
        let cw = contour_width(georef, first_row + y as i64);
        for v in row {
            *v /= cw;
        }
    }
}

/// A weights raster of true cell areas in `units` (times the cells of
/// `base` when given: a weights file), of the size and georeference of
/// `like`; f32, no nodata (a NaN weight counts 0, as in every weighted
/// accumulation). `None` for [`AreaUnits::Cells`] (the weights, if any, are
/// used as they are). Errors when the raster has no georeferencing.
pub struct CellAreas<'a> {
    info: RasterInfo,
    base: Option<&'a dyn RasterSource>,
    scale: f64,
}

impl<'a> CellAreas<'a> {
    /// Areas for the raster `like` in `units`, times `base` when given.
    pub fn new(
        like: &RasterInfo,
        base: Option<&'a dyn RasterSource>,
        units: AreaUnits,
    ) -> Result<Option<CellAreas<'a>>> {
        let Some(scale) = units.per_m2() else {
            return Ok(None);
        };
        if !like.georef.georeferenced {
            return Err(Error::invalid(format!(
                "{}: has no georeferencing, so its cells have no area; --units m2, km2 and sca need \
                 a georeferenced raster (or use --units cells)",
                like.path.display()
            )));
        }
        if let Some(b) = base {
            let bi = b.info();
            if (bi.width, bi.height) != (like.width, like.height) {
                return Err(Error::invalid(format!(
                    "{}: weights of {}x{} cells for a raster of {}x{}",
                    bi.path.display(),
                    bi.width,
                    bi.height,
                    like.width,
                    like.height
                )));
            }
        }
        let mut info = like.clone();
        info.dtype = DType::F32;
        info.georef = like.georef.clone().with_nodata(None);
        Ok(Some(CellAreas { info, base, scale }))
    }
}

impl RasterSource for CellAreas<'_> {
    fn info(&self) -> &RasterInfo {
        &self.info
    }
    fn read_native(&self, win: Window) -> Result<AnyGrid> {
        let base = match self.base {
            Some(b) => Some(crate::raster::read_window::<f32>(b, win)?),
            None => None,
        };
        let g = &self.info.georef;
        let mut out = Grid::new(win.w, win.h, 0f32);
        for y in 0..win.h {
            let row = win.y + y as i64;
            let a = g.cell_area_m2(row).unwrap_or(1.0) * self.scale;
            for x in 0..win.w {
                let v = match &base {
                    Some(b) => a * b.get(x, y) as f64,
                    None => a,
                };
                out.set(x, y, v as f32);
            }
        }
        Ok(AnyGrid::F32(out))
    }
}
