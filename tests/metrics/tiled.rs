//! Metrics on real DEMs: tiled == untiled, cell for cell and bit for bit,
//! for tile sizes 1, 7, 64 and the whole grid, for 1 and 2 threads; the
//! one-pass `MultiMetric` equals each metric run alone; `compute` writes
//! GeoTIFF and tile-store outputs equal to the in-memory result; spec
//! parsing and radius errors; halos from true cell sizes on geographic rasters.

#![allow(clippy::needless_range_loop)] // index loops read like the definitions

use orogen::exec::{Engine, EngineConfig, LocalEngine, MemSink, Run, TileSink};
use orogen::io::{open_raster, OpenOptions, OutputOptions};
use orogen::metrics::registry::{resolve, Length, MetricKind, METRICS};
use orogen::metrics::{compute, list, parse_specs, MultiMetric};
use orogen::raster::{Crs, DType, GeoRef, Grid, MemRaster, RasterSource, TileLayout};
use std::path::Path;

const SPECS: &str = "mean_curvature:radius=3c,profile_curvature:radius=2c,dzdx,slope,aspect,northness,normal_z,laplacian,profile_curvature,plan_curvature,tangential_curvature,mean_curvature,gaussian_curvature,min_curvature,max_curvature,mean:radius=4c,stdev:radius=3c,variance:radius=5c:shape=disk,tpi:radius=90m,ntpi:radius=4c,relief:radius=5c,tophat_white:radius=3c,tophat_black:radius=2c,percentile:radius=3c,sky_view_approx,tri_riley,tri,rugosity,roughness:radius=3c,openness:radius=150m,openness_neg:radius=4c:directions=16,sky_view:radius=150m";

use crate::common::run_bits as run;

fn tiled_equals_untiled(path: &str) {
    let src = open_raster(Path::new(path), &OpenOptions::default()).unwrap();
    check_tiled(src.as_ref(), path);
}

fn check_tiled(src: &dyn RasterSource, path: &str) {
    let info = src.info().clone();
    let whole = run(src, SPECS, info.width.max(info.height), 1);
    let specs = parse_specs(SPECS).unwrap();
    for (k, s) in specs.iter().enumerate() {
        let valid = whole[k].iter().filter(|&&v| v != u32::MAX).count();
        assert!(
            valid > info.width * info.height / 2,
            "{path}: {} mostly nodata",
            s.label()
        );
    }
    for (tile, threads) in [(1, 2), (7, 2), (64, 1), (64, 2)] {
        let got = run(src, SPECS, tile, threads);
        for (k, s) in specs.iter().enumerate() {
            if let Some(i) = (0..whole[k].len()).find(|&i| got[k][i] != whole[k][i]) {
                panic!(
                    "{path}: {} tile {tile}: cell ({}, {}) {:?} vs {:?}",
                    s.label(),
                    i % info.width,
                    i / info.width,
                    f32::from_bits(got[k][i]),
                    f32::from_bits(whole[k][i])
                );
            }
        }
    }
    // One pass for many metrics == each metric alone.
    for (k, s) in SPECS.split(',').enumerate() {
        let alone = run(src, s, 64, 1);
        assert!(
            alone[0] == whole[k],
            "{path}: {s} alone differs from the multi pass"
        );
    }
}

#[test]
fn tiled_equals_untiled_bigtujunga() {
    tiled_equals_untiled("tests/data/bigtujunga_crop.tif");
}

#[test]
fn tiled_equals_untiled_whitebox() {
    tiled_equals_untiled("tests/data/whitebox_DEM.tif");
}

/// Geographic 3" SRTM with nodata holes (the .asc has no .prj: its degrees
/// are declared WGS 84 here): per-row true cell sizes, halos from the
/// smallest true cell.
#[test]
fn tiled_equals_untiled_geographic() {
    let path = "tests/data/landlab_SRTMGL3_frontrange.asc";
    let asc = open_raster(Path::new(path), &OpenOptions::default()).unwrap();
    let i = asc.info().clone();
    let data = asc
        .read_native(orogen::raster::Window::full(i.width, i.height))
        .unwrap();
    let mut g = i.georef.clone();
    g.crs = Crs::wgs84();
    g.georeferenced = true;
    let src = MemRaster::new(data, g.clone(), path);
    let (ew, ns) = g.cell_size_m(0);
    assert!(
        ew > 60.0 && ew < 80.0 && ns > 90.0 && ns < 95.0,
        "{ew} {ns}"
    );
    check_tiled(&src, path);
}

