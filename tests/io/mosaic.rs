//! Mosaics: three in-memory sources with gaps and overlaps against a
//! brute-force per-cell expectation computed from map coordinates, rejection
//! of misaligned inputs, streaming (only intersecting sources are read),
//! directory expansion, and the real SRTM pair N43E006 + N43E007.

use orogen::io::hgt::read_hgt;
use orogen::io::mosaic::{expand_inputs, Mosaic};
use orogen::raster::{
    read_window, AnyGrid, Crs, DType, GeoRef, Grid, MemRaster, RasterInfo, RasterSource, Window,
};
use orogen::Error;
use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;

fn err<T>(r: orogen::Result<T>) -> Error {
    match r {
        Err(e) => e,
        Ok(_) => panic!("expected an error"),
    }
}

/// One synthetic input: name, top-left corner in map units, typed values.
struct Spec {
    name: &'static str,
    x0: f64,
    y0: f64,
    grid: AnyGrid,
    nodata: Option<f64>,
}

const CELL: f64 = 30.0;

fn specs() -> Vec<Spec> {
    // "b" overlaps "a" and "c"; "c" is apart, leaving a gap; each has nodata cells.
    let a = Grid::from_fn(10, 8, |x, y| {
        if (x + y) % 7 == 0 {
            -9999i16
        } else {
            (100 + x * 10 + y) as i16
        }
    });
    let b = Grid::from_fn(9, 9, |x, y| {
        if x == y {
            f32::NAN
        } else {
            500.0 + x as f32 * 0.5 - y as f32
        }
    });
    let c = Grid::from_fn(5, 4, |x, y| {
        if x == 0 && y == 0 {
            -32768i16
        } else {
            (900 + x + 10 * y) as i16
        }
    });
    vec![
        Spec {
            name: "/d/c.tif",
            x0: 1000.0 + 16.0 * CELL,
            y0: 5000.0 - 9.0 * CELL,
            grid: AnyGrid::I16(c),
            nodata: Some(-32768.0),
        },
        Spec {
            name: "/d/a.tif",
            x0: 1000.0,
            y0: 5000.0,
            grid: AnyGrid::I16(a),
            nodata: Some(-9999.0),
        },
        Spec {
            name: "/d/b.tif",
            x0: 1000.0 + 6.0 * CELL,
            y0: 5000.0 - 4.0 * CELL,
            grid: AnyGrid::F32(b),
            nodata: None,
        },
    ]
}

fn sources(specs: &[Spec]) -> Vec<Box<dyn RasterSource>> {
    specs
        .iter()
        .map(|s| {
            let g = GeoRef::north_up(s.x0, s.y0, CELL, Crs::projected(32611)).with_nodata(s.nodata);
            Box::new(MemRaster::new(s.grid.clone(), g, s.name)) as Box<dyn RasterSource>
        })
        .collect()
}

/// Brute force: for the centre of every cell of the union, the first source by
/// name whose extent contains it with a valid value.
fn expected(specs: &[Spec]) -> (f64, f64, Grid<f64>) {
    let mut order: Vec<&Spec> = specs.iter().collect();
    order.sort_by_key(|s| s.name);
    let x0 = order.iter().map(|s| s.x0).fold(f64::INFINITY, f64::min);
    let y0 = order.iter().map(|s| s.y0).fold(f64::NEG_INFINITY, f64::max);
    let x1 = order
        .iter()
        .map(|s| s.x0 + s.grid.width() as f64 * CELL)
        .fold(f64::NEG_INFINITY, f64::max);
    let y1 = order
        .iter()
        .map(|s| s.y0 - s.grid.height() as f64 * CELL)
        .fold(f64::INFINITY, f64::min);
    let w = ((x1 - x0) / CELL).round() as usize;
    let h = ((y0 - y1) / CELL).round() as usize;
    let g = Grid::from_fn(w, h, |c, r| {
        let (mx, my) = (x0 + (c as f64 + 0.5) * CELL, y0 - (r as f64 + 0.5) * CELL);
        for s in &order {
            let sc = ((mx - s.x0) / CELL).floor();
            let sr = ((s.y0 - my) / CELL).floor();
            if sc < 0.0 || sr < 0.0 || sc >= s.grid.width() as f64 || sr >= s.grid.height() as f64 {
                continue;
            }
            let v = s.grid.get_f64(sc as usize, sr as usize);
            if v.is_nan() || Some(v) == s.nodata {
                continue;
            }
            return v;
        }
        f64::NAN
    });
    (x0, y0, g)
}

