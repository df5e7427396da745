//! Declared sinks: the cells where water leaves the land although they are
//! not at the DEM's edge or beside nodata (endorheic basins: the Dead Sea,
//! the Caspian, karst sinkholes, a closed lake's bed), given as a raster on
//! the DEM's grid (non-zero, not nodata = sink; GDAL's mask convention read
//! the other way round: a map of where the sinks are) or as points (CSV
//! x,y / lon,lat or GeoJSON Points, [`super::vector`]), each the cell it
//! falls in. Read as a u8 raster source on the DEM's grid, 1 at sinks, so a
//! tiled step takes it as a second input and sees it through the same tile
//! views and halos as the DEM.

use crate::error::{Error, Result};
use crate::raster::{AnyGrid, DType, Grid, RasterInfo, RasterSource, Window};
use std::path::Path;

/// The sinks of `path` on the grid of `dem`: a raster (any format
/// [`super::open_raster`] reads; of the DEM's size and grid) or a points
/// file (`.csv`, `.geojson`, `.json`). Errors name the file and the fix.
pub fn open_sinks(path: &Path, dem: &RasterInfo) -> Result<Box<dyn RasterSource>> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    if matches!(ext.as_str(), "csv" | "geojson" | "json") {
        let pts = super::vector::read_points_in(
            path,
            super::vector::PointNoun {
                one: "sink",
                many: "sinks",
            },
            &dem.georef,
        )?;
        let mut cells = Vec::with_capacity(pts.len());
        for (i, p) in pts.iter().enumerate() {
            let inside = dem.georef.cell_at(p.x, p.y, dem.width, dem.height);
            let Some((c, r)) = inside else {
                return Err(Error::invalid(format!(
                    "{}: sink {} ({}, {}) lies outside {} ({}x{} cells); give points on the DEM",
                    path.display(),
                    p.name.clone().unwrap_or_else(|| (i + 1).to_string()),
                    p.x,
                    p.y,
                    dem.path.display(),
                    dem.width,
                    dem.height
                )));
            };
            cells.push(r * dem.width + c);
        }
        cells.sort_unstable();
        cells.dedup();
        let mut info = dem.clone();
        info.dtype = DType::U8;
        info.georef.nodata = None;
        info.path = path.to_path_buf();
        return Ok(Box::new(PointSinks { info, cells }));
    }
    let src = super::open_raster(path, &Default::default())?;
    super::reassign::same_grid(src.info(), dem, "sink raster")?;
    let mut info = dem.clone();
    info.dtype = DType::U8;
    info.georef.nodata = None;
    info.path = path.to_path_buf();
    info.block = src.info().block;
    Ok(Box::new(RasterSinks { inner: src, info }))
}

/// Sinks at the cells (row-major indices, sorted) of points.
struct PointSinks {
    info: RasterInfo,
    cells: Vec<usize>,
}

impl RasterSource for PointSinks {
    fn info(&self) -> &RasterInfo {
        &self.info
    }
    fn read_native(&self, win: Window) -> Result<AnyGrid> {
        let w = self.info.width;
        let mut g = Grid::<u8>::new(win.w, win.h, 0);
        for y in 0..win.h {
            let row = (win.y as usize + y) * w;
            let (a, b) = (row + win.x as usize, row + win.x as usize + win.w);
            let from = self.cells.partition_point(|&c| c < a);
            for &c in self.cells[from..].iter().take_while(|&&c| c < b) {
                g.set(c - a, y, 1);
            }
        }
        Ok(AnyGrid::U8(g))
    }
}

/// A raster of sinks: 1 where it is non-zero and not nodata.
struct RasterSinks {
    inner: Box<dyn RasterSource>,
    info: RasterInfo,
}

impl RasterSource for RasterSinks {
    fn info(&self) -> &RasterInfo {
        &self.info
    }
    fn read_native(&self, win: Window) -> Result<AnyGrid> {
        let g: Grid<f64> = crate::raster::read_window(self.inner.as_ref(), win)?;
        Ok(AnyGrid::U8(g.map(|v| u8::from(v != 0.0 && !v.is_nan()))))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raster::{read_window, GeoRef, MemRaster};

    #[test]
    fn points_become_cells_and_rasters_non_zero_cells() {
        let t = tempfile::tempdir().unwrap();
        let mut georef = GeoRef::pixel();
        georef.transform = [100.0, 10.0, 0.0, 500.0, 0.0, -10.0];
        georef.georeferenced = true;
        let dem = MemRaster::new(AnyGrid::F32(Grid::new(6, 4, 1.0)), georef, "dem.tif");
        let csv = t.path().join("s.csv");
        std::fs::write(&csv, "x,y\n125,485\n159.9,460.1\n125,481\n").unwrap();
        let s = open_sinks(&csv, dem.info()).unwrap();
        let g: Grid<u8> = read_window(s.as_ref(), Window::new(0, 0, 6, 4)).unwrap();
        let ones: Vec<usize> = (0..24).filter(|&i| g.data()[i] == 1).collect();
        assert_eq!(ones, vec![6 + 2, 3 * 6 + 5]);
        let part: Grid<u8> = read_window(s.as_ref(), Window::new(1, 0, 3, 4)).unwrap();
        assert_eq!(part.get(1, 1), 1);
        assert_eq!(part.data().iter().filter(|&&v| v == 1).count(), 1);
        std::fs::write(&csv, "x,y\n125,585\n").unwrap();
        let e = open_sinks(&csv, dem.info()).err().unwrap().to_string();
        assert!(e.contains("lies outside"), "{e}");
    }
}