#[test]
fn compute_writes_tif_and_store() {
    let dir = tempfile::tempdir().unwrap();
    let src = open_raster(
        Path::new("tests/data/bigtujunga_crop.tif"),
        &OpenOptions::default(),
    )
    .unwrap();
    let specs = parse_specs("slope,tpi:radius=3c,openness:radius=5c").unwrap();
    let outs = vec![
        dir.path().join("slope.tif"),
        dir.path().join("tpi.tiles"),
        dir.path().join("openness.tif"),
    ];
    let cfg = EngineConfig {
        threads: 2,
        ..EngineConfig::default()
    };
    compute(
        src.as_ref(),
        &specs,
        &outs,
        &OutputOptions::default(),
        Some(50),
        &cfg,
    )
    .unwrap();
    let want = run(
        src.as_ref(),
        "slope,tpi:radius=3c,openness:radius=5c",
        301,
        1,
    );
    for (k, p) in outs.iter().enumerate() {
        let r = open_raster(p, &OpenOptions::default()).unwrap();
        let i = r.info();
        assert_eq!((i.width, i.height, i.dtype), (301, 203, DType::F32));
        let g = orogen::raster::read_window::<f32>(
            r.as_ref(),
            orogen::raster::Window::full(i.width, i.height),
        )
        .unwrap();
        let bits: Vec<u32> = g
            .data()
            .iter()
            .map(|v| if v.is_nan() { u32::MAX } else { v.to_bits() })
            .collect();
        assert!(
            bits == want[k],
            "{} differs from the in-memory run",
            p.display()
        );
    }
    // Wrong number of outputs is an error, not a panic.
    let e = compute(
        src.as_ref(),
        &specs,
        &outs[..1],
        &OutputOptions::default(),
        None,
        &cfg,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("3 metric(s)"), "{e}");
}

fn err(s: &str) -> String {
    parse_specs(s).unwrap_err().to_string()
}

#[test]
fn parse_specs_values_and_errors() {
    let s = parse_specs("slope, tpi:radius=500m ,openness:radius=1.5km:directions=16,relief:radius=25c,slope:units=percent").unwrap();
    assert_eq!(s.len(), 5);
    assert_eq!(s[0].kind, MetricKind::Slope);
    assert_eq!(s[1].radius, Some(Length::Metres(500.0)));
    assert_eq!(s[2].radius, Some(Length::Metres(1500.0)));
    assert_eq!(s[2].directions, 16);
    assert_eq!(s[3].radius, Some(Length::Cells(25)));
    assert_eq!(s[4].label(), "slope_pct");
    let disk = parse_specs("tpi:radius=5c:shape=disk").unwrap();
    assert!(disk[0].disk);
    assert_eq!(disk[0].label(), "tpi_r5c_disk");
    assert!(err("tpi:shape=circle").contains("square or disk"));
    assert!(err("relief:shape=disk").contains("no parameter 'shape'"));
    assert_eq!(s[1].label(), "tpi_r500m");
    // Defaults.
    assert_eq!(
        parse_specs("tpi").unwrap()[0].radius,
        Some(Length::Cells(3))
    );

    let e = err("slope,bogus");
    assert!(
        e.contains("unknown metric 'bogus'") && e.contains("tpi") && e.contains("sky_view"),
        "{e}"
    );
    let e = err("tpi:size=3c");
    assert!(
        e.contains("no parameter 'size'") && e.contains("radius"),
        "{e}"
    );
    let e = err("slope:radius=3c");
    assert!(
        e.contains("no parameter 'radius'") && e.contains("no parameters") || e.contains("units"),
        "{e}"
    );
    let e = err("tpi:radius=-5m");
    assert!(e.contains("positive"), "{e}");
    let e = err("tpi:radius=0c");
    assert!(e.contains("out of range"), "{e}");
    let e = err("tpi:radius=5");
    assert!(e.contains("not a length") && e.contains("25c"), "{e}");
    let e = err("tpi:radius=nanm");
    assert!(e.contains("positive finite"), "{e}");
    let e = err("openness:directions=12");
    assert!(e.contains("8 or 16"), "{e}");
    let e = err("tpi:radius=3c:radius=4c");
    assert!(e.contains("twice"), "{e}");
    let e = err("slope,,tpi");
    assert!(e.contains("empty metric"), "{e}");
    let e = err("tpi:radius");
    assert!(e.contains("param=value"), "{e}");
    let e = err("tpi:radius=99999c");
    assert!(e.contains("out of range"), "{e}");

    // Output names from labels; duplicates refused.
    let p = orogen::metrics::output_paths(&s[..4], Path::new("out"), "tif").unwrap();
    assert_eq!(p[1], Path::new("out/tpi_r500m.tif"));
    assert_eq!(p[3], Path::new("out/relief_r25c.tif"));
    let dup = parse_specs("tpi:radius=3c,slope,tpi:radius=3c").unwrap();
    let e = orogen::metrics::output_paths(&dup, Path::new("o"), "tif")
        .unwrap_err()
        .to_string();
    assert!(e.contains("twice"), "{e}");
    // Curvatures at the default radius keep their plain name.
    assert_eq!(
        parse_specs("mean_curvature").unwrap()[0].label(),
        "mean_curvature"
    );
    assert_eq!(
        parse_specs("mean_curvature:radius=5c").unwrap()[0].label(),
        "mean_curvature_r5c"
    );

    // The list names every metric with its citation.
    let l = list();
    for d in METRICS {
        assert!(l.contains(d.name) && l.contains(d.citation), "{}", d.name);
    }
}