#[test]
fn three_sources_with_gaps_and_overlaps() {
    let sp = specs();
    let m = Mosaic::new(sources(&sp)).unwrap();
    let (x0, y0, want) = expected(&sp);
    let i = m.info();
    assert_eq!((i.width, i.height), (want.width(), want.height()));
    assert_eq!((i.width, i.height), (21, 13));
    assert_eq!(i.dtype, DType::F32, "i16 + f32 -> f32");
    assert!(
        i.georef.nodata.is_some_and(|v| v.is_nan()),
        "sources disagree -> NaN"
    );
    assert_eq!(i.georef.transform, [x0, CELL, 0.0, y0, 0.0, -CELL]);
    let names: Vec<_> = m.extents().into_iter().map(|(p, _)| p).collect();
    assert_eq!(
        names,
        ["/d/a.tif", "/d/b.tif", "/d/c.tif"].map(PathBuf::from)
    );
    let full: Grid<f64> = read_window(&m, Window::full(i.width, i.height)).unwrap();
    let mut gaps = 0;
    for r in 0..want.height() {
        for c in 0..want.width() {
            let (a, b) = (full.get(c, r), want.get(c, r));
            gaps += b.is_nan() as usize;
            assert!(
                a == b || (a.is_nan() && b.is_nan()),
                "({c}, {r}): {a} vs {b}"
            );
        }
    }
    assert!(gaps > 20, "the layout has gaps ({gaps})");
    // Sub-windows, including ones reaching beyond the mosaic.
    for (x, y, w, h) in [
        (3, 2, 7, 5),
        (0, 0, 1, 1),
        (15, 8, 6, 5),
        (-3, -2, 30, 20),
        (9, 4, 1, 9),
    ] {
        let got: Grid<f64> = read_window(&m, Window::new(x, y, w, h)).unwrap();
        for r in 0..h {
            for c in 0..w {
                let (gx, gy) = (x + c as i64, y + r as i64);
                let b = if gx < 0 || gy < 0 || gx >= 21 || gy >= 13 {
                    f64::NAN
                } else {
                    want.get(gx as usize, gy as usize)
                };
                let a = got.get(c, r);
                assert!(
                    a == b || (a.is_nan() && b.is_nan()),
                    "win ({x},{y}) cell ({c},{r}): {a} vs {b}"
                );
            }
        }
    }
}

#[test]
fn common_nodata_and_type_are_kept() {
    let mk = |name: &str, x0: f64, v: i16| {
        let g = Grid::from_fn(4, 3, |x, _| if x == 1 { -9999 } else { v });
        let geo = GeoRef::north_up(x0, 0.0, 1.0, Crs::wgs84()).with_nodata(Some(-9999.0));
        Box::new(MemRaster::new(AnyGrid::I16(g), geo, name)) as Box<dyn RasterSource>
    };
    // Overlap of one column (x = 3 of "p" is x = 0 of "q"), gap column from nothing.
    let m = Mosaic::new(vec![
        mk("q.hgt", 3.0, 2),
        mk("p.hgt", 0.0, 1),
        mk("r.hgt", 8.0, 3),
    ])
    .unwrap();
    assert_eq!(m.info().dtype, DType::I16);
    assert_eq!(m.info().georef.nodata, Some(-9999.0));
    let AnyGrid::I16(g) = m.read_native(Window::full(12, 3)).unwrap() else {
        panic!()
    };
    assert_eq!(
        g.row(0),
        &[1, -9999, 1, 1, -9999, 2, 2, -9999, 3, -9999, 3, 3]
    );
}

#[test]
fn misaligned_inputs_are_rejected() {
    let mk = |name: &str, x0: f64, cell: f64, crs: Crs| {
        let g = GeoRef::north_up(x0, 0.0, cell, crs);
        Box::new(MemRaster::new(AnyGrid::F32(Grid::new(3, 3, 1.0)), g, name))
            as Box<dyn RasterSource>
    };
    let base = || mk("a.tif", 0.0, 1.0, Crs::projected(32611));
    let e = err(Mosaic::new(vec![
        base(),
        mk("b.tif", 3.5, 1.0, Crs::projected(32611)),
    ]));
    let m = e.to_string();
    assert!(m.contains("b.tif") && m.contains("not aligned"), "{m}");
    let e = err(Mosaic::new(vec![
        base(),
        mk("b.tif", 3.0, 1.5, Crs::projected(32611)),
    ]));
    assert!(e.to_string().contains("cell size"), "{e}");
    let e = err(Mosaic::new(vec![
        base(),
        mk("b.tif", 3.0, 1.0, Crs::projected(32612)),
    ]));
    assert!(
        e.to_string().contains("EPSG:32612") && e.to_string().contains("b.tif"),
        "{e}"
    );
    let e = err(Mosaic::new(vec![
        base(),
        mk("b.tif", 3.0, 1.0, Crs::wgs84()),
    ]));
    assert!(e.to_string().contains("geographic"), "{e}");
    let mut rot = GeoRef::north_up(0.0, 0.0, 1.0, Crs::projected(32611));
    rot.transform[2] = 0.1;
    let r = Box::new(MemRaster::new(
        AnyGrid::F32(Grid::new(3, 3, 1.0)),
        rot,
        "c.tif",
    )) as Box<dyn RasterSource>;
    assert!(err(Mosaic::new(vec![base(), r]))
        .to_string()
        .contains("north-up"));
    // Within tolerance (1e-7 cell, 1e-12 relative cell size) is accepted.
    assert!(Mosaic::new(vec![
        base(),
        mk("b.tif", 3.0 + 1e-7, 1.0 + 1e-12, Crs::projected(32611))
    ])
    .is_ok());
    assert!(Mosaic::new(vec![]).is_err());
}

