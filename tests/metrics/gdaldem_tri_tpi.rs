//! Peer check: TRI (Riley and Wilson forms), TPI and roughness against GDAL
//! 3.6.2 `gdaldem` outputs recorded in `tests/data/gdaldem/` on a real DEM.
//! gdaldem's TPI is the centre minus the mean of its 8 neighbours (orogen's
//! `tpi:radius=1c`) and its roughness is max − min of the 3x3 window
//! (orogen's `relief:radius=1c`). gdaldem leaves the outer ring nodata;
//! orogen's windowed metrics use the partial window there, so only interior
//! cells are compared.

use orogen::exec::{Engine, EngineConfig, LocalEngine, MemSink, Run, TileSink};
use orogen::io::{open_raster, OpenOptions};
use orogen::metrics::{parse_specs, MultiMetric};
use orogen::raster::{read_window, DType, RasterSource, TileLayout, Window};
use std::path::Path;

#[test]
fn matches_gdaldem_tri_tpi_roughness() {
    let src = open_raster(
        Path::new("tests/data/bigtujunga_crop.tif"),
        &OpenOptions::default(),
    )
    .unwrap();
    let info = src.info().clone();
    let (w, h) = (info.width, info.height);
    let specs = parse_specs("tri_riley,tri,tpi:radius=1c,relief:radius=1c").unwrap();
    let step = MultiMetric::new(&specs, &info).unwrap();
    let mut sinks: Vec<Box<dyn TileSink>> = Vec::new();
    let mut handles = Vec::new();
    for _ in &specs {
        let (s, hd) = MemSink::new(w, h, DType::F32, None);
        sinks.push(Box::new(s));
        handles.push(hd);
    }
    LocalEngine::new(EngineConfig::default())
        .run_local(
            &step,
            Run::new(
                &[src.as_ref() as &dyn RasterSource],
                TileLayout::new(w, h, 64),
                sinks,
            ),
        )
        .unwrap();
    let files = ["tri_riley", "tri_wilson", "tpi", "roughness"];
    for (k, f) in files.iter().enumerate() {
        let got = handles[k].take().unwrap().to_typed::<f32>(None);
        let peer = open_raster(
            Path::new(&format!("tests/data/gdaldem/{f}.tif")),
            &OpenOptions::default(),
        )
        .unwrap();
        let want = read_window::<f32>(peer.as_ref(), Window::full(w, h)).unwrap();
        let mut compared = 0;
        for y in 1..h - 1 {
            for x in 1..w - 1 {
                let (g, e) = (got.get(x, y), want.get(x, y));
                assert!(!e.is_nan(), "{f}: gdaldem nodata inside at ({x},{y})");
                assert!(
                    (g - e).abs() <= 1e-4 * e.abs().max(1.0),
                    "{f} ({x},{y}): orogen {g}, gdaldem {e}"
                );
                compared += 1;
            }
        }
        assert_eq!(compared, (w - 2) * (h - 2));
    }
}