#[test]
fn radius_beyond_raster_is_an_error() {
    let g = Grid::new(40, 30, 1.0f32);
    let src = MemRaster::from_grid(g, GeoRef::north_up(0.0, 0.0, 30.0, Crs::projected(32611)));
    let ok = parse_specs("tpi:radius=900m").unwrap();
    let r = resolve(&ok, src.info()).unwrap();
    assert_eq!((r[0].radius_cells, r[0].radius_m), (30, 900.0));
    let bad = parse_specs("tpi:radius=2km").unwrap();
    let e = MultiMetric::new(&bad, src.info()).unwrap_err().to_string();
    assert!(e.contains("67 cells") && e.contains("40x30"), "{e}");
    let bad = parse_specs("relief:radius=41c").unwrap();
    assert!(MultiMetric::new(&bad, src.info()).is_err());
    assert!(MultiMetric::new(&[], src.info()).is_err());
}

#[test]
fn geographic_radius_uses_smallest_true_cell() {
    // 1/1200° cells from 60°N to 59.5°N: the east-west size shrinks
    // northwards and is smallest on the top row.
    let d = 1.0 / 1200.0;
    let mut gr = GeoRef::north_up(10.0, 60.0, d, Crs::wgs84());
    gr.transform[5] = -d;
    let src = MemRaster::from_grid(Grid::new(600, 600, 0.0f32), gr.clone());
    let (ew_top, _) = gr.cell_size_m(0);
    // Spherical check of the scale (independent of the ellipsoid formula):
    // 6371 km · cos(60°) · d · π/180 within 0.5 %.
    let sph = 6_371_000.0 * 60f64.to_radians().cos() * d.to_radians();
    assert!((ew_top - sph).abs() / sph < 5e-3, "{ew_top} vs {sph}");
    let r = resolve(&parse_specs("mean:radius=1km").unwrap(), src.info()).unwrap();
    assert_eq!(r[0].radius_cells, (1000.0 / ew_top).ceil() as usize);
    assert!(r[0].radius_cells > (1000.0 / gr.cell_size_m(599).0).ceil() as usize - 1);
}

#[test]
fn hostile_values_are_errors() {
    // Windowed sums are exact only within ±5e7: bigger values are refused.
    let mut g = Grid::new(10, 10, 1.0f32);
    g.set(3, 3, 1e9);
    let src = MemRaster::from_grid(g, GeoRef::north_up(0.0, 0.0, 1.0, Crs::projected(32611)));
    let specs = parse_specs("mean:radius=2c").unwrap();
    let step = MultiMetric::new(&specs, src.info()).unwrap();
    let (s, _h) = MemSink::new(10, 10, DType::F32, None);
    let e = LocalEngine::new(EngineConfig::default())
        .run_local(
            &step,
            Run::new(
                &[&src as &dyn RasterSource],
                TileLayout::new(10, 10, 4),
                vec![Box::new(s)],
            ),
        )
        .unwrap_err()
        .to_string();
    assert!(e.contains("rescale"), "{e}");
    // Infinite heights do not panic.
    let mut g = Grid::new(10, 10, 1.0f32);
    g.set(5, 5, f32::INFINITY);
    let src = MemRaster::from_grid(g, GeoRef::north_up(0.0, 0.0, 1.0, Crs::projected(32611)));
    let step = MultiMetric::new(
        &parse_specs("slope,laplacian,openness:radius=2c,relief:radius=2c").unwrap(),
        src.info(),
    )
    .unwrap();
    let sinks: Vec<Box<dyn TileSink>> = (0..4)
        .map(|_| Box::new(MemSink::new(10, 10, DType::F32, None).0) as Box<dyn TileSink>)
        .collect();
    LocalEngine::new(EngineConfig::default())
        .run_local(
            &step,
            Run::new(
                &[&src as &dyn RasterSource],
                TileLayout::new(10, 10, 4),
                sinks,
            ),
        )
        .unwrap();
}