/// A source that counts the windows read from it.
struct Counting {
    inner: MemRaster,
    reads: Arc<AtomicUsize>,
}
impl RasterSource for Counting {
    fn info(&self) -> &RasterInfo {
        self.inner.info()
    }
    fn read_native(&self, win: Window) -> orogen::Result<AnyGrid> {
        self.reads.fetch_add(1, Ordering::SeqCst);
        self.inner.read_native(win)
    }
}

#[test]
fn reads_only_intersecting_sources() {
    let counters: Vec<Arc<AtomicUsize>> = (0..3).map(|_| Arc::new(AtomicUsize::new(0))).collect();
    let srcs: Vec<Box<dyn RasterSource>> = (0..3)
        .map(|k| {
            let g = GeoRef::north_up(k as f64 * 100.0, 0.0, 1.0, Crs::projected(3035));
            let inner = MemRaster::new(
                AnyGrid::F32(Grid::new(100, 50, k as f32)),
                g,
                format!("t{k}.tif"),
            );
            Box::new(Counting {
                inner,
                reads: counters[k].clone(),
            }) as Box<dyn RasterSource>
        })
        .collect();
    let m = Mosaic::new(srcs).unwrap();
    let g: Grid<f32> = read_window(&m, Window::new(120, 10, 50, 5)).unwrap();
    assert!(g.data().iter().all(|&v| v == 1.0));
    let n: Vec<usize> = counters.iter().map(|c| c.load(Ordering::SeqCst)).collect();
    assert_eq!(n, [0, 1, 0]);
}

#[test]
fn directories_expand_to_sorted_raster_files() {
    let dir = tempfile::tempdir().unwrap();
    for n in ["b.TIF", "a.hgt", "notes.txt", "c.asc", "d.png", "e.tiff"] {
        std::fs::write(dir.path().join(n), b"x").unwrap();
    }
    std::fs::create_dir(dir.path().join("sub.tif")).unwrap();
    let single = dir.path().join("notes.txt");
    let got = expand_inputs(&[dir.path().to_path_buf(), single.clone()]).unwrap();
    let names: Vec<String> = got
        .iter()
        .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    assert_eq!(
        names,
        ["a.hgt", "b.TIF", "c.asc", "d.png", "e.tiff", "notes.txt"]
    );
    assert!(expand_inputs(&[dir.path().join("missing")]).is_err());
}

#[test]
fn real_srtm_pair() {
    let p6 = crate::common::test_data("srtm/N43E006.hgt");
    let p7 = crate::common::test_data("srtm/N43E007.hgt");
    let (a, b) = (read_hgt(&p6).unwrap(), read_hgt(&p7).unwrap());
    let (ga, gb) = (a.grid().clone(), b.grid().clone());
    // Given in reverse order: the mosaic orders by path.
    let m = Mosaic::new(vec![Box::new(b), Box::new(a)]).unwrap();
    let i = m.info();
    assert_eq!((i.width, i.height, i.dtype), (2401, 1201, DType::I16));
    assert_eq!(i.georef.nodata, Some(-32768.0));
    assert!((i.georef.transform[0] - 5.999583333333334).abs() < 1e-12);
    let AnyGrid::I16(mg) = m.read_native(Window::full(2401, 1201)).unwrap() else {
        panic!()
    };
    let (AnyGrid::I16(ga), AnyGrid::I16(gb)) = (ga, gb) else {
        panic!()
    };
    let (mut agree, mut differ, mut void6) = (0, 0, 0);
    for y in 0..1201 {
        let (va, vb, vm) = (ga.get(1200, y), gb.get(0, y), mg.get(1200, y));
        if va == vb {
            agree += 1;
            assert_eq!(vm, va);
        } else if va != -32768 {
            differ += 1;
            assert_eq!(vm, va, "row {y}: N43E006 is first by name and valid");
        } else {
            void6 += 1;
            assert_eq!(vm, vb, "row {y}: N43E006 void, N43E007 fills");
        }
        // Away from the seam each cell comes from its only source.
        assert_eq!(mg.get(17, y), ga.get(17, y));
        assert_eq!(mg.get(2400, y), gb.get(1200, y));
        assert_eq!(mg.get(1201 + 600, y), gb.get(601, y));
    }
    println!("shared column: {agree} rows agree, {differ} differ (N43E006 kept), {void6} void in N43E006 (N43E007 used)");
    assert_eq!(agree + differ + void6, 1201);
}
